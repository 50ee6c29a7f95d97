"""Contracts of the element library (``hdl/elements/``), each element with free inputs.

Every harness checks, in every clock after the first (``started``), that the element's
contents are what its docstring promises given the inputs of the clock before: the load and
clear priorities, the counts, the number codes, the taps.
"""

from amaranth import *
from amaranth.hdl import Assert, Assume

from ..elements import (AccumulatingAdder, Commutator, DelayElement, PulseExtender,
                        PulseGenerator, ReversibleCounter, Trigger)
from ._util import free, minus_zero, ones_value, past, state_register

__all__ = ["CounterProperties", "AdderProperties", "CommutatorProperties",
           "DelayProperties", "TriggerProperties", "GeneratorProperties",
           "ExtenderProperties"]


def _started(m):
    started = Signal(name="started")
    m.d.sync += started.eq(1)
    return started


def _in_range(value, width):
    """``value`` is a number a ``width``-bit ones'-complement code can hold."""
    limit = (1 << (width - 1)) - 1
    return (value >= -limit) & (value <= limit)


class CounterProperties(Elaboratable):
    """:class:`~kontur.hdl.elements.ReversibleCounter`: load over clear over counting, the count
    ``up - down - 2·down2``, ``q_n``, ``q_next``, ``underflow``; in ones' complement the
    count on the numbers the codes stand for, and counting down never yields −0. ``parallel``:
    the counter's parallel form (every count formed, the count inputs picking one), the same
    claims."""

    def __init__(self, width, *, ones_complement=False, parallel=False):
        self.width = width
        self.ones_complement = ones_complement
        self.parallel = parallel

    def elaborate(self, platform):
        m = Module()
        w = self.width
        m.submodules.counter = c = ReversibleCounter(w, ones_complement=self.ones_complement,
                                                     parallel=self.parallel)
        free(m, c.d, c.load, c.clr, c.up, c.down, c.down2)
        started = _started(m)
        count = c.up - c.down - 2 * c.down2
        was = {name: past(m, value, name=f"past_{name}") for name, value in (
            ("load", c.load), ("clr", c.clr), ("d", c.d), ("q", c.q), ("count", count))}
        was_q_next = past(m, c.q_next, name="past_q_next")
        m.d.comb += [
            Assert(c.q_n == ~c.q, "q_n inverts q"),
            Assert(c.underflow == ((c.q >= 0) & (c.q_next < 0)), "underflow: q >= 0, q_next < 0"),
        ]
        with m.If(started & was["load"]):
            m.d.comb += Assert(c.q == was["d"], "load wins")
        with m.If(started & ~was["load"] & was["clr"]):
            m.d.comb += Assert(c.q == 0, "clear wins over counting")
        with m.If(started & ~was["load"] & ~was["clr"]):
            m.d.comb += Assert(c.q == was_q_next, "q becomes q_next")
        if not self.ones_complement:
            m.d.comb += Assert(c.q_next == (c.q + count)[:w].as_signed(),
                               "q_next = q + up - down - 2 down2 (mod 2**width)")
        else:
            exact = Signal(signed(w + 3))
            m.d.comb += exact.eq(ones_value(c.q, w) + count)
            with m.If(_in_range(exact, w)):
                m.d.comb += Assert(ones_value(c.q_next, w) == exact,
                                   "ones' complement: the number counts by the count")
            with m.If(~c.up & (c.down | c.down2)):
                m.d.comb += Assert(~minus_zero(c.q_next), "counting down never yields -0")
        return m


