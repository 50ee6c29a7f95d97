"""A trace measured against the exact geometry: distances of a point from the equidistant
(:func:`distance_to_path`) and from the profile (:func:`distance_to_profile`), and the
:class:`Report` of a whole trace (:func:`check_trace`)."""

import math
from dataclasses import dataclass
from fractions import Fraction

from .geometry import Piece, _add, _dot, _norm, _scale, _sqrt, _sub, _turn
from .steps import trace_elements

__all__ = ["distance_to_path", "distance_to_profile", "path_points", "Report", "check_trace"]


def _segment_distance(point, a, b):
    ab = _sub(b, a)
    length2 = _dot(ab, ab)
    if length2 == 0:
        return _norm(_sub(point, a))
    t = min(max(_dot(_sub(point, a), ab) / length2, Fraction(0)), Fraction(1))
    return _norm(_sub(point, _add(a, _scale(ab, t))))


def _arc_distance(point, centre, rho, start, end, cw, full=False):
    v = _sub(point, centre)
    if v == (0, 0):
        return rho
    span = Fraction(4) if full else _turn(_sub(start, centre), _sub(end, centre), cw)
    if full or _turn(_sub(start, centre), v, cw) <= span:
        return abs(_norm(v) - rho)
    return min(_norm(_sub(point, start)), _norm(_sub(point, end)))


def _nearest(point, parts, exact, rough):
    """The least of ``exact(part)`` over ``parts``, computed exactly only for the parts whose
    floating-point estimate ``rough(part)`` is within ``2**-20`` of the least estimate."""
    estimates = [rough(part) for part in parts]
    least = min(estimates)
    return min(exact(part) for part, e in zip(parts, estimates) if e <= least + 2 ** -20)


def _rough_segment(point, a, b):
    ax, ay, bx, by = float(a[0]), float(a[1]), float(b[0]), float(b[1])
    px, py = float(point[0]), float(point[1])
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0 else min(max(((px - ax) * dx + (py - ay) * dy) / length2, 0.0), 1.0)
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


def distance_to_path(point, pieces, radius):
    """The distance (exact rational, roots to ``2**-96``) from ``point`` to the equidistant."""
    def exact(piece):
        if piece.kind == "line":
            return _segment_distance(point, piece.start, piece.end)
        return _arc_distance(point, piece.centre, piece.radius(radius), piece.start, piece.end,
                             piece.cw, full=piece.start == piece.end)

    def rough(piece):
        if piece.kind == "line":
            return _rough_segment(point, piece.start, piece.end)
        return abs(math.hypot(point[0] - piece.centre[0], point[1] - piece.centre[1])
                   - float(piece.radius(radius))) if _within(point, piece) else \
            min(_rough_segment(point, piece.start, piece.start),
                _rough_segment(point, piece.end, piece.end))
    return _nearest(point, pieces, exact, rough)


def _within(point, piece):
    """Whether the direction of ``point`` from an arc piece's centre lies in its span
    (floating point: for estimates only)."""
    cx, cy = float(piece.centre[0]), float(piece.centre[1])
    if (point[0], point[1]) == piece.centre or piece.start == piece.end:
        return True

    def angle(p):
        return math.atan2(float(p[1]) - cy, float(p[0]) - cx)

    def turn(a, b):
        t = (b - a) % (2 * math.pi)
        return (2 * math.pi - t) % (2 * math.pi) if piece.cw else t
    a0 = angle(piece.start)
    return turn(a0, angle(point)) <= turn(a0, angle(piece.end)) + 1e-12


def distance_to_profile(point, profile):
    """The distance from ``point`` to the profile (every segment of the part: an entry
    move's is not, :attr:`Profile.part`)."""
    def exact(seg):
        if seg.kind == "line":
            return _segment_distance(point, seg.start, seg.end)
        return _arc_distance(point, seg.centre, _sqrt(seg.r2), seg.start, seg.end, seg.cw,
                             full=seg.start == seg.end)

    def rough(seg):
        if seg.kind == "line":
            return _rough_segment(point, seg.start, seg.end)
        piece = Piece("arc", seg.start, seg.end, seg.line, "arc", centre=seg.centre, cw=seg.cw)
        if _within(point, piece):
            return abs(math.hypot(point[0] - seg.centre[0], point[1] - seg.centre[1])
                       - math.sqrt(seg.r2))
        return min(_rough_segment(point, seg.start, seg.start),
                   _rough_segment(point, seg.end, seg.end))
    return _nearest(point, profile.part, exact, rough)


def path_points(start, steps):
    """The lattice points visited: ``start`` and the point after every step."""
    points = [tuple(start)]
    for dx, dy in steps:
        points.append((points[-1][0] + dx, points[-1][1] + dy))
    return points


@dataclass(frozen=True)
class Report:
    """How a trace meets the geometry: the largest distance of a visited point from the
    equidistant (``path``), the smallest and largest distance from the profile (``near``,
    ``far``), whether it closes, and per corner the distance from where the element ended to
    the exact corner (``corners``: ``(line, distance)``)."""
    path: Fraction
    near: Fraction
    far: Fraction
    closed: bool
    corners: tuple
    points: int


def check_trace(prepared, traced=None):
    """Measure a trace (by default the step level's) against the exact geometry."""
    parts = trace_elements(prepared) if traced is None else traced
    r = prepared.radius
    point = prepared.start
    worst = near = far = None
    corners = []
    pieces = prepared.pieces
    visited = [point]
    for element, steps in parts:
        for step in steps:
            point = (point[0] + step[0], point[1] + step[1])
            visited.append(point)
        if element is not None:
            corners.append((element.line, point))
    for p in visited:
        d = distance_to_path(p, pieces, r)
        worst = d if worst is None else max(worst, d)
        q = distance_to_profile(p, prepared.profile)
        near = q if near is None else min(near, q)
        far = q if far is None else max(far, q)
    ends = []
    found = list(prepared.elements)
    for n, (line, p) in enumerate(corners):
        if n + 1 < len(found) and found[n + 1].split:
            continue
        ends.append((line, min(_norm(_sub(p, piece.end)) for piece in pieces)))
    return Report(worst, near, far, visited[-1] == visited[0], tuple(ends), len(visited))
