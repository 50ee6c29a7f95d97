"""Golden model of the SU 1665343 circular interpolator: one quadrant in its native frame.

Native motion (the patent's): first quadrant, X = |x| falling, Y = |y| rising, from a point
with X >= 1 until X = 0. The quadrant is split at the diagonal:

* sector 1 (X > Y), moves Y or diagonal D, ``F1 = r2 - (X - 1/2)² - (Y + 1)²``
  (eq. 3): F1 >= 0 -> Y step, ``F -= 2Y' + 1``; F1 < 0 -> D, ``F += 2(X' - Y') - 1``;
* sector 2 (Y >= X), moves D or X, ``F2 = r2 - (X - 1)² - (Y + 1/2)²`` (eq. 4):
  F2 >= 0 -> D, ``F += 2(X' - Y') - 1``; F2 < 0 -> X step, ``F += 2X' - 1``;
* after the sector-1 step that makes X - Y <= 0, F is re-based: ``F += X + Y`` (eq. 6).

``r2`` is any positive integer (``X0² + Y0²`` of a lattice start point); primes mark values
after the step. Exact integers: the step model keeps ``f4 = 4F``, which is always 3 mod 4, so
F is never zero. The hardware keeps ``⌊F⌋ = (f4 - 3) / 4``.

The cycle-level models mirror ``kontur.hdl.circular.CircularInterpolator`` (the patent's structure,
a step every generator period, delays and the sector switch-over correction as in Fig. 1),
``kontur.hdl.circular.CircularInterpolatorFast`` (the same trajectory at one step per clock) and the
arc cores around them (``FaithfulArcCore``, ``FastArcCore``) register for register.
"""

from kontur.hdl.circular_timing import FaithfulTiming

from .codes import mask, ones_add, ones_count, ones_decode, ones_encode, shift_code, sign_extend
from .engine import permit, probe
from .errors import InputError

__all__ = ["native_steps", "native_moves", "native_path", "f4_initial", "floor_f",
           "FaithfulTiming", "CircularInterpolatorModel", "CircularInterpolatorFastModel",
           "FaithfulArcCoreModel", "FastArcCoreModel", "core_inputs", "run_inputs"]


def f4_initial(x, y, r2):
    """``4F`` at a start point ``(x, y)`` of the native frame (eq. 3 or 4 by the sector)."""
    if y >= x:
        return 4 * r2 - 4 * (x - 1) ** 2 - (2 * y + 1) ** 2
    return 4 * r2 - (2 * x - 1) ** 2 - 4 * (y + 1) ** 2


def floor_f(f4):
    """``⌊F⌋`` from ``4F`` (which is 3 mod 4): what the hardware adder holds."""
    assert f4 % 4 == 3, f4
    return (f4 - 3) // 4


def native_steps(x, y, r2, *, end=None):
    """Return the native moves from ``(x, y)``: ``"Y"``, ``"D"`` or ``"X"``, with 4F after each.

    Runs until X = 0, or until the position equals ``end``. Each item is ``(move, f4)``.
    """
    return list(native_moves(x, y, r2, end=end))


def native_moves(x, y, r2, *, end=None):
    """Generate the moves of :func:`native_steps` one by one."""
    if x < 1 or y < 0:
        raise ValueError(f"native start must have X >= 1 and Y >= 0, not ({x}, {y})")
    sector = 2 if y >= x else 1
    f4 = f4_initial(x, y, r2)
    while x > 0 and (x, y) != end:
        if sector == 1:
            if f4 >= 0:
                y += 1
                f4 -= 4 * (2 * y + 1)
                move = "Y"
            else:
                x, y = x - 1, y + 1
                f4 += 4 * (2 * (x - y) - 1)
                move = "D"
            if x - y <= 0:                       # switch-over: F2 = F1 + X + Y
                f4 += 4 * (x + y)
                sector = 2
        else:
            if f4 >= 0:
                x, y = x - 1, y + 1
                f4 += 4 * (2 * (x - y) - 1)
                move = "D"
            else:
                x -= 1
                f4 += 4 * (2 * x - 1)
                move = "X"
        yield move, f4
    if end is not None and (x, y) != end:
        raise AssertionError(f"the path from the start never reaches the end point {end}")


