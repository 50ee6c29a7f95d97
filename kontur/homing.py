"""The homing cycle (issue 25): the host's frames for Grbl's cycle on the homing engine.

For each axis of ``homing_order``, one after the other (the engine moves one axis a pass):

1. ``FEED(seek)``, ``HOME`` toward the switch until it is active, at most 1.5 times the
   axis's travel (Grbl's seek limit) — the seek;
2. ``FEED(approach)``, ``HOME`` away from it until it is inactive, at most 5 pull-offs (Grbl's
   ``HOMING_AXIS_LOCATE_SCALAR``) — the back-off;
3. ``HOME`` toward it until it is active again, as far, setting the axis's position to the
   switch point's machine coordinate (``homing_offset``, by default the travel's end on that
   side) — the approach;
4. ``FEED(seek)``, a ``LINE`` of ``homing_pulloff`` away from the switch, ramping down to rest
   (the feed generator's floor speed, as the planner ends a move).

A ``DWELL`` of ``homing_debounce_ms`` (Grbl's ``$26``) follows each pass. The seek and
approach FEEDs have their exit rate equal to their cruise: a pass stops in the step its
switch is seen, as Grbl's seek stops at the switch. The machine keys are
:class:`kontur.machine.Machine`'s ``homing_*`` (Grbl's ``$23``-``$27`` defaults).

A pass that makes its most steps without its switch ends ``REFUSED``: :func:`failure` words
it.
"""

import math

from kontur.hdl.motion import protocol
from kontur.hdl.motion.homing import home_frame
from kontur.machine import MachineError
from kontur.planner import MARGIN_STEPS, dwell_clocks
from kontur.send import REFUSED

__all__ = ["homing_frames", "homing_job", "homed_position", "failure", "check_board",
           "LOCATE_SCALAR", "SEEK_SCALAR"]

#: Grbl's limits of a homing pass: the seek 1.5 travels, the locating passes 5 pull-offs.
SEEK_SCALAR, LOCATE_SCALAR = 1.5, 5

#: The passes of an axis that end on its switch (a HOME frame each).
PASSES = ("seek", "back-off", "approach")

#: FEED's ramp-down step for a pass that never ramps down (the 24-bit field's largest).
NO_RAMP = (1 << 24) - 1


def check_board(board_name):
    """Raise :exc:`kontur.trace.UsageError` (status 2) for a board whose controller has no
    homing engine (:attr:`kontur.registry.Board.homing`)."""
    from kontur import registry
    from kontur.trace import UsageError
    item = registry.board(board_name)
    if not item.homing:
        others = [b.name for b in registry.BOARDS.values() if b.homing]
        raise UsageError(f"homing: the {item.name}'s controller is built without the homing "
                         f"engine (no room for it on the {item.help}); boards with it: "
                         f"{', '.join(others)}")


def _travel(machine, axis):
    travel = (machine.travel_x, machine.travel_y, machine.travel_z)[axis]
    if travel is None:
        raise MachineError(f"homing needs travel_{'xyz'[axis]} (the seek's length is 1.5 times "
                           f"the travel, as Grbl's)")
    return travel


def homing_frames(machine, axes=2):
    """The frames of the homing cycle (CONFIG first, STOP last) and, for each, a description
    (the axis and pass: ``"x seek"`` ...; ``None`` for CONFIG and STOP); ``axes=3`` for a
    3-axis controller (its pull-offs are LINE3 frames; Z is homed where ``homing_order`` has
    it, as Grbl homes Z first when its cycle 0 is Z).

    Raises :exc:`~kontur.machine.MachineError` if an axis homed has no travel, Z is to be
    homed on two axes, or a rate does not fit the feed generator."""
    frames, names, _ = _cycle(machine, axes)
    return frames, names


def _switch_point(machine, axis):
    """The machine coordinate (steps) the approach sets on ``axis`` (``homing_offset``, by
    default the travel's end on the switch's side)."""
    low, high = _travel(machine, axis)
    negative = machine.homing_dir[axis] == "-"
    offset = machine.homing_offset[axis] if machine.homing_offset is not None else \
        (low if negative else high)
    return round(offset * machine.steps_per_mm)


def homed_position(machine, position):
    """Where the cycle leaves the machine (steps) from ``position``: each homed axis at its
    switch point moved off by the pull-off, the others where they were."""
    out = list(position)
    pulloff = round(machine.homing_pulloff * machine.steps_per_mm)
    for name in machine.homing_order:
        axis = "xyz".index(name)
        negative = machine.homing_dir[axis] == "-"
        out[axis] = _switch_point(machine, axis) + (pulloff if negative else -pulloff)
    return tuple(out)


