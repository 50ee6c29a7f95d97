"""The geometry (pure Python, exact): the part's profile (lines and arcs on the lattice, one
side of compensation), its equidistant at the cutter radius ``r`` and every corner of it, in
rationals with square roots to ``2**-96``; impossible geometry refused (:class:`ProfileError`,
naming the program line)."""

import math
from dataclasses import dataclass
from fractions import Fraction

from ..errors import InputError

__all__ = ["ProfileError", "Segment", "Profile", "TREATMENTS", "DETECTIONS", "profile_from_moves",
           "offset_path", "Piece"]

#: Convex-corner treatments: ``extend`` the equidistants to their intersection (an arc
#: extended along its tangent), go round the corner on an ``arc`` of radius r, or ``miter``:
#: extend where the intersection is at most :data:`MITER_LIMIT` times r from the vertex, and
#: go round on an arc where it would be farther (a sharper corner).
TREATMENTS = ("extend", "arc", "miter")

#: The ``miter`` treatment's limit: the intersection of the equidistants at most this many
#: radii from the vertex (``1/cos(turn/2) <= 2``: turns of up to 120° are extended).
MITER_LIMIT = 2


def _rounds(treatment, t1, t2):
    """Whether a convex corner with the tangents ``t1``, ``t2`` goes round on an arc under
    ``treatment`` (``miter``: where ``1/cos(turn/2) > MITER_LIMIT``, i.e. ``cos(turn) <
    2/MITER_LIMIT² - 1``; exact)."""
    if treatment != "miter":
        return treatment == "arc"
    c = Fraction(2, MITER_LIMIT * MITER_LIMIT) - 1
    dot, norms = _dot(t1, t2), _dot(t1, t1) * _dot(t2, t2)
    if (dot >= 0) != (c >= 0):
        return dot < 0                   # cos(turn) and c of opposite signs
    if dot >= 0:
        return dot * dot < c * c * norms     # 0 <= cos(turn) < c
    return dot * dot > c * c * norms         # cos(turn) < c < 0

#: What ends a line at a corner with a line: the ``normal`` of the line through the
#: intersection of the equidistants, or (the ``seed``'s rule) the next line's equidistant.
DETECTIONS = ("normal", "seed")

#: Frame kinds (the ``kind`` field).

_PREC = 96                         # square roots to 2**-96


class ProfileError(InputError):
    """A profile the interpolator refuses: impossible geometry, out of range; names the line."""


def _sqrt(value):
    """``sqrt(value)`` of a non-negative rational, rounded down to ``2**-96``."""
    value = Fraction(value)
    if value < 0:
        raise ValueError(f"square root of a negative number {value}")
    scaled = value.numerator * (1 << (2 * _PREC)) // value.denominator
    return Fraction(math.isqrt(scaled), 1 << _PREC)


def _cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1]


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1])


def _add(a, b):
    return (a[0] + b[0], a[1] + b[1])


def _scale(a, k):
    return (a[0] * k, a[1] * k)


def _left(a):
    """``a`` turned a quarter counter-clockwise."""
    return (-a[1], a[0])


def _norm(a):
    return _sqrt(_dot(a, a))


def _diamond(v):
    """A pseudo-angle of ``v`` in ``[0, 4)``, increasing counter-clockwise (exact)."""
    x, y = Fraction(v[0]), Fraction(v[1])
    if y >= 0:
        return y / (x + y) if x >= 0 else 1 - x / (-x + y)
    return 2 - y / (-x - y) if x < 0 else 3 + x / (x - y)


def _turn(v0, v1, cw):
    """The angle from ``v0`` to ``v1`` in the direction of motion, as a pseudo-angle in
    ``[0, 4)``."""
    a = (_diamond(v1) - _diamond(v0)) % 4
    return (4 - a) % 4 if cw else a


# ---- the profile ------------------------------------------------------------------------

