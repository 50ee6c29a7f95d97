"""Models of the motion side (``hdl/motion/``): the feed generator, clock by clock."""

from kontur.hdl.spec import ONE, SQRT2

__all__ = ["FeedGeneratorModel"]


class FeedGeneratorModel:
    """Clock-by-clock model of :class:`kontur.hdl.motion.feed.FeedGenerator`.

    ``profile`` is a dict with ``cruise``, ``exit`` (Q0.24) and ``decelerate``; ``accel`` is
    Q0.40; ``hold`` a level, ``feed_override`` the Q2.7 factor (128: 100 %),
    ``rapid_override`` the rapid's shift (0, 1, 2: 100, 50, 25 %), ``rapid`` whether the move
    is a rapid. :meth:`cycle` returns ``tick`` for the clock, then advances; after it,
    :attr:`held` is that clock's ``held``.
    """

    WIDTHS = {"cruise": 24, "exit": 24, "decelerate": 24}
    ONE_FACTOR = 128                      # :data:`~kontur.hdl.motion.feed.OVERRIDE_ONE`
    MARGIN = 16                           # :data:`~kontur.hdl.motion.feed.LOOKAHEAD_MARGIN`
    EXTRA = 48                            # bits of the look-ahead's distance (Q24.24)

    def __init__(self, *, max_rate=(1 << 24) - 1):
        self.max_rate = max_rate
        self.reset()

    def reset(self):
        self.rate = 0                     # Q0.40
        self.distance = 0                 # Q2.24
        self.steps = 0
        # The scaled cruise and its sequential multiplier.
        self.used = self.ONE_FACTOR
        self.bits = 0
        self.product = 0
        self.count = 0
        self.scaled = 0
        self.slower = False
        self.ready = False
        # The ramp-down look-ahead.
        self.rose = self.fell = False
        self.extra = 0
        self.above = False
        self.latched = False
        self.held = False

    def _check(self, p, accel, feed_override, rapid_override):
        for name, bits in self.WIDTHS.items():
            if not 0 <= p[name] < 1 << bits:
                raise ValueError(f"Profile {name} must be an unsigned {bits}-bit integer, "
                                 f"not {p[name]!r}")
        if not 0 <= accel < 1 << 32:
            raise ValueError(f"Acceleration must be an unsigned 32-bit integer, not {accel!r}")
        if not 0 <= feed_override < 1 << 9:
            raise ValueError(f"Feed override must be an unsigned 9-bit integer, "
                             f"not {feed_override!r}")
        if not 0 <= rapid_override < 4:
            raise ValueError(f"Rapid override must be 0 to 3, not {rapid_override!r}")

    def _clamp(self, value):
        return min(value, self.max_rate)

    def _scale(self, p, start, factor):
        """The sequential multiplier, one clock: the next state of the scaled cruise."""
        if start or factor != self.used:
            self.used, self.bits, self.product, self.count = factor, factor, 0, 10
        elif self.count > 1:
            self.product = ((self.product << 1) + (p["cruise"] if self.bits >> 8 & 1 else 0)) \
                % (1 << 33)
            self.bits = (self.bits << 1) % (1 << 9)
            self.count -= 1
        elif self.count == 1:
            self.scaled = self._clamp(self.product >> 7)
            self.slower = self.used < self.ONE_FACTOR
            self.ready = True
            self.count = 0
        if start:
            self.ready = False

    def _lookahead(self, p, start, planned):
        """The look-ahead, one clock: whether the move ramps down now; advances its state."""
        early = self.above and (self.steps + (self.extra >> 24) + self.MARGIN
                                >= p["decelerate"])
        down = (self.latched and not start) or self.steps >= p["decelerate"]
        now = self.rate >> 16
        if start or self.rate <= planned << 16:
            extra, above = 0, False
        else:
            above = self.above or self.rose
            if self.rose:
                extra = min(self.extra + now, (1 << self.EXTRA) - 1)
            elif self.fell:
                extra = max(self.extra - now, 0)
            else:
                extra = self.extra
        self.extra, self.above = extra, above
        self.latched = not start and (self.latched or early)
        return down

    def cycle(self, *, profile, accel, start=0, due=0, diagonal=0, hold=0,
              feed_override=ONE_FACTOR, rapid_override=0, rapid=0):
        p = profile
        self._check(p, accel, feed_override, rapid_override)
        planned = self._clamp(p["cruise"])
        exit = self._clamp(p["exit"])
        use = self.ready and not start
        scaled, slower = self.scaled, self.slower
        down = self._lookahead(p, start, planned)
        factor = (self.ONE_FACTOR >> rapid_override) if rapid else feed_override
        self._scale(p, start, factor)
        if hold:
            target = 0
        elif down:
            target = (scaled if use and slower and scaled < exit else exit) << 16
        else:
            target = (scaled if use else planned) << 16

        # The distance and the permission (from this clock's rate).
        stopped = self.held = bool(hold and self.rate == 0)
        length = SQRT2 if diagonal else ONE
        tick = int(not stopped and self.distance >= length)
        step = bool(tick and due)
        grown = self.distance + (self.rate >> 16)
        if step:
            self.distance = grown - length
        elif not tick:
            self.distance = grown
        if start:
            self.steps = int(step)
        elif step:
            self.steps += 1

        # The rate: one acceleration toward the target, never past it.
        up = self.rate < target
        moved = self.rate + accel if up else self.rate - accel
        passed = moved >= target if up else moved <= target
        self.rose, self.fell = up, not up and not passed
        self.rate = target if passed else moved
        return tick
