# amaranth: UnusedElaboratable=no
"""The textbook cores' RTL against their cycle models in Amaranth's simulator, clock for clock:
separate steps (line, circle) and the DDA, with their registers."""

import random
import unittest

from kontur.hdl.textbook import DdaCore, SeparateArcCore, SeparateLineCore
from kontur import registry
from kontur.sim.models.arc import points_ahead
from kontur.sim.runners import run_amaranth
from kontur.sim.stimulus import Job, first_difference, record_steps, run_model

from .utils import used


def state_signals(engine):
    """The named registers of a core, as its cycle model reports them."""
    core = engine.core
    if isinstance(core, DdaCore):
        return {"register_x": core.register_x.q, "register_y": core.register_y.q,
                "counter": core.counter.q, "trigger": core.trigger.q}
    return {"adder": core.adder.q, "counter_x": core.counter_x.q, "counter_y": core.counter_y.q,
            "trigger": core.trigger.q}


def random_arcs(rng, count, limit, *, longest=300, width=24):
    """Arcs of every quadrant and direction, end points taken along the path."""
    frames = []
    while len(frames) < count:
        x0, y0 = rng.randint(-limit, limit), rng.randint(-limit, limit)
        if (x0, y0) == (0, 0):
            continue
        cw = rng.randrange(2)
        x1, y1 = points_ahead(x0, y0, rng.randint(1, longest), cw=cw, width=width)[-1]
        frames.append({"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw})
    return frames


class EngineCase(unittest.TestCase):
    kind = None

    def check(self, job, *, variant, width, state=True, **params):
        engine = registry.make_engine(self.kind, variant, width=width, **params)
        model = registry.make_model(self.kind, variant, width=width, **params)
        expected = run_model(model, job, state=state)
        actual = run_amaranth(engine, job, state=state_signals(engine) if state else None)
        self.assertIsNone(first_difference(expected, actual))
        return actual

    def expected_steps(self, frames, variant, width, **params):
        moves = []
        for frame in frames:
            try:
                moves += registry.steps(self.kind, frame, variant, width=width, **params)
            except registry.InputError:
                pass
        return moves


class LineEngineTestCase(EngineCase):
    kind = "line"
    #: The line variants whose cores are the textbook's (``hdl/textbook.py``).
    VARIANTS = tuple((name, {}) for name in registry.variants("line")
                     if registry.variant("line", name).core.__module__ == "kontur.hdl.textbook")

    def all_end_points(self, variant, width=16, limit=14, **params):
        frames = [{"x": x, "y": y} for x in range(-limit, limit + 1)
                  for y in range(-limit, limit + 1)]
        random.Random(variant).shuffle(frames)
        record = self.check(Job(frames=frames), variant=variant, width=width, **params)
        self.assertEqual(record_steps(record),
                         self.expected_steps(frames, variant, width, **params))

    def test_all_end_points_14_separate(self):
        self.all_end_points("separate")

    def test_all_end_points_14_dda(self):
        self.all_end_points("dda")

    def test_all_end_points_14_dda_zero(self):
        self.all_end_points("dda-zero")

    def test_dda_register_capacity(self):
        # A fixed capacity 2**6: 64 clocks a segment, whatever its length.
        for variant in ("dda", "dda-zero"):
            self.all_end_points(variant, width=6, limit=5, capacity="register")

    def test_gaps_resets_ticks_aborts(self):
        rng = random.Random(5)
        frames = [{"x": rng.randint(-40, 40), "y": rng.randint(-40, 40)} for _ in range(60)]
        frames[10] = {"x": 1 << 16, "y": 3}             # refused: too wide
        frames[11] = {"x": 0, "y": 0}                   # zero length
        frames[12] = {"x": -(1 << 20), "y": -(1 << 20)}  # refused
        gaps = [rng.choice([0, 0, 0, 1, 2, 7]) for _ in frames]
        for variant, params in self.VARIANTS:
            for tick, status_ready in (([1], [1]), ([1, 0, 1, 1, 0], [1, 1, 0])):
                with self.subTest(variant=variant, tick=tick):
                    job = Job(frames=frames, gaps=gaps, tick=tick, status_ready=status_ready,
                              resets={300: 1, 900: 3}, aborts={500: 1, 1300: 2})
                    record = self.check(job, variant=variant, width=16, **params)
                    self.assertGreaterEqual(sum(e.get("error", 0) for e in record), 1)
                    self.assertGreaterEqual(sum(e.get("aborted", 0) for e in record), 1)

    def test_narrow_and_extreme(self):
        top = (1 << 5) - 1
        frames = [{"x": top, "y": -top}, {"x": -top, "y": 0}, {"x": 1, "y": top},
                  {"x": top + 1, "y": 0}, {"x": 0, "y": -(top + 1)}, {"x": 0, "y": 1},
                  {"x": -top, "y": -top + 1}]
        for variant, params in self.VARIANTS + (("dda", {"capacity": "register"}),):
            record = self.check(Job(frames=frames), variant=variant, width=5, **params)
            self.assertEqual(sum(e["error"] for e in record), 2)
            self.assertEqual(record_steps(record),
                             self.expected_steps(frames, variant, 5, **params))

    def test_width_32(self):
        rng = random.Random(32)
        frames = [{"x": rng.randint(-500, 500), "y": rng.randint(-500, 500)} for _ in range(5)]
        frames.append({"x": (1 << 32), "y": 0})
        for variant, params in self.VARIANTS:
            self.check(Job(frames=frames), variant=variant, width=32, **params)

    def test_parameters_wrong(self):
        with self.assertRaisesRegex(ValueError,
                r"^Preset must be one of 'half', 'zero', not 'third'$"):
            DdaCore(preset="third")
        with self.assertRaisesRegex(ValueError,
                r"^Capacity must be one of 'segment', 'register', not 8$"):
            DdaCore(capacity=8)
        for core in (SeparateLineCore, SeparateArcCore, DdaCore):
            with self.assertRaisesRegex(TypeError,
                    r"^Register width must be an integer of at least 2, not 1$"):
                core(width=1)
        with self.assertRaisesRegex(TypeError,
                r"^line variant 'dda' takes no parameter 'preset' \(it takes 'capacity'\)$"):
            registry.make_engine("line", "dda", preset="zero")
        with self.assertRaisesRegex(TypeError,
                r"^line variant 'separate' takes no parameter 'capacity' \(it takes nothing "
                r"but 'width'\)$"):
            registry.steps("line", {"x": 1, "y": 1}, "separate", capacity="register")
        core = DdaCore(width=8, preset="zero", capacity="register")
        self.assertEqual((core.width, core.preset, core.capacity), (8, "zero", "register"))
        used(core)


class ArcEngineTestCase(EngineCase):
    kind = "arc"

    def test_every_radius_to_40(self):
        frames = [{"x0": r, "y0": 0, "x1": r, "y1": 0, "cw": 0} for r in range(1, 41)]
        frames += [{"x0": 0, "y0": -r, "x1": 0, "y1": -r, "cw": 1} for r in range(1, 41, 3)]
        record = self.check(Job(frames=frames), variant="separate", width=24)
        self.assertEqual(record_steps(record), self.expected_steps(frames, "separate", 24))
        self.assertEqual(sum(e["done"] for e in record), len(frames))

    def test_random_arcs_gaps_resets_ticks(self):
        rng = random.Random(12)
        frames = random_arcs(rng, 40, 40)
        frames[7] = {"x0": 5, "y0": 0, "x1": 2, "y1": 4, "cw": 0}          # off the circle
        frames[8] = {"x0": 0, "y0": 0, "x1": 0, "y1": 0, "cw": 1}          # R = 0
        frames[9] = {"x0": 1 << 24, "y0": 0, "x1": 1 << 24, "y1": 0, "cw": 0}   # too wide
        frames[10] = {"x0": 3, "y0": 4, "x1": 3, "y1": 4, "cw": 1}         # full circle
        gaps = [rng.choice([0, 0, 0, 5, 90, 200]) for _ in frames]
        for tick in ([1], [1, 0, 1]):
            with self.subTest(tick=tick):
                job = Job(frames=frames, gaps=gaps, tick=tick, status_ready=[1, 1, 1, 0],
                          resets={1500: 2, 4000: 1}, aborts={2500: 1})
                record = self.check(job, variant="separate", width=24)
                self.assertGreaterEqual(sum(e.get("error", 0) for e in record), 2)

    def test_non_integer_radii(self):
        rng = random.Random(5)
        frames = []
        for _ in range(25):
            x0, y0 = rng.randint(1, 30), rng.randint(-30, 30)     # r2 rarely a square
            frames.append({"x0": x0, "y0": y0, "x1": x0, "y1": y0, "cw": rng.randrange(2)})
        record = self.check(Job(frames=frames), variant="separate", width=24)
        self.assertEqual(record_steps(record), self.expected_steps(frames, "separate", 24))

    def test_extremes_narrow(self):
        # Radii up to the register width: the registers' extremes (width 6: up to 63).
        top = (1 << 6) - 1
        frames = [{"x0": top, "y0": 0, "x1": top, "y1": 0, "cw": 0},
                  {"x0": 0, "y0": -top, "x1": -top, "y1": 0, "cw": 1},
                  {"x0": 44, "y0": 44, "x1": 44, "y1": 44, "cw": 1},        # Rn = 62
                  {"x0": 45, "y0": 45, "x1": 45, "y1": 45, "cw": 0}]        # Rn = 64: refused
        record = self.check(Job(frames=frames), variant="separate", width=6)
        self.assertEqual(sum(e["error"] for e in record), 1)
        self.assertEqual(record_steps(record), self.expected_steps(frames, "separate", 6))

    def test_large_radii_width_32(self):
        rng = random.Random(32)
        frames = []
        for _ in range(5):
            small, large = rng.randint(0, 400), rng.randint(1 << 28, (1 << 31) - 1)
            x0, y0 = rng.choice([(small, large), (large, -small), (-small, -large)])
            cw = rng.randrange(2)
            x1, y1 = points_ahead(x0, y0, rng.randint(1, 500), cw=cw, width=32)[-1]
            frames.append({"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw})
        self.check(Job(frames=frames), variant="separate", width=32, state=False)


if __name__ == "__main__":
    unittest.main()
