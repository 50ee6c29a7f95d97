"""Circular interpolator of patent SU 1665343: the faithful core, a one-step-per-clock core,
and each as an arc core."""

from amaranth import *
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from .arc import ArcCoreSignature
from .circular_timing import FaithfulTiming
from .elements import (AccumulatingAdder, Commutator, DelayElement, PulseExtender,
                       PulseGenerator, ReversibleCounter, Trigger, carry_save)
from .elements._checks import check_positive, check_width
from .engine import permit

__all__ = ["CircularInterpolator", "CircularInterpolatorFast", "FaithfulArcCore", "FastArcCore",
           "FaithfulTiming"]


def _core_signature(width):
    """Ports shared by both cores: the patent's inputs 29-34, outputs 35 and 36."""
    return {
        "in29":  In(signed(width + 4)),   # ⌊F⌋ at the start, into adder 1
        "in30":  In(signed(width + 1)),   # counter 7: Y (sector 1) or X - 1 (sector 2)
        "in31":  In(signed(width + 1)),   # counter 8: X - Y - 1 (sector 1) or X - Y (sector 2)
        "in32":  In(1),                   # end of work: stop, clear triggers and accumulators
        "in33":  In(1),                   # initialisation: load 29-31 and 34, set trigger 4
        "in34":  In(1),                   # |Y| >= |X|: set trigger 16 (start in sector 2)
        "tick":  In(1),                   # enable of the clock-pulse generator (feed rate)
        "step":  Out(2),                  # bit 0: output 36 (X), bit 1: output 35 (Y)
        "ready": Out(1),
        "busy":  Out(1),
        "done":  Out(1),
        "error": Out(1),
    }


_CORE_MEMBERS = """
    Members
    -------
    in29 : :py:`In(signed(width + 4))`
        ``⌊F⌋`` at the start point (``F = ⌊F⌋ + 0.75`` always), as a two's complement number.
    in30 : :py:`In(signed(width + 1))`
        Initial counter 7: ``Y`` in sector 1 (``X > Y``), ``X - 1`` in sector 2.
    in31 : :py:`In(signed(width + 1))`
        Initial counter 8: ``X - Y - 1`` in sector 1, ``X - Y`` in sector 2 (two's complement).
    in32 : :py:`In(1)`
        End of work: the run stops at the end of this clock (its steps of this clock are made).
    in33 : :py:`In(1)`
        Initialisation (start): loads inputs 29-31 and 34 and sets trigger 4.
    in34 : :py:`In(1)`
        ``Y >= X`` at the start point: trigger 16 starts in sector 2.
    tick : :py:`In(1)`
        Enable of the clock-pulse generator: tie high for the generator's own rate.
    step : :py:`Out(2)`
        Step pulses in native coordinates: bit 0 is output 36 (X falls by one), bit 1 is
        output 35 (Y rises by one); both for a diagonal.
    ready : :py:`Out(1)`
        A start (input 33) is accepted in this clock.
    busy : :py:`Out(1)`
        Trigger 4: a run is in progress.
    done : :py:`Out(1)`
        The run stops at the end of this clock.
    error : :py:`Out(1)`
        A start while :py:`ready` was low was refused in this clock.
"""


def _check_faithful(width, timing):
    """Check the faithful core's parameters; return its timing (the default for ``None``)."""
    check_width("Register width", width, minimum=2)
    if timing is None:
        timing = FaithfulTiming()
    if not isinstance(timing, FaithfulTiming):
        raise TypeError(f"Timing must be a FaithfulTiming, not {timing!r}")
    return timing


def _check_fast(width, period):
    check_width("Register width", width, minimum=2)
    check_positive("Generator period", period)


