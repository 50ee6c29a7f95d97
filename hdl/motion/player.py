"""Play a program of frames through an engine, with step/dir timed for drivers."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..elements._checks import check_width
from ..engine import EngineSignature, MotionSignature, Outcome
from .feed import FeedDivider
from .program import ProgramROM, check_program
from .stepdir import StepDirStage

__all__ = ["ProgramPlayer", "check_engine", "check_timing"]


def check_engine(engine):
    """Raise :exc:`TypeError` unless ``engine`` is a component with an engine signature."""
    if (not isinstance(engine, wiring.Component)
            or not isinstance(engine.signature, EngineSignature)):
        raise TypeError(f"Engine must be a component with an EngineSignature, not {engine!r}")


def check_timing(divider, dir_setup, step_width):
    """Raise unless the step pulses of a ``divider`` feed fit the driver timing."""
    check_width("Tick divider", divider)
    check_width("Direction setup", dir_setup, minimum=0)
    check_width("Step pulse width", step_width)
    if dir_setup + step_width >= divider:
        raise ValueError(f"Direction setup plus step pulse width must be less than the tick "
                         f"divider {divider}, not {dir_setup + step_width!r}")


class ProgramPlayer(wiring.Component):
    """A program of frames played in a loop through an engine, at a fixed feed, to drivers.

    :class:`ProgramROM` offers the frames back to back from the first clock after reset,
    :class:`FeedDivider` gives the engine one step permission every ``divider`` clocks (none
    while :py:`pause` is high), and :class:`StepDirStage` re-times the engine's steps for
    stepper drivers. The engine's outcomes are taken as they come; a refused frame lights
    :py:`error` for good.

    Parameters
    ----------
    engine : :class:`~amaranth.lib.wiring.Component`
        Any engine (:class:`~kontur.hdl.engine.EngineSignature`). It becomes the submodule ``engine``.
    program : :class:`list` of :class:`dict`
        The frames (see :class:`ProgramROM`).
    divider : :class:`int`
        Clocks per permission.
    dir_setup, step_width : :class:`int`
        See :class:`StepDirStage`.

    Members
    -------
    pause : :py:`In(1)`
        Hold the feed.
    motion : :py:`Out(MotionSignature(2))`
        Step pulses ``step_width`` clocks long, directions set up ``dir_setup`` clocks before.
    busy : :py:`Out(1)`
        The engine's ``busy``.
    error : :py:`Out(1)`
        The engine has refused a frame since reset (sticky).

    Raises
    ------
    :exc:`TypeError`, :exc:`ValueError`
        As :class:`ProgramROM` and :class:`StepDirStage`; :exc:`TypeError` also if ``engine``
        lacks the engine signature; :exc:`ValueError` if a step pulse does not end before the
        next permission (``dir_setup + step_width >= divider``).
    """

    def __init__(self, engine, program, divider, *, dir_setup=0, step_width=1):
        # Every check before any part is made: a refused player leaves no unused part behind.
        check_timing(divider, dir_setup, step_width)
        check_engine(engine)
        check_program(engine.signature.frame, program)
        self._engine = engine
        self.rom = ProgramROM(engine.signature.frame, program)
        self.feed = FeedDivider(divider)
        self.stepdir = StepDirStage(axes=engine.signature.axes, dir_setup=dir_setup,
                                    step_width=step_width)
        super().__init__({
            "pause":  In(1),
            "motion": Out(MotionSignature(engine.signature.axes)),
            "busy":   Out(1),
            "error":  Out(1),
        })

    @property
    def engine(self):
        return self._engine

    @property
    def program(self):
        return self.rom.program

    @property
    def divider(self):
        return self.feed.divider

    @property
    def dir_setup(self):
        return self.stepdir.dir_setup

    @property
    def step_width(self):
        return self.stepdir.step_width

    def elaborate(self, platform):
        m = Module()
        m.submodules.engine = engine = self._engine
        m.submodules.rom = self.rom
        m.submodules.feed = self.feed
        m.submodules.stepdir = self.stepdir
        wiring.connect(m, self.rom.o, engine.cmd)
        wiring.connect(m, engine.feed, self.feed.feed)
        wiring.connect(m, engine.motion, self.stepdir.i)
        wiring.connect(m, self.stepdir.o, wiring.flipped(self.motion))
        m.d.comb += [
            self.feed.pause.eq(self.pause),
            engine.status.ready.eq(1),
            self.busy.eq(engine.busy),
        ]
        with m.If(engine.status.valid & (engine.status.payload.outcome == Outcome.REFUSED)):
            m.d.sync += self.error.eq(1)
        return m
