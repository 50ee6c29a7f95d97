"""Golden model of the SU 1571551 linear interpolator, at step level and at cycle level.

Notation. ``a = max(|X|, |Y|)`` is the long projection, ``b = min(|X|, |Y|)`` the short one. A
*long* step (P) moves along the long axis only; a *diagonal* (D, the patent's combined step)
moves along both. The estimating function starts at ``F0 = a/2 - b`` (eq. 2); F >= 0 gives a
long step, F < 0 a diagonal. Exact integers: the step model keeps ``f2 = 2F``.

Two variants of the same structure (see ``docs/linear.md``):

* ``exact`` realises eq. (1): constant increments, long step ``F -= b``, diagonal
  ``F += a - b``. This is the midpoint (Bresenham) rule and keeps every point within
  ``0.5 cos α`` of the segment (α measured from the long axis).
* ``device`` reproduces the patent's block diagram, whose multiplexer feeds the *current*
  counter contents (eq. 5): long step ``F -= C2`` (diagonals left), diagonal ``F += C1``
  (long steps left). Its worked table is this variant. It ends on the end point in the same
  number of clocks but does not keep the ``0.5 cos α`` bound.

The cycle-level model mirrors ``hdl.linear.LineEngine`` register for register; the adder there
holds the integer part ``⌊F⌋`` (the half of ``F0`` never changes the sign test), so
``adder3 = f2 >> 1``.
"""

from .errors import InputError

__all__ = ["VARIANTS", "check_line", "patent_inputs", "table", "steps", "LineEngineModel"]

VARIANTS = ("device", "exact")


def _check_variant(variant):
    if variant not in VARIANTS:
        raise ValueError(f"Variant must be one of 'device', 'exact', not {variant!r}")


def check_line(x, y, width):
    """Refuse an end point whose magnitude does not fit the ``width``-bit registers."""
    for name, value in (("X", x), ("Y", y)):
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"{name} must be an integer, not {value!r}")
        if abs(value) > (1 << width) - 1:
            raise InputError(f"|{name}| = {abs(value)} is too wide for the {width}-bit registers "
                             f"(at most {(1 << width) - 1})")


def patent_inputs(x, y):
    """Values of the patent's inputs 22-25 for the segment to ``(x, y)``.

    Returns ``(in22, in23, in24, in25)``: counter 1 ``||X| - |Y||``, counter 2 ``min``, adder 3
    ``⌊F0⌋ = ⌊max/2 - min⌋``, trigger 15 ``|X| >= |Y|``.
    """
    ax, ay = abs(x), abs(y)
    a, b = max(ax, ay), min(ax, ay)
    return a - b, b, (a - 2 * b) >> 1, int(ax >= ay)


def table(x, y, variant="exact"):
    """Return the patent's worked table for the segment to ``(x, y)``: one row per clock.

    Each row is a dict with ``move`` (``"P"`` long step, ``"D"`` diagonal), ``f2`` (2F after
    the step), ``c1`` (long-only steps left, counter 1) and ``c2`` (diagonals left, the value
    counter 2 stands for).
    """
    _check_variant(variant)
    ax, ay = abs(x), abs(y)
    a, b = max(ax, ay), min(ax, ay)
    f2, c1, c2 = a - 2 * b, a - b, b
    rows = []
    for _ in range(a):
        if f2 >= 0:
            f2 -= 2 * (c2 if variant == "device" else b)
            c1 -= 1
            move = "P"
        else:
            f2 += 2 * (c1 if variant == "device" else a - b)
            c2 -= 1
            move = "D"
        rows.append({"move": move, "f2": f2, "c1": c1, "c2": c2})
    assert c1 == 0 and c2 == 0, "counters must be exhausted exactly at the end point"
    return rows


def steps(x, y, *, variant="exact", width=16):
    """Return the steps ``(dx, dy)``, ``dx, dy ∈ {-1, 0, 1}``, of the segment to ``(x, y)``."""
    check_line(x, y, width)
    sx, sy = (-1 if x < 0 else 1), (-1 if y < 0 else 1)
    x_long = abs(x) >= abs(y)
    result = []
    for row in table(x, y, variant):
        long_x = long_y = 0
        if x_long:
            long_x = 1
        else:
            long_y = 1
        diagonal = row["move"] == "D"
        dx = 1 if (long_x or diagonal) else 0
        dy = 1 if (long_y or diagonal) else 0
        result.append((sx * dx, sy * dy))
    return result


