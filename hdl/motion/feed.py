"""Feed: step permissions for an engine (:class:`~kontur.hdl.engine.FeedSignature`)."""

from amaranth import *
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from ..elements._checks import check_width
from ..engine import FeedSignature
from ..spec import ONE, SQRT2, STEP_LENGTHS   # the steps' lengths (Q2.24)

__all__ = ["FeedDivider", "FeedGenerator", "Profile", "RampSignature", "ONE", "SQRT2",
           "rate_limit", "override", "OVERRIDE_ONE", "LOOKAHEAD_MARGIN"]



def Profile():
    """The feed of one move (the FEED frame of :mod:`kontur.hdl.motion.link`): its cruise and exit
    rates in steps a clock (Q0.24), the steps it makes before it ramps down to the exit
    rate, and whether it is a rapid (G0: the rapid override applies to it)."""
    return data.StructLayout({"cruise": 24, "exit": 24, "decelerate": 24, "rapid": 1})


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


#: The feed override's unit: :py:`feed_override` is the factor times 128 (Q2.7), so 128 is
#: 100 %, 256 200 % and 13 about 10 %.
OVERRIDE_ONE = 128

#: Steps of margin in the ramp-down look-ahead of an overridden move
#: (:class:`FeedGenerator`): the look-ahead's lag (a clock, and a clock more for the target
#: register), the step counter's and the
#: accumulator's granularity, and the grid of the deceleration (docs/controller.md).
LOOKAHEAD_MARGIN = 16


