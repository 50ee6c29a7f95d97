"""The equidistant models: profile, exact geometry, preparation, step level, and the bounds."""

import math
import unittest
from fractions import Fraction
from pathlib import Path

from kontur.gcode import read
from kontur.sim.models.circular import FaithfulArcCoreModel, FastArcCoreModel
from kontur.sim.models.equidistant import (DETECTIONS, KIND, PATH_BOUND, TREATMENTS,
                                    EquidistantEngineModel, Formats, InputError,
                                    ProfileError, check_trace, elements, frame_outcomes,
                                    offset_path, prepare, profile_from_moves,
                                    program_frames, trace)
from kontur.sim.stimulus import Job, record_outcomes, run_model

PROGRAMS = Path(__file__).resolve().parent / "programs"
NAMES = sorted(path.stem for path in PROGRAMS.glob("*.ngc"))


def load(name, side=None):
    """A test program's profile; ``side`` swaps G41 and G42 when it is the other one."""
    text = (PROGRAMS / f"{name}.ngc").read_text()
    if side == "other":
        text = text.replace("G41", "@").replace("G42", "G41").replace("@", "G42")
    return profile_from_moves(read(text).moves)


def profile(text):
    return profile_from_moves(read(text).moves)


class ProfileTestCase(unittest.TestCase):
    def test_contour_and_side(self):
        square = load("square")
        self.assertEqual((square.side, square.closed, len(square.segments)), ("left", True, 4))
        self.assertEqual([s.line for s in square.segments], [4, 5, 6, 7])
        self.assertEqual(load("square", "other").side, "right")
        self.assertFalse(load("zigzag").closed)

    def test_refusals(self):
        cases = [
            ("G1 X10\n", r"^no compensated moves \(G41 or G42 with G1, G2 or G3\) in the "
                         r"program$"),
            ("G41 G1 X10\nG40 G1 X0\nG42 G1 Y5\n", r"^line 3: a second compensated contour "
                                                    r"\(the first is lines 1-1\): trace one at "
                                                    r"a time$"),
            ("G41 G1 X10\nG0 X0\n", r"^line 2: a rapid move \(G0\) inside the compensated "
                                    r"contour$"),
            ("G41 G1 X10\nG42 G1 Y5\n", r"^line 2: G42 changes the side inside the contour$"),
            ("G41 G1 X10.5\n", r"^line 1: X = 10\.5 is not a lattice point \(the program is "
                               r"in lattice units\)$"),
            ("G41 G1 X0 Y0\n", r"^line 1: a segment of length zero \(at \(0, 0\)\)$"),
            ("G41 G3 X0 Y0 I0 J0\n", r"^line 1: an arc of radius zero \(I = J = 0\)$"),
            ("G41 G3 X5 Y1 I3 J0\n", r"^line 1: the arc's end point \(5, 1\) is not on its "
                                     r"circle \(centre \(3, 0\), R² = 9, but 5 at the end "
                                     r"point\)$"),
        ]
        for text, message in cases:
            with self.subTest(text=text), self.assertRaisesRegex(ProfileError, message):
                profile(text)


