"""Models of the motion side (``hdl/motion/``): the feed generator, clock by clock."""

from kontur.hdl.spec import STEP_LENGTHS

__all__ = ["FeedGeneratorModel", "INPUTS", "STATES", "InputFilterModel", "StepDirModel",
           "AlarmModel", "EVENTS", "FRAME_EVENTS", "event_kind", "safety_run"]


class FeedGeneratorModel:
    """Clock-by-clock model of :class:`kontur.hdl.motion.feed.FeedGenerator`.

    ``profile`` is a dict with ``cruise``, ``exit`` (Q0.24) and ``decelerate``; ``accel`` is
    Q0.40; ``hold`` a level, ``feed_override`` the Q2.7 factor (128: 100 %),
    ``rapid_override`` the rapid's shift (0, 1, 2: 100, 50, 25 %), ``rapid`` whether the move
    is a rapid; ``overrides=False``, the generator built without them. :meth:`cycle` returns ``tick`` for the clock, then advances; after it,
    :attr:`held` is that clock's ``held``.
    """

    WIDTHS = {"cruise": 24, "exit": 24, "decelerate": 24}
    ONE_FACTOR = 128                      # :data:`~kontur.hdl.motion.feed.OVERRIDE_ONE`
    MARGIN = 16 << 16                     # :data:`~kontur.hdl.motion.feed.LOOKAHEAD_MARGIN`
    EXTRA = 1 << 33                       # the look-ahead's distance: Q17.16, modulo this

    def __init__(self, *, max_rate=(1 << 24) - 1, overrides=True):
        self.max_rate = max_rate
        self.overrides = overrides
        self.reset()

    def reset(self):
        self.rate = 0                     # Q0.40
        self.distance = 0                 # Q2.24
        self.steps = 0
        self.zero = False                 # the last clock moved toward hold's zero, reached it
        self.target = 0                   # the rate's target: a register, a clock ahead
        self.holding = False              # the hold the target was computed under
        self.held = False
        # The scaled cruise: the sequential multiplier.
        self.used = self.ONE_FACTOR
        self.busy = False
        self.bit = 0
        self.product = 0
        self.ready = False
        # The ramp-down look-ahead.
        self.rose = self.fell = False
        self.after = False                # the last clock was a move's start
        self.extra = self.MARGIN
        self.above = False
        self.latched = False

    def _check(self, p, accel, feed_override, rapid_override):
        for name, bits in self.WIDTHS.items():
            if not 0 <= p[name] < 1 << bits:
                raise ValueError(f"Profile {name} must be an unsigned {bits}-bit integer, "
                                 f"not {p[name]!r}")
        if not 0 <= accel < 1 << 32:
            raise ValueError(f"Acceleration must be an unsigned 32-bit integer, not {accel!r}")
        if not 0 <= feed_override < 1 << 9:
            raise ValueError(f"Feed override must be an unsigned 9-bit integer, "
                             f"not {feed_override!r}")
        if not 0 <= rapid_override < 4:
            raise ValueError(f"Rapid override must be 0 to 3, not {rapid_override!r}")

    def _scale(self, p, start, factor):
        """The sequential multiplier, one clock."""
        if start or factor != self.used:
            self.used, self.busy, self.bit, self.product = factor, True, 8, 0
            self.ready = False
        elif self.busy:
            taken = p["cruise"] if self.used >> self.bit & 1 else 0
            self.product = ((self.product << 1) + taken) % (1 << 33)
            if self.bit == 0:
                self.busy, self.ready = False, True
            self.bit = (self.bit - 1) % 16

    def _lookahead(self, p, start):
        """The look-ahead, one clock: whether the move ramps down now; advances its state."""
        early = self.above and (self.extra >= 1 << 32
                                or self.steps + (self.extra >> 16) % (1 << 16)
                                >= p["decelerate"])
        down = (self.latched and not start) or self.steps >= p["decelerate"]
        now = self.rate >> 24
        if start or self.rate >> 16 <= p["cruise"]:
            self.extra, self.above = self.MARGIN, False
        elif self.rose:
            self.extra, self.above = (self.extra + now + 1) % self.EXTRA, True
        elif self.fell:
            self.extra = (self.extra - now) % self.EXTRA
        self.latched = not start and (self.latched or early)
        return down

    def cycle(self, *, profile, accel, start=0, due=0, diagonal=0, hold=0,
              feed_override=ONE_FACTOR, rapid_override=0, rapid=0):
        p = profile
        self._check(p, accel, feed_override, rapid_override)
        use = self.ready and not start
        scaled, slower = self.product >> 7, self.used < self.ONE_FACTOR
        down = self._lookahead(p, start)
        factor = (self.ONE_FACTOR >> rapid_override) if rapid else feed_override
        # Without the overrides the factor is 100 %, where the look-ahead never acts (the
        # rate rises above a move's cruise only after its planned ramp-down step).
        self._scale(p, start, factor if self.overrides else self.ONE_FACTOR)
        if down:
            wanted = scaled if use and slower and scaled < p["exit"] else p["exit"]
        else:
            wanted = scaled if use else p["cruise"]
        target = self.target              # computed in the clock before
        self.target = 0 if hold else min(wanted, self.max_rate) << 16
        holding, self.holding = self.holding, bool(hold)

        # The distance and the permission (from this clock's rate).
        stopped = self.held = bool(hold and self.zero)
        length = STEP_LENGTHS[diagonal]           # 1, √2, √3 (diagonal 2: on three axes)
        tick = int(not stopped and self.distance >= length)
        step = bool(tick and due)
        grown = self.distance + (self.rate >> 16)
        if step:
            self.distance = grown - length
        elif not tick:
            self.distance = grown
        if start:
            self.steps = int(step)
        elif step:
            self.steps += 1

        # The rate: one acceleration toward the target, never past it.
        up = self.rate < target
        moved = self.rate + accel if up else self.rate - accel
        passed = moved >= target if up else moved <= target
        theirs = start or self.after      # the rate moved toward the move before's target
        self.rose, self.fell = up and not theirs, not up and not passed and not theirs
        self.after = bool(start)
        self.zero = bool(holding and passed)
        self.rate = target if passed else moved
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
          "limit-z": ("limit_z", True), "limit-z-release": ("limit_z", False),
          "unlock": (None, None)}

