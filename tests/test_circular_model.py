"""The SU 1665343 golden model against geometry, against itself at cycle level, and bad input."""

import math
import random
import unittest
from unittest import mock

from kontur.hdl.circular_timing import FaithfulTiming
from kontur import registry
from kontur.sim.models.arc import arc_steps, check_arc, points_ahead, round_sqrt
from kontur.sim.geometry import radial_error, walk
from kontur.sim.models import circular
from kontur.sim.models.circular import (CircularInterpolatorFastModel, CircularInterpolatorModel,
                                 core_inputs, f4_initial, floor_f, native_path, native_steps)
from kontur.sim.models.codes import mask
from kontur.sim.models.errors import InputError
from kontur.sim.stimulus import Job, record_steps, run_model


def core_moves(model, x, y, r2):
    """Run a core model from native (x, y) until it stops; return its moves and clock count."""
    in29, in30, in31, in34 = core_inputs(x, y, floor_f(f4_initial(x, y, r2)))
    moves = []
    for clock in range(1_000_000):
        outputs, _, _ = model.cycle(in29=in29, in30=in30, in31=in31, in34=in34,
                                    in33=int(clock == 0))
        if outputs["step"]:
            moves.append({1: "X", 2: "Y", 3: "D"}[outputs["step"]])
        if clock and outputs["done"]:
            return "".join(moves), clock + 1
    raise AssertionError("the core did not stop")


class QuadrantGeometryTestCase(unittest.TestCase):
    def test_quadrant_within_half_step_r_1_to_2000(self):
        worst = (0.0, None)
        for r in range(1, 2001):
            path = native_path(r, 0, r * r)
            self.assertEqual(path[-1], (0, r))
            self.assertEqual(len(path) - 1, sum(1 for _ in native_steps(r, 0, r * r)))
            error = radial_error(path, r * r)
            self.assertLess(error, 0.5, r)
            if error > worst[0]:
                worst = (error, r)
        # DECODING.md, section 5: max 0.499806 at R = 1936
        self.assertEqual(worst[1], 1936)
        self.assertAlmostEqual(worst[0], 0.499806, places=6)

    def test_step_counts_and_switch_variants(self):
        self.assertEqual(len(native_steps(12, 0, 144)), 17)
        self.assertEqual(len(native_steps(2000, 0, 2000 ** 2)), 2828)
        at_diagonal, reached_by_y = 0, []
        for r in range(1, 2001):
            path = native_path(r, 0, r * r)
            moves = "".join(m for m, _ in native_steps(r, 0, r * r))
            switch = next(i for i, (x, y) in enumerate(path) if x - y <= 0)
            if path[switch][0] == path[switch][1]:
                at_diagonal += 1
                if moves[switch - 1] == "Y":
                    reached_by_y.append(r)
        self.assertEqual(at_diagonal, 1000)               # and X - Y = -1 for the other 1000
        self.assertEqual(reached_by_y, [4, 11, 134, 373])

    def test_table_1_moves_and_f(self):
        # SU 1665343, Table 1 (R = 12), transcribed: moves and F after each.
        moves = "YYYDYDYDDDXDXDXXX"
        f = [7.75, 2.75, -4.25, 8.75, -2.25, 4.75, -10.25, -9.25, 4.75, -2.25, 8.75, -4.25,
             2.75, -16.25, -13.25, -12.25, -13.25]
        got = native_steps(12, 0, 144)
        self.assertEqual("".join(m for m, _ in got), moves)
        self.assertEqual([f4 / 4 for _, f4 in got], f)     # the correction folded into step 9
        self.assertEqual(f4_initial(12, 0, 144) / 4, 10.75)

    def test_non_integer_radii(self):
        for r2 in range(1, 20001, 7):
            rn = round_sqrt(r2)
            path = native_path(rn, 0, r2)
            self.assertEqual(path[-1], (0, rn))
            self.assertLess(radial_error(path, r2), 0.5, r2)

    def test_lattice_starts_lie_on_the_axis_path(self):
        for r2 in range(1, 4001):
            rn = round_sqrt(r2)
            axis_path = native_path(rn, 0, r2)
            for x in range(1, rn + 1):
                y2 = r2 - x * x
                y = math.isqrt(max(y2, 0))
                if y2 >= 0 and y * y == y2:
                    self.assertIn((x, y), axis_path)
                    i = axis_path.index((x, y))
                    self.assertEqual(native_path(x, y, r2), axis_path[i:])


