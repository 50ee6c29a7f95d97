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

from .circular import core_inputs, native_moves
from .engine import DONE, REFUSED, StatusModel
from .errors import InputError

__all__ = ["check_arc", "plan_arc", "arc_steps", "points_ahead", "quadrant", "native",
           "arc_plan", "setup_latency", "round_sqrt", "ArcPlannerModel", "ArcEngineModel"]


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

    Returns a dict: ``r2``, ``rn``, ``cw``, ``start`` and ``end`` (native, in their own
    quadrants), ``runs`` (a list of dicts ``q``, ``start`` (native), ``end`` (native, or
    ``None`` to run to the axis), ``inputs`` (29, 30, 31, 34)).
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
    return {"r2": r2, "rn": rn, "cw": cw, "start": start, "end": end, "runs": runs}


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
    """Clocks from an arc taken by :class:`kontur.hdl.arc.ArcPlanner` to its plan offered: ``width``
    clocks for x0² + y0², ``width`` for x1² + y1², one to check the end point, ``width + 1`` for
    the square root, one to form the plan, one to offer it."""
    return 3 * width + 4


def arc_plan(payload, width):
    """The plan :class:`kontur.hdl.arc.ArcPlanner` offers for the arc ``payload`` (a frame dict):
    ``refused``, and for an arc not refused ``cw``, ``quadrant``, ``runs``, ``start``,
    ``end`` (native, in the last run's quadrant), ``off_axis`` (the end is not the axis point
    the last run starts on), ``distance`` (steps along X and Y from the last run's start to the
    end, ``X - end X + end Y - Y``), ``radius``, ``residue``."""
    try:
        plan = plan_arc(payload["x0"], payload["y0"], payload["x1"], payload["y1"],
                        payload["cw"], width)
    except InputError:
        return {"refused": 1}
    last = plan["runs"][-1]["start"]
    end = plan["end"]
    return {"refused": 0, "cw": plan["cw"], "quadrant": plan["runs"][0]["q"],
            "runs": len(plan["runs"]), "start": plan["start"], "end": end,
            "off_axis": int(end[1] != 0),
            "distance": last[0] - end[0] + end[1] - last[1],
            "radius": plan["rn"], "residue": plan["r2"] - plan["rn"] ** 2}


class ArcPlannerModel:
    """Clock-by-clock model of :class:`kontur.hdl.arc.ArcPlanner`: takes an arc while it holds no
    plan, offers its plan :func:`setup_latency` clocks later, until it is transferred. While
    ``keep`` is set the plan before it is still in use (its radius and residue), and the
    planner waits in the clock before the offer."""

    def __init__(self, width):
        self.width = width
        self.reset()

    def reset(self):
        self.left = None                  # clocks until the plan is offered; None: idle
        self.plan = None

    @property
    def ready(self):
        return int(self.left is None)

    @property
    def valid(self):
        return int(self.left == 0)

    def cycle(self, *, valid, payload, o_ready, keep=0):
        if self.left is None:
            if valid:
                self.plan = arc_plan(payload, self.width)
                self.left = setup_latency(self.width) - 1     # offered from that clock on
        elif self.left == 0:
            if o_ready:
                self.left, self.plan = None, None
        elif not (self.left == 1 and keep):
            self.left -= 1


