"""Properties of SU 1665343 (``hdl/circular.py``): the one-step-per-clock core
:class:`CircularInterpolatorFast` and the faithful core :class:`CircularInterpolator`.

The harness follows the run the core accepted in its native frame: the current point
``(X, Y)`` (from the start, ``X`` falls by one on output 36, ``Y`` rises on output 35), the
sector (2 once a sector-1 step has made ``X <= Y``), and the *residue* of the point,
``ρ = r2 - X² - Y²``, kept by its increments (``+2X - 1`` when ``X`` falls, ``-2Y - 1`` when
``Y`` rises: ``(X - 1)² = X² - 2X + 1``); at the start ``ρ`` is the run's residue (the arc
core's ``residue``, zero for a start on its own circle).

Claims, while a run is in progress:

* **F tied to the point**: adder 1 holds ``⌊F1⌋ = ρ + X - 2Y - 2`` in sector 1 and
  ``⌊F2⌋ = ρ + 2X - Y - 2`` in sector 2 (``F1 = r2 - (X - ½)² - (Y + 1)²``,
  ``F2 = r2 - (X - 1)² - (Y + ½)²``, always ``⌊F⌋ + ¾``); counter 7 holds ``Y`` (sector 1) or
  ``X - 1`` (sector 2), counter 8 ``X - Y - 1`` or ``X - Y``, trigger 16 the sector, which is
  ``Y >= X``;
* **the half-step bound**: ``-M < ρ <= M``, ``M = max(X, Y)``: every point lies within half a
  step of the circle along its larger coordinate, hence radially (``|ρ| <= M`` with ``ρ`` an
  integer is ``|M - sqrt(r2 - m²)| <= ½``);
* **the switch-over**: it happens on the sector-1 step that makes ``X - Y`` 0 or -1, and
  only there, and adder 1 is re-based from ``F1`` to ``F2`` (``+X + Y``) with it;
* one move per generator pulse (Y or diagonal in sector 1, diagonal or X in sector 2), no
  step outside a run;
* **the end point**: the run ends (``done``) with the step that makes ``X = 0`` (or on input
  32), there the point ``(0, Y)`` is within half a step of the circle: ``X`` steps made equal
  the start's ``X``, ``Y`` steps the rise to ``round(sqrt(r2))``;
* a start while a run is in progress is refused (``error``) and changes nothing.

Assumed: each start is a native start on the path, ``X >= 1``, ``-M < residue <= M``, with
coordinates below ``2**(width - 1)`` (so that no point of the quadrant overflows the
``width``-bit counters: ``Y`` never exceeds ``2·max(X, Y) + 1`` of the start).
"""

from amaranth import *
from amaranth.hdl import Assert, Assume

from ..circular import CircularInterpolator, CircularInterpolatorFast, _choices
from ._util import free, ones_value

__all__ = ["CircularInterpolatorFastProperties", "CircularInterpolatorProperties",
           "run_inputs"]


def run_inputs(x, y, residue, w):
    """The patent's inputs 29, 30, 31 and 34 for a native start ``(x, y)`` of residue
    ``residue`` (as the arc cores form them): ``⌊F⌋``, counter 7, counter 8, ``Y >= X``."""
    sector2 = y >= x
    in29 = residue + Mux(sector2, 2 * x - y, x - 2 * y) - 2
    in30 = Mux(sector2, x - 1, y)
    in31 = Mux(sector2, x - y, x - y - 1)
    return in29, in30, in31, sector2


class _Run:
    """The harness's record of the running quadrant."""

    def __init__(self, w):
        self.x = Signal(w + 1, name="point_x")
        self.y = Signal(w + 1, name="point_y")
        self.rho = Signal(signed(w + 4), name="residue")     # r2 - X² - Y²
        self.sector2 = Signal(name="sector2")
        self.m0 = Signal(w, name="start_max")                # max(X, Y) at the start

    def after(self, m, step, w):
        """``(x, y, rho)`` after this clock's ``step``."""
        x = Signal(w + 1, name="next_x")
        y = Signal(w + 1, name="next_y")
        rho = Signal(signed(w + 4), name="next_residue")
        m.d.comb += [
            x.eq(self.x - step[0]),
            y.eq(self.y + step[1]),
            rho.eq(self.rho + Mux(step[0], 2 * self.x - 1, 0) - Mux(step[1], 2 * self.y + 1, 0)),
        ]
        return x, y, rho


