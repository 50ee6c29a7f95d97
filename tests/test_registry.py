# amaranth: UnusedElaboratable=no
"""The registry: lookups, refusals, and a new variant added through it alone."""

import contextlib
import io
import os
import random
import re
import subprocess
import sys
import unittest
from pathlib import Path
from unittest import mock

import pytest

from kontur.hdl.circular_timing import FaithfulTiming
from kontur import registry
from kontur import cli
from kontur.trace import trace
from kontur.sim.runners import run_amaranth
from kontur.sim.stimulus import Job, first_difference, record_steps, run_model

from . import standin_core


@contextlib.contextmanager
def staircase_registered():
    """The stand-in variant registered for the duration (the registry restored after)."""
    with mock.patch.dict(registry.VARIANTS):
        registry.register(standin_core.VARIANT)
        yield


class LookupTestCase(unittest.TestCase):
    def test_kinds_and_variants(self):
        # What is registered is what the tables declare, in their order.
        self.assertEqual(list(registry.KINDS), [kind.name for kind in registry.KIND_TABLE])
        self.assertEqual(list(registry.KINDS), ["line", "arc", "profile"])
        for kind in registry.KINDS:
            self.assertEqual(registry.variants(kind),
                             tuple(item.name for item in registry.VARIANT_TABLE
                                   if item.kind == kind))
        self.assertEqual(registry.variants("profile"), ("fast", "faithful"))
        self.assertEqual([kind.program for kind in registry.KINDS.values()],
                         [False, False, True])
        self.assertEqual(registry.variant("arc").name, "faithful")
        self.assertEqual(list(registry.BOARDS), ["icebreaker", "icebreaker-z", "ulx3s"])

    def test_unknown(self):
        with self.assertRaisesRegex(ValueError,
                r"^Kind must be one of 'line', 'arc', 'profile', not 'spline'$"):
            registry.variants("spline")
        names = ", ".join(f"'{name}'" for name in registry.variants("line"))
        with self.assertRaisesRegex(ValueError,
                rf"^line variant must be one of {re.escape(names)}, not 'fast'$"):
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


# ---- the generic suites over a variant they do not name ---------------------------------

ROOT = Path(__file__).resolve().parent.parent


def run_suites_over_the_standin(*files, env=None):
    """Run pytest over ``files`` with the stand-in added through ``KONTUR_EXTRA_VARIANTS``
    and only its cases selected; the passed cases per file, and pytest's output."""
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:xdist", "-p", "no:cacheprovider", "-q",
         "-rA", "-k", "staircase", *files],
        cwd=ROOT, capture_output=True, text=True, timeout=600,
        env={**os.environ, "KONTUR_EXTRA_VARIANTS": "tests.standin_core:VARIANT",
             **(env or {})})
    passed = {}
    for line in result.stdout.splitlines():
        found = re.match(r"^PASSED (tests/\w+\.py)::\S*staircase", line)
        if found:
            passed[found[1]] = passed.get(found[1], 0) + 1
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
    assert not re.search(r"^(FAILED|ERROR) ", result.stdout, re.M), result.stdout[-3000:]
    return passed, result.stdout


def test_generic_suites_take_a_new_variant():
    # The engine contracts (model against RTL, feed, back pressure, aborts, signature) and the
    # accuracy bench run the stand-in, which no test file names: every suite ran some case of
    # it, and every one passed.
    files = ("tests/test_engine.py", "tests/test_textbook_bench.py")
    passed, output = run_suites_over_the_standin(*files)
    assert set(passed) == set(files), output[-3000:]
    assert passed["tests/test_engine.py"] >= 4, output[-3000:]
    assert passed["tests/test_textbook_bench.py"] >= 1, output[-3000:]


@pytest.mark.cocotb
def test_cocotb_line_suite_takes_a_new_variant():
    # The cocotb line suite, on Icarus alone (about a minute): the stand-in's Verilog against
    # its model, at the kind's default width (it declares no widths).
    passed, output = run_suites_over_the_standin("tests/test_line_cocotb.py",
                                                 env={"SIM": "icarus"})
    assert passed == {"tests/test_line_cocotb.py": 1}, output[-3000:]
    assert "test_line_engine[icarus-staircase-16]" in output


