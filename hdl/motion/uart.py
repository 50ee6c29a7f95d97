"""A serial port: 8N1 UART receiver and transmitter, byte streams on the inside.

amaranth-stdio is not published on PyPI, so this is ours. One clock domain; the bit time is a
whole number of clocks (``divisor``), for instance 12 MHz / 115 200 baud = 104 clocks (0.16 %
off the nominal rate, well inside the 2 % a UART link tolerates).
"""

from amaranth import *
from amaranth.lib import stream, wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out

from ..elements._checks import check_width

__all__ = ["UARTReceiver", "UARTTransmitter", "divisor_for"]


def divisor_for(clock_hz, baud):
    """The bit time in clocks nearest ``clock_hz / baud``; :exc:`ValueError` if the rate would
    be more than 2 % off or the bit shorter than 4 clocks."""
    divisor = round(clock_hz / baud)
    if divisor < 4 or abs(clock_hz / divisor - baud) > 0.02 * baud:
        raise ValueError(f"A {clock_hz / 1e6:g} MHz clock cannot make {baud} baud within 2 % "
                         f"(bit time {clock_hz / baud:.2f} clocks)")
    return divisor


class UARTReceiver(wiring.Component):
    """8N1 receiver: bytes from the :py:`rx` line onto a stream.

    :py:`rx` is synchronised to the clock first (two flip-flops). A falling edge starts a
    character; the start bit is checked in its middle (a glitch shorter than half a bit is
    ignored), then each data bit (least significant first) and the stop bit are sampled in
    their middles, ``divisor`` clocks apart. A byte with its stop bit high is offered on
    :py:`o` from the clock after the stop bit's sample until it is taken; one with its stop bit
    low is dropped and :py:`error` pulses (a framing error). A byte completed while the previous
    one has not been taken replaces nothing: it is dropped and :py:`overrun` pulses.

    Parameters
    ----------
    divisor : :class:`int`
        Bit time in clocks (at least 4).

    Members
    -------
    rx : :py:`In(1, init=1)`
        The serial line (idle high).
    o : :py:`Out(stream.Signature(8))`
        Received bytes.
    error : :py:`Out(1)`
        A character with a bad stop bit was dropped.
    overrun : :py:`Out(1)`
        A character was dropped because the previous one was not taken in time.

    Raises
    ------
    :exc:`TypeError`
        If ``divisor`` is not an integer of at least 4.
    """

    def __init__(self, divisor):
        check_width("UART bit time", divisor, minimum=4)
        self._divisor = divisor
        super().__init__({
            "rx":      In(1, init=1),
            "o":       Out(stream.Signature(8)),
            "error":   Out(1),
            "overrun": Out(1),
        })

    @property
    def divisor(self):
        return self._divisor

    def elaborate(self, platform):
        m = Module()
        divisor = self._divisor
        line = Signal(init=1)
        m.submodules.sync = FFSynchronizer(self.rx, line, init=1)

        timer = Signal(range(divisor))
        bits = Signal(range(10))
        shift = Signal(8)
        full = Signal()
        data = Signal(8)
        m.d.comb += [self.o.valid.eq(full), self.o.payload.eq(data)]
        with m.If(self.o.ready):
            m.d.sync += full.eq(0)

        with m.FSM(name="rx"):
            with m.State("Idle"):
                with m.If(~line):
                    m.d.sync += timer.eq(divisor // 2 - 1)
                    m.next = "Start"
            with m.State("Start"):              # to the middle of the start bit
                with m.If(timer != 0):
                    m.d.sync += timer.eq(timer - 1)
                with m.Elif(line):
                    m.next = "Idle"             # a glitch, not a start bit
                with m.Else():
                    m.d.sync += [timer.eq(divisor - 1), bits.eq(0)]
                    m.next = "Data"
            with m.State("Data"):               # the middles of 8 data bits and the stop bit
                with m.If(timer != 0):
                    m.d.sync += timer.eq(timer - 1)
                with m.Elif(bits != 8):
                    m.d.sync += [shift.eq(Cat(shift[1:], line)), bits.eq(bits + 1),
                                 timer.eq(divisor - 1)]
                with m.Else():
                    with m.If(~line):
                        m.d.comb += self.error.eq(1)
                    with m.Elif(full & ~self.o.ready):
                        m.d.comb += self.overrun.eq(1)
                    with m.Else():
                        m.d.sync += [data.eq(shift), full.eq(1)]
                    m.next = "Idle"
        return m


class UARTTransmitter(wiring.Component):
    """8N1 transmitter: bytes from a stream onto the :py:`tx` line.

    A byte taken from :py:`i` goes out as a start bit, 8 data bits (least significant first)
    and a stop bit, each ``divisor`` clocks; :py:`i` is ready while nothing is being sent and
    in the last clock of a stop bit, so bytes follow one another with no gap.

    Parameters
    ----------
    divisor : :class:`int`
        Bit time in clocks (at least 4).

    Members
    -------
    i : :py:`In(stream.Signature(8))`
        Bytes to send.
    tx : :py:`Out(1, init=1)`
        The serial line (idle high).

    Raises
    ------
    :exc:`TypeError`
        If ``divisor`` is not an integer of at least 4.
    """

    def __init__(self, divisor):
        check_width("UART bit time", divisor, minimum=4)
        self._divisor = divisor
        super().__init__({"i": In(stream.Signature(8)), "tx": Out(1, init=1)})

    @property
    def divisor(self):
        return self._divisor

    def elaborate(self, platform):
        m = Module()
        timer = Signal(range(self._divisor))
        bits = Signal(range(11))                # bits still to send, start bit included
        frame = Signal(10, init=1)              # stop, data, start: shifted out from the bottom
        # Ready while idle and in the stop bit's last clock: the next start bit follows it.
        m.d.comb += [self.i.ready.eq((bits == 0) | ((bits == 1) & (timer == 0))),
                     self.tx.eq(frame[0] | (bits == 0))]
        with m.If(self.i.valid & self.i.ready):
            m.d.sync += [frame.eq(Cat(Const(0, 1), self.i.payload, Const(1, 1))),
                         bits.eq(10), timer.eq(self._divisor - 1)]
        with m.Elif(bits != 0):
            with m.If(timer != 0):
                m.d.sync += timer.eq(timer - 1)
            with m.Else():
                m.d.sync += [frame.eq(frame >> 1), bits.eq(bits - 1),
                             timer.eq(self._divisor - 1)]
        return m