def native_path(x, y, r2, *, end=None):
    """Lattice points of the native path from ``(x, y)``, start included."""
    points = [(x, y)]
    for move, _ in native_steps(x, y, r2, end=end):
        x -= move in "DX"
        y += move in "DY"
        points.append((x, y))
    return points


def run_inputs(x, y, residue):
    """The patent's inputs ``(in29, in30, in31, in34)`` for a quadrant run from native
    ``(x, y)`` on the circle with ``r2 = x² + y² + residue`` (what an arc core prepares)."""
    if y >= x:
        return core_inputs(x, y, residue + 2 * x - y - 2)
    return core_inputs(x, y, residue + x - 2 * y - 2)


def core_inputs(x, y, f_floor):
    """The patent's inputs for a run from native ``(x, y)``: ``(in29, in30, in31, in34)``.

    ``in29`` is ``⌊F⌋`` at the start, ``in30`` counter 7 (``Y`` in sector 1, ``X - 1`` in
    sector 2), ``in31`` counter 8 (``X - Y - 1``, or ``X - Y``), ``in34`` = ``Y >= X``. All are
    plain signed integers; the faithful core codes 29 and 31 in ones' complement itself.
    """
    if y >= x:
        return f_floor, x - 1, x - y, 1
    return f_floor, y, x - y - 1, 0


class _CoreBase:
    """What both core models share: widths, the registers both cores have, and the refusal of
    a start (input 33) while a run is in progress: the ``error`` output, as in the RTL, or with
    ``strict`` an :exc:`InputError`."""

    def __init__(self, width, strict=False):
        self.width = width
        self.strict = strict
        self.cw = width + 1                  # counters 7 and 8
        self.aw = width + 4                  # adder 1
        self.reset()

    def _refuse(self, in33, ready):
        if in33 and not ready and self.strict:
            raise InputError("start (input 33) while a run is in progress and not stopping "
                             "in this clock: refused")

    def armed(self):
        """Generator 5 pulses at its next enabled clock."""
        return int(self.phase == 0)

    def reset(self):
        """Return every register to its reset value (the RTL's synchronous reset)."""
        self.adder1 = 0
        self.trigger4 = 0
        self.phase = 0
        self.counter7 = 0
        self.counter8 = 0
        self.trigger16 = 0


