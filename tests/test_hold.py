# amaranth: UnusedElaboratable=no
"""Feed hold, resume and the overrides of the feed generator (issue 25).

The RTL is compared with its model in every clock (:func:`tests.test_feed.trace`); besides,
every run is checked from the clocks of its steps alone, with no model: the rate never changes
faster than the acceleration allows, no permission comes while the generator reports itself
held, and each move ends at most at its exit rate. A real arc engine under the generator shows
that a held and overridden run makes the same steps as an uninterrupted one."""

import bisect
import math
import random
import unittest

from amaranth import Module
from amaranth.lib import wiring

from kontur import registry
from kontur.hdl.motion.feed import OVERRIDE_ONE, FeedGenerator, override
from kontur.sim.models.motion import FeedGeneratorModel

from .test_feed import Q24, accel_of, profile, trace
from .utils import simulate

A = 4e-4                                 # the acceleration of the RTL runs, steps a clock²


def planned(length, cruise, exit, accel=A):
    """A move of ``length`` axial steps as the host's planner sends it (kontur/planner.py's
    rule, from the kinematics): it ramps down where the steps left are the distance from
    cruise to exit at ``accel``, and one more."""
    down = (cruise ** 2 - exit ** 2) / (2 * accel) + 1
    return profile(cruise, exit, max(math.floor(length - down), 0)), length


def schedule(changes):
    """``inputs(clock)`` from ``{clock: {input: value}}``: each change holds until the next
    (the inputs not named in a change keep their values)."""
    clocks = sorted(changes)
    states, state = [], {}
    for clock in clocks:
        state = dict(state, **changes[clock])
        states.append(state)

    def inputs(clock):
        at = bisect.bisect_right(clocks, clock) - 1
        return states[at] if at >= 0 else {}
    return inputs


def model_run(moves, *, accel, inputs=lambda clock: {}, model=None):
    """The model alone (an engine with a step always due): the steps as :func:`trace` gives
    them (the rate the model's, Q0.24)."""
    model = FeedGeneratorModel() if model is None else model
    steps, index, made, starting, clock = [], 0, 0, True, 0
    while index < len(moves):
        p, count = moves[index]
        rate = model.rate >> 16
        tick = model.cycle(profile=p, accel=accel, start=starting, due=1, **inputs(clock))
        starting = False
        if tick:
            steps.append((clock, index, 0, rate))
            made += 1
            if made == count:
                index, made, starting = index + 1, 0, True
        clock += 1
    return steps


class PlannedPointOnly(FeedGeneratorModel):
    """The model without the look-ahead: the ramp-down at the planned step alone, as an
    override above 100 % would have it if nothing looked ahead."""

    def _lookahead(self, p, start):
        return self.steps >= p["decelerate"]


# ---- checks from the step clocks alone --------------------------------------------------------

def _lengths(steps):
    out, total = [], 0.0
    for _, _, diagonal, _ in steps:
        total += math.sqrt(2) if diagonal else 1.0
        out.append(total)
    return out


def rate_jumps(steps, accel, cap, window=4):
    """Adjacent windows of ``window`` steps whose mean rates differ by more than the
    acceleration allows.

    The distance the generator has added by a step's clock is the path to that step plus less
    than one clock's rate (at most ``cap`` steps a clock), so a window's measured mean rate is
    the mean of the rate over its clocks within ``cap / T``; and if the rate changes by at
    most ``accel`` a clock (and the truncation to Q0.24 by one unit), two adjacent windows'
    mean rates differ by at most ``accel · (Ta + Tb) / 2``. Returns the offending windows'
    clocks and rates."""
    lengths = _lengths(steps)
    lipschitz = accel + 2 ** -24
    bad = []
    for i in range(len(steps) - 2 * window):
        j, k = i + window, i + 2 * window
        ta, tb = steps[j][0] - steps[i][0], steps[k][0] - steps[j][0]
        ma = (lengths[j] - lengths[i]) / ta
        mb = (lengths[k] - lengths[j]) / tb
        if abs(mb - ma) > lipschitz * (ta + tb) / 2 + cap / ta + cap / tb + 1e-12:
            bad.append((steps[i][0], ma, mb))
    return bad


