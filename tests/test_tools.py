"""The tool outputs (issue 28): spindle enable, direction, PWM, coolant; the laser mode.

The gateware against its model clock for clock on Amaranth's simulator (short runs), and the
model against what the pins must do, worked out here by hand: the duty counted on the PWM
waveform over a period is round(S/s_max × period); in laser mode with M4 it follows the rate
through a ramp; halt drops every output in its own clock.
"""

import math
import random
from fractions import Fraction

import pytest
from amaranth.sim import Simulator

from kontur.hdl.motion.tools import Spindle, ToolOutputs, min_period, pwm_period
from kontur.sim.models.tools import CCW, CW, OFF, ToolOutputsModel

PINS = ("enable", "direction", "pwm", "mist", "flood")


def command(spindle=OFF, s=0, mist=0, flood=0):
    return {"spindle": spindle, "s": s, "mist": mist, "flood": flood}


def run_model(model, clocks):
    """The model's outputs for ``clocks``, a list of input dicts (``cmd``, ``laser``, ``rate``,
    ``cruise``, ``halt``; missing ones 0 or ``None``)."""
    return [model.cycle(**clock) for clock in clocks]


def run_rtl(dut, clocks):
    """The gateware's outputs for the same inputs, on Amaranth's simulator."""
    outputs = []

    async def bench(ctx):
        for clock in clocks:
            cmd = clock.get("cmd")
            ctx.set(dut.cmd.valid, cmd is not None)
            if cmd is not None:
                ctx.set(dut.cmd.payload, {**cmd, "spindle": Spindle(cmd["spindle"])})
            for name in ("laser", "rate", "cruise", "halt"):
                ctx.set(getattr(dut, name), clock.get(name, 0))
            ctx.set(dut.spindle_override, clock.get("spindle_override", 128))
            outputs.append({name: ctx.get(getattr(dut, name)) for name in PINS}
                           | {"ready": ctx.get(dut.cmd.ready)})
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    return outputs


def periods(outputs, period):
    """The PWM waveform cut into whole periods (the counter starts at reset)."""
    return [[o["pwm"] for o in outputs[k:k + period]]
            for k in range(0, len(outputs) - period + 1, period)]


def high(wave):
    """The high clocks of one period, checked to be one pulse from the period's start."""
    count = sum(wave)
    assert wave == [1] * count + [0] * (len(wave) - count), wave
    return count


def half_up(value):
    """A fraction rounded to the nearest integer, halves up."""
    return math.floor(Fraction(value) + Fraction(1, 2))


# --- the model against the pins' meaning -------------------------------------------------