@dataclass(frozen=True)
class Segment:
    """An element of the profile: a line from ``start`` to ``end``, or an arc round
    ``centre`` (clockwise if ``cw``), on the lattice; ``line`` is its program line."""
    kind: str
    start: tuple
    end: tuple
    line: int
    centre: tuple = None
    cw: bool = False
    #: ``R²`` of an arc where it is not its start's (a program in millimetres: the radius as
    #: programmed, which the start rounded to the lattice misses by up to a step)
    radius2: int = None

    @property
    def r2(self):
        """``R²`` of an arc: ``radius2``, else its start's."""
        if self.radius2 is not None:
            return self.radius2
        return _dot(_sub(self.start, self.centre), _sub(self.start, self.centre))

    def tangent(self, point):
        """The direction of motion at ``point`` (an integer vector, not unit)."""
        if self.kind == "line":
            return _sub(self.end, self.start)
        radius = _sub(point, self.centre)
        return _scale(_left(radius), -1 if self.cw else 1)

    def span(self):
        """The arc's angle in the direction of motion, as a pseudo-angle in ``(0, 4]``."""
        if self.start == self.end:
            return Fraction(4)
        return _turn(_sub(self.start, self.centre), _sub(self.end, self.centre), self.cw)


@dataclass(frozen=True)
class Profile:
    """The compensated contour: its elements, the side (``"left"``: G41, ``"right"``: G42),
    and whether it is closed (its last element ends where its first begins)."""
    segments: tuple
    side: str
    #: The number of leading segments that are no part of the part: with any, the first is an
    #: entry move (LinuxCNC's rule, :mod:`kontur.compensation`): the cutter's centre starts
    #: where its equidistant ends (its corner with the next element), and the profile is
    #: open; those after it are lead-in moves (an arc onto the outline, which the last
    #: element returns to), traced as elements.
    lead: int = 0

    @property
    def closed(self):
        return not self.lead and self.segments[-1].end == self.segments[0].start

    @property
    def part(self):
        """The segments of the part (the entry move's not)."""
        return self.segments[int(self.lead):]

    @property
    def sign(self):
        """``+1`` for the left side, ``-1`` for the right."""
        return 1 if self.side == "left" else -1


def _lattice(value, letter, line):
    if Fraction(value).denominator != 1:
        raise ProfileError(f"line {line}: {letter} = {float(value):g} is not a lattice point "
                           f"(the program is in lattice units)")
    return int(value)


def profile_from_moves(moves, *, tolerance=0):
    """The compensated contour of a program's moves (:class:`kontur.gcode.Move` or anything
    with its attributes): the moves made while G41 or G42 is in effect.

    ``tolerance`` is how far (steps: the difference of the radii) an arc's end point may lie
    off the circle through its start; 0 (the default, a program in lattice units) wants it
    exactly on it. The machine controller's programs in millimetres, rounded to the lattice,
    have their arcs' ends up to about a step off (the host checks them against the machine's
    tolerance first, :mod:`kontur.compensation`): the end point stays where it is, where the
    next element begins, and the arc is the circle through its start.

    Raises
    ------
    ProfileError
        When there is no compensated move, more than one contour, a rapid move or a change of
        side inside the contour, a coordinate off the lattice, a segment of length zero, an
        arc of radius zero, or an arc's end point off its circle (beyond ``tolerance``).
    """
    runs, current = [], []
    for move in moves:
        if move.side is None:
            if current:
                runs.append(current)
                current = []
            continue
        if move.kind == "rapid":
            raise ProfileError(f"line {move.line}: a rapid move (G0) inside the compensated "
                               f"contour")
        if current and move.side != current[0].side:
            code = "G41" if move.side == "left" else "G42"
            raise ProfileError(f"line {move.line}: {code} changes the side inside the contour")
        current.append(move)
    if current:
        runs.append(current)
    if not runs:
        raise ProfileError("no compensated moves (G41 or G42 with G1, G2 or G3) in the program")
    if len(runs) > 1:
        raise ProfileError(f"line {runs[1][0].line}: a second compensated contour (the first "
                           f"is lines {runs[0][0].line}-{runs[0][-1].line}): trace one at a time")
    segments = []
    for move in runs[0]:
        line = move.line
        start = tuple(_lattice(v, a, line) for v, a in zip(move.start, "XY"))
        end = tuple(_lattice(v, a, line) for v, a in zip(move.end, "XY"))
        if move.kind == "line":
            if start == end:
                raise ProfileError(f"line {line}: a segment of length zero (at {start})")
            segments.append(Segment("line", start, end, line))
            continue
        centre = tuple(_lattice(v, a, line) for v, a in zip(move.centre, "IJ"))
        if centre == start:
            raise ProfileError(f"line {line}: an arc of radius zero (I = J = 0)")
        seg = Segment("arc", start, end, line, centre, bool(move.cw),
                      getattr(move, "r2", None))
        d2 = _dot(_sub(end, centre), _sub(end, centre))
        if d2 != seg.r2 and abs(math.sqrt(d2) - math.sqrt(seg.r2)) > tolerance:
            raise ProfileError(f"line {line}: the arc's end point {end} is not on its circle "
                               f"(centre {centre}, R² = {seg.r2}, but {d2} at the end point)")
        segments.append(seg)
    return Profile(tuple(segments), runs[0][0].side)


