"""Tool outputs: spindle (laser, torch) enable, direction and PWM, coolant (issue 28).

:class:`ToolOutputs` holds the tool state the controller hands it between moves (M3/M4/M5 with
S, M7/M8/M9) and drives the pins: ``enable``, ``direction`` (M4), ``pwm`` (duty S/s_max at a
fixed period), ``mist``, ``flood``. In Grbl's laser mode (``$32``, :py:`laser`) with M4 the
duty follows the feed: S/s_max × rate/cruise, worked out once a PWM period by a sequential
multiply-divide (:class:`ToolOutputs`' notes), so that a corner where the feed drops does not
burn.

:class:`ToolEngine` puts them in the controller: a row of its engine table (frame type
:data:`TOOL`, turn :data:`TOOL_UNIT`) whose TOOL frames take effect in their turn, when every
frame before them has ended and before any after them begins: between moves, never while the
move before still runs (docs/tools.md).
"""

import struct

from amaranth import *
from amaranth.lib import data, enum, stream, wiring
from amaranth.lib.wiring import In, Out

from ..engine import EngineSignature, Outcome, StatusUnit
from .dispatch import EngineUnit, raw_bits
from .feed import OVERRIDE_ONE              # the spindle override's unit too (Q2.7)
from .link import SYNC, profile_bytes
from .protocol import crc

__all__ = ["Spindle", "ToolCommand", "ToolOutputs", "pwm_period", "min_period", "TOOL",
           "TOOL_UNIT", "ToolFrame", "ToolEngine", "tool_row", "connect_tools", "tool_frame",
           "TOOL_PINS", "tool_engine"]

#: The TOOL frame's type and the tool engine's turn number (the built-in rows use 1 to 4,
#: homing 5).
TOOL, TOOL_UNIT = 0x1B, 7

#: The tool engine's pins, in the order of the boards' ``tool`` resource.
TOOL_PINS = ("enable", "direction", "pwm", "mist", "flood")


class Spindle(enum.Enum, shape=2):
    """The spindle's (laser's, torch's) command: M5, M3, M4."""
    OFF = 0
    CW = 1          # M3: clockwise; in laser mode constant power
    CCW = 2         # M4: counter-clockwise; in laser mode power following the feed


def ToolCommand(s_max):
    """The tool state one command sets, whole: spindle, S (0 to ``s_max``; above it is taken as
    ``s_max``, as Grbl clamps it), mist (M7) and flood (M8); M9 is both off."""
    return data.StructLayout({"spindle": Spindle, "s": range(s_max + 1), "mist": 1,
                              "flood": 1})


def pwm_period(clock_hz, pwm_hz):
    """The PWM period in clocks, ``clock_hz / pwm_hz`` rounded."""
    if not pwm_hz > 0:
        raise ValueError(f"PWM frequency must be above 0 Hz, not {pwm_hz!r}")
    return round(clock_hz / pwm_hz)


def min_period(period):
    """The shortest PWM period the sequential multiply-divide fits in: two passes of
    ``3 × (bits + 1)`` clocks, ``bits`` the period's bit length, and two clocks of margin."""
    return 6 * (period.bit_length() + 1) + 2


