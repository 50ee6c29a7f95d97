"""Timing of the faithful SU 1665343 core: generator period, delays, extender, and their checks.

Pure Python, no Amaranth: the RTL constructor (``kontur.hdl.circular``) and the golden cycle model
(``kontur.sim.models.circular``) both validate their parameters with it, so the two can never accept
different timings. It describes parameters only, not behaviour.
"""

__all__ = ["FaithfulTiming", "timing_problems"]


class FaithfulTiming:
    """Generator period, delay lengths and extender length of the faithful core, checked.

    The defaults are the structural minimum: the shortest timing for which every ordering the
    structure relies on holds (see ``docs/circular.md``). The same checks are made by the RTL's
    constructor, with the same messages.
    """

    def __init__(self, period=4, delay12=3, delay13=1, delay14=1, taps19=(1, 3, 3),
                 taps26=(1, 1, 1, 2), extender=3, *, check=True):
        for name, value in (("Generator period", period), ("Delay 12", delay12),
                            ("Delay 13", delay13), ("Delay 14", delay14),
                            ("Extender length", extender)):
            if not _positive(value):
                raise TypeError(f"{name} must be a positive integer, not {value!r}")
        for name, taps, count in (("Delay 19 taps", taps19, 3), ("Delay 26 taps", taps26, 4)):
            if (not isinstance(taps, (tuple, list)) or len(taps) != count
                    or not all(_positive(t) for t in taps)):
                raise TypeError(f"{name} must be {count} positive integers, not {taps!r}")
        self.period = period
        self.delay12, self.delay13, self.delay14 = delay12, delay13, delay14
        self.taps19 = tuple(taps19)
        self.taps26 = tuple(taps26)
        self.extender = extender
        if check:
            for message in timing_problems(self):
                raise ValueError(message[0].upper() + message[1:])

    def __eq__(self, other):
        return isinstance(other, FaithfulTiming) and vars(self) == vars(other)

    def __repr__(self):
        return (f"FaithfulTiming(period={self.period}, delay12={self.delay12}, "
                f"delay13={self.delay13}, delay14={self.delay14}, taps19={self.taps19}, "
                f"taps26={self.taps26}, extender={self.extender})")


def _positive(value):
    return isinstance(value, int) and not isinstance(value, bool) and value >= 1


def timing_problems(t):
    """Yield a message for every structural ordering the timing ``t`` breaks (first first)."""
    p, d12, d13, d14 = t.period, t.delay12, t.delay13, t.delay14
    b1, b2, b3 = t.taps19
    a1, a2, a3, a4 = t.taps26
    e = t.extender
    checks = [
        (p >= max(d12, d13, d14) + 1,
         f"the generator period must exceed every operand delay (12, 13, 14): at least "
         f"{max(d12, d13, d14) + 1} clocks, not {p}"),
        (b1 < b2 <= b3,
         f"delay 19 taps must satisfy tap 1 < tap 2 <= tap 3 (counter 7 is corrected before "
         f"and after adder 1 reads it), not {t.taps19}"),
        (a1 <= a3 and a2 <= a3 < a4,
         f"delay 26 taps must satisfy tap 1 <= tap 3, tap 2 <= tap 3 < tap 4 (trigger 16 is "
         f"set after adder 1 reads counter 7 and before counter 7 counts down), "
         f"not {t.taps26}"),
        (d12 >= 2 + a3,
         f"delay 12 must be at least delay 26 tap 3 + 2 = {a3 + 2} clocks: the diagonal that "
         f"lands on X = Y is read after counter 8 and trigger 16 are switched, not {d12}"),
        (d12 < 1 + b2,
         f"delay 12 must be shorter than delay 19 tap 2 + 1 = {b2 + 1} clocks: the diagonal "
         f"is added before the X - Y = -1 correction (Table 2), not {d12}"),
        (d14 <= 1 + a4,
         f"delay 14 must be at most delay 26 tap 4 + 1 = {a4 + 1} clocks: the Y step that "
         f"lands on X = Y is read before counter 7 counts down to X - 1, not {d14}"),
        (d12 != 1 + a2 and d14 != 1 + a2,
         "delays 12 and 14 must not end in the clock of delay 26 tap 2 + 1: the commutator "
         "passes one channel at a time"),
        (p >= a3 + 2,
         f"the generator period must be at least delay 26 tap 3 + 2 = {a3 + 2} clocks "
         f"(trigger 16 is set before the next pulse), not {p}"),
        (p - 1 <= e <= 2 * p - 2,
         f"the extender must hold AND 10 and 11 off for exactly the next generator pulse: "
         f"{p - 1} to {2 * p - 2} clocks, not {e}"),
        (2 + b2 <= 2 * p and 2 + a2 <= 2 * p and 1 + a4 < 2 * p,
         "the switch-over correction must be over within two generator periods"),
        (b3 + 3 <= 2 * p,
         f"delay 19 tap 3 must end at least 3 clocks before the second generator pulse "
         f"(at most {2 * p - 3} clocks): with a radius of 1 that correction ends the quadrant, "
         f"and the run must stop before that pulse, not {b3}"),
    ]
    for ok, message in checks:
        if not ok:
            yield message
