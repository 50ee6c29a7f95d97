# amaranth: UnusedElaboratable=no
"""Waveform regression: the RTL's dump, reduced to a per-clock trace, against golden traces.

The patents' worked tables are read back from the RTL's VCD and compared with goldens
transcribed from the patents. The named scenarios of :data:`kontur.waves.SCENARIOS` run on
Amaranth's simulator, Icarus and Verilator; each simulator's own dump gives the same trace, the
golden ``tests/golden/<scenario>.trace`` (reviewed, see docs/formal.md), and the engine's
outputs in it are the golden cycle model's. A broken core changes the trace, and the failure
names the first clock and signal that differ.
"""

import os
import unittest

import pytest

from amaranth.sim import Simulator

from kontur.hdl.circular import CircularInterpolator
from kontur import registry
from kontur.sim.models.circular import core_inputs, f4_initial, floor_f
from kontur.sim.models.codes import from_code, mask, ones_decode
from kontur.sim.runners import run_amaranth
from kontur.sim.stimulus import Job
from kontur.sim.stimulus import first_difference, run_model
from kontur.waves import (GTKW_VIEWS, SCENARIOS, check_trace, gtkw_view, sample_vcd,
                       scenario_job, scenario_trace)

from .broken import literal_transfer_core, opposite_tie_core
from .conftest import cocotb_build_root, selected_simulators
from .utils import BUILD_DIR

GOLDEN = BUILD_DIR.parent / "tests" / "golden"


class LinearTableWaveTestCase(unittest.TestCase):
    def test_patent_table_from_vcd(self):
        width = 16
        vcd = BUILD_DIR / "waves" / "su1571551_table.vcd"
        vcd.parent.mkdir(parents=True, exist_ok=True)
        run_amaranth(registry.make_engine("line", "device", width=width),
                     Job(frames=[{"x": 7, "y": 3}]), vcd=vcd)
        core = "core.interpolator"
        clocks = sample_vcd(vcd, {"step": "engine.motion__step", "f": f"{core}.adder3.q",
                                  "addend": f"{core}.mux12.o", "c1": f"{core}.counter1.q_next",
                                  "c2": f"{core}.counter2.q_next"})
        rows = []
        for clock in clocks:
            if not clock["step"]:
                continue
            move = "D" if clock["step"] == 0b11 else "P"
            # F after the step: adder 3 plus the multiplexer's code it adds in this clock,
            # plus the half that max = 7 leaves in F0 (adder 3 holds ⌊F⌋).
            f = from_code(clock["f"] + clock["addend"], width + 1) + 0.5
            c1 = from_code(clock["c1"], width + 1)
            c2 = from_code(clock["c2"], width + 1) + 1      # counter 2 holds C2 - 1
            rows.append([move, f, c1, c2])
        check_trace(GOLDEN / "su1571551_table.trace", ["move", "F", "C1", "C2"], rows)


class CircularTable2WaveTestCase(unittest.TestCase):
    def test_table_2_from_vcd(self):
        width = 24
        aw, cw = width + 4, width + 1
        dut = CircularInterpolator(width=width)
        in29, in30, in31, in34 = core_inputs(12, 0, floor_f(f4_initial(12, 0, 144)))

        async def testbench(ctx):
            ctx.set(dut.tick, 1)
            for port, value in ((dut.in29, in29), (dut.in30, in30), (dut.in31, in31),
                                (dut.in34, in34), (dut.in33, 1)):
                ctx.set(port, value)
            await ctx.tick()
            ctx.set(dut.in33, 0)
            await ctx.tick().until(dut.done)
            await ctx.tick()

        vcd = BUILD_DIR / "waves" / "su1665343_table2.vcd"
        vcd.parent.mkdir(parents=True, exist_ok=True)
        sim = Simulator(dut)
        sim.add_clock(1e-6)
        sim.add_testbench(testbench)
        with sim.write_vcd(str(vcd)):
            sim.run()

        clocks = sample_vcd(vcd, {"step": "step", "sign": "adder1.sign", "f": "adder1.q",
                                  "ct7": "counter7.q", "ct8": "counter8.q",
                                  "code": "commutator6.o", "strobe": "commutator6.strobe",
                                  "busy": "trigger4.q", "done": "done"})
        columns = {"move": [], "CT7": [], "CT8": [], "code": [], "F": []}

        def keep(name, value):
            if not columns[name] or columns[name][-1] != value:
                columns[name].append(value)

        for clock in clocks[1:]:                      # from the clock after the start
            if clock["step"]:
                move = {1: "X", 2: "Y", 3: "D"}[clock["step"]]
                columns["move"].append(move + ("-" if clock["sign"] else "+"))
            keep("CT7", from_code(clock["ct7"], cw))
            keep("CT8", ones_decode(clock["ct8"], cw))
            keep("F", ones_decode(clock["f"], aw) + 0.75)
            if clock["strobe"]:
                code = clock["code"]
                columns["code"].append("-0" if code == mask(aw) else ones_decode(code, aw))
            if clock["done"]:
                break
        rows = [[name, *values] for name, values in columns.items()]
        check_trace(GOLDEN / "su1665343_table2.trace", ["column", "values"], rows)