class ToolOutputs(wiring.Component):
    """The tool outputs, set by commands between moves.

    **PWM.** A counter runs through ``period`` clocks again and again; :py:`pwm` is high in the
    first ``duty`` clocks of a period, while the spindle is on. The duty is worked out during
    a period, from the state at its first clock, and taken at its last: so a duty changes
    only at a period's boundary, and a pulse always begins at one (no partial pulse when the
    spindle turns on: the first full period after a computation begun with the spindle on).
    Turning off is at once: M5 from the clock after it, :py:`halt` in its own clock.

    **Duty.** ``round(S × period / s_max)``; in laser mode (:py:`laser`) with M4
    ``round(round(period × min(rate, cruise) / cruise) × S / s_max)``, within one count of
    the exact S/s_max × rate/cruise × period (each rounding is half a count at most, the first
    scaled by S/s_max ≤ 1); 0 at a standstill (rate 0). The rate is taken at the period's
    first clock and its duty used in the next period. Both are ``round(a × b / c)`` with
    ``b ≤ c`` (a rate at or above the cruise is found by the first bit's first subtraction,
    ``rate ≥ cruise``, and the rate pass's result is then the period), by one sequential
    datapath, a bit of ``a`` (high first) every three clocks:
    ``r ← 2r + bit·b`` (``q ← 2q``), then twice ``r ← r - c`` (``q ← q + 1``) where
    ``r ≥ c``; a last step ``r ← 2r``, ``q ← q + 1`` where ``r ≥ c``, rounds. A 26-bit
    remainder and one adder: no multiplier and no divider in one clock (a
    24 × 24 product and its quotient would be hundreds of cells and a long path), and the
    result exact, where a fractional rate/cruise or a PWM compare against rate-scaled
    counters would need the same product at every clock.

    **Spindle override.** With ``spindle_override`` built, S in the duty is the commanded S
    times the factor on :py:`spindle_override` (Q2.7, Grbl's spindle override: 128 is
    100 %), rounded, and at most ``s_max`` (as Grbl clamps it at ``$30``):
    ``min((S × factor + 64) >> 7, s_max)``, worked out in the clock it is used from the S
    register and the factor then (a product of S's width by 9 bits: a multiplier block on
    the ECP5, and on the UP5K with ``synth_ice40 -dsp``, the builds' option). A new factor
    thus takes effect, like a new S, at the next period's duty.

    **Halt.** :py:`halt` drops every output in its own clock and clears the state: the
    outputs stay off until the next command.

    Parameters
    ----------
    s_max : :class:`int`
        The S of full power (the machine file's ``s_max``, Grbl's ``$30``), 1 to 2**24 - 1.
    period : :class:`int`
        The PWM period in clocks (:func:`pwm_period` of the clock and the machine file's
        ``pwm_hz``), at least :func:`min_period`.
    laser_mode : :class:`bool`
        With ``False`` the laser mode is not built: :py:`laser`, :py:`rate` and :py:`cruise`
        are ignored (M4 is S alone), and the datapath is as wide as ``s_max``, not 24 bits (for
        a device too small for it).
    spindle_override : :class:`bool`
        With ``False`` the spindle override is not built: :py:`spindle_override` is ignored
        (S as commanded).

    Members
    -------
    cmd : :py:`In(stream.Signature(ToolCommand(s_max)))`
        A command, taken in any clock but those of :py:`halt` (``ready`` is its inverse).
    spindle_override : :py:`In(9, init=128)`
        The spindle override, Q2.7 (128 is 100 %).
    laser : :py:`In(1)`
        Laser mode (Grbl's ``$32``).
    rate, cruise : :py:`In(24)`
        The feed generator's rate and the running move's cruise rate, Q0.24.
    halt : :py:`In(1)`
        E-stop or alarm: every output off in this clock, the state cleared.
    enable, direction, pwm, mist, flood : :py:`Out(1)`
        The pins: spindle on, M4, PWM, coolant mist (M7), flood (M8).
    """

    def __init__(self, *, s_max, period, laser_mode=True, spindle_override=True):
        if isinstance(s_max, bool) or not isinstance(s_max, int) or not 1 <= s_max < 1 << 24:
            raise TypeError(f"S of full power must be an integer from 1 to 2**24 - 1, not "
                            f"{s_max!r}")
        if isinstance(period, bool) or not isinstance(period, int):
            raise TypeError(f"PWM period must be an integer (clocks), not {period!r}")
        if period < min_period(period):
            raise ValueError(f"PWM period must be at least {min_period(period)} clocks (its "
                             f"duty's computation), not {period}")
        if not isinstance(laser_mode, bool):
            raise TypeError(f"Laser mode must be True or False, not {laser_mode!r}")
        if not isinstance(spindle_override, bool):
            raise TypeError(f"Spindle override must be True or False, not "
                            f"{spindle_override!r}")
        self._s_max, self._period, self._laser_mode = s_max, period, laser_mode
        self._spindle_override = spindle_override
        super().__init__({
            "cmd":       In(stream.Signature(ToolCommand(s_max))),
            "spindle_override": In(9, init=OVERRIDE_ONE),
            "laser":     In(1),
            "rate":      In(24),
            "cruise":    In(24),
            "halt":      In(1),
            "enable":    Out(1),
            "direction": Out(1),
            "pwm":       Out(1),
            "mist":      Out(1),
            "flood":     Out(1),
        })

    @property
    def s_max(self):
        return self._s_max

    @property
    def period(self):
        return self._period

    @property
    def laser_mode(self):
        return self._laser_mode

    def elaborate(self, platform):
        m = Module()
        enable, direction, mist, flood = Signal(), Signal(), Signal(), Signal()
        s = Signal(range(self._s_max + 1))
        count = Signal(range(self._period))
        duty = Signal(range(self._period + 1))
        first, last = count == 0, count == self._period - 1
        m.d.sync += count.eq(Mux(last, 0, count + 1))

        # The state: a command sets it whole; halt clears it.
        off = Signal()                          # the spindle turns off in this clock
        c = self.cmd.payload
        m.d.comb += self.cmd.ready.eq(~self.halt)
        with m.If(self.halt):
            m.d.sync += [enable.eq(0), direction.eq(0), mist.eq(0), flood.eq(0)]
            m.d.comb += off.eq(1)
        with m.Elif(self.cmd.valid):
            m.d.sync += [
                enable.eq(c.spindle != Spindle.OFF),
                direction.eq(c.spindle == Spindle.CCW),
                s.eq(Mux(c.s > self._s_max, self._s_max, c.s)),
                mist.eq(c.mist), flood.eq(c.flood),
            ]
            m.d.comb += off.eq(c.spindle == Spindle.OFF)

        if self._spindle_override:              # S times the factor, rounded, clamped
            scaled = Signal(len(s) + 9)
            overridden = Signal.like(s)
            m.d.comb += [
                scaled.eq((s * self.spindle_override + (OVERRIDE_ONE >> 1)) >> 7),
                overridden.eq(Mux(scaled > self._s_max, self._s_max, scaled)),
            ]
            s = overridden
        result, fresh = self._duty(m, first, off, enable, direction, s)
        with m.If(off):
            m.d.sync += duty.eq(0)
        with m.Elif(last):
            m.d.sync += duty.eq(Mux(fresh, result, 0))

        on = ~self.halt
        m.d.comb += [
            self.enable.eq(enable & on), self.direction.eq(direction & on),
            self.mist.eq(mist & on), self.flood.eq(flood & on),
            self.pwm.eq(enable & on & (count < duty)),
        ]
        return m

    def _duty(self, m, first, off, enable, direction, s):
        """The next period's duty, worked out from the period's first clock (module notes);
        returns it and whether it is valid (the spindle on at that clock and not off since)."""
        period = self._period
        bits = period.bit_length()
        width = 24 if self._laser_mode else self._s_max.bit_length()     # of b and c
        a = Signal(bits)                        # the multiplier, shifted out high bit first
        b = Signal(width)
        # c: the cruise or s_max (without laser mode s_max alone, a constant).
        c = Signal(width) if self._laser_mode else C(self._s_max, width)
        r = Signal(width + 2)                   # remainder, below 3c
        q = Signal(bits)                        # quotient
        phase = Signal(range(3))
        left = Signal(range(bits + 1))          # bits of a to take; 0: the rounding step
        busy, feed, fresh = Signal(), Signal(), Signal()   # feed: the rate pass runs

        # One adder: 2r + bit·b in phase 0, r - c (r + ~c + 1) in phases 1 and 2, where its
        # carry out is r ≥ c.
        first_phase = phase == 0
        total = Signal(width + 4)
        m.d.comb += total.eq(Mux(first_phase, r << 1, r)
                             + Mux(first_phase, Mux(a[-1], b, 0),
                                   c ^ C((1 << (width + 3)) - 1, width + 3))
                             + ~first_phase)
        ge = total[width + 3]

        # A cruise of 0 is taken as 1, its rate as 0. A rate above the cruise is not clamped
        # here (a 24-bit compare): the first bit's first subtraction is r = rate ≥ c, and
        # ``full`` then makes the rate pass's result the period, whatever its quotient.
        zero = Signal()
        m.d.comb += zero.eq(self.cruise == 0)
        cruise = Cat(self.cruise[0] | zero, self.cruise[1:])
        rate = Mux(zero, 0, self.rate)
        full = Signal()
        with m.If(busy & feed & (phase == 1) & (left == bits)):
            m.d.sync += full.eq(ge)

        with m.If(first):
            laser = (self.laser if self._laser_mode else C(0)) & enable & direction
            m.d.sync += [
                busy.eq(1), feed.eq(laser), a.eq(period), r.eq(0), q.eq(0), phase.eq(0),
                left.eq(bits), b.eq(Mux(laser, rate, s)),
            ]
            if self._laser_mode:
                m.d.sync += c.eq(Mux(laser, cruise, self._s_max))
        with m.Elif(busy):
            with m.If(phase == 0):
                # In the rounding step a is all shifted out: r ← 2r.
                m.d.sync += [r.eq(total), a.eq(a << 1), phase.eq(1)]
                with m.If(left != 0):
                    m.d.sync += q.eq(q << 1)
            with m.Else():
                with m.If(ge):
                    m.d.sync += [r.eq(total), q.eq(q + 1)]
                m.d.sync += phase.eq(Mux(phase == 2, 0, phase + 1))
                with m.If(phase == 2):
                    m.d.sync += left.eq(left - 1)
                    with m.If(left == 0):           # the pass ends
                        m.d.sync += [busy.eq(feed), feed.eq(0)]
        # The S pass after the rate pass: its multiplier is the rate pass's result (its last
        # clock subtracts nothing: the rounding step's r is below c after one subtraction).
        done = Signal()
        m.d.comb += done.eq(busy & (phase == 2) & (left == 0) & ~first)
        with m.If(done & feed):
            m.d.sync += [a.eq(Mux(full, period, q)), b.eq(s), r.eq(0), q.eq(0),
                         left.eq(bits)]
            if self._laser_mode:
                m.d.sync += c.eq(self._s_max)

        with m.If(off):
            m.d.sync += fresh.eq(0)
        with m.Elif(first):
            m.d.sync += fresh.eq(enable)
        return q, fresh


