"""Serial adder (последовательный сумматор): a full adder and its carry flip-flop."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

__all__ = ["SerialAdder"]


class SerialAdder(wiring.Component):
    """Adds two numbers one bit a clock, least significant bit first.

    In each clock :py:`s` is the sum bit of :py:`a`, :py:`b` and the carry: the carry-in
    :py:`ci` in the clock of the first bit (:py:`first`), the carry flip-flop in every other.
    The flip-flop takes the carry out on every clock in which :py:`en` is asserted, so a word
    of ``n`` bits is added in ``n`` enabled clocks. Subtraction is the addition of the inverse
    code with :py:`ci` set.

    Members
    -------
    a : :py:`In(1)`
        Bit of the first addend.
    b : :py:`In(1)`
        Bit of the second addend.
    ci : :py:`In(1)`
        Carry into the first bit.
    first : :py:`In(1)`
        This clock adds the first (least significant) bit of a word.
    en : :py:`In(1)`
        The carry flip-flop takes this clock's carry out.
    s : :py:`Out(1)`
        Sum bit.
    co : :py:`Out(1)`
        Carry out of this bit.
    """

    a: In(1)
    b: In(1)
    ci: In(1)
    first: In(1)
    en: In(1)
    s: Out(1)
    co: Out(1)

    def elaborate(self, platform):
        m = Module()
        carry = Signal()                              # the carry flip-flop
        c = Signal()
        m.d.comb += [
            c.eq(Mux(self.first, self.ci, carry)),
            self.s.eq(self.a ^ self.b ^ c),
            self.co.eq((self.a & self.b) | (self.a & c) | (self.b & c)),
        ]
        with m.If(self.en):
            m.d.sync += carry.eq(self.co)
        return m
