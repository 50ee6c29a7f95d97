"""The host's side of the serial link, clock by clock: what a PC does for the controller.

:class:`HostLink` is the testbench's half of a machine-controller run, written once for every
simulator that is driven from Python (Amaranth's simulator, cocotb on Icarus or Verilator);
``sim/fastrun.cpp`` is the same thing in C++ for Verilator at full speed. Each clock it is
given the controller's ``tx`` and step/dir pins and returns the level for ``rx``: it sends the
frames 8N1 at ``divisor`` clocks a bit, keeping at most ``window`` queued frames unanswered
(the protocol's flow control: a queued frame is answered by an ``OUTCOME``, or an ``ERROR``
when it was dropped), parses the replies off ``tx`` and records every rising step edge. A run
is over (:attr:`HostLink.done`) when every frame is sent and answered and the line has been
quiet for 64 bit times.

Its record is the one ``fastrun`` writes (:class:`Run`, :func:`parse_events`): ``S clock step
dir`` at each rising step edge, ``R clock type payload`` for each reply, ``A clock P word``,
``A clock U`` or ``A clock F hex`` for each scheduled event applied, ``T clock word`` at each
change of the tool pins (``fastrun`` only), ``E clock`` at the end.

**Scheduled events** (``schedule``, :func:`write_schedule`): the switch pins and UNLOCK frames
at given clocks after the first step (machining time: the first rising step edge is its
zero; if before any step every frame sent is answered and a QUERY is next, that clock is).
``("pins", word)`` sets the controller's :py:`inputs` to ``word`` in that clock (sampled at
its end); ``("unlock",)`` sends an UNLOCK then (after the bytes being sent), ``("frame",
bytes)`` any immediate frame (HOLD, RESUME, OVERRIDE, QUERY, ABORT) so. With a schedule the host behaves as a host
that stops a stream the machine has stopped: after an outcome other than ``DONE`` or an
``ERROR`` it sends no more queued frames (those in flight are answered ``ABORTED``, or
``REFUSED`` when they reach the machine in ALARM), and a
``QUERY`` waits for every event too, so the last one reads the state after them.
"""

import struct
from dataclasses import dataclass, field

from kontur.hdl.motion.link import ABORT, ERROR, OUTCOME, QUERY, UNLOCK

from kontur.hdl.motion.protocol import Reply, ReplyParser, parse_reply, unlock
from kontur.sim.processes import SimulatorError

__all__ = ["Run", "HostLink", "parse_events", "format_events", "steps_of", "run_amaranth",
           "run_cocotb", "read_frames", "write_frames", "write_schedule", "read_schedule"]


@dataclass
class Run:
    """What a run gave: ``steps`` ``(clock, step bits, dir bits)`` at each rising step edge,
    ``replies`` ``(clock, Reply)`` (:class:`kontur.hdl.motion.protocol.Reply`), the clocks simulated
    and the seconds it took (a build apart); ``applied``: ``(clock, event)`` for each scheduled
    event, when it was applied; ``tools``: ``(clock, word)`` at each change of the tool
    pins (a controller with tool outputs on ``fastrun``: bit n the n-th of
    :data:`kontur.hdl.motion.tools.TOOL_PINS`, all low before the first)."""
    steps: list
    replies: list
    clocks: int
    seconds: float = 0.0
    applied: list = field(default_factory=list)
    tools: list = field(default_factory=list)


def parse_events(text, applied=None, tools=None):
    """The ``(steps, replies, clocks)`` of an events file (the events applied appended to
    ``applied``, a list, if given; the tool pins' changes, ``T clock word``, to ``tools``)."""
    steps, replies, clocks = [], [], 0
    for line in text.splitlines():
        kind, *fields = line.split()
        if kind == "A" and applied is not None:
            applied.append((int(fields[0]), _event(fields[1:])))
        elif kind == "T" and tools is not None:
            tools.append((int(fields[0]), int(fields[1])))
        elif kind == "S":
            steps.append(tuple(int(f) for f in fields))
        elif kind == "R":
            reply_kind = int(fields[1], 16)
            payload = bytes(int(f, 16) for f in fields[2:])
            replies.append((int(fields[0]), parse_reply(reply_kind, payload)))
        elif kind == "E":
            clocks = int(fields[0])
    return steps, replies, clocks


