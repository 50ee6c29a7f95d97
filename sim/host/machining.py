"""``kontur run``: a G-code program through the whole machine controller.

:func:`prepare` reads the program (millimetres, :mod:`.gcode`), puts it on the step lattice and
plans its feed (:mod:`.planner`) for a board's controller (:func:`sim.registry.make_controller`:
its engines, clock and link) and writes its frames. :func:`execute` runs those frames:

* ``model``: the golden step-level models of the engines (the steps), with the times of the
  feed plan;
* ``amaranth``, ``icarus``: the controller's RTL in Amaranth's simulator or on Icarus (cocotb),
  the host's side of the serial link clock by clock in Python (:class:`sim.testbench.host.
  HostLink`): for short programs;
* ``verilator``: the controller's RTL built with ``sim/fastrun.cpp``, the host inside the
  simulation (:class:`sim.fastrun.FastRun`): millions of clocks a second.

Every RTL run is checked against the model: the same steps in the same order, every frame
answered ``DONE``, the final position read back equal to the program's end. A run may
compress time (``compress``: every rate that many times the planned one, the acceleration its
square; see :func:`sim.host.planner.frames`): the steps do not change, and the summary states
both the simulated time and the machining time it stands for.

:func:`write_outputs` writes ``steps.txt`` (one ``dx dy`` line per step, the format of ``kontur
trace``), ``toolpath.png`` (the programmed contour, the traced steps coloured by feed) and
``summary.json``; :func:`summary_text` is what ``kontur run`` prints.

Cutter-radius compensation (G41/G42) runs on a board whose controller has the equidistant
engine: :mod:`.compensation` puts the contours' frames among the moves (PROFILE frames, each
with its FEED), with the engine's step model as their steps.
"""

import json
import math
import time
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

from .. import registry
from .compensation import program_segments, references
from .gcode import GCodeError, read, sweep
from .machine import Machine
from .planner import ProgramError, frames as program_frames, lattice, plan, planned_feed

__all__ = ["ENGINES", "Job", "Result", "prepare", "execute", "auto_compress", "deviation",
           "write_outputs", "summary_text", "RunError"]

ENGINES = ("model", "amaranth", "icarus", "verilator")

#: Clocks a run may take at most, per engine (about ten minutes of each, as measured on these
#: machines: Amaranth ~10 k, Icarus ~8 k, Verilator's fast harness ~1.5 M clocks a second).
MAX_CLOCKS = {"amaranth": 6_000_000, "icarus": 5_000_000, "verilator": 1_000_000_000}


class RunError(RuntimeError):
    """The RTL did not do what the model says (or did not finish): the message says where."""


@dataclass
class Job:
    """A program ready for a board's controller."""
    name: str
    board: str
    machine: Machine
    moves: list                       # the program's moves (mm), sim.host.gcode.Move
    segments: list                    # on the lattice, sim.host.planner.Segment
    items: list                       # the feed plan, sim.host.planner.PlanItem
    start: tuple = (0, 0)             # steps
    contours: list = field(default_factory=list)    # sim.host.compensation.Contour

    @property
    def steps(self):
        """The model's steps: every segment's, in order."""
        return [step for segment in self.segments for step in segment.steps]

    @property
    def end(self):
        """The programmed end, in steps."""
        return self.segments[-1].end if self.segments else self.start

    @property
    def seconds(self):
        """Machining time at the programmed feeds (the plan's)."""
        return sum(item.seconds for item in self.items)

    def frames(self, compress=1):
        """The program's frames, and the program line of each."""
        return program_frames(self.segments, self.items, self.machine, compress=compress)


@dataclass
class Result:
    """A run: its engine, steps, each step's time (s of machining, ``None`` when not timed),
    the final position (steps), clocks and seconds simulated and the time compression."""
    engine: str
    steps: list
    times: list
    end: tuple
    compress: int = 1
    clocks: int = None
    wall: float = 0.0
    simulated: float = None
    notes: list = field(default_factory=list)


