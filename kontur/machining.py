"""``kontur run``: a G-code program through the whole machine controller.

:func:`prepare` reads the program (millimetres, :mod:`.gcode`), puts it on the step lattice and
plans its feed (:mod:`.planner`) for a board's controller (:func:`kontur.registry.make_controller`:
its engines, clock and link) and writes its frames. :func:`execute` runs those frames:

* ``model``: the golden step-level models of the engines (the steps), with the times of the
  feed plan;
* ``amaranth``, ``icarus``: the controller's RTL in Amaranth's simulator or on Icarus (cocotb),
  the host's side of the serial link clock by clock in Python (:class:`kontur.sim.testbench.hostlink.
  HostLink`): for short programs;
* ``verilator``: the controller's RTL built with ``sim/fastrun.cpp``, the host inside the
  simulation (:class:`kontur.sim.fastrun.FastRun`): millions of clocks a second.

Every RTL run is checked against the model: the same steps in the same order, every frame
answered ``DONE``, the final position read back equal to the program's end. A run may
compress time (``compress``: every rate that many times the planned one, the acceleration its
square; see :func:`kontur.planner.frames`): the steps do not change, and the summary states
both the simulated time and the machining time it stands for.

:func:`write_outputs` writes ``steps.txt`` (one ``dx dy`` line per step, ``dx dy dz`` on three axes; the format of ``kontur
trace``), ``toolpath.png`` (the programmed contour, the traced steps coloured by feed) and
``summary.json``; :func:`summary_text` is what ``kontur run`` prints.

Cutter-radius compensation (G41/G42) runs on a board whose controller has the equidistant
engine: :mod:`.compensation` puts the contours' frames among the moves (PROFILE frames, each
with its FEED), with the engine's step model as their steps.
"""

import copy
import itertools
import json
import math
import time
from dataclasses import dataclass, field, replace
from functools import cached_property
from fractions import Fraction
from pathlib import Path

from kontur import registry
from kontur.compensation import program_segments, references
from kontur.gcode import PLANE_AXES, GCodeError, planar, read, sweep
from kontur.hdl.motion.tools import tool_engine
from kontur.machine import Machine, MachineError
from kontur.planner import (ProgramError, Segment, frames as program_frames, lattice, lift,
                            plan, planned_feed, step_length, step_seconds, link_feed,
                            LINK_MARGIN)
from kontur.sim.models.motion import safety_run

__all__ = ["ENGINES", "Job", "Result", "prepare", "execute", "auto_compress", "max_compress",
           "estimate_steps", "deviation", "write_outputs", "summary_text", "RunError",
           "MAX_STEPS", "BYTES_PER_STEP", "check_compress", "staging_dir"]

ENGINES = ("model", "amaranth", "icarus", "verilator")

#: The events of a program listed as ``tool_events`` in the summary (:class:`kontur.gcode.
#: Event` kinds): T, M6/M61, M3/M4/M5, S, M7/M8/M9, G43/G43.1/G49.
TOOL_EVENTS = ("tool", "tool_change", "spindle", "speed", "coolant", "tool_length")

#: Clocks a run may take at most, per engine (about ten minutes of each, as measured on these
#: machines: Amaranth ~10 k, Icarus ~8 k, Verilator's fast harness ~1.5 M clocks a second).
MAX_CLOCKS = {"amaranth": 6_000_000, "icarus": 5_000_000, "verilator": 1_000_000_000}


#: Steps a run takes at most (``kontur run --max-steps``): every step is held in memory (the
#: steps, their times and speeds, the plot), about :data:`BYTES_PER_STEP` bytes each, so the
#: default keeps a run within about 2 GB. A program is refused before any step is computed
#: when its estimate (:func:`estimate_steps`) exceeds it.
MAX_STEPS = 10_000_000

#: Memory a step of a run takes, about (measured: ``kontur run --engine model`` of a long
#: line, peak resident memory over the steps).
BYTES_PER_STEP = 200


class RunError(RuntimeError):
    """The RTL did not do what the model says (or did not finish): the message says where."""


@dataclass
class Job:
    """A program ready for a board's controller."""
    name: str
    board: str
    machine: Machine
    moves: list                       # the program's moves (mm), kontur.gcode.Move
    segments: list                    # on the lattice, kontur.planner.Segment
    items: list                       # the feed plan, kontur.planner.PlanItem
    start: tuple = (0, 0)             # steps ((x, y, z) on a 3-axis board)
    contours: list = field(default_factory=list)    # kontur.compensation.Contour
    events: list = field(default_factory=list)      # kontur.gcode.Event: tools, pauses, ...

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

    @cached_property
    def link_seconds(self):
        """The time the program's frames take on the link at the machine's baud (10 bits a
        byte), the same at every compression (only the rates in them change)."""
        frames, _ = self.frames()
        return sum(len(f) for f in frames) * 10 / self.machine.baud


@dataclass
class Result:
    """A run: its engine, steps, each step's time (s of machining, ``None`` when not timed),
    the final position (steps), clocks and seconds simulated and the time compression;
    ``tool_pins``, from a Verilator run of a controller with tool outputs: ``(seconds, word)``
    at each change of the tool pins (machining time, as ``times``; bit n the n-th of
    :data:`kontur.hdl.motion.tools.TOOL_PINS`), else ``None``."""
    engine: str
    steps: list
    times: list
    end: tuple
    compress: int = 1
    clocks: int = None
    wall: float = 0.0
    simulated: float = None
    notes: list = field(default_factory=list)
    final_state: str = "IDLE"         # the controller's state at the end (STATUS's)
    alarm: list = field(default_factory=list)      # the inputs that tripped (ALARM's cause)
    events: list = field(default_factory=list)     # the scripted events as they were taken
    tool_pins: list = None


