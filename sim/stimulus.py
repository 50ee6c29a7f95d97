"""One stimulus, three simulators: the clock-by-clock driver every engine run goes through.

A :class:`Job` lists the frames to send to an engine's ``cmd`` stream, the idle clocks to leave
before offering each one, the clocks at which to pulse reset or abort, and the patterns of the
feed permission (``tick``) and of the status stream's ``ready``. A :class:`Driver` turns the
job into the inputs of each clock and follows the stream handshake from the outputs it is
shown. The same driver runs the golden cycle model (:func:`run_model`), Amaranth's simulator
(``kontur.sim.runners``) and cocotb on Icarus or Verilator (``kontur.sim.testbench``), so the three produce
records that can be compared entry for entry.

A *record* is a list with one dict per clock: ``cycle``, ``rst`` and, outside reset, the
engine's outputs (:data:`OUTPUTS`: ``ready`` of ``cmd``, ``step``, ``dir``, ``busy``, ``due``,
``diagonal``, and ``status``: ``[number, outcome, position]`` in a clock where an outcome is
transferred, else ``None``), the outcome flags ``done``, ``error`` and ``aborted`` derived
from it (:func:`entry`), plus any named state the caller asked for.
"""

from dataclasses import dataclass, field, asdict

from kontur.sim.models.engine import ABORTED, DONE, REFUSED

__all__ = ["Job", "Driver", "OUTPUTS", "entry", "eventful", "check_outcomes", "run_model", "plan_resets", "record_steps",
           "record_moves", "record_outcomes", "first_difference"]

#: The engine outputs a record holds, in every clock outside reset.
OUTPUTS = ("ready", "step", "dir", "busy", "due", "diagonal", "status")


def entry(cycle, outputs=None, valid=0):
    """A record entry: ``cycle``, ``rst`` and (outside reset, ``outputs`` given) the outputs,
    ``accepted`` (a command was taken: ``valid`` and ``ready``) and the outcome flags
    ``done``, ``error`` and ``aborted``."""
    if outputs is None:
        return {"cycle": cycle, "rst": 1}
    status = outputs["status"]
    outcome = None if status is None else status[1]
    return {"cycle": cycle, "rst": 0, **outputs, "accepted": int(bool(valid and outputs["ready"])),
            "done": int(outcome == DONE), "error": int(outcome == REFUSED),
            "aborted": int(outcome == ABORTED)}


def eventful(item):
    """Whether a record entry holds an event a sparse record keeps: a reset, a step, an
    acceptance or an outcome."""
    return bool(item["rst"] or item["step"] or item["accepted"] or item["status"] is not None)


def check_outcomes(record):
    """Raise :exc:`AssertionError` unless every command accepted in ``record`` ends with
    exactly one outcome, numbered in the order of acceptance, after it was accepted, and no
    outcome comes without a command (a reset loses the commands in flight and restarts the
    numbering)."""
    pending = []                         # clocks of accepted commands without an outcome
    number = 0
    for item in record:
        if item["rst"]:
            pending, number = [], 0
            continue
        if item["accepted"]:               # (a command may end in the clock it is taken)
            pending.append(item["cycle"])
        if item["status"] is not None:
            if not pending:
                raise AssertionError(f"clock {item['cycle']}: an outcome with no command")
            if item["status"][0] != number % 256:
                raise AssertionError(f"clock {item['cycle']}: outcome numbered "
                                     f"{item['status'][0]}, expected {number % 256}")
            pending.pop(0)
            number += 1
    if pending:
        raise AssertionError(f"the command accepted in clock {pending[0]} has no outcome")


@dataclass
class Job:
    """Frames and timing for one engine run.

    Parameters
    ----------
    frames : list of dict
        Payloads for the ``cmd`` stream, field name to integer.
    gaps : list of int
        Idle clocks before each frame is offered (counted from the previous acceptance, or from
        clock 0 for the first). Missing entries are 0 (back-to-back).
    resets : dict of int to int
        Clock at which to assert reset, and for how many clocks. A frame in flight is lost; the
        frames not yet accepted are offered again afterwards.
    tick : list of int
        Feed permission pattern, repeated (``[1]``: a step permitted in every clock).
    status_ready : list of int
        ``ready`` pattern of the status stream, repeated (``[1]``: outcomes taken at once).
    aborts : dict of int to int
        Clock at which to assert ``abort``, and for how many clocks.
    max_cycles : int
        Give up after this many clocks.
    """

    frames: list
    gaps: list = field(default_factory=list)
    resets: dict = field(default_factory=dict)
    tick: list = field(default_factory=lambda: [1])
    status_ready: list = field(default_factory=lambda: [1])
    aborts: dict = field(default_factory=dict)
    max_cycles: int = 1_000_000

    def to_json(self):
        data = asdict(self)
        data["resets"] = {str(k): v for k, v in self.resets.items()}
        data["aborts"] = {str(k): v for k, v in self.aborts.items()}
        return data

    @classmethod
    def from_json(cls, data):
        data = dict(data)
        data["resets"] = {int(k): v for k, v in data.get("resets", {}).items()}
        data["aborts"] = {int(k): v for k, v in data.get("aborts", {}).items()}
        return cls(**data)