def _trace(name, simulator, core=None, tag=""):
    scenario = SCENARIOS[name]
    vcd = BUILD_DIR / "waves" / f"{name}{tag}_{simulator}.vcd"
    return scenario_trace(scenario, simulator, vcd, core=core, build_root=cocotb_build_root())


def _check_scenario(name, simulator):
    scenario = SCENARIOS[name]
    record, columns, rows = _trace(name, simulator)
    model = registry.make_model(scenario.kind, scenario.variant, width=scenario.width)
    expected = run_model(model, scenario_job(scenario))
    difference = first_difference(expected, record)
    assert difference is None, f"{name} on {simulator}: {difference}"
    check_trace(GOLDEN / f"{name}.trace", columns, rows)


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_scenario_amaranth(name):
    _check_scenario(name, "amaranth")


@pytest.mark.cocotb
@pytest.mark.parametrize("simulator", selected_simulators())
@pytest.mark.parametrize("name", list(SCENARIOS))
def test_scenario_cocotb(name, simulator):
    _check_scenario(name, simulator)


def test_opposite_tie_changes_the_trace():
    # (4, 2) starts with F = 0: eq. (1) steps along X alone, the broken core diagonally.
    _, columns, rows = _trace("line_exact_back_to_back", "amaranth",
                              core=opposite_tie_core(8), tag="_opposite_tie")
    with pytest.raises(AssertionError, match=r"differs at row 3 \(clock 3\), signal step: "
                                             r"golden 01, trace 11"):
        check_trace(GOLDEN / "line_exact_back_to_back.trace", columns, rows)


def test_literal_transfer_changes_the_trace():
    # R = 10: the diagonal from (8, 6) lands on X = Y; the commutator passes -2 (the literal
    # reading) where the built core passes -1, three clocks after that step.
    _, columns, rows = _trace("arc_faithful_switch_x_eq_y", "amaranth",
                              core=literal_transfer_core(8), tag="_literal")
    with pytest.raises(AssertionError, match=r"differs at row \d+ \(clock \d+\), signal A: "
                                             r"golden 0, trace "):
        check_trace(GOLDEN / "arc_faithful_switch_x_eq_y.trace", columns, rows)


@pytest.mark.parametrize("view", list(GTKW_VIEWS))
def test_gtkw_view(view):
    # The saved view in docs/ is the one generated from the traced columns, and every signal
    # it names is in a dump of that core (by the same hierarchical name on every simulator).
    path = BUILD_DIR.parent / "docs" / f"{view}.gtkw"
    text = gtkw_view(view)
    if os.environ.get("UPDATE_GOLDEN") == "1":
        path.write_text(text)
    assert path.read_text() == text, f"{path} is stale: rerun with UPDATE_GOLDEN=1"
    scenario = {"linear": "line_exact_back_to_back", "circular_faithful":
                "arc_faithful_switch_x_eq_y", "circular_fast": "arc_fast_switch_x_eq_y",
                "separate_line": "line_separate_back_to_back",
                "separate_arc": "arc_separate_quadrant_crossing",
                "dda": "line_dda_back_to_back", "serial_line": "line_serial_back_to_back",
                "serial_arc": "arc_serial_quadrant_crossing"}[view]
    _trace(scenario, "amaranth", tag="_view")
    vcd = BUILD_DIR / "waves" / f"{scenario}_view_amaranth.vcd"
    names = [line.split("[")[0] for line in text.splitlines()
             if line.startswith("engine.")]
    clocks = sample_vcd(vcd, {name: name for name in names})
    assert clocks and set(clocks[0]) == set(names)


if __name__ == "__main__":
    unittest.main()