def _move_steps(move, spm):
    """An upper bound on the steps of a move (mm) on a lattice of ``spm`` steps/mm, computed
    exactly (a coordinate may have thousands of digits): a line's ``|dx| + |dy|`` steps (and 2
    for the rounding of its ends; a Z move's steps apart, :func:`estimate_steps`); an arc's share of a full circle's ``8R + 8`` (``R`` its
    radius in steps, rounded up) by its programmed sweep (:attr:`kontur.gcode.Move.sweep`),
    and 16 more (the lattice's sweep is the programmed one within the rounding)."""
    if move.kind == "dwell":
        return 0
    if move.kind == "arc" and move.plane != 17:   # G18, G19: in the plane, and its normal
        native = move.in_plane
        return _move_steps(native, spm) + \
            math.ceil(abs(Fraction(native.z) - Fraction(native.start_z)) * Fraction(spm)) + 2
    coordinates = [*move.start, *move.end, *(move.centre or ())]
    if all(abs(c) < 10 ** 9 for c in coordinates):       # floats exact enough: +2 steps slack
        x0, y0, x1, y1, *centre = map(float, coordinates)
        spm = float(spm)
        if move.kind != "arc":
            return math.ceil((abs(x1 - x0) + abs(y1 - y0)) * spm) + 4
        cx, cy = centre
        radius = math.ceil(max(math.hypot(x0 - cx, y0 - cy), math.hypot(x1 - cx, y1 - cy))
                           * spm) + 2
        return math.ceil((8 * radius + 8) * move.total_sweep / (2 * math.pi)) + 16
    spm = Fraction(spm)

    def steps(a, b):                       # a coordinate difference (mm) in whole steps, up
        return math.ceil(abs(Fraction(b) - Fraction(a)) * spm)

    (x0, y0), (x1, y1) = move.start, move.end
    if move.kind != "arc":
        return steps(x0, x1) + steps(y0, y1) + 2
    cx, cy = move.centre
    radius = max(math.isqrt(steps(cx, x) ** 2 + steps(cy, y) ** 2) + 1
                 for x, y in ((x0, y0), (x1, y1)))
    return math.ceil(Fraction(8 * radius + 8) * Fraction(move.total_sweep)
                     / Fraction(2 * math.pi)) + 16


def _figure(number, unit=1):
    """An int of any size divided by ``unit``, for a message: with commas up to 10**30, else
    as a power of ten."""
    if number < 10 ** 30 * unit:
        return f"{number / unit:.3g}" if unit > 1 else f"{number:,}"
    return f"10**{len(str(number // unit)) - 1}"


def estimate_steps(moves, machine, *, max_steps=None):
    """An upper bound on the steps of ``moves`` (mm, :class:`kontur.gcode.Move`), computed
    from the program alone, before any step is (see :func:`_move_steps`).

    Raises
    ------
    ProgramError
        Naming the line where the total passes ``max_steps`` (default :data:`MAX_STEPS`), with
        the estimate and the memory it would take.
    """
    limit = MAX_STEPS if max_steps is None else max_steps
    spm = machine.steps_per_mm
    total = 0
    z = 0
    for move in moves:
        total += _move_steps(move, spm)
        if move.z is not None and move.z != z:       # at most its Z steps more (a 3D line's)
            total += math.ceil(abs(Fraction(move.z) - Fraction(z)) * Fraction(spm)) + 2
            z = move.z
        if total > limit:
            raise ProgramError(
                move.line, f"the program reaches about {_figure(total)} steps by this line, more "
                           f"than the {limit:,} this run takes (about "
                           f"{_figure(total * BYTES_PER_STEP, 10 ** 9)} GB of memory at "
                           f"{BYTES_PER_STEP} bytes a step); raise --max-steps to run it "
                           f"anyway")
    return total


def prepare(text, *, machine=None, board="icebreaker", name=None, max_steps=None, tools=None,
            start=(0, 0)):
    """Read, place on the lattice and plan a program for ``board``'s controller (a board's
    name, or a :class:`kontur.registry.Board`); return the :class:`Job`.

    ``tools`` is the tool table (``{tool: diameter, mm}``, :func:`kontur.gcode.
    read_tool_table`) for the program's D words and loaded tools; the machine's G28 and G30
    positions are the program's parameters 5161-5163 and 5181-5183. A move that changes Z is
    refused (:func:`kontur.gcode.planar`) on a board whose controller has X and Y only (the
    iCEBreaker's); on a 3-axis board (the ULX3S's) Z moves, from 0 at the program's first Z
    word, lines in XYZ and helical arcs (:func:`kontur.planner.lattice` with ``axes=3``:
    the steps are ``(dx, dy, dz)``), but within a compensated program, which stays planar.
    With the machine's
    travel (``travel_x``, ``travel_y``) a move that leaves it is refused
    (:func:`check_travel`: every step point, an arc's bulge and a compensated contour's cutter
    path too).

    ``start`` is where the machine is when the program begins (mm, machine coordinates: the
    origin, or where a homing cycle left it, ``kontur send --home``).

    Before any step is computed the program's steps are estimated (:func:`estimate_steps`)
    and a program of more than ``max_steps`` (default :data:`MAX_STEPS`) is refused.

    Raises
    ------
    ProgramError
        For a program the machine refuses, naming its line (:class:`~kontur.gcode.
        GCodeError` for one it cannot read), or one with too many steps.
    """
    item = registry.board(board)
    machine = Machine(clock_hz=item.clock_hz) if machine is None else machine
    if machine.clock_hz != item.clock_hz:
        raise ValueError(f"The machine's clock ({machine.clock_hz:g} Hz) is not the "
                         f"{item.name}'s ({item.clock_hz:g} Hz)")
    from kontur.trace import UsageError
    try:
        registry.check_machine(item, machine.check())
    except MachineError as error:
        raise UsageError(str(error)) from None
    if machine.laser and item.tools and not item.laser_mode:
        others = ", ".join(b.name for b in registry.BOARDS.values() if b.tools and b.laser_mode)
        raise UsageError(f"laser = true, but the {item.name}'s tool outputs have no laser mode "
                         f"(no room: registry.Board.laser_mode); set laser = false, or use a "
                         f"board with it: {others}")
    try:
        program = read(text, name=name, units="mm", tools=tools, start=start,
                       parameters=machine.parameters)
        if item.axes == 2 or any(move.side is not None for move in program.moves):
            planar(program.moves, axes=item.axes)
    except GCodeError as error:
        raise ProgramError(error.line, error.reason) from None
    moves = list(program.moves)
    if not any(move.kind != "dwell" for move in moves):
        raise ProgramError(None, "the program has no moves")
    estimate_steps(moves, machine, max_steps=max_steps)
    contours = []
    if any(move.side is not None for move in moves):
        # A dwell inside a contour waits between two of the engine's elements: the contour is
        # made without it, and it goes in after (contour_dwells).
        dwells, kept = [], []
        for move in moves:
            if move.kind == "dwell" and move.side:
                dwells.append((len(kept), move))
            else:
                kept.append(move)
        segments, contours = program_segments(kept, machine, board)
        segments, contours = contour_dwells(segments, contours, kept, dwells)
        if item.axes == 3:
            segments = lift(segments)
    else:
        segments = lattice(moves, machine, variants=(item.line[0], item.arc[0]),
                           widths=(item.line[1], item.arc[1]), axes=item.axes)
    if item.tools:
        segments, contours = tool_stops(segments, contours, moves, program.events, machine)
    start = segments[0].start if segments else (0,) * item.axes
    check_travel(segments, machine, start)
    return Job(name or "program", board, machine, moves, segments, plan(segments, machine),
               start, contours, list(program.events))


