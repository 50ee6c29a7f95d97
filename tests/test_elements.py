# amaranth: UnusedElaboratable=no
"""The element library against reference arithmetic (sim/models/codes.py), clock by clock."""

import random
import unittest

from amaranth import Module, Signal, signed

from kontur.hdl.elements import (AccumulatingAdder, CapacityRegister, Commutator, DelayElement,
                          PulseExtender, PulseGenerator, ReversibleCounter, SerialAdder,
                          ShiftRegister, Trigger, magnitude)
from kontur.sim.models.codes import (from_code, mask, ones_add, ones_count, ones_decode, ones_encode,
                              ones_sub, sign_extend)

from .utils import simulate


def _twos(value, width):
    return from_code(value & mask(width), width)


class AccumulatingAdderTestCase(unittest.TestCase):
    def run_ops(self, width, ones, ops):
        dut = AccumulatingAdder(width, ones_complement=ones)
        code = 0                                    # reference contents, as a code
        seen = []

        async def testbench(ctx):
            nonlocal code
            for op, value in ops:
                ctx.set(dut.load, op == "load")
                ctx.set(dut.clr, op == "clr")
                ctx.set(dut.add, op == "add")
                ctx.set(dut.sub, op == "sub")
                ctx.set(dut.d, value)
                ctx.set(dut.b, value)
                q = ctx.get(dut.q) & mask(width)
                self.assertEqual(q, code)
                negative = code >> (width - 1)
                self.assertEqual((ctx.get(dut.sign), ctx.get(dut.sign_n)), (negative, 1 - negative))
                operand = value & mask(width)
                if op == "load":
                    code = operand
                elif op == "clr":
                    code = 0
                elif op == "add":
                    code = ones_add(code, operand, width) if ones else (code + operand) & mask(width)
                elif op == "sub":
                    code = ones_sub(code, operand, width) if ones else (code - operand) & mask(width)
                seen.append(code)
                await ctx.tick()

        simulate(dut, testbench, name=f"adder_w{width}_{'ones' if ones else 'twos'}")
        return seen

    def random_ops(self, width, count, seed):
        rng = random.Random(seed)
        limit = 1 << (width - 1)
        return [(rng.choice(["load", "clr", "add", "add", "sub", "sub", "hold"]),
                 rng.randrange(-limit + 1, limit)) for _ in range(count)]

    def test_twos_random(self):
        self.run_ops(8, False, self.random_ops(8, 400, 1))

    def test_ones_random(self):
        ops = [(op, ones_encode(v, 8) if v < 0 else v) for op, v in self.random_ops(8, 400, 2)]
        self.run_ops(8, True, ops)

    def test_ones_zero_sum_is_plus_zero(self):
        # 3 + (-3) must give +0 (sign_n = 1), not -0.
        seen = self.run_ops(6, True, [("load", 3), ("add", ones_encode(-3, 6)), ("hold", 0)])
        self.assertEqual(seen[1], 0)

    def test_ones_subtract(self):
        seen = self.run_ops(6, True, [("load", ones_encode(-5, 6)), ("sub", 4), ("hold", 0)])
        self.assertEqual(ones_decode(seen[1], 6), -9)

    def test_width_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^Adder width must be an integer of at least 2, not 1$"):
            AccumulatingAdder(1)


