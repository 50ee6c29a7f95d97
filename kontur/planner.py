"""From moves to frames: the step lattice, the look-ahead feed plan, the frames of a program.

:func:`lattice` puts a program's moves (in millimetres) on the step grid: every end point is
rounded to the nearest step, an arc's centre to the lattice point around it whose circle
through the start lies nearest the programmed circle. An arc's start and end radii then
differ by up to about a step; more than the machine's ``arc_tolerance`` is an error naming
the program line (as LinuxCNC does). Within it the arc is traced on its start point's circle
to the path point nearest the programmed end, and a short line (a step or two) finishes
exactly on the end: the machine ends every move, and so the program, exactly where it was
told, to the step. The arc's sweep on the lattice is its programmed sweep within the rounding
(:func:`sweep_slack`): a full turn only where the program's end is its start, a sliver whose
ends round together (or cross) a line to its end, anything else an error naming the line.

:func:`plan` is a look-ahead planner in GRBL's manner: each junction's speed comes from the
angle between the moves and the acceleration (junction deviation), an arc's speed is capped
by its centripetal acceleration, and backward and forward passes make every move's entry and
exit reachable from its neighbours within the acceleration. Each move then gets its cruise and
exit rates (whole rates of the feed generator, never above the feed; a feed below its lowest
rate is an error naming the line) and the step from which it ramps down; the gateware ramps
linearly between them (:class:`kontur.hdl.motion.feed.FeedGenerator`). :func:`frames` writes the
program's frames.
"""

import math
from dataclasses import dataclass, field
from fractions import Fraction

from kontur import registry
from kontur.sim.models.arc import check_arc
from kontur.sim.models.errors import InputError
from kontur.sim.models.helix import PLANES, from_axes, ride, to_axes
from kontur.sim.models.spatial import line_steps as spatial_line_steps
from kontur.hdl.motion import protocol
from kontur.hdl.motion.tools import tool_frame
from kontur.gcode import sweep

__all__ = ["Segment", "PlanItem", "lattice", "step_length", "lift", "plan", "frames",
           "dwell_clocks", "dwell_frames", "ProgramError",
           "on_lattice",
           "check_arc_radii", "check_sweep", "sweep_slack", "min_feed",
           "planned_feed"]


class ProgramError(ValueError):
    """A program the machine refuses: the message names the program line."""

    def __init__(self, line, reason):
        self.line, self.reason = line, reason
        super().__init__(f"line {line}: {reason}" if line is not None else reason)


class _Steep(Exception):
    """A helix steeper than the helix engine takes (:func:`lattice` makes it in chords)."""


#: How far (steps) a chord of a steep helix may be from its circle on the lattice.
CHORD_SAGITTA = 0.25


def _round(value):
    """The nearest integer (halves away from zero), exactly."""
    value = Fraction(value)
    return math.floor(value + Fraction(1, 2)) if value >= 0 else -math.floor(-value + Fraction(1, 2))


#: A step's length by the number of axes it moves (a step moves one to three).
_STEP_LENGTHS = (0.0, 1.0, math.sqrt(2), math.sqrt(3))


def step_length(step):
    """The length of a step (``(dx, dy)`` or ``(dx, dy, dz)``): 1, √2 or √3 step lengths."""
    return _STEP_LENGTHS[sum(1 for d in step if d)]


@dataclass
class Segment:
    """One move on the step lattice: its engine frame, where it starts and ends (steps,
    absolute), its nominal feed (mm/s), its steps and its tangents."""
    line: int
    kind: str
    payload: dict
    start: tuple
    end: tuple
    feed: float
    steps: list
    tangents: tuple
    radius: float = None                  # steps, for an arc
    source: object = None                 # the program's move it comes from (lattice's)

    @property
    def length(self):
        """Path length in step lengths (a diagonal step is √2 long, one on three axes √3):
        on three axes the true 3D length, along which the feed applies."""
        return sum(step_length(step) for step in self.steps)


def on_lattice(point, machine):
    """A point in millimetres on the step lattice: each coordinate rounded to the nearest step
    (halves away from zero), exactly."""
    spm = Fraction(machine.steps_per_mm)
    return tuple(_round(Fraction(c) * spm) for c in point)


