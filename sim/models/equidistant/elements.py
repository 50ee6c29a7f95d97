"""The elements of the hardware, independent of the radius (:func:`elements`): the profile's
segments, arc pieces of at most a quarter turn, the corners' extension and normal lines, each
with the function that ends the element before it."""

from dataclasses import dataclass, replace
from fractions import Fraction

from .geometry import (DETECTIONS, TREATMENTS, ProfileError, _add, _corner_kind, _corner_normal,
                       _cross, _rounds, _dot, _left, _normal_entry, _scale, _sub, _turn)

__all__ = ["Element", "elements"]


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


def elements(profile, *, treatment="extend", detection="normal", radius=None):
    """The hardware's elements for ``profile`` (any radius): a list of :class:`Element`, the
    last one the terminal aimed at (``last``): for a closed profile the first element again,
    for an open one the normal at the last end point.

    ``detection`` says what ends a line at a corner with a line: ``"normal"``, the normal of
    the line through the intersection of the equidistants (a combination of the two
    equations (13) that vanishes at the same point and crosses the line at a right angle), or
    ``"seed"``, the next line's own equidistant (equation (13) with Table 1's coefficients).

    ``radius`` (steps), when given, is the one radius the elements are for: a joint tangent
    up to the lattice's rounding is then smooth (:func:`~.geometry._corner_kind`), as
    :func:`~.geometry.offset_path` at that radius has it; without it (the program for any
    radius) only an exactly tangent joint is.

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
        corners[i] = (_corner_kind(s1, s2, side, radius), s1, s2)

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
    if _rounds(treatment, t1, t2):
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