class GeometryTestCase(unittest.TestCase):
    """The exact equidistant against geometry worked out independently."""

    def corners(self, pieces):
        return [tuple(piece.start) for piece in pieces]

    def test_square_inside_and_outside(self):
        for r in (0, 1, 7):
            inside = offset_path(load("square"), r)
            self.assertEqual(self.corners(inside), [(r, r), (40 - r, r), (40 - r, 40 - r),
                                                    (r, 40 - r)])
            outside = offset_path(load("square", "other"), r)
            self.assertEqual(self.corners(outside), [(-r, -r), (40 + r, -r), (40 + r, 40 + r),
                                                     (-r, 40 + r)])
        rounded = offset_path(load("square", "other"), 3, treatment="arc")
        arcs = [p for p in rounded if p.kind == "arc"]
        self.assertEqual([(p.centre, p.radius(3)) for p in arcs],
                         [((40, 0), 3), ((40, 40), 3), ((0, 40), 3), ((0, 0), 3)])
        self.assertEqual([(p.start, p.end) for p in arcs[:1]], [((40, -3), (43, 0))])

    def test_triangle_shrinks_about_its_incentre(self):
        a, b, c = (0, 0), (60, 0), (25, 10)
        la, lb, lc = math.dist(b, c), math.dist(a, c), math.dist(a, b)
        perimeter = la + lb + lc
        incentre = [(la * a[i] + lb * b[i] + lc * c[i]) / perimeter for i in range(2)]
        area = abs((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])) / 2
        inradius = 2 * area / perimeter
        for r in (1, 2, 3):
            pieces = offset_path(load("triangle"), r)
            for vertex, piece in zip((a, b, c), pieces):
                expected = [incentre[i] + (vertex[i] - incentre[i]) * (inradius - r) / inradius
                            for i in range(2)]
                self.assertAlmostEqual(float(piece.start[0]), expected[0], places=9)
                self.assertAlmostEqual(float(piece.start[1]), expected[1], places=9)

    def test_miter_limit(self):
        """``miter``: a convex corner is extended where the intersection of the equidistants
        is at most 2 r from the vertex (a turn of at most 120°), else rounded. A triangle run
        clockwise with G41 (outside): its turns at (0, 0) 90°, at (0, 30) 180° - atan(100/30)
        = 106.7°, both extended to r/cos(turn/2) from the vertex; at (100, 0) 163.3°, rounded
        about the vertex."""
        shape = profile("G41 G1 X0 Y30\nG1 X100 Y0\nG1 X0 Y0\n")
        pieces = offset_path(shape, 4, treatment="miter")
        arcs = {p.centre for p in pieces if p.what == "corner arc"}
        self.assertEqual(arcs, {(100, 0)})
        lines = [p for p in pieces if p.kind == "line"]
        for vertex, turn in (((0, 0), math.pi / 2), ((0, 30), math.pi - math.atan(100 / 30))):
            reach = min(math.dist(vertex, [float(c) for c in p.end]) for p in lines)
            self.assertAlmostEqual(reach, 4 / math.cos(turn / 2), places=9)
        self.assertEqual({p.what for p in offset_path(shape, 4, treatment="extend")},
                         {"line"})

    def test_tangent_up_to_the_lattice(self):
        """A line meeting an arc at a turn of 1/500 rad (a tangent joint rounded to the
        lattice), the cutter inside the arc (a concave joint). With the radius known and the
        gap r·sin(turn) at most a step, the joint is smooth: the arc is entered on its normal
        at the vertex; with a larger gap, or without a radius (the program for any radius),
        it is a concave corner at the intersection of the equidistants."""
        # The arc round (0, 5000) from (10, 0), ccw, a quarter turn: its tangent there
        # (5000, 10), the line's (1, 0).
        shape = profile("G0 X-2000\nG41 G1 X10 Y0\nG3 X5000 Y5010 I-10 J5000\n")
        for r in (1, 200, 500):
            pieces = offset_path(shape, r)
            self.assertEqual(pieces[1].entry, ((10, 0), (-10, 5000), 0))
            arc = next(e for e in elements(shape, radius=r) if e.kind == "arc")
            self.assertEqual(arc.entry, ((10, 0), (-10, 5000), 0))
        self.assertIsNone(offset_path(shape, 1000)[1].entry)
        self.assertIsNone(next(e for e in elements(shape) if e.kind == "arc").entry)

    def test_circle(self):
        for side, rho in ((None, 27), ("other", 33)):
            pieces = offset_path(load("circle", side), 3)
            self.assertEqual([p.kind for p in pieces], ["arc"] * 4)
            self.assertEqual({p.radius(3) for p in pieces}, {rho})
            self.assertEqual(pieces[0].start, (rho, 0))
            self.assertEqual(pieces[-1].end, (rho, 0))

    def test_impossible_geometry(self):
        cases = [
            ("G41 G1 X10\nG1 X0\n", r"^line 2: the path reverses at \(10, 0\): the segments of "
                                    r"lines 1 and 2 are parallel and their equidistants do not "
                                    r"meet$", 1),
            ((PROGRAMS / "triangle.ngc").read_text(),
             r"^line 4: the cutter \(radius 5\) is too large: the equidistant of this segment "
             r"would run backwards between its corners$", 5),
            ((PROGRAMS / "pie.ngc").read_text(),
             r"^line 5: the cutter \(radius 30\) is too large for the concave corner at "
             r"\(50, 0\) between lines 4 and 5: their equidistants do not meet$", 30),
            ("G0 X5\nG41 G3 X5 Y0 I-5 J0\n", r"^line 2: the cutter \(radius 5\) is too large "
                                             r"for the arc of radius 5 on its inside$", 5),
            ((PROGRAMS / "bite.ngc").read_text(),
             r"^line 6: the cutter \(radius 8\) is too large: the equidistant of this segment "
             r"would run backwards between its corners$", 8),
        ]
        for text, message, r in cases:
            with self.subTest(message=message), self.assertRaisesRegex(ProfileError, message):
                prepare(profile(text), r)

    def test_parameters_wrong(self):
        square = load("square")
        with self.assertRaisesRegex(TypeError, r"^Cutter radius must be a non-negative integer "
                                               r"or Fraction, "
                                               r"not -1$"):
            offset_path(square, -1)
        with self.assertRaisesRegex(TypeError, r"^Cutter radius must be a non-negative integer "
                                               r"or Fraction, "
                                               r"not 1\.5$"):
            prepare(square, 1.5)
        with self.assertRaisesRegex(ValueError, r"^Corner treatment must be one of 'extend', "
                                                r"'arc', 'miter', not 'round'$"):
            elements(square, treatment="round")
        with self.assertRaisesRegex(ValueError, r"^Corner treatment must be one of 'extend', "
                                                r"'arc', 'miter', not 'round'$"):
            offset_path(square, 1, treatment="round")
        with self.assertRaisesRegex(ValueError, r"^Corner detection must be one of 'normal', "
                                                r"'seed', not 'late'$"):
            elements(square, detection="late")
        with self.assertRaisesRegex(TypeError, r"^Coordinate width must be an integer of at "
                                               r"least 4, not 3$"):
            Formats(3)
        with self.assertRaisesRegex(TypeError, r"^Fractional bits must be an integer of at "
                                               r"least 2, not 1$"):
            Formats(8, 1)

    def test_numbers_beyond_the_registers(self):
        cases = [
            ("G41 G1 X40000\n", 0, r"^line 1: the end \(40000, 0\) is beyond the 15-bit "
                                   r"registers \(at most 32767\)$"),
            ("G41 G1 X32766\n", 1, r"^line 1: the cutter's path would leave the 15-bit "
                                   r"registers \(at most 32767\) here$"),
            ("G41 G1 X10\n", 32768, r"^the cutter radius 32768 is too wide for the 15-bit "
                                    r"registers \(at most 32767\)$"),
            ("G0 X30000 Y1000\nG42 G3 X30000 Y1000 I-1000 J0\n", 2800,
             r"^line 2: the cutter's path would leave the 15-bit registers \(at most 32767\) "
             r"here$"),
        ]
        for text, r, message in cases:
            with self.subTest(message=message), self.assertRaisesRegex(ProfileError, message):
                prepare(profile(text), r, formats=Formats(15))


