# amaranth: UnusedElaboratable=no
"""``kontur run``'s resources and limits (issue 23): the time compression the step timing, the
acceleration's field and the link keep; the work estimated before any step is computed; a
long program drawn in bounded time; each run's outputs in a folder of their own; bad outputs
and inputs refused with status 2 and one line before anything runs. All on the model: cheap."""

import json
import math
import re

import pytest

from kontur import registry
from kontur import machining
from kontur.cli import main
from kontur.machine import Machine, MachineError
from kontur.machining import prepare
from kontur.planner import ProgramError

CLOCK = registry.board("icebreaker").clock_hz

#: One long line at one feed: its cruise is the programmed feed.
LINE = "G21 G90\nG1 X50 Y0 F1200\n"


def zigzag(lines):
    """A program of ``lines`` lines: columns of zig-zag G1 lines 0.25 mm wide in a 40 mm
    square, every tenth move a half circle (G3 by I J), a G0 to the next column."""
    out = ["G21 G90", "G0 X0 Y0", "F1200"]
    base, x, y, n = 0.0, 0.0, 0.0, 0
    while len(out) < lines:
        n += 1
        if y > 40:
            base += 0.5
            x, y = base, 0.0
            out.append(f"G0 X{x:.3f} Y{y:.3f}")
        elif n % 10 == 0:
            out.append(f"G3 X{x:.3f} Y{y + 0.1:.3f} I0 J0.05")
            y += 0.1
        else:
            x = base + 0.25 if x == base else base
            y += 0.05
            out.append(f"G1 X{x:.3f} Y{y:.3f}")
    return "\n".join(out) + "\n"


def refused(capsys, argv):
    """Run the command line; assert status 2 and one line on standard error, no traceback;
    return the line."""
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert status == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.fixture
def program(tmp_path):
    def write(text, name="part.ngc", mode="w"):
        path = tmp_path / name
        (path.write_bytes if mode == "wb" else path.write_text)(text)
        return path
    return write


# ---- 1. time compression ----------------------------------------------------------------

def test_compression_beyond_the_step_timing_refused_with_the_largest(program, tmp_path, capsys):
    """``--compress 10**12`` is refused on the model (as on every engine) with the largest
    value allowed; that value keeps the feed's step rate within the step/dir timing (a step
    every dir_setup + step_width + 1 clocks, from the machine's microseconds and the board's
    clock) and one more does not; it runs."""
    path = program(LINE)
    line = refused(capsys, ["run", path, "--compress", 10 ** 12, "--out", tmp_path / "o"])
    largest = int(re.search(r"at most (\d+)", line).group(1))
    spacing = math.ceil(1e-6 * CLOCK) + math.ceil(2e-6 * CLOCK) + 1       # dir 1 us, step 2 us
    steps_per_s = 1200 / 60 * 80
    assert largest * steps_per_s <= CLOCK / spacing < (largest + 1) * steps_per_s * 1.001
    assert main(["run", str(path), "--compress", str(largest), "--out",
                 str(tmp_path / "o")]) == 0
    refused(capsys, ["run", path, "--compress", largest + 1, "--out", tmp_path / "o"])


def test_compression_beyond_the_link_refused(program, tmp_path, capsys):
    """Many tiny moves: the frames (15 + 1 + 10 bytes of FEED and LINE, 10 bits a byte at
    115 200 baud) take longer to send than the motion lasts at a compression of 64: refused,
    the link named."""
    moves = "".join(f"G1 X{(i % 2) * 0.05:.2f} Y{i * 0.05:.2f}\n" for i in range(1, 200))
    line = refused(capsys, ["run", program("G21 G90 F3000\n" + moves), "--compress", 64,
                            "--out", tmp_path / "o"])
    assert "link" in line


