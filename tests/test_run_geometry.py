"""``kontur run``'s path and times against geometry computed from the G-code text itself.

The programs are generated (hypothesis): lines and rapids, arcs by ``I J`` and by ``R``, both
ways, tiny (sweeps and lines shorter than a step) and large, full circles and near ones, G20
and G21, G90 and G91. A small evaluator here reads the generated text (it shares nothing with
:mod:`kontur.gcode`) and gives each move's exact geometry in millimetres; the model's run
(:func:`~kontur.machining.prepare`, :func:`~kontur.machining.execute`) must then:

1. visit only points within 1.5 steps of the programmed path of the move they belong to (a
   line segment), 1.75 on an arc (a curve: its circle within its sweep, its nearer end
   outside; see :data:`ARC_BOUND`);
2. end every move exactly on its programmed end rounded to the step grid (halves away from
   zero);
3. plan each move no faster than its feed (the machine's maximum for G0 and above it, the
   centripetal limit sqrt(accel r) on an arc) and no slower than that less one rate of the
   feed generator, plus a ramp of feed / accel for each of its segments (two for an arc: the
   arc and the short line onto its end);
4. make as many steps on an arc as its programmed sweep asks: its steps' contour length is
   the programmed arc's length within the rounding, so a sliver is never a full turn.

Plus the regression cases of issue 23, each of which fails on c106e3b.
"""

import contextlib
import io
import math
import re
import tempfile
import unittest
from fractions import Fraction
from pathlib import Path

from hypothesis import given, settings, strategies as st

from kontur import registry
from kontur.cli import main
from kontur.machine import Machine
from kontur.machining import deviation, execute, prepare, summary, summary_text
from kontur.planner import ProgramError

MACHINE = Machine(clock_hz=registry.board("icebreaker").clock_hz)   # the default machine
SPM = 80
STEP = 1 / SPM
#: The feed generator's speed resolution: a rate of 1 (Q0.24 step lengths a clock), mm/s.
UNIT = MACHINE.clock_hz / (1 << 24) / SPM
#: The longest contour a step path takes per unit of straight length: a line at
#: atan(sqrt(2) - 1) = 22.5 degrees, whose steps are axial and diagonal in turn.
STAIR = math.sqrt(4 - 2 * math.sqrt(2))
#: The default board's arc core (registry.Variant): within ``accuracy`` steps of its circle
#: (half a step, or half a diagonal for a core of separate steps: the bit-serial node).
ARC = registry.variant("arc", registry.board("icebreaker").arc[0])
#: ... and its steps' contour per unit of arc: STAIR, or for separate steps (axial only) up
#: to sqrt(2), where the arc runs at 45 degrees.
ARC_STAIR = math.sqrt(2) if ARC.accuracy > 0.5 else STAIR
INCH = Fraction(254, 10)
#: How far (steps) an arc's steps may lie from its programmed circle. The engine traces a
#: circle about a lattice point through the lattice start: the planner picks the best of the
#: four lattice points around the programmed centre, and the best is up to 1.22 steps off the
#: programmed circle (|centre's shift| + |radius's change|; the worst of 200 000 random
#: circles, e.g. G0 X0.4041 Y-4.5664 / G2 I-0.5829 J0.011 at 80 steps/mm), the steps up to
#: half a step off that circle (the core's accuracy): 1.72 (1.93 for separate steps, half a
#: diagonal). Not the 1.5 of a line's (half a step, and its ends rounded by sqrt(2)/2).
ARC_BOUND = 1.25 + ARC.accuracy


# ---- an evaluator of the generated subset of G-code ----------------------------------------

