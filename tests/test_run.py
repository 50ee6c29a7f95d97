# amaranth: UnusedElaboratable=no
"""``kontur run``: programs through the whole controller. The model's runs against geometry
(every program ends on its end to the step, the path near the contour), the RTL against the
model on every simulator (the same steps, outcomes and position read back), the command line's
outputs and refusals."""

import json
import math
import random
import tempfile
import unittest
from pathlib import Path

import pytest

from kontur import registry
from kontur.cli import main
from kontur.machine import Machine
from kontur.machining import auto_compress, deviation, execute, prepare, summary
from kontur.planner import ProgramError

from .conftest import selected_simulators

#: The iCEBreaker controller's clock (the programs here run on its controller).
CLOCK = registry.board("icebreaker").clock_hz

PART = Path(__file__).resolve().parent.parent / "kontur" / "programs" / "bracket.ngc"

#: A short program of every kind of move: a few thousand clocks of motion, quick on any engine.
SHORT = """(short)
G21 G90 G17
G1 X2 Y1 F3000
G3 X1 Y2 I-1 J0
G91 G1 X-0.5 Y-0.25
G90 G2 X1 Y1.75 R0.3
G0 X0 Y0
M30
"""

TINY = """G21 G90
G1 X1 Y0.5 F3000
G3 X0.5 Y1 I-0.5 J0
G0 X0 Y0
"""


def random_program(rng, count=12):
    """A program of random lines and arcs (both forms, both ways, incremental and absolute,
    inches and millimetres), in a 40 mm square, and its programmed end (mm)."""
    lines = ["G21 G90 G17", "F1200"]
    x = y = 0.0
    for _ in range(count):
        tx, ty = round(rng.uniform(-20, 20), 3), round(rng.uniform(-20, 20), 3)
        choice = rng.randrange(4)
        if choice == 0 or math.hypot(tx - x, ty - y) < 0.5:
            lines.append(f"G1 X{tx} Y{ty}")
        elif choice == 1:
            half = math.hypot(tx - x, ty - y) / 2
            radius = round(half * rng.uniform(1.01, 3), 3) * rng.choice((1, -1))
            lines.append(f"{rng.choice(('G2', 'G3'))} X{tx} Y{ty} R{radius}")
        elif choice == 2:
            # By centre: a centre on the bisector, so both ends are on its circle.
            mx, my = (x + tx) / 2, (y + ty) / 2
            k = rng.uniform(-2, 2)
            cx, cy = mx - k * (ty - y), my + k * (tx - x)
            lines.append(f"{rng.choice(('G2', 'G3'))} X{tx} Y{ty} I{cx - x:.4f} J{cy - y:.4f}")
        else:
            lines += [f"G91 G1 X{tx - x:.3f} Y{ty - y:.3f}", "G90"]
            tx, ty = x + round(tx - x, 3), y + round(ty - y, 3)
        x, y = tx, ty
    lines.append("M30")
    return "\n".join(lines) + "\n", (x, y)


class PrepareTestCase(unittest.TestCase):
    def test_refusals_name_the_line(self):
        cases = [
            ("G1 X1 F100\nG2 X20 R2\n", r"^line 2: the radius 2 is less than half"),
            ("G1 X1 F100\nM62\n", r"^line 2: unknown code M62$"),
            ("G0 Z0\nG1 X1 F100\nG1 X2 Z-1\n", r"^line 3: Z moves need the third axis, which "
                                               r"this board's controller does not have \(the icebreaker-z's and the ulx3s's have it\) \(Z from 0 "
                                               r"to -1 mm\)$"),
            ("G0 Z5\nG1 X1 F100\nG0 Z6\n", r"^line 3: Z moves need the third axis"),
            ("G1 X1 F100\nG2 X3.2 Y0 I1 J0\n", r"^line 2: the arc's radius is .* more than the "
                                               r"0.05 mm tolerance$"),
            ("(nothing)\n", r"no moves"),
            ("G1 X1 F100\nG41 G1 X5\n", r"^line 2: cutter-radius compensation"),
        ]
        for text, message in cases:
            with self.subTest(text=text), self.assertRaisesRegex(ProgramError, message):
                prepare(text)

    def test_machine_clock_is_the_boards(self):
        with self.assertRaisesRegex(ValueError, "machine's clock"):
            prepare(SHORT, machine=Machine(clock_hz=1e6))