# ---- the exact equidistant --------------------------------------------------------------

@dataclass(frozen=True)
class Piece:
    """A piece of the equidistant: a line from ``start`` to ``end`` (on the line through
    ``base`` with direction ``d`` moved by ``offset`` units of r to the left), or an arc
    round ``centre`` of squared profile radius ``r2``, ``sigma = +1`` when the cutter runs
    outside it (its radius is ``sqrt(r2) + sigma·r``), clockwise if ``cw``.

    ``start`` and ``end`` are exact (rational) points; ``entry`` is how the piece before ends:
    ``None`` where the two equidistants cross (the seed's principle), else a line through
    ``entry[0]`` with direction ``entry[1]`` (the common normal of a smooth joint) it crosses.
    ``line`` is the program line it comes from, ``what`` says what it is.
    """
    kind: str
    start: tuple
    end: tuple
    line: int
    what: str
    base: tuple = None
    d: tuple = None
    offset: int = 0
    centre: tuple = None
    r2: int = 0
    sigma: int = 1
    cw: bool = False
    entry: tuple = None

    def radius(self, r):
        return _sqrt(self.r2) + self.sigma * r


def _offset_point(seg, point, side, r):
    """``point`` of ``seg`` moved by ``r`` to the cutter's side (its normal there); for an arc
    whose radius is not its start's (``radius2``), the point of its equidistant's circle on
    the radial line through ``point`` (an end rounded to the lattice lies off the circle)."""
    if seg.kind == "arc" and seg.radius2 is not None:
        radial = _sub(point, seg.centre)
        rho = _sqrt(seg.r2) + _sigma(seg, side) * r
        return _add(seg.centre, _scale(radial, rho / _norm(radial)))
    t = seg.tangent(point)
    n = _left(t)
    return _add(point, _scale(n, side * r / _norm(t)))


def _line_line(p1, d1, p2, d2):
    """Intersection of the lines ``p1 + s·d1`` and ``p2 + t·d2`` (not parallel)."""
    t = _cross(_sub(p2, p1), d2) / Fraction(_cross(d1, d2))
    return _add(p1, _scale(d1, t))


def _line_circle(p, d, c, radius):
    """The intersections of ``p + t·d`` with the circle (none, or two points)."""
    o = _sub(p, c)
    a = Fraction(_dot(d, d))
    b = _dot(d, o)
    cc = _dot(o, o) - radius * radius
    disc = b * b - a * cc
    if disc < 0:
        return []
    root = _sqrt(disc)
    return [_add(p, _scale(d, (-b + sgn * root) / a)) for sgn in (-1, 1)]


