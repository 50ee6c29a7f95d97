"""The building blocks of the patents' block diagrams, each once, as synthesizable components.

Every pulse is a one-clock strobe in a single synchronous clock domain (``sync``); a delay is a
number of clocks.
"""

from .adder import AccumulatingAdder
from .counter import ReversibleCounter
from .commutator import Commutator
from .delay import DelayElement
from .trigger import Trigger
from .pulse import PulseGenerator, PulseExtender

__all__ = ["AccumulatingAdder", "ReversibleCounter", "Commutator", "DelayElement", "Trigger",
           "PulseGenerator", "PulseExtender"]
