"""The cocotb test ``kontur run`` runs a controller with on Icarus or Verilator: the frames
in, the events out.

Started by :func:`kontur.sim.runners.CocotbBuild.run_controller` with ``KONTUR_RUN`` naming a JSON
file: the frames file (:func:`kontur.sim.testbench.hostlink.write_frames`), the events file to write
(the format of ``sim/fastrun.cpp``, :func:`kontur.sim.testbench.hostlink.format_events`), the serial
divisor, the window and the clock bound; optionally a schedule of the switch pins
(:func:`kontur.sim.testbench.hostlink.write_schedule`'s file).
"""

import json
import os
from pathlib import Path

import cocotb

from kontur.sim.testbench.hostlink import format_events, read_frames, read_schedule, run_cocotb


@cocotb.test()
async def run(dut):
    spec = json.loads(Path(os.environ["KONTUR_RUN"]).read_text())
    schedule, idle = read_schedule(spec["schedule"]) if spec.get("schedule") else ((), None)
    result = await run_cocotb(dut, read_frames(spec["frames"]), divisor=spec["divisor"],
                              window=spec["window"], max_clocks=spec["max_clocks"],
                              schedule=schedule, idle=idle)
    Path(spec["events"]).write_text(format_events(result))
