# amaranth: UnusedElaboratable=no
"""The arc engine's Verilog on Icarus and Verilator, every variant: cocotb testbenches.

As in ``test_line_cocotb.py``: each ``@cocotb.test`` plays a :class:`~kontur.sim.stimulus.Job` with a
:class:`~kontur.sim.testbench.Scoreboard` holding the golden cycle model, which checks every output in
every clock; the pytest function at the bottom builds the engine once per simulator, variant
and width and runs this module's tests on it.
"""

import os
import random

import cocotb
import pytest

from kontur import registry
from kontur.sim.models.arc import points_ahead, round_sqrt
from kontur.sim.runners import CocotbBuild
from kontur.sim.stimulus import Driver, Job, record_outcomes, record_steps
from kontur.sim.testbench import EngineBench, Scoreboard, random_gaps, random_pattern

from .conftest import cocotb_build_root, register_extra_variants, selected_simulators

KIND = "arc"
register_extra_variants()                 # in the simulator's process too


def _parameters():
    return os.environ["KONTUR_VARIANT"], int(os.environ["KONTUR_WIDTH"])


def _model():
    variant, width = _parameters()
    return registry.make_model(KIND, variant, width=width)


async def play(dut, job):
    """Play ``job`` (after a reset) with the model as scoreboard; return the record."""
    job.resets = {0: 1, **{k + 1: v for k, v in job.resets.items()}}
    job.aborts = {k + 1: v for k, v in job.aborts.items()}
    return await EngineBench.from_env(dut).play(job, scoreboard=Scoreboard(_model()))


def expected_steps(frames):
    variant, width = _parameters()
    moves = []
    for frame in frames:
        try:
            moves += registry.steps(KIND, frame, variant, width=width)
        except registry.InputError:
            pass
    return moves


def clocks_per_step():
    """Clocks a step of the variant's core takes at full feed (about; 1 for most)."""
    variant, width = _parameters()
    item = registry.variant(KIND, variant)
    if item.clocks is None:
        return 1
    circle = {"x0": 1000, "y0": 0, "x1": 1000, "y1": 0, "cw": 0}
    return max(1, round(item.clocks(circle, width) / 8000))


