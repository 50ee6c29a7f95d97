# amaranth: UnusedElaboratable=no
"""G41/G42 in ``kontur run``: compensated contours through the equidistant engine of the
machine controller (the ULX3S's). The model's runs against geometry (the cutter's centre a
cutter radius from the part's outline, measured here from the outline itself), the RTL
against the model (the same steps, outcomes and position read back), the refusals."""

import json
import math
import tempfile
import unittest
from pathlib import Path

import pytest

from kontur import registry
from kontur.cli import main
from kontur.machine import Machine
from kontur.machining import deviation, execute, prepare
from kontur.planner import ProgramError

from .conftest import selected_simulators

#: The board with the equidistant engine, and its controller's clock.
BOARD = "ulx3s"
CLOCK = registry.board(BOARD).clock_hz

PLATE = Path(__file__).resolve().parent.parent / "kontur" / "programs" / "plate.ngc"

#: A small compensated contour on a coarse machine: quick on any simulator.
TINY = """G21 G90
G0 X0 Y0
G42 G1 X2 Y0 F3000
G1 X2 Y1
G3 X1 Y2 I-1 J0
G1 X0 Y2
G1 X0 Y0
G40 G0 X0 Y-1
"""


def outline_distance(point):
    """Signed distance (mm) of ``point`` (mm) from the plate's outline: the rectangle 40 x 30
    with corners of radius 5; positive outside, negative inside."""
    qx = abs(point[0] - 20) - 15
    qy = abs(point[1] - 15) - 10
    outside = math.hypot(max(qx, 0), max(qy, 0))
    return outside + min(max(qx, qy), 0) - 5


def contour_points(job):
    """The points (steps) the steps visit on the compensated contour's elements (not the
    approach to it, not the moves after it)."""
    (contour,) = job.contours
    points = []
    for index in range(contour.first, contour.first + contour.count):
        if index == contour.approach:
            continue
        segment = job.segments[index]
        x, y = segment.start[:2]                 # (the ULX3S's: three axes, Z still)
        for dx, dy, *_ in segment.steps:
            x, y = x + dx, y + dy
            points.append((x, y))
    return points


def plate_job(text=None, **machine):
    return prepare(text or PLATE.read_text(), machine=Machine(clock_hz=CLOCK, **machine),
                   board=BOARD, name="plate.ngc")


class ModelTestCase(unittest.TestCase):
    """The golden path against the part's geometry."""

    def check_offset(self, job, side, radius):
        spm = job.machine.steps_per_mm
        points = contour_points(job)
        # The straight edges alone are 100 mm long, and a step moves at most sqrt(2) steps.
        self.assertGreater(len(points), 100 * spm / math.sqrt(2))
        worst = max(abs(outline_distance((x / spm, y / spm)) - side * radius)
                    for x, y in points)
        # The engine's bound: every point within 0.85 steps of the exact equidistant.
        self.assertLess(worst, 0.85 / spm)
        self.assertTrue(all(abs(dx) <= 1 and abs(dy) <= 1 and (dx or dy) and dz == 0
                            for dx, dy, dz in job.steps))
        # A closed outline: the contour's last point is its first.
        (contour,) = job.contours
        first = job.segments[contour.first + 1 + (contour.approach is not None)]
        self.assertEqual(points[-1], first.start[:2])

    def test_outside_with_g42(self):
        job = plate_job(cutter_radius=3)
        result = execute(job, "model")
        self.assertEqual(result.end, (0, 0, 0))
        self.check_offset(job, +1, 3)
        self.assertLess(deviation(job, result.steps), 0.85 / 80)

    def test_inside_with_g41(self):
        for radius in (1, 4.5):
            with self.subTest(radius=radius):
                job = plate_job(PLATE.read_text().replace("G42", "G41"), cutter_radius=radius)
                self.assertEqual(execute(job, "model").end, (0, 0, 0))
                self.check_offset(job, -1, radius)

    def test_radius_zero_is_the_outline(self):
        job = plate_job(cutter_radius=0, steps_per_mm=20)
        self.check_offset(job, 0, 0)

    def test_summary_names_the_contour(self):
        from kontur.machining import summary
        job = plate_job(cutter_radius=3)
        data = summary(job, execute(job, "model"))
        self.assertEqual(data["cutter_radius_mm"], 3)
        self.assertEqual(data["cutter_radius_steps"], 240)
        (contour,) = data["contours"]
        self.assertEqual(contour["lines"], [6, 14])
        self.assertFalse(contour["closed"])   # LinuxCNC's rule: entered by a move
        self.assertEqual(data["arcs"], 4)
        self.assertEqual(data["end_steps"], data["programmed_end_steps"])

    def test_refusals_name_the_line(self):
        inside = PLATE.read_text().replace("G42", "G41")
        cases = [
            (PLATE.read_text(), {}, BOARD, r"^line 6: .* needs a cutter radius: give --radius"),
            (inside, {"cutter_radius": 6}, BOARD,
             r"^line 8: the cutter \(radius 480\) is too large for the arc of radius 400 on its "
             r"inside$"),
            (PLATE.read_text(), {"cutter_radius": 3}, "icebreaker",
             r"^line 6: .*equidistant engine, which the icebreaker's controller does not have.*"
             r"boards with it: ulx3s$"),
        ]
        for text, machine, board, message in cases:
            with self.subTest(message=message), self.assertRaisesRegex(ProgramError, message):
                prepare(text, machine=Machine(clock_hz=registry.board(board).clock_hz,
                                              **machine), board=board)

    def test_convex_corners_arc_or_miter(self):
        """A 20 mm square cut outside (G42) at r = 2: with ``corner = "arc"`` (the default,
        LinuxCNC's) the cutter's centre stays r from the outline (its distance from the square
        within the engine's 0.85 steps of r: round every corner); with ``"miter"`` the 90°
        corners are extended to the point r·√2 from the vertex."""
        square = ("G21 G90\nG0 X-5 Y0\nG42 G1 X0 Y0 F1200\nG1 X20\nG1 Y20\nG1 X0\nG1 Y0\n"
                  "G40 G1 X0 Y-5\nM2\n")

        def outside(point):
            qx, qy = abs(point[0] - 10) - 10, abs(point[1] - 10) - 10
            return math.hypot(max(qx, 0), max(qy, 0)) + min(max(qx, qy), 0)

        for corner, reach in (("arc", 2), ("miter", 2 * math.sqrt(2))):
            with self.subTest(corner=corner):
                job = plate_job(square, cutter_radius=2, steps_per_mm=20, corner=corner)
                points = [(x / 20, y / 20) for x, y in contour_points(job)]
                far = max(outside(p) for p in points)
                self.assertLess(abs(far - reach), 1 / 20, far)
                self.assertGreater(min(outside(p) for p in points), 2 - 0.85 / 20)

    def test_cutter_radius_is_checked(self):
        from kontur.machine import MachineError
        for value in (-1, float("nan"), "3", True):
            with self.subTest(value=value), self.assertRaisesRegex(MachineError,
                                                                   "cutter_radius"):
                Machine(clock_hz=CLOCK, cutter_radius=value)