class CircularInterpolatorModel(_CoreBase):
    """Clock-by-clock model of ``kontur.hdl.circular.CircularInterpolator`` (SU 1665343, Fig. 1).

    Registers: adder 1 (ones' complement code of ⌊F⌋), trigger 4 (run), generator 5 phase,
    counter 7 (two's complement), counter 8 (ones' complement), trigger 16 (sector), the delay
    lines 12, 13, 14, 19, 26, extender 25, and the previous values of the AND 22 / AND 23
    decodes (their pulses are taken at the front, as the delay line reacts to a pulse's front).
    """

    def __init__(self, width=24, timing=None, *, strict=False):
        self.timing = timing or FaithfulTiming()
        super().__init__(width, strict)

    def reset(self):
        super().reset()
        t = self.timing
        self.line12 = [0] * t.delay12
        self.line13 = [0] * t.delay13
        self.line14 = [0] * t.delay14
        self.line19 = [0] * max(t.taps19)
        self.line26 = [0] * max(t.taps26)
        self.extender25 = 0
        self.prev22 = 0
        self.prev23 = 0

    def state(self):
        return {"adder1": ones_decode(self.adder1, self.aw), "counter7": self.counter7,
                "counter8": ones_decode(self.counter8, self.cw), "trigger4": self.trigger4,
                "trigger16": self.trigger16}

    def _gates(self, tick):
        """AND 2, 3, 10 and 11 in this clock (they read registers and the generator only)."""
        t4, t16 = self.trigger4, self.trigger16
        gen5 = int(bool(tick) and self.phase == 0)
        sign = self.adder1 >> (self.aw - 1)                  # direct output: F < 0
        ext_n = int(self.extender25 == 0)
        return (sign & t4 & gen5 & (1 - t16),                # AND 2: sector 1, F < 0: D
                (1 - sign) & t4 & gen5 & (1 - t16),          # AND 3: sector 1, F >= 0: Y
                (1 - sign) & t4 & gen5 & t16 & ext_n,        # AND 10: sector 2, F >= 0: D
                sign & t4 & gen5 & t16 & ext_n)              # AND 11: sector 2, F < 0: X

    def peek(self, tick=1):
        """``(step, stopping)`` in this clock without input 32, leaving the model untouched."""
        and2, and3, and10, and11 = self._gates(tick)
        or9 = and2 | and10
        return (or9 | and11) | (or9 | and3) << 1, self.trigger4 & int(self.counter7 < 0)

    def cycle(self, *, in29=0, in30=0, in31=0, in33=0, in34=0, in32=0, tick=1):
        """One clock; returns ``(outputs, state, extra)``, then advances.

        ``outputs``: ``step`` (bit 0 X = output 36, bit 1 Y = output 35), ``ready``, ``busy``,
        ``done``, ``error``. ``extra``: the commutator code and whether it is strobed.
        """
        t, cw, aw = self.timing, self.cw, self.aw
        t4, t16 = self.trigger4, self.trigger16
        and2, and3, and10, and11 = self._gates(tick)
        or9 = and2 | and10
        d12 = self.line12[-1]
        d13 = self.line13[-1]
        d14 = self.line14[-1]
        tap19 = [self.line19[k - 1] for k in t.taps19]
        tap26 = [self.line26[k - 1] for k in t.taps26]
        decode22 = int(self.counter8 == ones_encode(-1, cw)) & (1 - t16)
        decode23 = int(self.counter8 == ones_encode(-2, cw)) & (1 - t16)
        and22 = decode22 & (1 - self.prev22)
        and23 = decode23 & (1 - self.prev23)
        or15 = d13 | tap19[1] | tap26[1]
        or17 = or9 | and3 | and11 | tap19[0] | tap19[2] | tap26[3]
        or18 = and23 | tap26[2]                              # (input 34: at the start only)
        or20 = and3 | and11
        or21 = and23 | tap26[0]
        or24 = and22 | and23
        or27 = or9 | and3                                    # output 35, Y
        or28 = or9 | and11                                   # output 36, X

        # Commutator 6: A1 = counter 8 with ~T16 below it, A2 = counter 7 with T16, A3 = the
        # inverse of counter 7 with ~T4; each shifted one bit up, sign-extended to the adder.
        code = 0
        if d12:
            code |= sign_extend(shift_code(self.counter8, 1 - t16, cw), cw + 1, aw)
        if or15:
            code |= sign_extend(shift_code(self.counter7 & mask(cw), t16, cw), cw + 1, aw)
        if d14:
            code |= sign_extend(shift_code(~self.counter7 & mask(cw), 1 - t4, cw), cw + 1, aw)
        strobe = d12 | or15 | d14

        stop = t4 & (int(self.counter7 < 0) | in32)          # counter 7 underflow, or input 32
        ready = (1 - t4) | stop
        self._refuse(in33, ready)
        start = in33 & ready
        outputs = {"step": or28 | or27 << 1, "ready": ready, "busy": t4, "done": stop,
                   "error": in33 & (1 - ready)}
        state = self.state()
        extra = {"code": code, "strobe": strobe}

        # ---- clock edge -------------------------------------------------------------------
        clear = stop
        if start:
            self.adder1 = ones_encode(in29, aw)
            self.counter7 = in30
            self.counter8 = ones_encode(in31, cw)
        elif clear:
            self.adder1 = self.counter7 = self.counter8 = 0
        else:
            if strobe:
                self.adder1 = ones_add(self.adder1, code, aw)
            up7 = or17 & (1 - t16)
            down7 = or17 & t16
            self.counter7 += up7 - down7
            self.counter8 = ones_count(self.counter8, or21 - or20 - 2 * or9, cw)
        self.trigger4 = 1 if start else 0 if stop else t4
        if start:
            self.trigger16 = in34
        elif clear:
            self.trigger16 = 0
        elif or18:
            self.trigger16 = 1
        if start or clear:
            self.line12 = [0] * t.delay12
            self.line13 = [0] * t.delay13
            self.line14 = [0] * t.delay14
            self.line19 = [0] * len(self.line19)
            self.line26 = [0] * len(self.line26)
            self.extender25 = 0
        else:
            self.line12 = [or9] + self.line12[:-1]
            self.line13 = [and11] + self.line13[:-1]
            self.line14 = [and3] + self.line14[:-1]
            self.line19 = [and23] + self.line19[:-1]
            self.line26 = [and22] + self.line26[:-1]
            if or24:
                self.extender25 = t.extender
            elif self.extender25:
                self.extender25 -= 1
        self.prev22, self.prev23 = decode22, decode23
        if tick:
            self.phase = (self.phase + 1) % t.period
        return outputs, state, extra