def evaluate(text):
    """The moves of ``text`` (the subset generated below): dicts with ``line``, ``kind``
    (``"rapid"``, ``"line"``, ``"arc"``), ``start``, ``end`` (mm, exact), ``feed`` (mm/min)
    and for an arc ``centre``, ``cw``, ``full``, ``sweep`` (radians)."""
    scale, absolute, motion, feed = Fraction(1), True, None, None
    position = (Fraction(0), Fraction(0))
    moves = []
    for number, line in enumerate(text.splitlines(), start=1):
        words = {letter: Fraction(value)
                 for letter, value in re.findall(r"([A-Z])([-+]?[0-9.]+)", line)
                 if letter != "G"}
        for code in map(int, re.findall(r"G(\d+)", line)):
            if code in (20, 21):
                scale = INCH if code == 20 else Fraction(1)
            elif code in (90, 91):
                absolute = code == 90
            elif code in (0, 1, 2, 3):
                motion = code
        if "F" in words:
            feed = words["F"] * scale
        if not {"X", "Y", "I", "J", "R"} & set(words):
            continue
        x = words.get("X")
        y = words.get("Y")
        if absolute:
            end = (position[0] if x is None else x * scale, position[1] if y is None else y * scale)
        else:
            end = (position[0] + (x or 0) * scale, position[1] + (y or 0) * scale)
        move = {"line": number, "start": position, "end": end, "feed": feed}
        if motion in (0, 1):
            move["kind"] = "rapid" if motion == 0 else "line"
        else:
            cw = motion == 2
            start = tuple(map(float, position))
            if "R" in words:
                r = float(words["R"] * scale)
                dx, dy = float(end[0]) - start[0], float(end[1]) - start[1]
                d = math.hypot(dx, dy)
                h = math.sqrt(max(r * r - d * d / 4, 0))
                # Moving from start to end, a clockwise arc of at most a half turn (R > 0) has
                # its centre on the right of the chord; R < 0 or counter-clockwise: the left.
                side = (1 if cw else -1) * (1 if r > 0 else -1)
                centre = (start[0] + dx / 2 + side * h * dy / d,
                          start[1] + dy / 2 - side * h * dx / d)
            else:
                centre = (start[0] + float(words.get("I", 0) * scale),
                          start[1] + float(words.get("J", 0) * scale))
            full = end == position
            u = (start[0] - centre[0], start[1] - centre[1])
            v = (float(end[0]) - centre[0], float(end[1]) - centre[1])
            turn = math.atan2(u[0] * v[1] - u[1] * v[0], u[0] * v[0] + u[1] * v[1])
            turn = -turn if cw else turn
            sweep = 2 * math.pi if full else turn % (2 * math.pi)
            move.update(kind="arc", centre=centre, cw=cw, full=full, sweep=sweep,
                        radius=math.hypot(*u))
        moves.append(move)
        position = end
    return moves


def distance(p, move):
    """The distance (mm) of ``p`` from the programmed path of ``move``."""
    s = tuple(map(float, move["start"]))
    e = tuple(map(float, move["end"]))
    if move["kind"] != "arc":
        ax, ay = e[0] - s[0], e[1] - s[1]
        length2 = ax * ax + ay * ay
        t = 0.0 if not length2 else max(0.0, min(1.0, ((p[0] - s[0]) * ax + (p[1] - s[1]) * ay)
                                                 / length2))
        return math.hypot(p[0] - s[0] - t * ax, p[1] - s[1] - t * ay)
    c = move["centre"]
    u = (s[0] - c[0], s[1] - c[1])
    w = (p[0] - c[0], p[1] - c[1])
    turn = math.atan2(u[0] * w[1] - u[1] * w[0], u[0] * w[0] + u[1] * w[1])
    turn = (-turn if move["cw"] else turn) % (2 * math.pi)
    if move["full"] or turn <= move["sweep"]:
        return abs(math.hypot(*w) - move["radius"])
    return min(math.hypot(p[0] - s[0], p[1] - s[1]), math.hypot(p[0] - e[0], p[1] - e[1]))


def on_grid(value):
    """A length in mm as steps, rounded to the nearest (halves away from zero)."""
    steps = value * SPM
    half = Fraction(1, 2)
    return math.floor(steps + half) if steps >= 0 else -math.floor(-steps + half)


# ---- the generator -----------------------------------------------------------------------

def _number(value, inch):
    """``value`` (mm) as program text in the program's units: 4 decimals (mm), 5 (inches)."""
    return f"{value / 25.4:.5f}" if inch else f"{value:.4f}"


