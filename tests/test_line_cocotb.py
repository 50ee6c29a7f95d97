# amaranth: UnusedElaboratable=no
"""The line engine's Verilog on Icarus and Verilator, every variant: cocotb testbenches.

Each ``@cocotb.test`` drives the engine's command stream (with random stalls), its feed and its
status stream from a :class:`~kontur.sim.stimulus.Job`, and a :class:`~kontur.sim.testbench.Scoreboard`
checks every output in every clock against the golden cycle model as the simulation runs. The
pytest function at the bottom builds the engine once per simulator, variant and width and runs
this module's tests on it through cocotb's Python runner.
"""

import math
import os
import random

import cocotb
import pytest

from kontur import registry
from kontur.sim.runners import CocotbBuild
from kontur.sim.stimulus import Job, plan_resets, record_outcomes, record_steps
from kontur.sim.testbench import EngineBench, Scoreboard, random_gaps, random_pattern

from .conftest import cocotb_build_root, register_extra_variants, selected_simulators

KIND = "line"
register_extra_variants()                 # in the simulator's process too


def _parameters():
    return os.environ["KONTUR_VARIANT"], int(os.environ["KONTUR_WIDTH"])


def random_magnitude(rng, width):
    """Magnitudes spread over every bit length up to ``width`` (0, 1 and the maximum included)."""
    bits = rng.randint(0, width)
    return rng.randrange(1 << bits) if bits else 0


def core_clocks(frame, variant, width):
    """An upper bound on the clocks a variant's core takes for ``frame`` at full feed."""
    item = registry.variant(KIND, variant)
    if item.clocks is not None:
        return item.clocks(frame, width)
    return max(abs(frame["x"]), abs(frame["y"])) + 2


def segment_bits(variant, width):
    """Bit lengths of the random segments: up to 12, fewer for a core that takes many clocks a
    step (the bit-serial node), so that its runs take about as many clocks as the others'."""
    per_step = core_clocks({"x": 1024, "y": 0}, variant, width) / 1024
    return min(width, 12) - (math.ceil(math.log2(per_step)) if per_step > 4 else 0)


def random_frames(rng, width, count):
    return [{"x": rng.choice([-1, 1]) * random_magnitude(rng, width),
             "y": rng.choice([-1, 1]) * random_magnitude(rng, width)} for _ in range(count)]


async def play(dut, job, *, limit=None):
    """Play ``job`` (after a reset) against the model; cut frames running ``limit`` clocks."""
    variant, width = _parameters()
    job.resets = {0: 1, **{k + 1: v for k, v in job.resets.items()}}
    if limit is not None:
        job = plan_resets(registry.make_model(KIND, variant, width=width), job, limit)
    scoreboard = Scoreboard(registry.make_model(KIND, variant, width=width))
    record = await EngineBench.from_env(dut).play(job, scoreboard=scoreboard)
    return job, record


def expected_steps(frames, variant, width):
    moves = []
    for frame in frames:
        try:
            moves += registry.steps(KIND, frame, variant, width=width)
        except registry.InputError:
            pass
    return moves


@cocotb.test()
async def extremes(dut):
    """Zero, one, the maximum in every direction, the first values too wide."""
    variant, width = _parameters()
    top = (1 << width) - 1
    # The first values too wide come before the long frames: a reset that cuts a frame also
    # drops the one waiting behind it in the engine's stage.
    # The maximum on both axes (top, top), and on each axis with the other at 1, in other
    # quadrants; the third quadrant's diagonal shorter (the run's length is its cost).
    ends = [(0, 0), (1, 0), (top + 1, 0), (0, -(top + 1)), (0, 1), (-1, -1), (1, -1),
            (top, top), (-top, 1), (1, -top), (-(top >> 3), -(top >> 3)), (2, 3)]
    frames = [{"x": x, "y": y} for x, y in ends]
    # At 16 bits every frame runs to its end (65535 steps) if the core takes no more than
    # 70 000 clocks for it, on Verilator; at 32, for a slower core (separate steps, 131070;
    # the serial node, 18 clocks a step), or on Icarus (the same Verilog, a third slower a
    # clock: these 200 000 clocks were 23.7 s of the exact core's 36 s there), frames are cut
    # by a reset after 3000 clocks.
    longest = max(core_clocks(f, variant, width) for f in frames
                  if max(abs(f["x"]), abs(f["y"])) <= top)
    complete = width <= 16 and longest <= 70_000 and cocotb.SIM_NAME.lower() == "verilator"
    job, record = await play(dut, Job(frames=frames), limit=70_000 if complete else 3000)
    if complete:
        assert record_steps(record) == expected_steps(frames, variant, width)
    assert sum(e.get("error", 0) for e in record) == 2


@cocotb.test()
@cocotb.parametrize(stalls=[False, True])
async def random_segments(dut, stalls):
    """Random end points across the register width, back to back or with random stalls on
    the command and status streams and gaps in the feed."""
    variant, width = _parameters()
    rng = random.Random(width * 7 + stalls)
    frames = random_frames(rng, segment_bits(variant, width), 60)
    job = Job(frames=frames)
    if stalls:
        job = Job(frames=frames, gaps=random_gaps(rng, len(frames)),
                  tick=random_pattern(rng), status_ready=random_pattern(rng, ones=0.5))
    _, record = await play(dut, job)
    assert record_steps(record) == expected_steps(frames, variant, width)


@cocotb.test()
async def resets_and_aborts(dut):
    """Short frames with resets and aborts in the middle of frames."""
    rng = random.Random(5)
    frames = [{"x": rng.randint(-30, 30), "y": rng.randint(-30, 30)} for _ in range(40)]
    job = Job(frames=frames, resets={37: 1, 120: 2, 333: 1}, aborts={70: 1, 200: 3, 201: 1})
    _, record = await play(dut, job)
    outcomes = [outcome for _, _, outcome, _ in record_outcomes(record)]
    assert outcomes.count(2) >= 2                     # aborted


@cocotb.test()
async def long_segments_cut(dut):
    """Random frames across the whole width, cut by a reset after 3000 clocks."""
    variant, width = _parameters()
    rng = random.Random(width)
    await play(dut, Job(frames=random_frames(rng, width, 20)), limit=3000)


#: Every variant at the widths it declares (:attr:`kontur.registry.Variant.widths`; the
#: kind's default width where it declares none): the patents' cores at 16 and 32 bits, the
#: textbook's at 16 (their other widths run on Amaranth's simulator). One build per
#: simulator and case.
CASES = [(variant, width) for variant in registry.variants(KIND)
         for width in (registry.variant(KIND, variant).widths
                       or (registry.KINDS[KIND].default_width,))]


@pytest.mark.cocotb
@pytest.mark.parametrize("variant, width", CASES)
@pytest.mark.parametrize("simulator", selected_simulators())
def test_line_engine(simulator, variant, width):
    build = CocotbBuild(registry.make_engine(KIND, variant, width=width), simulator,
                        cocotb_build_root())
    build.test(__name__, env={"KONTUR_VARIANT": variant, "KONTUR_WIDTH": str(width)})
