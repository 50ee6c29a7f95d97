"""Golden model of helical arcs (``kontur.hdl.helix.HelixEngine``): step level and cycle level.

A helix is an arc frame (``x0``, ``y0``, ``x1``, ``y1``, ``cw``) with ``z``, the Z move, and
``n``, the arc's step count (:func:`helix_frame` fills it in from the arc model). Its XY steps
are the plain arc's; Z steps ride on them, spread by Bresenham's rule over ``n``: an accumulator
starting at ``⌊n/2⌋`` gains ``|z|`` at every XY step and a Z step is made, in that step's clock,
whenever it reaches ``n`` (then it loses ``n``).

``plane`` (0, 1, 2: G17, G18, G19) names the machine axes of the arc's native coordinates and
its linear axis: ``(X, Y, Z)``, ``(Z, X, Y)``, ``(Y, Z, X)``, as LinuxCNC's canonical arcs
(first, second, normal axis); the steps are made natively and rotated (:func:`to_axes`).
"""

from .arc import arc_steps
from .engine import ABORTED, REFUSED
from .errors import InputError

__all__ = ["PLANES", "helix_frame", "check_helix", "helix_steps", "ride", "to_axes", "from_axes",
           "HelixEngineModel"]

#: The HELIX frame's ``plane`` by G-code plane (G17, G18, G19).
PLANES = {17: 0, 18: 1, 19: 2}


def to_axes(native, plane):
    """A native triple ``(a, b, c)`` (the arc's first and second coordinate, its linear axis)
    as the machine's ``(x, y, z)`` in ``plane`` (0, 1, 2): axis ``k`` is native ``(k + plane)
    mod 3``."""
    return tuple(native[(k + plane) % 3] for k in range(3))


def from_axes(point, plane):
    """The machine's ``(x, y, z)`` as the native triple of ``plane``: :func:`to_axes` undone."""
    return tuple(point[(k - plane) % 3] for k in range(3))


def helix_frame(x0, y0, x1, y1, z, *, cw=0, width=24, plane=0):
    """The helix frame to ``z`` over the arc, its step count ``n`` from the arc model."""
    n = len(arc_steps(x0, y0, x1, y1, cw=bool(cw), width=width))
    return {"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": int(bool(cw)), "z": z, "n": n,
            "plane": plane}


def check_helix(z, n, width):
    """Refuse a Z move the engine cannot spread over ``n`` steps (more Z steps than XY ones)."""
    if abs(z) > n:
        raise InputError(f"|Z| = {abs(z)} is more than the arc's {n} steps: a helix moves Z "
                         f"at most one step per XY step")
    if n >= 1 << (width + 4):
        raise InputError(f"an arc of {n} steps is too long for the {width}-bit engine")


def helix_steps(x0, y0, x1, y1, cw=0, z=0, n=None, *, width=24, plane=0):
    """Return the steps ``(dx, dy, dz)`` of the helix (``n`` by default the arc's step
    count), on the machine's axes for ``plane``."""
    steps = ride(arc_steps(x0, y0, x1, y1, cw=bool(cw), width=width), z, n, width=width)
    return [to_axes(step, plane) for step in steps] if plane else steps


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
        self.plane = 0

    def state(self):
        return {**self.arc.state(), "z_ahead": self.ahead, "z_moved": self.moved}

    def _wrap(self, value):
        half = 1 << (self.position_width - 1)
        return (value + half) % (2 * half) - half

    def cycle(self, *, valid=0, payload=None, tick=1, abort=0, status_ready=1):
        limit = (1 << self.count_width) - 1
        z = payload["z"] if payload is not None else 0
        n = payload["n"] if payload is not None else 0
        plane = payload.get("plane", 0) if payload is not None else 0
        refused = int(abs(z) > limit or abs(z) > n or plane == 3)
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
            status = [self.number, outcome, list(to_axes((*position, z_position), self.plane))]
        else:
            status = None

        def rotated(bits):
            return sum(b << k for k, b in enumerate(to_axes([bits >> k & 1 for k in range(3)],
                                                            self.plane)))

        outputs = {"ready": ready, "step": rotated(arc_out["step"] | z_step << 2),
                   "dir": rotated(arc_out["dir"] | self.sign << 2), "busy": self.active,
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
            self.plane = plane
        if abort and self.own:
            self.own_outcome = ABORTED
        self.moved = z_position
        if status is not None:
            self.active = self.own = 0
            self.number = (self.number + 1) % (1 << self.number_width)
            self.moved = 0
        return outputs, state
