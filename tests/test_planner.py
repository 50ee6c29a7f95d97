"""The host's planner: moves onto the step lattice, junction speeds, trapezoids, frames."""

import math
import unittest
from collections import namedtuple
from fractions import Fraction

from kontur.machine import Machine, MachineError, RateError
from kontur.planner import ProgramError, _on_sweep, frames, lattice, plan

Move = namedtuple("Move", "line kind start end centre cw feed", defaults=(None, False, 600))


def walk(segments):
    x, y = segments[0].start
    for segment in segments:
        assert (x, y) == segment.start
        for dx, dy in segment.steps:
            x, y = x + dx, y + dy
        assert (x, y) == segment.end
    return x, y


class LatticeTestCase(unittest.TestCase):
    machine = Machine(steps_per_mm=10, arc_tolerance=0.2)

    def test_ends_exactly_where_programmed(self):
        # A square with a rounded corner whose centre is off the grid: every move ends on its
        # programmed point rounded to the step, and the program at its end.
        moves = [Move(1, "line", (0, 0), (Fraction(303, 100), 0)),
                 Move(2, "arc", (Fraction(303, 100), 0), (Fraction(503, 100), 2),
                      centre=(Fraction(303, 100), 2), cw=False),
                 Move(3, "line", (Fraction(503, 100), 2), (Fraction(503, 100), 5)),
                 Move(4, "rapid", (Fraction(503, 100), 5), (0, 0))]
        segments = lattice(moves, self.machine)
        self.assertEqual(walk(segments), (0, 0))
        self.assertEqual([s.end for s in segments if s.line == 2][-1], (50, 20))
        self.assertEqual(segments[-1].feed, self.machine.max_feed / 60)

    def test_arc_radii_beyond_the_tolerance(self):
        moves = [Move(7, "arc", (0, 0), (Fraction(21, 10), Fraction(21, 10)),
                      centre=(2, 0), cw=False)]
        with self.assertRaisesRegex(ProgramError,
                r"^line 7: the arc's radius is 2\.0000 mm at its start and 2\.1024 mm at its "
                r"end: 0\.1024 mm apart, more than the 0\.05 mm tolerance$"):
            lattice(moves, Machine(steps_per_mm=10, arc_tolerance=0.05))
        segments = lattice(moves, self.machine)            # within 0.2 mm: traced, and ends
        self.assertEqual(walk(segments), (21, 21))
        self.assertEqual([s.kind for s in segments], ["arc", "line"])
        with self.assertRaisesRegex(ProgramError,
                r"^line 3: the arc's start is its centre: radius zero$"):
            lattice([Move(3, "arc", (1, 1), (1, 1), centre=(1, 1))], self.machine)

    def test_full_circle(self):
        segments = lattice([Move(1, "arc", (5, 0), (5, 0), centre=(0, 0), cw=True)],
                           self.machine)
        self.assertEqual(len(segments), 1)
        self.assertEqual(walk(segments), (50, 0))
        self.assertGreater(len(segments[0].steps), 4 * 50)

    def test_sweep_on_the_lattice_is_the_programmed_one(self):
        # A quarter turn (counter-clockwise from (5, 0) about the origin) put on a lattice arc
        # that ends half a turn on, or one that is a full circle: refused, naming the line.
        quarter = Move(4, "arc", (5, 0), (0, 5), centre=(0, 0))
        for reach in ((-50, 0), (50, 0)):
            with self.subTest(reach=reach), self.assertRaisesRegex(
                    ProgramError, r"^line 4: the arc sweeps 90\.0000 degrees as programmed but"):
                _on_sweep(quarter, (50, 0), reach, 50)
        self.assertEqual(_on_sweep(quarter, (50, 0), (0, 50), 50), (0, 50))
        # A sliver (0.001 mm of a 5 mm circle, a fiftieth of a step) whose ends round to one
        # step: no arc (a line to the end); a sliver short of a full turn: a full circle.
        sliver = Move(5, "arc", (5, 0), (5, Fraction(1, 1000)), centre=(0, 0))
        self.assertIsNone(_on_sweep(sliver, (50, 0), (50, 0), 50))
        short = sliver._replace(cw=True)
        self.assertEqual(_on_sweep(short, (50, 0), (50, 0), 50), (50, 0))
        self.assertEqual(lattice([sliver], self.machine), [])        # no step to make
        segments = lattice([short], self.machine)
        self.assertEqual(walk(segments), (50, 0))
        self.assertGreater(len(segments[0].steps), 4 * 50)