# ---- clocks a step: the cycle models' (the RTL's, clock for clock) at full feed -------------

LINE = {"x": 57, "y": -23}
CIRCLE = {"x0": 60, "y0": 11, "x1": 60, "y1": 11, "cw": 0}     # every quadrant
#: A full circle with cutter compensation (the equidistant engine's arcs alone).
PROFILE = "G0 X30 Y0\nG41 G3 X30 Y0 I-30 J0\nG40\nM2\n"


def _shortest_interval(moves):
    cycles = [cycle for cycle, _, _ in moves]
    return min(b - a for a, b in zip(cycles, cycles[1:]))


@pytest.mark.parametrize("width", [16, 20])
@pytest.mark.parametrize("kind, name", [(item.kind, item.name) for item in
                                        registry.VARIANT_TABLE if item.kind != "profile"])
def test_step_clocks_are_the_shortest_interval_between_steps(kind, name, width):
    # The variant's model, clock for clock, given every permission: no two steps closer than
    # its clocks a step, and some that close (the bit-serial node's word is 2 bits longer
    # than the coordinates; SU 1665343's faithful core takes 4 clocks).
    moves = trace(kind, LINE if kind == "line" else CIRCLE, variant=name, engine="model",
                  width=width, cycles=True)
    assert len(moves) > 40
    assert _shortest_interval(moves) == registry.step_clocks(kind, name, width)


@pytest.mark.parametrize("name", registry.variants("profile"))
def test_step_clocks_of_the_equidistant_engine(name):
    from kontur.trace import trace_profile
    run = trace_profile(PROFILE, radius=3, variant=name, width=16, cycles=True)
    assert len(run.moves) > 100
    assert _shortest_interval(run.moves) == registry.step_clocks("profile", name, 16)


@pytest.mark.parametrize("kind, name, params", [
    ("line", "exact", {"period": 3}), ("arc", "fast", {"period": 5}),
    ("arc", "faithful", {"timing": FaithfulTiming(period=6, extender=5)})])
def test_step_clocks_with_a_slower_generator(kind, name, params):
    # A core built with a slower generator than its default: its period, in the model's
    # clocks too (kontur trace bounds its runs by it).
    moves = trace(kind, LINE if kind == "line" else CIRCLE, variant=name, engine="model",
                  width=16 if kind == "line" else 24, cycles=True, params=params)
    clocks = registry.step_clocks(kind, name, **params)
    assert clocks == (params["period"] if "period" in params else params["timing"].period)
    assert _shortest_interval(moves) == clocks


def test_boards_slowest_engine():
    # The two-axis iCEBreaker's arcs are on the bit-serial node at 20 bits: a word of 22
    # clocks a step, its line core's one.
    item = registry.board("icebreaker")
    assert item.engines == [("line", item.line[0], 16), ("arc", "serial", 20)]
    assert item.slowest() == (22, "arc", "serial", 20)
    assert registry.board("icebreaker-z").engines[0] == ("line", "spatial", 16)


def test_a_feed_the_boards_engines_cannot_make_is_refused():
    from kontur.machine import Machine, RateError
    # Drives with 0.2 µs set-up and pulse: 3 + 3 + 1 clocks a step at 12 MHz (1.7 M steps/s),
    # more than the serial node's 12e6 / 22 = 545 455.
    fast = dict(clock_hz=12e6, dir_setup_us=0.2, step_width_us=0.2, steps_per_mm=1000)
    slow = Machine(max_feed=30000, **fast)                    # 500 000 steps/s
    assert registry.check_machine("icebreaker", slow) is slow
    with pytest.raises(RateError, match=r"^max_feed 40000 mm/min is 666667 steps/s, more "
                       r"than the 545455 the icebreaker's arc engine makes "
                       r"\(serial at 20 bits: a step every 22 clocks\)$"):
        registry.check_machine("icebreaker", Machine(max_feed=40000, **fast))
    # The three-axis board's node is 16 bits wide: 18 clocks, 666 667 steps/s.
    registry.check_machine("icebreaker-z", Machine(max_feed=40000, **fast))


if __name__ == "__main__":
    unittest.main()