def _circle_circle(c1, r1, c2, r2):
    d = _sub(c2, c1)
    dd = Fraction(_dot(d, d))
    if dd == 0:
        return []
    a = (r1 * r1 - r2 * r2 + dd) / (2 * dd)
    h2 = r1 * r1 / dd - a * a
    if h2 < 0:
        return []
    h = _sqrt(h2)
    mid = _add(c1, _scale(d, a))
    return [_add(mid, _scale(_left(d), sgn * h)) for sgn in (-1, 1)]


def _offset_of(seg, side, r):
    """The equidistant of ``seg`` as ``("line", point, d)`` or ``("circle", centre, radius)``."""
    if seg.kind == "line":
        return ("line", _offset_point(seg, seg.start, side, r), _sub(seg.end, seg.start))
    return ("circle", seg.centre, _sqrt(seg.r2) + _sigma(seg, side) * r)


def _sigma(seg, side):
    """``+1`` when the cutter on ``side`` (+1 left) runs outside the arc ``seg``."""
    return 1 if (side > 0) == seg.cw else -1


def _intersections(a, b):
    if a[0] == "line" and b[0] == "line":
        if _cross(a[2], b[2]) == 0:
            return []
        return [_line_line(a[1], a[2], b[1], b[2])]
    if a[0] == "line":
        return _line_circle(a[1], a[2], b[1], b[2])
    if b[0] == "line":
        return _line_circle(b[1], b[2], a[1], a[2])
    return _circle_circle(a[1], a[2], b[1], b[2])


def _radius(radius):
    """A cutter radius (steps): a non-negative integer or :class:`~fractions.Fraction` (an
    integral Fraction as an int)."""
    if isinstance(radius, bool) or not isinstance(radius, (int, Fraction)) or radius < 0:
        raise TypeError(f"Cutter radius must be a non-negative integer or Fraction, not "
                        f"{radius!r}")
    return int(radius) if Fraction(radius).denominator == 1 else radius


def _shown(radius):
    """A radius (steps) as a message shows it."""
    return radius if isinstance(radius, int) else f"{float(radius):.6g}"


def _dist2(a, b):
    d = _sub(a, b)
    return _dot(d, d)


#: A joint is taken as smooth (tangent) when its turn is at most this sine (0.57°; LinuxCNC
#: makes no corner below 0.05 rad, its TOLERANCE_CONCAVE_CORNER) and the equidistants' ends
#: at the vertex are at most :data:`SMOOTH_GAP` steps apart at the radius: the tangent joints
#: of a program in millimetres are tangent only up to the rounding of its points and centres
#: to the lattice (turns of up to 0.003 rad at 80 steps/mm on the corpus).
SMOOTH_SINE = Fraction(1, 100)
#: (steps) the largest gap ``r·sin(turn)`` between the equidistants' ends at a joint taken as
#: smooth.
SMOOTH_GAP = Fraction(1)


def _corner_kind(seg1, seg2, side, radius=None):
    """``"smooth"``, ``"concave"`` or ``"convex"`` at the joint of ``seg1`` and ``seg2``; with
    a ``radius`` a joint that is tangent up to the lattice's rounding (:data:`SMOOTH_SINE`,
    :data:`SMOOTH_GAP`) is smooth."""
    t1, t2 = seg1.tangent(seg1.end), seg2.tangent(seg2.start)
    turn = _cross(t1, t2)
    if turn and radius is not None and _dot(t1, t2) > 0:
        sine2 = Fraction(turn * turn, _dot(t1, t1) * _dot(t2, t2))
        if sine2 <= SMOOTH_SINE ** 2 and radius * radius * sine2 <= SMOOTH_GAP ** 2:
            return "smooth"
    if turn == 0:
        if _dot(t1, t2) < 0:
            raise ProfileError(f"line {seg2.line}: the path reverses at {seg2.start}: the "
                               f"segments of lines {seg1.line} and {seg2.line} are parallel and "
                               f"their equidistants do not meet")
        return "smooth"
    return "concave" if (turn > 0) == (side > 0) else "convex"