def prepare(text, *, machine=None, board="icebreaker", name=None):
    """Read, place on the lattice and plan a program for ``board``'s controller (a board's
    name, or a :class:`sim.registry.Board`); return the :class:`Job`.

    Raises
    ------
    ProgramError
        For a program the machine refuses, naming its line (:class:`~sim.host.gcode.
        GCodeError` for one it cannot read).
    """
    item = registry.board(board)
    machine = Machine(clock_hz=item.clock_hz) if machine is None else machine
    if machine.clock_hz != item.clock_hz:
        raise ValueError(f"The machine's clock ({machine.clock_hz:g} Hz) is not the "
                         f"{item.name}'s ({item.clock_hz:g} Hz)")
    try:
        program = read(text, name=name, units="mm")
    except GCodeError as error:
        raise ProgramError(error.line, error.reason) from None
    moves = list(program.moves)
    if not moves:
        raise ProgramError(None, "the program has no moves")
    contours = []
    if any(move.side is not None for move in moves):
        segments, contours = program_segments(moves, machine, board)
    else:
        segments = lattice(moves, machine, variants=(item.line[0], item.arc[0]),
                           widths=(item.line[1], item.arc[1]))
    start = segments[0].start if segments else (0, 0)
    return Job(name or "program", board, machine, moves, segments, plan(segments, machine),
               start, contours)


def auto_compress(job):
    """The time compression a simulation of ``job`` may use: a power of two that keeps the
    fastest planned step rate at most half what the step/dir timing allows, and the serial
    link at most half as busy as the motion (so that the queue does not run dry). 1 when the
    program is too fast for any."""
    machine = job.machine
    fastest = max((item.cruise for item in job.items), default=0) * machine.steps_per_mm
    by_rate = machine.max_step_rate / (2 * fastest) if fastest else 1
    frames, _ = job.frames()
    link_seconds = sum(len(f) for f in frames) * 10 / machine.baud
    by_link = job.seconds / (2 * link_seconds) if link_seconds else 1
    limit = max(1, min(by_rate, by_link))
    return 1 << int(math.floor(math.log2(limit)))


def _plan_times(job):
    """Each step's time (s from the start) under the feed plan: trapezoids of every segment."""
    a, spm = job.machine.accel, job.machine.steps_per_mm
    times, now = [], 0.0
    for segment, item in zip(job.segments, job.items):
        total = segment.length / spm
        covered = 0.0
        for dx, dy in segment.steps:
            step = (math.sqrt(2) if dx and dy else 1.0) / spm
            middle = covered + step / 2
            speed = min(math.sqrt(item.entry ** 2 + 2 * a * middle), item.cruise,
                        math.sqrt(item.exit ** 2 + 2 * a * max(total - middle, 0)))
            now += step / max(speed, 1e-9)
            covered += step
            times.append(now)
    return times


