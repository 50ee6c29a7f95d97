"""A machine's configuration: resolution, speeds, acceleration, timing, link; read from TOML.

```toml
# machine.toml: every key optional; the defaults are those below.
steps_per_mm = 80          # X and Y alike (arcs are circles on the step lattice)
max_feed = 3000            # mm/min: G0, and the cap of every F
accel = 500                # mm/s^2 along the contour
junction_deviation = 0.01  # mm (GRBL's): how fast corners may be taken
arc_tolerance = 0.05       # mm: an arc's start and end radii may differ by this much
baud = 115200
dir_setup_us = 1.0         # step/dir timing of the drivers
step_width_us = 2.0
queue_frames = 32          # at least 2
cutter_radius = 3.0        # mm, for G41/G42 (no default: a program with them needs it)
corner = "arc"             # G41/G42's convex corners: "arc" (LinuxCNC's) or "miter" (extended
                           # to a point up to 2 radii from the vertex, on an arc beyond)
input_filter_us = 100      # the switch inputs' glitch filter, at most 10 000 (10 ms)
estop = "nc"               # each input's switch: "nc" (normally closed) or "no" (open)
limit_x = "nc"
limit_y = "nc"
probe = "no"
cycle_start = "no"
feed_hold = "nc"
limit_z = "nc"             # Z's limit, on a board with three axes (ulx3s, icebreaker-z)
g28_position = [0, 0]      # mm, machine coordinates: where G28 goes (X Y, or X Y Z)
g30_position = [0, 0]      # mm: where G30 goes (LinuxCNC's parameters 5161-5163, 5181-5183)
travel_x = [0, 300]        # mm, machine coordinates: the soft limits (no default: unchecked)
travel_y = [0, 200]
travel_z = [-60, 0]        # Z's, on a board with three axes (Grbl's machine zero at the top)
s_max = 1000               # the S of full spindle (laser) power (Grbl's $30), an integer
pwm_hz = 1000              # the spindle (laser) PWM's frequency
laser = false              # Grbl's laser mode ($32): in M4 the power follows the feed
homing_order = ["x", "y"]  # the axes homed, one after the other (kontur send --home, $H);
                           # ["z", "x", "y"] homes Z first, on a board with three axes
homing_dir = ["+", "+"]    # toward which end each axis's switch is (Grbl's $23 = 0: "+"),
                           # [X, Y] or [X, Y, Z] (Z "+" when not given: its switch at the top)
homing_feed = 25.0         # mm/min: the slow approach (Grbl's $24)
homing_seek = 500.0        # mm/min: the seek (Grbl's $25)
homing_debounce_ms = 250   # the wait between the passes (Grbl's $26)
homing_pulloff = 1.0       # mm: the move off the switch at the end (Grbl's $27)
homing_offset = [0, 300]   # mm, machine coordinates of the switch points (X Y or X Y Z); default: the
                           # travel's end on the switch's side, 0 without a travel
```

The clock is not a key of the file: it is the board's (``kontur run --board``, ``kontur send
--board``; :data:`kontur.registry.BOARDS`), given to :meth:`Machine.from_toml` by the caller.

Every value is checked once against what the gateware takes (the same for every engine, the
model included): :exc:`MachineError` names the key and its range. ``queue_frames`` when the
machine is made; the baud and acceleration, which depend on the clock, by :meth:`Machine.check`
(called by :func:`kontur.machining.prepare` once the clock is the board's).

1. ``queue_frames``: an integer from 2 to 255 (:class:`kontur.hdl.motion.controller.
   MotionController`).
2. ``baud``: the clock divided by it, rounded, is the UART's bit time in clocks; it must be at
   least 4 clocks and the rate it makes within 2 % of ``baud``
   (:func:`kontur.hdl.motion.uart.divisor_for`).
3. ``accel``: as the feed generator's rate change a clock, Q0.40, it must round to at least 1
   and fit its 32-bit field (:attr:`Machine.accel_q40`).
4. ``max_feed``: at most the step rate the step/dir timing allows (one step every
   ``dir_setup + step_width + 1`` clocks per axis).
5. ``input_filter_us``: more than 0, at most 10 000 (10 ms); the switches' kinds ``"nc"`` or
   ``"no"``.
6. ``travel_x``, ``travel_y``, ``travel_z`` (a board with three axes): ``[min, max]`` in mm
   with min < max, or absent (no soft limit on that axis). A program whose steps would take the machine outside them is refused before
   anything moves (:func:`kontur.machining.check_travel`), as LinuxCNC's and Grbl's soft
   limits refuse it.
7. ``s_max``: an integer from 1 to 2**24 - 1; ``pwm_hz``: its period at the clock, rounded to
   whole clocks (:attr:`Machine.pwm_period`), at least the clocks the tool outputs take to
   work a duty out (:func:`kontur.hdl.motion.tools.min_period`). ``laser``: ``true`` or
   ``false``, Grbl's ``$32`` (the TOOL frames carry it: in M4 the power follows the feed;
   the laser is lit in G1/G2/G3 only, and a change of power alone is taken without a stop:
   :func:`kontur.machining.tool_changes`).
"""

