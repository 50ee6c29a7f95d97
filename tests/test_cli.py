# amaranth: UnusedElaboratable=no
"""The ``kontur`` command line, run as a program: output format, engines, refusals, waveforms."""

import os
import shutil
import subprocess
import sys

import pytest

from kontur.sim.models.arc import arc_steps
from kontur.sim.models.linear import steps
from kontur.sim.runners import verilator_environment
from kontur.waves import sample_vcd

from .conftest import selected_simulators
from .utils import BUILD_DIR


def kontur(*args):
    return subprocess.run([sys.executable, "-m", "kontur.cli", *map(str, args)],
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


# ---- reliability: what a CNC or verification engineer relies on ---------------------------

def kontur_env(**env):
    """``kontur`` as a process with extra environment (for instance a fresh build root)."""
    import os
    return dict(os.environ, **env)


def _interruptible():
    # As from a terminal: SIGINT at its default, whatever the test worker inherited (a
    # process started with SIGINT ignored keeps ignoring it, and Python then never raises
    # KeyboardInterrupt).
    import signal
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start(*args, env=None):
    return subprocess.Popen([sys.executable, "-m", "kontur.cli", *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, preexec_fn=_interruptible)


@pytest.mark.cocotb
@pytest.mark.parametrize("simulator", selected_simulators())
def test_concurrent_runs_on_a_fresh_build(simulator, tmp_path):
    # Several runs of the same kind, variant and width at once, the build not made yet: each
    # prints its own command's steps, exactly the model's.
    arcs = [(5, 0, -3, 4), (0, -7, 0, -7), (6, -1, 1, 6), (-4, -3, 3, -4)]
    env = kontur_env(KONTUR_BUILD=str(tmp_path))
    runs = [start("trace", "arc", *arc, "--engine", simulator, "--variant", "fast", env=env)
            for arc in arcs]
    for arc, run in zip(arcs, runs):
        stdout, stderr = run.communicate(timeout=600)
        assert run.returncode == 0, stderr
        assert stdout == expected_lines(arc_steps(*arc)), arc
    (build,) = (tmp_path / simulator).iterdir()             # one build, shared
    assert not list((build / "runs").iterdir())             # every run cleaned up after it
    if simulator == "verilator" and shutil.which("ccache"):
        # Verilator's runtime compiled through ccache (runners.verilator_environment)
        log = (build / "build.log").read_text().splitlines()
        assert any(line.startswith("ccache ") and "verilated.cpp" in line for line in log)


def test_verilator_builds_use_ccache_unless_told(monkeypatch):
    for name in ("PATH", "VERILATOR_ROOT"):                 # restored after the test
        monkeypatch.setenv(name, os.environ.get(name, ""))
    monkeypatch.setattr(shutil, "which", lambda name: f"/usr/bin/{name}")
    monkeypatch.delenv("OBJCACHE", raising=False)
    verilator_environment()
    assert os.environ["OBJCACHE"] == "ccache"
    monkeypatch.setenv("OBJCACHE", "")                      # set, even empty: kept
    verilator_environment()
    assert os.environ["OBJCACHE"] == ""
    monkeypatch.delenv("OBJCACHE")
    monkeypatch.setattr(shutil, "which", lambda name: None)  # no ccache: none
    verilator_environment()
    assert "OBJCACHE" not in os.environ


def test_full_circle_of_a_million_on_the_model():
    run = kontur("trace", "arc", 1_000_000, 0, 1_000_000, 0)
    assert run.returncode == 0, run.stderr
    x, y, r2 = 1_000_000, 0, 10 ** 12
    count = 0
    worst = 0
    for line in run.stdout.splitlines():
        dx, dy = map(int, line.split())
        assert abs(dx) <= 1 and abs(dy) <= 1 and (dx or dy)
        x, y = x + dx, y + dy
        count += 1
        if count % 97 == 0:                                 # radial error, sampled
            worst = max(worst, abs((x * x + y * y) ** 0.5 - 1_000_000))
    assert (x, y) == (1_000_000, 0)                         # closed, to the step
    assert count > 4 * 1_000_000
    assert worst < 0.5


@pytest.mark.cocotb
def test_full_circle_of_100000_on_rtl():
    # A radius beyond 17 bits, one step per clock the whole way round.
    simulator = "verilator" if "verilator" in selected_simulators() else "icarus"
    r = 100_000
    run = kontur("trace", "arc", r, 0, r, 0, "--engine", simulator, "--variant", "fast",
                 "--cycles")
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert [tuple(map(int, line.split()[1:])) for line in lines] == arc_steps(r, 0, r, 0)
    clocks = [int(line.split()[0]) for line in lines]
    assert clocks == list(range(clocks[0], clocks[0] + len(clocks)))   # one step per clock


def test_runs_beyond_the_limits_are_refused_up_front():
    run = kontur("trace", "arc", 16_000_000, 0, 16_000_000, 0, "--cycles")
    assert run.returncode == 2 and run.stdout == ""
    reason = run.stderr.splitlines()[-1]
    assert reason.startswith("kontur: this arc needs up to ") and "--max-clocks" in reason
    run = kontur("trace", "line", 65535, 3, "--engine", "amaranth", "--max-clocks", "100")
    assert run.returncode == 2 and "more than the 100 that --engine amaranth" in run.stderr
    run = kontur("trace", "line", 5, 3, "--max-clocks", "0")
    assert run.returncode == 2 and "--max-clocks must be a positive integer, not 0" in run.stderr


def test_positional_given_as_a_double_dash_is_a_usage_error():
    # Found by test_cli_fuzz: argparse leaves Y1 an empty list here, not a converted word.
    run = kontur("trace", "arc", 0, 0, 0, "--", "--")
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.splitlines()[-1].endswith("argument Y1: expected an integer")


@pytest.mark.parametrize("width", ["0", "1", "-5", "65", "1000000", "x"])
def test_bad_width(width):
    run = kontur("trace", "line", 1, 1, "--width", width)
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.splitlines()[-1].startswith("kontur: ")


def test_bad_vcd_is_refused_before_anything_runs(tmp_path):
    env = kontur_env(KONTUR_BUILD=str(tmp_path / "builds"))
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    cases = {str(tmp_path / "no" / "such" / "dir" / "a.vcd"): "no directory",
             "": "--vcd needs a file name",
             str(tmp_path): "is a directory"}
    import os
    if os.geteuid() != 0:                                   # root may write anywhere
        cases[str(locked / "a.vcd")] = "not writable"
    for engine in ("icarus", "verilator", "amaranth"):
        for vcd, reason in cases.items():
            run = subprocess.run([sys.executable, "-m", "kontur.cli", "trace", "line", "3",
                                  "1", "--engine", engine, "--vcd", vcd], capture_output=True,
                                 text=True, env=env, timeout=60)
            assert run.returncode == 2 and run.stdout == "", (engine, vcd)
            assert reason in run.stderr.splitlines()[-1], (engine, vcd, run.stderr)
    assert not (tmp_path / "builds").exists()               # nothing was built


@pytest.mark.cocotb
def test_interrupt_stops_everything(tmp_path):
    import os
    import signal
    import time
    if "verilator" not in selected_simulators():
        pytest.skip("needs Verilator selected (SIM)")       # a compile to interrupt
    env = kontur_env(KONTUR_BUILD=str(tmp_path))
    run = start("trace", "arc", 9, 0, 9, 0, "--engine", "verilator", env=env)
    deadline = time.monotonic() + 120
    while not list(tmp_path.glob("verilator/*/Vtop.mk")):   # the C++ compile is under way
        assert run.poll() is None and time.monotonic() < deadline, run.stderr.read()
        time.sleep(0.2)
    time.sleep(1)
    run.send_signal(signal.SIGINT)                          # to kontur alone, not its group
    stdout, stderr = run.communicate(timeout=60)
    assert run.returncode == 130
    assert stdout == "" and stderr.strip().splitlines() == ["kontur: interrupted"]
    time.sleep(1)
    ps = subprocess.run(["ps", "-eo", "args"], capture_output=True, text=True).stdout
    assert str(tmp_path) not in ps                          # no compiler left running
    again = start("trace", "arc", 9, 0, 9, 0, "--engine", "verilator", env=env)
    stdout, stderr = again.communicate(timeout=600)
    assert again.returncode == 0, stderr                    # and the next run builds afresh
    assert stdout == expected_lines(arc_steps(9, 0, 9, 0))
