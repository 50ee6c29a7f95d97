"""Shift register (регистр сдвига) with parallel load: the rings of a bit-serial interpolator."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ._checks import check_width

__all__ = ["ShiftRegister"]


class ShiftRegister(wiring.Component):
    """Shift register, least significant bit first, with parallel load.

    On a clock in which :py:`en` is asserted the contents move one place towards the least
    significant end: bit 0 leaves on :py:`o` (it is :py:`o` during that clock) and :py:`i` enters
    at the most significant end. Fed back from its own output (directly or through an adder)
    it is a ring that turns once in ``width`` clocks, as the registers of a serial machine do.
    :py:`load` replaces the contents by :py:`d` (the input mode: "режим ввода"); it wins over
    :py:`en`. The new contents appear one clock later. A one-bit register is the case
    ``width=1``: :py:`o` is its contents, :py:`i` what it takes when :py:`en` is asserted.

    Parameters
    ----------
    width : :class:`int`
        Number of bits.

    Members
    -------
    d : :py:`In(width)`
        Value loaded by :py:`load`.
    load : :py:`In(1)`
        Parallel load strobe.
    en : :py:`In(1)`
        Shift strobe.
    i : :py:`In(1)`
        Serial input, entering at the most significant end.
    o : :py:`Out(1)`
        Serial output: the least significant bit.
    q : :py:`Out(width)`
        Contents.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not a positive integer.
    """

    def __init__(self, width):
        check_width("Shift register width", width)
        self._width = width
        super().__init__({
            "d":    In(width),
            "load": In(1),
            "en":   In(1),
            "i":    In(1),
            "o":    Out(1),
            "q":    Out(width),
        })

    @property
    def width(self):
        return self._width

    def elaborate(self, platform):
        m = Module()
        with m.If(self.load):
            m.d.sync += self.q.eq(self.d)
        with m.Elif(self.en):
            m.d.sync += self.q.eq(Cat(self.q[1:], self.i))
        m.d.comb += self.o.eq(self.q[0])
        return m
