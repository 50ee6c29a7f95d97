"""The virtual machine's motion: the golden model's steps played against a clock.

The steps of every move are the step-level models' (:func:`kontur.planner.lattice`, as
``kontur run`` takes them); their times come from the same look-ahead feed plan
(:func:`kontur.planner.plan`, timed as :func:`kontur.machining.execute` times the model's
steps). A move that arrives while others are queued re-plans the moves not yet made (from
the step the machine is at; the moves behind it may now end faster), so the plan of a line
already sent changes as later lines arrive, as in Grbl.

The clock is virtual: it runs ``speed`` times real time (``kontur serve --speed``) and the
override of the move being made (a feed override on feed moves, a rapid override on rapids:
timing changes, the steps do not), the feed override's factor quantised as the feed
generator takes it (Q2.7: ``round(percent * 128 / 100) / 128``); a change of override during
a move changes the speed at the acceleration, as the feed generator ramps its rate to the
new target (:meth:`Motion.override`). A feed hold ramps the
machine down at its acceleration, as the feed generator's model does under ``hold`` (its
rate falls by the acceleration every clock): the steps ahead re-timed until the speed
reaches zero (``Hold:1``), then the clock stops (``Hold:0``); a resume ramps it up again from
rest at the acceleration until the plan's speed is reached (both in the virtual clock's
seconds, where an override's factor ``f`` makes the acceleration ``accel / f**2``).
"""

import math
import time
from collections import deque
from dataclasses import dataclass, field, replace

from kontur import registry
from kontur.machining import Job, execute
from kontur.planner import plan, step_length

__all__ = ["Block", "Motion"]


