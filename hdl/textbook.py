"""The textbook's interpolators: estimating function with separate steps (line and circle), DDA.

The excerpt (seed ``004``, ``docs/textbook.md``) describes two methods of hardware
interpolation: the estimating function with separate steps along the coordinates (one axis per
step; its Fig. 11) and the digital differential analyser (ЦДА). Each core here is one of them
as a core of the common engines: :class:`SeparateLineCore` and :class:`DdaCore` are line cores
(:class:`~hdl.line.LineCoreSignature`), :class:`SeparateArcCore` a quadrant core
(:class:`~hdl.arc.ArcCoreSignature`) for :class:`~hdl.arc.ArcEngine`, whose planner plans the
quadrants. The text gives no circuit for these (its Fig. 12 node is :mod:`hdl.serial`), so the
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
    The counters hold the steps left on each axis; the last step is decoded from their present
    contents and the step passing (``(1, 0)`` with an X step, ``(0, 1)`` with a Y step). An
    exhausted axis is never chosen: at ``x = X`` D is negative, at ``y = Y`` it is not.

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
        self.counter_x = ReversibleCounter(width + 1)
        self.counter_y = ReversibleCounter(width + 1)
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

        # The prepared segment.
        full = Signal()
        prepared_x = Signal(w)
        prepared_y = Signal(w)
        empty = Signal()                              # of length zero, decoded as it is taken

        run = trigger.q
        enable = permit(m, self.feed, armed=1, running=run, abort=self.abort)
        move = Signal()
        x_step = Signal()
        y_step = Signal()
        last = Signal()
        take = Signal()
        go = Signal()
        end = Signal()
        # Whether an X step or a Y step would be the last, decoded from the counters a step
        # ahead (at the start, and after each step from the contents before it), so that the
        # decision to take the next segment starts from flip-flops.
        last_if_x = Signal()                          # the counters hold (1, 0)
        last_if_y = Signal()                          # ... (0, 1)
        m.d.comb += [
            move.eq(run & enable),
            x_step.eq(move & adder.sign_n),
            y_step.eq(move & adder.sign),
            last.eq((x_step & last_if_x) | (y_step & last_if_y)),
            take.eq(full & (~run | (last & ~empty)) & ~self.abort),
            go.eq(take & ~empty),
            end.eq(last | self.abort),
            self.cmd.ready.eq(~full | take),
        ]
        with m.If(self.cmd.valid & self.cmd.ready):
            m.d.sync += [full.eq(1), prepared_x.eq(self.cmd.payload.x),
                         prepared_y.eq(self.cmd.payload.y),
                         empty.eq((self.cmd.payload.x == 0) & (self.cmd.payload.y == 0))]
        with m.Elif(take | self.abort):
            m.d.sync += full.eq(0)

        cx, cy = counter_x.q, counter_y.q
        with m.If(go):
            m.d.sync += [last_if_x.eq((prepared_x == 1) & (prepared_y == 0)),
                         last_if_y.eq((prepared_x == 0) & (prepared_y == 1))]
        with m.Elif(end):
            m.d.sync += [last_if_x.eq(0), last_if_y.eq(0)]
        with m.Elif(x_step):
            m.d.sync += [last_if_x.eq((cx == 2) & (cy == 0)), last_if_y.eq((cx == 1) & (cy == 1))]
        with m.Elif(y_step):
            m.d.sync += [last_if_x.eq((cx == 1) & (cy == 1)), last_if_y.eq((cx == 0) & (cy == 2))]

        # The increments 2Y (X step) and 2X (Y step), held for the whole segment.
        reg_x = Signal(w)
        reg_y = Signal(w)
        with m.If(go):
            m.d.sync += [reg_x.eq(prepared_x), reg_y.eq(prepared_y)]
        m.d.comb += [
            commutator.b[0].eq(reg_y),
            commutator.a[0].eq(x_step),
            commutator.b[1].eq(reg_x),
            commutator.a[1].eq(y_step),
            adder.d.eq(prepared_x - prepared_y),
            adder.load.eq(go),
            adder.clr.eq(end),
            adder.b.eq(commutator.o),
            adder.sub.eq(x_step),
            adder.add.eq(y_step),
            counter_x.d.eq(prepared_x),
            counter_x.load.eq(go),
            counter_x.clr.eq(end),
            counter_x.down.eq(x_step),
            counter_y.d.eq(prepared_y),
            counter_y.load.eq(go),
            counter_y.clr.eq(end),
            counter_y.down.eq(y_step),
            trigger.set.eq(go),
            trigger.reset.eq(end),
            self.feed.diagonal.eq(0),
            self.step.eq(Cat(x_step, y_step)),
            self.start.eq(take),
            self.done.eq((run & end) | (take & empty)),
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
        self.counter_x = ReversibleCounter(width + 1)
        self.counter_y = ReversibleCounter(width + 2)
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
        _zero_ahead(m, x_zero, counter_x, load=take, d=prepared_x, clr=end, down=x_step)
        m.d.comb += [
            move.eq(run & enable),
            x_step.eq(move & adder.sign_n),
            y_step.eq(move & adder.sign),
            stopping.eq(run & ((x_step & x_zero) | self.stop)),
            take.eq(full & (~run | stopping) & ~self.abort),
            end.eq(stopping | self.abort),
            self.cmd.ready.eq(~full | take),
        ]
        with m.If(self.cmd.valid & self.cmd.ready):
            m.d.sync += [full.eq(1), prepared_g.eq(y - x - residue), prepared_x.eq(x - 1),
                         prepared_y.eq(y + 1)]
        with m.Elif(take | self.abort):
            m.d.sync += full.eq(0)

        m.d.comb += [
            commutator.b[0].eq(counter_x.q),               # 2(x - 1) = 2x'
            commutator.a[0].eq(x_step),
            commutator.b[1].eq(counter_y.q[:w + 1]),       # 2(y + 1) = 2y' (below 2**(w+1))
            commutator.a[1].eq(y_step),
            adder.d.eq(prepared_g),
            adder.load.eq(take),
            adder.clr.eq(end),
            adder.b.eq(commutator.o),
            adder.sub.eq(x_step),
            adder.add.eq(y_step),
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


def _zero_ahead(m, flag, counter, *, load, d, clr, down):
    """Keep ``flag`` equal to ``counter.q == 0`` from the clock after each change, decoded from
    what the counter is given (``d`` at ``load``, zero at ``clr``, ``q - 1`` at ``down``) in
    the clock it changes: a decision that waits for the counter to run out starts from a
    flip-flop, not from a wide comparison of its contents."""
    with m.If(load):
        m.d.sync += flag.eq(d == 0)
    with m.Elif(clr):
        m.d.sync += flag.eq(1)
    with m.Elif(down):
        m.d.sync += flag.eq(counter.q == 1)


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
        self.counter = ReversibleCounter(width + 1)
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
            with m.If(self.cmd.valid & self.cmd.ready):
                m.d.sync += prepared_mask.eq(_smear(payload.x | payload.y))

        run = trigger.q
        over_x = Signal()
        over_y = Signal()
        over = Signal()
        m.d.comb += [
            over_x.eq(run & register_x.overflow),
            over_y.eq(run & register_y.overflow),
            over.eq(over_x | over_y),
        ]
        enable = permit(m, self.feed, armed=1, running=over, free=~over, abort=self.abort)
        iterate = Signal()
        last = Signal()
        counted_out = Signal()                        # the counter is zero, known a clock ahead
        take = Signal()
        go = Signal()
        end = Signal()
        m.d.comb += [
            iterate.eq(run & enable),
            last.eq(iterate & counted_out),
            take.eq(full & (~run | (last & ~empty)) & ~self.abort),
            go.eq(take & ~empty),
            end.eq(last | self.abort),
            self.cmd.ready.eq(~full | take),
        ]
        with m.If(self.cmd.valid & self.cmd.ready):
            m.d.sync += [full.eq(1), prepared_x.eq(payload.x), prepared_y.eq(payload.y),
                         empty.eq((payload.x == 0) & (payload.y == 0))]
        with m.Elif(take | self.abort):
            m.d.sync += full.eq(0)

        _zero_ahead(m, counted_out, counter, load=go, d=prepared_mask, clr=end, down=iterate)

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
