"""Models of homing (``hdl/motion/homing.py``): the HomingEngine clock by clock, and the bench's
switches that close at a position of an axis. Exact integers."""

from .engine import DONE, REFUSED, StatusModel

__all__ = ["HomingModel", "BenchSwitches", "pass_steps", "cycle_steps"]


class HomingModel:
    """Clock-by-clock model of :class:`kontur.hdl.motion.homing.HomingEngine`.

    :meth:`cycle` takes a clock's inputs (the command offered, the feed's tick, the limit
    switches' levels, the status stream's readiness, abort) and returns its outputs; the
    clock edge is then taken.
    """

    def __init__(self):
        self.status = StatusModel(axes=2)
        self.run = 0
        self.pass_ = None              # axis, negative, until, set, steps, value
        self.left = 0

    def cycle(self, *, cmd_valid=0, cmd=None, tick=0, limits=0, status_ready=1, abort=0):
        status = self.status
        hold = status.hold
        p = self.pass_ or {"axis": 0, "negative": 0, "until": 0, "set": 0, "value": 0}
        met = int((limits >> p["axis"] & 1) == p["until"])
        ending = int(bool(self.run and status_ready and not hold and not abort)
                     and bool(met or self.left == 0))
        due = int(bool(self.run and not hold and not abort and not met) and self.left != 0)
        stepping = int(due and bool(tick))
        step = (1 << p["axis"]) if stepping else 0
        direction = 0b11 if p["negative"] else 0
        cmd_ready = int(status.idle and not status.flushing and not abort)
        accept = int(bool(cmd_valid) and cmd_ready)
        shown = status.evaluate(step=step, direction=direction, end=ending,
                                outcome=DONE if met else REFUSED, status_ready=status_ready)
        out = {"cmd_ready": cmd_ready, "due": due, "step": step,
               "dir": direction, "status_valid": shown["valid"],
               "status": shown["payload"], "busy": status.busy, "homing": self.run,
               "mask": (1 << p["axis"]) if self.run else 0,
               "load": int(ending and met and p["set"]),
               "load_axis": p["axis"], "load_value": p["value"]}
        status.advance(accept=accept, flush=abort)
        if accept:
            self.run, self.pass_, self.left = 1, dict(cmd), cmd["steps"]
        elif ending or abort:
            self.run = 0
        elif stepping:
            self.left -= 1
        return out


class BenchSwitches:
    """The bench machine's limit switches: the switch of an axis is active while the axis is at
    or beyond ``trip`` steps on the side of the switch (``negative``: at or below it).

    :meth:`levels` gives the bit word of the active switches at a position (bit 0 X, bit 1 Y).
    """

    def __init__(self, trip, *, negative=(True, True)):
        self.trip = tuple(trip)
        self.negative = tuple(negative)

    def active(self, axis, position):
        if self.negative[axis]:
            return position <= self.trip[axis]
        return position >= self.trip[axis]

    def levels(self, position):
        return sum(1 << axis for axis in range(len(self.trip))
                   if self.active(axis, position[axis]))


def pass_steps(position, item, switches):
    """The steps of one homing pass (``item``: a HOME frame's fields) from ``position`` against
    the bench's ``switches``, the switch seen before the next step (a step interval longer
    than the switch's lag): ``(steps, outcome)``, each step a ``(dx, dy)``."""
    axis, way = item["axis"], -1 if item["negative"] else 1
    here, steps = list(position), []
    while True:
        if switches.active(axis, here[axis]) == bool(item["until"]):
            return steps, DONE
        if len(steps) == item["steps"]:
            return steps, REFUSED
        here[axis] += way
        steps.append((way, 0) if axis == 0 else (0, way))


def cycle_steps(items, start, switches):
    """A homing cycle's steps, outcomes and position counter: ``items`` are ``("home",
    fields)`` (:func:`pass_steps`; a pass ending ``DONE`` with ``set`` loads ``value``) and
    ``("line", dx, dy)`` (an axis-parallel move's steps). Returns ``(steps, outcomes,
    position, counter)``."""
    position, counter, steps, outcomes = list(start), list(start), [], []
    for item in items:
        if item[0] == "home":
            made, outcome = pass_steps(position, item[1], switches)
        else:
            dx, dy = item[1], item[2]
            made = [((dx > 0) - (dx < 0), 0)] * abs(dx) + [(0, (dy > 0) - (dy < 0))] * abs(dy)
            outcome = DONE
        for dx, dy in made:
            position = [position[0] + dx, position[1] + dy]
            counter = [counter[0] + dx, counter[1] + dy]
        if item[0] == "home" and outcome == DONE and item[1]["set"]:
            counter[item[1]["axis"]] = item[1]["value"]
        steps += made
        outcomes.append(outcome)
    return steps, outcomes, position, counter
