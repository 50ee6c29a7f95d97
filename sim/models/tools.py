"""Model of the tool outputs (:class:`kontur.hdl.motion.tools.ToolOutputs`), clock by clock."""

__all__ = ["ToolOutputsModel", "OFF", "CW", "CCW"]

#: The spindle codes (:class:`~kontur.hdl.motion.tools.Spindle`): M5, M3, M4.
OFF, CW, CCW = 0, 1, 2


class ToolOutputsModel:
    """Clock-by-clock model of :class:`~kontur.hdl.motion.tools.ToolOutputs`.

    :meth:`cycle` takes this clock's inputs: ``cmd`` (``None``, or a dict of ``spindle``,
    ``s``, ``mist``, ``flood``), ``laser``, ``rate``, ``cruise``, ``halt`` and
    ``spindle_override`` (Q2.7); returns the
    dict of this clock's outputs (``enable``, ``direction``, ``pwm``, ``mist``, ``flood``, and
    the command stream's ``ready``), then advances. The multiply-divide is kept register by
    register, as the gateware has it, but for a rate above the cruise: clamped here to the
    cruise, found by the gateware in the rate pass's first subtraction (its result is then the
    period, as the clamp's). ``laser_mode=False``: the gateware built without it (``laser``,
    ``rate`` and ``cruise`` ignored); ``spindle_override=False`` likewise (S as commanded).
    """

    def __init__(self, *, s_max, period, laser_mode=True, spindle_override=True):
        self.s_max, self.period, self.laser_mode = s_max, period, laser_mode
        self.spindle_override = spindle_override
        self.bits = period.bit_length()
        self.enable = self.direction = self.mist = self.flood = self.s = 0
        self.count = self.duty = 0
        self.a = self.b = self.c = self.r = self.q = 0
        self.phase = self.left = self.busy = self.feed = self.fresh = 0

    def cycle(self, cmd=None, *, laser=0, rate=0, cruise=0, halt=0, spindle_override=128):
        on = not halt
        out = {"enable": int(self.enable and on), "direction": int(self.direction and on),
               "mist": int(self.mist and on), "flood": int(self.flood and on),
               "pwm": int(self.enable and on and self.count < self.duty), "ready": int(on)}
        first, last = self.count == 0, self.count == self.period - 1
        enable, direction, s = self.enable, self.direction, self.s
        if self.spindle_override:           # S times the factor (Q2.7), rounded, clamped
            s = min((s * spindle_override + 64) >> 7, self.s_max)
        off = bool(halt)
        if halt:
            self.enable = self.direction = self.mist = self.flood = 0
        elif cmd is not None:
            self.enable = int(cmd["spindle"] != OFF)
            self.direction = int(cmd["spindle"] == CCW)
            self.s = min(cmd["s"], self.s_max)
            self.mist, self.flood = cmd["mist"], cmd["flood"]
            off = cmd["spindle"] == OFF
        result, fresh = self.q, self.fresh
        self._duty(first, off, enable, direction, s, laser, rate, cruise)
        if off:
            self.duty = 0
        elif last:
            self.duty = result if fresh else 0
        self.count = 0 if last else self.count + 1
        return out

    def _duty(self, first, off, enable, direction, s, laser, rate, cruise):
        """One clock of the multiply-divide (the registers before the edge: ``enable``,
        ``direction``, ``s``)."""
        top = 1 << self.bits
        ge = self.r >= self.c
        if first:
            feed = int(bool(self.laser_mode and laser and enable and direction))
            self.busy, self.feed, self.a, self.r, self.q = 1, feed, self.period, 0, 0
            self.phase, self.left = 0, self.bits
            self.b = min(rate, cruise) if feed else s
            self.c = max(cruise, 1) if feed else self.s_max
        elif self.busy:
            done, feed = self.phase == 2 and self.left == 0, self.feed
            q_next = (self.q + 1) % top if ge else self.q
            if self.phase == 0:         # in the rounding step a is all shifted out
                self.r = 2 * self.r + (self.b if self.a >> (self.bits - 1) & 1 else 0)
                self.a = 2 * self.a % top
                if self.left:
                    self.q = 2 * self.q % top
                self.phase = 1
            else:
                if ge:
                    self.r, self.q = self.r - self.c, q_next
                if self.phase == 2:
                    self.phase = 0
                    self.left -= 1
                    if done:
                        self.busy, self.feed = feed, 0
                else:
                    self.phase += 1
            if done and feed:           # the S pass, its multiplier the rate pass's result
                self.a, self.b, self.c, self.r, self.q = self.q, s, self.s_max, 0, 0
                self.left = self.bits
        if off:
            self.fresh = 0
        elif first:
            self.fresh = enable