class CircularInterpolatorFastModel(_CoreBase):
    """Clock-by-clock model of ``kontur.hdl.circular.CircularInterpolatorFast``: one step per clock.

    The same registers as the patent (adder ⌊F⌋, counters 7 and 8, triggers 4 and 16), in two's
    complement; each step's increment and the sector switch-over correction are formed in the
    same clock, so a quadrant takes exactly as many clocks as it has steps.
    """

    def __init__(self, width=24, period=1, *, strict=False):
        self.period = period
        super().__init__(width, strict)

    def state(self):
        return {"adder1": self.adder1, "counter7": self.counter7, "counter8": self.counter8,
                "trigger4": self.trigger4, "trigger16": self.trigger16}

    def peek(self, tick=1):
        """``(step, stopping)`` in this clock without input 32, leaving the model untouched."""
        step, _, underflow = self._advance(tick)
        return step, self.trigger4 & underflow

    def _advance(self, tick):
        """This clock's step, the registers after it, and counter 7's underflow."""
        t4, t16 = self.trigger4, self.trigger16
        gen = int(bool(tick) and self.phase == 0) & t4
        negative = int(self.adder1 < 0)
        ct7, ct8, f = self.counter7, self.counter8, self.adder1
        step_x = step_y = switch = 0
        if gen and not t16:
            ct7 += 1
            step_y = 1
            if negative:                                  # D: F += 2(X' - Y') - 1
                ct8 -= 2
                f += 2 * ct8 + 1
                step_x = 1
            else:                                         # Y: F -= 2Y' + 1
                ct8 -= 1
                f -= 2 * ct7 + 1
            if ct8 == -1:                                 # X' = Y': F += 2Y', CT7 = X' - 1
                f += 2 * ct7
                ct7, ct8, switch = ct7 - 1, 0, 1
            elif ct8 == -2:                               # X' - Y' = -1: F += 2Y' - 1
                f += 2 * ct7 - 1
                ct7, ct8, switch = ct7 - 2, -1, 1
        elif gen:
            ct7 -= 1
            step_x = 1
            if negative:                                  # X: F += 2X' - 1 = 2·CT7' + 1
                ct8 -= 1
                f += 2 * ct7 + 1
            else:                                         # D: F += 2(X' - Y') - 1
                ct8 -= 2
                f += 2 * ct8 - 1
                step_y = 1
        underflow = int(bool(gen) and ct7 < 0)
        return step_x | step_y << 1, (f, ct7, ct8, switch, gen), underflow

    def cycle(self, *, in29=0, in30=0, in31=0, in33=0, in34=0, in32=0, tick=1):
        t4 = self.trigger4
        step, (f, ct7, ct8, switch, gen), underflow = self._advance(tick)
        stop = t4 & (underflow | in32)
        ready = (1 - t4) | stop
        self._refuse(in33, ready)
        start = in33 & ready
        outputs = {"step": step, "ready": ready, "busy": t4, "done": stop,
                   "error": in33 & (1 - ready)}
        state = self.state()
        extra = {}

        if start:
            self.adder1, self.counter7, self.counter8 = in29, in30, in31
            self.trigger16 = in34
        elif stop:
            self.adder1 = self.counter7 = self.counter8 = 0
            self.trigger16 = 0
        elif gen:
            self.adder1, self.counter7, self.counter8 = f, ct7, ct8
            if switch:
                self.trigger16 = 1
        self.trigger4 = 1 if start else 0 if stop else t4
        if tick:
            self.phase = (self.phase + 1) % self.period
        return outputs, state, extra


