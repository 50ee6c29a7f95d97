"""Golden model of lines in space (``kontur.hdl.spatial.SpatialLineCore``): step level and cycle level.

Every axis keeps SU 1571551's estimating function (equation (1), the ``exact`` variant of
:mod:`kontur.sim.models.linear`) against the dominant axis: with ``a`` the dominant projection and
``m`` the axis's own, ``2F`` starts at ``a - 2m``; a negative ``F`` moves the axis (``2F += 2(a -
m)``), any other keeps it (``2F -= 2m``). The dominant axis (``m = a``) moves at every step.
Exact integers.
"""

from .errors import InputError

__all__ = ["AXIS_NAMES", "check_spatial", "spatial_steps", "line_steps", "SpatialLineCoreModel"]

AXIS_NAMES = ("x", "y", "z")


def check_spatial(x, y, z, width):
    """Refuse an end point whose magnitude does not fit the ``width``-bit registers."""
    for name, value in (("X", x), ("Y", y), ("Z", z)):
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"{name} must be an integer, not {value!r}")
        if abs(value) > (1 << width) - 1:
            raise InputError(f"|{name}| = {abs(value)} is too wide for the {width}-bit registers "
                             f"(at most {(1 << width) - 1})")


def spatial_steps(x, y, z=0, *, width=16):
    """Return the steps ``(dx, dy, dz)``, each in ``{-1, 0, 1}``, of the segment to ``(x, y,
    z)``."""
    check_spatial(x, y, z, width)
    ends = (x, y, z)
    signs = [-1 if value < 0 else 1 for value in ends]
    magnitudes = [abs(value) for value in ends]
    a = max(magnitudes)
    f2 = [a - 2 * mag for mag in magnitudes]
    steps = []
    for _ in range(a):
        step = []
        for axis, mag in enumerate(magnitudes):
            if f2[axis] < 0:
                f2[axis] += 2 * (a - mag)
                step.append(signs[axis])
            else:
                f2[axis] -= 2 * mag
                step.append(0)
        steps.append(tuple(step))
    return steps


class SpatialLineCoreModel:
    """Clock-by-clock model of :class:`kontur.hdl.spatial.SpatialLineCore`, register for register.

    :meth:`evaluate` gives this clock's outputs for the feed and abort inputs, :meth:`cycle`
    also takes the segment offered on ``cmd`` (magnitudes ``x``, ``y``, ``z``) and advances.
    """

    def __init__(self, *, width=16, axes=3):
        self.width = width
        self.axes = axes
        self.names = AXIS_NAMES[:axes]
        self.reset()

    def reset(self):
        """Return every register to its reset value (the RTL's synchronous reset)."""
        self.full = self.queued = 0
        self.prepared = None             # (magnitudes, longest), held while full
        self.running = 0
        self.left = 0
        self.functions = [0] * self.axes
        self.stays = [0] * self.axes
        self.moves = [0] * self.axes

    def state(self):
        """Contents of the named registers."""
        return {"left": self.left, "running": self.running,
                **{f"function_{name}": f for name, f in zip(self.names, self.functions)}}

    def _moving(self):
        return [int(f < 0) for f in self.functions]

    def _signals(self, tick, abort):
        due = int(bool(self.running) and not abort)
        stepping = int(due and bool(tick))
        ending = int(stepping and self.left == 1)
        empty = self.prepared is not None and self.prepared[1] == 0
        take = int(not abort and ((bool(self.full) and not self.running)
                                  or (bool(self.queued) and bool(ending))))
        return due, stepping, ending, take, int(take and not empty)

    def evaluate(self, *, tick=1, abort=0):
        """Outputs of this clock: ``step``, ``start``, ``done``, ``ready`` (of ``cmd``),
        ``busy``, ``due``, ``diagonal``."""
        due, stepping, ending, take, go = self._signals(tick, abort)
        moving = self._moving()
        step = sum(bit << axis for axis, bit in enumerate(moving)) if stepping else 0
        empty = take and not go
        mask = (1 << (self.axes - 1).bit_length()) - 1
        return {"step": step, "start": take,
                "done": int(bool(ending) or bool(empty) or bool(abort and self.running)),
                "ready": int(not self.full or bool(take)),
                "busy": int(bool(self.full) or bool(self.running)),
                "due": due, "diagonal": (sum(moving) - 1) & mask}

    def cycle(self, *, tick=1, abort=0, valid=0, payload=None):
        """One clock with segment ``payload`` offered if ``valid``; returns ``(outputs,
        state)``, then advances."""
        outputs = self.evaluate(tick=tick, abort=abort)
        state = self.state()
        _, stepping, ending, take, go = self._signals(tick, abort)
        moving = self._moving()
        if go:
            magnitudes, a = self.prepared
            self.running, self.left = 1, a
            self.functions = [(a - 2 * mag) >> 1 for mag in magnitudes]
            self.stays = list(magnitudes)
            self.moves = [a - mag for mag in magnitudes]
        else:
            if abort or ending:
                self.running = 0
            if stepping:
                self.left -= 1
                self.functions = [f + (move if bit else -stay) for f, move, stay, bit
                                  in zip(self.functions, self.moves, self.stays, moving)]
        if take or abort:
            self.full = self.queued = 0
        if valid and outputs["ready"]:
            magnitudes = [payload[name] for name in self.names]
            self.full, self.queued = 1, int(any(magnitudes))
            self.prepared = (magnitudes, max(magnitudes))
        elif take or abort:
            self.prepared = None
        return outputs, state


def line_steps(x, y, z=0, *, width=16, axes=3):
    """:func:`spatial_steps` on ``axes`` axes: ``(dx, dy)`` steps on two (the registry's
    ``spatial`` line variant), ``(dx, dy, dz)`` on three."""
    return [step[:axes] for step in spatial_steps(x, y, z, width=width)]
