"""The specifications both sides share (``hdl/spec.py``): one definition, pure Python; and the
equidistant engine's RTL and models split along Siimut's blocks (no function over 150 lines)."""

import ast
import math
import subprocess
import sys
import unittest
from pathlib import Path

import kontur.sim.models.equidistant as model
from kontur.hdl import equidistant, spec, top

ROOT = Path(__file__).resolve().parent.parent


class SpecTestCase(unittest.TestCase):
    def test_formats_and_kinds_defined_once(self):
        self.assertIs(equidistant.Formats, spec.Formats)
        self.assertIs(model.Formats, spec.Formats)
        self.assertIs(equidistant.Kind, spec.Kind)
        self.assertEqual(model.KIND, {name.lower(): getattr(spec.Kind, name)
                                      for name in ("RADIUS", "START", "LINE", "ARC", "CLOSE")})

    def test_formats_checks(self):
        self.assertEqual(spec.Formats(8), spec.Formats(8, 12))
        with self.assertRaisesRegex(TypeError, r"^Coordinate width must be an integer of at "
                                               r"least 4, not 3$"):
            spec.Formats(3)
        with self.assertRaisesRegex(TypeError, r"^Fractional bits must be an integer of at "
                                               r"least 2, not True$"):
            spec.Formats(8, True)

    def test_pure_python(self):
        # The spec and the golden models load without Amaranth (a fresh interpreter).
        code = ("import sys, kontur.hdl.spec, kontur.sim.models.equidistant; "
                "print(sorted(m for m in sys.modules if m.split('.')[0] == 'amaranth'))")
        out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                             text=True, check=True)
        self.assertEqual(out.stdout.strip(), "[]")

    def test_demo_octagon(self):
        self.assertEqual(top.OCTAGON, [{"x": x, "y": y} for x, y in spec.OCTAGON])
        # A closed octagon, one segment in each octant.
        self.assertEqual((sum(x for x, _ in spec.OCTAGON),
                          sum(y for _, y in spec.OCTAGON)), (0, 0))
        octants = {math.floor(math.atan2(y, x) / (math.pi / 4)) % 8
                   for x, y in spec.OCTAGON}
        self.assertEqual(octants, set(range(8)))


class SplitTestCase(unittest.TestCase):
    def test_no_function_over_150_lines(self):
        files = [ROOT / "hdl" / "equidistant.py",
                 *sorted((ROOT / "sim" / "models" / "equidistant").glob("*.py"))]
        self.assertGreater(len(files), 2)
        for path in files:
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.FunctionDef):
                    with self.subTest(path=path.name, function=node.name):
                        self.assertLessEqual(node.end_lineno - node.lineno + 1, 150)
