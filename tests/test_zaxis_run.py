"""The third axis through the whole chain (issue 28): ``kontur run --board ulx3s`` (and
``icebreaker-z``) of a program with lines in XYZ, a helical entry and helices, against
LinuxCNC's interpreter.

The program (``tests/programs/xyz/zaxis.ngc``, tests/programs/SOURCES.md) is run on the
ULX3S's 3-axis controller and the iCEBreaker's: on the model and on Verilator (the whole controller's RTL, whose
steps :func:`kontur.machining.execute` compares with the model's step for step, the position
read back with the program's end), through the command line, steps.txt with a ``dz`` column.
The model's steps are held against rs274's canonical commands (``rs274 -g``: STRAIGHT_TRAVERSE,
STRAIGHT_FEED, ARC_FEED with its end Z), not against kontur's own frames:

* every move ends exactly on rs274's end (X, Y and Z) rounded to the step grid;
* every step point of a line lies within :data:`LINE_XY_BOUND` steps of rs274's line in XY
  and :data:`LINE_3D_BOUND` in space: its ends are rounded to the grid (up to √3/2 in space,
  √2/2 in XY) and the spatial core keeps each axis within half a step of the line between
  them (√2/2 for the two axes that are not the dominant one);
* every step point of a helix lies within :data:`ARC_BOUND` of rs274's arc in XY (the engine's
  circle is about a lattice centre: tests/test_corpus_path.py) and its Z follows the helix
  engine's rule exactly: after ``k`` of the arc's ``n`` XY steps Z has made
  ``⌊(⌊n/2⌋ + k|z|)/n⌋`` steps (within half a step of ``k·z/n``, ending exactly on ``z``);
  against rs274's helix, whose Z is linear in the angle, Z is within
  ``1 + |z|·δ`` steps, ``δ`` the largest difference between the share of the arc's steps made
  (``k/n``) and the share of its sweep reached (the angle of the ``k``-th point about rs274's
  centre): the steps are not evenly spread over the angle (an axial step is shorter than a
  diagonal one), and each end of Z is rounded to the grid by up to half a step.

The iCEBreaker's 2-axis controller refuses the program with one line (status 2); a helix
steeper than one Z step per XY step is made in chords on the ULX3S.
"""

import json
import math
from fractions import Fraction
from pathlib import Path

import pytest

from kontur import registry
from kontur.cli import main
from kontur.machine import Machine
from kontur.machining import execute, prepare
from kontur.planner import ProgramError
from kontur.rs274 import canonical

from .conftest import selected_simulators

PROGRAM = Path(__file__).resolve().parent / "programs" / "xyz" / "zaxis.ngc"
BOARD = "ulx3s"
SPM = 80

LINE_XY_BOUND = 1.5                              # √2/2 + √2/2 = 1.414
LINE_3D_BOUND = math.sqrt(3) / 2 + math.sqrt(2) / 2
ARC_BOUND = 1.75                                 # tests/test_corpus_path.py's


def _grid(value):
    """A coordinate (mm) on the step grid, halves away from zero."""
    scaled = Fraction(value).limit_denominator(10 ** 6) * SPM
    return math.floor(scaled + Fraction(1, 2)) if scaled >= 0 else \
        -math.floor(-scaled + Fraction(1, 2))


def _to_segment(p, a, b):
    """Distance from ``p`` to the segment ``a``-``b`` (any dimension)."""
    d = [q - r for q, r in zip(b, a)]
    length = sum(c * c for c in d)
    t = 0.0 if length == 0 else max(0.0, min(1.0, sum((q - r) * c for q, r, c in
                                                       zip(p, a, d)) / length))
    return math.dist(p, [r + t * c for r, c in zip(a, d)])


def _along(p, a, b, centre, cw, hint=None):
    """``(distance, share)``: of ``p`` (XY) from rs274's arc from ``a`` to ``b`` about
    ``centre``, and the share of the arc's sweep its angle has reached (on a full turn, of
    the two angles a point at its start has, the one nearer the share ``hint``)."""
    cx, cy = centre
    sign = -1 if cw else 1

    def angle(q):
        return math.atan2(q[1] - cy, q[0] - cx)
    sweep = (sign * (angle(b) - angle(a))) % (2 * math.pi) or 2 * math.pi
    along = (sign * (angle(p) - angle(a))) % (2 * math.pi)
    if hint is not None and abs(along + 2 * math.pi - hint * sweep) < abs(along - hint * sweep):
        along += 2 * math.pi             # a full turn's end: its start's angle, once round
    if along > sweep:                    # past the end (or a hair before the start; a
        # full turn's end a hair past its start has had 2π added: nearer its end)
        along = sweep if along - sweep < (2 * math.pi - along) % (2 * math.pi) else 0.0
    radius = math.hypot(a[0] - cx, a[1] - cy)
    return abs(math.hypot(p[0] - cx, p[1] - cy) - radius), along / sweep


