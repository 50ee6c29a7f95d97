"""LinuxCNC's own interpreter, ``rs274 -g`` (Debian's ``linuxcnc-uspace``), as a reference.

:func:`canonical` runs it on a program and reads its canonical machine commands (moves in
millimetres, machine coordinates; the tool events); :func:`path_distance` measures a point
against the path those moves describe (lines and arcs as curves), so that a cutter's path
traced by kontur can be compared with the compensated path LinuxCNC makes
(:func:`compare_steps`; the corpus of ``tests/programs/comp/``, ``python -m kontur.bench
compensation``). rs274 reads a tool table's diameters in inches (its default machine units):
:func:`canonical` takes the table in millimetres and writes it so.
"""

import fcntl
import math
import re
import shutil
import subprocess
import tempfile
from fractions import Fraction
from pathlib import Path

from kontur.gcode import PLANE_AXES

__all__ = ["RS274", "canonical", "path_distance", "compare_steps", "available"]

RS274 = "/usr/bin/rs274"

_CALL = re.compile(r"^\s*\d+\s+N\S*\s+([A-Z_0-9]+)\((.*)\)\s*$")


def _numbers(text):
    return [float(x) for x in re.split(r"[,\s]+", text.strip()) if x]


def available():
    """The rs274 executable's path, or ``None``."""
    return shutil.which("rs274") or (RS274 if Path(RS274).exists() else None)


def inch_table(tools):
    """A tool table ``{tool: diameter, mm}`` (and its ``lengths``, mm, when it has them:
    :class:`kontur.gcode.ToolTable`) in LinuxCNC's format with its diameters and lengths in
    inches, as the standalone rs274 reads them."""
    lengths = getattr(tools, "lengths", {})
    inch = Fraction(254, 10)
    return "".join(f"T{tool} P{tool} D{float(Fraction(diameter) / inch):.6f} "
                   f"Z{float(Fraction(lengths.get(tool, 0)) / inch):.6f}\n"
                   for tool, diameter in tools.items())


