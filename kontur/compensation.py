"""G41 / G42 in the machine controller: compensated contours through Siimut's equidistant engine.

:func:`program_segments` puts a program with compensated contours on the step lattice for a
board whose controller has the equidistant engine (:attr:`kontur.registry.Board.profile`): the
moves outside the contours as :func:`kontur.planner.lattice` puts them, and every contour
(the moves made while G41 or G42 is in effect) as the engine's frames, one
:class:`~kontur.planner.Segment` of kind ``"profile"`` each, with the steps the engine makes
in it (its step model, :func:`kontur.registry.outcomes`), so that the look-ahead planner
(:func:`~kontur.planner.plan`) gives every frame its FEED like a line's or an arc's.

A contour on the lattice. Its points and arc centres are rounded to the nearest step, as every
move's are; an arc's radius is the mean of its start's and its end's on the lattice, which may
differ by the machine's ``arc_tolerance`` (more is an error naming the line, as for any arc).
The ends stay where they were rounded to, where the elements meet: the engine does not trace an
arc from its start or to its end point but from and to where the elements' equidistants (or
their entry lines) meet, so the arc's ends only have to be near its circle
(:func:`kontur.sim.models.equidistant.profile_from_moves`'s ``tolerance``). The contour is then
prepared at the cutter radius (the machine's ``cutter_radius``, in steps exactly: the engine
dials its whole steps and the elements' frames carry the rest, so that a radius half a step
off the lattice does not move the path by half a step)
by :func:`kontur.sim.models.equidistant.prepare`, which refuses impossible geometry and any contour
whose path it cannot bound (0.85 steps from the exact equidistant), naming the line.

LinuxCNC's rules (``rs274``; docs/equidistant.md): the first move of a contour, a line, is
its *entry move* (:attr:`kontur.sim.models.equidistant.Profile.lead`): it must be longer than
the cutter radius, and the cutter goes straight from where it is (the approach) to where the
line's equidistant meets the first element's; the last element ends on its normal at its end
point, where the move after G40 begins; convex corners go round on an arc of the cutter radius
(the machine's ``corner``, ``"arc"``; ``"miter"`` extends them up to 2 radii).

Coordinates. The engine's registers hold ``±(2**width - 1)``; its frames are in coordinates
relative to the contour's *origin*, the lattice point nearest the middle of the contour's
extent, so a contour of up to about ``2**(width + 1)`` steps across runs anywhere on the
machine (the steps do not depend on the origin: every number of a frame moves with it
exactly).

The frames of a contour, in program order: ``START`` (the engine's counters at the cutter's
centre where the contour begins), the approach (a LINE from where the machine is to that
point, when it is elsewhere), the elements, ``CLOSE`` for a closed contour. ``RADIUS`` is sent
once, at the head of the program. ``START`` goes before the approach because the engine takes
it only once every frame before it has its outcome: sent after the approach it would wait for
the approach's end, and the contour's first elements would be read and formed only then, a
pause at the joint; sent before, the engine forms them while the approach moves. A frame
without steps (``RADIUS``, ``START``, the terminal, an empty ``CLOSE``) is a segment of length
zero to the planner: its FEED holds the rate it arrives at. After a contour the machine is on
its equidistant: the next move starts there (an arc right after a contour is therefore
refused unless the cutter radius is within the arc tolerance).
"""

import math
import re
from collections import namedtuple
from dataclasses import dataclass, replace
from fractions import Fraction

from kontur import registry
from kontur.gcode import Move
from kontur.sim.models import equidistant
from kontur.planner import ProgramError, Segment, check_arc_radii, check_sweep, lattice, on_lattice

__all__ = ["Contour", "runs", "program_segments", "references", "needs_engine",
           "contour_radius"]

#: A move on the lattice, as :func:`kontur.sim.models.equidistant.profile_from_moves` reads it.
_LatticeMove = namedtuple("_LatticeMove", "line kind start end centre cw side r2")
#: A move in millimetres, as :func:`kontur.planner.lattice` reads it (the approach).
_Move = namedtuple("_Move", "line kind start end centre cw feed")