def _cycle(machine, axes=2):
    """:func:`homing_frames`'s frames and names, and each frame's longest time (s): a pass its
    most steps at its rate, a DWELL its clocks, a pull-off its steps at the seek rate."""
    spm, clock = machine.steps_per_mm, machine.clock_hz
    seek, approach = machine.rate(machine.homing_seek / 60), machine.rate(machine.homing_feed / 60)
    if seek == 0 or approach == 0:
        raise MachineError("homing_seek and homing_feed must be at least the feed generator's "
                           "lowest rate")
    pause = dwell_clocks(machine.homing_debounce_ms / 1000, machine)
    frames, names, seconds = [protocol.config(machine.accel_q40)], [None], [0.0]

    def add(frame, name, time=0.0):
        frames.append(frame)
        names.append(name)
        seconds.append(time)

    def at(rate, steps):                    # s: steps at a Q0.24 rate of steps a clock
        return steps * (1 << 24) / (rate * clock)

    if "z" in machine.homing_order and axes != 3:
        raise MachineError("homing_order homes Z, and the controller has two axes (X, Y)")
    for name in machine.homing_order:
        axis = "xyz".index(name)
        low, high = _travel(machine, axis)
        negative = machine.homing_dir[axis] == "-"
        seek_steps = math.ceil(SEEK_SCALAR * (high - low) * spm)
        locate_steps = math.ceil(LOCATE_SCALAR * machine.homing_pulloff * spm)
        passes = ((seek, negative, True, seek_steps, None, "seek"),
                  (approach, not negative, False, locate_steps, None, "back-off"),
                  (approach, negative, True, locate_steps, _switch_point(machine, axis),
                   "approach"))
        for rate, way, until, steps, value, what in passes:
            add(protocol.feed(rate, rate, NO_RAMP), f"{name} {what}")
            add(home_frame(axis, way, until, steps, value), f"{name} {what}", at(rate, steps))
            for clocks in pause:
                add(protocol.dwell(clocks), f"{name} {what}", clocks / clock)
        pulloff = round(machine.homing_pulloff * spm)
        if pulloff:
            add(_pulloff_feed(machine, seek, pulloff), f"{name} pull-off")
            delta = pulloff if negative else -pulloff     # away from the switch
            move = [0, 0, 0]
            move[axis] = delta
            add(protocol.line3(*move) if axes == 3 else protocol.line(*move[:2]),
                f"{name} pull-off",
                at(machine.rate(math.sqrt(2 * machine.accel / spm)) or 1, pulloff))
    add(protocol.stop(), None)
    return frames, names, seconds


def homing_job(machine, position):
    """The homing cycle as :func:`kontur.send.send` streams a program's job: its frames with
    their passes (:func:`homing_frames`) and longest times, from anywhere (no start), ending
    at :func:`homed_position` from ``position`` (steps: ``(x, y, z)`` for a 3-axis controller,
    whose frames it then makes); a pass ``REFUSED`` is worded by :func:`failure`."""
    import types
    frames, names, seconds = _cycle(machine, len(position))
    return types.SimpleNamespace(
        name="the homing cycle", machine=machine, start=None,
        end=homed_position(machine, position), segments=[], items=[], seconds=sum(seconds),
        durations=seconds, frames=lambda: (list(frames), list(names)),
        explain=lambda name, code: failure(machine, name) if code == REFUSED and name and \
        name.split()[1] in PASSES else None)


def _pulloff_feed(machine, seek, steps):
    """The pull-off's FEED: the seek rate, down to the floor speed ``sqrt(2 accel /
    steps_per_mm)`` (the planner's end of a move at rest) from ``MARGIN_STEPS`` before its end
    (kontur/planner.py's rule)."""
    a, spm = machine.accel, machine.steps_per_mm
    cruise = seek * machine.clock_hz / (1 << 24) / spm                   # mm/s
    floor = min(math.sqrt(2 * a / spm), cruise)
    down = (cruise ** 2 - floor ** 2) / (2 * a) * spm + MARGIN_STEPS     # steps
    return protocol.feed(seek, min(machine.rate(floor), seek), max(math.floor(steps - down), 0))


def failure(machine, name):
    """The host's words for a pass ``name`` (:func:`homing_frames`) that ended ``REFUSED``."""
    axis, what = name.split(" ", 1)
    index = "xyz".index(axis)
    if what == "seek":
        low, high = _travel(machine, index)
        reach = SEEK_SCALAR * (high - low)
    else:
        reach = LOCATE_SCALAR * machine.homing_pulloff
    state = "active" if what != "back-off" else "released"
    return f"homing failed: the {axis.upper()} switch was not {state} within {reach:g} mm " \
           f"({what})"
