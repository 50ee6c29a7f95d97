# amaranth: UnusedElaboratable=no
"""``kontur trace profile FILE --radius R``, run as a program: output, engines, refusals."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

from kontur import registry
from kontur.gcode import read
from kontur.sim.models.equidistant import Formats, prepare, profile_from_moves
from kontur.waves import sample_vcd

from .conftest import selected_simulators
from .utils import BUILD_DIR

PROGRAMS = Path(__file__).resolve().parent / "programs"


def kontur(*args):
    return subprocess.run([sys.executable, "-m", "kontur.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=900)


def model_steps(name, r, *, width=registry.KINDS["profile"].default_width, treatment="extend",
                detection="normal"):
    """The steps of a test program by the model's functions (no command line)."""
    shape = profile_from_moves(read((PROGRAMS / f"{name}.ngc").read_text()).moves)
    prepared = prepare(shape, r, treatment=treatment, detection=detection,
                       formats=Formats(width))
    return registry.steps("profile", list(prepared.frames), width=width)


def lines(steps):
    return "".join(f"{dx} {dy}\n" for dx, dy in steps)


def test_output_is_the_steps_only():
    run = kontur("trace", "profile", PROGRAMS / "rounded.ngc", "--radius", 4)
    assert run.returncode == 0, run.stderr
    assert run.stdout == lines(model_steps("rounded", 4))
    steps = [tuple(map(int, line.split())) for line in run.stdout.splitlines()]
    assert all(abs(dx) <= 1 and abs(dy) <= 1 and (dx or dy) for dx, dy in steps)
    assert (sum(dx for dx, _ in steps), sum(dy for _, dy in steps)) == (0, 0)   # closed
    assert run.stderr == ""


def test_options_change_the_path():
    plain = kontur("trace", "profile", PROGRAMS / "polygon.ngc", "--radius", 3).stdout
    rounded = kontur("trace", "profile", PROGRAMS / "polygon.ngc", "--radius", 3, "--corner",
                     "arc").stdout
    seed = kontur("trace", "profile", PROGRAMS / "triangle.ngc", "--radius", 1, "--detect",
                  "seed", "--width", "12").stdout
    assert rounded == lines(model_steps("polygon", 3, treatment="arc")) != plain
    assert seed == lines(model_steps("triangle", 1, width=12, detection="seed"))
    radii = {r: kontur("trace", "profile", PROGRAMS / "square.ngc", "--radius", r).stdout
             for r in (0, 2, 5)}
    assert [len(text.splitlines()) for text in radii.values()] == \
        [4 * (40 - 2 * r) for r in radii]


def test_cycles_on_the_model_and_amaranth():
    model = kontur("trace", "profile", PROGRAMS / "pie.ngc", "--radius", 2, "--cycles",
                   "--width", "10")
    rtl = kontur("trace", "profile", PROGRAMS / "pie.ngc", "--radius", 2, "--cycles",
                 "--width", "10", "--engine", "amaranth", "--variant", "faithful")
    fast = kontur("trace", "profile", PROGRAMS / "pie.ngc", "--radius", 2, "--cycles",
                  "--width", "10", "--engine", "amaranth")
    assert model.returncode == rtl.returncode == 0, rtl.stderr
    assert [line.split()[1:] for line in rtl.stdout.splitlines()] == \
        [line.split()[1:] for line in model.stdout.splitlines()]
    assert fast.stdout == model.stdout                   # the default variant: fast
    clocks = [int(line.split()[0]) for line in model.stdout.splitlines()]
    assert clocks == sorted(clocks) and len(set(clocks)) == len(clocks)


