"""The textbook's interpolators: estimating function with separate steps (line and circle), DDA.

The excerpt (seed ``004``, ``docs/textbook.md``) describes two methods of hardware
interpolation: the estimating function with separate steps along the coordinates (one axis per
step; its Fig. 11) and the digital differential analyser (ЦДА). Each core here is one of them
as a core of the common engines: :class:`SeparateLineCore` and :class:`DdaCore` are line cores
(:class:`~kontur.hdl.line.LineCoreSignature`), :class:`SeparateArcCore` a quadrant core
(:class:`~kontur.hdl.arc.ArcCoreSignature`) for :class:`~kontur.hdl.arc.ArcEngine`, whose planner plans the
quadrants. The text gives no circuit for these (its Fig. 12 node is :mod:`kontur.hdl.serial`), so the
cores are built of the element library, one step per clock: a register of the estimating
function, counters of the coordinates, a commutator for the increments.
"""

from amaranth import *
from amaranth.lib import wiring

from .arc import ArcCoreSignature
from .elements import (AccumulatingAdder, CapacityRegister, Commutator, ReversibleCounter,
                       Trigger)
from .elements._checks import check_choice, check_width
from .engine import permit
from .line import LineCoreSignature

__all__ = ["SeparateLineCore", "SeparateArcCore", "DdaCore", "DDA_PRESETS", "DDA_CAPACITIES"]

DDA_PRESETS = ("half", "zero")
DDA_CAPACITIES = ("segment", "register")