def _event(fields):
    """A scheduled event from its fields in a file: ``P word``, ``U``, ``F hex``."""
    if fields[0] == "P":
        return ("pins", int(fields[1]))
    if fields[0] == "F":
        return ("frame", bytes.fromhex(fields[1]))
    return ("unlock",)


def _event_text(event):
    if event[0] == "pins":
        return f"P {event[1]}"
    if event[0] == "frame":
        return f"F {bytes(event[1]).hex()}"
    return "U"


def format_events(run):
    """The text of an events file for ``run`` (the inverse of :func:`parse_events`)."""
    lines = [f"S {clock} {step} {direction}" for clock, step, direction in run.steps]
    lines += [f"R {clock} {reply.kind:02x}" + "".join(f" {b:02x}" for b in reply.payload())
              for clock, reply in run.replies]
    lines += [f"A {clock} {_event_text(event)}" for clock, event in run.applied]
    lines += [f"T {clock} {word}" for clock, word in run.tools]
    lines.append(f"E {run.clocks}")
    return "\n".join(lines) + "\n"


def write_schedule(path, schedule, idle):
    """Write a schedule (``(offset, event)`` pairs) as ``fastrun`` reads it: ``I word`` (the
    pins before any event), then ``offset P word``, ``offset U`` or ``offset F hex`` (a
    frame's bytes) a line."""
    from pathlib import Path
    lines = [f"I {idle}"] + [f"{offset} {_event_text(event)}" for offset, event in schedule]
    Path(path).write_text("\n".join(lines) + "\n")


def read_schedule(path):
    """``(schedule, idle)`` of a file written by :func:`write_schedule`."""
    from pathlib import Path
    schedule, idle = [], 0
    for line in Path(path).read_text().splitlines():
        fields = line.split()
        if fields[0] == "I":
            idle = int(fields[1])
        else:
            schedule.append((int(fields[0]), _event(fields[1:])))
    return schedule, idle


def steps_of(run, axes=2):
    """The ``(dx, dy)`` of every step of a run, in order (a step pin's rising edge, its
    direction pin: 1 is negative); ``(dx, dy, dz)`` with ``axes=3``."""
    moves = []
    for _, rising, direction in run.steps:
        moves.append(tuple((-1 if direction >> axis & 1 else 1) if rising >> axis & 1 else 0
                           for axis in range(axes)))
    return moves


