# amaranth: UnusedElaboratable=no
"""The whole machine controller on Icarus and Verilator, end to end over its serial pin.

A host coroutine sends a planned program's frames with ``cocotbext-uart`` (keeping at most
the queue's length unanswered), a monitor records the step/dir pins every clock, and the
checks compare them with the golden models: the exact step sequence, the final position, the
direction set-up and the pulse widths, the acceleration limit, a corrupt frame rejected and
never executed, and the queue never overflowing under the flow control.
"""

import math
import os
from collections import namedtuple
from fractions import Fraction

import cocotb
import pytest

from kontur.hdl.motion.controller import MotionController
from kontur.hdl.motion.inputs import pin_levels
from kontur.hdl.motion.link import ERROR, OUTCOME, STATUS
from kontur import registry
from kontur.hdl.motion import protocol
from kontur.machine import Machine
from kontur.planner import frames as program_frames
from kontur.planner import lattice, plan
from kontur.sim.runners import CocotbBuild
from kontur.sim.testbench.hostlink import run_cocotb, steps_of

from .conftest import cocotb_build_root, selected_simulators

MACHINE = Machine(steps_per_mm=10, clock_hz=1e6, baud=125_000, dir_setup_us=1,
                  step_width_us=2, accel=2e5, max_feed=90_000, junction_deviation=0.05,
                  arc_tolerance=0.2, queue_frames=8)
#: The engines of the iCEBreaker's controller (its variants and widths, line then arc), at
#: this machine's clock.
VARIANTS, WIDTHS = zip(registry.BOARDS["icebreaker"].line, registry.BOARDS["icebreaker"].arc)
Move = namedtuple("Move", "line kind start end centre cw feed", defaults=(None, False, 60_000))


def controller():
    return MotionController(line=registry.make_engine("line", VARIANTS[0], width=WIDTHS[0]),
                            arc=registry.make_engine("arc", VARIANTS[1], width=WIDTHS[1]),
                            clock_hz=MACHINE.clock_hz, baud=MACHINE.baud,
                            queue_frames=MACHINE.queue_frames, dir_setup=MACHINE.dir_setup,
                            step_width=MACHINE.step_width)


def part():
    """A plate with a rounded corner and a hole: lines, arcs, a full circle, two feeds."""
    f = Fraction
    return [
        Move(1, "line", (0, 0), (20, 0)),
        Move(2, "line", (20, 0), (20, 10), feed=30_000),
        Move(3, "arc", (20, 10), (15, 15), centre=(15, 10), cw=False),
        Move(4, "line", (15, 15), (0, 15)),
        Move(5, "rapid", (0, 15), (f(45, 10), f(75, 10))),
        Move(6, "arc", (f(45, 10), f(75, 10)), (f(45, 10), f(75, 10)), centre=(f(75, 10),
                                                                             f(75, 10)), cw=True),
        Move(7, "line", (f(45, 10), f(75, 10)), (0, 0), feed=45_000),
    ]


async def run_program(dut, frames, *, query=False, schedule=(), applied=None):
    """Reset, send ``frames`` with the window flow control, record every clock's pins until
    all are answered (and then, with ``query``, until the reply to a QUERY); return
    ``(levels, moves, replies)``: the pins each clock, ``(clock, dx, dy)`` at each rising step
    edge, the replies. ``schedule``: the switch pins' events (``applied`` gets them as
    applied)."""
    levels = []
    result = await run_cocotb(dut, frames + ([protocol.query()] if query else []),
                              divisor=round(MACHINE.clock_hz / MACHINE.baud),
                              window=MACHINE.queue_frames, max_clocks=3_000_000, levels=levels,
                              schedule=schedule)
    if applied is not None:
        applied += result.applied
    moves = [(clock, dx, dy) for (clock, _, _), (dx, dy) in zip(result.steps,
                                                                steps_of(result))]
    return levels, moves, [reply for _, reply in result.replies]


