# amaranth: UnusedElaboratable=no
"""The UART: bytes through the line and back, rate error, glitches, framing errors, overrun."""

import random
import unittest

from amaranth import *
from amaranth.lib import wiring

from kontur.hdl.motion.uart import UARTReceiver, UARTTransmitter, divisor_for

from .utils import simulate


def line_levels(data, bit_clocks, *, stop=1, gap=0):
    """The levels of an 8N1 line sending ``data``: a start bit, 8 data bits LSB first, a stop
    bit of level ``stop``, then ``gap`` idle clocks; ``bit_clocks`` clocks a bit (may be
    fractional: the sender's clock is not ours)."""
    bits = [0] + [(data >> i) & 1 for i in range(8)] + [stop]
    levels = []
    time = 0.0
    for bit in bits:
        time += bit_clocks
        levels += [bit] * (round(time) - len(levels))
    return levels + [1] * gap


class ReceiverTestCase(unittest.TestCase):
    def receive(self, levels, *, divisor, ready=lambda clock: 1):
        dut = UARTReceiver(divisor)
        got, errors, overruns = [], [], []

        async def testbench(ctx):
            for clock, level in enumerate(levels + [1] * (4 * divisor)):
                ctx.set(dut.rx, level)
                ctx.set(dut.o.ready, ready(clock))
                if ctx.get(dut.o.valid) and ready(clock):
                    got.append(ctx.get(dut.o.payload))
                errors.append(ctx.get(dut.error))
                overruns.append(ctx.get(dut.overrun))
                await ctx.tick()

        simulate(dut, testbench, name=f"uart_rx_{divisor}")
        return got, sum(errors), sum(overruns)

    def test_bytes_at_rate_errors(self):
        rng = random.Random(1)
        data = [rng.randrange(256) for _ in range(60)] + [0x00, 0xFF, 0x55, 0xAA]
        for divisor in (8, 16, 104):
            for error in (-0.02, 0.0, 0.02):               # the sender 2 % slow or fast
                levels = []
                for byte in data:
                    levels += line_levels(byte, divisor * (1 + error), gap=rng.choice([0, 3]))
                with self.subTest(divisor=divisor, error=error):
                    got, errors, overruns = self.receive(levels, divisor=divisor)
                    self.assertEqual(got, data)
                    self.assertEqual((errors, overruns), (0, 0))

    def test_glitch_is_not_a_start_bit(self):
        divisor = 16
        levels = [1] * 20 + [0] * 3 + [1] * 30 + line_levels(0x3C, divisor)
        got, errors, _ = self.receive(levels, divisor=divisor)
        self.assertEqual((got, errors), ([0x3C], 0))

    def test_framing_error_drops_the_byte(self):
        divisor = 8
        levels = line_levels(0x12, divisor) + line_levels(0x34, divisor, stop=0) + [1] * 20
        levels += line_levels(0x56, divisor)
        got, errors, _ = self.receive(levels, divisor=divisor)
        self.assertEqual((got, errors), ([0x12, 0x56], 1))

    def test_overrun(self):
        divisor = 8
        levels = line_levels(0x01, divisor) + line_levels(0x02, divisor) + line_levels(0x03,
                                                                                     divisor)
        # The consumer takes nothing until late: the first byte waits, the next two are lost.
        got, _, overruns = self.receive(levels, divisor=divisor,
                                        ready=lambda clock: int(clock > len(levels)))
        self.assertEqual((got, overruns), ([0x01], 2))

    def test_parameters_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^UART bit time must be an integer of at least 4, not 3$"):
            UARTReceiver(3)
        with self.assertRaisesRegex(TypeError,
                r"^UART bit time must be an integer of at least 4, not 2.5$"):
            UARTTransmitter(2.5)
        self.assertEqual(divisor_for(12e6, 115200), 104)
        self.assertEqual(divisor_for(25e6, 115200), 217)
        with self.assertRaisesRegex(ValueError,
                r"^A 12 MHz clock cannot make 4000000 baud within 2 % \(bit time 3\.00 "
                r"clocks\)$"):
            divisor_for(12e6, 4_000_000)


class TransmitterTestCase(unittest.TestCase):
    def test_levels_and_loopback(self):
        rng = random.Random(2)
        data = [rng.randrange(256) for _ in range(40)]
        divisor = 8
        m = Module()
        m.submodules.tx = tx = UARTTransmitter(divisor)
        m.submodules.rx = rx = UARTReceiver(divisor)
        m.d.comb += rx.rx.eq(tx.tx)
        levels, got = [], []

        async def testbench(ctx):
            queue = list(data)
            for _ in range(len(data) * 10 * divisor + 200):
                ctx.set(tx.i.valid, bool(queue))
                if queue:
                    ctx.set(tx.i.payload, queue[0])
                ctx.set(rx.o.ready, 1)
                levels.append(ctx.get(tx.tx))
                if queue and ctx.get(tx.i.ready):
                    queue.pop(0)
                if ctx.get(rx.o.valid):
                    got.append(ctx.get(rx.o.payload))
                await ctx.tick()

        simulate(m, testbench, name="uart_loopback")
        self.assertEqual(got, data)
        # The line, bit for bit: every byte back to back, 10 bits of `divisor` clocks each.
        start = levels.index(0)
        expected = [level for byte in data for level in line_levels(byte, divisor)]
        line = levels[start:start + len(expected)]
        at = next((i for i, (a, b) in enumerate(zip(line, expected)) if a != b), None)
        self.assertIsNone(at, f"the line differs from clock {at} after the first start bit: "
                              f"{line[at:at + 12] if at is not None else ''} instead of "
                              f"{expected[at:at + 12] if at is not None else ''}")
        self.assertEqual(len(line), len(expected))
        self.assertEqual(levels[:start].count(0), 0)


if __name__ == "__main__":
    unittest.main()
