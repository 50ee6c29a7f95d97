"""Models of the motion side (``hdl/motion/``): the feed generator, clock by clock."""

from kontur.hdl.spec import ONE, SQRT2

__all__ = ["FeedGeneratorModel", "INPUTS", "STATES", "InputFilterModel", "StepDirModel",
           "AlarmModel", "EVENTS", "safety_run"]


class FeedGeneratorModel:
    """Clock-by-clock model of :class:`kontur.hdl.motion.feed.FeedGenerator`.

    ``profile`` is a dict with ``cruise``, ``exit`` (Q0.24) and ``decelerate``; ``accel`` is
    Q0.40. :meth:`cycle` returns ``tick`` for the clock, then advances.
    """

    WIDTHS = {"cruise": 24, "exit": 24, "decelerate": 24}

    def __init__(self, *, max_rate=(1 << 24) - 1):
        self.max_rate = max_rate
        self.reset()

    def reset(self):
        self.rate = 0                     # Q0.40
        self.distance = 0                 # Q2.24
        self.steps = 0

    def cycle(self, *, profile, accel, start=0, due=0, diagonal=0, hold=0):
        p = profile
        for name, bits in self.WIDTHS.items():
            if not 0 <= p[name] < 1 << bits:
                raise ValueError(f"Profile {name} must be an unsigned {bits}-bit integer, "
                                 f"not {p[name]!r}")
        if not 0 <= accel < 1 << 32:
            raise ValueError(f"Acceleration must be an unsigned 32-bit integer, not {accel!r}")
        wanted = p["cruise"] if self.steps < p["decelerate"] else p["exit"]
        target = min(wanted, self.max_rate) << 16
        length = SQRT2 if diagonal else ONE
        tick = int(not hold and self.distance >= length)
        step = bool(tick and due)
        grown = self.distance + (self.rate >> 16)
        if step:
            self.distance = grown - length
        elif not hold and not tick:
            self.distance = grown
        diff = target - self.rate
        self.rate = target if abs(diff) <= accel else self.rate + (accel if diff > 0 else -accel)
        if start:
            self.steps = int(step)
        elif step:
            self.steps += 1
        return tick


# ---- safety: the inputs, the step/dir stage's halt, the ALARM -----------------------------

#: The switch inputs, bit by bit (:data:`kontur.hdl.motion.inputs.INPUTS`).
INPUTS = ("estop", "limit_x", "limit_y", "probe", "cycle_start", "feed_hold")

#: The controller's states (STATUS's state codes).
STATES = ("IDLE", "RUN", "HOLD", "HOMING", "ALARM")


class InputFilterModel:
    """Clock-by-clock model of :class:`kontur.hdl.motion.inputs.InputFilter`: two
    synchronising flip-flops, then a level that must hold ``filter`` clocks. :meth:`cycle`
    takes the pin, returns the filtered level of this clock, then advances."""

    def __init__(self, filter, init=0):
        self.filter = filter
        self.first = self.second = self.level = init
        self.count = 0

    def cycle(self, pin):
        level = self.level
        if self.filter == 1:
            self.level = self.second
        elif self.second == self.level:
            self.count = 0
        elif self.count == self.filter - 1:
            self.level, self.count = self.second, 0
        else:
            self.count += 1
        self.first, self.second = pin, self.first
        return level


class StepDirModel:
    """Clock-by-clock model of :class:`kontur.hdl.motion.stepdir.StepDirStage`, its halt
    included. :meth:`cycle` takes the engine's ``step`` and ``dir`` bits and ``halt``;
    returns ``(step, dir, made)`` of this clock (bits per axis), then advances."""

    def __init__(self, *, axes=2, dir_setup=0, step_width=1):
        self.axes, self.setup, self.width = axes, dir_setup, step_width
        self.left = [0] * axes
        self.dir = 0

    def cycle(self, step, direction, halt=0):
        out = made = 0
        for axis in range(self.axes):
            left = self.left[axis]
            out |= int(0 < left <= self.width) << axis
            made |= int(left == self.width) << axis
        ways = self.dir
        for axis in range(self.axes):
            left = self.left[axis]
            if halt and left > self.width:
                self.left[axis] = 0
            elif step >> axis & 1 and not halt:
                self.left[axis] = self.setup + self.width
                self.dir = self.dir & ~(1 << axis) | (direction & (1 << axis))
            elif left:
                self.left[axis] = left - 1
        return out, ways, made


