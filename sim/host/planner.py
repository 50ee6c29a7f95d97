"""From moves to frames: the step lattice, the look-ahead feed plan, the frames of a program.

:func:`lattice` puts a program's moves (in millimetres) on the step grid: every end point
and arc centre is rounded to the nearest step. An arc's start and end radii then differ by up
to about a step; more than the machine's ``arc_tolerance`` is an error naming the program
line (as LinuxCNC does). Within it the arc is traced on its start point's circle to the path
point nearest the programmed end, and a short line (a step or two) finishes exactly on the
end: the machine ends every move, and so the program, exactly where it was told, to the step.

:func:`plan` is a look-ahead planner in GRBL's manner: each junction's speed comes from the
angle between the moves and the acceleration (junction deviation), an arc's speed is capped
by its centripetal acceleration, and backward and forward passes make every move's entry and
exit reachable from its neighbours within the acceleration. Each move then gets its cruise
and exit rates and the step from which it ramps down; the gateware ramps linearly between
them (:class:`hdl.motion.feed.FeedGenerator`). :func:`frames` writes the program's frames.
"""

import math
from dataclasses import dataclass, field
from fractions import Fraction

from .. import registry
from ..models.arc import check_arc
from ..models.errors import InputError
from . import protocol

__all__ = ["Segment", "PlanItem", "lattice", "plan", "frames", "ProgramError", "on_lattice",
           "check_arc_radii"]


class ProgramError(ValueError):
    """A program the machine refuses: the message names the program line."""

    def __init__(self, line, reason):
        self.line, self.reason = line, reason
        super().__init__(f"line {line}: {reason}" if line is not None else reason)


def _round(value):
    """The nearest integer (halves away from zero), exactly."""
    value = Fraction(value)
    return math.floor(value + Fraction(1, 2)) if value >= 0 else -math.floor(-value + Fraction(1, 2))


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

    @property
    def length(self):
        """Contour length in step lengths (a diagonal step is √2 long)."""
        return sum(math.sqrt(2) if dx and dy else 1.0 for dx, dy in self.steps)


def on_lattice(point, machine):
    """A point in millimetres on the step lattice: each coordinate rounded to the nearest step
    (halves away from zero), exactly."""
    spm = Fraction(machine.steps_per_mm)
    return tuple(_round(Fraction(c) * spm) for c in point)


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


def _unit(x, y):
    norm = math.hypot(x, y)
    return (x / norm, y / norm)


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


def lattice(moves, machine, *, variants=("exact", "fast"), widths=(16, 24), start=None):
    """The moves on the step lattice: a list of :class:`Segment`.

    ``moves`` have ``line``, ``kind`` (``"rapid"``, ``"line"``, ``"arc"``), ``start``,
    ``end``, ``centre``, ``cw`` and ``feed`` (mm/min, ``None`` for the machine's maximum), in
    millimetres. ``variants`` and ``widths`` are the line and arc engines' (their steps are
    the segments' steps). The first move starts at ``start`` (steps) when it is given (where
    the machine is: after a compensated contour, on its equidistant), else at its own start.

    Raises
    ------
    ProgramError
        For an arc whose radii differ by more than the tolerance, an arc of radius zero, or a
        move the engines cannot make (too wide for their registers).
    """
    segments = []
    position = None if start is None else tuple(start)

    def add(line, kind, payload, start, end, feed, tangents=None, radius=None):
        variant, width = (variants[0], widths[0]) if kind == "line" else (variants[1], widths[1])
        try:
            steps = registry.steps(kind, payload, variant, width=width)
        except InputError as error:
            raise ProgramError(line, str(error)) from None
        if not steps:
            return
        if tangents is None:
            direction = _unit(end[0] - start[0], end[1] - start[1])
            tangents = (direction, direction)
        segments.append(Segment(line, kind, payload, start, end, feed, steps, tangents,
                                radius))

    for move in moves:
        speed = machine.max_feed if move.kind == "rapid" or move.feed is None else \
            min(float(move.feed), machine.max_feed)
        feed = speed / 60
        if position is None:
            position = on_lattice(move.start, machine)
        end = on_lattice(move.end, machine)
        if move.kind in ("rapid", "line"):
            add(move.line, "line", {"x": end[0] - position[0], "y": end[1] - position[1]},
                position, end, feed)
            position = end
            continue
        centre = on_lattice(move.centre, machine)
        x0, y0 = position[0] - centre[0], position[1] - centre[1]
        x1, y1 = end[0] - centre[0], end[1] - centre[1]
        if (x0, y0) == (0, 0):
            raise ProgramError(move.line, "the arc's start is its centre: radius zero")
        r_start = check_arc_radii(move.line, (x0, y0), (x1, y1), machine)
        try:
            reach = _path_point(x0, y0, x1, y1, widths[1])
        except InputError as error:
            raise ProgramError(move.line, str(error)) from None
        cw = int(bool(move.cw))
        sign = -1 if cw else 1

        def tangent(x, y):
            return _unit(-sign * y, sign * x)

        arrive = (centre[0] + reach[0], centre[1] + reach[1])
        add(move.line, "arc", {"x0": x0, "y0": y0, "x1": reach[0], "y1": reach[1], "cw": cw},
            position, arrive, feed, (tangent(x0, y0), tangent(*reach)), r_start)
        if arrive != end:                 # finish exactly on the programmed end
            add(move.line, "line", {"x": end[0] - arrive[0], "y": end[1] - arrive[1]},
                arrive, end, feed)
        position = end
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