class BoundsTestCase(unittest.TestCase):
    """Every program, both sides, both corner treatments, several radii: the stated bounds."""

    RADII = (0, 1, 2, 5)

    def cases(self):
        for name in NAMES:
            for side in (None, "other"):
                shape = load(name, side)
                for treatment in TREATMENTS:
                    for r in self.RADII:
                        try:
                            yield name, shape, treatment, r, prepare(
                                shape, r, treatment=treatment, verify=False)
                        except ProfileError:
                            pass

    def test_bounds(self):
        count = 0
        for name, shape, treatment, r, prepared in self.cases():
            label = (name, shape.side, treatment, r)
            report = check_trace(prepared)
            self.assertLessEqual(report.path, PATH_BOUND, label)
            self.assertGreaterEqual(report.near, r - PATH_BOUND, label)
            if treatment == "arc":         # the equidistant is at r from the profile throughout
                self.assertLessEqual(report.far, r + PATH_BOUND, label)
            for line, distance in report.corners:
                self.assertLessEqual(distance, 1, (label, line))
            self.assertEqual(report.closed, shape.closed, label)
            if shape.closed:            # the contour closes on its start: no return move
                self.assertEqual(frame_outcomes(prepared.frames, prepared.formats)[-1][1], [],
                                 label)
            count += 1
        self.assertGreater(count, 120)

    def test_one_program_for_every_radius(self):
        for name in NAMES:
            shape = load(name)
            frames = {r: prepare(shape, r).frames for r in (0, 1, 2)}
            self.assertEqual(frames[0][2:], frames[2][2:], name)
            program = program_frames(shape)
            self.assertEqual(list(frames[1][2:2 + len(program)]), program, name)
            self.assertEqual(frames[1][2 + len(program):], ({"kind": KIND["close"]},)
                             if shape.closed else (), name)
            self.assertEqual([f["kind"] for f in frames[1][:2]], [KIND["radius"],
                                                                  KIND["start"]])
            self.assertEqual(frames[1][0]["x"], 1)

    def test_radius_between_steps(self):
        """A radius of a fraction of a step (a radius in millimetres on a lattice of steps):
        the radius frame dials its whole steps and the elements' frames carry the rest, so
        the square's path keeps to its equidistant at the whole radius (inside the 40 x 40
        square at r: every visited point r from the nearest side, up to the path's bound),
        not at the whole steps."""
        square = load("square")
        for r in (Fraction(5, 2), Fraction(7, 4), Fraction(3, 10)):
            prepared = prepare(square, r)
            self.assertEqual(prepared.frames[0], {"kind": KIND["radius"], "x": math.floor(r)})
            x, y = prepared.start
            worst = 0
            for dx, dy in trace(prepared):
                x, y = x + dx, y + dy
                worst = max(worst, abs(min(x, y, 40 - x, 40 - y) - r))
            self.assertLessEqual(worst, PATH_BOUND, r)
            self.assertLessEqual(check_trace(prepared).path, PATH_BOUND, r)
        # Along the sides (away from the corners) the lattice line nearest the equidistant:
        # 1.75 and 2.75 from the side are 2 and 3 (the whole steps alone would be 1 and 2).
        for r, nearest in ((Fraction(7, 4), 2), (Fraction(11, 4), 3)):
            prepared = prepare(square, r)
            x, y = prepared.start
            sides = set()
            for dx, dy in trace(prepared):
                x, y = x + dx, y + dy
                if 6 <= x <= 34 or 6 <= y <= 34:
                    sides.add(min(x, y, 40 - x, 40 - y))
            self.assertEqual(sides, {nearest}, r)

    def test_closed_profiles_return_to_their_start(self):
        for name in NAMES:
            shape = load(name)
            if not shape.closed:
                continue
            for r in self.RADII:
                try:
                    steps = trace(prepare(shape, r))
                except ProfileError:
                    continue
                self.assertEqual((sum(dx for dx, _ in steps), sum(dy for _, dy in steps)),
                                 (0, 0), (name, r))

    def test_seed_rule_at_a_shallow_corner(self):
        # Two lines meeting at 2.6 degrees: the seed's comparison with the next equidistant
        # ends the first far from the corner; the normal through the intersection does not.
        shallow = profile("G41 G1 X89 Y14\nG1 X178 Y24\n")
        ends = {}
        for detection in DETECTIONS:
            prepared = prepare(shallow, 3, detection=detection, verify=False)
            ends[detection] = max(d for _, d in check_trace(prepared).corners)
        self.assertLessEqual(ends["normal"], 1)
        self.assertGreater(ends["seed"], 4)


