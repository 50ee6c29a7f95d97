# amaranth: UnusedElaboratable=no
"""The comparison rows of ``kontur bench accuracy``: every variant on the same commands."""

import io
import math
import unittest
from unittest import mock

import pytest

from kontur import accuracy, registry
from kontur.sim.models.serial import word_length
from kontur.sim.models.textbook import dda_capacity


class ComparisonTestCase(unittest.TestCase):
    SEGMENTS = [(30, 0), (21, 21), (-5, 17), (0, -9), (2, 1)]

    def test_lines(self):
        # Steps and clocks per segment as each method defines them: the longer projection
        # (patents), |X| + |Y| (separate steps), N = 2**n iterations (DDA), a word of W clocks
        # per step and one more per segment (the serial node).
        with mock.patch.object(accuracy, "COMPARISON_LINES", self.SEGMENTS):
            rows = {row[0]: row for row in accuracy.line_comparison(limit=6)}
        self.assertEqual(list(rows), list(registry.variants("line")))
        count = len(self.SEGMENTS)
        longest = sum(max(abs(x), abs(y)) for x, y in self.SEGMENTS) / count
        both = sum(abs(x) + abs(y) for x, y in self.SEGMENTS) / count
        iterations = sum(1 << dda_capacity(x, y, width=16) for x, y in self.SEGMENTS) / count
        for name in ("device", "exact"):
            self.assertEqual(rows[name][3:5], (longest, longest))
        self.assertEqual(rows["separate"][3:6], (both, both, 1.0))
        self.assertEqual(rows["serial"][3], both)
        self.assertAlmostEqual(rows["serial"][4], word_length(16) * (both + 1), places=9)
        self.assertEqual(rows["dda"][4], iterations)
        self.assertEqual(rows["dda-zero"][4], iterations)
        for name, row in rows.items():
            self.assertEqual(row[1], 13 * 13 - 1)

    def test_arcs(self):
        with mock.patch.object(accuracy, "COMPARISON_CIRCLES", (3, 7)):
            rows = {row[0]: row for row in accuracy.arc_comparison(limit=12)}
        self.assertEqual(list(rows), list(registry.variants("arc")))
        self.assertEqual(rows["separate"][3], 8 * (3 + 7) / 2)        # 2R steps a quadrant
        self.assertEqual(rows["serial"][3], rows["separate"][3])
        self.assertGreater(rows["serial"][5], word_length(24))       # a word a step, and setup
        self.assertGreaterEqual(rows["faithful"][5], 4)                # a generator period
        self.assertGreaterEqual(rows["separate"][5], 1)

    def test_contour_speed(self):
        # The DDA's contour speed is the same in every direction; the estimating function's
        # changes 1 : sqrt(2) between axial and diagonal moves (down with separate steps, up
        # with the patents' diagonal steps).
        # Length 50: (50, 0), (35, 35), (0, 50), every one N = 64 clocks in the DDA.
        rows = {row[0]: row for row in accuracy.contour_speed(length=50, angles=(0, 45, 90),
                                                                  width=8)}
        diagonal = math.hypot(35, 35)
        for label in ("dda", "dda-zero", "dda, capacity register"):
            self.assertEqual(rows[label][1], [1.0, diagonal / 50, 1.0])
        self.assertEqual(rows["dda"][3], 50 / 64)
        self.assertEqual(rows["dda, capacity register"][3], 50 / 256)
        self.assertAlmostEqual(rows["separate"][1][1], diagonal / 70, places=9)
        # The serial node: a word a step and one more a segment.
        self.assertAlmostEqual(rows["serial"][1][1], (diagonal / 71) / (50 / 51), places=9)
        for label in ("exact", "device"):
            self.assertAlmostEqual(rows[label][1][1], diagonal / 35, places=9)
            self.assertAlmostEqual(rows[label][2], math.sqrt(2), delta=0.01)

    def test_contour_speed_of_a_capacity_per_segment(self):
        # Length 40: the diagonal's longer projection (28) needs only N = 32, the axial segments
        # N = 64: with the capacity chosen per segment the DDA is twice as fast on the diagonal;
        # with one capacity for all it is not.
        rows = {row[0]: row for row in accuracy.contour_speed(length=40, angles=(0, 45), width=8)}
        self.assertEqual(rows["dda"][1], [1.0, (math.hypot(28, 28) / 32) / (40 / 64)])
        self.assertEqual(rows["dda, capacity register"][1], [1.0, math.hypot(28, 28) / 40])

    def test_reference(self):
        midpoint, literal = accuracy.reference_table(limit=10, r2_limit=60)
        self.assertEqual(midpoint[2], 0)
        self.assertGreater(literal[2], 0)
        self.assertGreater(literal[1], midpoint[1])

    def test_main_prints_the_tables(self):
        # The tables on small cases (the patents' own tables left out).
        out = io.StringIO()
        small = {"line_comparison": {"limit": 3}, "arc_comparison": {"limit": 5},
                 "contour_speed": {"length": 20, "width": 6},
                 "reference_table": {"limit": 3, "r2_limit": 20}}
        patches = {name: (lambda f=getattr(accuracy, name), k=kwargs: f(**k))
                   for name, kwargs in small.items()}
        patches.update(linear_table=list, circular_table=list, throughput_table=list,
                       COMPARISON_LINES=self.SEGMENTS, COMPARISON_CIRCLES=(3,))
        with mock.patch.multiple(accuracy, **patches):
            self.assertEqual(accuracy.main(out), 0)
        text = out.getvalue()
        for name in registry.variants("line") + registry.variants("arc"):
            self.assertRegex(text, rf"(?m)^{name} +\d")
        self.assertRegex(text, r"(?m)^dda, capacity register +1\.000")
        self.assertRegex(text, r"(?m)^F at the point \(reference\) +\d")