import math
from dataclasses import dataclass, fields

__all__ = ["Machine", "MachineError", "RateError", "SWITCHES"]

#: The switch inputs' keys, and their default kinds (as :data:`kontur.hdl.motion.inputs.
#: DEFAULT_POLARITY`).
SWITCHES = {"estop": "nc", "limit_x": "nc", "limit_y": "nc", "probe": "no",
            "cycle_start": "no", "feed_hold": "nc", "limit_z": "nc"}

#: The longest input filter, µs.
MAX_INPUT_FILTER_US = 10_000


class MachineError(ValueError):
    """A configuration the machine cannot run with: the message names the key."""


class RateError(MachineError):
    """A ``max_feed`` above the step rate the machine makes: the step/dir timing's
    (:attr:`Machine.max_step_rate`) or a board's slowest engine's
    (:func:`kontur.registry.check_machine`). Grbl's ``$110`` answers it with error:12."""


@dataclass(frozen=True)
class Machine:
    steps_per_mm: float = 80.0
    max_feed: float = 3000.0
    accel: float = 500.0
    junction_deviation: float = 0.01
    arc_tolerance: float = 0.05
    clock_hz: float = 12e6
    baud: int = 115200
    dir_setup_us: float = 1.0
    step_width_us: float = 2.0
    queue_frames: int = 32
    cutter_radius: float = None       # mm: G41/G42's (None: a program with them is refused)
    corner: str = "arc"               # G41/G42's convex corners: "arc" or "miter"
    input_filter_us: float = 100.0
    estop: str = "nc"
    limit_x: str = "nc"
    limit_y: str = "nc"
    probe: str = "no"
    cycle_start: str = "no"
    feed_hold: str = "nc"
    limit_z: str = "nc"               # Z's limit (a board with three axes)
    g28_position: tuple = (0.0, 0.0)  # mm, machine coordinates: G28's (X, Y) or (X, Y, Z)
    g30_position: tuple = (0.0, 0.0)  # mm: G30's
    travel_x: tuple = None            # mm, machine coordinates: (min, max), None: unchecked
    travel_y: tuple = None
    travel_z: tuple = None            # Z's (a board with three axes)
    s_max: int = 1000                 # the S of full power (Grbl's $30)
    pwm_hz: float = 1000.0            # the spindle (laser) PWM's frequency
    laser: bool = False               # Grbl's laser mode ($32): in M4 power follows the feed
    homing_order: tuple = ("x", "y")  # kontur.homing: the axes homed, in order
    homing_dir: tuple = ("+", "+", "+")  # toward which end each switch is (Grbl's $23 = 0)
    homing_feed: float = 25.0         # mm/min (Grbl's $24)
    homing_seek: float = 500.0        # mm/min (Grbl's $25)
    homing_debounce_ms: float = 250.0  # (Grbl's $26)
    homing_pulloff: float = 1.0       # mm (Grbl's $27)
    homing_offset: tuple = None       # mm: the switch points (None: from the travel)

    def __post_init__(self):
        if not isinstance(self.laser, bool):
            raise MachineError(f"laser must be true or false (Grbl's laser mode, $32), not "
                               f"{self.laser!r}")
        if self.corner not in ("arc", "miter"):
            raise MachineError(f"corner must be \"arc\" (round a convex corner on an arc of "
                               f"the cutter radius) or \"miter\" (extend it up to 2 radii), "
                               f"not {self.corner!r}")
        for name in SWITCHES:
            if getattr(self, name) not in ("nc", "no"):
                raise MachineError(f"{name} must be \"nc\" (normally closed) or \"no\" "
                                   f"(normally open), not {getattr(self, name)!r}")
        for name in ("g28_position", "g30_position"):
            value = getattr(self, name)
            if not isinstance(value, (list, tuple)) or len(value) not in (2, 3) or any(
                    isinstance(c, bool) or not isinstance(c, (int, float))
                    or not math.isfinite(c) for c in value):
                raise MachineError(f"{name} must be [X, Y] or [X, Y, Z] in mm, not {value!r}")
            object.__setattr__(self, name, tuple(float(c) for c in value))
        for name in ("travel_x", "travel_y", "travel_z"):
            value = getattr(self, name)
            if value is None:
                continue
            if not isinstance(value, (list, tuple)) or len(value) != 2 or any(
                    isinstance(c, bool) or not isinstance(c, (int, float))
                    or not math.isfinite(c) for c in value) or not value[0] < value[1]:
                raise MachineError(f"{name} must be [min, max] in mm with min < max, not "
                                   f"{value!r}")
            object.__setattr__(self, name, (float(value[0]), float(value[1])))
        self._check_homing()
        if self.cutter_radius is not None:
            value = self.cutter_radius
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value) or value < 0:
                raise MachineError(f"cutter_radius must be a number of at least 0 (mm), not "
                                   f"{value!r}")
        for item in fields(self):
            if item.name in ("cutter_radius", "g28_position", "g30_position", "travel_x",
                             "travel_y", "travel_z", "corner", "homing_order", "homing_dir",
                             "homing_offset", "laser") \
                    or item.name in SWITCHES:
                continue
            value = getattr(self, item.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise MachineError(f"{item.name} must be a number, not {value!r}")
            if not math.isfinite(value) or value <= 0:
                raise MachineError(f"{item.name} must be positive, not {value!r}")
        for name in ("baud", "queue_frames", "s_max"):
            if int(getattr(self, name)) != getattr(self, name):
                raise MachineError(f"{name} must be an integer, not {getattr(self, name)!r}")
            object.__setattr__(self, name, int(getattr(self, name)))
        if self.input_filter_us > MAX_INPUT_FILTER_US:
            raise MachineError(f"input_filter_us must be at most {MAX_INPUT_FILTER_US} (10 ms), "
                               f"not {self.input_filter_us!r}")
        if not self.s_max < 1 << 24:
            raise MachineError(f"s_max must be an integer from 1 to {(1 << 24) - 1}, not "
                               f"{self.s_max!r}")
        if not 2 <= self.queue_frames <= 255:
            raise MachineError(f"queue_frames must be an integer from 2 to 255 (STATUS reports "
                               f"the free slots in a byte), not {self.queue_frames!r}")
        if self.max_step_rate < self.max_feed / 60 * self.steps_per_mm:
            raise RateError(
                f"max_feed {self.max_feed:g} mm/min is {self.max_feed / 60 * self.steps_per_mm:.0f}"
                f" steps/s, more than the {self.max_step_rate:.0f} the step/dir timing allows")

    def _check_homing(self):
        order, ways, offset = self.homing_order, self.homing_dir, self.homing_offset
        if not isinstance(order, (list, tuple)) or not 1 <= len(order) <= 3 or \
                len(set(order)) != len(order) or any(a not in ("x", "y", "z") for a in order):
            raise MachineError(f"homing_order must be a list of \"x\", \"y\" and \"z\", each "
                               f"once, not {order!r}")
        if not isinstance(ways, (list, tuple)) or len(ways) not in (2, 3) or \
                any(w not in ("+", "-") for w in ways):
            raise MachineError(f"homing_dir must be [X, Y] or [X, Y, Z], each \"+\" or \"-\", "
                               f"not {ways!r}")
        if offset is not None and (not isinstance(offset, (list, tuple))
                                   or len(offset) not in (2, 3)
                                   or any(isinstance(c, bool) or not isinstance(c, (int, float))
                                          or not math.isfinite(c) for c in offset)):
            raise MachineError(f"homing_offset must be [X, Y] or [X, Y, Z] in mm, not "
                               f"{offset!r}")
        if "z" in order and offset is not None and len(offset) == 2:
            raise MachineError(f"homing_offset must give Z's switch point too ([X, Y, Z]) when "
                               f"homing_order homes Z, not {offset!r}")
        object.__setattr__(self, "homing_order", tuple(order))
        object.__setattr__(self, "homing_dir", tuple(ways) + ("+",) * (3 - len(ways)))
        if offset is not None:
            object.__setattr__(self, "homing_offset", tuple(float(c) for c in offset))

    @classmethod
    def from_toml(cls, path, *, clock_hz, **overrides):
        """Read ``path`` (TOML) for a board clocked at ``clock_hz``; keys given in
        ``overrides`` (not ``None``) win."""
        import tomllib
        try:
            with open(path, "rb") as handle:
                table = tomllib.load(handle)
        except OSError as error:
            raise MachineError(f"cannot read the machine file {path}: {error.strerror}")
        except UnicodeDecodeError as error:
            raise MachineError(f"{path}: not a TOML file (not UTF-8 text: {error.reason} at "
                               f"byte {error.start})")
        except tomllib.TOMLDecodeError as error:
            raise MachineError(f"{path}: {error}")
        known = {item.name for item in fields(cls)} - {"clock_hz"}
        for key in table:
            if key == "clock_hz":
                raise MachineError(f"{path}: clock_hz is the board's, not the machine's: choose "
                                   f"the board (--board)")
            if key not in known:
                raise MachineError(f"{path}: unknown key {key!r} (known: {', '.join(sorted(known))})")
        table.update({k: v for k, v in overrides.items() if v is not None})
        return cls(**table, clock_hz=clock_hz)

    @property
    def parameters(self):
        """The G-code parameters the machine gives a program (:func:`kontur.gcode.interpret`):
        G28's position in 5161-5163, G30's in 5181-5183 (mm)."""
        out = {}
        for base, position in ((5161, self.g28_position), (5181, self.g30_position)):
            for axis, value in enumerate(position):
                out[base + axis] = value
        return out

    # ---- in the gateware's units --------------------------------------------------------

    @property
    def dir_setup(self):
        """Direction set-up in clocks."""
        return math.ceil(self.dir_setup_us * 1e-6 * self.clock_hz)

    @property
    def step_width(self):
        """Step pulse width in clocks."""
        return max(1, math.ceil(self.step_width_us * 1e-6 * self.clock_hz))

    @property
    def input_filter(self):
        """The switch inputs' glitch filter in clocks (at least 1)."""
        return max(1, math.ceil(self.input_filter_us * 1e-6 * self.clock_hz))

    @property
    def polarity(self):
        """Each switch input's kind, ``"nc"`` or ``"no"``."""
        return {name: getattr(self, name) for name in SWITCHES}

    @property
    def step_dir_clocks(self):
        """The step/dir stage's clocks a step per axis at least: ``dir_setup + step_width + 1``
        (the low time between two pulses is at least ``dir_setup + 1``)."""
        return self.dir_setup + self.step_width + 1

    @property
    def max_step_rate(self):
        """Steps a second per axis at most: one every :attr:`step_dir_clocks`."""
        return self.clock_hz / self.step_dir_clocks

    def check(self):
        """Raise :exc:`MachineError` (naming the key and its range) for a value the gateware
        at this clock cannot take: the baud (:meth:`check_baud`), the acceleration
        (:attr:`accel_q40`). Called by :func:`kontur.machining.prepare` for every engine,
        once the clock is known to be the board's; return the machine."""
        self.check_baud()
        self.accel_q40                                  # noqa: B018 (raises if out of range)
        self.pwm_period                                 # noqa: B018 (raises if out of range)
        return self

    def check_baud(self):
        """Raise :exc:`MachineError` unless the UART can make ``baud`` from the clock: a bit
        time of at least 4 clocks, its rate within 2 % (:func:`kontur.hdl.motion.uart.divisor_for`);
        return the bit time in clocks."""
        from kontur.hdl.motion.uart import divisor_for
        try:
            return divisor_for(self.clock_hz, self.baud)
        except ValueError:
            raise MachineError(
                f"baud {self.baud:g} cannot be made from the {self.clock_hz / 1e6:g} MHz clock: "
                f"the bit time ({self.clock_hz / self.baud:.2f} clocks) must round to at least "
                f"4 whole clocks and give a rate within 2 % of the baud (at most "
                f"{self.clock_hz / 4 / 0.98:.0f} baud)") from None

    @property
    def pwm_period(self):
        """The tool outputs' PWM period in clocks (:func:`kontur.hdl.motion.tools.pwm_period`):
        ``clock_hz / pwm_hz`` rounded; at least :func:`~kontur.hdl.motion.tools.min_period`."""
        from kontur.hdl.motion.tools import min_period, pwm_period
        period = pwm_period(self.clock_hz, self.pwm_hz)
        if period < min_period(period):
            shortest = next(p for p in range(2, 1 << 10) if p >= min_period(p))
            raise MachineError(
                f"pwm_hz {self.pwm_hz:g} is a PWM period of {period} clocks at "
                f"{self.clock_hz / 1e6:g} MHz; the tool outputs need at least {shortest} (at "
                f"most {self.clock_hz / (shortest - 0.5):.0f} Hz)")
        return period

    @property
    def max_rate(self):
        """The feed generator's highest rate (Q0.24): one step every ``dir_setup +
        step_width + 1`` clocks (:func:`kontur.hdl.motion.feed.rate_limit`)."""
        return ((1 << 24) - 1) // self.step_dir_clocks

    def rate(self, mm_per_s):
        """A contour speed as the feed generator's rate: step lengths a clock, Q0.24.

        Raises
        ------
        MachineError
            If it does not fit the 24-bit field (never clamped)."""
        value = round(mm_per_s * self.steps_per_mm / self.clock_hz * (1 << 24))
        if not 0 <= value < 1 << 24:
            raise MachineError(f"a speed of {mm_per_s * 60:g} mm/min is a feed generator rate "
                               f"of {value}, beyond its 24-bit field (at most {(1 << 24) - 1})")
        return value

    @property
    def accel_q40(self):
        """The acceleration as the feed generator's rate change a clock, Q0.40."""
        scale = self.steps_per_mm / self.clock_hz ** 2 * (1 << 40)
        value = round(self.accel * scale)
        if not 1 <= value < 1 << 32:
            raise MachineError(
                f"accel {self.accel:g} mm/s^2 does not fit the feed generator at "
                f"{self.clock_hz:g} Hz and {self.steps_per_mm:g} steps/mm: it must be from "
                f"{0.5 / scale:.4g} to {((1 << 32) - 0.5) / scale:.4g} mm/s^2 (a rate change a "
                f"clock of 1 to 2**32 - 1 in Q0.40)")
        return value
