"""Golden models of the textbook interpolators: estimating function with separate steps, and DDA.

**Separate steps** (the textbook's Fig. 11: one axis per step). The text's estimating
functions are ``F = y·X - x·Y`` for the line to ``(X, Y)`` and ``F = x² + y² - R²`` for the
circle; the sign of F chooses the axis. Here F is evaluated at the *midpoint* of the two
points the next step can reach, not at the point reached: that is the sign of ``F(a) + F(b)``
for the two candidates ``a`` and ``b``, so the step goes to the candidate nearer the curve
(see ``docs/textbook.md`` for why: it closes every quadrant on the arc planner's axis point
``(0, Rn)``, passes through every end point the planner accepts, never steps an exhausted axis,
and halves the line's deviation). Exact integers:

* line, first quadrant, magnitudes ``X, Y``: ``D = 2F(x + 1/2, y + 1/2) = 2(y·X - x·Y) + X - Y``,
  ``D0 = X - Y``. ``D >= 0`` -> X step, ``D -= 2Y``; ``D < 0`` -> Y step, ``D += 2X``.
  ``X + Y`` steps; ``D`` stays in ``[-2Y, 2X)``. The tie ``D = 0`` (the line through the
  midpoint: both candidates equally near) goes to X: the decision is the register's sign bit.
* circle, native quadrant (X falls, Y rises, as SU 1665343's; ``r2`` the square of the radius):
  ``G = F(x - 1/2, y + 1/2) - 1/2 = x² - x + y² + y - r2``, ``G0 = y - x - residue`` with
  ``residue = r2 - x² - y²``. ``G >= 0`` -> X step, ``G -= 2x'``; ``G < 0`` -> Y step,
  ``G += 2y'`` (primes: after the step). ``F`` at the midpoint is ``G + 1/2``, never zero: no
  tie. A quadrant from ``(Rn, 0)`` has ``2·Rn`` steps and ends on ``(0, Rn)``.

The ``lattice_*`` functions are the text's rule taken literally, F at the point reached, with
the tie ``F = 0`` to X; they are a reference for ``kontur bench accuracy``, not a core.

**DDA** (ЦДА): two registers of capacity ``N = 2**n``; each iteration adds ``|X|`` to one and
``|Y|`` to the other, and an overflow (the sum reaching N, which is then subtracted) is a step
of that axis. After exactly N iterations the registers have overflowed ``|X|`` and ``|Y|``
times. Both start at ``N/2`` (``preset="half"``: the point after k iterations is
``round(k·X/N)``) or at zero (``"zero"``: ``floor(k·X/N)``). The capacity is ``2**width``
(``capacity="register"``) or, per segment, the smallest power of two above ``max(|X|, |Y|)``
(``capacity="segment"``: N is then at most twice the longer projection).

The cycle-level models mirror ``kontur.hdl.textbook.SeparateLineCore``, ``SeparateArcCore`` and
``DdaCore`` register for register.
"""

from .arc import plan_arc, real_step
from .codes import from_code, mask
from .engine import permit
from .linear import check_line

__all__ = ["separate_line_moves", "separate_line_steps", "separate_native_moves",
           "separate_native_path", "separate_arc_steps", "separate_points_ahead",
           "lattice_line_steps", "lattice_native_path",
           "PRESETS", "CAPACITIES", "dda_capacity", "dda_iterations", "dda_steps",
           "SeparateLineCoreModel", "SeparateArcCoreModel", "DdaCoreModel"]

PRESETS = ("half", "zero")
CAPACITIES = ("segment", "register")


def _signs(x, y):
    return (-1 if x < 0 else 1), (-1 if y < 0 else 1)


# ---- separate steps: line ----------------------------------------------------------------

def separate_line_moves(x_end, y_end):
    """Generate the moves ``("X" or "Y", D after the move)`` of the line to magnitudes
    ``(x_end, y_end)``."""
    if x_end < 0 or y_end < 0:
        raise ValueError(f"magnitudes must not be negative, not ({x_end}, {y_end})")
    d = x_end - y_end
    x = y = 0
    for _ in range(x_end + y_end):
        if d >= 0:
            x += 1
            d -= 2 * y_end
            move = "X"
        else:
            y += 1
            d += 2 * x_end
            move = "Y"
        yield move, d
    assert (x, y) == (x_end, y_end), "the path must end on the end point"


