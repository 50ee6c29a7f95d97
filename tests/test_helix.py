# amaranth: UnusedElaboratable=no
"""Helical arcs: the step model against the ideal helix, the RTL against the cycle model and
the plain arc engine."""

import math
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kontur import registry
from kontur.hdl.helix import HelixEngine
from kontur.sim.models.arc import arc_steps, points_ahead
from kontur.sim.models.errors import InputError
from kontur.sim.models.helix import HelixEngineModel, helix_frame, helix_steps, ride
from kontur.sim.runners import run_amaranth
from kontur.sim.stimulus import Job, first_difference, record_outcomes, record_steps, run_model

WIDTH = 8

#: Steps per radian along a circle of radius R lie between R/√2 and R (a step moves the
#: dominant axis by one), so the share of an arc's steps made by an angle differs from the
#: share of its angle by at most (√r - 1)/(√r + 1), r = √2 (the density's extreme ratio,
#: concentrated at the start).
DENSITY = (2 ** 0.25 - 1) / (2 ** 0.25 + 1)


def random_arc(rng, top=60):
    r = rng.randint(1, top)
    x0 = rng.randint(-r, r)
    y0 = rng.choice([-1, 1]) * math.isqrt(r * r - x0 * x0)
    cw = rng.randint(0, 1)
    x1, y1 = points_ahead(x0, y0, rng.randint(1, 8 * r), cw=cw, width=WIDTH)[-1]
    return x0, y0, x1, y1, cw


def check_helix(x0, y0, x1, y1, cw, z):
    """The helix to ``z`` judged by the plain arc and the ideal helix through its end points:
    its XY steps are the plain arc's; Z moves at most one step per XY step, toward ``z``,
    within half a step of ``k·z/n`` after the ``k``-th and exactly ``z`` at the end; and it
    stays within ``1/2 + |z|·(DENSITY + 1/n)`` of the helix whose Z is proportional to the
    angle turned."""
    plain = arc_steps(x0, y0, x1, y1, cw=bool(cw), width=WIDTH)
    n = len(plain)
    path = helix_steps(x0, y0, x1, y1, cw, z, width=WIDTH)
    assert [step[:2] for step in path] == plain
    sign = -1 if cw else 1
    start = math.atan2(y0, x0)

    def turned(x, y):
        return ((math.atan2(y, x) - start) * sign) % (2 * math.pi)

    total = 2 * math.pi if (x0, y0) == (x1, y1) else turned(x1, y1)
    x, y, height, before = x0, y0, 0, 0.0
    for k, (dx, dy, dz) in enumerate(path, 1):
        assert dz in ((0, 1) if z > 0 else (0, -1) if z < 0 else (0,))
        x, y, height = x + dx, y + dy, height + dz
        assert abs(2 * (n * height - k * z)) <= n, (k, height)
        angle = 2 * math.pi if k == n and total == 2 * math.pi else turned(x, y)
        if angle < before - 1:                       # past the start again (a full circle)
            angle += 2 * math.pi
        before = angle
        assert abs(height - z * angle / total) <= 0.5 + abs(z) * (DENSITY + 1 / n) + 1e-9
    assert (x, y, height) == (x1, y1, z)


def test_random_helices():
    rng = random.Random(28)
    for _ in range(400):
        x0, y0, x1, y1, cw = random_arc(rng)
        n = len(arc_steps(x0, y0, x1, y1, cw=bool(cw), width=WIDTH))
        check_helix(x0, y0, x1, y1, cw, rng.randint(-n, n))


@settings(max_examples=60, deadline=None)
@given(st.randoms(use_true_random=False), st.floats(-1, 1))
def test_helices(rng, slope):
    x0, y0, x1, y1, cw = random_arc(rng, top=120)
    n = len(arc_steps(x0, y0, x1, y1, cw=bool(cw), width=WIDTH))
    check_helix(x0, y0, x1, y1, cw, round(slope * n))


def test_full_turn_and_steepest():
    # A full circle of radius 5 climbing one step per XY step, and one Z step over it.
    n = len(arc_steps(5, 0, 5, 0, width=WIDTH))
    assert [s[2] for s in helix_steps(5, 0, 5, 0, 0, n, width=WIDTH)] == [1] * n
    check_helix(5, 0, 5, 0, 0, -1)
    assert sum(s[2] for s in helix_steps(5, 0, 5, 0, 1, -1, width=WIDTH)) == -1


def test_refused():
    with pytest.raises(InputError, match="at most one step per XY step"):
        helix_steps(6, 0, 0, 6, 0, 9, width=WIDTH)       # a quarter of radius 6: 8 steps
    assert helix_frame(6, 0, 0, 6, 3, width=WIDTH)["n"] == 8


def _engine(variant="fast"):
    return HelixEngine(registry.make_engine("arc", variant, width=WIDTH))


def _model(variant="fast"):
    return HelixEngineModel(registry.make_model("arc", variant, width=WIDTH))


def _arc(frame):
    return {k: frame[k] for k in ("x0", "y0", "x1", "y1", "cw")}