@st.composite
def programs(draw):
    """A program of a few moves of every kind, in G20 or G21, each move G90 or G91."""
    inch = draw(st.booleans())
    lines = ["G20" if inch else "G21"]
    feed = draw(st.sampled_from([10, 37.5, 240, 900, 3000, 5000]))
    lines.append(f"G90 F{_number(feed, inch)}")
    x = y = 0.0                              # where the text puts the tool (mm, as written)
    position = (Fraction(0), Fraction(0))    # exact, in the program's units
    unit = INCH if inch else Fraction(1)
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["G0", "G1", "tiny", "IJ", "R", "R-tiny", "full", "sliver"]))
        words = []
        if draw(st.booleans()):
            words.append(f"F{_number(draw(st.sampled_from([10, 120, 600, 2000, 4000])), inch)}")
        if kind in ("G0", "G1", "tiny"):
            if kind == "tiny":
                tx = x + draw(st.floats(-0.009, 0.009))
                ty = y + draw(st.floats(-0.009, 0.009))
            else:
                tx, ty = draw(st.floats(-30, 30)), draw(st.floats(-30, 30))
            code = "G0" if kind == "G0" else "G1"
        elif kind in ("R", "R-tiny"):
            if kind == "R-tiny":
                tx, ty = x + draw(st.floats(-0.009, 0.009)), y + draw(st.floats(-0.009, 0.009))
            else:
                tx, ty = draw(st.floats(-30, 30)), draw(st.floats(-30, 30))
            half = math.hypot(tx - x, ty - y) / 2
            radius = max(half * draw(st.floats(1.05, 4)), draw(st.floats(0.5, 20)))
            code = draw(st.sampled_from(["G2", "G3"]))
            sign = draw(st.sampled_from([1, -1]))
        else:
            radius = draw(st.floats(0.5, 20))
            angle = draw(st.floats(0, 2 * math.pi))
            cx, cy = x - radius * math.cos(angle), y - radius * math.sin(angle)
            if kind == "full":
                turn = 0.0
            elif kind == "sliver":               # a sliver of a turn, or a sliver short of one
                turn = draw(st.floats(-0.004, 0.004)) / radius
            else:
                turn = draw(st.floats(-2 * math.pi, 2 * math.pi))
            tx = cx + radius * math.cos(angle + turn)
            ty = cy + radius * math.sin(angle + turn)
            code = draw(st.sampled_from(["G2", "G3"]))
        relative = draw(st.booleans())
        ex = Fraction(_number(tx, inch)) if not relative else \
            Fraction(_number(tx - float(position[0] * unit), inch))
        ey = Fraction(_number(ty, inch)) if not relative else \
            Fraction(_number(ty - float(position[1] * unit), inch))
        words = [code, "G91" if relative else "G90", f"X{_decimal(ex)}", f"Y{_decimal(ey)}"] \
            + words
        end = (position[0] + ex, position[1] + ey) if relative else (ex, ey)
        if kind in ("R", "R-tiny"):
            if end == position:
                continue                         # an arc by R cannot end where it starts
            words.append(f"R{_number(sign * radius, inch)}")
        elif kind in ("IJ", "full", "sliver"):
            i, j = _number(cx - x, inch), _number(cy - y, inch)
            if Fraction(i) == 0 and Fraction(j) == 0:
                continue
            words += [f"I{i}", f"J{j}"]
        lines.append(" ".join(words))
        position = end
        x, y = float(end[0] * unit), float(end[1] * unit)
    if len(lines) == 2:
        lines.append("G1 X1 Y1")
    return "\n".join(lines) + "\n"


def _decimal(value):
    """An exact decimal Fraction as text."""
    text = f"{float(value):.6f}".rstrip("0").rstrip(".")
    assert Fraction(text) == value
    return text


def _speeds(move):
    """A move's feed (mm/s), and the highest and lowest cruise the plan may give it."""
    feed = MACHINE.max_feed if move["kind"] == "rapid" else \
        min(float(move["feed"]), MACHINE.max_feed)
    v = high = low = feed / 60
    if move["kind"] == "arc":
        # The centripetal limit sqrt(accel r), on the lattice's radius: the programmed one
        # within two steps (start and centre each rounded by up to sqrt(2)/2).
        high = min(v, math.sqrt(MACHINE.accel * (move["radius"] + 2 * STEP)))
        low = min(v, math.sqrt(MACHINE.accel * max(move["radius"] - 2 * STEP, STEP)))
    return v, high, low


