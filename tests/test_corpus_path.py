"""The corpus's traced paths against LinuxCNC's: every program of the rs274 corpus that
kontur runs (``tests/test_gcode_rs274.py``'s ``CORPUS``, the uncompensated ones) is prepared
for the ULX3S's controller, and every step point of the model's path must lie within
:data:`LINE_BOUND` steps of the rs274 move it belongs to (a line) or :data:`ARC_BOUND` (an arc:
the engine's circle is about a lattice centre, see ``tests/test_run_geometry.py``), every move
ending exactly on rs274's end rounded to the step grid. The geometry here is rs274's canonical
commands (STRAIGHT_TRAVERSE, STRAIGHT_FEED, ARC_FEED), not kontur's reader's.

The ULX3S's controller has three axes (issue 28): Z moves from 0 at a program's first Z word,
as rs274's does, so the programs that move Z (refused on the iCEBreaker: :data:`ZRUNS`) run
too, and every point is checked in space as well: within :data:`LINE_3D_BOUND` of rs274's line
(tests/test_zaxis_run.py says why), and on a helix Z within ``1 + |z|·(0.0865 + 1/n)`` steps
of rs274's Z at the point's angle (docs/architecture.md, "Helical arcs": the share of the
arc's ``n`` steps made against the share of its angle, and each end of Z rounded to the grid);
each move ends exactly on rs274's X, Y and Z rounded to the grid.

The same holds on the iCEBreaker's three-axis controller (``icebreaker-z``), whose arcs are
the bit-serial node's separate steps at 16 bits: within half a diagonal of the lattice's
circle, not half a step, so its arcs' bound is :data:`SERIAL_ARC_BOUND` (LinuxCNC's
tort.ngc, run whole since steep helices are made in chords, has a full circle of radius 720
steps 1.751 steps off).

A helix steeper than the helix engine takes is made in chords (lines between lattice points
nearest the programmed circle): in the plane within the arc's bound, on its normal axis within
:data:`CHORD_Z_BOUND` of rs274's at the point's angle (and the angle's uncertainty).

A third of the programs also run on Verilator (the whole controller), whose steps must be the
model's (:func:`kontur.machining.execute` compares them step for step and raises otherwise).
"""

import math
from fractions import Fraction

import pytest

from kontur.machining import execute, prepare
from kontur.gcode import PLANE_AXES

from .test_gcode_rs274 import CORPUS, Z, canonical, rs274_text, tools_of, _text
from .conftest import selected_simulators
from .test_zaxis_run import _along, _to_segment

BOARD = "ulx3s"
SPM = 80
LINE_BOUND = 1.5
ARC_BOUND = 1.75
#: The lattice's circle up to 1.22 steps off the programmed one (tests/test_run_geometry.py)
#: and the bit-serial node's separate steps within √2/2 of it.
SERIAL_ARC_BOUND = 1.22 + math.sqrt(2) / 2
LINE_3D_BOUND = math.sqrt(3) / 2 + math.sqrt(2) / 2
#: A steep helix's chords: each vertex's normal axis rounded to the grid (1/2), the spatial
#: core within half a step of the chord between them (1/2), the chord's share of the angle
#: against its share of the line (under 1/2 step for chords of a quarter step's sagitta); and
#: the angle's uncertainty from the lattice's rounding (in the test).
CHORD_Z_BOUND = 1.5

#: The corpus's programs kontur runs, without cutter compensation (its paths are the
#: equidistant engine's: tests/test_compensation_run.py).
RUNS = [path for path, refusal in sorted(CORPUS.items(), key=lambda item: item[0].name)
        if refusal is None and not any(word in _text(path).upper()
                                       for word in ("G41", "G42"))
        and path.name not in ("factorial.ngc", "retval.ngc")]   # these two make no move
#: The corpus's programs that move Z (refused on the iCEBreaker's 2-axis controller), which
#: run on the ULX3S's 3-axis one; those with cutter compensation stay refused there (its
#: contours are planar).
ZRUNS = [path for path, refusal in sorted(CORPUS.items(), key=lambda item: item[0].name)
         if refusal is not None and Z in refusal
         and not any(word in _text(path).upper() for word in ("G41", "G42"))]
RUNS += ZRUNS
#: A third of them on Verilator (an arc in XZ among them): the quickest (3 to 6 million clocks each
#: at the run's time compression; inch.ngc is 420 million), and the two shortest real CAM
#: outputs (Estlcam's and jscut's engravings: ten moves each).
VERILATOR = [path for path in RUNS if path.name in ("zconst.ngc", "owords.ngc", "modes.ngc",
                                                     "tools.ngc", "zplunge.ngc", "helix.ngc",
                                                     "planes.ngc", "drill.ngc",
                                                     "freecad_grbl.ngc", "turns.ngc",
                                                     "estlcam_engrave.nc", "jscut_engrave.nc")]


