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

    The contents after the next addition are held in a register of their own, formed a clock
    ahead (at the load, and in every clock that changes the contents), with every bit above
    the capacity set: adding the increment to it carries out of the top bit exactly when the
    sum reaches ``N`` (the carry runs through the set bits), and the bits below ``N`` are the
    sum less ``N``. So :py:`overflow` is a flip-flop loaded from the carry of one plain sum,
    not from a comparison after it: the decision of a DDA's iteration (which waits for the
    feed only when it steps) starts from registers, as a bare accumulator's does, and the
    register's loop is the accumulator's (its contents plus the increment, the carry out).

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
    overflow_next : :py:`Out(1)`
        What :py:`overflow` becomes at the next clock edge (under this clock's strobes).

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
            "overflow_next": Out(1),
        })

    @property
    def width(self):
        return self._width

    def elaborate(self, platform):
        m = Module()
        w = self._width
        increment = Signal(w)
        capacity = Signal(w)                         # the mask taken by the load
        ahead = Signal(w)                            # (q + increment) mod N, bits above N set
        whole = Signal()                             # the increment is N (it always overflows)

        def raised(value, mask):
            # ``value`` (below N) with every bit above the capacity set.
            return value | ~mask

        # The sum for an addition, and the contents a load or a clear start from: the
        # carry out of the top bit is the overflow.
        added = Signal(w + 1)
        loaded = Signal(w + 1)
        m.d.comb += [
            added.eq(ahead + increment),
            loaded.eq(raised(self.d, self.mask) + self.b),
        ]
        ahead_next = Signal(w)
        with m.If(self.load):
            m.d.comb += [ahead_next.eq(raised(loaded[:w], self.mask)),
                         self.overflow_next.eq(loaded[w])]
        with m.Elif(self.clr):
            # 0 + increment: the increment itself, or zero when it is N (which overflows).
            m.d.comb += [ahead_next.eq(raised(Mux(whole, 0, increment), capacity)),
                         self.overflow_next.eq(whole)]
        with m.Elif(self.en):
            m.d.comb += [ahead_next.eq(raised(added[:w], capacity)),
                         self.overflow_next.eq(added[w])]
        with m.Else():
            m.d.comb += [ahead_next.eq(ahead), self.overflow_next.eq(self.overflow)]
        m.d.sync += [ahead.eq(ahead_next), self.overflow.eq(self.overflow_next)]

        with m.If(self.load):
            m.d.sync += [self.q.eq(self.d), increment.eq(self.b), capacity.eq(self.mask),
                         whole.eq((self.b & ~self.mask).any())]
        with m.Elif(self.clr):
            m.d.sync += self.q.eq(0)
        with m.Elif(self.en):
            m.d.sync += self.q.eq(ahead & capacity)
        return m
