"""The textbook golden models against geometry, against the arc planner, and at cycle level."""

import math
import random
import unittest

from kontur import registry
from kontur.sim.geometry import radial_error, walk
from kontur.sim.models.arc import check_arc, plan_arc, points_ahead, round_sqrt
from kontur.sim.models.circular import native_path
from kontur.sim.models.errors import InputError
from kontur.sim.models.textbook import (DdaCoreModel, dda_capacity, dda_iterations, dda_steps,
                                 lattice_line_steps, lattice_native_path, separate_arc_steps,
                                 separate_line_moves, separate_line_steps,
                                 separate_native_moves, separate_native_path,
                                 separate_points_ahead)
from kontur.sim.stimulus import Job, record_moves, record_steps, run_model

END_POINTS_64 = [(x, y) for x in range(-64, 65) for y in range(-64, 65) if (x, y) != (0, 0)]


def deviation(x_end, y_end, path):
    """Largest distance of the visited points from the line through the origin and the end."""
    length = math.hypot(x_end, y_end)
    return max(abs(x * y_end - y * x_end) / length for x, y in walk((0, 0), path))


class SeparateLineTestCase(unittest.TestCase):
    def test_every_end_point_64(self):
        # |X| + |Y| steps along one axis each, towards the end point, ending on it, every
        # point within (|X| + |Y|) / 2L of the line (the midpoint bound; at most 1/sqrt(2)).
        worst = 0.0
        for x, y in END_POINTS_64:
            path = separate_line_steps(x, y)
            self.assertEqual(len(path), abs(x) + abs(y))
            self.assertEqual(walk((0, 0), path)[-1], (x, y))
            for dx, dy in path:
                self.assertEqual(abs(dx) + abs(dy), 1)
                self.assertIn(dx, (0, 1 if x > 0 else -1))
                self.assertIn(dy, (0, 1 if y > 0 else -1))
            error = deviation(x, y, path)
            self.assertLessEqual(error, (abs(x) + abs(y)) / (2 * math.hypot(x, y)) + 1e-12,
                                 (x, y))
            worst = max(worst, error)
        self.assertLess(worst, 1 / math.sqrt(2) + 1e-12)
        self.assertGreater(worst, 0.7)

    def test_estimating_function_stays_in_its_register(self):
        # D = 2F(x + 1/2, y + 1/2) after every move, and always in [-2Y, 2X): width + 2 bits.
        for x_end in range(0, 41):
            for y_end in range(0, 41):
                x = y = 0
                for move, d in separate_line_moves(x_end, y_end):
                    x, y = (x + 1, y) if move == "X" else (x, y + 1)
                    self.assertEqual(d, 2 * (y * x_end - x * y_end) + x_end - y_end)
                    self.assertTrue(-2 * y_end <= d < 2 * x_end, (x_end, y_end, x, y))

    def test_tie_goes_to_x(self):
        # (3, 3): D0 = 0, the line through the midpoint of (1, 0) and (0, 1): X first, then the
        # path alternates; (1, 3) meets D = 0 after its first step, at (0, 1).
        self.assertEqual("".join(m for m, _ in separate_line_moves(3, 3)), "XYXYXY")
        moves = list(separate_line_moves(1, 3))
        self.assertEqual(moves[0], ("Y", 0))
        self.assertEqual(moves[1][0], "X")

    def test_axis_parallel(self):
        self.assertEqual(separate_line_steps(0, -5), [(0, -1)] * 5)
        self.assertEqual(separate_line_steps(7, 0), [(1, 0)] * 7)
        self.assertEqual(separate_line_steps(0, 0), [])

    def test_text_rule_at_the_point(self):
        # The text's F at the point reached (tie to X, exhausted axis guarded): also |X| + |Y|
        # steps onto the end point, but up to max/L from the line (nearly a whole step).
        worst = 0.0
        for x, y in END_POINTS_64:
            path = lattice_line_steps(x, y)
            self.assertEqual(len(path), abs(x) + abs(y))
            self.assertEqual(walk((0, 0), path)[-1], (x, y))
            error = deviation(x, y, path)
            self.assertLess(error, max(abs(x), abs(y)) / math.hypot(x, y) + 1e-12)
            worst = max(worst, error)
        self.assertGreater(worst, 0.99)

    def test_refusals(self):
        with self.assertRaisesRegex(InputError,
                r"^\|X\| = 65536 is too wide for the 16-bit registers \(at most 65535\)$"):
            separate_line_steps(1 << 16, 0)
        with self.assertRaisesRegex(TypeError, r"^Y must be an integer, not 1\.5$"):
            separate_line_steps(1, 1.5)
        with self.assertRaisesRegex(ValueError,
                r"^magnitudes must not be negative, not \(-1, 2\)$"):
            list(separate_line_moves(-1, 2))


