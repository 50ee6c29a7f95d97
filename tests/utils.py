"""Helpers shared by the Amaranth-simulator tests."""

import os
import re
from pathlib import Path

from amaranth import Module, Signal
from amaranth.sim import Simulator

__all__ = ["simulate", "BUILD_DIR"]

BUILD_DIR = Path(__file__).resolve().parent.parent / "build"


def simulate(dut, testbench, *, name, traces=()):
    """Run ``testbench`` against ``dut`` on a 1 MHz clock.

    With ``WAVES=1`` in the environment the run is dumped to ``build/waves/<name>.vcd`` (with a
    GTKWave save file listing ``traces``); waveforms are build outputs, never compared raw.
    """
    top = Module()
    top.submodules.dut = dut
    heartbeat = Signal()                 # gives purely combinational DUTs a clock domain to tick
    top.d.sync += heartbeat.eq(~heartbeat)
    sim = Simulator(top)
    sim.add_clock(1e-6)
    sim.add_testbench(testbench)
    if os.environ.get("WAVES") == "1":
        wave_dir = BUILD_DIR / "waves"
        wave_dir.mkdir(parents=True, exist_ok=True)
        stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", name)
        with sim.write_vcd(wave_dir / f"{stem}.vcd", wave_dir / f"{stem}.gtkw", traces=traces):
            sim.run()
    else:
        sim.run()
