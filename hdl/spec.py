"""Specifications the gateware and the golden models share: the equidistant engine's frame
kinds and number widths, and the iCEBreaker demo's program.

Pure Python, no Amaranth (as ``kontur.hdl.circular_timing``): the RTL (``kontur.hdl.equidistant``,
``kontur.hdl.top``) and the golden models and host (``kontur.sim.models.equidistant``, ``kontur.demo``)
import these one definitions, so the two sides cannot disagree on them. It describes
parameters and data only, not behaviour.
"""

import math
from dataclasses import dataclass

__all__ = ["Kind", "Formats", "SETTLE", "OCTAGON", "ONE", "SQRT2", "SQRT3", "STEP_LENGTHS"]

#: The clocks the equidistant engine takes after every step or change of the traced and
#: compared slots (the slots' positions a clock after the step and their functions a clock
#: after that, then block 11's test in three registered stages): an element steps every
#: ``SETTLE + 1`` clocks at most.
SETTLE = 4


class Kind:
    """Frame kinds of the equidistant engine (the ``kind`` field of
    :meth:`kontur.hdl.equidistant.EquidistantEngine.Frame`)."""
    RADIUS = 0       #: set the cutter radius (``x``); DONE once r² is formed
    START = 1        #: the cutter's centre is at ``(x, y)``: a contour begins
    LINE = 2         #: a line element
    ARC = 3          #: an arc element
    CLOSE = 4        #: return to the start of the contour


def _check(name, value, minimum):
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise TypeError(f"{name} must be an integer of at least {minimum}, not {value!r}")


@dataclass(frozen=True)
class Formats:
    """The widths of the equidistant engine's numbers, in the RTL and in the golden models.

    Parameters
    ----------
    width : :class:`int`
        Coordinate width: every coordinate (profile, centres, the cutter's path) within
        ``±(2**width - 1)``; the radius below ``2**width``.
    fraction : :class:`int`
        Fractional bits of ``k``, ``b``, ``1/cos α``, ``2R`` and of the line functions (default
        ``width + 4``).

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 4 or ``fraction`` not one of at least 2.
    """
    width: int = 16
    fraction: int = None

    def __post_init__(self):
        _check("Coordinate width", self.width, 4)
        if self.fraction is None:
            object.__setattr__(self, "fraction", self.width + 4)
        _check("Fractional bits", self.fraction, 2)

    @property
    def one(self):
        """``1`` in fixed point: ``2**fraction``."""
        return 1 << self.fraction

    @property
    def position(self):
        """Width of the position counters (signed)."""
        return self.width + 2

    @property
    def coefficient(self):
        """Width of ``k`` and ``1/cos α`` (signed)."""
        return self.fraction + 2

    @property
    def intercept(self):
        """Width of ``b`` and of an offset coefficient (signed)."""
        return self.width + self.fraction + 3

    @property
    def square(self):
        """Width of ``R²`` (unsigned)."""
        return 2 * self.width + 3

    @property
    def diameter(self):
        """Width of ``2R`` (unsigned, with the fraction)."""
        return self.width + self.fraction + 3

    @property
    def value(self):
        """Width of a function's value (signed): a line's ``T·2**F``, a circle's ``S``."""
        return max(self.fraction + self.width + 4, 2 * self.width + 5)

    @property
    def core(self):
        """Register width of the arc core."""
        return self.width + 2


#: The iCEBreaker demo's program: a closed octagon, one relative move ``(x, y)`` in each
#: octant, chosen where SU 1571551's device strays (``kontur.hdl.top.DemoTop`` plays it,
#: ``kontur.demo`` plots it).
OCTAGON = ((14, 4), (9, 11), (-9, 11), (-14, 4), (-14, -4), (-9, -11), (9, -11), (14, -4))


#: Distances in the feed generator's accumulator (:class:`kontur.hdl.motion.feed.FeedGenerator`, its
#: model :class:`kontur.sim.models.motion.FeedGeneratorModel`): one axial step and one diagonal step
#: (Q2.24); a step on three axes (a 3-axis engine's ``feed.diagonal`` of 2).
ONE = 1 << 24
SQRT2 = round(math.sqrt(2) * ONE)
SQRT3 = round(math.sqrt(3) * ONE)
#: A step's length by ``feed.diagonal``, the number of axes it moves beyond one.
STEP_LENGTHS = (ONE, SQRT2, SQRT3)