class AdderProperties(Elaboratable):
    """:class:`~kontur.hdl.elements.AccumulatingAdder`: load over clear over add over add2 over
    subtract, the sums, the sign outputs; in ones' complement the sum of the numbers the codes
    stand for, and no sum or difference is −0 unless the contents were −0 already."""

    def __init__(self, width, *, ones_complement=False):
        self.width = width
        self.ones_complement = ones_complement

    def elaborate(self, platform):
        m = Module()
        w = self.width
        m.submodules.adder = a = AccumulatingAdder(w, ones_complement=self.ones_complement)
        free(m, a.d, a.load, a.clr, a.b, a.add, a.b2, a.add2, a.sub)
        started = _started(m)
        was = {name: past(m, value, name=f"past_{name}") for name, value in (
            ("load", a.load), ("clr", a.clr), ("add", a.add), ("add2", a.add2),
            ("sub", a.sub), ("d", a.d), ("b", a.b), ("b2", a.b2), ("q", a.q))}
        m.d.comb += [
            Assert(a.sign == (a.q < 0), "sign: the contents are negative"),
            Assert(a.sign_n == ~a.sign, "sign_n inverts sign"),
        ]
        counting = started & ~was["load"] & ~was["clr"]
        with m.If(started & was["load"]):
            m.d.comb += Assert(a.q == was["d"], "load wins")
        with m.If(started & ~was["load"] & was["clr"]):
            m.d.comb += Assert(a.q == 0, "clear wins over add and subtract")
        second = ~was["add"] & was["add2"]              # add2, add not asserted
        subtract = ~was["add"] & ~was["add2"] & was["sub"]
        with m.If(counting & ~was["add"] & ~was["add2"] & ~was["sub"]):
            m.d.comb += Assert(a.q == was["q"], "no strobe: the contents hold")
        if not self.ones_complement:
            with m.If(counting & was["add"]):
                m.d.comb += Assert(a.q == (was["q"] + was["b"])[:w].as_signed(), "q += b")
            with m.If(counting & second):
                m.d.comb += Assert(a.q == (was["q"] + was["b2"])[:w].as_signed(), "q += b2")
            with m.If(counting & subtract):
                m.d.comb += Assert(a.q == (was["q"] - was["b"])[:w].as_signed(), "q -= b")
        else:
            total = Signal(signed(w + 2))
            total2 = Signal(signed(w + 2))
            difference = Signal(signed(w + 2))
            m.d.comb += [
                total.eq(ones_value(was["q"], w) + ones_value(was["b"], w)),
                total2.eq(ones_value(was["q"], w) + ones_value(was["b2"], w)),
                difference.eq(ones_value(was["q"], w) - ones_value(was["b"], w)),
            ]
            with m.If(counting & was["add"] & _in_range(total, w)):
                m.d.comb += Assert(ones_value(a.q, w) == total, "ones' complement: q += b")
            with m.If(counting & second & _in_range(total2, w)):
                m.d.comb += Assert(ones_value(a.q, w) == total2, "ones' complement: q += b2")
            with m.If(counting & subtract & _in_range(difference, w)):
                m.d.comb += Assert(ones_value(a.q, w) == difference,
                                   "ones' complement: q -= b")
            with m.If(counting & (was["add"] | was["add2"] | was["sub"])
                      & ~minus_zero(was["q"])):
                m.d.comb += Assert(~minus_zero(a.q), "a sum is never -0")
        return m


class CommutatorProperties(Elaboratable):
    """:class:`~kontur.hdl.elements.Commutator` with at most one control input at a time: the
    output is the selected channel's code (its input shifted up, the separate bit below),
    sign-extended, or zero; read in ones' complement a shifted code ``c`` stands for
    ``2c + lsb`` (``c >= 0``) or ``2c - 1 + lsb`` (``c < 0``)."""

    def __init__(self, in_width, out_width, *, channels, shift=1):
        self.in_width = in_width
        self.out_width = out_width
        self.channels = channels
        self.shift = shift

    def elaborate(self, platform):
        m = Module()
        iw, ow = self.in_width, self.out_width
        m.submodules.commutator = c = Commutator(iw, ow, channels=self.channels,
                                                 shift=self.shift)
        for i in range(self.channels):
            free(m, c.b[i], c.lsb[i], c.a[i])
        controls = Cat(*c.a)
        m.d.comb += Assume((controls & (controls - 1)) == 0)      # one-hot or none
        m.d.comb += Assert(c.strobe == controls.any(), "strobe: some channel is selected")
        with m.If(~controls.any()):
            m.d.comb += Assert(c.o == 0, "no channel: the output is zero")
        for i in range(self.channels):
            with m.If(c.a[i]):
                if self.shift:
                    code = Cat(c.lsb[i], c.b[i]).as_signed()
                    m.d.comb += Assert(c.o == code, f"channel {i + 1}: 2b + lsb")
                    number = Signal(signed(ow + 2), name=f"number{i + 1}")
                    value = ones_value(c.b[i], iw)
                    m.d.comb += number.eq(Mux(c.b[i] < 0, 2 * value - 1, 2 * value)
                                          + c.lsb[i])
                    m.d.comb += Assert(ones_value(c.o, ow) == number,
                                       f"channel {i + 1}: the ones' complement reading")
                else:
                    m.d.comb += Assert(c.o == c.b[i], f"channel {i + 1}: b")
        return m


