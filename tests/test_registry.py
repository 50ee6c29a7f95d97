# amaranth: UnusedElaboratable=no
"""The registry: lookups, refusals, and a new variant added through it alone."""

import contextlib
import io
import random
import unittest
from unittest import mock

from hdl.circular_timing import FaithfulTiming
from kontur import registry
from kontur import cli
from kontur.trace import trace
from sim.runners import run_amaranth
from sim.stimulus import Job, first_difference, record_steps, run_model

from . import standin_core


@contextlib.contextmanager
def staircase_registered():
    """The stand-in variant registered for the duration (the registry restored after)."""
    with mock.patch.dict(registry.VARIANTS):
        registry.register(standin_core.VARIANT)
        yield


class LookupTestCase(unittest.TestCase):
    def test_kinds_and_variants(self):
        self.assertEqual(list(registry.KINDS), ["line", "arc", "profile"])
        self.assertEqual(registry.variants("line"),
                         ("device", "exact", "separate", "dda", "dda-zero", "serial"))
        self.assertEqual(registry.variants("arc"), ("faithful", "fast", "separate", "serial"))
        self.assertEqual(registry.variants("profile"), ("fast", "faithful"))
        self.assertEqual([kind.program for kind in registry.KINDS.values()],
                         [False, False, True])
        self.assertEqual(registry.variant("arc").name, "faithful")
        self.assertEqual(list(registry.BOARDS), ["icebreaker", "ulx3s"])

    def test_unknown(self):
        with self.assertRaisesRegex(ValueError,
                r"^Kind must be one of 'line', 'arc', 'profile', not 'spline'$"):
            registry.variants("spline")
        with self.assertRaisesRegex(ValueError,
                r"^line variant must be one of 'device', 'exact', 'separate', 'dda', "
                r"'dda-zero', 'serial', not 'fast'$"):
            registry.make_engine("line", "fast")

    def test_parameters_that_do_not_apply(self):
        with self.assertRaisesRegex(TypeError,
                r"^arc variant 'faithful' takes no parameter 'period' \(it takes 'timing'\)$"):
            registry.make_model("arc", "faithful", period=2)
        with self.assertRaisesRegex(TypeError,
                r"^line variant 'exact' takes no parameter 'timing' \(it takes 'period'\)$"):
            registry.make_engine("line", "exact", timing=FaithfulTiming())
        with self.assertRaisesRegex(TypeError,
                r"^Register width must be an integer of at least 2, not 1$"):
            registry.make_engine("arc", width=1)

    def test_register_wrong(self):
        with self.assertRaisesRegex(ValueError,
                r"^Variant \('line', 'exact'\) is registered already$"):
            registry.register(registry.variant("line", "exact"))
        with self.assertRaisesRegex(ValueError,
                r"^Variant 'x' is of an unknown kind 'spline'$"):
            registry.register(registry.Variant("spline", "x", "", None, None, None))
        with self.assertRaisesRegex(TypeError,
                r"^Only a Kind, Variant or Board can be registered, not 3$"):
            registry.register(3)


class NewVariantTestCase(unittest.TestCase):
    """A core added by one file (``tests/standin_core.py``) and one registration."""

    FRAMES = [{"x": 3, "y": -2}, {"x": 0, "y": 0}, {"x": -1, "y": 4}, {"x": 300, "y": 1},
              {"x": 0, "y": 0}, {"x": 5, "y": 0}]

    def test_rtl_matches_its_model_and_steps(self):
        rng = random.Random(2)
        with staircase_registered():
            frames = self.FRAMES + [{"x": rng.randint(-9, 9), "y": rng.randint(-9, 9)}
                                    for _ in range(30)]
            for job in (Job(frames=frames), Job(frames=frames, tick=[1, 0, 1],
                                                status_ready=[1, 1, 0], aborts={40: 1})):
                expected = run_model(registry.make_model("line", "staircase", width=8), job)
                actual = run_amaranth(registry.make_engine("line", "staircase", width=8), job)
                self.assertIsNone(first_difference(expected, actual))
            want = []
            for frame in frames:
                try:
                    want += registry.steps("line", frame, "staircase", width=8)
                except registry.InputError:
                    pass
            self.assertEqual(record_steps(run_model(registry.make_model("line", "staircase",
                                                                        width=8),
                                                    Job(frames=frames))), want)

    def test_command_line_knows_it(self):
        with staircase_registered():
            self.assertEqual(trace("line", {"x": 2, "y": -1}, variant="staircase",
                                   engine="amaranth", cycles=True),
                             [(3, 1, 0), (4, 1, 0), (5, 0, -1)])   # first step at k + 3
            out = io.StringIO()
            with mock.patch("sys.stdout", out):
                self.assertEqual(cli.main(["trace", "line", "2", "-1", "--variant",
                                           "staircase"]), 0)
            self.assertEqual(out.getvalue(), "1 0\n1 0\n0 -1\n")
        self.assertNotIn(("line", "staircase"), registry.VARIANTS)


if __name__ == "__main__":
    unittest.main()