def end_rates(steps, accel, cap):
    """For every move, a lower bound of the rate in the clock of its last step, from the
    windows of 1, 2 and 4 steps before it and after it: the rate there is at least a window's
    mean less the measuring error (``cap / T``) and the acceleration over the mean distance
    from it."""
    lengths = _lengths(steps)
    lipschitz = accel + 2 ** -24
    last = {}
    for index, (_, move, _, _) in enumerate(steps):
        last[move] = index
    bounds = {}
    for move, k in last.items():
        best = 0.0
        for w in (1, 2, 4):
            if k - w >= 0:
                t = steps[k][0] - steps[k - w][0]
                mean = (lengths[k] - lengths[k - w]) / t
                best = max(best, mean - cap / t - lipschitz * (t + 1) / 2)
            if k + w < len(steps):
                t = steps[k + w][0] - steps[k][0]
                mean = (lengths[k + w] - lengths[k]) / t
                best = max(best, mean - cap / t - lipschitz * (t - 1) / 2)
        bounds[move] = best
    return bounds


def exit_bound(exit, accel=A):
    """The highest rate (steps a clock) a move may end at: its exit, or what braking at
    ``accel`` one step short of the exit leaves (the planner's margin of one step)."""
    return math.sqrt(exit ** 2 + 2 * accel)


class Checks:
    """The checks every run of this file passes, with the model's and the RTL's rate too."""

    def check_run(self, moves, steps, *, accel=A, cap, held=()):
        self.assertEqual(len(steps), sum(count for _, count in moves))     # nothing skipped
        self.assertEqual(rate_jumps(steps, accel, cap), [])
        for move, bound in end_rates(steps, accel, cap).items():
            exit = moves[move][0]["exit"] / Q24
            self.assertLessEqual(bound, exit_bound(exit, accel), f"move {move}")
        for move, (p, _) in enumerate(moves):
            last = [rate for _, m, _, rate in steps if m == move][-1]
            self.assertLessEqual(last / Q24, exit_bound(p["exit"] / Q24, accel), f"move {move}")
        stepped = {clock for clock, *_ in steps}
        self.assertEqual(stepped & set(held), set())                     # no step while held

    def plateau(self, steps, start, end):
        """The mean rate measured between clocks ``start`` and ``end``."""
        inside = [(clock, length) for (clock, *_), length in zip(steps, _lengths(steps))
                  if start <= clock < end]
        (t0, l0), (t1, l1) = inside[0], inside[-1]
        return (l1 - l0) / (t1 - t0)


def intervals(clocks):
    """Runs of consecutive clocks as ``(first, last)``."""
    runs = []
    for clock in clocks:
        if runs and runs[-1][1] == clock - 1:
            runs[-1][1] = clock
        else:
            runs.append([clock, clock])
    return [tuple(run) for run in runs]


