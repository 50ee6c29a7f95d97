"""Register of capacity 2**n (регистр ёмкостью 2**n): the integrator of a DDA (ЦДА)."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ._checks import check_width

__all__ = ["CapacityRegister"]


class CapacityRegister(wiring.Component):
    """Accumulates its increment modulo its capacity; an overflow is a pulse.

    The capacity is ``N = mask + 1`` for a :py:`mask` of the form ``2**n - 1`` (``n`` from 0 to
    ``width``), so one register serves every capacity up to ``2**width``. :py:`load` replaces
    the contents by :py:`d` (a preset) and takes the increment :py:`b` and the capacity, which
    hold until the next :py:`load`; :py:`clr` sets the contents to zero; on a clock in which
    :py:`en` is asserted the increment is added and ``N`` subtracted if the sum reaches it:
    :py:`overflow` is high in that clock (it looks ahead at the sum, whether or not :py:`en`
    is asserted). The contents must stay below ``N`` and the increment must not exceed ``N``.
    Priority, highest first: :py:`load`, :py:`clr`, :py:`en`. The new contents appear one
    clock later.

    The sum of the contents and the increment, and whether it reaches ``N``, are held in
    registers of their own, formed a clock ahead (at the load, and in every clock that changes
    the contents): :py:`overflow` is a flip-flop, not the end of the sum's carry chain, so the
    decision of a DDA's iteration (which waits for the feed only when it steps) starts from
    registers, as a bare accumulator's does, and the sum's chain has the clock to itself.

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
        Increment, taken by :py:`load`.
    mask : :py:`In(width)`
        Capacity minus one, taken by :py:`load`.
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
        w = self._width
        increment = Signal(w)
        capacity = Signal(w)                         # the mask taken by the load
        total = Signal(w + 1)                        # q + increment, always
        wrapped = Signal(w)                          # total less N if it reaches N
        m.d.comb += wrapped.eq(total & capacity)

        def reaches(value, mask):
            # Below 2N, a sum reaches N exactly when it has a bit outside the mask.
            return (value & ~Cat(mask, Const(0, 1))).any()

        loaded, cleared, added = Signal(w + 1), Signal(w + 1), Signal(w + 1)
        m.d.comb += [loaded.eq(self.d + self.b), cleared.eq(increment),
                     added.eq(wrapped + increment)]
        with m.If(self.load):
            m.d.sync += [self.q.eq(self.d), increment.eq(self.b), capacity.eq(self.mask),
                         total.eq(loaded), self.overflow.eq(reaches(loaded, self.mask))]
        with m.Elif(self.clr):
            m.d.sync += [self.q.eq(0), total.eq(cleared),
                         self.overflow.eq(reaches(cleared, capacity))]
        with m.Elif(self.en):
            m.d.sync += [self.q.eq(wrapped), total.eq(added),
                         self.overflow.eq(reaches(added, capacity))]
        return m
