"""Reversible (up/down) counter (реверсивный счётчик) of the patents' block diagrams."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ._checks import check_width

__all__ = ["ReversibleCounter"]


class ReversibleCounter(wiring.Component):
    """Reversible counter with parallel load, clear and a weight-2 subtract input.

    On each clock the contents change by ``up - down - 2·down2`` (all three inputs may be asserted
    together). :py:`load` replaces the contents by :py:`d` and :py:`clr` sets them to zero;
    priority, highest first: :py:`load`, :py:`clr`, counting. The new contents appear one clock
    later.

    Two number codes are supported:

    * two's complement (default), the plain binary counter;
    * ones' complement, as counter 8 of SU 1665343 (Table 2 lists its negative contents as
      inverted magnitudes: −1 = ``1…10``, −3 = ``1…100``). Counting down subtracts with an
      end-around borrow and never yields −0 (2 − 2 = +0, as Table 2 shows); counting up adds with
      an end-around carry, so −1 + 1 gives −0 (``1…1``), which reads as zero everywhere.

    Parameters
    ----------
    width : :class:`int`
        Number of bits, sign included.
    ones_complement : :class:`bool`
        Use the ones' complement code instead of two's complement.
    parallel : :class:`bool`
        Two's complement only: form every count the inputs can ask for (``+1``, ``-1``,
        ``-2``, ``-3``) in parallel from the contents and let the count inputs pick one, so
        that they arrive at the end of the carry chains instead of at their start. The same
        behaviour, in more logic where several count inputs are used.

    Members
    -------
    d : :py:`In(signed(width))`
        Value loaded by :py:`load`.
    load : :py:`In(1)`
        Parallel load strobe.
    clr : :py:`In(1)`
        Clear strobe.
    up : :py:`In(1)`
        Count +1.
    down : :py:`In(1)`
        Count −1.
    down2 : :py:`In(1)`
        Count −2 (the subtract input of the second bit).
    q : :py:`Out(signed(width))`
        Direct outputs.
    q_n : :py:`Out(signed(width))`
        Inverse outputs (every bit of :py:`q` inverted).
    q_next : :py:`Out(signed(width))`
        The contents after this clock's count, i.e. what :py:`q` becomes at the next clock edge
        unless :py:`load` or :py:`clr` is asserted (the count logic's output).
    underflow : :py:`Out(1)`
        Asserted in the clock whose count takes the contents from non-negative to negative.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2.
    """

    def __init__(self, width, *, ones_complement=False, parallel=False):
        check_width("Counter width", width, minimum=2)
        self._width = width
        self._ones_complement = bool(ones_complement)
        self._parallel = bool(parallel) and not ones_complement
        super().__init__({
            "d":         In(signed(width)),
            "load":      In(1),
            "clr":       In(1),
            "up":        In(1),
            "down":      In(1),
            "down2":     In(1),
            "q":         Out(signed(width)),
            "q_n":       Out(signed(width)),
            "q_next":    Out(signed(width)),
            "underflow": Out(1),
        })

    @property
    def width(self):
        return self._width

    @property
    def ones_complement(self):
        return self._ones_complement

    @property
    def parallel(self):
        return self._parallel

    def elaborate(self, platform):
        m = Module()
        w = self._width
        q = self.q.as_unsigned()
        dec = Signal(range(4))                       # amount counted down: 0..3
        m.d.comb += dec.eq(self.down + (self.down2 << 1))

        if self._ones_complement:
            plus = Signal(w + 1)
            minus = Signal(w + 1)
            m.d.comb += [
                plus.eq(q + 1),
                minus.eq(q - dec),
            ]
            incremented = (plus[:w] + plus[w])[:w]   # end-around carry
            decremented = (minus[:w] - minus[w])[:w]  # end-around borrow
            with m.If(self.up & (dec == 0)):
                m.d.comb += self.q_next.eq(incremented)
            with m.Elif(self.up):
                # up and down together: one fewer to count down (dec >= 1 here)
                less = Signal(w + 1)
                m.d.comb += less.eq(q - (dec - 1))
                m.d.comb += self.q_next.eq((less[:w] - less[w])[:w])
            with m.Else():
                m.d.comb += self.q_next.eq(decremented)
        elif self._parallel:
            # up - down - 2·down2 for each combination of the count inputs, bit 0 up.
            def count(up, down, down2):
                delta = up - down - 2 * down2
                return self.q + delta if delta else self.q
            m.d.comb += self.q_next.eq(
                Mux(self.down2,
                    Mux(self.down, Mux(self.up, count(1, 1, 1), count(0, 1, 1)),
                        Mux(self.up, count(1, 0, 1), count(0, 0, 1))),
                    Mux(self.down, Mux(self.up, count(1, 1, 0), count(0, 1, 0)),
                        Mux(self.up, count(1, 0, 0), count(0, 0, 0)))))
        else:
            m.d.comb += self.q_next.eq(self.q + self.up - dec)

        with m.If(self.load):
            m.d.sync += self.q.eq(self.d)
        with m.Elif(self.clr):
            m.d.sync += self.q.eq(0)
        with m.Else():
            m.d.sync += self.q.eq(self.q_next)

        m.d.comb += [
            self.q_n.eq(~self.q),
            self.underflow.eq(~self.q[-1] & self.q_next[-1]),
        ]
        return m