def separate_line_steps(x, y, *, width=16):
    """Return the steps ``(dx, dy)`` of the line to ``(x, y)``, one axis each (``|x| + |y|``)."""
    check_line(x, y, width)
    sx, sy = _signs(x, y)
    return [(sx, 0) if move == "X" else (0, sy) for move, _ in separate_line_moves(abs(x),
                                                                                     abs(y))]


def lattice_line_steps(x, y):
    """The text's rule taken literally: ``F = y·X - x·Y`` at the point reached, ``F >= 0`` -> X
    (an exhausted axis is never stepped). Steps ``(dx, dy)``; a reference, not a core."""
    ax, ay = abs(x), abs(y)
    sx, sy = _signs(x, y)
    f = px = py = 0
    result = []
    for _ in range(ax + ay):
        if py == ay or (f >= 0 and px < ax):
            px += 1
            f -= ay
            result.append((sx, 0))
        else:
            py += 1
            f += ax
            result.append((0, sy))
    return result


# ---- separate steps: circle --------------------------------------------------------------

def separate_native_moves(x, y, r2, *, end=None):
    """Generate the native moves from ``(x, y)`` on the circle of ``r2``: ``("X" or "Y", G after
    the move)``, until X = 0 or until the position equals ``end``."""
    if x < 1 or y < 0:
        raise ValueError(f"native start must have X >= 1 and Y >= 0, not ({x}, {y})")
    g = x * x - x + y * y + y - r2
    while x > 0 and (x, y) != end:
        if g >= 0:
            x -= 1
            g -= 2 * x
            move = "X"
        else:
            y += 1
            g += 2 * y
            move = "Y"
        yield move, g
    if end is not None and (x, y) != end:
        raise AssertionError(f"the path from the start never reaches the end point {end}")


def separate_native_path(x, y, r2, *, end=None):
    """Lattice points of the native path from ``(x, y)``, start included."""
    points = [(x, y)]
    for move, _ in separate_native_moves(x, y, r2, end=end):
        x, y = (x - 1, y) if move == "X" else (x, y + 1)
        points.append((x, y))
    return points


def lattice_native_path(x, y, r2):
    """The text's rule taken literally: ``F = x² + y² - r2`` at the point reached, ``F >= 0`` ->
    X. Lattice points from ``(x, y)`` until X = 0; a reference, not a core."""
    f = x * x + y * y - r2
    points = [(x, y)]
    while x > 0:
        if f >= 0:
            x -= 1
            f -= 2 * x + 1
        else:
            y += 1
            f += 2 * y - 1
        points.append((x, y))
    return points


def _arc_moves(plan):
    for run in plan["runs"]:
        sx, sy = run["start"]
        for move, _ in separate_native_moves(sx, sy, plan["r2"], end=run["end"]):
            yield real_step(int(move == "X"), int(move == "Y"), run["q"], plan["cw"])


def separate_arc_steps(x0, y0, x1, y1, *, cw=False, width=24):
    """Return the steps ``(dx, dy)`` of the arc, planned as :func:`kontur.sim.models.arc.plan_arc`
    plans it for the arc engine; raises :exc:`InputError` for an arc it refuses."""
    return list(_arc_moves(plan_arc(x0, y0, x1, y1, cw, width)))


def separate_points_ahead(x0, y0, count, *, cw=False, width=24):
    """The first ``count`` lattice points the separate-step arc from ``(x0, y0)`` visits."""
    x, y = x0, y0
    points = []
    for dx, dy in _arc_moves(plan_arc(x0, y0, x0, y0, cw, width)):
        if len(points) == count:
            break
        x, y = x + dx, y + dy
        points.append((x, y))
    return points


# ---- DDA ---------------------------------------------------------------------------------

def _check_choice(name, value, choices):
    if value not in choices:
        options = ", ".join(repr(c) for c in choices)
        raise ValueError(f"{name} must be one of {options}, not {value!r}")


def dda_capacity(x, y, *, width, capacity="segment"):
    """``n`` of the capacity ``N = 2**n`` for the segment to ``(x, y)`` (0 for length zero with
    ``"segment"``)."""
    _check_choice("Capacity", capacity, CAPACITIES)
    if capacity == "register":
        return width
    return max(abs(x), abs(y)).bit_length()