def _frames(rng, count, variant="fast"):
    """Random helices, ``n`` from the XY steps of the variant's arc core."""
    frames = []
    for _ in range(count):
        x0, y0, x1, y1, cw = random_arc(rng, top=12)
        frame = {"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw}
        frame["n"] = len(registry.steps("arc", frame, variant, width=WIDTH))
        frame["z"] = rng.randint(-frame["n"], frame["n"])
        frames.append(frame)
    return frames


def _helix(frame, variant):
    return ride(registry.steps("arc", _arc(frame), variant, width=WIDTH), frame["z"], frame["n"],
                width=WIDTH)


#: Any arc engine: the wrapper follows its steps, whatever its core's timing.
ARC_VARIANTS = pytest.mark.parametrize("variant", registry.variants("arc"))


@ARC_VARIANTS
def test_rtl_equals_model_and_plain_arc(variant):
    rng = random.Random(5)
    circle = {"x0": 3, "y0": 4, "x1": 3, "y1": 4, "cw": 0}
    n = len(registry.steps("arc", circle, variant, width=WIDTH))
    frames = _frames(rng, 10, variant) + [
        {"x0": 4, "y0": -4, "x1": -4, "y1": -4, "cw": 1, "z": 9, "n": 8},     # too steep
        {"x0": 0, "y0": 0, "x1": 0, "y1": 0, "cw": 0, "z": 0, "n": 0},        # arc refused
        {**circle, "z": 1 - n, "n": n}]
    job = Job(frames=frames, tick=[int(rng.random() < 0.7) for _ in range(29)],
              status_ready=[int(rng.random() < 0.8) for _ in range(17)],
              gaps=[rng.choice([0, 0, 3]) for _ in frames])
    expected = run_model(_model(variant), job)
    actual = run_amaranth(_engine(variant), job)
    assert first_difference(expected, actual) is None
    outcomes = record_outcomes(actual)
    assert [outcome for _, _, outcome, _ in outcomes] == [0] * 10 + [1, 1, 0]
    made = record_steps(actual, 3)
    want = [s for f in frames[:10] + frames[12:] for s in _helix(f, variant)]
    assert made == want
    for (_, _, _, position), frame in zip(outcomes, frames):
        if position != [0, 0, 0]:
            assert position == [frame["x1"] - frame["x0"], frame["y1"] - frame["y0"],
                                frame["z"]]
    for entry in actual:
        if not entry["rst"] and entry["step"]:
            assert entry["diagonal"] == bin(entry["step"]).count("1") - 1
    # The arc engine alone, given the same arcs, makes the same XY steps.
    arcs = [_arc(f) for f in frames]
    plain = run_amaranth(registry.make_engine("arc", variant, width=WIDTH),
                         Job(frames=arcs[:10] + arcs[12:]))
    assert record_steps(plain) == [s[:2] for s in made]


@ARC_VARIANTS
def test_rtl_aborts(variant):
    rng = random.Random(11)
    frames = _frames(rng, 8, variant)
    job = Job(frames=frames, aborts={30: 1, 31: 1, 80: 2, 160: 1})
    expected = run_model(_model(variant), job)
    actual = run_amaranth(_engine(variant), job)
    assert first_difference(expected, actual) is None
    outcomes = record_outcomes(actual)
    assert [o for _, _, o, _ in outcomes].count(2) >= 2
    made = record_steps(actual, 3)
    moved = [p for _, _, _, p in outcomes]
    assert [sum(p[a] for p in moved) for a in range(3)] == \
        [sum(s[a] for s in made) for a in range(3)]


#: A native step ``(a, b, c)`` (the arc's first and second coordinate, its linear axis) as
#: ``(dx, dy, dz)`` in each plane, written out from LinuxCNC's canonical arcs (G18: first Z,
#: second X, normal Y; G19: first Y, second Z, normal X), not from the model's rotation.
PLANE_AXES = {0: lambda a, b, c: (a, b, c), 1: lambda a, b, c: (b, c, a),
              2: lambda a, b, c: (c, a, b)}


def test_rtl_planes():
    """Helices in G17, G18 and G19 (the frame's ``plane`` 0, 1, 2) back to back: the RTL is
    the model clock for clock, each helix's steps are the G17 helix's with its axes renamed as
    LinuxCNC names them, its outcome's position is its end on the machine's axes; plane 3 is
    refused with no step."""
    rng = random.Random(17)
    frames = [{**f, "plane": rng.randint(0, 2)} for f in _frames(rng, 9)]
    frames.insert(4, {**frames[0], "plane": 3})
    job = Job(frames=frames, tick=[int(rng.random() < 0.7) for _ in range(23)],
              gaps=[rng.choice([0, 0, 2]) for _ in frames])
    expected = run_model(_model(), job)
    actual = run_amaranth(_engine(), job)
    assert first_difference(expected, actual) is None
    assert {f["plane"] for f in frames} == {0, 1, 2, 3}
    outcomes = record_outcomes(actual)
    assert [outcome for _, _, outcome, _ in outcomes] == [0] * 4 + [1] + [0] * 5
    made = record_steps(actual, 3)
    taken = [f for f in frames if f["plane"] != 3]
    assert made == [PLANE_AXES[f["plane"]](*s) for f in taken for s in _helix(f, "fast")]
    for (_, _, _, position), frame in zip(outcomes, frames):
        if frame["plane"] != 3:
            native = (frame["x1"] - frame["x0"], frame["y1"] - frame["y0"], frame["z"])
            assert tuple(position) == PLANE_AXES[frame["plane"]](*native)