class ModelTestCase(unittest.TestCase):
    """The golden path against geometry: ends exact, points near the programmed contour."""

    def test_random_programs_end_on_their_end(self):
        rng = random.Random(11)
        machine = Machine(clock_hz=CLOCK, steps_per_mm=40, arc_tolerance=0.1)
        for index in range(25):
            text, (x, y) = random_program(rng)
            with self.subTest(index=index):
                job = prepare(text, machine=machine)
                result = execute(job, "model")
                end = (sum(dx for dx, _ in result.steps), sum(dy for _, dy in result.steps))
                self.assertEqual(end, (round(x * 40), round(y * 40)))
                # Every point within a step of the programmed path (half a step of rounding of
                # the ends and centre, half of the interpolator's own error, and the arc's
                # finishing line within the tolerance).
                self.assertLess(deviation(job, result.steps), 1.0 / 40 + 0.1)
                self.assertTrue(all(abs(dx) <= 1 and abs(dy) <= 1 and (dx or dy)
                                    for dx, dy in result.steps))

    def test_part_and_plan_times(self):
        job = prepare(PART.read_text())
        result = execute(job, "model")
        self.assertEqual(result.end, (0, 0))
        # Within the accuracy its board's cores declare (registry.Variant.accuracy, steps):
        # half a step for the exact line core, half a diagonal for the arcs' bit-serial node
        # (separate steps).
        board = registry.board("icebreaker")
        bound = max(registry.variant(kind, spec[0]).accuracy or 0.5
                    for kind, spec in (("line", board.line), ("arc", board.arc)))
        self.assertLessEqual(bound, 0.5 ** 0.5 + 1e-12)
        self.assertLessEqual(deviation(job, result.steps), bound / 80 + 1e-9)
        # The plan's time is at least the contour's length at the programmed feeds.
        self.assertAlmostEqual(result.times[-1], job.seconds, delta=0.01 * job.seconds)
        self.assertGreaterEqual(job.seconds, 180 * 2 / (900 / 60) * 0.5)

    def test_compression(self):
        job = prepare(PART.read_text())
        compress = auto_compress(job)
        self.assertEqual(compress & (compress - 1), 0)
        fastest = max(item.cruise for item in job.items) * job.machine.steps_per_mm
        self.assertLessEqual(fastest * compress, job.machine.max_step_rate / 2)
        fast_frames, _ = job.frames(compress)
        slow_frames, _ = job.frames(1)
        self.assertEqual(len(fast_frames), len(slow_frames))
        with self.assertRaisesRegex(ValueError, "compression"):
            job.frames(0)