@dataclass(frozen=True)
class Contour:
    """A compensated contour of a job: ``prepared`` (:class:`kontur.sim.models.equidistant.Prepared`,
    in the engine's coordinates), ``origin`` (steps: the machine's point that is the engine's
    ``(0, 0)``), the program ``lines`` it spans (first, last), the indices of its segments in
    the job (``first`` is its ``START``'s, ``count`` of them), ``approach`` (the index of the
    approach line, ``None`` without one) and ``radius`` (steps, exact: a
    :class:`~fractions.Fraction`; the engine's radius frame dials its whole steps, the
    elements' frames take the rest), and the radius as given
    (``radius_mm``) and where it came from (``radius_from``: the program's G41.1/G42.1 D, the
    tool table, ``--radius`` or the machine file)."""
    prepared: object
    origin: tuple
    lines: tuple
    first: int
    count: int
    approach: int = None
    radius: int = 0
    radius_mm: object = None
    radius_from: str = None

    def on_machine(self, point):
        """An engine point in machine steps."""
        return (point[0] + self.origin[0], point[1] + self.origin[1])


def runs(moves):
    """The program's moves in runs, in order: ``(side, moves)``, ``side`` ``"left"`` (G41),
    ``"right"`` (G42) or ``None`` (no compensation). A change of side starts a new run (the
    reader of the contour refuses it, naming the line)."""
    out = []
    for move in moves:
        if out and out[-1][0] == move.side:
            out[-1][1].append(move)
        else:
            out.append((move.side, [move]))
    return out


def needs_engine(moves, board):
    """Raise :exc:`ProgramError` (naming the first compensated line) when ``moves`` have G41 or
    G42 and ``board`` (a name or :class:`kontur.registry.Board`) has no equidistant engine."""
    item = registry.board(board)
    first = next((move for move in moves if move.side is not None), None)
    if first is None or item.profile is not None:
        return
    having = [b.name for b in registry.BOARDS.values() if b.profile is not None]
    raise ProgramError(first.line, f"cutter-radius compensation (G41/G42) runs on the "
                                   f"equidistant engine, which the {item.name}'s controller does "
                                   f"not have (no room for it on the {item.help}); boards with it: "
                                   f"{', '.join(having) if having else 'none registered here'}")


def _feed(move, machine):
    """A move's nominal feed, mm/s (the machine's maximum without an F)."""
    return (machine.max_feed if move.feed is None else min(float(move.feed), machine.max_feed)) / 60


def _unit(v):
    norm = math.hypot(v[0], v[1])
    return (v[0] / norm, v[1] / norm) if norm else None


def _profile_error(error, origin, machine):
    """A :class:`~kontur.sim.models.equidistant.ProfileError` as a :exc:`ProgramError` (its line
    apart), saying what its coordinates are."""
    message = str(error)
    match = re.match(r"line (\d+): (.*)$", message, re.S)
    line, reason = (int(match[1]), match[2]) if match else (None, message)
    if re.search(r"\(-?\d+, -?\d+\)", reason):
        spm = machine.steps_per_mm
        reason += (f" (points in steps from the contour's origin at ({origin[0] / spm:.4f}, "
                   f"{origin[1] / spm:.4f}) mm)")
    return ProgramError(line, reason)