def _bound(rho, x, y):
    big = Mux(x >= y, x, y)
    return (rho > -big) & (rho <= big)


def _free_start(m, ip, w):
    """Free native starts, assumed on their path; return ``(start, x, y, residue)``."""
    x = Signal(w, name="start_x")
    y = Signal(w, name="start_y")
    residue = Signal(signed(w + 1), name="start_residue")
    free(m, x, y, residue, ip.in32, ip.in33, ip.tick)
    in29, in30, in31, in34 = run_inputs(x, y, residue, w)
    m.d.comb += [ip.in29.eq(in29), ip.in30.eq(in30), ip.in31.eq(in31), ip.in34.eq(in34)]
    start = ip.in33 & ip.ready
    limit = 1 << (w - 1)
    with m.If(start):
        m.d.comb += Assume((x >= 1) & (x < limit) & (y < limit) & _bound(residue, x, y))
    return start, x, y, residue


def _follow(m, run, *, start, x, y, residue, step, running, w):
    nx, ny, nrho = run.after(m, step, w)
    with m.If(start):
        m.d.sync += [run.x.eq(x), run.y.eq(y), run.rho.eq(residue), run.sector2.eq(y >= x),
                     run.m0.eq(Mux(x >= y, x, y))]
    with m.Elif(running & step.any()):
        m.d.sync += [run.x.eq(nx), run.y.eq(ny), run.rho.eq(nrho),
                     run.sector2.eq(run.sector2 | (nx <= ny))]
    return nx, ny, nrho


def _run_claims(m, ip, run, nx, ny, nrho, *, moving, f, ct8, running, stopping):
    """Claims on the point, the sector and the counters of a running quadrant."""
    X, Y, s2 = run.x, run.y, run.sector2
    step = ip.step
    m.d.comb += [
        Assert(~ip.error | (ip.in33 & ~ip.ready), "error: a start refused"),
        Assert(~ip.error | running, "a start is refused only while a run is in progress"),
        Assert(running == ip.busy, "busy is trigger 4"),
        Assert(~step.any() | running, "no step outside a run"),
    ]
    with m.If(running):
        m.d.comb += [
            Assert(X >= 1, "X >= 1 while running"),
            Assert(run.m0 < (1 << (len(run.m0) - 1)), "the start's coordinates were below "
                                                      "2**(width - 1)"),
            Assert(s2 == (Y >= X), "the sector is Y >= X"),
            Assert(ip.trigger16.q == s2, "trigger 16: the sector"),
            Assert(Mux(s2, X + Y <= 2 * run.m0 + 1, (Y < X) & (X <= run.m0)),
                   "the point stays within the start's reach"),
            Assert(ip.counter7.q == Mux(s2, X - 1, Y), "counter 7: Y, then X - 1"),
            Assert(ct8 == Mux(s2, X - Y, X - Y - 1), "counter 8: X - Y - 1, then X - Y"),
            Assert(f == run.rho + Mux(s2, 2 * X - Y, X - 2 * Y) - 2,
                   "adder 1: floor(F1), then floor(F2), of the point"),
            Assert(_bound(run.rho, X, Y), "the point is within half a step of the circle"),
        ]
        with m.If(moving):
            m.d.comb += [
                Assert(step.any(), "a move at every step pulse"),
                Assert(Mux(s2, step[0], step[1]), "sector 1: Y or D; sector 2: D or X"),
            ]
        with m.If(step.any() & ~s2 & (nx <= ny)):
            m.d.comb += Assert((nx - ny == 0) | (nx - ny == -1),
                               "the switch-over comes at X - Y = 0 or -1")
        with m.If(step.any() & (nx == 0)):
            m.d.comb += [
                Assert(stopping, "the run ends with the step to X = 0"),
                Assert(_bound(nrho, nx, ny), "it ends within half a step of the circle"),
            ]
    with m.If(~running):
        m.d.comb += [
            Assert(ip.adder1.q == 0, "idle: adder 1 clear"),
            Assert(ip.counter7.q == 0, "idle: counter 7 clear"),
            Assert(ip.counter8.q == 0, "idle: counter 8 clear"),
            Assert(~ip.trigger16.q, "idle: trigger 16 clear"),
            Assert(ip.ready, "idle: ready"),
        ]


