"""T. Siimut's interpolator with transition to the equidistant (1963): cutter-radius
compensation in hardware.

The program describes the part's profile; the cutter radius is a register (the console's
dial, set by a frame); the engine moves the cutter's centre along the equidistant and finds by
itself where the equidistant of one element meets the next one's. The seed's blocks keep their
numbers (Fig. 4): ``block1`` the input and conversion of frames, ``block2`` the intermediate
memory (three slots: the element traced, the next one, the one after), ``block3`` the pulse
distributor of lines, ``block4``/``block10`` the integrators of every slot's function,
``block5x``/``block5y`` and ``block6`` the multipliers (``C·x00``, ``D·y00``; ``G·r``),
``block7``/``block8`` the sums they feed, ``block9`` the axis swap, ``block11`` the comparator,
``block12``/``block13`` the position counters, ``block14``/``block15`` the step permission of
the feed interface. ``docs/equidistant.md`` maps them and states what the text leaves open.
"""

from types import SimpleNamespace

from amaranth import *
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from .arc import ArcCoreSignature, _quadrant_of_signs, _x_falls
from .elements import AccumulatingAdder, ReversibleCounter
from .elements._checks import check_width
from .engine import EngineSignature, Outcome, StatusUnit, step_delta
from .spec import SETTLE, Formats, Kind

__all__ = ["Kind", "Formats", "SerialMultiplier", "EquidistantEngine", "SETTLE"]


class SerialMultiplier(wiring.Component):
    """Shift-and-add multiplier: one multiplier bit a clock, from the least significant.

    :py:`start` takes the magnitudes :py:`a` and :py:`b`; ``b_width`` clocks later
    :py:`product` holds ``a·b`` and :py:`done` pulses (in the clock after the last addition),
    the product held until the next start; :py:`clear` stops it and clears the product. The
    partial sums are formed by an :class:`~kontur.hdl.elements.AccumulatingAdder` (loaded with zero
    at the start, the multiplicand shifted left a place a clock).

    Parameters
    ----------
    a_width, b_width : :class:`int`
        Widths of the multiplicand and the multiplier.

    Members
    -------
    start : :py:`In(1)`
        Take the operands.
    clear : :py:`In(1)`
        Stop, and clear the product (wins over :py:`start`).
    a : :py:`In(a_width)`
        Multiplicand.
    b : :py:`In(b_width)`
        Multiplier.
    busy : :py:`Out(1)`
        Multiplying.
    done : :py:`Out(1)`
        The product is ready (one clock).
    product : :py:`Out(a_width + b_width)`
        ``a·b``.

    Raises
    ------
    :exc:`TypeError`
        If a width is not a positive integer.
    """

    def __init__(self, a_width, b_width):
        check_width("Multiplicand width", a_width)
        check_width("Multiplier width", b_width)
        self._a_width = a_width
        self._b_width = b_width
        self.adder = AccumulatingAdder(a_width + b_width + 1)
        super().__init__({
            "start":   In(1),
            "clear":   In(1),
            "a":       In(a_width),
            "b":       In(b_width),
            "busy":    Out(1),
            "done":    Out(1),
            "product": Out(a_width + b_width),
        })

    def elaborate(self, platform):
        m = Module()
        m.submodules.adder = adder = self.adder
        width = self._a_width + self._b_width
        multiplicand = Signal(width)
        multiplier = Signal(self._b_width)
        count = Signal(range(self._b_width + 1))
        finish = Signal()
        m.d.comb += [
            adder.load.eq(self.start),               # d is zero
            adder.clr.eq(self.clear),
            adder.b.eq(multiplicand),
            adder.add.eq(~self.start & self.busy & multiplier[0]),
            self.product.eq(adder.q[:width]),
            self.done.eq(finish),
        ]
        m.d.sync += finish.eq(0)
        with m.If(self.clear):
            m.d.sync += self.busy.eq(0)
        with m.Elif(self.start):
            m.d.sync += [multiplicand.eq(self.a), multiplier.eq(self.b),
                         count.eq(self._b_width), self.busy.eq(1)]
        with m.Elif(self.busy):
            m.d.sync += [multiplicand.eq(multiplicand << 1), multiplier.eq(multiplier >> 1),
                         count.eq(count - 1)]
            with m.If(count == 1):
                m.d.sync += [self.busy.eq(0), finish.eq(1)]
        return m


def _frame(f):
    w, fr = f.width, f.fraction
    return data.StructLayout({
        "kind": 3,                           # Kind
        "last": 1,                           # the terminal: aimed at, not traced
        "h": 1,                              # its function falls along the element before
        "side": signed(2),                   # +1 left (G41), -1 right (G42), 0 no offset
        "cw": 1,                             # arc: clockwise
        "swap": 1,                           # line: the y, x system (|k| <= 1 in it)
        "minor": 1,                          # line: the minor coordinate falls
        "k": signed(f.coefficient),          # line: ±k · 2**F
        "b": signed(f.intercept),            # line: ±b · 2**F (through its base point)
        "sec": signed(f.coefficient),        # line: ±1/cos α · 2**F, sign of the major step
        "x": signed(w + 1),                  # arc: centre; START: position; RADIUS: r
        "y": signed(w + 1),
        "e": unsigned(f.square),             # arc: R²
        "g": unsigned(f.intercept),          # arc: 2R · 2**F
        "entry": 1,                          # the element before ends on this line instead:
        "eswap": 1,
        "eminor": 1,
        "ek": signed(f.coefficient),
        "eb": signed(f.intercept),
        "eg": signed(f.intercept),           # ... moved eg·r (2**F) along its minor axis
    })


def _slot(f):
    return data.StructLayout({
        "valid": 1, "ready": 1, "computing": 1, "last": 1, "arc": 1, "h": 1, "entry": 1,
        "empty": 1,
        "swap": 1, "minor": 1, "back": 1, "k": signed(f.coefficient),
        "cu": signed(f.width + 3), "cv": signed(f.width + 3),   # the position less the centre
        "zu": 1, "zv": 1,                    # cu, cv are zero (kept with them, not tested)
        "cw": 1,
        "eswap": 1, "eminor": 1, "ek": signed(f.coefficient),
        "v": signed(f.value),                # its own function at the position
        "w": signed(f.value),                # its entry line's function at the position
    })


