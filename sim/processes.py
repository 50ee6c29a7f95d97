"""Child processes that end with the command that started them.

1. Every tool the project starts (the cocotb runner's ``iverilog``, ``vvp``, ``verilator`` and
   ``make``, the Verilator test bench of :mod:`kontur.sim.fastrun` and its build, Yosys and nextpnr of
   :mod:`kontur.constraints.flow`) is started by :func:`popen` (or :func:`run`, or :func:`child`), in
   a process group of its own, so that everything it starts (a compiler under ``make``, say)
   is in that group too.
2. A group is *live* from its start until it is ended: :func:`stop` ends one group (the
   :func:`child` block does when it is left, however) and :func:`stop_all` every live one:
   ``SIGTERM`` to the whole group, up to :data:`GRACE` seconds for it to go, then ``SIGKILL``,
   and the leader waited for.
3. :func:`signals_handled` (``kontur``'s ``main`` holds it for the command's life) turns
   ``SIGTERM`` and ``SIGHUP`` into :exc:`Interrupted`, a :exc:`KeyboardInterrupt`, as Python
   turns ``SIGINT`` into one: each of the three takes the same path out, and every live group
   is ended on the way (by the :func:`child` being left, and by :func:`stop_all` at the end).
   The exit status is ``128 +`` the signal's number (130, 143, 129).

A group of its own also keeps the tools out of the terminal's group: Ctrl-C reaches ``kontur``
alone, which ends them in order, not the tools half-way through writing a build.
"""

import contextlib
import os
import signal
import subprocess
import threading
import time

__all__ = ["SimulatorError", "Interrupted", "SIGNALS", "catch", "restore", "GRACE", "popen", "run", "child", "stop", "stop_all", "live",
           "hold", "signals_handled"]

GRACE = 2.0
"""Seconds a group has to end after ``SIGTERM`` before it gets ``SIGKILL``."""

_live = {}                     # leader's pid (= the group's id) -> its Popen
_stopping = False              # while ending groups, a signal is held in _pending
_pending = []


class SimulatorError(RuntimeError):
    """A simulator build or run failed; the message names its log."""


class Interrupted(KeyboardInterrupt):
    """The command was asked to stop by signal :attr:`signum` (``SIGINT``, ``SIGTERM`` or
    ``SIGHUP``)."""

    def __init__(self, signum=signal.SIGINT):
        super().__init__(signal.Signals(signum).name)
        self.signum = signal.Signals(signum)


def popen(args, **options):
    """:class:`subprocess.Popen` of ``args`` in a new session (so a group of its own), live
    until :func:`stop` or :func:`stop_all` ends it."""
    process = subprocess.Popen(args, start_new_session=True, **options)
    _live[process.pid] = process
    return process


@contextlib.contextmanager
def child(args, **options):
    """:func:`popen` for the ``with`` block; whatever ends the block (the child's end, an
    error, an interrupt), the group is ended with it: nothing it started outlives it, and the
    pipes to it are closed (as :class:`subprocess.Popen`'s own ``with`` closes them)."""
    process = popen(args, **options)
    try:
        try:
            yield process
        except BaseException:
            _end(process)             # a signal meanwhile changes nothing: already leaving
            raise
        stop(process)
    finally:
        for stream in (process.stdin, process.stdout, process.stderr):
            if stream is not None:
                stream.close()


def run(args, *, timeout=None, **options):
    """Run ``args`` to its end in a group of its own (:func:`child`); return its
    :class:`subprocess.CompletedProcess` (``stdout`` read if ``stdout=subprocess.PIPE``).
    :exc:`subprocess.TimeoutExpired` after ``timeout`` seconds, the group ended."""
    with child(args, **options) as process:
        stdout, stderr = process.communicate(timeout=timeout)
    return subprocess.CompletedProcess(args, process.returncode, stdout, stderr)


def live():
    """The leaders' pids of the live groups."""
    return sorted(_live)


def stop(process):
    """End ``process``'s group (``SIGTERM``, :data:`GRACE` seconds, ``SIGKILL``) and wait for
    its leader. A signal that arrives meanwhile is held until the group is gone, then raised
    (:exc:`Interrupted`)."""
    _end(process)
    if _pending and not _stopping:
        signum = _pending[0]
        _pending.clear()
        raise Interrupted(signum)


def stop_all():
    """End every live group, as :func:`stop` does, a signal meanwhile held and dropped (the
    command is ending)."""
    for process in list(_live.values()):
        _end(process)


def hold():
    """From now until :func:`signals_handled` ends, hold every signal (the command is ending)."""
    global _stopping
    _stopping = True


def _end(process):
    global _stopping
    was, _stopping = _stopping, True
    try:
        group = process.pid
        if _group_alive(group):
            _signal(group, signal.SIGTERM)
            deadline = time.monotonic() + GRACE
            while _group_alive(group) and time.monotonic() < deadline:
                if process.poll() is not None:
                    time.sleep(0.02)                # the leader gone, a member not yet
                else:
                    with contextlib.suppress(subprocess.TimeoutExpired):
                        process.wait(timeout=0.02)
            _signal(group, signal.SIGKILL)
        process.wait()
        deadline = time.monotonic() + GRACE     # killed members, until their parent reaps
        while _group_alive(group) and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        _live.pop(process.pid, None)
        _stopping = was


def _signal(group, signum):
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(group, signum)


def _group_alive(group):
    """Whether group ``group`` still has a member that is not a zombie."""
    try:
        os.killpg(group, 0)
    except (ProcessLookupError, PermissionError):
        return False
    # killpg(0) counts zombies too: look for a member that still runs.
    for pid in os.listdir("/proc") if os.path.isdir("/proc") else ():
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/stat") as handle:
                fields = handle.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == group and fields[0] != "Z":
            return True
    return not os.path.isdir("/proc")


#: The signals that stop a command.
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def catch(handler):
    """Install ``handler`` for each of :data:`SIGNALS` that is not ignored (one ignored when the
    command started stays so: Ctrl-C for a job started in the background, ``SIGHUP`` under
    ``nohup``); return the handlers replaced, for :func:`restore`. Outside the main thread,
    where Python allows no handlers, none is installed."""
    saved = {}
    if threading.current_thread() is threading.main_thread():
        for signum in SIGNALS:
            if signal.getsignal(signum) is not signal.SIG_IGN:
                saved[signum] = signal.signal(signum, handler)
    return saved


def restore(saved):
    """Put back the handlers :func:`catch` replaced."""
    for signum, previous in saved.items():
        signal.signal(signum, previous)


@contextlib.contextmanager
def signals_handled():
    """For the block: ``SIGINT``, ``SIGTERM`` and ``SIGHUP`` raise :exc:`Interrupted` (one
    that arrives while groups are being ended is held until they are), and every group still
    live when the block ends is ended. The previous handlers are restored after. Outside the
    main thread (where Python allows no handlers) only the ending is done."""
    global _stopping

    def handler(signum, frame):
        if _stopping:
            _pending.append(signum)
            return
        raise Interrupted(signum)

    entered = _stopping
    saved = catch(handler)
    try:
        yield
    finally:
        _stopping = True
        try:
            stop_all()
        finally:
            _stopping = entered
            _pending.clear()
            restore(saved)