class HoldTestCase(Checks, unittest.TestCase):
    def test_hold_in_a_ramp_and_in_cruise(self):
        # From rest the rate rises by A a clock: at clock 300 it is 0.12, so a hold there
        # comes to a standstill 0.12 / A = 300 clocks later; at cruise (0.2, from clock 1400
        # after the first resume) one at clock 1500 takes 500 clocks. Steps go on until then.
        moves = [planned(300, 0.2, 0.08), planned(200, 0.15, 0.02)]
        inputs = schedule({300: {"hold": 1}, 900: {"hold": 0}, 1500: {"hold": 1},
                           2200: {"hold": 0}})
        steps, held = trace(moves, accel=accel_of(A), inputs=inputs)
        self.check_run(moves, steps, cap=0.2, held=held)
        runs = intervals(held)
        self.assertEqual(len(runs), 2)
        (first, until), (second, until2) = runs
        self.assertLessEqual(abs(first - (300 + 300)), 3)
        self.assertEqual(until, 899)                       # held until the hold drops
        self.assertLessEqual(abs(second - (1500 + 500)), 3)
        self.assertEqual(until2, 2199)
        clocks = [clock for clock, *_ in steps]
        # Braking from 0.12 covers 0.12² / 2A = 18 steps, from 0.2 50 steps.
        self.assertLessEqual(abs(sum(300 <= c < first for c in clocks) - 18), 2)
        self.assertLessEqual(abs(sum(1500 <= c < second for c in clocks) - 50), 2)
        # Resumed, the rate comes back to cruise: 0.2 within 2 % before the second hold.
        self.assertAlmostEqual(self.plateau(steps, 1420, 1500), 0.2, delta=0.004)

    def test_hold_at_rest_and_across_moves(self):
        # A hold before the first step is held almost at once (the rate is zero) and gives
        # nothing;
        # a hold late in a move brakes through the move's end into the next one: resumed at
        # clock 50, at clock 470 the rate is 0.168 and 35 of the first move's 40 steps are
        # made; braking covers 35 steps more.
        moves = [planned(40, 0.2, 0.2), planned(150, 0.2, 0.02)]
        inputs = schedule({0: {"hold": 1}, 50: {"hold": 0}, 470: {"hold": 1},
                           1400: {"hold": 0}})
        steps, held = trace(moves, accel=accel_of(A), inputs=inputs)
        self.check_run(moves, steps, cap=0.2, held=held)
        runs = intervals(held)
        # From clock 2 (clock 1 before issue 27): the target is a register, so the hold's
        # target (zero) is the rate's in clock 1, and held says the rate reached it a clock later.
        self.assertEqual(runs[0], (2, 49))
        self.assertGreater(steps[0][0], 50)
        hold_moves = {move for clock, move, *_ in steps if 470 <= clock < runs[1][0]}
        self.assertEqual(hold_moves, {0, 1})
        self.assertLessEqual(abs(runs[1][0] - (470 + 420)), 3)