class EndPointCriterionTestCase(unittest.TestCase):
    """On the path <=> -M < r2 - (x² + y²) <= M, M the larger coordinate."""

    def criterion(self, x, y, r2):
        big = max(x, y)
        return -big < r2 - (x * x + y * y) <= big

    def test_every_lattice_point_small_radii(self):
        for r2 in range(1, 3001):
            rn = round_sqrt(r2)
            on_path = set(native_path(rn, 0, r2))
            for x in range(1, rn + 2):
                for y in range(0, rn + 2):
                    self.assertEqual(self.criterion(x, y, r2), (x, y) in on_path, (r2, x, y))

    def test_band_points_large_radii(self):
        rng = random.Random(1665343)
        for _ in range(60):
            r2 = rng.randrange(10 ** 6, 10 ** 8)
            rn = round_sqrt(r2)
            on_path = set(native_path(rn, 0, r2))
            for _ in range(300):                # points within 2 steps of the circle
                x = rng.randrange(1, rn + 1)
                y0 = math.isqrt(max(r2 - x * x, 0))
                for y in range(max(y0 - 2, 0), y0 + 3):
                    self.assertEqual(self.criterion(x, y, r2), (x, y) in on_path, (r2, x, y))


class ArcGeometryTestCase(unittest.TestCase):
    def test_full_circles_both_directions(self):
        for r in range(1, 301):
            for start in ((r, 0), (0, r), (-r, 0), (0, -r)):
                ccw = arc_steps(*start, *start)
                cw = arc_steps(*start, *start, cw=True)
                points = walk(start, ccw)
                self.assertEqual(points[-1], start)
                self.assertEqual(len(set(points)), len(points))
                self.assertEqual(cw, [(-dx, -dy) for dx, dy in reversed(ccw)])
                self.assertLess(radial_error(points, r * r), 0.5)

    def test_arcs_every_quadrant_and_direction(self):
        rng = random.Random(3)
        for _ in range(2000):
            x0, y0 = rng.randint(-70, 70), rng.randint(-70, 70)
            if (x0, y0) == (0, 0):
                continue
            cw = rng.random() < 0.5
            full = arc_steps(x0, y0, x0, y0, cw=cw)
            points = walk((x0, y0), full)
            self.assertEqual(points[-1], (x0, y0))
            self.assertLess(radial_error(points, x0 * x0 + y0 * y0), 0.5)
            for dx, dy in full:
                self.assertIn((dx, dy), [(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1)
                                         if (a, b) != (0, 0)])
            k = rng.randrange(len(full))
            self.assertEqual(arc_steps(x0, y0, *points[k], cw=cw),
                             full if points[k] == (x0, y0) else full[:k + 1])

    def test_direction_of_motion(self):
        # Counter-clockwise: the cross product of position and step is positive.
        for cw in (False, True):
            x, y = 17, 5
            for dx, dy in arc_steps(17, 5, 17, 5, cw=cw):
                cross = x * dy - y * dx
                self.assertTrue(cross < 0 if cw else cross > 0)
                x, y = x + dx, y + dy

    def test_points_ahead_of_large_radius(self):
        points = points_ahead(300, 16_000_000, 700)
        self.assertEqual(len(points), 700)
        steps = arc_steps(300, 16_000_000, *points[-1])
        self.assertEqual(walk((300, 16_000_000), steps), points)
        self.assertLess(points[-1][0], 0)                    # crossed into quadrant II