def line_pieces(start, end, limit):
    """The points where a line from ``start`` to ``end`` (steps) is split so that no piece
    moves an axis more than ``limit`` steps: the list of the pieces' ends, ``end`` last.

    Where the line passes through lattice points close enough together, the splits are on
    the line itself (its pieces trace the line exactly as one frame would, point for point
    only at the splits); otherwise each split is on the dominant axis, its other coordinate
    rounded to the nearest step (within half a step of the line), so the pieces' steps stay
    within a step of the programmed line."""
    deltas = [b - a for a, b in zip(start, end)]
    dominant = max(abs(d) for d in deltas)
    if dominant <= limit:
        return [tuple(end)]
    common = math.gcd(*deltas)
    primitive = dominant // common
    if primitive <= limit:            # splits on lattice points of the line itself
        count = -(-common // (limit // primitive))
        marks = [_round(Fraction(k * common, count)) for k in range(1, count + 1)]
        return [tuple(a + d // common * j for a, d in zip(start, deltas)) for j in marks]
    count = -(-dominant // limit)
    axis = max(range(len(deltas)), key=lambda n: abs(deltas[n]))
    points = []
    for k in range(1, count + 1):
        along = _round(Fraction(deltas[axis] * k, count))
        points.append(tuple(a + (along if n == axis else _round(Fraction(d * along,
                                                                          deltas[axis])))
                            for n, (a, d) in enumerate(zip(start, deltas))))
    return points


def check_arc_radii(line, start, end, machine):
    """Raise :exc:`ProgramError` (naming ``line``) when an arc's radii at its ``start`` and
    ``end`` (relative to its centre, in steps) differ by more than the machine's
    ``arc_tolerance``; return the start's radius (steps)."""
    spm = float(machine.steps_per_mm)
    r_start, r_end = math.hypot(*start), math.hypot(*end)
    difference = abs(r_start - r_end) / spm
    if difference > machine.arc_tolerance:
        raise ProgramError(line,
                           f"the arc's radius is {r_start / spm:.4f} mm at its start "
                           f"and {r_end / spm:.4f} mm at its end: {difference:.4f} mm "
                           f"apart, more than the {machine.arc_tolerance:g} mm tolerance")
    return r_start


def _unit(*vector):
    norm = math.hypot(*vector)
    return tuple(c / norm for c in vector)


def _path_point(x0, y0, x1, y1, width):
    """The point of the arc's lattice path from ``(x0, y0)`` nearest ``(x1, y1)``: the
    interpolator's path is the lattice points within half a step of the circle along their
    larger coordinate."""
    r2 = x0 * x0 + y0 * y0
    best = None
    for along_x in (True, False):
        fixed = y1 if along_x else x1
        free = x1 if along_x else y1
        if r2 < fixed * fixed:
            continue
        root = math.isqrt(r2 - fixed * fixed)
        for magnitude in range(max(root - 2, 0), root + 3):
            value = magnitude if free >= 0 else -magnitude
            point = (value, fixed) if along_x else (fixed, value)
            try:
                check_arc(x0, y0, *point, width)
            except InputError:
                continue
            distance = (point[0] - x1) ** 2 + (point[1] - y1) ** 2
            if best is None or distance < best[0]:
                best = (distance, point)
    if best is None:
        raise InputError(f"no point of the arc's path near ({x1}, {y1})")
    return best[1]


def _centre(move, start, end, machine):
    """An arc's centre on the lattice: of the four lattice points around the programmed centre
    (and the nearest), the one whose circle through the lattice ``start`` lies nearest the
    programmed circle: the least ``|centre's shift| + |radius's change|`` (the farthest the
    two circles are apart), among those whose ``end`` keeps within the arc tolerance (the
    nearest lattice point when none does: the caller has checked the program's radii on it).
    Rounding the centre and the start each to the nearest step puts the circle up to 2.0 steps
    off the programmed one (the worst of 200 000 random circles); the best of the four, up
    to 1.22."""
    spm = Fraction(machine.steps_per_mm)
    cx, cy = (Fraction(c) * spm for c in move.centre)
    sx, sy = (Fraction(c) * spm for c in move.start)
    radius = math.hypot(sx - cx, sy - cy)
    best = None
    nearest = on_lattice(move.centre, machine)
    for candidate in {nearest, *((math.floor(cx) + i, math.floor(cy) + j)
                                 for i in (0, 1) for j in (0, 1))}:
        r_start = math.hypot(start[0] - candidate[0], start[1] - candidate[1])
        r_end = math.hypot(end[0] - candidate[0], end[1] - candidate[1])
        if abs(r_start - r_end) / float(spm) > machine.arc_tolerance or not r_start:
            continue
        cost = (math.hypot(candidate[0] - cx, candidate[1] - cy) + abs(r_start - radius),
                candidate != nearest, candidate)
        best = cost if best is None or cost < best else best
    return nearest if best is None else best[2]


def sweep_slack(radius):
    """How far (radians) an arc's sweep on the lattice may differ from its programmed sweep,
    for a radius of ``radius`` steps: its start, end and centre are each rounded by up to
    √2/2 of a step, and the path point nearest the end lies up to a step along the circle from
    it, so each end's angle moves by up to (√2 + 1)/``radius``; 4/``radius`` for both ends."""
    return 4 / radius


def _full(move):
    """An arc programmed as a full circle: its end is its start, exactly (as LinuxCNC)."""
    return tuple(move.end) == tuple(move.start)


def _sweeps(move, start, end):
    """An arc's sweeps (radians): as programmed, and on the lattice from ``start`` to ``end``
    (relative to its lattice centre; a full turn where they are one point)."""
    programmed = sweep(move.start, move.end, move.centre, move.cw, full=_full(move))
    traced = sweep(start, end, (0, 0), move.cw, full=tuple(end) == tuple(start))
    return programmed, traced


def _on_sweep(move, start, reach, radius):
    """The end ``reach`` (relative to the lattice centre) of an arc from ``start`` whose sweep
    on the lattice is its programmed sweep: ``reach`` itself, the start (a full circle, for a
    programmed sweep within the rounding of a full turn whose end rounds a hair past its start),
    or ``None`` for a programmed sweep within the rounding of nothing whose lattice arc is not
    (its end rounds onto its start, or a hair behind it: the engine would trace a full turn).

    Raises
    ------
    ProgramError
        When the lattice arc's sweep is none of these (a full circle programmed, another
        traced; a sweep on the lattice that is not the programmed one).
    """
    programmed, traced = _sweeps(move, start, reach)
    slack = sweep_slack(radius)
    if _full(move):
        if traced == programmed:
            return reach
    elif abs(traced - programmed) <= slack:
        return reach
    elif programmed >= 2 * math.pi - slack and traced <= slack:
        return start
    elif programmed <= slack:
        return None
    raise ProgramError(move.line, f"the arc sweeps {math.degrees(programmed):.4f} degrees as "
                                  f"programmed but {math.degrees(traced):.4f} on the step "
                                  f"lattice, more than its rounding "
                                  f"({math.degrees(slack):.4f}) apart")


def check_sweep(move, start, end, radius):
    """Raise :exc:`ProgramError` unless the arc of ``move`` on the lattice, from ``start`` to
    ``end`` (relative to its lattice centre, ``radius`` steps), sweeps its programmed sweep
    within the rounding (:func:`sweep_slack`): a full circle only where one is programmed.
    (A compensated contour's arc, which the equidistant engine traces as it is given.)"""
    if _on_sweep(move, start, end, radius) != tuple(end):
        programmed, traced = _sweeps(move, start, end)
        raise ProgramError(move.line, f"the arc sweeps {math.degrees(programmed):.4f} degrees "
                                      f"as programmed but {math.degrees(traced):.4f} on the "
                                      f"step lattice: too short for a compensated contour")


def lattice(moves, machine, *, variants=("exact", "fast"), widths=(16, 24), start=None,
            axes=2):
    """The moves on the step lattice: a list of :class:`Segment`.

    With ``axes=3`` (a 3-axis controller's) every point is ``(x, y, z)`` (steps; Z from 0
    until the program's first Z word, then where the moves put it: ``move.z``), a line is a
    LINE3 frame (``x``, ``y``, ``z``) traced by the spatial core's model, and an arc a HELIX
    frame: the plain arc's XY steps with the move's Z spread over them (``z``, and ``n`` the
    arc's step count: :func:`kontur.sim.models.helix.ride`); its finishing line (below) moves
    XY only. The steps are ``(dx, dy, dz)``.

    ``moves`` have ``line``, ``kind`` (``"rapid"``, ``"line"``, ``"arc"``), ``start``,
    ``end``, ``centre``, ``cw`` and ``feed`` (mm/min, ``None`` for the machine's maximum), in
    millimetres; on three axes ``z``, and an arc in XZ or YZ (G18, G19) its ``plane`` and
    :attr:`~kontur.gcode.Move.in_plane` (:class:`kontur.gcode.Move`): it is worked out in its
    plane as a G17 arc, its HELIX frame naming the plane. ``variants`` and ``widths`` are the line
    and arc engines' (their steps are the segments' steps). The first move starts at ``start``
    (steps) when it is given (where the machine is: after a compensated contour, on its
    equidistant), else at its own start.

    Raises
    ------
    ProgramError
        For an arc whose radii differ by more than the tolerance, an arc of radius zero, or an
        arc the engines cannot make (too wide for their registers). A line longer than the
        line engine's registers is made in pieces (:func:`line_pieces`); on three axes a helix
        steeper than one step of its normal axis per step of its arc, which the helix engine
        refuses, in chords (:data:`CHORD_SAGITTA`).
    """
    segments = []
    position = None if start is None else tuple(start)
    if position is not None and len(position) < axes:
        position += (0,) * (axes - len(position))

    source = None

    def add(line, kind, payload, start, end, feed, tangents=None, radius=None):
        variant, width = (variants[0], widths[0]) if kind == "line" else (variants[1], widths[1])
        try:
            if axes == 3 and kind == "line":
                steps = spatial_line_steps(payload["x"], payload["y"], payload["z"],
                                           width=width)
            elif axes == 3:
                arc = {name: payload[name] for name in ("x0", "y0", "x1", "y1", "cw")}
                xy = registry.steps(kind, arc, variant, width=width)
                payload["n"] = len(xy)
                if abs(payload["z"]) > len(xy):     # (made in chords instead: below)
                    raise _Steep
                steps = ride(xy, payload["z"], width=width)
                if payload.get("plane"):  # G18, G19: the native steps on the machine's axes
                    steps = [to_axes(step, payload["plane"]) for step in steps]
            else:
                steps = registry.steps(kind, payload, variant, width=width)
        except InputError as error:
            raise ProgramError(line, str(error)) from None
        if not steps:
            return
        if tangents is None:
            direction = _unit(*(b - a for a, b in zip(start, end)))
            tangents = (direction, direction)
        segments.append(Segment(line, kind, payload, start, end, feed, steps, tangents,
                                radius, source))

    for move in moves:
        source = move
        if position is None:
            position = on_lattice(move.start, machine) + (0,) * (axes - 2)
        if move.kind == "dwell":          # G4: the machine waits where it is
            segments.append(Segment(move.line, "dwell", {"seconds": move.seconds}, position,
                                    position, 0.0, [], None, None, move))
            continue
        speed = machine.max_feed if move.kind == "rapid" or move.feed is None else \
            min(float(move.feed), machine.max_feed)
        feed = speed / 60
        end = on_lattice(move.end, machine)
        if axes == 3:                     # Z where the move ends (it stays before a Z word)
            end += (position[2] if move.z is None else on_lattice((move.z,), machine)[0],)
        if move.kind in ("rapid", "line"):   # a line longer than the registers: in pieces
            for piece in line_pieces(position, end, (1 << widths[0]) - 1):
                add(move.line, "line", dict(zip("xyz", (b - a for a, b in zip(position, piece)))),
                    position, piece, feed)
                position = piece
            continue
        # An arc in XZ or YZ (G18, G19) is worked out in its plane's coordinates (first,
        # second and normal axis, kontur.gcode.PLANE_AXES) as a G17 one; its segments' points,
        # steps and tangents go back on the machine's axes, and its HELIX frame says the plane
        # (kontur.hdl.helix.HelixEngine).
        plane = PLANES[getattr(move, "plane", 17)]
        machine_end = end
        if plane:
            move = move.in_plane
            position, end = from_axes(position, plane), from_axes(end, plane)

        def emit(kind, payload, start, end, tangents=None, radius=None):
            if plane:
                start, end = to_axes(start, plane), to_axes(end, plane)
                tangents = tangents and tuple(to_axes(t, plane) for t in tangents)
                if kind == "arc":
                    payload["plane"] = plane
            if kind == "line":
                payload = dict(zip("xyz", (b - a for a, b in zip(start, end))))
            add(move.line, kind, payload, start, end, feed, tangents, radius)

        # The program's arc, its centre rounded to the nearest step: refused as before (radius
        # zero, radii beyond the tolerance); then the lattice centre nearest its circle.
        centre = on_lattice(move.centre, machine)
        if position[:2] == centre:        # (in the plane: on three axes the position has more)
            raise ProgramError(move.line, "the arc's start is its centre: radius zero")
        check_arc_radii(move.line, (position[0] - centre[0], position[1] - centre[1]),
                        (end[0] - centre[0], end[1] - centre[1]), machine)
        centre = _centre(move, position, end, machine)
        x0, y0 = position[0] - centre[0], position[1] - centre[1]
        x1, y1 = end[0] - centre[0], end[1] - centre[1]
        r_start = math.hypot(x0, y0)      # radii within the tolerance: _centre chose so
        try:                              # the start and radius in the engine's registers
            check_arc(x0, y0, x0, y0, widths[1])
        except InputError:
            raise ProgramError(move.line, f"the arc's radius, {r_start:.0f} steps "
                                          f"({r_start / machine.steps_per_mm:g} mm), is more "
                                          f"than this board's {widths[1]}-bit arc engine takes "
                                          f"({(1 << widths[1]) - 1} steps)") from None
        try:
            reach = _path_point(x0, y0, x1, y1, widths[1])
        except InputError as error:
            raise ProgramError(move.line, str(error)) from None
        reach = _on_sweep(move, (x0, y0), reach, r_start)
        cw = int(bool(move.cw))
        sign = -1 if cw else 1

        def tangent(x, y, rise, run):
            # On three axes the tangents have Z: the helix's rise over its length in the plane.
            if axes == 3:
                return _unit(-sign * y / r_start * run, sign * x / r_start * run, rise)
            return _unit(-sign * y, sign * x)

        def helix(here, there, x1, y1, sweep):
            """The arc from ``here`` to ``there`` (``(x1, y1)`` from the centre) turning
            ``sweep``; a helix steeper than one step of the normal axis per step of the arc,
            which the helix engine refuses, as chords: lines (the spatial core's) between
            lattice points nearest the programmed circle, the normal axis even over the angle,
            no chord more than :data:`CHORD_SAGITTA` steps from the circle."""
            rise = there[2] - here[2] if axes == 3 else 0
            run = r_start * max(sweep, 1e-9)
            payload = {"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw}
            if axes == 3:
                payload["z"] = rise
            try:
                emit("arc", payload, here, there,
                     (tangent(x0, y0, rise, run), tangent(x1, y1, rise, run)), r_start)
                return
            except _Steep:
                pass
            # (the vertices on the programmed circle, the judge's: the lattice's circle may be
            # a step off it, and a vertex rounded half a diagonal off its own)
            spm = float(machine.steps_per_mm)
            cx, cy = (float(c) * spm for c in move.centre)
            radius = math.dist((float(move.start[0]) * spm, float(move.start[1]) * spm),
                               (cx, cy))
            a0 = math.atan2(float(move.start[1]) * spm - cy, float(move.start[0]) * spm - cx)
            count = max(2, math.ceil(sweep / (2 * math.acos(1 - CHORD_SAGITTA / radius))))
            points = [here]
            for k in range(1, count):
                angle = a0 + sign * sweep * k / count
                points.append((round(cx + radius * math.cos(angle)),
                               round(cy + radius * math.sin(angle)),
                               here[2] + round(rise * k / count)))
            for start, stop in zip(points, points[1:] + [there]):
                emit("line", None, start, stop)

        # G2/G3 P: the whole turns first, each a full circle from the start, the normal axis
        # rising evenly over the whole angle (rs274's ARC_FEED with its turns).
        turns = getattr(move, "turns", 1)
        first = position
        for k in range(1, turns):
            here = position
            if axes == 3:
                share = 2 * math.pi * k / move.total_sweep
                position = position[:2] + (first[2] + round((end[2] - first[2]) * share),)
            helix(here, position, x0, y0, 2 * math.pi)
        if reach is None:                 # a sweep that rounds to nothing: a line to the end
            emit("line", None, position, end)
            position = machine_end
            continue
        arrive = (centre[0] + reach[0], centre[1] + reach[1]) + tuple(end[2:])
        helix(position, arrive, *reach, _sweeps(move, (x0, y0), reach)[1])
        if arrive != end:                 # finish exactly on the programmed end
            emit("line", None, arrive, end)
        position = machine_end
    return segments


@dataclass
class PlanItem:
    """The feed plan of one segment: entry, cruise and exit speeds (mm/s), the step from
    which it ramps down, its duration (s)."""
    entry: float
    cruise: float
    exit: float
    decelerate: int
    seconds: float


#: How much longer a move takes at least than its frames (FEED and the move's) on the link at
#: the machine's baud: the link at most two thirds busy, so that the board's queue never runs
#: dry in the middle of the motion (:func:`plan`, 4).
LINK_MARGIN = 1.5


def link_seconds(segment, machine):
    """The time (s) a move's frames, its FEED and its move frame, take on the link at the
    machine's baud (10 bits a byte)."""
    return (len(protocol.feed(0, 0, 0)) + len(_move_frame(segment))) * 10 / machine.baud


def link_feed(segment, machine):
    """The highest speed (mm/s) a move may cruise at for its frames to keep ahead of it: its
    length over :data:`LINK_MARGIN` times :func:`link_seconds`."""
    return segment.length / machine.steps_per_mm / (LINK_MARGIN * link_seconds(segment, machine))


#: The step lengths before a move's end at which the feed generator is to be at the exit rate:
#: its ramp-down begins that much early (the generator's look-ahead and the rounding of its
#: rate), and the last of the move runs at the exit rate.
MARGIN_STEPS = 2


def step_seconds(segment, item, machine):
    """The duration (s) of each step of ``segment`` under ``item``'s plan, as the feed
    generator makes it: up from the entry speed, at most the cruise, down to the exit speed
    :data:`MARGIN_STEPS` step lengths before the end and at the exit speed from there; each
    step at the speed in its middle."""
    a, spm = machine.accel, machine.steps_per_mm
    total = segment.length / spm
    ramp_end = max(total - MARGIN_STEPS / spm, 0)
    out, covered = [], 0.0
    for each in segment.steps:
        step = step_length(each) / spm
        middle = covered + step / 2
        speed = min(math.sqrt(item.entry ** 2 + 2 * a * middle), item.cruise,
                    math.sqrt(item.exit ** 2 + 2 * a * max(ramp_end - middle, 0)))
        out.append(step / max(speed, 1e-9))
        covered += step
    return out


def _junction(previous, following, machine):
    """The highest speed (mm/s) through the corner from ``previous`` into ``following``."""
    a, b = previous.tangents[1], following.tangents[0]
    cos_theta = -sum(p * q for p, q in zip(a, b))
    if cos_theta > 0.999999:             # a reversal
        return 0.0
    if cos_theta < -0.999999:            # straight on
        return math.inf
    sin_half = math.sqrt(0.5 * (1 - cos_theta))
    return math.sqrt(machine.accel * machine.junction_deviation * sin_half / (1 - sin_half))


def rest_speed(machine):
    """The speed (mm/s) a move that ends at rest in the plan ends at: one step stops it within
    the acceleration, ``sqrt(2 accel / steps_per_mm)`` (:func:`plan`, 3); a move's exit above
    it goes on at speed into the next move."""
    return math.sqrt(2 * machine.accel / machine.steps_per_mm)


def min_feed(machine):
    """The lowest contour speed (mm/s) the feed generator makes: a rate of 1 in Q0.24, one
    step length every 2**24 clocks (:class:`kontur.hdl.motion.feed.FeedGenerator` adds the rate's
    upper 24 bits to its distance every clock, so a lower rate is 0 and never steps). Every
    rate the planner sends is a whole number of these (:func:`plan`)."""
    return machine.clock_hz / (machine.steps_per_mm * (1 << 24))


def _quantise(speed, unit):
    """``speed`` rounded down to the feed generator's rates (whole units): never faster
    than asked."""
    return math.floor(speed / unit + 1e-9) * unit


def planned_feed(feed, machine):
    """The feed (mm/min) the plan cruises at for a programmed ``feed`` (mm/min): capped by the
    machine's ``max_feed`` and rounded down to the feed generator's rates (an arc's
    centripetal cap and a move too short to reach it apart)."""
    unit = min_feed(machine)
    return max(_quantise(min(float(feed), machine.max_feed) / 60, unit), unit) * 60


def plan(segments, machine):
    """The feed plan of ``segments``: a :class:`PlanItem` each.

    A dwell (a segment of kind ``"dwell"``: G4, or a tool change on a board with tool
    outputs) stops the machine: the moves before it end at
    rest and those after it start from rest (each stretch between dwells is planned alone), and
    its item is its time. A tool change taken on the fly (payload ``"stop"`` false: laser
    mode's change of power, :func:`kontur.machining.tool_changes`) stops nothing: the moves
    round it are planned as if it were not there, and its item is all zero.

    1. Every speed of the plan (a move's cruise, its exit, the next move's entry) is one the
       feed generator makes: its rate rounded down to a whole Q0.24 rate (:func:`min_feed`),
       so a move is never faster than its feed and its planned time is the generator's.
    2. A move cruises at its feed (capped by the machine's maximum and, on an arc, by the
       centripetal acceleration), however low: a feed below :func:`min_feed` is refused.
    3. A move that ends at rest in the plan (a reversal, the program's end) ends at the speed
       from which one step stops it within the acceleration, ``sqrt(2 accel / steps_per_mm)``,
       or its own cruise and the next move's if they are lower: the generator ramps toward
       the exit rate, and a rate of zero would never make the last step.
    4. A move cruises no faster than its frames arrive: it takes at least :data:`LINK_MARGIN`
       times its frames' time on the link (:func:`link_seconds`; a move of no length, the
       equidistant engine's frame of a corner it passes without motion, is left as it is). The board's queue then
       fills while the machine moves and never runs dry in the middle of the motion, where
       the machine would stop at once, at speed, and go on at that speed when the next frame
       came (the feed generator keeps the rate of the move before): many short moves at a
       high feed (a finely divided curve) run slower than their feed instead.

    Raises
    ------
    ProgramError
        For a feed below :func:`min_feed`, naming the line and the minimum.
    """
    if not any(s.kind == "dwell" for s in segments):
        return _plan(segments, machine)
    items, stretch = [], []

    def moves(stretch):                  # planned together, a change on the fly in its place
        planned = iter(_plan([s for s in stretch if s.kind != "dwell"], machine))
        return [PlanItem(0.0, 0.0, 0.0, 0, 0.0) if s.kind == "dwell" else next(planned)
                for s in stretch]

    for segment in segments:
        if segment.kind == "dwell" and segment.payload.get("stop", True):
            items += moves(stretch)
            stretch = []
            items.append(PlanItem(0.0, 0.0, 0.0, 0, float(segment.payload["seconds"])))
        else:
            stretch.append(segment)
    return items + moves(stretch)


def _plan(segments, machine):
    """:func:`plan` of segments without a dwell."""
    spm = machine.steps_per_mm
    a = machine.accel
    unit = min_feed(machine)
    floor = rest_speed(machine)
    lengths = [s.length / spm for s in segments]
    nominal = []
    for s in segments:
        if s.feed < unit * (1 - 1e-9):
            raise ProgramError(s.line, f"the feed {s.feed * 60:g} mm/min is below the lowest "
                                       f"the feed generator makes, {unit * 60:.4f} mm/min (one "
                                       f"step in 2^24 clocks at {machine.clock_hz:g} Hz and "
                                       f"{spm:g} steps/mm)")
        v = s.feed
        if s.radius:
            v = min(v, math.sqrt(a * s.radius / spm))       # centripetal acceleration
        if s.length:                    # (a profile frame of no motion: nothing to slow)
            v = min(v, link_feed(s, machine))
        nominal.append(max(_quantise(v, unit), unit))
    count = len(segments)
    limit = [0.0] * (count + 1)                # speed limits at the junctions
    for i in range(1, count):
        limit[i] = min(_junction(segments[i - 1], segments[i], machine), nominal[i - 1],
                       nominal[i])
    for i in range(count - 1, -1, -1):         # backward: able to slow down in time
        limit[i] = min(limit[i], math.sqrt(limit[i + 1] ** 2 + 2 * a * lengths[i]))
    for i in range(count):                     # forward: able to speed up in time
        limit[i + 1] = min(limit[i + 1], math.sqrt(limit[i] ** 2 + 2 * a * lengths[i]))
    items = []
    v0 = 0.0
    for i, s in enumerate(segments):
        following = nominal[i + 1] if i + 1 < count else math.inf
        v1 = _quantise(max(limit[i + 1], min(floor, nominal[i], following), unit), unit)
        length = lengths[i]
        peak = math.sqrt(max((2 * a * length + v0 * v0 + v1 * v1) / 2, 0))
        vc = max(_quantise(min(nominal[i], peak), unit), v1, v0)
        down = max((vc * vc - v1 * v1) / (2 * a), 0) * spm + MARGIN_STEPS   # step lengths
        remaining = s.length
        decelerate = 0
        for index, step in enumerate(s.steps):
            if remaining < down:
                break
            decelerate = index
            remaining -= step_length(step)
        item = PlanItem(v0, vc, v1, decelerate, 0.0)
        item.seconds = sum(step_seconds(s, item, machine))
        items.append(item)
        v0 = v1
    return items


def lift(segments):
    """2-axis segments (a compensated program's, which keeps Z where it is) for a 3-axis
    controller: every point and step with Z 0, a line a LINE3 frame's, an arc a HELIX frame's
    with no Z move (``n`` its step count); a PROFILE segment keeps its frame (its engine is on
    two axes)."""
    out = []
    for s in segments:
        payload = dict(s.payload)
        if s.kind == "line":
            payload["z"] = 0
        elif s.kind == "arc":
            payload |= {"z": 0, "n": len(s.steps)}
        tangents = None if s.tangents is None else tuple(tuple(t) + (0.0,) for t in s.tangents)
        out.append(Segment(s.line, s.kind, payload, tuple(s.start) + (0,), tuple(s.end) + (0,),
                           s.feed, [tuple(step) + (0,) for step in s.steps], tangents,
                           s.radius, s.source))
    return out


def _move_frame(segment):
    """The frame of a segment: a LINE (LINE3 on three axes), an ARC (HELIX), or a PROFILE (one frame of the equidistant
    engine: ``payload`` is ``{"frame": its fields, "width": the engine's width}``)."""
    p = segment.payload
    if segment.kind == "line":
        return protocol.line3(p["x"], p["y"], p["z"]) if "z" in p else \
            protocol.line(p["x"], p["y"])
    if segment.kind == "arc":
        if "n" in p:                      # a 3-axis controller's: a helix (Z may be 0)
            return protocol.helix(p["x0"], p["y0"], p["x1"], p["y1"], p["cw"], p["z"], p["n"],
                                  p.get("plane", 0))
        return protocol.arc(p["x0"], p["y0"], p["x1"], p["y1"], p["cw"])
    return protocol.profile(p["frame"], width=p["width"])


def dwell_clocks(seconds, machine, compress=1):
    """The DWELL frames' clocks for a dwell of ``seconds`` (its time divided by the time
    compression): one frame for each 2**32 - 1 clocks, none for a dwell of no clock."""
    clocks = round(Fraction(seconds) * Fraction(machine.clock_hz) / compress)
    limit = (1 << 32) - 1
    return [limit] * (clocks // limit) + ([clocks % limit] if clocks % limit else [])


def dwell_frames(segment, machine, compress=1):
    """The frames of a stop (a segment of kind ``"dwell"``): its DWELL frames
    (:func:`dwell_clocks`), then the TOOL frame of a tool change (``payload["tool"]``, the
    keywords of :func:`kontur.hdl.motion.tools.tool_frame`), which the controller's tool
    outputs take in its turn, after the move before has ended."""
    out = [protocol.dwell(clocks)
           for clocks in dwell_clocks(segment.payload["seconds"], machine, compress)]
    if "tool" in segment.payload:
        out.append(tool_frame(**segment.payload["tool"]))
    return out


def frames(segments, items, machine, *, compress=1):
    """The frames of the program: the configuration, a FEED and a move for each segment (a
    stop's DWELL and TOOL frames, :func:`dwell_frames`), the STOP. A rapid's FEED (a segment of a G0
    move) carries the rapid flag. Returns ``(frames, lines)``: the bytes of each frame, and the program line each
    frame comes from (``None`` for CONFIG and STOP).

    With ``compress`` (a simulation's time compression) every rate is ``compress`` times the
    planned one and the acceleration ``compress**2`` times: the same ramps, ``compress`` times
    faster; the steps do not change.

    Raises
    ------
    ProgramError
        When a value does not fit its field (nothing is clamped): a rate beyond FEED's 24 bits
        (Q0.24), a ramp-down step beyond its 24 bits, the compressed acceleration beyond
        CONFIG's 32 bits (Q0.40).
    """
    if isinstance(compress, bool) or not isinstance(compress, int) or compress < 1:
        raise ValueError(f"Time compression must be a positive integer, not {compress!r}")
    accel = machine.accel_q40 * compress ** 2
    if accel >= 1 << 32:
        raise ProgramError(None, f"a time compression of {compress} makes the acceleration "
                                 f"{accel} a clock (Q0.40), beyond CONFIG's 32-bit field")
    out, lines = [protocol.config(accel)], [None]
    for segment, item in zip(segments, items):
        if segment.kind == "dwell":       # DWELL frames, a TOOL frame: between moves
            stop = dwell_frames(segment, machine, compress)
            out += stop
            lines += [segment.line] * len(stop)
            continue
        if item.decelerate >= 1 << 24:
            raise ProgramError(segment.line, f"the move has {len(segment.steps)} steps: its "
                                             f"ramp-down starts at step {item.decelerate}, "
                                             f"beyond FEED's 24-bit field (at most "
                                             f"{(1 << 24) - 1})")
        try:
            rates = machine.rate(item.cruise * compress), machine.rate(item.exit * compress)
        except ValueError as error:          # MachineError: never clamped
            raise ProgramError(segment.line, f"{error} (time compression {compress})") \
                from None
        # A rapid (G0) says so: the rapid override applies to it, not the feed override.
        rapid = getattr(segment.source, "kind", None) == "rapid"
        out.append(protocol.feed(*rates, item.decelerate, rapid=rapid))
        out.append(_move_frame(segment))
        lines += [segment.line, segment.line]
    out.append(protocol.stop())
    lines.append(None)
    return out, lines
