# amaranth: UnusedElaboratable=no
"""The engine interface: signatures, the status unit, and the contracts every engine keeps."""

import random
import unittest

import pytest

from amaranth import *
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from kontur.hdl.engine import (EngineSignature, FeedSignature, MotionSignature, Outcome, StatusLayout,
                        StatusUnit)
from kontur.hdl.motion import FeedDivider, StepDirStage
from kontur import registry
from kontur.sim.models.engine import ABORTED, DONE, REFUSED, StatusModel
from kontur.sim.runners import run_amaranth
from kontur.sim.stimulus import (Job, check_outcomes, first_difference, record_outcomes,
                          record_steps, run_model)

from .utils import simulate

FRAME = data.StructLayout({"x": signed(8), "y": signed(8)})


def _profile_frames():
    """A program for the profile kind at width 8: a pie slice (lines and an arc), its corners
    rounded, and an open zigzag after it."""
    from pathlib import Path
    from kontur.gcode import read
    from kontur.sim.models.equidistant import Formats, prepare, profile_from_moves
    programs = Path(__file__).resolve().parent / "programs"
    frames = []
    for name, treatment in (("pie", "arc"), ("zigzag", "extend")):
        shape = profile_from_moves(read((programs / f"{name}.ngc").read_text()).moves)
        frames += prepare(shape, 2, treatment=treatment, formats=Formats(8)).frames
    return frames


class SignatureTestCase(unittest.TestCase):
    def test_motion(self):
        self.assertEqual(MotionSignature(2), MotionSignature(2))
        self.assertNotEqual(MotionSignature(2), MotionSignature(3))
        self.assertEqual(MotionSignature(3).axes, 3)
        self.assertEqual(repr(MotionSignature(2)), "MotionSignature(2)")
        self.assertEqual(MotionSignature(2).members["step"], Out(2))
        self.assertEqual(MotionSignature(2).members["dir"], Out(2))

    def test_motion_wrong(self):
        with self.assertRaisesRegex(TypeError, r"^Axis count must be a positive integer, not 0$"):
            MotionSignature(0)
        with self.assertRaisesRegex(TypeError,
                r"^Axis count must be a positive integer, not True$"):
            MotionSignature(True)

    def test_feed(self):
        feed = FeedSignature()
        self.assertEqual(feed, FeedSignature())
        self.assertEqual(repr(feed), "FeedSignature()")
        self.assertEqual(feed.members["tick"], In(1))
        self.assertEqual(feed.members["due"], Out(1))
        self.assertEqual(feed.members["diagonal"], Out(1))

    def test_status_layout(self):
        layout = StatusLayout(axes=3, position_width=10, number_width=4)
        self.assertEqual((layout.axes, layout.position_width, layout.number_width), (3, 10, 4))
        self.assertEqual(layout.size, 4 + 2 + 30)
        self.assertEqual(layout["outcome"].shape, Outcome)
        self.assertEqual(repr(layout),
                         "StatusLayout(axes=3, position_width=10, number_width=4)")

    def test_status_layout_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^Position width must be an integer of at least 2, not 1$"):
            StatusLayout(position_width=1)
        with self.assertRaisesRegex(TypeError,
                r"^Command number width must be a positive integer, not 0$"):
            StatusLayout(number_width=0)
        with self.assertRaisesRegex(TypeError, r"^Axis count must be a positive integer, not -1$"):
            StatusLayout(axes=-1)

    def test_engine(self):
        signature = EngineSignature(FRAME, position_width=9)
        self.assertEqual(signature, EngineSignature(FRAME, position_width=9))
        self.assertNotEqual(signature, EngineSignature(FRAME, position_width=10))
        self.assertNotEqual(signature, EngineSignature(data.StructLayout({"x": 8}),
                                                       position_width=9))
        self.assertEqual(signature.frame, FRAME)
        self.assertEqual((signature.axes, signature.position_width, signature.number_width),
                         (2, 9, 8))
        self.assertEqual(signature.members["cmd"], In(stream.Signature(FRAME)))
        self.assertEqual(signature.members["feed"], Out(FeedSignature()))
        self.assertEqual(signature.members["motion"], Out(MotionSignature(2)))
        self.assertEqual(signature.members["status"],
                         Out(stream.Signature(StatusLayout(position_width=9))))
        self.assertRegex(repr(signature), r"^EngineSignature\(StructLayout\(.*\), axes=2, "
                                          r"position_width=9, number_width=8\)$")

    def test_engine_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^Frame layout must be a data layout, not unsigned\(8\)$"):
            EngineSignature(unsigned(8))

    def test_motion_and_feed_connect(self):
        engine = registry.make_engine("line", width=8)
        stage = StepDirStage(dir_setup=1, step_width=1)
        feed = FeedDivider(3)
        m = Module()
        m.submodules += [engine, stage, feed]
        wiring.connect(m, engine.motion, stage.i)
        wiring.connect(m, engine.feed, feed.feed)
        Fragment.get(m, None)