def execute(job, engine="model", *, compress=None, vcd=None, vcd_clocks=None, build_root=None,
            progress=None):
    """Run ``job`` on ``engine`` (one of :data:`ENGINES`); return the :class:`Result`.

    ``compress`` is the time compression of an RTL run (default :func:`auto_compress`); ``vcd``
    a path for the waveform (RTL engines; with ``vcd_clocks``, on Verilator, of the first
    that many clocks only); ``progress`` a callable taking the steps made so far,
    called now and then (Verilator, Amaranth).

    Raises
    ------
    RunError
        If the RTL's steps differ from the model's, a frame is not ``DONE``, the final
        position read back is not the program's end, or the run does not end in time.
    """
    if engine not in ENGINES:
        raise ValueError(f"Engine must be one of {', '.join(ENGINES)}, not {engine!r}")
    expected = job.steps
    if engine == "model":
        if vcd is not None:
            raise ValueError("a waveform comes from an RTL run, not the model")
        return Result("model", expected, _plan_times(job), job.end)
    from ..testbench.host import steps_of
    from .protocol import query
    compress = auto_compress(job) if compress is None else compress
    frames, _ = job.frames(compress)
    machine = job.machine
    divisor = round(machine.clock_hz / machine.baud)
    bound = MAX_CLOCKS[engine]
    planned = job.seconds / compress * machine.clock_hz
    link = sum(len(f) for f in frames) * 10 * divisor
    max_clocks = int(min(bound, 2 * (planned + link) + 10 * machine.clock_hz / compress
                         + 1_000_000))
    controller = registry.make_controller(job.board, machine)
    # The final position is read back after the program: the host sends a QUERY once every
    # frame before it is answered.
    sent = frames + [query()]
    started = time.monotonic()
    if engine == "verilator":
        from ..fastrun import FastRun
        fast = FastRun(controller, _root(build_root, "fastrun"), waves=vcd is not None)
        started = time.monotonic()                      # the build apart
        run = fast.run(sent, divisor=divisor, window=machine.queue_frames,
                       max_clocks=max_clocks, vcd=vcd, vcd_clocks=vcd_clocks,
                       progress=progress)
    elif engine == "amaranth":
        from ..testbench.host import run_amaranth
        run = run_amaranth(controller, sent, divisor=divisor, window=machine.queue_frames,
                           max_clocks=max_clocks, vcd=vcd, progress=progress)
    else:
        from ..runners import CocotbBuild
        build = CocotbBuild(controller, engine, _root(build_root, "cocotb"),
                            waves=vcd is not None, quiet=True)
        started = time.monotonic()
        run = build.run_controller(sent, divisor=divisor, window=machine.queue_frames,
                                   max_clocks=max_clocks, vcd=vcd)
    wall = time.monotonic() - started
    steps = steps_of(run)
    _check(job, run, steps, expected, len(frames))
    times = [clock * compress / machine.clock_hz for clock, _, _ in run.steps]
    first = times[0] if times else 0.0
    times = [t - first for t in times]
    (status,) = [reply.fields for _, reply in run.replies if reply.kind == 0x81][-1:] or [None]
    return Result(engine, steps, times, (status[0], status[1]), compress, run.clocks, wall,
                  run.clocks / machine.clock_hz)


def _check(job, run, steps, expected, count):
    from hdl.motion.link import ERROR, OUTCOME, STATUS
    if steps != expected:
        at = next((i for i, (a, b) in enumerate(zip(steps, expected)) if a != b),
                  min(len(steps), len(expected)))
        raise RunError(f"the RTL's steps differ from the model's at step {at} (RTL "
                       f"{len(steps)} steps, model {len(expected)})")
    outcomes = [reply.fields for _, reply in run.replies if reply.kind == OUTCOME]
    errors = [reply.fields for _, reply in run.replies if reply.kind == ERROR]
    if errors:
        raise RunError(f"the controller reported errors {errors}")
    if outcomes != [(n % 256, 0) for n in range(count)]:
        bad = next((o for n, o in enumerate(outcomes) if o != (n % 256, 0)), None)
        raise RunError(f"not every frame ended DONE: {len(outcomes)} outcomes of {count}, "
                       f"first unexpected {bad}")
    status = [reply.fields for _, reply in run.replies if reply.kind == STATUS]
    if not status or (status[-1][0], status[-1][1]) != tuple(job.end):
        raise RunError(f"the position read back, {status[-1][:2] if status else None}, is "
                       f"not the program's end {tuple(job.end)}")


def _root(build_root, what):
    from .trace import build_root as default_root
    return Path(build_root or default_root()) / what


# ---- measurement and outputs -------------------------------------------------------------

def _distance_to_segment(p, a, b):
    ax, ay = b[0] - a[0], b[1] - a[1]
    length2 = ax * ax + ay * ay
    t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * ax + (p[1] - a[1]) * ay)
                                               / length2))
    return math.hypot(p[0] - a[0] - t * ax, p[1] - a[1] - t * ay)


