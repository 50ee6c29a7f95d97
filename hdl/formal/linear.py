"""Properties of SU 1571551 (``hdl/linear.py``): :class:`LinearInterpolator` and
:class:`LinearCore`.

The harness keeps a record of the frame the interpolator accepted (``a = max(|X|, |Y|)``,
``b = min``, which axis is long, the end point) and of the steps made since (``n`` moves of
the long axis, ``k`` of them combined, ``sx``, ``sy`` per axis), and the scaled deviation of
the current point from the line, ``E = 2(n·b - k·a)`` (``E/2a`` is how far the true short
coordinate ``n·b/a`` lies from the point's ``k``). It is kept by its own increments
(``+2b`` for a long step, ``+2b - 2a`` for a combined one), which is the identity
``E(n + 1, k + dk) = E(n, k) + 2b - 2a·dk``; with ``bounded`` the harness also claims
``E = 2(n·b - k·a)`` with the products themselves.

Claims, in every clock (``busy`` is trigger 14, a frame running):

* a step only at a generator pulse of a running frame, and every such pulse moves the long
  axis by one and the short one by at most one;
* counters 1 and 2 hold the long-only and combined steps left (``C1``, ``C2 - 1``); adder 3
  holds ``⌊F⌋`` of eq. (1) (``exact``: ``2F = a - 2b - E``; registers 22' and 23' hold
  ``a - b`` and ``b - 1``, whose inverse code is ``-b``) or of eq. (5) (``device``:
  ``F -= C2`` on a long step, ``F += C1`` on a combined one, from the counts);
* ``last_step`` is AND 9's decode of the counters (1 and -1, or 0 and 0: one step left) while
  a frame runs, and is clear otherwise;
* the frame ends (``done``) exactly at the generator pulse that finds one step left
  (``C1, C2`` = 1, 0 or 0, 1), which is its ``a``-th step: the long axis ends on its end
  coordinate; a last step of the kind left (long-only at 1, 0, combined at 0, 1) ends on
  ``|X|`` and ``|Y|``; with ``bounded`` (which also claims that no budget
  runs out early) every frame ends on ``|X|`` and ``|Y|``. A frame of length zero ends in the
  clock it starts, with no step; idle, the counters, adder 3, trigger 15 and ``last_step``
  are clear;
* a start while a frame runs is refused (``error``) and changes nothing: the claims above are
  about the frame accepted, whatever starts are refused meanwhile;
* ``exact`` only: ``-a < E <= a`` after every step: every point is within ``0.5 cos α`` of
  the line (``2|x·Y - y·X| <= max(|X|, |Y|)``), and at a tie (``E = a``, the midpoint on the
  line) the long step was taken (eq. 1's ``F >= 0``), never the combined one (``E = -a``).

Why the end point is claimed for the last step of the kind left: AND 9 no longer looks at the
kind of the passing step (it is the pulse and ``last_step``, a decode of the counters before
the step), so a frame ends at the pulse with one step left whatever that step is, and ends on
the end point when the step is the one its budgets leave, i.e. when no budget ran out early.
That needs the products (see ``docs/formal.md``): proven with them at width 4 (``bounded``),
for ``exact`` at every width on paper from the claims proven at width 16.

:class:`LinearCore` ends a segment of length zero itself, in an idle clock of the interpolator
(which it builds with ``zero_frames=False``): claimed, and that input 26 never comes with
inputs 22 and 23 both zero.
"""

from amaranth import *
from amaranth.hdl import Assert, Assume

from ..linear import LinearCore, LinearInterpolator
from ._util import free, state_registers

__all__ = ["LinearInterpolatorProperties", "LinearCoreProperties"]


def _inputs(x, y, w):
    """The patent's inputs 22-25 for the magnitudes ``x``, ``y`` (as ``LinearCore`` forms
    them, from the definitions: ``||X| - |Y||``, ``min``, ``⌊max/2 - min⌋``, ``|X| >= |Y|``)."""
    x_long = x >= y
    long_ = Mux(x_long, x, y)
    short = Mux(x_long, y, x)
    return (long_ - short)[:w], short, (long_ - 2 * short) >> 1, x_long