@pytest.mark.cocotb
class RTLTestCase(unittest.TestCase):
    """The whole controller's RTL against the model (execute raises RunError otherwise)."""

    def check(self, job, engine):
        result = execute(job, engine)
        self.assertEqual(result.steps, job.steps)
        self.assertEqual(result.end, tuple(job.end))
        # The traced machining time is the plan's, within a few percent (the ramps'
        # quantisation, the joints), and two steps at the slowest speed for every stop: the
        # generator's braking (a sum of rates a clock apart, begun at a whole step) reaches
        # the exit rate up to two steps earlier than the plan's margin of two
        # (tests/test_planner_margin.py).
        m = job.machine
        floor = math.sqrt(2 * m.accel / m.steps_per_mm)
        stops = sum(1 for item in job.items if 0 < item.exit <= floor * 1.001)
        crawl = stops * 2 / m.steps_per_mm / floor
        self.assertAlmostEqual(result.times[-1], job.seconds,
                               delta=0.05 * job.seconds + 0.002 + crawl)

    def test_short_on_icarus(self):
        # Verilator runs the whole part below; the short program on it only when it is the
        # one simulator selected. A fast link lets the run compress time twice as much (half
        # the clocks: auto_compress keeps the link half as busy as the motion).
        job = prepare(SHORT, machine=Machine(clock_hz=CLOCK, baud=1_000_000), name="short.ngc")
        for engine in [s for s in selected_simulators() if s != "verilator"] or ["verilator"]:
            with self.subTest(engine=engine):
                self.check(job, engine)

    def test_tiny_on_amaranth(self):
        # Amaranth's simulator runs the whole controller at a few thousand clocks a second: a
        # program of a line, an arc and the way back on a coarse, quick machine with a fast link.
        job = prepare(TINY, machine=Machine(clock_hz=CLOCK, steps_per_mm=10, baud=1_000_000,
                                           accel=5000), name="tiny.ngc")
        self.check(job, "amaranth")

    def test_dwell_on_amaranth(self):
        # G4 between two lines: a DWELL frame, which the controller waits out between the
        # moves' steps (its clocks at the run's time compression stand for 0.02 s).
        job = prepare("G21 G90\nG1 X1 F600\nG4 P0.02\nG1 Y1\n",
                      machine=Machine(clock_hz=CLOCK, steps_per_mm=10, baud=1_000_000,
                                      accel=5000), name="dwell.ngc")
        result = execute(job, "amaranth")
        self.assertEqual(result.steps, job.steps)
        split = len(job.segments[0].steps)
        self.assertGreaterEqual(result.times[split] - result.times[split - 1], 0.02)
        # and little more: the last step before it and the first after it at the rest rate.
        self.assertLess(result.times[split] - result.times[split - 1], 0.02 + 0.015)

    def test_low_feed_on_amaranth(self):
        # A millimetre at 10 mm/min: 6 s at the feed, and a little longer as the feed generator
        # makes it (10 steps/mm at 12 MHz: a rate of 1 in Q0.24 is 4.29 mm/min, so F10 runs at 2
        # of them, 8.58 mm/min). The RTL's every step at the model's time (time compressed
        # x4096: the rates 4096 times as many units, the acceleration within its 32 bits).
        machine = Machine(clock_hz=CLOCK, steps_per_mm=10, baud=1_000_000)
        job = prepare("G21 G90\nG1 X1 F10\n", machine=machine, name="slow.ngc")
        unit = CLOCK / (1 << 24) / 10 * 60                          # mm/min
        self.assertGreaterEqual(job.seconds, 1 / (10 / 60))
        self.assertLessEqual(job.seconds, 1 / (math.floor(10 / unit) * unit / 60) + 0.01)
        model = execute(job, "model")
        result = execute(job, "amaranth", compress=4096)
        self.assertEqual(result.steps, job.steps)
        for rtl, planned in zip(result.times, model.times):
            # The RTL's times count from its first step, the model's from the start.
            self.assertAlmostEqual(rtl + model.times[0], planned, delta=0.01 * planned + 0.002)

    def test_part_on_verilator_at_two_compressions(self):
        if "verilator" not in selected_simulators():
            self.skipTest("SIM selects another simulator")
        job = prepare(PART.read_text(), name="bracket.ngc")
        for compress in (auto_compress(job), auto_compress(job) // 4):
            with self.subTest(compress=compress):
                result = execute(job, "verilator", compress=compress)
                self.assertEqual(result.steps, job.steps)
                self.assertAlmostEqual(result.times[-1], job.seconds, delta=0.02 * job.seconds)


class CommandLineTestCase(unittest.TestCase):
    def test_outputs(self):
        with tempfile.TemporaryDirectory() as folder:
            program = Path(folder) / "short.ngc"
            program.write_text(SHORT)
            out = Path(folder) / "out"
            self.assertEqual(main(["run", str(program), "--out", str(out),
                                   "--steps-per-mm", "100"]), 0)
            steps = [tuple(map(int, line.split()))
                     for line in (out / "steps.txt").read_text().splitlines()]
            job = prepare(SHORT, machine=Machine(clock_hz=CLOCK, steps_per_mm=100))
            self.assertEqual(steps, job.steps)
            data = json.loads((out / "summary.json").read_text())
            self.assertEqual(data, summary(job, execute(job, "model")) | {
                "wall_seconds": data["wall_seconds"], "program": "short.ngc"})
            self.assertEqual(data["end_steps"], [0, 0])
            self.assertEqual((out / "toolpath.png").read_bytes()[:8], b"\x89PNG\r\n\x1a\n")

    def test_refusals(self):
        with tempfile.TemporaryDirectory() as folder:
            program = Path(folder) / "p.ngc"
            program.write_text("G1 X1 F100\nG7\n")
            self.assertEqual(main(["run", str(program)]), 2)
            program.write_text(SHORT)
            machine = Path(folder) / "m.toml"
            machine.write_text("clock_hz = 1e6\n")
            self.assertEqual(main(["run", str(program), "--machine", str(machine)]), 2)
            machine.write_text("steps_per_mm = 0\n")
            self.assertEqual(main(["run", str(program), "--machine", str(machine)]), 2)
            self.assertEqual(main(["run", str(program), "--vcd"]), 2)
            self.assertEqual(main(["run", str(program), "--compress", "0"]), 2)
            self.assertEqual(main(["run", str(Path(folder) / "none.ngc")]), 2)


if __name__ == "__main__":
    unittest.main()
