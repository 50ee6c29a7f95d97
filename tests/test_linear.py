# amaranth: UnusedElaboratable=no
"""The SU 1571551 RTL against the golden cycle model in Amaranth's simulator, clock for clock."""

import random
import unittest

from kontur.hdl.line import LineEngine
from kontur.hdl.linear import LinearCore, LinearInterpolator
from kontur import registry
from kontur.sim.models.errors import InputError
from kontur.sim.models.linear import LinearInterpolatorModel, patent_inputs, steps, table
from kontur.sim.runners import run_amaranth
from kontur.sim.stimulus import Job, first_difference, record_steps, run_model

from .utils import compare_core, used


def state_signals(engine):
    """The named registers of the core, as the cycle model reports them."""
    core = engine.core.interpolator
    return {"adder3": core.adder3.q, "counter1": core.counter1.q, "counter2": core.counter2.q,
            "trigger14": core.trigger14.q, "trigger15": core.trigger15.q}


class LineEngineTestCase(unittest.TestCase):
    def check(self, job, *, variant, width=16, period=1):
        engine = registry.make_engine("line", variant, width=width, period=period)
        model = registry.make_model("line", variant, width=width, period=period)
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
        engine = registry.make_engine("line", "device")
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
            LinearCore(variant="fast")
        with self.assertRaisesRegex(TypeError,
                r"^Register width must be an integer of at least 2, not 1$"):
            LinearCore(width=1)
        core = LinearCore(width=16)
        with self.assertRaisesRegex(ValueError, r"^Coordinate width must be at least 17, not 16$"):
            LineEngine(core, coord_width=16)
        used(core)
        with self.assertRaisesRegex(TypeError,
                r"^Core must be a component with a LineCoreSignature, not 'exact'$"):
            LineEngine("exact")
        with self.assertRaisesRegex(TypeError,
                r"^Generator period must be a positive integer, not 0$"):
            LinearInterpolator(period=0)
        with self.assertRaisesRegex(TypeError, r"^Zero frames must be a bool, not 0$"):
            LinearInterpolator(zero_frames=0)
        with self.assertRaisesRegex(TypeError, r"^One step input must be a bool, not 1$"):
            LinearInterpolator(one_step_input=1)


class LinearInterpolatorTestCase(unittest.TestCase):
    """The patent-level core on its own, inputs 22-26 driven directly, against the core model."""

    @staticmethod
    def schedule(starts, clocks, tick=(1,)):
        """Per-clock inputs: a start (input 26) at each clock of ``starts`` with that frame's
        inputs 22-25, which stay on the inputs until the next start."""
        current = (0, 0, 0, 0)
        rows = []
        for clock in range(clocks):
            row = {"tick": tick[clock % len(tick)]}
            if clock in starts:
                current = patent_inputs(*starts[clock])
                row["in26"] = 1
            row.update(zip(("in22", "in23", "in24", "in25"), current))
            rows.append(row)
        return rows

    def run_core(self, variant, starts, clocks, tick=(1,), period=1):
        dut = LinearInterpolator(width=8, variant=variant, period=period)
        model = LinearInterpolatorModel(width=8, variant=variant, period=period)
        state = {"adder3": dut.adder3.q, "counter1": dut.counter1.q, "counter2": dut.counter2.q,
                 "trigger14": dut.trigger14.q, "trigger15": dut.trigger15.q}
        return compare_core(self, dut, model, self.schedule(starts, clocks, tick), state=state,
                            name=f"linear_core_{variant}_{period}")

    def test_starts_refusals_and_back_to_back(self):
        # (7, 3) runs in clocks 1-7; a start in clock 3 is refused; (2, 1) starts in the last
        # clock of (7, 3) and runs in 8-9; a zero-length frame in (2, 1)'s last clock is refused
        # (one frame ends per clock) and accepted when idle; then (-5, 5) and (0, 4).
        starts = {0: (7, 3), 3: (9, 9), 7: (2, 1), 9: (0, 0), 11: (0, 0), 12: (-5, 5),
                  17: (0, 4)}
        for variant in ("device", "exact"):
            outputs = self.run_core(variant, starts, 24)
            errors = [c for c, o in enumerate(outputs) if o["error"]]
            dones = [c for c, o in enumerate(outputs) if o["done"]]
            self.assertEqual(errors, [3, 9])
            self.assertEqual(dones, [7, 9, 11, 17, 21])
            moves = [o["step"] for o in outputs if o["step"]]
            self.assertEqual(len(moves), 7 + 2 + 5 + 4)

    def test_generator_period_and_tick(self):
        starts = {0: (6, -4), 30: (3, 3)}
        for variant in ("device", "exact"):
            self.run_core(variant, starts, 50, tick=(1, 0, 1), period=2)

    def test_strict_model_raises(self):
        model = LinearInterpolatorModel(width=8, strict=True)
        inputs = dict(zip(("in22", "in23", "in24", "in25"), patent_inputs(7, 3)))
        model.cycle(in26=1, **inputs)
        model.cycle(**inputs)
        with self.assertRaisesRegex(InputError,
                r"^start of frame \(input 26\) while a frame is running and not in its last "
                r"step: refused$"):
            model.cycle(in26=1, **inputs)


if __name__ == "__main__":
    unittest.main()