class Driver:
    """Inputs for each clock of a :class:`Job`, following the ``cmd`` handshake."""

    def __init__(self, job):
        self.job = job
        self.index = 0                       # next frame to offer
        self.wait = job.gaps[0] if job.gaps else 0
        self.reset_left = 0
        self.abort_left = 0
        self.last_reset = max(job.resets, default=-1)
        self.idle = False                    # the engine reported busy = 0 after the last frame
        # The payload presented: the frame offered, or while none is, the last one (the
        # engine may look at it: ready may depend on it). None (zeros) before the first.
        self.payload = None

    def inputs(self, cycle):
        """Return ``{"rst", "valid", "payload", "tick", "abort", "status_ready"}`` for
        ``cycle``."""
        job = self.job
        if cycle in job.resets:
            self.reset_left = job.resets[cycle]
        if cycle in job.aborts:
            self.abort_left = job.aborts[cycle]
        tick = job.tick[cycle % len(job.tick)]
        status_ready = job.status_ready[cycle % len(job.status_ready)]
        abort = int(self.abort_left > 0)
        if self.reset_left:
            return {"rst": 1, "valid": 0, "payload": None, "tick": tick, "abort": abort,
                    "status_ready": status_ready}
        offer = self.index < len(job.frames) and self.wait == 0
        if offer:
            self.payload = job.frames[self.index]
        return {"rst": 0, "valid": int(offer), "payload": self.payload, "tick": tick,
                "abort": abort, "status_ready": status_ready}

    def observe(self, cycle, inputs, outputs):
        """Update from the outputs sampled in ``cycle`` (``None`` during reset)."""
        if self.abort_left:
            self.abort_left -= 1
        if inputs["rst"]:
            self.reset_left -= 1
            return
        accepted = inputs["valid"] and outputs["ready"]
        if accepted:
            self.index += 1
            self.wait = self.job.gaps[self.index] if self.index < len(self.job.gaps) else 0
        elif self.wait:
            self.wait -= 1
        # Idle: every frame accepted, none in this clock (busy shows it from the next), the
        # engine not busy, and no reset still to come.
        self.idle = (self.index == len(self.job.frames) and not accepted
                     and not outputs["busy"] and cycle >= self.last_reset)

    @property
    def finished(self):
        return self.idle


def _model_cycle(model, inputs):
    return model.cycle(valid=inputs["valid"], payload=inputs["payload"], tick=inputs["tick"],
                       abort=inputs["abort"], status_ready=inputs["status_ready"])


def run_model(model, job, *, state=False, sparse=False):
    """Run ``job`` on an engine's cycle model (``model.cycle(valid=, payload=, tick=, abort=,
    status_ready=)``); return the record (with ``sparse``, only its :func:`eventful`
    entries)."""
    driver = Driver(job)
    record = []
    for cycle in range(job.max_cycles):
        inputs = driver.inputs(cycle)
        if inputs["rst"]:
            model.reset()
            item = entry(cycle)
            driver.observe(cycle, inputs, None)
        else:
            outputs, regs = _model_cycle(model, inputs)
            item = entry(cycle, outputs, inputs["valid"])
            if state:
                item.update(regs)
            driver.observe(cycle, inputs, outputs)
        if not sparse or eventful(item):
            record.append(item)
        if driver.finished:
            check_outcomes(record)
            return record
    raise RuntimeError(f"the engine did not finish the job within {job.max_cycles} clocks")


def plan_resets(model, job, limit, *, length=1):
    """Return a copy of ``job`` with a reset wherever a frame would run ``limit`` clocks or more.

    Runs ``job`` on the cycle ``model`` and, whenever the engine has been busy for ``limit``
    clocks without ending a frame, schedules a reset of ``length`` clocks right there. This is
    how segments of billions of steps are tested: run for a while, compared clock for clock,
    then cut by a reset in the middle of the frame.
    """
    planned = Job(frames=list(job.frames), gaps=list(job.gaps), resets=dict(job.resets),
                  tick=list(job.tick), status_ready=list(job.status_ready),
                  aborts=dict(job.aborts), max_cycles=job.max_cycles)
    driver = Driver(planned)
    running = 0
    for cycle in range(planned.max_cycles):
        if running >= limit and cycle not in planned.resets:
            planned.resets[cycle] = length
            driver.last_reset = max(driver.last_reset, cycle)
        inputs = driver.inputs(cycle)
        if inputs["rst"]:
            model.reset()
            driver.observe(cycle, inputs, None)
            running = 0
            continue
        outputs, _ = _model_cycle(model, inputs)
        driver.observe(cycle, inputs, outputs)
        ended = outputs["status"] is not None
        running = running + 1 if outputs["busy"] and not ended else 0
        if driver.finished:
            return planned
    raise RuntimeError(f"the engine did not finish the job within {job.max_cycles} clocks")


def record_moves(record, axes=2):
    """Return ``(cycle, dx, dy)`` (``(cycle, dx, dy, dz)`` on three axes) for every clock of
    ``record`` with a step pulse."""
    moves = []
    for entry in record:
        if entry["rst"] or not entry["step"]:
            continue
        step, direction = entry["step"], entry["dir"]
        moves.append((entry["cycle"], *((-1 if direction >> axis & 1 else 1)
                                        if step >> axis & 1 else 0 for axis in range(axes))))
    return moves


def record_steps(record, axes=2):
    """Return the ``(dx, dy)`` (on three axes ``(dx, dy, dz)``) steps of ``record`` in
    order."""
    return [move[1:] for move in record_moves(record, axes)]


def record_outcomes(record):
    """Return ``(cycle, number, outcome, position)`` for every outcome transferred in
    ``record``."""
    return [(e["cycle"], *e["status"]) for e in record if not e["rst"] and e["status"]]


def first_difference(expected, actual, keys=None):
    """Describe the first clock at which two records differ, or return ``None``."""
    for want, got in zip(expected, actual):
        names = keys or sorted(set(want) | set(got))
        if any(want.get(k) != got.get(k) for k in names):
            diff = {k: (want.get(k), got.get(k)) for k in names if want.get(k) != got.get(k)}
            return f"clock {want['cycle']}: (model, rtl) {diff}"
    if len(expected) != len(actual):
        return f"records differ in length: model {len(expected)} clocks, rtl {len(actual)}"
    return None
