"""Grbl's ``$`` settings on kontur's machine file.

The settings a kontur machine has are its machine file's (:class:`kontur.machine.Machine`):
``$0`` the step pulse, ``$11`` junction deviation, ``$12`` arc tolerance (kontur's: how far an
arc's start and end radii may differ), ``$100``/``$101`` steps/mm, ``$110``/``$111`` the maximum
rate, ``$120``/``$121`` the acceleration. X and Y share each of these (the step lattice is
square and the feed is along the contour): writing either axis's writes both. The others are
kept as Grbl's defaults, in memory, for a sender to read; those that would promise what kontur
has not (soft and hard limits, homing, laser mode) are refused when set. A write of a setting
on the machine file is kept in that file (``kontur serve --machine FILE``: its key's line
rewritten in place, its comment kept, or the key added at the end), as Grbl keeps its settings
in EEPROM; without a file, and for the others, it lasts for the session.
"""

import os
import re
from dataclasses import replace
from pathlib import Path

from kontur import registry
from kontur.grbl.protocol import number
from kontur.machine import MachineError, RateError

__all__ = ["Settings", "MACHINE_KEYS", "DEFAULTS", "SettingError"]

#: Settings on the machine file: number -> its key.
MACHINE_KEYS = {0: "step_width_us", 11: "junction_deviation", 12: "arc_tolerance",
                24: "homing_feed", 25: "homing_seek", 26: "homing_debounce_ms",
                27: "homing_pulloff",
                100: "steps_per_mm", 101: "steps_per_mm", 110: "max_feed", 111: "max_feed",
                120: "accel", 121: "accel"}
#: Settings kept in memory, Grbl's defaults (``$10=3``: MPos and the buffer state reported).
DEFAULTS = {1: 25, 2: 0, 3: 0, 4: 0, 5: 0, 6: 0, 10: 3, 13: 0, 20: 0, 21: 0, 22: 0, 23: 0,
            30: 1000, 31: 0, 32: 0,
            102: 250.0, 112: 500.0, 122: 10.0, 130: 200.0, 131: 200.0, 132: 200.0}
INTEGERS = {0, 1, 2, 3, 4, 5, 6, 10, 13, 20, 21, 22, 23, 26, 30, 31, 32}
#: Settings that must stay 0 until kontur has what they enable: (error code, the reason).
REFUSED = {20: (10, None),
           21: (3, "hard limits: a board's limit inputs always trip its ALARM (in the "
                   "gateware, docs/controller.md); the virtual machine has no switches"),
           22: (3, "homing: the virtual machine has no limit switches; $22=1 and $H home a "
                   "board with the homing engine (kontur serve --port, the ULX3S)"),
           23: (3, "homing: the directions are the machine file's homing_dir"),
           32: (17, None)}


class SettingError(Exception):
    """A write refused: Grbl's error ``code`` and, where kontur says more, ``reason``."""

    def __init__(self, code, reason=None):
        super().__init__(reason or f"error {code}")
        self.code, self.reason = code, reason


class Settings:
    """The ``$`` settings of a session on ``machine`` (the machine file's); ``homing``: the
    machine can home (``$22`` may be set); ``board``: the board whose engines must make the
    highest feed (:func:`kontur.registry.check_machine`; none: the step/dir timing alone)."""

    def __init__(self, machine, path=None, *, homing=False, board=None):
        self.homing = homing
        self.board = board
        self.original = machine
        self.machine = machine
        self.path = None if path is None else Path(path)
        self.memory = dict(DEFAULTS)

    def value(self, key):
        if key in MACHINE_KEYS:
            return getattr(self.machine, MACHINE_KEYS[key])
        if key == 20:                       # soft limits: on where the file gives a travel
            return int(bool(self.machine.travel_x or self.machine.travel_y
                            or self.machine.travel_z))
        return self.memory[key]

    def lines(self):
        """``$$``'s lines, in Grbl's order."""
        keys = sorted({*MACHINE_KEYS, *DEFAULTS})
        return [f"${key}={number(self.value(key), 0 if key in INTEGERS else 3)}"
                for key in keys]

    def write(self, key, value):
        """``$key=value``: returns the new machine when the write changed it (else
        ``None``). Raises :exc:`SettingError`."""
        if key not in MACHINE_KEYS and key not in DEFAULTS:
            raise SettingError(3)
        if value < 0:
            raise SettingError(4)
        if key == 20 and value != self.value(20):
            raise SettingError(10 if value else 3, None if value else
                               "soft limits are the machine file's travel_x, travel_y and travel_z: "
                               "remove them there to turn them off")
        if key == 20:
            return None
        if key in REFUSED and value and not (key == 22 and self.homing):
            code, reason = REFUSED[key]
            raise SettingError(code, reason)
        if key not in MACHINE_KEYS:
            self.memory[key] = int(value) if key in INTEGERS else value
            return None
        try:
            machine = replace(self.machine, **{MACHINE_KEYS[key]: value}).check()
            if self.board is not None:
                machine = registry.check_machine(self.board, machine)
        except MachineError as error:
            raise SettingError(12 if isinstance(error, RateError) else 3, str(error)) from None
        self.machine = machine
        self._keep(MACHINE_KEYS[key], value)
        return machine

    def restore(self):
        """``$RST=$``: the machine file's values (as the session found them) and Grbl's
        defaults again."""
        for key in sorted(set(MACHINE_KEYS.values())):
            if getattr(self.machine, key) != getattr(self.original, key):
                self._keep(key, getattr(self.original, key))
        self.machine = self.original
        self.memory = dict(DEFAULTS)

    def keep_home(self, code, position):
        """G28.1/G30.1 (``code`` 28 or 30): the machine's ``g28_position``/``g30_position``
        is ``position`` (X, Y in mm), kept in the machine file as Grbl keeps it in EEPROM."""
        key = f"g{code}_position"
        position = tuple(float(c) for c in position[:2])
        self.machine = replace(self.machine, **{key: position})
        self._keep(key, position)

    def _keep(self, key, value):
        """Write ``key = value`` (a number, or a list of them) into the machine file (if
        any): its line's value replaced, or the line added; the file replaced at once (a
        rename)."""
        if self.path is None:
            return
        text = self.path.read_text()

        def form(value):
            return str(int(value)) if float(value).is_integer() else repr(float(value))
        number = f"[{', '.join(map(form, value))}]" if isinstance(value, tuple) else form(value)
        line = re.compile(rf"^(\s*{key}\s*=\s*)([^#\n]*?)(\s*(?:#.*)?)$", re.M)
        if line.search(text):
            text = line.sub(lambda m: f"{m.group(1)}{number}{m.group(3)}", text, count=1)
        else:
            text += ("" if not text or text.endswith("\n") else "\n") + f"{key} = {number}\n"
        temporary = self.path.with_name(f".{self.path.name}.{os.getpid()}")
        temporary.write_text(text)
        temporary.replace(self.path)
