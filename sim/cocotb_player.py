"""cocotb test module: plays a :class:`~sim.stimulus.Job` on an engine's Verilog, records it.

Started by :class:`sim.runners.CocotbBuild` (never collected by pytest directly). The job file
named by ``KONTUR_JOB`` holds the job and the ``cmd`` payload layout; the record of every clock
is written to ``KONTUR_RECORD`` in the format of :func:`sim.stimulus.run_model`, so that it can
be compared with the golden cycle model entry for entry.

Clock ``n`` is the interval before the ``n + 1``-th rising edge: inputs are driven at its
start (for clock 0, at 1 ns), outputs sampled once they have settled (``ReadOnly``), exactly as
the Amaranth runner and the model do.
"""

import json
import os
import traceback
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ReadOnly, RisingEdge, Timer

from sim.stimulus import Driver, Job


def _pack(payload, fields):
    value = 0
    for name, (offset, width, _signed) in fields.items():
        value |= (payload[name] & ((1 << width) - 1)) << offset
    return value


@cocotb.test()
async def play(dut):
    spec = json.loads(Path(os.environ["KONTUR_JOB"]).read_text())
    out_path = Path(os.environ["KONTUR_RECORD"])
    job = Job.from_json(spec["job"])
    fields = spec["fields"]
    record = []
    try:
        Clock(dut.clk, 10, unit="ns").start(start_high=False)
        # Let time-zero events settle before clock 0 is sampled: Icarus evaluates the
        # "always @*" blocks Amaranth emits (FSM outputs) only after cocotb's first read-only
        # phase. The first rising edge is at 5 ns.
        await Timer(1, unit="ns")
        driver = Driver(job)
        outputs_by_port = {"ready": dut.cmd__ready, "step": dut.step, "dir": dut.dir,
                           "busy": dut.busy, "done": dut.done, "error": dut.error}
        for cycle in range(job.max_cycles):
            inputs = driver.inputs(cycle)
            dut.rst.value = inputs["rst"]
            dut.tick.value = inputs["tick"]
            dut.cmd__valid.value = inputs["valid"]
            if inputs["payload"] is not None:
                dut.cmd__payload.value = _pack(inputs["payload"], fields)
            await ReadOnly()
            if inputs["rst"]:
                outputs = None
                entry = {"cycle": cycle, "rst": 1}
            else:
                outputs = {name: int(port.value)
                           for name, port in outputs_by_port.items()}
                entry = {"cycle": cycle, "rst": 0, **outputs}
            driver.observe(cycle, inputs, outputs)
            record.append(entry)
            if driver.finished:
                break
            await RisingEdge(dut.clk)
        else:
            raise RuntimeError(f"the engine did not finish the job within {job.max_cycles} "
                               f"clocks")
    except Exception:
        out_path.write_text(json.dumps({"record": record, "failure": traceback.format_exc()}))
        raise
    out_path.write_text(json.dumps({"record": record, "failure": None}))