class FormatsTestCase(unittest.TestCase):
    def test_fraction_bits_and_accuracy(self):
        # A long line: k is rounded to the fraction; the deviation from the exact line grows
        # along it by the rounding of k times the distance.
        line = profile("G41 G1 X30001 Y10000\n")
        deviation = {}
        for fraction in (8, 12, 19):
            prepared = prepare(line, 0, formats=Formats(15, fraction), verify=False)
            deviation[fraction] = check_trace(prepared).path
        self.assertLessEqual(deviation[19], Fraction(1, 2) + Fraction(1, 16))
        self.assertGreater(deviation[12], 1)
        self.assertGreater(deviation[8], deviation[12])

    def test_widths(self):
        f = Formats(16)
        self.assertEqual((f.fraction, f.one, f.coefficient, f.intercept, f.square, f.value,
                          f.core), (20, 1 << 20, 22, 39, 35, 40, 18))


class FramesTestCase(unittest.TestCase):
    def test_refused_and_waiting_frames(self):
        square = prepare(load("square"), 2, formats=Formats(8))
        element = square.frames[2]
        outcomes = frame_outcomes([element, {"kind": 7}, {"kind": KIND["radius"], "x": -1},
                                   *square.frames], Formats(8))
        self.assertEqual([o for o, _ in outcomes[:3]], [1, 1, 1])
        self.assertEqual([o for o, _ in outcomes[3:]], [0] * len(square.frames))
        with self.assertRaisesRegex(InputError, r"^a radius, start or return frame inside a "
                                                r"contour \(before its terminal\): the engine "
                                                r"would wait for ever$"):
            frame_outcomes([square.frames[1], element, square.frames[0]], Formats(8))
        with self.assertRaisesRegex(InputError, r"^the contour has no terminal frame: the "
                                                r"engine would wait for ever$"):
            frame_outcomes([square.frames[1], element], Formats(8))


class CycleModelTestCase(unittest.TestCase):
    """The cycle level makes the step level's steps, frame by frame, on both arc cores."""

    def test_cycle_level_makes_the_step_level(self):
        cores = {"fast": FastArcCoreModel, "faithful": FaithfulArcCoreModel}
        for name in ("pie", "lens", "polygon", "zigzag", "rounded"):
            prepared = prepare(load(name), 2, treatment="arc", formats=Formats(10))
            want = [(o, [sum(s[0] for s in p), sum(s[1] for s in p)])
                    for o, p in frame_outcomes(prepared.frames, prepared.formats)]
            for core, make in cores.items():
                model = EquidistantEngineModel(make(width=12))
                record = run_model(model, Job(frames=list(prepared.frames), tick=[1, 1, 0],
                                              max_cycles=100_000))
                got = [(outcome, position) for _, _, outcome, position
                       in record_outcomes(record)]
                self.assertEqual(got, want, (name, core))


if __name__ == "__main__":
    unittest.main()