def _coefficients(swap, minor, k, one):
    """``(C, D)`` of a line function (Table 1 with the sign ``s`` of the minor direction)."""
    sk = Mux(minor, -k, k)
    sone = Mux(minor, -one, one)
    return Mux(swap, -sone, sk), Mux(swap, sk, -sone)


def _zero_after(value, step, negative):
    """Whether ``value`` plus the step ``(step, negative)`` is zero, from equality tests of
    ``value`` (no carry chain): it is -1, 1 or 0."""
    return Mux(step, Mux(negative, value == 1, value == -1), value == 0)


def _near_after(value, step, negative):
    """Whether ``value`` plus the step ``(step, negative)`` is -1, 0 or 1, from equality tests
    of ``value``."""
    def within(low):
        return (value == low) | (value == low + 1) | (value == low + 2)
    return Mux(step, Mux(negative, within(0), within(-2)), within(-1))


def _line_terms(swap, minor, k, one, step_x, step_y, neg_x, neg_y):
    """``C·dx + D·dy`` of a line function (:func:`_coefficients`) as the terms of a sum with
    no carry chain of its own: ``±k`` (``~k`` and a carry of one where negative), ``±one``
    (a constant), the carry."""
    step_k, neg_k = Mux(swap, step_y, step_x), Mux(swap, neg_y, neg_x)
    step_one, neg_one = Mux(swap, step_x, step_y), Mux(swap, neg_x, neg_y)
    k_negative = minor ^ neg_k               # C (D when swapped) is ±k: sk = (minor ? -k : k)
    one_negative = ~minor ^ neg_one          # ... the other is -sone = (minor ? one : -one)
    return (Mux(step_k, Mux(k_negative, ~k, k), 0),
            Mux(step_one, Mux(one_negative, -one, one), 0),
            step_k & k_negative)


def _abs(value):
    return Mux(value < 0, -value, value)


def _abs_difference(a, b):
    """``|a - b|``: both differences formed side by side, the sign of one choosing (one carry
    chain deep)."""
    return Mux(a < b, b - a, a - b)


