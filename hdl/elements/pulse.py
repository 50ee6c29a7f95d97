"""Pulse generator (генератор тактовых импульсов) and pulse extender (расширитель импульсов)."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ._checks import check_positive

__all__ = ["PulseGenerator", "PulseExtender"]


class PulseGenerator(wiring.Component):
    """Clock-pulse generator with a programmable period.

    Runs freely from reset: it counts the clocks in which :py:`en` is asserted and emits a
    one-clock strobe on :py:`o` on every ``period``-th of them, starting with the first. With
    ``period=1`` the output is :py:`en` itself. :py:`en` is the feed-rate input (a permitted-step
    strobe); tie it high for a pulse every ``period`` clocks. :py:`armed` is high when the next
    enabled clock pulses (always, with ``period=1``).

    Parameters
    ----------
    period : :class:`int`
        Number of enabled clocks per pulse.

    Members
    -------
    en : :py:`In(1)`
        Enable (tick).
    o : :py:`Out(1)`
        Pulse output.
    armed : :py:`Out(1)`
        The next enabled clock emits a pulse.

    Raises
    ------
    :exc:`TypeError`
        If ``period`` is not a positive integer.
    """

    en: In(1)
    o: Out(1)
    armed: Out(1)

    def __init__(self, period=1):
        check_positive("Generator period", period)
        self._period = period
        super().__init__()

    @property
    def period(self):
        return self._period

    def elaborate(self, platform):
        m = Module()
        if self._period == 1:
            m.d.comb += [self.o.eq(self.en), self.armed.eq(1)]
            return m
        phase = Signal(range(self._period))
        with m.If(self.en):
            m.d.sync += phase.eq(Mux(phase == self._period - 1, 0, phase + 1))
        m.d.comb += [
            self.armed.eq(phase == 0),
            self.o.eq(self.en & self.armed),
        ]
        return m


class PulseExtender(wiring.Component):
    """Pulse extender: stretches a pulse into a gate ``length`` clocks long.

    A pulse on :py:`i` in clock ``k`` drives :py:`o` high in clocks ``k + 1`` to ``k + length``;
    a pulse while the gate is open restarts it. :py:`clr` closes the gate from the next clock.

    Parameters
    ----------
    length : :class:`int`
        Gate length in clocks.

    Members
    -------
    i : :py:`In(1)`
        Pulse input.
    clr : :py:`In(1)`
        Clear strobe.
    o : :py:`Out(1)`
        Direct output (the gate).
    o_n : :py:`Out(1)`
        Inverse output.

    Raises
    ------
    :exc:`TypeError`
        If ``length`` is not a positive integer.
    """

    i: In(1)
    clr: In(1)
    o: Out(1)
    o_n: Out(1)

    def __init__(self, length):
        check_positive("Extender length", length)
        self._length = length
        super().__init__()

    @property
    def length(self):
        return self._length

    def elaborate(self, platform):
        m = Module()
        left = Signal(range(self._length + 1))
        with m.If(self.clr):
            m.d.sync += left.eq(0)
        with m.Elif(self.i):
            m.d.sync += left.eq(self._length)
        with m.Elif(left != 0):
            m.d.sync += left.eq(left - 1)
        m.d.comb += [
            self.o.eq(left != 0),
            self.o_n.eq(left == 0),
        ]
        return m
