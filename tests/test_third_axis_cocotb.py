# amaranth: UnusedElaboratable=no
"""The third axis's engines on Icarus and Verilator: lines in XYZ and helical arcs.

As ``test_line_cocotb.py``: each ``@cocotb.test`` plays a :class:`~kontur.sim.stimulus.Job` with a
:class:`~kontur.sim.testbench.Scoreboard` holding the golden cycle model, which checks every
output in every clock. ``KONTUR_DESIGN`` says which engine was built: ``line3``
(:class:`~kontur.hdl.line.LineEngine` around :class:`~kontur.hdl.spatial.SpatialLineCore`) or
``helix`` (:class:`~kontur.hdl.helix.HelixEngine` around the fast arc engine). Tiny cases: each
design runs in seconds.
"""

import math
import os
import random

import cocotb
import pytest

from kontur import registry
from kontur.hdl.helix import HelixEngine
from kontur.hdl.line import LineEngine
from kontur.hdl.spatial import SpatialLineCore
from kontur.sim.models.arc import points_ahead
from kontur.sim.models.errors import InputError
from kontur.sim.models.helix import HelixEngineModel, helix_frame, helix_steps
from kontur.sim.models.line import LineEngineModel
from kontur.sim.models.spatial import SpatialLineCoreModel, spatial_steps
from kontur.sim.runners import CocotbBuild
from kontur.sim.stimulus import Job, record_outcomes, record_steps
from kontur.sim.testbench import EngineBench, Scoreboard, random_gaps, random_pattern

from .conftest import cocotb_build_root, selected_simulators

#: ``design: (width, engine, model)``.
DESIGNS = {
    "line3": (8, lambda w: LineEngine(SpatialLineCore(width=w)),
              lambda w: LineEngineModel(SpatialLineCoreModel(width=w))),
    "helix": (6, lambda w: HelixEngine(registry.make_engine("arc", "fast", width=w)),
              lambda w: HelixEngineModel(registry.make_model("arc", "fast", width=w))),
}


def _design():
    name = os.environ["KONTUR_DESIGN"]
    return name, DESIGNS[name][0]


def _steps(frame):
    name, width = _design()
    try:
        if name == "line3":
            return spatial_steps(frame["x"], frame["y"], frame["z"], width=width)
        return helix_steps(**frame, width=width)
    except InputError:
        return []


def _frames(rng, count):
    name, width = _design()
    if name == "line3":
        top = (1 << width) - 1
        ends = [(0, 0, 0), (1, 0, 0), (0, 0, -1), (top, 1, 1), (-top, top, -top),
                (top + 1, 0, 0), (0, 0, -(top + 1)), (3, -5, 7)]
        frames = [dict(zip("xyz", end)) for end in ends]
        return frames + [{axis: rng.randint(-40, 40) for axis in "xyz"} for _ in range(count)]
    frames = [{"x0": 4, "y0": -4, "x1": -4, "y1": -4, "cw": 1, "z": 9, "n": 8, "plane": 1},
              {"x0": 0, "y0": 0, "x1": 0, "y1": 0, "cw": 0, "z": 0, "n": 0, "plane": 2}]
    for _ in range(count):
        r = rng.randint(1, 12)
        x0 = rng.randint(-r, r)
        y0 = rng.choice([-1, 1]) * math.isqrt(r * r - x0 * x0)
        cw = rng.randint(0, 1)
        x1, y1 = points_ahead(x0, y0, rng.randint(1, 8 * r), cw=cw, width=width)[-1]
        frame = helix_frame(x0, y0, x1, y1, 0, cw=cw, width=width, plane=rng.randint(0, 2))
        frame["z"] = rng.randint(-frame["n"], frame["n"])
        frames.append(frame)
    return frames


async def play(dut, job):
    name, width = _design()
    job.resets = {0: 1, **{k + 1: v for k, v in job.resets.items()}}
    job.aborts = {k + 1: v for k, v in job.aborts.items()}
    scoreboard = Scoreboard(DESIGNS[name][2](width))
    return await EngineBench.from_env(dut).play(job, scoreboard=scoreboard)


@cocotb.test()
@cocotb.parametrize(stalls=[False, True])
async def random_moves(dut, stalls):
    """Extremes and random moves, back to back or with stalls on every stream."""
    rng = random.Random(3 + stalls)
    frames = _frames(rng, 12)
    job = Job(frames=frames)
    if stalls:
        job = Job(frames=frames, gaps=random_gaps(rng, len(frames)),
                  tick=random_pattern(rng), status_ready=random_pattern(rng, ones=0.5))
    record = await play(dut, job)
    assert record_steps(record, 3) == [s for f in frames for s in _steps(f)]
    refused = [o for _, _, o, _ in record_outcomes(record)].count(1)
    assert refused == 2


@cocotb.test()
async def aborts(dut):
    """Aborts in the middle of moves: every clock still the model's."""
    rng = random.Random(9)
    record = await play(dut, Job(frames=_frames(rng, 8), aborts={30: 1, 75: 2, 150: 1}))
    assert [o for _, _, o, _ in record_outcomes(record)].count(2) >= 2


@pytest.mark.cocotb
@pytest.mark.parametrize("design", list(DESIGNS))
@pytest.mark.parametrize("simulator", selected_simulators())
def test_third_axis_engine(simulator, design):
    width, engine, _ = DESIGNS[design]
    build = CocotbBuild(engine(width), simulator, cocotb_build_root())
    build.test(__name__, env={"KONTUR_DESIGN": design})