@dataclass
class Block:
    """One move in the planner: its kind (``"feed"``, ``"rapid"``, ``"jog"``, ``"tool"``),
    the program line, its segments on the lattice; ``left``: its steps not yet made. A tool
    change's block is one stop with no step (:func:`kontur.machining.tool_stop`): it is made
    in its turn, once the steps before it are (the controller takes the TOOL frame after the
    move before has ended)."""
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
    a cancel listed in :attr:`cut`, the stops of tool changes among them); :attr:`tool` the
    tool state of the last tool change made (``None``: none yet, all off)."""

    def __init__(self, machine, board, *, speed=1.0, position=None, clock=time.monotonic):
        self.machine, self.board, self.speed = machine, board, speed
        axes = registry.board(board).axes
        self.position = (0,) * axes if position is None else \
            tuple(position) + (0,) * (axes - len(position))
        self.tool = None
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
        self._made_factor = 1.0             # the override factor it was made at
        self._replan_from = None            # blocks added since the last plan: moving then?
        self.made, self.times, self.segments = [], [], []
        self._stopping = 0                  # steps left in a hold's ramp down
        self._ramp = None                   # a resume's ramp up: (steps made then, mm since)
        self.cut = set()                    # indexes in segments of those cut short

    #: The virtual machine has no limit switches to home to (a board's does: PortMotion).
    can_home = False

    # ---- the queue ----------------------------------------------------------------------

    def add(self, block):
        """Queue ``block``; everything not yet made is re-planned at the next :meth:`tick`
        (once for all the blocks added meanwhile). A block of stops only (a tool change) is
        made at once when nothing is queued before it."""
        if not block.segments:
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
        if self._ramp is not None:
            self._ramp_up(self._last if k or moving else self.now)
        if self.held and self._stopping:    # a line taken while ramping down
            self._ramp_down()

    @property
    def planned(self):
        """The blocks in the planner (Grbl's: the moves not yet finished)."""
        return len(self.blocks)

    @property
    def reported(self):
        """Where a status report says the machine is (steps): here, :attr:`position`."""
        return self.position

    @property
    def pins(self):
        """The inputs active now, as a status report's ``Pn:`` letters: none here (the
        virtual machine has no switches)."""
        return ""

    @property
    def busy(self):
        """Steps are queued (the machine runs, or would but for a hold)."""
        return bool(self._times) or self._replan_from is not None

    @property
    def kind(self):
        """The kind of the block being made (``None`` when idle)."""
        return self.blocks[0].kind if self.blocks else None

    # ---- time ---------------------------------------------------------------------------

    def _factor(self):
        """The override factor of the block being made: the feed override quantised to the
        feed generator's Q2.7, the rapid override's exact 100/50/25 %."""
        kind = self.kind
        if kind == "feed":
            return round(self.overrides[0] * 128 / 100) / 128
        return self.overrides[1] / 100 if kind == "rapid" else 1.0

    def _rate(self):
        return self.speed * self._factor()

    @property
    def stopping(self):
        """A hold ramping the machine down (Grbl's ``Hold:1``)."""
        return self.held and self._stopping > 0

    def tick(self):
        """Move the virtual clock to the present (at the rate of the block being made: ticks
        come every few milliseconds) and make the steps whose time has come (under a hold,
        those of its ramp down only)."""
        if self._replan_from is not None:
            self._replan(self._replan_from)
        if not self.held:
            self._stops()
        real = self.clock()
        if not self.held or self._stopping:
            self.now += (real - self._real) * self._rate()
            while self._times and self._times[0] <= self.now and \
                    (not self.held or self._stopping):
                self._step()
                if self.held:
                    self._stopping -= 1
            if self.held and not self._stopping and self._times:
                self.now = min(self.now, self._times[0])
        self._real = real

    # ---- the ramps of a hold and a resume ---------------------------------------------

    def _length(self, step):
        return step_length(step) / self.machine.steps_per_mm

    def _ahead(self):
        """The steps not yet made, in order."""
        done = self._done
        for segment, _ in self._queue:
            yield from segment.steps[done:]
            done = 0

    def _accel(self):
        """The machine's acceleration in the virtual clock's seconds (mm/s²)."""
        return self.machine.accel / self._factor() ** 2

    def _retime(self, start, reach, *, shift=True, until=None):
        """Re-time the steps ahead from ``start`` (virtual s): each no earlier than
        ``start + reach(distance to its end)`` (``None``: it is not reached, nor are those
        after it), than its planned speed allows after the one before, than planned. With
        ``shift`` the steps after those re-timed (``until(distance)`` says where the ramp no
        longer binds) are as late as the last of them is; returns the times replaced (the
        plan's)."""
        planned, previous, times = list(self._times), start, []
        covered = 0.0
        for index, step in enumerate(self._ahead()):
            length = self._length(step)
            covered += length
            earliest = reach(covered)
            if earliest is None:
                break
            interval = planned[index] - (planned[index - 1] if index else self._last)
            previous = max(start + earliest, previous + max(interval, 0.0), planned[index])
            times.append(previous)
            if until is not None and until(covered):
                break
        for index, at in enumerate(times):
            self._times[index] = at
        if shift and times:
            delay = times[-1] - planned[len(times) - 1]
            for index in range(len(times), len(planned)):
                self._times[index] += delay
        return planned[:len(times)]

    @property
    def _fastest(self):
        """No planned speed is above this (mm/s, virtual): twice the machine's maximum
        feed."""
        return self.machine.max_feed / 60 * 2

    def _ramp_up(self, start):
        """From rest (or the speed a ramp down had reached) at the acceleration: the time to
        a distance ``d`` past the point where the speed was zero is ``sqrt(2 d / a)``."""
        made, before = self._ramp
        since = before + sum(map(self._length, self.made[made:]))
        accel = self._accel()
        if 2 * accel * since >= self._fastest ** 2:      # past any speed: the ramp is over
            self._ramp = None
            return
        offset = math.sqrt(2 * since / accel)
        self._retime(start, lambda d: math.sqrt(2 * (since + d) / accel) - offset,
                     until=lambda d: 2 * accel * (since + d) >= self._fastest ** 2)

    def _stops(self):
        """The stops with no step at the head of the queue (tool changes), made: the tool
        state is theirs."""
        while self._queue and not self._done and not self._queue[0][0].steps:
            segment, block = self._queue.popleft()
            self.segments.append(segment)
            if "tool" in segment.payload:
                self.tool = segment.payload["tool"]
            if self.blocks and self.blocks[0] is block and \
                    not (self._queue and self._queue[0][1] is block):
                self.blocks.popleft()

    def _step(self):
        at = self._times.popleft()
        segment, block = self._queue[0]
        step = segment.steps[self._done]
        self.position = tuple(c + d for c, d in zip(self.position, step))
        self.made.append(step)
        self.times.append(at)
        length = self._length(step)
        self._interval = (length, at - self._last)
        self._made_factor = self._factor()
        self._last = at
        if self._done == 0:
            self.segments.append(segment)
        self._done += 1
        block.left -= 1
        if self._done == len(segment.steps):
            self._queue.popleft()
            self._done = 0
        if not block.left and not (self._queue and self._queue[0][1] is block):
            self.blocks.popleft()
        self._stops()
        if not self._times:
            self._ramp = None

    def feed(self):
        """The feed now (mm/min): the last step's length over its interval; 0 when idle or
        held."""
        if not self._times or self.held or self._interval is None:
            return 0.0
        length, seconds = self._interval
        return 60 * length / seconds * self._rate() / self.speed if seconds > 0 else 0.0

    # ---- real-time commands -------------------------------------------------------------

    def override(self, index, percent):
        """Set override ``index`` (0 feed, 1 rapid, 2 spindle) to ``percent``; on the move
        being made the speed changes at the machine's acceleration, as the feed generator
        ramps its rate to the new target, not at once."""
        self.tick()
        before = self._factor()
        self.overrides[index] = percent
        after = self._factor()
        if after == before or self.held or not self._times or self._interval is None:
            return
        speed = self._speed()                     # the machine's speed, in virtual seconds
        planned = self._length(next(self._ahead())) / max(self._times[0] - self._last, 1e-12)
        if speed < planned:                       # faster: up from that speed
            self._ramp = (len(self.made), speed ** 2 / (2 * self._accel()))
            self._ramp_up(self._last)
        else:
            self._slow_down(speed)

    def _slow_down(self, speed):
        """From ``speed`` (virtual mm/s, above the plan's) down to the plan's at the
        acceleration: the steps ahead earlier than planned until then, the rest as much
        earlier as the last of them."""
        accel, planned = self._accel(), list(self._times)
        previous, covered, count = self._last, 0.0, 0
        for index, step in enumerate(self._ahead()):
            length = self._length(step)
            interval = planned[index] - (planned[index - 1] if index else self._last)
            left = speed ** 2 - 2 * accel * (covered + length / 2)
            if interval <= 0 or left <= (length / interval) ** 2:
                break                           # down to the plan's speed
            previous = min(previous + length / math.sqrt(left), planned[index])
            self._times[index] = previous
            covered += length
            count += 1
        if count:
            delay = previous - planned[count - 1]
            for index in range(count, len(planned)):
                self._times[index] += delay

    def hold(self):
        """Ramp down to a stop (the steps within the stopping distance re-timed), then
        hold."""
        self.tick()
        if self.held:
            return
        self.held = True
        self._ramp = None
        self._ramp_down()

    def _ramp_down(self):
        """The steps ahead within the stopping distance from the speed now, re-timed."""
        speed, accel = self._speed(), self._accel()
        if not self._times or not speed:
            self._stopping = 0
            return

        def stop(distance):                 # the time to a distance on the way down
            left = speed ** 2 - 2 * accel * distance
            return (speed - math.sqrt(left)) / accel if left >= 0 else None
        self._saved = self._retime(self._last, stop, shift=False)
        self._stopping = len(self._saved)

    def _speed(self):
        """The speed now (mm/s, virtual, at the override in force): the last step's length
        over its interval, made at the override then in force."""
        if self._interval is None:
            return 0.0
        length, seconds = self._interval
        return length / seconds * self._made_factor / self._factor() if seconds > 0 else 0.0

    def resume(self):
        """Ramp up from rest (the steps ahead re-timed from now, at the acceleration until
        the plan's speed)."""
        self.tick()
        if not self.held:
            return
        self.held = False
        speed = 0.0
        if self._stopping:                  # still ramping down: up again from this speed
            speed = self._speed()
            for index, at in enumerate(self._saved[-self._stopping:]):
                self._times[index] = at
            self._stopping = 0
        self._ramp = (len(self.made), speed ** 2 / (2 * self._accel()))
        if self._times:
            self._ramp_up(self._last if speed else self.now)

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
        self._stopping = 0
        self._ramp = None
