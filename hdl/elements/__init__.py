"""The building blocks of the patents' and the textbook's block diagrams, each once, as components.

Every pulse is a one-clock strobe in a single synchronous clock domain (``sync``); a delay is a
number of clocks.
"""

from .adder import AccumulatingAdder, carry_save, magnitude
from .counter import ReversibleCounter
from .commutator import Commutator
from .delay import DelayElement
from .trigger import Trigger
from .pulse import PulseGenerator, PulseExtender
from .shift import ShiftRegister
from .serial_adder import SerialAdder
from .capacity import CapacityRegister

__all__ = ["AccumulatingAdder", "ReversibleCounter", "Commutator", "DelayElement", "Trigger",
           "PulseGenerator", "PulseExtender", "ShiftRegister", "SerialAdder", "CapacityRegister",
           "carry_save", "magnitude"]