class ToolStates:
    """The tool state a program sets, change by change (:func:`tool_changes`' rules, kept
    from one call to the next: ``kontur serve`` takes a program line by line).

    :meth:`take` applies an event (M3 and M4 turn the spindle on clockwise and
    counter-clockwise, M5 off; S sets the power, rounded to a whole number, above the
    machine's ``s_max`` taken as ``s_max``, as Grbl clamps it; M7 turns mist on, M8 flood, M9
    both off); :meth:`change` says what the pins show before a move (or at the program's end,
    where everything is switched off) when it differs from what they show: ``(state, stop)``,
    ``state`` the keywords of :func:`kontur.hdl.motion.tools.tool_frame` (the machine's
    ``laser``, Grbl's ``$32``, with every state), ``stop`` whether the machine stops for it.
    S alone changes nothing on the pins while the spindle is off.

    Without laser mode the machine stops for every change, as LinuxCNC and Grbl stop for a
    spindle or coolant change. In laser mode (Grbl's laser_mode.md) the laser is lit only in
    a feed move (G1, G2, G3; a G4 keeps the move before's, and before the first move the
    laser is off, G0 being the mode at power-up): a G0 moves with the power 0 and the state
    still on; the machine stops only where the spindle (M3, M4, M5) or the coolant changes;
    a change of power alone (an S, the way into or out of a G0) is taken on the fly, between
    the two moves, with no stop."""

    _SPINDLES = ("M5", "M3", "M4")

    def __init__(self, machine):
        from kontur.hdl.motion.tools import Spindle
        self.machine = machine
        self.off = Spindle.OFF
        self.state = {"spindle": Spindle.OFF, "s": 0, "mist": False, "flood": False,
                      "laser": machine.laser}
        self.shown = dict(self.state)         # what the pins show
        self.lit = False                      # laser mode: in a feed move

    def copy(self):
        """A copy to go on from (a line that may be refused: the state is kept until it is
        taken)."""
        other = copy.copy(self)
        other.state, other.shown = dict(self.state), dict(self.shown)
        return other

    def take(self, event):
        """Apply ``event``; ``False`` for one that sets no tool state."""
        from kontur.hdl.motion.tools import Spindle
        state = self.state
        if event.kind == "spindle":
            state["spindle"] = Spindle(self._SPINDLES.index(event.text.split()[0]))
        elif event.kind == "speed":
            state["s"] = min(round(event.value), self.machine.s_max)
        elif event.kind == "coolant":
            code = event.text.strip()
            if code == "M7":
                state["mist"] = True
            elif code == "M8":
                state["flood"] = True
            else:
                state["mist"] = state["flood"] = False
        else:
            return False
        return True

    def _pins(self, state):                   # what the pins show: S only while on
        return (state["spindle"], state["s"] if state["spindle"] != self.off else None,
                state["mist"], state["flood"])

    def change(self, move=None, *, end=False):
        """The change before ``move`` (its kind: ``"rapid"``, ``"line"``, ``"arc"``,
        ``"dwell"``; ``None``: where the moves so far end), or at the program's ``end`` (all
        off): ``(state, stop)``, or ``None`` when the pins show it already."""
        if end:                               # the program's end: M2 turns all off
            self.state.update(spindle=self.off, mist=False, flood=False)
        elif move is not None and move.kind != "dwell":
            self.lit = move.kind != "rapid"
        new = dict(self.state)
        if self.machine.laser and not self.lit and new["spindle"] != self.off:
            new["s"] = 0                      # laser mode: no power outside G1/G2/G3
        if self._pins(new) == self._pins(self.shown):
            return None
        stop = not self.machine.laser or any(new[key] != self.shown[key]
                                             for key in ("spindle", "mist", "flood"))
        self.shown = new
        return new, stop

    @property
    def on(self):
        """The spindle or a coolant is on (the state set, whatever the pins show)."""
        return self.state["spindle"] != self.off or self.state["mist"] or self.state["flood"]


def tool_changes(events, machine, moves):
    """The tool states a program sets, for a board with tool outputs: ``(at, line, state,
    stop)`` for each place the state changes: before move ``at`` of ``moves`` (``len(moves)``:
    after the last), named by program ``line`` (``None`` for the last change a program that
    leaves anything on gets), ``state`` the keywords of
    :func:`kontur.hdl.motion.tools.tool_frame` (the changes between the same two moves are
    one), and ``stop`` whether the machine stops for it: :class:`ToolStates`' rules. A program
    that leaves the spindle or coolant on gets a last change turning them off (LinuxCNC's and
    Grbl's M2/M30)."""
    tools = ToolStates(machine)
    queue = sorted(((event.move, n, event) for n, event in enumerate(events)
                    if event.kind in ("spindle", "speed", "coolant")), key=lambda e: e[:2])
    out, taken = [], 0
    for at in range(len(moves) + 1):
        line = None
        while taken < len(queue) and queue[taken][0] <= at:
            event = queue[taken][2]
            taken += 1
            line = event.line
            tools.take(event)
        change = tools.change(moves[at] if at < len(moves) else None, end=at == len(moves))
        if change is None:
            continue
        if line is None:                      # a change of mode alone: the move's line
            line = moves[at].line if at < len(moves) else None
        out.append((at, line, *change))
    return out


def tool_stop(line, state, stop, position):
    """The segment of a tool change: of kind ``"dwell"``, of no time, at ``position`` (steps),
    whose payload's ``"tool"`` is ``state`` (its TOOL frame, :func:`kontur.planner.
    dwell_frames`) and ``"stop"`` whether the machine stops for it (:func:`kontur.planner.
    plan`)."""
    return Segment(line, "dwell", {"seconds": 0, "tool": state, "stop": stop}, position,
                   position, 0.0, [], None, None, None)


def tool_stops(segments, contours, moves, events, machine):
    """``segments`` and ``contours`` with a segment of kind ``"dwell"`` of no time for each
    tool change (:func:`tool_changes`), whose payload's ``"tool"`` is the state (its TOOL
    frame, :func:`kontur.planner.dwell_frames`) and ``"stop"`` whether the machine stops for it
    (:func:`kontur.planner.plan`), before the segments of the first move after the change (the
    change at the end: after the last). The controller takes it after the move before has
    ended, before the move after begins; inside a compensated contour, between two of the
    equidistant engine's elements (the contour's segments count it).
    """
    changes = tool_changes(events, machine, moves)
    segments, contours = list(segments), list(contours)
    for at, line, state, stop in reversed(changes):
        _insert_stop(segments, contours, moves[at] if at < len(moves) else None,
                     lambda position: tool_stop(segments[-1].line if line is None else line,
                                                state, stop, position))
    return segments, contours