def check_timing(levels, moves):
    """Pulse widths, direction set-up, and the acceleration limit on the pins."""
    setup, width = MACHINE.dir_setup, MACHINE.step_width
    for axis in range(2):
        level = [(s >> axis) & 1 for s, _ in levels]
        ways = [(d >> axis) & 1 for _, d in levels]
        for c in range(1, len(level) - width):
            if level[c] and not level[c - 1]:
                assert level[c:c + width + 1] == [1] * width + [0], f"pulse at {c}"
                assert len(set(ways[c - setup:c + width])) == 1, f"dir moves at {c}"
    # The contour rate between steps changes by at most the acceleration (with the
    # accumulator's quantisation: one clock in an interval).
    accel = MACHINE.accel_q40 / (1 << 40)
    for (c0, *s0), (c1, *s1), (c2, *s2) in zip(moves, moves[1:], moves[2:]):
        l1 = math.sqrt(2) if all(s1) else 1
        l2 = math.sqrt(2) if all(s2) else 1
        t1, t2 = c1 - c0, c2 - c1
        change = abs(l2 / t2 - l1 / t1)
        assert change <= accel * (t1 + t2) + 1.5 * l2 / (t2 * (t2 - 1)), (c1, change)


def planned():
    segments = lattice(part(), MACHINE, variants=VARIANTS, widths=WIDTHS)
    frames, _ = program_frames(segments, plan(segments, MACHINE), MACHINE)
    return segments, frames


@cocotb.test()
async def part_program(dut):
    segments, frames = planned()
    levels, moves, replies = await run_program(dut, frames, query=True)
    assert [(dx, dy) for _, dx, dy in moves] == [s for seg in segments for s in seg.steps]
    end = (sum(dx for _, dx, _ in moves), sum(dy for _, _, dy in moves))
    assert end == segments[-1].end == (0, 0)
    outcomes = [r.fields for r in replies if r.kind == OUTCOME]
    assert outcomes == [(n, 0) for n in range(len(frames))]
    assert not [r for r in replies if r.kind == ERROR]          # no overflow, no error
    status = [r.fields for r in replies if r.kind == STATUS][-1]
    assert status[:3] == (0, 0, MACHINE.queue_frames)
    check_timing(levels, moves)


@cocotb.test()
async def corrupt_frame(dut):
    segments, frames = planned()
    index = 2 + 2 * 3                                           # the fourth move (line 4)
    bad = bytearray(frames[index])
    bad[-1] ^= 0x01                                             # its CRC
    frames[index] = bytes(bad)
    _, moves, replies = await run_program(dut, frames)
    errors = [r.fields for r in replies if r.kind == ERROR]
    assert errors == [(1,)]
    moves = [(dx, dy) for _, dx, dy in moves]
    skipped = segments[3]
    assert moves == [s for seg in segments if seg is not skipped for s in seg.steps]


@cocotb.test()
async def estop_mid_arc(dut):
    # The e-stop pressed half-way through the first arc (line 3, by the plan's times): no
    # rising step edge later than the bound (the filter, 1 clock here, the synchroniser's 2,
    # and 1 for cocotb's driver, which sets the pins a clock after the host decides), every
    # pulse whole, every frame after the running one ABORTED (or REFUSED, once in ALARM), the
    # position read back the steps made, ALARM with the e-stop as its cause.
    segments, frames = planned()
    items = plan(segments, MACHINE)
    seconds = items[0].seconds + items[1].seconds + items[2].seconds / 2
    estop = pin_levels(["estop"])
    applied = []
    levels, moves, replies = await run_program(
        dut, frames, query=True, schedule=[(round(seconds * MACHINE.clock_hz), ("pins", estop))],
        applied=applied)
    made = [(dx, dy) for _, dx, dy in moves]
    program = [s for seg in segments for s in seg.steps]
    assert made == program[:len(made)]
    before = len(segments[0].steps) + len(segments[1].steps)
    assert before < len(made) < before + len(segments[2].steps)
    (trip, _), = applied
    assert moves[-1][0] <= trip + 1 + 2 + 1, (moves[-1][0], trip)
    outcomes = [r.fields[1] for r in replies if r.kind == OUTCOME]
    first = outcomes.index(2)
    assert set(outcomes[:first]) == {0} and set(outcomes[first:]) <= {1, 2}
    status = [r for r in replies if r.kind == STATUS][-1]
    assert status.fields[:2] == (sum(dx for dx, _ in made), sum(dy for _, dy in made))
    assert (status.state, status.fields[5], status.fields[6]) == ("ALARM", 1, 1)
    check_timing(levels, moves)


@pytest.mark.cocotb
@pytest.mark.parametrize("simulator", selected_simulators())
def test_controller(simulator):
    build = CocotbBuild(controller(), simulator, cocotb_build_root())
    build.test(__name__)
