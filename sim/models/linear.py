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

The cycle-level models mirror ``kontur.hdl.linear.LinearInterpolator`` (the patent's inputs 22-26)
and ``kontur.hdl.linear.LinearCore`` (the line core around it) register for register; the adder there
holds the integer part ``⌊F⌋`` (the half of ``F0`` never changes the sign test), so
``adder3 = f2 >> 1``.
"""

from .engine import permit, probe
from .errors import InputError

__all__ = ["VARIANTS", "check_line", "patent_inputs", "table", "steps",
           "LinearInterpolatorModel", "LinearCoreModel"]

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
    # Two step tuples, shared by every step of the segment (a long program holds millions).
    axial, diagonal = ((sx, 0) if x_long else (0, sy)), (sx, sy)
    return [diagonal if row["move"] == "D" else axial for row in table(x, y, variant)]


class LinearInterpolatorModel:
    """Clock-by-clock model of :class:`kontur.hdl.linear.LinearInterpolator`: the patent's inputs 22-26.

    With ``strict`` a start of frame (input 26) while :meth:`ready` is low raises
    :exc:`InputError`; otherwise it is refused as the RTL refuses it, with the ``error`` output.
    """

    def __init__(self, *, variant="exact", width=16, period=1, strict=False):
        _check_variant(variant)
        self.variant = variant
        self.width = width
        self.period = period
        self.strict = strict
        self.reset()

    def reset(self):
        """Return every register to its reset value (the RTL's synchronous reset)."""
        self.counter1 = 0
        self.counter2 = 0
        self.adder3 = 0
        self.reg22 = 0                   # exact variant: constant increments
        self.reg23 = 0
        self.trigger14 = 0
        self.trigger15 = 0
        self.phase = 0                   # generator 4

    def state(self):
        """Contents of the named registers."""
        return {"adder3": self.adder3, "counter1": self.counter1, "counter2": self.counter2,
                "trigger14": self.trigger14, "trigger15": self.trigger15}

    def armed(self):
        """Generator 4 pulses at its next enabled clock."""
        return int(self.phase == 0)

    def _pulses(self, tick):
        """Node 18: generator 4, AND 5 (F >= 0, long step), AND 6 (F < 0, combined step)."""
        gen4 = int(bool(tick) and self.phase == 0)
        sign = int(self.adder3 < 0)
        return gen4 & self.trigger14 & (1 - sign), gen4 & self.trigger14 & sign

    def _and9_run(self, and5, and6):
        """AND 9: a pulse while one step is left, counters 1 and 2 holding 1 and -1 or 0 and 0
        (the pulse is then that step: a frame exhausts both counters at its last step)."""
        one_left = (self.counter1, self.counter2) in ((1, -1), (0, 0))
        return int(bool(self.trigger14) and bool(and5 | and6) and one_left)

    def ready(self, in22, in23, tick=1):
        """Whether a start of frame is accepted in this clock (one frame ends per clock)."""
        empty = in22 == 0 and in23 == 0
        return int(not self.trigger14 or (self._and9_run(*self._pulses(tick)) and not empty))

    def cycle(self, *, in22=0, in23=0, in24=0, in25=0, in26=0, tick=1):
        """One clock; returns ``(outputs, state)``, then advances."""
        and5, and6 = self._pulses(tick)
        and9_run = self._and9_run(and5, and6)
        ready = self.ready(in22, in23, tick)
        if in26 and not ready and self.strict:
            raise InputError("start of frame (input 26) while a frame is running and not in "
                             "its last step: refused")
        start = in26 & ready
        empty = int(in22 == 0 and in23 == 0)
        and9_load = start & empty
        go = start & (1 - empty)
        and9 = and9_run | and9_load
        x_step = (and5 & self.trigger15) | and6            # node 20: OR 10
        y_step = (and5 & (1 - self.trigger15)) | and6      # OR 11
        outputs = {"step": x_step | y_step << 1, "ready": ready, "busy": self.trigger14,
                   "done": and9, "error": in26 & (1 - ready)}
        state = self.state()

        if go:
            self.counter1 = in22
            self.counter2 = in23 - 1               # OR 13: the start pulse subtracts one
            self.adder3 = in24
            self.reg22, self.reg23 = in22, in23 - 1     # register 23' holds min - 1
        elif and9:
            self.counter1 = self.counter2 = self.adder3 = 0
        else:
            if and5:   # multiplexer 12, channel 1: F -= C2 (device) or F -= min (exact)
                self.adder3 += ~(self.counter2 if self.variant == "device" else self.reg23)
            if and6:   # multiplexer 12, channel 2: F += C1 (device) or F += |X|-|Y| (exact)
                self.adder3 += self.counter1 if self.variant == "device" else self.reg22
            self.counter1 -= and5
            self.counter2 -= and6
        self.trigger14 = 1 if go else 0 if and9 else self.trigger14
        self.trigger15 = 1 if (go and in25) else 0 if and9 else self.trigger15
        if tick:
            self.phase = (self.phase + 1) % self.period
        return outputs, state


class LinearCoreModel:
    """Clock-by-clock model of :class:`kontur.hdl.linear.LinearCore`: the prepared segment, the step
    permission and :class:`LinearInterpolatorModel` (its inputs 22-26 driven from them).

    :meth:`evaluate` gives this clock's outputs for the feed and abort inputs, :meth:`cycle`
    also takes the segment offered on ``cmd`` and advances.
    """

    def __init__(self, *, width=16, variant="exact", period=1):
        _check_variant(variant)
        self.width = width
        self.interpolator = LinearInterpolatorModel(variant=variant, width=width, period=period)
        self.reset()

    def reset(self):
        """Return every register to its reset value (the RTL's synchronous reset)."""
        self.interpolator.reset()
        self.prepared = None             # (in22, in23, in24, in25) or None

    def state(self):
        return self.interpolator.state()

    def _inputs(self, tick, abort):
        ip = self.interpolator
        due, enable = permit(tick, armed=ip.armed(), running=ip.trigger14, abort=abort)
        in22, in23, in24, in25 = self.prepared or (0, 0, 0, 0)
        take = int(self.prepared is not None and not abort
                   and bool(ip.ready(in22, in23, enable)))
        return due, take, {"in22": in22, "in23": in23, "in24": in24, "in25": in25,
                           "in26": take, "tick": enable}

    def evaluate(self, *, tick=1, abort=0):
        """Outputs of this clock: ``step``, ``start``, ``done``, ``ready`` (of ``cmd``),
        ``busy``, ``due``, ``diagonal``."""
        due, take, inputs = self._inputs(tick, abort)
        ip = self.interpolator
        outputs, _ = probe(ip, **inputs)
        return {"step": outputs["step"], "start": take,
                "done": int(bool(outputs["done"]) or bool(abort and ip.trigger14)),
                "ready": int(self.prepared is None or bool(take)),
                "busy": int(self.prepared is not None or bool(ip.trigger14)),
                "due": due, "diagonal": int(ip.adder3 < 0)}

    def cycle(self, *, tick=1, abort=0, valid=0, payload=None):
        """One clock with segment ``payload`` (magnitudes ``x``, ``y``) offered if ``valid``;
        returns ``(outputs, state)``, then advances."""
        outputs = self.evaluate(tick=tick, abort=abort)
        state = self.state()
        _, take, inputs = self._inputs(tick, abort)
        if abort:
            self.interpolator.reset()    # the interpolator's synchronous reset
        else:
            self.interpolator.cycle(**inputs)
        if valid and outputs["ready"]:
            self.prepared = patent_inputs(payload["x"], payload["y"])
        elif take or abort:
            self.prepared = None
        return outputs, state
