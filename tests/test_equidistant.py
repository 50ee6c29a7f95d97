# amaranth: UnusedElaboratable=no
"""The equidistant engine's RTL: its parts, and against the cycle model clock for clock."""

import random
import unittest

from amaranth import Fragment, Module
from amaranth.lib import wiring

from kontur.hdl.circular import FaithfulArcCore, FastArcCore
from kontur.hdl.engine import EngineSignature
from kontur.hdl.equidistant import (SETTLE, EquidistantEngine, Formats, Kind,
                                   SerialMultiplier)
from kontur.hdl.motion import FeedDivider, StepDirStage
from kontur.hdl.linear import LinearCore
from kontur import registry
from kontur.gcode import read
from kontur.sim.models import equidistant as model
from kontur.sim.models.circular import FaithfulArcCoreModel, FastArcCoreModel
from kontur.sim.models.engine import ABORTED, DONE, REFUSED
from kontur.sim.runners import run_amaranth
from kontur.sim.stimulus import (Job, first_difference, record_moves, record_outcomes,
                                 record_steps, run_model)

from .test_equidistant_model import load
from .utils import simulate, used

WIDTH = 8
ARROW = """G0 X0 Y60
G42 G1 X90 Y60
G1 X90 Y15
G1 X180 Y90
G1 X90 Y165
G1 X90 Y120
G1 X15 Y135
G1 X0 Y60
"""
CORES = {"fast": (FastArcCore, FastArcCoreModel),
         "faithful": (FaithfulArcCore, FaithfulArcCoreModel)}


def program(name, r, *, treatment="extend", side=None, width=WIDTH):
    return list(model.prepare(load(name, side), r, treatment=treatment,
                              formats=model.Formats(width)).frames)


def compare(testcase, job, variant="fast", width=WIDTH, label=""):
    rtl_core, model_core = CORES[variant]
    expected = run_model(model.EquidistantEngineModel(model_core(width=width + 2)), job)
    actual = run_amaranth(EquidistantEngine(rtl_core(width=width + 2)), job)
    testcase.assertIsNone(first_difference(expected, actual), label)
    return actual


class PartsTestCase(unittest.TestCase):
    def test_parameters_wrong(self):
        line_core = LinearCore(width=8)
        with self.assertRaisesRegex(TypeError, r"^Core must be a component with an "
                                               r"ArcCoreSignature, not <kontur\.hdl\.linear\.LinearCore "
                                               r"object at 0x[0-9a-f]+>$"):
            EquidistantEngine(line_core)
        narrow = FastArcCore(width=5)
        with self.assertRaisesRegex(TypeError, r"^Core width must be an integer of at least 6, "
                                               r"not 5$"):
            EquidistantEngine(narrow)
        core = FastArcCore(width=10)
        with self.assertRaisesRegex(TypeError, r"^Fractional bits must be an integer of at "
                                               r"least 2, not 1$"):
            EquidistantEngine(core, fraction=1)
        with self.assertRaisesRegex(TypeError, r"^Coordinate width must be an integer of at "
                                               r"least 4, not 2$"):
            Formats(2)
        with self.assertRaisesRegex(TypeError, r"^Multiplicand width must be a positive "
                                               r"integer, not 0$"):
            SerialMultiplier(0, 4)
        with self.assertRaisesRegex(TypeError, r"^Multiplier width must be a positive integer, "
                                               r"not 0$"):
            SerialMultiplier(4, 0)
        used(line_core, narrow, core)

    def test_signature_and_frame(self):
        engine = EquidistantEngine(FastArcCore(width=WIDTH + 2))
        self.assertIsInstance(engine.signature, EngineSignature)
        self.assertEqual(engine.signature.position_width, WIDTH + 3)
        self.assertEqual(engine.formats, Formats(WIDTH))
        self.assertEqual(repr(engine.formats), "Formats(width=8, fraction=12)")
        self.assertEqual((engine.width, engine.coord_width), (WIDTH, WIDTH + 1))
        names = [name for name, _ in EquidistantEngine.Frame(engine.formats)]
        self.assertEqual(tuple(names), model._FRAME_FIELDS)
        self.assertEqual({name: getattr(Kind, name.upper()) for name in model.KIND},
                         model.KIND)
        f = model.Formats(WIDTH)
        widths = {"k": f.coefficient, "b": f.intercept, "sec": f.coefficient, "x": WIDTH + 1,
                  "e": f.square, "g": f.intercept, "ek": f.coefficient, "eb": f.intercept}
        layout = EquidistantEngine.Frame(engine.formats)
        for name, width in widths.items():
            self.assertEqual(layout[name].shape.width, width, name)
        Fragment.get(engine, None)

    def test_serial_multiplier(self):
        dut = SerialMultiplier(7, 5)
        rng = random.Random(1)
        cases = [(0, 0), (127, 31), (1, 31), (127, 1)] + [(rng.randrange(128), rng.randrange(32))
                                                          for _ in range(20)]

        async def testbench(ctx):
            for a, b in cases:
                ctx.set(dut.a, a)
                ctx.set(dut.b, b)
                ctx.set(dut.start, 1)
                await ctx.tick()
                ctx.set(dut.start, 0)
                clocks = 0
                while not ctx.get(dut.done):
                    self.assertEqual(ctx.get(dut.busy), 1)
                    await ctx.tick()
                    clocks += 1
                self.assertEqual(clocks, 5)           # b_width clocks, done in the next
                self.assertEqual(ctx.get(dut.product), a * b, (a, b))
                await ctx.tick()
                self.assertEqual((ctx.get(dut.done), ctx.get(dut.product)), (0, a * b))

        simulate(dut, testbench, name="serial_multiplier")