class ReversibleCounterTestCase(unittest.TestCase):
    def run_counts(self, width, ones, ops):
        dut = ReversibleCounter(width, ones_complement=ones)
        code = 0

        async def testbench(ctx):
            nonlocal code
            for load, clr, up, down, down2, value in ops:
                for port, level in ((dut.load, load), (dut.clr, clr), (dut.up, up),
                                    (dut.down, down), (dut.down2, down2)):
                    ctx.set(port, level)
                ctx.set(dut.d, value)
                self.assertEqual(ctx.get(dut.q) & mask(width), code)
                self.assertEqual(ctx.get(dut.q_n) & mask(width), ~code & mask(width))
                delta = up - down - 2 * down2
                if ones:
                    after = ones_count(code, delta, width)
                else:
                    after = (code + delta) & mask(width)
                self.assertEqual(ctx.get(dut.q_next) & mask(width), after)
                went_negative = not code >> (width - 1) and after >> (width - 1)
                self.assertEqual(ctx.get(dut.underflow), int(bool(went_negative)))
                code = value & mask(width) if load else 0 if clr else after
                await ctx.tick()

        simulate(dut, testbench, name=f"counter_w{width}_{'ones' if ones else 'twos'}")

    def random_ops(self, width, count, seed):
        rng = random.Random(seed)
        return [(int(rng.random() < 0.05), int(rng.random() < 0.03), rng.randrange(2),
                 rng.randrange(2), rng.randrange(2), rng.randrange(1 << width))
                for _ in range(count)]

    def test_twos_random(self):
        self.run_counts(7, False, self.random_ops(7, 600, 3))

    def test_ones_random(self):
        self.run_counts(7, True, self.random_ops(7, 600, 4))

    def test_ones_table2_sequence(self):
        # Counter 8 of SU 1665343, R = 12 (Table 2): 11, -1, -2 each step ... through zero.
        w = 6
        ops = [(1, 0, 0, 0, 0, 2), (0, 0, 0, 0, 1, 0), (0, 0, 0, 1, 0, 0), (0, 0, 0, 0, 1, 0),
               (0, 0, 1, 0, 0, 0), (0, 0, 1, 0, 0, 0), (0, 0, 1, 0, 0, 0), (0, 0, 1, 0, 0, 0),
               (1, 0, 0, 0, 0, mask(w)), (0, 0, 1, 1, 0, 0), (0, 0, 1, 0, 1, 0),
               (0, 0, 0, 0, 0, 0)]
        self.run_counts(w, True, ops)
        # reference: 2 -2 -> +0; -1 -> -1 (1..10); -2 -> -3; +1 -> -2; +1 -> -1
        code = 2
        for delta, expect in ((-2, 0), (-1, ones_encode(-1, w)), (-2, ones_encode(-3, w)),
                              (1, ones_encode(-2, w)), (1, ones_encode(-1, w)), (1, mask(w))):
            code = ones_count(code, delta, w)
            self.assertEqual(code, expect)
        self.assertEqual(ones_decode(code, w), 0)     # -1 + 1 is -0, which decodes as zero
        self.assertEqual(ones_count(code, 1, w), 1)   # -0 + 1 = +1 through the end-around carry

    def test_width_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^Counter width must be an integer of at least 2, not 'x'$"):
            ReversibleCounter("x")


class CommutatorTestCase(unittest.TestCase):
    def check(self, in_width, out_width, channels, shift, seed):
        dut = Commutator(in_width, out_width, channels=channels, shift=shift)
        rng = random.Random(seed)

        async def testbench(ctx):
            for _ in range(300):
                data = [rng.randrange(1 << in_width) for _ in range(channels)]
                lsbs = [rng.randrange(2) for _ in range(channels)]
                strobe = rng.randrange(channels + 1)        # == channels: none
                for i in range(channels):
                    ctx.set(dut.b[i], from_code(data[i], in_width))
                    ctx.set(dut.lsb[i], lsbs[i])
                    ctx.set(dut.a[i], int(i == strobe))
                if strobe == channels:
                    expect = 0
                else:
                    code = (data[strobe] << 1 | lsbs[strobe]) if shift else data[strobe]
                    expect = sign_extend(code, in_width + shift, out_width)
                self.assertEqual(ctx.get(dut.o) & mask(out_width), expect)
                self.assertEqual(ctx.get(dut.strobe), int(strobe != channels))
                await ctx.tick()

        simulate(dut, testbench, name=f"commutator_{channels}_{shift}")

    def test_three_channels_shifted(self):
        self.check(5, 9, 3, 1, 5)

    def test_two_channels_plain(self):
        self.check(6, 6, 2, 0, 6)

    def test_out_width_wrong(self):
        with self.assertRaisesRegex(ValueError,
                r"^Commutator output width must be at least 6, not 5$"):
            Commutator(5, 5, channels=3)

    def test_shift_wrong(self):
        with self.assertRaisesRegex(TypeError, r"^Commutator shift must be 0 or 1, not 2$"):
            Commutator(5, 8, channels=3, shift=2)


