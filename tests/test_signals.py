"""``kontur`` stopped by SIGINT, SIGTERM or SIGHUP in the middle of a simulator's build or run:
the status (128 + the signal), one line, and not one process of the command's tree left.

Each test starts the command as a process with a fresh build root (so the build really runs),
watches its process tree in ``/proc`` until the tool to interrupt is there (a C++ compiler of
the Verilator build, Icarus's ``vvp``), notes every descendant, sends the signal to ``kontur``
alone and then looks for the noted processes: none may still run."""

import contextlib
import os
import signal
import subprocess
import sys
import time

import pytest

PROGRAM = "G21 G90\nG1 X1 Y1 F600\nG1 X0 Y0\n"
COMPILERS = {"cc1plus", "g++", "c++", "clang++", "clang"}


def _processes():
    """``{pid: (ppid, comm, state, starttime)}`` of every process, from ``/proc``."""
    table = {}
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat") as handle:
                text = handle.read()
        except OSError:
            continue
        comm = text[text.index("(") + 1:text.rindex(")")]
        fields = text[text.rindex(")") + 2:].split()
        table[int(name)] = (int(fields[1]), comm, fields[0], fields[19])
    return table


def _descendants(pid):
    """``{pid: (comm, starttime)}`` of every process below ``pid``."""
    table = _processes()
    children = {}
    for child, (parent, *_) in table.items():
        children.setdefault(parent, []).append(child)
    found, todo = {}, [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found[child] = (table[child][1], table[child][3])
            todo.append(child)
    return found


def _running(noted):
    """The noted processes that still run (the same process: same start time; not a
    zombie)."""
    table = _processes()
    return {pid: comm for pid, (comm, start) in noted.items()
            if pid in table and table[pid][3] == start and table[pid][2] != "Z"}


def _interruptible():
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, signal.SIG_DFL)           # as from a terminal (a runner's
                                                        # ignored ones stay ignored in kontur)


def _interrupt(args, tmp_path, signum, wanted):
    """Start ``kontur args`` with a fresh build root, wait until a process whose name is in
    ``wanted`` runs below it, send ``signum``; return the run, its stderr and the processes
    that outlived it."""
    program = tmp_path / "p.ngc"
    program.write_text(PROGRAM)
    # (No ccache: a build whose objects are all in its cache ends before the signal comes.)
    env = dict(os.environ, KONTUR_BUILD=str(tmp_path / "builds"), OBJCACHE="")
    run = subprocess.Popen([sys.executable, "-m", "kontur.cli", *args], cwd=tmp_path,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                           preexec_fn=_interruptible)
    try:
        deadline = time.monotonic() + 300
        while not any(comm in wanted for comm, _ in _descendants(run.pid).values()):
            assert run.poll() is None, run.communicate()
            assert time.monotonic() < deadline, f"no {wanted} within 300 s"
            time.sleep(0.1)
        time.sleep(0.5)
        noted = _descendants(run.pid)
        run.send_signal(signum)                         # to kontur alone, not its group
        _, stderr = run.communicate(timeout=60)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    left = _running(noted)
    deadline = time.monotonic() + 5
    while left and time.monotonic() < deadline:
        time.sleep(0.1)
        left = _running(noted)
    return run, stderr, noted, left


@pytest.mark.cocotb
@pytest.mark.parametrize("signum, line", [
    (signal.SIGINT, "kontur: interrupted"),
    (signal.SIGHUP, "kontur: stopped by SIGHUP"),
], ids=["SIGINT", "SIGHUP"])
def test_signal_during_the_verilator_build_of_run(tmp_path, signum, line):
    # The controller's Verilator build (verilator, make, the compiler) for `kontur run`.
    run, stderr, noted, left = _interrupt(["run", "p.ngc", "--engine", "verilator", "--out",
                                           "out"], tmp_path, signum, COMPILERS)
    assert {"make"} <= {comm for comm, _ in noted.values()}
    assert run.returncode == 128 + signum, stderr
    assert stderr.strip().splitlines() == [line]
    assert left == {}


@pytest.mark.cocotb
def test_sigterm_during_the_verilator_build_of_trace(tmp_path):
    # An engine's Verilator build under cocotb's runner, for `kontur trace`.
    run, stderr, noted, left = _interrupt(["trace", "line", "7", "-3", "--engine", "verilator"],
                                          tmp_path, signal.SIGTERM, COMPILERS)
    assert run.returncode == 143, stderr
    assert stderr.strip().splitlines() == ["kontur: stopped by SIGTERM"]
    assert left == {}


