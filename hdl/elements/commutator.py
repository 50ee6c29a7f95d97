"""Commutator (коммутатор): one-hot strobed channels built of AND/OR elements."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ._checks import check_width

__all__ = ["Commutator"]


class Commutator(wiring.Component):
    """Channel selector built of AND/OR elements, with each input shifted left.

    Each channel ``i`` has a data input :py:`b[i]`, a separate least significant bit
    :py:`lsb[i]` and a control input :py:`a[i]`. The output is the OR over the channels of
    ``a[i] AND (b[i] << shift | lsb[i])``, sign-extended to ``out_width`` bits: this is the
    "2x3 AND/OR" commutator 6 of SU 1665343 (Fig. 3), whose counter inputs are wired one bit
    towards the most significant end, and, with ``shift=0``, multiplexer 12 of SU 1571551. The
    output is combinational; at most one control input should be asserted at a time (two at once
    OR their codes together, as the gates would).

    Parameters
    ----------
    in_width : :class:`int`
        Width of each data input, sign included.
    out_width : :class:`int`
        Width of the output, at least ``in_width + shift``.
    channels : :class:`int`
        Number of channels.
    shift : :class:`int`
        0 or 1: how many bits the data inputs are shifted towards the MSB. With ``shift=1`` the
        vacated bit is filled from :py:`lsb`; with ``shift=0`` :py:`lsb` is ignored.

    Members
    -------
    b : :py:`In(signed(in_width)).array(channels)`
        Data inputs.
    lsb : :py:`In(1).array(channels)`
        Separate least significant bits (with ``shift=1``).
    a : :py:`In(1).array(channels)`
        Control (strobe) inputs.
    o : :py:`Out(signed(out_width))`
        Output code.
    strobe : :py:`Out(1)`
        OR of the control inputs: some channel is switched through.

    Raises
    ------
    :exc:`TypeError`
        If a width or the channel count is not a positive integer, or ``shift`` is not 0 or 1.
    :exc:`ValueError`
        If ``out_width`` is smaller than ``in_width + shift``.
    """

    def __init__(self, in_width, out_width, *, channels, shift=1):
        check_width("Commutator input width", in_width)
        check_width("Commutator output width", out_width)
        check_width("Commutator channel count", channels)
        if shift not in (0, 1) or isinstance(shift, bool):
            raise TypeError(f"Commutator shift must be 0 or 1, not {shift!r}")
        if out_width < in_width + shift:
            raise ValueError(f"Commutator output width must be at least {in_width + shift}, "
                             f"not {out_width!r}")
        self._in_width = in_width
        self._out_width = out_width
        self._channels = channels
        self._shift = shift
        super().__init__({
            "b":      In(signed(in_width)).array(channels),
            "lsb":    In(1).array(channels),
            "a":      In(1).array(channels),
            "o":      Out(signed(out_width)),
            "strobe": Out(1),
        })

    @property
    def channels(self):
        return self._channels

    @property
    def shift(self):
        return self._shift

    def elaborate(self, platform):
        m = Module()
        combined = 0
        for i, (b, lsb, a) in enumerate(zip(self.b, self.lsb, self.a)):
            code = Cat(lsb, b).as_signed() if self._shift else b   # sign bit of b stays the sign
            gated = Signal(signed(self._out_width), name=f"channel{i + 1}")
            m.d.comb += gated.eq(Mux(a, code, 0))                     # AND, sign-extended
            combined = combined | gated.as_unsigned()                 # OR
        m.d.comb += [
            self.o.eq(combined),
            self.strobe.eq(Cat(*self.a).any()),
        ]
        return m
