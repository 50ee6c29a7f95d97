"""Any arc from the SU 1665343 quadrant: quadrant/direction mapping, sequencing, checks.

An arc is given relative to its centre: from the start ``(x0, y0)``, a lattice point, to the end
``(x1, y1)``, counter-clockwise or clockwise; a full circle when the two are equal. The radius
is ``sqrt(r2)`` with ``r2 = x0² + y0²`` (not necessarily an integer).

Mapping onto the native quadrant (X = |x| or |y| falling, Y rising):

* each quadrant is *type A* (|x| falls, |y| rises: counter-clockwise in quadrants 1 and 3,
  clockwise in 2 and 4), run with ``X = |x|, Y = |y|``, or *type B*, run with X and Y swapped;
* a point on an axis belongs to the quadrant the motion enters there, so that every run starts
  at native X >= 1 and ends at X = 0, on the axis point where the next run starts;
* every run after the first starts at the axis point ``(Rn, 0)``, ``Rn = round(sqrt(r2))``.

The end point must lie on the arc's lattice path. Exactly those lattice points do whose larger
coordinate ``M = max(|x1|, |y1|)`` is the one the interpolator rounds, i.e. which lie within half
a step of the circle along that axis; in integers: ``-M < r2 - (x1² + y1²) <= M``. (Checked
against the path for every lattice point with r2 <= 20000, integer and not; see the tests.)
"""

import math

from .circular import CORE_VARIANTS, FaithfulCoreModel, FastCoreModel, core_inputs, native_moves
from .errors import InputError

__all__ = ["check_arc", "plan_arc", "arc_steps", "points_ahead", "quadrant", "native",
           "ArcEngineModel", "setup_latency", "round_sqrt"]


def round_sqrt(r2):
    """``round(sqrt(r2))`` for an integer ``r2 >= 0`` (never a tie)."""
    s = math.isqrt(r2)
    return s + 1 if r2 - s * s > s else s


def quadrant(x, y, cw):
    """Quadrant 0-3 (I-IV) of the point, axis points going to the quadrant the motion enters."""
    if not cw:
        if x > 0 and y >= 0:
            return 0
        if x <= 0 and y > 0:
            return 1
        if x < 0 and y <= 0:
            return 2
        return 3
    if x >= 0 and y > 0:
        return 0
    if x < 0 and y >= 0:
        return 1
    if x <= 0 and y < 0:
        return 2
    return 3


SIGNS = ((1, 1), (-1, 1), (-1, -1), (1, -1))


def type_a(q, cw):
    """Whether quadrant ``q`` is run with X = |x| (type A) in direction ``cw``."""
    return (q % 2 == 0) != bool(cw)


def native(x, y, q, cw):
    """Native ``(X, Y)`` of a point of quadrant ``q``."""
    return (abs(x), abs(y)) if type_a(q, cw) else (abs(y), abs(x))


def real_step(step_x, step_y, q, cw):
    """The ``(dx, dy)`` of a native step (``step_x``: X falls by one; ``step_y``: Y rises)."""
    sx, sy = SIGNS[q]
    if type_a(q, cw):
        return (-sx * step_x, sy * step_y)
    return (sx * step_y, -sy * step_x)


def direction_bits(q, cw):
    """The engine's ``dir`` outputs (bit 0 X, bit 1 Y; 1 = negative) in quadrant ``q``."""
    sx, sy = SIGNS[q]
    if type_a(q, cw):
        return int(sx > 0) | int(sy < 0) << 1
    return int(sx < 0) | int(sy > 0) << 1