class CircularInterpolator(wiring.Component):
    """The circular interpolator of SU 1665343 (Fig. 1): a whole quadrant in one run.

    Every element of the block diagram is here under its number: accumulating adder 1 (ones'
    complement, end-around carry), AND 2, 3, 10, 11, 22, 23, mode trigger 4, generator 5,
    commutator 6 (three channels of 2x3 AND/OR 37, inputs shifted one bit up, least significant
    bits from triggers 4 and 16), reversible counters 7 (two's complement) and 8 (ones'
    complement, with its weight-2 subtract input), "separating OR" 9, delay elements 12, 13, 14,
    19 (3 taps) and 26 (4 taps), OR 15, 17, 18, 20, 21, 24, 27, 28, sector trigger 16, pulse
    extender 25. Outputs 35 (Y) and 36 (X) are the two bits of :py:`step`.

    A run starts with a pulse on input 33 while :py:`ready` is high: adder 1, counters 7 and 8
    and trigger 16 take inputs 29, 30, 31 and 34 in that clock. From then on each pulse of
    generator 5 makes one step (Y, X or diagonal), and the operand of that step reaches adder 1
    through the commutator after delay 12, 13 or 14 (the counters have counted by then). When a
    sector-1 step makes ``X - Y <= 0`` the run switches to sector 2 and corrects F by ``X + Y``
    (the X = Y variant through AND 22 and delay 26, the X - Y = -1 variant through AND 23 and
    delay 19), with extender 25 holding AND 10 and 11 off for one generator period: a quadrant
    takes one period more than it has steps. The run stops when counter 7 turns negative (the
    step that reached X = 0 has been made) or on input 32; :py:`done` pulses in the stopping
    clock, adder 1, the counters, trigger 16, the delay lines and the extender are cleared, and
    a new run may be started in that same clock.

    The diagonal whose step makes X = Y must add ``2(X' - Y') - 1 = -1`` (the patent leaves
    this transfer open). Here, as the patent states for the X - Y = -1 variant, the delay-12
    strobe of the diagonal that causes the switch-over reaches the commutator after the
    switch-over has corrected counter 8 and set trigger 16: counter 8 then holds ``-1 + 1``,
    which a ones'-complement counter forms as -0 (``1…1``), and with the least significant bit
    from the inverse output of trigger 16 (0) the commutator's code is ``1…10``: -1. Delay 12
    is long enough for this by construction (see :class:`FaithfulTiming`).

    Parameters
    ----------
    width : :class:`int`
        Register width: counters 7 and 8 hold magnitudes up to ``2**width - 1`` (with a sign
        bit); adder 1 has ``width + 4`` bits.
    timing : :class:`FaithfulTiming`
        Generator period, delays 12, 13, 14, taps of 19 and 26, extender length, in clocks.
        Default: the structural minimum (period 4, delays 3, 1, 1, taps (1, 3, 3) and
        (1, 1, 1, 2), extender 3).
    {members}
    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2, or ``timing`` not a
        :class:`FaithfulTiming`.
    """

    def __init__(self, *, width=24, timing=None):
        timing = _check_faithful(width, timing)
        self._width = width
        self._timing = timing
        aw, cw = width + 4, width + 1
        self.adder1 = AccumulatingAdder(aw, ones_complement=True)
        self.trigger4 = Trigger(priority="set")
        self.generator5 = PulseGenerator(timing.period)
        self.commutator6 = Commutator(cw, aw, channels=3, shift=1)
        self.counter7 = ReversibleCounter(cw)
        self.counter8 = ReversibleCounter(cw, ones_complement=True)
        self.delay12 = DelayElement(timing.delay12)
        self.delay13 = DelayElement(timing.delay13)
        self.delay14 = DelayElement(timing.delay14)
        self.trigger16 = Trigger(priority="set")
        self.delay19 = DelayElement(timing.taps19)
        self.extender25 = PulseExtender(timing.extender)
        self.delay26 = DelayElement(timing.taps26)
        super().__init__(_core_signature(width))

    @property
    def width(self):
        return self._width

    @property
    def timing(self):
        return self._timing

    def elaborate(self, platform):
        m = Module()
        for name in ("adder1", "trigger4", "generator5", "commutator6", "counter7", "counter8",
                     "delay12", "delay13", "delay14", "trigger16", "delay19", "extender25",
                     "delay26"):
            m.submodules[name] = getattr(self, name)
        adder1, trigger4, generator5 = self.adder1, self.trigger4, self.generator5
        commutator6, counter7, counter8 = self.commutator6, self.counter7, self.counter8
        delay12, delay13, delay14 = self.delay12, self.delay13, self.delay14
        trigger16, delay19, extender25, delay26 = (self.trigger16, self.delay19,
                                                   self.extender25, self.delay26)

        # ---- run control: trigger 4, inputs 32 and 33 -------------------------------------------
        stop = Signal()       # counter 7 negative (inverse output of its sign bit), or input 32
        start = Signal()      # input 33, accepted
        clear = Signal()      # input 32 / counter 7 sign: triggers and accumulators to zero
        m.d.comb += [
            stop.eq(trigger4.q & (counter7.q[-1] | self.in32)),
            self.ready.eq(trigger4.q_n | stop),
            start.eq(self.in33 & self.ready),
            self.error.eq(self.in33 & ~self.ready),
            clear.eq(stop),
            trigger4.set.eq(start),
            trigger4.reset.eq(stop),
            generator5.en.eq(self.tick),
            self.busy.eq(trigger4.q),
            self.done.eq(stop),
        ]

        # ---- AND 2, 3, 10, 11: the step decision ------------------------------------------------
        and2 = Signal()       # sector 1, F < 0: diagonal
        and3 = Signal()       # sector 1, F >= 0: Y step
        and10 = Signal()      # sector 2, F >= 0: diagonal
        and11 = Signal()      # sector 2, F < 0: X step
        or9 = Signal()        # "separating OR": the diagonals of both sectors
        running = trigger4.q & generator5.o
        m.d.comb += [
            and2.eq(adder1.sign & running & trigger16.q_n),
            and3.eq(adder1.sign_n & running & trigger16.q_n),
            and10.eq(adder1.sign_n & running & trigger16.q & extender25.o_n),
            and11.eq(adder1.sign & running & trigger16.q & extender25.o_n),
            or9.eq(and2 | and10),
        ]

        # ---- sector switch-over: AND 22 (X = Y), AND 23 (X - Y = -1), OR 24, extender 25 ----
        # AND 22 decodes counter 8 = -1 (1…10 in ones' complement; the patent's "all direct
        # outputs" would be -0), AND 23 counter 8 = -2 (1…101), both gated by trigger 16's
        # inverse output. Each sends one pulse, at the front of the decoded state: the delay
        # line and the counters react to a pulse's front, and the state lasts until corrected.
        cw = self._width + 1
        decode22 = Signal()
        decode23 = Signal()
        front22 = Signal()
        front23 = Signal()
        and22 = Signal()
        and23 = Signal()
        or24 = Signal()
        m.d.comb += [
            decode22.eq((counter8.q.as_unsigned() == (1 << cw) - 2) & trigger16.q_n),
            decode23.eq((counter8.q.as_unsigned() == (1 << cw) - 3) & trigger16.q_n),
            and22.eq(decode22 & ~front22),
            and23.eq(decode23 & ~front23),
            or24.eq(and22 | and23),
        ]
        m.d.sync += [front22.eq(decode22), front23.eq(decode23)]

        # ---- the ORs ----------------------------------------------------------------------------
        or15 = Signal()       # commutator A2: delay 13, delay 19 tap 2, delay 26 tap 2
        or17 = Signal()       # counter 7 count input
        or18 = Signal()       # trigger 16 set
        or20 = Signal()       # counter 8 subtract 1
        or21 = Signal()       # counter 8 add 1
        or27 = Signal()       # output 35, Y
        or28 = Signal()       # output 36, X
        m.d.comb += [
            or15.eq(delay13.o[0] | delay19.o[1] | delay26.o[1]),
            or17.eq(or9 | and3 | and11 | delay19.o[0] | delay19.o[2] | delay26.o[3]),
            or18.eq(and23 | delay26.o[2] | (start & self.in34)),
            or20.eq(and3 | and11),
            or21.eq(and23 | delay26.o[0]),
            or27.eq(or9 | and3),
            or28.eq(or9 | and11),
            self.step.eq(Cat(or28, or27)),
        ]

        # ---- delay elements 12, 13, 14, 19, 26 and extender 25 ----------------------------------
        flush = start | clear
        m.d.comb += [
            delay12.i.eq(or9),
            delay13.i.eq(and11),
            delay14.i.eq(and3),
            delay19.i.eq(and23),
            delay26.i.eq(and22),
            extender25.i.eq(or24),
        ]
        for element in (delay12, delay13, delay14, delay19, delay26, extender25):
            m.d.comb += element.clr.eq(flush)

        # ---- trigger 16 (sector) ---------------------------------------------------------------
        # Takes input 34 at the start; otherwise cleared on a stop, set by OR 18.
        m.d.comb += [
            trigger16.set.eq(Mux(start, self.in34, or18 & ~clear)),
            trigger16.reset.eq(Mux(start, ~self.in34, clear)),
        ]

        # ---- counters 7 and 8 ------------------------------------------------------------------
        # Inputs 29-31 arrive as two's complement numbers; counter 8 and adder 1 work in ones'
        # complement, which writes a negative number one less.
        m.d.comb += [
            counter7.d.eq(self.in30),
            counter7.load.eq(start),
            counter7.clr.eq(clear),
            counter7.up.eq(or17 & trigger16.q_n),       # count mode chosen by trigger 16
            counter7.down.eq(or17 & trigger16.q),
            counter8.d.eq(self.in31 - self.in31[-1]),
            counter8.load.eq(start),
            counter8.clr.eq(clear),
            counter8.down.eq(or20),
            counter8.down2.eq(or9),
            counter8.up.eq(or21),
        ]

        # ---- commutator 6 and adder 1 ----------------------------------------------------------
        m.d.comb += [
            commutator6.b[0].eq(counter8.q),             # A1: 2·CT8 + ~T16
            commutator6.lsb[0].eq(trigger16.q_n),
            commutator6.a[0].eq(delay12.o[0]),
            commutator6.b[1].eq(counter7.q),             # A2: 2·CT7 + T16
            commutator6.lsb[1].eq(trigger16.q),
            commutator6.a[1].eq(or15),
            commutator6.b[2].eq(counter7.q_n),           # A3: ones' complement of 2·CT7 + 1
            commutator6.lsb[2].eq(trigger4.q_n),
            commutator6.a[2].eq(delay14.o[0]),
            adder1.d.eq(self.in29 - self.in29[-1]),
            adder1.load.eq(start),
            adder1.clr.eq(clear),
            adder1.b.eq(commutator6.o),
            adder1.add.eq(commutator6.strobe),
        ]
        return m