class HostLink:
    """A host on the controller's serial line (see the module's text).

    Parameters
    ----------
    frames : list of bytes
        The frames, in order.
    divisor : int
        Clocks a bit.
    window : int
        Queued frames the host may have unanswered (the controller's queue length).
    inject : dict
        ``{clock: bytes}``: bytes put on the line at those clocks besides the frames (line
        noise, a frame out of turn).
    schedule : list
        ``(offset, event)`` pairs: events at ``offset`` clocks after the first step (see the
        module's text).
    idle : int
        The switch pins' word before any event (:attr:`pins`).

    A ``QUERY`` among the frames is sent once every frame before it is answered (it asks for
    the position after them); an ``ABORT`` goes at once.
    """

    def __init__(self, frames, *, divisor, window, inject=None, schedule=(), idle=0):
        self.frames = list(frames)
        self.schedule = sorted(schedule, key=lambda item: item[0])
        self.scheduled = bool(self.schedule)
        self.pins = idle
        self.applied = []
        self._base = None                  # machining time's zero: the first step's clock
        self.divisor = divisor
        self.window = window
        self.inject = dict(inject or {})
        self.clock = 0
        self.steps, self.replies = [], []
        self.outstanding = 0
        self.sent = self.answered = 0
        self._levels = []
        self._parser = ReplyParser()
        self._rx_state, self._rx_timer, self._rx_bits = "idle", 0, []
        self._previous_step = 0
        self._quiet = 0

    def _bits(self, data):
        levels = []
        for byte in data:
            for bit in [0] + [(byte >> i) & 1 for i in range(8)] + [1]:
                levels += [bit] * self.divisor
        return levels

    def cycle(self, *, tx, step, direction):
        """One clock: the controller's pins now; returns the level of ``rx`` for the next
        clock."""
        # ---- the pins ------------------------------------------------------------------
        rising = step & ~self._previous_step
        if rising:
            self.steps.append((self.clock, rising, direction))
            if self._base is None:
                self._base = self.clock
        self._previous_step = step
        # ---- machine to host: the middle of each bit of tx -----------------------------
        if self._rx_state == "idle":
            if not tx:
                self._rx_state, self._rx_timer, self._rx_bits = "bits", self.divisor + \
                    self.divisor // 2, []
        else:
            self._rx_timer -= 1
            if self._rx_timer == 0:
                self._rx_bits.append(tx)
                self._rx_timer = self.divisor
                if len(self._rx_bits) == 9:                # 8 data bits and the stop bit
                    byte = sum(b << i for i, b in enumerate(self._rx_bits[:8]))
                    for reply in self._parser.feed(bytes([byte])):
                        self.replies.append((self.clock, reply))
                        if reply.kind in (OUTCOME, ERROR):
                            self.outstanding -= 1
                            self.answered += 1
                            if self.scheduled and (reply.kind == ERROR or reply.fields[1]):
                                # The machine stopped the stream: send no more of it.
                                self.frames = [f for f in self.frames if f[1] == QUERY]
                    self._rx_state = "idle"
        # ---- the schedule: machining time counts from the first step ----------------------
        if self._base is None and self.answered == self.sent and \
                (not self.frames or self.frames[0][1] == QUERY):
            self._base = self.clock                    # no step, and the host waits to ask
        while self.schedule and self._base is not None and \
                self.clock >= self._base + self.schedule[0][0]:
            _, event = self.schedule.pop(0)
            self.applied.append((self.clock, event))
            if event[0] == "pins":
                self.pins = event[1]
            elif event[0] == "frame":
                self._levels += self._bits(event[1])
            else:
                self._levels += self._bits(unlock())
        # ---- host to machine: the next frame once the window allows it -----------------
        if not self._levels and self.frames:
            kind = self.frames[0][1]
            queued = kind not in (QUERY, ABORT)
            if (self.outstanding < self.window if queued else
                    kind == ABORT or self.answered == self.sent and not self.schedule):
                frame = self.frames.pop(0)
                self.outstanding += queued
                self.sent += queued
                self._levels = self._bits(frame)
        if self.clock in self.inject:
            self._levels += self._bits(self.inject.pop(self.clock))
        level = self._levels.pop(0) if self._levels else 1
        busy = self.frames or self._levels or self.inject or self.answered < self.sent or \
            self._rx_state != "idle" or self.schedule
        self._quiet = 0 if busy else self._quiet + 1
        self.clock += 1
        return level

    @property
    def done(self):
        """Everything sent and answered, and the line quiet for 64 bit times."""
        return self._quiet >= 64 * self.divisor

    def run(self, seconds=0.0):
        """The :class:`Run` recorded so far."""
        return Run(list(self.steps), list(self.replies), self.clock, seconds,
                   list(self.applied))