class DelayElementTestCase(unittest.TestCase):
    def test_taps(self):
        taps = (1, 2, 2, 4)
        dut = DelayElement(taps)
        rng = random.Random(7)
        pulses = [rng.random() < 0.3 for _ in range(200)]
        clears = {50, 51, 120}

        async def testbench(ctx):
            history = []
            for k, pulse in enumerate(pulses):
                ctx.set(dut.i, pulse)
                ctx.set(dut.clr, k in clears)
                got = ctx.get(dut.o)
                for j, t in enumerate(taps):
                    src = k - t
                    alive = src >= 0 and history[src] and not any(src <= c < k for c in clears)
                    self.assertEqual((got >> j) & 1, int(alive), f"clock {k} tap {j}")
                history.append(pulse)
                await ctx.tick()

        simulate(dut, testbench, name="delay_taps")

    def test_taps_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^Delay taps must be a sequence of positive integers, not \(1, 0\)$"):
            DelayElement((1, 0))
        with self.assertRaisesRegex(ValueError,
                r"^Delay taps must be in non-decreasing order, not \(2, 1\)$"):
            DelayElement((2, 1))


class TriggerTestCase(unittest.TestCase):
    def check(self, priority):
        dut = Trigger(priority=priority)
        seq = [(1, 0), (0, 0), (1, 1), (0, 1), (0, 0), (1, 1), (0, 0)]

        async def testbench(ctx):
            q = 0
            for s, r in seq:
                ctx.set(dut.set, s)
                ctx.set(dut.reset, r)
                self.assertEqual((ctx.get(dut.q), ctx.get(dut.q_n)), (q, 1 - q))
                if s and r:
                    q = int(priority == "set")
                elif s or r:
                    q = s
                await ctx.tick()

        simulate(dut, testbench, name=f"trigger_{priority}")

    def test_reset_priority(self):
        self.check("reset")

    def test_set_priority(self):
        self.check("set")

    def test_priority_wrong(self):
        with self.assertRaisesRegex(ValueError,
                r"^Trigger priority must be one of 'set', 'reset', not 'both'$"):
            Trigger(priority="both")


class PulseGeneratorTestCase(unittest.TestCase):
    def check(self, period):
        dut = PulseGenerator(period)
        rng = random.Random(period)

        async def testbench(ctx):
            enabled = 0
            for _ in range(120):
                en = int(rng.random() < 0.7)
                ctx.set(dut.en, en)
                self.assertEqual(ctx.get(dut.o), int(en and enabled % period == 0))
                enabled += en
                await ctx.tick()

        simulate(dut, testbench, name=f"generator_{period}")

    def test_period_1(self):
        self.check(1)

    def test_period_4(self):
        self.check(4)

    def test_period_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^Generator period must be a positive integer, not 0$"):
            PulseGenerator(0)


class PulseExtenderTestCase(unittest.TestCase):
    def test_gate(self):
        dut = PulseExtender(3)
        pulses = [1, 0, 0, 0, 0, 1, 0, 1, 0, 0, 0, 0, 1, 0, 0]
        clears = {13}

        async def testbench(ctx):
            last = None
            for k, pulse in enumerate(pulses):
                ctx.set(dut.i, pulse)
                ctx.set(dut.clr, k in clears)
                gate = last is not None and 1 <= k - last <= 3 and not (k - 1 in clears)
                self.assertEqual((ctx.get(dut.o), ctx.get(dut.o_n)), (int(gate), int(not gate)),
                                 f"clock {k}")
                if k in clears:
                    last = None
                elif pulse:
                    last = k
                await ctx.tick()

        simulate(dut, testbench, name="extender")

    def test_length_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^Extender length must be a positive integer, not -1$"):
            PulseExtender(-1)


class ShiftRegisterTestCase(unittest.TestCase):
    def check(self, width, seed):
        dut = ShiftRegister(width)
        rng = random.Random(seed)

        async def testbench(ctx):
            code = 0                                # reference contents
            for clock in range(300):
                op = rng.choice(["load", "shift", "shift", "shift", "hold"])
                d, i = rng.randrange(1 << width), rng.randrange(2)
                ctx.set(dut.load, op == "load")
                ctx.set(dut.en, op == "shift" or rng.random() < 0.2)
                ctx.set(dut.d, d)
                ctx.set(dut.i, i)
                self.assertEqual(ctx.get(dut.q), code, f"clock {clock}")
                self.assertEqual(ctx.get(dut.o), code & 1, f"clock {clock}")
                if op == "load":
                    code = d
                elif ctx.get(dut.en):
                    code = (code >> 1) | (i << (width - 1))
                await ctx.tick()

        simulate(dut, testbench, name=f"shift_register_{width}")

    def test_ring_of_8(self):
        self.check(8, 1)

    def test_one_bit_register(self):
        self.check(1, 2)

    def test_width_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^Shift register width must be a positive integer, not 0$"):
            ShiftRegister(0)


