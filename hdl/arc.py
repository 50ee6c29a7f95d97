"""Any arc from a quadrant core: the core signature, the planner, and the engine around them."""

from types import SimpleNamespace

from amaranth import *
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from .elements._checks import check_width
from .engine import EngineSignature, FeedSignature, Outcome, StatusUnit, frame_coord_width

__all__ = ["ArcCoreSignature", "ArcPlanner", "ArcEngine"]


class ArcCoreSignature(wiring.Signature):
    """What a quadrant core offers the arc engine: native quadrant runs in, native steps out.

    The native quadrant is SU 1665343's: X falls, Y rises, from a start with ``X >= 1`` until
    ``X = 0``. A run is given by its start ``(x, y)`` and ``residue = r2 - x² - y²``, where
    ``r2`` is the square of the circle's radius (zero for a start on its own circle). The core
    holds one run prepared while another runs, so that quadrants follow one another with no
    idle clock.

    Parameters
    ----------
    width : :class:`int`
        Register width: coordinates up to ``2**width - 1``.

    Members
    -------
    cmd : :py:`In(stream.Signature(ArcCoreSignature.Run(width)))`
        Quadrant runs. A run transferred in clock ``k`` may start in clock ``k + 1``.
    feed : :py:`Out(FeedSignature())`
        Permission for each step (:class:`~kontur.hdl.engine.FeedSignature`).
    stop : :py:`In(1)`
        End the running run at the end of this clock (its step of this clock is made): the
        arc's end point is reached.
    abort : :py:`In(1)`
        No step in this clock; the running run ends (:py:`done`) and the prepared one is
        dropped.
    step : :py:`Out(2)`
        Native steps: bit 0 X falls by one, bit 1 Y rises by one; both for a diagonal.
    start : :py:`Out(1)`
        The prepared run starts in this clock (its steps from the next clock).
    done : :py:`Out(1)`
        The running run ends in this clock.
    busy : :py:`Out(1)`
        A run is prepared or running.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2.
    """

    @staticmethod
    def Run(width):
        return data.StructLayout({"x": unsigned(width), "y": unsigned(width),
                                  "residue": signed(width + 1)})

    def __init__(self, width):
        check_width("Register width", width, minimum=2)
        self._width = width
        super().__init__({
            "cmd":   In(stream.Signature(self.Run(width))),
            "feed":  Out(FeedSignature()),
            "stop":  In(1),
            "abort": In(1),
            "step":  Out(2),
            "start": Out(1),
            "done":  Out(1),
            "busy":  Out(1),
        })

    @property
    def width(self):
        return self._width

    def __eq__(self, other):
        return type(other) is type(self) and other.width == self.width

    def __hash__(self):
        return hash((type(self), self._width))

    def __repr__(self):
        return f"ArcCoreSignature({self._width})"


def _arc_frame(coord_width):
    return data.StructLayout({"x0": signed(coord_width), "y0": signed(coord_width),
                              "x1": signed(coord_width), "y1": signed(coord_width),
                              "cw": 1})


def _quadrant_of_signs(positive_x, negative_x, positive_y, negative_y, clockwise):
    """Quadrant 0-3 of a point from its coordinates' signs; an axis point belongs to the
    quadrant the motion enters."""
    px, nx, py, ny = positive_x, negative_x, positive_y, negative_y
    ccw = Mux(px & ~ny, 0, Mux(~px & py, 1, Mux(nx & ~py, 2, 3)))
    cwq = Mux(~nx & py, 0, Mux(nx & ~ny, 1, Mux(~px & ny, 2, 3)))
    return Mux(clockwise, cwq, ccw)


def _quadrant(x, y, clockwise):
    """Quadrant 0-3 of a point; an axis point belongs to the quadrant the motion enters."""
    return _quadrant_of_signs(x > 0, x < 0, y > 0, y < 0, clockwise)


def _x_falls(quadrant, clockwise):
    """Whether |x| falls in ``quadrant`` (native X = |x|): even quadrants counter-clockwise."""
    return ~quadrant[0] ^ clockwise


def _swapped(quadrant, clockwise):
    """Whether ``quadrant`` is run with X and Y swapped (native X = |y|), where |x| rises."""
    return quadrant[0] ^ clockwise


class _Coordinate:
    """What the planner reads off a frame coordinate as it takes the arc: its sign, whether it
    is zero or positive, and whether its magnitude is too wide for ``width`` bits. (Too wide a
    coordinate refuses the arc, so the other flags may then be anything.)"""

    def __init__(self, value, width):
        self.value = value
        self.sign = value[-1]
        low_zero = value[:width] == 0
        self.zero = low_zero & ~self.sign
        self.positive = ~low_zero & ~self.sign
        high = value[width:]
        # In range: the high bits all equal the sign, and -2**width (all ones over zeros) is
        # one too far.
        self.over = ~((high == 0) | high.all()) | (self.sign & low_zero)