#: The events of a 3-axis controller's Z limit (input bit 6): refused on a 2-axis board.
Z_EVENTS = ("limit-z", "limit-z-release")

#: The events that are the host's frames besides UNLOCK: feed hold and resume (HOLD,
#: RESUME), and the overrides (OVERRIDE): ``feed=PCT`` (10 to 200 %), ``rapid=PCT`` (100,
#: 50 or 25 %) and ``spindle=PCT`` (10 to 200 %: S in the tool outputs' PWM).
FRAME_EVENTS = ("hold", "resume", "feed=PCT", "rapid=PCT", "spindle=PCT")

#: The overrides an event may set.
FEED_PERCENT, RAPID_PERCENT = (10, 200), (100, 50, 25)


def event_kind(name):
    """What the ``--event`` name ``name`` does: ``("pins", input, pressed)``, ``("unlock",)``,
    ``("hold",)``, ``("resume",)``, ``("feed", percent)``, ``("rapid", percent)`` or
    ``("spindle", percent)``.

    Raises :exc:`ValueError` (one line) for any other name or an override out of range."""
    if name in EVENTS:
        switch, press = EVENTS[name]
        return ("unlock",) if switch is None else ("pins", switch, press)
    if name in ("hold", "resume"):
        return (name,)
    what, equals, value = name.partition("=")
    if equals and what in ("feed", "rapid", "spindle"):
        percent = int(value) if value.isdigit() else None
        if what != "rapid" and percent is not None and \
                FEED_PERCENT[0] <= percent <= FEED_PERCENT[1]:
            return (what, percent)
        if what == "rapid" and percent in RAPID_PERCENT:
            return ("rapid", percent)
        allowed = "10 to 200" if what != "rapid" else "100, 50 or 25"
        raise ValueError(f"Event {name}: the {what} override must be {allowed} %, "
                         f"not {value!r}")
    raise ValueError(f"Event must be one of {', '.join(list(EVENTS) + list(FRAME_EVENTS))}, "
                     f"not {name!r}")


