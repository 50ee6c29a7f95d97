"""T. Siimut's interpolator with transition to the equidistant (1963): the golden models.

Three levels, pure Python:

* **geometry** (:func:`profile_from_moves`, :func:`offset_path`): the part's profile (lines and
  arcs on the lattice, one side of compensation), its equidistant at the cutter radius ``r``
  and every corner of it, in exact rationals (square roots to ``2**-96``). Corners where the
  equidistants meet are their intersections (the seed's principle); convex corners are
  extended to the intersection of the equidistants (arcs extended along their tangents) or
  rounded by an arc of radius ``r`` around the profile's vertex (:data:`TREATMENTS`);
  impossible geometry is refused (:class:`ProfileError`, naming the program line).
* **host preparation** (:func:`prepare`): the frames of the hardware: per element the seed's
  numbers (``±k``, ``±b``, ``±1/cos α``, the coordinate-system flag, the direction flag) or an
  arc's centre, ``R²`` and ``2R``, in fixed point with :attr:`Formats.fraction` fractional
  bits; the radius and the start point.
* **step level** (:func:`trace`): the trajectory the hardware makes from those frames, every
  function evaluated afresh at every point (the hardware integrates them).

The cycle level (:class:`EquidistantEngineModel`) mirrors ``hdl.equidistant`` clock for clock.

Functions of the hardware (the ``V`` of every element, exact integers):

* a line in the ``x, y`` system (``|k| <= 1``), ``s`` its minor direction (``-1`` when the
  direction flag is set): ``T = s·(k·x + b - y) + G·r`` scaled by ``2**F``, ``G = s·side·sec``,
  the deviation of the point from the equidistant along the minor axis; in the ``y, x`` system
  ``T = s·(k·y + b - x) - s·side·sec·r``. In the seed's terms ``T = E + C·x + D·y + G·r`` with
  Table 1's ``C = k, D = -1`` (``C = -1, D = k``) up to the sign ``s``.
* a circle: ``S = (x - x0)² + (y - y0)² - N``, ``N = R² + r² + σ·2R·r`` rounded to an integer,
  ``σ = +1`` where the cutter is outside the circle.
"""

import math
from dataclasses import dataclass, replace
from fractions import Fraction

from .arc import SIGNS, direction_bits, native, quadrant, real_step, type_a
from .circular import native_moves
from .errors import InputError

__all__ = ["ProfileError", "Segment", "Profile", "Formats", "TREATMENTS", "DETECTIONS", "KIND",
           "PATH_BOUND", "profile_from_moves", "offset_path", "Piece", "Element", "elements",
           "prepare", "program_frames", "Prepared", "frame_outcomes", "trace", "trace_elements",
           "line_function", "circle_function", "LineFunction", "CircleFunction",
           "distance_to_path", "distance_to_profile", "path_points", "check_trace", "Report",
           "EquidistantEngineModel"]

#: Convex-corner treatments: ``extend`` the equidistants to their intersection (an arc
#: extended along its tangent), or go round the corner on an ``arc`` of radius r.
TREATMENTS = ("extend", "arc")

#: What ends a line at a corner with a line: the ``normal`` of the line through the
#: intersection of the equidistants, or (the ``seed``'s rule) the next line's equidistant.
DETECTIONS = ("normal", "seed")

#: Frame kinds (the ``kind`` field).
KIND = {"radius": 0, "start": 1, "line": 2, "arc": 3, "close": 4}

_PREC = 96                         # square roots to 2**-96
_START_ROUNDS = 4                  # rounds of the search for a closed profile's start


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

    @property
    def r2(self):
        """``R²`` of an arc."""
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

    @property
    def closed(self):
        return self.segments[-1].end == self.segments[0].start

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
    """The compensated contour of a program's moves (:class:`sim.host.gcode.Move` or anything
    with its attributes): the moves made while G41 or G42 is in effect.

    ``tolerance`` is how far (steps: the difference of the radii) an arc's end point may lie
    off the circle through its start; 0 (the default, a program in lattice units) wants it
    exactly on it. The machine controller's programs in millimetres, rounded to the lattice,
    have their arcs' ends up to about a step off (the host checks them against the machine's
    tolerance first, :mod:`sim.host.compensation`): the end point stays where it is, where the
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
        seg = Segment("arc", start, end, line, centre, bool(move.cw))
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
    """``point`` of ``seg`` moved by ``r`` to the cutter's side (its normal there)."""
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


def _dist2(a, b):
    d = _sub(a, b)
    return _dot(d, d)