def _junction(previous, following, machine):
    """The highest speed (mm/s) through the corner from ``previous`` into ``following``."""
    a, b = previous.tangents[1], following.tangents[0]
    cos_theta = -(a[0] * b[0] + a[1] * b[1])
    if cos_theta > 0.999999:             # a reversal
        return 0.0
    if cos_theta < -0.999999:            # straight on
        return math.inf
    sin_half = math.sqrt(0.5 * (1 - cos_theta))
    return math.sqrt(machine.accel * machine.junction_deviation * sin_half / (1 - sin_half))


def plan(segments, machine):
    """The feed plan of ``segments``: a :class:`PlanItem` each."""
    spm = machine.steps_per_mm
    a = machine.accel
    # The slowest speed a move may end at: what one step's acceleration from rest gives (the
    # gateware's rate must not reach zero before the last step).
    floor = math.sqrt(2 * a / spm)
    lengths = [s.length / spm for s in segments]
    nominal = []
    for s in segments:
        v = s.feed
        if s.radius:
            v = min(v, math.sqrt(a * s.radius / spm))       # centripetal acceleration
        nominal.append(max(v, floor))
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
    for i, s in enumerate(segments):
        v0, v1, length = limit[i], max(limit[i + 1], floor), lengths[i]
        peak = math.sqrt(max((2 * a * length + v0 * v0 + v1 * v1) / 2, 0))
        vc = max(min(nominal[i], peak), v1, v0)
        down = max((vc * vc - v1 * v1) / (2 * a), 0) * spm + 1     # step lengths, and one more
        remaining = s.length
        decelerate = 0
        for index, (dx, dy) in enumerate(s.steps):
            if remaining < down:
                break
            decelerate = index
            remaining -= math.sqrt(2) if dx and dy else 1.0
        up = max((vc * vc - v0 * v0) / (2 * a), 0)
        down_mm = max((vc * vc - v1 * v1) / (2 * a), 0)
        cruise_mm = max(length - up - down_mm, 0)
        seconds = (vc - v0) / a + (vc - v1) / a + cruise_mm / vc
        items.append(PlanItem(v0, vc, v1, decelerate, seconds))
    return items


def _move_frame(segment):
    """The frame of a segment: a LINE, an ARC, or a PROFILE (one frame of the equidistant
    engine: ``payload`` is ``{"frame": its fields, "width": the engine's width}``)."""
    p = segment.payload
    if segment.kind == "line":
        return protocol.line(p["x"], p["y"])
    if segment.kind == "arc":
        return protocol.arc(p["x0"], p["y0"], p["x1"], p["y1"], p["cw"])
    return protocol.profile(p["frame"], width=p["width"])


def frames(segments, items, machine, *, compress=1):
    """The frames of the program: the configuration, a FEED and a move for each segment, the
    STOP. Returns ``(frames, lines)``: the bytes of each frame, and the program line each
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
        out.append(protocol.feed(*rates, item.decelerate))
        out.append(_move_frame(segment))
        lines += [segment.line, segment.line]
    out.append(protocol.stop())
    lines.append(None)
    return out, lines
