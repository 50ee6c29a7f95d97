"""Models of what every engine shares (``hdl/engine.py``): outcomes, the feed permission, the
status unit. Exact integers, clock by clock."""

__all__ = ["DONE", "REFUSED", "ABORTED", "OUTCOMES", "permit", "probe", "StatusModel"]

#: Outcome codes, as :class:`hdl.engine.Outcome` has them.
DONE, REFUSED, ABORTED = 0, 1, 2
OUTCOMES = {DONE: "done", REFUSED: "refused", ABORTED: "aborted"}


def permit(tick, *, armed, running, free=0, abort=0):
    """``(due, enable)``: :func:`hdl.engine.permit` for one clock."""
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
    """Clock-by-clock model of :class:`hdl.engine.StatusUnit`.

    Call :meth:`evaluate` with the inputs of a clock (they may be given in two steps: the end
    of a command before the acceptance that may depend on :meth:`room`), then :meth:`advance`.
    """

    def __init__(self, *, axes=2, position_width=32, number_width=8, depth=2):
        self.axes = axes
        self.position_width = position_width
        self.number_width = number_width
        self.depth = depth
        self.reset()

    def reset(self):
        self.moved = [0] * self.axes
        self.queue = []                   # (outcome, position) entries
        self.inflight = 0
        self.flushing = 0
        self.number = 0

    @property
    def busy(self):
        return int(self.inflight != 0 or bool(self.queue))

    def _wrap(self, value):
        half = 1 << (self.position_width - 1)
        return (value + half) % (2 * half) - half

    def evaluate(self, *, step, direction, end, outcome, status_ready):
        """This clock's status stream and room, for the given end of a command and motion.

        Returns ``{"valid", "payload", "transfer", "room"}``; ``payload`` is ``(number,
        outcome, position)``.
        """
        position = [self._wrap(self.moved[a] + ((-1 if direction >> a & 1 else 1)
                                                if step >> a & 1 else 0))
                    for a in range(self.axes)]
        flushed = int(self.flushing and self.inflight != 0
                      and len(self.queue) < self.depth and not end)
        write = int(bool(end) or flushed)
        event = (outcome if end else ABORTED, position if end else [0] * self.axes)
        valid = int(bool(self.queue) or write)
        head = self.queue[0] if self.queue else event
        transfer = int(valid and bool(status_ready))
        room = int(not self.flushing
                   and self.inflight + len(self.queue) - transfer < self.depth)
        self._clock = {"position": position, "flushed": flushed, "write": write,
                       "event": event, "transfer": transfer, "end": end}
        return {"valid": valid, "payload": [self.number, head[0], list(head[1])],
                "transfer": transfer, "room": room}

    def advance(self, *, accept, flush):
        """The clock edge, after :meth:`evaluate` of the same clock."""
        c = self._clock
        bypass = not self.queue
        if c["transfer"]:
            self.number = (self.number + 1) % (1 << self.number_width)
        if c["write"] and not (bypass and c["transfer"]):
            self.queue.append(c["event"])
        if c["transfer"] and not bypass:
            self.queue.pop(0)
        flushed, inflight = c["flushed"], self.inflight
        self.inflight = inflight + int(bool(accept)) - c["write"]
        if flush:
            self.flushing = 1
        elif self.flushing and (inflight == 0 or (inflight == 1 and flushed)):
            self.flushing = 0
        self.moved = [0] * self.axes if c["end"] else list(c["position"])
