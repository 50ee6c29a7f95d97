# amaranth: UnusedElaboratable=no
"""The tool outputs in the controller (issue 28): TOOL frames take effect in their turn, after
the move before them has made its last step and before the move after them makes its first;
the PWM's duty is S/s_max of the period; in laser mode with M4 it follows the feed (none while
held); e-stop turns every output off. Checked from the pins alone (the step pins' pulses, the
tool pins' levels each clock), not from the controller's insides."""

import pytest

from kontur import registry
from kontur.hdl.motion import protocol as p
from kontur.hdl.motion.controller import MotionController
from kontur.hdl.motion.inputs import INPUTS
from kontur.hdl.motion.tools import TOOL_PINS, Spindle, tool_engine, tool_frame, tool_row
from kontur.sim.testbench.hostlink import run_amaranth

DONE, ABORTED = 0, 2
S_MAX, PERIOD = 100, 100
RATE = round(0.05 * (1 << 24))                # a step every 20 clocks


def _run(frames, clocks, *, inject=None, estop_at=None):
    """Run ``frames`` through a small controller with a tool engine; every clock's ``(x, y,
    pins)``: the position from the step pins' pulses and the tool pins (a dict)."""
    dut = MotionController(line=registry.make_engine("line", width=12),
                           arc=registry.make_engine("arc", "fast", width=12),
                           clock_hz=1e6, baud=250_000, dir_setup=1, step_width=2,
                           queue_frames=8, engines=[tool_row(s_max=S_MAX, period=PERIOD)])
    tools = tool_engine(dut)
    trace, position, before = [], [0, 0], [0]

    def each(ctx, clock):
        step, direction = ctx.get(dut.motion.step), ctx.get(dut.motion.dir)
        for axis in range(2):
            if step >> axis & 1 and not before[0] >> axis & 1:     # a pulse's first clock
                position[axis] += -1 if direction >> axis & 1 else 1
        before[0] = step
        trace.append((*position, {name: ctx.get(getattr(tools, name)) for name in TOOL_PINS}))
        if estop_at is not None and clock >= estop_at:
            ctx.set(dut.inputs, dut.idle_inputs ^ 1 << INPUTS.index("estop"))

    result = run_amaranth(dut, frames, divisor=4, window=8, max_clocks=clocks, inject=inject,
                          each=each)
    outcomes = [reply.fields[1] for _, reply in result.replies if reply.kind == 0x80]
    return outcomes, trace


def _feed():
    return p.feed(RATE, RATE, 1 << 20)


