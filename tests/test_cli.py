"""The ``kontur`` command line, run as a program: output format, engines, refusals, waveforms."""

import subprocess
import sys

import pytest

from sim.models.arc import arc_steps
from sim.models.linear import steps
from sim.waves import sample_vcd

from .conftest import selected_simulators
from .utils import BUILD_DIR


def kontur(*args):
    return subprocess.run([sys.executable, "-m", "sim.host.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=600)


def expected_lines(path):
    return "".join(f"{dx} {dy}\n" for dx, dy in path)


def test_trace_line_model_output_is_steps_only():
    run = kontur("trace", "line", 7, -3)
    assert run.returncode == 0, run.stderr
    assert run.stdout == expected_lines(steps(7, -3))


def test_trace_line_variants_and_width():
    run = kontur("trace", "line", -64, 62, "--variant", "device", "--width", "8")
    assert run.returncode == 0, run.stderr
    assert run.stdout == expected_lines(steps(-64, 62, variant="device", width=8))


def test_trace_line_cycles():
    run = kontur("trace", "line", 3, 2, "--cycles")
    assert run.returncode == 0
    lines = run.stdout.splitlines()
    assert [tuple(map(int, line.split()[1:])) for line in lines] == steps(3, 2)
    assert [int(line.split()[0]) for line in lines] == [3, 4, 5]   # one step per clock


def test_trace_line_zero_length():
    run = kontur("trace", "line", 0, 0)
    assert run.returncode == 0 and run.stdout == ""


@pytest.mark.parametrize("engine", ["model", "amaranth"])
def test_trace_line_refused(engine):
    run = kontur("trace", "line", 65536, 1, "--engine", engine)
    assert run.returncode == 2
    assert run.stdout == ""
    assert "|X| = 65536 is too wide for the 16-bit registers (at most 65535)" in run.stderr


def test_trace_line_does_not_fit_frame():
    run = kontur("trace", "line", 1 << 40, 0, "--engine", "amaranth")
    assert run.returncode == 2 and run.stdout == ""
    assert "does not fit the frame's 32-bit signed coordinates" in run.stderr


def test_trace_line_amaranth_vcd():
    vcd = BUILD_DIR / "waves" / "cli_amaranth.vcd"
    vcd.parent.mkdir(parents=True, exist_ok=True)
    run = kontur("trace", "line", -5, 9, "--engine", "amaranth", "--vcd", vcd)
    assert run.returncode == 0, run.stderr
    assert run.stdout == expected_lines(steps(-5, 9))
    clocks = sample_vcd(vcd, {"step": "engine.motion__step"})
    assert sum(1 for c in clocks if c["step"]) == 9


def test_bad_usage():
    run = kontur("trace", "line", 1, 1, "--engine", "spice")
    assert run.returncode == 2 and "invalid choice" in run.stderr
    run = kontur("trace", "line", 1, 1, "--vcd", "x.vcd")
    assert run.returncode == 2 and "--vcd needs an RTL engine" in run.stderr


@pytest.mark.cocotb
@pytest.mark.parametrize("simulator", selected_simulators())
def test_trace_line_cocotb(simulator):
    vcd = BUILD_DIR / "waves" / f"cli_{simulator}.vcd"
    vcd.parent.mkdir(parents=True, exist_ok=True)
    run = kontur("trace", "line", 11, -4, "--engine", simulator, "--cycles", "--vcd", vcd)
    assert run.returncode == 0, run.stderr
    model = kontur("trace", "line", 11, -4, "--cycles")
    assert run.stdout == model.stdout
    clocks = sample_vcd(vcd, {"step": "motion__step", "dir": "motion__dir"})
    moves = [(i, c["step"], c["dir"]) for i, c in enumerate(clocks) if c["step"]]
    assert [m[0] for m in moves] == [int(line.split()[0]) for line in run.stdout.splitlines()]
    refused = kontur("trace", "line", 1, -70000, "--engine", simulator)
    assert refused.returncode == 2 and refused.stdout == ""
    assert "refused by the RTL" in refused.stderr


def test_trace_arc_model():
    run = kontur("trace", "arc", 5, 0, -3, 4)
    assert run.returncode == 0, run.stderr
    assert run.stdout == expected_lines(arc_steps(5, 0, -3, 4))
    run = kontur("trace", "arc", 5, 0, -3, 4, "--cw", "--variant", "fast")
    assert run.stdout == expected_lines(arc_steps(5, 0, -3, 4, cw=True))


def test_trace_arc_full_circle_and_cycles():
    run = kontur("trace", "arc", 0, -7, 0, -7, "--cycles")
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert [tuple(map(int, line.split()[1:])) for line in lines] == arc_steps(0, -7, 0, -7)
    fast = kontur("trace", "arc", 0, -7, 0, -7, "--cycles", "--variant", "fast").stdout
    clocks = [int(line.split()[0]) for line in fast.splitlines()]
    assert clocks == list(range(clocks[0], clocks[0] + len(clocks)))   # one step per clock


@pytest.mark.parametrize("engine", ["model", "amaranth"])
def test_trace_arc_refused(engine):
    run = kontur("trace", "arc", 4, 0, 2, 4, "--engine", engine)
    assert run.returncode == 2 and run.stdout == ""
    assert "is not on the circle through the start point" in run.stderr
    run = kontur("trace", "arc", 0, 0, 1, 1, "--engine", engine, "--variant", "fast")
    assert run.returncode == 2 and "radius R = 0" in run.stderr
    run = kontur("trace", "arc", 300, 0, 300, 0, "--width", "8", "--engine", engine)
    assert run.returncode == 2 and "too wide for the 8-bit registers" in run.stderr


def test_trace_arc_amaranth():
    for variant in ("faithful", "fast"):
        run = kontur("trace", "arc", -2, 3, 3, 2, "--cw", "--engine", "amaranth", "--cycles",
                     "--variant", variant)
        model = kontur("trace", "arc", -2, 3, 3, 2, "--cw", "--cycles", "--variant", variant)
        assert run.returncode == 0, run.stderr
        assert run.stdout == model.stdout


@pytest.mark.cocotb
@pytest.mark.parametrize("simulator", selected_simulators())
def test_trace_arc_cocotb(simulator):
    vcd = BUILD_DIR / "waves" / f"cli_arc_{simulator}.vcd"
    vcd.parent.mkdir(parents=True, exist_ok=True)
    for variant in ("faithful", "fast"):
        run = kontur("trace", "arc", 6, -1, 6, -1, "--engine", simulator, "--cycles",
                     "--variant", variant, "--vcd", vcd)
        assert run.returncode == 0, run.stderr
        assert run.stdout == kontur("trace", "arc", 6, -1, 6, -1, "--cycles",
                                    "--variant", variant).stdout
        clocks = sample_vcd(vcd, {"step": "motion__step"})
        assert [i for i, c in enumerate(clocks) if c["step"]] == \
            [int(line.split()[0]) for line in run.stdout.splitlines()]
    refused = kontur("trace", "arc", 4, 0, 2, 4, "--engine", simulator)
    assert refused.returncode == 2 and "refused by the RTL" in refused.stderr