class ArcEngineModel:
    """Clock-by-clock model of :class:`kontur.hdl.arc.ArcEngine` around a quadrant core model.

    ``core`` is the model of the RTL's core (:class:`~kontur.sim.models.circular.FaithfulArcCoreModel`
    or :class:`~kontur.sim.models.circular.FastArcCoreModel`): ``width``, ``reset()``, ``state()``,
    ``peek(tick=, abort=)``, ``evaluate(tick=, stop=, abort=)`` and ``cycle(tick=, stop=,
    abort=, valid=, payload=)``, as the RTL core has its :class:`~kontur.hdl.arc.ArcCoreSignature`.
    """

    def __init__(self, core, *, number_width=8):
        self.core = core
        self.width = core.width
        self.planner = ArcPlannerModel(self.width)
        self.status = StatusModel(position_width=self.width + 2, number_width=number_width)
        self.reset()

    def reset(self):
        self.core.reset()
        self.planner.reset()
        self.status.reset()
        self.active = 0
        self.later_runs = 0
        self.to_offer = 0
        self.first_offered = 0
        self.cw = 0
        self.quadrant = 0
        self.radius = 0
        self.residue = 0
        self.end = (0, 0)
        self.position = (0, 0)            # native, in the running run
        self.swap = 0
        self.dir = 0

    def state(self):
        return self.core.state()

    def _enter(self, q, cw):
        self.swap = int(not type_a(q, cw))
        self.dir = direction_bits(q, cw)

    def cycle(self, *, valid=0, payload=None, tick=1, abort=0, status_ready=1):
        core, planner, status = self.core, self.planner, self.status
        plan = planner.plan if planner.valid else None
        hold = status.hold
        tick = int(bool(tick) and not hold)

        # The run's end point is reached by a step in this clock (look-ahead on the position).
        step = core.peek(tick=tick, abort=abort)
        x, y = self.position
        after = (x - (step & 1), y + (step >> 1 & 1))
        last_run = self.active and self.later_runs == 0
        reached = int(bool(last_run) and self.end[1] != 0 and step != 0 and after == self.end)
        out = core.evaluate(tick=tick, stop=reached, abort=abort)
        assert out["step"] == step
        if last_run and out["done"] and not reached and not abort and self.end[1] != 0:
            raise AssertionError("the core stopped before the arc reached its end point")
        arc_done = int(bool(last_run) and bool(out["done"]) and not abort)
        begin = int(bool(out["start"]) and not (self.active and self.later_runs != 0))
        following = int(bool(out["start"]) and bool(self.active) and self.later_runs != 0)
        refuse = int(plan is not None and plan["refused"] and not out["busy"] and not hold
                     and not abort)
        plan_ready = begin or refuse

        # Runs handed to the core: this arc's later quadrants, then the next plan's first run.
        keep = self.to_offer != 0         # the planner keeps this arc's radius and residue
        # (the next plan's first axis run is offered once its first run is prepared; the core
        # takes it as that run starts, when the plan begins)
        offer_axis = (self.to_offer != 0
                      or bool(self.first_offered and plan is not None and plan["runs"] > 1))
        offer_first = (not offer_axis and not begin and plan is not None
                       and not plan["refused"] and not self.first_offered)
        core_valid = int((offer_axis or offer_first) and not abort)
        if offer_axis:
            radius, residue = ((plan["radius"], plan["residue"]) if self.to_offer == 0
                               else (self.radius, self.residue))
            run = {"x": radius, "y": 0, "residue": residue}
        elif offer_first:
            run = {"x": plan["start"][0], "y": plan["start"][1], "residue": 0}
        else:
            run = None
        offered = core_valid and out["ready"]

        end = int(bool(arc_done) or bool(refuse))
        real = ((step & 1) << 1 | step >> 1) if self.swap else step
        stream = status.evaluate(step=real, direction=self.dir, end=end,
                                 outcome=REFUSED if refuse else DONE,
                                 status_ready=status_ready)
        accepting = not abort and not status.flushing
        ready = int(bool(planner.ready) and accepting)
        accept = int(bool(valid) and bool(ready))
        outputs = {"ready": ready, "step": real, "dir": self.dir, "busy": status.busy,
                   "due": int(bool(out["due"]) and not hold), "diagonal": out["diagonal"],
                   "status": stream["payload"] if stream["transfer"] else None}
        state = self.state()

        # ---- clock edge -------------------------------------------------------------------
        core.cycle(tick=tick, stop=reached, abort=abort, valid=core_valid, payload=run)
        if begin:
            self.to_offer = plan["runs"] - 1 - int(bool(offered and offer_axis))
            self.first_offered = 0
        else:
            if offered and offer_axis:
                self.to_offer -= 1
            if offered and offer_first:
                self.first_offered = 1
        if begin:
            self.active, self.later_runs = 1, plan["runs"] - 1
            self.cw, self.quadrant = plan["cw"], plan["quadrant"]
            self.radius, self.residue, self.end = plan["radius"], plan["residue"], plan["end"]
            self.position = plan["start"]
            self._enter(plan["quadrant"], plan["cw"])
        elif following:
            self.later_runs -= 1
            self.quadrant = (self.quadrant - 1 if self.cw else self.quadrant + 1) % 4
            self.position = (self.radius, 0)
            self._enter(self.quadrant, self.cw)
        else:
            if arc_done:
                self.active = 0
            if self.active:
                self.position = after
        if abort:
            self.active = self.later_runs = self.to_offer = self.first_offered = 0
        if abort:
            planner.reset()
        else:
            planner.cycle(valid=bool(valid) and accepting, payload=payload, o_ready=plan_ready,
                          keep=keep)
        status.advance(accept=accept, flush=abort)
        return outputs, state