class SeparateLineCore(wiring.Component):
    """Line core: the estimating function with separate steps, one step per permission.

    The segment to magnitudes ``(X, Y)`` takes ``X + Y`` steps, each along one axis. Adder D
    holds ``D = 2F(x + 1/2, y + 1/2) = 2(y·X - x·Y) + X - Y``: the text's estimating function at
    the midpoint of the two points the next step can reach. ``D >= 0`` (its sign flip-flop
    clear) makes an X step and ``D -= 2Y``; ``D < 0`` a Y step and ``D += 2X``; the increments
    come through a commutator from two registers holding X and Y, shifted one place (times two).
    The counters hold the steps left on each axis. An exhausted axis is never chosen: at
    ``x = X`` D is negative, at ``y = Y`` it is not; so the last step is the one made when the
    counters hold one step in all, whichever axis it is on.

    The sign selects the increment before the adder's carry chain (``2X``, or a register of
    ``-2Y``) and the step only enables the sum, as in the bare accumulator; the other decisions
    (the last step, whether the prepared segment may be taken) come from flip-flops formed a
    clock ahead.

    A segment taken from :py:`cmd` is prepared and started as soon as the core is idle, or in
    the clock of the running segment's last step; a segment of length zero starts and ends in
    an idle clock. Every step is due while a segment runs (never diagonal); :py:`abort` clears
    the registers and drops the prepared segment.

    Parameters
    ----------
    width : :class:`int`
        Register width: magnitudes up to ``2**width - 1``; adder D has ``width + 2`` bits.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2.
    """

    def __init__(self, *, width=16):
        check_width("Register width", width, minimum=2)
        self.adder = AccumulatingAdder(width + 2)
        self.counter_x = ReversibleCounter(width + 1, parallel=True)
        self.counter_y = ReversibleCounter(width + 1, parallel=True)
        self.commutator = Commutator(width + 1, width + 2, channels=2, shift=1)
        self.trigger = Trigger(priority="set")
        super().__init__(LineCoreSignature(width))

    @property
    def width(self):
        return self.signature.width

    def elaborate(self, platform):
        m = Module()
        w = self.width
        for name in ("adder", "counter_x", "counter_y", "commutator", "trigger"):
            m.submodules[name] = getattr(self, name)
        adder, counter_x, counter_y = self.adder, self.counter_x, self.counter_y
        commutator, trigger = self.commutator, self.trigger
        payload = self.cmd.payload

        # The prepared segment, and what the start will need of it, decoded as it is taken.
        full = Signal()
        prepared_x = Signal(w)
        prepared_y = Signal(w)
        empty = Signal()                              # of length zero
        one = Signal()                                # of length one: its step is the last

        # The running segment. The next step is the last when the counters hold one step in
        # all, whichever axis it is on: the sign never chooses an exhausted axis, so with
        # (1, 0) left it makes the X step and with (0, 1) the Y step.
        run = trigger.q
        final = Signal()                              # one step left
        # What the decisions of the next clock need, registered: a segment may be taken at
        # the next step (idle, or the step left is the last) and is prepared (of length zero
        # or not).
        may_take = Signal()                           # full, and idle or final
        may_go = Signal()                             # ... and not of length zero
        idle_empty = Signal()                         # full of length zero, idle

        enable = permit(m, self.feed, armed=1, running=run, abort=self.abort)
        advance = Signal()                            # a step is permitted now, or the core idles
        move = Signal()
        x_step = Signal()
        y_step = Signal()
        take = Signal()
        go = Signal()
        end = Signal()
        m.d.comb += [
            advance.eq(self.feed.tick | ~run),
            move.eq(run & enable),
            x_step.eq(move & adder.sign_n),
            y_step.eq(move & adder.sign),
            take.eq(may_take & advance & ~self.abort),
            go.eq(may_go & advance & ~self.abort),
            end.eq((self.feed.tick & final) | self.abort),     # final only while running
            self.cmd.ready.eq(~full | take),
        ]

        # The next state of the flags above, from which the registered ones are formed.
        transfer = Signal()
        full_next = Signal()
        empty_next = Signal()
        run_next = Signal()
        final_next = Signal()
        cx, cy = counter_x.q, counter_y.q
        two_left = Signal()                           # the counters hold two steps in all
        m.d.comb += [
            transfer.eq(self.cmd.valid & self.cmd.ready),
            full_next.eq(transfer | (full & ~take & ~self.abort)),
            empty_next.eq(Mux(transfer, (payload.x == 0) & (payload.y == 0), empty)),
            run_next.eq(go | (run & ~end)),
            two_left.eq((cx[2:] == 0) & (cy[2:] == 0)
                        & (Cat(cx[:2], cy[:2]).matches("0010", "0101", "1000"))),
            final_next.eq(Mux(go, one, Mux(end, 0, Mux(move, two_left, final)))),
        ]
        # The payload is taken whenever the core may take one (full tells whether it did).
        with m.If(self.cmd.ready):
            m.d.sync += [prepared_x.eq(payload.x), prepared_y.eq(payload.y),
                         one.eq(((payload.x == 1) & (payload.y == 0))
                                | ((payload.x == 0) & (payload.y == 1)))]
        m.d.sync += [
            full.eq(full_next),
            empty.eq(empty_next),
            final.eq(final_next),
            may_take.eq(full_next & (~run_next | (final_next & ~empty_next))),
            may_go.eq(full_next & ~empty_next & (~run_next | final_next)),
            idle_empty.eq(full_next & empty_next & ~run_next),
        ]

        # The increments 2Y (X step) and 2X (Y step), held for the whole segment, and -2Y.
        reg_x = Signal(w)
        reg_y = Signal(w)
        minus_2y = Signal(signed(w + 2))
        with m.If(go):
            m.d.sync += [reg_x.eq(prepared_x), reg_y.eq(prepared_y),
                         minus_2y.eq(-Cat(0, prepared_y))]
        # The adder adds the increment its sign selects, as the bare accumulator does: the
        # choice precedes the carry chain, and the step only enables the sum. The commutator
        # shows the increment of the step made (its strobes are the steps).
        operand = Signal(signed(w + 2))
        m.d.comb += [
            operand.eq(Mux(adder.sign, Cat(0, reg_x), minus_2y)),
            commutator.b[0].eq(reg_y),
            commutator.a[0].eq(x_step),
            commutator.b[1].eq(reg_x),
            commutator.a[1].eq(y_step),
            adder.d.eq(prepared_x - prepared_y),
            adder.load.eq(go),
            adder.clr.eq(end),
            adder.b.eq(operand),
            adder.add.eq(move),
            counter_x.d.eq(prepared_x),
            counter_x.load.eq(go),
            counter_x.clr.eq(self.abort),
            counter_x.down.eq(x_step),
            counter_y.d.eq(prepared_y),
            counter_y.load.eq(go),
            counter_y.clr.eq(self.abort),
            counter_y.down.eq(y_step),
            trigger.set.eq(go),
            trigger.reset.eq(end),
            self.feed.diagonal.eq(0),
            self.step.eq(Cat(x_step, y_step)),
            self.start.eq(take),
            self.done.eq((run & end) | (~self.abort & idle_empty)),
            self.busy.eq(full | run),
        ]
        return m