def run_amaranth(controller, frames, *, divisor, window, max_clocks, inject=None, vcd=None,
                 levels=None, progress=None, schedule=(), each=None):
    """Run ``frames`` through ``controller`` (a
    :class:`~kontur.hdl.motion.controller.MotionController`) in Amaranth's simulator with a
    :class:`HostLink`; return the :class:`Run`. With ``levels`` (a list), every clock's
    ``(step, dir)`` is appended to it. ``schedule``: events on the switch pins
    (:class:`HostLink`), from the controller's idle pins. ``each``, if given, is called
    ``each(ctx, clock)`` in every clock before the edge (to compare insides with a model).

    Raises :exc:`kontur.sim.processes.SimulatorError` if the run does not end within ``max_clocks``.
    """
    import time

    from amaranth.sim import Simulator


    host = HostLink(frames, divisor=divisor, window=window, inject=inject, schedule=schedule,
                    idle=controller.idle_inputs)

    async def testbench(ctx):
        for clock in range(max_clocks):
            if progress is not None and clock % 4096 == 0:
                progress(len(host.steps))
            step, direction = ctx.get(controller.motion.step), ctx.get(controller.motion.dir)
            if levels is not None:
                levels.append((step, direction))
            ctx.set(controller.rx, host.cycle(tx=ctx.get(controller.tx), step=step,
                                              direction=direction))
            ctx.set(controller.inputs, host.pins)
            if each is not None:
                each(ctx, clock)
            if host.done:
                return
            await ctx.tick()

    sim = Simulator(controller)
    sim.add_clock(1e-6)
    sim.add_testbench(testbench)
    started = time.monotonic()
    if vcd:
        with sim.write_vcd(str(vcd)):
            sim.run()
    else:
        sim.run()
    if not host.done:
        raise SimulatorError(f"the program did not end within {max_clocks} clocks")
    return host.run(time.monotonic() - started)


async def run_cocotb(dut, frames, *, divisor, window, max_clocks, inject=None, levels=None,
                     schedule=(), idle=None):
    """:func:`run_amaranth` on a cocotb ``dut`` (the controller's Verilog: ports ``clk``,
    ``rst``, ``rx``, ``tx``, ``inputs``, ``motion__step``, ``motion__dir``): start its clock,
    reset it, run a :class:`HostLink` (its switch pins from ``idle``, default the default
    polarity's idle word); return the :class:`Run` (:exc:`AssertionError` if it does not end
    within ``max_clocks``)."""
    from kontur.hdl.motion.inputs import idle_pins
    import time

    from cocotb.clock import Clock
    from cocotb.triggers import ReadOnly, RisingEdge

    Clock(dut.clk, 1, unit="us").start(start_high=False)
    idle = idle_pins() if idle is None else idle
    dut.rst.value = 1
    dut.rx.value = 1
    dut.inputs.value = idle
    for _ in range(4):
        await RisingEdge(dut.clk)
    dut.rst.value = 0
    host = HostLink(frames, divisor=divisor, window=window, inject=inject, schedule=schedule,
                    idle=idle)
    inputs_pin = dut.inputs
    started = time.monotonic()
    step_pin, dir_pin, tx_pin, rx_pin = dut.motion__step, dut.motion__dir, dut.tx, dut.rx
    level, driven = 1, (1, idle)
    for _ in range(max_clocks):
        await RisingEdge(dut.clk)
        if (level, host.pins) != driven:    # (a write is a simulator call: none if unchanged)
            driven = level, host.pins
            rx_pin.value = level            # applied after this edge: sampled at the next
            inputs_pin.value = host.pins
        await ReadOnly()
        step, direction = int(step_pin.value), int(dir_pin.value)
        if levels is not None:
            levels.append((step, direction))
        level = host.cycle(tx=int(tx_pin.value), step=step, direction=direction)
        if host.done:
            return host.run(time.monotonic() - started)
    raise AssertionError(f"the program did not end within {max_clocks} clocks")


def write_frames(path, frames):
    """Write ``frames`` to ``path`` as ``fastrun`` reads them: a 16-bit little-endian length,
    then the bytes, for each."""
    from pathlib import Path
    Path(path).write_bytes(b"".join(len(f).to_bytes(2, "little") + bytes(f) for f in frames))


def read_frames(path):
    """The frames of a file written by :func:`write_frames`."""
    from pathlib import Path
    data, frames, at = Path(path).read_bytes(), [], 0
    while at < len(data):
        size = int.from_bytes(data[at:at + 2], "little")
        frames.append(data[at + 2:at + 2 + size])
        at += 2 + size
    return frames