class _Frame:
    """The harness's record of the running frame and of its steps."""

    def __init__(self, m, w):
        self.a = Signal(w, name="frame_a")             # long projection
        self.b = Signal(w, name="frame_b")             # short projection
        self.x_long = Signal(name="frame_x_long")
        self.x = Signal(w, name="frame_x")             # end point |X|, |Y|
        self.y = Signal(w, name="frame_y")
        self.n = Signal(w + 1, name="steps_n")         # steps made (long-axis moves)
        self.k = Signal(w + 1, name="steps_k")         # combined steps made
        self.sx = Signal(w + 1, name="steps_x")
        self.sy = Signal(w + 1, name="steps_y")
        self.e = Signal(signed(w + 4), name="deviation_e")   # 2(n·b - k·a)
        self.g = Signal(w + 2, name="device_2f")     # 2F of eq. (5), modulo 2**(w + 2)

    def follow(self, m, *, start, x, y, step, running):
        """Take a frame at ``start``; count the ``step`` pulses while ``running``."""
        long_step = Mux(self.x_long, step[0], step[1])
        short_step = Mux(self.x_long, step[1], step[0])
        w = len(self.a)
        c1 = ((self.a - self.b) - (self.n - self.k))[:w + 1]   # long-only steps left
        c2 = (self.b - self.k)[:w + 1]                        # combined steps left
        with m.If(start):
            x_long = x >= y
            a = Mux(x_long, x, y)
            b = Mux(x_long, y, x)
            m.d.sync += [
                self.a.eq(a), self.b.eq(b), self.x_long.eq(x_long), self.x.eq(x),
                self.y.eq(y), self.n.eq(0), self.k.eq(0), self.sx.eq(0), self.sy.eq(0),
                self.e.eq(0), self.g.eq(a - 2 * b),
            ]
        with m.Elif(running & long_step):
            m.d.sync += [
                self.n.eq(self.n + 1), self.k.eq(self.k + short_step),
                self.sx.eq(self.sx + step[0]), self.sy.eq(self.sy + step[1]),
                self.e.eq(self.e + 2 * self.b - Mux(short_step, 2 * self.a, 0)),
                self.g.eq(Mux(short_step, self.g + 2 * c1, self.g - 2 * c2)[:w + 2]),
            ]
        return long_step, short_step, c1, c2