# ---- what every variant meets: its declared accuracy (Variant.accuracy), and a step a clock
# at most ----------------------------------------------------------------------------------

def _every(kind):
    return pytest.mark.parametrize("name", registry.variants(kind),
                                   ids=[f"{kind}-{name}" for name in registry.variants(kind)])


@_every("line")
def test_line_variant_meets_its_accuracy(name):
    # Every end point with |X|, |Y| <= 16: the largest deviation is within the variant's
    # declared bound; a segment takes at least its longer projection in steps (a step moves
    # each axis by one at most) and a clock a step at least.
    segments = ComparisonTestCase.SEGMENTS
    with mock.patch.object(accuracy, "COMPARISON_LINES", segments):
        (row,) = accuracy.line_comparison(limit=16, names=(name,))
    bound = registry.variant("line", name).accuracy
    if bound is not None:
        assert row[2] <= bound + 1e-12, (name, row[2], bound)
    assert row[1] == 33 * 33 - 1
    assert row[3] >= sum(max(abs(x), abs(y)) for x, y in segments) / len(segments)
    assert row[5] >= 1.0


@_every("arc")
def test_arc_variant_meets_its_accuracy(name):
    # Every full circle of radius 1..24: the largest radial error is within the declared
    # bound; a circle of radius R takes at least pi·R·sqrt(2) steps (its length over the
    # longest step, a diagonal one) and a clock a step at least.
    circles = (3, 7)
    with mock.patch.object(accuracy, "COMPARISON_CIRCLES", circles):
        (row,) = accuracy.arc_comparison(limit=24, names=(name,))
    bound = registry.variant("arc", name).accuracy
    if bound is not None:
        assert row[2] <= bound + 1e-12, (name, row[2], bound)
    assert row[3] >= sum(2 * math.pi * r / math.sqrt(2) for r in circles) / len(circles) - 1
    assert row[5] >= 1.0


if __name__ == "__main__":
    unittest.main()
