"""Delay element (элемент задержки) with one or several taps."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

__all__ = ["DelayElement"]


class DelayElement(wiring.Component):
    """Pulse delay line with taps.

    A one-clock pulse on :py:`i` in clock ``k`` appears on tap ``j`` in clock ``k + taps[j]``.
    The line holds any number of pulses in flight (it is a shift register), so pulses closer
    together than the longest tap are all delivered. :py:`clr` empties the line: pulses in flight
    are dropped and nothing appears on the taps in the clock after.

    Parameters
    ----------
    taps : :class:`tuple` of :class:`int`
        Delay of each tap in clocks, each at least 1, in non-decreasing order (several taps may
        share a stage).

    Members
    -------
    i : :py:`In(1)`
        Pulse input.
    clr : :py:`In(1)`
        Clear strobe.
    o : :py:`Out(len(taps))`
        Tap outputs; bit ``j`` is tap ``j`` (the patent's output ``j + 1``).

    Raises
    ------
    :exc:`TypeError`
        If ``taps`` is not a non-empty sequence of positive integers.
    :exc:`ValueError`
        If the taps are not in non-decreasing order.
    """

    def __init__(self, taps):
        if isinstance(taps, int) and not isinstance(taps, bool):
            taps = (taps,)
        try:
            taps = tuple(taps)
        except TypeError:
            raise TypeError(f"Delay taps must be a sequence of positive integers, not {taps!r}")
        if not taps or any(not isinstance(t, int) or isinstance(t, bool) or t < 1 for t in taps):
            raise TypeError(f"Delay taps must be a sequence of positive integers, not {taps!r}")
        if list(taps) != sorted(taps):
            raise ValueError(f"Delay taps must be in non-decreasing order, not {taps!r}")
        self._taps = taps
        super().__init__({
            "i":   In(1),
            "clr": In(1),
            "o":   Out(len(taps)),
        })

    @property
    def taps(self):
        return self._taps

    def elaborate(self, platform):
        m = Module()
        line = Signal(max(self._taps))               # line[k] = input delayed by k + 1 clocks
        with m.If(self.clr):
            m.d.sync += line.eq(0)
        with m.Else():
            m.d.sync += line.eq(Cat(self.i, line[:-1]))
        m.d.comb += self.o.eq(Cat(*[line[t - 1] for t in self._taps]))
        return m
