"""cocotb testbench parts for any engine's Verilog: driver, monitor, scoreboard.

:class:`EngineBench` drives an engine's ports clock by clock from a
:class:`~kontur.sim.stimulus.Job` (the command stream with its gaps, the feed permissions, the status
stream's stalls, aborts and resets: the same :class:`~kontur.sim.stimulus.Driver` the golden models
and Amaranth's simulator are run with) and monitors its outputs into a record; a
:class:`Scoreboard` holds the golden cycle model and checks every clock against it as the
simulation runs. Clock ``n`` is the interval before the ``n + 1``-th rising edge: inputs are
driven at its start (for clock 0, at 1 ns), outputs sampled once they have settled
(``ReadOnly``), exactly as the Amaranth runner and the models do.

Imported inside the simulator's Python only (it needs a running cocotb).
"""

import json
import os

from cocotb.clock import Clock
from cocotb.triggers import ReadOnly, RisingEdge, Timer

from kontur.sim.runners import unpack_status
from kontur.sim.stimulus import Driver, entry, eventful, first_difference

__all__ = ["EngineBench", "Scoreboard", "random_gaps", "random_pattern"]


def random_gaps(rng, count, choices=(0, 0, 0, 1, 3)):
    """Idle clocks before each of ``count`` frames: random stalls on the command stream."""
    return [rng.choice(choices) for _ in range(count)]


def random_pattern(rng, length=97, ones=0.7):
    """A repeating 0/1 pattern, mostly ones (feed permissions, status stream stalls)."""
    pattern = [int(rng.random() < ones) for _ in range(length)]
    pattern[0] = 1
    return pattern


def _pack(payload, fields):
    value = 0
    for name, (offset, width, _signed) in fields.items():
        value |= (payload.get(name, 0) & ((1 << width) - 1)) << offset
    return value


class Scoreboard:
    """The golden cycle model of an engine, stepped with the inputs the DUT gets.

    :meth:`check` runs the model for one clock and raises :exc:`AssertionError`, naming the
    clock and every output that differs, when the DUT's outputs are not the model's.
    """

    def __init__(self, model):
        self.model = model
        self.expected = []

    def check(self, cycle, inputs, outputs):
        if inputs["rst"]:
            self.model.reset()
            want = entry(cycle)
        else:
            result, _ = self.model.cycle(valid=inputs["valid"], payload=inputs["payload"],
                                         tick=inputs["tick"], abort=inputs["abort"],
                                         status_ready=inputs["status_ready"])
            want = entry(cycle, result, inputs["valid"])
        got = entry(cycle, outputs, inputs["valid"]) if outputs is not None else entry(cycle)
        self.expected.append(want)
        if want != got:                  # (the same keys: the difference only when they differ)
            raise AssertionError(first_difference([want], [got]))


class EngineBench:
    """Driver and monitor of an engine's Verilog (ports as Amaranth names them).

    Parameters
    ----------
    dut
        The cocotb handle of the engine's top level.
    fields : dict
        The command payload's fields, ``name: (offset, width, signed)``.
    status : dict
        The status payload's fields (:func:`kontur.sim.runners.status_fields`).
    """

    def __init__(self, dut, fields, status):
        self.dut = dut
        self.fields = fields
        self.status = status
        self.started = False

    @classmethod
    def from_env(cls, dut):
        """A bench with the layouts :meth:`kontur.sim.runners.CocotbBuild.test` passes in
        ``KONTUR_PORTS``."""
        ports = json.loads(os.environ["KONTUR_PORTS"])
        return cls(dut, ports["fields"], ports["status"])

    async def start(self):
        """Start the clock; let the simulator's time-zero events settle (Icarus evaluates the
        ``always @*`` blocks Amaranth emits only after cocotb's first read-only phase)."""
        Clock(self.dut.clk, 10, unit="ns").start(start_high=False)
        await Timer(1, unit="ns")
        self._ports()
        self.started = True

    def _ports(self):
        dut = self.dut
        self._in = {"rst": dut.rst, "tick": dut.feed__tick, "abort": dut.abort,
                    "status_ready": dut.status__ready, "valid": dut.cmd__valid}
        self._payload = dut.cmd__payload
        self._out = {"ready": dut.cmd__ready, "step": dut.motion__step, "dir": dut.motion__dir,
                     "busy": dut.busy, "due": dut.feed__due, "diagonal": dut.feed__diagonal,
                     "status_valid": dut.status__valid, "status": dut.status__payload}
        self._driven = {}

    def drive(self, inputs):
        """Drive one clock's inputs (only those that change)."""
        for name, handle in self._in.items():
            value = inputs[name]
            if self._driven.get(name) != value:
                handle.value = value
                self._driven[name] = value
        payload = inputs["payload"]
        if payload is not None and self._driven.get("payload") is not payload:
            self._payload.value = _pack(payload, self.fields)
            self._driven["payload"] = payload

    def sample(self, inputs):
        """The engine's outputs in this clock (after ``ReadOnly``), as a record has them."""
        out = self._out
        transfer = int(out["status_valid"].value) and inputs["status_ready"]
        return {"ready": int(out["ready"].value), "step": int(out["step"].value),
                "dir": int(out["dir"].value), "busy": int(out["busy"].value),
                "due": int(out["due"].value), "diagonal": int(out["diagonal"].value),
                "status": (unpack_status(int(out["status"].value), self.status)
                           if transfer else None)}

    def sample_events(self, inputs):
        """:meth:`sample` for a sparse record: a clock without a step, an acceptance or an
        outcome reads only what the driver needs (``busy``), so long runs go faster."""
        out = self._out
        step = int(out["step"].value)
        valid = int(out["status_valid"].value) and inputs["status_ready"]
        ready = int(out["ready"].value) if inputs["valid"] else 0
        if not (step or valid or ready):
            return {"ready": 0, "step": 0, "dir": 0, "busy": int(out["busy"].value), "due": 0,
                    "diagonal": 0, "status": None}
        return self.sample(inputs)

    async def play(self, job, *, scoreboard=None, record=None, sparse=False):
        """Play ``job`` to its end; return the record (also appended to ``record``; with
        ``sparse``, only its :func:`~kontur.sim.stimulus.eventful` entries).

        With a ``scoreboard`` every clock is checked against the golden model as it goes.
        """
        if not self.started:
            await self.start()
        record = [] if record is None else record
        driver = Driver(job)
        for cycle in range(job.max_cycles):
            inputs = driver.inputs(cycle)
            self.drive(inputs)
            await ReadOnly()
            if inputs["rst"]:
                outputs = None
            elif sparse and scoreboard is None:
                outputs = self.sample_events(inputs)
            else:
                outputs = self.sample(inputs)
            if scoreboard is not None:
                scoreboard.check(cycle, inputs, outputs)
            item = entry(cycle, outputs, inputs["valid"])
            if not sparse or eventful(item):
                record.append(item)
            driver.observe(cycle, inputs, outputs)
            if driver.finished:
                return record
            await RisingEdge(self.dut.clk)
        raise RuntimeError(f"the engine did not finish the job within {job.max_cycles} clocks")