@pytest.mark.cocotb
def test_sigterm_during_an_icarus_run(tmp_path):
    # The build done, the simulator running the program under cocotb.
    run, stderr, noted, left = _interrupt(["run", "p.ngc", "--engine", "icarus", "--out", "out"],
                                          tmp_path, signal.SIGTERM, {"vvp"})
    assert run.returncode == 143, stderr
    assert stderr.strip().splitlines() == ["kontur: stopped by SIGTERM"]
    assert left == {}


def test_a_group_deaf_to_sigterm_is_killed_with_all_it_started():
    # A shell and two children, all ignoring SIGTERM; the block left by an error: every one
    # of them ends, after the grace.
    from kontur.sim import processes
    started = time.monotonic()
    with pytest.raises(LookupError):
        with processes.child(["sh", "-c", "trap '' TERM; sleep 60 & sleep 60 & wait"]) as shell:
            deadline = time.monotonic() + 10
            # (Until both children have become sleep: a forked child is sh until its exec.)
            while sorted(c for c, _ in _descendants(os.getpid()).values()) != \
                    ["sh", "sleep", "sleep"]:
                assert time.monotonic() < deadline
                time.sleep(0.02)
            noted = _descendants(os.getpid())
            raise LookupError
    seconds = time.monotonic() - started
    assert sorted(comm for comm, _ in noted.values()) == ["sh", "sleep", "sleep"]
    assert _running(noted) == {}
    assert shell.returncode == -signal.SIGKILL
    assert processes.GRACE <= seconds < processes.GRACE + 5
    assert processes.live() == []


def test_sigterm_and_sighup_raise_keyboard_interrupt_and_handlers_come_back():
    from kontur.sim import processes
    # As from a terminal: none of the three ignored (a runner may ignore some, and kontur
    # keeps an ignored one ignored: test_an_ignored_signal_stays_ignored).
    inherited = {s: signal.getsignal(s) for s in processes.SIGNALS}
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGHUP, signal.SIG_DFL)
    try:
        before = {s: signal.getsignal(s) for s in processes.SIGNALS}
        for signum in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
            with pytest.raises(KeyboardInterrupt) as caught:
                with processes.signals_handled():
                    os.kill(os.getpid(), signum)
                    time.sleep(5)
            assert caught.value.signum == signum
        assert {s: signal.getsignal(s) for s in before} == before
    finally:
        for signum, handler in inherited.items():
            signal.signal(signum, handler)


def test_an_ignored_signal_stays_ignored():
    # Under nohup SIGHUP is ignored when kontur starts: it must not end the command (nor
    # kontur send, whose Stop keeps the same rule, sim.processes.catch).
    from kontur.sim import processes
    saved = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        with processes.signals_handled():
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGHUP)
            time.sleep(0.2)                                 # nothing raised
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, saved)


def test_a_signal_while_a_group_ends_is_held_then_raised():
    # SIGTERM arrives while a finished child's group is being ended (the shell gone, its
    # `sleep`, deaf to SIGTERM, left in the group until SIGKILL after the grace): the ending
    # is not cut short, and the signal is raised after it.
    import threading
    from kontur.sim import processes
    with processes.signals_handled():
        with pytest.raises(KeyboardInterrupt) as caught:
            with processes.child(["sh", "-c", "trap '' TERM; sleep 60 >/dev/null & echo $!"],
                                 stdout=subprocess.PIPE, text=True) as shell:
                sleeper = int(shell.communicate()[0])
                noted = {sleeper: (_processes()[sleeper][1], _processes()[sleeper][3])}
                timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGTERM))
                started = time.monotonic()
                timer.start()
        seconds = time.monotonic() - started
        timer.join()
    assert caught.value.signum == signal.SIGTERM
    assert seconds >= processes.GRACE
    assert [comm for comm, _ in noted.values()] == ["sleep"] and _running(noted) == {}
    assert processes.live() == []


@pytest.mark.parametrize("error", [False, True])
def test_a_childs_pipes_are_closed_with_it(error):
    # Whether the block ends or fails (a failed assertion in a test of `kontur serve`), the
    # pipes to the child are closed with it: none is left for the garbage collector to find
    # in a later test (a ResourceWarning, an error under PYTHONWARNINGS=error).
    from kontur.sim import processes
    with contextlib.suppress(AssertionError):
        with processes.child(["cat"], stdin=subprocess.PIPE, stdout=subprocess.PIPE) as cat:
            assert not error
    assert cat.stdin.closed and cat.stdout.closed
    assert processes.live() == []
