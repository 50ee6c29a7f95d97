"""Models of the motion side (``hdl/motion/``): the feed generator, clock by clock."""

from kontur.hdl.spec import ONE, SQRT2

__all__ = ["FeedGeneratorModel"]


class FeedGeneratorModel:
    """Clock-by-clock model of :class:`kontur.hdl.motion.feed.FeedGenerator`.

    ``profile`` is a dict with ``cruise``, ``exit`` (Q0.24) and ``decelerate``; ``accel`` is
    Q0.40. :meth:`cycle` returns ``tick`` for the clock, then advances.
    """

    WIDTHS = {"cruise": 24, "exit": 24, "decelerate": 24}

    def __init__(self, *, max_rate=(1 << 24) - 1):
        self.max_rate = max_rate
        self.reset()

    def reset(self):
        self.rate = 0                     # Q0.40
        self.distance = 0                 # Q2.24
        self.steps = 0

    def cycle(self, *, profile, accel, start=0, due=0, diagonal=0, hold=0):
        p = profile
        for name, bits in self.WIDTHS.items():
            if not 0 <= p[name] < 1 << bits:
                raise ValueError(f"Profile {name} must be an unsigned {bits}-bit integer, "
                                 f"not {p[name]!r}")
        if not 0 <= accel < 1 << 32:
            raise ValueError(f"Acceleration must be an unsigned 32-bit integer, not {accel!r}")
        wanted = p["cruise"] if self.steps < p["decelerate"] else p["exit"]
        target = min(wanted, self.max_rate) << 16
        length = SQRT2 if diagonal else ONE
        tick = int(not hold and self.distance >= length)
        step = bool(tick and due)
        grown = self.distance + (self.rate >> 16)
        if step:
            self.distance = grown - length
        elif not hold and not tick:
            self.distance = grown
        diff = target - self.rate
        self.rate = target if abs(diff) <= accel else self.rate + (accel if diff > 0 else -accel)
        if start:
            self.steps = int(step)
        elif step:
            self.steps += 1
        return tick