class BadInputTestCase(unittest.TestCase):
    def test_zero_radius(self):
        with self.assertRaisesRegex(InputError, r"^the start point is the centre: radius R = 0$"):
            check_arc(0, 0, 3, 4, 24)

    def test_end_off_circle(self):
        with self.assertRaisesRegex(InputError,
                r"^the end point \(2, 4\) is not on the circle through the start point "
                r"\(radius 4\): its \|Y\| = 4 is 0\.536 of a step from the circle's 3\.4641, "
                r"more than half a step$"):
            check_arc(4, 0, 2, 4, 24)
        self.assertEqual(check_arc(4, 0, 2, 3, 24), 16)
        with self.assertRaises(InputError):
            check_arc(5, 0, 0, 0, 24)

    def test_too_wide(self):
        with self.assertRaisesRegex(InputError,
                r"^\|Y1\| = 16777216 is too wide for the 24-bit registers \(at most 16777215\)$"):
            check_arc(1, 0, 0, 1 << 24, 24)
        with self.assertRaisesRegex(InputError,
                r"^the radius 1\.13137e\+07 rounds to 11313708, too wide for the 23-bit "
                r"registers \(at most 8388607\)$"):
            check_arc(8_000_000, 8_000_000, 8_000_000, 8_000_000, 23)

    def test_refused_in_engine_model(self):
        frames = [{"x0": 5, "y0": 0, "x1": 0, "y1": 5, "cw": 0},
                  {"x0": 0, "y0": 0, "x1": 0, "y1": 0, "cw": 0},
                  {"x0": 5, "y0": 0, "x1": 2, "y1": 4, "cw": 0},
                  {"x0": -3, "y0": 4, "x1": -3, "y1": 4, "cw": 1}]
        for variant in ("faithful", "fast"):
            record = run_model(registry.make_model("arc", variant), Job(frames=frames))
            self.assertEqual(sum(e["error"] for e in record), 2)
            self.assertEqual(sum(e["done"] for e in record), 2)
            self.assertEqual(record_steps(record),
                             arc_steps(5, 0, 0, 5) + arc_steps(-3, 4, -3, 4, cw=True))


