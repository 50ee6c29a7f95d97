"""The hardware's numbers (:class:`Formats`, from :mod:`kontur.hdl.spec`), the functions of its
elements in fixed point (:class:`LineFunction`, :class:`CircleFunction`: the seed's
``E + C·x + D·y + G·r``), block 3's line step and block 11's threshold, and an element's frame
(:func:`element_frame`)."""

import math
from dataclasses import dataclass
from fractions import Fraction

from kontur.hdl.spec import Formats, Kind

from ..arc import SIGNS, native, quadrant
from .geometry import _add, _left, _scale, _sqrt

__all__ = ["Formats", "KIND", "LineFunction", "CircleFunction", "line_function", "circle_function",
           "own_function", "step_signs", "threshold", "line_step", "element_frame"]

#: Frame kinds (the ``kind`` field; :class:`kontur.hdl.spec.Kind`).
KIND = {"radius": Kind.RADIUS, "start": Kind.START, "line": Kind.LINE, "arc": Kind.ARC,
        "close": Kind.CLOSE}

def _round(value):
    """``value`` rounded to the nearest integer, halves up (exact)."""
    value = Fraction(value)
    return math.floor(value + Fraction(1, 2))


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


def line_function(base, d, offset, formats, delta=0):
    """The hardware's line through the lattice point ``base`` with direction ``d``, moved
    ``offset`` times r to the left (:class:`LineFunction`).

    ``k``, ``1/cos α`` and ``offset/cos α`` are rounded to the nearest multiple of ``2**-F``;
    ``b`` is formed from the rounded ``k`` so that the line passes exactly through ``base``
    (with ``delta``, the part of the cutter radius below the dial's whole steps, through
    ``base`` moved ``offset·delta`` to the left: ``b`` rounded to ``2**-F``).
    """
    dx, dy = d
    one = formats.one
    length = _sqrt(dx * dx + dy * dy)
    if delta and offset:
        base = _add(base, _scale(_left(d), offset * Fraction(delta) / length))
    if abs(dy) <= abs(dx):
        swap, minor = 0, int(dy < 0)
        k = _round(Fraction(dy, dx) * one)
        secant = length / dx
        b = _round(base[1] * one - k * base[0])
    else:
        swap, minor = 1, int(dx < 0)
        k = _round(Fraction(dx, dy) * one)
        secant = length / dy
        b = _round(base[0] * one - k * base[1])
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


def circle_function(centre, r2, sigma, formats, delta=0):
    """The hardware's circle round ``centre`` of profile radius ``sqrt(r2)`` (``2R`` rounded to
    ``2**-F``), the cutter outside it when ``sigma`` is +1 (:class:`CircleFunction`).

    With ``delta`` (the part of the cutter radius below the dial's whole steps) the profile
    radius is ``R + σ·delta`` (``R²`` rounded to an integer, ``2R`` to ``2**-F``), so that the
    circle traced at the dial's ``r`` is the equidistant at ``r + delta``; so too where ``r2``
    is not an integer (a radius fitted by the host)."""
    if not delta and Fraction(r2).denominator == 1:
        return CircleFunction(tuple(centre), int(r2), _round(2 * _sqrt(r2) * formats.one),
                              sigma, formats.fraction)
    rho = _sqrt(r2) + sigma * Fraction(delta)
    if rho < 0:
        raise ValueError(f"the circle's radius less the radius's fraction is negative ({rho})")
    return CircleFunction(tuple(centre), _round(rho * rho), _round(2 * rho * formats.one),
                          sigma, formats.fraction)


def own_function(element, formats, delta=0):
    """The function of an element's own equidistant (``delta``: see :func:`line_function`)."""
    if element.kind == "line":
        return line_function(element.base, element.d, element.offset, formats, delta)
    return circle_function(element.centre, element.r2, element.sigma, formats, delta)


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


def element_frame(element, formats, delta=0):
    """The frame of one element (a dict of the frame's fields, see ``kontur.hdl.equidistant``);
    ``delta``: the cutter radius less the dial's whole steps (``0 <= delta < 1``), taken into
    the frame's numbers (:func:`line_function`, :func:`circle_function`), so that the engine,
    dialled at the whole steps, traces the equidistant at the whole radius."""
    frame = {"kind": KIND[element.kind], "last": int(element.last), "h": int(element.h < 0)}
    if element.kind == "line":
        own = own_function(element, formats, delta)
        frame.update(side=element.offset, swap=own.swap, minor=own.minor, k=own.k, b=own.b,
                     sec=own.sec)
    else:
        own = own_function(element, formats, delta)
        frame.update(side=element.side, cw=int(element.cw), x=own.centre[0], y=own.centre[1],
                     e=own.e, g=own.g)
    if element.entry is not None:
        entry = line_function(*element.entry, formats, delta)
        frame.update(entry=1, eswap=entry.swap, eminor=entry.minor, ek=entry.k, eb=entry.b,
                     eg=entry.g)
    return frame


DONE_CODE, REFUSED_CODE = 0, 1

_FRAME_FIELDS = ("kind", "last", "h", "side", "cw", "swap", "minor", "k", "b", "sec", "x", "y",
                 "e", "g", "entry", "eswap", "eminor", "ek", "eb", "eg")


def _frame_defaults(payload):
    """A frame dict with every field (missing ones zero)."""
    return {name: int((payload or {}).get(name, 0)) for name in _FRAME_FIELDS}