class EquidistantEngine(wiring.Component):
    """Cutter-radius compensation (T. Siimut, 1963) around a quadrant core: profile elements
    in, the cutter centre's steps out.

    Frames (:meth:`Frame`) on :py:`cmd`, in order: ``RADIUS`` (the dial: ``x = r``), ``START``
    (the cutter's centre is at ``(x, y)``: a contour begins), the elements of the contour
    (``LINE``: the seed's ``k``, ``b``, ``1/cos α``, system and direction flags, the side;
    ``ARC``: centre, ``R²``, ``2R``, direction, side), the last of them the terminal
    (``last``: its function only ends the element before), and for a closed contour ``CLOSE``
    (return to the start: a no-op when the contour closed on it). No element frame depends on
    the radius.

    Every element's function (a line's deviation ``T`` in the minor axis, a circle's
    ``S = u² + v² - N``) is formed when its frame enters the memory, by the multipliers,
    at the position then (two elements ahead), and integrated over every step from there;
    while an element is traced, the next one's function (or its entry line) is compared with
    the threshold of the element's steps (block 11): the element ends at the first point where
    ``2·h·F + 2τ >= 0`` (``2τ`` the largest change of ``F`` over one step of the element's
    kinds), without a step from it. The slots follow the position a clock late (every
    relative position takes the step of the clock before; the functions take its terms,
    registered, a clock after that) and the test is three registered stages (:data:`SETTLE`
    clocks in all), so an element steps only after four clocks with no step and no change of
    its slots (every fifth clock at most). The next element starts from there: a line with
    its deviation in register III, an arc by a quadrant run handed to the core two clocks
    before its first step; ten clocks from the last step of one line to the first of the
    next. An element whose frame is still being prepared when its predecessor ends waits for
    it (``2·(width + 2) + 10`` clocks at most).

    Everything else is the common interface (:class:`~kontur.hdl.engine.EngineSignature`): one
    outcome per frame, in order, with the steps made during it; :py:`abort`. Refused
    (:attr:`~kontur.hdl.engine.Outcome.REFUSED`, taken when nothing is in flight): an element with no
    contour open, an unknown kind, a negative radius.

    Parameters
    ----------
    core : :class:`~amaranth.lib.wiring.Component`
        A quadrant core (:class:`~kontur.hdl.arc.ArcCoreSignature`) of width ``width + 2``; it becomes
        the submodule ``core``.
    fraction : :class:`int`
        Fractional bits (default ``width + 4``).

    Members
    -------
    cmd : :py:`In(stream.Signature(EquidistantEngine.Frame(formats)))`
        Frames.
    feed, motion, status, abort, busy
        As :class:`~kontur.hdl.engine.EngineSignature`; positions are ``width + 3`` bits.

    Raises
    ------
    :exc:`TypeError`
        If ``core`` is not a component with an :class:`~kontur.hdl.arc.ArcCoreSignature` of width at
        least 6, or ``fraction`` not an integer of at least 2.
    """

    @staticmethod
    def Frame(formats):
        return _frame(formats)

    @staticmethod
    def Slot(formats):
        return _slot(formats)

    def __init__(self, core, *, fraction=None):
        if (not isinstance(core, wiring.Component)
                or not isinstance(core.signature, ArcCoreSignature)):
            raise TypeError(f"Core must be a component with an ArcCoreSignature, not {core!r}")
        if core.signature.width < 6:
            raise TypeError(f"Core width must be an integer of at least 6, not "
                            f"{core.signature.width!r}")
        self._formats = Formats(core.signature.width - 2, fraction)
        self._core = core
        f = self._formats
        a5 = max(f.fraction + 1, f.width + 2)
        self.block5x = SerialMultiplier(a5, f.width + 2)
        self.block5y = SerialMultiplier(a5, f.width + 2)
        self.block6 = SerialMultiplier(f.intercept, f.width + 2)
        self.block12 = ReversibleCounter(f.position)
        self.block13 = ReversibleCounter(f.position)
        super().__init__(EngineSignature(_frame(f), position_width=f.width + 3))

    @property
    def core(self):
        return self._core

    @property
    def formats(self):
        return self._formats

    @property
    def width(self):
        return self._formats.width

    @property
    def coord_width(self):
        return self._formats.width + 1

    def elaborate(self, platform):
        m = Module()
        m.submodules.core = self._core
        for name in ("block5x", "block5y", "block6", "block12", "block13"):
            m.submodules[name] = getattr(self, name)
        m.submodules.status = StatusUnit(position_width=self._formats.width + 3,
                                         number_width=self.signature.number_width)
        n = self._block2_registers(m)
        self._block3_line_steps(m, n)
        self._block9_steps(m, n)
        self._blocks4_10_integrators(m, n)
        self._block11_comparator(m, n)
        self._element_ends(m, n)
        self._arc_runs(m, n)
        self._block1_frames(m, n)
        self._blocks5_8_functions(m, n)
        self._block2_memory(m, n)
        self._control_frames(m, n)
        self._blocks12_13_position(m, n)
        self._blocks14_15_outputs(m, n)
        return m

    # The helpers below each elaborate one group of Fig. 4's blocks into ``m``; ``n`` (a
    # namespace) carries the signals that one group drives and another reads, under the names
    # the groups give them.

    def _block2_registers(self, m):
        """Block 2's three slots, the dial, the start and the contour's flags."""
        f = self._formats
        w, fr = f.width, f.fraction
        n = SimpleNamespace(f=f, one=1 << fr, half=1 << (fr - 1), core=m.submodules.core,
                            status=m.submodules.status, frame=self.cmd.payload, slot=_slot(f))
        slot = n.slot
        own = Signal(slot)                   # block 2: the element traced (register III in v)
        cmp = Signal(slot)                   # ... the next one (its function in blocks 4, 10)
        prep = Signal(slot)                  # ... the one after (being formed, blocks 5-8)
        n.own, n.cmp, n.prep = own, cmp, prep
        n.slots = (own, cmp, prep)
        # Each slot's terms of the step of the clock before, added into its functions (block 2)
        n.tv = [Signal(signed(f.value), name=f"tv{i}") for i in range(3)]
        n.tw = [Signal(signed(f.value), name=f"tw{i}") for i in range(3)]
        n.x, n.y = self.block12.q, self.block13.q    # blocks 12, 13: the cutter's centre
        radius = Signal(w)
        radius2 = Signal(2 * w)
        contour = Signal()                   # a contour is open: elements are taken
        homing = Signal()
        fresh_next = Signal()                # block 11's test will be of the next state
        at_point_next = Signal()             # ... and the element ends at its point
        n.radius, n.radius2 = radius, radius2
        n.contour, n.homing, n.fresh_next, n.at_point_next = (contour, homing, fresh_next,
                                                               at_point_next)
        return n

    def _block3_line_steps(self, m, n):
        """This clock's step: whether the traced element runs; block 3, the line's steps;
        the arc run's hand-over registers; the return's steps."""
        f, own, cmp, core = n.f, n.own, n.cmp, n.core
        half = n.half
        hold = n.status.hold
        end_now = Signal()
        # The slots' flags registered: they change only in a clock that is not quiet (a shift,
        # a function formed into the traced or compared slot, an abort), so while the test is
        # fresh they are this clock's.
        # The element runs, ends at the point, runs a line or an arc: registered from the
        # slots' flags, the test's freshness and its outcome of the next clock.
        slots_ready = own.valid & ~own.last & own.ready & cmp.valid & cmp.ready
        ends = Signal()
        runs_line = Signal()
        runs_arc = Signal()
        go = slots_ready & n.fresh_next
        m.d.sync += [
            ends.eq(go & n.at_point_next),
            runs_line.eq(go & ~n.at_point_next & ~own.arc),
            runs_arc.eq(go & ~n.at_point_next & own.arc),
        ]
        free = ~hold & ~self.abort
        m.d.comb += end_now.eq(ends & free)

        # Block 3: the pulse distributor of lines. Register I holds |k|; register III the
        # element's deviation T (+ 1/2): every step moves the major axis, and the minor one
        # when the line is half a step ahead after it (overflow), back when it is more than
        # half a step behind; a step along the minor axis alone when it is half a step ahead
        # already (the catch-up after a corner).
        # |k| as k or ~k and a carry; ahead = T + |k| tested against ±half from the signs of
        # two sums (each one carry chain, not a negation, a sum and a comparator in a row).
        k_negative = own.k[-1]
        register1 = Mux(k_negative, ~own.k, own.k)
        minor_only = own.v >= half
        ahead_less_half = Signal(signed(f.value + 2))
        ahead_plus_half = Signal(signed(f.value + 2))
        m.d.comb += [ahead_less_half.eq(own.v + register1 + k_negative - half),
                     ahead_plus_half.eq(own.v + register1 + k_negative + half)]
        forward = ~minor_only & ~ahead_less_half[-1]
        backward = ~minor_only & ahead_plus_half[-1]
        # The step's kinds are registered, formed from the slot of the clock before: a line
        # steps only while block 11's test is fresh, i.e. when that clock changed nothing of
        # its slot, so they are this clock's (and block 3's carry chains leave the step's
        # path).
        line_major = Signal()
        line_minor = Signal()
        line_minor_negative = Signal()
        m.d.sync += [
            line_major.eq(~minor_only),
            line_minor.eq(minor_only | forward | backward),
            line_minor_negative.eq(own.minor ^ backward),
        ]

        line_due = Signal()
        m.d.comb += line_due.eq(runs_line & free)
        line_step = Signal()
        m.d.comb += line_step.eq(line_due & self.feed.tick)

        # Arc runs on the quadrant core: one at a time, handed over in WAIT, taken in TAKE.
        arc_state = Signal(2)                # 0 wait, 1 take, 2 run
        run_swap = Signal()
        run_dir = Signal(2)
        arc_go = Signal()
        m.d.comb += [
            arc_go.eq(runs_arc & free),
            core.feed.tick.eq(self.feed.tick & arc_go),
        ]

        # The return: the position less the start (counted with every step, blocks 12 and 13
        # beside it), from which the steps (towards the start) and the return's end (the start
        # within a step on each axis) are read without a carry chain.
        home_ux = Signal(signed(f.position + 1))
        home_uy = Signal(signed(f.position + 1))
        # Whether each is non-zero, and within a step of zero: kept with them (registered
        # from the value and the step, by equality tests), not tested after them.
        home_dx = Signal()
        home_dy = Signal()
        near_x = Signal(init=1)
        near_y = Signal(init=1)

        n.home_near = near_x & near_y
        n.home_ux, n.home_uy = home_ux, home_uy
        n.near_x, n.near_y = near_x, near_y
        home_due = n.homing & (home_dx | home_dy) & ~hold & ~self.abort
        home_step = home_due & self.feed.tick
        n.hold, n.end_now = hold, end_now
        n.line_major, n.line_minor, n.line_minor_negative = (line_major, line_minor,
                                                             line_minor_negative)
        n.line_due, n.line_step = line_due, line_step
        n.arc_state, n.run_swap, n.run_dir, n.arc_go = arc_state, run_swap, run_dir, arc_go
        n.home_dx, n.home_dy, n.home_due, n.home_step = home_dx, home_dy, home_due, home_step

    def _block9_steps(self, m, n):
        """Block 9: the steps of lines, arcs and the return onto the real axes."""
        own, x, y = n.own, n.x, n.y
        native = n.core.step
        arc_bits = Mux(n.run_swap, Cat(native[1], native[0]), native)
        step_x = Signal()
        step_y = Signal()
        neg_x = Signal()
        neg_y = Signal()
        with m.If(n.line_step):
            with m.If(own.swap):
                m.d.comb += [step_x.eq(n.line_minor), neg_x.eq(n.line_minor_negative),
                             step_y.eq(n.line_major), neg_y.eq(own.back)]
            with m.Else():
                m.d.comb += [step_x.eq(n.line_major), neg_x.eq(own.back),
                             step_y.eq(n.line_minor), neg_y.eq(n.line_minor_negative)]
        with m.Elif(n.home_step):
            m.d.comb += [step_x.eq(n.home_dx), neg_x.eq(n.home_dx & ~n.home_ux[-1]),
                         step_y.eq(n.home_dy), neg_y.eq(n.home_dy & ~n.home_uy[-1])]
        with m.Elif(n.arc_go):
            m.d.comb += [step_x.eq(arc_bits[0]), neg_x.eq(n.run_dir[0]),
                         step_y.eq(arc_bits[1]), neg_y.eq(n.run_dir[1])]
        n.step_x, n.step_y, n.neg_x, n.neg_y = step_x, step_y, neg_x, neg_y

    def _relative(self, n, s):
        """The position relative to slot ``s``'s centre (the slot's registers: counted with
        every step from the position it entered at, so that no subtraction precedes the
        functions' sums and block 11)."""
        return s.cu, s.cv

    def _blocks4_10_integrators(self, m, n):
        """Blocks 4 and 10: the terms every slot's functions ``(v, w)`` and its relative
        position take from the step of the clock before (added by block 2 with the functions
        formed, one sum each). The slots follow the position a clock late, so that the step's
        decision ends in a register here; block 11's first stage reads them a clock after
        that (SETTLE)."""
        one = n.one
        late = Signal(4)                     # the step of the clock before: x, y, -x, -y
        m.d.sync += late.eq(Cat(n.step_x, n.step_y, n.neg_x, n.neg_y))
        n.late = late
        # The last slot was taken in the clock before, its functions at the position after
        # that clock's step: the step is not theirs (its relative position, taken before the
        # step, follows it as every slot's).
        n.taken_late = Signal()

        def terms(s, skip):
            """The terms of ``v`` and of ``w`` of slot ``s`` for the step ``(step_x,
            step_y)`` in the directions ``(neg_x, neg_y)``: a circle's ``±2u + 1`` is ``2u + 1``
            or ``~2u`` and a carry of two, a line's :func:`_line_terms`; and the step."""
            step_x, step_y = late[0] & ~skip, late[1] & ~skip
            neg_x, neg_y = late[2], late[3]
            u, v = self._relative(n, s)
            circle = (Mux(step_x, Mux(neg_x, ~(u << 1), (u << 1) | 1), 0),
                      Mux(step_y, Mux(neg_y, ~(v << 1), (v << 1) | 1), 0),
                      Cat(C(0, 1), (step_x & neg_x) ^ (step_y & neg_y),
                          step_x & neg_x & step_y & neg_y))
            line = _line_terms(s.swap, s.minor, s.k, one, step_x, step_y, neg_x, neg_y)
            entry = _line_terms(s.eswap, s.eminor, s.ek, one, step_x, step_y, neg_x, neg_y)
            return ([Mux(s.arc, a, b) for a, b in zip(circle, line)], entry,
                    (step_delta(late[0], neg_x), step_delta(late[1], neg_y)))

        skips = (C(0, 1), C(0, 1), n.taken_late)
        n.terms = [terms(s, skip) for s, skip in zip(n.slots, skips)]

    def _block11_comparator(self, m, n):
        """Block 11: the traced element's end at the point where the next element's function
        (or its entry line) reaches the threshold ``2τ`` (the test registered); the arc core's
        run from the position, aborted by it."""
        f, one, own, cmp = n.f, n.one, n.own, n.cmp
        # The kinds of the traced element's steps (signs qx, qy; which axis steps occur).
        own_u, own_v = self._relative(n, own)
        quadrant = _quadrant_of_signs(~own_u[-1] & ~own.zu, own_u[-1],
                                      ~own_v[-1] & ~own.zv, own_v[-1], own.cw)
        x_negative = (quadrant == 1) | (quadrant == 2)
        y_negative = (quadrant == 2) | (quadrant == 3)
        qx_neg = Mux(own.arc, Mux(own.cw, y_negative, ~y_negative),
                     Mux(own.swap, own.minor, own.back))
        qy_neg = Mux(own.arc, Mux(own.cw, ~x_negative, x_negative),
                     Mux(own.swap, own.back, own.minor))
        x_kind = own.arc | ~own.swap
        y_kind = own.arc | own.swap

        tc, td = _coefficients(Mux(cmp.entry, cmp.eswap, cmp.swap),
                               Mux(cmp.entry, cmp.eminor, cmp.minor),
                               Mux(cmp.entry, cmp.ek, cmp.k), one)
        tu, tv = self._relative(n, cmp)
        target_circle = cmp.arc & ~cmp.entry
        # The test is three registered stages: the first forms the kinds of the traced
        # element's steps against the target (the quadrant and the kinds from the slots'
        # registers), the second the sums with the function (which the slots keep two clocks
        # behind the position), the third the comparisons. Block 2's freshness says nothing of
        # the state (position, traced and compared slots) changed in the SETTLE clocks before
        # (the first of them the slots' late step), so the test is of this state and an
        # element runs only after SETTLE clocks with no step and no change of its slots.
        kind_a = Signal(signed(f.value))
        kind_b = Signal(signed(f.value))
        twice = Signal(signed(f.value + 1))
        kinds = Signal(2)                    # x_kind, y_kind
        falls = Signal()                     # cmp.h
        special = Signal()                   # an arc ends where it is empty or at its centre
        at_centre = own.arc & own.zu & own.zv
        m.d.sync += [
            kind_a.eq(Mux(target_circle, Mux(qx_neg, -2 * tu + 1, 2 * tu + 1),
                          Mux(qx_neg, -tc, tc))),
            kind_b.eq(Mux(target_circle, Mux(qy_neg, -2 * tv + 1, 2 * tv + 1),
                          Mux(qy_neg, -td, td))),
            kinds.eq(Cat(x_kind, y_kind)),
            falls.eq(cmp.h),
            special.eq(own.arc & (own.empty | at_centre)),
        ]
        # 2τ, the largest change over one step, is max(x_kind·|a|, y_kind·|b|, |a + b|) of
        # the kinds a, b; the element ends where ±2F + 2τ >= 0. Formed as that test against
        # each of ±a, ±b, ±(a + b) (2F + 2τ >= 0 holds when it holds for one of the three,
        # and for |z| when it holds for z or -z), with no absolute value and no maximum; the
        # sums with a + b are written out, so that synthesis adds their three terms with one
        # carry chain.
        def at_most_zero(value):
            return value[-1] | ~value.any()

        # The third stage: the sums registered, then their signs and zero tests (the kinds
        # and the flags carried along a clock).
        m.d.comb += twice.eq(Mux(cmp.entry, cmp.w, cmp.v) << 1)
        kinds_late = Signal(2)
        falls_late = Signal()
        special_late = Signal()
        m.d.sync += [kinds_late.eq(kinds), falls_late.eq(falls), special_late.eq(special)]
        tests = []
        for plus_value, minus_value, kind in (
                (twice + kind_a, twice - kind_a, kinds_late[0]),
                (twice + kind_b, twice - kind_b, kinds_late[1]),
                (twice + kind_a + kind_b, twice - kind_a - kind_b, 1)):
            plus = Signal(signed(f.value + 3))
            minus = Signal(signed(f.value + 3))
            m.d.sync += [plus.eq(plus_value), minus.eq(minus_value)]
            # h: -2F ± z >= 0, i.e. 2F ∓ z <= 0. Read from the sign and a zero test, not by
            # a comparator (a second carry chain).
            tests.append(kind & Mux(falls_late, at_most_zero(minus) | at_most_zero(plus),
                                    ~plus[-1] | ~minus[-1]))
        m.d.comb += n.at_point_next.eq(tests[0] | tests[1] | tests[2] | special_late)

        # The arc core: a run from the position, on the circle N (residue = -S), stopped by
        # this comparator.
        core, arc_state = n.core, n.arc_state
        # The run's operands registered from the slot of the clock before: a run is handed
        # over only while block 11's test is fresh, i.e. when that clock changed nothing of the
        # traced slot, so they are this clock's.
        core_native_x = Signal.like(core.cmd.payload.x)
        core_native_y = Signal.like(core.cmd.payload.y)
        core_residue = Signal.like(core.cmd.payload.residue)
        m.d.sync += [
            core_native_x.eq(Mux(_x_falls(quadrant, own.cw), _abs(own_u), _abs(own_v))),
            core_native_y.eq(Mux(_x_falls(quadrant, own.cw), _abs(own_v), _abs(own_u))),
            core_residue.eq(-own.v),
        ]
        m.d.comb += [
            core.cmd.valid.eq(n.arc_go & (arc_state == 0)),
            core.cmd.payload.x.eq(core_native_x),
            core.cmd.payload.y.eq(core_native_y),
            core.cmd.payload.residue.eq(core_residue),
            core.stop.eq(0),
            core.abort.eq(self.abort | (own.arc & n.end_now)),
        ]
        n.own_u, n.own_v, n.quadrant = own_u, own_v, quadrant
        n.x_negative, n.y_negative = x_negative, y_negative

    def _element_ends(self, m, n):
        """The contour's elements: ends and block 2's shifts."""
        element_end = Signal()
        terminal_end = Signal()
        shift_own = Signal()
        shift_cmp = Signal()
        m.d.comb += [
            element_end.eq(n.end_now),
            terminal_end.eq(n.own.valid & n.own.last & ~n.hold & ~self.abort),
            shift_own.eq(element_end | terminal_end | ~n.own.valid),
            shift_cmp.eq(shift_own | ~n.cmp.valid),
        ]
        n.element_end, n.terminal_end = element_end, terminal_end
        n.shift_own, n.shift_cmp = shift_own, shift_cmp

    def _arc_runs(self, m, n):
        """The arc runs' state: a run handed to the core in WAIT, taken in TAKE, run to its
        axis or aborted by block 11."""
        own, core, quadrant = n.own, n.core, n.quadrant
        x_negative, y_negative, arc_state = n.x_negative, n.y_negative, n.arc_state
        with m.If(self.abort):
            m.d.sync += arc_state.eq(0)
        with m.Elif(n.element_end):
            m.d.sync += arc_state.eq(0)
        with m.Elif((arc_state == 0) & core.cmd.valid):
            x_falls = _x_falls(quadrant, own.cw)
            m.d.sync += [
                arc_state.eq(1),
                n.run_swap.eq(~x_falls),
                n.run_dir.eq(Cat(Mux(x_falls, ~x_negative, x_negative),
                                 Mux(x_falls, y_negative, ~y_negative))),
            ]
        with m.Elif(arc_state == 1):
            m.d.sync += arc_state.eq(2)
        with m.Elif((arc_state == 2) & core.done):
            m.d.sync += arc_state.eq(0)

    def _block1_frames(self, m, n):
        """Block 1: frames in: checked, taken or refused, an element decoded into a slot."""
        frame, own, cmp, prep, status = n.frame, n.own, n.cmp, n.prep, n.status
        kind = frame.kind
        is_element = (kind == Kind.LINE) | (kind == Kind.ARC)
        bad = Signal()
        m.d.comb += bad.eq((kind > Kind.CLOSE) | (is_element & ~n.contour)
                           | ((kind == Kind.RADIUS) & (frame.x < 0)))
        unit = Signal(3)                     # blocks 5-8: 0 idle, 1 launch, 2 round 1,
        #                                      3 launch 2, 4 round 2, 5 radius
        unit_entry = Signal()
        unit_last_round = Signal()
        pending = Signal(_frame(n.f))        # the frame being formed
        engine_idle = Signal()
        m.d.comb += engine_idle.eq(~own.valid & ~cmp.valid & ~prep.valid & (unit == 0)
                                   & ~n.homing & ~n.contour)
        accepting = ~self.abort & ~status.flushing
        take_element = Signal()
        take_control = Signal()
        refuse = Signal()
        m.d.comb += [
            take_element.eq(accepting & n.contour & is_element & ~prep.valid
                            & ((unit == 0) | unit_last_round)),
            take_control.eq(accepting & ~is_element & ~bad & engine_idle & status.idle),
            refuse.eq(self.cmd.valid & accepting & bad & engine_idle & status.idle),
            self.cmd.ready.eq(Mux(bad, refuse, Mux(is_element, take_element, take_control))),
        ]
        accept = self.cmd.valid & self.cmd.ready
        # A control frame taken (RADIUS, START, CLOSE: its end is then formed without the
        # elements' shifts, which only an element's taking waits for).
        taken = self.cmd.valid & take_control
        new = Signal(n.slot)
        m.d.comb += [
            new.valid.eq(1), new.computing.eq(1), new.last.eq(frame.last),
            new.arc.eq(kind == Kind.ARC), new.h.eq(frame.h), new.entry.eq(frame.entry),
            new.swap.eq(frame.swap), new.minor.eq(frame.minor), new.back.eq(frame.sec < 0),
            new.k.eq(frame.k), new.cw.eq(frame.cw),
            # The position less the centre (before this clock's step, which it follows a
            # clock late as every slot).
            new.cu.eq(n.x - frame.x),
            new.cv.eq(n.y - frame.y),
            new.zu.eq(n.x == frame.x),
            new.zv.eq(n.y == frame.y),
            new.eswap.eq(frame.eswap), new.eminor.eq(frame.eminor), new.ek.eq(frame.ek),
        ]
        n.kind, n.unit, n.unit_entry, n.unit_last_round, n.pending = (
            kind, unit, unit_entry, unit_last_round, pending)
        n.take_element, n.refuse, n.accept, n.taken, n.new = (take_element, refuse, accept,
                                                             taken, new)

    def _blocks5_8_functions(self, m, n):
        """Blocks 5, 6, 7, 8: a frame's functions at the position it entered the memory (and
        r² when the radius is set)."""
        f, frame, pending, unit, kind = n.f, n.frame, n.pending, n.unit, n.kind
        one, half, fr = n.one, n.half, f.fraction
        b5x, b5y, b6 = self.block5x, self.block5y, self.block6
        x, y, radius = n.x, n.y, n.radius
        p0x = Signal(signed(f.width + 2))
        p0y = Signal(signed(f.width + 2))
        launching = (unit == 1) | (unit == 3)
        base_x = Mux(unit == 1, x, p0x)
        base_y = Mux(unit == 1, y, p0y)
        second = (unit == 3) | (unit == 4)
        u0 = _abs_difference(base_x, pending.x)
        v0 = _abs_difference(base_y, pending.y)
        circle = (pending.kind == Kind.ARC) & ~second
        lswap = Mux(second, pending.eswap, pending.swap)
        lk = Mux(second, pending.ek, pending.k)
        # The magnitudes of the coefficients, taken with the frame (no negation between the
        # frame being formed and the multipliers' operands); g: ±1/cos α by the side (none
        # with no offset), or the entry line's shift.
        magnitude = Signal(data.StructLayout({
            "k": f.coefficient, "ek": f.coefficient, "sec": f.coefficient, "eg": f.intercept}))
        lk_magnitude = Mux(second, magnitude.ek, magnitude.k)
        lg_magnitude = Mux(second, magnitude.eg, Mux(pending.side == 0, 0, magnitude.sec))
        lg_negative = Mux(second, pending.eg[-1], pending.side[-1] ^ pending.sec[-1])
        # The multipliers start a clock after the launch, from their operands registered (the
        # differences and magnitudes are off the multipliers' loading).
        m.d.comb += [b5x.clear.eq(self.abort), b5y.clear.eq(self.abort),
                     b6.clear.eq(self.abort)]
        m.d.sync += [
            b5x.start.eq(launching & ~self.abort),
            b5y.start.eq(launching & ~self.abort),
            b6.start.eq((launching | ((unit == 0) & n.taken & (kind == Kind.RADIUS)))
                        & ~self.abort),
            b5x.a.eq(Mux(circle, u0, Mux(~lswap, lk_magnitude, 0))),
            b5x.b.eq(Mux(circle, u0, _abs(base_x))),
            b5y.a.eq(Mux(circle, v0, Mux(lswap, lk_magnitude, 0))),
            b5y.b.eq(Mux(circle, v0, _abs(base_y))),
            b6.a.eq(Mux(unit == 0, frame.x, Mux(circle, pending.g, lg_magnitude))),
            b6.b.eq(Mux(unit == 0, frame.x, radius)),
        ]
        # Block 7 (E + G·r) and block 8 (+ C·x00 + D·y00): the function at the position, in
        # two registered stages after the products are done (they are held after it): first
        # every term signed by a complement and a carry (and G·r rounded), then each sum with
        # one carry chain (modulo 2**value, as the function is kept); added into the slot in
        # the clock after that.
        def term(value, negative):
            ext = Signal(signed(f.value))
            operand = Signal(signed(f.value))
            m.d.comb += ext.eq(value)
            m.d.sync += operand.eq(Mux(negative, ~ext, ext))
            return operand, negative

        lb = Mux(second, pending.eb, pending.b)
        lminor = Mux(second, pending.eminor, pending.minor)
        # line (x, y): k·x00 + b - y00·one + g·r; (y, x): k·y00 + b - x00·one - g·r; negated
        # when the minor coordinate falls.
        line_terms = [
            term(Mux(lswap, b5y.product, b5x.product),
                 Mux(lswap, lk[-1] ^ base_y[-1], lk[-1] ^ base_x[-1]) ^ lminor),
            term(lb, lminor),
            term(Mux(lswap, base_x, base_y) * one, ~lminor),
            term(b6.product, lg_negative ^ lswap ^ lminor),
        ]
        sigma_out = (pending.side == 1) == pending.cw
        rounded = Signal(unsigned(f.value))
        m.d.sync += rounded.eq((b6.product + half) >> fr)
        # N = E + r² ± G·r (rounded); S = x00² + y00² - N.
        n_value = Signal(signed(f.value))
        m.d.comb += n_value.eq(pending.e + n.radius2 + Mux(sigma_out, rounded, ~rounded)
                               + ~sigma_out)
        circle_value = Signal(signed(f.value))
        # The terms' carries (one for each complemented term) as one number, registered with
        # them: one narrow operand of the sum, not four.
        line_carries = Signal(3)
        m.d.sync += line_carries.eq(sum(negative for _, negative in line_terms))
        m.d.comb += circle_value.eq(b5x.product + b5y.product - pending.e - n.radius2
                                    + Mux(sigma_out, ~rounded, rounded) + sigma_out)
        # The function formed (the circle's in round 1 of an arc, else the line's) and the
        # rounds' ends registered, so that a slot adds it with no decision before the sum.
        value = Signal(signed(f.value))
        circle_empty = Signal()
        terms_done = Signal()
        combine1 = Signal()
        combine2 = Signal()
        m.d.sync += [
            value.eq(Mux(circle, circle_value, sum(t for t, _ in line_terms) + line_carries)),
            circle_empty.eq(n_value <= 0),
            terms_done.eq(b6.done & ~self.abort),
            combine1.eq((unit == 2) & terms_done & ~self.abort),
            combine2.eq((unit == 4) & terms_done & ~self.abort),
        ]
        m.d.comb += [
            n.unit_entry.eq(pending.entry),
            n.unit_last_round.eq((combine1 & ~pending.entry) | combine2),
        ]
        with m.If(self.abort):
            m.d.sync += unit.eq(0)
        with m.Elif(unit == 0):
            with m.If(n.taken & (kind == Kind.RADIUS)):
                m.d.sync += [unit.eq(5), radius.eq(frame.x)]
        with m.Elif(unit == 1):
            m.d.sync += [unit.eq(2), p0x.eq(x), p0y.eq(y)]
        with m.Elif(combine1):
            m.d.sync += unit.eq(Mux(pending.entry, 3, 0))
        with m.Elif(unit == 3):
            m.d.sync += unit.eq(4)
        with m.Elif(combine2):
            m.d.sync += unit.eq(0)
        with m.Elif((unit == 5) & b6.done):
            m.d.sync += [unit.eq(0), n.radius2.eq(b6.product)]
        with m.If(n.take_element & self.cmd.valid & ~self.abort):
            m.d.sync += [pending.eq(frame), unit.eq(1),
                         magnitude.k.eq(_abs(frame.k)), magnitude.ek.eq(_abs(frame.ek)),
                         magnitude.sec.eq(_abs(frame.sec)), magnitude.eg.eq(_abs(frame.eg))]
        n.value, n.circle_empty = value, circle_empty
        n.combine1, n.combine2 = combine1, combine2

    def _block2_memory(self, m, n):
        """Block 2's next contents: every slot stepped, its functions added when formed, the
        slots shifted at an element's end, a new frame taken into the last."""
        own, cmp, prep, slots, pending = n.own, n.cmp, n.prep, n.slots, n.pending

        def advanced(i):
            """Slot ``i`` after this clock: stepped, and its functions added when formed (each
            function one sum of its terms, so one carry chain)."""
            s = slots[i]
            out = Signal(n.slot, name=f"advanced{i}")
            _, _, (du, dv) = n.terms[i]
            formed_v = Mux(s.computing & n.combine1, n.value, 0)
            formed_w = Mux(s.computing & n.combine2, n.value, 0)
            m.d.comb += [
                out.eq(s),
                out.v.eq(s.v + n.tv[i] + formed_v),
                out.w.eq(s.w + n.tw[i] + formed_w),
                out.cu.eq(s.cu + du),
                out.cv.eq(s.cv + dv),
                out.zu.eq(_zero_after(s.cu, n.late[0], n.late[2])),
                out.zv.eq(_zero_after(s.cv, n.late[1], n.late[3])),
            ]
            with m.If(s.computing & n.combine1):
                with m.If(s.arc):
                    m.d.comb += out.empty.eq(n.circle_empty)
                with m.If(~pending.entry):
                    m.d.comb += [out.computing.eq(0), out.ready.eq(1)]
            with m.If(s.computing & n.combine2):
                m.d.comb += [out.computing.eq(0), out.ready.eq(1)]
            return out

        moved = [advanced(i) for i in range(3)]
        # Each slot's step terms (blocks 4 and 10) are registered and added into its functions
        # a clock after, so the functions follow the position two clocks late. They stay with
        # the slot's place, not its contents: a shift comes only in a clock with no step of the
        # clock before (an element ends at the point only while its test is fresh; a terminal,
        # an empty slot make no step), so the terms of every slot that moves are then zero, and
        # the registers are cleared (as they are for an empty last slot, which a frame may
        # enter).
        for i, clear in enumerate((n.shift_own, n.shift_cmp, n.shift_cmp | ~prep.valid)):
            (v1, v2, v_carry), (w1, w2, w_carry), _ = n.terms[i]
            with m.If(clear):
                m.d.sync += [n.tv[i].eq(0), n.tw[i].eq(0)]
            with m.Else():
                m.d.sync += [n.tv[i].eq(v1 + v2 + v_carry), n.tw[i].eq(w1 + w2 + w_carry)]
        # Block 11's registered test is of this state when the SETTLE clocks before changed
        # neither the position nor the traced and compared slots (the functions formed into
        # the slot after them change neither).
        formed_here = ((own.valid & own.computing) | (cmp.valid & cmp.computing)) & (
            n.combine1 | n.combine2)
        quiet = Signal(SETTLE)               # of the clocks before, the last first
        quiet_now = ~n.step_x & ~n.step_y & ~n.shift_cmp & ~formed_here & ~self.abort
        m.d.sync += quiet.eq(Cat(quiet_now, quiet[:-1]))
        m.d.comb += n.fresh_next.eq(quiet_now & quiet[:-1].all())
        m.d.sync += n.taken_late.eq(~prep.valid & n.take_element & self.cmd.valid
                                    & ~self.abort)
        m.d.sync += [
            own.eq(Mux(n.shift_own, moved[1], moved[0])),
            cmp.eq(Mux(n.shift_cmp, moved[2], moved[1])),
        ]
        # A frame is taken into the last slot when it is empty (not in the clock it empties:
        # the decision to take does not wait for the element's end). An empty slot loads the
        # frame on the input whether it is taken or not (a slot is read only while valid), so
        # the decision sets only its valid flag: the handshake and the abort stay off the
        # slots' contents.
        with m.If(~prep.valid):
            m.d.sync += [prep.eq(n.new), prep.valid.eq(n.take_element & self.cmd.valid)]
        with m.Elif(n.shift_cmp):
            m.d.sync += prep.valid.eq(0)
        with m.Else():
            m.d.sync += prep.eq(moved[2])
        with m.If(self.abort):
            m.d.sync += [own.valid.eq(0), cmp.valid.eq(0), prep.valid.eq(0)]

    def _control_frames(self, m, n):
        """Control frames: the radius's end, the start, the return (``CLOSE``)."""
        frame, kind, taken = n.frame, n.kind, n.taken
        start_now = taken & (kind == Kind.START)
        close_now = taken & (kind == Kind.CLOSE)
        close_end = Signal()
        # A step of the return is towards the start on every axis it is away on, so it ends
        # there when the start is within a step on each.
        m.d.comb += close_end.eq((close_now & ~n.home_dx & ~n.home_dy)
                                 | (n.home_step & n.home_near))
        with m.If(self.abort):
            m.d.sync += [n.contour.eq(0), n.homing.eq(0)]
        with m.Else():
            with m.If(start_now):
                m.d.sync += n.contour.eq(1)     # (the return counts from the start: home_ux)
            with m.If(n.take_element & self.cmd.valid & frame.last):
                m.d.sync += n.contour.eq(0)
            with m.If(close_now & ~close_end):
                m.d.sync += n.homing.eq(1)
            with m.If(close_end):
                m.d.sync += n.homing.eq(0)
        n.radius_end = (n.unit == 5) & self.block6.done
        n.start_now, n.close_end = start_now, close_end

    def _blocks12_13_position(self, m, n):
        """Blocks 12, 13: the position counters, loaded by ``START``, counting every step."""
        step_x, step_y, neg_x, neg_y = n.step_x, n.step_y, n.neg_x, n.neg_y
        block12, block13 = self.block12, self.block13
        with m.If(n.start_now):              # the position and the start alike
            m.d.sync += [n.home_ux.eq(0), n.home_uy.eq(0), n.home_dx.eq(0), n.home_dy.eq(0),
                         n.near_x.eq(1), n.near_y.eq(1)]
        with m.Else():
            m.d.sync += [n.home_ux.eq(n.home_ux + step_delta(step_x, neg_x)),
                         n.home_uy.eq(n.home_uy + step_delta(step_y, neg_y)),
                         n.home_dx.eq(~_zero_after(n.home_ux, step_x, neg_x)),
                         n.home_dy.eq(~_zero_after(n.home_uy, step_y, neg_y)),
                         n.near_x.eq(_near_after(n.home_ux, step_x, neg_x)),
                         n.near_y.eq(_near_after(n.home_uy, step_y, neg_y))]
        m.d.comb += [
            block12.d.eq(n.frame.x), block12.load.eq(n.start_now),
            block12.up.eq(step_x & ~neg_x), block12.down.eq(step_x & neg_x),
            block13.d.eq(n.frame.y), block13.load.eq(n.start_now),
            block13.up.eq(step_y & ~neg_y), block13.down.eq(step_y & neg_y),
        ]

    def _blocks14_15_outputs(self, m, n):
        """Blocks 14 and 15: the step permission (the feed interface); motion; outcomes."""
        core, status = n.core, n.status
        step_x, step_y, neg_x, neg_y = n.step_x, n.step_y, n.neg_x, n.neg_y
        line_due, home_due = n.line_due, n.home_due
        arc_due = core.feed.due & n.arc_go
        due = Signal()
        m.d.comb += [
            due.eq(line_due | arc_due | home_due),
            self.feed.due.eq(due),
            self.feed.diagonal.eq(due & Mux(line_due, n.line_major & n.line_minor,
                                            Mux(home_due, n.home_dx & n.home_dy,
                                                core.feed.diagonal))),
            self.motion.step.eq(Cat(step_x, step_y)),
            self.motion.dir.eq(Cat(step_x & neg_x, step_y & neg_y)),

            status.motion.step.eq(Cat(step_x, step_y)),
            status.motion.dir.eq(Cat(neg_x, neg_y)),
            status.accept.eq(n.accept),
            status.end.eq(n.element_end | n.terminal_end | n.start_now | n.close_end
                          | n.radius_end | n.refuse),
            status.outcome.eq(Mux(n.refuse, Outcome.REFUSED, Outcome.DONE)),
            status.flush.eq(self.abort),
            self.busy.eq(status.busy),
        ]
        wiring.connect(m, wiring.flipped(self.status), status.status)