class _QuadrantCoreModel:
    """Model of an arc core of ``kontur.hdl.circular``: the prepared run, the step permission and the
    interpolator model (its inputs 29-34 driven from them).

    :meth:`peek` gives this clock's step (which does not depend on ``stop``),
    :meth:`evaluate` every output, :meth:`cycle` also takes the run offered on ``cmd`` and
    advances.
    """

    def __init__(self, interpolator):
        self.interpolator = interpolator
        self.width = interpolator.width
        self.reset()

    def reset(self):
        self.interpolator.reset()
        self.prepared = None             # (in29, in30, in31, in34) or None

    def state(self):
        return self.interpolator.state()

    def _feed(self):
        """``(running, free)`` of the permission."""
        return self.interpolator.trigger4, 0

    def _negative(self):
        """Adder 1 holds a negative F."""
        return int(self.interpolator.adder1 < 0)

    def _inputs(self, tick, stop, abort):
        ip = self.interpolator
        running, free = self._feed()
        due, enable = permit(tick, armed=ip.armed(), running=running, free=free, abort=abort)
        in29, in30, in31, in34 = self.prepared or (0, 0, 0, 0)
        inputs = {"in29": in29, "in30": in30, "in31": in31, "in34": in34, "in33": 0,
                  "in32": int(bool(stop) or bool(abort)), "tick": enable}
        ready = probe(ip, **inputs)[0]["ready"]
        take = int(self.prepared is not None and not abort and bool(ready))
        inputs["in33"] = take
        return due, take, inputs

    def peek(self, *, tick=1, abort=0):
        """This clock's native step."""
        _, _, inputs = self._inputs(tick, 0, abort)
        return probe(self.interpolator, **inputs)[0]["step"]

    def evaluate(self, *, tick=1, stop=0, abort=0):
        """Outputs of this clock: ``step``, ``start``, ``done``, ``ready`` (of ``cmd``),
        ``busy``, ``due``, ``diagonal``."""
        due, take, inputs = self._inputs(tick, stop, abort)
        ip = self.interpolator
        outputs = probe(ip, **inputs)[0]
        return {"step": outputs["step"], "start": take, "done": outputs["done"],
                "ready": int(self.prepared is None or bool(take)),
                "busy": int(self.prepared is not None or bool(ip.trigger4)),
                "due": due, "diagonal": int(bool(self._negative()) != bool(ip.trigger16))}

    def cycle(self, *, tick=1, stop=0, abort=0, valid=0, payload=None):
        """One clock with run ``payload`` (``x``, ``y``, ``residue``) offered if ``valid``;
        returns ``(outputs, state)``, then advances."""
        outputs = self.evaluate(tick=tick, stop=stop, abort=abort)
        state = self.state()
        _, take, inputs = self._inputs(tick, stop, abort)
        self.interpolator.cycle(**inputs)
        if valid and outputs["ready"]:
            self.prepared = run_inputs(payload["x"], payload["y"], payload["residue"])
        elif take or abort:
            self.prepared = None
        return outputs, state


class FaithfulArcCoreModel(_QuadrantCoreModel):
    """Model of ``kontur.hdl.circular.FaithfulArcCore``."""

    def __init__(self, *, width=24, timing=None):
        super().__init__(CircularInterpolatorModel(width, timing))

    def _feed(self):
        ip = self.interpolator
        blocked = ip.trigger16 & int(ip.extender25 != 0)
        return ip.trigger4 & (1 - blocked), ip.trigger4 & blocked

    def _negative(self):
        ip = self.interpolator                # ones' complement code: the sign bit
        return ip.adder1 >> (ip.aw - 1)


class FastArcCoreModel(_QuadrantCoreModel):
    """Model of ``kontur.hdl.circular.FastArcCore``."""

    def __init__(self, *, width=24, period=1):
        super().__init__(CircularInterpolatorFastModel(width, period))
