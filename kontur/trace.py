"""Trace one command on any engine: the golden model, Amaranth's simulator, Icarus, Verilator.

Every kind of command and variant comes from :mod:`kontur.registry`. :func:`trace` checks the
request before anything is built or run (:func:`plan`), runs the single frame on the chosen
engine and returns its moves. Bad input is refused the same way everywhere: the model raises
:exc:`InputError` before running; the RTL raises its ``REFUSED`` outcome, which is turned into
the same :exc:`InputError` here. A run that cannot be completed within the limits is refused
up front with the reason, never cut short.
"""

import math
import os
from dataclasses import dataclass
from pathlib import Path

from kontur import registry
from kontur.sim.models.errors import InputError
from kontur.sim.runners import ENGINES, ROOT
from kontur.sim.stimulus import Job, record_moves, run_model

__all__ = ["trace", "plan", "Plan", "UsageError", "WIDTHS", "MAX_CLOCKS", "MAX_STEPS", "SPEED",
           "STEP_MODEL_SPEED", "trace_profile", "ProfileRun"]

#: Register widths a command may ask for.
WIDTHS = range(2, 65)

#: Clocks each engine traces at most (``--max-clocks`` raises it; about ten minutes each) and
#: its speed in clocks a second, measured with ``kontur trace arc R 0 R 0 --cycles`` (R = 3000
#: to 10000) on this project's kind of machine (2 cores) while other jobs ran: the cycle model
#: (``--cycles``; 12 000 for the faithful arc, 23 000 for the fast one), Amaranth's
#: simulator, and the cocotb harness on Icarus and Verilator. Without ``--cycles`` the model is
#: the step-level one: about a million steps a second, and its limit counts steps.
MAX_CLOCKS = {"model": 5_000_000, "amaranth": 1_000_000, "icarus": 5_000_000,
              "verilator": 10_000_000}
SPEED = {"model": 12_000, "amaranth": 3_000, "icarus": 8_000, "verilator": 16_000}
MAX_STEPS = 200_000_000
STEP_MODEL_SPEED = 1_000_000


class UsageError(ValueError):
    """A request that cannot be run as asked (bad option, or beyond the stated limits)."""


@dataclass(frozen=True)
class Plan:
    """A checked request: what :func:`trace` runs."""
    kind: str
    variant: str
    engine: str
    width: int
    payload: dict
    vcd: object
    cycles: bool
    steps: int              # an upper bound on the steps of the command
    clocks: int             # an upper bound on the clocks of the run
    max_clocks: int
    params: dict = None     # the core's parameters (a generator period, a faithful timing)


