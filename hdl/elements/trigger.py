"""Trigger (триггер): set/reset flip-flop with direct and inverse outputs."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ._checks import check_choice

__all__ = ["Trigger"]


class Trigger(wiring.Component):
    """Set/reset flip-flop.

    :py:`set` makes the output 1 and :py:`reset` makes it 0 from the next clock on; when both are
    asserted in the same clock the one named by ``priority`` wins.

    Parameters
    ----------
    priority : ``"set"`` or ``"reset"``
        Which input wins when both are asserted.

    Members
    -------
    set : :py:`In(1)`
        Set strobe.
    reset : :py:`In(1)`
        Reset strobe.
    q : :py:`Out(1)`
        Direct output.
    q_n : :py:`Out(1)`
        Inverse output.

    Raises
    ------
    :exc:`ValueError`
        If ``priority`` is neither ``"set"`` nor ``"reset"``.
    """

    set: In(1)
    reset: In(1)
    q: Out(1)
    q_n: Out(1)

    def __init__(self, *, priority="reset"):
        check_choice("Trigger priority", priority, ("set", "reset"))
        self._priority = priority
        super().__init__()

    @property
    def priority(self):
        return self._priority

    def elaborate(self, platform):
        m = Module()
        set_wins = self._priority == "set"
        with m.If(self.set if set_wins else self.reset):
            m.d.sync += self.q.eq(set_wins)
        with m.Elif(self.reset if set_wins else self.set):
            m.d.sync += self.q.eq(not set_wins)
        m.d.comb += self.q_n.eq(~self.q)
        return m