class PlanTestCase(unittest.TestCase):
    machine = Machine(steps_per_mm=100, accel=200, junction_deviation=0.02, max_feed=6000)
    #: The feed generator's speed resolution: a rate of 1 in Q0.24 step lengths a clock, mm/s.
    unit = machine.clock_hz / (1 << 24) / machine.steps_per_mm

    def corner(self, angle):
        """Two 20 mm lines at F3000 meeting at ``angle`` degrees of turn."""
        turn = math.radians(angle)
        end = (20 + 20 * math.cos(turn), 20 * math.sin(turn))
        moves = [Move(1, "line", (0, 0), (20, 0), feed=3000),
                 Move(2, "line", (20, 0), (round(end[0], 2), round(end[1], 2)), feed=3000)]
        segments = lattice(moves, self.machine)
        return plan(segments, self.machine)

    def test_junction_speed_drops_with_the_angle(self):
        speeds = [self.corner(angle)[0].exit for angle in (0, 10, 45, 90, 135, 179)]
        # Straight on: F3000, as the feed generator makes it (a whole Q0.24 rate, not above).
        self.assertTrue(50.0 - self.unit < speeds[0] <= 50.0)
        self.assertEqual(speeds, sorted(speeds, reverse=True))
        self.assertLess(speeds[-1], 3.0)                           # almost a reversal
        # GRBL's formula at 90 degrees: v² = a δ sin(θ/2) / (1 - sin(θ/2)), θ = 90°.
        s = math.sin(math.radians(45))
        self.assertAlmostEqual(speeds[3], math.sqrt(200 * 0.02 * s / (1 - s)), places=2)

    def test_trapezoids(self):
        items = self.corner(90)
        first, second = items
        self.assertEqual(first.entry, 0.0)
        vc = first.cruise
        self.assertTrue(50.0 - self.unit < vc <= 50.0)              # reached in 6.25 mm
        self.assertEqual(second.entry, first.exit)
        # The program ends at the slowest speed the gateware may end a move at: one step's
        # acceleration from rest (it must not stop short of the last step), a whole rate.
        self.assertTrue(0 <= math.sqrt(2 * 200 / 100) - second.exit < self.unit)
        # Time: up to the cruise and down to the corner speed within 20 mm, less the margin
        # of two steps (0.02 mm) run at the corner speed. The plan sums its steps, each at
        # the speed in its middle: the first, from rest, at sqrt(a * 0.01 mm) instead of the
        # integral's sqrt(2 * 0.01 mm / a) seconds; the others within 0.2 ms of the integral.
        v1 = first.exit
        cruise_mm = 20 - 0.02 - vc ** 2 / 400 - (vc ** 2 - v1 ** 2) / 400
        expected = vc / 200 + (vc - v1) / 200 + cruise_mm / vc + 0.02 / v1 \
            - math.sqrt(2 * 0.01 / 200) + 0.01 / math.sqrt(200 * 0.01)
        self.assertAlmostEqual(first.seconds, expected, delta=2e-4)
        # The ramp down starts with room to reach the exit speed.
        segment = lattice([Move(1, "line", (0, 0), (20, 0), feed=3000)], self.machine)[0]
        down = (50 ** 2 - v1 ** 2) / (2 * 200) * 100
        self.assertLessEqual(first.decelerate, len(segment.steps) - down)

    def test_frames(self):
        segments = lattice([Move(1, "line", (0, 0), (3, 4))], self.machine)
        out, lines = frames(segments, plan(segments, self.machine), self.machine)
        self.assertEqual([frame[1] for frame in out], [0x15, 0x13, 0x10, 0x14])
        self.assertEqual(lines, [None, 1, 1, None])