def _interpolator_claims(m, ip, frame, variant, *, zero, long_step, short_step, c1, c2,
                         bounded):
    """The claims on a :class:`LinearInterpolator` and the harness's ``frame``; ``zero``: a
    frame of length zero is started in this clock. Counts and budgets are compared modulo
    ``2**(width + 1)`` (the counters' width): these claims hold whatever the budgets; with
    ``bounded`` the budgets are also claimed never to run out before the frame ends (the
    claim that needs the products, proven at small widths)."""
    w = len(frame.a)
    running = ip.trigger14.q
    pulse = ip.generator4.o
    step = ip.step
    a, b, n, k = frame.a, frame.b, frame.n, frame.k
    q1, q2 = ip.counter1.q, ip.counter2.q
    # AND 9's decode of the counters (the old AND 9 made it of the contents and the kind of the
    # passing pulse; now the flip-flop last_step keeps it from the contents alone).
    and9_decode = ((q1 == 1) & q2.all()) | (~q1.any() & ~q2.any())
    long_left = (c1 == 1) & (c2 == 0)               # one step left, a long-only one
    combined_left = (c1 == 0) & (c2 == 1)           # one step left, a combined one
    m.d.comb += [
        Assert(running == ip.busy, "busy is trigger 14"),
        Assert(~step.any() | (running & pulse), "a step only at a pulse of a running frame"),
        Assert(~(running & pulse) | long_step, "every pulse of a running frame moves the "
                                               "long axis"),
        Assert(~ip.error | (ip.in26 & ~ip.ready), "error: a start refused"),
        Assert(~ip.error | running, "a start is refused only while a frame runs"),
        Assert(ip.last_step == (running & and9_decode),
               "last_step: AND 9's decode of the counters while a frame runs"),
    ]
    with m.If(zero):
        m.d.comb += Assert(ip.done & ~step.any(), "a zero-length frame ends at once, no step")
    with m.If(~running):
        m.d.comb += [
            Assert(ip.counter1.q == 0, "idle: counter 1 clear"),
            Assert(ip.counter2.q == 0, "idle: counter 2 clear"),
            Assert(ip.adder3.q == 0, "idle: adder 3 clear"),
            Assert(~ip.trigger15.q, "idle: trigger 15 clear"),
            Assert(ip.ready, "idle: ready"),
            Assert(~ip.done | zero, "idle: done only for a zero-length frame"),
        ]
    with m.If(running):
        m.d.comb += [
            Assert(a != 0, "a running frame has steps"),
            Assert(frame.x_long == (frame.x >= frame.y), "the long axis of the frame"),
            Assert(a == Mux(frame.x_long, frame.x, frame.y), "a = max(|X|, |Y|)"),
            Assert(b == Mux(frame.x_long, frame.y, frame.x), "b = min(|X|, |Y|)"),
            Assert(ip.counter1.q.as_unsigned() == c1, "counter 1: long-only steps left"),
            Assert(ip.counter2.q.as_unsigned() == (c2 - 1)[:w + 1],
                   "counter 2: combined steps left, minus one"),
            Assert(ip.trigger15.q == frame.x_long, "trigger 15: X is the long axis"),
            Assert(frame.sx == Mux(frame.x_long, n, k), "X steps counted"),
            Assert(frame.sy == Mux(frame.x_long, k, n), "Y steps counted"),
            Assert(ip.done == (pulse & (long_left | combined_left)),
                   "done exactly at the pulse that finds one step left"),
        ]
        ends_x = (frame.sx + step[0])[:w + 1] == frame.x
        ends_y = (frame.sy + step[1])[:w + 1] == frame.y
        with m.If(ip.done):
            m.d.comb += Assert(Mux(frame.x_long, ends_x, ends_y),
                               "the frame ends with its a-th step, the long axis on its end")
        with m.If(ip.done & ((long_left & ~short_step) | (combined_left & short_step))):
            m.d.comb += [
                Assert(ends_x, "a last step of the kind left ends on |X|"),
                Assert(ends_y, "a last step of the kind left ends on |Y|"),
            ]
        if bounded:
            m.d.comb += [
                Assert(frame.e == 2 * (n * b - k * a), "E = 2(n b - k a), with the products"),
                Assert(n < a, "fewer than a steps made while running"),
                Assert(k <= b, "the combined budget never runs out early"),
                Assert(n - k <= a - b, "the long-only budget never runs out early"),
            ]
            with m.If(ip.done):
                m.d.comb += [
                    Assert(Mux(long_left, ~short_step, short_step),
                           "the last step is of the kind left"),
                    Assert(ends_x, "the frame ends on |X|"),
                    Assert(ends_y, "the frame ends on |Y|"),
                ]
        if variant == "exact":
            m.d.comb += [
                Assert(ip.reg22 == a - b, "register 22: a - b"),
                Assert(ip.reg23 == b - 1, "register 23: b - 1 (its inverse code is -b)"),
                Assert(ip.adder3.q.as_unsigned() == ((a - 2 * b - frame.e) >> 1)[:w + 1],
                       "adder 3: eq. (1)'s F"),
                Assert((frame.e > -a) & (frame.e <= a),
                       "every point within 0.5 cos(alpha), the tie along the long axis"),
            ]
        else:
            m.d.comb += Assert(ip.adder3.q.as_unsigned() == (frame.g >> 1)[:w + 1],
                               "adder 3: eq. (5)'s F")


class LinearInterpolatorProperties(Elaboratable):
    """The claims above on :class:`LinearInterpolator` with every input free: the end point
    ``(X, Y)`` of every clock's start pulse, the start pulse (input 26) and the generator's
    enable; inputs 22-25 are formed from ``X`` and ``Y``.

    Parameters
    ----------
    width, variant, period
        As :class:`LinearInterpolator`.
    interpolator : :class:`LinearInterpolator`
        The design under proof (default: one made from the parameters); a test passes a broken
        one to see the proof fail.
    """

    def __init__(self, *, width=16, variant="exact", period=1, interpolator=None,
                 bounded=False):
        self.width = width
        self.variant = variant
        self.bounded = bounded
        self.interpolator = interpolator or LinearInterpolator(width=width, variant=variant,
                                                               period=period)

    def elaborate(self, platform):
        m = Module()
        w = self.width
        m.submodules.interpolator = ip = self.interpolator
        x = Signal(w, name="x")
        y = Signal(w, name="y")
        free(m, x, y, ip.in26, ip.tick)
        in22, in23, in24, in25 = _inputs(x, y, w)
        m.d.comb += [ip.in22.eq(in22), ip.in23.eq(in23), ip.in24.eq(in24), ip.in25.eq(in25)]

        accepted = ip.in26 & ip.ready
        empty = (x == 0) & (y == 0)
        frame = _Frame(m, w)
        long_step, short_step, c1, c2 = frame.follow(
            m, start=accepted & ~empty, x=x, y=y, step=ip.step, running=ip.trigger14.q)
        _interpolator_claims(m, ip, frame, self.variant, zero=accepted & empty,
                             long_step=long_step, short_step=short_step, c1=c1, c2=c2,
                             bounded=self.bounded)
        return m


