# amaranth: UnusedElaboratable=no
"""The SU 1665343 RTL against the golden cycle model in Amaranth's simulator, clock for clock."""

import math
import random
import unittest

from kontur.hdl.arc import ArcEngine, ArcPlanner
from kontur.hdl.circular import (CircularInterpolator, CircularInterpolatorFast, FaithfulArcCore,
                          FastArcCore, FaithfulTiming)
from kontur import registry
from kontur.sim.models.arc import arc_plan, arc_steps, points_ahead, setup_latency
from kontur.sim.models.circular import (CircularInterpolatorFastModel, CircularInterpolatorModel,
                                 core_inputs, f4_initial, floor_f, native_steps)
from kontur.sim.models.codes import ones_decode
from kontur.sim.models.engine import REFUSED
from kontur.sim.models.errors import InputError
from kontur.sim.runners import run_amaranth
from kontur.sim.stimulus import Job, first_difference, record_steps, run_model

from .utils import compare_core, simulate, used


def state_signals(engine):
    core = engine.core.interpolator
    return {"adder1": core.adder1.q, "counter7": core.counter7.q, "counter8": core.counter8.q,
            "trigger4": core.trigger4.q, "trigger16": core.trigger16.q}


def decode_state(engine, record):
    """The faithful core's adder 1 and counter 8 hold ones' complement codes: decode them."""
    if isinstance(engine.core, FaithfulArcCore):
        for entry in record:
            if not entry["rst"]:
                entry["adder1"] = ones_decode(entry["adder1"], engine.width + 4)
                entry["counter8"] = ones_decode(entry["counter8"], engine.width + 1)
    return record