def override(percent):
    """The :py:`feed_override` factor (Q2.7) nearest ``percent`` (10 to 200)."""
    if isinstance(percent, bool) or not isinstance(percent, int) or not 10 <= percent <= 200:
        raise ValueError(f"Feed override must be a whole percentage from 10 to 200, "
                         f"not {percent!r}")
    return (percent * OVERRIDE_ONE + 50) // 100


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
    permission waits for the engine the accumulator stands still, so a wait never turns into
    a burst.

    The target the rate moves toward is a register computed a clock ahead (from the move's
    profile, its step count, the hold and the overrides of the clock before), so the turn
    queue's output never reaches the rate's adder in one clock: the rate follows a move's
    start, its ramp-down step, a hold and its release a clock after them.

    **Hold.** While :py:`hold` is high the rate ramps toward zero at the same acceleration:
    the steps go on, slower and slower, until the rate is zero (:py:`held`); then no
    permission is given (not even one already earned). When :py:`hold` drops the rate ramps
    back toward the move's target. The steps are the engine's, so a held run makes the same
    steps as an uninterrupted one; only their times differ.

    **Overrides.** The cruise rate is scaled by the feed override (:py:`feed_override`, Q2.7:
    128 is 100 %), or for a rapid move (:py:`rapid`) by the rapid override
    (:py:`rapid_override`: 100 %, 50 %, 25 % for 0, 1, 2). The scaled cruise is worked out by a
    sequential multiplier (9 clocks) when a move starts or the factor changes, never in the
    rate's loop; until it is ready (the rate's target takes it 11 clocks after a move's start or
    a change of the factor) the rate ramps toward the unscaled cruise. Below 100 % the exit
    target is the lower of the exit and the scaled cruise. Above 100 % the rate passes the
    cruise the planner timed the ramp-down for, and the planned ramp-down step would come too
    late: a look-ahead counts the distance it takes to come back down to the cruise from the
    rate now (every clock the rate rises above the cruise it adds the rate; every full step down
    it takes the rate off), and the ramp-down starts where that distance and a margin of
    :data:`LOOKAHEAD_MARGIN` steps reach the planned ramp-down step. So the move still reaches
    its exit rate before its end. With :py:`hold` low and both overrides at 100 % the generator
    is exactly the one without these inputs.

    Parameters
    ----------
    max_rate : :class:`int`
        The highest rate, Q0.24 (default: one step a clock); see :func:`rate_limit`.
    overrides : :class:`bool`
        With ``False`` the override inputs are ignored (always 100 %) and their multiplier
        and look-ahead are not built; hold works the same (for a device too small for them).
    axes : :class:`int`
        2 (default) or 3: the engines' axes; on three a step is 1, √2 or √3 long
        (:py:`feed.diagonal` 0, 1, 2; :data:`~kontur.hdl.spec.STEP_LENGTHS`).

    Members
    -------
    feed : :py:`In(FeedSignature(axes))`
        To the engine.
    ramp : :py:`In(RampSignature())`
        The running move's feed (:py:`ramp.profile`), and its start (:py:`ramp.start`).
    accel : :py:`In(32)`
        The rate's change a clock, Q0.40 (the configured acceleration).
    hold : :py:`In(1)`
        Feed hold (a level): ramp down to a standstill, then no permission; resume on its fall.
    feed_override : :py:`In(9, init=128)`
        The feed override, Q2.7 (:func:`override`): the controller sends 13 to 256 (10 % to
        200 %).
    rapid_override : :py:`In(2)`
        The rapid override: the cruise of a rapid move shifted right by it (0: 100 %, 1: 50 %,
        2: 25 %).
    rapid : :py:`In(1)`
        The running move is a rapid (G0): :py:`rapid_override` applies, not
        :py:`feed_override`.
    rate : :py:`Out(24)`
        The rate now, Q0.24.
    steps : :py:`Out(24)`
        Steps of the running move so far.
    held : :py:`Out(1)`
        At a standstill under :py:`hold`.

    Raises
    ------
    :exc:`TypeError`
        If ``max_rate`` is not an integer from 1 to 2**24 - 1, or ``overrides`` not a
        :class:`bool`.
    """

    def __init__(self, *, max_rate=(1 << 24) - 1, overrides=True, axes=2):
        if axes not in (2, 3):
            raise ValueError(f"Axes must be 2 or 3, not {axes!r}")
        self._axes = axes
        check_width("Highest rate", max_rate)
        if max_rate >= 1 << 24:
            raise TypeError(f"Highest rate must be below 2**24 (one step a clock), "
                            f"not {max_rate!r}")
        if not isinstance(overrides, bool):
            raise TypeError(f"Overrides must be True or False, not {overrides!r}")
        self._max_rate = max_rate
        self._overrides = overrides
        super().__init__({
            "feed":           In(FeedSignature(axes)),
            "ramp":           In(RampSignature()),
            "accel":          In(32),
            "hold":           In(1),
            "feed_override":  In(9, init=OVERRIDE_ONE),
            "rapid_override": In(2),
            "rapid":          In(1),
            "rate":           Out(24),
            "steps":          Out(24),
            "held":           Out(1),
        })

    @property
    def max_rate(self):
        return self._max_rate

    @property
    def overrides(self):
        return self._overrides

    def _clamp(self, value):
        return Mux(value > self._max_rate, self._max_rate, value)

    def elaborate(self, platform):
        m = Module()
        p, start = self.ramp.profile, self.ramp.start
        rate = Signal(40)                       # Q0.40
        steps = Signal(24)
        scaled, slower, ready = self._scale(m)
        rose, fell = Signal(), Signal()         # how the rate changes at this clock's edge
        down = self._lookahead(m, rate, steps, rose, fell)

        # The target: zero under hold; the exit from the ramp-down on (the scaled cruise if
        # lower, below 100 %); else the cruise, scaled once its product is ready.
        use = ready & ~start
        cruise, exit, wanted = Signal(26), Signal(26), Signal(26)
        m.d.comb += [
            cruise.eq(Mux(use, scaled, p.cruise)),
            exit.eq(Mux(use & slower & (scaled < p.exit), scaled, p.exit)),
            wanted.eq(Mux(down, exit, cruise)),
        ]
        # The target is a register, computed a clock ahead: the turn queue's output (its FIFO's
        # read) never reaches the rate's adder in the same clock. So the rate follows a change
        # of the target (a move's start, its ramp-down, a hold and its release) a clock late.
        target = Signal(40)
        holding = Signal()                      # the hold the target was computed under
        m.d.sync += [target.eq(Mux(self.hold, 0, self._clamp(wanted) << 16)),
                     holding.eq(self.hold)]
        # One step of the ramp toward the target, and the target itself where that step would
        # pass it: three carry chains (the direction, the step, the overshoot), not five.
        up = Signal()
        m.d.comb += up.eq(rate < target)
        moved = Signal(41)
        m.d.comb += moved.eq(Mux(up, rate + self.accel, rate - self.accel))
        passed = Signal()
        m.d.comb += passed.eq(Mux(up, moved >= target, moved[40] | (moved <= target)))
        m.d.sync += rate.eq(Mux(passed, target, moved[:40]))
        m.d.comb += [rose.eq(up), fell.eq(~up & ~passed)]

        # Held: the clock before moved toward the hold's target (zero) and reached it.
        zero = Signal()
        m.d.sync += zero.eq(holding & passed)
        stopped = Signal()
        m.d.comb += stopped.eq(self.hold & zero)
        self._steps(m, rate, steps, stopped)
        m.d.comb += [self.rate.eq(rate[16:]), self.steps.eq(steps), self.held.eq(stopped)]
        return m

    def _scale(self, m):
        """The scaled cruise, ``cruise * factor >> 7`` (26 bits, clamped with the target), by a
        sequential multiplier (one bit of the factor a clock, high bit first) restarted at a
        move's start and whenever the factor changes. Returns it, whether its factor is below
        100 %, and whether it is ready (for the running move and the factor now)."""
        p, start = self.ramp.profile, self.ramp.start
        if not self._overrides:
            return p.cruise, C(0), C(0)
        factor = Signal(9)
        m.d.comb += factor.eq(Mux(self.rapid, OVERRIDE_ONE >> self.rapid_override,
                                  self.feed_override))
        used = Signal(9, init=OVERRIDE_ONE)     # the factor of the product
        busy = Signal()
        bit = Signal(range(9))                  # the factor's bit to take, high first
        product = Signal(33)
        ready = Signal()
        with m.If(start | (factor != used)):
            m.d.sync += [used.eq(factor), busy.eq(1), bit.eq(8), product.eq(0), ready.eq(0)]
        with m.Elif(busy):
            m.d.sync += [
                product.eq((product << 1) + Mux(used.bit_select(bit, 1), p.cruise, 0)),
                bit.eq(bit - 1),
            ]
            with m.If(bit == 0):
                m.d.sync += [busy.eq(0), ready.eq(1)]
        return product[7:], used < OVERRIDE_ONE, ready

    def _lookahead(self, m, rate, steps, rose, fell):
        """Whether the move ramps down now: from its planned step on, or earlier where the rate
        above the planned cruise needs the distance.

        ``extra`` (Q17.16 step lengths) is the distance the rate of the clock before takes to
        come down to the cruise at the acceleration, plus :data:`LOOKAHEAD_MARGIN`: a clock
        later than the rate, on a rise it adds the rate (rounded up: exact or more for a full
        step, more for a part), on a full step down it takes the new rate off (a little less
        than exact), and it stands on a part step down; the changes in a move's start clock and
        the clock after (toward targets computed before the move's step count was reset) are
        not counted. Reset (to the margin) at a move's start and while the rate (whole Q0.24)
        is not above the cruise. The ramp-down begins when the steps made and ``extra`` reach
        the planned step, or ``extra`` reaches 2**16 steps; it is latched until the next
        move."""
        p, start = self.ramp.profile, self.ramp.start
        if not self._overrides:
            return steps >= p.decelerate
        # This move's changes: not in its start's clock (toward the move before's target) nor
        # in the clock after (toward the target computed in the start's clock, from the move
        # before's step count), as the target is a clock behind.
        after = Signal()                        # the clock after a move's start
        m.d.sync += after.eq(start)
        theirs = Signal()
        m.d.comb += theirs.eq(start | after)
        rose_q, fell_q = Signal(), Signal()
        m.d.sync += [rose_q.eq(rose & ~theirs), fell_q.eq(fell & ~theirs)]
        extra = Signal(33, init=LOOKAHEAD_MARGIN << 16)
        above = Signal()                        # the rate rose above the cruise
        now = Signal(33)
        m.d.comb += now.eq(Mux(fell_q, Cat(~rate[24:], C((1 << 17) - 1, 17)), rate[24:]))
        summed = Signal(34)                     # extra + now + 1: the 1 as a carry in
        m.d.comb += summed.eq(Cat(C(1, 1), extra) + Cat(C(1, 1), now))
        with m.If(start | (rate[16:] <= p.cruise)):
            m.d.sync += [extra.eq(LOOKAHEAD_MARGIN << 16), above.eq(0)]
        with m.Elif(rose_q | fell_q):
            m.d.sync += [extra.eq(summed[1:]), above.eq(above | rose_q)]
        # One subtraction for the planned step and the look-ahead: ``left`` is
        # ``decelerate - steps - 1`` (its bit 24 set while steps < decelerate), and
        # steps + extra >= decelerate where the whole steps of extra exceed it.
        left = Signal(25)
        m.d.comb += left.eq(p.decelerate + (~steps & ((1 << 24) - 1)))
        planned = ~left[24]
        early = Signal()
        m.d.comb += early.eq(above & (extra[32] | planned | (left[:24] < extra[16:32])))
        latched = Signal()                      # the ramp-down began early in this move
        m.d.sync += latched.eq(~start & (latched | early))
        down = Signal()
        m.d.comb += down.eq((latched & ~start) | planned)
        return down

    def _steps(self, m, rate, steps, stopped):
        """The distance accumulator, the permissions and the move's step count."""
        distance = Signal(26)                   # Q2.24: below √3 + 1
        length = Mux(self.feed.diagonal, SQRT2, ONE) if self._axes == 2 else \
            Array(C(n, 26) for n in STEP_LENGTHS)[self.feed.diagonal]   # 1, √2, √3
        # The distance against every step length at once, the step's length (the engine's
        # diagonal, late in the clock) choosing among the results: the diagonal reaches no
        # comparator.
        lengths = (ONE, SQRT2) if self._axes == 2 else STEP_LENGTHS
        reached = Array(distance >= C(n, 26) for n in lengths)[self.feed.diagonal]
        tick = Signal()
        step = Signal()
        grown = distance + rate[16:]
        m.d.comb += [
            tick.eq(~stopped & reached),
            self.feed.tick.eq(tick),
            step.eq(tick & self.feed.due),
        ]
        with m.If(step):
            m.d.sync += distance.eq(grown - length)
        with m.Elif(~tick):                         # a pending permission holds its distance
            m.d.sync += distance.eq(grown)
        with m.If(self.ramp.start):
            m.d.sync += steps.eq(Mux(step, 1, 0))
        with m.Elif(step):
            m.d.sync += steps.eq(steps + 1)