@pytest.mark.cocotb
class RTLTestCase(unittest.TestCase):
    """The ULX3S controller, with its equidistant engine, against the model (execute raises
    RunError when the steps, an outcome or the position read back differ)."""

    def test_tiny_on_icarus(self):
        # A fast link (2.5 Mbaud, 10 clocks a bit) lets the run compress time by 32: 172 000
        # clocks, at about 9000 a second on Icarus (auto_compress keeps the link half as busy
        # as the motion).
        job = prepare(TINY, machine=Machine(clock_hz=CLOCK, steps_per_mm=10, baud=2_500_000,
                                           accel=5000, cutter_radius=0.3),
                      board=BOARD, name="tiny.ngc")
        self.assertTrue(job.contours)
        for engine in [s for s in selected_simulators() if s != "verilator"] or ["verilator"]:
            with self.subTest(engine=engine):
                result = execute(job, engine)
                self.assertEqual(result.steps, job.steps)
                self.assertEqual(result.end, (0, -10, 0))

    def test_plate_on_verilator(self):
        if "verilator" not in selected_simulators():
            self.skipTest("SIM selects another simulator")
        job = plate_job(cutter_radius=3)
        result = execute(job, "verilator")
        self.assertEqual(result.steps, job.steps)
        self.assertEqual(result.end, (0, 0, 0))
        self.assertAlmostEqual(result.times[-1], job.seconds, delta=0.02 * job.seconds)


class CommandLineTestCase(unittest.TestCase):
    def test_radius_option_and_machine_file(self):
        with tempfile.TemporaryDirectory() as folder:
            out = Path(folder) / "out"
            self.assertEqual(main(["run", str(PLATE), "--board", BOARD, "--radius", "3",
                                   "--steps-per-mm", "20", "--out", str(out)]), 0)
            data = json.loads((out / "summary.json").read_text())
            self.assertEqual(data["cutter_radius_steps"], 60)
            steps = [tuple(map(int, line.split()))
                     for line in (out / "steps.txt").read_text().splitlines()]
            self.assertEqual(steps, plate_job(cutter_radius=3, steps_per_mm=20).steps)
            machine = Path(folder) / "m.toml"
            machine.write_text("steps_per_mm = 20\ncutter_radius = 2.5\n")
            self.assertEqual(main(["run", str(PLATE), "--board", BOARD, "--machine",
                                   str(machine), "--out", str(out)]), 0)
            data = json.loads((out / "summary.json").read_text())
            self.assertEqual(data["cutter_radius_mm"], 2.5)
            self.assertEqual(data["cutter_radius_steps"], 50)
            # No radius, or no engine: refused before anything runs (exit status 2).
            self.assertEqual(main(["run", str(PLATE), "--board", BOARD]), 2)
            self.assertEqual(main(["run", str(PLATE), "--radius", "3"]), 2)
            self.assertEqual(main(["run", str(PLATE), "--board", BOARD, "--radius", "-1"]), 2)


if __name__ == "__main__":
    unittest.main()