def test_waveform_and_plot():
    vcd = BUILD_DIR / "waves" / "profile_amaranth.vcd"
    png = BUILD_DIR / "waves" / "profile.png"
    vcd.parent.mkdir(parents=True, exist_ok=True)
    run = kontur("trace", "profile", PROGRAMS / "lens.ngc", "--radius", 1, "--width", "10",
                 "--engine", "amaranth", "--vcd", vcd, "--plot", png)
    assert run.returncode == 0, run.stderr
    clocks = sample_vcd(vcd, {"step": "engine.motion__step"})
    assert sum(1 for c in clocks if c["step"]) == len(run.stdout.splitlines())
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("args, reason", [
    (["--radius", 30, PROGRAMS / "pie.ngc"],
     r"kontur: refused: line 5: the cutter \(radius 30\) is too large for the concave corner "
     r"at \(50, 0\) between lines 4 and 5: their equidistants do not meet"),
    (["--radius", 9, PROGRAMS / "triangle.ngc"],
     r"kontur: refused: line 4: the cutter \(radius 9\) is too large: the equidistant of this "
     r"segment would run backwards between its corners"),
    (["--radius", 2, PROGRAMS / "square.ngc", "--width", "5"],
     r"kontur: refused: line 4: the end \(40, 0\) is beyond the 5-bit registers \(at most "
     r"31\)"),
    (["--radius", -1, PROGRAMS / "square.ngc"],
     r"kontur: --radius must be a non-negative integer, not -1"),
    (["--radius", 1, PROGRAMS / "nothing.ngc"],
     r"kontur: .*nothing\.ngc: No such file or directory"),
    (["--radius", 1, PROGRAMS / "square.ngc", "--vcd", "x.vcd"],
     r"kontur: --vcd needs an RTL engine \(amaranth, icarus or verilator\)"),
    (["--radius", 1, PROGRAMS / "square.ngc", "--engine", "amaranth", "--max-clocks", "10"],
     r"kontur: this contour needs up to \d+ clocks, more than the 10 that --engine amaranth "
     r"traces \(.*\); raise --max-clocks to run it anyway"),
])
def test_refusals(args, reason):
    run = kontur("trace", "profile", *args)
    assert run.returncode == 2
    assert run.stdout == ""
    assert re.fullmatch(reason, run.stderr.splitlines()[-1]), run.stderr


def test_bad_program_names_the_line(tmp_path):
    program = tmp_path / "bad.ngc"
    program.write_text("G90\nG41 G1 X10\nG1 E4\n")
    run = kontur("trace", "profile", program, "--radius", 1)
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.splitlines()[-1] == f"kontur: {program}:3: unknown word E4"
    program.write_text("G90\nG1 X10\n")
    run = kontur("trace", "profile", program, "--radius", 1)
    assert run.returncode == 2
    assert run.stderr.splitlines()[-1] == ("kontur: refused: no compensated moves (G41 or G42 "
                                           "with G1, G2 or G3) in the program")
    run = kontur("trace", "profile", program)
    assert run.returncode == 2 and "the following arguments are required: --radius" in \
        run.stderr


@pytest.mark.cocotb
@pytest.mark.parametrize("simulator", selected_simulators())
def test_every_engine_traces_the_same(simulator):
    args = ["trace", "profile", PROGRAMS / "bite.ngc", "--radius", 2, "--width", "8",
            "--corner", "arc", "--cycles"]
    model = kontur(*args)
    rtl = kontur(*args, "--engine", simulator)
    assert model.returncode == 0 and rtl.returncode == 0, rtl.stderr
    assert rtl.stdout == model.stdout
    assert len(model.stdout.splitlines()) > 100


def test_clock_bound_holds_on_a_long_contour():
    # `kontur trace profile` stops an RTL run at _profile_clocks' bound: on a square of 2000
    # steps a side (block 11's settling clock after every step doubles the clocks of the
    # steps) the cycle model ends well inside it, on both cores.
    from kontur.sim.stimulus import Job, run_model
    from kontur.trace import _profile_clocks
    text = "G90\nG0 X0 Y0\nG41 G1 X2000 Y0\nG1 X2000 Y2000\nG1 X0 Y2000\nG1 X0 Y0\nG40\nM30\n"
    shape = profile_from_moves(read(text).moves)
    prepared = prepare(shape, 2, formats=Formats(16))
    for variant in registry.variants("profile"):
        bound, steps = _profile_clocks(prepared, registry.step_clocks("profile", variant, 16))
        record = run_model(registry.make_model("profile", variant, width=16),
                           Job(frames=list(prepared.frames), max_cycles=bound))
        assert steps > 7000
        assert max(e["cycle"] for e in record) < bound