def _prepare(run, machine, radius, width):
    """The contour of ``run`` (compensated moves) on the lattice, prepared at ``radius``
    (steps) for an engine of ``width``: ``(prepared, origin)``."""
    vertex = on_lattice(run[0].start, machine)
    moves = []
    for move in run:
        end = on_lattice(move.end, machine)
        centre = None
        if move.kind == "arc":
            centre = on_lattice(move.centre, machine)
            rho = check_arc_radii(move.line, (vertex[0] - centre[0], vertex[1] - centre[1]),
                                  (end[0] - centre[0], end[1] - centre[1]), machine)
            check_sweep(move, (vertex[0] - centre[0], vertex[1] - centre[1]),
                        (end[0] - centre[0], end[1] - centre[1]), rho)
        r2 = None
        if move.kind == "arc":
            # The mean of the radii of the start and the end on the lattice (squared, in
            # steps), not the start's alone: the circle then misses neither end point by more
            # than half their difference (the start's alone: the end's by all of it).
            programmed = (math.dist(vertex, centre) + math.dist(end, centre)) / 2
            r2 = round(programmed ** 2)
        moves.append(_LatticeMove(move.line, move.kind, vertex, end, centre, move.cw, move.side,
                                  r2))
        vertex = end
    # The origin: the middle of the contour's extent (arcs as whole circles: enough).
    xs, ys = [], []
    for move in moves:
        for x, y in (move.start, move.end):
            xs.append(x)
            ys.append(y)
        if move.centre is not None:
            rho = math.isqrt((move.start[0] - move.centre[0]) ** 2
                             + (move.start[1] - move.centre[1]) ** 2) + 1
            xs += [move.centre[0] - rho, move.centre[0] + rho]
            ys += [move.centre[1] - rho, move.centre[1] + rho]
    origin = ((min(xs) + max(xs)) // 2, (min(ys) + max(ys)) // 2)

    def moved(point):
        return None if point is None else (point[0] - origin[0], point[1] - origin[1])

    moves = [m._replace(start=moved(m.start), end=moved(m.end), centre=moved(m.centre))
             for m in moves]
    try:
        profile = equidistant.profile_from_moves(moves, tolerance=math.inf)
        lead = len(moves) > 1
        if lead:
            entry = moves[0]
            if entry.kind == "line" and math.dist(entry.start, entry.end) <= radius:
                raise equidistant.ProfileError(
                    f"line {entry.line}: the entry move (the first move with G41/G42) is not "
                    f"longer than the cutter radius ({math.dist(entry.start, entry.end):.4g} "
                    f"steps, radius {radius}): LinuxCNC refuses it too")
            # Lead-in moves after the entry: those up to the element whose end the outline
            # returns to (LinuxCNC's comp311.ngc: an arc onto the outline).
            lead = next((k + 1 for k in range(1, len(moves) - 1)
                         if moves[k].end == moves[-1].end), 1)
            # The exit: the last element ends on its normal through its end point as
            # programmed, not as rounded to the lattice (the move after G40 starts there;
            # rounded, its start was up to 0.7 steps off rs274's, across that move).
            spm = Fraction(machine.steps_per_mm)
            end = tuple(Fraction(c) * spm - o for c, o in zip(run[-1].end, origin))
            last = profile.segments[-1]
            if last.kind == "arc" or math.dist(last.start, end) > 2:
                profile = replace(profile, segments=profile.segments[:-1]
                                  + (replace(last, end=end),))
            profile = replace(profile, lead=lead)
        # Convex corners: the machine's ``corner``, "arc" (LinuxCNC's) or "miter".
        prepared = _at_radius(profile, radius, machine.corner, width)
    except equidistant.ProfileError as error:
        raise _profile_error(error, origin, machine) from None
    return prepared, origin


def _at_radius(profile, radius, corner, width):
    """``profile`` prepared at ``radius`` (steps, exact): the engine dials its whole steps and
    the frames carry the rest. Where that path would leave the engine's bound (the check of
    :func:`~kontur.sim.models.equidistant.prepare`; seen once in 45 random profiles, 0.886
    steps at a corner), it is prepared at the radius rounded to the nearest step, as before
    (the path then up to half a step farther from rs274's); where both fail, the error at the
    exact radius is raised."""
    formats = equidistant.Formats(width)
    try:
        return equidistant.prepare(profile, radius, treatment=corner, formats=formats)
    except equidistant.ProfileError as error:
        if Fraction(radius).denominator == 1:
            raise
        exact = error
    try:
        return equidistant.prepare(profile, math.floor(radius + Fraction(1, 2)),
                                   treatment=corner, formats=formats)
    except equidistant.ProfileError:
        raise exact from None


def _dial(prepared):
    """The radius a prepared contour's RADIUS frame dials (whole steps)."""
    return prepared.frames[0]["x"]


def _tangents(element, first, last):
    """The directions of motion at the two ends of an element's steps (engine points
    ``first`` and ``last``; ``element`` ``None`` for a ``CLOSE``), or ``None`` where there is
    none (a step from an arc's centre)."""
    if element is None or element.kind == "line":
        direction = _unit(element.d) if element is not None else \
            _unit((last[0] - first[0], last[1] - first[1]))
        return None if direction is None else (direction, direction)
    sign = -1 if element.cw else 1
    ends = [_unit((-sign * (p[1] - element.centre[1]), sign * (p[0] - element.centre[0])))
            for p in (first, last)]
    return None if None in ends else tuple(ends)


def _contour_segments(prepared, origin, run, machine, position, board, radius_frame=False):
    """The segments of one prepared contour from the machine's ``position``: ``START``, the
    approach, the elements, ``CLOSE`` (and ``RADIUS`` first with ``radius_frame``); returns
    ``(segments, approach index or None)``."""
    item = registry.board(board)
    variant, width = item.profile
    frames = list(prepared.frames)
    outcomes = registry.outcomes("profile", frames, variant, width=width)
    refused = [n for n, (outcome, _) in enumerate(outcomes) if outcome]
    if refused:                          # (prepare's frames are never refused: a model error)
        raise ProgramError(run[0].line, f"the equidistant engine would refuse frame "
                                        f"{refused[0]} of the contour")
    feeds = {move.line: _feed(move, machine) for move in run}
    first_feed = _feed(run[0], machine)
    elements = list(prepared.elements) + [None] * (len(frames) - 2 - len(prepared.elements))
    out = []

    def frame_segment(frame, steps, feed, line, element, at):
        end = at
        for dx, dy in steps:
            end = (end[0] + dx, end[1] + dy)
        tangents, radius = None, None
        if steps:
            tangents = _tangents(element, (at[0] - origin[0], at[1] - origin[1]),
                                 (end[0] - origin[0], end[1] - origin[1]))
            if element is not None and element.kind == "arc":
                radius = math.sqrt(element.r2) + element.sigma * prepared.radius
        out.append(Segment(line, "profile", {"frame": frame, "width": width}, at, end, feed,
                           list(steps), tangents, radius or None))
        return end

    line0 = run[0].line
    if radius_frame:
        frame_segment(frames[0], outcomes[0][1], first_feed, line0, None, position)
    frame_segment(frames[1], outcomes[1][1], first_feed, line0, None, position)
    approach = None
    start = (prepared.start[0] + origin[0], prepared.start[1] + origin[1])
    if start != position:
        lead = _approach(run[0], position, start, machine)
        (segment,) = lattice([lead], machine, variants=(item.line[0], item.arc[0]),
                             widths=(item.line[1], item.arc[1]), start=position)
        approach = len(out)
        out.append(segment)
    at = start
    for index in range(2, len(frames)):
        element = elements[index - 2]
        line = element.line if element is not None else run[-1].line
        at = frame_segment(frames[index], outcomes[index][1], feeds.get(line, first_feed), line,
                           element, at)
    return out, approach


def _approach(entry, position, start, machine):
    """The move from where the machine is (``position``, steps) to the contour's ``start``
    (steps), as LinuxCNC makes its entry move: a line, or for an entry by an arc an arc in its
    direction through both points, centred on the radial line of the programmed arc's end."""
    spm = Fraction(machine.steps_per_mm)
    c = tuple(Fraction(v) / spm for v in position)
    s = tuple(Fraction(v) / spm for v in start)
    if entry.kind == "arc":
        o = tuple(Fraction(v) for v in entry.centre)
        u = (Fraction(entry.end[0]) - o[0], Fraction(entry.end[1]) - o[1])
        across = 2 * (u[0] * (s[0] - c[0]) + u[1] * (s[1] - c[1]))
        if across:
            t = ((s[0] - o[0]) ** 2 + (s[1] - o[1]) ** 2
                 - (c[0] - o[0]) ** 2 - (c[1] - o[1]) ** 2) / across
            return Move(entry.line, "arc", c, s, (o[0] + t * u[0], o[1] + t * u[1]),
                        entry.cw, feed=entry.feed)
    return _Move(entry.line, "line", c, s, None, False, entry.feed)


def _settle_tangents(segments):
    """A segment without steps (a frame that makes none) takes the direction of motion it is
    in: the exit of the segment before it (the first ones, the entry of the first that moves),
    so that the planner's junctions are the corners of the motion."""
    previous = next((s.tangents[0] for s in segments if s.tangents is not None), (1.0, 0.0))
    for segment in segments:
        if segment.tangents is None:
            segment.tangents = (previous, previous)
        previous = segment.tangents[1]


def program_segments(moves, machine, board):
    """The segments of a whole program with compensated contours (``moves`` in millimetres,
    :class:`kontur.gcode.Move`) for ``board``'s controller (a name or a
    :class:`kontur.registry.Board` with an equidistant engine): ``(segments, contours)``, the
    :class:`~kontur.planner.Segment` list and the :class:`Contour` of each contour.

    Raises
    ------
    ProgramError
        Naming the line: the board has no equidistant engine, the machine no cutter radius, an
        arc's radii beyond the tolerance, geometry the engine cannot follow (see
        :func:`kontur.sim.models.equidistant.prepare`), a move the engines cannot make.
    """
    needs_engine(moves, board)
    item = registry.board(board)
    spm = Fraction(machine.steps_per_mm)
    widths = {"variants": (item.line[0], item.arc[0]), "widths": (item.line[1], item.arc[1])}
    segments, contours = [], []
    position = on_lattice(moves[0].start, machine)
    after = None                         # the contour the run follows
    for side, run in runs(moves):
        if side is None:
            try:
                segments += lattice(run, machine, start=position, **widths)
            except ProgramError as error:
                if after is None or run[0].kind != "arc":
                    raise
                raise ProgramError(error.line, f"{error.reason} (it starts where the "
                                               f"compensated contour of lines {after[0]}-"
                                               f"{after[1]} left the cutter, on the "
                                               f"equidistant: put a line first)") from None
        else:
            radius_mm, source = contour_radius(run[0], machine)
            # (steps, exact: the engine dials its whole steps, the frames take the rest)
            radius = Fraction(radius_mm) * spm
            prepared, origin = _prepare(run, machine, radius, item.profile[1])
            part, approach = _contour_segments(prepared, origin, run, machine, position, board,
                                               radius_frame=not contours or _dial(
                                                   contours[-1].prepared) != _dial(prepared))
            if not contours:                 # RADIUS: at the head of the program
                segments.insert(0, part.pop(0))
                if approach is not None:
                    approach -= 1
            index = len(segments)
            contours.append(Contour(prepared, origin, (run[0].line, run[-1].line), index,
                                    len(part), None if approach is None else index + approach,
                                    radius, radius_mm, source))
            segments += part
            after = (run[0].line, run[-1].line)
        if segments:
            position = segments[-1].end
    segments[0].start = segments[0].end = on_lattice(moves[0].start, machine)   # RADIUS
    _settle_tangents(segments)
    return segments, contours


def contour_radius(move, machine):
    """The cutter radius (mm) of the contour ``move`` begins, and where it comes from: the
    program's (G41.1/G42.1 D, or D and the loaded tool in the tool table: ``move.radius``),
    else the machine's (``--radius``, else the machine file's ``cutter_radius``).

    Raises
    ------
    ProgramError
        When there is none."""
    if move.radius is not None:
        return move.radius, move.radius_source
    if machine.cutter_radius is None:
        raise ProgramError(move.line, "cutter-radius compensation (G41/G42) needs a cutter "
                                      "radius: give --radius MM (or cutter_radius in the "
                                      "machine file, or a tool table with --tool-table)")
    return machine.cutter_radius, "--radius or the machine file's cutter_radius"


def references(job):
    """What each segment of ``job``'s contours is measured against: ``{segment index:
    distance(point) -> mm}`` (``point`` in machine steps), an element's steps against the
    exact equidistant; ``None`` for the approach and the move after the contour, measured
    against their own lines (they start where the machine is, not where the program was); an
    approach by an arc against its own circle."""
    spm = job.machine.steps_per_mm
    out = {}
    for contour in job.contours:
        def to_path(point, contour=contour):
            prepared = contour.prepared
            return float(equidistant.distance_to_path(
                (point[0] - contour.origin[0], point[1] - contour.origin[1]),
                prepared.pieces, prepared.radius)) / spm
        for index in range(contour.first, contour.first + contour.count):
            out[index] = None if index == contour.approach else to_path
            segment = job.segments[index]
            if index == contour.approach and segment.kind == "arc":
                # An entry by an arc (LinuxCNC's): from its own circle, the engine's path.
                x0, y0 = segment.payload["x0"], segment.payload["y0"]
                centre = (segment.start[0] - x0, segment.start[1] - y0)
                out[index] = (lambda point, centre=centre, rho=math.hypot(x0, y0):
                              abs(math.dist(point, centre) - rho) / spm)
        after = contour.first + contour.count
        if after < len(job.segments) and job.segments[after].kind == "line":
            out[after] = None            # the move off the equidistant: from where it starts
    return out
