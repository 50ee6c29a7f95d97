# amaranth: UnusedElaboratable=no
"""Lines in XYZ: the step model against the ideal 3D line, the RTL against the cycle model."""

import itertools
import math
import random

import pytest
from amaranth.lib.wiring import Out
from hypothesis import given, settings
from hypothesis import strategies as st

from kontur.hdl.engine import FeedSignature
from kontur.hdl.line import LineCoreSignature, LineEngine
from kontur.hdl.spatial import SpatialLineCore
from kontur.sim.models.errors import InputError
from kontur.sim.models.line import LineEngineModel
from kontur.sim.models.linear import steps as linear_steps
from kontur.sim.models.spatial import SpatialLineCoreModel, spatial_steps
from kontur.sim.runners import run_amaranth
from kontur.sim.stimulus import Job, first_difference, record_outcomes, record_steps, run_model

#: The bound of docs/architecture.md ("The third axis"): each axis within half a step of the
#: line at the dominant axis's coordinate, so a point within sqrt(1/4 + 1/4) of the line.
BOUND = math.sqrt(0.5)


def check_against_line(end, path):
    """The path from the origin to ``end``, judged by the ideal line alone (exact integers):
    it ends on ``end``; every step moves the dominant axis by one toward it, each axis by at
    most one; at every step each axis is within half a step of the line's point at the same
    dominant coordinate; every point is within ``BOUND`` of the line. Returns the largest
    distance."""
    a = max(map(abs, end))
    assert len(path) == a
    dominant = [axis for axis in range(3) if abs(end[axis]) == a]
    point = [0, 0, 0]
    worst = 0.0
    norm2 = sum(c * c for c in end)
    for k, step in enumerate(path, 1):
        assert all(s in (-1, 0, 1) for s in step)
        for axis in dominant:
            assert step[axis] == (1 if end[axis] > 0 else -1)
        point = [p + s for p, s in zip(point, step)]
        for axis in range(3):
            # |point - k·end/a| <= 1/2, times 2a
            assert abs(2 * (a * point[axis] - k * end[axis])) <= a, (end, k, point)
        cross = (point[1] * end[2] - point[2] * end[1], point[2] * end[0] - point[0] * end[2],
                 point[0] * end[1] - point[1] * end[0])
        distance = math.sqrt(sum(c * c for c in cross) / norm2)
        assert distance < BOUND, (end, point)
        worst = max(worst, distance)
    assert point == list(end)
    return worst


def test_every_line_of_width_3():
    # Every end point with |x|, |y|, |z| <= 7, in every octant.
    worst = 0.0
    for end in itertools.product(range(-7, 8), repeat=3):
        path = spatial_steps(*end, width=3)
        if end == (0, 0, 0):
            assert path == []
            continue
        worst = max(worst, check_against_line(end, path))
    # Above the 2-axis bound of 0.5 (two axes half a step off at once): (6, 1, 1) at (3, 0, 0)
    # is sqrt(1/4 + 1/4 - 1/38) away.
    assert worst == pytest.approx(math.sqrt(0.5 - 1 / 38))


def test_every_line_of_width_5_in_the_first_octant():
    for end in itertools.product(range(32), repeat=3):
        if any(end):
            check_against_line(end, spatial_steps(*end, width=5))


@settings(max_examples=200, deadline=None)
@given(st.tuples(*[st.integers(-(1 << 12) + 1, (1 << 12) - 1)] * 3))
def test_random_lines(end):
    if any(end):
        check_against_line(end, spatial_steps(*end, width=12))


def test_two_axes_are_the_exact_variant():
    # With z = 0 the steps are SU 1571551's equation (1), the 2-axis exact core's.
    for x, y in itertools.product(range(-20, 21), repeat=2):
        assert [s[:2] for s in spatial_steps(x, y, 0, width=5)] == \
            linear_steps(x, y, variant="exact", width=5)


def test_too_wide():
    with pytest.raises(InputError, match=r"\|Z\| = 8"):
        spatial_steps(1, 2, -8, width=3)


def test_signatures():
    assert FeedSignature() == FeedSignature(2)
    assert FeedSignature(3) != FeedSignature()
    assert FeedSignature(2).members["diagonal"] == Out(1)
    assert FeedSignature(3).members["diagonal"] == Out(2)
    assert repr(FeedSignature(3)) == "FeedSignature(3)"
    assert LineCoreSignature(8) == LineCoreSignature(8, 2) != LineCoreSignature(8, 3)
    engine = LineEngine(SpatialLineCore(width=8))
    assert engine.signature.axes == 3
    assert list(engine.signature.frame.members) == ["x", "y", "z"]
    assert engine.signature.members["feed"].signature == FeedSignature(3)
    with pytest.raises(ValueError):
        LineCoreSignature(8, 4)


def _frames(rng, count, bits, axes):
    def value():
        return rng.choice([-1, 1]) * rng.randrange(1 << rng.randint(0, bits))
    names = ("x", "y", "z")[:axes]
    return [{name: value() for name in names} for _ in range(count)]


def _expected(frames, width):
    moves = []
    for frame in frames:
        try:
            moves += spatial_steps(*frame.values(), width=width)
        except InputError:
            pass
    return moves


@pytest.mark.parametrize("axes", [2, 3])
def test_rtl_equals_model(axes):
    # Amaranth's simulator: every output in every clock, with stalls, aborts and refusals.
    rng = random.Random(axes)
    frames = _frames(rng, 30, 6, axes) + [dict.fromkeys("xyz"[:axes], 0),
                                           {"x": 300, **dict.fromkeys("yz"[:axes - 1], 1)}]
    job = Job(frames=frames, tick=[int(rng.random() < 0.7) for _ in range(41)],
              status_ready=[int(rng.random() < 0.8) for _ in range(23)],
              gaps=[rng.choice([0, 0, 2]) for _ in frames])
    expected = run_model(LineEngineModel(SpatialLineCoreModel(width=8, axes=axes)), job)
    actual = run_amaranth(LineEngine(SpatialLineCore(width=8, axes=axes)), job)
    assert first_difference(expected, actual) is None
    steps = record_steps(actual, axes)
    assert [s + (0,) * (3 - axes) for s in steps] == _expected(
        [{**f, "z": f.get("z", 0)} for f in frames], 8)
    outcomes = record_outcomes(actual)
    assert [outcome for _, _, outcome, _ in outcomes].count(1) == 1      # 300 is too wide
    for entry in actual:
        if not entry["rst"] and entry["step"]:
            assert entry["diagonal"] == bin(entry["step"]).count("1") - 1


def test_rtl_aborts():
    rng = random.Random(7)
    frames = _frames(rng, 12, 5, 3)
    job = Job(frames=frames, aborts={20: 1, 45: 2, 90: 1})
    expected = run_model(LineEngineModel(SpatialLineCoreModel(width=6)), job)
    actual = run_amaranth(LineEngine(SpatialLineCore(width=6)), job)
    assert first_difference(expected, actual) is None
    outcomes = record_outcomes(actual)
    assert [o for _, _, o, _ in outcomes].count(2) >= 2
    made = record_steps(actual, 3)
    moved = [p for _, _, _, p in outcomes]
    assert [sum(p[a] for p in moved) for a in range(3)] == \
        [sum(s[a] for s in made) for a in range(3)]