_CHOICE = data.StructLayout({
    "from_pos": 1,              # operand_neg' is formed from ~operand_pos (2Y + 2 in sector 1)
    "k_neg":    signed(4),      # ... plus this
    "keep_pos": 1,              # operand_pos' is formed from operand_pos (else from 0)
    "k_pos":    signed(4),      # ... plus this
})
_CHOICES = data.StructLayout({"neg": _CHOICE, "pos": _CHOICE})


def _choices(m, sector2, near):
    """The fast core's choices (:data:`_CHOICES`) of a state: sector 2, or sector 1 with
    ``near[k - 1]`` for ``X - Y = k`` (``k = 1 .. 4``; none of them: ``X - Y >= 5``). Each is
    how the step of that sign moves the operands on (the table of
    :class:`CircularInterpolatorFast`: a source and a constant)."""
    e1, e2, e3, e4 = (Signal(name=f"near{k}") for k in range(1, 5))
    choices = Signal(_CHOICES)
    m.d.comb += [Cat(e1, e2, e3, e4).eq(Mux(sector2, 0, Cat(*near)))]
    neg, pos = choices.neg, choices.pos
    m.d.comb += [
        # F < 0, a diagonal in sector 1 (d falls by 2) or an X step in sector 2.
        neg.from_pos.eq(e2 | e3 | e4),
        neg.k_neg.eq(Mux(sector2, -2, Mux(e1, -1, Mux(e2, -3, Mux(e3, -2, Mux(e4, 1, -4)))))),
        neg.keep_pos.eq(~(e1 | e2 | e3)),
        neg.k_pos.eq(Mux(e1, -7, Mux(e2, -5, Mux(e3, -1, -2)))),
        # F >= 0, a Y step in sector 1 (d falls by 1) or a diagonal in sector 2.
        pos.from_pos.eq(e2 | e3),
        pos.k_neg.eq(Mux(e1 | e3, 1, -2)),
        pos.keep_pos.eq(~(e1 | e2)),
        pos.k_pos.eq(Mux(sector2, -4, Mux(e1, -5, Mux(e2, -1, -2)))),
    ]
    return choices


