"""Golden model of helical arcs (``kontur.hdl.helix.HelixEngine``): step level and cycle level.

A helix is an arc frame (``x0``, ``y0``, ``x1``, ``y1``, ``cw``) with ``z``, the Z move, and
``n``, the arc's step count (:func:`helix_frame` fills it in from the arc model). Its XY steps
are the plain arc's; Z steps ride on them, spread by Bresenham's rule over ``n``: an accumulator
starting at ``⌊n/2⌋`` gains ``|z|`` at every XY step and a Z step is made, in that step's clock,
whenever it reaches ``n`` (then it loses ``n``).
"""

from .arc import arc_steps
from .engine import ABORTED, REFUSED
from .errors import InputError

__all__ = ["helix_frame", "check_helix", "helix_steps", "ride", "HelixEngineModel"]


def helix_frame(x0, y0, x1, y1, z, *, cw=0, width=24):
    """The helix frame to ``z`` over the arc, its step count ``n`` from the arc model."""
    n = len(arc_steps(x0, y0, x1, y1, cw=bool(cw), width=width))
    return {"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": int(bool(cw)), "z": z, "n": n}


def check_helix(z, n, width):
    """Refuse a Z move the engine cannot spread over ``n`` steps (more Z steps than XY ones)."""
    if abs(z) > n:
        raise InputError(f"|Z| = {abs(z)} is more than the arc's {n} steps: a helix moves Z "
                         f"at most one step per XY step")
    if n >= 1 << (width + 4):
        raise InputError(f"an arc of {n} steps is too long for the {width}-bit engine")


def helix_steps(x0, y0, x1, y1, cw=0, z=0, n=None, *, width=24):
    """Return the steps ``(dx, dy, dz)`` of the helix (``n`` by default the arc's step
    count)."""
    return ride(arc_steps(x0, y0, x1, y1, cw=bool(cw), width=width), z, n, width=width)


def ride(xy, z, n=None, *, width=24):
    """Z spread over the XY steps ``xy`` of any arc core (the textbook's too): the steps
    ``(dx, dy, dz)``; ``n`` by default ``len(xy)``."""
    n = len(xy) if n is None else n
    check_helix(z, n, width)
    sign = -1 if z < 0 else 1
    accumulator = n >> 1
    steps = []
    for dx, dy in xy:
        accumulator += abs(z)
        dz = 0
        if accumulator >= n and z:
            accumulator -= n
            dz = sign
        steps.append((dx, dy, dz))
    return steps


class HelixEngineModel:
    """Clock-by-clock model of :class:`kontur.hdl.helix.HelixEngine` around an
    :class:`~kontur.sim.models.arc.ArcEngineModel`."""

    def __init__(self, arc, *, number_width=8):
        self.arc = arc
        self.width = arc.width
        self.count_width = arc.width + 4
        self.position_width = self.count_width + 1
        self.number_width = number_width
        self.reset()

    def reset(self):
        self.arc.reset()
        self.active = self.own = 0
        self.own_outcome = REFUSED
        self.number = 0
        self.moved = 0
        self.rate = self.back = self.ahead = 0
        self.moves = self.sign = 0

    def state(self):
        return {**self.arc.state(), "z_ahead": self.ahead, "z_moved": self.moved}

    def _wrap(self, value):
        half = 1 << (self.position_width - 1)
        return (value + half) % (2 * half) - half

    def cycle(self, *, valid=0, payload=None, tick=1, abort=0, status_ready=1):
        limit = (1 << self.count_width) - 1
        z = payload["z"] if payload is not None else 0
        n = payload["n"] if payload is not None else 0
        refused = int(abs(z) > limit or abs(z) > n)
        arc_valid = int(bool(valid) and not self.active and not refused and not abort)
        frame = (None if payload is None
                 else {name: payload[name] for name in ("x0", "y0", "x1", "y1", "cw")})
        arc_out, _ = self.arc.cycle(valid=arc_valid, payload=frame, tick=tick, abort=abort,
                                    status_ready=status_ready)
        ready = int(not self.active and not abort and bool(arc_out["ready"]))
        accept = int(bool(valid) and bool(ready))
        state = self.state()
        coming = int(bool(self.moves) and self.ahead >= 0)
        xy = int(arc_out["step"] != 0)
        z_step = xy & coming
        z_position = self._wrap(self.moved + ((-1 if self.sign else 1) if z_step else 0))
        own_valid = int(bool(self.active) and bool(self.own) and not abort)
        if own_valid:
            status = [self.number, self.own_outcome, [0, 0, 0]] if status_ready else None
        elif arc_out["status"] is not None:
            _, outcome, position = arc_out["status"]
            status = [self.number, outcome, [*position, z_position]]
        else:
            status = None
        outputs = {"ready": ready, "step": arc_out["step"] | z_step << 2,
                   "dir": arc_out["dir"] | self.sign << 2, "busy": self.active,
                   "due": arc_out["due"], "diagonal": arc_out["diagonal"] + coming,
                   "status": status}

        # ---- clock edge -------------------------------------------------------------------
        if xy and not accept:
            self.ahead += self.back if self.ahead >= 0 else self.rate
        if accept:
            self.active, self.own, self.own_outcome = 1, refused, REFUSED
            self.rate = abs(z) & limit
            self.back = self.rate - n
            self.ahead = (n >> 1) + self.rate - n
            self.moves, self.sign = int(z != 0), int(z < 0)
        if abort and self.own:
            self.own_outcome = ABORTED
        self.moved = z_position
        if status is not None:
            self.active = self.own = 0
            self.number = (self.number + 1) % (1 << self.number_width)
            self.moved = 0
        return outputs, state