def dda_iterations(x, y, *, width=16, preset="half", capacity="segment"):
    """Return the ``(dx, dy)`` of every iteration of the DDA, ``(0, 0)`` where neither register
    overflows: ``N = 2**n`` items (none for a segment of length zero)."""
    check_line(x, y, width)
    _check_choice("Preset", preset, PRESETS)
    ax, ay = abs(x), abs(y)
    if ax == 0 and ay == 0:
        return []
    n = dda_capacity(ax, ay, width=width, capacity=capacity)
    capacity_n = 1 << n
    sx, sy = _signs(x, y)
    acc_x = acc_y = capacity_n >> 1 if preset == "half" else 0
    result = []
    for _ in range(capacity_n):
        acc_x += ax
        acc_y += ay
        dx, dy = acc_x >= capacity_n, acc_y >= capacity_n
        acc_x -= capacity_n * dx
        acc_y -= capacity_n * dy
        result.append((sx * dx, sy * dy))
    return result


def dda_steps(x, y, *, width=16, preset="half", capacity="segment"):
    """The steps of :func:`dda_iterations` (the iterations that step)."""
    return [s for s in dda_iterations(x, y, width=width, preset=preset, capacity=capacity)
            if s != (0, 0)]


# ---- cycle-level models ------------------------------------------------------------------

class _PreparedCore:
    """What the textbook cores share: one command prepared while another runs, started in the
    clock the running one ends (a command of length zero in an idle clock), and the interface
    the front-end models call: ``evaluate``, ``cycle``, ``reset``, ``state``."""

    def __init__(self, width):
        self.width = width
        self.reset()

    def reset(self):
        """Return every register to its reset value (the RTL's synchronous reset)."""
        self.prepared = None
        self.running = 0
        self._clear()

    # Subclasses: _clear(), _prepare(payload), _empty(prepared), _advance(tick, stop, abort)
    # -> (step, last, due, diagonal, update), _start(prepared).

    def _outputs(self, tick, stop, abort):
        step, last, due, diagonal, update = self._advance(tick, stop, abort)
        empty = self.prepared is not None and self._empty(self.prepared)
        take = int(self.prepared is not None and not abort
                   and (not self.running or (bool(last) and not empty)))
        done = int((bool(self.running) and (bool(last) or bool(abort)))
                   or (bool(take) and empty))
        outputs = {"step": step, "start": take, "done": done,
                   "ready": int(self.prepared is None or bool(take)),
                   "busy": int(self.prepared is not None or bool(self.running)),
                   "due": due, "diagonal": diagonal}
        return outputs, last, update

    def evaluate(self, *, tick=1, stop=0, abort=0):
        """Outputs of this clock: ``step``, ``start``, ``done``, ``ready`` (of ``cmd``),
        ``busy``, ``due``, ``diagonal``."""
        return self._outputs(tick, stop, abort)[0]

    def cycle(self, *, tick=1, stop=0, abort=0, valid=0, payload=None):
        """One clock with the command ``payload`` offered if ``valid``; returns ``(outputs,
        state)``, then advances."""
        outputs, last, update = self._outputs(tick, stop, abort)
        state = self.state()
        if outputs["start"]:
            prepared = self.prepared
            if self._empty(prepared):
                self.running = 0
                self._clear()
            else:
                self.running = 1
                self._start(prepared)
        elif abort or last:
            self.running = 0
            self._clear()
        else:
            update()
        if valid and outputs["ready"]:
            self.prepared = self._prepare(payload)
        elif outputs["start"] or abort:
            self.prepared = None
        return outputs, state


class SeparateLineCoreModel(_PreparedCore):
    """Clock-by-clock model of :class:`kontur.hdl.textbook.SeparateLineCore`: one step per permission.

    Registers: adder D (``width + 2`` bits), counters of the X and Y steps left, the segment's
    magnitudes (the increments ``2Y`` and ``2X``), the run trigger.
    """

    def _clear(self):
        self.adder = self.counter_x = self.counter_y = self.reg_x = self.reg_y = 0

    def state(self):
        return {"adder": self.adder, "counter_x": self.counter_x, "counter_y": self.counter_y,
                "trigger": self.running}

    def _prepare(self, payload):
        return payload["x"], payload["y"]

    def _empty(self, prepared):
        return prepared == (0, 0)

    def _start(self, prepared):
        x, y = prepared
        self.adder = x - y
        self.counter_x, self.counter_y = x, y
        self.reg_x, self.reg_y = x, y

    def _advance(self, tick, stop, abort):
        due, enable = permit(tick, armed=1, running=self.running, abort=abort)
        move = self.running and enable
        x_step = int(bool(move) and self.adder >= 0)
        y_step = int(bool(move) and self.adder < 0)
        last = int((x_step and self.counter_x == 1 and self.counter_y == 0)
                   or (y_step and self.counter_x == 0 and self.counter_y == 1))

        def update():
            aw = self.width + 2
            if x_step:
                self.adder = from_code(self.adder - 2 * self.reg_y, aw)
                self.counter_x -= 1
            elif y_step:
                self.adder = from_code(self.adder + 2 * self.reg_x, aw)
                self.counter_y -= 1
        return x_step | y_step << 1, last, due, 0, update