def ToolFrame():
    """The tool state, as the TOOL frame's payload carries it (4 bytes, little-endian, least
    significant bit first): the spindle (:class:`Spindle`: M5, M3, M4), mist (M7), flood (M8),
    laser mode (Grbl's ``$32``), and S (an integer; above ``s_max`` taken as ``s_max``)."""
    return data.StructLayout({"spindle": Spindle, "mist": 1, "flood": 1, "laser": 1,
                              "reserved": 3, "s": unsigned(24)})


class ToolEngine(wiring.Component):
    """The tool outputs as a row of the controller's engine table: TOOL frames in their turn.

    A TOOL frame is taken when the engine is idle (no frame in flight, no outcome waiting) and
    ends ``DONE`` in its turn (the turn queue's readiness for its outcome, :py:`status.ready`)
    once the step/dir stage is idle (:py:`settled`): the moves before it have made their last
    pulse on the pins, those after it have not begun. In that
    clock its state goes to :class:`ToolOutputs` (whole: spindle, S, mist, flood) and the laser
    mode is set. It makes no step. :py:`abort` drops a frame not yet in its turn (it ends
    ``ABORTED``, the outputs unchanged); the alarm's halt (:py:`halt`) turns every output off.

    Parameters
    ----------
    s_max, period, laser_mode, spindle_override
        As :class:`ToolOutputs`.
    axes : :class:`int`
        The controller's axes (its engines' motion width).

    Members (besides :class:`~kontur.hdl.engine.EngineSignature`'s)
    -------
    rate, cruise : :py:`Signal(24)`, in
        The feed generator's rate and the running move's cruise (for the laser mode's power).
    spindle_override : :py:`Signal(9, init=128)`, in
        The spindle override (Q2.7), from the host's OVERRIDE frames.
    halt : :py:`Signal(1)`, in
        The alarm's halt.
    settled : :py:`Signal(1)`, in
        The step/dir stage is idle (:py:`~.stepdir.StepDirStage.idle`): the last pulse of the
        move before is over on its pin; the frame ends only then.
    enable, direction, pwm, mist, flood : :py:`Signal(1)`, out
        The pins (:data:`TOOL_PINS`), :class:`ToolOutputs`'.
    """

    def __init__(self, *, s_max, period, laser_mode=True, spindle_override=True, axes=2):
        self.outputs = ToolOutputs(s_max=s_max, period=period, laser_mode=laser_mode,
                                   spindle_override=spindle_override)
        super().__init__(EngineSignature(ToolFrame(), axes=axes))
        self._axes = axes
        self.rate, self.cruise, self.halt = Signal(24), Signal(24), Signal()
        self.spindle_override = Signal(9, init=OVERRIDE_ONE)
        self.settled = Signal()
        for name in TOOL_PINS:
            setattr(self, name, Signal(name=name))

    def elaborate(self, platform):
        m = Module()
        m.submodules.unit = unit = StatusUnit(axes=self._axes)
        m.submodules.outputs = outputs = self.outputs
        state = Signal(ToolFrame())
        run = Signal()
        ending = Signal()
        laser = Signal()
        m.d.comb += [
            ending.eq(run & self.status.ready & self.settled & ~unit.hold & ~self.abort),
            self.feed.due.eq(0),
            self.cmd.ready.eq(unit.idle & ~unit.flushing & ~self.abort),
            unit.accept.eq(self.cmd.valid & self.cmd.ready),
            unit.end.eq(ending),
            unit.outcome.eq(Outcome.DONE),
            unit.flush.eq(self.abort),
            self.busy.eq(unit.busy),
            outputs.cmd.valid.eq(ending),
            outputs.cmd.payload.spindle.eq(state.spindle),
            outputs.cmd.payload.s.eq(Mux(state.s > outputs.s_max, outputs.s_max, state.s)),
            outputs.cmd.payload.mist.eq(state.mist),
            outputs.cmd.payload.flood.eq(state.flood),
            outputs.laser.eq(laser),
            outputs.rate.eq(self.rate),
            outputs.cruise.eq(self.cruise),
            outputs.spindle_override.eq(self.spindle_override),
            outputs.halt.eq(self.halt),
        ]
        m.d.comb += [getattr(self, name).eq(getattr(outputs, name)) for name in TOOL_PINS]
        wiring.connect(m, unit.status, wiring.flipped(self.status))
        with m.If(unit.accept):
            m.d.sync += [run.eq(1), state.eq(self.cmd.payload)]
        with m.Elif(ending | self.abort):
            m.d.sync += run.eq(0)
        with m.If(ending):
            m.d.sync += laser.eq(state.laser)
        return m