@pytest.mark.parametrize("s_max, period", [(1000, 120), (100, 64), (255, 97)])
def test_duty_follows_s(s_max, period):
    """Every S from 0 to s_max (and one above, clamped): from the third period on, one pulse a
    period of round(S/s_max × period) clocks."""
    for s in [*range(0, s_max + 1, max(1, s_max // 60)), s_max, s_max + 1]:
        model = ToolOutputsModel(s_max=s_max, period=period)
        clocks = [{"cmd": command(CW, s)}] + [{}] * (4 * period - 1)
        waves = periods(run_model(model, clocks), period)
        expected = half_up(Fraction(min(s, s_max) * period, s_max))
        assert [high(w) for w in waves] == [0, 0, expected, expected], s


def test_laser_follows_rate_through_a_ramp():
    """Laser mode, M4 S600 of 1000, period 200: the rate ramps up by an eighth of the cruise a
    period, stays, then ramps down to a standstill. The duty of a period is that of the rate at
    the first clock of the period before: 600/1000 × k/8 × 200 = 15k clocks (the first period's
    is 0: the spindle was off at its first clock)."""
    period, cruise = 200, 1 << 20
    ramp = [*range(0, 9), 8, 8, *range(7, -1, -1), 0]        # eighths of the cruise, a period
    clocks = []
    for k in ramp:
        clocks += [{"laser": 1, "rate": k * cruise // 8, "cruise": cruise}] * period
    clocks[0] = {**clocks[0], "cmd": command(CCW, 600)}
    waves = periods(run_model(ToolOutputsModel(s_max=1000, period=period), clocks), period)
    assert [high(w) for w in waves] == [0] + [15 * k for k in ramp[:-1]]


def test_laser_through_a_corner():
    """The feed generator's model (``FeedGeneratorModel``) takes a move at a quarter step a
    clock down to a quarter of that at a corner, and the next back up: the laser's power
    (M4 S800 of 1000, period 200) in every period is within one count of 0.8 × rate/cruise ×
    200 at the rate of the period before's first clock; at cruise 160 clocks, at the corner
    40."""
    from kontur.sim.models.motion import FeedGeneratorModel
    period, cruise, exit = 200, 1 << 22, 1 << 20
    feed = FeedGeneratorModel()
    accel = (cruise << 16) // 4000                 # Q0.40: the cruise in 4000 clocks
    moves = [({"cruise": cruise, "exit": exit, "decelerate": 1000}, 1500),
             ({"cruise": cruise, "exit": 0, "decelerate": 1 << 23}, 1000)]
    tools = ToolOutputsModel(s_max=1000, period=period)
    rates, pwm = [], []
    for number, (profile, length) in enumerate(moves):
        steps, start = 0, 1
        while steps < length:
            rate = feed.rate >> 16                 # the generator's rate output, this clock
            rates.append(rate)
            cmd = command(CCW, 800) if len(rates) == 1 else None
            pwm.append(tools.cycle(cmd, laser=1, rate=rate, cruise=profile["cruise"])["pwm"])
            steps += feed.cycle(profile=profile, accel=accel, start=start, due=1)
            start = 0
    counts = [high(w) for w in periods([{"pwm": p} for p in pwm], period)]
    for n in range(2, len(counts)):
        exact = Fraction(800, 1000) * Fraction(rates[(n - 1) * period], cruise) * period
        assert abs(counts[n] - exact) <= 1, n
    assert max(counts) == 160
    corner = min(range(20, len(counts)), key=lambda n: counts[n])
    assert abs(counts[corner] - 40) <= 1 and counts[-1] == 160


def test_laser_modes():
    """Laser mode: M3 is constant power whatever the rate; in M4 a standstill is dark (the
    spindle enable stays on) and a rate above the cruise (an override) is full S; without
    laser mode M4 is S alone."""
    period, cruise = 120, 3 << 18

    def duty(spindle, laser, rate):
        model = ToolOutputsModel(s_max=1000, period=period)
        clocks = [{"cmd": command(spindle, 500), "laser": laser, "rate": rate,
                   "cruise": cruise}] + [{"laser": laser, "rate": rate,
                                          "cruise": cruise}] * (3 * period - 1)
        outputs = run_model(model, clocks)
        assert all(o["enable"] for o in outputs[1:])
        return high(periods(outputs, period)[2])

    assert duty(CW, 1, 0) == duty(CW, 1, cruise // 3) == 60
    assert duty(CCW, 1, 0) == 0
    assert duty(CCW, 1, cruise * 2) == 60
    assert duty(CCW, 0, cruise // 3) == 60
    assert duty(CCW, 1, cruise // 3) == 20


def test_laser_duty_within_one_count():
    """Random S, rate and cruise: the duty within one count of S/s_max × rate/cruise ×
    period."""
    rng = random.Random(28)
    period, s_max = 1000, 1000
    for _ in range(40):
        s, cruise = rng.randint(0, s_max), rng.randint(1, (1 << 24) - 1)
        rate = rng.randint(0, cruise)
        model = ToolOutputsModel(s_max=s_max, period=period)
        inputs = {"laser": 1, "rate": rate, "cruise": cruise}
        outputs = run_model(model, [{"cmd": command(CCW, s), **inputs}]
                            + [inputs] * (3 * period - 1))
        exact = Fraction(s, s_max) * Fraction(rate, cruise) * period
        assert abs(high(periods(outputs, period)[2]) - exact) <= 1, (s, rate, cruise)


def test_halt_within_one_clock():
    """Halt drops every output in its own clock; they stay off (a command under halt is not
    taken: ``ready`` is low) until a command after it; the PWM then starts again at a
    period's start."""
    period = 64
    clocks = ([{"cmd": command(CCW, 50, mist=1, flood=1)}] + [{}] * (3 * period + 9)
              + [{"halt": 1}] + [{"halt": 1, "cmd": command(CW, 90, 1, 1)}]
              + [{}] * (2 * period)
              + [{"cmd": command(CW, 25, flood=1)}] + [{}] * (4 * period))
    outputs = run_model(ToolOutputsModel(s_max=100, period=period), clocks)
    halt = 1 + 3 * period + 9
    before = outputs[halt - 1]
    assert before == {"enable": 1, "direction": 1, "pwm": 1, "mist": 1, "flood": 1, "ready": 1}
    assert [o["ready"] for o in outputs[halt - 1:halt + 3]] == [1, 0, 0, 1]
    for o in outputs[halt:halt + 2 * period + 2]:
        assert not any(o[p] for p in PINS)
    resume = halt + 2 * period + 2
    after = outputs[resume + 1]
    assert (after["enable"], after["direction"], after["mist"], after["flood"]) == (1, 0, 0, 1)
    # No pulse before the first period that began, and was worked out, with the spindle on.
    start = -(-(resume + 1) // period) * period
    assert not any(o["pwm"] for o in outputs[resume:start + period])
    assert high([o["pwm"] for o in outputs[start + period:start + 2 * period]]) == 16


def test_duty_changes_at_a_boundary():
    """An S changed in mid-period, mid-computation and in a period's last clock: every period
    is one pulse from its start, of the old duty or the new; M5 cuts the pulse in the next
    clock."""
    period = 64
    for at in (5, 20, period - 1, period + 30):
        clocks = ([{"cmd": command(CW, 30)}] + [{}] * (3 * period - 1 + at)
                  + [{"cmd": command(CW, 70)}] + [{}] * (4 * period))
        waves = periods(run_model(ToolOutputsModel(s_max=100, period=period), clocks), period)
        counts = [high(w) for w in waves]
        old, new = half_up(Fraction(30 * period, 100)), half_up(Fraction(70 * period, 100))
        change = counts.index(new)
        assert counts[2:change] == [old] * (change - 2) and set(counts[change:]) == {new}
    outputs = run_model(ToolOutputsModel(s_max=100, period=period),
                        [{"cmd": command(CW, 100)}] + [{}] * (3 * period + 4)
                        + [{"cmd": command(OFF)}] + [{}] * period)
    assert outputs[3 * period + 5]["pwm"] == 1                # M5's clock: the state before
    assert not any(o["pwm"] or o["enable"] for o in outputs[3 * period + 6:])


@pytest.mark.parametrize("laser", [0, 1])
def test_spindle_override(laser):
    """Grbl's spindle override (10 % to 200 %, sent as its Q2.7 factor) scales S, clamped at
    s_max, in M3 and in laser mode's M4 at the cruise: the duty within the factor's rounding
    of S × percent / 100 (a 256th of S) and half a count of the exact; at 50 %, 100 % and
    200 % (factors 64, 128, 256: exact) the duty of S/2, S and min(2S, s_max). A change takes
    effect at a period's boundary, one pulse a period."""
    from kontur.hdl.motion.protocol import feed_factor
    period, s_max, cruise = 120, 1000, 1 << 20
    spindle = CCW if laser else CW

    def duties(s, factors):
        """The count of every period: the factor 128 for three periods, then each of
        ``factors`` from 40 clocks before a period's end for three; factor k's duty is that
        of periods 3k + 4 to 3k + 6 (worked out in the period before)."""
        inputs = {"laser": laser, "rate": cruise, "cruise": cruise}
        clocks = []
        for n in range((2 + len(factors)) * 3 * period):
            k = min((n + 40) // (3 * period) - 1, len(factors) - 1)
            clocks.append({**inputs, "spindle_override": factors[k] if k >= 0 else 128})
        clocks[0]["cmd"] = command(spindle, s)
        counts = [high(w) for w in periods(run_model(
            ToolOutputsModel(s_max=s_max, period=period), clocks), period)]
        return counts[1:3], [counts[3 * k + 4:3 * k + 7] for k in range(len(factors))]

    for s in (0, 1, 250, 499, 500, 777, 1000):
        whole, half, double = (half_up(Fraction(min(s * k, 2 * s_max) * period, 2 * s_max))
                               for k in (2, 1, 4))
        before, after = duties(s, [64, 256, 128])
        assert before == [0, whole] and after == [[half] * 3, [double] * 3, [whole] * 3], s
        percents = (10, 37, 110, 160)
        _, after = duties(s, [feed_factor(percent, "spindle") for percent in percents])
        for percent, counts in zip(percents, after):
            (count,) = set(counts)
            exact = Fraction(min(Fraction(s * percent, 100), s_max) * period, s_max)
            assert abs(count - exact) <= Fraction(1, 2) + Fraction(period * s, 256 * s_max) \
                + Fraction(period, 2 * s_max), (s, percent)


def test_without_spindle_override():
    """Built without the spindle override (a board without overrides), S is as commanded
    whatever the factor."""
    period = 120
    clocks = [{"cmd": command(CW, 500), "spindle_override": 256}] + \
        [{"spindle_override": 256}] * (3 * period - 1)
    outputs = run_model(ToolOutputsModel(s_max=1000, period=period, spindle_override=False),
                        clocks)
    assert high(periods(outputs, period)[2]) == 60
    outputs = run_rtl(ToolOutputs(s_max=1000, period=period, spindle_override=False), clocks)
    assert high(periods(outputs, period)[2]) == 60


# --- the gateware against the model ------------------------------------------------------

def random_clocks(rng, period, s_max, count):
    """Commands a few periods apart (S up to the field's top, above s_max too), the laser mode
    switched now and then, a cruise (0 and 1 among them) and a rate wandering up to a quarter
    above it, a halt now and then."""
    clocks, laser, cruise, rate, factor = [], 1, 1 << 20, 0, 128
    while len(clocks) < count:
        if rng.random() < 0.2:                 # a spindle override of 10 % to 200 %
            factor = rng.choice([128, 13, 256, rng.randint(13, 256)])
        if rng.random() < 0.2:
            laser = int(rng.random() < 0.7)
        if rng.random() < 0.3:
            cruise = rng.choice([0, 1, rng.randint(1, (1 << 24) - 1), rng.randint(1, 1 << 12)])
        cmd = command(rng.choice([OFF, CW, CCW, CCW, CCW]),
                      rng.randint(0, (1 << s_max.bit_length()) - 1),
                      rng.randint(0, 1), rng.randint(0, 1))
        clocks.append({"cmd": cmd, "laser": laser, "spindle_override": factor})
        for _ in range(rng.randint(0, 5 * period)):
            if rng.random() < 0.02:
                rate = rng.randint(0, min((1 << 24) - 1, cruise * 5 // 4))
            clocks.append({"laser": laser, "rate": rate, "cruise": cruise,
                           "halt": int(rng.random() < 0.002), "spindle_override": factor})
    return clocks[:count]


@pytest.mark.parametrize("s_max, period, seed, laser_mode, spindle_override", [
    (100, 64, 1, True, True), (1000, 97, 2, True, True), ((1 << 24) - 1, 200, 3, True, True),
    (1000, 97, 4, False, True), (1, 50, 5, False, False), (1000, 97, 6, False, False)])
def test_rtl_equals_model(s_max, period, seed, laser_mode, spindle_override):
    clocks = random_clocks(random.Random(seed), period, s_max, 40 * period)
    options = {"laser_mode": laser_mode, "spindle_override": spindle_override}
    model = run_model(ToolOutputsModel(s_max=s_max, period=period, **options), clocks)
    rtl = run_rtl(ToolOutputs(s_max=s_max, period=period, **options), clocks)
    for k, (got, want) in enumerate(zip(rtl, model)):
        assert got == want, f"clock {k}: {got} != {want}"
    assert sum(o["pwm"] for o in model) > 0 and any(c.get("halt") for c in clocks)


def test_rtl_duty_and_halt():
    """The gateware alone: S 30 of 100 at period 64 is 19 clocks a period (19.2); halt in
    mid-pulse drops everything in that clock."""
    period = 64
    clocks = [{"cmd": command(CW, 30, mist=1)}] + [{}] * (4 * period + 4) + [{"halt": 1}] + [{}]
    outputs = run_rtl(ToolOutputs(s_max=100, period=period), clocks)
    assert [high(w) for w in periods(outputs, period)[2:4]] == [19, 19]
    assert outputs[4 * period + 4]["pwm"] == 1 and outputs[4 * period + 4]["mist"] == 1
    assert not any(outputs[4 * period + 5][p] for p in PINS)
    assert not any(outputs[-1][p] for p in PINS)


def test_rtl_laser():
    """The gateware in laser mode, M4 S80 of 100: a cruise of 0 (between moves) is dark
    whatever the rate, half the cruise is 80/100 × 1/2 × 64 = 25.6, 26 clocks; the model
    the same clock for clock."""
    period, cruise = 64, (1 << 24) - 2
    clocks = ([{"cmd": command(CCW, 80), "laser": 1, "rate": 5}]
              + [{"laser": 1, "rate": 5}] * (3 * period - 1)
              + [{"laser": 1, "rate": cruise // 2, "cruise": cruise}] * (3 * period))
    outputs = run_rtl(ToolOutputs(s_max=100, period=period), clocks)
    assert outputs == run_model(ToolOutputsModel(s_max=100, period=period), clocks)
    assert [high(w) for w in periods(outputs, period)] == [0, 0, 0, 0, 26, 26]


def test_without_laser_mode():
    """Built without laser mode, M4 in laser mode is S alone: 60 of 120 clocks at S 500 of
    1000 at any rate, a standstill too."""
    period = 120
    for rate in (0, 1 << 10):
        inputs = {"laser": 1, "rate": rate, "cruise": 1 << 20}
        clocks = [{"cmd": command(CCW, 500), **inputs}] + [inputs] * (3 * period - 1)
        outputs = run_rtl(ToolOutputs(s_max=1000, period=period, laser_mode=False), clocks)
        assert high(periods(outputs, period)[2]) == 60


def test_parameters():
    assert pwm_period(12e6, 1000) == 12000 and pwm_period(12e6, 7e3) == 1714
    assert min_period(64) == 50
    with pytest.raises(ValueError, match="at least 44"):
        ToolOutputs(s_max=100, period=40)
    with pytest.raises(TypeError, match="S of full power"):
        ToolOutputs(s_max=0, period=1000)
    with pytest.raises(TypeError, match="Laser mode"):
        ToolOutputs(s_max=100, period=1000, laser_mode=1)
    with pytest.raises(ValueError, match="above 0 Hz"):
        pwm_period(12e6, 0)


def test_machine_file_parameters():
    """The machine file's s_max and pwm_hz: the machine takes what the gateware takes."""
    from kontur.machine import Machine, MachineError
    clock = 12e6
    assert Machine(clock_hz=clock).pwm_period == 12000                  # 1 kHz: 12 000 clocks
    for hz in (1, 1000, 20_000, clock / 44, clock / 43.4, clock / 30, clock):
        machine = Machine(clock_hz=clock, pwm_hz=hz)
        try:
            ToolOutputs(s_max=machine.s_max, period=pwm_period(clock, hz))
        except ValueError:
            with pytest.raises(MachineError, match="pwm_hz"):
                machine.check()
        else:
            assert machine.check().pwm_period == round(clock / hz)
    assert Machine(clock_hz=clock, pwm_hz=clock / 44).pwm_period == 44
    with pytest.raises(MachineError, match="pwm_hz"):
        Machine(clock_hz=clock, pwm_hz=clock / 43).check()
    for s_max in (0, 1.5, 1 << 24, True):
        with pytest.raises(MachineError, match="s_max"):
            Machine(clock_hz=clock, s_max=s_max)
    assert Machine(clock_hz=clock, s_max=255.0).s_max == 255