class SeparateArcCoreModel(_PreparedCore):
    """Clock-by-clock model of :class:`kontur.hdl.textbook.SeparateArcCore`: one step per permission,
    native quadrant runs until X = 0 or ``stop``.

    Registers: adder G (``width + 2`` bits), counter X holding ``x - 1``, counter Y holding
    ``y + 1`` (so that the increments ``2x'`` and ``2y'`` are twice their present contents), the
    run trigger.
    """

    def _clear(self):
        self.adder = self.counter_x = self.counter_y = 0

    def state(self):
        return {"adder": self.adder, "counter_x": self.counter_x, "counter_y": self.counter_y,
                "trigger": self.running}

    def _prepare(self, payload):
        x, y = payload["x"], payload["y"]
        return (from_code(y - x - payload["residue"], self.width + 2), x - 1, y + 1)

    def _empty(self, prepared):
        return False

    def _start(self, prepared):
        self.adder, self.counter_x, self.counter_y = prepared

    def _advance(self, tick, stop, abort):
        due, enable = permit(tick, armed=1, running=self.running, abort=abort)
        move = self.running and enable
        x_step = int(bool(move) and self.adder >= 0)
        y_step = int(bool(move) and self.adder < 0)
        last = int(bool(self.running) and ((x_step and self.counter_x == 0) or bool(stop)))

        def update():
            aw = self.width + 2
            if x_step:
                self.adder = from_code(self.adder - 2 * self.counter_x, aw)
                self.counter_x -= 1
            elif y_step:
                self.adder = from_code(self.adder + 2 * self.counter_y, aw)
                self.counter_y = from_code(self.counter_y + 1, self.width + 2)
        return x_step | y_step << 1, last, due, 0, update

    def peek(self, *, tick=1, abort=0):
        """This clock's native step (it does not depend on ``stop``)."""
        return self._advance(tick, 0, abort)[0]


class DdaCoreModel(_PreparedCore):
    """Clock-by-clock model of :class:`kontur.hdl.textbook.DdaCore`.

    Registers: the two registers of capacity ``N = mask + 1``, the iteration counter (iterations
    left after this one), the increments, the mask, the run trigger. An iteration in which
    neither register overflows runs freely; one that steps waits for the permission (``due``
    looks ahead at the sums).
    """

    def __init__(self, *, width=16, preset="half", capacity="segment"):
        _check_choice("Preset", preset, PRESETS)
        _check_choice("Capacity", capacity, CAPACITIES)
        self.preset = preset
        self.capacity = capacity
        super().__init__(width)

    def _clear(self):
        self.register_x = self.register_y = self.counter = 0
        self.inc_x = self.inc_y = self.mask = 0

    def state(self):
        return {"register_x": self.register_x, "register_y": self.register_y,
                "counter": self.counter, "trigger": self.running}

    def _prepare(self, payload):
        x, y = payload["x"], payload["y"]
        if self.capacity == "register":
            capacity_mask = mask(self.width)
        else:
            capacity_mask = mask(max(x, y).bit_length())
        return x, y, capacity_mask

    def _empty(self, prepared):
        return prepared[:2] == (0, 0)

    def _start(self, prepared):
        x, y, capacity_mask = prepared
        preset = (capacity_mask + 1) >> 1 if self.preset == "half" else 0
        self.register_x = self.register_y = preset
        self.inc_x, self.inc_y, self.mask = x, y, capacity_mask
        self.counter = capacity_mask

    def _advance(self, tick, stop, abort):
        sum_x = self.register_x + self.inc_x
        sum_y = self.register_y + self.inc_y
        over_x = int(bool(self.running) and sum_x > self.mask)
        over_y = int(bool(self.running) and sum_y > self.mask)
        over = over_x | over_y
        due, enable = permit(tick, armed=1, running=int(bool(self.running) and bool(over)),
                             free=1 - over, abort=abort)
        iterate = int(bool(self.running) and bool(enable))
        step = (over_x | over_y << 1) if iterate else 0
        last = int(bool(iterate) and self.counter == 0)

        def update():
            if iterate:
                self.register_x = sum_x & self.mask
                self.register_y = sum_y & self.mask
                self.counter -= 1
        return step, last, due, int(bool(over_x) and bool(over_y)), update