def _duties(trace, first, last):
    """The high clocks of ``pwm`` in each whole period (the counter runs from reset) within
    clocks ``first`` to ``last``."""
    start = -(-first // PERIOD) * PERIOD
    return [sum(pins["pwm"] for _, _, pins in trace[at:at + PERIOD])
            for at in range(start, last - PERIOD + 1, PERIOD)]


def _rise(trace, name):
    return next(clock for clock, (_, _, pins) in enumerate(trace) if pins[name])


def test_changes_between_moves_and_the_duty():
    frames = [p.config((1 << 32) - 1),
              _feed(), p.line(40, 0),
              tool_frame(Spindle.CW, 50, flood=True),
              _feed(), p.line(0, 40),
              tool_frame(Spindle.CCW, 25),
              _feed(), p.line(-40, 0),
              tool_frame(Spindle.OFF, 25),
              p.query()]
    outcomes, trace = _run(frames, 12_000)
    assert outcomes == [DONE] * 10
    on = _rise(trace, "enable")
    # On once X has made its 40 steps, before Y's first.
    assert trace[on][:2] == (40, 0) and trace[on - 1][:2] == (40, 0)
    assert trace[on][2]["flood"]
    assert not any(pins["mist"] for _, _, pins in trace)
    # The M4 change after Y's 40 steps: direction rises there, before the X move back.
    ccw = _rise(trace, "direction")
    assert trace[ccw][:2] == (40, 40) and trace[ccw - 1][:2] == (40, 40)
    assert all(pins["enable"] and pins["flood"] and not pins["direction"]
               for _, _, pins in trace[on:ccw])
    # Off after the last step: everything low from there to the end.
    off = next(clock for clock in range(ccw, len(trace)) if not trace[clock][2]["enable"])
    assert trace[off][:2] == (0, 40)
    assert all(not any(pins.values()) for _, _, pins in trace[off:])
    assert not any(pins["enable"] for _, _, pins in trace[:on])
    # The duty: S/s_max of the period, from the second whole period after a change on.
    assert set(_duties(trace, on + 2 * PERIOD, ccw)) == {50}
    assert set(_duties(trace, ccw + 2 * PERIOD, off)) == {25}
    # No pulse before the spindle is on or after it is off.
    assert not any(pins["pwm"] for _, _, pins in trace[:on] + trace[off:])


def test_laser_m4_follows_the_feed():
    """Laser mode, M4 S80: the power is S/s_max × rate/cruise, a period late: full while the
    line cruises, none while a feed hold keeps it at a standstill, full again after RESUME."""
    frames = [p.config((1 << 32) - 1),
              tool_frame(Spindle.CCW, 80, laser=True),
              _feed(), p.line(300, 0),
              tool_frame(Spindle.OFF, 0),
              p.query()]
    hold_at, resume_at = 2500, 4500
    outcomes, trace = _run(frames, 14_000, inject={hold_at: p.hold(), resume_at: p.resume()})
    assert outcomes == [DONE] * 5
    moving = [clock for clock in range(1, len(trace)) if trace[clock][:2] != trace[clock - 1][:2]]
    start, end = moving[0], moving[-1]
    stop = max(clock for clock in moving if clock < resume_at) + 1       # standing still
    again = min(clock for clock in moving if clock > resume_at)
    assert start < hold_at < stop < resume_at < again < end
    assert set(_duties(trace, start + 2 * PERIOD, hold_at)) == {80}      # cruising
    assert set(_duties(trace, stop + 2 * PERIOD, again)) == {0}          # held: no power
    assert set(_duties(trace, again + 2 * PERIOD, end)) == {80}
    assert trace[-1][:2] == (300, 0)


def test_spindle_override():
    """OVERRIDE frames' spindle factor (Grbl's spindle override) scales S in the duty, on the
    fly, whatever is queued: M3 S80 of 100 is 80 clocks a period, 40 after a 50 % override,
    full (S 120 clamped at s_max) after 150 %, while the line's steps keep their pace."""
    frames = [p.config((1 << 32) - 1),
              tool_frame(Spindle.CW, 80),
              _feed(), p.line(300, 0),
              tool_frame(Spindle.OFF, 0),
              p.query()]
    half, more = 2500, 4500
    outcomes, trace = _run(frames, 14_000, inject={half: p.override(spindle=50),
                                                  more: p.override(spindle=150)})
    assert outcomes == [DONE] * 5
    moving = [clock for clock in range(1, len(trace)) if trace[clock][:2] != trace[clock - 1][:2]]
    start, end = moving[0], moving[-1]
    assert start < half < more < end and trace[-1][:2] == (300, 0)
    assert {b - a for a, b in zip(moving, moving[1:])} == {20}
    # A frame of 10 bytes takes 400 clocks on this link; the duty changes a period later.
    assert set(_duties(trace, start + 2 * PERIOD, half)) == {80}
    assert set(_duties(trace, half + 400 + 2 * PERIOD, more)) == {40}
    assert set(_duties(trace, more + 400 + 2 * PERIOD, end)) == {100}


def test_estop_turns_the_tool_off():
    frames = [p.config((1 << 32) - 1),
              tool_frame(Spindle.CW, 60, mist=True, flood=True),
              _feed(), p.line(200, 0),
              p.query()]
    outcomes, trace = _run(frames, 6_000, estop_at=2000)
    assert outcomes == [DONE, DONE, DONE, ABORTED]
    on = _rise(trace, "enable")
    assert on < 2000 and trace[1999][2]["enable"] and trace[1999][2]["mist"]
    # The e-stop reaches the alarm after the input's synchroniser and filter: a few clocks.
    off = next(clock for clock in range(2000, len(trace)) if not trace[clock][2]["enable"])
    assert off <= 2000 + 5
    assert all(not any(pins.values()) for _, _, pins in trace[off:])


def test_tool_frame_fields():
    frame = tool_frame(Spindle.CCW, 1000, mist=True, laser=True)
    assert frame[1:3] == bytes([0x1B, 4])
    assert frame[3:7] == bytes([0b10110, 1000 & 0xFF, 1000 >> 8, 0])
    with pytest.raises(ValueError, match="S must be an integer"):
        tool_frame(Spindle.CW, 1 << 24)


def test_laser_power_changes_on_the_fly():
    """Laser mode, M3: a change of power alone between two moves that the plan runs through
    at cruise (the host sends no stop: kontur.machining.tool_changes) takes effect between
    the move before and the move after, and the pulses keep their pace through it: no stop,
    no pulse late. (A step every 80 clocks: at 20 this test's UART, 4 clocks a bit, cannot
    bring a move's frames within its 30 steps, and the queue runs dry.)"""
    every = 80
    feed = p.feed(round((1 << 24) / every), round((1 << 24) / every), 1 << 20)
    frames = [p.config((1 << 32) - 1),
              tool_frame(Spindle.CW, 80, laser=True),
              feed, p.line(30, 0),
              tool_frame(Spindle.CW, 20, laser=True),
              feed, p.line(30, 0),
              tool_frame(Spindle.CW, 0, laser=True),
              feed, p.line(30, 0),
              tool_frame(Spindle.OFF, 0, laser=True),
              p.query()]
    outcomes, trace = _run(frames, 12_000)
    assert outcomes == [DONE] * 11
    pulses = [clock for clock in range(1, len(trace)) if trace[clock][0] != trace[clock - 1][0]]
    assert len(pulses) == 90 and trace[-1][:2] == (90, 0)
    # The pace: every pulse `every` clocks after the one before, through both changes too.
    assert {b - a for a, b in zip(pulses, pulses[1:])} == {every}
    # The power: 80 up to the 30th pulse, 20 from the second whole period after the 31st (the
    # duty worked out a period ahead) to the 60th, none after the 61st; M3 S0 stays enabled.
    assert set(_duties(trace, pulses[0] + 2 * PERIOD, pulses[29])) == {80}
    assert set(_duties(trace, pulses[30] + 2 * PERIOD, pulses[59])) == {20}
    assert set(_duties(trace, pulses[60] + 2 * PERIOD, pulses[89])) == {0}
    assert all(pins["enable"] for _, _, pins in trace[pulses[0]:pulses[89]])