def check_path(job, theirs):
    """The model's steps against rs274's moves (see the module's text); returns the worst
    figures: ``{"line_xy", "line_3d", "arc_xy", "helix_z", "helix_z_bound"}``."""
    assert len(job.moves) == len(theirs)
    index = {id(move): n for n, move in enumerate(job.moves)}
    starts, at = {}, (0.0, 0.0, 0.0)
    for n, ref in enumerate(theirs):
        starts[n] = at
        at = (*(c * SPM for c in ref["end"]), ref["z"] * SPM)
    worst = dict.fromkeys(("line_xy", "line_3d", "arc_xy", "helix_z", "helix_z_bound"), 0.0)
    position = list(job.start)
    assert tuple(position) == (0, 0, 0)
    for segment in job.segments:
        n = index[id(segment.source)]
        ref = theirs[n]
        a, b = starts[n], (*(c * SPM for c in ref["end"]), ref["z"] * SPM)
        if ref["kind"] == "arc":
            centre = tuple(c * SPM for c in ref["centre"])
            helix = segment.kind == "arc"
            if helix:
                n_xy, z = segment.payload["n"], segment.payload["z"]
                assert len(segment.steps) == n_xy
                z0 = position[2]
                points = []
                for k, (dx, dy, dz) in enumerate(segment.steps, 1):
                    position = [position[0] + dx, position[1] + dy, position[2] + dz]
                    made = ((n_xy >> 1) + k * abs(z)) // n_xy
                    assert position[2] - z0 == (made if z >= 0 else -made), (segment.line, k)
                    points.append((k / n_xy, list(position)))
                assert position[2] - z0 == z
                shares = [(share, _along(p[:2], a[:2], b[:2], centre, ref["cw"], share))
                          for share, p in points]
                delta = max(abs(share - along) for share, (_, along) in shares)
                bound = 1.0 + abs(z) * delta
                for (share, (off, along)), (_, p) in zip(shares, points):
                    z_ref = a[2] + (b[2] - a[2]) * along
                    worst["arc_xy"] = max(worst["arc_xy"], off)
                    worst["helix_z"] = max(worst["helix_z"], abs(p[2] - z_ref))
                    assert off <= ARC_BOUND, (segment.line, p, off)
                    assert abs(p[2] - z_ref) <= bound, (segment.line, p, z_ref, bound)
                worst["helix_z_bound"] = max(worst["helix_z_bound"], bound)
            else:                          # the finishing line: XY only, on the arc's end
                for dx, dy, dz in segment.steps:
                    position = [position[0] + dx, position[1] + dy, position[2] + dz]
                    off, along = _along(position[:2], a[:2], b[:2], centre, ref["cw"])
                    assert dz == 0 and off <= ARC_BOUND, (segment.line, position, off)
                    worst["arc_xy"] = max(worst["arc_xy"], off)
        else:
            for dx, dy, dz in segment.steps:
                position = [position[0] + dx, position[1] + dy, position[2] + dz]
                xy, space = _to_segment(position[:2], a[:2], b[:2]), _to_segment(position, a, b)
                worst["line_xy"], worst["line_3d"] = max(worst["line_xy"], xy), \
                    max(worst["line_3d"], space)
                assert xy <= LINE_XY_BOUND and space <= LINE_3D_BOUND, (segment.line, position)
        if segment is [s for s in job.segments if s.source is segment.source][-1]:
            assert tuple(position) == (*(_grid(c) for c in ref["end"]), _grid(ref["z"])), \
                f"line {segment.line} ends at {position}, rs274 at {ref['end']} Z {ref['z']}"
    return worst


def _job(board=BOARD):
    text = PROGRAM.read_text()
    machine = Machine(clock_hz=registry.board(board).clock_hz, steps_per_mm=SPM)
    return prepare(text, machine=machine, board=board, name=PROGRAM.name), text


#: The boards with the third axis: the ULX3S (arcs on the fast core, 24 bits) and the
#: iCEBreaker's three-axis controller (arcs on the bit-serial node, 16 bits: separate steps).
THREE_AXES = pytest.mark.parametrize("board", ["ulx3s", "icebreaker-z"])


