# amaranth: UnusedElaboratable=no
"""The feed generator: contour rate (√2 for diagonals), linear ramps, no bursts; and the model."""

import math
import random
import unittest

from kontur.hdl.motion.feed import ONE, SQRT2, FeedGenerator, rate_limit
from kontur.sim.models.motion import FeedGeneratorModel

from .utils import simulate

Q24 = 1 << 24


def profile(cruise=0.0, exit=0.0, decelerate=0):
    """A profile from rates in steps a clock."""
    return {"cruise": round(cruise * Q24), "exit": round(exit * Q24),
            "decelerate": decelerate}


def accel_of(steps_per_clock2):
    return round(steps_per_clock2 * (1 << 40))


def trace(moves, *, accel=0, due=lambda clock: 1, diagonal=lambda step: 0, clocks=None,
          max_rate=None, inputs=lambda clock: {}, overrides=True, axes=2):
    """Run ``moves`` (profiles, each for its step count) through the RTL and the model at the
    acceleration ``accel`` (Q0.40), every output compared in every clock. The moves follow one
    another (start at each move's first clock); ``inputs(clock)`` gives the other inputs of a
    clock (``hold``, ``feed_override``, ``rapid_override``, ``rapid``; missing ones at their
    defaults). Returns the steps as ``(clock, move, diagonal, rate)`` (``rate`` the RTL's
    output in that clock, Q0.24) and the clocks with ``held`` high."""
    kwargs = {"overrides": overrides}
    if max_rate is not None:
        kwargs["max_rate"] = max_rate
    dut = FeedGenerator(**kwargs, axes=axes)
    model = FeedGeneratorModel(**kwargs)
    plan = [(p, count) for p, count in moves]
    stepped, held = [], []

    async def testbench(ctx):
        index, made, starting = 0, 0, True
        clock = 0
        while index < len(plan) and (clocks is None or clock < clocks):
            p, count = plan[index]
            d, diag = due(clock), diagonal(len(stepped))
            extra = inputs(clock)
            ctx.set(dut.ramp.profile, p)
            ctx.set(dut.accel, accel)
            ctx.set(dut.ramp.start, starting)
            ctx.set(dut.feed.due, d)
            ctx.set(dut.feed.diagonal, diag)
            for name in ("hold", "feed_override", "rapid_override", "rapid"):
                ctx.set(getattr(dut, name), extra.get(name, getattr(dut, name).init))
            state = (model.rate >> 16, model.steps)
            tick = model.cycle(profile=p, accel=accel, start=starting, due=d, diagonal=diag,
                               **extra)
            assert ctx.get(dut.feed.tick) == tick, f"clock {clock}"
            assert (ctx.get(dut.rate), ctx.get(dut.steps)) == state, f"clock {clock}"
            assert ctx.get(dut.held) == model.held, f"clock {clock}"
            if model.held:
                held.append(clock)
            starting = False
            if tick and d:
                stepped.append((clock, index, diag, state[0]))
                made += 1
                if made == count:
                    index, made, starting = index + 1, 0, True
            await ctx.tick()
            clock += 1

    simulate(dut, testbench, name="feed_generator")
    return stepped, held


def run(moves, **kwargs):
    """:func:`trace`'s step clocks alone."""
    return [clock for clock, *_ in trace(moves, **kwargs)[0]]