class ArcPlanner(wiring.Component):
    """Check an arc and plan its quadrant runs, with serial arithmetic; hold one plan.

    Takes an arc on :py:`i` (the frame of :class:`ArcEngine`) while it holds no plan. It forms
    ``r2 = x0² + y0²`` and then ``S = x1² + y1²`` (``width`` clocks each, one multiplier bit a
    clock), checks the end point (one clock), takes the rounded square root of ``r2`` with its
    remainder (``width + 1`` clocks), and forms the plan (one clock): it is offered on :py:`o`
    ``3·width + 4`` clocks after the arc was taken, and held there until it is transferred.
    The radius and the residue stay after the transfer while :py:`keep` is set (the engine still
    hands the arc's later quadrant runs to its core); the next plan waits for them in its last
    clock.

    One serial datapath: the frame's coordinates are taken as they are, in two's complement;
    each pass shifts the multiplier bits of two of them out at the bottom of their registers,
    turns them into the bits of their magnitudes on the way (a negation a bit at a time) and
    shifts those in at the top, each into the register of its native coordinate (X and Y
    swapped where |x| rises, see :class:`ArcEngine`), so that after the passes the registers
    hold the native start and end. The multiplicands are the two coordinates of the pass,
    negated in the adder where negative. The bits of the end point's check and of the order of
    start and end within a quadrant are formed a bit at a time during the second pass (the low
    half of ``r2 - S`` as ``S``'s bits leave the adder); only the high halves of ``r2`` and
    ``S`` meet in one subtraction.

    A plan is refused (:py:`refused` set; nothing else in it counts) for a coordinate magnitude
    above ``2**width - 1``, a start point at the centre (R = 0), a radius that rounds above
    ``2**width - 1``, or an end point not on the start point's circle. An end point is on the
    circle when it is a point of the interpolated path, i.e. within half a step of the circle
    along its larger coordinate ``M``: ``-M < x0² + y0² - x1² - y1² <= M``.

    Parameters
    ----------
    width : :class:`int`
        Register width of the core.
    coord_width : :class:`int`
        Width of the signed coordinates of a frame.

    Members
    -------
    i : :py:`In(stream.Signature(ArcEngine.Frame(coord_width)))`
        Arcs.
    o : :py:`Out(stream.Signature(ArcPlanner.Plan(width)))`
        Their plans, in order.
    keep : :py:`In(1)`
        The plan transferred last is still in use: keep its radius and residue.

    Raises
    ------
    :exc:`TypeError`
        If a width is not an integer of at least 2.
    :exc:`ValueError`
        If ``coord_width`` is smaller than ``width + 1``.
    """

    @staticmethod
    def Plan(width):
        """The plan of an arc: its quadrant runs (see :class:`ArcEngine`)."""
        point = data.StructLayout({"x": unsigned(width), "y": unsigned(width)})
        return data.StructLayout({
            "refused":  1,                    # the arc is refused; nothing else counts
            "cw":       1,                    # clockwise
            "quadrant": 2,                    # quadrant of the first run (0-3: I-IV)
            "runs":     3,                    # number of quadrant runs, 1 to 5
            "start":    point,                # native start of the first run
            "off_axis": 1,                    # the arc ends off the axis (native end Y > 0)
            "distance": unsigned(width + 1),  # steps along X and Y from the last run's start
                                              # to the end (X - end X + end Y - Y); valid from
                                              # the clock after the plan is first offered
            "radius":   unsigned(width),      # Rn = round(sqrt(r2)): later runs start at (Rn, 0)
            "residue":  signed(width + 1),    # r2 - Rn²
        })

    def __init__(self, *, width=24, coord_width=None):
        check_width("Register width", width, minimum=2)
        self._width = width
        self._coord_width = frame_coord_width(width, coord_width)
        super().__init__({
            "i":    In(stream.Signature(_arc_frame(self._coord_width))),
            "o":    Out(stream.Signature(self.Plan(width))),
            "keep": In(1),
        })

    @property
    def width(self):
        return self._width

    @property
    def coord_width(self):
        return self._coord_width

    def elaborate(self, platform):
        m = Module()
        n = self._plan_registers(m)
        self._serial_datapath(m, n)
        self._serial_check(n)
        with m.FSM(name="planner"):
            self._take_arc(m, n)
            self._squares(m, n)
            self._end_check(m, n)
            self._square_root(m, n)
            self._plan_offer(m, n)
        return m

    # The helpers below each elaborate one part of the serial datapath into ``m`` (the FSM's
    # states in the order of its phases); ``n`` (a namespace) carries the signals that one part
    # drives and another reads, under the names the parts give them.

    def _plan_registers(self, m):
        """The plan's registers (which the engine reads) and what the frame tells at once."""
        w = self._width
        frame = self.i.payload
        x0, y0, x1, y1 = (_Coordinate(v, w) for v in (frame.x0, frame.y0, frame.x1, frame.y1))
        n = SimpleNamespace(w=w, frame=frame, x0=x0, y0=y0, x1=x1, y1=y1)

        # ---- the plan (registers the engine reads) -----------------------------------------
        cw = Signal()
        start_quadrant = Signal(2)
        end_quadrant = Signal(2)
        start_x, start_y = Signal(w), Signal(w)      # the start's coordinates, then native |.|
        # The end's coordinates; after the second pass the bits of F = start X - start Y and
        # E = end Y - end X; then the plan's distance, F + E from the start if the last run is
        # the first, else Rn + E from the axis point.
        end_x, end_y = Signal(w + 1), Signal(w)
        refused = Signal()
        runs = Signal(3)
        end_on_axis = Signal()                       # native end Y = 0
        radius = Signal(w)
        residue = Signal(signed(w + 1))
        m.d.comb += [
            self.o.payload.refused.eq(refused), self.o.payload.cw.eq(cw),
            self.o.payload.quadrant.eq(start_quadrant), self.o.payload.runs.eq(runs),
            self.o.payload.start.x.eq(start_x), self.o.payload.start.y.eq(start_y),
            self.o.payload.off_axis.eq(~end_on_axis), self.o.payload.distance.eq(end_x),
            self.o.payload.radius.eq(radius), self.o.payload.residue.eq(residue),
        ]
        n.cw, n.start_quadrant, n.end_quadrant = cw, start_quadrant, end_quadrant
        n.start_x, n.start_y, n.end_x, n.end_y = start_x, start_y, end_x, end_y
        n.refused, n.runs, n.end_on_axis, n.radius, n.residue = \
            refused, runs, end_on_axis, radius, residue

        # ---- what the frame tells at once --------------------------------------------------
        start_swapped = Signal()                     # native X = |y0|
        end_swapped = Signal()                       # native X = |y1|
        end_signs = Signal(2)                        # of x1, y1
        too_wide = Signal()
        zero_radius = Signal()
        n.start_swapped, n.end_swapped, n.end_signs = start_swapped, end_swapped, end_signs
        n.too_wide, n.zero_radius = too_wide, zero_radius
        return n

    def _serial_datapath(self, m, n):
        """The serial datapath: the multiplier bits, the magnitudes' bits they make, and the
        shift-and-add sum of the squares."""
        w = n.w
        second = Signal()                            # 0: x0² + y0², 1: x1² + y1²
        count = Signal(range(w + 1))
        mult_x = Signal(signed(w + 1))               # multiplicands: x0, y0, then x1, y1
        mult_y = Signal(signed(w + 1))
        seen_x = Signal()                            # a one has left (the negation's state)
        seen_y = Signal()
        upper = Signal(w + 1)                        # the sum's high half; then the root
        lower = Signal(w)                            # r2's low half
        r2_high = Signal(w + 2)                      # r2's high half
        remainder = Signal(w + 3)                    # r2 - root²
        n.second, n.count, n.mult_x, n.mult_y, n.seen_x, n.seen_y = \
            second, count, mult_x, mult_y, seen_x, seen_y
        n.upper, n.lower, n.r2_high, n.remainder = upper, lower, r2_high, remainder

        # The multiplier bits of this pass, and the magnitudes' bits they make: -v keeps the
        # bits of v up to its lowest one and inverts the rest. Each is formed a clock ahead, in
        # a flip-flop, from the bit that comes next (so that the adder starts from registers).
        start_x, start_y, end_x, end_y = n.start_x, n.start_y, n.end_x, n.end_y
        out_x = Mux(second, end_x[0], start_x[0])
        out_y = Mux(second, end_y[0], start_y[0])
        bit_x, bit_y = Signal(), Signal()
        next_x = Mux(second, end_x[1], start_x[1])
        next_y = Mux(second, end_y[1], start_y[1])
        seen_after_x = seen_x | out_x                # the negation's state after this bit
        seen_after_y = seen_y | out_y
        m.d.sync += [bit_x.eq(next_x ^ (mult_x[-1] & seen_after_x)),
                     bit_y.eq(next_y ^ (mult_y[-1] & seen_after_y))]
        swapped = Mux(second, n.end_swapped, n.start_swapped)
        native_x = Mux(swapped, bit_y, bit_x)        # the bits entering the native registers
        native_y = Mux(swapped, bit_x, bit_y)
        n.bit_x, n.bit_y, n.seen_after_x, n.seen_after_y = bit_x, bit_y, seen_after_x, seen_after_y
        n.native_x, n.native_y = native_x, native_y

        # Each clock adds the magnitudes whose multiplier bit is set, |v| = (v ^ s) + s, to
        # the upper half and shifts the whole sum down one place; after `w` clocks it holds
        # the sum of the two squares.
        def operand(bit, v):
            return Mux(bit, v[:w] ^ v[-1].replicate(w), 0)
        partial = Signal(w + 2)
        m.d.comb += partial.eq(upper + operand(bit_x, mult_x) + operand(bit_y, mult_y)
                               + (bit_x & mult_x[-1]) + (bit_y & mult_y[-1]))
        n.partial = partial

    def _serial_check(self, n):
        """The registers of the end point's check, of the order of start and end in one
        quadrant and of the distance's differences, formed a bit at a time in the second pass."""
        upper, lower, partial = n.upper, n.lower, n.partial
        # The end point's check, -M < D <= M for D = r2 - S (M = max(x1, y1)), split at bit w:
        # with r2 = R·2**w + r and S = T·2**w + t (r, t < 2**w) and H = R - T, D + M > 0 is
        # H + qa >= 0 for qa = (r - t + M - 1) // 2**w, and M - D >= 0 is H <= qb for
        # qb = (t - r + M) // 2**w, both qa and qb in {-1, 0, 1}. The low halves go a bit at a
        # time as S's bits leave the adder and r2's low half turns in `lower`: r + ~t + M and
        # t + ~r + M + 1 are serial sums whose carries out (0 to 2) are qa + 1 and qb + 1,
        # for either coordinate as M. Only H is formed in parallel, and it passes only as -1
        # (carry above 2), 0 (neither carry 0) or 1 (carry below 2).
        r_bit, t_bit = lower[0], partial[0]
        above = Array(Signal(2, name=f"above_{a}") for a in "xy")   # carries of r + ~t + M
        below = Array(Signal(2, name=f"below_{a}") for a in "xy")   # of t + ~r + M + 1
        x_longer = Signal()                          # |x1| >= |y1|: M is |x1|
        # Start and end in one quadrant: whether the end is ahead, native end Y > start Y, or
        # equal and end X < start X (the start's bits turn in their registers beside).
        y_above, y_equal, x_below = Signal(), Signal(), Signal()
        # The differences of the distance, a bit at a time: E = ey - ex as ey + ~ex + 1, F =
        # sx - sy as sx + ~sy + 1 (each negative where its carry out is 0).
        e_carry = Signal()
        f_carry = Signal()

        on_circle = Signal()
        n.r_bit, n.t_bit, n.above, n.below, n.x_longer = r_bit, t_bit, above, below, x_longer
        n.y_above, n.y_equal, n.x_below, n.e_carry, n.f_carry, n.on_circle = \
            y_above, y_equal, x_below, e_carry, f_carry, on_circle

    def _take_arc(self, m, n):
        """Idle: take an arc, load its coordinates and flags, start the first pass."""
        w, frame, x0, y0, x1, y1 = n.w, n.frame, n.x0, n.y0, n.x1, n.y1
        with m.State("Idle"):
            m.d.comb += self.i.ready.eq(1)
            with m.If(self.i.valid):
                q0 = _quadrant_of_signs(x0.positive, x0.sign, y0.positive, y0.sign,
                                        frame.cw)
                q1 = _quadrant_of_signs(x1.positive, x1.sign, y1.positive, y1.sign,
                                        frame.cw)
                swapped_1 = _swapped(q1, frame.cw)
                m.d.sync += [
                    n.cw.eq(frame.cw), n.start_quadrant.eq(q0), n.end_quadrant.eq(q1),
                    n.start_swapped.eq(_swapped(q0, frame.cw)), n.end_swapped.eq(swapped_1),
                    n.end_on_axis.eq(Mux(swapped_1, x1.zero, y1.zero)),
                    n.end_signs.eq(Cat(x1.sign, y1.sign)),
                    n.too_wide.eq(x0.over | y0.over | x1.over | y1.over),
                    n.zero_radius.eq(x0.zero & y0.zero),
                    n.start_x.eq(frame.x0[:w]), n.start_y.eq(frame.y0[:w]),
                    n.end_x.eq(frame.x1[:w]), n.end_y.eq(frame.y1[:w]),
                    n.mult_x.eq(frame.x0[:w + 1]), n.mult_y.eq(frame.y0[:w + 1]),
                    n.upper.eq(0), n.second.eq(0), n.count.eq(0), n.seen_x.eq(0),
                    n.seen_y.eq(0),
                    n.above[0].eq(0), n.above[1].eq(0), n.below[0].eq(1), n.below[1].eq(1),
                    n.x_longer.eq(1), n.y_above.eq(0), n.y_equal.eq(1), n.x_below.eq(0),
                    n.e_carry.eq(1), n.f_carry.eq(1),
                ]
                m.d.sync += [n.bit_x.eq(frame.x0[0]), n.bit_y.eq(frame.y0[0])]
                m.next = "Square"

    def _squares(self, m, n):
        """Square: the two passes, ``r2 = x0² + y0²`` then ``S = x1² + y1²``; in the second,
        the check's carries, the order of start and end and the distance's differences."""
        w, partial, lower = n.w, n.partial, n.lower
        start_x, start_y, end_x, end_y = n.start_x, n.start_y, n.end_x, n.end_y
        bit_x, bit_y, above, below = n.bit_x, n.bit_y, n.above, n.below
        r_bit, t_bit = n.r_bit, n.t_bit
        with m.State("Square"):
            m.d.sync += [
                n.upper.eq(partial[1:]),
                n.seen_x.eq(n.seen_after_x), n.seen_y.eq(n.seen_after_y),
                n.count.eq(n.count + 1),
            ]
            with m.If(~n.second):
                m.d.sync += [
                    lower.eq(Cat(lower[1:], partial[0])),
                    start_x.eq(Cat(start_x[1:], n.native_x)),
                    start_y.eq(Cat(start_y[1:], n.native_y)),
                ]
            with m.Else():
                ex, ey, sx, sy = n.native_x, n.native_y, start_x[0], start_y[0]
                e_sum = ey + ~ex + n.e_carry
                f_sum = sx + ~sy + n.f_carry
                for k, bit in enumerate((bit_x, bit_y)):
                    m.d.sync += [
                        above[k].eq((r_bit + ~t_bit + bit + above[k])[1:]),
                        below[k].eq((t_bit + ~r_bit + bit + below[k])[1:]),
                    ]
                m.d.sync += [
                    lower.eq(Cat(lower[1:], lower[0])),
                    start_x.eq(Cat(start_x[1:], sx)), start_y.eq(Cat(start_y[1:], sy)),
                    end_x.eq(Cat(end_x[1:w], f_sum[0])), end_y.eq(Cat(end_y[1:], e_sum[0])),
                    n.e_carry.eq(e_sum[1]), n.f_carry.eq(f_sum[1]),
                    n.x_longer.eq(Mux(bit_x != bit_y, bit_x, n.x_longer)),
                    n.y_above.eq(Mux(ey != sy, ey, n.y_above)),
                    n.y_equal.eq(n.y_equal & (ey == sy)),
                    n.x_below.eq(Mux(ex != sx, sx, n.x_below)),
                ]
            with m.If(n.count == w - 1):
                m.d.sync += [n.count.eq(0), n.seen_x.eq(0), n.seen_y.eq(0)]
                with m.If(~n.second):
                    m.d.sync += [
                        n.r2_high.eq(partial[1:]), n.upper.eq(0), n.second.eq(1),
                        n.mult_x.eq(Cat(end_x[:w], n.end_signs[0])),
                        n.mult_y.eq(Cat(end_y, n.end_signs[1])),
                        bit_x.eq(end_x[0]), bit_y.eq(end_y[0]),
                    ]
                with m.Else():
                    m.next = "Check end"

    def _end_check(self, m, n):
        """Check end: the high halves meet in one subtraction; the end is on the circle or
        not."""
        w, above, below = n.w, n.above, n.below
        with m.State("Check end"):
            high = Signal(signed(w + 3))             # H = R - T (upper holds T)
            m.d.comb += high.eq(n.r2_high - n.upper)
            carry_above = above[~n.x_longer]
            carry_below = below[~n.x_longer]
            m.d.sync += [
                n.on_circle.eq(((high == -1) & (carry_above == 2))
                               | ((high == 0) & (carry_above != 0) & (carry_below != 0))
                               | ((high == 1) & (carry_below == 2))),
                n.upper.eq(0), n.remainder.eq(0),
            ]
            m.next = "Root"

    def _square_root(self, m, n):
        """Root: the square root of ``r2`` and its remainder, two radicand bits a clock."""
        w, lower, r2_high, remainder = n.w, n.lower, n.r2_high, n.remainder
        with m.State("Root"):                        # two radicand bits a clock, from the top
            root = n.upper
            shifted = Cat(r2_high[-2:], remainder)
            trial = Cat(Const(1, 2), root)
            fits = shifted >= trial
            m.d.sync += [
                Cat(lower, r2_high).eq(Cat(lower, r2_high) << 2),
                remainder.eq(Mux(fits, shifted - trial, shifted)),
                root.eq(Cat(fits, root)),
                n.count.eq(n.count + 1),
            ]
            with m.If(n.count == w):
                m.next = "Plan"

    def _plan_offer(self, m, n):
        """Plan, Offer, Hold: the plan formed once the plan before is let go, its distance
        formed as it is offered, and the plan held until it is transferred."""
        w, remainder, runs, radius = n.w, n.remainder, n.runs, n.radius
        with m.State("Plan"):                        # once the plan before is let go
            root = n.upper
            round_up = remainder > root              # sqrt(r2) >= root + 1/2
            rn = Signal(w + 1)
            # (the increment beside the comparison, not after it: one carry chain deep)
            m.d.comb += rn.eq(Mux(round_up, root + 1, root))
            start_quadrant, end_quadrant = n.start_quadrant, n.end_quadrant
            ahead = (end_quadrant == start_quadrant) & (n.y_above | (n.y_equal & n.x_below))
            turns = Mux(n.cw, start_quadrant - end_quadrant, end_quadrant - start_quadrant)[:2]
            quadrants = Mux((turns == 0) & ~ahead, 4, turns)
            with m.If(~self.keep):
                m.d.sync += [
                    n.refused.eq(n.too_wide | n.zero_radius | rn[w] | ~n.on_circle),
                    runs.eq(quadrants + 1 - n.end_on_axis),
                    radius.eq(rn[:w]),
                    n.residue.eq(Mux(round_up, remainder - 2 * root - 1, remainder)),
                ]
                m.next = "Offer"
        with m.State("Offer"):
            # The plan is offered; its distance is formed in this clock, which the engine
            # reads only as the plan begins, a clock after its first run is taken at the
            # earliest: from the start (F + E) if the last run is the first, else from the
            # axis point (Rn + E).
            e = Signal(signed(w + 1))                # E = end Y - end X
            f = Signal(signed(w + 1))                # F = start X - start Y
            m.d.comb += [e.eq(Cat(n.end_y, ~n.e_carry)), f.eq(Cat(n.end_x[:w], ~n.f_carry)),
                         self.o.valid.eq(1)]
            m.d.sync += n.end_x.eq(Mux(runs == 1, f, radius) + e)
            with m.If(self.o.ready):
                m.next = "Idle"
            with m.Else():
                m.next = "Hold"
        with m.State("Hold"):
            m.d.comb += self.o.valid.eq(1)
            with m.If(self.o.ready):
                m.next = "Idle"