def contour_dwells(segments, contours, moves, dwells):
    """``segments`` and ``contours`` with the dwells (G4) of ``dwells`` (``(index, move)``:
    the dwells inside compensated contours, taken out of ``moves`` before the contours were
    made, each before the move of ``moves`` at its index) put in as segments of kind
    ``"dwell"`` between the equidistant engine's elements, as :func:`tool_stops` puts a tool
    change."""
    segments, contours = list(segments), list(contours)
    for at, dwell in reversed(dwells):
        _insert_stop(segments, contours, moves[at] if at < len(moves) else None,
                     lambda position: Segment(dwell.line, "dwell", {"seconds": dwell.seconds},
                                              position, position, 0.0, [], None, None, dwell))
    return segments, contours


def _insert_stop(segments, contours, before, make):
    """Insert ``make(position)`` into ``segments`` before the segments of the move ``before``
    (``None``: at the end), where the machine is then; inside a compensated contour between two
    of its elements (the TOOL or DWELL frame's turn comes when the element before has ended
    on its equidistant, where LinuxCNC's compensated move before it ends; the engine holds the
    next element, already formed, until that turn is done): ``contours`` count it."""
    head = 1 if contours else 0                 # RADIUS heads a program with contours
    place = len(segments)
    if before is not None:
        place = next((i for i in range(head, len(segments))
                      if segments[i].line >= before.line), len(segments))
    for n, contour in enumerate(contours):
        if contour.first < place < contour.first + contour.count:
            contours[n] = replace(contour, count=contour.count + 1)
        elif contour.first >= place:
            contours[n] = replace(contour, first=contour.first + 1,
                                  approach=None if contour.approach is None
                                  else contour.approach + 1)
    position = segments[place - 1].end if place else segments[0].start
    segments.insert(place, make(position))


def check_travel(segments, machine, start):
    """Raise :exc:`ProgramError` at the first segment whose steps take the machine (from
    ``start``, steps) outside the machine file's travel (``travel_x``, ``travel_y``, on three
    axes ``travel_z``: the soft limits), naming its line, the point reached and the travel.
    Every step point is checked (the path on the lattice, a compensated contour's equidistant
    included), before anything moves."""
    spm = machine.steps_per_mm
    axes = (("X", machine.travel_x), ("Y", machine.travel_y), ("Z", machine.travel_z))
    limits = [(n, axis, travel) for n, (axis, travel) in enumerate(axes[:len(start)])
              if travel]
    if not limits:
        return
    bounds = [(n, axis, travel, math.ceil(travel[0] * spm - 1e-9),
               math.floor(travel[1] * spm + 1e-9)) for n, axis, travel in limits]
    position = list(start)
    for n, axis, travel, low, high in bounds:
        if not low <= position[n] <= high:
            raise ProgramError(segments[0].line if segments else None,
                               f"the program starts at {axis} {position[n] / spm:g} mm, beyond "
                               f"the machine's travel ({axis} from {travel[0]:g} to "
                               f"{travel[1]:g} mm, travel_{axis.lower()} in the machine file)")
    for segment in segments:
        for n, axis, travel, low, high in bounds:
            path = list(itertools.accumulate((step[n] for step in segment.steps),
                                             initial=position[n]))
            outside = [c for c in (min(path), max(path)) if not low <= c <= high]
            if outside:
                raise ProgramError(segment.line,
                                   f"the move reaches {axis} {outside[0] / spm:g} mm, beyond "
                                   f"the machine's travel ({axis} from {travel[0]:g} to "
                                   f"{travel[1]:g} mm, travel_{axis.lower()} in the machine "
                                   f"file): a soft limit")
        position = [c + sum(step[n] for step in segment.steps) for n, c in enumerate(position)]