def canonical(text, tools=None, *, folder=None):
    """rs274's canonical commands for ``text`` (a table ``tools``, ``{tool: diameter, mm}``,
    given to it in inches): ``(moves, events, run)``, its moves in mm and machine coordinates
    (dicts: ``kind`` ``"rapid"``, ``"line"``, ``"arc"`` or ``"dwell"``; ``end``; an arc's
    ``centre``, ``cw``, ``turns``; ``z``, ``feed``, ``unit``), its tool events, and the
    completed process (``returncode``, ``stderr``: its refusal). Machine coordinates: the
    work offsets, G92's and the tool length offset (USE_TOOL_LENGTH_OFFSET) added to what it
    prints, as LinuxCNC's motion adds them. An arc in the XZ or YZ plane
    (after SELECT_PLANE, ARC_FEED's first and second axis Z X or Y Z) has ``plane`` 18 or 19
    and its ``centre`` as ``(x, y, z)``, its coordinate on the plane's normal axis the
    start's (where the move before ended), as :class:`kontur.gcode.Move` gives it."""
    executable = available()
    if executable is None:
        raise FileNotFoundError("rs274 (LinuxCNC's interpreter, package linuxcnc-uspace) is "
                                "missing: run make setup")
    with tempfile.TemporaryDirectory(dir=folder) as where:
        path = Path(where) / "program.ngc"
        path.write_text(text)
        table = Path(where) / "tools-inch.tbl"
        table.write_text(inch_table(tools or {}))
        # (in its own folder: rs274 keeps files in its working directory, and runs side by
        # side must not share them). Runs side by side with different tool tables read one
        # another's (LinuxCNC 2.9 keeps the tool table in shared memory): one runs at a time,
        # under a lock. A run killed by a signal (seen once: SIGBUS, with no message, on a
        # loaded machine) is no answer: it is run again, twice at most.
        with open(Path(tempfile.gettempdir()) / "kontur-rs274.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            for _ in range(3):
                run = subprocess.run([executable, "-t", str(table), "-g", str(path)],
                                     capture_output=True, text=True, timeout=60,
                                     stdin=subprocess.DEVNULL, cwd=where)
                if run.returncode >= 0:
                    break
    unit, g5x, g92, tlo, feed, plane = 1.0, [0.0] * 3, [0.0] * 3, [0.0] * 3, None, 17
    at = [0.0] * 3                        # where the last move ended (mm, machine)
    moves, events = [], []
    for line in run.stdout.splitlines():
        match = _CALL.match(line)
        if not match:
            continue
        name, args = match.groups()
        if name == "USE_LENGTH_UNITS":
            unit = 25.4 if "INCHES" in args else 1.0
        elif name == "SET_G5X_OFFSET":
            g5x = [c * unit for c in _numbers(args)[1:4]]
        elif name == "SET_G92_OFFSET":
            g92 = [c * unit for c in _numbers(args)[0:3]]
        elif name == "USE_TOOL_LENGTH_OFFSET":    # x y z, a b c, u v w: program units
            tlo = [c * unit for c in _numbers(args)[0:3]]
        elif name == "SELECT_PLANE":
            plane = {"CANON_PLANE_XY": 17, "CANON_PLANE_XZ": 18, "CANON_PLANE_YZ": 19}.get(
                args.strip(), plane)
        elif name == "SET_FEED_RATE":
            feed = _numbers(args)[0] * unit
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED"):
            v = _numbers(args)
            off = [g5x[i] + g92[i] + tlo[i] for i in range(3)]
            move = {"end": (v[0] * unit + off[0], v[1] * unit + off[1]), "unit": unit}
            if name == "ARC_FEED" and plane != 17:
                # first end, second end, first centre, second centre, rotation, normal end
                first, second, normal = PLANE_AXES[plane]
                end, centre = [0.0] * 3, list(at)
                end[first], end[second], end[normal] = v[0], v[1], v[5]
                centre[first], centre[second] = v[2] * unit + off[first], \
                    v[3] * unit + off[second]
                end = [c * unit + o for c, o in zip(end, off)]
                move.update(kind="arc", end=tuple(end[:2]), centre=tuple(centre), cw=v[4] < 0,
                            turns=abs(v[4]), z=end[2], feed=feed, plane=plane)
            elif name == "ARC_FEED":
                move.update(kind="arc", centre=(v[2] * unit + off[0], v[3] * unit + off[1]),
                            cw=v[4] < 0, turns=abs(v[4]), z=v[5] * unit + off[2], feed=feed)
            else:
                move.update(kind="rapid" if name == "STRAIGHT_TRAVERSE" else "line",
                            z=v[2] * unit + off[2], feed=feed)
            moves.append(move)
            at = [*move["end"], move["z"]]
        elif name == "DWELL":
            moves.append({"kind": "dwell", "seconds": _numbers(args)[0]})
        elif name == "CHANGE_TOOL":
            events.append(("tool_change", int(_numbers(args)[0])))
        elif name in ("START_SPINDLE_CLOCKWISE", "START_SPINDLE_COUNTERCLOCKWISE"):
            events.append(("spindle", 3 if "COUNTER" not in name else 4))
        elif name in ("MIST_ON", "FLOOD_ON"):
            events.append(("coolant", 7 if name == "MIST_ON" else 8))
        elif name in ("PROGRAM_STOP", "OPTIONAL_PROGRAM_STOP"):
            events.append(("pause", 0 if name == "PROGRAM_STOP" else 1))
        elif name == "MESSAGE":
            events.append(("message", args.strip()[1:-1]))
    return moves, events, run


def refusal(run):
    """rs274's error message (its first line naming the error), or ``None`` when it read the
    program."""
    if run.returncode == 0:
        return None
    lines = [line for line in run.stderr.splitlines()
             if line.strip() and line.strip() != "executing"]
    return lines[0].strip() if lines else f"exit status {run.returncode}"


# ---- a path against rs274's ----------------------------------------------------------------

def _segment(p, a, b):
    """The distance from ``p`` to the segment ``a``-``b`` (the run's own measure)."""
    from kontur.machining import _distance_to_segment
    return _distance_to_segment(p, a, b)


def _angle(v):
    return math.atan2(v[1], v[0])


def _arc(p, start, move):
    """Distance of ``p`` from rs274's arc ``move`` begun at ``start`` (its radius from the
    start to the end changing linearly with the angle, as LinuxCNC's)."""
    c, end = move["centre"], move["end"]
    r0 = math.hypot(start[0] - c[0], start[1] - c[1])
    r1 = math.hypot(end[0] - c[0], end[1] - c[1])
    sign = -1 if move["cw"] else 1
    sweep = sign * (_angle((end[0] - c[0], end[1] - c[1]))
                    - _angle((start[0] - c[0], start[1] - c[1])))
    sweep %= 2 * math.pi
    if sweep < 1e-12 or move["turns"] > 1:
        sweep += 2 * math.pi * max(1, move["turns"] - (0 if sweep < 1e-12 else 1))
    at = (sign * (_angle((p[0] - c[0], p[1] - c[1]))
                  - _angle((start[0] - c[0], start[1] - c[1])))) % (2 * math.pi)
    ends = min(math.hypot(p[0] - start[0], p[1] - start[1]),
               math.hypot(p[0] - end[0], p[1] - end[1]))
    if at <= sweep:
        radius = r0 + (r1 - r0) * at / sweep if sweep else r0
        return min(ends, abs(math.hypot(p[0] - c[0], p[1] - c[1]) - radius))
    return ends


def path_distance(point, moves, start):
    """The distance (mm) of ``point`` (mm) from the path of rs274's ``moves`` (begun at
    ``start``, mm): its lines and arcs as curves, rapid moves included, dwells skipped."""
    best = math.inf
    at = start
    for move in moves:
        if move["kind"] == "dwell":
            continue
        if move["kind"] == "arc":
            best = min(best, _arc(point, at, move))
        else:
            best = min(best, _segment(point, at, move["end"]))
        at = move["end"]
    return best


def _samples(moves, start, spacing):
    """Points along rs274's path, ``spacing`` mm apart at most (its ends included)."""
    at = start
    for move in moves:
        if move["kind"] == "dwell":
            continue
        end = move["end"]
        if move["kind"] == "arc":
            c = move["centre"]
            r0 = math.hypot(at[0] - c[0], at[1] - c[1])
            r1 = math.hypot(end[0] - c[0], end[1] - c[1])
            a0 = _angle((at[0] - c[0], at[1] - c[1]))
            sign = -1 if move["cw"] else 1
            sweep = (sign * (_angle((end[0] - c[0], end[1] - c[1])) - a0)) % (2 * math.pi)
            if sweep < 1e-12:
                sweep = 2 * math.pi
            sweep += 2 * math.pi * (move["turns"] - 1)
            count = max(1, math.ceil(sweep * max(r0, r1) / spacing))
            for i in range(count + 1):
                t = i / count
                angle = a0 + sign * sweep * t
                radius = r0 + (r1 - r0) * t
                yield (c[0] + radius * math.cos(angle), c[1] + radius * math.sin(angle))
        else:
            count = max(1, math.ceil(math.hypot(end[0] - at[0], end[1] - at[1]) / spacing))
            for i in range(count + 1):
                t = i / count
                yield (at[0] + (end[0] - at[0]) * t, at[1] + (end[1] - at[1]) * t)
        at = end


def compare_steps(points, moves, start, spm):
    """Both ways between the points a cutter's centre visits (``points``, machine steps) and
    rs274's path (``moves`` from ``start``, mm): ``(out, back)`` in steps, ``out`` the largest
    distance of a visited point from rs274's path, ``back`` the largest distance of a point of
    rs274's path (sampled every quarter step) from the nearest visited point."""
    out = max((path_distance((x / spm, y / spm), moves, start) for x, y in points),
              default=0.0) * spm
    grid = {}
    for x, y in points:
        grid.setdefault((x // 8, y // 8), []).append((x, y))
    back = 0.0
    for px, py in _samples(moves, start, 0.25 / spm):
        sx, sy = px * spm, py * spm
        cx, cy = int(sx // 8), int(sy // 8)
        near = math.inf
        for reach in range(1, 64):
            for gx in range(cx - reach, cx + reach + 1):
                for gy in range(cy - reach, cy + reach + 1):
                    for qx, qy in grid.get((gx, gy), ()):
                        near = min(near, math.hypot(qx - sx, qy - sy))
            if near <= 8 * reach:
                break
        back = max(back, near)
    return out, back


# ---- kontur's compensated path against rs274's ----------------------------------------------

#: Where Debian's linuxcnc-uspace installs LinuxCNC's example programs (GPL: read, not copied).
LINUXCNC_EXAMPLES = Path("/usr/share/linuxcnc/ncfiles")

#: LinuxCNC's compensation examples that are 2D once their Z moves are dropped, and the tool
#: table they assume (tool 4: 1 inch, comp-g1.ngc's comment).
LINUXCNC_COMPENSATED = ("comp311", "comp-g1")
LINUXCNC_TOOLS = {4: Fraction(254, 10)}


def planar_copy(text):
    """A LinuxCNC example without its Z moves: every line whose code (outside comments) has a
    Z word is dropped (they move Z alone in the compensation examples)."""
    out = []
    for line in text.splitlines():
        code = re.sub(r"\(.*?\)|;.*$", "", line)
        if not re.search(r"(?i)z\s*[-+.\d]", code):
            out.append(line)
    return "\n".join(out) + "\n"


#: The board whose controller has the equidistant engine.
BOARD = "ulx3s"


def check_program(text, *, tools=None, steps_per_mm=80, engine="model", name=None):
    """Run ``text`` through rs274 and through ``kontur run --board ulx3s`` (``engine``) and
    compare: a dict with ``rs274`` (its refusal or ``None``), ``kontur`` (kontur's refusal,
    ``"line N: reason"``, or ``None``), and where both ran ``out`` and ``back`` (steps,
    :func:`compare_steps` over the whole path from the program's start) and ``steps``."""
    from kontur import registry
    from kontur.machine import Machine
    from kontur.machining import execute, prepare
    from kontur.planner import ProgramError
    moves, _, run = canonical(text, tools)
    result = {"name": name, "rs274": refusal(run), "kontur": None}
    machine = Machine(clock_hz=registry.board(BOARD).clock_hz, steps_per_mm=steps_per_mm)
    try:
        job = prepare(text, machine=machine, board=BOARD, name=name, tools=tools)
    except ProgramError as error:
        result["kontur"] = f"line {error.line}: {error.reason}"
        return result
    if result["rs274"] is not None:
        return result
    ran = execute(job, engine)
    x, y = job.start[:2]
    points = [(x, y)]
    for dx, dy, *_ in ran.steps:
        x, y = x + dx, y + dy
        points.append((x, y))
    result["out"], result["back"] = compare_steps(points, moves, (0.0, 0.0), steps_per_mm)
    result["steps"] = len(ran.steps)
    return result