class SeparateCircleTestCase(unittest.TestCase):
    def test_every_radius_to_500(self):
        # Full circles both ways from an axis and from a point off the axes: 8R steps, one axis
        # each, back on the start, every point within 1/sqrt(2) of the circle.
        worst = 0.0
        for r in range(1, 501):
            for x0, y0, cw in ((r, 0, 0), (0, -r, 1)):
                path = separate_arc_steps(x0, y0, x0, y0, cw=cw)
                self.assertEqual(len(path), 8 * r)
                points = walk((x0, y0), path)
                self.assertEqual(points[-1], (x0, y0))
                self.assertTrue(all(abs(dx) + abs(dy) == 1 for dx, dy in path))
                error = radial_error(points, r * r)
                self.assertLess(error, 1 / math.sqrt(2), r)
                worst = max(worst, error)
        self.assertGreater(worst, 0.70)

    def test_quadrant_closes_on_the_planners_axis_point(self):
        # Every r2 up to 20000 (integer radius or not): the run from (Rn, 0) has 2·Rn steps,
        # ends on (0, Rn), passes through every point of the patent's path (the end points
        # the planner accepts) and keeps G in [-2x, 2y) (width + 2 bits).
        for r2 in range(1, 20001):
            rn = round_sqrt(r2)
            path = separate_native_path(rn, 0, r2)
            self.assertEqual(len(path) - 1, 2 * rn, r2)
            self.assertEqual(path[-1], (0, rn), r2)
            self.assertLessEqual(set(native_path(rn, 0, r2)), set(path), r2)
            values = [g for _, g in separate_native_moves(rn, 0, r2)]
            self.assertEqual(values, [x * x - x + y * y + y - r2 for x, y in path[1:]])
            self.assertTrue(all(-2 * x <= g < 2 * y for g, (x, y) in zip(values, path[1:-1])),
                            r2)

    def test_every_accepted_end_point_is_reached(self):
        # Every lattice end point the planner accepts, from random starts of every quadrant,
        # ends the arc exactly there.
        rng = random.Random(7)
        for _ in range(300):
            x0, y0 = rng.randint(-60, 60), rng.randint(-60, 60)
            if (x0, y0) == (0, 0):
                continue
            cw = rng.randrange(2)
            for x1, y1 in points_ahead(x0, y0, 40, cw=cw)[::7]:
                path = separate_arc_steps(x0, y0, x1, y1, cw=cw)
                self.assertEqual(walk((x0, y0), path)[-1], (x1, y1))
                self.assertIn((x1, y1), separate_points_ahead(x0, y0, len(path), cw=cw))

    def test_text_rule_at_the_point_misses_the_axis_point(self):
        # The text's F = x² + y² - r2 at the point reached (tie to X) ends a quadrant of
        # r2 = 42 on (0, 7), where the arc engine starts the next at Rn = 6; and R = 1 at the
        # centre. The midpoint rule ends both on (0, Rn).
        self.assertEqual(lattice_native_path(6, 0, 42)[-1], (0, 7))
        self.assertEqual(lattice_native_path(1, 0, 1)[-1], (0, 0))
        self.assertEqual(separate_native_path(6, 0, 42)[-1], (0, 6))
        self.assertEqual(separate_native_path(1, 0, 1), [(1, 0), (1, 1), (0, 1)])

    def test_refusals(self):
        with self.assertRaisesRegex(InputError, r"^the start point is the centre: radius R = 0$"):
            separate_arc_steps(0, 0, 0, 0)
        with self.assertRaisesRegex(InputError, r"^the end point \(2, 4\) is not on the circle "):
            separate_arc_steps(5, 0, 2, 4)
        with self.assertRaisesRegex(ValueError,
                r"^native start must have X >= 1 and Y >= 0, not \(0, 3\)$"):
            separate_native_path(0, 3, 9)
        with self.assertRaisesRegex(AssertionError,
                r"^the path from the start never reaches the end point \(3, 3\)$"):
            separate_native_path(5, 0, 25, end=(3, 3))