def max_compress(job):
    """The largest time compression ``job`` can be run at, and what sets it: ``(n, reason)``.

    1. The step/dir timing: the fastest planned rate, ``n`` times, must not exceed the feed
       generator's highest rate (:attr:`~kontur.machine.Machine.max_rate`: one step every
       ``dir_setup + step_width + 1`` clocks, :attr:`~kontur.machine.Machine.
       max_step_rate`).
    2. The acceleration: ``n**2`` times the Q0.40 rate change must fit CONFIG's 32 bits.
    3. The link: the frames, at ``baud``, must arrive at least as fast as the motion, ``n``
       times faster, uses them (on average over the program).

    1 is always allowed (the machine's own time), whatever the link."""
    machine = job.machine
    fastest = max((item.cruise for item in job.items), default=0)
    limits = []
    if fastest:
        exact = machine.max_rate / (fastest * machine.steps_per_mm / machine.clock_hz
                                    * (1 << 24))
        n = max(1, math.floor(exact))
        while n > 1 and machine.rate(fastest * n) > machine.max_rate:
            n -= 1
        limits.append((n, f"the step/dir timing: the fastest planned feed, "
                          f"{fastest * 60:g} mm/min ({fastest * machine.steps_per_mm:.0f} "
                          f"steps/s), times it must stay within "
                          f"{machine.max_step_rate:.0f} steps/s"))
    limits.append((max(1, math.isqrt(((1 << 32) - 1) // machine.accel_q40)),
                   f"the acceleration: {machine.accel_q40} a clock (Q0.40) times its square "
                   f"must fit CONFIG's 32 bits"))
    link = job.link_seconds
    if link:
        limits.append((max(1, math.floor(job.seconds / link)),
                       f"the link: {link:.3f} s of frames at {machine.baud} baud for "
                       f"{job.seconds:.3f} s of machining"))
    return min(limits, key=lambda item: item[0])


def check_compress(job, compress):
    """Raise :exc:`kontur.trace.UsageError` (one line: the largest value allowed and what
    sets it) unless ``compress`` is a positive integer :func:`max_compress` allows."""
    from kontur.trace import UsageError
    if isinstance(compress, bool) or not isinstance(compress, int) or compress < 1:
        raise UsageError(f"--compress must be a positive integer, not {compress!r}")
    limit, reason = max_compress(job)
    if compress > limit:
        raise UsageError(f"--compress {compress}: this program allows at most {limit}, set by "
                         f"{reason}")


def auto_compress(job):
    """The time compression a simulation of ``job`` may use: a power of two that keeps the
    fastest planned step rate at most half what the step/dir timing allows, and the serial
    link at most half as busy as the motion (so that the queue does not run dry), and within
    :func:`max_compress`. 1 when the program is too fast for any."""
    machine = job.machine
    fastest = max((item.cruise for item in job.items), default=0) * machine.steps_per_mm
    by_rate = machine.max_step_rate / (2 * fastest) if fastest else 1
    link_seconds = job.link_seconds
    by_link = job.seconds / (2 * link_seconds) if link_seconds else 1
    limit = max(1, min(by_rate, by_link, max_compress(job)[0]))
    return 1 << int(math.floor(math.log2(limit)))


def _plan_times(job):
    """Each step's time (s from the start) under the feed plan (:func:`.planner.step_seconds`)."""
    times, now = [], 0.0
    for segment, item in zip(job.segments, job.items):
        if segment.kind == "dwell":
            now += item.seconds
            continue
        for seconds in step_seconds(segment, item, job.machine):
            now += seconds
            times.append(now)
    return times


def execute(job, engine="model", *, compress=None, vcd=None, vcd_clocks=None, build_root=None,
            progress=None, events=()):
    """Run ``job`` on ``engine`` (one of :data:`ENGINES`); return the :class:`Result`.

    ``compress`` is the time compression of an RTL run (default :func:`auto_compress`); it is
    checked on every engine, the model included (which times its steps by the plan, whatever
    the compression): more than :func:`max_compress` allows is refused. ``vcd``
    a path for the waveform (RTL engines; with ``vcd_clocks``, on Verilator, of the first
    that many clocks only); ``progress`` a callable taking the steps made so far,
    called now and then (Verilator, Amaranth). ``events``: ``(seconds, name)`` pairs
    (:data:`kontur.sim.models.motion.EVENTS`: the e-stop, the limits, UNLOCK) at that much
    machining time after the first step; the model (:func:`kontur.sim.models.motion.
    safety_run`) stops the program at the first trip, the RTL runs drive the switch pins and
    send the UNLOCKs then, and are checked against it (:func:`_check_events`).

    Raises
    ------
    RunError
        If the RTL's steps differ from the model's, a frame is not ``DONE``, the final
        position read back is not the program's end, or the run does not end in time.
    kontur.trace.UsageError
        For a ``compress`` beyond :func:`max_compress`, or a run whose planned clocks exceed
        :data:`MAX_CLOCKS` of the engine (before anything runs).
    """
    if engine not in ENGINES:
        raise ValueError(f"Engine must be one of {', '.join(ENGINES)}, not {engine!r}")
    if compress is not None:
        check_compress(job, compress)
    expected = job.steps
    events = list(events)
    if engine == "model":
        if vcd is not None:
            raise ValueError("a waveform comes from an RTL run, not the model")
        times = _plan_times(job)
        if not events:
            return Result("model", expected, times, job.end)
        model = safety_run(times, events, braking=_braking(job, times))
        steps = expected[:model["steps"]]
        end = _made(job.start, steps)
        return Result("model", steps, model["times"], end, final_state=model["state"],
                      alarm=model["alarm"], events=model["events"])
    from kontur.sim.testbench.hostlink import steps_of
    from kontur.hdl.motion.protocol import query
    compress = auto_compress(job) if compress is None else compress
    frames, _ = job.frames(compress)
    machine = job.machine
    divisor = round(machine.clock_hz / machine.baud)
    bound = MAX_CLOCKS[engine]
    held = sum(b[0] - a[0] for a, b in _hold_spans(events))      # the holds' time
    planned = (max([job.seconds] + [at for at, _ in events]) + held) / compress \
        * machine.clock_hz
    link = sum(len(f) for f in frames) * 10 * divisor
    if planned + link > bound:
        from kontur.trace import UsageError
        raise UsageError(f"this program takes about {planned + link:,.0f} clocks at a time "
                         f"compression of {compress}, more than the {bound:,} that --engine "
                         f"{engine} runs (about ten minutes)")
    max_clocks = int(min(bound, 2 * (planned + link) + 10 * machine.clock_hz / compress
                         + 1_000_000))
    controller = registry.make_controller(job.board, machine)
    model = safety_run(_plan_times(job), events, braking=_braking(job, _plan_times(job))) \
        if events else None
    schedule = _schedule(events, machine, compress, job=job,
                         held=model is not None and model["state"] == "HOLD")
    # The final position is read back after the program: the host sends a QUERY once every
    # frame before it is answered (and every event taken).
    sent = frames + [query()]
    started = time.monotonic()
    if engine == "verilator":
        from kontur.sim.fastrun import FastRun
        fast = FastRun(controller, _root(build_root, "fastrun"), waves=vcd is not None)
        started = time.monotonic()                      # the build apart
        run = fast.run(sent, divisor=divisor, window=machine.queue_frames,
                       max_clocks=max_clocks, vcd=vcd, vcd_clocks=vcd_clocks,
                       progress=progress, schedule=schedule)
    elif engine == "amaranth":
        from kontur.sim.testbench.hostlink import run_amaranth
        run = run_amaranth(controller, sent, divisor=divisor, window=machine.queue_frames,
                           max_clocks=max_clocks, vcd=vcd, progress=progress,
                           schedule=schedule)
    else:
        from kontur.sim.runners import CocotbBuild
        build = CocotbBuild(controller, engine, _root(build_root, "cocotb"),
                            waves=vcd is not None, quiet=True)
        started = time.monotonic()
        run = build.run_controller(sent, divisor=divisor, window=machine.queue_frames,
                                   max_clocks=max_clocks, vcd=vcd, schedule=schedule,
                                   idle=controller.idle_inputs)
    wall = time.monotonic() - started
    steps = steps_of(run, len(job.start))
    if model is not None and (model["stopped"] is not None or model["state"] == "HOLD"):
        slack = 1 if engine == "icarus" else 0        # cocotb drives the pins a clock later
        _check_events(job, run, steps, expected, model, machine.input_filter + 2 + slack)
    else:                                             # held and resumed, overridden: whole
        _check(job, run, steps, expected, len(frames), model)
    times = [clock * compress / machine.clock_hz for clock, _, _ in run.steps]
    first = times[0] if times else 0.0
    times = [t - first for t in times]
    pins = [(clock * compress / machine.clock_hz - first, word) for clock, word in run.tools] \
        if engine == "verilator" and tool_engine(controller) is not None else None
    status = [reply for _, reply in run.replies if reply.kind == 0x81][-1]
    from kontur.hdl.motion.protocol import input_names
    result = Result(engine, steps, times, status.position, compress,
                    run.clocks, wall, run.clocks / machine.clock_hz, final_state=status.state,
                    alarm=input_names(status.fields[5]), tool_pins=pins)
    if model is not None:
        base = run.steps[0][0] if run.steps else None
        result.events = [dict(taken, taken_at=(clock - base) * compress / machine.clock_hz
                              if base is not None else None)
                         for taken, (clock, _) in zip(model["events"], run.applied)]
    return result


def _schedule(events, machine, compress, *, job=None, held=False):
    """The switch pins and frames of ``events`` (``(seconds, name)``, machining time) as a
    host link's schedule: clocks after the first step at ``compress``, each pin event the
    whole pin word after it (:func:`kontur.hdl.motion.inputs.pin_levels`), UNLOCK, HOLD and
    RESUME frames, an OVERRIDE with all three overrides as they stand after it. With ``held`` (the
    run ends held: a hold never resumed) an ABORT follows the last event once the braking
    from twice the program's fastest feed is surely over (:func:`_brake_seconds`), ending
    the frames the hold keeps waiting (as an operator does), so that the run ends."""
    from kontur.hdl.motion import protocol
    from kontur.hdl.motion.inputs import pin_levels
    from kontur.sim.models.motion import event_kind
    schedule, pressed, overrides = [], set(), {"feed": 100, "rapid": 100, "spindle": 100}
    for at, name in sorted(events, key=lambda item: item[0]):
        offset = round(at * machine.clock_hz / compress)
        kind = event_kind(name)
        if kind[0] == "unlock":
            schedule.append((offset, ("unlock",)))
        elif kind[0] == "pins":
            _, switch, press = kind
            (pressed.add if press else pressed.discard)(switch)
            schedule.append((offset, ("pins", pin_levels(pressed, machine.polarity,
                                                         len(job.start) if job else 2))))
        elif kind[0] in ("hold", "resume"):
            schedule.append((offset, ("frame", getattr(protocol, kind[0])())))
        else:
            overrides[kind[0]] = kind[1]
            schedule.append((offset, ("frame", protocol.override(**overrides))))
    if held and schedule:
        last = max(at for at, _ in events)
        offset = round((last + _brake_seconds(job)) * machine.clock_hz / compress)
        schedule.append((offset, ("frame", protocol.abort())))
    return schedule


def _brake_seconds(job):
    """Seconds of machining within which a hold surely stands still: the braking from twice
    the fastest planned feed (the feed override's 200 %), and 10 ms more (the link's frames
    and the look-ahead)."""
    fastest = max((item.cruise for item in job.items), default=0.0)
    return 2 * fastest / job.machine.accel + 0.01


def _braking(job, times):
    """``braking(t)``: the steps a hold at time ``t`` of the plan makes before it stands
    still, about: the braking distance ``v² / 2a`` at the plan's speed there, in steps."""
    import bisect
    spm, a = job.machine.steps_per_mm, job.machine.accel

    def braking(t):
        i = bisect.bisect_right(times, t)
        if i == 0 or i >= len(times):
            return 0
        interval = times[i] - times[i - 1]
        speed = 1 / (spm * interval) if interval > 0 else 0.0       # mm/s, an axial step
        return math.ceil(speed * speed / (2 * a) * spm)
    return braking


def _hold_spans(events):
    """``((hold time, name), (resume time, name))`` of each hold resumed, in time order."""
    spans, hold = [], None
    for at, name in sorted(events, key=lambda item: item[0]):
        if name == "hold" and hold is None:
            hold = (at, name)
        elif name == "resume" and hold is not None:
            spans.append((hold, (at, name)))
            hold = None
    return spans


def _check_events(job, run, steps, expected, model, bound):
    """An RTL run with scripted events against the model (:func:`kontur.sim.models.motion.
    safety_run`): the steps made are the program's first ones, step for step; none rises
    later than ``bound`` clocks after the first trip's pin changed; every frame sent is
    answered, none ``DONE`` after one ``ABORTED``; each UNLOCK's STATUS and the last say
    ALARM where the model does, with its cause; the position read back is the steps made."""
    from kontur.hdl.motion.link import OUTCOME, STATUS
    from kontur.hdl.motion.protocol import input_names
    if steps != expected[:len(steps)]:
        at = next(i for i, (a, b) in enumerate(zip(steps, expected)) if a != b) \
            if len(steps) <= len(expected) else len(expected)
        raise RunError(f"the RTL's steps differ from the program's at step {at}")
    if model["stopped"] is not None:
        (trip,) = [clock for (clock, event), taken in zip(run.applied, model["events"])
                   if taken["at"] == model["stopped"] and event[0] == "pins"][:1]
        late = [clock for clock, _, _ in run.steps if clock > trip + bound]
        if late:
            raise RunError(f"a step rose {late[0] - trip} clocks after the trip's pin changed, "
                           f"more than the bound of {bound}")
    outcomes = [reply.fields[1] for _, reply in run.replies if reply.kind == OUTCOME]
    if 2 in outcomes and 0 in outcomes[outcomes.index(2):]:
        raise RunError("a frame ended DONE after one ended ABORTED")
    status = [reply for _, reply in run.replies if reply.kind == STATUS]
    unlocks = [taken for taken in model["events"] if taken["event"] == "unlock"]
    if len(status) != len(unlocks) + 1:
        raise RunError(f"{len(status)} STATUS replies, expected one for each of the "
                       f"{len(unlocks)} UNLOCKs and the last QUERY")
    for reply, taken in zip(status, unlocks + [{"alarm": model["state"] == "ALARM"}]):
        if (reply.state == "ALARM") != taken["alarm"]:
            raise RunError(f"the RTL reports {reply.state} where the model says "
                           f"{'ALARM' if taken['alarm'] else 'no ALARM'}")
    final = status[-1].fields
    position = status[-1].position
    if (status[-1].state == "HOLD") != (model["state"] == "HOLD"):
        raise RunError(f"the RTL ends in {status[-1].state}, the model in {model['state']}")
    if model["state"] == "ALARM" and input_names(final[5]) != model["alarm"]:
        raise RunError(f"the RTL's ALARM cause {input_names(final[5])} is not the model's "
                       f"{model['alarm']}")
    end = _made(job.start, steps)
    if position != end:
        raise RunError(f"the position read back, {position}, is not the steps made {end}")


def _made(start, steps):
    """Where ``steps`` take the machine from ``start`` (every axis of it)."""
    return tuple(c + sum(step[axis] for step in steps) for axis, c in enumerate(start))


def _check(job, run, steps, expected, count, model=None):
    """A run that makes the whole program (held and resumed, overridden, or without events)
    against the model: the same steps, every frame ``DONE``, no error, the position read back
    the program's end, and (with ``model``, :func:`kontur.sim.models.motion.safety_run`'s)
    the state the model ends in."""
    from kontur.hdl.motion.link import ERROR, OUTCOME, STATUS
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
    status = [reply.position for _, reply in run.replies if reply.kind == STATUS]
    if not status or status[-1] != tuple(job.end):
        raise RunError(f"the position read back, {status[-1] if status else None}, is "
                       f"not the program's end {tuple(job.end)}")
    final = [reply for _, reply in run.replies if reply.kind == STATUS][-1]
    if model is not None and final.state != model["state"]:
        raise RunError(f"the RTL ends in {final.state}, the model in {model['state']}")


def _root(build_root, what):
    from kontur.trace import build_root as default_root
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
    if move.full or move.turns > 1 or \
            sweep(start, p, centre, move.cw, full=False) <= move.sweep + 1e-12:
        return abs(math.hypot(p[0] - centre[0], p[1] - centre[1]) - radius)
    return min(math.hypot(p[0] - start[0], p[1] - start[1]),
               math.hypot(p[0] - end[0], p[1] - end[1]))


def deviation(job, steps):
    """The largest distance (mm) of a point the steps visit from the programmed contour: for
    each segment's points, from its program move (a line segment, or the programmed arc: its
    circle within its programmed sweep, its nearer end outside it, so a turn traced where a
    sliver was programmed is far from it); a compensated contour's, from its exact equidistant
    (the approach to it from its own line). On three axes this is the XY deviation (the
    steps' X and Y; Z is checked against rs274 in the tests), and an arc's in the XZ or YZ
    plane (G18, G19) in its own plane."""
    moves = {move.line: move for move in job.moves if move.kind != "dwell"}
    ids = {id(move) for move in job.moves}
    special = references(job)
    spm = job.machine.steps_per_mm
    worst = 0.0
    index = 0
    for number, segment in enumerate(job.segments):
        x, y = segment.start[:2]
        if segment.kind == "dwell":
            continue
        if number in special:
            measure = special[number] or (lambda p, a=segment.start, b=segment.end:
                                          _distance_to_segment(p, a, b) / spm)
            for dx, dy, *_ in steps[index:index + len(segment.steps)]:
                x, y = x + dx, y + dy
                worst = max(worst, measure((x, y)))
            index += len(segment.steps)
            continue
        # The move the segment comes from (several moves may share a line: G28, loops), as
        # long as it is one of the job's moves.
        move = segment.source if id(segment.source) in ids else moves[segment.line]
        start = tuple(float(c) for c in move.start)
        end = tuple(float(c) for c in move.end)
        if move.kind == "arc" and move.plane != 17:      # G18, G19: in the arc's plane
            first, second, _ = PLANE_AXES[move.plane]
            native, z = move.in_plane, segment.start[2]
            for dx, dy, dz in steps[index:index + len(segment.steps)]:
                x, y, z = x + dx, y + dy, z + dz
                p = (x / spm, y / spm, z / spm)
                worst = max(worst, _distance_to_arc((p[first], p[second]), native))
            index += len(segment.steps)
            continue
        for dx, dy, *_ in steps[index:index + len(segment.steps)]:
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
    """The feed (mm/min) at each step: its length over the time since the step before (NaN
    for none); an ``array('d')``, 8 bytes a step."""
    from array import array
    speeds, previous = array("d"), 0.0
    for step, t in zip(steps, times):
        interval = t - previous
        speeds.append(step_length(step) * 60 / spm / interval if interval > 0 else math.nan)
        previous = t
    return speeds


def summary(job, result):
    """The figures of a run, as a dict (``summary.json``)."""
    spm = job.machine.steps_per_mm
    steps = result.steps
    end = result.end
    moves = [move for move in job.moves if move.kind != "dwell"]
    dwells = [move for move in job.moves if move.kind == "dwell"]
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
        "diagonal_steps": sum(1 for step in steps if step[0] and step[1]),
        "axes": len(job.start),
        "machining_seconds": job.seconds,
        "max_deviation_mm": deviation(job, steps),
        "end_steps": list(end),
        "end_mm": [c / spm for c in end],
        "programmed_end_steps": list(job.end),
        "steps_per_mm": spm,
        "feeds_mm_min": sorted({round(float(m.feed), 3) for m in moves
                                if m.feed is not None and m.kind != "rapid"}),
        "planned_feeds_mm_min": sorted({round(planned_feed(m.feed, job.machine), 3)
                                        for m in moves
                                        if m.feed is not None and m.kind != "rapid"}),
        "link_limited": _link_limited(job),
        "compress": result.compress,
        "clocks": result.clocks,
        "simulated_seconds": result.simulated,
        "wall_seconds": result.wall,
        "clocks_per_second": (result.clocks / result.wall if result.clocks and result.wall
                              else None),
        "machine_seconds_traced": result.times[-1] if result.times else 0.0,
        "final_state": result.final_state,
        "alarm": list(result.alarm),
        "events": [dict(event) for event in result.events],
        "dwells": len(dwells),
        "dwell_seconds": float(sum(move.seconds for move in dwells)),
        "tool_events": [event.as_dict() for event in job.events if event.kind in TOOL_EVENTS],
        "tool_outputs": registry.board(job.board).tools,
        # The TOOL frames sent (a board with tool outputs): the state each sets, and its line.
        "tool_frames": [{"line": segment.line, **{key: value.name.lower() if key == "spindle"
                                                   else value for key, value in
                                                   segment.payload["tool"].items()}}
                        for segment in job.segments if "tool" in segment.payload],
        "pauses": [event.as_dict() for event in job.events if event.kind == "pause"],
        "messages": [event.as_dict() for event in job.events if event.kind == "message"],
    }
    if len(job.start) == 3:
        data["z_steps"] = sum(1 for step in steps if step[2])
        data["helices"] = sum(1 for s in job.segments if s.kind == "arc" and s.payload.get("z"))
        data["plane_arcs"] = {f"G{17 + plane}": sum(1 for s in job.segments if s.kind == "arc"
                                                    and s.payload.get("plane") == plane)
                              for plane in (1, 2)}
    if job.contours:
        data["cutter_radius_mm"] = float(job.contours[0].radius_mm)
        data["cutter_radius_steps"] = float(job.contours[0].radius)
        data["contours"] = [{
            "lines": list(contour.lines),
            "radius_mm": float(contour.radius_mm),
            "radius_steps": float(contour.radius),
            "radius_from": contour.radius_from,
            "side": contour.prepared.profile.side,
            "closed": contour.prepared.closed,
            "profile_frames": len(contour.prepared.frames) - (1 if number else 0),
            "steps": sum(len(s.steps) for s in job.segments[contour.first:contour.first
                                                            + contour.count]),
        } for number, contour in enumerate(job.contours)]
    return data


def _link_limited(job):
    """The moves the link holds below their feed (:func:`kontur.planner.link_feed`): how many
    of how many, the lowest such bound (mm/min), the baud; ``None`` if none."""
    moves = [s for s in job.segments if s.kind != "dwell" and s.length]
    bounds = [(link_feed(s, job.machine) * 60, planned_feed(s.feed * 60, job.machine))
              for s in moves]
    bounds = [bound for bound, feed in bounds if bound < feed]
    if not bounds:
        return None
    return {"moves": len(bounds), "of": len(moves), "lowest_mm_min": min(bounds),
            "baud": job.machine.baud}


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
    if data.get("link_limited"):
        held = data["link_limited"]
        lines.append(f"link       {held['moves']} of {held['of']} moves slower than their feed, "
                     f"down to {held['lowest_mm_min']:.0f} mm/min: a move takes at least "
                     f"{LINK_MARGIN:g} times its frames' time at {held['baud']} baud (a higher "
                     f"baud in the machine file lifts it)")
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
                     f"engine, cutter radius {contour['radius_mm']:g} mm "
                     f"({contour['radius_steps']} steps, {contour['radius_from']}), "
                     f"{contour['steps']} steps")
    if data.get("axes") == 3:
        planes = ", ".join(f"{count} in {'XZ (G18)' if plane == 'G18' else 'YZ (G19)'}"
                           for plane, count in data.get("plane_arcs", {}).items() if count)
        helices = f"{data['helices']} helix" if data["helices"] == 1 else \
            f"{data['helices']} helices"
        lines.append(f"z          {data['z_steps']} steps move Z, {helices} "
                     f"(HELIX frames: the normal axis spread over the arc's steps)"
                     + (f"; arcs {planes}" if planes else ""))
    if data.get("dwells"):
        lines.append(f"dwells     {data['dwells']} (G4, and the P of G82, G89), "
                     f"{data['dwell_seconds']:g} s, as DWELL frames")
    if data.get("tool_events"):
        driven = data.get("tool_frames")
        lines.append(f"tools      {len(data['tool_events'])} tool events ("
                     + (f"{len(driven)} TOOL frames to the tool outputs" if driven else
                        "no TOOL frame: none switches the tool outputs"
                        if data.get("tool_outputs", True) else
                        "not driven: the controller has no tool outputs") + "): "
                     + ", ".join(f"{e['text']} (line {e['line']})"
                                 for e in data["tool_events"][:6])
                     + (", ..." if len(data["tool_events"]) > 6 else ""))
    for pause in data.get("pauses", ()):
        lines.append(f"pause      line {pause['line']}: {pause['text']}, resumed at once (a "
                     f"simulated operator)")
    lines += [
        f"deviation  {data['max_deviation_mm']:.4f} mm at most from the programmed contour"
        + (" (a compensated one's: from its equidistant)" if data.get("contours") else "")
        + (" in XY" if data.get("axes") == 3 else "")
        + (" (an arc in XZ or YZ: in its plane)" if any(data.get("plane_arcs", {}).values())
           else ""),
        f"end        ({', '.join(f'{c:.4f}' for c in data['end_mm'])}) mm = "
        f"({', '.join(str(c) for c in data['end_steps'])}) steps"
        + (", the programmed end" if data["end_steps"] == data["programmed_end_steps"]
           else f", stopped short of the programmed end {tuple(data['programmed_end_steps'])}"
           if any(e["alarm"] or e.get("hold") for e in data.get("events", ()))
           else f", NOT the programmed end {tuple(data['programmed_end_steps'])}"),
    ]
    for event in data.get("events", ()):
        taken = event.get("taken_at")
        lines.append(f"event      {event['event']} at {event['at']:g} s"
                     + (f" (taken at {taken:.6f} s)" if taken is not None else "")
                     + (": ALARM" if event["alarm"] else ": HOLD" if event.get("hold")
                        else ": no ALARM"))
    lines.append(f"state      {data['final_state']}"
                 + (f" (tripped: {', '.join(data['alarm'])})" if data.get("alarm") else ""))
    if data["engine"] != "model" and data.get("events") and \
            data["end_steps"] == data["programmed_end_steps"]:
        lines.append("checked    the RTL's steps equal the model's (held, resumed or "
                     "overridden: only the timing differs), every frame DONE, the state and "
                     "the position read back")
    elif data["engine"] != "model" and data.get("events"):
        lines.append("checked    the RTL's steps are the program's first ones, none after the "
                     "stop bound, the state and the position read back as the model's")
    elif data["engine"] != "model":
        lines.append("checked    the RTL's steps equal the model's, every frame DONE, the "
                     "position read back")
    if out_dir is not None:
        lines.append(f"outputs    {out_dir}/")
    return "\n".join(lines) + "\n"