def _corner_kind(seg1, seg2, side):
    """``"smooth"``, ``"concave"`` or ``"convex"`` at the joint of ``seg1`` and ``seg2``."""
    t1, t2 = seg1.tangent(seg1.end), seg2.tangent(seg2.start)
    turn = _cross(t1, t2)
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
        If ``radius`` is not a non-negative integer.
    ValueError
        If ``treatment`` is not one of :data:`TREATMENTS`.
    ProfileError
        For impossible geometry: the path reversing, a cutter too large for a concave corner
        (the equidistants do not meet) or for an arc on its inside, an equidistant running
        backwards between its corners.
    """
    if isinstance(radius, bool) or not isinstance(radius, int) or radius < 0:
        raise TypeError(f"Cutter radius must be a non-negative integer, not {radius!r}")
    if treatment not in TREATMENTS:
        raise ValueError(f"Corner treatment must be one of {', '.join(map(repr, TREATMENTS))}, "
                         f"not {treatment!r}")
    side = profile.sign
    r = Fraction(radius)
    segs = profile.segments
    for seg in segs:
        if seg.kind == "arc" and _sigma(seg, side) < 0 and _sqrt(seg.r2) <= r:
            raise ProfileError(f"line {seg.line}: the cutter (radius {radius}) is too large for "
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
                raise ProfileError(f"line {seg.line}: the cutter (radius {radius}) is too "
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
                raise ProfileError(f"line {seg.line}: the cutter (radius {radius}) is too "
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
    kind = _corner_kind(s1, s2, side)
    n1, n2 = _offset_point(s1, v, side, r), _offset_point(s2, v, side, r)
    t1, t2 = s1.tangent(v), s2.tangent(v)
    if kind == "smooth":
        return {"finish": n1, "begin": n2, "pieces": [], "entry": _normal_entry(s2, v)}
    if kind == "concave" or radius == 0:
        points = _intersections(_offset_of(s1, side, r), _offset_of(s2, side, r))
        if not points:
            raise ProfileError(f"line {s2.line}: the cutter (radius {radius}) is too large for "
                               f"the concave corner at {v} between lines {s1.line} and "
                               f"{s2.line}: their equidistants do not meet")
        q = min(points, key=lambda p: _dist2(p, v))
        return {"finish": q, "begin": q, "pieces": [], "entry": None}
    if treatment == "arc":
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


# ---- the elements of the hardware (independent of the radius) ---------------------------

@dataclass(frozen=True)
class Element:
    """One element the hardware traces (or, with ``last``, only aims at), independent of r.

    ``kind`` ``"line"``: the line through the lattice point ``base`` with direction ``d`` (an
    integer vector), moved ``offset`` (``+1`` left, ``-1`` right, ``0`` none) times r to the
    left. ``kind`` ``"arc"``: the circle round ``centre`` with squared profile radius ``r2``
    and radius ``sqrt(r2) ± r`` by ``side`` and ``cw`` (the cutter outside when
    ``(side > 0) == cw``). ``entry`` is the line ``(base, direction, c)`` (through ``base``,
    moved ``c·r`` to its left) whose crossing ends the element before (``None``: this
    element's own equidistant ends it), ``h`` the sign in which that function grows along the
    element before. ``line`` is the program line, ``what`` what
    the element is (``line``, ``arc``, ``corner arc``, ``extension``, ``stop``).
    """
    kind: str
    line: int
    what: str
    base: tuple = None
    d: tuple = None
    offset: int = 0
    centre: tuple = None
    r2: int = 0
    cw: bool = False
    side: int = 1
    entry: tuple = None
    h: int = 1
    last: bool = False
    split: bool = False          # its entry cuts a line in two: not a corner

    @property
    def sigma(self):
        return 1 if (self.side > 0) == self.cw else -1


def _grows(element, point, direction):
    """The sign in which the function that ends the element before ``element`` grows along
    ``direction`` at ``point`` (exact): that of the entry line, else of the element's own
    equidistant (a line's function grows to its left, a circle's outwards)."""
    if element.entry is not None:
        value = _dot(_line_gradient(element.entry[1]), direction)
    elif element.kind == "line":
        value = _dot(_line_gradient(element.d), direction)
    else:
        value = _dot(_sub(point, element.centre), direction)
    return (value > 0) - (value < 0)


def _line_gradient(d):
    """The gradient of the hardware's function of a line with direction ``d`` (see
    :func:`line_function`): ``s·(k, -1)`` in the ``x, y`` system, ``s·(-1, k)`` in ``y, x``."""
    dx, dy = d
    if abs(dy) <= abs(dx):
        s = -1 if dy < 0 else 1
        return (s * Fraction(dy, dx), -s)
    s = -1 if dx < 0 else 1
    return (-s, s * Fraction(dx, dy))


def _arc_tangent(radius, cw):
    return _scale(_left(radius), -1 if cw else 1)


def elements(profile, *, treatment="extend", detection="normal"):
    """The hardware's elements for ``profile`` (any radius): a list of :class:`Element`, the
    last one the terminal aimed at (``last``): for a closed profile the first element again,
    for an open one the normal at the last end point.

    ``detection`` says what ends a line at a corner with a line: ``"normal"``, the normal of
    the line through the intersection of the equidistants (a combination of the two
    equations (13) that vanishes at the same point and crosses the line at a right angle), or
    ``"seed"``, the next line's own equidistant (equation (13) with Table 1's coefficients).

    Raises
    ------
    ValueError
        If ``treatment`` is not one of :data:`TREATMENTS` or ``detection`` not one of
        :data:`DETECTIONS`.
    ProfileError
        If the path reverses, or where one element would have to be ended by a function it
        touches without crossing.
    """
    if treatment not in TREATMENTS:
        raise ValueError(f"Corner treatment must be one of {', '.join(map(repr, TREATMENTS))}, "
                         f"not {treatment!r}")
    if detection not in DETECTIONS:
        raise ValueError(f"Corner detection must be one of {', '.join(map(repr, DETECTIONS))}, "
                         f"not {detection!r}")
    side = profile.sign
    segs = profile.segments
    count = len(segs)
    # (element, junction point, direction of motion arriving there)
    items = []

    def arc_items(centre, cw, r2, ref, span, entry, line, what, point, arriving):
        rotate = (lambda a: (a[1], -a[0])) if cw else _left
        direction = ref
        turned = 0
        while True:
            items.append((Element("arc", line, what, centre=centre, r2=r2, cw=cw, side=side,
                                  entry=entry), point, arriving))
            if turned + 1 >= span:
                break
            direction = rotate(direction)
            entry = (centre, direction, Fraction(0))
            point, arriving = _add(centre, direction), _arc_tangent(direction, cw)
            turned += 1

    corners = {}
    for i in range(count if profile.closed else count - 1):
        s1, s2 = segs[i], segs[(i + 1) % count]
        corners[i] = (_corner_kind(s1, s2, side), s1, s2)

    arriving = None
    entry = None
    if profile.closed:
        kind, s1, s2 = corners[count - 1]
        entry, arriving = _corner_items(kind, s1, s2, side, treatment, detection, None)[1:]
    for i, seg in enumerate(segs):
        if seg.kind == "line":
            items.append((Element("line", seg.line, "line", base=seg.start,
                                  d=_sub(seg.end, seg.start), offset=side, entry=entry),
                          seg.start, arriving))
        else:
            arc_items(seg.centre, seg.cw, seg.r2, _sub(seg.start, seg.centre), seg.span(),
                      entry, seg.line, "arc", seg.start, arriving)
        if i in corners:
            kind, s1, s2 = corners[i]
            inserted, entry, arriving = _corner_items(kind, s1, s2, side, treatment,
                                                      detection, arc_items)
            for element, point, direction in inserted:
                items.append((element, point, direction))
    if profile.closed:
        first, point, _ = items[0]
        items.append((replace(first, entry=entry, last=True), point, arriving))
    else:
        seg = segs[-1]
        t = seg.tangent(seg.end)
        items.append((Element("line", seg.line, "stop", base=seg.end, d=_left(t), offset=0,
                              last=True), seg.end, t))

    # A line ended by a circle is cut in two by its normal at the middle: a line may start on
    # the circle it must leave (both its corners on one arc), and only its second half, which
    # starts inside, is ended by the circle.
    split = []
    for n, (element, point, direction) in enumerate(items):
        split.append((element, point, direction))
        after = items[n + 1][0] if n + 1 < len(items) else None
        if (element.kind == "line" and after is not None and after.kind == "arc"
                and after.entry is None):
            middle = _add(element.base, (element.d[0] // 2, element.d[1] // 2))
            split.append((replace(element, entry=(middle, _left(element.d), Fraction(0)),
                                  split=True), middle, element.d))
    items = split

    out = []
    for n, (element, point, direction) in enumerate(items):
        if n == 0 and not profile.closed:
            out.append(element)                  # entered from the start point
            continue
        h = _grows(element, point, direction)
        if h == 0:
            raise ProfileError(f"line {element.line}: the equidistants touch at {point} "
                               f"without crossing: the interpolator cannot find the corner")
        out.append(replace(element, h=h))
    return out


def _corner_items(kind, s1, s2, side, treatment, detection, arc_items):
    """The elements a corner inserts (as ``(element, point, arriving)``), the entry of the
    element after it and the direction of motion arriving there. With ``arc_items`` ``None``
    only the last two are wanted (nothing is appended)."""
    v = s1.end
    t1, t2 = s1.tangent(v), s2.tangent(v)

    def crossing(line1, line2):
        """How the element after a corner between two lines is entered."""
        return _corner_normal(v, line1, line2, side) if detection == "normal" else None

    if kind == "smooth":
        return [], _normal_entry(s2, v), t1
    if kind == "concave":
        both = s1.kind == "line" and s2.kind == "line"
        return [], crossing(t1, t2) if both else None, t1
    if treatment == "arc":
        if arc_items is not None:
            cw = _cross(t1, t2) < 0
            ref = _scale(_left(t1), side)
            span = _turn(ref, _scale(_left(t2), side), cw)
            arc_items(v, cw, 0, ref, span, _normal_entry(s1, v), s2.line, "corner arc", v, t1)
        return [], _normal_entry(s2, v), t2
    inserted = []
    if s1.kind == "arc":
        inserted.append((Element("line", s2.line, "extension", base=v, d=t1, offset=side,
                                 entry=_normal_entry(s1, v)), v, t1))
    if s2.kind == "arc":
        inserted.append((Element("line", s2.line, "extension", base=v, d=t2, offset=side,
                                 entry=crossing(t1, t2)), v, t1))
        return inserted, _normal_entry(s2, v), t2
    return inserted, crossing(t1, t2), t1


# ---- number formats and the hardware's functions ----------------------------------------

def _round(value):
    """``value`` rounded to the nearest integer, halves up (exact)."""
    value = Fraction(value)
    return math.floor(value + Fraction(1, 2))


@dataclass(frozen=True)
class Formats:
    """The widths of the hardware's numbers.

    Parameters
    ----------
    width : :class:`int`
        Coordinate width: every coordinate (profile, centres, the cutter's path) within
        ``±(2**width - 1)``; the radius below ``2**width``.
    fraction : :class:`int`
        Fractional bits of ``k``, ``b``, ``1/cos α``, ``2R`` and of the line functions (default
        ``width + 4``).
    """
    width: int = 16
    fraction: int = None

    def __post_init__(self):
        if isinstance(self.width, bool) or not isinstance(self.width, int) or self.width < 4:
            raise TypeError(f"Coordinate width must be an integer of at least 4, not "
                            f"{self.width!r}")
        if self.fraction is None:
            object.__setattr__(self, "fraction", self.width + 4)
        if (isinstance(self.fraction, bool) or not isinstance(self.fraction, int)
                or self.fraction < 2):
            raise TypeError(f"Fractional bits must be an integer of at least 2, not "
                            f"{self.fraction!r}")

    @property
    def one(self):
        return 1 << self.fraction

    @property
    def coefficient(self):
        """Width of ``k`` and ``1/cos α`` (signed)."""
        return self.fraction + 2

    @property
    def intercept(self):
        """Width of ``b`` (signed)."""
        return self.width + self.fraction + 3

    @property
    def square(self):
        """Width of ``R²`` (unsigned)."""
        return 2 * self.width + 3

    @property
    def diameter(self):
        """Width of ``2R`` (unsigned, with the fraction)."""
        return self.width + self.fraction + 3

    @property
    def value(self):
        """Width of a function's value (signed): a line's ``T·2**F``, a circle's ``S``."""
        return max(self.fraction + self.width + 4, 2 * self.width + 5)

    @property
    def core(self):
        """Register width of the arc core."""
        return self.width + 2


@dataclass(frozen=True)
class LineFunction:
    """A line as the hardware holds it: the seed's numbers (``swap``: the ``y, x`` system;
    ``minor``: the minor coordinate falls; ``k``, ``b``, ``sec`` = ``±1/cos α`` with the sign
    of the major direction, all scaled by ``2**F``) and ``g``, the offset per unit of r along
    the minor axis (``±sec`` for an equidistant, by the side; ``0`` for none) scaled alike."""
    swap: int
    minor: int
    k: int
    b: int
    sec: int
    g: int
    one: int

    @property
    def s(self):
        return -1 if self.minor else 1

    def coefficients(self):
        """``(C, D, E, G)``: ``T·2**F = E + C·x + D·y + G·r``."""
        s, one = self.s, self.one
        if self.swap:
            return -s * one, s * self.k, s * self.b, -s * self.g
        return s * self.k, -s * one, s * self.b, s * self.g

    def value(self, point, r):
        c, d, e, g = self.coefficients()
        return e + c * point[0] + d * point[1] + g * r

    def delta(self, dx, dy):
        c, d, _, _ = self.coefficients()
        return c * dx + d * dy


def line_function(base, d, offset, formats):
    """The hardware's line through the lattice point ``base`` with direction ``d``, moved
    ``offset`` times r to the left (:class:`LineFunction`).

    ``k``, ``1/cos α`` and ``offset/cos α`` are rounded to the nearest multiple of ``2**-F``;
    ``b`` is formed from the rounded ``k`` so that the line passes exactly through ``base``.
    """
    dx, dy = d
    one = formats.one
    length = _sqrt(dx * dx + dy * dy)
    if abs(dy) <= abs(dx):
        swap, minor = 0, int(dy < 0)
        k = _round(Fraction(dy, dx) * one)
        secant = length / dx
        b = base[1] * one - k * base[0]
    else:
        swap, minor = 1, int(dx < 0)
        k = _round(Fraction(dx, dy) * one)
        secant = length / dy
        b = base[0] * one - k * base[1]
    sec = _round(secant * one)
    return LineFunction(swap, minor, k, b, sec, _round(offset * secant * one), one)


@dataclass(frozen=True)
class CircleFunction:
    """A circle as the hardware holds it: centre, ``R²`` (``e``), ``2R·2**F`` (``g``), and
    ``sigma`` (+1: the cutter outside)."""
    centre: tuple
    e: int
    g: int
    sigma: int
    fraction: int

    def n(self, r):
        """``N = R² + r² + σ·round(2R·r)``: the squared radius the arc core traces."""
        product = (self.g * r + (1 << (self.fraction - 1))) >> self.fraction
        return self.e + r * r + self.sigma * product

    def value(self, point, r):
        u, v = point[0] - self.centre[0], point[1] - self.centre[1]
        return u * u + v * v - self.n(r)


def circle_function(centre, r2, sigma, formats):
    """The hardware's circle round ``centre`` of profile radius ``sqrt(r2)`` (``2R`` rounded to
    ``2**-F``), the cutter outside it when ``sigma`` is +1 (:class:`CircleFunction`)."""
    g = _round(2 * _sqrt(r2) * formats.one)
    return CircleFunction(tuple(centre), r2, g, sigma, formats.fraction)


def own_function(element, formats):
    """The function of an element's own equidistant."""
    if element.kind == "line":
        return line_function(element.base, element.d, element.offset, formats)
    return circle_function(element.centre, element.r2, element.sigma, formats)


def step_signs(element, function, point):
    """The signs ``(qx, qy)`` of the steps an element makes at ``point`` and which of its axis
    steps occur (``(x_axis, y_axis)``): a line its major axis and the diagonal, an arc in the
    quadrant of ``point`` (the one the motion enters on an axis) both axes and the diagonal."""
    if element.kind == "line":
        major = -1 if function.sec < 0 else 1
        if function.swap:
            return (function.s, major), (0, 1)
        return (major, function.s), (1, 0)
    u, v = point[0] - element.centre[0], point[1] - element.centre[1]
    q = quadrant(u, v, element.cw)
    sx, sy = SIGNS[q]
    # counter-clockwise in quadrant I: x falls, y rises; each quadrant turns the signs
    if element.cw:
        return (sy, -sx), (1, 1)
    return (-sy, sx), (1, 1)


def threshold(target, element, function, point, r):
    """``2τ``: the largest change of the target function over one step of the element's kinds
    at ``point`` (the element ends where ``2·h·F + 2τ >= 0``)."""
    (qx, qy), (x_axis, y_axis) = step_signs(element, function, point)
    kinds = [(qx, qy)] + ([(qx, 0)] if x_axis else []) + ([(0, qy)] if y_axis else [])
    if isinstance(target, LineFunction):
        return max(abs(target.delta(dx, dy)) for dx, dy in kinds)
    u, v = point[0] - target.centre[0], point[1] - target.centre[1]
    return max(abs(2 * u * dx + dx * dx + 2 * v * dy + dy * dy) for dx, dy in kinds)


def line_step(function, value):
    """The step ``(dx, dy)`` of the line whose function is ``value`` here (block 3): the
    major axis every step; the minor one when the line is half a step or more ahead after it
    (register III overflows), back when it is more than half a step behind; a step along the
    minor axis alone when the line is half a step ahead already."""
    half = function.one >> 1
    major = -1 if function.sec < 0 else 1
    s = function.s
    if value >= half:
        step = (0, s)
    else:
        ahead = value + abs(function.k)
        step = (major, s if ahead >= half else -s if ahead < -half else 0)
    return (step[1], step[0]) if function.swap else step


def _native_start(point, centre, cw):
    u, v = point[0] - centre[0], point[1] - centre[1]
    q = quadrant(u, v, cw)
    return q, native(u, v, q, cw)


# ---- host preparation: frames -----------------------------------------------------------

def element_frame(element, formats):
    """The frame of one element (a dict of the frame's fields, see ``hdl.equidistant``)."""
    frame = {"kind": KIND[element.kind], "last": int(element.last), "h": int(element.h < 0)}
    if element.kind == "line":
        own = own_function(element, formats)
        frame.update(side=element.offset, swap=own.swap, minor=own.minor, k=own.k, b=own.b,
                     sec=own.sec)
    else:
        own = own_function(element, formats)
        frame.update(side=element.side, cw=int(element.cw), x=own.centre[0], y=own.centre[1],
                     e=own.e, g=own.g)
    if element.entry is not None:
        entry = line_function(*element.entry, formats)
        frame.update(entry=1, eswap=entry.swap, eminor=entry.minor, ek=entry.k, eb=entry.b,
                     eg=entry.g)
    return frame


@dataclass(frozen=True)
class Prepared:
    """A profile prepared for the hardware at one radius: ``frames`` (the radius, the start
    point, one per element, and the return to the start for a closed profile), the
    ``elements`` behind them, the ``start`` point, and the exact equidistant (``pieces``)."""
    profile: Profile
    radius: int
    treatment: str
    detection: str
    formats: Formats
    elements: tuple
    start: tuple
    pieces: tuple
    frames: tuple

    @property
    def closed(self):
        return self.profile.closed


def program_frames(profile, *, treatment="extend", detection="normal", formats=Formats()):
    """The frames of the profile's elements: the program, the same for every radius."""
    return [element_frame(e, formats)
            for e in elements(profile, treatment=treatment, detection=detection)]


def prepare(profile, radius, *, treatment="extend", detection="normal", formats=Formats(),
            verify=True):
    """Check ``profile`` at the cutter radius ``radius`` and prepare the hardware's frames.

    The element frames do not depend on the radius (:func:`program_frames`); the radius frame
    and the start point do: the start is the lattice point nearest where the equidistant
    begins (halves rounded up).

    With ``verify`` (the default) the step level is run and every point the cutter's centre
    would visit is measured against the exact geometry: farther than :data:`PATH_BOUND` from
    the equidistant, or nearer the profile than ``radius - PATH_BOUND`` (where the
    equidistant of one part of the profile comes too near another: a slot narrower than the
    cutter), and the profile is refused before anything moves.

    Raises
    ------
    ProfileError
        For impossible geometry (:func:`offset_path`), numbers beyond the formats (a
        coordinate or centre beyond ``±(2**width - 1)``, the radius beyond ``2**width - 1``,
        the cutter's path out of range), or
        a path that would leave the equidistant or cut into the part (``verify``).
    """
    limit = (1 << formats.width) - 1
    if isinstance(radius, bool) or not isinstance(radius, int) or radius < 0:
        raise TypeError(f"Cutter radius must be a non-negative integer, not {radius!r}")
    if radius > limit:
        raise ProfileError(f"the cutter radius {radius} is too wide for the {formats.width}-bit "
                           f"registers (at most {limit})")
    for seg in profile.segments:
        for name, point in (("start", seg.start), ("end", seg.end), ("centre", seg.centre)):
            if point is not None and max(abs(point[0]), abs(point[1])) > limit:
                raise ProfileError(f"line {seg.line}: the {name} {point} is beyond the "
                                   f"{formats.width}-bit registers (at most {limit})")
        if max(abs(seg.start[0]), abs(seg.start[1]), abs(seg.end[0]), abs(seg.end[1])) \
                + radius + 2 > limit:
            raise ProfileError(f"line {seg.line}: the cutter's path would leave the "
                               f"{formats.width}-bit registers (at most {limit}) here")
        if seg.kind == "arc":
            rho = _sqrt(seg.r2) + radius
            if max(abs(seg.centre[0]), abs(seg.centre[1])) + rho + 2 > limit:
                raise ProfileError(f"line {seg.line}: the cutter's path would leave the "
                                   f"{formats.width}-bit registers (at most {limit}) here")
    pieces = offset_path(profile, radius, treatment=treatment)
    found = tuple(elements(profile, treatment=treatment, detection=detection))
    body = [element_frame(e, formats) for e in found]

    def made(start):
        frames = [{"kind": KIND["radius"], "x": radius},
                  {"kind": KIND["start"], "x": start[0], "y": start[1]}, *body]
        if profile.closed:
            frames.append({"kind": KIND["close"]})
        return Prepared(profile, radius, treatment, detection, formats, found, start,
                        tuple(pieces), tuple(frames))

    start = tuple(_round(c) for c in pieces[0].start)
    prepared = made(start)
    # A closed profile starts where its last element ends (the corner it closes on), so that
    # the return to the start is empty: found by running the step level from the nearest
    # lattice point, at most a few times (it settles at once unless the first element is
    # too short to forget its start).
    for _ in range(_START_ROUNDS if profile.closed else 0):
        parts = trace_elements(prepared)
        end = path_points(start, [s for _, steps in parts[:-1] for s in steps])[-1]
        if end == start:
            break
        start = end
        prepared = made(start)
    if verify:
        _verify(prepared)
    return prepared


#: Every point the cutter's centre visits lies within this distance of the exact equidistant
#: (and no nearer the profile than the radius less it): checked on every profile prepared.
PATH_BOUND = Fraction(17, 20)


def _verify(prepared):
    """Refuse a prepared profile whose trace leaves the equidistant or cuts into the part."""
    r = prepared.radius
    point = prepared.start
    for element, steps in trace_elements(prepared):
        line = element.line if element is not None else prepared.profile.segments[0].line
        for step in [None, *steps]:
            if step is not None:
                point = (point[0] + step[0], point[1] + step[1])
            off = distance_to_path(point, prepared.pieces, r)
            if off > PATH_BOUND:
                raise ProfileError(f"line {line}: the cutter's centre would pass {float(off):.3g}"
                                   f" steps from the equidistant at {point}: the interpolator "
                                   f"cannot follow this corner")
            near = distance_to_profile(point, prepared.profile)
            if near < r - PATH_BOUND:
                seg = min(prepared.profile.segments, key=lambda g: distance_to_profile(
                    point, Profile((g,), prepared.profile.side)))
                raise ProfileError(f"line {line}: the cutter (radius {r}) would cut "
                                   f"{float(r - near):.3g} steps into the part at line "
                                   f"{seg.line} (its centre at {point})")


# ---- step level --------------------------------------------------------------------------

def _ends(target, h, point, tau2, r):
    return 2 * h * target.value(point, r) + tau2 >= 0


@dataclass(frozen=True)
class _Traced:
    """An element as its frame gives it to the step level."""
    kind: str
    own: object
    target: object              # the function that ends the element *before* this one
    h: int
    last: bool
    centre: tuple = None
    cw: bool = False


def _from_frame(frame, formats):
    one = formats.one
    if frame["kind"] == KIND["line"]:
        own = LineFunction(frame["swap"], frame["minor"], frame["k"], frame["b"], frame["sec"],
                           frame["side"] * frame["sec"], one)
        traced = dict(kind="line", own=own)
    else:
        sigma = 1 if (frame["side"] == 1) == bool(frame["cw"]) else -1
        own = CircleFunction((frame["x"], frame["y"]), frame["e"], frame["g"], sigma,
                             formats.fraction)
        traced = dict(kind="arc", own=own, centre=(frame["x"], frame["y"]),
                      cw=bool(frame["cw"]))
    target = own
    if frame["entry"]:
        target = LineFunction(frame["eswap"], frame["eminor"], frame["ek"], frame["eb"], 0,
                              frame["eg"], one)
    return _Traced(target=target, h=-1 if frame["h"] else 1, last=bool(frame["last"]),
                   **traced)


def _trace_contour(traced, point, r):
    """The steps of every element of a contour from ``point``: ``(steps per element,
    end point)``."""
    out = []
    for i in range(len(traced) - 1):
        element, after = traced[i], traced[i + 1]
        own, target, h = element.own, after.target, after.h
        steps = []

        def move(step):
            nonlocal point
            point = (point[0] + step[0], point[1] + step[1])
            steps.append(step)

        if element.kind == "line":
            while True:
                tau2 = threshold(target, element, own, point, r)
                if _ends(target, h, point, tau2, r):
                    break
                move(line_step(own, own.value(point, r)))
                if _ends(target, h, point, tau2, r):
                    break
        else:
            n = own.n(r)
            ended = False
            while not ended:
                tau2 = threshold(target, element, own, point, r)
                if _ends(target, h, point, tau2, r) or n <= 0 or point == own.centre:
                    break
                q, (x, y) = _native_start(point, own.centre, element.cw)
                for kind, _ in native_moves(x, y, n):
                    tau2 = threshold(target, element, own, point, r)
                    if _ends(target, h, point, tau2, r):
                        ended = True
                        break
                    move(real_step(int(kind in "DX"), int(kind in "DY"), q, element.cw))
                    if _ends(target, h, point, tau2, r):
                        ended = True
                        break
        out.append(steps)
    out.append([])                               # the terminal: aimed at, not traced
    return out, point


def frame_outcomes(frames, formats=None):
    """What the hardware makes of ``frames``, frame by frame (step level): a list of
    ``(outcome, steps)``, ``outcome`` 0 (done) or 1 (refused), as
    :class:`EquidistantEngineModel` and the RTL have them with no abort.

    Every function is evaluated afresh at every point from the frame's numbers (the
    hardware integrates them). Refused: an element with no contour open, an unknown kind, a
    negative radius.

    Raises
    ------
    InputError
        For a program the hardware would wait on for ever: a radius, start or return frame
        inside a contour (before its terminal), or a contour that never ends.
    """
    formats = formats or Formats()
    out = []
    r = 0
    point = start = (0, 0)
    contour = None                               # indices and elements of an open contour
    for frame in frames:
        frame = _frame_defaults(frame)
        kind = frame["kind"]
        if kind in (KIND["line"], KIND["arc"]):
            if contour is None:
                out.append((REFUSED_CODE, []))
                continue
            contour.append((len(out), _from_frame(frame, formats)))
            out.append(None)
            if frame["last"]:
                traced, point = _trace_contour([e for _, e in contour], point, r)
                for (index, _), steps in zip(contour, traced):
                    out[index] = (DONE_CODE, steps)
                contour = None
            continue
        if contour is not None and kind <= KIND["close"]:
            raise InputError("a radius, start or return frame inside a contour (before its "
                             "terminal): the engine would wait for ever")
        if kind > KIND["close"] or (kind == KIND["radius"] and frame["x"] < 0):
            out.append((REFUSED_CODE, []))
        elif kind == KIND["radius"]:
            r = frame["x"]
            out.append((DONE_CODE, []))
        elif kind == KIND["start"]:
            point = start = (frame["x"], frame["y"])
            contour = []
            out.append((DONE_CODE, []))
        else:
            steps = []
            while point != start:
                step = tuple((t > p) - (t < p) for p, t in zip(point, start))
                point = (point[0] + step[0], point[1] + step[1])
                steps.append(step)
            out.append((DONE_CODE, steps))
    if contour is not None and contour:
        raise InputError("the contour has no terminal frame: the engine would wait for ever")
    return out


def trace_elements(prepared):
    """The steps of every element of a prepared profile: a list of ``(element, steps)``,
    then ``(None, steps)`` for the return to the start of a closed profile."""
    outcomes = frame_outcomes(prepared.frames, prepared.formats)
    parts = [(element, steps) for element, (_, steps)
             in zip(prepared.elements, outcomes[2:2 + len(prepared.elements)])]
    parts = parts[:-1]                           # (the terminal makes no step)
    if prepared.closed:
        parts.append((None, outcomes[-1][1]))
    return parts


def trace(prepared):
    """The steps ``(dx, dy)`` of the cutter's centre from the start point (step level)."""
    return [step for _, steps in trace_elements(prepared) for step in steps]


# ---- measuring a trace against the geometry ---------------------------------------------

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
    """The distance from ``point`` to the profile (every segment)."""
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
    return _nearest(point, profile.segments, exact, rough)


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


# ---- cycle level -------------------------------------------------------------------------

class EquidistantEngineModel:
    """Clock-by-clock model of :class:`hdl.equidistant.EquidistantEngine` around a quadrant
    core model (:class:`~sim.models.circular.FastArcCoreModel` or
    :class:`~sim.models.circular.FaithfulArcCoreModel` of width ``width + 2``).

    Registers as the RTL has them: the three slots of block 2 (``None`` when empty), the
    position counters (blocks 12, 13), the radius and r², the start, the product unit
    (blocks 5-8: its state, the frame being formed, the position it is formed at, the clocks
    left), the arc run (state, swap, directions), the contour and return flags, the status
    unit. Call :meth:`cycle` once per clock.
    """

    def __init__(self, core, *, fraction=None, number_width=8):
        from .engine import StatusModel
        self.core = core
        self.formats = Formats(core.width - 2, fraction)
        self.width = self.formats.width
        self.status = StatusModel(position_width=self.width + 3, number_width=number_width)
        self.reset()

    def reset(self):
        self.core.reset()
        self.status.reset()
        self.own = self.cmp = self.prep = None
        self.x = self.y = 0
        self.radius = self.radius2 = 0
        self.start = (0, 0)
        self.contour = 0
        self.homing = 0
        self.unit = 0
        self.left = 0
        self.pending = None
        self.p0 = (0, 0)
        self.arc_state = 0
        self.run_swap = 0
        self.run_dir = 0
        self.product = 0                  # block 6's last product (r² is taken from it)

    def state(self):
        return {"x": self.x, "y": self.y, "unit": self.unit, "arc_state": self.arc_state}

    # -- the functions of a slot --

    def _coefficients(self, swap, minor, k):
        one = self.formats.one
        sk, sone = (-k, -one) if minor else (k, one)
        return (-sone, sk) if swap else (sk, -sone)

    def _stepped(self, s, dx, dy):
        c, d = self._coefficients(s["swap"], s["minor"], s["k"])
        ec, ed = self._coefficients(s["eswap"], s["eminor"], s["ek"])
        if s["arc"]:
            u, v = self.x - s["cx"], self.y - s["cy"]
            dv = (2 * u * dx + 1 if dx else 0) + (2 * v * dy + 1 if dy else 0)
        else:
            dv = c * dx + d * dy
        return s["v"] + dv, s["w"] + ec * dx + ed * dy

    def _line_value(self, frame, second, base):
        one = self.formats.one
        bx, by = base
        if second:
            swap, minor, k, b, g = (frame["eswap"], frame["eminor"], frame["ek"], frame["eb"],
                                    frame["eg"])
        else:
            swap, minor, k, b = frame["swap"], frame["minor"], frame["k"], frame["b"]
            g = frame["side"] * frame["sec"]
        raw = (k * by + b - bx * one - g * self.radius if swap
               else k * bx + b - by * one + g * self.radius)
        return -raw if minor else raw

    def _circle_value(self, frame, base):
        f = self.formats
        u, v = base[0] - frame["x"], base[1] - frame["y"]
        rounded = (frame["g"] * self.radius + (f.one >> 1)) >> f.fraction
        sigma = 1 if (frame["side"] == 1) == bool(frame["cw"]) else -1
        n = frame["e"] + self.radius2 + sigma * rounded
        return u * u + v * v - n, n

    def cycle(self, *, valid=0, payload=None, tick=1, abort=0, status_ready=1):
        f = self.formats
        one, half = f.one, f.one >> 1
        frame = _frame_defaults(payload)
        own, cmp, prep = self.own, self.cmp, self.prep
        status = self.status
        hold = status.hold
        x, y = self.x, self.y

        running = int(own is not None and not own["last"] and own["ready"] and cmp is not None
                      and cmp["ready"] and not hold and not abort)

        # block 3
        line = {}
        if own is not None:
            reg1 = abs(own["k"])
            minor_only = own["v"] >= half
            ahead = own["v"] + reg1
            forward = not minor_only and ahead >= half
            backward = not minor_only and ahead < -half
            line = {"major": int(not minor_only),
                    "minor": int(minor_only or forward or backward),
                    "minor_negative": int(bool(own["minor"]) != backward)}

        # block 11: the kinds of the traced element's steps and the target's threshold
        tau2 = 0
        quadrant_own = 0
        if own is not None:
            ou, ov = x - own["cx"], y - own["cy"]
            quadrant_own = quadrant(ou, ov, own["cw"])
        if own is not None and cmp is not None:
            x_negative = quadrant_own in (1, 2)
            y_negative = quadrant_own in (2, 3)
            if own["arc"]:
                qxn = y_negative if own["cw"] else not y_negative
                qyn = (not x_negative) if own["cw"] else x_negative
            else:
                qxn = own["minor"] if own["swap"] else own["back"]
                qyn = own["back"] if own["swap"] else own["minor"]
            x_kind = own["arc"] or not own["swap"]
            y_kind = own["arc"] or own["swap"]
            qx, qy = -1 if qxn else 1, -1 if qyn else 1
            if cmp["arc"] and not cmp["entry"]:
                tu, tv = x - cmp["cx"], y - cmp["cy"]
                ka, kb = 2 * tu * qx + 1, 2 * tv * qy + 1
            else:
                if cmp["entry"]:
                    tc, td = self._coefficients(cmp["eswap"], cmp["eminor"], cmp["ek"])
                else:
                    tc, td = self._coefficients(cmp["swap"], cmp["minor"], cmp["k"])
                ka, kb = tc * qx, td * qy
            tau2 = max(abs(ka) if x_kind else 0, abs(kb) if y_kind else 0, abs(ka + kb))

        def reached(value):
            return (2 * (-value if cmp["h"] else value) + tau2) >= 0

        end_now = 0
        if running:
            target = cmp["w"] if cmp["entry"] else cmp["v"]
            at_centre = own["arc"] and (x, y) == (own["cx"], own["cy"])
            end_now = int(reached(target) or (own["arc"] and (own["empty"] or at_centre)))

        line_due = int(running and not end_now and not own["arc"])
        line_step = int(line_due and bool(tick))
        arc_go = int(running and not end_now and bool(own["arc"]))
        core_tick = int(bool(tick) and arc_go)
        core_abort = int(bool(abort) or (own is not None and own["arc"] and end_now))
        native = self.core.peek(tick=core_tick, abort=core_abort)
        arc_bits = ((native & 1) << 1 | native >> 1) if self.run_swap else native
        home_dx, home_dy = int(x != self.start[0]), int(y != self.start[1])
        home_due = int(bool(self.homing) and bool(home_dx or home_dy) and not hold
                       and not abort)
        home_step = int(home_due and bool(tick))

        step_x = step_y = neg_x = neg_y = 0
        if line_step:
            if own["swap"]:
                step_x, neg_x = line["minor"], line["minor_negative"]
                step_y, neg_y = line["major"], own["back"]
            else:
                step_x, neg_x = line["major"], own["back"]
                step_y, neg_y = line["minor"], line["minor_negative"]
        elif home_step:
            step_x, neg_x = home_dx, int(x > self.start[0])
            step_y, neg_y = home_dy, int(y > self.start[1])
        elif arc_go:
            step_x, neg_x = arc_bits & 1, self.run_dir & 1
            step_y, neg_y = arc_bits >> 1 & 1, self.run_dir >> 1 & 1
        dx = (-1 if neg_x else 1) if step_x else 0
        dy = (-1 if neg_y else 1) if step_y else 0
        stepped = int(bool(step_x or step_y) and not self.homing)

        slots = [own, cmp, prep]
        stepped_vw = [self._stepped(s, dx, dy) if s is not None else (0, 0) for s in slots]
        end_after = 0
        if running and not end_now and stepped:
            target_after = stepped_vw[1][1] if cmp["entry"] else stepped_vw[1][0]
            end_after = int(reached(target_after))
        core_stop = int(own is not None and bool(own["arc"]) and bool(end_after))
        core_out = self.core.evaluate(tick=core_tick, stop=core_stop, abort=core_abort)

        element_end = int(bool(end_now) or bool(end_after))
        terminal_end = int(own is not None and bool(own["last"]) and not hold and not abort)
        shift_own = int(bool(element_end) or bool(terminal_end) or own is None)
        shift_cmp = int(bool(shift_own) or cmp is None)
        shift_prep = int(bool(shift_cmp) or prep is None)

        # block 1
        kind = frame["kind"]
        is_element = kind in (KIND["line"], KIND["arc"])
        bad = (kind > KIND["close"] or (is_element and not self.contour)
               or (kind == KIND["radius"] and frame["x"] < 0))
        combine1 = self.unit == 2 and self.left == 0
        combine2 = self.unit == 4 and self.left == 0
        last_round = (combine1 and not self.pending["entry"]) or combine2 if self.pending \
            else False
        engine_idle = (own is None and cmp is None and prep is None and self.unit == 0
                       and not self.homing and not self.contour)
        accepting = not abort and not status.flushing
        take_element = (accepting and bool(self.contour) and is_element and bool(shift_prep)
                        and (self.unit == 0 or bool(last_round)))
        take_control = accepting and not is_element and not bad and engine_idle and \
            bool(status.idle)
        refuse = int(bool(valid) and accepting and bool(bad) and engine_idle
                     and bool(status.idle))
        ready = refuse if bad else int(bool(take_element) if is_element
                                       else bool(take_control))
        accept = int(bool(valid) and bool(ready))

        taken = accept and not bad
        start_now = int(taken and kind == KIND["start"])
        close_now = int(taken and kind == KIND["close"])
        close_end = int((close_now and not home_dx and not home_dy)
                        or (home_step and (x + dx, y + dy) == self.start))
        radius_end = int(self.unit == 5 and self.left == 0)

        arc_due = int(bool(core_out["due"]) and bool(arc_go))
        due = int(bool(line_due) or bool(arc_due) or bool(home_due))
        if line_due:
            diagonal = int(bool(line["major"]) and bool(line["minor"]))
        elif home_due:
            diagonal = int(bool(home_dx) and bool(home_dy))
        else:
            diagonal = int(core_out["diagonal"])
        diagonal = int(bool(due) and bool(diagonal))
        end = int(bool(element_end) or bool(terminal_end) or bool(start_now)
                  or bool(close_end) or bool(radius_end) or bool(refuse))
        step_bits = step_x | step_y << 1
        stream = status.evaluate(step=step_bits, direction=neg_x | neg_y << 1, end=end,
                                 outcome=REFUSED_CODE if refuse else DONE_CODE,
                                 status_ready=status_ready)
        outputs = {"ready": ready, "step": step_bits,
                   "dir": (step_x & neg_x) | (step_y & neg_y) << 1, "busy": status.busy,
                   "due": due, "diagonal": diagonal,
                   "status": stream["payload"] if stream["transfer"] else None}
        state = self.state()

        # ---- clock edge -------------------------------------------------------------------
        core_valid = int(bool(arc_go) and self.arc_state == 0)
        run = None
        if core_valid:
            q = quadrant_own
            u, v = x - own["cx"], y - own["cy"]
            run = {"x": abs(u) if type_a(q, own["cw"]) else abs(v),
                   "y": abs(v) if type_a(q, own["cw"]) else abs(u), "residue": -own["v"]}
        self.core.cycle(tick=core_tick, stop=core_stop, abort=core_abort, valid=core_valid,
                        payload=run)

        values = {}
        if self.unit in (2, 4) and self.left == 0:
            second = self.unit == 4
            if self.pending["kind"] == KIND["arc"] and not second:
                values["circle"] = self._circle_value(self.pending, self.p0)
            values["line"] = self._line_value(self.pending, second, self.p0)

        def advanced(n):
            s = slots[n]
            if s is None:
                return None
            s = dict(s)
            s["v"], s["w"] = stepped_vw[n]
            if s["computing"] and combine1:
                if s["arc"]:
                    value, big_n = values["circle"]
                    s["v"] += value
                    s["empty"] = int(big_n <= 0)
                else:
                    s["v"] += values["line"]
                if not self.pending["entry"]:
                    s["computing"], s["ready"] = 0, 1
            if s["computing"] and combine2:
                s["w"] += values["line"]
                s["computing"], s["ready"] = 0, 1
            return s

        moved = [advanced(n) for n in range(3)]
        if abort:
            self.own = self.cmp = self.prep = None
        else:
            self.own = moved[1] if shift_own else moved[0]
            self.cmp = moved[2] if shift_cmp else moved[1]
            if shift_prep:
                self.prep = _new_slot(frame) if (take_element and valid) else None
            else:
                self.prep = moved[2]

        # arc run state
        if abort or element_end:
            self.arc_state = 0
        elif self.arc_state == 0 and core_valid:
            q = quadrant_own
            self.arc_state = 1
            self.run_swap = int(not type_a(q, own["cw"]))
            self.run_dir = direction_bits(q, own["cw"])
        elif self.arc_state == 1:
            self.arc_state = 2
        elif self.arc_state == 2 and core_out["done"]:
            self.arc_state = 0

        # blocks 5-8
        length = self.width + 2
        if abort:
            self.unit = 0
        elif self.unit == 0:
            if taken and kind == KIND["radius"]:
                self.unit, self.radius, self.left = 5, frame["x"], length
                self.product = frame["x"] * frame["x"]
        elif self.unit == 1:
            self.unit, self.p0, self.left = 2, (x, y), length
        elif combine1:
            self.unit = 3 if self.pending["entry"] else 0
        elif self.unit == 3:
            self.unit, self.left = 4, length
        elif combine2:
            self.unit = 0
        elif self.unit == 5 and self.left == 0:
            self.unit, self.radius2 = 0, self.product
        elif self.left:
            self.left -= 1
        if take_element and valid and not abort:
            self.pending, self.unit = frame, 1

        # control frames and position
        if abort:
            self.contour = self.homing = 0
        else:
            if start_now:
                self.contour, self.start = 1, (frame["x"], frame["y"])
            if take_element and valid and frame["last"]:
                self.contour = 0
            if close_now and not close_end:
                self.homing = 1
            if close_end:
                self.homing = 0
        if start_now:
            self.x, self.y = frame["x"], frame["y"]
        else:
            self.x, self.y = x + dx, y + dy
        status.advance(accept=accept, flush=abort)
        return outputs, state


DONE_CODE, REFUSED_CODE = 0, 1

_FRAME_FIELDS = ("kind", "last", "h", "side", "cw", "swap", "minor", "k", "b", "sec", "x", "y",
                 "e", "g", "entry", "eswap", "eminor", "ek", "eb", "eg")


def _frame_defaults(payload):
    """A frame dict with every field (missing ones zero)."""
    return {name: int((payload or {}).get(name, 0)) for name in _FRAME_FIELDS}


def _new_slot(frame):
    return {"valid": 1, "ready": 0, "computing": 1, "last": frame["last"],
            "arc": int(frame["kind"] == KIND["arc"]), "h": frame["h"], "entry": frame["entry"],
            "empty": 0, "swap": frame["swap"], "minor": frame["minor"],
            "back": int(frame["sec"] < 0), "k": frame["k"], "cx": frame["x"], "cy": frame["y"],
            "cw": frame["cw"], "eswap": frame["eswap"], "eminor": frame["eminor"],
            "ek": frame["ek"], "v": 0, "w": 0}