class SerialAdderTestCase(unittest.TestCase):
    def test_words(self):
        # Random 9-bit words added (or subtracted: inverse code, carry in) one bit a clock, with
        # clocks between bits in which the carry flip-flop holds (en low).
        dut = SerialAdder()
        rng = random.Random(3)
        width = 9

        async def testbench(ctx):
            for _ in range(60):
                a, b, ci = rng.randrange(1 << width), rng.randrange(1 << width), rng.randrange(2)
                total = 0
                for k in range(width):
                    for hold in [1] * rng.choice([0, 0, 1, 2]) + [0]:
                        ctx.set(dut.a, a >> k & 1)
                        ctx.set(dut.b, b >> k & 1)
                        ctx.set(dut.ci, ci if k == 0 else rng.randrange(2))
                        ctx.set(dut.first, k == 0)
                        ctx.set(dut.en, not hold)
                        if not hold:
                            total |= ctx.get(dut.s) << k
                            carry = ctx.get(dut.co)
                        await ctx.tick()
                self.assertEqual(total | carry << width, a + b + ci)

        simulate(dut, testbench, name="serial_adder")


class CapacityRegisterTestCase(unittest.TestCase):
    def test_random(self):
        # Capacities 2**n for every n up to the width; contents below N, increments up to N.
        # The increment and the capacity are taken by a load: their inputs change in every
        # clock, and only the load's count.
        width = 6
        dut = CapacityRegister(width)
        rng = random.Random(4)

        async def testbench(ctx):
            code = increment = 0
            mask_n = mask(0)                    # the reset's: capacity 1, increment 0
            for clock in range(1500):
                op = "load" if rng.random() < 0.05 else rng.choice(["add", "add", "add", "clr",
                                                                    "hold"])
                new_mask = mask(rng.randint(0, width))
                d = rng.randint(0, new_mask)
                b = rng.randint(0, min(new_mask + 1, mask(width)))
                ctx.set(dut.load, op == "load")
                ctx.set(dut.clr, op == "clr")
                ctx.set(dut.en, op == "add")
                ctx.set(dut.d, d)
                ctx.set(dut.b, b)
                ctx.set(dut.mask, new_mask)
                self.assertEqual(ctx.get(dut.q), code, f"clock {clock}")
                self.assertEqual(ctx.get(dut.overflow), int(code + increment > mask_n),
                                 f"clock {clock}")
                if op == "load":
                    code, increment, mask_n = d, b, new_mask
                elif op == "clr":
                    code = 0
                elif op == "add":
                    code = (code + increment) & mask_n
                # overflow_next: the overflow after this clock's edge, under its strobes.
                self.assertEqual(ctx.get(dut.overflow_next), int(code + increment > mask_n),
                                 f"clock {clock}")
                await ctx.tick()

        simulate(dut, testbench, name="capacity_register")

    def test_width_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^Register width must be a positive integer, not 'wide'$"):
            CapacityRegister("wide")


class MagnitudeTestCase(unittest.TestCase):
    def check(self, value_width, width):
        m = Module()
        value = Signal(signed(value_width))
        result, over = magnitude(m, value, width)
        seen = []

        async def testbench(ctx):
            for v in range(-(1 << (value_width - 1)), 1 << (value_width - 1)):
                ctx.set(value, v)
                seen.append((v, ctx.get(result), ctx.get(over)))

        simulate(m, testbench, name=f"magnitude_{value_width}_{width}")
        self.assertEqual(len(seen), 1 << value_width)
        for v, got, got_over in seen:
            with self.subTest(value=v):
                self.assertEqual(got_over, int(abs(v) > (1 << width) - 1))
                if not got_over:
                    self.assertEqual(got, abs(v))

    def test_every_value(self):
        # Wider than the magnitude by one bit (the line engine at its narrowest), and by more.
        self.check(5, 4)
        self.check(8, 4)

    def test_value_not_signed_or_too_narrow(self):
        with self.assertRaisesRegex(TypeError,
                r"^Value must be signed and at least 5 bits wide, not unsigned\(8\)$"):
            magnitude(Module(), Signal(8), 4)
        with self.assertRaisesRegex(TypeError,
                r"^Value must be signed and at least 5 bits wide, not signed\(4\)$"):
            magnitude(Module(), Signal(signed(4)), 4)


if __name__ == "__main__":
    unittest.main()
