"""Linear interpolator of patent SU 1571551: the patent's device, and the line core around it."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .elements import (AccumulatingAdder, Commutator, PulseGenerator, ReversibleCounter,
                       Trigger)
from .elements._checks import check_choice, check_positive, check_width
from .engine import permit
from .line import LineCoreSignature

__all__ = ["LinearInterpolator", "LinearCore", "LINEAR_VARIANTS"]

LINEAR_VARIANTS = ("device", "exact")


def _check(width, variant, period):
    check_width("Register width", width, minimum=2)
    check_choice("Variant", variant, LINEAR_VARIANTS)
    check_positive("Generator period", period)


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
      two registers.

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
    zero_frames : :class:`bool`
        Whether a start may come with inputs 22 and 23 both zero (a zero-length segment, as
        above). ``False`` promises it never does (:class:`LinearCore` ends those itself), which
        takes the decode of inputs 22 and 23 off the path of a start.
    one_step_input : :class:`bool`
        Whether the decode "a frame of one step" (inputs 22 and 23 are 1 and 0, or 0 and 1) is
        an input, :py:`one_step`, formed by whoever forms inputs 22-25 (:class:`LinearCore`,
        from the magnitudes, a clock ahead), instead of decoded here from inputs 22 and 23 in
        the clock of the start.

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
    one_step : :py:`In(1)`
        With ``one_step_input``: the frame started has one step (read with input 26).
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
        If ``width`` is not an integer of at least 2, ``period`` not a positive integer, or
        ``zero_frames`` or ``one_step_input`` not a bool.
    :exc:`ValueError`
        If ``variant`` is not one of the two above.
    """

    def __init__(self, *, width=16, variant="exact", period=1, zero_frames=True,
                 one_step_input=False):
        _check(width, variant, period)
        if not isinstance(zero_frames, bool):
            raise TypeError(f"Zero frames must be a bool, not {zero_frames!r}")
        if not isinstance(one_step_input, bool):
            raise TypeError(f"One step input must be a bool, not {one_step_input!r}")
        self._width = width
        self._variant = variant
        self._period = period
        self._zero_frames = zero_frames
        self._one_step_input = one_step_input
        # The numbered elements, reachable as attributes (tests sample their contents).
        self.counter1 = ReversibleCounter(width + 1, parallel=True)
        self.counter2 = ReversibleCounter(width + 1, parallel=True)
        self.adder3 = AccumulatingAdder(width + 1)
        self.generator4 = PulseGenerator(period)
        self.mux12 = Commutator(width + 1, width + 1, channels=2, shift=0)
        self.trigger14 = Trigger(priority="set")
        self.trigger15 = Trigger(priority="set")
        # AND 9's decode, with trigger 14: a frame runs and one step is left (see elaborate).
        self.last_step = Signal(name="last_step")
        if variant == "exact":
            self.reg22 = Signal(width, name="reg22")    # constant increment ||X| - |Y||
            self.reg23 = Signal(signed(width + 1), name="reg23")   # min(|X|, |Y|) - 1
        members = {
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
        }
        if one_step_input:
            members["one_step"] = In(1)
        super().__init__(members)

    @property
    def width(self):
        return self._width

    @property
    def variant(self):
        return self._variant

    @property
    def period(self):
        return self._period

    @property
    def zero_frames(self):
        return self._zero_frames

    @property
    def one_step_input(self):
        return self._one_step_input

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
        # generator pulse in every clock the same timing needs AND 9 to fire in the clock of the
        # last step, from the counters' contents before it: 1 and -1 (one long step left) or 0
        # and 0 (one combined step left). Each pulse counts down one of the two counters, the
        # one of its kind, and a frame exhausts both exactly at its last step (the step models
        # assert it), so with one step left the passing pulse is that step. The decode is kept in
        # a flip-flop with trigger 14, updated with the counters (a count moves one counter by
        # one, so the next decode is a decode of the present contents): AND 9 is then the pulse
        # and that flip-flop, and the wide comparisons stay off the path to the next frame.
        and9_run = Signal()   # the running frame makes its last step now
        and9_load = Signal()  # a zero-length frame: its counters are exhausted when loaded
        and9 = Signal()
        or13 = Signal()
        empty = Signal()
        start = Signal()      # input 26, accepted
        go = Signal()         # a frame with steps starts running
        last_step = self.last_step
        m.d.comb += [
            and9_run.eq(generator4.o & last_step),
            empty.eq(~self.in22.any() & ~self.in23.any() if self._zero_frames else 0),
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
        c1, c2 = counter1.q, counter2.q
        c1_high_zero = ~c1[2:].any()
        c2_high_zero = ~c2[1:].any()
        two_left_1 = c1_high_zero & (c1[:2] == 2) & c2.all()                     # 2 and -1
        two_left_2 = c1_high_zero & (c1[:2] == 1) & c2_high_zero & ~c2[0]        # 1 and 0
        two_left_3 = c1_high_zero & (c1[:2] == 0) & c2_high_zero & c2[0]         # 0 and 1
        if self._one_step_input:
            one_step = self.one_step
        else:
            # Inputs 22 and 23 are 1 and 0, or 0 and 1: a frame of one step. Written bit by
            # bit (a wide OR and an XOR), so that it does not wait for the carry chain that
            # forms input 23 minus one for counter 2.
            one_step = (~self.in22[1:].any() & ~self.in23[1:].any()
                        & (self.in22[0] ^ self.in23[0]))
        with m.If(go):
            m.d.sync += last_step.eq(one_step)
        with m.Elif(and9):
            m.d.sync += last_step.eq(0)
        with m.Elif(and5):       # counter 1 counts down
            m.d.sync += last_step.eq(two_left_1 | two_left_2)
        with m.Elif(and6):       # counter 2 counts down
            m.d.sync += last_step.eq(two_left_2 | two_left_3)

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
        # Multiplexer 12 passes the inverse code of counter 2 (channel 1, AND 5: F -= C2) or
        # counter 1 (channel 2, AND 6: F += C1) to adder 3. Here adder 3 forms both sums in
        # parallel, each channel's code on an operand input of its own, and the channel's strobe
        # picks the sum: the sign of F then chooses at the end of the carry chain, not at its
        # start (the loop is that of a bare accumulator).
        m.d.comb += [
            adder3.d.eq(self.in24),
            adder3.load.eq(go),
            adder3.clr.eq(and9),
            mux12.a[0].eq(and5),
            mux12.a[1].eq(and6),
        ]
        if self._variant == "device":
            m.d.comb += [
                mux12.b[0].eq(counter2.q_n),
                mux12.b[1].eq(counter1.q),
            ]
        else:
            # Constant increments of eq. (1): registers 22' and 23' keep input 22 and, as
            # counter 2 is loaded, input 23 minus one, whose inverse code is -min.
            reg22, reg23 = self.reg22, self.reg23
            with m.If(go):
                m.d.sync += [reg22.eq(self.in22), reg23.eq(self.in23 - 1)]
            m.d.comb += [
                mux12.b[0].eq(~reg23),       # F -= min
                mux12.b[1].eq(reg22),        # F += |X| - |Y|
            ]
        m.d.comb += [
            adder3.b2.eq(mux12.b[0]),
            adder3.add2.eq(mux12.a[0]),
            adder3.b.eq(mux12.b[1]),
            adder3.add.eq(mux12.a[1]),
        ]

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


class LinearCore(wiring.Component):
    """:class:`LinearInterpolator` as a line core (:class:`~kontur.hdl.line.LineCoreSignature`).

    A segment taken from :py:`cmd` is prepared in registers holding the candidates for the
    patent's inputs 22-25 under either long axis, the comparison ``|X| >= |Y|`` and the flag
    "one step", all formed from the magnitudes in parallel in the clock it is taken; the
    registered comparison selects inputs 22-25 (a multiplexer, no carry chain after the
    comparison). It is started by input 26 as soon as the
    interpolator is ready: in the next clock when it is idle, in the clock of the running
    segment's last step otherwise. A segment of length zero does not reach the interpolator: it
    starts and ends in an idle clock of the interpolator, as the interpolator would end it. The
    step permission drives generator 4 (:func:`~kontur.hdl.engine.permit`): with the default period of
    1 the step is made in the clock of the permission; the next step is diagonal when adder 3
    is negative. :py:`abort` clears the interpolator (a synchronous reset of its registers: the
    patent has no stop input) and drops the prepared segment.

    Parameters
    ----------
    width, variant, period
        As :class:`LinearInterpolator`.

    Raises
    ------
    :exc:`TypeError`, :exc:`ValueError`
        As :class:`LinearInterpolator`.
    """

    def __init__(self, *, width=16, variant="exact", period=1):
        _check(width, variant, period)          # before the interpolator is made
        self.interpolator = LinearInterpolator(width=width, variant=variant, period=period,
                                               zero_frames=False, one_step_input=True)
        super().__init__(LineCoreSignature(width))

    @property
    def width(self):
        return self.interpolator.width

    @property
    def variant(self):
        return self.interpolator.variant

    @property
    def period(self):
        return self.interpolator.period

    def elaborate(self, platform):
        m = Module()
        w = self.width
        ip = self.interpolator
        m.submodules.interpolator = ResetInserter(self.abort)(ip)

        # The prepared segment: the candidates for inputs 22-25 under either long axis, from
        # the magnitudes in parallel, and the comparison that chooses between them. The choice
        # is made after the registers, so that the comparison's carry chain ends at a flip-flop
        # instead of fanning out to every input bit in the clock the segment is taken.
        mx, my = self.cmd.payload.x, self.cmd.payload.y
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

        # The prepared segment's registers need no reset (only ``full`` says they count), which
        # keeps the reset off their load enable.
        full = Signal()
        queued = Signal()                         # full, and the segment has steps
        empty = Signal(reset_less=True)           # the prepared segment has length zero
        one_step = Signal(reset_less=True)        # the prepared segment has one step
        x_ge_y = Signal(reset_less=True)          # |x| >= |y|: X is the long axis (input 25)
        prepared_x = Signal(w, reset_less=True)   # the magnitudes (input 23 is the short one)
        prepared_y = Signal(w, reset_less=True)
        long_less_x = Signal(w, reset_less=True)  # input 22 with X long: |x| - |y|
        long_less_y = Signal(w, reset_less=True)
        f0_x = Signal(signed(w + 1), reset_less=True)    # input 24 with X long: F0
        f0_y = Signal(signed(w + 1), reset_less=True)
        take = Signal()
        ending = Signal()       # the running segment makes its last step in this clock
        # A segment of length zero never reaches the interpolator: it starts and ends here, in
        # an idle clock (as the interpolator would end it).
        m.d.comb += [
            # full & ~abort & (ip.ready, or idle for a zero-length segment), written out from
            # the interpolator's registers so that it is two gates deep.
            ending.eq(ip.generator4.o & ip.last_step),
            take.eq(~self.abort & ((full & ip.trigger14.q_n) | (queued & ending))),
            self.cmd.ready.eq(~full | take),
        ]
        with m.If(self.cmd.valid & self.cmd.ready):
            m.d.sync += [full.eq(1), queued.eq(mx.any() | my.any())]
        with m.Elif(take | self.abort):
            m.d.sync += [full.eq(0), queued.eq(0)]
        # The registers follow cmd whenever it may be taken (what they hold counts only with
        # full set), so that their load enable does not wait for cmd.valid.
        with m.If(self.cmd.ready):
            m.d.sync += [
                empty.eq(~mx.any() & ~my.any()),
                # max(|x|, |y|) == 1: inputs 22 and 23 are 1 and 0, or 0 and 1.
                one_step.eq(~mx[1:].any() & ~my[1:].any() & (mx[0] | my[0])),
                x_ge_y.eq(~x_minus_y[-1]),
                prepared_x.eq(mx),
                prepared_y.eq(my),
                long_less_x.eq(x_minus_y[:w]),
                long_less_y.eq(y_minus_x[:w]),
                f0_x.eq(f0_x_long >> 1),
                f0_y.eq(f0_y_long >> 1),
            ]

        enable = permit(m, self.feed, armed=ip.generator4.armed, running=ip.busy,
                        abort=self.abort)
        m.d.comb += [
            ip.in22.eq(Mux(x_ge_y, long_less_x, long_less_y)),
            ip.in23.eq(Mux(x_ge_y, prepared_y, prepared_x)),
            ip.in24.eq(Mux(x_ge_y, f0_x, f0_y)),
            ip.in25.eq(x_ge_y),
            ip.one_step.eq(one_step),
            ip.in26.eq(~self.abort & queued & (ip.trigger14.q_n | ending)),
            ip.tick.eq(enable),
            self.feed.diagonal.eq(ip.adder3.sign),
            self.step.eq(ip.step),
            self.start.eq(take),
            self.done.eq(ip.done | (take & empty) | (self.abort & ip.busy)),
            self.busy.eq(full | ip.busy),
        ]
        return m