class CircularInterpolatorFastProperties(Elaboratable):
    """The claims above on :class:`CircularInterpolatorFast` with free starts (inputs 29-31
    and 34 formed from ``(X, Y, residue)``), free start, stop and generator enable.

    Parameters
    ----------
    width, period
        As :class:`CircularInterpolatorFast`.
    interpolator
        The design under proof (default: one made from the parameters).
    """

    def __init__(self, *, width=24, period=1, interpolator=None):
        self.width = width
        self.interpolator = interpolator or CircularInterpolatorFast(width=width,
                                                                     period=period)

    def elaborate(self, platform):
        m = Module()
        w = self.width
        m.submodules.interpolator = ip = self.interpolator
        start, x, y, residue = _free_start(m, ip, w)
        run = _Run(w)
        running = ip.trigger4.q
        nx, ny, nrho = _follow(m, run, start=start, x=x, y=y, residue=residue, step=ip.step,
                               running=running, w=w)
        stop_now = running & ip.in32
        m.d.comb += Assert(ip.done == (running & (ip.in32 | (ip.step[0] & (nx == 0)))),
                           "done: input 32, or the step to X = 0")
        _run_claims(m, ip, run, nx, ny, nrho, moving=running & ip.generator5.o,
                    f=ip.adder1.q, ct8=ip.counter8.q, running=running,
                    stopping=ip.done | stop_now)
        _operand_claims(m, ip, run, running=running)
        return m


def _operand_claims(m, ip, run, *, running):
    """The one-step-per-clock core's own registers: the two operands of the next step (the
    switch-over correction folded in), the flags ``X - Y = 1, 2`` of sector 1, the choices of
    the state (by the core's own decoding of it: these tie the register for the induction; the
    claims are on the operands) and counter 7's zero, each tied to the point."""
    X, Y, s2 = run.x, run.y, run.sector2
    d = Signal(signed(len(X) + 1), name="point_d")
    m.d.comb += d.eq(X - Y)
    neg = Mux(s2, 2 * X - 3, Mux(d == 1, 2 * Y - 2, Mux(d == 2, 2 * Y + 1, 2 * d - 5)))
    pos = Mux(s2, 2 * d - 5, Mux(d == 1, -1, -(2 * Y + 3)))
    choices = _choices(m, s2, [d == k for k in range(1, 5)])
    with m.If(running):
        m.d.comb += [
            Assert(ip.operand_neg == neg, "operand for F < 0: D (sector 1), X (sector 2)"),
            Assert(ip.operand_pos == pos, "operand for F >= 0: Y (sector 1), D (sector 2)"),
            Assert(ip.near == Cat(*(~s2 & (d == k) for k in range(1, 3))),
                   "flags: sector 1 and X - Y = 1, 2"),
            Assert(ip.choices.as_value() == choices.as_value(),
                   "choices: how each sign moves the operands on, of the point's state"),
            Assert(ip.last7 == (ip.counter7.q == 0), "flag: counter 7 holds 0"),
        ]