def _grid(value):
    """A coordinate (mm) on the step grid, halves away from zero."""
    scaled = Fraction(value).limit_denominator(10 ** 6) * SPM
    return math.floor(scaled + Fraction(1, 2)) if scaled >= 0 else -math.floor(-scaled + Fraction(1, 2))


def _to_line(p, a, b):
    """Distance (steps) from ``p`` to the segment ``a``-``b``."""
    (px, py), (ax, ay), (bx, by) = p, a, b
    dx, dy = bx - ax, by - ay
    length = dx * dx + dy * dy
    t = 0.0 if length == 0 else max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / length))
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


def _to_arc(p, a, b, centre, cw, turns=1):
    """Distance (steps) from ``p`` to the arc from ``a`` to ``b`` about ``centre`` (a full
    circle when ``a`` is ``b``, or when it turns more than once)."""
    cx, cy = centre
    radius = math.hypot(a[0] - cx, a[1] - cy)
    sign = -1 if cw else 1

    def angle(q):
        return math.atan2(q[1] - cy, q[0] - cx)
    sweep = (sign * (angle(b) - angle(a))) % (2 * math.pi) or 2 * math.pi
    along = (sign * (angle(p) - angle(a))) % (2 * math.pi)
    if along <= sweep or turns > 1:
        return abs(math.hypot(p[0] - cx, p[1] - cy) - radius)
    return min(math.hypot(p[0] - q[0], p[1] - q[1]) for q in (a, b))


def _sweep(a, b, centre, cw):
    """The sweep (radians) of an arc from ``a`` to ``b`` about ``centre``, a full turn when
    they are one point."""
    sign = -1 if cw else 1

    def angle(q):
        return math.atan2(q[1] - centre[1], q[0] - centre[0])
    return (sign * (angle(b) - angle(a))) % (2 * math.pi) or 2 * math.pi