class GeometryTestCase(unittest.TestCase):

    def check(self, text):
        try:
            job = prepare(text, machine=MACHINE)
        except ProgramError as error:
            # The generator keeps arcs' radii within the tolerance; what may still be refused:
            # a feed below the generator's lowest, which it does not generate.
            raise AssertionError(f"refused: {error}\n{text}") from None
        result = execute(job, "model")
        moves = evaluate(text)
        by_line = {}
        for segment in job.segments:
            by_line.setdefault(segment.line, []).append(segment)
        planned = {}
        for segment, item in zip(job.segments, job.items):
            planned[segment.line] = planned.get(segment.line, 0.0) + item.seconds
        slowest = min([math.sqrt(2 * MACHINE.accel / SPM)]
                      + [_speeds(move)[2] for move in moves]) - UNIT
        index = 0
        point = (on_grid(moves[0]["start"][0]), on_grid(moves[0]["start"][1]))
        for move in moves:
            count = sum(len(s.steps) for s in by_line.get(move["line"], []))
            steps = result.steps[index:index + count]
            index += count
            worst = 0.0
            contour = 0.0
            for dx, dy in steps:
                point = (point[0] + dx, point[1] + dy)
                worst = max(worst, distance((point[0] * STEP, point[1] * STEP), move))
                contour += math.sqrt(2) if dx and dy else 1.0
            where = f"line {move['line']} of\n{text}"
            # 1. the path
            self.assertLessEqual(worst, (ARC_BOUND if move["kind"] == "arc" else 1.5) * STEP,
                                 where)
            # 2. the end, exactly
            self.assertEqual(point, (on_grid(move["end"][0]), on_grid(move["end"][1])), where)
            # 3. the time
            v, high, low = _speeds(move)
            ramps = 2 if move["kind"] == "arc" else 1
            seconds = planned.get(move["line"], 0.0)
            # Each segment's last two steps (planner.MARGIN_STEPS) at its exit speed: at least
            # the slowest a move may end at, the stop's one-step speed or the slowest feed.
            margin = len(by_line.get(move["line"], [])) * 2 * math.sqrt(2) * STEP / slowest
            length = contour * STEP
            # A segment cruising at c takes length / c and at most c / accel more (ramps from and
            # to rest: (c - v0)^2 / 2ac + (c - v1)^2 / 2ac; a move too short to reach c,
            # 2 sqrt(length / accel), which is at most length / c + c / accel). The cruise is
            # at most the feed and at least it less one rate of the generator.
            self.assertGreaterEqual(seconds, length / high * (1 - 1e-9), where)
            self.assertLessEqual(seconds, length / (low - UNIT) + ramps * v / MACHINE.accel
                                 + margin + 1e-9, where)
            # 4. the steps of an arc: its length, within the rounding (the radius by two steps,
            # each end's angle by 4 / r: start, end and centre rounded, the end's path point a
            # step along the circle), the contour of a step path up to ARC_STAIR times longer.
            if move["kind"] == "arc":
                r = move["radius"] * SPM
                slack = 4 / r
                least = max(r - 2, 0) * max(move["sweep"] - 2 * slack, 0) - 2
                most = ARC_STAIR * ((r + 2) * (move["sweep"] + 2 * slack) + 4)
                self.assertGreaterEqual(contour, least, where)
                self.assertLessEqual(contour, most, where)
        self.assertEqual(index, len(result.steps))
        self.assertEqual(result.end, (on_grid(moves[-1]["end"][0]), on_grid(moves[-1]["end"][1])))

    @settings(max_examples=60, deadline=None, derandomize=True)
    @given(programs())
    def test_programs(self, text):
        self.check(text)