class StatusUnitTestCase(unittest.TestCase):
    """The status unit against its model, clock by clock, with random events and stalls."""

    def test_against_model(self):
        rng = random.Random(4)
        dut = StatusUnit(position_width=6, number_width=3)
        model = StatusModel(position_width=6, number_width=3)

        async def testbench(ctx):
            accepted = outcomes = 0
            for clock in range(3000):
                # Commands end now and then, never while an outcome waits (the contract);
                # steps come only while one runs and nothing waits.
                running = model.inflight > 0 and not model.hold
                end = int(running and rng.random() < 0.3)
                inputs = {"step": rng.randrange(4) if running else 0,
                          "direction": rng.randrange(4), "end": end,
                          "outcome": rng.choice([DONE, REFUSED]),
                          "status_ready": int(rng.random() < 0.6)}
                flush = int(rng.random() < 0.02)
                accept = int(model.inflight < 2 and not model.flushing and not flush
                             and rng.random() < 0.5)
                expected = model.evaluate(**inputs)
                ctx.set(dut.motion.step, inputs["step"])
                ctx.set(dut.motion.dir, inputs["direction"])
                ctx.set(dut.end, end)
                ctx.set(dut.outcome, Outcome(inputs["outcome"]))
                ctx.set(dut.status.ready, inputs["status_ready"])
                ctx.set(dut.accept, accept)
                ctx.set(dut.flush, flush)
                for name in ("hold", "idle", "busy", "flushing"):
                    self.assertEqual(ctx.get(getattr(dut, name)), getattr(model, name),
                                     f"clock {clock}: {name}")
                self.assertEqual(ctx.get(dut.status.valid), expected["valid"], f"clock {clock}")
                if expected["valid"]:
                    payload = ctx.get(dut.status.payload)
                    got = [payload.number, payload.outcome.value,
                           [payload.position[0], payload.position[1]]]
                    self.assertEqual(got, expected["payload"], f"clock {clock}")
                outcomes += expected["transfer"]
                accepted += accept
                model.advance(accept=accept, flush=flush)
                await ctx.tick()
            self.assertGreater(accepted, 300)
            self.assertGreater(outcomes, 300)

        simulate(dut, testbench, name="status_unit")


def feed_engines():
    """``(label, engine factory, model factory)`` of every registered variant, narrow."""
    for kind in registry.KINDS:
        for name in registry.variants(kind):
            yield (f"{kind} {name}", lambda k=kind, n=name: registry.make_engine(k, n, width=8),
                   lambda k=kind, n=name: registry.make_model(k, n, width=8))


FRAMES = {"line": [{"x": 7, "y": 3}, {"x": -5, "y": 12}, {"x": 0, "y": 0}, {"x": 300, "y": 0},
                   {"x": -40, "y": -1}, {"x": 13, "y": -13}, {"x": 0, "y": -9}],
          "arc": [{"x0": 9, "y0": 0, "x1": 9, "y1": 0, "cw": 0},
                  {"x0": 0, "y0": 0, "x1": 0, "y1": 0, "cw": 0},
                  {"x0": -5, "y0": 3, "x1": 3, "y1": 5, "cw": 1},
                  {"x0": 4, "y0": -4, "x1": -4, "y1": -4, "cw": 1}],
          "profile": _profile_frames()}

#: Every registered variant, one test case each (named ``kind-variant``, for ``-k``).
EVERY_VARIANT = pytest.mark.parametrize(
    "label, make_engine, make_model", list(feed_engines()),
    ids=[label.replace(" ", "-") for label, _, _ in feed_engines()])


def run_both(label, make_engine, make_model, job):
    kind = label.split()[0]
    expected = run_model(make_model(), job)
    actual = run_amaranth(make_engine(), job)
    assert first_difference(expected, actual) is None, label
    return kind, actual


# What every engine promises, checked on every registered variant.

@EVERY_VARIANT
def test_feed_permission_and_next_step_kind(label, make_engine, make_model):
    # A step is made in exactly the clocks where the permission meets a due step, and the
    # due step's kind was shown before it (in that same clock at the latest).
    rng = random.Random(9)
    tick = [int(rng.random() < 0.4) for _ in range(89)]
    kind = label.split()[0]
    job = Job(frames=FRAMES[kind], tick=tick)
    _, record = run_both(label, make_engine, make_model, job)
    steps = 0
    for entry in record:
        if entry["rst"]:
            continue
        permitted = entry["due"] and tick[entry["cycle"] % len(tick)]
        assert bool(entry["step"]) == bool(permitted), (label, entry["cycle"])
        if entry["step"]:
            assert (entry["step"] == 0b11) == bool(entry["diagonal"]), (label, entry["cycle"])
            steps += 1
    assert steps > 20, label


