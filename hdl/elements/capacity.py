"""Register of capacity 2**n (регистр ёмкостью 2**n): the integrator of a DDA (ЦДА)."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ._checks import check_width

__all__ = ["CapacityRegister"]


class CapacityRegister(wiring.Component):
    """Accumulates its increment modulo its capacity; an overflow is a pulse.

    The capacity is ``N = mask + 1`` for a :py:`mask` of the form ``2**n - 1`` (``n`` from 0 to
    ``width``), so one register serves every capacity up to ``2**width``. On a clock in which
    :py:`en` is asserted the increment :py:`b` is added and ``N`` subtracted if the sum reaches
    it: :py:`overflow` is high in that clock (it looks ahead at the sum, whether or not
    :py:`en` is asserted). The contents must stay below ``N`` and the increment must not exceed
    ``N``. :py:`load` replaces the contents by :py:`d` (a preset), :py:`clr` sets them to zero;
    priority, highest first: :py:`load`, :py:`clr`, :py:`en`. The new contents appear one clock
    later.

    Parameters
    ----------
    width : :class:`int`
        Number of bits: the largest capacity is ``2**width``.

    Members
    -------
    d : :py:`In(width)`
        Value loaded by :py:`load`.
    load : :py:`In(1)`
        Load strobe.
    clr : :py:`In(1)`
        Clear strobe.
    b : :py:`In(width)`
        Increment.
    mask : :py:`In(width)`
        Capacity minus one.
    en : :py:`In(1)`
        Add strobe.
    q : :py:`Out(width)`
        Contents.
    overflow : :py:`Out(1)`
        The sum of the contents and the increment reaches the capacity.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not a positive integer.
    """

    def __init__(self, width):
        check_width("Register width", width)
        self._width = width
        super().__init__({
            "d":        In(width),
            "load":     In(1),
            "clr":      In(1),
            "b":        In(width),
            "mask":     In(width),
            "en":       In(1),
            "q":        Out(width),
            "overflow": Out(1),
        })

    @property
    def width(self):
        return self._width

    def elaborate(self, platform):
        m = Module()
        total = Signal(self._width + 1)
        m.d.comb += [
            total.eq(self.q + self.b),
            # Below 2N, the sum reaches N exactly when it has a bit outside the mask.
            self.overflow.eq((total & ~Cat(self.mask, Const(0, 1))).any()),
        ]
        with m.If(self.load):
            m.d.sync += self.q.eq(self.d)
        with m.Elif(self.clr):
            m.d.sync += self.q.eq(0)
        with m.Elif(self.en):
            m.d.sync += self.q.eq(total & self.mask)
        return m
