"""Models of what every engine shares (``hdl/engine.py``): outcomes, the feed permission, the
status unit. Exact integers, clock by clock."""

__all__ = ["DONE", "REFUSED", "ABORTED", "OUTCOMES", "permit", "probe", "StatusModel"]

#: Outcome codes, as :class:`kontur.hdl.engine.Outcome` has them.
DONE, REFUSED, ABORTED = 0, 1, 2
OUTCOMES = {DONE: "done", REFUSED: "refused", ABORTED: "aborted"}


def permit(tick, *, armed, running, free=0, abort=0):
    """``(due, enable)``: :func:`kontur.hdl.engine.permit` for one clock."""
    due = int(bool(running) and bool(armed) and not abort)
    enable = int(not abort and (not armed or bool(tick) or bool(free)))
    return due, enable


def probe(model, **inputs):
    """The outputs of ``model.cycle(**inputs)`` in this clock, leaving the model as it was.

    The cycle models replace their registers on every clock (they never mutate one in place),
    so a shallow copy of their attributes is a snapshot.
    """
    saved = dict(vars(model))
    try:
        return model.cycle(**inputs)
    finally:
        vars(model).clear()
        vars(model).update(saved)


class StatusModel:
    """Clock-by-clock model of :class:`kontur.hdl.engine.StatusUnit`.

    Call :meth:`evaluate` with the inputs of a clock, then :meth:`advance`.
    """

    def __init__(self, *, axes=2, position_width=32, number_width=8):
        self.axes = axes
        self.position_width = position_width
        self.number_width = number_width
        self.reset()

    def reset(self):
        self.moved = [0] * self.axes
        self.waiting = None              # the outcome waiting for the consumer, or None
        self.inflight = 0
        self.flushing = 0
        self.number = 0

    @property
    def hold(self):
        return int(self.waiting is not None)

    @property
    def idle(self):
        return int(self.inflight == 0 and self.waiting is None)

    @property
    def alone(self):
        return int(self.inflight == 1 and self.waiting is None)

    @property
    def busy(self):
        return int(self.inflight != 0 or self.waiting is not None)

    def _wrap(self, value):
        half = 1 << (self.position_width - 1)
        return (value + half) % (2 * half) - half

    def evaluate(self, *, step, direction, end, outcome, status_ready):
        """This clock's status stream for the given end of a command and motion.

        Returns ``{"valid", "payload", "transfer"}``; ``payload`` is ``[number, outcome,
        position]``.
        """
        position = [self._wrap(self.moved[a] + ((-1 if direction >> a & 1 else 1)
                                                if step >> a & 1 else 0))
                    for a in range(self.axes)]
        flushed = int(bool(self.flushing) and self.inflight != 0 and self.waiting is None
                      and not end)
        event = int(bool(end) or flushed)
        event_outcome = outcome if end else ABORTED
        valid = int(self.waiting is not None or event)
        shown = self.waiting if self.waiting is not None else event_outcome
        transfer = int(valid and bool(status_ready))
        self._clock = {"position": position, "flushed": flushed, "event": event,
                       "event_outcome": event_outcome, "transfer": transfer}
        return {"valid": valid, "payload": [self.number, shown, position],
                "transfer": transfer}

    def advance(self, *, accept, flush):
        """The clock edge, after :meth:`evaluate` of the same clock."""
        c = self._clock
        if c["transfer"]:
            self.number = (self.number + 1) % (1 << self.number_width)
            self.waiting = None
            self.moved = [0] * self.axes
        else:
            self.moved = list(c["position"])
            if c["event"]:
                self.waiting = c["event_outcome"]
        flushed, inflight = c["flushed"], self.inflight
        self.inflight = inflight + int(bool(accept)) - c["event"]
        if flush:
            self.flushing = 1
        elif self.flushing and (inflight == 0 or (inflight == 1 and flushed)):
            self.flushing = 0