@THREE_AXES
def test_model_path_is_rs274s(tmp_path, board):
    job, text = _job(board)
    theirs, _, run = canonical(text, folder=tmp_path)
    assert run.returncode == 0, run.stderr[-300:]
    worst = check_path(job, theirs)
    # The program moves Z in lines and in four helices, two of them full turns.
    helices = [s for s in job.segments if s.kind == "arc"]
    assert len(helices) == 4 and all(s.payload["z"] for s in helices)
    assert sum(1 for step in job.steps if step[2]) > 500
    assert worst["line_3d"] > 0 and worst["helix_z"] > 0, worst
    # (the spread's unevenness over the angle stays small: the Z bound under 2 steps)
    assert worst["helix_z_bound"] < 2, worst
    # The frames: LINE3 and HELIX only (a 3-axis controller knows no LINE or ARC).
    from kontur.hdl.motion.link import ARC, HELIX, LINE, LINE3
    kinds = {frame[1] for frame in job.frames()[0]}
    assert {LINE3, HELIX} <= kinds and not {LINE, ARC} & kinds


def test_feed_is_along_the_3d_path():
    # A plunge at 45° in XZ at F600: its planned cruise is 600 mm/min along the 3D path, so
    # its time is the 3D length over the feed (plus the ramps), not the XY length's.
    machine = Machine(clock_hz=registry.board(BOARD).clock_hz, steps_per_mm=SPM,
                      accel=1e6)
    job = prepare("G21 G90\nG1 X10 Z-10 F600\nM2\n", machine=machine, board=BOARD)
    (segment,) = job.segments
    assert segment.length == pytest.approx(800 * math.sqrt(2))
    length_mm = math.hypot(10, 10)
    assert job.seconds == pytest.approx(length_mm / 10, rel=0.01)


def _run(tmp_path, capsys, *args, out="out"):
    status = main(["run", *map(str, args), "--out", str(tmp_path / out)])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def _steps(path):
    return [tuple(map(int, line.split())) for line in path.read_text().splitlines()]


@THREE_AXES
def test_run_on_the_model(tmp_path, capsys, board):
    status, out, err = _run(tmp_path, capsys, PROGRAM, "--board", board)
    assert status == 0, err
    job, _ = _job(board)
    steps = _steps(tmp_path / "out" / "steps.txt")
    assert steps == [tuple(s) for s in job.steps] and all(len(s) == 3 for s in steps)
    data = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert data["axes"] == 3 and data["helices"] == 4
    assert data["z_steps"] == sum(1 for s in steps if s[2])
    assert data["end_steps"] == [0, 0, 240] == list(job.end)
    assert "z          " in out


@pytest.mark.cocotb
@THREE_AXES
def test_run_on_verilator(tmp_path, capsys, board):
    if "verilator" not in selected_simulators():
        pytest.skip("SIM selects another simulator")
    status, out, err = _run(tmp_path, capsys, PROGRAM, "--board", board, "--engine",
                            "verilator")
    assert status == 0, err
    job, _ = _job(board)
    # execute() checked the RTL's steps against the model's, every frame DONE, and the
    # position read back (X, Y and Z) against the program's end.
    assert _steps(tmp_path / "out" / "steps.txt") == [tuple(s) for s in job.steps]
    data = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert data["engine"] == "verilator" and data["end_steps"] == [0, 0, 240]
    assert "the RTL's steps equal the model's" in out


def test_icebreaker_refuses_z(tmp_path, capsys):
    status, out, err = _run(tmp_path, capsys, PROGRAM)
    assert status == 2 and out == ""
    assert err.splitlines() == [f"kontur: {PROGRAM}: line 5: Z moves need the third axis, "
                                f"which this board's controller does not have (the "
                                f"icebreaker-z's and the ulx3s's have it) (Z from 2 to 0.5 "
                                f"mm)"]


def test_arc_wider_than_the_boards_arc_engine(tmp_path):
    # The three-axis iCEBreaker's arc engine is 16 bits wide: a radius of 900 mm (72 000
    # steps) is refused with its line; the two-axis one's (24 bits) makes it.
    text = "G21 G90\nG0 X0 Y0\nG2 X1800 Y0 I900 J0 F500\nM2\n"
    machine = Machine(clock_hz=12e6, steps_per_mm=SPM)
    with pytest.raises(ProgramError, match=r"^line 3: the arc's radius, 72000 steps \(900 mm\), "
                                           r"is more than this board's 16-bit arc engine takes "
                                           r"\(65535 steps\)$"):
        prepare(text, machine=machine, board="icebreaker-z")
    job = prepare(text, machine=machine, board="icebreaker")
    assert job.end == (144000, 0)