def _distance_to_arc(p, move):
    """The distance of ``p`` (mm) from the programmed arc of ``move`` as a curve: from its
    circle (the start's radius) where ``p`` lies within the programmed sweep, else from the
    nearer of its two end points."""
    start = tuple(float(c) for c in move.start)
    end = tuple(float(c) for c in move.end)
    centre = tuple(float(c) for c in move.centre)
    radius = math.hypot(start[0] - centre[0], start[1] - centre[1])
    if move.full or sweep(start, p, centre, move.cw, full=False) <= move.sweep + 1e-12:
        return abs(math.hypot(p[0] - centre[0], p[1] - centre[1]) - radius)
    return min(math.hypot(p[0] - start[0], p[1] - start[1]),
               math.hypot(p[0] - end[0], p[1] - end[1]))


def deviation(job, steps):
    """The largest distance (mm) of a point the steps visit from the programmed contour: for
    each segment's points, from its program move (a line segment, or the programmed arc: its
    circle within its programmed sweep, its nearer end outside it, so a turn traced where a
    sliver was programmed is far from it); a compensated contour's, from its exact equidistant
    (the approach to it from its own line)."""
    moves = {move.line: move for move in job.moves}
    special = references(job)
    spm = job.machine.steps_per_mm
    worst = 0.0
    index = 0
    for number, segment in enumerate(job.segments):
        x, y = segment.start
        if number in special:
            measure = special[number] or (lambda p, a=segment.start, b=segment.end:
                                          _distance_to_segment(p, a, b) / spm)
            for dx, dy in steps[index:index + len(segment.steps)]:
                x, y = x + dx, y + dy
                worst = max(worst, measure((x, y)))
            index += len(segment.steps)
            continue
        move = moves[segment.line]
        start = tuple(float(c) for c in move.start)
        end = tuple(float(c) for c in move.end)
        for dx, dy in steps[index:index + len(segment.steps)]:
            x, y = x + dx, y + dy
            p = (x / spm, y / spm)
            if move.kind == "arc":
                d = _distance_to_arc(p, move)
            else:
                d = _distance_to_segment(p, start, end)
            worst = max(worst, d)
        index += len(segment.steps)
    return worst


def _speeds(steps, times, spm):
    speeds, previous = [], 0.0
    for (dx, dy), t in zip(steps, times):
        length = (math.sqrt(2) if dx and dy else 1.0) / spm
        interval = t - previous
        speeds.append(length / interval * 60 if interval > 0 else float("nan"))
        previous = t
    return speeds


def summary(job, result):
    """The figures of a run, as a dict (``summary.json``)."""
    spm = job.machine.steps_per_mm
    steps = result.steps
    end = result.end
    moves = job.moves
    data = {
        "program": job.name,
        "board": registry.board(job.board).name,
        "engine": result.engine,
        "moves": len(moves),
        "lines": [moves[0].line, moves[-1].line] if moves else None,
        "segments": len(job.segments),
        "arcs": sum(1 for s in job.segments if s.kind == "arc"
                    or s.kind == "profile" and s.radius is not None),
        "steps": len(steps),
        "diagonal_steps": sum(1 for dx, dy in steps if dx and dy),
        "machining_seconds": job.seconds,
        "max_deviation_mm": deviation(job, steps),
        "end_steps": list(end),
        "end_mm": [end[0] / spm, end[1] / spm],
        "programmed_end_steps": list(job.end),
        "steps_per_mm": spm,
        "feeds_mm_min": sorted({round(float(m.feed), 3) for m in moves
                                if m.feed is not None and m.kind != "rapid"}),
        "planned_feeds_mm_min": sorted({round(planned_feed(m.feed, job.machine), 3)
                                        for m in moves
                                        if m.feed is not None and m.kind != "rapid"}),
        "compress": result.compress,
        "clocks": result.clocks,
        "simulated_seconds": result.simulated,
        "wall_seconds": result.wall,
        "clocks_per_second": (result.clocks / result.wall if result.clocks and result.wall
                              else None),
        "machine_seconds_traced": result.times[-1] if result.times else 0.0,
    }
    if job.contours:
        data["cutter_radius_mm"] = job.machine.cutter_radius
        data["cutter_radius_steps"] = job.contours[0].radius
        data["contours"] = [{
            "lines": list(contour.lines),
            "side": contour.prepared.profile.side,
            "closed": contour.prepared.closed,
            "profile_frames": len(contour.prepared.frames) - (1 if number else 0),
            "steps": sum(len(s.steps) for s in job.segments[contour.first:contour.first
                                                            + contour.count]),
        } for number, contour in enumerate(job.contours)]
    return data