class LinearCoreProperties(Elaboratable):
    """:class:`LinearCore` with every input free (the segment stream, the feed permission,
    the abort): the interpolator's claims for the segment the core started; a segment taken
    from ``cmd`` is the one started next, unless an abort drops it; ``cmd`` is refused only
    while one is prepared; a step only in a clock of ``tick & due``; ``done`` with the last
    step, and the last step ends on the segment's ``(x, y)`` (as the interpolator's claims
    say); a segment of length zero never reaches the interpolator (input 26 is the start of a
    segment with steps) and starts and ends in an idle clock of it, with no step.

    Parameters
    ----------
    width, variant, period
        As :class:`LinearCore`.
    core : :class:`LinearCore`
        The design under proof (default: one made from the parameters).
    """

    def __init__(self, *, width=16, variant="exact", period=1, core=None, bounded=False):
        self.width = width
        self.variant = variant
        self.bounded = bounded
        self.core = core or LinearCore(width=width, variant=variant, period=period)

    def elaborate(self, platform):
        m = Module()
        w = self.width
        core = self.core
        # The prepared segment's flags (no port shows them apart): it counts, it has steps, it
        # has length zero.
        m.submodules.core, (full, queued, zero_length) = state_registers(
            core, "full", "queued", "empty")
        ip = core.interpolator
        free(m, core.cmd.valid, core.cmd.payload, core.feed.tick, core.abort)

        # The segment taken, until it starts.
        pending = Signal(name="pending")
        px = Signal(w, name="pending_x")
        py = Signal(w, name="pending_y")
        taken = core.cmd.valid & core.cmd.ready
        with m.If(taken):
            m.d.sync += [pending.eq(1), px.eq(core.cmd.payload.x), py.eq(core.cmd.payload.y)]
        with m.Elif(core.start | core.abort):
            m.d.sync += pending.eq(0)

        empty = (px == 0) & (py == 0)
        frame = _Frame(m, w)
        long_step, short_step, c1, c2 = frame.follow(
            m, start=core.start & ~empty, x=px, y=py, step=core.step,
            running=ip.trigger14.q)
        in22, in23, in24, in25 = _inputs(px, py, w)
        m.d.comb += [
            Assert(core.cmd.ready == (~pending | core.start), "cmd refused only while a "
                                                              "segment is prepared"),
            Assert(~core.start | pending, "a start only of a segment taken"),
            Assert(~core.start | ~core.abort, "no start in a clock of abort"),
            Assert(ip.in26 == (core.start & ~empty),
                   "input 26: the start of a segment with steps"),
            Assert(~ip.in26 | ip.in22.any() | ip.in23.any(),
                   "input 26 never with inputs 22 and 23 both zero (zero_frames=False)"),
            Assert(~ip.error, "no start refused by the interpolator"),
            Assert(~core.step.any() | (core.feed.tick & core.feed.due),
                   "a step only in a clock of tick and due"),
            Assert(~core.abort | ~core.step.any(), "no step in a clock of abort"),
            Assert(core.busy == (pending | ip.trigger14.q), "busy: prepared or running"),
            Assert(core.done == (ip.done | (core.start & empty)
                                 | (core.abort & ip.trigger14.q)),
                   "done: the last step, a zero-length segment's start, or an abort of a "
                   "running segment"),
        ]
        with m.If(core.start & empty):
            m.d.comb += Assert(~ip.trigger14.q & ~core.step.any(),
                               "a zero-length segment starts and ends in an idle clock of the "
                               "interpolator, no step")
        m.d.comb += [
            Assert(full == pending, "full: a segment prepared"),
            Assert(queued == (pending & ~empty), "queued: a segment with steps prepared"),
        ]
        with m.If(pending):
            m.d.comb += [
                Assert(zero_length == empty, "prepared: the segment has length zero"),
                Assert(ip.in22 == in22, "prepared: input 22"),
                Assert(ip.in23 == in23, "prepared: input 23"),
                Assert(ip.in24 == in24, "prepared: input 24"),
                Assert(ip.in25 == in25, "prepared: input 25"),
                Assert(ip.one_step == ((px <= 1) & (py <= 1) & ~empty),
                       "prepared: one step, max(|x|, |y|) == 1"),
            ]
        with m.If(~core.abort):
            _interpolator_claims(m, ip, frame, self.variant, zero=C(0),
                                 long_step=long_step, short_step=short_step,
                                 c1=c1, c2=c2, bounded=self.bounded)
        return m
