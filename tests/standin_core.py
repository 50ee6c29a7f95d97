"""A stand-in line core, with its model and step-level trajectory, in one file.

It shows what a new variant takes: a component with a :class:`~kontur.hdl.line.LineCoreSignature`,
a cycle model with ``evaluate``/``cycle``/``reset``/``state``, a step function, a bound on its
clocks (it makes more steps than a segment's longer projection), and one
:class:`kontur.registry.Variant` entry (:data:`VARIANT`). The trajectory is a staircase: every X
step first, then every Y step, one step per permission; a step is never diagonal.
"""

from amaranth import *
from amaranth.lib import wiring

from kontur.hdl.engine import permit
from kontur.hdl.line import LineCoreSignature
from kontur.sim.models.engine import permit as permit_model
from kontur.sim.models.linear import check_line
from kontur.registry import Variant

__all__ = ["StaircaseCore", "StaircaseCoreModel", "staircase", "VARIANT"]


class StaircaseCore(wiring.Component):
    """X steps, then Y steps, one per permission; a segment prepared while another runs."""

    def __init__(self, *, width=16):
        super().__init__(LineCoreSignature(width))

    def elaborate(self, platform):
        m = Module()
        w = self.signature.width
        full = Signal()
        prepared_x, prepared_y = Signal(w), Signal(w)
        left_x, left_y = Signal(w), Signal(w)
        running = Signal()
        step = Signal(2)
        last = Signal()
        take = Signal()
        empty = (prepared_x == 0) & (prepared_y == 0)
        # A segment of length zero ends when it starts: it waits for an idle clock, so that
        # two segments never end in one clock.
        m.d.comb += [
            step.eq(Mux(self.feed.due & self.feed.tick, Mux(left_x != 0, 0b01, 0b10), 0)),
            last.eq(step.any() & ((left_x + left_y) == 1)),
            take.eq(full & (~running | (last & ~empty)) & ~self.abort),
            self.cmd.ready.eq(~full | take),
        ]
        permit(m, self.feed, armed=1, running=running, abort=self.abort)
        with m.If(self.cmd.valid & self.cmd.ready):
            m.d.sync += [full.eq(1), prepared_x.eq(self.cmd.payload.x),
                         prepared_y.eq(self.cmd.payload.y)]
        with m.Elif(take | self.abort):
            m.d.sync += full.eq(0)
        with m.If(take):
            m.d.sync += [left_x.eq(prepared_x), left_y.eq(prepared_y), running.eq(~empty)]
        with m.Elif(self.abort | last):
            m.d.sync += [running.eq(0), left_x.eq(0), left_y.eq(0)]
        with m.Elif(step[0]):
            m.d.sync += left_x.eq(left_x - 1)
        with m.Elif(step[1]):
            m.d.sync += left_y.eq(left_y - 1)
        m.d.comb += [
            self.feed.diagonal.eq(0),
            self.step.eq(step),
            self.start.eq(take),
            self.done.eq((running & (last | self.abort)) | (take & empty)),
            self.busy.eq(full | running),
        ]
        return m


class StaircaseCoreModel:
    """Clock-by-clock model of :class:`StaircaseCore`."""

    def __init__(self, *, width=16):
        self.width = width
        self.reset()

    def reset(self):
        self.prepared = None
        self.left = (0, 0)
        self.running = 0

    def state(self):
        return {"left_x": self.left[0], "left_y": self.left[1]}

    def evaluate(self, *, tick=1, abort=0):
        due, _ = permit_model(tick, armed=1, running=self.running, abort=abort)
        step = (1 if self.left[0] else 2) if due and tick else 0
        last = int(step != 0 and sum(self.left) == 1)
        empty = self.prepared == (0, 0)
        take = int(self.prepared is not None and (not self.running or (last and not empty))
                   and not abort)
        return {"step": step, "start": take,
                "done": int((self.running and (last or abort)) or (take and empty)),
                "ready": int(self.prepared is None or take),
                "busy": int(self.prepared is not None or self.running),
                "due": due, "diagonal": 0, "_last": last}

    def cycle(self, *, tick=1, abort=0, valid=0, payload=None):
        outputs = self.evaluate(tick=tick, abort=abort)
        state = self.state()
        if outputs["start"]:
            self.left = self.prepared
            self.running = int(self.prepared != (0, 0))
        elif abort or outputs["_last"]:
            self.running, self.left = 0, (0, 0)
        elif outputs["step"] == 1:
            self.left = (self.left[0] - 1, self.left[1])
        elif outputs["step"] == 2:
            self.left = (self.left[0], self.left[1] - 1)
        if valid and outputs["ready"]:
            self.prepared = (payload["x"], payload["y"])
        elif outputs["start"] or abort:
            self.prepared = None
        del outputs["_last"]
        return outputs, state


def staircase(x, y, *, width=16):
    """The staircase's steps, ``(dx, dy)``."""
    check_line(x, y, width)
    return [(1 if x > 0 else -1, 0)] * abs(x) + [(0, 1 if y > 0 else -1)] * abs(y)


def staircase_clocks(payload, width, **params):
    """Clocks at full feed: a step each, more than the longer projection (hence declared)."""
    return abs(payload["x"]) + abs(payload["y"]) + 2


#: The variant, for :func:`kontur.registry.register` (or ``KONTUR_EXTRA_VARIANTS=
#: tests.standin_core:VARIANT``). Its path's deviation grows with the segment (the corner of
#: the staircase): it declares no accuracy bound.
VARIANT = Variant("line", "staircase", "stand-in: every X step, then every Y step",
                  StaircaseCore, StaircaseCoreModel, staircase, clocks=staircase_clocks)
