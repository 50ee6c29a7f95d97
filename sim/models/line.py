"""Clock-by-clock model of ``hdl.line.LineEngine``: the front end of any line core model."""

from .engine import ABORTED, DONE, REFUSED, StatusModel

__all__ = ["LineEngineModel"]


class LineEngineModel:
    """Model of :class:`hdl.line.LineEngine` around a line core model.

    ``core`` is the model of the RTL's core (for instance
    :class:`~sim.models.linear.LinearCoreModel`): it has ``width``, ``reset()``, ``state()``,
    ``evaluate(tick=, abort=)`` and ``cycle(tick=, abort=, valid=, payload=)``, as the RTL core
    has its :class:`~hdl.line.LineCoreSignature`.

    Call :meth:`cycle` once per clock with the inputs of that clock; it returns the outputs
    during that clock and the core's named registers, then advances.
    """

    def __init__(self, core, *, number_width=8):
        self.core = core
        self.width = core.width
        self.status = StatusModel(position_width=self.width + 1, number_width=number_width)
        self.reset()

    def reset(self):
        """Return every register to its reset value (the RTL's synchronous reset)."""
        self.core.reset()
        self.status.reset()
        self.prepared_dir = 0
        self.prepared_moves = 0
        self.direction = 0

    def state(self):
        return self.core.state()

    def cycle(self, *, valid=0, payload=None, tick=1, abort=0, status_ready=1):
        core = self.core.evaluate(tick=tick, abort=abort)
        status = self.status
        limit = (1 << self.width) - 1
        x = payload["x"] if payload is not None else 0
        y = payload["y"] if payload is not None else 0
        too_wide = abs(x) > limit or abs(y) > limit

        refuse = int(bool(valid) and too_wide and not status.busy and not status.flushing
                     and not abort)
        end = int(bool(core["done"]) or bool(refuse))
        outcome = REFUSED if refuse else ABORTED if abort else DONE
        stream = status.evaluate(step=core["step"], direction=self.direction, end=end,
                                 outcome=outcome, status_ready=status_ready)
        accepting = stream["room"] and not abort
        core_valid = int(bool(valid) and accepting and not too_wide)
        ready = refuse if too_wide else int(bool(core["ready"]) and accepting)
        accept = int(bool(valid) and bool(ready))

        outputs = {"ready": ready, "step": core["step"], "dir": self.direction,
                   "busy": status.busy, "due": core["due"], "diagonal": core["diagonal"],
                   "status": stream["payload"] if stream["transfer"] else None}
        state = self.state()

        # ---- clock edge -------------------------------------------------------------------
        magnitudes = {"x": abs(x) & limit, "y": abs(y) & limit}
        self.core.cycle(tick=tick, abort=abort, valid=core_valid, payload=magnitudes)
        if core["start"] and self.prepared_moves:
            self.direction = self.prepared_dir
        if core_valid and core["ready"]:
            self.prepared_dir = int(x < 0) | int(y < 0) << 1
            self.prepared_moves = int(magnitudes["x"] != 0 or magnitudes["y"] != 0)
        status.advance(accept=accept, flush=abort)
        return outputs, state
