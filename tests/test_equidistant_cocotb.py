# amaranth: UnusedElaboratable=no
"""The equidistant engine's Verilog on Icarus and Verilator, both arc cores: cocotb testbenches.

As in ``test_arc_cocotb.py``: each ``@cocotb.test`` plays a :class:`~kontur.sim.stimulus.Job` with a
:class:`~kontur.sim.testbench.Scoreboard` holding the golden cycle model, which checks every output in
every clock; the pytest function at the bottom builds the engine once per simulator and
variant and runs this module's tests on it.
"""

import os
import random
from pathlib import Path

import cocotb
import pytest

from kontur import registry
from kontur.gcode import read
from kontur.sim.models.equidistant import Formats, KIND, prepare, profile_from_moves
from kontur.sim.runners import CocotbBuild
from kontur.sim.stimulus import Job, record_outcomes, record_steps
from kontur.sim.testbench import EngineBench, Scoreboard, random_gaps, random_pattern

from .conftest import cocotb_build_root, selected_simulators

PROGRAMS = Path(__file__).resolve().parent / "programs"
WIDTH = 12


def _variant():
    return os.environ["KONTUR_VARIANT"]


def frames_of(name, r, *, treatment="extend", other_side=False):
    text = (PROGRAMS / f"{name}.ngc").read_text()
    if other_side:
        text = text.replace("G41", "@").replace("G42", "G41").replace("@", "G42")
    shape = profile_from_moves(read(text).moves)
    return list(prepare(shape, r, treatment=treatment, formats=Formats(WIDTH)).frames)


async def play(dut, job):
    """Play ``job`` (after a reset) with the model as scoreboard; return the record."""
    job.resets = {0: 1, **{k + 1: v for k, v in job.resets.items()}}
    job.aborts = {k + 1: v for k, v in job.aborts.items()}
    model = registry.make_model("profile", _variant(), width=WIDTH)
    return await EngineBench.from_env(dut).play(job, scoreboard=Scoreboard(model))


def expected(frames):
    return registry.steps("profile", frames, _variant(), width=WIDTH)


@cocotb.test()
@cocotb.parametrize(treatment=["extend", "arc"], other_side=[False, True])
async def contours(dut, treatment, other_side):
    """Closed and open contours of lines and arcs, both sides, both corner treatments."""
    frames = []
    for name, r in (("square", 3), ("triangle", 1), ("rounded", 4), ("pie", 2), ("lens", 3),
                    ("bite", 2), ("zigzag", 5)):
        frames += frames_of(name, r, treatment=treatment, other_side=other_side)
    record = await play(dut, Job(frames=frames, max_cycles=200_000))
    assert record_steps(record) == expected(frames)


@cocotb.test()
async def several_radii(dut):
    """One program, the radius dialled anew before each run."""
    frames = []
    for r in (0, 1, 3, 6):
        frames += frames_of("polygon", r, treatment="arc")
    record = await play(dut, Job(frames=frames, max_cycles=200_000))
    assert record_steps(record) == expected(frames)


@cocotb.test()
async def stalls(dut):
    """Gaps in the command stream and the feed, stalls on the status stream."""
    rng = random.Random(5)
    frames = frames_of("rounded", 2, treatment="arc") + frames_of("polygon", 1)
    job = Job(frames=frames, gaps=random_gaps(rng, len(frames), (0, 0, 30)),
              tick=random_pattern(rng), status_ready=random_pattern(rng, ones=0.5),
              max_cycles=200_000)
    record = await play(dut, job)
    assert record_steps(record) == expected(frames)


@cocotb.test()
async def refusals_and_aborts(dut):
    """Frames the engine refuses, and aborts while contours run."""
    square = frames_of("square", 2)
    frames = [square[3], {"kind": 7}, {"kind": KIND["radius"], "x": -1}, *square,
              *frames_of("lens", 1), *square]
    record = await play(dut, Job(frames=frames, aborts={200: 1, 420: 2},
                                 max_cycles=200_000))
    outcomes = [outcome for _, _, outcome, _ in record_outcomes(record)]
    assert outcomes[:3] == [1, 1, 1]                  # refused
    assert outcomes.count(2) >= 2                     # aborted


@pytest.mark.cocotb
@pytest.mark.parametrize("variant", registry.variants("profile"))
@pytest.mark.parametrize("simulator", selected_simulators())
def test_equidistant_engine(simulator, variant):
    build = CocotbBuild(registry.make_engine("profile", variant, width=WIDTH), simulator,
                        cocotb_build_root())
    build.test(__name__, env={"KONTUR_VARIANT": variant})