class AlarmModel:
    """Clock-by-clock model of :class:`kontur.hdl.motion.alarm.Alarm`. :meth:`cycle` takes
    the filtered inputs (a word, :data:`INPUTS`), ``unlock``, ``busy``, ``hold`` and
    ``homing``; returns a dict of this clock's ``enter``, ``halt``, ``alarm``, ``cause`` and
    ``state`` (its code), then advances."""

    def __init__(self):
        self.alarm = self.cause = self.pressed = 0

    def cycle(self, active, *, unlock=0, busy=0, hold=0, homing=0):
        estop = active & 1
        limits = active >> 1 & 3
        tripped = estop | (limits & ~self.pressed) << 1
        state = 4 if self.alarm else 3 if homing else 2 if hold else 1 if busy else 0
        out = {"enter": int(bool(tripped) and not self.alarm),
               "halt": int(bool(tripped) or bool(self.alarm)),
               "alarm": self.alarm, "cause": self.cause, "state": state}
        if tripped:
            self.alarm, self.cause = 1, self.cause | tripped
        elif unlock:
            self.alarm = self.cause = 0
        self.pressed = limits
        return out


#: ``kontur run --event`` names: the inputs they press or release, or UNLOCK.
EVENTS = {"estop": ("estop", True), "estop-release": ("estop", False),
          "limit-x": ("limit_x", True), "limit-x-release": ("limit_x", False),
          "limit-y": ("limit_y", True), "limit-y-release": ("limit_y", False),
          "unlock": (None, None)}


def safety_run(times, events):
    """What a run does with scripted events, at the level of a program's steps: ``times`` the
    time (s of machining from the first step) of each step of the uninterrupted run, in
    order, ``events`` ``(seconds, name)`` pairs (:data:`EVENTS`).

    The events are taken in time order (two at one time in the order given). The e-stop trips
    while pressed, a limit switch when pressed: the first trip stops the program (the steps
    up to then are made, no later one: the host sends no more of it) and enters ALARM; UNLOCK
    leaves ALARM unless the e-stop is pressed. Returns a dict: ``steps`` (how many are made),
    ``stopped`` (the first trip's time, or ``None``), ``state`` (the final state: ``ALARM``,
    or ``IDLE``), ``alarm`` (the inputs that tripped since ALARM began), ``events`` (each
    taken: ``{"at", "event", "alarm"}``, whether the controller is in ALARM after it)."""
    for at, name in events:
        if name not in EVENTS:
            raise ValueError(f"Event must be one of {', '.join(EVENTS)}, not {name!r}")
        if not at >= 0:
            raise ValueError(f"An event's time must be at least 0 s, not {at!r}")
    pressed, alarm, cause, stopped = set(), False, [], None
    taken = []
    for at, name in sorted(events, key=lambda item: item[0]):
        switch, press = EVENTS[name]
        if switch is None:
            if alarm and "estop" not in pressed:
                alarm, cause = False, []
        elif press:
            if switch == "estop" or switch not in pressed:
                alarm = True
                if switch not in cause:
                    cause.append(switch)
                if stopped is None:
                    stopped = at
            pressed.add(switch)
        else:
            pressed.discard(switch)
        taken.append({"at": at, "event": name, "alarm": alarm})
    made = len(times) if stopped is None else sum(1 for t in times if t <= stopped)
    return {"steps": made, "stopped": stopped, "state": "ALARM" if alarm else "IDLE",
            "alarm": [name for name in INPUTS if name in cause], "events": taken}