class MachineTestCase(unittest.TestCase):
    def test_units(self):
        m = Machine(steps_per_mm=80, accel=500, clock_hz=12e6)
        self.assertEqual(m.dir_setup, 12)
        self.assertEqual(m.step_width, 24)
        self.assertAlmostEqual(m.max_step_rate, 12e6 / 37)
        self.assertEqual(m.rate(50), round(50 * 80 / 12e6 * (1 << 24)))
        self.assertEqual(m.accel_q40, round(500 * 80 / 144e12 * (1 << 40)))

    def test_wrong(self):
        with self.assertRaisesRegex(MachineError, r"^accel must be positive, not 0$"):
            Machine(accel=0)
        with self.assertRaisesRegex(MachineError, r"^baud must be an integer, not 9600\.5$"):
            Machine(baud=9600.5)
        with self.assertRaisesRegex(RateError,
                r"^max_feed 1e\+06 mm/min is 1333333 steps/s, more than the 324324 the "
                r"step/dir timing allows$"):
            Machine(max_feed=1e6)
        # Only a rate refusal is a RateError (Grbl's $110 answers it with error:12).
        with self.assertRaises(MachineError) as caught:
            Machine(accel=0)
        self.assertNotIsInstance(caught.exception, RateError)


if __name__ == "__main__":
    unittest.main()


# ---- the link: the board's queue never runs dry in the middle of the motion ----------------

def _finely_divided_circle(count=2000, radius=30, feed=3000):
    """A circle of ``radius`` mm in ``count`` straight moves (0.094 mm each at the defaults,
    a CAM program's linearised curve) at F``feed``."""
    points = [(radius * math.cos(2 * math.pi * i / count) - radius,
               radius * math.sin(2 * math.pi * i / count)) for i in range(1, count + 1)]
    return "G21 G90 G17\nG0 X0 Y0\n" + f"F{feed}\n" + \
        "".join(f"G1 X{x:.3f} Y{y:.3f}\n" for x, y in points) + "M2\n"


def _waits(job):
    """The board's waits (s) for a move frame once the motion has begun: the frames sent back
    to back at the machine's baud (10 bits a byte), never more than ``queue_frames`` of them
    unanswered; the board takes each once it has arrived and the one before is done, a move
    frame taking its planned time (the others none)."""
    from kontur.send import _frame_plan
    frames, _ = job.frames()
    durations, _ = _frame_plan(job, len(frames))
    window, baud = job.machine.queue_frames, job.machine.baud
    link = board = 0.0
    done, waits = [], []
    for index, frame in enumerate(frames):
        link = max(link, done[index - window] if index >= window else 0.0) + \
            len(frame) * 10 / baud
        if link > board and durations[index] and any(durations[:index]):
            waits.append(link - board)
        board = max(board, link) + durations[index]
        done.append(board)
    return waits


def test_short_moves_never_outrun_the_link(monkeypatch):
    # 2000 moves of 0.094 mm at F3000 (50 mm/s: 1.9 ms each) on the iCEBreaker at 115200
    # baud: a move's FEED and LINE frames (28 bytes) take 2.4 ms on the link. Planned at their
    # feed the board's queue would run dry between moves, the machine stopping at speed; the
    # plan holds each move to 1.5 times its frames' time instead.
    from kontur import planner
    from kontur.machining import prepare
    text = _finely_divided_circle()
    job = prepare(text, board="icebreaker")
    assert _waits(job) == []
    frames, _ = job.frames()
    link = sum(len(frame) for frame in frames) * 10 / job.machine.baud
    assert job.seconds >= planner.LINK_MARGIN * link * 0.99
    cruise = max(item.cruise for item in job.items)
    assert 20 < cruise < 30                     # mm/s: 0.094 mm in 3.65 ms, not 50
    # kontur run says so (its summary's "link" line): every move held below F3000.
    from kontur.machining import _link_limited
    held = _link_limited(job)
    assert (held["moves"], held["of"], held["baud"]) == (2000, 2000, 115200)
    assert held["lowest_mm_min"] <= cruise * 60
    assert _link_limited(prepare(_finely_divided_circle(count=100), board="icebreaker")) is None
    # Without that bound the same program starves the board, move after move.
    monkeypatch.setattr(planner, "LINK_MARGIN", 1e-9)
    assert len(_waits(prepare(text, board="icebreaker"))) > 100