def _feeds(data):
    """The programmed feeds, and the planned ones where any differs by more than 0.1 % (the
    machine's maximum, a low feed's rounding to the feed generator's rates)."""
    programmed = ", ".join(f"{f:g}" for f in data["feeds_mm_min"])
    if all(abs(a - b) <= 0.001 * a for a, b in zip(data["feeds_mm_min"],
                                                  data["planned_feeds_mm_min"])) \
            and len(data["feeds_mm_min"]) == len(data["planned_feeds_mm_min"]):
        return f"{programmed} mm/min"
    planned = ", ".join(f"{f:g}" for f in data["planned_feeds_mm_min"])
    return f"{programmed} mm/min programmed, planned at {planned} mm/min"


def summary_text(data, out_dir=None):
    """What ``kontur run`` prints: the summary's figures, one per line."""
    lines = [
        f"program    {data['program']} on the {data['board']}: {data['moves']} moves "
        f"(lines {data['lines'][0]}-{data['lines'][1]}), {data['segments']} segments "
        f"({data['arcs']} arcs)",
        f"steps      {data['steps']} ({data['diagonal_steps']} diagonal) at "
        f"{data['steps_per_mm']:g} steps/mm; feeds {_feeds(data)}",
        f"time       {data['machining_seconds']:.2f} s machining at the programmed feeds "
        f"(the plan)",
    ]
    if data["engine"] != "model":
        lines.append(f"traced     {data['machine_seconds_traced']:.2f} s of machining in "
                     f"{data['simulated_seconds']:.3f} s simulated (time compressed x"
                     f"{data['compress']}), {data['clocks']:,} clocks in {data['wall_seconds']:.1f}"
                     f" s on {data['engine']} ({data['clocks_per_second']:,.0f} clocks/s)")
    for contour in data.get("contours", ()):
        lines.append(f"contour    lines {contour['lines'][0]}-{contour['lines'][1]} "
                     f"({'G41' if contour['side'] == 'left' else 'G42'}, "
                     f"{'closed' if contour['closed'] else 'open'}): "
                     f"{contour['profile_frames']} PROFILE frames through the equidistant "
                     f"engine, cutter radius {data['cutter_radius_mm']:g} mm "
                     f"({data['cutter_radius_steps']} steps), {contour['steps']} steps")
    lines += [
        f"deviation  {data['max_deviation_mm']:.4f} mm at most from the programmed contour"
        + (" (a compensated one's: from its equidistant)" if data.get("contours") else ""),
        f"end        ({data['end_mm'][0]:.4f}, {data['end_mm'][1]:.4f}) mm = "
        f"({data['end_steps'][0]}, {data['end_steps'][1]}) steps"
        + (", the programmed end" if data["end_steps"] == data["programmed_end_steps"]
           else f", NOT the programmed end {tuple(data['programmed_end_steps'])}"),
    ]
    if data["engine"] != "model":
        lines.append("checked    the RTL's steps equal the model's, every frame DONE, the "
                     "position read back")
    if out_dir is not None:
        lines.append(f"outputs    {out_dir}/")
    return "\n".join(lines) + "\n"


def write_outputs(job, result, out_dir):
    """Write ``steps.txt``, ``toolpath.png`` and ``summary.json`` into ``out_dir``; return the
    summary dict."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "steps.txt").write_text("".join(f"{dx} {dy}\n" for dx, dy in result.steps))
    data = summary(job, result)
    from .plot import plot_toolpath
    plot_toolpath(job, result.steps, _speeds(result.steps, result.times,
                                             job.machine.steps_per_mm),
                  out_dir / "toolpath.png",
                  title=f"{job.name}: {len(result.steps)} steps, {result.engine}")
    (out_dir / "summary.json").write_text(json.dumps(data, indent=2) + "\n")
    return data