def check_arc(x0, y0, x1, y1, width):
    """Refuse an arc the ``width``-bit interpolator cannot trace exactly; return ``r2``."""
    for name, value in (("X0", x0), ("Y0", y0), ("X1", x1), ("Y1", y1)):
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"{name} must be an integer, not {value!r}")
    limit = (1 << width) - 1
    for name, value in (("X0", x0), ("Y0", y0), ("X1", x1), ("Y1", y1)):
        if abs(value) > limit:
            raise InputError(f"|{name}| = {abs(value)} is too wide for the {width}-bit "
                             f"registers (at most {limit})")
    r2 = x0 * x0 + y0 * y0
    if r2 == 0:
        raise InputError("the start point is the centre: radius R = 0")
    rn = round_sqrt(r2)
    if rn > limit:
        raise InputError(f"the radius {math.sqrt(r2):.6g} rounds to {rn}, too wide for the "
                         f"{width}-bit registers (at most {limit})")
    big, small = max(abs(x1), abs(y1)), min(abs(x1), abs(y1))
    d = r2 - (x1 * x1 + y1 * y1)
    if not -big < d <= big:
        along = "X" if abs(x1) >= abs(y1) else "Y"
        true = math.sqrt(max(r2 - small * small, 0))
        raise InputError(
            f"the end point ({x1}, {y1}) is not on the circle through the start point "
            f"(radius {math.sqrt(r2):.6g}): its |{along}| = {big} is {abs(big - true):.3g} of "
            f"a step from the circle's {true:.6g}, more than half a step")
    return r2


def plan_arc(x0, y0, x1, y1, cw, width):
    """Plan the quadrant runs of an arc; raises :exc:`InputError` for a refused arc.

    Returns a dict: ``r2``, ``rn``, ``runs`` (a list of dicts ``q``, ``start`` (native),
    ``end`` (native, or ``None`` to run to the axis), ``inputs`` (29, 30, 31, 34)).
    """
    r2 = check_arc(x0, y0, x1, y1, width)
    rn = round_sqrt(r2)
    cw = int(bool(cw))
    q0, qe = quadrant(x0, y0, cw), quadrant(x1, y1, cw)
    start, end = native(x0, y0, q0, cw), native(x1, y1, qe, cw)
    ahead = qe == q0 and (end[1] > start[1] or (end[1] == start[1] and end[0] < start[0]))
    k = ((q0 - qe) if cw else (qe - q0)) % 4
    if k == 0 and not ahead:
        k = 4
    count = k + 1
    if end[1] == 0:                       # the end is the axis point the last run starts on
        count -= 1
    axis_f = (r2 - rn * rn) + rn - 2      # ⌊F⌋ at (Rn, 0)
    runs = []
    for i in range(count):
        q = (q0 - i if cw else q0 + i) % 4
        s = start if i == 0 else (rn, 0)
        if i == 0:
            f = (2 * s[0] - s[1] - 2) if s[1] >= s[0] else (s[0] - 2 * s[1] - 2)
        else:
            f = axis_f
        last = i == count - 1
        runs.append({"q": q, "start": s, "end": end if last and end[1] != 0 else None,
                     "inputs": core_inputs(s[0], s[1], f)})
    return {"r2": r2, "rn": rn, "cw": cw, "runs": runs}


def arc_steps(x0, y0, x1, y1, *, cw=False, width=24):
    """Return the steps ``(dx, dy)`` of the arc (step-level golden model)."""
    return list(_plan_moves(plan_arc(x0, y0, x1, y1, cw, width)))


def _plan_moves(plan):
    for run in plan["runs"]:
        sx, sy = run["start"]
        for move, _ in native_moves(sx, sy, plan["r2"], end=run["end"]):
            yield real_step(int(move in "DX"), int(move in "DY"), run["q"], plan["cw"])


def points_ahead(x0, y0, count, *, cw=False, width=24):
    """The first ``count`` lattice points the arc from ``(x0, y0)`` visits (around the circle)."""
    plan = plan_arc(x0, y0, x0, y0, cw, width)
    x, y = x0, y0
    points = []
    for dx, dy in _plan_moves(plan):
        if len(points) == count:
            break
        x, y = x + dx, y + dy
        points.append((x, y))
    return points


def setup_latency(width):
    """Clocks from accepting an arc to its plan being ready (the RTL's serial arithmetic):
    ``width`` clocks for x0² + y0², ``width`` for x1² + y1², ``width + 1`` for the square root,
    two to form the plan."""
    return 3 * width + 3


