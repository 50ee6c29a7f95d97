"""Feed: step permissions for an engine (:class:`~kontur.hdl.engine.FeedSignature`)."""

from amaranth import *
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from ..elements._checks import check_width
from ..engine import FeedSignature
from ..spec import ONE, SQRT2          # one axial and one diagonal step (Q2.24)

__all__ = ["FeedDivider", "FeedGenerator", "Profile", "RampSignature", "ONE", "SQRT2",
           "rate_limit"]



def Profile():
    """The feed of one move (the FEED frame of :mod:`kontur.hdl.motion.link`): its cruise and exit
    rates in steps a clock (Q0.24), and the steps it makes before it ramps down to the exit
    rate."""
    return data.StructLayout({"cruise": 24, "exit": 24, "decelerate": 24})


class RampSignature(wiring.Signature):
    """What the feed generator ramps toward, as its source (the controller's turn queue)
    sees it.

    Members
    -------
    profile : :py:`Out(Profile())`
        The running move's feed.
    start : :py:`Out(1)`
        A move begins in this clock: its step count starts from zero.
    """

    def __init__(self):
        super().__init__({"profile": Out(Profile()), "start": Out(1)})

    def __eq__(self, other):
        return type(other) is type(self)

    def __hash__(self):
        return hash(type(self))

    def __repr__(self):
        return "RampSignature()"


def rate_limit(min_interval):
    """The highest rate (Q0.24) that keeps axial steps ``min_interval`` clocks apart."""
    return ((1 << 24) - 1) // min_interval


class FeedDivider(wiring.Component):
    """A fixed feed: one step permission every ``divider`` clocks.

    :py:`feed.tick` is high in one clock of every ``divider``, counting from reset, except
    while :py:`pause` is high; a permission the engine has no step due for is not kept. For an
    engine with a step due in every clock of a program (a line engine's segments back to back)
    this is one step every ``divider`` clocks.

    Parameters
    ----------
    divider : :class:`int`
        Clocks per permission.

    Members
    -------
    feed : :py:`In(FeedSignature())`
        To the engine's :py:`feed`.
    pause : :py:`In(1)`
        No permission while high.

    Raises
    ------
    :exc:`TypeError`
        If ``divider`` is not a positive integer.
    """

    def __init__(self, divider):
        check_width("Tick divider", divider)
        self._divider = divider
        super().__init__({"feed": In(FeedSignature()), "pause": In(1)})

    @property
    def divider(self):
        return self._divider

    def elaborate(self, platform):
        m = Module()
        phase = Signal(range(self._divider))
        last = phase == self._divider - 1
        m.d.sync += phase.eq(Mux(last, 0, phase + 1))
        m.d.comb += self.feed.tick.eq(last & ~self.pause)
        return m


class FeedGenerator(wiring.Component):
    """The feed: step permissions at a contour speed ramped between a move's rates.

    The seeds' block 15. A rate (steps a clock, kept to 40 fractional bits) changes by
    :py:`accel` every clock toward the move's ``cruise`` rate, and after ``decelerate`` steps
    of the move toward its ``exit`` rate; it never overshoots either and never exceeds
    ``max_rate``. A move starts at the rate the move before ended at, so the rate is
    continuous across moves and no step interval ever changes faster than the acceleration
    allows (the host's planner chooses each move's exit rate so that the next can go on from
    it, or stop). Every clock the rate is added to a distance accumulator; a step is permitted
    when the accumulator holds the length of the engine's next step: 1 for an axial step, √2
    for a diagonal (:py:`feed.diagonal`), so the tool moves along the contour at the rate
    whatever the direction. A step made takes its length off the accumulator; while a
    permission waits for the engine (or :py:`hold` is high) the accumulator stands still, so
    a wait never turns into a burst.

    Parameters
    ----------
    max_rate : :class:`int`
        The highest rate, Q0.24 (default: one step a clock); see :func:`rate_limit`.

    Members
    -------
    feed : :py:`In(FeedSignature())`
        To the engine.
    ramp : :py:`In(RampSignature())`
        The running move's feed (:py:`ramp.profile`), and its start (:py:`ramp.start`).
    accel : :py:`In(32)`
        The rate's change a clock, Q0.40 (the configured acceleration).
    hold : :py:`In(1)`
        No permission while high (the rate goes on).
    rate : :py:`Out(24)`
        The rate now, Q0.24.
    steps : :py:`Out(24)`
        Steps of the running move so far.

    Raises
    ------
    :exc:`TypeError`
        If ``max_rate`` is not an integer from 1 to 2**24 - 1.
    """

    def __init__(self, *, max_rate=(1 << 24) - 1):
        check_width("Highest rate", max_rate)
        if max_rate >= 1 << 24:
            raise TypeError(f"Highest rate must be below 2**24 (one step a clock), "
                            f"not {max_rate!r}")
        self._max_rate = max_rate
        super().__init__({
            "feed":    In(FeedSignature()),
            "ramp":    In(RampSignature()),
            "accel":   In(32),
            "hold":    In(1),
            "rate":    Out(24),
            "steps":   Out(24),
        })

    @property
    def max_rate(self):
        return self._max_rate

    def elaborate(self, platform):
        m = Module()
        p = self.ramp.profile
        rate = Signal(40)                       # Q0.40
        distance = Signal(26)                   # Q2.24: below √2 + 1
        steps = Signal(24)

        target = Signal(40)
        wanted = Mux(steps < p.decelerate, p.cruise, p.exit)
        m.d.comb += target.eq(Mux(wanted > self._max_rate, self._max_rate, wanted) << 16)
        # One step of the ramp toward the target, and the target itself where that step would
        # pass it: three carry chains (the direction, the step, the overshoot), not five.
        up = Signal()
        m.d.comb += up.eq(rate <= target)
        moved = Signal(41)
        m.d.comb += moved.eq(Mux(up, rate + self.accel, rate - self.accel))
        passed = Signal()
        m.d.comb += passed.eq(Mux(up, moved >= target, moved[40] | (moved <= target)))
        m.d.sync += rate.eq(Mux(passed, target, moved[:40]))

        length = Mux(self.feed.diagonal, SQRT2, ONE)
        tick = Signal()
        step = Signal()
        grown = distance + rate[16:]
        m.d.comb += [
            tick.eq(~self.hold & (distance >= length)),
            self.feed.tick.eq(tick),
            step.eq(tick & self.feed.due),
            self.rate.eq(rate[16:]),
            self.steps.eq(steps),
        ]
        with m.If(step):
            m.d.sync += distance.eq(grown - length)
        with m.Elif(~self.hold & ~tick):            # a pending permission holds its distance
            m.d.sync += distance.eq(grown)
        with m.If(self.ramp.start):
            m.d.sync += steps.eq(Mux(step, 1, 0))
        with m.Elif(step):
            m.d.sync += steps.eq(steps + 1)
        return m