@pytest.mark.parametrize("board", ["icebreaker", "icebreaker-z", "ulx3s"])
def test_arc_whose_centre_rounds_to_its_start(board):
    # A centre 0.001 mm from the start rounds to the start's step: radius zero, refused with
    # its line on every board (on three axes the position's Z once hid the equality, and the
    # arc became a circle of one step about a neighbouring point).
    machine = Machine(clock_hz=registry.board(board).clock_hz, steps_per_mm=SPM)
    with pytest.raises(ProgramError, match=r"^line 2: the arc's start is its centre: "
                                           r"radius zero$"):
        prepare("G21 G90\nG2 X0 Y0 I0.001 J0 F300\nM2\n", machine=machine, board=board)


def test_steep_helix_in_chords(tmp_path):
    """A turn of radius 0.5 mm (40 steps: 226 XY steps) down 5 mm (400 Z steps), steeper than
    the helix engine's one Z step per XY step (it was refused), as LinuxCNC runs it: in chords,
    LINE3 frames between lattice points of the programmed circle, every step point within
    :data:`ARC_BOUND` of the circle, Z falling evenly to exactly -5 mm; the RTL's steps are the
    model's."""
    machine = Machine(clock_hz=registry.board(BOARD).clock_hz, steps_per_mm=SPM)
    job = prepare("G21 G90\nG0 X0.5 Y0 Z0\nG2 X0.5 Y0 I-0.5 J0 Z-5 F300\nM2\n",
                  machine=machine, board=BOARD)
    chords = [s for s in job.segments if s.line == 3]
    assert {s.kind for s in chords} == {"line"} and len(chords) >= 8
    x, y, z = chords[0].start
    assert (x, y, z) == (40, 0, 0)
    for segment in chords:
        for dx, dy, dz in segment.steps:
            x, y, z = x + dx, y + dy, z + dz
            assert abs(math.hypot(x, y) - 40) <= ARC_BOUND
            assert dz <= 0
    assert (x, y, z) == (40, 0, -400)
    # the normal axis even over the angle: each chord's fall within a step of its share
    falls = [s.start[2] - s.end[2] for s in chords]
    assert max(falls) - min(falls) <= 1
    if "verilator" in selected_simulators():
        result = execute(job, "verilator")
        assert result.steps == job.steps and tuple(result.end) == tuple(job.end)


def test_compensated_program_stays_planar():
    machine = Machine(clock_hz=registry.board(BOARD).clock_hz, steps_per_mm=SPM,
                      cutter_radius=1)
    with pytest.raises(ProgramError, match=r"^line 4: Z moves in a program with cutter-radius "
                                           r"compensation"):
        prepare("G21 G90\nG0 X-5 Y-5 Z1\nG41 G1 X0 Y0 F300\nG1 X10 Z-1\nG40 G1 X20 Y-5\n"
                "M2\n", machine=machine, board=BOARD)


def test_z_limit_event(tmp_path, capsys):
    # --event limit-z@SECONDS (the ULX3S's Z limit, input bit 6) stops the program in ALARM
    # with limit_z its cause; the iCEBreaker has no Z limit: status 2, one line.
    status, out, err = _run(tmp_path, capsys, PROGRAM, "--board", BOARD, "--event",
                            "limit-z@2")
    assert status == 0, err
    data = json.loads((tmp_path / "out" / "summary.json").read_text())
    job, _ = _job()
    assert data["final_state"] == "ALARM" and data["alarm"] == ["limit_z"]
    assert 0 < data["steps"] < len(job.steps)
    status, out, err = _run(tmp_path, capsys, PROGRAM, "--event", "limit-z@2", out="o2")
    assert status == 2 and err.splitlines() == [
        "kontur: --event limit-z: the icebreaker's controller has no Z axis (no Z limit switch)"]


@pytest.mark.cocotb
def test_z_limit_event_on_verilator(tmp_path):
    # The RTL's Z limit against the model's (kontur.machining._check_events): the steps made
    # are the program's first, none after the bound, ALARM with limit_z (bit 6) its cause.
    if "verilator" not in selected_simulators():
        pytest.skip("SIM selects another simulator")
    job, _ = _job()
    result = execute(job, "verilator", events=[(2.0, "limit-z")])
    assert result.final_state == "ALARM" and result.alarm == ["limit_z"]
    assert 0 < len(result.steps) < len(job.steps)
