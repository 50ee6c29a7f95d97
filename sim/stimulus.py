"""One stimulus, three simulators: the clock-by-clock driver every engine run goes through.

A :class:`Job` lists the frames to send to an engine's ``cmd`` stream, the idle clocks to leave
before offering each one, the clocks at which to pulse reset, and the ``tick`` pattern. A
:class:`Driver` turns the job into the inputs of each clock and follows the stream handshake
from the outputs it is shown. The same driver runs the golden cycle model
(:func:`run_model`), Amaranth's simulator (``sim.runners``) and cocotb on Icarus or Verilator
(``sim.cocotb_player``), so the three produce records that can be compared entry for entry.

A *record* is a list with one dict per clock: ``cycle``, ``rst`` and, outside reset, the
engine's outputs ``ready``, ``step``, ``dir``, ``busy``, ``done``, ``error`` (plus any named
state the caller asked for).
"""

from dataclasses import dataclass, field, asdict

__all__ = ["Job", "Driver", "run_model", "plan_resets", "record_steps", "record_moves",
           "first_difference"]


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
        ``tick`` input pattern, repeated (``[1]``: a permitted step every clock).
    max_cycles : int
        Give up after this many clocks.
    """

    frames: list
    gaps: list = field(default_factory=list)
    resets: dict = field(default_factory=dict)
    tick: list = field(default_factory=lambda: [1])
    max_cycles: int = 1_000_000

    def to_json(self):
        data = asdict(self)
        data["resets"] = {str(k): v for k, v in self.resets.items()}
        return data

    @classmethod
    def from_json(cls, data):
        data = dict(data)
        data["resets"] = {int(k): v for k, v in data.get("resets", {}).items()}
        return cls(**data)


class Driver:
    """Inputs for each clock of a :class:`Job`, following the ``cmd`` handshake."""

    def __init__(self, job):
        self.job = job
        self.index = 0                       # next frame to offer
        self.wait = job.gaps[0] if job.gaps else 0
        self.reset_left = 0
        self.last_reset = max(job.resets, default=-1)
        self.idle = False                    # the engine reported busy = 0 after the last frame

    def inputs(self, cycle):
        """Return ``{"rst", "valid", "payload", "tick"}`` for ``cycle``."""
        if cycle in self.job.resets:
            self.reset_left = self.job.resets[cycle]
        tick = self.job.tick[cycle % len(self.job.tick)]
        if self.reset_left:
            return {"rst": 1, "valid": 0, "payload": None, "tick": tick}
        offer = self.index < len(self.job.frames) and self.wait == 0
        payload = self.job.frames[self.index] if offer else None
        return {"rst": 0, "valid": int(offer), "payload": payload, "tick": tick}

    def observe(self, cycle, inputs, outputs):
        """Update from the outputs sampled in ``cycle`` (``None`` during reset)."""
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


def run_model(model, job, *, state=False):
    """Run ``job`` on a cycle model (``model.cycle(valid=, payload=, tick=)``); return the record."""
    driver = Driver(job)
    record = []
    for cycle in range(job.max_cycles):
        inputs = driver.inputs(cycle)
        if inputs["rst"]:
            model.reset()
            entry = {"cycle": cycle, "rst": 1}
            driver.observe(cycle, inputs, None)
        else:
            outputs, regs = model.cycle(valid=inputs["valid"], payload=inputs["payload"],
                                        tick=inputs["tick"])
            entry = {"cycle": cycle, "rst": 0, **outputs}
            if state:
                entry.update(regs)
            driver.observe(cycle, inputs, outputs)
        record.append(entry)
        if driver.finished:
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
                  tick=list(job.tick), max_cycles=job.max_cycles)
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
        outputs, _ = model.cycle(valid=inputs["valid"], payload=inputs["payload"],
                                 tick=inputs["tick"])
        driver.observe(cycle, inputs, outputs)
        ended = outputs["done"] or outputs["error"]
        running = running + 1 if outputs["busy"] and not ended else 0
        if driver.finished:
            return planned
    raise RuntimeError(f"the engine did not finish the job within {job.max_cycles} clocks")


def record_moves(record):
    """Return ``(cycle, dx, dy)`` for every clock of ``record`` with a step pulse."""
    moves = []
    for entry in record:
        if entry["rst"] or not entry["step"]:
            continue
        step, direction = entry["step"], entry["dir"]
        dx = (-1 if direction & 1 else 1) if step & 1 else 0
        dy = (-1 if direction & 2 else 1) if step & 2 else 0
        moves.append((entry["cycle"], dx, dy))
    return moves


def record_steps(record):
    """Return the ``(dx, dy)`` steps of ``record`` in order."""
    return [(dx, dy) for _, dx, dy in record_moves(record)]


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