class CoreCycleModelTestCase(unittest.TestCase):
    def test_cores_follow_the_step_model(self):
        for r2 in list(range(1, 700)) + [r * r for r in range(27, 160)]:
            rn = round_sqrt(r2)
            starts = [(rn, 0)] + [(x, math.isqrt(r2 - x * x)) for x in range(1, rn + 1)
                                  if x * x <= r2 and math.isqrt(r2 - x * x) ** 2 == r2 - x * x][:2]
            for x, y in starts:
                reference = "".join(m for m, _ in native_steps(x, y, r2))
                for model in (CircularInterpolatorModel(), CircularInterpolatorFastModel()):
                    moves, _ = core_moves(model, x, y, r2)
                    self.assertEqual(moves, reference, (type(model).__name__, r2, x, y))

    def test_clocks_per_quadrant(self):
        # Faithful: a step per generator period (4 clocks) plus one period for the
        # correction, starting at the first generator pulse after the start (clock 4), and
        # the stop in the clock after the last step. Fast: one step per clock.
        moves, clocks = core_moves(CircularInterpolatorModel(), 12, 0, 144)
        self.assertEqual(len(moves), 17)
        self.assertEqual(clocks, 4 * (17 + 1) + 2)
        moves, clocks = core_moves(CircularInterpolatorFastModel(), 12, 0, 144)
        self.assertEqual(clocks, 17 + 1)

    def test_engine_model_matches_arc_steps(self):
        rng = random.Random(8)
        for variant in ("faithful", "fast"):
            frames = []
            for _ in range(30):
                x0, y0 = rng.randint(-25, 25), rng.randint(-25, 25)
                if (x0, y0) == (0, 0):
                    continue
                cw = rng.randrange(2)
                ahead = points_ahead(x0, y0, rng.randint(1, 200), cw=cw)
                x1, y1 = ahead[-1]
                frames.append({"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw})
            record = run_model(registry.make_model("arc", variant), Job(frames=frames))
            expected = [s for f in frames
                        for s in arc_steps(f["x0"], f["y0"], f["x1"], f["y1"], cw=f["cw"])]
            self.assertEqual(record_steps(record), expected)


class TimingTestCase(unittest.TestCase):
    def test_defaults_are_structural_minimum(self):
        t = FaithfulTiming()
        self.assertEqual((t.period, t.delay12, t.delay13, t.delay14, t.taps19, t.taps26,
                          t.extender), (4, 3, 1, 1, (1, 3, 3), (1, 1, 1, 2), 3))
        with self.assertRaisesRegex(ValueError, r"^The generator period must exceed"):
            FaithfulTiming(period=3)
        with self.assertRaisesRegex(ValueError, r"^Delay 12 must be at least delay 26 tap 3 \+ 2"):
            FaithfulTiming(delay12=2)

    def test_messages(self):
        with self.assertRaisesRegex(TypeError,
                r"^Delay 19 taps must be 3 positive integers, not \(1, 2\)$"):
            FaithfulTiming(taps19=(1, 2))
        with self.assertRaisesRegex(TypeError, r"^Generator period must be a positive integer, "
                                               r"not 0$"):
            FaithfulTiming(period=0)
        with self.assertRaisesRegex(ValueError, r"^The extender must hold AND 10 and 11 off"):
            FaithfulTiming(extender=7)

    def test_longer_timings_keep_the_trajectory(self):
        for timing in (FaithfulTiming(period=6, delay12=4, delay13=2, delay14=2,
                                      taps19=(2, 4, 5), taps26=(1, 2, 2, 3), extender=6),
                       FaithfulTiming(period=9, delay12=8, delay13=8, delay14=8,
                                      taps19=(1, 8, 9), taps26=(2, 3, 5, 7), extender=10)):
            for r in (1, 4, 10, 12, 23, 64, 97):
                reference = "".join(m for m, _ in native_steps(r, 0, r * r))
                moves, clocks = core_moves(CircularInterpolatorModel(timing=timing), r, 0, r * r)
                self.assertEqual(moves, reference)

    def test_random_valid_timings_keep_the_trajectory(self):
        rng = random.Random(1989)
        radii = (1, 2, 4, 10, 11, 12, 23, 64)
        reference = {r: "".join(m for m, _ in native_steps(r, 0, r * r)) for r in radii}
        tried = 0
        while tried < 40:
            try:
                timing = FaithfulTiming(
                    period=rng.randint(4, 12), delay12=rng.randint(1, 11),
                    delay13=rng.randint(1, 11), delay14=rng.randint(1, 11),
                    taps19=tuple(sorted(rng.randint(1, 10) for _ in range(3))),
                    taps26=tuple(sorted(rng.randint(1, 10) for _ in range(4))),
                    extender=rng.randint(1, 22))
            except ValueError:
                continue
            tried += 1
            for r in radii:
                moves, _ = core_moves(CircularInterpolatorModel(timing=timing), r, 0, r * r)
                self.assertEqual(moves, reference[r], (timing, r))

    def test_constraints_are_necessary(self):
        # Each of these breaks exactly one ordering, and the trajectory breaks with it.
        cases = [
            # delay 14 after tap 4: the Y step landing on X = Y (R = 4) reads X - 1, not Y
            (dict(period=9, delay12=8, delay13=8, delay14=8, taps19=(1, 8, 9),
                  taps26=(2, 3, 5, 6), extender=10), 4, r"^Delay 14 must be at most"),
            # tap 3 of delay 19 too late: R = 1 ends in the correction, one step too many
            (dict(period=6, delay12=5, delay13=1, delay14=5, taps19=(3, 7, 10),
                  taps26=(1, 2, 2, 7), extender=10), 1, r"^Delay 19 tap 3 must end"),
        ]
        for parameters, r, message in cases:
            with self.assertRaisesRegex(ValueError, message):
                FaithfulTiming(**parameters)
            unchecked = FaithfulTiming(**parameters, check=False)
            moves, _ = core_moves(CircularInterpolatorModel(timing=unchecked), r, 0, r * r)
            self.assertNotEqual(moves, "".join(m for m, _ in native_steps(r, 0, r * r)))

    def test_plain_ones_complement_adder_breaks_r_5(self):
        # Adder 1 forms its ones'-complement sum so that zero is +0. A plain adder with an
        # end-around carry turns 3 + (-3) into -0, reads it as negative and at R = 5 steps
        # diagonally from (5, 1) to (4, 2), 0.53 of a step off the circle.
        def plain(a, b, width):
            total = (a & mask(width)) + (b & mask(width))
            return (total & mask(width)) + (total >> width)

        with mock.patch.object(circular, "ones_add", plain):
            moves, _ = core_moves(CircularInterpolatorModel(), 5, 0, 25)
        self.assertEqual("".join(m for m, _ in native_steps(5, 0, 25)), "YYDDDXX")
        self.assertEqual(moves[:2], "YD")

    def test_literal_reading_breaks_the_bound(self):
        # Delay 12 read before the X = Y switch-over has set trigger 16 (the patent's text
        # taken literally) adds -2 instead of -1 on the diagonal that lands on X = Y. The
        # path then changes, and at R = 10 leaves the half-step band (DECODING.md, item 16).
        literal = FaithfulTiming(delay12=2, check=False)
        moves, _ = core_moves(CircularInterpolatorModel(timing=literal), 10, 0, 100)
        reference = "".join(m for m, _ in native_steps(10, 0, 100))
        self.assertNotEqual(moves, reference)
        x, y, points = 10, 0, []
        for move in moves:
            x, y = x - (move in "DX"), y + (move in "DY")
            points.append((x, y))
        self.assertIn((3, 9), points)
        self.assertGreater(radial_error(points, 100), 0.5)


if __name__ == "__main__":
    unittest.main()
