"""Deliberately broken cores, built in the tests to show that the proofs and the waveform
regression catch them (never registered, never in hdl/).

* :class:`OppositeTieInterpolator`: SU 1571551's exact variant with the opposite tie at
  ``F = 0`` (a combined step where eq. (1) makes a long one). Both choices stay within
  ``0.5 cos α``; the tie rule is what the proof's strict bound ``-a < E`` pins down.
* :func:`literal_transfer_core`: SU 1665343's faithful core with delay 12 read before the
  X = Y switch-over has set trigger 16, the patent's text taken literally: the diagonal that
  lands on X = Y adds -2 instead of -1 (``docs/circular.md``, item 16).
"""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from kontur.hdl.circular import FaithfulArcCore, FaithfulTiming
from kontur.hdl.elements import AccumulatingAdder
from kontur.hdl.linear import LinearCore, LinearInterpolator

from .utils import used

__all__ = ["OppositeTieInterpolator", "opposite_tie_core", "literal_transfer_core"]


class _TieAdder(wiring.Component):
    """Adder 3 whose sign output also reads ``F = 0`` as negative (``even``: the frame's F has
    no half, so ``⌊F⌋ = 0`` is ``F = 0``)."""

    def __init__(self, width):
        self._width = width
        super().__init__({
            "d": In(signed(width)), "load": In(1), "clr": In(1), "b": In(signed(width)),
            "add": In(1), "b2": In(signed(width)), "add2": In(1), "sub": In(1), "even": In(1),
            "q": Out(signed(width)), "sign": Out(1), "sign_n": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        m.submodules.adder = adder = AccumulatingAdder(self._width)
        for name in ("d", "load", "clr", "b", "add", "b2", "add2", "sub"):
            m.d.comb += getattr(adder, name).eq(getattr(self, name))
        negative = adder.sign | (self.even & (adder.q == 0))
        m.d.comb += [self.q.eq(adder.q), self.sign.eq(negative), self.sign_n.eq(~negative)]
        return m


class OppositeTieInterpolator(LinearInterpolator):
    """:class:`~kontur.hdl.linear.LinearInterpolator` (``exact``) with the opposite tie at F = 0."""

    def __init__(self, *, width=16, period=1, zero_frames=True, one_step_input=False):
        super().__init__(width=width, variant="exact", period=period, zero_frames=zero_frames,
                         one_step_input=one_step_input)
        used(self.adder3)                                 # the one it replaces
        self.adder3 = _TieAdder(width + 1)

    def elaborate(self, platform):
        m = super().elaborate(platform)
        a = self.reg22 + self.reg23 + 1                   # max(|X|, |Y|) of the frame
        m.d.comb += self.adder3.even.eq(~a[0])
        return m


def opposite_tie_core(width):
    """A :class:`~kontur.hdl.linear.LinearCore` around :class:`OppositeTieInterpolator`."""
    core = LinearCore(width=width, variant="exact")
    used(core.interpolator)                               # the one it replaces
    core.interpolator = OppositeTieInterpolator(width=width, zero_frames=False,
                                                one_step_input=True)
    return core


def literal_transfer_core(width):
    """A :class:`~kontur.hdl.circular.FaithfulArcCore` with the literal reading of the transfer:
    delay 12 shortened to 2 clocks (unchecked timing), so it reads counter 8 and trigger 16
    before the X = Y correction."""
    return FaithfulArcCore(width=width, timing=FaithfulTiming(delay12=2, check=False))
