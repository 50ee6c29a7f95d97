"""cocotb testbench parts for any engine's Verilog: driver, monitor, scoreboard.

:class:`EngineBench` drives an engine's ports clock by clock from a
:class:`~sim.stimulus.Job` (the command stream with its gaps, the feed permissions, the status
stream's stalls, aborts and resets: the same :class:`~sim.stimulus.Driver` the golden models
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

from ..runners import unpack_status
from ..stimulus import Driver, entry, first_difference

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
        difference = first_difference([want], [got])
        if difference is not None:
            raise AssertionError(difference)


class EngineBench:
    """Driver and monitor of an engine's Verilog (ports as Amaranth names them).

    Parameters
    ----------
    dut
        The cocotb handle of the engine's top level.
    fields : dict
        The command payload's fields, ``name: (offset, width, signed)``.
    status : dict
        The status payload's fields (:func:`sim.runners.status_fields`).
    """

    def __init__(self, dut, fields, status):
        self.dut = dut
        self.fields = fields
        self.status = status
        self.started = False

    @classmethod
    def from_env(cls, dut):
        """A bench with the layouts :meth:`sim.runners.CocotbBuild.test` passes in
        ``KONTUR_PORTS``."""
        ports = json.loads(os.environ["KONTUR_PORTS"])
        return cls(dut, ports["fields"], ports["status"])

    async def start(self):
        """Start the clock; let the simulator's time-zero events settle (Icarus evaluates the
        ``always @*`` blocks Amaranth emits only after cocotb's first read-only phase)."""
        Clock(self.dut.clk, 10, unit="ns").start(start_high=False)
        await Timer(1, unit="ns")
        self.started = True

    def drive(self, inputs):
        dut = self.dut
        dut.rst.value = inputs["rst"]
        dut.feed__tick.value = inputs["tick"]
        dut.abort.value = inputs["abort"]
        dut.status__ready.value = inputs["status_ready"]
        dut.cmd__valid.value = inputs["valid"]
        if inputs["payload"] is not None:
            dut.cmd__payload.value = _pack(inputs["payload"], self.fields)

    def sample(self, inputs):
        """The engine's outputs in this clock (after ``ReadOnly``), as a record has them."""
        dut = self.dut
        transfer = int(dut.status__valid.value) and inputs["status_ready"]
        return {"ready": int(dut.cmd__ready.value), "step": int(dut.motion__step.value),
                "dir": int(dut.motion__dir.value), "busy": int(dut.busy.value),
                "due": int(dut.feed__due.value), "diagonal": int(dut.feed__diagonal.value),
                "status": (unpack_status(int(dut.status__payload.value), self.status)
                           if transfer else None)}

    async def play(self, job, *, scoreboard=None, record=None):
        """Play ``job`` to its end; return the record (also appended to ``record``).

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
            outputs = None if inputs["rst"] else self.sample(inputs)
            if scoreboard is not None:
                scoreboard.check(cycle, inputs, outputs)
            record.append(entry(cycle, outputs, inputs["valid"]))
            driver.observe(cycle, inputs, outputs)
            if driver.finished:
                return record
            await RisingEdge(self.dut.clk)
        raise RuntimeError(f"the engine did not finish the job within {job.max_cycles} clocks")