class RegressionTestCase(unittest.TestCase):
    """The cases of issue 23, each wrong on c106e3b."""

    def test_tiny_arc_by_centre_is_not_a_full_circle(self):
        # A sliver of a 10 mm circle, 4 microns long: its ends round to one step. On
        # c106e3b the arc went out as a full circle: 5324 steps.
        text = "G21 G90\nG0 X10 Y0\nG3 X10 Y0.004 I-10 J0 F600\n"
        job = prepare(text, machine=MACHINE)
        result = execute(job, "model")
        self.assertEqual(result.steps, [(1, 0)] * 800)             # the rapid, and nothing
        GeometryTestCase().check(text)
        # The same arc the other way round is 0.0004 rad short of a full turn: a full circle
        # (its steps' contour at least the circumference, 2 pi 800 steps, but for rounding).
        job = prepare(text.replace("G3", "G2"), machine=MACHINE)
        contour = sum(math.sqrt(2) if dx and dy else 1 for dx, dy in job.steps[800:])
        self.assertGreater(contour, 2 * math.pi * 800 - 4)
        GeometryTestCase().check(text.replace("G3", "G2"))

    def test_tiny_arc_by_radius_is_not_a_full_circle(self):
        text = "G21 G90\nG0 X10 Y0\nG3 X10.004 Y0 R5 F600\n"
        job = prepare(text, machine=MACHINE)
        self.assertEqual(execute(job, "model").steps, [(1, 0)] * 800)
        GeometryTestCase().check(text)

    def test_tiny_arc_in_a_compensated_contour_is_refused(self):
        # The equidistant engine traces a contour's arcs as given: a sliver whose ends round
        # to one step would be a full turn of the cutter. Refused, naming the line.
        text = ("G21 G90 F600\nG0 X0 Y0\nG41 G1 X20 Y0\nG1 X20 Y10\nG3 X20 Y10.004 I-5 J0\n"
                "G1 X0 Y10\nG1 X0 Y0\nG40 G0 X-5 Y-5\n")
        machine = Machine(clock_hz=registry.board("ulx3s").clock_hz, cutter_radius=1)
        with self.assertRaisesRegex(ProgramError, r"^line 5: the arc sweeps 0\.0458 degrees as "
                                                  r"programmed but 360\.0000 on the step lattice"):
            prepare(text, machine=machine, board="ulx3s")

    def test_deviation_from_the_programmed_arc(self):
        # The steps of a full circle measured against a sliver programmed in its place: far
        # from it (a diameter, 20 mm, on the far side), not the 0.006 mm of its circle.
        full = prepare("G21 G90\nG0 X10 Y0\nG3 X10 Y0 I-10 J0 F600\n", machine=MACHINE)
        sliver = prepare("G21 G90\nG0 X10 Y0\nG3 X10 Y0.004 I-10 J0 F600\n", machine=MACHINE)
        full.moves = sliver.moves
        self.assertGreater(deviation(full, full.steps), 19.9)

    def test_low_feed_takes_its_time(self):
        # 5 mm at 10 mm/min is 30 s: at most one rate of the feed generator slower, plus the
        # ramps (none to speak of at 10 mm/min). On c106e3b: 1.42 s.
        job = prepare("G21 G90\nG1 X5 F10\n", machine=MACHINE)
        self.assertGreaterEqual(job.seconds, 30)
        self.assertLessEqual(job.seconds, 5 / (10 / 60 - UNIT) + 1)
        result = execute(job, "model")
        self.assertAlmostEqual(result.times[-1], job.seconds, delta=0.01)
        # The summary says what is planned: F10 as a whole number of the generator's rates
        # (at 12 MHz, 18 of 0.536 mm/min).
        planned = math.floor(10 / (UNIT * 60)) * UNIT * 60
        self.assertIn(f"feeds 10 mm/min programmed, planned at {planned:.3f} mm/min",
                      summary_text(summary(job, result)))
        job = prepare("G21 G90\nG1 X5 F600\n", machine=MACHINE)      # within 0.1 %: as is
        self.assertIn("feeds 600 mm/min\n", summary_text(summary(job, execute(job, "model"))))

    def test_feed_below_the_generators_lowest_is_refused(self):
        lowest = UNIT * 60                                  # 0.536 mm/min at 12 MHz, 80 steps/mm
        prepare(f"G1 X1 F{lowest * 1.01:.6f}\n", machine=MACHINE)
        with self.assertRaisesRegex(ProgramError, r"^line 2: the feed 0\.25 mm/min is below the "
                                                  r"lowest the feed generator makes, "
                                                  + re.escape(f"{lowest:.4f}")):
            prepare("G1 X1 F100\nG1 X2 F0.25\n", machine=MACHINE)

    def test_feed_move_without_a_feed_is_refused(self):
        with tempfile.TemporaryDirectory() as folder:
            for text, line, code in (("G21 G90\nG0 X1\nG1 X5\n", 3, "G1"),
                                     ("G0 X1\n\nG3 X1 Y0 I1 J0\nF100\n", 3, "G3")):
                program = Path(folder) / "nofeed.ngc"
                program.write_text(text)
                with contextlib.redirect_stderr(io.StringIO()) as err:
                    status = main(["run", str(program), "--out", str(Path(folder) / "out")])
                self.assertEqual(status, 2)
                self.assertRegex(err.getvalue(), rf"nofeed\.ngc: line {line}: {code} with no "
                                                 rf"feed rate")
                self.assertEqual(len(err.getvalue().strip().splitlines()), 1)
                self.assertFalse((Path(folder) / "out").exists())


if __name__ == "__main__":
    unittest.main()
