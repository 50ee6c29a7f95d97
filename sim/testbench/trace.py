"""The cocotb test ``kontur trace`` runs an RTL engine with: one job in, its record out.

Started by :class:`kontur.sim.runners.CocotbBuild` with the environment variable ``KONTUR_JOB``
naming a job file (the job, its identity, the payload fields); the record of every clock is
written to ``KONTUR_RECORD`` with the same identity, so that a record can never be taken for
another run's.
"""

import json
import os
import traceback
from pathlib import Path

import cocotb

from kontur.sim.stimulus import Job
from kontur.sim.testbench import EngineBench


@cocotb.test()
async def play(dut):
    spec = json.loads(Path(os.environ["KONTUR_JOB"]).read_text())
    out_path = Path(os.environ["KONTUR_RECORD"])
    record = []
    result = {"id": spec["id"], "record": record, "failure": None}
    try:
        bench = EngineBench(dut, spec["fields"], spec["status"])
        await bench.play(Job.from_json(spec["job"]), record=record,
                         sparse=spec.get("sparse", False))
    except Exception:
        result["failure"] = traceback.format_exc()
        raise
    finally:
        out_path.write_text(json.dumps(result))