def tool_frame(spindle=Spindle.OFF, s=0, *, mist=False, flood=False, laser=False):
    """The TOOL frame of a tool state (the host's side): ``spindle`` a :class:`Spindle`, ``s``
    an integer S (0 to 2**24 - 1), the coolant and Grbl's laser mode."""
    spindle = Spindle(spindle)
    if isinstance(s, bool) or not isinstance(s, int) or not 0 <= s < 1 << 24:
        raise ValueError(f"S must be an integer from 0 to 2**24 - 1, not {s!r}")
    flags = spindle.value | bool(mist) << 2 | bool(flood) << 3 | bool(laser) << 4
    payload = struct.pack("<I", flags | s << 8)
    body = bytes([TOOL, len(payload)]) + payload
    return bytes([SYNC]) + body + crc(body).to_bytes(2, "big")


def tool_row(*, s_max, period, laser_mode=True, spindle_override=True, axes=2):
    """The engine-table row of a tool engine: ``MotionController(engines=[tool_row(...)])``."""
    engine = ToolEngine(s_max=s_max, period=period, laser_mode=laser_mode,
                        spindle_override=spindle_override, axes=axes)
    return EngineUnit("tools", TOOL_UNIT, TOOL, engine, profile_bytes(ToolFrame()), raw_bits)


def tool_engine(controller):
    """The tool engine of ``controller``'s table, or ``None``."""
    return next((row.engine for row in controller.table if isinstance(row.engine, ToolEngine)),
                None)


def connect_tools(m, controller):
    """Wire the tool engine of ``controller``'s table (none: nothing is built): the feed
    generator's rate, the running move's cruise, the spindle override (the last OVERRIDE
    frame's), the alarm's halt, the step/dir stage's idleness."""
    engine = tool_engine(controller)
    if engine is None:
        return
    m.d.comb += [
        engine.rate.eq(controller.feed.rate),
        engine.cruise.eq(controller.turns.ramp.profile.cruise),
        engine.spindle_override.eq(controller.spindle_override),
        engine.halt.eq(controller.alarm_unit.halt),
        engine.settled.eq(controller.stepdir.idle),
    ]