class ArcEngine(wiring.Component):
    """Arcs in, step/dir out: the planner and the quadrant sequencer around any quadrant core.

    Each transfer on :py:`cmd` is one arc, relative to its centre: from the start ``(x0, y0)``
    (the current position) to the end ``(x1, y1)``, clockwise if ``cw`` is set, a full circle
    when the two points are equal. The radius is that of the start point, ``sqrt(x0² + y0²)``,
    not necessarily an integer.

    :class:`ArcPlanner` checks and plans the arc while the arc before it may still run. The
    sequencer then runs the core once per quadrant: each quadrant is mapped onto the core's
    native one (X falling, Y rising) by signs and, where |x| rises, by swapping X and Y (the
    directions therefore change at every quadrant); the first run starts at the start point,
    every later one at the axis point ``(Rn, 0)``, ``Rn = round(sqrt(x0² + y0²))``, where the
    previous one ended, and the last run stops (the core's :py:`stop`) in the clock its step
    reaches the end point. Each run is handed to the core while the one before it runs, the
    first run of the next arc while the last of this one runs, so quadrants and arcs follow one
    another with no pause (each plan being ready in time). An arc offered to an idle engine at
    clock ``k`` makes its first step at ``k + 3·width + 6`` at the earliest.

    The plan is held once, in the planner: the sequencer keeps only what the running run needs
    (its quadrant, the distances to the end for the last run, loaded as the arc begins), and
    reads the radius and residue of the later runs from the plan, which the planner keeps
    (:py:`keep`) until the last of them is handed over; the next plan is offered after that.

    A refused arc (see :class:`ArcPlanner`) ends :attr:`~kontur.hdl.engine.Outcome.REFUSED` before
    any step, once the arc before it has ended and its outcome has been taken. Everything else
    is the common interface (:class:`~kontur.hdl.engine.EngineSignature`); status positions are
    ``width + 2`` bits.

    Parameters
    ----------
    core : :class:`~amaranth.lib.wiring.Component`
        A quadrant core, whose signature is an :class:`ArcCoreSignature`. It becomes the
        submodule ``core``.
    coord_width : :class:`int`
        Width of the signed coordinates in a frame; default ``max(32, width + 1)``.

    Members
    -------
    cmd : :py:`In(stream.Signature(ArcEngine.Frame(coord_width)))`
        Arcs.
    feed, motion, status, abort, busy
        As :class:`~kontur.hdl.engine.EngineSignature`.

    Raises
    ------
    :exc:`TypeError`
        If ``core`` is not a component with an :class:`ArcCoreSignature`, or ``coord_width``
        not an integer of at least 2.
    :exc:`ValueError`
        If ``coord_width`` is smaller than ``width + 1``.
    """

    @staticmethod
    def Frame(coord_width):
        return _arc_frame(coord_width)

    def __init__(self, core, *, coord_width=None):
        if (not isinstance(core, wiring.Component)
                or not isinstance(core.signature, ArcCoreSignature)):
            raise TypeError(f"Core must be a component with an ArcCoreSignature, not {core!r}")
        width = core.signature.width
        self._coord_width = frame_coord_width(width, coord_width)
        self._core = core
        self.planner = ArcPlanner(width=width, coord_width=self._coord_width)
        super().__init__(EngineSignature(self.Frame(self._coord_width),
                                         position_width=width + 2))

    @property
    def core(self):
        return self._core

    @property
    def width(self):
        return self._core.signature.width

    @property
    def coord_width(self):
        return self._coord_width

    def elaborate(self, platform):
        m = Module()
        w = self.width
        m.submodules.core = core = self._core
        m.submodules.planner = planner = ResetInserter(self.abort)(self.planner)
        m.submodules.status = status = StatusUnit(position_width=w + 2,
                                                  number_width=self.signature.number_width)
        planner_o = self.planner.o
        next_plan = planner_o.payload

        accepting = ~self.abort & ~status.flushing
        m.d.comb += [
            self.planner.i.payload.eq(self.cmd.payload),
            self.planner.i.valid.eq(self.cmd.valid & accepting),
            self.cmd.ready.eq(self.planner.i.ready & accepting),
        ]

        n = SimpleNamespace(w=w, core=core, status=status, planner_o=planner_o,
                            next_plan=next_plan, native=core.step)
        self._sequencer_registers(n)
        self._distance_to_end(m, n)
        self._sequencer_control(m, n)
        self._hand_over(m, n)
        self._sequencer(m, n)
        self._status(m, n)
        return m

    # The helpers below each elaborate one part of the engine into ``m``; ``n`` (a namespace)
    # carries the signals that one part drives and another reads, under the names the parts
    # give them.

    def _sequencer_registers(self, n):
        """The arc being traced: what the sequencer keeps of the running run."""
        w = n.w
        active = Signal()                 # an arc's run is running
        later_runs = Signal(3)            # its runs still to start after the running one
        to_offer = Signal(3)              # its runs not yet handed to the core
        first_offered = Signal()          # the next plan's first run is prepared in the core
        clockwise = Signal()
        quadrant = Signal(2)              # of the running run
        off_axis = Signal()               # the arc ends off the axis (native end Y > 0)
        # The distance to the end in the arc's last run, along both axes (X - end X + end Y -
        # Y): a step lowers it by one, a diagonal by two, and it is zero on the path only at the
        # end (the path is monotonic and passes through it).
        distance = Signal(w + 1)
        # The step that lands on the end, known from registers: in the last run of an arc
        # that ends off the axis, distance = 1 (reach[0]: any step) or 2 (reach[1]: a diagonal).
        reach = Signal(2)
        swap = Signal()
        direction = Signal(2)
        n.active, n.later_runs, n.to_offer, n.first_offered = \
            active, later_runs, to_offer, first_offered
        n.clockwise, n.quadrant, n.off_axis = clockwise, quadrant, off_axis
        n.distance, n.reach, n.swap, n.direction = distance, reach, swap, direction

    def _distance_to_end(self, m, n):
        """The distance to the end: the step that lands on it, found from registers, stops the
        core (the sequencer loads the distance and counts it down)."""
        native = n.native
        n.last_run = n.active & (n.later_runs == 0)
        reached = Signal()
        m.d.comb += [
            # The step lands on the end (X falls by native[0], Y rises by native[1]): one LUT
            # after the step, the rest from registers.
            reached.eq(Mux(native[0] & native[1], n.reach[1], native.any() & n.reach[0])),
            n.core.stop.eq(reached),
        ]

    def _sequencer_control(self, m, n):
        """The sequencer's events: the arc done, the next plan begun, a later quadrant
        started, a refused plan taken."""
        core, active, later_runs = n.core, n.active, n.later_runs
        arc_done = Signal()
        begin = Signal()                  # the next plan's first run starts: the plan is taken
        following = Signal()              # a later quadrant of this arc starts
        refuse = Signal()
        m.d.comb += [
            arc_done.eq(n.last_run & core.done & ~self.abort),
            begin.eq(core.start & ~(active & (later_runs != 0))),
            following.eq(core.start & active & (later_runs != 0)),
            refuse.eq(n.planner_o.valid & n.next_plan.refused & ~core.busy & ~n.status.hold
                      & ~self.abort),
            n.planner_o.ready.eq(begin | refuse),
        ]
        n.arc_done, n.begin, n.following, n.refuse = arc_done, begin, following, refuse

    def _hand_over(self, m, n):
        """The runs handed to the core."""
        core, next_plan, to_offer, first_offered = n.core, n.next_plan, n.to_offer, n.first_offered
        begin = n.begin
        # Runs handed to the core, in order: this arc's later quadrants (each from the axis),
        # then the next plan's first run. Once that is prepared in the core, the plan's own
        # first axis run is offered from the plan itself: the core takes it in the clock it
        # starts the first run, when the plan begins. Which run is offered, and whether, is
        # known from registers (no run of this arc left to offer; the next plan's first run
        # already offered): the offer never waits for the clock's start, so neither does the
        # core's preparation of the run.
        offer_axis = Signal()
        offer_first = Signal()
        own_axis = to_offer != 0          # this arc's later quadrants (never in a begin clock)
        plan_axis = ~own_axis & first_offered       # the next plan's, in the clock it begins
        m.d.comb += [
            offer_axis.eq(own_axis | (first_offered & (next_plan.runs > 1))),
            offer_first.eq(~own_axis & ~first_offered & n.planner_o.valid & ~next_plan.refused),
            core.cmd.valid.eq((offer_axis | offer_first) & ~self.abort),
            # The radius and residue of an axis run are the plan's, own or next: the planner
            # keeps them until the last of this arc's axis runs is handed over.
            core.cmd.payload.x.eq(Mux(own_axis | plan_axis, next_plan.radius, next_plan.start.x)),
            core.cmd.payload.y.eq(Mux(own_axis | plan_axis, 0, next_plan.start.y)),
            core.cmd.payload.residue.eq(Mux(own_axis | plan_axis, next_plan.residue, 0)),
            self.planner.keep.eq(own_axis),
        ]
        offered = core.cmd.valid & core.cmd.ready
        with m.If(begin):
            m.d.sync += to_offer.eq(next_plan.runs - 1 - (offered & offer_axis))
        with m.Elif(offered & offer_axis):
            m.d.sync += to_offer.eq(to_offer - 1)
        with m.If(begin):
            m.d.sync += first_offered.eq(0)
        with m.Elif(offered & offer_first):
            m.d.sync += first_offered.eq(1)

    def _sequencer(self, m, n):
        """The quadrant sequencer: the run's quadrant, swap and directions, and the distance
        to the end counted down in the last run."""
        next_plan, native, last_run = n.next_plan, n.native, n.last_run
        active, later_runs, clockwise, quadrant = n.active, n.later_runs, n.clockwise, n.quadrant
        off_axis, distance, reach, swap, direction = \
            n.off_axis, n.distance, n.reach, n.swap, n.direction

        def enter(q, rot):
            """Swap and direction registers for a run in quadrant ``q``."""
            x_falls = _x_falls(q, rot)
            x_negative = (q == 1) | (q == 2)
            y_negative = (q == 2) | (q == 3)
            return [swap.eq(~x_falls),
                    direction.eq(Cat(Mux(x_falls, ~x_negative, x_negative),
                                     Mux(x_falls, y_negative, ~y_negative)))]

        # The distance is that of the arc's last run, loaded as the arc begins; it counts only
        # in the last run.
        with m.If(n.begin):
            m.d.sync += [
                active.eq(1), later_runs.eq(next_plan.runs - 1),
                clockwise.eq(next_plan.cw), quadrant.eq(next_plan.quadrant),
                off_axis.eq(next_plan.off_axis),
                distance.eq(next_plan.distance),
                reach.eq(Cat(next_plan.distance == 1, next_plan.distance == 2)
                         & (next_plan.off_axis & (next_plan.runs == 1)).replicate(2)),
                *enter(next_plan.quadrant, next_plan.cw),
            ]
        with m.Elif(n.following):
            q_next = Mux(clockwise, quadrant - 1, quadrant + 1)[:2]
            m.d.sync += [
                later_runs.eq(later_runs - 1), quadrant.eq(q_next),
                reach.eq(Cat(distance == 1, distance == 2)
                         & (off_axis & (later_runs == 1)).replicate(2)),
                *enter(q_next, clockwise),
            ]
        with m.Else():
            with m.If(n.arc_done):
                m.d.sync += [active.eq(0), reach.eq(0)]
            with m.Elif(last_run & native.any()):
                diagonal = native[0] & native[1]
                m.d.sync += [
                    distance.eq(distance - 1 - diagonal),
                    reach.eq(Mux(diagonal, Cat(distance == 3, distance == 4),
                                 Cat(distance == 2, distance == 3))
                             & off_axis.replicate(2)),
                ]

        with m.If(self.abort):
            m.d.sync += [active.eq(0), later_runs.eq(0), n.to_offer.eq(0),
                         n.first_offered.eq(0), reach.eq(0)]

    def _status(self, m, n):
        """The steps and directions out, the feed through, and the status unit."""
        core, status, native = n.core, n.status, n.native
        step = Signal(2)
        m.d.comb += [
            step.eq(Mux(n.swap, Cat(native[1], native[0]), native)),
            core.feed.tick.eq(self.feed.tick & ~status.hold),
            self.feed.due.eq(core.feed.due & ~status.hold),
            self.feed.diagonal.eq(core.feed.diagonal),
            core.abort.eq(self.abort),
            self.motion.step.eq(step),
            self.motion.dir.eq(n.direction),

            status.motion.step.eq(step),
            status.motion.dir.eq(n.direction),
            status.accept.eq(self.cmd.valid & self.cmd.ready),
            status.end.eq(n.arc_done | n.refuse),
            status.outcome.eq(Mux(n.refuse, Outcome.REFUSED, Outcome.DONE)),
            status.flush.eq(self.abort),
            self.busy.eq(status.busy),
        ]
        wiring.connect(m, wiring.flipped(self.status), status.status)
