"""The tool outputs' Verilog on Icarus and Verilator: every pin in every clock against the model.

One ``@cocotb.test`` drives the random commands, laser mode, rates, halts and spindle
overrides of :func:`tests.test_tools.random_clocks` and compares the five pins with
:class:`~kontur.sim.models.tools.ToolOutputsModel` clock for clock. The pytest function at the
bottom builds the component once per simulator and runs it through cocotb's Python runner.
"""

import random

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ReadOnly, RisingEdge, Timer

from kontur.hdl.motion.tools import Spindle, ToolCommand, ToolOutputs
from kontur.sim.models.tools import ToolOutputsModel
from kontur.sim.runners import CocotbBuild

from .conftest import cocotb_build_root, selected_simulators
from .test_tools import PINS, random_clocks

S_MAX, PERIOD = 1000, 97


@cocotb.test()
async def random_tool_commands(dut):
    """Random commands, laser mode, rates, halts, spindle overrides: the pins equal the
    model's in every clock, and the PWM is seen high."""
    layout = ToolCommand(S_MAX)
    clocks = random_clocks(random.Random(5), PERIOD, S_MAX, 40 * PERIOD)
    model = ToolOutputsModel(s_max=S_MAX, period=PERIOD)
    Clock(dut.clk, 10, unit="ns").start(start_high=False)
    await Timer(1, unit="ns")
    dut.rst.value = 1
    for name in ("cmd__valid", "cmd__payload", "laser", "rate", "cruise", "halt"):
        getattr(dut, name).value = 0
    dut.spindle_override.value = 128
    await RisingEdge(dut.clk)
    await RisingEdge(dut.clk)
    dut.rst.value = 0
    high = 0
    for k, clock in enumerate(clocks):
        cmd = clock.get("cmd")
        dut.cmd__valid.value = int(cmd is not None)
        if cmd is not None:
            dut.cmd__payload.value = layout.const(
                {**cmd, "spindle": Spindle(cmd["spindle"])}).as_value().value
        for name in ("laser", "rate", "cruise", "halt"):
            getattr(dut, name).value = clock.get(name, 0)
        dut.spindle_override.value = clock.get("spindle_override", 128)
        await ReadOnly()
        got = {name: int(getattr(dut, name).value) for name in PINS}
        got["ready"] = int(dut.cmd__ready.value)
        want = model.cycle(**clock)
        assert got == want, f"clock {k}: {got} != {want}"
        high += got["pwm"]
        await RisingEdge(dut.clk)
    assert high > 0


@pytest.mark.cocotb
@pytest.mark.parametrize("simulator", selected_simulators())
def test_tool_outputs(simulator):
    build = CocotbBuild(ToolOutputs(s_max=S_MAX, period=PERIOD), simulator, cocotb_build_root())
    assert build.test(__name__) == 1