class CircularInterpolatorFast(wiring.Component):
    """The SU 1665343 trajectory at one step per clock.

    The same registers as the patent's structure (adder, counters 7 and 8, triggers 4 and 16,
    generator 5) and the same inputs and outputs as :class:`CircularInterpolator`, so a quadrant
    takes exactly as many generator pulses as it has steps and a run can follow another with no
    idle clock: :py:`done` pulses in the clock of the last step. The numbers are two's
    complement.

    The clock's decision is the bare accumulator's: the sign of adder 1 selects one of two
    *operand registers*, :py:`operand_neg` (``F < 0``) or :py:`operand_pos` (``F >= 0``), which
    hold the two possible increments of ``F`` for the next step, the switch-over correction
    ``X + Y`` already folded in. With ``d = X - Y`` in sector 1 and the point ``(X, Y)``:

    ============  =========================  ==========================
    state         operand_neg (``F < 0``)    operand_pos (``F >= 0``)
    ============  =========================  ==========================
    sector 1      D: ``2d - 5``              Y: ``-(2Y + 3)``
    ``d = 2``     D and switch: ``2Y + 1``   Y: ``-(2Y + 3)``
    ``d = 1``     D and switch: ``2Y - 2``   Y and switch: ``-1``
    sector 2      X: ``2X - 3``              D: ``2(X - Y) - 5``
    ============  =========================  ==========================

    Each step moves the operands on by a constant (``-1`` to ``-7``, or ``+1``) added to
    themselves or to the inverse of :py:`operand_pos` (``2Y + 2`` in sector 1), or replaces
    :py:`operand_pos` by a constant. The source and the constant of each sign are
    :py:`choices`, registered one step ahead from the counters (they depend on the sector and on
    ``d = 1 .. 4``), so that in the clock of a step the sign only selects: no increment is formed
    from the counters then. The flags ``d = 1, 2`` (:py:`near`) and ``counter 7 = 0``
    (:py:`last7`) are registered ahead in the same way; with them the switch-over and the end of
    the run (counter 7's underflow) are known from registers. The proof ``circular_fast``
    (``docs/formal.md``) ties every one of these registers to the point.

    Parameters
    ----------
    width : :class:`int`
        Register width, as for :class:`CircularInterpolator`.
    period : :class:`int`
        Generator period in :py:`tick` clocks (1: a step every clock).
    decoded : :class:`bool`
        Take the decodes of inputs 30, 31 and 34 that a start needs from the ports
        :py:`in31_near` and :py:`in30_zero` (an arc core registers them with the inputs, so
        that they are not formed in the clock of the start); otherwise they are decoded here.
    {members}
    in31_near : :py:`In(4)`
        With ``decoded`` only: bit ``k - 1`` is ``~in34 & (in31 == k - 1)``, sector 1 and
        ``X - Y = k`` at the start (``k = 1 .. 4``).
    in30_zero : :py:`In(1)`
        With ``decoded`` only: ``in30 == 0``.
    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2 or ``period`` not a positive integer.
    """

    def __init__(self, *, width=24, period=1, decoded=False):
        _check_fast(width, period)
        self._width = width
        self._period = period
        self._decoded = bool(decoded)
        aw, cw = width + 4, width + 1
        self.adder1 = AccumulatingAdder(aw)
        self.trigger4 = Trigger(priority="set")
        self.generator5 = PulseGenerator(period)
        self.counter7 = ReversibleCounter(cw)
        self.counter8 = ReversibleCounter(cw)
        self.trigger16 = Trigger(priority="set")
        # The registers of the one-step-per-clock decision (see above).
        self.operand_neg = Signal(signed(aw))
        self.operand_pos = Signal(signed(aw))
        self.near = Signal(2)             # bit k - 1: sector 1 and X - Y = k (k = 1, 2)
        self.choices = Signal(_CHOICES)   # how each sign moves the operands on (_choices)
        self.last7 = Signal()             # counter 7 holds 0
        signature = _core_signature(width)
        if self._decoded:
            signature.update({"in31_near": In(4), "in30_zero": In(1)})
        super().__init__(signature)

    @property
    def width(self):
        return self._width

    @property
    def period(self):
        return self._period

    @property
    def decoded(self):
        return self._decoded

    def elaborate(self, platform):
        m = Module()
        for name in ("adder1", "trigger4", "generator5", "counter7", "counter8", "trigger16"):
            m.submodules[name] = getattr(self, name)
        adder1, trigger4, generator5 = self.adder1, self.trigger4, self.generator5
        counter7, counter8, trigger16 = self.counter7, self.counter8, self.trigger16
        op_neg, op_pos, near, last7 = self.operand_neg, self.operand_pos, self.near, self.last7
        d1, d2 = near

        move = Signal()                   # a step is made in this clock
        sector2 = trigger16.q
        negative = adder1.sign            # F < 0: operand_neg
        step_x = Signal()                 # X falls (output 36)
        step_y = Signal()                 # Y rises (output 35)
        diagonal = Signal()
        m.d.comb += [
            generator5.en.eq(self.tick),
            move.eq(generator5.o & trigger4.q),
            step_x.eq(move & (sector2 | negative)),
            step_y.eq(move & (~sector2 | ~negative)),
            diagonal.eq(step_x & step_y),
            self.step.eq(Cat(step_x, step_y)),
        ]

        # The switch-over (sector 1 only, where the flags are): a Y step at d = 1 makes X = Y,
        # a diagonal at d = 2 X = Y, a diagonal at d = 1 X - Y = -1.
        at_diagonal = Signal()
        past_diagonal = Signal()
        switch = Signal()
        m.d.comb += [
            at_diagonal.eq(move & Mux(negative, d2, d1)),
            past_diagonal.eq(move & negative & d1),
            switch.eq(at_diagonal | past_diagonal),
        ]

        # The operands after this step: a source plus a constant, both chosen by the sign
        # from the registered choices of the state (see _choices):
        #   operand_neg' = (operand_neg or ~operand_pos) + k_neg
        #   operand_pos' = (operand_pos or 0) + k_pos
        choices = self.choices
        choice = Signal(_CHOICE)
        m.d.comb += choice.eq(Mux(negative, choices.neg, choices.pos))

        # The flags and the choices after this step. In sector 1, X - Y falls by one on a Y
        # step and by two on a diagonal; counter 8 holds X - Y - 1 there (and X - Y <= 0 in
        # sector 2, so no flag). Counter 7 rises on a sector-1 step but for the switch-over's
        # correction, falls in sector 2.
        c7, c8 = counter7.q, counter8.q
        near_next = Signal(2)
        for k in range(2):
            m.d.comb += near_next[k].eq(Mux(negative, c8 == k + 2, c8 == k + 1))
        after_neg = _choices(m, sector2 | d1 | d2, [c8 == k + 1 for k in range(1, 5)])
        after_pos = _choices(m, sector2 | d1, [c8 == k for k in range(1, 5)])
        last7_next = Signal()
        m.d.comb += last7_next.eq(Mux(sector2, c7 == 1,
                                      Mux(past_diagonal, c7 == 1,
                                          Mux(at_diagonal, c7 == 0, c7 == -1))))

        # Counter 7's underflow, known ahead: the step that makes X = 0 (sector 2, counter 7
        # = X - 1 = 0; or the diagonal from (1, 0)).
        last = Signal()
        m.d.comb += last.eq(move & last7 & (sector2 | (negative & d1)))

        stop = Signal()
        start = Signal()
        m.d.comb += [
            stop.eq(trigger4.q & (last | self.in32)),
            self.ready.eq(trigger4.q_n | stop),
            start.eq(self.in33 & self.ready),
            self.error.eq(self.in33 & ~self.ready),
            trigger4.set.eq(start),
            trigger4.reset.eq(stop),
            self.busy.eq(trigger4.q),
            self.done.eq(stop),

            adder1.d.eq(self.in29),
            adder1.load.eq(start),
            adder1.clr.eq(stop),
            adder1.b.eq(Mux(negative, op_neg, op_pos)),
            adder1.add.eq(move),

            counter7.d.eq(self.in30),
            counter7.load.eq(start),
            counter7.clr.eq(stop),
            counter7.up.eq(move & ~sector2),
            counter7.down.eq((move & sector2) | at_diagonal),
            counter7.down2.eq(past_diagonal),

            counter8.d.eq(self.in31),
            counter8.load.eq(start),
            counter8.clr.eq(stop),
            counter8.down.eq(move & ~diagonal),
            counter8.down2.eq(diagonal),
            counter8.up.eq(switch),

            trigger16.set.eq(Mux(start, self.in34, switch & ~stop)),
            trigger16.reset.eq(Mux(start, ~self.in34, stop)),
        ]

        # The operands and flags of a starting run, from inputs 30, 31 and 34 (counter 7: Y
        # or X - 1; counter 8: d - 1 or X - Y). The carry chains start from the inputs (input
        # 34 at most selects ahead of one), and the decoded d = 1, 2 only select after them:
        # 2·in30 - 1 is 2X - 3 in sector 2 and, its bit 0 cleared, 2Y - 2 at d = 1; 2Y + 1 at
        # d = 2 is 2·in30 with bit 0 set; 2·in31 - 3 is 2d - 5 in sector 1.
        in30, in31, in34 = self.in30, self.in31, self.in34
        aw = self._width + 4
        if self._decoded:
            first_near, first_zero7 = self.in31_near, self.in30_zero
        else:
            first_near = Cat(*(~in34 & (in31 == k) for k in range(4)))
            first_zero7 = in30 == 0
        first_d1, first_d2 = first_near[0], first_near[1]
        twice30 = Signal(signed(aw))      # 2·in30 - 1
        twice31 = Signal(signed(aw))      # 2·in31 - 3
        first_pos = Signal(signed(aw))    # 2(X - Y) - 5 in sector 2, -(2Y + 3) in sector 1
        m.d.comb += [
            twice30.eq(2 * in30 - 1),
            twice31.eq(2 * in31 - 3),
            first_pos.eq(2 * Mux(in34, in31, ~in30) + Mux(in34, -5, -1)),
        ]
        with m.If(start):
            m.d.sync += [
                # 2X - 3, 2Y - 2, 2Y + 1, 2d - 5 (the table above)
                op_neg.eq(Mux(in34, twice30,
                              Mux(first_d1, Cat(C(0, 1), twice30[1:]).as_signed(),
                                  Mux(first_d2, Cat(C(1, 1), in30).as_signed(), twice31)))),
                # 2(X - Y) - 5, -1, -(2Y + 3)
                op_pos.eq(Mux(first_d1, -1, first_pos)),
                near.eq(Cat(first_d1, first_d2)),
                choices.eq(_choices(m, in34, list(first_near))),
                last7.eq(first_zero7),
            ]
        with m.Elif(move):
            m.d.sync += [
                op_neg.eq(Mux(choice.from_pos, ~op_pos, op_neg) + choice.k_neg),
                op_pos.eq(Mux(choice.keep_pos, op_pos, 0) + choice.k_pos),
                near.eq(near_next),
                choices.eq(Mux(negative, after_neg, after_pos)),
                last7.eq(last7_next),
            ]
        return m