class SeparateArcCore(wiring.Component):
    """Quadrant core: the estimating function with separate steps, one step per permission.

    A native run (X falls, Y rises) from ``(x, y)`` on the circle ``r2 = x² + y² + residue``
    steps until X = 0 (``2·Rn`` steps from the axis point ``(Rn, 0)``, ending on ``(0, Rn)``)
    or until :py:`stop`. Adder G holds ``G = F(x - 1/2, y + 1/2) - 1/2 = x² - x + y² + y - r2``,
    the text's estimating function at the midpoint of the two points the next step can reach
    (never zero there: no tie). ``G >= 0`` makes an X step and ``G -= 2x'``, ``G < 0`` a Y step
    and ``G += 2y'`` (primes: after the step); counter X holds ``x - 1`` and counter Y ``y + 1``,
    so each increment is twice the present contents of one counter, through a commutator. The
    run ends with the X step taken while counter X holds 0.

    A run taken from :py:`cmd` is prepared (``G0 = y - x - residue``) and started as soon as the
    core is idle, or in the clock the running one stops. Every step is due while a run runs
    (never diagonal); :py:`abort` clears the registers and drops the prepared run.

    Parameters
    ----------
    width : :class:`int`
        Register width: coordinates up to ``2**width - 1``; adder G has ``width + 2`` bits.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2.
    """

    def __init__(self, *, width=24):
        check_width("Register width", width, minimum=2)
        self.adder = AccumulatingAdder(width + 2)
        self.counter_x = ReversibleCounter(width + 1, parallel=True)
        self.counter_y = ReversibleCounter(width + 2, parallel=True)
        self.commutator = Commutator(width + 1, width + 2, channels=2, shift=1)
        self.trigger = Trigger(priority="set")
        super().__init__(ArcCoreSignature(width))

    @property
    def width(self):
        return self.signature.width

    def elaborate(self, platform):
        m = Module()
        w = self.width
        for name in ("adder", "counter_x", "counter_y", "commutator", "trigger"):
            m.submodules[name] = getattr(self, name)
        adder, counter_x, counter_y = self.adder, self.counter_x, self.counter_y
        commutator, trigger = self.commutator, self.trigger

        full = Signal()
        prepared_g = Signal(signed(w + 2))
        prepared_x = Signal(signed(w + 1))        # x - 1
        prepared_y = Signal(signed(w + 2))        # y + 1
        prepared_minus_x = Signal(signed(w + 1))  # 1 - x
        x, y, residue = self.cmd.payload.x, self.cmd.payload.y, self.cmd.payload.residue

        run = trigger.q
        enable = permit(m, self.feed, armed=1, running=run, abort=self.abort)
        move = Signal()
        x_step = Signal()
        y_step = Signal()
        stopping = Signal()
        take = Signal()
        end = Signal()
        x_zero = Signal()                             # counter X is zero, known a clock ahead
        final = Signal()                              # ... while running: an X step ends the run
        zero_next = _zero_ahead(m, x_zero, counter_x.q, load=take, d=prepared_x, clr=end,
                                down=x_step)
        m.d.sync += final.eq(zero_next & (take | (run & ~end)))
        m.d.comb += [
            move.eq(run & enable),
            x_step.eq(move & adder.sign_n),
            y_step.eq(move & adder.sign),
            stopping.eq((x_step & final) | (run & self.stop)),
            take.eq(full & (~run | stopping) & ~self.abort),
            end.eq(stopping | self.abort),
            self.cmd.ready.eq(~full | take),
        ]
        # The payload is taken whenever the core may take one (full tells whether it did).
        with m.If(self.cmd.ready):
            m.d.sync += [prepared_g.eq(y - x - residue), prepared_x.eq(x - 1),
                         prepared_y.eq(y + 1), prepared_minus_x.eq(1 - x)]
        with m.If(self.cmd.valid & self.cmd.ready):
            m.d.sync += full.eq(1)
        with m.Elif(take | self.abort):
            m.d.sync += full.eq(0)

        # -(x - 1), beside counter X: the increment of an X step, -2x', in a register, so that
        # the adder adds the increment its sign selects, as the bare accumulator does (the
        # choice precedes the carry chain; the step only enables the sum). The commutator shows
        # the increment of the step made (its strobes are the steps).
        minus_x = Signal(signed(w + 1))
        with m.If(take):
            m.d.sync += minus_x.eq(prepared_minus_x)
        with m.Elif(x_step):
            m.d.sync += minus_x.eq(minus_x + 1)
        operand = Signal(signed(w + 2))
        m.d.comb += operand.eq(Mux(adder.sign, Cat(0, counter_y.q[:w + 1]), Cat(0, minus_x)))

        m.d.comb += [
            commutator.b[0].eq(counter_x.q),               # 2(x - 1) = 2x'
            commutator.a[0].eq(x_step),
            commutator.b[1].eq(counter_y.q[:w + 1]),       # 2(y + 1) = 2y' (below 2**(w+1))
            commutator.a[1].eq(y_step),
            adder.d.eq(prepared_g),
            adder.load.eq(take),
            adder.clr.eq(end),
            adder.b.eq(operand),
            adder.add.eq(move),
            counter_x.d.eq(prepared_x),
            counter_x.load.eq(take),
            counter_x.clr.eq(end),
            counter_x.down.eq(x_step),
            counter_y.d.eq(prepared_y),
            counter_y.load.eq(take),
            counter_y.clr.eq(end),
            counter_y.up.eq(y_step),
            trigger.set.eq(take),
            trigger.reset.eq(end),
            self.feed.diagonal.eq(0),
            self.step.eq(Cat(x_step, y_step)),
            self.start.eq(take),
            self.done.eq(run & end),
            self.busy.eq(full | run),
        ]
        return m