def staging_dir(out_dir):
    """A fresh, empty folder beside ``out_dir`` (``.<name>.<random>.tmp`` in its parent, made
    here with its parents) for a run's outputs to be written into, then moved into place by
    :func:`write_outputs`: two runs into one ``out_dir`` never mix their files.

    Raises
    ------
    OSError
        When the parent cannot be made or written to (before anything runs)."""
    import uuid
    out_dir = Path(out_dir)
    for folder in (out_dir, *out_dir.parents):
        if folder.exists() and not folder.is_dir():
            raise NotADirectoryError(20, f"{folder} is not a directory", str(folder))
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    staging = out_dir.parent / f".{out_dir.name}.{uuid.uuid4().hex}.tmp"
    staging.mkdir()                          # the umask's mode, as the folder it replaces
    return staging


def _move_into_place(staging, out_dir):
    """Put the folder ``staging`` where ``out_dir`` is: a rename, the old ``out_dir`` (if
    any) renamed aside first and removed after; retried when another run swaps at once."""
    import shutil
    import uuid
    while True:
        try:
            staging.replace(out_dir)        # an empty or missing out_dir: one rename
            return
        except OSError:
            if not out_dir.is_dir():
                if out_dir.exists():
                    raise
                continue                    # another run has just moved it aside
        aside = out_dir.with_name(f".{out_dir.name}.{uuid.uuid4().hex[:8]}.old")
        try:
            out_dir.replace(aside)
        except FileNotFoundError:
            continue
        try:
            staging.replace(out_dir)
        except OSError:
            continue
        finally:
            shutil.rmtree(aside, ignore_errors=True)
        return