CircularInterpolator.__doc__ = CircularInterpolator.__doc__.replace("{members}", _CORE_MEMBERS)
CircularInterpolatorFast.__doc__ = CircularInterpolatorFast.__doc__.replace("{members}",
                                                                            _CORE_MEMBERS)


def _sum_small(m, a, b):
    """Bit ``k`` of the result: ``a + b == k`` modulo ``2**len(a)``, for ``k = 0 .. 3``,
    without a carry chain. Where the sum's bits 3 and up are zero, every carry into them is
    known from the bit below (``a | b``, as for a sum of zero), so each bit is checked on its
    own and the checks are ANDed; the low three bits are summed apart."""
    width = len(a)
    high = Signal(name="sum_high_zero")
    low = Signal(3, name="sum_low")
    a, b = a.as_unsigned(), b.as_unsigned()
    m.d.comb += [
        high.eq(~((a[3:] ^ b[3:]) ^ (a[2:width - 1] | b[2:width - 1])).any()),
        low.eq(a[:3] + b[:3]),
    ]
    return Cat(*(high & (low == k) for k in range(4)))


class _QuadrantCore(wiring.Component):
    """A SU 1665343 interpolator as an arc core (:class:`~kontur.hdl.arc.ArcCoreSignature`).

    A quadrant run taken from :py:`cmd`, the native start ``(x, y)`` and ``residue = r2 - x² -
    y²``, is prepared in a register holding the patent's inputs 30, 31 and 34 and ``residue -
    1``, from which input 29 (``⌊F⌋ = residue + x - 2y - 2`` in sector 1, ``residue + 2x - y -
    2`` in sector 2, since the start's own circle has ``r2 = x² + y² + residue``) is formed as
    the interpolator loads it (one carry chain each side of the register, not two sums and a
    choice before it); for an interpolator that takes them (``decoded``), the register holds
    the decodes of inputs 30 and 31 its start needs too. The run is started by input 33 as
    soon as the interpolator is ready: in the next clock when it is idle, in the clock the
    running quadrant stops otherwise. :py:`stop` is input 32. The step permission drives
    generator 5 (:func:`~kontur.hdl.engine.permit`); the next step is diagonal when F is negative in
    sector 1 and not negative in sector 2. :py:`abort` stops the run through input 32 with no
    step in that clock and drops the prepared run.
    """

    def __init__(self, interpolator):
        self.interpolator = interpolator
        super().__init__(ArcCoreSignature(interpolator.width))

    @property
    def width(self):
        return self.interpolator.width

    def _feed(self, ip):
        """``(running, free)`` for :func:`~kontur.hdl.engine.permit`."""
        return ip.trigger4.q, 0

    def elaborate(self, platform):
        m = Module()
        w = self.width
        m.submodules.interpolator = ip = self.interpolator

        x, y, residue = self.cmd.payload.x, self.cmd.payload.y, self.cmd.payload.residue
        cw, aw = w + 1, w + 4
        full = Signal()
        in30 = Signal(signed(cw))
        in31 = Signal(signed(cw))
        in34 = Signal()
        residue_1 = Signal(signed(w + 2))     # residue - 1, for input 29 (below)
        take = Signal()
        m.d.comb += [
            take.eq(full & ip.ready & ~self.abort),
            self.cmd.ready.eq(~full | take),
        ]
        # Inputs 30, 31 and 34 from one carry chain each: x - y - 1 is counter 8 in sector 1,
        # and its sign is sector 2 (Y >= X).
        x_, y_ = Signal(signed(cw)), Signal(signed(cw))
        below = Signal(signed(cw))            # x - y - 1
        sector2 = below[-1]
        m.d.comb += [x_.eq(x), y_.eq(y), below.eq(x_ + ~y_)]
        # The register takes the payload whenever it may (:py:`cmd.valid` only sets full), so
        # that the handover's valid is not on the path to every bit's enable.
        with m.If(self.cmd.ready):
            m.d.sync += [
                in30.eq(Mux(sector2, x_ - 1, y_)),
                in31.eq(Mux(sector2, x_ - y_, below)),
                in34.eq(sector2),
                residue_1.eq(residue - 1),
            ]
        if getattr(ip, "decoded", False):
            # The decodes the fast interpolator's start needs, registered with its inputs:
            # x - y - 1 = k >= 0 for k = 0 .. 3 (it is sector 1 then), and counter 7's zero,
            # X - 1 = 0 in sector 2 (x = 1 and y >= 1) or Y = 0 in sector 1 (y = 0 and x >= 1),
            # both decoded from the payload beside the carry chain, not after it.
            in31_near = Signal(4)
            in30_zero = Signal()
            with m.If(self.cmd.ready):
                m.d.sync += [
                    in31_near.eq(_sum_small(m, x_, ~y_)),
                    in30_zero.eq(((x == 1) & (y != 0)) | ((y == 0) & (x != 0))),
                ]
            m.d.comb += [ip.in31_near.eq(in31_near), ip.in30_zero.eq(in30_zero)]
        # Input 29, ⌊F⌋ = residue + x - 2y - 2 (sector 1) or residue + 2x - y - 2 (sector 2),
        # formed from the registers as it is loaded, in one carry chain after a carry-save
        # reduction: (residue - 1) + in31 + (in30 or ~in30) + (1 in sector 1), the last in the
        # reduction's free carry bit 0 (numbers modulo 2**(width + 4)).
        in29 = Signal(signed(aw))
        r_1, c8, c7 = Signal(aw), Signal(aw), Signal(aw)
        m.d.comb += [r_1.eq(residue_1), c8.eq(in31), c7.eq(Mux(in34, in30, ~in30))]
        total, carries = carry_save(m, r_1, c8, c7)
        m.d.comb += in29.eq(total + (carries | ~in34))
        with m.If(self.cmd.valid & self.cmd.ready):
            m.d.sync += full.eq(1)
        with m.Elif(take | self.abort):
            m.d.sync += full.eq(0)

        running, free = self._feed(ip)
        enable = permit(m, self.feed, armed=ip.generator5.armed, running=running, free=free,
                        abort=self.abort)
        m.d.comb += [
            ip.in29.eq(in29),
            ip.in30.eq(in30),
            ip.in31.eq(in31),
            ip.in34.eq(in34),
            ip.in33.eq(take),
            ip.in32.eq(self.stop | self.abort),
            ip.tick.eq(enable),
            self.feed.diagonal.eq(Mux(ip.trigger16.q, ip.adder1.sign_n, ip.adder1.sign)),
            self.step.eq(ip.step),
            self.start.eq(take),
            self.done.eq(ip.done),
            self.busy.eq(full | ip.busy),
        ]
        return m


