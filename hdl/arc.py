"""Any arc, from the SU 1665343 quadrant core: every quadrant, both directions, full circles."""

from amaranth import *
from amaranth.lib import data, wiring

from .circular import CircularInterpolator, CircularInterpolatorFast
from .elements._checks import check_choice, check_positive, check_width
from .engine import engine_members, frame_coord_width

__all__ = ["ArcEngine", "ARC_VARIANTS"]

ARC_VARIANTS = ("faithful", "fast")


class ArcEngine(wiring.Component):
    """Arcs in, step/dir pulses out: the circular interpolator wrapped for any arc.

    Each transfer on :py:`cmd` is one arc, relative to its centre: from the start ``(x0, y0)``
    (the current position) to the end ``(x1, y1)``, clockwise if ``cw`` is set, a full circle
    when the two points are equal. The radius is that of the start point, ``sqrt(x0² + y0²)``,
    not necessarily an integer.

    A setup unit checks the arc and plans it, with serial arithmetic: ``x0² + y0²`` and
    ``x1² + y1²`` take ``width`` clocks each, the rounded square root of the first
    ``width + 1``, forming the plan two more: the plan is ready ``3·width + 4`` clocks after the
    arc was accepted, while the arc before it may still be running. A sequencer then runs the
    core once per quadrant: each quadrant is mapped onto the core's native one (X falling,
    Y rising) by signs and, where |x| rises, by swapping X and Y; the first run starts at the
    start point, every later one at the axis point ``round(sqrt(x0² + y0²))`` where the
    previous one ended, and the last run stops in the clock its step reaches the end point
    (input 32). Arcs follow one another with no pause when each plan is ready in time.

    Every accepted arc ends with exactly one pulse: :py:`done`, or :py:`error` if it is refused
    before any step: a coordinate magnitude above ``2**width - 1``, a start point at the centre
    (R = 0), a radius that rounds above ``2**width - 1``, or an end point not on the start
    point's circle. An end point is on the circle when it is a point of the interpolated path,
    i.e. within half a step of the circle along its larger coordinate ``M``:
    ``-M < x0² + y0² - x1² - y1² <= M``.

    Parameters
    ----------
    variant : ``"faithful"`` or ``"fast"``
        :class:`~hdl.circular.CircularInterpolator` (the patent's structure and timing) or
        :class:`~hdl.circular.CircularInterpolatorFast` (one step per clock).
    width : :class:`int`
        Register width of the core.
    coord_width : :class:`int`
        Width of the signed coordinates in a frame; default ``max(32, width + 1)``.
    timing : :class:`~hdl.circular.FaithfulTiming`
        Timing of the faithful core (default: its structural minimum).
    period : :class:`int`
        Generator period of the fast core, in :py:`tick` clocks.

    Members
    -------
    cmd : :py:`In(stream.Signature(ArcEngine.Frame(coord_width)))`
        Arcs.
    tick : :py:`In(1)`
        Feed-rate strobe for the core's generator.
    step : :py:`Out(2)`
        Step pulses, bit 0 X, bit 1 Y.
    dir : :py:`Out(2)`
        Directions, bit 0 X, bit 1 Y: 1 for the negative direction. Valid with :py:`step`.
    busy : :py:`Out(1)`
        An arc is being planned, waiting or running.
    done : :py:`Out(1)`
        An arc ended.
    error : :py:`Out(1)`
        An arc was refused.

    Raises
    ------
    :exc:`TypeError`
        If a width or the period is not a positive integer (width at least 2).
    :exc:`ValueError`
        If ``variant`` is unknown or ``coord_width`` is smaller than ``width + 1``.
    """

    @staticmethod
    def Frame(coord_width):
        return data.StructLayout({"x0": signed(coord_width), "y0": signed(coord_width),
                                  "x1": signed(coord_width), "y1": signed(coord_width),
                                  "cw": 1})

    def __init__(self, *, variant="faithful", width=24, coord_width=None, timing=None,
                 period=1):
        check_choice("Variant", variant, ARC_VARIANTS)
        check_width("Register width", width, minimum=2)
        check_positive("Generator period", period)
        coord_width = frame_coord_width(width, coord_width)
        self._variant = variant
        self._width = width
        self._coord_width = coord_width
        if variant == "faithful":
            self.core = CircularInterpolator(width=width, timing=timing)
        else:
            self.core = CircularInterpolatorFast(width=width, period=period)
        super().__init__(engine_members(self.Frame(coord_width)))

    @property
    def variant(self):
        return self._variant

    @property
    def width(self):
        return self._width

    @property
    def coord_width(self):
        return self._coord_width

    def elaborate(self, platform):
        m = Module()
        m.submodules.core = core = self.core
        w = self._width
        aw, cw = w + 4, w + 1

        # ======== setup unit: check the arc and plan its quadrant runs ===========================
        p = self.cmd.payload
        magnitude = [Mux(v < 0, -v, v)[:self._coord_width] for v in (p.x0, p.y0, p.x1, p.y1)]
        too_wide_now = Cat(*[(v >> w).any() for v in magnitude]).any()

        ax0, ay0, ax1, ay1 = (Signal(w, name=n) for n in ("ax0", "ay0", "ax1", "ay1"))
        rotation = Signal()                          # 1: clockwise
        q0 = Signal(2)
        qe = Signal(2)
        xs, ys, xe, ye = (Signal(w, name=n) for n in ("xs", "ys", "xe", "ye"))
        too_wide = Signal()
        zero_radius = Signal()

        # serial sum of squares and square root
        mcand_x = Signal(2 * w)
        mcand_y = Signal(2 * w)
        mplier_x = Signal(w)
        mplier_y = Signal(w)
        acc = Signal(2 * w + 1)
        r2 = Signal(2 * w + 1)
        radicand = Signal(2 * w + 2)
        root = Signal(w + 1)
        rem = Signal(w + 3)
        count = Signal(range(w + 1))
        partial = (Mux(mplier_x[0], mcand_x, 0) + Mux(mplier_y[0], mcand_y, 0))
        acc_next = acc + partial

        # plan, stage A
        rn = Signal(w + 1)
        residue = Signal(signed(w + 3))             # r2 - rn²
        on_circle = Signal()
        # plan slot (stage B)
        plan_valid = Signal()
        plan = {
            "error": Signal(name="plan_error"), "cw": Signal(name="plan_cw"),
            "q0": Signal(2, name="plan_q0"), "runs": Signal(3, name="plan_runs"),
            "in29": Signal(signed(aw), name="plan_in29"), "in30": Signal(signed(cw),
                                                                         name="plan_in30"),
            "in31": Signal(signed(cw), name="plan_in31"), "in34": Signal(name="plan_in34"),
            "xs": Signal(w, name="plan_xs"), "ys": Signal(w, name="plan_ys"),
            "axis29": Signal(signed(aw), name="plan_axis29"), "rn": Signal(w, name="plan_rn"),
            "xe": Signal(w, name="plan_xe"), "ye": Signal(w, name="plan_ye"),
        }

        take = Signal()                              # the sequencer takes the plan this clock

        def quadrant(x, y, clockwise):
            """Quadrant 0-3; an axis point belongs to the quadrant the motion enters."""
            ccw = Mux((x > 0) & (y >= 0), 0, Mux((x <= 0) & (y > 0), 1,
                                                  Mux((x < 0) & (y <= 0), 2, 3)))
            cwq = Mux((x >= 0) & (y > 0), 0, Mux((x < 0) & (y >= 0), 1,
                                                  Mux((x <= 0) & (y < 0), 2, 3)))
            return Mux(clockwise, cwq, ccw)

        def type_a(q, clockwise):
            """Quadrant run with X = |x| (|x| falls): even quadrants counter-clockwise."""
            return ~q[0] ^ clockwise

        q0_now = quadrant(p.x0, p.y0, p.cw)
        qe_now = quadrant(p.x1, p.y1, p.cw)

        with m.FSM(name="setup"):
            with m.State("Idle"):
                m.d.comb += self.cmd.ready.eq(1)
                with m.If(self.cmd.valid):
                    a_s = type_a(q0_now, p.cw)
                    a_e = type_a(qe_now, p.cw)
                    m.d.sync += [
                        ax0.eq(magnitude[0]), ay0.eq(magnitude[1]),
                        ax1.eq(magnitude[2]), ay1.eq(magnitude[3]),
                        rotation.eq(p.cw), q0.eq(q0_now), qe.eq(qe_now),
                        xs.eq(Mux(a_s, magnitude[0], magnitude[1])),
                        ys.eq(Mux(a_s, magnitude[1], magnitude[0])),
                        xe.eq(Mux(a_e, magnitude[2], magnitude[3])),
                        ye.eq(Mux(a_e, magnitude[3], magnitude[2])),
                        too_wide.eq(too_wide_now),
                        zero_radius.eq((p.x0 == 0) & (p.y0 == 0)),
                        mcand_x.eq(magnitude[0][:w]), mplier_x.eq(magnitude[0][:w]),
                        mcand_y.eq(magnitude[1][:w]), mplier_y.eq(magnitude[1][:w]),
                        acc.eq(0),
                        count.eq(0),
                    ]
                    m.next = "Square start"
            with m.State("Square start"):           # x0² + y0², one bit a clock
                m.d.sync += [
                    acc.eq(acc_next), mcand_x.eq(mcand_x << 1), mcand_y.eq(mcand_y << 1),
                    mplier_x.eq(mplier_x >> 1), mplier_y.eq(mplier_y >> 1),
                    count.eq(count + 1),
                ]
                with m.If(count == w - 1):
                    m.d.sync += [
                        r2.eq(acc_next), acc.eq(0), count.eq(0),
                        mcand_x.eq(ax1), mplier_x.eq(ax1), mcand_y.eq(ay1), mplier_y.eq(ay1),
                    ]
                    m.next = "Square end"
            with m.State("Square end"):             # x1² + y1²
                m.d.sync += [
                    acc.eq(acc_next), mcand_x.eq(mcand_x << 1), mcand_y.eq(mcand_y << 1),
                    mplier_x.eq(mplier_x >> 1), mplier_y.eq(mplier_y >> 1),
                    count.eq(count + 1),
                ]
                with m.If(count == w - 1):
                    m.d.sync += [radicand.eq(r2), root.eq(0), rem.eq(0), count.eq(0)]
                    m.next = "Root"
            with m.State("Root"):                   # ⌊sqrt(r2)⌋ and r2 - root², a bit a clock
                shifted = Cat(radicand[-2:], rem)
                trial = Cat(Const(1, 2), root)
                fits = shifted >= trial
                m.d.sync += [
                    radicand.eq(radicand << 2),
                    rem.eq(Mux(fits, shifted - trial, shifted)),
                    root.eq(Cat(fits, root)),
                    count.eq(count + 1),
                ]
                with m.If(count == w):
                    m.next = "Plan A"
            with m.State("Plan A"):
                round_up = rem > root                 # sqrt(r2) >= root + 1/2
                d = Signal(signed(2 * w + 3))
                big = Mux(ax1 >= ay1, ax1, ay1)
                m.d.comb += d.eq(r2 - acc)
                m.d.sync += [
                    rn.eq(root + round_up),
                    residue.eq(Mux(round_up, rem - 2 * root - 1, rem)),
                    on_circle.eq((d > -big) & (d <= big)),
                ]
                m.next = "Plan B"
            with m.State("Plan B"):
                ahead = (qe == q0) & ((ye > ys) | ((ye == ys) & (xe < xs)))
                k = Mux(rotation, q0 - qe, qe - q0)[:2]
                quadrants = Mux((k == 0) & ~ahead, 4, k)
                sector2 = ys >= xs
                m.d.sync += [
                    plan_valid.eq(1),
                    plan["error"].eq(too_wide | zero_radius | rn[w] | ~on_circle),
                    plan["cw"].eq(rotation),
                    plan["q0"].eq(q0),
                    plan["runs"].eq(quadrants + 1 - (ye == 0)),
                    plan["in29"].eq(Mux(sector2, 2 * xs - ys - 2, xs - 2 * ys - 2)),
                    plan["in30"].eq(Mux(sector2, xs - 1, ys)),
                    plan["in31"].eq(Mux(sector2, xs - ys, xs - ys - 1)),
                    plan["in34"].eq(sector2),
                    plan["xs"].eq(xs), plan["ys"].eq(ys),
                    plan["axis29"].eq(residue + rn - 2),
                    plan["rn"].eq(rn),
                    plan["xe"].eq(xe), plan["ye"].eq(ye),
                ]
                m.next = "Hold"
            with m.State("Hold"):
                with m.If(take):
                    m.d.sync += plan_valid.eq(0)
                    m.next = "Idle"
        setup_idle = self.cmd.ready

        # ======== sequencer: one core run per quadrant ===========================================
        running = Signal()
        run = Signal(3)                              # index of the current run
        runs = Signal(3)
        q = Signal(2)
        clockwise = Signal()
        axis29 = Signal(signed(aw))
        radius = Signal(w)
        end_x = Signal(w)
        end_y = Signal(w)
        x = Signal(w + 1)                            # native position in the current run
        y = Signal(w + 1)
        swap = Signal()
        direction = Signal(2)

        native = core.step
        x_next = x - native[0]
        y_next = y + native[1]
        last_run = running & (run == runs - 1)
        reached = Signal()
        arc_done = Signal()
        next_run = Signal()
        refuse = Signal()
        begin = Signal()
        m.d.comb += [
            reached.eq(last_run & (end_y != 0) & native.any() &
                       (x_next == end_x) & (y_next == end_y)),
            core.in32.eq(reached),
            arc_done.eq(last_run & core.done),
            next_run.eq(running & core.done & ~last_run),
            take.eq(plan_valid & (~running | arc_done)),
            refuse.eq(take & plan["error"]),
            begin.eq(take & ~plan["error"]),
            core.in33.eq(begin | next_run),
            core.in29.eq(Mux(begin, plan["in29"], axis29)),
            core.in30.eq(Mux(begin, plan["in30"], 0)),
            core.in31.eq(Mux(begin, plan["in31"], radius - 1)),
            core.in34.eq(begin & plan["in34"]),
            core.tick.eq(self.tick),
        ]

        def enter(quad, rot):
            """Swap and direction registers for a run in quadrant ``quad``."""
            a = type_a(quad, rot)
            x_negative = (quad == 1) | (quad == 2)
            y_negative = (quad == 2) | (quad == 3)
            return [swap.eq(~a),
                    direction.eq(Cat(Mux(a, ~x_negative, x_negative),
                                     Mux(a, y_negative, ~y_negative)))]

        with m.If(begin):
            m.d.sync += [
                running.eq(1), run.eq(0), runs.eq(plan["runs"]), q.eq(plan["q0"]),
                clockwise.eq(plan["cw"]), axis29.eq(plan["axis29"]), radius.eq(plan["rn"]),
                end_x.eq(plan["xe"]), end_y.eq(plan["ye"]),
                x.eq(plan["xs"]), y.eq(plan["ys"]),
                *enter(plan["q0"], plan["cw"]),
            ]
        with m.Elif(next_run):
            following = Mux(clockwise, q - 1, q + 1)[:2]
            m.d.sync += [
                run.eq(run + 1), q.eq(following), x.eq(radius), y.eq(0),
                *enter(following, clockwise),
            ]
        with m.Else():
            with m.If(arc_done):
                m.d.sync += running.eq(0)
            with m.If(running):
                m.d.sync += [x.eq(x_next), y.eq(y_next)]

        m.d.comb += [
            self.step.eq(Mux(swap, Cat(native[1], native[0]), native)),
            self.dir.eq(direction),
            self.busy.eq(running | ~setup_idle),
            self.done.eq(arc_done),
            self.error.eq(refuse),
        ]
        return m
