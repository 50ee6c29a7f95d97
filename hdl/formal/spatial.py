"""Properties of lines in space (``hdl/spatial.py``): :class:`SpatialLineCore`.

The harness keeps a record of the segment the core took (its magnitudes ``m``, the dominant
one ``a``) and, from its start, of the steps made: ``n`` (steps), ``p`` (moves per axis), and
per axis the scaled deviation ``E = 2(n·m - p·a)`` (``E/2a`` is how far the line's coordinate
``n·m/a`` lies from the point's ``p``), kept by its own increments and claimed equal to the
products (``bounded``, small widths: the products make the proof slow).

Claims, in every clock, with every input free (the segment stream, the feed permission, the
abort):

* ``cmd`` is refused only while a segment is prepared; a start only of a segment taken, never
  in a clock of abort; the prepared registers hold the segment taken (its magnitudes, the
  dominant one, whether it is empty);
* a step in exactly the clocks of ``tick`` and ``due`` (``due``: running and no abort), none in a
  clock of abort; ``diagonal`` with a step is the number of axes it moves, less one;
* while a segment runs: ``left = a - n`` steps are left (``n < a``); every axis's registers
  hold ``m`` and ``a - m``; its function is ``⌊(a - 2m - E)/2⌋`` and **``-a < E <= a``**: the
  axis is within half a step of the line's point at the same dominant coordinate (the bound
  of docs/architecture.md, "The third axis"); a step moves the dominant axis;
* ``done`` is the last step (the ``a``-th), a zero-length segment's start (in an idle clock,
  no step), or an abort of a running segment;
* ``bounded`` only: ``E = 2(n·m - p·a)`` with the products, and the last step ends on ``(x,
  y, z)`` (at every width it follows from ``-a < E <= a`` at ``n = a``: ``E = 2a(m - p)``).
"""

from amaranth import *
from amaranth.hdl import Assert

from ..line import AXIS_NAMES
from ..spatial import SpatialLineCore
from ._util import free, state_registers

__all__ = ["SpatialLineCoreProperties"]


