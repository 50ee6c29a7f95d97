"""Soft limits (issue 25): the host refuses a program whose moves leave the machine's travel
(``travel_x``, ``travel_y`` in the machine file), with the program line, before anything moves.

The expected extents are worked out here from the geometry: a circle of radius 5 about (10, 10)
reaches x = 15 at its rightmost point whatever its ends."""

import tempfile
import unittest
from pathlib import Path

from kontur import registry
from kontur.cli import main
from kontur.machine import Machine, MachineError
from kontur.machining import prepare
from kontur.planner import ProgramError

#: Travel X 0..14.5, Y 0..20 (mm).
TRAVEL = {"travel_x": [0, 14.5], "travel_y": [0, 20]}

#: Both ends of the arc inside the travel (x = 10 and 13 at most), its bulge not: the quarter
#: from (10, 5) counter-clockwise about (10, 10) through the 0° direction (x = 15) to (10, 15).
BULGE = """G21 G90
G0 X10 Y5
G3 X10 Y15 I0 J5 F600
G1 X5 Y15
"""

#: The same arc the other way round (clockwise, through 180°: x = 5): inside.
INSIDE = """G21 G90
G0 X10 Y5
G2 X10 Y15 I0 J5 F600
G1 X5 Y15
"""


def machine(**keys):
    return Machine(clock_hz=registry.board("icebreaker").clock_hz, steps_per_mm=10, **keys)


class TravelTestCase(unittest.TestCase):
    def test_arc_bulge_beyond_the_travel(self):
        with self.assertRaisesRegex(ProgramError, r"^line 3: the move reaches X 15 mm, beyond the "
                                    r"machine's travel \(X from 0 to 14\.5 mm, travel_x in the "
                                    r"machine file\): a soft limit$"):
            prepare(BULGE, machine=machine(**TRAVEL), name="bulge.ngc")
        prepare(INSIDE, machine=machine(**TRAVEL), name="inside.ngc")      # the other way
        prepare(BULGE, machine=machine(), name="bulge.ngc")                 # no travel given
        prepare(BULGE, machine=machine(travel_x=[0, 15]), name="bulge.ngc")  # just inside

    def test_lines_and_rapids(self):
        for text, line, message in (
                ("G0 X-1 Y3\n", 2, r"the move reaches X -1 mm, beyond the machine's "
                                   r"travel \(X from 0 to 14\.5 mm"),
                ("G0 X1 Y1\nG1 X2 Y20.5 F600\n", 3, r"the move reaches Y 20\.5 mm"),
                # A full circle of radius 2 about (5, 1.5): down to y = -0.5.
                ("G0 X7 Y1.5\nG2 X7 Y1.5 I-2 J0 F600\n", 3, r"the move reaches Y -0\.5 mm")):
            with self.subTest(text=text):
                with self.assertRaisesRegex(ProgramError, rf"^line {line}: {message}"):
                    prepare("G21 G90\n" + text, machine=machine(**TRAVEL), name="p.ngc")

    def test_compensated_contour_is_checked_on_the_cutter_path(self):
        # The outline stays within X 0..2; the cutter, 0.3 mm outside it (G42 going
        # counter-clockwise round the part), reaches X 2.3: refused with travel_x max 2.1,
        # taken with 2.4.
        contour = ("G21 G90\nG0 X0 Y0\nG42 G1 X2 Y0 F3000\nG1 X2 Y2\nG1 X0 Y2\nG1 X0 Y0\n"
                   "G40 G0 X0 Y-1\n")
        keys = dict(clock_hz=registry.board("ulx3s").clock_hz, steps_per_mm=10, cutter_radius=0.3, travel_y=[-2, 3])
        with self.assertRaisesRegex(ProgramError, r"^line [3-6]: the move reaches X 2\.[23] "
                                    r"mm, beyond the machine's travel \(X from -1 to 2\.1 mm, "
                                    r"travel_x in the machine file\): a soft limit$"):
            prepare(contour, machine=Machine(travel_x=[-1, 2.1], **keys), board="ulx3s")
        prepare(contour, machine=Machine(travel_x=[-1, 2.4], **keys), board="ulx3s")

    def test_z_on_three_axes(self):
        # A plunge to Z -6 with Z's travel -5..0: refused at the plunge on the ULX3S (three
        # axes), with -6..0 taken; a helix down to Z -4 then -6 (the second turn) refused at
        # its line. (Z starts at 0, the machine's, until the first Z word.)
        keys = dict(clock_hz=registry.board("ulx3s").clock_hz, steps_per_mm=10, **TRAVEL)
        plunge = "G21 G90\nG0 X5 Y5\nG1 Z-6 F300\nG1 X6\n"
        with self.assertRaisesRegex(ProgramError, r"^line 3: the move reaches Z -6 mm, beyond "
                                    r"the machine's travel \(Z from -5 to 0 mm, travel_z in "
                                    r"the machine file\): a soft limit$"):
            prepare(plunge, machine=Machine(travel_z=[-5, 0], **keys), board="ulx3s")
        prepare(plunge, machine=Machine(travel_z=[-6, 0], **keys), board="ulx3s")
        helix = ("G21 G90\nG0 X7 Y5\nG1 Z0 F300\nG2 X7 Y5 I0 J5 Z-4\n"
                 "G2 X7 Y5 I0 J5 Z-6\n")
        with self.assertRaisesRegex(ProgramError, r"^line 5: the move reaches Z -6 mm"):
            prepare(helix, machine=Machine(travel_z=[-5, 0], **keys), board="ulx3s")
        with self.assertRaisesRegex(MachineError, r"^travel_z must be \[min, max\]"):
            machine(travel_z=[0, -5])

    def test_machine_keys(self):
        with self.assertRaisesRegex(MachineError, r"^travel_y must be \[min, max\]"):
            machine(travel_y=[5, 5])
        with self.assertRaisesRegex(MachineError, r"^travel_x must be \[min, max\]"):
            machine(travel_x=[0])

    def test_command_line_refuses_before_anything_moves(self):
        with tempfile.TemporaryDirectory() as folder:
            program = Path(folder) / "bulge.ngc"
            program.write_text(BULGE)
            toml = Path(folder) / "machine.toml"
            toml.write_text("steps_per_mm = 10\ntravel_x = [0, 14.5]\ntravel_y = [0, 20]\n")
            out = Path(folder) / "out"
            import contextlib
            import io
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                status = main(["run", str(program), "--machine", str(toml), "--out", str(out),
                               "--engine", "verilator"])
            self.assertEqual(status, 2)
            lines = err.getvalue().strip().splitlines()
            self.assertEqual(len(lines), 1)
            self.assertIn("line 3", lines[0])
            self.assertIn("(X from 0 to 14.5 mm, travel_x in the machine file)", lines[0])
            self.assertFalse(out.exists())                 # nothing ran, nothing written


if __name__ == "__main__":
    unittest.main()