def _check_vcd(vcd, engine):
    if vcd is None:
        return None
    if engine == "model":
        raise UsageError("--vcd needs an RTL engine (amaranth, icarus or verilator)")
    if str(vcd) == "":
        raise UsageError("--vcd needs a file name")
    path = Path(vcd)
    if path.is_dir():
        raise UsageError(f"--vcd {vcd}: is a directory")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"--vcd {vcd}: no directory {parent}")
    if not os.access(parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise UsageError(f"--vcd {vcd}: not writable")
    return path


def _step_bound(kind, payload, width):
    """An upper bound on the steps of a command the model accepts."""
    if kind == "line":
        return max(abs(payload["x"]), abs(payload["y"]))
    from kontur.sim.models.arc import round_sqrt
    radius = round_sqrt(payload["x0"] ** 2 + payload["y0"] ** 2)
    return 8 * radius + 8                  # at most 2R steps in each of 5 quadrant runs


def _latency(kind, width):
    if kind == "line":
        return 2
    from kontur.sim.models.arc import setup_latency
    return setup_latency(width) + 2


def plan(kind, payload, *, variant=None, engine="model", width=None, vcd=None, cycles=False,
         max_clocks=None, params=None):
    """Check a request; return its :class:`Plan`.

    Raises
    ------
    UsageError
        For an unknown engine or variant, a width outside :data:`WIDTHS`, a ``vcd`` that
        cannot be written or is asked of the model, or a run longer than ``max_clocks``
        (default :data:`MAX_CLOCKS` of the engine).
    InputError
        If the model refuses the command (the RTL engines run it anyway, to show the RTL's
        refusal; see :func:`trace`).
    """
    params = dict(params or {})
    if engine not in ENGINES:
        raise UsageError(f"engine must be one of {', '.join(ENGINES)}, not {engine!r}")
    try:
        item = registry.variant(kind, variant)
    except ValueError as error:
        raise UsageError(str(error)) from None
    width = registry.KINDS[kind].default_width if width is None else width
    if isinstance(width, bool) or not isinstance(width, int) or width not in WIDTHS:
        raise UsageError(f"--width must be an integer from {WIDTHS.start} to "
                         f"{WIDTHS.stop - 1}, not {width!r}")
    vcd = _check_vcd(vcd, engine)
    limit = MAX_CLOCKS[engine] if max_clocks is None else max_clocks
    if isinstance(limit, bool) or not isinstance(limit, int) or limit < 1:
        raise UsageError(f"--max-clocks must be a positive integer, not {limit!r}")

    refused = None
    try:
        registry.check(kind, payload, width)
    except InputError as reason:
        if engine == "model":
            raise
        refused = reason
    steps = 0 if refused else _step_bound(kind, payload, width)
    if item.clocks is not None and not refused:
        core_clocks = item.clocks(payload, width, **params)    # a core with its own timing
    else:
        core_clocks = registry.step_clocks(kind, item.name, width, **params) * (steps + 16)
    clocks = _latency(kind, width) + core_clocks + 64
    step_model = engine == "model" and not cycles
    if not step_model and clocks > limit:
        seconds = clocks / SPEED[engine]
        raise UsageError(
            f"this {kind} needs up to {clocks} clocks, more than the {limit} that --engine "
            f"{engine} traces (about {_duration(seconds)} at {SPEED[engine]} clocks a second); "
            f"raise --max-clocks to run it anyway")
    steps_limit = MAX_STEPS if max_clocks is None else max_clocks
    if step_model and steps > steps_limit:
        raise UsageError(f"this {kind} has up to {steps} steps, more than the {steps_limit} "
                         f"that --engine model traces (about "
                         f"{_duration(steps / STEP_MODEL_SPEED)}); raise --max-clocks to run "
                         f"it anyway")
    return Plan(kind, item.name, engine, width, dict(payload), vcd, cycles, steps, clocks,
                limit, params)


def _duration(seconds):
    if seconds < 120:
        return f"{math.ceil(seconds)} s"
    if seconds < 7200:
        return f"{math.ceil(seconds / 60)} min"
    return f"{seconds / 3600:.1f} h"


def build_root():
    """Where the command line keeps its simulator builds (shared between calls and processes,
    one directory per design; see :class:`kontur.sim.runners.CocotbBuild`): ``$KONTUR_BUILD`` if
    set, else ``build/cli`` in the project."""
    return Path(os.environ.get("KONTUR_BUILD") or ROOT / "build" / "cli")


def trace(kind, payload, **options):
    """Run one command; return its moves, ``[(cycle, dx, dy), ...]``.

    ``options`` are those of :func:`plan`. With the model and without ``cycles`` the moves
    come from the step-level model (their cycles are then ``None``).

    Raises
    ------
    InputError
        If the command is refused (by the model's check, or by the RTL's outcome).
    UsageError
        See :func:`plan`.
    RuntimeError
        If the RTL and the model disagree on whether the command is refused.
    """
    run = plan(kind, payload, **options)
    if run.engine == "model" and not run.cycles:
        return [(None, dx, dy) for dx, dy in registry.steps(kind, payload, run.variant,
                                                            width=run.width)]
    job = Job(frames=[payload], max_cycles=run.clocks)
    if run.engine == "model":
        record = run_model(registry.make_model(kind, run.variant, width=run.width,
                                               **run.params), job, sparse=True)
        return record_moves(record)

    engine = registry.make_engine(kind, run.variant, width=run.width, **run.params)
    limit = 1 << (engine.coord_width - 1)
    for name, value in payload.items():
        if name != "cw" and not -limit <= value < limit:
            raise InputError(f"{name.upper()} = {value} does not fit the frame's "
                             f"{engine.coord_width}-bit signed coordinates")
    if run.engine == "amaranth":
        from kontur.sim.runners import run_amaranth
        record = run_amaranth(engine, job, vcd=run.vcd, sparse=True)
    else:
        from kontur.sim.runners import CocotbBuild
        build = CocotbBuild(engine, run.engine, build_root(), waves=run.vcd is not None,
                            quiet=True)
        record = build.run(job, vcd=run.vcd, sparse=True)

    refused = any(item.get("error") for item in record)
    try:
        registry.check(kind, payload, run.width)
    except InputError as reason:
        if refused:
            raise InputError(f"{reason} (refused by the RTL)") from None
        raise RuntimeError(f"the RTL accepted a command the model refuses: {reason}")
    if refused:
        raise RuntimeError("the RTL refused a command the model accepts")
    return record_moves(record)


# ---- programs: a contour of a G-code file ------------------------------------------------

@dataclass(frozen=True)
class ProfileRun:
    """A traced contour: its moves ``[(cycle, dx, dy), ...]`` and what was traced (the
    :class:`kontur.sim.models.equidistant.Prepared` profile)."""
    moves: list
    prepared: object


def _profile_clocks(prepared, clocks_per_step):
    """An upper bound on the clocks of a contour on the engine: forming every frame
    (``2·(width + 2) + 10`` clocks each, a few frames at once before the first step, and
    block 11's settling at each), every step (``clocks_per_step``, the variant's
    :func:`kontur.registry.step_clocks`: block 11's settling and the step's own clock at
    least, and two idle clocks for each quadrant run of an arc), plus slack."""
    from kontur.hdl.equidistant import SETTLE
    width = prepared.formats.width
    frames = len(prepared.frames)
    steps = sum(1 for _, steps in _parts(prepared) for _ in steps)
    arcs = sum(1 for e in prepared.elements if e.kind == "arc")
    return (frames * (2 * (width + 2) + 12 + 2 * SETTLE)
            + clocks_per_step * (steps + 16) + 10 * (arcs + 1) + 64), steps


def _parts(prepared):
    from kontur.sim.models.equidistant import trace_elements
    return trace_elements(prepared)


def trace_profile(text, *, radius, name=None, variant=None, engine="model", width=None,
                  vcd=None, cycles=False, max_clocks=None, treatment="extend",
                  detection="normal", params=None):
    """Trace the compensated contour of a G-code program (lattice units) at the cutter radius
    ``radius`` on any engine; return a :class:`ProfileRun`.

    Raises
    ------
    UsageError
        For a program the reader cannot read (:exc:`kontur.gcode.GCodeError`, naming the
        line), an unknown engine, variant, treatment or detection, a width outside
        :data:`WIDTHS`, a ``vcd`` that cannot be written or is asked of the model, a radius
        that is not a non-negative integer, or a run longer than ``max_clocks``.
    InputError
        When the profile is refused (:class:`kontur.sim.models.equidistant.ProfileError`: impossible
        geometry, numbers beyond the registers, a path that would cut into the part), naming
        the program line.
    RuntimeError
        If the RTL refuses a frame of the prepared program.
    """
    from kontur.sim.models.equidistant import (DETECTIONS, TREATMENTS, Formats, prepare,
                                      profile_from_moves)
    from kontur.gcode import GCodeError, planar, read
    params = dict(params or {})
    if engine not in ENGINES:
        raise UsageError(f"engine must be one of {', '.join(ENGINES)}, not {engine!r}")
    try:
        item = registry.variant("profile", variant)
    except ValueError as error:
        raise UsageError(str(error)) from None
    width = registry.KINDS["profile"].default_width if width is None else width
    if isinstance(width, bool) or not isinstance(width, int) or not 4 <= width < WIDTHS.stop:
        raise UsageError(f"--width must be an integer from 4 to {WIDTHS.stop - 1}, "
                         f"not {width!r}")
    if isinstance(radius, bool) or not isinstance(radius, int) or radius < 0:
        raise UsageError(f"--radius must be a non-negative integer, not {radius!r}")
    if treatment not in TREATMENTS:
        raise UsageError(f"--corner must be one of {', '.join(TREATMENTS)}, not {treatment!r}")
    if detection not in DETECTIONS:
        raise UsageError(f"--detect must be one of {', '.join(DETECTIONS)}, not "
                         f"{detection!r}")
    vcd = _check_vcd(vcd, engine)
    limit = MAX_CLOCKS[engine] if max_clocks is None else max_clocks
    if isinstance(limit, bool) or not isinstance(limit, int) or limit < 1:
        raise UsageError(f"--max-clocks must be a positive integer, not {limit!r}")
    try:
        program = read(text, name=name)
        planar(program.moves, name=name, unit="steps")
    except GCodeError as error:
        raise UsageError(str(error)) from None
    # A dwell is no part of the contour's geometry (the trace has no time).
    profile = profile_from_moves([move for move in program.moves if move.kind != "dwell"])
    prepared = prepare(profile, radius, treatment=treatment, detection=detection,
                       formats=Formats(width))
    clocks, steps = _profile_clocks(prepared,
                                    registry.step_clocks("profile", item.name, width, **params))
    step_model = engine == "model" and not cycles
    if not step_model and clocks > limit:
        seconds = clocks / SPEED[engine]
        raise UsageError(
            f"this contour needs up to {clocks} clocks, more than the {limit} that --engine "
            f"{engine} traces (about {_duration(seconds)} at {SPEED[engine]} clocks a second);"
            f" raise --max-clocks to run it anyway")
    step_limit = MAX_STEPS if max_clocks is None else limit
    if step_model and steps > step_limit:
        raise UsageError(f"this contour has {steps} steps, more than the {step_limit} that "
                         f"--engine model traces; raise --max-clocks to run it anyway")
    frames = list(prepared.frames)
    if step_model:
        moves = [(None, dx, dy) for dx, dy in registry.steps("profile", frames, item.name,
                                                              width=width)]
        return ProfileRun(moves, prepared)
    job = Job(frames=frames, max_cycles=clocks)
    if engine == "model":
        record = run_model(registry.make_model("profile", item.name, width=width, **params),
                           job)
    else:
        rtl = registry.make_engine("profile", item.name, width=width, **params)
        if engine == "amaranth":
            from kontur.sim.runners import run_amaranth
            record = run_amaranth(rtl, job, vcd=vcd)
        else:
            from kontur.sim.runners import CocotbBuild
            build = CocotbBuild(rtl, engine, build_root(), waves=vcd is not None, quiet=True)
            record = build.run(job, vcd=vcd)
    if any(entry.get("error") for entry in record):
        raise RuntimeError("the RTL refused a frame of the prepared program")
    return ProfileRun(record_moves(record), prepared)