class FeedGeneratorTestCase(unittest.TestCase):
    def test_cruise_rate_and_diagonals(self):
        # At a quarter step a clock, axial steps come every 4 clocks, diagonals every 4√2.
        fast = profile(cruise=0.25, exit=0.25, decelerate=10_000)
        big = (1 << 32) - 1                              # at cruise within 64 clocks
        axial = run([(fast, 200)], accel=big)
        gaps = [b - a for a, b in zip(axial, axial[1:])]
        self.assertEqual(set(gaps[20:]), {4})
        diagonal = run([(fast, 200)], accel=big, diagonal=lambda step: 1)
        self.assertAlmostEqual((diagonal[-1] - diagonal[20]) / 179, 4 * math.sqrt(2), places=2)

    def test_three_axes(self):
        # On three axes a step is 1, √2 or √3 long (diagonal 0, 1, 2): at a quarter step a
        # clock the √3 steps come every 4√3 clocks; a random mix follows the model clock for
        # clock within the rate limit.
        fast = profile(cruise=0.25, exit=0.25, decelerate=10_000)
        spatial = run([(fast, 200)], accel=(1 << 32) - 1, diagonal=lambda step: 2, axes=3)
        self.assertAlmostEqual((spatial[-1] - spatial[20]) / 179, 4 * math.sqrt(3), places=2)
        rng = random.Random(28)
        moves = [(profile(rng.random() * 0.5, rng.random() * 0.3, rng.randrange(50)),
                  rng.randrange(1, 60)) for _ in range(12)]
        clocks = run(moves, accel=accel_of(1e-5), due=lambda clock: int(rng.random() < 0.8),
                     diagonal=lambda step: step % 3, max_rate=rate_limit(5), axes=3)
        self.assertGreaterEqual(min(b - a for a, b in zip(clocks, clocks[1:])), 5)

    def test_ramp_up_cruise_down(self):
        # From rest, accelerate to cruise, hold it, decelerate to rest over the last steps;
        # the step rate never changes faster than the acceleration (plus the accumulator's
        # quantisation: one clock of a step interval).
        accel, cruise, count, down = 1e-5, 0.05, 600, 450
        clocks = run([(profile(cruise, 0.002, down), count)], accel=accel_of(accel))
        intervals = [b - a for a, b in zip(clocks, clocks[1:])]
        self.assertLessEqual(min(intervals), math.ceil(1 / cruise))
        self.assertGreater(intervals[0], 50)                     # slow start
        self.assertGreater(intervals[-1], 50)                    # slow stop
        for i in range(1, len(intervals)):
            dt = intervals[i]
            rate_change = abs(1 / intervals[i] - 1 / intervals[i - 1])
            self.assertLessEqual(rate_change, accel * (dt + intervals[i - 1]) + 1 / dt ** 2 * 2,
                                 i)

    def test_waits_do_not_burst(self):
        # The engine has no step due for a while: the first step after the wait comes at once,
        # the next ones at the rate again, never two clocks in a row.
        p = profile(0.1, 0.1, 10 ** 6)
        clocks = run([(p, 100)], accel=(1 << 32) - 1,
                     due=lambda clock: int(not 100 <= clock < 400))
        intervals = [b - a for a, b in zip(clocks, clocks[1:])]
        self.assertGreaterEqual(min(intervals), 10)

    def test_random_against_model_and_limit(self):
        rng = random.Random(4)
        moves = [(profile(rng.random() * 0.5, rng.random() * 0.3, rng.randrange(50)),
                  rng.randrange(1, 60)) for _ in range(20)]
        clocks = run(moves, accel=accel_of(1e-5), due=lambda clock: int(rng.random() < 0.8),
                     diagonal=lambda step: step % 3 == 0, max_rate=rate_limit(5))
        intervals = [b - a for a, b in zip(clocks, clocks[1:])]
        self.assertGreaterEqual(min(intervals), 5)               # the rate limit holds

    def test_constants_and_parameters(self):
        self.assertEqual(ONE, 1 << 24)
        self.assertEqual(SQRT2, round(math.sqrt(2) * (1 << 24)))
        self.assertEqual(rate_limit(4), (Q24 - 1) // 4)
        with self.assertRaisesRegex(TypeError,
                r"^Highest rate must be below 2\*\*24 \(one step a clock\), not 16777216$"):
            FeedGenerator(max_rate=Q24)
        with self.assertRaisesRegex(TypeError, r"^Highest rate must be a positive integer, "
                                               r"not 0$"):
            FeedGenerator(max_rate=0)
        with self.assertRaisesRegex(TypeError, r"^Overrides must be True or False, not 1$"):
            FeedGenerator(overrides=1)


if __name__ == "__main__":
    unittest.main()