class LineEngineModel:
    """Clock-by-clock model of :class:`hdl.linear.LineEngine`.

    Call :meth:`cycle` once per clock with the inputs of that clock; it returns the outputs
    during that clock and the contents of the named registers, then advances to the next clock.
    """

    def __init__(self, *, variant="exact", width=16, period=1, coord_width=None):
        _check_variant(variant)
        self.variant = variant
        self.width = width
        self.period = period
        self.coord_width = coord_width if coord_width is not None else max(32, width + 1)
        self.reset()

    def reset(self):
        """Return every register to its reset value (the RTL's synchronous reset)."""
        self.prep = None                 # frame register of the engine: None or a dict
        self.counter1 = 0
        self.counter2 = 0
        self.adder3 = 0
        self.reg22 = 0                   # exact variant: constant increments
        self.reg23 = 0
        self.trigger14 = 0
        self.trigger15 = 0
        self.phase = 0                   # generator 4
        self.dir = 0

    def _prepare(self, payload):
        x, y = payload["x"], payload["y"]
        limit = (1 << self.width) - 1
        bad = int(abs(x) > limit or abs(y) > limit)
        in22, in23, in24, in25 = (0, 0, 0, 0) if bad else patent_inputs(x, y)
        return {"in22": in22, "in23": in23, "in24": in24, "in25": in25, "bad": bad,
                "dir": int(x < 0) | int(y < 0) << 1}

    def state(self):
        """Contents of the named registers."""
        return {"adder3": self.adder3, "counter1": self.counter1, "counter2": self.counter2,
                "trigger14": self.trigger14, "trigger15": self.trigger15}

    def cycle(self, *, valid=0, payload=None, tick=1):
        # ---- combinational: node 18 (generator 4, AND 5, AND 6) --------------------------------
        gen4 = int(bool(tick) and self.phase == 0)
        sign = int(self.adder3 < 0)
        and5 = gen4 & self.trigger14 & (1 - sign)          # F >= 0: long step (output 16)
        and6 = gen4 & self.trigger14 & sign                # F < 0: diagonal (output 17)
        # ---- node 21 (AND 9, OR 13, trigger 14): AND 9 on the counters' next contents ----------
        c1_next = self.counter1 - and5
        c2_next = self.counter2 - and6
        and9_run = int(self.trigger14 and c1_next == 0 and c2_next == -1)
        p = self.prep
        empty = int(p is not None and p["in22"] == 0 and p["in23"] == 0)
        core_ready = int(not self.trigger14 or (and9_run and not empty))
        take = int(p is not None and core_ready)
        start = take & (1 - p["bad"]) if take else 0       # input 26, "start of frame"
        refuse = take & p["bad"] if take else 0
        and9_load = start & empty
        go = start & (1 - empty)
        and9 = and9_run | and9_load
        # ---- node 20 (AND 7, AND 8, OR 10, OR 11) ----------------------------------------------
        x_step = (and5 & self.trigger15) | and6
        y_step = (and5 & (1 - self.trigger15)) | and6
        cmd_ready = int(p is None or take)
        outputs = {
            "ready": cmd_ready,
            "step": x_step | y_step << 1,
            "dir": self.dir,
            "busy": int(p is not None or bool(self.trigger14)),
            "done": and9,
            "error": refuse,
        }
        state = self.state()

        # ---- clock edge -------------------------------------------------------------------------
        if go:
            self.counter1 = p["in22"]
            self.counter2 = p["in23"] - 1          # OR 13: the start pulse subtracts one
            self.adder3 = p["in24"]
            self.reg22, self.reg23 = p["in22"], p["in23"]
            self.dir = p["dir"]
        elif and9:
            self.counter1 = self.counter2 = self.adder3 = 0
        else:
            if and5:   # multiplexer 12, channel 1: F -= C2 (device) or F -= min (exact)
                self.adder3 += ~self.counter2 if self.variant == "device" else -self.reg23
            if and6:   # multiplexer 12, channel 2: F += C1 (device) or F += |X|-|Y| (exact)
                self.adder3 += self.counter1 if self.variant == "device" else self.reg22
            self.counter1, self.counter2 = c1_next, c2_next
        self.trigger14 = 1 if go else 0 if and9 else self.trigger14
        self.trigger15 = 1 if (go and p["in25"]) else 0 if and9 else self.trigger15
        if tick:
            self.phase = (self.phase + 1) % self.period
        if valid and cmd_ready:
            self.prep = self._prepare(payload)
        elif take:
            self.prep = None
        return outputs, state
