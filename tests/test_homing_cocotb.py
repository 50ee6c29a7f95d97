# amaranth: UnusedElaboratable=no
"""A homing cycle through the controller's Verilog on Icarus or Verilator (issue 25): the
switch pin driven from a schedule (the RTL runs' harnesses drive the pins from a schedule, not
from the position), every pass ending on it, the position set by the approach."""

import pytest

from kontur.hdl.motion import protocol
from kontur.hdl.motion.controller import MotionController
from kontur.hdl.motion.homing import home_frame, homing_row
from kontur.hdl.motion.inputs import INPUTS
from kontur import registry

from .conftest import cocotb_build_root, selected_simulators

RATE = round(0.05 * (1 << 24))                   # a step every 20 clocks


def controller():
    return MotionController(line=registry.make_engine("line", width=12),
                            arc=registry.make_engine("arc", "fast", width=12),
                            clock_hz=1e6, baud=250_000, dir_setup=1, step_width=2,
                            queue_frames=8, engines=[homing_row()])


@pytest.mark.cocotb
@pytest.mark.parametrize("simulator", selected_simulators())
def test_homing_pass_on_the_switch(simulator):
    dut = controller()
    feed = protocol.feed(RATE, RATE, (1 << 24) - 1)
    frames = [protocol.config((1 << 32) - 1), feed, home_frame(0, True, True, 1000), feed,
              home_frame(0, False, False, 100), home_frame(0, True, True, 100, 11),
              protocol.query()]
    idle = dut.idle_inputs
    pressed = idle ^ (1 << INPUTS.index("limit_x"))
    # The switch closes 200 clocks after the first step, opens at 1500, closes at 2500 (the
    # back-off's HOME frame comes over the serial line some 900 clocks after the first step).
    closes, opens, again = 200, 1500, 2500
    schedule = [(closes, ("pins", pressed)), (opens, ("pins", idle)), (again, ("pins", pressed))]
    if simulator == "verilator":
        from kontur.sim.fastrun import FastRun
        run = FastRun(dut, cocotb_build_root() / "fastrun-homing").run(
            frames, divisor=4, window=8, max_clocks=20_000, schedule=schedule)
    else:
        from kontur.sim.runners import CocotbBuild
        run = CocotbBuild(dut, simulator, cocotb_build_root(), quiet=True).run_controller(
            frames, divisor=4, window=8, max_clocks=20_000, schedule=schedule, idle=idle)
    replies = [reply for _, reply in run.replies]
    assert [r.fields[1] for r in replies if r.kind == 0x80] == [0] * 6     # every pass DONE
    (status,) = [r for r in replies if r.kind == 0x81]
    # The approach ended on the switch and set X to 11: no step after it.
    assert (status.fields[:2], status.state) == ((11, 0), "IDLE")
    clocks = [clock for clock, _, _ in run.steps]
    ways = [direction & 1 for _, _, direction in run.steps]
    first = clocks[0]
    # Seek (negative) until the switch, back off (positive) until it opens, approach
    # (negative): the directions change exactly twice, near the switch's changes.
    changes = [i for i in range(1, len(ways)) if ways[i] != ways[i - 1]]
    assert ways[0] == 1 and len(changes) == 2
    # Each pass's last step at most a step before the switch changed, or after it by no more
    # than the latency: the pass sees the pin F + 2 = 3 clocks after it changed (the filter
    # and the synchroniser; a clock more on Icarus, whose driver sets the pins a clock late),
    # and a step permitted before then still reaches the step pin, dir_setup + 1 clocks later.
    # Where in it a step falls depends on the steps' phase (a clock's shift of the feed
    # generator's timing, issue 27, moved Icarus's back-off step from 1486 to 1505).
    late = 3 + (simulator == "icarus") + 1 + 1
    assert closes - 20 <= clocks[changes[0] - 1] - first <= closes + late
    assert opens - 20 <= clocks[changes[1] - 1] - first <= opens + late
    assert again - 20 <= clocks[-1] - first <= again + late