class OverrideTestCase(Checks, unittest.TestCase):
    def test_feed_override_up_and_down(self):
        moves = [planned(400, 0.1, 0.05), planned(250, 0.1, 0.02)]
        inputs = schedule({600: {"feed_override": 2 * OVERRIDE_ONE},
                           1600: {"feed_override": OVERRIDE_ONE // 2},
                           2400: {"feed_override": override(150)}})
        steps, held = trace(moves, accel=accel_of(A), inputs=inputs)
        self.check_run(moves, steps, cap=0.2, held=held)
        self.assertEqual(held, [])
        self.assertAlmostEqual(self.plateau(steps, 1200, 1600), 0.2, delta=0.004)
        self.assertAlmostEqual(self.plateau(steps, 2100, 2400), 0.05, delta=0.001)
        self.assertAlmostEqual(self.plateau(steps, 3800, 4300), 0.15, delta=0.003)

    def test_override_above_the_plan_still_reaches_the_exit(self):
        # At 200 % the move cruises at 0.2; braking from there to its exit takes
        # (0.2² - 0.02²) / 2A = 49.5 steps, but the planned ramp-down leaves
        # (0.1² - 0.02²) / 2A + 1 = 13 steps. The look-ahead ramps down in time; the planned
        # step alone ends the move far above its exit.
        moves = [planned(300, 0.1, 0.02), planned(60, 0.02, 0.02)]
        p, length = moves[0]
        self.assertGreater((0.2 ** 2 - 0.02 ** 2) / (2 * A), length - p["decelerate"] + 30)
        inputs = schedule({0: {"feed_override": 2 * OVERRIDE_ONE}})
        steps, _ = trace(moves, accel=accel_of(A), inputs=inputs)
        self.check_run(moves, steps, cap=0.2)
        self.assertAlmostEqual(self.plateau(steps, 1200, 1500), 0.2, delta=0.004)
        plain = model_run(moves, accel=accel_of(A))
        self.assertLess(steps[-1][0], plain[-1][0] * 0.8)        # and it is faster
        naive = model_run(moves, accel=accel_of(A), inputs=inputs, model=PlannedPointOnly())
        with self.assertRaises(AssertionError):
            self.check_run(moves, naive, cap=0.2)
        bounds = end_rates(naive, A, 0.2)
        self.assertGreater(bounds[0], 2 * exit_bound(0.02))      # seen from the clocks alone

    def test_hold_and_override_together(self):
        # At 200 %, held in cruise; while held the override drops to 50 %; resumed, the rate
        # comes back to 0.05, then to 0.1 at 100 %.
        moves = [planned(400, 0.1, 0.02)]
        inputs = schedule({0: {"feed_override": 2 * OVERRIDE_ONE}, 1000: {"hold": 1},
                           1600: {"feed_override": OVERRIDE_ONE // 2}, 1800: {"hold": 0},
                           2600: {"feed_override": OVERRIDE_ONE}})
        steps, held = trace(moves, accel=accel_of(A), inputs=inputs)
        self.check_run(moves, steps, cap=0.2, held=held)
        (first, last), = intervals(held)
        self.assertLessEqual(abs(first - (1000 + 500)), 3)
        self.assertEqual(last, 1799)
        self.assertAlmostEqual(self.plateau(steps, 2100, 2600), 0.05, delta=0.001)
        self.assertAlmostEqual(self.plateau(steps, 3000, 3300), 0.1, delta=0.002)

    def test_rapid_override(self):
        # A rapid takes the rapid override (50 %, then 25 %), not the feed override.
        moves = [planned(300, 0.2, 0.02)]
        inputs = schedule({0: {"rapid": 1, "rapid_override": 1,
                               "feed_override": 2 * OVERRIDE_ONE},
                           1500: {"rapid_override": 2}})
        steps, held = trace(moves, accel=accel_of(A), inputs=inputs)
        self.check_run(moves, steps, cap=0.2, held=held)
        self.assertAlmostEqual(self.plateau(steps, 800, 1500), 0.1, delta=0.002)
        self.assertAlmostEqual(self.plateau(steps, 2000, 2600), 0.05, delta=0.001)

    def test_without_overrides(self):
        # Built without them, the generator ignores the overrides and still holds.
        moves = [planned(200, 0.2, 0.02)]
        inputs = schedule({0: {"feed_override": 2 * OVERRIDE_ONE}, 600: {"hold": 1},
                           1300: {"hold": 0}})
        steps, held = trace(moves, accel=accel_of(A), inputs=inputs, overrides=False)
        self.check_run(moves, steps, cap=0.2, held=held)
        self.assertLessEqual(abs(intervals(held)[0][0] - (600 + 500)), 3)
        self.assertAlmostEqual(self.plateau(steps, 500, 600), 0.2, delta=0.004)

    def test_random_inputs_against_model(self):
        # Any profiles, waits and diagonals, and every input changed at random times, to
        # values the controller never sends too (a factor of 0 or 511, the rapid shift 3):
        # the RTL is the model, clock by clock (trace asserts it).
        rng = random.Random(25)
        moves = [(profile(rng.random() * 0.3, rng.random() * 0.3, rng.randrange(40)),
                  rng.randrange(1, 40)) for _ in range(12)]
        changes, clock = {}, 0
        while clock < 4000:
            clock += rng.randrange(1, 200)
            changes[clock] = rng.choice([
                {"hold": rng.randrange(2)}, {"rapid": rng.randrange(2)},
                {"rapid_override": rng.randrange(4)},
                {"feed_override": rng.choice([0, 1, 13, 100, 128, 129, 256, 511])}])
        steps, held = trace(moves, accel=accel_of(2e-3), inputs=schedule(changes),
                            due=lambda clock: int(rng.random() < 0.8),
                            diagonal=lambda step: step % 3 == 0, max_rate=Q24 // 5,
                            clocks=4000)
        self.assertGreater(len(steps), 100)
        self.assertGreater(len(held), 10)

    def test_override_factor(self):
        self.assertEqual([override(p) for p in (10, 50, 100, 150, 200)],
                         [13, 64, 128, 192, 256])
        for bad in (9, 201, 1.5, True):
            with self.assertRaisesRegex(ValueError, r"^Feed override must be a whole "
                                                    r"percentage from 10 to 200, not "):
                override(bad)


def before(moves, *, accel, due, diagonal, max_rate):
    """The feed generator as it was before hold and the overrides (its model then, kept here as
    the reference, with the target a register computed a clock ahead as the generator has it
    since it runs at the iCEBreaker's 12 MHz): the clocks of its permissions."""
    rate = distance = steps = target = 0
    index, made, starting, clock, ticks = 0, 0, True, 0, []
    while index < len(moves):
        p, count = moves[index]
        d, diag = due(clock), diagonal(clock)
        wanted = p["cruise"] if steps < p["decelerate"] else p["exit"]
        aim, target = target, min(wanted, max_rate) << 16    # the rate moves toward aim
        length = round(math.sqrt(2) * Q24) if diag else Q24
        tick = distance >= length
        step = tick and d
        grown = distance + (rate >> 16)
        if step:
            distance = grown - length
        elif not tick:
            distance = grown
        diff = aim - rate
        rate = aim if abs(diff) <= accel else rate + (accel if diff > 0 else -accel)
        steps = int(step) if starting else steps + step
        starting = False
        if tick:
            ticks.append(clock)
        if step:
            made += 1
            if made == count:
                index, made, starting = index + 1, 0, True
        clock += 1
    return ticks


class ModelTestCase(Checks, unittest.TestCase):
    def test_defaults_are_the_generator_before(self):
        # Hold low and both overrides at 100 %: the same permissions in the same clocks as the
        # generator before, on profiles the planner never sends too (exits above cruises,
        # entries above them).
        for seed in range(6):
            rng = random.Random(seed)
            moves = [(profile(rng.random() * 0.4, rng.random() * 0.4, rng.randrange(60)),
                      rng.randrange(1, 60)) for _ in range(25)]
            accel = accel_of(rng.choice([1e-5, 1e-4, 1e-3]))
            max_rate = rng.choice([Q24 - 1, Q24 // 5])
            pattern = [rng.random() < 0.8 for _ in range(997)]

            def due(clock):
                return int(pattern[clock % 997])

            def diagonal(clock):
                return int(pattern[clock * 7 % 997])

            expected = before(moves, accel=accel, due=due, diagonal=diagonal,
                              max_rate=max_rate)
            model = FeedGeneratorModel(max_rate=max_rate)
            ticks, index, made, starting, clock = [], 0, 0, True, 0
            while index < len(moves):
                p, count = moves[index]
                d, diag = due(clock), diagonal(clock)
                tick = model.cycle(profile=p, accel=accel, start=starting, due=d,
                                   diagonal=diag)
                starting = False
                if tick:
                    ticks.append(clock)
                if tick and d:
                    made += 1
                    if made == count:
                        index, made, starting = index + 1, 0, True
                clock += 1
            self.assertGreater(len(expected), 500)
            self.assertEqual(ticks, expected, f"seed {seed}")

    def test_random_programs_held_and_overridden(self):
        # Planned programs (entries, cruises and exits the planner's way) under holds and
        # override changes at random times, from 10 % to 400 %, on the model: every check
        # holds, whatever the acceleration.
        for seed in range(5):
            rng = random.Random(seed)
            accel = rng.choice([4e-5, 4e-4, 2e-3])
            moves, v0 = [], 0.0
            for _ in range(12):
                length = rng.randrange(5, 250)
                nominal = rng.uniform(0.01, 0.2)
                v1 = min(rng.uniform(0.005, 0.2), nominal,
                         math.sqrt(v0 ** 2 + 2 * accel * length))
                v1 = max(v1, math.sqrt(max(v0 ** 2 - 2 * accel * length, 0)))
                peak = math.sqrt((2 * accel * length + v0 ** 2 + v1 ** 2) / 2)
                moves.append(planned(length, max(min(nominal, peak), v0, v1), v1, accel))
                v0 = v1
            changes, clock = {}, 0
            while clock < 100_000:
                clock += rng.randrange(1, 600)
                changes[clock] = ({"hold": int(rng.random() < 0.5)} if rng.random() < 0.25
                                  else {"feed_override": rng.choice([13, 64, 128, 256, 511])})
            steps = model_run(moves, accel=accel_of(accel), inputs=schedule(changes))
            self.check_run(moves, steps, accel=accel, cap=0.8)

    def test_checks_catch_a_jump(self):
        # The same override change with an acceleration eight times the one checked: the
        # step clocks show the jump.
        moves = [planned(300, 0.1, 0.1)]
        inputs = schedule({1000: {"feed_override": 2 * OVERRIDE_ONE}})
        steps = model_run(moves, accel=accel_of(8 * A), inputs=inputs)
        self.assertNotEqual(rate_jumps(steps, A, 0.2), [])
        self.assertEqual(rate_jumps(steps, 8 * A, 0.2), [])


class EngineTestCase(unittest.TestCase):
    """An arc engine under the generator: held and overridden, the same steps."""

    FRAMES = [{"x0": 30, "y0": 0, "x1": 30, "y1": 0, "cw": 0},
              {"x0": -20, "y0": 15, "x1": 15, "y1": -20, "cw": 1}]

    def motion(self, inputs):
        """The steps (``step``, ``dir``) and their clocks."""
        engine = registry.make_engine("arc", "fast", width=8)
        feed = FeedGenerator()
        m = Module()
        m.submodules.engine, m.submodules.feed = engine, feed
        wiring.connect(m, engine.feed, feed.feed)
        made, clocks = [], []

        async def testbench(ctx):
            ctx.set(feed.ramp.profile, profile(0.2, 0.2, (1 << 24) - 1))
            ctx.set(feed.accel, accel_of(A))
            ctx.set(engine.status.ready, 1)
            ctx.set(feed.ramp.start, 1)
            frames = list(self.FRAMES)
            for clock in range(20_000):
                for name, value in inputs(clock).items():
                    ctx.set(getattr(feed, name), value)
                ctx.set(engine.cmd.valid, bool(frames))
                if frames:
                    ctx.set(engine.cmd.payload, frames[0])
                step = ctx.get(engine.motion.step)
                if step:
                    made.append((step, ctx.get(engine.motion.dir)))
                    clocks.append(clock)
                taken = frames and ctx.get(engine.cmd.ready)
                await ctx.tick()
                ctx.set(feed.ramp.start, 0)
                if taken:
                    frames.pop(0)
                if not frames and not ctx.get(engine.busy):
                    break

        simulate(m, testbench, name="hold_arc")
        return made, clocks

    def test_same_steps(self):
        # A full circle of radius 30 (8·30 + 8 steps on the lattice, SU 1665343) and a
        # quarter-plus arc, uninterrupted, then held twice (in the circle and in the second
        # arc) with the feed override at 200 %, then 50 %, at 150 % across the joint.
        plain, plain_clocks = self.motion(lambda clock: {})
        moved = [sum((step >> axis & 1) * (-1 if ways >> axis & 1 else 1)
                     for step, ways in plain) for axis in (0, 1)]
        self.assertEqual(moved, [35, -35])        # the circle closes; the arc's end
        self.assertGreater(len(plain), 4 * 30)
        inputs = schedule({300: {"feed_override": 2 * OVERRIDE_ONE}, 700: {"hold": 1},
                           1400: {"hold": 0, "feed_override": OVERRIDE_ONE // 2},
                           2000: {"feed_override": override(150)}, 2600: {"hold": 1},
                           3300: {"hold": 0}})
        held, held_clocks = self.motion(inputs)
        self.assertEqual(held, plain)
        self.assertNotEqual(held_clocks, plain_clocks)
        self.assertGreater(held_clocks[-1], plain_clocks[-1])
