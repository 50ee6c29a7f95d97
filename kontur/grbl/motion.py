"""The virtual machine's motion: the golden model's steps played against a clock.

The steps of every move are the step-level models' (:func:`kontur.planner.lattice`, as
``kontur run`` takes them); their times come from the same look-ahead feed plan
(:func:`kontur.planner.plan`, timed as :func:`kontur.machining.execute` times the model's
steps). A move that arrives while others are queued re-plans the moves not yet made (from
the step the machine is at; the moves behind it may now end faster), so the plan of a line
already sent changes as later lines arrive, as in Grbl.

The clock is virtual: it runs ``speed`` times real time (``kontur serve --speed``) and the
override of the move being made (a feed override on feed moves, a rapid override on rapids:
timing changes, the steps do not); a feed hold stops it at once (host-side: the machine
halts between two steps, with no deceleration; the gateware's ramped hold is issue 25's).
"""

import time
from collections import deque
from dataclasses import dataclass, field, replace

from kontur.machining import Job, execute
from kontur.planner import plan

__all__ = ["Block", "Motion"]


@dataclass
class Block:
    """One move in the planner: its kind (``"feed"``, ``"rapid"``, ``"jog"``), the program
    line, its segments on the lattice; ``left``: its steps not yet made."""
    kind: str
    line: int
    segments: list
    left: int = field(init=False)

    def __post_init__(self):
        self.left = sum(len(s.steps) for s in self.segments)


class Motion:
    """Queued blocks made step by step as the virtual clock passes their times.

    :meth:`add` queues a block, :meth:`tick` moves the clock to the present, :meth:`hold`,
    :meth:`resume`, :meth:`cancel` (a jog cancel, a reset) act at once. :attr:`position` is
    where the machine is (steps); :attr:`made` the steps made since the start, :attr:`times`
    their times (s, virtual), :attr:`segments` the segments they belong to (those cut short by
    a cancel listed in :attr:`cut`)."""

    def __init__(self, machine, board, *, speed=1.0, position=(0, 0), clock=time.monotonic):
        self.machine, self.board, self.speed = machine, board, speed
        self.position = tuple(position)
        self.clock = clock
        self.now = 0.0                      # virtual seconds
        self._real = clock()
        self.held = False
        self.overrides = [100, 100, 100]    # feed, rapid, spindle (percent)
        self.blocks = deque()               # not finished, the first being made
        self._queue = deque()               # (segment, block): not finished; the first at _done
        self._done = 0
        self._times = deque()               # virtual times of the steps left, in order
        self._last = 0.0                    # time of the last step made
        self._interval = None               # (length mm, seconds) of the last step
        self._replan_from = None            # blocks added since the last plan: moving then?
        self.made, self.times, self.segments = [], [], []
        self.cut = set()                    # indexes in segments of those cut short

    # ---- the queue ----------------------------------------------------------------------

    def add(self, block):
        """Queue ``block``; everything not yet made is re-planned at the next :meth:`tick`
        (once for all the blocks added meanwhile)."""
        if not block.left:
            return
        if self._replan_from is None:
            self._replan_from = bool(self._times)
        self.blocks.append(block)
        for segment in block.segments:
            self._queue.append((segment, block))

    def _replan(self, moving):
        self._replan_from = None
        window = [segment for segment, _ in self._queue]
        job = Job("served", self.board, self.machine, [], window, plan(window, self.machine))
        times = execute(job, "model").times
        k = self._done
        if k:
            base = self._last - times[k - 1]
        else:
            base = self._last if moving else self.now
        self._times = deque(base + t for t in times[k:])

    @property
    def busy(self):
        """Steps are queued (the machine runs, or would but for a hold)."""
        return bool(self._times) or self._replan_from is not None

    @property
    def kind(self):
        """The kind of the block being made (``None`` when idle)."""
        return self.blocks[0].kind if self.blocks else None

    # ---- time ---------------------------------------------------------------------------

    def _rate(self):
        kind = self.kind
        scale = (self.overrides[0] if kind == "feed" else
                 self.overrides[1] if kind == "rapid" else 100) / 100
        return self.speed * scale

    def tick(self):
        """Move the virtual clock to the present (at the rate of the block being made: ticks
        come every few milliseconds) and make the steps whose time has come."""
        if self._replan_from is not None:
            self._replan(self._replan_from)
        real = self.clock()
        if not self.held:
            self.now += (real - self._real) * self._rate()
            while self._times and self._times[0] <= self.now:
                self._step()
        self._real = real

    def _step(self):
        at = self._times.popleft()
        segment, block = self._queue[0]
        dx, dy = segment.steps[self._done]
        self.position = (self.position[0] + dx, self.position[1] + dy)
        self.made.append((dx, dy))
        self.times.append(at)
        length = (2 ** 0.5 if dx and dy else 1.0) / self.machine.steps_per_mm
        self._interval = (length, at - self._last)
        self._last = at
        if self._done == 0:
            self.segments.append(segment)
        self._done += 1
        block.left -= 1
        if self._done == len(segment.steps):
            self._queue.popleft()
            self._done = 0
        if not block.left:
            self.blocks.popleft()

    def feed(self):
        """The feed now (mm/min): the last step's length over its interval; 0 when idle or
        held."""
        if not self._times or self.held or self._interval is None:
            return 0.0
        length, seconds = self._interval
        return 60 * length / seconds * self._rate() / self.speed if seconds > 0 else 0.0

    # ---- real-time commands -------------------------------------------------------------

    def hold(self):
        self.tick()
        self.held = True

    def resume(self):
        self.tick()
        self.held = False

    def cancel(self):
        """Drop every step not made (a jog cancel, a soft reset): the machine stops where it
        is; the segment it was making is kept cut short (:attr:`segments`)."""
        self.tick()
        if self._done:
            self.segments[-1] = replace(self.segments[-1],
                                        steps=self.segments[-1].steps[:self._done],
                                        end=self.position)
            self.cut.add(len(self.segments) - 1)
        self.blocks.clear()
        self._queue.clear()
        self._times.clear()
        self._done = 0
        self._replan_from = None