class DdaTestCase(unittest.TestCase):
    def test_every_end_point_64(self):
        # Exactly N = 2**n iterations, ending on the end point; after k iterations the point is
        # floor((p + k·X) / N) (p = N/2 or 0); within (|X| + |Y|)/2L of the line with the
        # half preset, within max/L without; each step moves each axis at most once.
        for preset in ("half", "zero"):
            for capacity, width in (("segment", 16), ("register", 7)):
                for x, y in END_POINTS_64:
                    iterations = dda_iterations(x, y, width=width, preset=preset,
                                                capacity=capacity)
                    n = dda_capacity(x, y, width=width, capacity=capacity)
                    capacity_n = 1 << n
                    self.assertEqual(len(iterations), capacity_n)
                    self.assertGreater(capacity_n, max(abs(x), abs(y)))
                    if capacity == "segment":
                        self.assertLessEqual(capacity_n, 2 * max(abs(x), abs(y)))
                    p = capacity_n // 2 if preset == "half" else 0
                    points = walk((0, 0), iterations)
                    sx, sy = (-1 if x < 0 else 1), (-1 if y < 0 else 1)
                    self.assertEqual(points, [(sx * ((p + k * abs(x)) // capacity_n),
                                               sy * ((p + k * abs(y)) // capacity_n))
                                              for k in range(1, capacity_n + 1)])
                    self.assertEqual(points[-1], (x, y))
                    bound = ((abs(x) + abs(y)) / 2 if preset == "half" else max(abs(x), abs(y)))
                    self.assertLessEqual(deviation(x, y, iterations),
                                         bound / math.hypot(x, y) + 1e-12, (preset, x, y))

    def test_steps_and_capacity(self):
        self.assertEqual(dda_capacity(5, -3, width=16), 3)
        self.assertEqual(dda_capacity(8, 0, width=16), 4)
        self.assertEqual(dda_capacity(5, 3, width=10, capacity="register"), 10)
        self.assertEqual(dda_iterations(0, 0), [])
        self.assertEqual(dda_iterations(1, 0, preset="zero"), [(0, 0), (1, 0)])
        self.assertEqual(dda_iterations(1, 0, preset="half"), [(1, 0), (0, 0)])
        self.assertEqual(dda_steps(3, 3), [(1, 1)] * 3)
        self.assertEqual(len(dda_iterations(3, 1, width=8, capacity="register")), 256)

    def test_parameters_wrong(self):
        with self.assertRaisesRegex(ValueError, r"^Preset must be one of 'half', 'zero', not "
                                                r"'third'$"):
            dda_iterations(1, 1, preset="third")
        with self.assertRaisesRegex(ValueError, r"^Capacity must be one of 'segment', "
                                                r"'register', not 'fixed'$"):
            dda_capacity(1, 1, width=8, capacity="fixed")
        with self.assertRaisesRegex(ValueError, r"^Preset must be one of 'half', 'zero', not "
                                                r"None$"):
            DdaCoreModel(preset=None)
        with self.assertRaisesRegex(InputError,
                r"^\|Y\| = 256 is too wide for the 8-bit registers \(at most 255\)$"):
            dda_iterations(3, -256, width=8)


class CycleModelTestCase(unittest.TestCase):
    """The cycle models' steps are the step models', their clocks those the text implies."""

    def line_record(self, variant, frames, width=8, **params):
        return run_model(registry.make_model("line", variant, width=width, **params),
                         Job(frames=frames))

    def test_lines_step_for_step(self):
        frames = [{"x": x, "y": y} for x in range(-20, 21) for y in range(-20, 21)]
        random.Random(1).shuffle(frames)
        for variant, width, params in (("separate", 8, {}), ("dda", 8, {}),
                                       ("dda-zero", 8, {}), ("dda", 6, {"capacity": "register"}),
                                       ("serial", 8, {})):
            if params or variant == "serial":       # 64 clocks a segment, 10 clocks a step
                frames = frames[::2]
            record = self.line_record(variant, frames, width=width, **params)
            expected = [s for f in frames
                        for s in registry.steps("line", f, variant, width=width, **params)]
            self.assertEqual(record_steps(record), expected, (variant, params))

    def test_arcs_step_for_step(self):
        rng = random.Random(2)
        frames = [{"x0": r, "y0": 0, "x1": r, "y1": 0, "cw": r % 2} for r in range(1, 30)]
        for _ in range(40):
            x0, y0 = rng.randint(-40, 40), rng.randint(1, 40)
            cw = rng.randrange(2)
            x1, y1 = points_ahead(x0, y0, rng.randint(1, 250), cw=cw)[-1]
            frames.append({"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw})
        for variant in ("separate", "serial"):
            record = run_model(registry.make_model("arc", variant, width=10), Job(frames=frames))
            expected = [s for f in frames for s in registry.steps("arc", f, variant, width=10)]
            self.assertEqual(record_steps(record), expected, variant)

    def test_clocks(self):
        # With the permission in every clock: separate steps one a clock; the DDA N clocks a
        # segment, idle iterations included, whichever direction; the serial node W = width + 2
        # clocks a step. Each within the registry's bound.
        for variant, per_step in (("separate", 1), ("serial", 10)):
            moves = record_moves(self.line_record(variant, [{"x": 9, "y": -4}]))
            self.assertEqual([c for c, _, _ in moves],
                             list(range(moves[0][0], moves[0][0] + per_step * 13, per_step)))
        for x, y in ((100, 0), (71, 71), (0, -100), (-87, 50)):
            record = self.line_record("dda", [{"x": x, "y": y}])
            busy = [e["cycle"] for e in record if not e["rst"] and e["busy"]]
            # the clock it is taken, the clock in the engine's stage register, then N
            self.assertEqual(len(busy), 128 + 2, (x, y))
        for variant in ("separate", "dda", "dda-zero", "serial"):
            for frame in ({"x": 9, "y": -4}, {"x": 0, "y": 200}, {"x": 255, "y": 255}):
                record = self.line_record(variant, [frame])
                bound = registry.variant("line", variant).clocks(frame, 8)
                self.assertLessEqual(sum(e["busy"] for e in record), bound + 2, variant)
        for variant in ("separate", "serial"):
            frame = {"x0": 11, "y0": -3, "x1": 11, "y1": -3, "cw": 0}
            record = run_model(registry.make_model("arc", variant, width=10), Job(frames=[frame]))
            moves = record_moves(record)
            bound = registry.variant("arc", variant).clocks(frame, 10)
            self.assertLessEqual(moves[-1][0] - moves[0][0], bound, variant)

    def test_planner_refusals_hold(self):
        # The separate-step arc is refused exactly where the patent's is.
        for frame in ({"x0": 5, "y0": 0, "x1": 2, "y1": 4}, {"x0": 0, "y0": 0, "x1": 1, "y1": 0},
                      {"x0": 1 << 10, "y0": 0, "x1": 0, "y1": 1 << 10}):
            with self.assertRaises(InputError):
                check_arc(frame["x0"], frame["y0"], frame["x1"], frame["y1"], 10)
            with self.assertRaises(InputError):
                separate_arc_steps(frame["x0"], frame["y0"], frame["x1"], frame["y1"], width=10)
        self.assertEqual(len(plan_arc(3, 4, 3, 4, 0, 10)["runs"]), 5)


if __name__ == "__main__":
    unittest.main()