def _normal_entry(seg, point):
    """The line through ``point`` along the normal of ``seg`` there: where a piece ends at a
    smooth joint (``(base, direction, 0)``: integer vectors, no offset)."""
    return (point, _left(seg.tangent(point)), Fraction(0))


def _corner_normal(v, t1, t2, side):
    """The normal of the line ``t1`` through the intersection of the equidistants of the lines
    ``t1`` and ``t2`` through ``v``, for any radius: ``(v, left(t1), c)``, the line through
    ``v`` moved ``c·r`` to its left (the intersection moves along a fixed direction as r
    grows, so the normal through it is the normal through ``v`` moved in proportion)."""
    n1 = _add(v, _scale(_left(t1), side / _norm(t1)))
    n2 = _add(v, _scale(_left(t2), side / _norm(t2)))
    w = _sub(_line_line(n1, t1, n2, t2), v)
    return (v, _left(t1), -_dot(w, t1) / _norm(t1))


def offset_path(profile, radius, *, treatment="extend"):
    """The equidistant of ``profile`` at the cutter radius ``radius``: a list of
    :class:`Piece`, in order; for a closed profile the last ends where the first begins.

    Arcs are cut into pieces of at most a quarter turn (at the quarter turns of the radius to
    the arc's start), so that every piece meets the function that ends it once.

    Raises
    ------
    TypeError
        If ``radius`` is not a non-negative integer or Fraction.
    ValueError
        If ``treatment`` is not one of :data:`TREATMENTS`.
    ProfileError
        For impossible geometry: the path reversing, a cutter too large for a concave corner
        (the equidistants do not meet) or for an arc on its inside, an equidistant running
        backwards between its corners.
    """
    radius = _radius(radius)
    if treatment not in TREATMENTS:
        raise ValueError(f"Corner treatment must be one of {', '.join(map(repr, TREATMENTS))}, "
                         f"not {treatment!r}")
    side = profile.sign
    r = Fraction(radius)
    segs = profile.segments
    for seg in segs:
        if seg.kind == "arc" and _sigma(seg, side) < 0 and _sqrt(seg.r2) <= r:
            raise ProfileError(f"line {seg.line}: the cutter (radius {_shown(radius)}) is too "
                               f"large for "
                               f"the arc of radius {float(_sqrt(seg.r2)):.6g} on its inside")
    count = len(segs)
    joints = range(count) if profile.closed else range(count - 1)
    corners = {i: _corner(segs[i], segs[(i + 1) % count], side, r, radius, treatment)
               for i in joints}
    pieces = []
    for i, seg in enumerate(segs):
        before = corners.get((i - 1) % count) if (i > 0 or profile.closed) else None
        if before is None:
            start, entry = _offset_point(seg, seg.start, side, r), None
        else:
            start, entry = before["begin"], before["entry"]
        end = corners[i]["finish"] if i in corners else _offset_point(seg, seg.end, side, r)
        if seg.kind == "line":
            d = _sub(seg.end, seg.start)
            if _dot(_sub(end, start), d) < 0:
                raise ProfileError(f"line {seg.line}: the cutter (radius {_shown(radius)}) is too "
                                   f"large: the equidistant of this segment would run backwards "
                                   f"between its corners")
            pieces.append(Piece("line", start, end, seg.line, "line", base=seg.start, d=d,
                                offset=side, entry=entry))
        else:
            sigma = _sigma(seg, side)
            rho = _sqrt(seg.r2) + sigma * r
            ref = _sub(seg.start, seg.centre)
            first = _turn(ref, _sub(start, seg.centre), seg.cw)
            if first > 2:                        # (just before the profile's start)
                first -= 4
            span = _turn(_sub(start, seg.centre), _sub(end, seg.centre), seg.cw)
            if start == end or (span == 0 and seg.span() == 4):
                span = Fraction(4)
            if first + span > seg.span() + Fraction(1, 1 << 60):
                raise ProfileError(f"line {seg.line}: the cutter (radius {_shown(radius)}) is too "
                                   f"large: the equidistant of this arc would run backwards "
                                   f"between its corners")
            pieces.extend(_arc_pieces(seg.centre, seg.cw, seg.r2, sigma, rho, ref, start, end,
                                      span, entry, seg.line, "arc"))
        if i in corners:
            pieces.extend(corners[i]["pieces"])
    return pieces


