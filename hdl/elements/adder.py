"""Accumulating adder (накапливающий сумматор) of the patents' block diagrams."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ._checks import check_width

__all__ = ["AccumulatingAdder", "carry_save"]


class AccumulatingAdder(wiring.Component):
    """Accumulating adder with a sign flip-flop.

    Holds a signed number. On a clock in which :py:`add` is asserted the operand :py:`b` is added
    to the contents; with :py:`sub` it is subtracted (the "сумматор-вычитатель" of SU 1571551);
    with :py:`add2` a second operand :py:`b2` is added. :py:`load` replaces the contents by
    :py:`d`; :py:`clr` sets them to zero. Priority, highest first: :py:`load`, :py:`clr`,
    :py:`add`, :py:`add2`, :py:`sub`. The new contents appear one clock later. Every sum is
    formed in parallel and the strobes only pick one, so an operand chosen by a commutator
    ahead of the adder can instead be wired to an operand input of its own, with the
    commutator's strobes picking the sum: the choice then follows the carry chain instead of
    preceding it.

    Two number codes are supported:

    * two's complement (default);
    * ones' complement with end-around carry, as SU 1665343 needs to add inverse (ones'
      complement) codes taken from a counter. The sum is formed as the difference between the
      contents and the complemented operand, with the borrow fed back to the least significant
      bit; this is the same ones'-complement sum, except that a zero result is always +0
      (``0…0``), never −0 (``1…1``), so the sign output reads every zero as non-negative. A plain
      adder would turn 3 + (−3) into −0 and flip the estimating function's sign test.

    Parameters
    ----------
    width : :class:`int`
        Number of bits, sign included.
    ones_complement : :class:`bool`
        Use the ones' complement code instead of two's complement.

    Members
    -------
    d : :py:`In(signed(width))`
        Value loaded by :py:`load`.
    load : :py:`In(1)`
        Load strobe.
    clr : :py:`In(1)`
        Clear strobe.
    b : :py:`In(signed(width))`
        Operand (the second addend).
    add : :py:`In(1)`
        Add strobe.
    b2 : :py:`In(signed(width))`
        Second operand.
    add2 : :py:`In(1)`
        Strobe: add :py:`b2`.
    sub : :py:`In(1)`
        Subtract strobe.
    q : :py:`Out(signed(width))`
        Contents.
    sign : :py:`Out(1)`
        Direct output of the sign flip-flop: 1 while the contents are negative.
    sign_n : :py:`Out(1)`
        Inverse output of the sign flip-flop: 1 while the contents are positive or zero.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2.
    """

    def __init__(self, width, *, ones_complement=False):
        check_width("Adder width", width, minimum=2)
        self._width = width
        self._ones_complement = bool(ones_complement)
        super().__init__({
            "d":      In(signed(width)),
            "load":   In(1),
            "clr":    In(1),
            "b":      In(signed(width)),
            "add":    In(1),
            "b2":     In(signed(width)),
            "add2":   In(1),
            "sub":    In(1),
            "q":      Out(signed(width)),
            "sign":   Out(1),
            "sign_n": Out(1),
        })

    @property
    def width(self):
        return self._width

    @property
    def ones_complement(self):
        return self._ones_complement

    def elaborate(self, platform):
        m = Module()
        w = self._width
        q = self.q.as_unsigned()
        b = self.b.as_unsigned()

        if self._ones_complement:
            # q - x with the borrow fed back to bit 0 (end-around borrow).
            def minus(x):
                diff = Signal(w + 1)
                m.d.comb += diff.eq(q - x)
                return (diff[:w] - diff[w])[:w]
            total = minus(~b)        # q + b == q - (ones' complement of b)
            total2 = minus(~self.b2.as_unsigned())
            difference = minus(b)
        else:
            total = (q + b)[:w]
            total2 = (q + self.b2.as_unsigned())[:w]
            difference = (q - b)[:w]

        with m.If(self.load):
            m.d.sync += self.q.eq(self.d)
        with m.Elif(self.clr):
            m.d.sync += self.q.eq(0)
        with m.Elif(self.add):
            m.d.sync += self.q.eq(total)
        with m.Elif(self.add2):
            m.d.sync += self.q.eq(total2)
        with m.Elif(self.sub):
            m.d.sync += self.q.eq(difference)

        m.d.comb += [
            self.sign.eq(self.q[-1]),
            self.sign_n.eq(~self.q[-1]),
        ]
        return m


def carry_save(m, a, b, c):
    """Reduce ``a + b + c`` to two numbers with no carry chain: return ``(total, carries)``,
    signals of ``len(a)`` bits with ``total + carries == a + b + c`` modulo ``2**len(a)``.

    One full adder per bit (its sum in ``total``, its carry one bit up in ``carries``, whose
    lowest bit is 0), so that a three-operand sum needs one carry chain, not two. The operands
    should be ``len(a)`` bits wide (shorter ones are extended by their signedness).
    """
    width = len(a)
    total, carries = Signal(width), Signal(width)
    m.d.comb += [total.eq(a ^ b ^ c), carries.eq(((a & b) | (a & c) | (b & c)) << 1)]
    return total, carries


def magnitude(m, value, width):
    """``|value|`` in ``width`` bits, in one carry chain: return ``(magnitude, over)``.

    ``magnitude`` is ``(value ^ s) + s`` over the low ``width`` bits (``s`` the sign), a
    conditional negation that needs one LUT and one carry a bit, where ``Mux(value < 0,
    -value, value)`` builds a negation and a multiplexer beside it. ``over`` is set when
    ``|value| > 2**width - 1`` (then ``magnitude`` does not count). ``value`` is a signed value
    of at least ``width + 1`` bits.
    """
    value = Value.cast(value)
    if not value.shape().signed or len(value) < width + 1:
        raise TypeError(f"Value must be signed and at least {width + 1} bits wide, not "
                        f"{value.shape()!r}")
    sign = value[-1]
    low, high = value[:width], value[width:]
    result, over = Signal(width), Signal()
    m.d.comb += [
        result.eq(((low ^ sign.replicate(width)) + sign)[:width]),
        # In range: the high bits are all zero, or all one with a nonzero low part (-2**width,
        # all ones over zeros, is one too far).
        over.eq(~((high == 0) | (high.all() & low.any()))),
    ]
    return result, over
