"""The machine controller on Verilator at full speed: the host side inside the simulation.

:class:`FastRun` converts a top level (ports ``rx``, ``tx``, ``motion``; the
:class:`~kontur.hdl.motion.controller.MotionController`) to Verilog, builds it once with Verilator and
``sim/fastrun.cpp`` (a C++ testbench playing the host: the frames onto ``rx`` at the serial
rate, the window flow control, the replies parsed off ``tx``, every step edge recorded), and
runs programs on it. Nothing in Python runs per clock, so the simulation goes at Verilator's
own speed (millions of clocks a second). Builds are shared between runs and processes under a
lock, one directory per design digest, like :class:`kontur.sim.runners.CocotbBuild`'s.
"""

import hashlib
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from amaranth import Cat, ClockDomain, Module, Signal
from amaranth.lib import wiring

from kontur.hdl.motion.tools import TOOL_PINS, tool_engine
from kontur.sim import processes
from kontur.sim.runners import SimulatorError, _locked, verilator_environment
from kontur.sim.testbench.hostlink import Run, parse_events, write_frames, write_schedule

__all__ = ["FastRun", "Run"]


HARNESS = Path(__file__).resolve().parent / "fastrun.cpp"

#: The clocks the controller is held in reset at the start (the harness waits as many).
RESET_CLOCKS = 4


class _FastTop(wiring.Component):
    """The controller as ``fastrun`` runs it: every port of its passed through, ``clk``, and
    its reset made inside, high in the first :data:`RESET_CLOCKS` clocks (a counter of its
    own, reset-less), not a port. A reset port is an input like ``rx``: Verilator evaluates
    all the logic an input reaches (every register's reset multiplexer) at each of the two
    evaluations of a clock, which was half the time of a run (docs/controller.md,
    "Simulation"). With tool outputs (:func:`~kontur.hdl.motion.tools.tool_engine`) their pins
    are a port too: ``tools``, bit n the n-th of :data:`~kontur.hdl.motion.tools.TOOL_PINS`
    (as the boards' top levels take them), so that ``fastrun`` records them."""

    def __init__(self, controller):
        self._controller = controller
        self.idle_inputs = getattr(controller, "idle_inputs", 0)
        self._tools = tool_engine(controller) if hasattr(controller, "table") else None
        members = {"clk": wiring.In(1), **controller.signature.members}
        if self._tools is not None:
            members["tools"] = wiring.Out(len(TOOL_PINS))
        super().__init__(members)

    def elaborate(self, platform):
        m = Module()
        m.domains.sync = sync = ClockDomain("sync")
        m.domains.power = power = ClockDomain("power", reset_less=True)
        held = Signal(range(RESET_CLOCKS + 1))
        m.d.comb += [sync.clk.eq(self.clk), power.clk.eq(self.clk),
                     sync.rst.eq(held != RESET_CLOCKS)]
        with m.If(held != RESET_CLOCKS):
            m.d.power += held.eq(held + 1)
        m.submodules.controller = controller = self._controller
        for name, member in controller.signature.members.items():
            ours, theirs = getattr(self, name), getattr(controller, name)
            if member.is_signature:
                wiring.connect(m, theirs, wiring.flipped(ours))
            elif member.flow == wiring.In:
                m.d.comb += theirs.eq(ours)
            else:
                m.d.comb += ours.eq(theirs)
        if self._tools is not None:
            m.d.comb += self.tools.eq(Cat(getattr(self._tools, name) for name in TOOL_PINS))
        return m


