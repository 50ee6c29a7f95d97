"""Clock-by-clock model of ``kontur.hdl.line.LineEngine``: the front end of any line core model."""

from .engine import DONE, REFUSED, StatusModel

__all__ = ["LineEngineModel", "AXIS_NAMES"]

#: The frames' coordinate names, axis by axis (as ``kontur.hdl.line.AXIS_NAMES``).
AXIS_NAMES = ("x", "y", "z")


class LineEngineModel:
    """Model of :class:`kontur.hdl.line.LineEngine` around a line core model.

    ``core`` is the model of the RTL's core (for instance
    :class:`~kontur.sim.models.linear.LinearCoreModel`): it has ``width``, ``reset()``, ``state()``,
    ``evaluate(tick=, abort=)`` and ``cycle(tick=, abort=, valid=, payload=)``, as the RTL core
    has its :class:`~kontur.hdl.line.LineCoreSignature`; a core model with ``axes = 3`` makes
    a three-axis engine (segments ``x``, ``y``, ``z``).

    Call :meth:`cycle` once per clock with the inputs of that clock; it returns the outputs
    during that clock and the core's named registers, then advances.
    """

    def __init__(self, core, *, number_width=8):
        self.core = core
        self.width = core.width
        self.axes = getattr(core, "axes", 2)
        self.names = AXIS_NAMES[:self.axes]
        self.status = StatusModel(axes=self.axes, position_width=self.width + 1,
                                  number_width=number_width)
        self.reset()

    def reset(self):
        """Return every register to its reset value (the RTL's synchronous reset)."""
        self.core.reset()
        self.status.reset()
        self.stage = None                # the stage register's segment, or None
        self.prepared_dir = 0
        self.prepared_moves = 0
        self.direction = 0

    def state(self):
        return self.core.state()

    def cycle(self, *, valid=0, payload=None, tick=1, abort=0, status_ready=1):
        status = self.status
        hold = status.hold
        core = self.core.evaluate(tick=int(bool(tick) and not hold), abort=abort)
        limit = (1 << self.width) - 1
        coords = [payload[name] if payload is not None else 0 for name in self.names]

        # The stage register: a segment's magnitudes, signs and checks on their way to the
        # core (or, refused, to its outcome).
        stage = self.stage
        core_valid = int(stage is not None and not stage["wide"]
                         and (not stage["zero"] or bool(status.alone)) and not abort)
        handover = core_valid and bool(core["ready"])
        refuse = int(stage is not None and stage["wide"] and bool(status.alone) and not abort)
        ready = int(not abort and not status.flushing
                    and (stage is None or bool(handover) or bool(refuse)))
        accept = int(bool(valid) and bool(ready))
        end = int((bool(core["done"]) and not abort) or bool(refuse))
        stream = status.evaluate(step=core["step"], direction=self.direction, end=end,
                                 outcome=REFUSED if refuse else DONE,
                                 status_ready=status_ready)

        outputs = {"ready": ready, "step": core["step"], "dir": self.direction,
                   "busy": status.busy, "due": int(bool(core["due"]) and not hold),
                   "diagonal": core["diagonal"],
                   "status": stream["payload"] if stream["transfer"] else None}
        state = self.state()

        # ---- clock edge -------------------------------------------------------------------
        magnitudes = (stage["magnitudes"] if stage is not None
                      else {name: 0 for name in self.names})
        self.core.cycle(tick=int(bool(tick) and not hold), abort=abort, valid=core_valid,
                        payload=magnitudes)
        if core["start"] and self.prepared_moves:
            self.direction = self.prepared_dir
        if handover:
            self.prepared_dir, self.prepared_moves = stage["dir"], int(not stage["zero"])
        if accept:
            self.stage = {"magnitudes": {name: abs(c) & limit
                                         for name, c in zip(self.names, coords)},
                          "dir": sum(int(c < 0) << axis for axis, c in enumerate(coords)),
                          "zero": all(abs(c) & limit == 0 for c in coords),
                          "wide": any(abs(c) > limit for c in coords)}
        elif handover or refuse or abort:
            self.stage = None
        status.advance(accept=accept, flush=abort)
        return outputs, state