@EVERY_VARIANT
def test_outcomes_under_back_pressure(label, make_engine, make_model):
    # The status stream stalls at random; no outcome is lost, numbers count up, positions
    # are the moves made, and the steps are those of the commands traced.
    rng = random.Random(3)
    stalls = [int(rng.random() < 0.3) for _ in range(53)]
    kind = label.split()[0]
    frames = FRAMES[kind] * 2
    _, record = run_both(label, make_engine, make_model, Job(frames=frames, status_ready=stalls))
    outcomes = record_outcomes(record)
    assert [number for _, number, _, _ in outcomes] == list(range(len(frames)))
    expected = [(DONE if outcome == 0 else REFUSED,
                 [sum(dx for dx, _ in path), sum(dy for _, dy in path)])
                for outcome, path in registry.outcomes(kind, frames, label.split()[1], width=8)]
    assert [(outcome, position) for _, _, outcome, position in outcomes] == expected, label


@EVERY_VARIANT
def test_abort(label, make_engine, make_model):
    # Aborts in the middle of commands: no step in an abort clock, the running command
    # reports where it stopped, the waiting ones end with no step, and the engine goes on
    # with the commands offered after.
    kind = label.split()[0]
    frames = FRAMES[kind] * 2
    job = Job(frames=frames, aborts={25: 1, 60: 3, 140: 1, 141: 1})
    _, record = run_both(label, make_engine, make_model, job)
    for entry in record:
        if not entry["rst"] and entry["cycle"] in (25, 60, 61, 62, 140, 141):
            assert entry["step"] == 0, (label, entry["cycle"])
    outcomes = record_outcomes(record)
    aborted = [o for o in outcomes if o[2] == ABORTED]
    assert len(aborted) >= 2, label
    moved = [position for _, _, outcome, position in outcomes if outcome != REFUSED]
    assert [sum(p[0] for p in moved), sum(p[1] for p in moved)] == \
        [sum(dx for dx, _ in record_steps(record)), sum(dy for _, dy in record_steps(record))], \
        label


class EngineContractTestCase(unittest.TestCase):
    def test_check_outcomes_catches(self):
        record = run_model(registry.make_model("line", width=8), Job(frames=FRAMES["line"]))
        last = max(i for i, entry in enumerate(record) if not entry["rst"] and entry["status"])
        lost = [dict(entry, status=None) if i == last else entry
                for i, entry in enumerate(record)]
        with self.assertRaisesRegex(AssertionError, r"^the command accepted in clock \d+ has no "
                                                    r"outcome$"):
            check_outcomes(lost)
        extra = [dict(entry, accepted=0) for entry in record]
        with self.assertRaisesRegex(AssertionError, r"^clock \d+: an outcome with no command$"):
            check_outcomes(extra)

    def test_scoreboard_names_the_first_difference(self):
        # The cocotb benches' check, clock by clock: the model's own outputs pass, one output
        # changed fails, naming the clock and the output with (model, rtl).
        from kontur.sim.testbench import Scoreboard
        model = registry.make_model("line", width=8)
        board = Scoreboard(registry.make_model("line", width=8))
        board.check(0, {"rst": 1}, None)
        model.reset()
        inputs = {"rst": 0, "valid": 1, "payload": {"x": 5, "y": 2}, "tick": 1, "abort": 0,
                  "status_ready": 1}
        for cycle in range(1, 4):
            outputs, _ = model.cycle(valid=1, payload=inputs["payload"], tick=1, abort=0,
                                     status_ready=1)
            board.check(cycle, inputs, dict(outputs))
        outputs, _ = model.cycle(valid=1, payload=inputs["payload"], tick=1, abort=0,
                                 status_ready=1)
        wrong = dict(outputs, step=1 - outputs["step"])
        with self.assertRaisesRegex(AssertionError, rf"^clock 4: \(model, rtl\) "
                                                    rf"{{'step': \({outputs['step']}, "
                                                    rf"{wrong['step']}\)}}$"):
            board.check(4, inputs, wrong)


@EVERY_VARIANT
def test_every_engine_has_the_signature(label, make_engine, make_model):
    engine = make_engine()
    assert isinstance(engine.signature, EngineSignature), label
    assert engine.signature.frame.size == engine.cmd.payload.shape().size
    Fragment.get(engine, None)           # and it elaborates


if __name__ == "__main__":
    unittest.main()