def test_frames_never_clamp_a_field():
    """A rate beyond FEED's 24 bits and a compressed acceleration beyond CONFIG's 32 bits are
    refused, not clamped to the field's largest value."""
    machine = Machine(clock_hz=CLOCK)
    with pytest.raises(MachineError):
        machine.rate(CLOCK / machine.steps_per_mm)         # one step a clock: 2**24
    job = prepare(LINE)
    big = math.isqrt((1 << 32) // machine.accel_q40) + 1     # its square times accel > 2**32
    with pytest.raises(ProgramError):
        job.frames(big)
    with pytest.raises(ProgramError):
        job.frames(10 ** 6)


# ---- 2. the work estimated up front ------------------------------------------------------

def test_huge_arc_refused_before_any_step(program, tmp_path):
    """A full circle of radius 200 000 mm (16 million steps: 8R + 8 = 128 million steps) is
    refused at once, its line and its estimate named, more than 8R. (In a process held to
    2 GB and 60 s: without the estimate it would grow to 8 GB.)"""
    import resource
    import subprocess
    import sys

    def held():
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
    run = subprocess.run([sys.executable, "-m", "kontur.cli", "run",
                          str(program("G21 G90\nG2 X0 Y0 I200000 J0 F100\n")),
                          "--out", str(tmp_path / "o")],
                         capture_output=True, text=True, timeout=60, preexec_fn=held)
    assert run.returncode == 2, run.stderr
    line, = run.stderr.strip().splitlines()
    assert "line 2" in line and "--max-steps" in line
    estimate = int(re.search(r"about ([\d,]+) steps", line).group(1).replace(",", ""))
    assert estimate >= 8 * 200000 * 80


@pytest.mark.parametrize("text", [
    "G21 G90\nG1 X10 Y3 F600\nG2 X20 Y3 I5 J0\nG3 X15 Y8 R5\nG0 X0 Y0\n",
    "G21 G90\nG2 X0 Y0 I7.3 J-2.1 F900\n",
    "G20 G91\nG1 X1 Y-0.5 F20\nG3 X-0.5 Y0.5 I0 J0.5\n",
])
def test_estimate_bounds_the_steps(text, program, tmp_path, capsys):
    """The estimate is at least the steps made (counted from the run), and ``--max-steps``
    just below it refuses the program."""
    job = prepare(text)
    estimate = machining.estimate_steps(job.moves, job.machine)
    assert estimate >= len(job.steps)
    refused(capsys, ["run", program(text), "--max-steps", estimate - 1, "--out",
                     tmp_path / "o"])


# ---- 3. large programs drawn in bounded time and memory ---------------------------------

def test_decimate():
    points = [(i, i * i) for i in range(100_001)]
    kept = machining_plot().decimate(points, 1000)
    assert len(kept) <= 1000 and kept[0] == points[0] and kept[-1] == points[-1]
    assert kept == sorted(kept) and set(kept) <= set(points)
    assert machining_plot().decimate(points[:10], 1000) == points[:10]


def machining_plot():
    from kontur import plot
    return plot


def test_toolpath_draws_a_bounded_number_of_points(monkeypatch, tmp_path):
    """A 2000-line program's toolpath.png: a handful of artists (not one per move), each of at
    most about MAX_POINTS points, whatever the program's length."""
    from matplotlib.figure import Figure
    seen = []
    original = Figure.savefig

    def savefig(self, *args, **kwargs):
        seen.append(self)
        return original(self, *args, **kwargs)
    monkeypatch.setattr(Figure, "savefig", savefig)
    job = prepare(zigzag(2000))
    result = machining.execute(job, "model")
    machining.write_outputs(job, result, tmp_path / "o")
    (figure,) = seen
    axes = figure.axes[0]
    artists = list(axes.lines) + list(axes.collections)
    assert len(artists) <= 8
    limit = machining_plot().MAX_POINTS * 1.1
    for artist in axes.lines:
        assert len(artist.get_xdata()) <= limit
    for collection in axes.collections:
        assert sum(len(p) for p in collection.get_segments()) <= 2 * limit


# ---- 4. machine values the RTL cannot take ----------------------------------------------

@pytest.mark.parametrize("key, value", [("queue_frames", "1"), ("accel", "1e-9"),
                                        ("baud", "100000000")])
def test_machine_values_the_rtl_cannot_take(key, value, program, tmp_path, capsys):
    machine = tmp_path / "m.toml"
    machine.write_text(f"{key} = {value}\n")
    line = refused(capsys, ["run", program(LINE), "--machine", machine, "--out",
                            tmp_path / "o"])
    assert key in line


def test_a_feed_faster_than_the_boards_engines_is_refused(program, tmp_path, capsys):
    # Drives with 0.2 µs set-up and pulse allow 1.7 M steps/s at 12 MHz; the iCEBreaker's
    # arcs (the bit-serial node at 20 bits) make a step every 22 clocks, 545 455 a second.
    machine = tmp_path / "m.toml"
    machine.write_text("dir_setup_us = 0.2\nstep_width_us = 0.2\nsteps_per_mm = 1000\n"
                       "max_feed = 40000\n")
    line = refused(capsys, ["run", program(LINE), "--machine", machine, "--out",
                            tmp_path / "o"])
    assert line.endswith("max_feed 40000 mm/min is 666667 steps/s, more than the 545455 the "
                         "icebreaker's arc engine makes (serial at 20 bits: a step every 22 "
                         "clocks)"), line
    assert not (tmp_path / "o").exists()


# ---- 5. every run's outputs its own ------------------------------------------------------

def test_outputs_replace_the_folder_whole(program, tmp_path, capsys):
    """A run into a folder that holds an earlier run's files (a waveform) leaves only its
    own, and nothing beside the folder."""
    out = tmp_path / "runs" / "part"
    out.mkdir(parents=True)
    (out / "run.vcd").write_text("an earlier run's\n")
    assert main(["run", str(program(LINE)), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["steps.txt", "summary.json",
                                                     "toolpath.png"]
    assert len((out / "steps.txt").read_text().splitlines()) == 50 * 80
    assert [p.name for p in out.parent.iterdir()] == ["part"]


# ---- 6. status 2, one line, never a traceback --------------------------------------------

def test_bad_inputs_and_outputs_refused_before_running(program, tmp_path, capsys, monkeypatch):
    """Each is refused with status 2 and one line, and nothing is run (the run's entry points
    are made to fail)."""
    def never(*args, **kwargs):
        raise AssertionError("ran")
    monkeypatch.setattr(machining, "execute", never)
    monkeypatch.setattr("kontur.trace.trace_profile", never)
    path = program(LINE)
    # a program that is not UTF-8, for trace profile
    bad = program(b"G1 X1 Y1 \xff\xfe\n", name="bad.ngc", mode="wb")
    assert "UTF-8" in refused(capsys, ["trace", "profile", bad, "--radius", 3])
    # a number of 5000 digits
    assert "line 2" in refused(capsys, ["run", program("G21 G90\nG1 X" + "1" * 5000 + " F100\n",
                                                       name="long.ngc"), "--out", tmp_path / "o"])
    # a binary machine file
    machine = tmp_path / "m.toml"
    machine.write_bytes(bytes(range(256)))
    assert "m.toml" in refused(capsys, ["run", path, "--machine", machine, "--out",
                                        tmp_path / "o"])
    # an output folder that cannot be written: under a file, and /proc's
    assert "--out" in refused(capsys, ["run", path, "--out", path / "sub"])
    assert "--out" in refused(capsys, ["run", path, "--out", "/proc/self"])
    # --plot into a missing folder, or with an extension matplotlib does not write
    profile = program("G90\nG0 X0 Y0\nG41\nG1 X100 Y0\nG1 X100 Y100\nG40\n", name="p.ngc")
    assert "--plot" in refused(capsys, ["trace", "profile", profile, "--radius", 3, "--plot",
                                        tmp_path / "missing" / "p.png"])
    assert "--plot" in refused(capsys, ["trace", "profile", profile, "--radius", 3, "--plot",
                                        tmp_path / "p.xyz"])


# ---- 3. lines longer than the line engine's registers -----------------------------------

@pytest.mark.parametrize("start, end, limit", [
    ((0, 0), (72000, 800), 65535),        # through lattice points 90 steps apart: exact splits
    ((5, -3), (-200001, 77777), 65535),   # a primitive direction: the splits rounded
    ((0, 0), (17, 1000), 255),
    ((0, 0), (3, 3), 1),
])
def test_line_pieces(start, end, limit):
    """Every piece moves each axis at most ``limit`` steps, the last ends on ``end``, and every
    split is within half a step of the line along its minor axis (on it, where the line passes
    lattice points close enough together)."""
    from kontur.planner import line_pieces
    pieces = line_pieces(start, end, limit)
    assert pieces[-1] == end
    previous = start
    (x0, y0), (x1, y1) = start, end
    for x, y in pieces:
        assert max(abs(x - previous[0]), abs(y - previous[1])) <= limit
        previous = (x, y)
        if abs(x1 - x0) >= abs(y1 - y0):
            off = abs(y - (y0 + (y1 - y0) * (x - x0) / (x1 - x0)))
        else:
            off = abs(x - (x0 + (x1 - x0) * (y - y0) / (y1 - y0)))
        assert off <= 0.5 + 1e-9
    if math.gcd(x1 - x0, y1 - y0) > 1 and max(abs(x1 - x0), abs(y1 - y0)) // math.gcd(
            x1 - x0, y1 - y0) <= limit:
        assert all((x - x0) * (y1 - y0) == (y - y0) * (x1 - x0) for x, y in pieces)


def test_a_line_longer_than_the_registers_runs_in_pieces(program, tmp_path, capsys):
    """A 900 mm line (72 000 steps at 80 steps/mm) on the ULX3S's 16-bit line engine runs
    (it was refused as too wide) in two frames: every step point within one step of the
    programmed line (computed here from the G-code), the end exact, the steps counted."""
    path = program("G21 G90\nG1 X900 Y9.9875 F3000\nG0 X0 Y0\n")   # Y 799 steps: no split on it
    assert main(["run", str(path), "--board", "ulx3s", "--out", str(tmp_path / "o")]) == 0
    capsys.readouterr()
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["segments"] == 4 and summary["end_steps"] == [0, 0, 0]    # 3 axes
    x = y = worst = 0
    for n, row in enumerate((tmp_path / "o" / "steps.txt").read_text().splitlines()):
        dx, dy, dz = map(int, row.split())
        x, y = x + dx, y + dy
        assert dz == 0
        if n < 72000:
            worst = max(worst, abs(y - 799 * x / 72000))
        if n == 71999:
            assert (x, y) == (72000, 799)
    assert n + 1 == 144000 and worst <= 1


# ---- 4. soft limits (tests/test_travel.py holds the rest) ---------------------------------

def test_a_program_starting_outside_the_travel_refused(program, tmp_path, capsys):
    machine = program("travel_x = [5, 48]\n", name="m.toml")
    line = refused(capsys, ["run", program("G21 G90\nG0 X10 Y0\n"), "--machine", machine,
                            "--out", tmp_path / "o"])
    assert line.endswith("line 2: the program starts at X 0 mm, beyond the machine's travel (X "
                         "from 5 to 48 mm, travel_x in the machine file)")
    assert not (tmp_path / "o").exists()
