"""The motion side of a machine: where frames come from, the feed, and the step/dir stage.

Everything here works on any engine with the common interface (:class:`kontur.hdl.engine.
EngineSignature`), joined with :func:`amaranth.lib.wiring.connect`.
"""

from .feed import FeedDivider
from .player import ProgramPlayer
from .program import ProgramROM
from .stepdir import StepDirStage

__all__ = ["ProgramROM", "FeedDivider", "StepDirStage", "ProgramPlayer"]
