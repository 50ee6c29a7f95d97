"""Geometry of step paths: where steps lead, and how far the points lie from the true curve.

Used to check the golden models against geometry (tests) and to report accuracy (demo,
``kontur bench accuracy``). Floating point is fine here: these are measurements, never part of
an algorithm.
"""

import math

__all__ = ["walk", "segment_deviation", "radial_error"]


def walk(start, steps):
    """The points visited from ``start`` by ``steps`` (``(dx, dy)`` pairs), start excluded."""
    x, y = start
    points = []
    for dx, dy in steps:
        x, y = x + dx, y + dy
        points.append((x, y))
    return points


def segment_deviation(start, end, points):
    """Largest distance of ``points`` from the line through ``start`` and ``end``."""
    (x0, y0), (x1, y1) = start, end
    length = math.hypot(x1 - x0, y1 - y0)
    return max(abs((x - x0) * (y1 - y0) - (y - y0) * (x1 - x0)) / length for x, y in points)


def radial_error(points, r2, centre=(0, 0)):
    """Largest distance of ``points`` from the circle of radius ``sqrt(r2)`` about ``centre``."""
    cx, cy = centre
    radius = math.sqrt(r2)
    return max(abs(math.hypot(x - cx, y - cy) - radius) for x, y in points)