def _check_path(path, job, theirs):
    """Each segment's step points against the rs274 move its program move is (in space on
    the ULX3S's three axes)."""
    assert len(job.moves) == len(theirs)
    index = {id(move): n for n, move in enumerate(job.moves)}
    position = list(job.start)
    axes = len(position)
    previous = {}                          # rs274's start of each move, steps
    at = (0.0,) * axes
    for n, ref in enumerate(theirs):
        previous[n] = at
        if ref["kind"] != "dwell":
            at = tuple(c * SPM for c in ref["end"]) + ((ref["z"] * SPM,) if axes == 3 else ())
    worst = 0.0
    for segment in job.segments:
        if segment.kind == "dwell":
            continue
        n = index[id(segment.source)]
        ref = theirs[n]
        a, b = previous[n], tuple(c * SPM for c in ref["end"]) + \
            ((ref["z"] * SPM,) if axes == 3 else ())
        helix = axes == 3 and segment.kind == "arc" and segment.payload["z"]
        # An arc in XZ or YZ is judged in its plane: its points as rs274's first, second and
        # normal axis (ARC_FEED's), where it is a G17 arc and its normal axis the helix's Z.
        order = PLANE_AXES[ref.get("plane", 17)]

        def native(point):
            return tuple(point[i] for i in order) if len(point) == 3 else tuple(point)

        # An arc of several turns (G2/G3 P) is its whole turns (full circles from its start)
        # and then the last sweep, segment by segment: this segment's turn, and the angle of
        # the whole arc before it and in it, over which rs274's normal axis rises evenly.
        turns = int(ref.get("turns", 1))
        turn = sum(1 for s in job.segments[:job.segments.index(segment)]
                   if s.source is segment.source and s.kind == "arc")
        # A helix steeper than the helix engine takes is made in chords (lines): their normal
        # axis within CHORD_Z_BOUND of rs274's at the point's angle, the share of the move's
        # steps made the hint for a full turn's start and end.
        siblings = [s for s in job.segments if s.source is segment.source]
        made = sum(len(s.steps) for s in siblings[:siblings.index(segment)])
        chord = (axes == 3 and segment.kind == "line" and ref["kind"] == "arc" and turns == 1
                 and ref["z"] * SPM != a[2] and any(s.kind == "line" for s in siblings[:-1]))
        for k, step in enumerate(segment.steps, 1):
            position = [c + d for c, d in zip(position, step)]
            if ref["kind"] == "arc":
                centre = native(tuple(c * SPM for c in ref["centre"]))[:2]
                p, a_n, b_n = native(position), native(a), native(b)
                off = _to_arc(p[:2], a_n[:2], b_n[:2], centre, ref["cw"], turns)
                bound = SERIAL_ARC_BOUND if job.board == "icebreaker-z" else ARC_BOUND
                if helix:
                    last = _sweep(a_n, b_n, centre, ref["cw"])
                    whole = turn < turns - 1 and segment.kind == "arc"
                    _, share = _along(p, a_n, a_n if whole else b_n, centre, ref["cw"],
                                      k / len(segment.steps))
                    total = (turns - 1) * 2 * math.pi + last
                    share = (min(turn, turns - 1) * 2 * math.pi
                             + share * (2 * math.pi if whole else last)) / total
                    z_ref = a_n[2] + (b_n[2] - a_n[2]) * share
                    # (a whole turn's end on the normal axis is rounded to the grid too)
                    z_bound = 1 + abs(segment.payload["z"]) * (0.0865 + 1 / len(segment.steps)) \
                        + (0.5 if turns > 1 else 0)
                    assert abs(p[2] - z_ref) <= z_bound, \
                        (f"{path.name}: line {segment.line}: step point {position}: the "
                         f"normal axis {abs(p[2] - z_ref):.3f} steps off rs274's helix")
                if chord:
                    _, share = _along(p, a_n, b_n, centre, ref["cw"],
                                      (made + k) / sum(len(s.steps) for s in siblings))
                    z_ref = a_n[2] + (b_n[2] - a_n[2]) * share
                    # (the lattice's centre and start, each up to √2/2 from rs274's, turn a
                    # point's angle about rs274's centre by up to √2/r: the steeper the helix,
                    # the more of the normal axis that is)
                    rate = abs(b_n[2] - a_n[2]) / _sweep(a_n, b_n, centre, ref["cw"])
                    slack = rate * math.sqrt(2) / math.dist(a_n[:2], centre)
                    assert abs(p[2] - z_ref) <= CHORD_Z_BOUND + slack, \
                        (f"{path.name}: line {segment.line}: chord point {position}: the "
                         f"normal axis {abs(p[2] - z_ref):.3f} steps off rs274's helix")
            else:
                off, bound = _to_line(position[:2], a[:2], b[:2]), LINE_BOUND
                if axes == 3:
                    assert _to_segment(position, a, b) <= LINE_3D_BOUND, \
                        f"{path.name}: line {segment.line}: step point {position}"
            worst = max(worst, off)
            assert off <= bound, (f"{path.name}: line {segment.line}: step point {position} "
                                  f"{off:.3f} steps off rs274's {ref}")
        if segment is _last_of(job, segment.source):
            # (rs274 prints four decimals of the program's unit: a coordinate that close to a
            # half step may round either way; the reader has the program's own value)
            ends = list(ref["end"]) + ([ref["z"]] if axes == 3 else [])
            slack = 0.00005 * ref["unit"]
            for c, value in zip(position, ends):
                assert c in {_grid(value - slack), _grid(value + slack)}, \
                    f"{path.name}: line {segment.line} ends at {position}, rs274 at {ends}"
    return worst


def _last_of(job, move):
    return [s for s in job.segments if s.source is move][-1]


def _prepare(path, tmp_path, board=BOARD):
    text = _text(path)
    theirs, _, run = canonical(rs274_text(path, text), tmp_path, path)
    assert run.returncode == 0, run.stderr[-300:]
    job = prepare(text, board=board, name=path.name, tools=tools_of(path))
    return job, theirs


def test_enough_programs_run():
    assert len(RUNS) >= 11 and len(VERILATOR) * 3 >= len(RUNS), [p.name for p in RUNS]
    assert len(ZRUNS) >= 5, [p.name for p in ZRUNS]


@pytest.mark.parametrize("board", [BOARD, "icebreaker-z"])
@pytest.mark.parametrize("path", RUNS, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_model_path_is_rs274s(path, tmp_path, board):
    # On the three-axis iCEBreaker too: its arcs on the bit-serial node (separate steps)
    # within the same bounds.
    job, theirs = _prepare(path, tmp_path, board)
    assert job.steps, path.name
    _check_path(path, job, theirs)


@pytest.mark.cocotb
@pytest.mark.parametrize("path", VERILATOR, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_verilator_steps_are_the_models(path, tmp_path):
    if "verilator" not in selected_simulators():
        pytest.skip("SIM selects another simulator")
    job, _ = _prepare(path, tmp_path)
    result = execute(job, "verilator")
    assert result.steps == job.steps and tuple(result.end) == tuple(job.end)