def _corner(s1, s2, side, r, radius, treatment):
    """The joint of ``s1`` and ``s2``: where ``s1``'s equidistant ends (``finish``), where
    ``s2``'s begins (``begin``), the pieces between, and how the piece before ``s2``'s ends."""
    v = s1.end
    kind = _corner_kind(s1, s2, side, radius)
    n1, n2 = _offset_point(s1, v, side, r), _offset_point(s2, v, side, r)
    t1, t2 = s1.tangent(v), s2.tangent(v)
    if kind == "smooth":
        return {"finish": n1, "begin": n2, "pieces": [], "entry": _normal_entry(s2, v)}
    if kind == "concave" or radius == 0:
        points = _intersections(_offset_of(s1, side, r), _offset_of(s2, side, r))
        if not points:
            raise ProfileError(f"line {s2.line}: the cutter (radius {_shown(radius)}) is too "
                               f"large for "
                               f"the concave corner at {v} between lines {s1.line} and "
                               f"{s2.line}: their equidistants do not meet")
        q = min(points, key=lambda p: _dist2(p, v))
        return {"finish": q, "begin": q, "pieces": [], "entry": None}
    if _rounds(treatment, t1, t2):
        cw = _cross(t1, t2) < 0
        ref = _scale(_left(t1), side)            # the radius to the corner arc's start
        span = _turn(ref, _scale(_left(t2), side), cw)
        pieces = _arc_pieces(v, cw, 0, 1, r, ref, n1, n2, span, _normal_entry(s1, v),
                             s2.line, "corner arc")
        return {"finish": n1, "begin": n2, "pieces": pieces, "entry": _normal_entry(s2, v)}
    # Extend: the equidistants of lines and the tangents of arcs' equidistants, intersected.
    q = _line_line(n1, t1, n2, t2)
    pieces = []
    if s1.kind == "arc":
        pieces.append(Piece("line", n1, q, s2.line, "extension", base=v, d=t1, offset=side,
                            entry=_normal_entry(s1, v)))
    if s2.kind == "arc":
        pieces.append(Piece("line", q, n2, s2.line, "extension", base=v, d=t2, offset=side,
                            entry=None))
    return {"finish": n1 if s1.kind == "arc" else q, "begin": n2 if s2.kind == "arc" else q,
            "pieces": pieces, "entry": _normal_entry(s2, v) if s2.kind == "arc" else None}


def _arc_pieces(centre, cw, r2, sigma, rho, ref, start, end, span, entry, line, what):
    """An arc's equidistant from ``start`` to ``end`` (``span`` pseudo-angle) in pieces of at
    most a quarter turn, split where the integer vector ``ref`` turned by quarters points."""
    rotate = (lambda a: (a[1], -a[0])) if cw else _left
    v0 = _sub(start, centre)
    splits = []
    direction = ref
    for _ in range(4):
        direction = rotate(direction)
        at = _turn(v0, direction, cw)
        if 0 < at < span:
            splits.append((at, direction))
    splits.sort()
    pieces = []
    point = start
    for _, direction in splits:
        split = _add(centre, _scale(direction, rho / _norm(direction)))
        pieces.append(Piece("arc", point, split, line, what, centre=centre, r2=r2, sigma=sigma,
                            cw=cw, entry=entry))
        entry = (centre, direction, Fraction(0))
        point = split
    pieces.append(Piece("arc", point, end, line, what, centre=centre, r2=r2, sigma=sigma,
                        cw=cw, entry=entry))
    return pieces
