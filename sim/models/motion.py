"""Models of the motion side (``hdl/motion/``): the feed generator, clock by clock."""

from hdl.motion.feed import ONE, SQRT2

__all__ = ["FeedGeneratorModel"]


class FeedGeneratorModel:
    """Clock-by-clock model of :class:`hdl.motion.feed.FeedGenerator`.

    ``profile`` is a dict with ``entry``, ``cruise``, ``exit`` (Q0.24), ``accel`` (Q0.48) and
    ``decelerate``; :meth:`cycle` returns ``tick`` for the clock, then advances.
    """

    def __init__(self, *, max_rate=(1 << 24) - 1):
        self.limit = max_rate << 24
        self.reset()

    def reset(self):
        self.rate = 0                     # Q0.48
        self.distance = 0                 # Q2.32
        self.steps = 0

    WIDTHS = {"entry": 24, "cruise": 24, "exit": 24, "accel": 32, "decelerate": 24}

    def cycle(self, *, profile, start=0, due=0, diagonal=0, hold=0):
        p = profile
        for name, bits in self.WIDTHS.items():
            if not 0 <= p[name] < 1 << bits:
                raise ValueError(f"Profile {name} must be an unsigned {bits}-bit integer, "
                                 f"not {p[name]!r}")
        target = min((p["cruise"] if self.steps < p["decelerate"] else p["exit"]) << 24,
                     self.limit)
        if self.rate < target:
            following = min(self.rate + p["accel"], target)
        else:
            following = max(self.rate - p["accel"], target)
        length = SQRT2 if diagonal else ONE
        tick = int(not hold and self.distance >= length)
        step = tick and due
        grown = self.distance + (self.rate >> 16)
        if step:
            self.distance = grown - length
        elif not hold and not tick:
            self.distance = grown
        if start:
            self.rate, self.steps = min(p["entry"] << 24, self.limit), 0
        else:
            self.rate = following
            self.steps += int(bool(step))
        return tick