def safety_run(times, events, *, braking=None):
    """What a run does with scripted events, at the level of a program's steps: ``times`` the
    time (s of machining from the first step) of each step of the uninterrupted run, in
    order, ``events`` ``(seconds, name)`` pairs (:func:`event_kind`); ``braking(t)`` the
    steps a hold at time ``t`` of the uninterrupted run still makes before it stands still
    (default none).

    The events are taken in time order (two at one time in the order given). The e-stop trips
    while pressed, a limit switch when pressed: the first trip stops the program (the steps
    up to then are made, no later one: the host sends no more of it) and enters ALARM, which
    ends a hold; UNLOCK leaves ALARM unless the e-stop is pressed. A hold stops the program
    after its braking until a resume, which delays every later step by the hold's length (the
    braking and the ramp back are not timed); the overrides change only the timing, which
    this model does not follow. Returns a dict: ``steps`` (how many are made), ``times``
    (theirs, holds' delays added), ``stopped`` (the first trip's time, or ``None``),
    ``state`` (the final state: ``ALARM``, ``HOLD`` or ``IDLE``), ``alarm`` (the inputs that
    tripped since ALARM began), ``events`` (each taken: ``{"at", "event", "alarm",
    "hold"}``, whether the controller is in ALARM and whether the feed is held after it)."""
    kinds = [event_kind(name) for _, name in events]
    for at, _ in events:
        if not at >= 0:
            raise ValueError(f"An event's time must be at least 0 s, not {at!r}")
    braking = braking or (lambda t: 0)
    pressed, alarm, cause, stopped = set(), False, [], None
    held = None                            # (time taken, steps made by its standstill)
    shift, delays = 0.0, []                # delays: (plan time, seconds) of each resumed hold
    limit = len(times)                     # the steps made at most
    taken = []
    order = sorted(range(len(events)), key=lambda i: events[i][0])
    for i in order:
        at, name = events[i]
        kind = kinds[i]
        if kind[0] == "unlock":
            if alarm and "estop" not in pressed:
                alarm, cause = False, []
        elif kind[0] == "pins":
            _, switch, press = kind
            if press:
                if switch == "estop" or switch not in pressed:
                    alarm = True
                    if switch not in cause:
                        cause.append(switch)
                    if stopped is None:
                        stopped = at
                        plan = at - shift
                        made = sum(1 for t in times if t <= plan)
                        limit = min(limit, made if held is None else held[1])
                    held = None
                pressed.add(switch)
            else:
                pressed.discard(switch)
        elif kind[0] == "hold":
            if held is None:
                plan = at - shift
                held = (at, min(len(times), sum(1 for t in times if t <= plan) + braking(plan)))
        elif kind[0] == "resume":
            if held is not None:
                delays.append((held[0] - shift, at - held[0]))
                shift += at - held[0]
                held = None
        taken.append({"at": at, "event": name, "alarm": alarm, "hold": held is not None})
    if held is not None:
        limit = min(limit, held[1])
    shifted = []
    for t in times[:limit]:
        shifted.append(t + sum(d for plan, d in delays if t > plan))
    return {"steps": limit, "times": shifted, "stopped": stopped,
            "state": "ALARM" if alarm else "HOLD" if held is not None else "IDLE",
            "alarm": [name for name in INPUTS + ("limit_z",) if name in cause], "events": taken}