def write_outputs(job, result, out_dir, *, staging=None, plot=True, extra=None):
    """Write ``steps.txt``, ``toolpath.png`` (unless ``plot`` is false: ``kontur serve``
    rewrites its outputs after every run of motion) and ``summary.json`` (with the keys of
    ``extra`` added) into ``out_dir``; return the summary dict.

    The files are written into ``staging`` (default a fresh :func:`staging_dir`; the run's
    waveform may already be there), and that folder then replaces ``out_dir`` whole: its
    earlier contents are gone, and a run never mixes its files with another's."""
    out_dir = Path(out_dir)
    staging = staging_dir(out_dir) if staging is None else Path(staging)
    lines = {(dx, dy): f"{dx} {dy}\n" for dx in (-1, 0, 1) for dy in (-1, 0, 1)}
    lines |= {(dx, dy, dz): f"{dx} {dy} {dz}\n" for dx in (-1, 0, 1) for dy in (-1, 0, 1)
              for dz in (-1, 0, 1)}
    with open(staging / "steps.txt", "w") as handle:
        handle.writelines(map(lines.__getitem__, result.steps))
    data = summary(job, result)
    data.update(extra or {})
    if plot:
        from kontur.plot import plot_toolpath
        plot_toolpath(job, result.steps, _speeds(result.steps, result.times,
                                                 job.machine.steps_per_mm),
                      staging / "toolpath.png",
                      title=f"{job.name}: {len(result.steps)} steps, {result.engine}")
    (staging / "summary.json").write_text(json.dumps(data, indent=2) + "\n")
    _move_into_place(staging, out_dir)
    return data
