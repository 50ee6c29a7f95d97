# amaranth: UnusedElaboratable=no
"""The SU 1571551 RTL against the golden cycle model in Amaranth's simulator, clock for clock."""

import random
import unittest

from hdl.linear import LineEngine, LinearInterpolator
from sim.models.linear import LineEngineModel, patent_inputs, steps, table
from sim.runners import run_amaranth
from sim.stimulus import Job, first_difference, record_steps, run_model

from .utils import simulate


def state_signals(engine):
    """The named registers of the core, as the cycle model reports them."""
    core = engine.core
    return {"adder3": core.adder3.q, "counter1": core.counter1.q, "counter2": core.counter2.q,
            "trigger14": core.trigger14.q, "trigger15": core.trigger15.q}


class LineEngineTestCase(unittest.TestCase):
    def check(self, job, *, variant, width=16, period=1):
        engine = LineEngine(variant=variant, width=width, period=period)
        model = LineEngineModel(variant=variant, width=width, period=period)
        expected = run_model(model, job, state=True)
        actual = run_amaranth(engine, job, state=state_signals(engine))
        self.assertIsNone(first_difference(expected, actual))
        return actual

    def all_end_points(self, variant):
        frames = [{"x": x, "y": y} for x in range(-24, 25) for y in range(-24, 25)]
        random.Random(variant).shuffle(frames)
        record = self.check(Job(frames=frames), variant=variant)
        self.assertEqual(record_steps(record),
                         [s for f in frames for s in steps(f["x"], f["y"], variant=variant)])

    def test_all_end_points_24_device(self):
        self.all_end_points("device")

    def test_all_end_points_24_exact(self):
        self.all_end_points("exact")

    def test_gaps_resets_ticks(self):
        rng = random.Random(5)
        frames = [{"x": rng.randint(-40, 40), "y": rng.randint(-40, 40)} for _ in range(80)]
        frames[10] = {"x": 1 << 16, "y": 3}             # refused: too wide
        frames[11] = {"x": 0, "y": 0}                   # zero length
        frames[12] = {"x": -(1 << 20), "y": -(1 << 20)}  # refused
        gaps = [rng.choice([0, 0, 0, 1, 2, 7]) for _ in frames]
        resets = {300: 1, 301: 0, 900: 3, 1500: 1}
        resets = {k: v for k, v in resets.items() if v}
        for variant in ("device", "exact"):
            for period, tick in ((1, [1]), (2, [1]), (1, [1, 0, 1, 1, 0]), (3, [1, 1, 0])):
                with self.subTest(variant=variant, period=period, tick=tick):
                    job = Job(frames=frames, gaps=gaps, resets=resets, tick=tick)
                    record = self.check(job, variant=variant, period=period)
                    self.assertGreaterEqual(sum(e.get("error", 0) for e in record), 1)

    def test_narrow_and_extreme(self):
        top = (1 << 5) - 1
        frames = [{"x": top, "y": -top}, {"x": -top, "y": 0}, {"x": 1, "y": top},
                  {"x": top + 1, "y": 0}, {"x": 0, "y": -(top + 1)}, {"x": 0, "y": 1}]
        for variant in ("device", "exact"):
            record = self.check(Job(frames=frames), variant=variant, width=5)
            self.assertEqual(sum(e["error"] for e in record), 2)

    def test_patent_table_clock_by_clock(self):
        # The worked table (7, 3): F, counters 1 and 2 after each clock, device variant.
        engine = LineEngine(variant="device")
        record = run_amaranth(engine, Job(frames=[{"x": 7, "y": 3}]), state=state_signals(engine))
        running = [e for e in record if e["trigger14"]]
        after = running[1:] + [None]
        rows = table(7, 3, "device")
        self.assertEqual(len(running), len(rows))
        for entry, nxt, row in zip(running, after, rows):
            self.assertEqual(entry["step"], 0b01 if row["move"] == "P" else 0b11)
            if nxt is not None:                      # the last clock clears the registers
                self.assertEqual(nxt["adder3"], row["f2"] >> 1)
                self.assertEqual(nxt["counter1"], row["c1"])
                self.assertEqual(nxt["counter2"], row["c2"] - 1)   # counter 2 holds C2 - 1

    def test_width_32(self):
        rng = random.Random(32)
        frames = [{"x": rng.randint(-500, 500), "y": rng.randint(-500, 500)} for _ in range(20)]
        frames.append({"x": (1 << 32), "y": 0})
        for variant in ("device", "exact"):
            self.check(Job(frames=frames), variant=variant, width=32)

    def test_parameters_wrong(self):
        with self.assertRaisesRegex(ValueError,
                r"^Variant must be one of 'device', 'exact', not 'fast'$"):
            LineEngine(variant="fast")
        with self.assertRaisesRegex(TypeError,
                r"^Register width must be an integer of at least 2, not 1$"):
            LineEngine(width=1)
        with self.assertRaisesRegex(ValueError, r"^Coordinate width must be at least 17, not 16$"):
            LineEngine(width=16, coord_width=16)
        with self.assertRaisesRegex(TypeError,
                r"^Generator period must be a positive integer, not 0$"):
            LinearInterpolator(period=0)


class LinearInterpolatorTestCase(unittest.TestCase):
    """The patent-level core on its own: inputs 22-26 driven directly."""

    def run_core(self, x, y, intrude_at=None, intruder=(9, 9)):
        dut = LinearInterpolator(width=8, variant="exact")
        moves, errors = [], []

        async def testbench(ctx):
            def present(px, py):
                in22, in23, in24, in25 = patent_inputs(px, py)
                ctx.set(dut.in22, in22)
                ctx.set(dut.in23, in23)
                ctx.set(dut.in24, in24)
                ctx.set(dut.in25, in25)
            ctx.set(dut.tick, 1)
            present(x, y)
            ctx.set(dut.in26, 1)
            await ctx.tick()
            ctx.set(dut.in26, 0)
            for clock in range(1, 40):
                if clock == intrude_at:
                    present(*intruder)
                    ctx.set(dut.in26, 1)
                step = ctx.get(dut.step)
                errors.append(ctx.get(dut.error))
                if step:
                    moves.append(step)
                if ctx.get(dut.done):
                    break
                await ctx.tick()
                ctx.set(dut.in26, 0)
                present(x, y)

        simulate(dut, testbench, name=f"core_{x}_{y}_{intrude_at}")
        return moves, errors

    def test_start_while_running_is_refused(self):
        clean, clean_errors = self.run_core(7, 3)
        self.assertEqual(len(clean), 7)
        self.assertEqual(sum(clean_errors), 0)
        hit, errors = self.run_core(7, 3, intrude_at=3)
        self.assertEqual(hit, clean)                # the running frame is untouched
        self.assertEqual(errors[2], 1)              # the refusal is flagged in that clock
        self.assertEqual(sum(errors), 1)

    def test_start_in_last_clock_is_accepted(self):
        _, errors = self.run_core(2, 1, intrude_at=2)   # clock 2 is (2, 1)'s last step
        self.assertEqual(sum(errors), 0)


if __name__ == "__main__":
    unittest.main()