class AgainstModelTestCase(unittest.TestCase):
    """The RTL against the cycle model, every output in every clock."""

    def test_programs_both_cores(self):
        for name, treatment, side in (("square", "extend", "other"), ("pie", "arc", None),
                                      ("lens", "extend", None), ("zigzag", "arc", "other"),
                                      ("bite", "extend", None)):
            frames = program(name, 2, treatment=treatment, side=side)
            for variant in CORES:
                record = compare(self, Job(frames=frames, max_cycles=50_000), variant,
                                 label=(name, variant))
                self.assertEqual(record_steps(record),
                                 registry.steps("profile", frames, variant, width=WIDTH))

    def test_feed_stalls_gaps_and_aborts(self):
        rng = random.Random(7)
        frames = program("polygon", 1, treatment="arc") + program("rounded", 3)
        for variant in CORES:
            tick = [int(rng.random() < 0.6) for _ in range(41)]
            ready = [int(rng.random() < 0.7) for _ in range(29)]
            tick[0] = ready[0] = 1
            gaps = [rng.choice([0, 0, 1, 6]) for _ in frames]
            record = compare(self, Job(frames=frames, tick=tick, status_ready=ready, gaps=gaps,
                                       aborts={150: 1, 151: 1}, max_cycles=50_000), variant)
            outcomes = [outcome for _, _, outcome, _ in record_outcomes(record)]
            self.assertIn(ABORTED, outcomes)
            self.assertIn(REFUSED, outcomes)          # the rest of the aborted contour
            self.assertEqual(outcomes[-len(program("rounded", 3)):],
                             [DONE] * len(program("rounded", 3)))

    def test_refusals(self):
        square = program("square", 2)
        frames = [square[2], {"kind": 6}, {"kind": Kind.RADIUS, "x": -3}, *square]
        record = compare(self, Job(frames=frames))
        outcomes = [outcome for _, _, outcome, _ in record_outcomes(record)]
        self.assertEqual(outcomes, [REFUSED] * 3 + [DONE] * len(square))

    def test_lines_follow_lines_with_settling_clocks(self):
        # Each element here lasts longer than the forming of a frame (2·width + 10 clocks),
        # so from the first step to the last there is a step in every SETTLE + 1 clocks
        # (block 11's registered test settles for SETTLE clocks after each), and twice that
        # from the last step of an element to the first of the next (its end at the point,
        # the shift).
        arrow = model.profile_from_moves(read(ARROW).moves)
        cases = [program("square", 1), program("square", 1, side="other"),
                 list(model.prepare(arrow, 2, formats=model.Formats(WIDTH)).frames)]
        for frames in cases:
            record = compare(self, Job(frames=frames))
            moves = [e["cycle"] for e in record if not e["rst"] and e["step"]]
            gaps = [b - a for a, b in zip(moves, moves[1:])]
            traced = [f for f in frames if f["kind"] in (Kind.LINE, Kind.ARC)
                      and not f.get("last")]
            self.assertEqual(set(gaps), {SETTLE + 1, 2 * (SETTLE + 1)})
            self.assertEqual(gaps.count(2 * (SETTLE + 1)), len(traced) - 1)
            self.assertGreater(len(moves), 100)

    def test_close_returns_by_a_staircase(self):
        # An open contour, then CLOSE: the engine returns from the contour's end to its start
        # by sign steps (both axes while both are away), ending where it began.
        frames = program("zigzag", 2) + [{"kind": Kind.CLOSE}]
        for variant in CORES:
            record = compare(self, Job(frames=frames, max_cycles=50_000), variant)
            outcomes = record_outcomes(record)
            self.assertEqual([outcome for _, _, outcome, _ in outcomes], [DONE] * len(frames))
            contour_end = outcomes[-2][0]           # the terminal's outcome, then CLOSE's
            moves = record_moves(record)
            self.assertEqual((sum(dx for _, dx, _ in moves), sum(dy for _, _, dy in moves)),
                             (0, 0))                 # back at the start
            returned = [(dx, dy) for cycle, dx, dy in moves if cycle > contour_end]
            rx, ry = (sum(d[axis] for d in returned) for axis in (0, 1))
            self.assertEqual(tuple(outcomes[-1][3]), (rx, ry))
            # Sign steps: both axes while both are away, so max(|rx|, |ry|) steps.
            self.assertGreater(len(returned), 10)
            self.assertEqual(len(returned), max(abs(rx), abs(ry)))

    def test_one_program_several_radii(self):
        frames = program("rounded", 0)
        body = frames[2:]
        job = []
        for r in (0, 2, 5):
            start = model.prepare(load("rounded"), r, formats=model.Formats(WIDTH)).start
            job += [{"kind": Kind.RADIUS, "x": r}, {"kind": Kind.START, "x": start[0],
                                                    "y": start[1]}, *body]
        record = compare(self, Job(frames=job, max_cycles=50_000))
        self.assertEqual(record_steps(record), registry.steps("profile", job, width=WIDTH))


class InterfaceTestCase(unittest.TestCase):
    def test_engine_of_the_common_interface(self):
        engine = registry.make_engine("profile", width=WIDTH)
        stage = StepDirStage(dir_setup=1, step_width=1)
        feed = FeedDivider(3)
        m = Module()
        m.submodules += [engine, stage, feed]
        wiring.connect(m, engine.motion, stage.i)
        wiring.connect(m, engine.feed, feed.feed)
        Fragment.get(m, None)


if __name__ == "__main__":
    unittest.main()
