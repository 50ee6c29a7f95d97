"""Lines in space: SU 1571551's estimating function on every axis against the dominant one.

SU 1571551 traces a line on two axes with one estimating function: every step moves the long
(dominant) axis, and the function's sign says whether the short one moves with it (the
combined step). On three axes the same method keeps one such function per axis, each
against the dominant axis: the dominant axis moves at every step, and each other axis moves
with it when its own function is negative. Every function is the patent's equation (1), the
``exact`` variant of :class:`~kontur.hdl.linear.LinearCore`, with that axis as the short one: it
starts at ``F0 = a/2 - m`` and moves by ``-m`` (the axis stays) or ``a - m`` (the axis moves),
``a`` the dominant projection, ``m`` the axis's own. The dominant axis needs no decision of its
own: with ``m = a`` its function starts at ``-a/2`` and never changes, so it moves at every
step, and the three axes are alike (no multiplexer chooses the dominant one). Each axis is
then within half a step of the line at every step (docs/architecture.md, "The third axis").
"""

from amaranth import *
from amaranth.lib import wiring

from .elements._checks import check_width
from .line import AXIS_NAMES, LineCoreSignature

__all__ = ["SpatialLineCore"]


class SpatialLineCore(wiring.Component):
    """A line core on two or three axes (:class:`~kontur.hdl.line.LineCoreSignature` with
    ``axes``): one step per permission, the dominant axis at every step, each other axis by its
    own estimating function.

    A segment taken from :py:`cmd` is prepared in registers (its magnitudes, the dominant one,
    whether it is empty) and started as soon as the running one makes its last step (in that
    same clock), or in the next clock when the core is idle, so segments follow one another with
    no idle clock; a segment of length zero starts and ends in an idle clock. At its start every
    axis's function is loaded with ``⌊(a - 2m)/2⌋`` (the integer part of ``F0``; the half never
    changes a sign test) and its two increments; a counter counts the ``a`` steps. :py:`feed.due`
    is high while a segment runs; :py:`feed.diagonal` is the number of axes the waiting step
    moves beyond one (0, 1 or 2: a step of length 1, √2 or √3). :py:`abort` stops the running
    segment (:py:`done`) and drops the prepared one.

    Parameters
    ----------
    width : :class:`int`
        Register width: magnitudes up to ``2**width - 1``.
    axes : :class:`int`
        2 or 3 (on two axes its steps are those of ``LinearCore(variant="exact")``).
    """

    def __init__(self, *, width=16, axes=3):
        check_width("Register width", width, minimum=2)
        super().__init__(LineCoreSignature(width, axes))

    @property
    def width(self):
        return self.signature.width

    @property
    def axes(self):
        return self.signature.axes

    def _prepared(self, m):
        """The prepared segment's registers: magnitudes, the dominant one, empty, full."""
        w = self.width
        names = AXIS_NAMES[:self.axes]
        magnitudes = [self.cmd.payload[name] for name in names]
        longest = magnitudes[0]
        for value in magnitudes[1:]:
            longest = Mux(longest >= value, longest, value)
        p = {
            "full": Signal(name="full"),
            "queued": Signal(name="queued"),             # full, and the segment has steps
            "empty": Signal(name="prepared_empty", reset_less=True),
            "longest": Signal(w, name="prepared_longest", reset_less=True),
            "m": [Signal(w, name=f"prepared_{name}", reset_less=True) for name in names],
        }
        p["nonzero"] = nonzero = Cat(*magnitudes).any()
        # The registers follow cmd whenever it may be taken (``full`` says they count).
        with m.If(self.cmd.ready):
            m.d.sync += [
                p["empty"].eq(~nonzero),
                p["longest"].eq(longest),
                *(reg.eq(value) for reg, value in zip(p["m"], magnitudes)),
            ]
        return p

    def elaborate(self, platform):
        m = Module()
        w, axes = self.width, self.axes
        p = self._prepared(m)

        running = Signal(name="running")
        left = Signal(w, name="left")     # steps left, the waiting one included
        functions = [Signal(signed(w + 1), name=f"function_{name}")
                     for name in AXIS_NAMES[:axes]]
        stays = [Signal(w, name=f"stays_{name}") for name in AXIS_NAMES[:axes]]   # m
        moves = [Signal(w, name=f"moves_{name}") for name in AXIS_NAMES[:axes]]   # a - m
        moving = Cat(*(function[-1] for function in functions))    # F < 0: the axis moves

        stepping = Signal()
        ending = Signal()
        take = Signal()
        go = Signal()
        m.d.comb += [
            self.feed.due.eq(running & ~self.abort),
            stepping.eq(self.feed.due & self.feed.tick),
            ending.eq(stepping & (left == 1)),
            take.eq(~self.abort & ((p["full"] & ~running) | (p["queued"] & ending))),
            go.eq(take & ~p["empty"]),
            self.cmd.ready.eq(~p["full"] | take),
            self.feed.diagonal.eq(sum(moving[axis] for axis in range(axes)) - 1),
            self.step.eq(Mux(stepping, moving, 0)),
            self.start.eq(take),
            self.done.eq(ending | (take & p["empty"]) | (self.abort & running)),
            self.busy.eq(p["full"] | running),
        ]
        with m.If(take | self.abort):
            m.d.sync += [p["full"].eq(0), p["queued"].eq(0)]
        with m.If(self.cmd.valid & self.cmd.ready):
            m.d.sync += [p["full"].eq(1), p["queued"].eq(p["nonzero"])]

        a = p["longest"]
        with m.If(go):
            m.d.sync += [running.eq(1), left.eq(a)]
            for function, stay, move, mag in zip(functions, stays, moves, p["m"]):
                m.d.sync += [
                    function.eq((a - (mag << 1)) >> 1),
                    stay.eq(mag),
                    move.eq(a - mag),
                ]
        with m.Elif(self.abort | ending):
            m.d.sync += running.eq(0)
        with m.If(stepping & ~go):
            m.d.sync += left.eq(left - 1)
            for axis, (function, stay, move) in enumerate(zip(functions, stays, moves)):
                m.d.sync += function.eq(Mux(moving[axis], function + move, function - stay))
        return m