class CircularInterpolatorProperties(Elaboratable):
    """The claims above on the faithful :class:`CircularInterpolator`, with its generator
    running at its own rate (``tick`` high: the patent's free-running generator 5) and free
    starts and stops. Between a step and the next generator pulse the step's operand, and
    after a switch-over the correction, are on their way through the delay elements; the
    claims on adder 1, the counters and trigger 16 are made at the *settled* clocks: a
    generator pulse of a running quadrant that extender 25 does not hold off. The claims on
    the steps are made in every clock.

    Parameters
    ----------
    width, timing
        As :class:`CircularInterpolator`.
    interpolator
        The design under proof (default: one made from the parameters).
    """

    def __init__(self, *, width=24, timing=None, interpolator=None):
        self.width = width
        self.interpolator = interpolator or CircularInterpolator(width=width, timing=timing)

    def elaborate(self, platform):
        m = Module()
        w = self.width
        m.submodules.interpolator = ip = self.interpolator
        period = ip.timing.period
        start, x, y, residue = _free_start(m, ip, w)
        m.d.comb += Assume(ip.tick)
        phase = Signal(range(period), name="phase")           # clocks since reset, mod period
        m.d.sync += phase.eq(Mux(phase == period - 1, 0, phase + 1))
        run = _Run(w)
        running = ip.trigger4.q
        nx, ny, nrho = _follow(m, run, start=start, x=x, y=y, residue=residue, step=ip.step,
                               running=running, w=w)
        X, Y, s2 = run.x, run.y, run.sector2
        step = ip.step
        pulse = ip.generator5.o
        settled = running & pulse & ~ip.extender25.o
        ended = Signal(name="ended")                          # the step to X = 0 was made
        with m.If(start):
            m.d.sync += ended.eq(0)
        with m.Elif(running & step.any() & (nx == 0)):
            m.d.sync += ended.eq(1)
        m.d.comb += [
            Assert(ip.generator5.armed == (phase == 0), "generator 5: a pulse every period"),
            Assert(~ip.error | (ip.in33 & ~ip.ready), "error: a start refused"),
            Assert(running == ip.busy, "busy is trigger 4"),
            Assert(~step.any() | (running & pulse), "a step only at a pulse of a run"),
        ]
        with m.If(running):
            m.d.comb += [
                Assert(run.m0 < (1 << (w - 1)), "the start's coordinates were below "
                                                "2**(width - 1)"),
                Assert(X >= Mux(ended, 0, 1), "X >= 1 until the last step"),
                Assert(ended == (X == 0), "ended: X = 0"),
                Assert(s2 == (Y >= X), "the sector is Y >= X"),
                Assert(Mux(s2, X + Y <= 2 * run.m0 + 1, (Y < X) & (X <= run.m0)),
                       "the point stays within the start's reach"),
                Assert(_bound(run.rho, X, Y), "the point is within half a step of the circle"),
                Assert(~ip.done | ended | ip.in32, "the run ends only after the step to X = 0"),
            ]
            with m.If(settled & ~ended):
                m.d.comb += [
                    Assert(ip.trigger16.q == s2, "settled: trigger 16 is the sector"),
                    Assert(ip.counter7.q == Mux(s2, X - 1, Y), "settled: counter 7"),
                    Assert(ones_value(ip.counter8.q, w + 1) == Mux(s2, X - Y, X - Y - 1),
                           "settled: counter 8"),
                    Assert(ones_value(ip.adder1.q, w + 4)
                           == run.rho + Mux(s2, 2 * X - Y, X - 2 * Y) - 2,
                           "settled: adder 1 holds floor(F) of the point"),
                    Assert(step.any(), "settled: a move at the pulse"),
                    Assert(Mux(s2, step[0], step[1]), "sector 1: Y or D; sector 2: D or X"),
                ]
            with m.If(step.any() & ~s2 & (nx <= ny)):
                m.d.comb += Assert((nx - ny == 0) | (nx - ny == -1),
                                   "the switch-over comes at X - Y = 0 or -1")
            with m.If(step.any() & (nx == 0)):
                m.d.comb += Assert(_bound(nrho, nx, ny),
                                   "it ends within half a step of the circle")
        with m.If(~running):
            m.d.comb += [
                Assert(ip.adder1.q == 0, "idle: adder 1 clear"),
                Assert(ip.counter7.q == 0, "idle: counter 7 clear"),
                Assert(ip.counter8.q == 0, "idle: counter 8 clear"),
                Assert(~ip.trigger16.q, "idle: trigger 16 clear"),
            ]
        return m
