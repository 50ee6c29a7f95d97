"""Linear interpolator of patent SU 1571551: the patent's device, and the engine around it."""

from amaranth import *
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from .elements import (AccumulatingAdder, Commutator, PulseGenerator, ReversibleCounter,
                       Trigger)
from .elements._checks import check_choice, check_positive, check_width
from .engine import engine_members, frame_coord_width

__all__ = ["LinearInterpolator", "LineEngine", "LINEAR_VARIANTS"]

LINEAR_VARIANTS = ("device", "exact")


class LinearInterpolator(wiring.Component):
    """The linear interpolator of SU 1571551 (Fig. 1), one step per generator pulse.

    Every element of the block diagram is here under its number: counters 1 and 2, adder 3,
    generator 4, AND 5-9, OR 10, 11 and 13, multiplexer 12, triggers 14 and 15, grouped in the
    patent's nodes 18 (sign analysis), 19 (adder-subtractor), 20 (increment forming) and 21
    (start/stop). It works on magnitudes: the signs of X and Y are applied outside
    (:class:`LineEngine`).

    A frame is started by a pulse on input 26 while :py:`ready` is high; inputs 22-25 are read
    in that clock. The first step comes at the next generator pulse. Each generator pulse
    then makes exactly one step, long (X or Y alone, by trigger 15) or diagonal, until
    ``max(|X|, |Y|)`` steps are made. :py:`done` pulses in the clock of the last step, and a
    new frame may be started in that same clock, so frames follow with no idle clock. A frame
    with inputs 22 and 23 both zero is a zero-length segment: it ends in the clock it is started
    in, with no step (:py:`done` pulses then). A start pulse while :py:`ready` is low is refused:
    :py:`error` pulses and the running frame goes on untouched.

    Two variants of the same structure:

    * ``"device"``: multiplexer 12 feeds the counters' current contents to adder 3, as the
      patent's description, claims and worked table do (eq. 5);
    * ``"exact"``: multiplexer 12 feeds two registers holding inputs 22 and 23 for the whole
      frame, which realises the patent's eq. (1) and its ``0.5 cos α`` error bound. Cost: the
      two registers and the adder's subtract path.

    Adder 3 holds the integer part ``⌊F⌋`` of the estimating function: ``F0 = max/2 - min`` may
    end in one half, every increment is an integer, so the half never changes the sign test.

    Parameters
    ----------
    width : :class:`int`
        Register width: the largest magnitude is ``2**width - 1``.
    variant : ``"device"`` or ``"exact"``
        See above.
    period : :class:`int`
        Period of generator 4, in :py:`tick` clocks (1: a step every clock).

    Members
    -------
    in22 : :py:`In(width)`
        ``||X| - |Y||``, loaded into counter 1.
    in23 : :py:`In(width)`
        ``min(|X|, |Y|)``, loaded into counter 2.
    in24 : :py:`In(signed(width + 1))`
        ``⌊max(|X|, |Y|)/2 - min(|X|, |Y|)⌋``, loaded into adder 3.
    in25 : :py:`In(1)`
        ``|X| >= |Y|``: sets trigger 15 (the long axis is X).
    in26 : :py:`In(1)`
        Start of frame ("Начало кадра").
    tick : :py:`In(1)`
        Enable of generator 4 (feed rate): tie high for one step per ``period`` clocks.
    step : :py:`Out(2)`
        Step pulses: bit 0 is X (OR 10), bit 1 is Y (OR 11).
    ready : :py:`Out(1)`
        A start pulse is accepted in this clock.
    busy : :py:`Out(1)`
        Trigger 14: a frame is running.
    done : :py:`Out(1)`
        A frame ends in this clock.
    error : :py:`Out(1)`
        A start pulse was refused in this clock.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2, or ``period`` not a positive integer.
    :exc:`ValueError`
        If ``variant`` is not one of the two above.
    """

    def __init__(self, *, width=16, variant="exact", period=1):
        check_width("Register width", width, minimum=2)
        check_choice("Variant", variant, LINEAR_VARIANTS)
        check_positive("Generator period", period)
        self._width = width
        self._variant = variant
        self._period = period
        # The numbered elements, reachable as attributes (tests sample their contents).
        self.counter1 = ReversibleCounter(width + 1)
        self.counter2 = ReversibleCounter(width + 1)
        self.adder3 = AccumulatingAdder(width + 1)
        self.generator4 = PulseGenerator(period)
        self.mux12 = Commutator(width + 1, width + 1, channels=2, shift=0)
        self.trigger14 = Trigger(priority="set")
        self.trigger15 = Trigger(priority="set")
        if variant == "exact":
            self.reg22 = Signal(width, name="reg22")    # constant increment ||X| - |Y||
            self.reg23 = Signal(width, name="reg23")    # constant increment min(|X|, |Y|)
        super().__init__({
            "in22":  In(width),
            "in23":  In(width),
            "in24":  In(signed(width + 1)),
            "in25":  In(1),
            "in26":  In(1),
            "tick":  In(1),
            "step":  Out(2),
            "ready": Out(1),
            "busy":  Out(1),
            "done":  Out(1),
            "error": Out(1),
        })

    @property
    def width(self):
        return self._width

    @property
    def variant(self):
        return self._variant

    @property
    def period(self):
        return self._period

    def elaborate(self, platform):
        m = Module()
        m.submodules.counter1 = counter1 = self.counter1
        m.submodules.counter2 = counter2 = self.counter2
        m.submodules.adder3 = adder3 = self.adder3
        m.submodules.generator4 = generator4 = self.generator4
        m.submodules.mux12 = mux12 = self.mux12
        m.submodules.trigger14 = trigger14 = self.trigger14
        m.submodules.trigger15 = trigger15 = self.trigger15

        # ---- node 18: sign analysis (generator 4, AND 5, AND 6) --------------------------------
        and5 = Signal()     # F >= 0: step along the long projection only (output 16)
        and6 = Signal()     # F < 0: combined step along both projections (output 17)
        m.d.comb += [
            generator4.en.eq(self.tick),
            and5.eq(generator4.o & trigger14.q & adder3.sign_n),
            and6.eq(generator4.o & trigger14.q & adder3.sign),
        ]

        # ---- node 21: start/stop (AND 9, OR 13, trigger 14) ------------------------------------
        # AND 9 fires when counter 1 holds 0 and counter 2 holds -1 (all inverse outputs of
        # counter 1, all direct outputs of counter 2). In the patent it resets trigger 14 as soon
        # as the counters settle after the last step, before the generator's next pulse; with a
        # generator pulse in every clock the same timing needs AND 9 to see the counters' next
        # contents, so it fires in the clock of the last step. It decodes them from the present
        # contents and the pulse now passing (a long step ends the frame from 1 and -1, a
        # combined step from 0 and 0), which keeps the counters' carry chains off this path.
        and9_run = Signal()   # the running frame makes its last step now
        and9_load = Signal()  # a zero-length frame: its counters are exhausted when loaded
        and9 = Signal()
        or13 = Signal()
        empty = Signal()
        start = Signal()      # input 26, accepted
        go = Signal()         # a frame with steps starts running
        m.d.comb += [
            and9_run.eq(trigger14.q & (
                (and5 & (counter1.q == 1) & counter2.q.all()) |
                (and6 & ~counter1.q.any() & ~counter2.q.any()))),
            empty.eq(~self.in22.any() & ~self.in23.any()),
            # At most one frame ends per clock: a zero-length frame waits for an idle clock.
            self.ready.eq(trigger14.q_n | (and9_run & ~empty)),
            start.eq(self.in26 & self.ready),
            self.error.eq(self.in26 & ~self.ready),
            and9_load.eq(start & empty),
            go.eq(start & ~empty),
            and9.eq(and9_run | and9_load),
            trigger14.set.eq(go),
            trigger14.reset.eq(and9),
            or13.eq(and6),
            self.busy.eq(trigger14.q),
            self.done.eq(and9),
        ]

        # ---- counters 1 and 2 ------------------------------------------------------------------
        # The patent loads counter 2 with min and then lets the start pulse subtract one through
        # OR 13, so that its inverse outputs read -min. Load and start share one clock here, so
        # that subtraction is made on the load path.
        m.d.comb += [
            counter1.d.eq(self.in22),
            counter1.load.eq(go),
            counter1.clr.eq(and9),
            counter1.down.eq(and5),
            counter2.d.eq(self.in23 - 1),
            counter2.load.eq(go),
            counter2.clr.eq(and9),
            counter2.down.eq(or13),
        ]

        # ---- node 19: adder-subtractor (adder 3, multiplexer 12) -------------------------------
        m.d.comb += [
            adder3.d.eq(self.in24),
            adder3.load.eq(go),
            adder3.clr.eq(and9),
            mux12.a[0].eq(and5),
            mux12.a[1].eq(and6),
        ]
        if self._variant == "device":
            # AND 5: add the inverse code of counter 2 (= -C2); AND 6: add counter 1 (+C1).
            m.d.comb += [
                mux12.b[0].eq(counter2.q_n),
                mux12.b[1].eq(counter1.q),
                adder3.add.eq(mux12.strobe),
            ]
        else:
            # Constant increments of eq. (1): registers 22' and 23' keep inputs 22 and 23.
            reg22, reg23 = self.reg22, self.reg23
            with m.If(go):
                m.d.sync += [reg22.eq(self.in22), reg23.eq(self.in23)]
            m.d.comb += [
                mux12.b[0].eq(reg23),
                mux12.b[1].eq(reg22),
                adder3.sub.eq(and5),         # F -= min
                adder3.add.eq(and6),         # F += |X| - |Y|
            ]
        m.d.comb += adder3.b.eq(mux12.o)

        # ---- node 20: coordinate increments (trigger 15, AND 7, AND 8, OR 10, OR 11) -----------
        and7 = Signal()     # long step to X
        and8 = Signal()     # long step to Y
        or10 = Signal()     # X output
        or11 = Signal()     # Y output
        m.d.comb += [
            trigger15.set.eq(go & self.in25),
            trigger15.reset.eq(and9),
            and7.eq(and5 & trigger15.q),
            and8.eq(and5 & trigger15.q_n),
            or10.eq(and7 | and6),
            or11.eq(and8 | and6),
            self.step.eq(Cat(or10, or11)),
        ]
        return m


