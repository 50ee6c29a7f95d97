"""Any arc from a quadrant core: the core signature, the planner, and the engine around them."""

from amaranth import *
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from .elements import carry_save, magnitude
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
        Permission for each step (:class:`~hdl.engine.FeedSignature`).
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


def _quadrant(x, y, clockwise):
    """Quadrant 0-3 of a point; an axis point belongs to the quadrant the motion enters."""
    ccw = Mux((x > 0) & (y >= 0), 0, Mux((x <= 0) & (y > 0), 1, Mux((x < 0) & (y <= 0), 2, 3)))
    cwq = Mux((x >= 0) & (y > 0), 0, Mux((x < 0) & (y >= 0), 1, Mux((x <= 0) & (y < 0), 2, 3)))
    return Mux(clockwise, cwq, ccw)


def _x_falls(quadrant, clockwise):
    """Whether |x| falls in ``quadrant`` (native X = |x|): even quadrants counter-clockwise."""
    return ~quadrant[0] ^ clockwise


class ArcPlanner(wiring.Component):
    """Check an arc and plan its quadrant runs, with serial arithmetic; hold one plan.

    Takes an arc on :py:`i` (the frame of :class:`ArcEngine`) while it holds no plan. It maps
    the start and the end onto the native quadrant of the quadrant they lie in (the start's
    quadrant is the first run's, the end's the last's), forms ``r2 = x0² + y0²`` and
    ``x1² + y1²`` (``width`` clocks each, one multiplier bit a clock), checks the end point
    (one clock), takes the rounded square root of ``r2`` with its remainder (``width + 1``
    clocks), and forms the plan (one clock): it is offered on :py:`o` ``3·width + 4`` clocks
    after the arc was taken, and held there until it is transferred.

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
            "end":      point,                # native end in the last run (y = 0: its axis)
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
        w = self._width
        frame = self.i.payload
        plan = Signal(self.Plan(w))                  # the one plan, built in place
        m.d.comb += self.o.payload.eq(plan)

        magnitudes, overs = zip(*[magnitude(m, v, w)
                                  for v in (frame.x0, frame.y0, frame.x1, frame.y1)])
        start_quadrant = _quadrant(frame.x0, frame.y0, frame.cw)
        end_quadrant = Signal(2)                     # the quadrant of the last run
        too_wide = Signal()
        zero_radius = Signal()

        # Serial sum of squares a² + b², one multiplier bit a clock: each clock adds the
        # multiplicands whose multiplier bit is set to the upper half, then shifts the whole
        # sum down one place; after `w` clocks it holds a² + b² (2w + 1 bits).
        upper = Signal(w + 1)
        lower = Signal(w)
        bits_a = Signal(w)                           # multiplier bits, shifted out at the bottom
        bits_b = Signal(w)
        second = Signal()                            # 0: x0² + y0², 1: x1² + y1²
        a = Mux(second, plan.end.x, plan.start.x)
        b = Mux(second, plan.end.y, plan.start.y)
        partial = Signal(w + 2)
        m.d.comb += partial.eq(upper + Mux(bits_a[0], a, 0) + Mux(bits_b[0], b, 0))
        square_sum = Cat(lower, upper)

        r2 = Signal(2 * w + 2)                       # x0² + y0², then shifted out by the root
        on_circle = Signal()
        big = Signal(w)                              # M = max(x1, y1), the end's bound
        root = Signal(w + 1)                         # ⌊sqrt(r2)⌋, a bit a clock
        remainder = Signal(w + 3)                    # r2 - root²
        count = Signal(range(w + 1))

        with m.FSM(name="planner"):
            with m.State("Idle"):
                m.d.comb += self.i.ready.eq(1)
                with m.If(self.i.valid):
                    x_falls_0 = _x_falls(start_quadrant, frame.cw)
                    end_q = _quadrant(frame.x1, frame.y1, frame.cw)
                    x_falls_1 = _x_falls(end_q, frame.cw)
                    m.d.sync += [
                        plan.cw.eq(frame.cw),
                        plan.quadrant.eq(start_quadrant),
                        end_quadrant.eq(end_q),
                        plan.start.x.eq(Mux(x_falls_0, magnitudes[0], magnitudes[1])),
                        plan.start.y.eq(Mux(x_falls_0, magnitudes[1], magnitudes[0])),
                        plan.end.x.eq(Mux(x_falls_1, magnitudes[2], magnitudes[3])),
                        plan.end.y.eq(Mux(x_falls_1, magnitudes[3], magnitudes[2])),
                        too_wide.eq(Cat(*overs).any()),
                        zero_radius.eq((frame.x0 == 0) & (frame.y0 == 0)),
                        upper.eq(0), lower.eq(0), second.eq(0), count.eq(0),
                        bits_a.eq(Mux(x_falls_0, magnitudes[0], magnitudes[1])),
                        bits_b.eq(Mux(x_falls_0, magnitudes[1], magnitudes[0])),
                    ]
                    m.next = "Square"
            with m.State("Square"):
                m.d.sync += [
                    big.eq(Mux(plan.end.x >= plan.end.y, plan.end.x, plan.end.y)),
                    upper.eq(partial[1:]), lower.eq(Cat(lower[1:], partial[0])),
                    bits_a.eq(bits_a >> 1), bits_b.eq(bits_b >> 1),
                    count.eq(count + 1),
                ]
                with m.If(count == w - 1):
                    m.d.sync += [upper.eq(0), lower.eq(0), count.eq(0)]
                    with m.If(~second):
                        m.d.sync += [
                            r2.eq(Cat(lower[1:], partial)), second.eq(1),
                            bits_a.eq(plan.end.x), bits_b.eq(plan.end.y),
                        ]
                    with m.Else():
                        m.d.sync += [upper.eq(partial[1:]), lower.eq(Cat(lower[1:],
                                                                         partial[0]))]
                        m.next = "Check end"
            with m.State("Check end"):               # -M < r2 - (x1² + y1²) <= M
                # Both bounds as the sign of a three-operand sum, one carry chain each:
                # r2 - S > -M is r2 + ~S + M >= 0, and r2 - S <= M is M + ~r2 + S + 1 >= 0 (the
                # + 1 in the free lowest bit of the carries).
                cw2 = 2 * w + 4
                r2_, s_, big_ = Signal(cw2), Signal(cw2), Signal(cw2)
                m.d.comb += [r2_.eq(r2), s_.eq(square_sum), big_.eq(big)]
                above = carry_save(m, r2_, ~s_, big_)
                below = carry_save(m, big_, ~r2_, s_)
                m.d.sync += [on_circle.eq(~(above[0] + above[1])[cw2 - 1]
                                          & ~(below[0] + (below[1] | 1))[cw2 - 1]),
                             root.eq(0), remainder.eq(0)]
                m.next = "Root"
            with m.State("Root"):                    # two radicand bits a clock, from the top
                shifted = Cat(r2[-2:], remainder)
                trial = Cat(Const(1, 2), root)
                fits = shifted >= trial
                m.d.sync += [
                    r2.eq(r2 << 2),
                    remainder.eq(Mux(fits, shifted - trial, shifted)),
                    root.eq(Cat(fits, root)),
                    count.eq(count + 1),
                ]
                with m.If(count == w):
                    m.next = "Plan"
            with m.State("Plan"):                    # once the plan before is let go
                round_up = remainder > root          # sqrt(r2) >= root + 1/2
                rn = Signal(w + 1)
                m.d.comb += rn.eq(root + round_up)
                start, end = plan.start, plan.end
                ahead = ((end_quadrant == plan.quadrant)
                         & ((end.y > start.y) | ((end.y == start.y) & (end.x < start.x))))
                turns = Mux(plan.cw, plan.quadrant - end_quadrant,
                            end_quadrant - plan.quadrant)[:2]
                quadrants = Mux((turns == 0) & ~ahead, 4, turns)
                with m.If(~self.keep):
                    m.d.sync += [
                        plan.refused.eq(too_wide | zero_radius | rn[w] | ~on_circle),
                        plan.runs.eq(quadrants + 1 - (end.y == 0)),
                        plan.radius.eq(rn[:w]),
                        plan.residue.eq(Mux(round_up, remainder - 2 * root - 1, remainder)),
                    ]
                    m.next = "Hold"
            with m.State("Hold"):
                m.d.comb += self.o.valid.eq(1)
                with m.If(self.o.ready):
                    m.next = "Idle"
        return m


def _distances(m, dx, dy, near, x_distance, y_distance):
    """Assignments loading the sequencer's distances to the end and their flags."""
    dx_, dy_ = Signal.like(dx), Signal.like(dy)
    m.d.comb += [dx_.eq(x_distance), dy_.eq(y_distance)]
    return [dx.eq(dx_), dy.eq(dy_), near.eq(Cat(dx_ == 0, dx_ == 1, dy_ == 0, dy_ == 1))]


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

    A refused arc (see :class:`ArcPlanner`) ends :attr:`~hdl.engine.Outcome.REFUSED` before
    any step, once the arc before it has ended and its outcome has been taken. Everything else is the common interface
    (:class:`~hdl.engine.EngineSignature`); status positions are ``width + 2`` bits.

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
        As :class:`~hdl.engine.EngineSignature`.

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

        # ---- the arc being traced ---------------------------------------------------------
        active = Signal()                 # an arc's run is running
        later_runs = Signal(3)            # its runs still to start after the running one
        to_offer = Signal(3)              # its runs not yet handed to the core
        first_offered = Signal()          # the next plan's first run is prepared in the core
        clockwise = Signal()
        quadrant = Signal(2)              # of the running run
        off_axis = Signal()               # the arc ends off the axis (native end Y > 0)
        dx = Signal(signed(w + 2))        # native X - end X in the arc's last run
        dy = Signal(signed(w + 2))        # end Y - native Y
        near = Signal(4)                  # dx = 0, dx = 1, dy = 0, dy = 1
        swap = Signal()
        direction = Signal(2)

        native = core.step
        last_run = active & (later_runs == 0)
        reached = Signal()
        arc_done = Signal()
        begin = Signal()                  # the next plan's first run starts: the plan is taken
        following = Signal()              # a later quadrant of this arc starts
        refuse = Signal()
        m.d.comb += [
            # The step lands on the end (X falls by native[0], Y rises by native[1]): the
            # distances are compared from registers, not through the step's own sums.
            reached.eq(last_run & off_axis & native.any()
                       & Mux(native[0], near[1], near[0]) & Mux(native[1], near[3], near[2])),
            core.stop.eq(reached),
            arc_done.eq(last_run & core.done & ~self.abort),
            begin.eq(core.start & ~(active & (later_runs != 0))),
            following.eq(core.start & active & (later_runs != 0)),
            refuse.eq(planner_o.valid & next_plan.refused & ~core.busy & ~status.hold
                      & ~self.abort),
            planner_o.ready.eq(begin | refuse),
        ]

        # Runs handed to the core, in order: this arc's later quadrants (each from the axis),
        # then the next plan's first run. In the clock a plan is taken its own later runs come
        # first, from the plan itself. Which run is offered is known from registers (no run of
        # this arc left to offer; the next plan's first run already offered): the clock's
        # start only validates the offer, so the core's preparation of the run does not wait
        # for the handover.
        offer_axis = Signal()
        offer_first = Signal()
        own_axis = to_offer != 0          # this arc's later quadrants (never in a begin clock)
        plan_axis = ~own_axis & first_offered       # the next plan's, in the clock it begins
        m.d.comb += [
            offer_axis.eq(own_axis | (begin & (next_plan.runs > 1))),
            offer_first.eq(~own_axis & ~first_offered & planner_o.valid & ~next_plan.refused),
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

        def enter(q, rot):
            """Swap and direction registers for a run in quadrant ``q``."""
            x_falls = _x_falls(q, rot)
            x_negative = (q == 1) | (q == 2)
            y_negative = (q == 2) | (q == 3)
            return [swap.eq(~x_falls),
                    direction.eq(Cat(Mux(x_falls, ~x_negative, x_negative),
                                     Mux(x_falls, y_negative, ~y_negative)))]

        # The distances to the end are those of the arc's last run, loaded as the arc begins:
        # from the start when it is its only run, else from the axis point (Rn, 0). They count
        # only in the last run.
        single = next_plan.runs == 1
        with m.If(begin):
            m.d.sync += [
                active.eq(1), later_runs.eq(next_plan.runs - 1),
                clockwise.eq(next_plan.cw), quadrant.eq(next_plan.quadrant),
                off_axis.eq(next_plan.end.y != 0),
                *_distances(m, dx, dy, near,
                            Mux(single, next_plan.start.x, next_plan.radius) - next_plan.end.x,
                            next_plan.end.y - Mux(single, next_plan.start.y, 0)),
                *enter(next_plan.quadrant, next_plan.cw),
            ]
        with m.Elif(following):
            q_next = Mux(clockwise, quadrant - 1, quadrant + 1)[:2]
            m.d.sync += [
                later_runs.eq(later_runs - 1), quadrant.eq(q_next),
                *enter(q_next, clockwise),
            ]
        with m.Else():
            with m.If(arc_done):
                m.d.sync += active.eq(0)
            with m.If(last_run):
                m.d.sync += [
                    dx.eq(dx - native[0]), dy.eq(dy - native[1]),
                    near.eq(Cat(Mux(native[0], near[1], near[0]),
                                Mux(native[0], dx == 2, near[1]),
                                Mux(native[1], near[3], near[2]),
                                Mux(native[1], dy == 2, near[3]))),
                ]

        with m.If(self.abort):
            m.d.sync += [active.eq(0), later_runs.eq(0), to_offer.eq(0),
                         first_offered.eq(0)]

        step = Signal(2)
        m.d.comb += [
            step.eq(Mux(swap, Cat(native[1], native[0]), native)),
            core.feed.tick.eq(self.feed.tick & ~status.hold),
            self.feed.due.eq(core.feed.due & ~status.hold),
            self.feed.diagonal.eq(core.feed.diagonal),
            core.abort.eq(self.abort),
            self.motion.step.eq(step),
            self.motion.dir.eq(direction),

            status.motion.step.eq(step),
            status.motion.dir.eq(direction),
            status.accept.eq(self.cmd.valid & self.cmd.ready),
            status.end.eq(arc_done | refuse),
            status.outcome.eq(Mux(refuse, Outcome.REFUSED, Outcome.DONE)),
            status.flush.eq(self.abort),
            self.busy.eq(status.busy),
        ]
        wiring.connect(m, wiring.flipped(self.status), status.status)
        return m