class FaithfulArcCore(_QuadrantCore):
    """:class:`CircularInterpolator` (the patent's structure and timing) as an arc core.

    A step is due at generator 5's pulse, once every period (four clocks by default); the
    pulse that extender 25 blocks after a switch-over makes no step and needs no permission.

    Parameters
    ----------
    width, timing
        As :class:`CircularInterpolator`.
    """

    def __init__(self, *, width=24, timing=None):
        _check_faithful(width, timing)           # before the interpolator is made
        super().__init__(CircularInterpolator(width=width, timing=timing))

    @property
    def timing(self):
        return self.interpolator.timing

    def _feed(self, ip):
        blocked = ip.trigger16.q & ip.extender25.o         # AND 10 and 11 held off
        return ip.trigger4.q & ~blocked, ip.trigger4.q & blocked


class FastArcCore(_QuadrantCore):
    """:class:`CircularInterpolatorFast` (one step per clock) as an arc core.

    Parameters
    ----------
    width, period
        As :class:`CircularInterpolatorFast`.
    """

    def __init__(self, *, width=24, period=1):
        _check_fast(width, period)               # before the interpolator is made
        super().__init__(CircularInterpolatorFast(width=width, period=period, decoded=True))

    @property
    def period(self):
        return self.interpolator.period
