"""The arc engine's Verilog on Icarus and Verilator against the golden cycle model.

One build per simulator, variant and width, reused for every job. Each job runs on the cycle
model and on the simulator through the same driver; the records must agree in every clock.
"""

import random

import pytest

from hdl.arc import ArcEngine
from sim.models.arc import ArcEngineModel, points_ahead, round_sqrt
from sim.runners import CocotbBuild
from sim.stimulus import Driver, Job, first_difference, record_steps, run_model

from .conftest import cocotb_build_dir, selected_simulators


def large_arc(rng, width, cw):
    """A lattice start of random radius up to the register width, near an axis, and an end
    point a few hundred steps along the path (so the arc usually crosses into the next
    quadrant)."""
    top = (1 << width) - 1
    while True:
        large = rng.randint(1, top)
        small = rng.randint(0, min(large, 600))
        x0, y0 = rng.choice([(small, large), (large, small), (-small, large), (-large, small),
                             (-small, -large), (-large, -small), (small, -large),
                             (large, -small)])
        if round_sqrt(x0 * x0 + y0 * y0) <= top:
            break
    x1, y1 = points_ahead(x0, y0, rng.randint(1, 700), cw=cw, width=width)[-1]
    return {"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw}


def correction_clock(variant, width, job):
    """A clock inside a sector switch-over of ``job``: the faithful core's extender is running
    (corrections pending), or the fast core is making its switch-over step."""
    model = ArcEngineModel(variant=variant, width=width)
    driver = Driver(job)
    for cycle in range(job.max_cycles):
        inputs = driver.inputs(cycle)
        core = model.core
        if variant == "faithful" and core.extender25 > 1:
            return cycle
        if variant == "fast" and core.trigger4 and not core.trigger16 and core.counter8 <= 1:
            step, _ = core.peek(inputs["tick"])
            if step:
                return cycle
        outputs, _ = model.cycle(valid=inputs["valid"], payload=inputs["payload"],
                                 tick=inputs["tick"])
        driver.observe(cycle, inputs, outputs)
    raise AssertionError("the job has no switch-over")


def arc_jobs(variant, width, seed):
    rng = random.Random(seed)
    top = (1 << width) - 1
    jobs = {}

    circles = [{"x0": x, "y0": y, "x1": x, "y1": y, "cw": cw}
               for r, cw in ((1, 0), (2, 1), (4, 0), (10, 1), (12, 0), (23, 1))
               for x, y in ((r, 0), (0, -r))]
    circles += [{"x0": 2, "y0": 3, "x1": 2, "y1": 3, "cw": 0},      # radius sqrt(13)
                {"x0": -7, "y0": 1, "x1": 1, "y1": 7, "cw": 1}]     # sqrt(50), 3/4 circle
    jobs["circles"] = Job(frames=circles)

    frames = [large_arc(rng, width, rng.randrange(2)) for _ in range(24)]
    gaps = [rng.choice([0, 0, 10, 200]) for _ in frames]
    jobs["random"] = Job(frames=frames, gaps=gaps)

    refused = [
        {"x0": top, "y0": 0, "x1": 0, "y1": top - 1, "cw": 0},        # end off the circle
        {"x0": 0, "y0": 0, "x1": 0, "y1": 0, "cw": 1},                # R = 0
        {"x0": top + 1, "y0": 0, "x1": top + 1, "y1": 0, "cw": 0},    # coordinate too wide
        {"x0": top, "y0": top, "x1": top, "y1": top, "cw": 0},        # radius too wide
        {"x0": 5, "y0": 0, "x1": -4, "y1": -3, "cw": 1},              # fine: 3/4 clockwise
        {"x0": top, "y0": 0, "x1": top, "y1": 2, "cw": 0},            # fine: 2 steps
    ]
    jobs["refused"] = Job(frames=refused)

    # Back-to-back arcs with a reset in the middle of a switch-over correction.
    frames = [{"x0": r, "y0": 0, "x1": 0, "y1": r, "cw": 0} for r in (12, 10, 4, 30, 7)]
    probe = Job(frames=frames)
    jobs["reset in correction"] = Job(frames=frames,
                                      resets={correction_clock(variant, width, probe): 2})
    return jobs


@pytest.mark.cocotb
@pytest.mark.parametrize("width", [24, 32])
@pytest.mark.parametrize("variant", ["faithful", "fast"])
@pytest.mark.parametrize("simulator", selected_simulators())
def test_arc_engine(simulator, variant, width):
    engine = ArcEngine(variant=variant, width=width)
    build = CocotbBuild(engine, simulator, cocotb_build_dir(simulator, f"arc_{variant}_w{width}"))
    for name, job in arc_jobs(variant, width, seed=width).items():
        expected = run_model(ArcEngineModel(variant=variant, width=width), job)
        actual = build.run(job, name=name.replace(" ", "_"))
        assert first_difference(expected, actual) is None, name
        assert record_steps(actual) == record_steps(expected)
        if name == "refused":
            assert sum(e.get("error", 0) for e in actual) == 4
            assert sum(e.get("done", 0) for e in actual) == 2
        if name == "reset in correction":
            assert any(e["rst"] for e in actual)