class FastRun:
    """A Verilator build of a controller top level, with the host-side testbench.

    Parameters
    ----------
    top : :class:`~amaranth.hdl.Elaboratable`
        The design, with ports ``rx``, ``tx``, ``motion.step``, ``motion.dir``.
    root : path
        Where builds are kept (``root/<digest>``).
    waves : bool
        Build with VCD tracing (needed for :meth:`run` with ``vcd``).
    """

    def __init__(self, top, root, *, waves=False):
        from amaranth.back import verilog

        verilator_environment()
        top = _FastTop(top)
        self.idle = top.idle_inputs                         # the switch pins, all idle
        self.tools = top._tools is not None
        text = verilog.convert(top, name="top", emit_src=False)
        source = HARNESS.read_text()
        digest = hashlib.sha256(f"{int(waves)}\n{source}\n{text}".encode()).hexdigest()[:16]
        self.build_dir = (Path(root) / digest).resolve()
        self.build_dir.mkdir(parents=True, exist_ok=True)
        self.waves = waves
        self.binary = self.build_dir / "obj" / "fastrun"
        with _locked(self.build_dir / ".lock"):
            if not (self.build_dir / ".built").exists():
                for item in self.build_dir.iterdir():
                    if item.is_dir():
                        shutil.rmtree(item)
                    elif item.name != ".lock":
                        item.unlink()
                self._build(text)
                (self.build_dir / ".built").touch()

    def _build(self, text):
        (self.build_dir / "top.v").write_text(text)
        # (X values as Verilator likes them fastest: every register of the design has its
        # declared initial value, and no case of its has an X default that matters.)
        command = ["verilator", "--cc", "--exe", "--build", "-O3", "--top-module", "top",
                   "--x-assign", "fast", "--x-initial", "fast", "--noassert",
                   "-Wno-WIDTHEXPAND", "-Wno-WIDTHTRUNC", "-Wno-CASEINCOMPLETE", "-Wno-CASEOVERLAP",
                   "-Wno-SYMRSVDWORD", "--prefix", "Vtop", "-Mdir", "obj", "-o", "fastrun",
                   "-CFLAGS", "-O2" + (" -DKONTUR_TOOLS" if self.tools else ""),
                   "-MAKEFLAGS", "CFG_CXXFLAGS_PCH_I=-include",
                   *(["--trace"] if self.waves else []), "top.v", str(HARNESS)]
        log = self.build_dir / "build.log"
        with open(log, "w") as handle:
            # verilator runs make, make the compiler: one group, ended as one.
            result = processes.run(command, cwd=self.build_dir, stdout=handle,
                                   stderr=subprocess.STDOUT)
        if result.returncode != 0:
            raise SimulatorError(f"the Verilator build of the controller failed; see {log}")

    def run(self, frames, *, divisor, window, max_clocks, vcd=None, vcd_clocks=None,
            progress=None, schedule=()):
        """Run ``frames`` (a list of bytes objects, in order), and ``schedule`` on the switch
        pins (:class:`kontur.sim.testbench.hostlink.HostLink`'s); return a :class:`Run`. With
        ``vcd``, the waveform of the run (of its first ``vcd_clocks`` clocks, if given) is
        written there.
        ``progress``, if given, is called with the number of steps made so far about twice a
        second while the simulation runs.

        Raises :exc:`SimulatorError` if the program did not end within ``max_clocks``.
        """
        if vcd is not None and not self.waves:
            raise ValueError("a waveform needs a build made with waves=True")
        runs = self.build_dir / "runs"
        runs.mkdir(exist_ok=True)
        run_dir = Path(tempfile.mkdtemp(prefix="run-", dir=runs))
        write_frames(run_dir / "frames.bin", frames)
        write_schedule(run_dir / "schedule.txt", schedule, self.idle)
        command = [str(self.binary), f"--schedule={run_dir / 'schedule.txt'}",
                   str(run_dir / "frames.bin"), str(run_dir / "events.txt"),
                   str(divisor), str(window), str(max_clocks)]
        if vcd is not None:
            command.append(str(Path(vcd).resolve()))
            if vcd_clocks is not None:
                command.append(str(vcd_clocks))
        started = time.monotonic()
        with processes.child(command, cwd=run_dir) as process:
            code = self._wait(process, run_dir / "events.txt", progress)
        seconds = time.monotonic() - started
        if code not in (0, 3):
            raise SimulatorError(f"the controller run failed (status {code}); see {run_dir}")
        applied, tools = [], []
        steps, replies, clocks = parse_events((run_dir / "events.txt").read_text(), applied,
                                              tools)
        if code == 3:
            raise SimulatorError(f"the program did not end within {max_clocks} clocks "
                                 f"({run_dir})")
        shutil.rmtree(run_dir, ignore_errors=True)
        return Run(steps, replies, clocks, seconds, applied, tools)

    @staticmethod
    def _wait(process, events, progress):
        if progress is None:
            return process.wait()
        made, offset = 0, 0
        while True:
            try:
                return process.wait(timeout=0.5)
            except subprocess.TimeoutExpired:
                pass
            if events.exists():
                with open(events, "rb") as handle:
                    handle.seek(offset)
                    chunk = handle.read()
                cut = chunk.rfind(b"\n") + 1          # whole lines only
                made += chunk[:cut].count(b"S ")
                offset += cut
                progress(made)