class ArcEngineModel:
    """Clock-by-clock model of ``hdl.arc.ArcEngine``.

    A command is accepted when the setup unit is idle; its plan is ready ``setup_latency``
    clocks later and waits there until the sequencer takes it, at the end of the arc before it
    (back to back) or at once if idle. The sequencer loads the core with each run's inputs and
    starts it in the same clock; a run ends by the core's own stop (counter 7 underflow, the
    quadrant is done) or by input 32 in the clock its step reaches the end point.
    """

    def __init__(self, *, variant="faithful", width=24, timing=None, period=1):
        if variant not in CORE_VARIANTS:
            raise ValueError(f"Variant must be one of 'faithful', 'fast', not {variant!r}")
        self.variant = variant
        self.width = width
        self.core = (FaithfulCoreModel(width, timing) if variant == "faithful"
                     else FastCoreModel(width, period))
        self.reset()

    def reset(self):
        self.core.reset()
        self.setup_left = None        # clocks until the plan is ready, None when idle
        self.setup_plan = None        # plan being computed / ready
        self.plan = None              # the arc being traced
        self.run_index = 0
        self.position = (0, 0)        # native position in the current run
        self.dir = 0
        self.swap = 0

    def _prepare(self, payload):
        try:
            return plan_arc(payload["x0"], payload["y0"], payload["x1"], payload["y1"],
                            payload["cw"], self.width)
        except InputError:
            return {"error": 1}

    def state(self):
        return self.core.state()

    def cycle(self, *, valid=0, payload=None, tick=1):
        core = self.core
        plan_ready = self.setup_left == 0
        running = self.plan is not None
        run = self.plan["runs"][self.run_index] if running else None

        # The run's end point is reached by a step in this clock (look-ahead on the position).
        step, stopping = core.peek(tick)
        x, y = self.position
        after = (x - (step & 1), y + (step >> 1 & 1))    # native position after this step
        reached = int(running and run["end"] is not None and step != 0 and after == run["end"])
        core_done = stopping or reached
        last_run = running and self.run_index == len(self.plan["runs"]) - 1
        arc_done = int(running and core_done and last_run)
        next_run = running and core_done and not last_run
        take = plan_ready and (not running or arc_done)
        refuse = take and self.setup_plan.get("error", 0)
        begin = take and not refuse
        cmd_ready = int(self.setup_left is None)
        accepted = valid and cmd_ready

        # Core inputs for this clock.
        load = None
        if begin:
            load = (self.setup_plan, 0)
        elif next_run:
            load = (self.plan, self.run_index + 1)
        if load is not None:
            in29, in30, in31, in34 = load[0]["runs"][load[1]]["inputs"]
        else:
            in29 = in30 = in31 = in34 = 0
        outputs, regs, _ = core.cycle(in29=in29, in30=in30, in31=in31, in34=in34,
                                      in33=int(load is not None), in32=reached, tick=tick)
        assert outputs["step"] == step and outputs["error"] == 0
        if running and outputs["done"] and not reached and run["end"] is not None:
            raise AssertionError("the core stopped before the arc reached its end point")
        # Outputs 35/36 are native Y/X: a type-B quadrant swaps them onto the real axes.
        real = ((step & 1) << 1 | step >> 1) if self.swap else step
        result = {"ready": cmd_ready, "step": real, "dir": self.dir,
                  "busy": int(running or self.setup_left is not None),
                  "done": arc_done, "error": int(bool(refuse))}

        # ---- clock edge -------------------------------------------------------------------
        if running:
            self.position = after
        if load is not None:
            plan, index = load
            self.plan, self.run_index = plan, index
            new_run = plan["runs"][index]
            self.position = new_run["start"]
            self.dir = direction_bits(new_run["q"], plan["cw"])
            self.swap = int(not type_a(new_run["q"], plan["cw"]))
        elif arc_done:
            self.plan = None
        if take:
            self.setup_left, self.setup_plan = None, None
        elif self.setup_left:
            self.setup_left -= 1
        if accepted:
            self.setup_plan = self._prepare(payload)
            self.setup_left = setup_latency(self.width)
        return result, regs