def _zero_ahead(m, flag, q, *, load, d, clr, down):
    """Keep ``flag`` equal to ``q == 0`` (a counter's contents, or the bits of them that can be
    set) from the clock after each change, decoded from what the counter is given (``d`` at
    ``load``, zero at ``clr``, ``q - 1`` at ``down``) in the clock it changes: a decision that
    waits for the counter to run out starts from a flip-flop, not from a wide comparison of
    its contents. Returns the flag's next value (for flags formed from it)."""
    zero_next = Signal()
    with m.If(load):
        m.d.comb += zero_next.eq(d == 0)
    with m.Elif(clr):
        m.d.comb += zero_next.eq(1)
    with m.Elif(down):
        m.d.comb += zero_next.eq(q == 1)
    with m.Else():
        m.d.comb += zero_next.eq(flag)
    m.d.sync += flag.eq(zero_next)
    return zero_next


def _smear(value):
    """``2**n - 1`` for the bit length ``n`` of ``value``: every bit below its highest one set."""
    result = value
    shift = 1
    while shift < len(value):
        result = result | (result >> shift)
        shift *= 2
    return result


class DdaCore(wiring.Component):
    """Line core: the digital differential analyser (ЦДА), two registers of capacity ``2**n``.

    Each iteration adds X to register X and Y to register Y; a register whose sum reaches the
    capacity ``N = 2**n`` subtracts it and makes a step on its axis (both at once: a diagonal).
    After exactly N iterations the segment ends on its end point. The registers start at
    ``N/2`` (``preset="half"``: the point after ``k`` iterations is ``round(k·X/N)``) or at zero
    (``"zero"``: ``floor(k·X/N)``). The capacity is fixed, ``2**width`` (``"register"``), or set
    per segment to the smallest power of two above ``max(X, Y)`` (``"segment"``: N is then at
    most twice the longer projection, the iterations without a step fewer than half).

    The feed sees only the iterations that step: an iteration in which neither register
    overflows runs freely, one clock, with no permission; one that steps raises :py:`feed.due`
    (the registers look ahead at their sums; :py:`feed.diagonal` when both overflow) and waits
    for the permission. With the permission in every clock an iteration takes one clock and the
    segment N clocks, whichever axes move: the text's constant contour speed.

    A segment taken from :py:`cmd` is prepared and started (its capacity formed) as soon as the
    core is idle, or in the clock of the running segment's last iteration; a segment of length
    zero starts and ends in an idle clock. :py:`abort` clears the registers and drops the
    prepared segment.

    Parameters
    ----------
    width : :class:`int`
        Register width: magnitudes up to ``2**width - 1``.
    preset : ``"half"`` or ``"zero"``
        The registers' contents at the start.
    capacity : ``"segment"`` or ``"register"``
        See above.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2.
    :exc:`ValueError`
        If ``preset`` or ``capacity`` is not one of the above.
    """

    def __init__(self, *, width=16, preset="half", capacity="segment"):
        check_width("Register width", width, minimum=2)
        check_choice("Preset", preset, DDA_PRESETS)
        check_choice("Capacity", capacity, DDA_CAPACITIES)
        self._preset = preset
        self._capacity = capacity
        self.register_x = CapacityRegister(width)
        self.register_y = CapacityRegister(width)
        self.counter = ReversibleCounter(width + 1, parallel=True)
        self.trigger = Trigger(priority="set")
        super().__init__(LineCoreSignature(width))

    @property
    def width(self):
        return self.signature.width

    @property
    def preset(self):
        return self._preset

    @property
    def capacity(self):
        return self._capacity

    def elaborate(self, platform):
        m = Module()
        w = self.width
        for name in ("register_x", "register_y", "counter", "trigger"):
            m.submodules[name] = getattr(self, name)
        register_x, register_y = self.register_x, self.register_y
        counter, trigger = self.counter, self.trigger

        full = Signal()
        prepared_x = Signal(w)
        prepared_y = Signal(w)
        empty = Signal()                              # of length zero, decoded as it is taken
        payload = self.cmd.payload
        # The capacity of the prepared segment, formed as it is taken (so that the registers'
        # look-ahead sums and overflows at the start begin from flip-flops).
        prepared_mask = Signal(w)                     # capacity - 1
        if self._capacity == "register":
            m.d.comb += prepared_mask.eq((1 << w) - 1)
        else:
            with m.If(self.cmd.ready):
                m.d.sync += prepared_mask.eq(_smear(payload.x | payload.y))

        run = trigger.q
        over_x = Signal()
        over_y = Signal()
        over = Signal()                               # either register overflows (0 while idle)
        # Whether the prepared segment's first iteration steps, decoded as it is taken: with the
        # registers at N/2 it does exactly when the longer projection reaches N/2 (with the
        # capacity of the segment, always), from zero never.
        prepared_over = Signal()
        if self._preset == "half":
            top = Const(1) if self._capacity == "segment" else (payload.x | payload.y)[w - 1]
            with m.If(self.cmd.ready):
                m.d.sync += prepared_over.eq(top & (payload.x | payload.y).any())
        m.d.comb += [
            over_x.eq(run & register_x.overflow),
            over_y.eq(run & register_y.overflow),
        ]
        enable = permit(m, self.feed, armed=1, running=over, free=~over, abort=self.abort)
        # An iteration is made now if the core runs and the feed lets it (the permission, or
        # no step): ``advance``, with ``over`` only while running.
        advance = Signal()
        iterate = Signal()
        counted_out = Signal()                        # the counter is zero, known a clock ahead
        final = Signal()                              # ... while running: the last iteration
        take = Signal()
        go = Signal()
        end = Signal()
        # What the decisions of the next clock need, registered: a segment may be taken at the
        # next iteration (idle, or it is the last) and is prepared (of length zero or not).
        may_take = Signal()
        may_go = Signal()
        m.d.comb += [
            advance.eq(self.feed.tick | ~over),
            iterate.eq(run & enable),
            take.eq(may_take & advance & ~self.abort),
            go.eq(may_go & advance & ~self.abort),
            end.eq((final & advance) | self.abort),
            self.cmd.ready.eq(~full | take),
        ]
        # The next state of the flags above.
        transfer = Signal()
        full_next = Signal()
        empty_next = Signal()
        run_next = Signal()
        m.d.comb += [
            transfer.eq(self.cmd.valid & self.cmd.ready),
            full_next.eq(transfer | (full & ~take & ~self.abort)),
            empty_next.eq(Mux(transfer, (payload.x == 0) & (payload.y == 0), empty)),
            run_next.eq(go | (run & ~end)),
        ]
        # The payload is taken whenever the core may take one (full tells whether it did).
        with m.If(self.cmd.ready):
            m.d.sync += [prepared_x.eq(payload.x), prepared_y.eq(payload.y)]
        # The counter never holds more than the mask, below 2**width: its top bit is not decoded.
        zero_next = _zero_ahead(m, counted_out, counter.q[:w], load=go, d=prepared_mask,
                                clr=end, down=iterate)
        m.d.sync += [
            over.eq(Mux(go, prepared_over, register_x.overflow_next | register_y.overflow_next)),
            full.eq(full_next),
            empty.eq(empty_next),
            final.eq(run_next & zero_next),
            may_take.eq(full_next & (~run_next | (zero_next & ~empty_next))),
            may_go.eq(full_next & ~empty_next & (~run_next | zero_next)),
        ]

        # The registers take their increments and the capacity at the start.
        preset = (prepared_mask ^ (prepared_mask >> 1)) if self._preset == "half" else 0
        for register, increment in ((register_x, prepared_x), (register_y, prepared_y)):
            m.d.comb += [
                register.d.eq(preset),
                register.load.eq(go),
                register.clr.eq(end),
                register.b.eq(increment),
                register.mask.eq(prepared_mask),
                register.en.eq(iterate),
            ]
        m.d.comb += [
            counter.d.eq(prepared_mask),
            counter.load.eq(go),
            counter.clr.eq(end),
            counter.down.eq(iterate),
            trigger.set.eq(go),
            trigger.reset.eq(end),
            self.feed.diagonal.eq(over_x & over_y),
            self.step.eq(Cat(over_x & iterate, over_y & iterate)),
            self.start.eq(take),
            self.done.eq((run & end) | (take & empty)),
            self.busy.eq(full | run),
        ]
        return m