def large_arc(rng, width, cw, reach=700):
    """A lattice start of random radius up to the register width, near an axis, and an end
    point up to ``reach`` points along the path (a few hundred: the arc usually crosses into
    the next quadrant)."""
    top = (1 << width) - 1
    while True:
        large = rng.randint(1, top)
        small = rng.randint(0, min(large, 6 * reach // 7))
        x0, y0 = rng.choice([(small, large), (large, small), (-small, large), (-large, small),
                             (-small, -large), (-large, -small), (small, -large),
                             (large, -small)])
        if round_sqrt(x0 * x0 + y0 * y0) <= top:
            break
    x1, y1 = points_ahead(x0, y0, rng.randint(1, reach), cw=cw, width=width)[-1]
    return {"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw}


def correction_clock(job):
    """A clock inside a sector switch-over of ``job``: the faithful interpolator's extender
    is running (corrections pending), or the fast one makes its switch-over step; for a core
    with no switch-over, the clock its second run starts (one arc ends, the next begins)."""
    model = _model()
    driver = Driver(job)
    starts = 0
    for cycle in range(job.max_cycles):
        inputs = driver.inputs(cycle)
        interpolator = getattr(model.core, "interpolator", None)
        if interpolator is None:
            starts += model.core.evaluate(tick=inputs["tick"])["start"]
            if starts == 2:
                return cycle
        elif hasattr(interpolator, "extender25"):
            if interpolator.extender25 > 1:
                return cycle
        elif (interpolator.trigger4 and not interpolator.trigger16
              and interpolator.counter8 <= 1 and model.core.peek(tick=inputs["tick"])):
            return cycle
        outputs, _ = model.cycle(valid=inputs["valid"], payload=inputs["payload"],
                                 tick=inputs["tick"])
        driver.observe(cycle, inputs, outputs)
    raise AssertionError("the job has no switch-over")


@cocotb.test()
async def circles(dut):
    """Full circles of small radii, both directions, integer and not."""
    frames = [{"x0": x, "y0": y, "x1": x, "y1": y, "cw": cw}
              for r, cw in ((1, 0), (2, 1), (4, 0), (10, 1), (12, 0), (23, 1))
              for x, y in ((r, 0), (0, -r))]
    frames += [{"x0": 2, "y0": 3, "x1": 2, "y1": 3, "cw": 0},      # radius sqrt(13)
               {"x0": -7, "y0": 1, "x1": 1, "y1": 7, "cw": 1}]     # sqrt(50), 3/4 circle
    record = await play(dut, Job(frames=frames))
    assert record_steps(record) == expected_steps(frames)


@cocotb.test()
@cocotb.parametrize(stalls=[False, True])
async def large_radii(dut, stalls):
    """Random arcs of radii across the register width, crossing quadrants; with stalls on the
    command and status streams and gaps in the feed."""
    _, width = _parameters()
    rng = random.Random(width + stalls)
    reach = 700 // clocks_per_step()           # shorter arcs for the bit-serial node
    frames = [large_arc(rng, width, rng.randrange(2), reach) for _ in range(16)]
    job = Job(frames=frames, gaps=[rng.choice([0, 0, 10, 200]) for _ in frames])
    if stalls:
        job = Job(frames=frames, gaps=random_gaps(rng, len(frames), (0, 0, 50)),
                  tick=random_pattern(rng), status_ready=random_pattern(rng, ones=0.5))
    record = await play(dut, job)
    assert record_steps(record) == expected_steps(frames)


@cocotb.test()
async def refusals(dut):
    """Arcs the engine must refuse, between arcs it must trace."""
    _, width = _parameters()
    top = (1 << width) - 1
    frames = [
        {"x0": top, "y0": 0, "x1": 0, "y1": top - 1, "cw": 0},        # end off the circle
        {"x0": 0, "y0": 0, "x1": 0, "y1": 0, "cw": 1},                # R = 0
        {"x0": top + 1, "y0": 0, "x1": top + 1, "y1": 0, "cw": 0},    # coordinate too wide
        {"x0": top, "y0": top, "x1": top, "y1": top, "cw": 0},        # radius too wide
        {"x0": 5, "y0": 0, "x1": -4, "y1": -3, "cw": 1},              # fine: 3/4 clockwise
        {"x0": top, "y0": 0, "x1": top, "y1": 2, "cw": 0},            # fine: 2 steps
    ]
    record = await play(dut, Job(frames=frames))
    assert sum(e.get("error", 0) for e in record) == 4
    assert sum(e.get("done", 0) for e in record) == 2


@cocotb.test()
async def reset_in_correction(dut):
    """Back-to-back arcs with a reset in the middle of a switch-over correction."""
    frames = [{"x0": r, "y0": 0, "x1": 0, "y1": r, "cw": 0} for r in (12, 10, 4, 30, 7)]
    clock = correction_clock(Job(frames=frames))
    record = await play(dut, Job(frames=frames, resets={clock: 2}))
    assert any(e["rst"] for e in record[2:])


@cocotb.test()
async def aborts(dut):
    """Aborts while arcs run, while one is planned, and in a switch-over."""
    frames = [{"x0": r, "y0": 0, "x1": r, "y1": 0, "cw": r % 2} for r in (12, 10, 4, 30, 7)]
    clock = correction_clock(Job(frames=frames))
    record = await play(dut, Job(frames=frames, aborts={40: 1, clock + 40: 2, 600: 1}))
    outcomes = [outcome for _, _, outcome, _ in record_outcomes(record)]
    assert outcomes.count(2) >= 2                     # aborted


#: Every variant at the widths it declares (:attr:`kontur.registry.Variant.widths`; the
#: kind's default width where it declares none): the patents' cores at 24 and 32 bits, the
#: textbook's at 24 (their other widths run on Amaranth's simulator). One build per
#: simulator and case.
CASES = [(variant, width) for variant in registry.variants(KIND)
         for width in (registry.variant(KIND, variant).widths
                       or (registry.KINDS[KIND].default_width,))]


@pytest.mark.cocotb
@pytest.mark.parametrize("variant, width", CASES)
@pytest.mark.parametrize("simulator", selected_simulators())
def test_arc_engine(simulator, variant, width):
    build = CocotbBuild(registry.make_engine(KIND, variant, width=width), simulator,
                        cocotb_build_root())
    build.test(__name__, env={"KONTUR_VARIANT": variant, "KONTUR_WIDTH": str(width)})