class DelayProperties(Elaboratable):
    """:class:`~kontur.hdl.elements.DelayElement`: tap ``j`` shows the input of ``taps[j]`` clocks
    ago, unless a clear came in between (the clear's own clock included)."""

    def __init__(self, taps):
        self.taps = tuple(taps)

    def elaborate(self, platform):
        m = Module()
        d = DelayElement(self.taps)
        m.submodules.delay, line = state_register(d, "line")
        free(m, d.i, d.clr)
        depth = max(self.taps)
        seen = [d.i]                          # seen[k]: the input k clocks ago
        cleared = [d.clr]                     # cleared[k]: the clear k clocks ago
        for k in range(1, depth + 1):
            seen.append(past(m, seen[-1], name=f"i_{k}"))
            cleared.append(past(m, cleared[-1], name=f"clr_{k}"))
        for k in range(depth):                # the line itself: 1-inductive
            m.d.comb += Assert(line[k] == (seen[k + 1] & ~Cat(*cleared[1:k + 2]).any()),
                               "the line holds the inputs not yet cleared")
        for j, tap in enumerate(self.taps):
            dropped = Cat(*cleared[1:tap + 1]).any()
            m.d.comb += Assert(d.o[j] == (seen[tap] & ~dropped),
                               f"tap {j + 1}: the input {tap} clocks ago")
        return m


class TriggerProperties(Elaboratable):
    """:class:`~kontur.hdl.elements.Trigger`: set, reset, hold, and the priority when both come."""

    def __init__(self, *, priority="reset"):
        self.priority = priority

    def elaborate(self, platform):
        m = Module()
        m.submodules.trigger = t = Trigger(priority=self.priority)
        free(m, t.set, t.reset)
        started = _started(m)
        was_set = past(m, t.set, name="past_set")
        was_reset = past(m, t.reset, name="past_reset")
        was_q = past(m, t.q, name="past_q")
        both = 1 if self.priority == "set" else 0
        m.d.comb += Assert(t.q_n == ~t.q, "q_n inverts q")
        with m.If(started):
            m.d.comb += Assert(t.q == Mux(was_set & was_reset, both,
                                          Mux(was_set, 1, Mux(was_reset, 0, was_q))),
                               f"set, reset, hold; both: {self.priority} wins")
        return m


class GeneratorProperties(Elaboratable):
    """:class:`~kontur.hdl.elements.PulseGenerator`: a pulse on every ``period``-th enabled clock,
    the first one included, never without :py:`en`; :py:`armed` says the next enabled clock
    pulses."""

    def __init__(self, period):
        self.period = period

    def elaborate(self, platform):
        m = Module()
        g = PulseGenerator(self.period)
        m.submodules.generator, phase = (state_register(g, "phase") if self.period > 1
                                         else (g, None))
        free(m, g.en)
        enabled = Signal(range(self.period), name="enabled")  # enabled clocks so far, mod p
        with m.If(g.en):
            m.d.sync += enabled.eq(Mux(enabled == self.period - 1, 0, enabled + 1))
        m.d.comb += [
            Assert(g.o == (g.en & (enabled == 0)), "a pulse every period-th enabled clock"),
            Assert(g.armed == (enabled == 0), "armed: the next enabled clock pulses"),
        ]
        if phase is not None:
            m.d.comb += Assert(phase == enabled, "the phase counts the enabled clocks")
        return m


class ExtenderProperties(Elaboratable):
    """:class:`~kontur.hdl.elements.PulseExtender`: the gate is open in the ``length`` clocks after
    the last pulse (a pulse restarts it), unless a clear came after that pulse."""

    def __init__(self, length):
        self.length = length

    def elaborate(self, platform):
        m = Module()
        n = self.length
        e = PulseExtender(n)
        m.submodules.extender, left = state_register(e, "left")
        free(m, e.i, e.clr)
        since = Signal(range(n + 2), name="since", init=n + 1)   # clocks since the last
        with m.If(e.clr):                                        # pulse, n + 1: long ago
            m.d.sync += since.eq(n + 1)
        with m.Elif(e.i):
            m.d.sync += since.eq(1)
        with m.Elif(since <= n):
            m.d.sync += since.eq(since + 1)
        m.d.comb += [
            Assert(e.o == (since <= n), "open for length clocks after the last pulse"),
            Assert(e.o_n == ~e.o, "o_n inverts o"),
            Assert(left == Mux(since <= n, n + 1 - since, 0), "the count: clocks still open"),
        ]
        return m
