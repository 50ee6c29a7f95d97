"""Feed: step permissions for an engine (:class:`~hdl.engine.FeedSignature`)."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In

from ..elements._checks import check_width
from ..engine import FeedSignature

__all__ = ["FeedDivider"]


class FeedDivider(wiring.Component):
    """A fixed feed: one step permission every ``divider`` clocks.

    :py:`feed.tick` is high in one clock of every ``divider``, counting from reset, except
    while :py:`pause` is high; a permission the engine has no step due for is not kept. For an
    engine with a step due in every clock of a program (a line engine's segments back to back)
    this is one step every ``divider`` clocks.

    Parameters
    ----------
    divider : :class:`int`
        Clocks per permission.

    Members
    -------
    feed : :py:`In(FeedSignature())`
        To the engine's :py:`feed`.
    pause : :py:`In(1)`
        No permission while high.

    Raises
    ------
    :exc:`TypeError`
        If ``divider`` is not a positive integer.
    """

    def __init__(self, divider):
        check_width("Tick divider", divider)
        self._divider = divider
        super().__init__({"feed": In(FeedSignature()), "pause": In(1)})

    @property
    def divider(self):
        return self._divider

    def elaborate(self, platform):
        m = Module()
        phase = Signal(range(self._divider))
        last = phase == self._divider - 1
        m.d.sync += phase.eq(Mux(last, 0, phase + 1))
        m.d.comb += self.feed.tick.eq(last & ~self.pause)
        return m