class SpatialLineCoreProperties(Elaboratable):
    """:class:`SpatialLineCore` with every input free: the claims above.

    Parameters
    ----------
    width, axes
        As :class:`SpatialLineCore`.
    bounded : :class:`bool`
        Claim ``E = 2(n·m - p·a)`` with the products, and the end point (the products make
        the proof slow: small widths only).
    core : :class:`SpatialLineCore`
        The design under proof (default: one made from the parameters).
    """

    def __init__(self, *, width=6, axes=3, core=None, bounded=False):
        self.width = width
        self.axes = axes
        self.bounded = bounded
        self.core = core or SpatialLineCore(width=width, axes=axes)

    def elaborate(self, platform):
        m = Module()
        w, axes = self.width, self.axes
        core = self.core
        names = AXIS_NAMES[:axes]
        fragment, registers = state_registers(
            core, "full", "queued", "prepared_empty", "prepared_longest", "running", "left",
            *(f"{kind}_{name}" for kind in ("prepared", "function", "stays", "moves")
              for name in names))
        m.submodules.core = fragment
        full, queued, prepared_empty, prepared_longest, running, left = registers[:6]
        prepared, functions, stays, moves = (registers[6 + k * axes:6 + (k + 1) * axes]
                                             for k in range(4))
        free(m, core.cmd.valid, core.cmd.payload, core.feed.tick, core.abort)

        # The segment taken, until it starts.
        pending = Signal(name="pending")
        pm = [Signal(w, name=f"pending_{name}") for name in names]
        with m.If(core.cmd.valid & core.cmd.ready):
            m.d.sync += [pending.eq(1), *(r.eq(core.cmd.payload[name])
                                          for r, name in zip(pm, names))]
        with m.Elif(core.start | core.abort):
            m.d.sync += pending.eq(0)
        empty = Cat(*pm) == 0
        longest = pm[0]
        for value in pm[1:]:
            longest = Mux(longest >= value, longest, value)

        # The running segment and its steps.
        a = Signal(w, name="frame_a")
        mag = [Signal(w, name=f"frame_{name}") for name in names]
        n = Signal(w + 1, name="steps_n")
        p = [Signal(w + 1, name=f"steps_{name}") for name in names]
        e = [Signal(signed(2 * w + 4), name=f"deviation_{name}") for name in names]
        with m.If(core.start & ~empty):
            m.d.sync += [a.eq(longest), n.eq(0), *(r.eq(v) for r, v in zip(mag, pm)),
                         *(r.eq(0) for r in p), *(r.eq(0) for r in e)]
        with m.Elif(core.step.any()):
            m.d.sync += n.eq(n + 1)
            for axis in range(axes):
                m.d.sync += [
                    p[axis].eq(p[axis] + core.step[axis]),
                    e[axis].eq(e[axis] + 2 * mag[axis] - Mux(core.step[axis], 2 * a, 0)),
                ]

        m.d.comb += [
            Assert(core.cmd.ready == (~pending | core.start),
                   "cmd refused only while a segment is prepared"),
            Assert(~core.start | pending, "a start only of a segment taken"),
            Assert(~core.start | ~core.abort, "no start in a clock of abort"),
            Assert(full == pending, "full: a segment prepared"),
            Assert(queued == (pending & ~empty), "queued: a segment with steps prepared"),
            Assert(core.feed.due == (running & ~core.abort), "due: running, no abort"),
            Assert(core.step.any() == (core.feed.tick & core.feed.due),
                   "a step in exactly the clocks of tick and due"),
            Assert(core.busy == (pending | running), "busy: prepared or running"),
            Assert(core.done == ((core.step.any() & (left == 1)) | (core.start & empty)
                                 | (core.abort & running)),
                   "done: the last step, a zero-length segment's start, or an abort"),
        ]
        with m.If(core.step.any()):
            m.d.comb += Assert(core.feed.diagonal == sum(core.step[i] for i in range(axes)) - 1,
                               "diagonal: the axes the step moves, less one")
        with m.If(core.start & empty):
            m.d.comb += Assert(~running & ~core.step.any(),
                               "a zero-length segment starts and ends in an idle clock")
        with m.If(pending):
            m.d.comb += [
                Assert(prepared_empty == empty, "prepared: empty"),
                Assert(prepared_longest == longest, "prepared: the dominant magnitude"),
                *(Assert(r == v, f"prepared: |{name}|") for r, v, name in zip(prepared, pm, names)),
            ]
        dominant = mag[0]
        for value in mag[1:]:
            dominant = Mux(dominant >= value, dominant, value)
        with m.If(running):
            m.d.comb += [
                Assert(a == dominant, "a: the dominant magnitude"),
                Assert(left == a - n, "left: the steps left"),
                Assert(n < a, "fewer steps made than the segment has"),
            ]
            for axis, name in enumerate(names):
                mi, ei = mag[axis], e[axis]
                m.d.comb += [
                    Assert(stays[axis] == mi, f"{name}: its magnitude"),
                    Assert(moves[axis] == a - mi, f"{name}: the dominant less its magnitude"),
                    Assert((ei > -a) & (ei <= a), f"{name}: within half a step of the line"),
                    Assert(functions[axis] == ((a - 2 * mi - ei) >> 1),
                           f"{name}: F = floor((a - 2m - E)/2)"),
                ]
                with m.If(core.step.any() & (mi == a)):
                    m.d.comb += Assert(core.step[axis], f"{name}: dominant, moves every step")
                if self.bounded:
                    m.d.comb += Assert(ei == 2 * (n * mi - p[axis] * a),
                                       f"{name}: E = 2(n m - p a)")
                    with m.If(core.step.any() & (left == 1)):
                        m.d.comb += Assert(p[axis] + core.step[axis] == mi,
                                           f"{name}: the last step ends on the end point")
        return m
