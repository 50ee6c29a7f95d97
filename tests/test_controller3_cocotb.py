# amaranth: UnusedElaboratable=no
"""The 3-axis machine controller (issue 28) on Icarus and Verilator, end to end over its serial
pin, as ``test_controller_cocotb.py`` runs the 2-axis one: a planned program of lines in XYZ
and helices (``kontur.planner.lattice(axes=3)``), its frames (LINE3, HELIX) sent with the
window flow control, the step/dir pins recorded every clock, and checked against the golden
models (the spatial line core's and the helix's steps, which ``tests/test_spatial.py`` and
``tests/test_helix.py`` hold against geometry): the exact step sequence on X, Y and Z, the final
position read back (STATUS of 24 bytes), every pulse's width and direction set-up on the three
axes, and the contour rate's change within the acceleration with steps of 1, √2 and √3.
"""

import math
from collections import namedtuple
from fractions import Fraction

import cocotb
import pytest

from kontur.hdl.helix import HelixEngine
from kontur.hdl.line import LineEngine
from kontur.hdl.motion.controller import MotionController
from kontur.hdl.motion.link import ERROR, OUTCOME, STATUS
from kontur.hdl.spatial import SpatialLineCore
from kontur import registry
from kontur.hdl.motion import protocol
from kontur.planner import frames as program_frames
from kontur.planner import lattice, plan, step_length
from kontur.sim.runners import CocotbBuild
from kontur.sim.testbench.hostlink import run_cocotb, steps_of

from .conftest import cocotb_build_root, selected_simulators
from .test_controller_cocotb import MACHINE

#: The ULX3S's engines (line width 16, arc variant and width), at this machine's clock.
BOARD = registry.BOARDS["ulx3s"]
Move = namedtuple("Move", "line kind start end centre cw feed z",
                  defaults=(None, False, 60_000, None))


def controller():
    return MotionController(line=LineEngine(SpatialLineCore(width=BOARD.line[1], axes=3)),
                            arc=HelixEngine(registry.make_engine("arc", BOARD.arc[0],
                                                                 width=BOARD.arc[1])),
                            clock_hz=MACHINE.clock_hz, baud=MACHINE.baud,
                            queue_frames=MACHINE.queue_frames, dir_setup=MACHINE.dir_setup,
                            step_width=MACHINE.step_width)


def part():
    """A pocket's entry and a contour at depth: a plunge, a helix down, lines in XYZ, a
    helical half turn up (10 steps/mm)."""
    f = Fraction
    return [
        Move(1, "rapid", (0, 0), (10, 0), z=f(2)),
        Move(2, "line", (10, 0), (10, 0), z=f(1, 2), feed=30_000),
        Move(3, "arc", (10, 0), (10, 0), centre=(5, 0), cw=True, z=f(-1)),
        Move(4, "line", (10, 0), (15, 4), z=f(-3, 2)),
        Move(5, "arc", (15, 4), (5, 4), centre=(10, 4), cw=False, z=f(-1, 2)),
        Move(6, "line", (5, 4), (0, 0), z=f(2), feed=45_000),
    ]


def planned():
    segments = lattice(part(), MACHINE, variants=(BOARD.line[0], BOARD.arc[0]),
                       widths=(BOARD.line[1], BOARD.arc[1]), axes=3)
    frames, _ = program_frames(segments, plan(segments, MACHINE), MACHINE)
    return segments, frames


@cocotb.test()
async def part_program(dut):
    segments, frames = planned()
    levels = []
    result = await run_cocotb(dut, frames + [protocol.query()],
                              divisor=round(MACHINE.clock_hz / MACHINE.baud),
                              window=MACHINE.queue_frames, max_clocks=3_000_000, levels=levels)
    moves = [(clock, *step) for (clock, _, _), step in zip(result.steps, steps_of(result, 3))]
    replies = [reply for _, reply in result.replies]
    assert [tuple(step) for _, *step in moves] == [s for seg in segments for s in seg.steps]
    assert sum(1 for _, _, _, dz in moves if dz) > 40         # Z moves, on lines and helices
    outcomes = [r.fields for r in replies if r.kind == OUTCOME]
    assert outcomes == [(n, 0) for n in range(len(frames))]
    assert not [r for r in replies if r.kind == ERROR]
    status = [r for r in replies if r.kind == STATUS][-1]
    assert status.position == segments[-1].end == (0, 0, 20)
    assert status.fields[2] == MACHINE.queue_frames
    # Pulse widths and direction set-up on every axis, Z's too.
    setup, width = MACHINE.dir_setup, MACHINE.step_width
    for axis in range(3):
        level = [(s >> axis) & 1 for s, _ in levels]
        ways = [(d >> axis) & 1 for _, d in levels]
        for c in range(1, len(level) - width):
            if level[c] and not level[c - 1]:
                assert level[c:c + width + 1] == [1] * width + [0], f"axis {axis} pulse at {c}"
                assert len(set(ways[c - setup:c + width])) == 1, f"axis {axis} dir at {c}"
    # The contour rate between steps (each 1, √2 or √3 long) changes by at most the
    # acceleration (with the accumulator's quantisation: one clock in an interval).
    accel = MACHINE.accel_q40 / (1 << 40)
    for (c0, *s0), (c1, *s1), (c2, *s2) in zip(moves, moves[1:], moves[2:]):
        l1, l2 = step_length(s1), step_length(s2)
        t1, t2 = c1 - c0, c2 - c1
        change = abs(l2 / t2 - l1 / t1)
        assert change <= accel * (t1 + t2) + 1.5 * l2 / (t2 * (t2 - 1)), (c1, change)


@pytest.mark.cocotb
@pytest.mark.parametrize("simulator", selected_simulators())
def test_controller3(simulator):
    build = CocotbBuild(controller(), simulator, cocotb_build_root())
    build.test(__name__)