def random_arcs(rng, count, limit, *, longest=300):
    """Arcs of every quadrant and direction, end points taken along the path."""
    frames = []
    while len(frames) < count:
        x0, y0 = rng.randint(-limit, limit), rng.randint(-limit, limit)
        if (x0, y0) == (0, 0):
            continue
        cw = rng.randrange(2)
        x1, y1 = points_ahead(x0, y0, rng.randint(1, longest), cw=cw)[-1]
        frames.append({"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw})
    return frames


def near_bound_arcs(rng, count, width):
    """Arcs whose end point is within a step or two of either bound of the planner's check
    -M < x0² + y0² - x1² - y1² <= M (M = max(|x1|, |y1|)), every quadrant, with radii up to
    the register's."""
    top = (1 << width) - 1
    frames = []
    while len(frames) < count:
        x0, y0 = rng.randint(-top, top), rng.randint(-top, top)
        r2 = x0 * x0 + y0 * y0
        if r2 == 0 or r2 > top * top:
            continue
        x1 = rng.randint(-math.isqrt(r2), math.isqrt(r2))
        centre = math.isqrt(r2 - x1 * x1)
        for y1 in range(max(0, centre - 3), min(top, centre + 3) + 1):
            y1 = rng.choice([y1, -y1])
            big, excess = max(abs(x1), abs(y1)), r2 - x1 * x1 - y1 * y1
            if min(abs(excess - big), abs(excess + big)) <= 2:
                frames.append({"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": rng.randrange(2)})
    return frames


class ArcPlannerTestCase(unittest.TestCase):
    """The planner alone: every plan as :func:`~kontur.sim.models.arc.arc_plan` forms it, offered
    :func:`~kontur.sim.models.arc.setup_latency` clocks after the arc is taken (its distance a clock
    later)."""

    def check(self, frames, width):
        dut = ArcPlanner(width=width)
        seen = []

        async def testbench(ctx):
            ctx.set(dut.o.ready, 0)
            for frame in frames:
                ctx.set(dut.i.payload, frame)
                ctx.set(dut.i.valid, 1)
                self.assertEqual(ctx.get(dut.i.ready), 1)
                await ctx.tick()
                ctx.set(dut.i.valid, 0)
                clocks = 1
                while not ctx.get(dut.o.valid):
                    await ctx.tick()
                    clocks += 1
                plan = ctx.get(dut.o.payload)
                await ctx.tick()                     # the distance: a clock after the offer
                self.assertEqual(ctx.get(dut.o.valid), 1)
                seen.append((frame, clocks, plan, ctx.get(dut.o.payload.distance)))
                ctx.set(dut.o.ready, 1)
                await ctx.tick()
                ctx.set(dut.o.ready, 0)

        simulate(dut, testbench, name=f"arc_planner_{width}")
        self.assertEqual(len(seen), len(frames))
        refused = 0
        for frame, clocks, plan, distance in seen:
            with self.subTest(frame=frame):
                self.assertEqual(clocks, setup_latency(width))
                expected = arc_plan(frame, width)
                self.assertEqual(plan.refused, expected["refused"])
                refused += expected["refused"]
                if not expected["refused"]:
                    got = {"cw": plan.cw, "quadrant": plan.quadrant, "runs": plan.runs,
                           "start": (plan.start.x, plan.start.y),
                           "off_axis": plan.off_axis, "radius": plan.radius,
                           "residue": plan.residue}
                    if plan.off_axis:                # (the distance counts only then)
                        got["distance"] = distance
                    self.assertEqual(got, {k: expected[k] for k in got})
        return refused

    def test_end_points_near_the_bounds(self):
        # Both sides of both bounds, at widths where x0² + y0² and x1² + y1² cross bit
        # `width` (the check splits them there) in either direction.
        for width, count in ((6, 150), (11, 120)):
            with self.subTest(width=width):
                frames = near_bound_arcs(random.Random(width), count, width)
                refused = self.check(frames, width)
                self.assertTrue(20 < refused < len(frames) - 20, (refused, len(frames)))

    def test_refusals_at_the_register_limits(self):
        width = 8
        top = (1 << width) - 1
        frames = [
            {"x0": top, "y0": 0, "x1": -top, "y1": 0, "cw": 0},          # R = 255, half a turn
            {"x0": -top, "y0": 0, "x1": -top, "y1": 0, "cw": 1},         # full circle
            {"x0": top + 1, "y0": 0, "x1": top + 1, "y1": 0, "cw": 0},   # coordinate too wide
            {"x0": -top - 1, "y0": 0, "x1": -top - 1, "y1": 0, "cw": 0},  # ... negative
            {"x0": 0, "y0": -top - 1, "x1": 0, "y1": -top - 1, "cw": 1},
            {"x0": 3, "y0": 4, "x1": 0, "y1": -top - 1, "cw": 1},        # the end too wide
            {"x0": 181, "y0": 181, "x1": 181, "y1": 181, "cw": 0},       # radius rounds to 256
            {"x0": 180, "y0": 180, "x1": -180, "y1": 180, "cw": 0},      # radius 254.6: 255
            {"x0": 0, "y0": 0, "x1": 0, "y1": 0, "cw": 0},               # R = 0
            {"x0": -(1 << 30), "y0": 5, "x1": 5, "y1": 5, "cw": 0},      # far beyond
        ]
        self.assertEqual(self.check(frames, width), 7)


class ArcEngineTestCase(unittest.TestCase):
    def check(self, job, *, variant, width=24, state=True, **params):
        engine = registry.make_engine("arc", variant, width=width, **params)
        model = registry.make_model("arc", variant, width=width, **params)
        expected = run_model(model, job, state=state)
        actual = run_amaranth(engine, job, state=state_signals(engine) if state else None)
        if state:
            decode_state(engine, actual)
        self.assertIsNone(first_difference(expected, actual))
        return actual

    def every_radius(self, variant):
        frames = [{"x0": r, "y0": 0, "x1": r, "y1": 0, "cw": 0} for r in range(1, 65)]
        frames += [{"x0": 0, "y0": -r, "x1": 0, "y1": -r, "cw": 1} for r in range(1, 65)]
        record = self.check(Job(frames=frames), variant=variant)
        self.assertEqual(record_steps(record),
                         [s for f in frames for s in arc_steps(f["x0"], f["y0"], f["x1"],
                                                               f["y1"], cw=f["cw"])])
        self.assertEqual(sum(e["done"] for e in record), len(frames))

    def test_every_radius_to_64_faithful(self):
        self.every_radius("faithful")

    def test_every_radius_to_64_fast(self):
        self.every_radius("fast")

    def test_random_arcs_gaps_resets_ticks(self):
        rng = random.Random(12)
        frames = random_arcs(rng, 40, 40)
        frames[7] = {"x0": 5, "y0": 0, "x1": 2, "y1": 4, "cw": 0}          # off the circle
        frames[8] = {"x0": 0, "y0": 0, "x1": 0, "y1": 0, "cw": 1}          # R = 0
        frames[9] = {"x0": 1 << 24, "y0": 0, "x1": 1 << 24, "y1": 0, "cw": 0}   # too wide
        frames[10] = {"x0": 3, "y0": 4, "x1": 3, "y1": 4, "cw": 1}         # full circle
        gaps = [rng.choice([0, 0, 0, 5, 90, 200]) for _ in frames]
        for variant in ("faithful", "fast"):
            for tick in ([1], [1, 0, 1]):
                with self.subTest(variant=variant, tick=tick):
                    job = Job(frames=frames, gaps=gaps, tick=tick, resets={1500: 2, 4000: 1})
                    record = self.check(job, variant=variant)
                    self.assertGreaterEqual(sum(e.get("error", 0) for e in record), 2)

    def test_end_point_bound(self):
        # End points on both sides of each bound of -M < r2 - x1² - y1² <= M: the planner's
        # check (two three-operand sums) refuses exactly the ones the model refuses.
        frames = []
        for x0, y0 in ((9, 4), (-13, 7), (20, -3)):
            r2 = x0 * x0 + y0 * y0
            for x1 in range(-25, 26):
                for y1 in range(-25, 26):
                    big = max(abs(x1), abs(y1))
                    if r2 - x1 * x1 - y1 * y1 in (-big - 1, -big, -big + 1, big, big + 1):
                        frames.append({"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": 0})
        refused = [f for f in frames
                   if not -max(abs(f["x1"]), abs(f["y1"])) < f["x0"] ** 2 + f["y0"] ** 2
                   - f["x1"] ** 2 - f["y1"] ** 2 <= max(abs(f["x1"]), abs(f["y1"]))]
        self.assertTrue(10 < len(refused) < len(frames) - 10, (len(refused), len(frames)))
        record = self.check(Job(frames=frames), variant="fast", width=8, state=False)
        outcomes = [e["status"][1] for e in record if e.get("status")]
        self.assertEqual(len(outcomes), len(frames))
        self.assertEqual(outcomes.count(REFUSED), len(refused))

    def test_non_integer_radii(self):
        rng = random.Random(5)
        frames = []
        for _ in range(25):
            x0, y0 = rng.randint(1, 30), rng.randint(-30, 30)     # r2 rarely a square
            frames.append({"x0": x0, "y0": y0, "x1": x0, "y1": y0, "cw": rng.randrange(2)})
        for variant in ("faithful", "fast"):
            self.check(Job(frames=frames), variant=variant)

    def test_longer_faithful_timing(self):
        timing = FaithfulTiming(period=6, delay12=4, delay13=2, delay14=2, taps19=(2, 4, 5),
                                taps26=(1, 2, 2, 3), extender=6)
        frames = [{"x0": r, "y0": 0, "x1": 0, "y1": r, "cw": 0} for r in (1, 4, 10, 11, 12, 23)]
        self.check(Job(frames=frames), variant="faithful", timing=timing)

    def test_fast_generator_period(self):
        frames = [{"x0": r, "y0": 0, "x1": 0, "y1": -r, "cw": 1} for r in (1, 4, 10, 12)]
        for tick in ([1], [1, 1, 0]):
            record = self.check(Job(frames=frames, tick=tick), variant="fast", period=3)
            self.assertEqual(record_steps(record),
                             [s for f in frames for s in arc_steps(f["x0"], f["y0"], f["x1"],
                                                                   f["y1"], cw=f["cw"])])

    def test_large_radii_width_32(self):
        rng = random.Random(32)
        frames = []
        for _ in range(6):
            small, large = rng.randint(0, 400), rng.randint(1 << 28, (1 << 31) - 1)
            x0, y0 = rng.choice([(small, large), (large, -small), (-small, -large)])
            cw = rng.randrange(2)
            x1, y1 = points_ahead(x0, y0, rng.randint(1, 600), cw=cw, width=32)[-1]
            frames.append({"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw})
        frames.append({"x0": (1 << 32) - 1, "y0": 1 << 20, "x1": 0, "y1": 0, "cw": 0})  # too wide
        for variant in ("faithful", "fast"):
            self.check(Job(frames=frames), variant=variant, width=32, state=False)

    def test_parameters_wrong(self):
        with self.assertRaisesRegex(ValueError,
                r"^arc variant must be one of 'faithful', 'fast', 'separate', 'serial', "
                r"not 'exact'$"):
            registry.make_engine("arc", "exact")
        with self.assertRaisesRegex(TypeError,
                r"^arc variant 'fast' takes no parameter 'timing' \(it takes 'period'\)$"):
            registry.make_engine("arc", "fast", timing=FaithfulTiming())
        core = FastArcCore(width=24)
        with self.assertRaisesRegex(ValueError, r"^Coordinate width must be at least 25, not 24$"):
            ArcEngine(core, coord_width=24)
        used(core)
        with self.assertRaisesRegex(TypeError,
                r"^Core must be a component with an ArcCoreSignature, not 4$"):
            ArcEngine(4)
        with self.assertRaisesRegex(TypeError, r"^Timing must be a FaithfulTiming, not 4$"):
            CircularInterpolator(timing=4)
        with self.assertRaisesRegex(TypeError,
                r"^Generator period must be a positive integer, not 0$"):
            CircularInterpolatorFast(period=0)


class CoreTestCase(unittest.TestCase):
    """The cores on their own, inputs 29-34 driven directly, against the core models."""

    def schedule(self, starts, stops, clocks):
        """Per-clock inputs: a start (input 33) at each clock of ``starts`` (native start point
        and r2), input 32 at each clock of ``stops``; inputs 29-31, 34 stay until the next."""
        current = (0, 0, 0, 0)
        rows = []
        for clock in range(clocks):
            row = {"tick": 1, "in32": int(clock in stops)}
            if clock in starts:
                x, y, r2 = starts[clock]
                current = core_inputs(x, y, floor_f(f4_initial(x, y, r2)))
                row["in33"] = 1
            row.update(zip(("in29", "in30", "in31", "in34"), current))
            rows.append(row)
        return rows

    def run_core(self, make_dut, make_model, starts, stops, clocks):
        dut, model = make_dut(), make_model()
        state = {"adder1": dut.adder1.q, "counter7": dut.counter7.q,
                 "counter8": dut.counter8.q, "trigger4": dut.trigger4.q,
                 "trigger16": dut.trigger16.q}
        decode = {}
        if isinstance(dut, CircularInterpolator):
            decode = {"adder1": lambda v: ones_decode(v, dut.width + 4),
                      "counter8": lambda v: ones_decode(v, dut.width + 1)}
        return compare_core(self, dut, model, self.schedule(starts, stops, clocks), state=state,
                            decode=decode, name=f"circular_core_{type(dut).__name__}")

    def first_done(self, make_model, x, y, r2):
        model = make_model()
        for clock, inputs in enumerate(self.schedule({0: (x, y, r2)}, (), 10_000)):
            outputs, _, _ = model.cycle(**inputs)
            if clock and outputs["done"]:
                return clock
        raise AssertionError("no stop")

    def check_core(self, make_dut, make_model):
        # R = 12 from (12, 0); a start while it runs (refused); the next run, R = 10 from a
        # sector-2 point, started in the clock the first stops; stopped by input 32 in the
        # middle, with a new run (R = 4, the Y-step switch-over) started in the same clock.
        end = self.first_done(make_model, 12, 0, 144)
        starts = {0: (12, 0, 144), 9: (5, 5, 50), end: (6, 8, 100), end + 20: (4, 0, 16)}
        outputs = self.run_core(make_dut, make_model, starts, {end + 20}, end + 150)
        self.assertEqual([c for c, o in enumerate(outputs) if o["error"]], [9])
        moves = "".join({1: "X", 2: "Y", 3: "D"}[o["step"]] for o in outputs[:end + 1]
                        if o["step"])
        self.assertEqual(moves, "".join(m for m, _ in native_steps(12, 0, 144)))

    def test_faithful_core(self):
        self.check_core(CircularInterpolator, CircularInterpolatorModel)

    def test_fast_core(self):
        self.check_core(CircularInterpolatorFast, CircularInterpolatorFastModel)

    def test_strict_models_raise(self):
        for model in (CircularInterpolatorModel(strict=True),
                      CircularInterpolatorFastModel(strict=True)):
            inputs = dict(zip(("in29", "in30", "in31", "in34"),
                              core_inputs(12, 0, floor_f(f4_initial(12, 0, 144)))))
            model.cycle(in33=1, **inputs)
            with self.assertRaisesRegex(InputError,
                    r"^start \(input 33\) while a run is in progress and not stopping in "
                    r"this clock: refused$"):
                model.cycle(in33=1, **inputs)


if __name__ == "__main__":
    unittest.main()
