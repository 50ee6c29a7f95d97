"""The SU 1571551 engine's Verilog on Icarus and Verilator against the golden cycle model.

One build per simulator, variant and width, reused for every job below. Each job is run on the
cycle model and on the simulator through the same driver, and the two records must agree on
every output in every clock.
"""

import random

import pytest

from hdl.linear import LineEngine
from sim.models.linear import LineEngineModel
from sim.runners import CocotbBuild
from sim.stimulus import Job, first_difference, plan_resets, record_steps, run_model

from .conftest import cocotb_build_dir, selected_simulators


def random_magnitude(rng, width):
    """Magnitudes spread over every bit length up to ``width`` (0, 1 and the maximum included)."""
    bits = rng.randint(0, width)
    return rng.randrange(1 << bits) if bits else 0


def linear_jobs(width, seed):
    rng = random.Random(seed)
    top = (1 << width) - 1
    jobs = {}

    # Extremes: zero, one, the maximum in every direction, the first too wide values.
    extremes = [(0, 0), (1, 0), (0, 1), (-1, -1), (1, -1), (top, top), (-top, 1), (1, -top),
                (-top, -top), (top + 1, 0), (0, -(top + 1)), (2, 3)]
    jobs["extremes"] = Job(frames=[{"x": x, "y": y} for x, y in extremes])

    # Random end points across the whole register width, back to back and with gaps.
    frames = []
    for _ in range(60):
        x, y = random_magnitude(rng, width), random_magnitude(rng, width)
        frames.append({"x": rng.choice([-1, 1]) * x, "y": rng.choice([-1, 1]) * y})
    gaps = [rng.choice([0, 0, 0, 1, 3]) for _ in frames]
    jobs["random"] = Job(frames=frames, gaps=gaps)

    # Short frames back to back with resets in the middle of frames.
    frames = [{"x": rng.randint(-30, 30), "y": rng.randint(-30, 30)} for _ in range(40)]
    jobs["resets"] = Job(frames=frames, resets={37: 1, 120: 2, 121: 0, 333: 1})
    jobs["resets"].resets = {k: v for k, v in jobs["resets"].resets.items() if v}

    # Long segments run for up to `limit` clocks, then are cut by a reset. At 16 bits the
    # extremes run to the end (65535 steps each); at 32 bits nothing that long can be simulated.
    limits = {"extremes": 70_000 if width <= 16 else 3000, "random": 3000, "resets": 3000}
    return {name: plan_resets(LineEngineModel(width=width), job, limits[name])
            for name, job in jobs.items()}


@pytest.mark.cocotb
@pytest.mark.parametrize("width", [16, 32])
@pytest.mark.parametrize("variant", ["device", "exact"])
@pytest.mark.parametrize("simulator", selected_simulators())
def test_line_engine(simulator, variant, width):
    engine = LineEngine(variant=variant, width=width)
    build = CocotbBuild(engine, simulator,
                        cocotb_build_dir(simulator, f"line_{variant}_w{width}"))
    for name, job in linear_jobs(width, seed=width).items():
        expected = run_model(LineEngineModel(variant=variant, width=width), job)
        actual = build.run(job, name=name)
        assert first_difference(expected, actual) is None, name
        assert record_steps(actual) == record_steps(expected)
        assert any(e.get("step") for e in actual), name
