"""Helpers shared by the Amaranth-simulator tests."""

import os
import re
from pathlib import Path

from amaranth import Fragment, Module, Signal
from amaranth.sim import Simulator

__all__ = ["simulate", "used", "waves_path", "BUILD_DIR"]

BUILD_DIR = Path(__file__).resolve().parent.parent / "build"


def used(*elaboratables):
    """Elaborate what a test only inspects, or made for a constructor that refused it: the
    parts a component made inside ``hdl/`` would otherwise warn (UnusedElaboratable) when
    collected, which a test file's pragma does not cover."""
    for elaboratable in elaboratables:
        Fragment.get(elaboratable, None)


def waves_path(name):
    """``build/waves/<name>.vcd`` with ``WAVES=1`` in the environment, else ``None``."""
    if os.environ.get("WAVES") != "1":
        return None
    wave_dir = BUILD_DIR / "waves"
    wave_dir.mkdir(parents=True, exist_ok=True)
    return wave_dir / (re.sub(r"[^A-Za-z0-9_.-]+", "_", name) + ".vcd")


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


def compare_core(testcase, dut, model, schedule, *, state=None, decode=None, name):
    """Drive ``dut`` and the cycle ``model`` with the same per-clock inputs; assert they agree.

    ``schedule`` is a list of dicts, port name to value, one per clock (missing ports are 0).
    Every output of ``model.cycle`` and every register of ``state`` (name to signal; ``decode``
    maps a name to a function applied to the RTL's value) must agree in every clock. Returns
    the model's outputs, clock by clock.
    """
    state = state or {}
    decode = decode or {}
    ports = sorted({port for inputs in schedule for port in inputs})
    seen = []

    async def testbench(ctx):
        for clock, inputs in enumerate(schedule):
            for port in ports:
                ctx.set(getattr(dut, port), inputs.get(port, 0))
            outputs, registers = model.cycle(**{p: inputs.get(p, 0) for p in ports})[:2]
            for key, expected in outputs.items():
                testcase.assertEqual(ctx.get(getattr(dut, key)), expected,
                                     f"clock {clock}: output {key}")
            for key, signal in state.items():
                value = decode.get(key, lambda v: v)(ctx.get(signal))
                testcase.assertEqual(value, registers[key], f"clock {clock}: register {key}")
            seen.append(outputs)
            await ctx.tick()

    simulate(dut, testbench, name=name)
    return seen