class LineEngine(wiring.Component):
    """Signed line segments in, step/dir pulses out: :class:`LinearInterpolator` in a frame stream.

    Each transfer on :py:`cmd` is one segment, relative to the current position: the end point
    ``(x, y)``. A frame register takes it (at most one frame waits there while another runs),
    splits it into signs and magnitudes, checks that the magnitudes fit the registers and forms
    the patent's inputs 22-25 for the next clock. The frame starts as soon as the core is ready:
    frames follow one another with no idle clock between the last step of one and the first
    step of the next. A frame is first offered at clock ``k`` and, the engine being idle, makes
    its first step at ``k + 2``.

    Every accepted frame ends with exactly one pulse: :py:`done` (made, possibly with no steps)
    or :py:`error` (refused: a magnitude above ``2**width - 1``; nothing moves). Frames are
    ended in the order they were accepted.

    Parameters
    ----------
    width : :class:`int`
        Register width of the interpolator.
    variant : ``"device"`` or ``"exact"``
        Variant of :class:`LinearInterpolator`.
    period : :class:`int`
        Generator period in :py:`tick` clocks.
    coord_width : :class:`int`
        Width of the signed coordinates in a frame; default ``max(32, width + 1)``.

    Members
    -------
    cmd : :py:`In(stream.Signature(LineEngine.Frame(coord_width)))`
        Segments.
    tick : :py:`In(1)`
        Feed-rate strobe: a step is permitted in clocks where it is high.
    step : :py:`Out(2)`
        Step pulses, bit 0 X, bit 1 Y.
    dir : :py:`Out(2)`
        Directions, bit 0 X, bit 1 Y: 1 for the negative direction. Valid with :py:`step`.
    busy : :py:`Out(1)`
        A frame is waiting or running.
    done : :py:`Out(1)`
        A frame ended normally.
    error : :py:`Out(1)`
        A frame was refused.

    Raises
    ------
    :exc:`TypeError`
        If a width or the period is not a positive integer.
    :exc:`ValueError`
        If ``variant`` is unknown or ``coord_width`` is smaller than ``width + 1``.
    """

    @staticmethod
    def Frame(coord_width):
        return data.StructLayout({"x": signed(coord_width), "y": signed(coord_width)})

    def __init__(self, *, width=16, variant="exact", period=1, coord_width=None):
        check_width("Register width", width, minimum=2)
        check_choice("Variant", variant, LINEAR_VARIANTS)
        check_positive("Generator period", period)
        coord_width = frame_coord_width(width, coord_width)
        self._width = width
        self._variant = variant
        self._period = period
        self._coord_width = coord_width
        self.core = LinearInterpolator(width=width, variant=variant, period=period)
        super().__init__(engine_members(self.Frame(coord_width)))

    @property
    def width(self):
        return self._width

    @property
    def variant(self):
        return self._variant

    @property
    def coord_width(self):
        return self._coord_width

    def elaborate(self, platform):
        m = Module()
        w = self._width
        m.submodules.core = core = self.core

        # Frame register: the patent's inputs 22-25, precomputed from the signed end point.
        full = Signal()
        in22 = Signal(w)
        in23 = Signal(w)
        in24 = Signal(signed(w + 1))
        in25 = Signal()
        bad = Signal()
        frame_dir = Signal(2)

        x = self.cmd.payload.x
        y = self.cmd.payload.y
        ax = Signal(self._coord_width)
        ay = Signal(self._coord_width)
        m.d.comb += [
            ax.eq(Mux(x < 0, -x, x)),
            ay.eq(Mux(y < 0, -y, y)),
        ]
        too_wide = (ax >> w).any() | (ay >> w).any()
        # Every candidate is formed in parallel from the magnitudes and the comparison only
        # selects: one carry chain after the absolute values instead of three in a row.
        mx, my = ax[:w], ay[:w]
        x_minus_y = Signal(signed(w + 2))         # |x| - |y|; its sign is the comparison
        y_minus_x = Signal(signed(w + 2))
        f0_x_long = Signal(signed(w + 3))         # 2·F0 when X is the long axis: |x| - 2|y|
        f0_y_long = Signal(signed(w + 3))
        m.d.comb += [
            x_minus_y.eq(mx - my),
            y_minus_x.eq(my - mx),
            f0_x_long.eq(mx - (my << 1)),
            f0_y_long.eq(my - (mx << 1)),
        ]
        x_ge_y = ~x_minus_y[-1]
        longer_minus_shorter = Mux(x_ge_y, x_minus_y, y_minus_x)[:w]
        shorter = Mux(x_ge_y, my, mx)
        twice_f0 = Mux(x_ge_y, f0_x_long, f0_y_long)

        take = Signal()
        m.d.comb += [
            take.eq(full & core.ready),
            self.cmd.ready.eq(~full | take),
        ]
        with m.If(self.cmd.valid & self.cmd.ready):
            m.d.sync += [
                full.eq(1),
                bad.eq(too_wide),
                # A refused frame presents zeros, so it waits for the core to be idle.
                in22.eq(Mux(too_wide, 0, longer_minus_shorter)),
                in23.eq(Mux(too_wide, 0, shorter)),
                in24.eq(Mux(too_wide, 0, twice_f0 >> 1)),
                in25.eq(~too_wide & x_ge_y),
                frame_dir.eq(Cat(x < 0, y < 0)),
            ]
        with m.Elif(take):
            m.d.sync += full.eq(0)

        start = Signal()
        m.d.comb += [
            core.in22.eq(in22),
            core.in23.eq(in23),
            core.in24.eq(in24),
            core.in25.eq(in25),
            start.eq(take & ~bad),
            core.in26.eq(start),
            core.tick.eq(self.tick),
        ]

        direction = Signal(2)
        with m.If(start & (in22.any() | in23.any())):
            m.d.sync += direction.eq(frame_dir)

        m.d.comb += [
            self.step.eq(core.step),
            self.dir.eq(direction),
            self.busy.eq(full | core.busy),
            self.done.eq(core.done),
            self.error.eq(take & bad),
        ]
        return m
