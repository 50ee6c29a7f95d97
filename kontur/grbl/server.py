"""``kontur serve``: a Grbl 1.1 device on a pseudo-terminal (and a localhost TCP port).

One loop, one thread: it waits (a few milliseconds at most) for bytes from the pseudo-terminal
and the TCP clients, hands them to the :class:`~kontur.grbl.session.Session` (real-time bytes
are acted on as they are read, a status report written back in the same turn), lets the
session take its lines and move its clock, and writes what it says to every endpoint. The
pseudo-terminal is raw (no echo, no line-end translation); opening it is a connection, and the
welcome line is sent to it :data:`BOOT` seconds later, as a Grbl board boots after the reset by
the serial port's DTR (the machine itself is not reset). After every run of motion, and at the
end, the steps made since the start are written to ``--out DIR`` as ``kontur run`` writes them
(``steps.txt``, ``summary.json``). With ``--engine verilator`` every run of motion is also run,
once the machine rests, on the controller's RTL under Verilator (:class:`RTLCheck`), whose
steps must be the model's.
"""

import contextlib
import errno
import os
import select
import socket
import time
import sys
import threading
import tty
from pathlib import Path

from kontur.grbl.session import Session

__all__ = ["serve", "Outputs"]

TICK = 0.005          # seconds: the longest the loop waits


class RTLCheck:
    """The segments the model made, run again on the controller's RTL (``engine``, Verilator)
    a run of motion at a time, from rest to rest: its steps must be the model's
    (:func:`kontur.machining.execute` checks them, every frame DONE and the position read
    back). A segment cut short by a soft reset or a jog cancel is not checked (the RTL would
    make it whole); nor is one not yet finished. :attr:`record` is what ``summary.json``
    says of it (``rtl_check``)."""

    def __init__(self, session, engine):
        self.session, self.engine = session, engine
        self.checked = 0                    # segments looked at
        self.record = {"engine": engine, "runs": 0, "segments": 0, "steps": 0,
                       "segments_cut_short": 0, "wall_seconds": 0.0, "failures": []}

    def check(self, segments, cut, made):
        """Check the finished segments of ``segments`` from :attr:`checked` on (``cut``: the
        indexes of those cut short; ``made``: the steps made so far)."""
        finished, total = 0, 0
        for segment in segments:
            total += len(segment.steps)
            if total > made:
                break
            finished += 1
        batch = []
        for index in range(self.checked, finished):
            if index in cut:
                self._run(batch)
                batch = []
                self.record["segments_cut_short"] += 1
            else:
                batch.append(segments[index])
        self._run(batch)
        self.checked = finished

    def _run(self, batch):
        from dataclasses import replace

        from kontur.machining import Job, execute
        from kontur.planner import plan
        # the moves and the tool changes' stops (their TOOL frames)
        batch = [segment for segment in batch if segment.steps or "tool" in segment.payload]
        if not any(segment.steps for segment in batch):
            return
        origin = batch[0].start                 # the RTL starts at its origin

        def moved(point):
            return tuple(c - o for c, o in zip(point, origin))
        batch = [replace(s, start=moved(s.start), end=moved(s.end)) for s in batch]
        machine = self.session.machine
        job = Job("kontur serve", self.session.board, machine, [], batch,
                  plan(batch, machine), (0,) * len(origin))
        try:
            result = execute(job, self.engine)
        except Exception as error:      # RunError, a run too long, the simulator failing:
            lines = sorted({segment.line for segment in batch})     # recorded, never lost
            self.record["failures"].append(f"lines {lines[0]}-{lines[-1]}: "
                                           f"{type(error).__name__}: {error}")
            sys.stderr.write(f"kontur: serve: the RTL check failed: {error}\n")
            return
        self.record["runs"] += 1
        self.record["segments"] += len(batch)
        self.record["steps"] += len(result.steps)
        self.record["wall_seconds"] += result.wall


class Outputs:
    """The session's steps, written to ``out_dir`` as ``kontur run`` writes them whenever
    the machine has made new ones and stood still :data:`SETTLE` seconds: in a thread of its
    own (a long session's summary takes a while), one write at a time; :meth:`close` waits
    for it and writes the last."""

    #: Seconds the machine must have stood still before its steps are written (a sender that
    #: falls behind the motion does not make a write at every pause).
    SETTLE = 0.25

    def __init__(self, session, out_dir, *, engine="model"):
        self.session = session
        self.out_dir = None if out_dir is None else Path(out_dir)
        self.rtl = RTLCheck(session, engine) if engine != "model" else None
        self.written = None
        self._moving = 0.0
        self._thread = None

    def update(self):
        motion = self.session.motion
        now = motion.clock()
        if motion.busy:
            self._moving = now
            return
        if now - self._moving < self.SETTLE or (self._thread and self._thread.is_alive()):
            return
        snapshot = self._snapshot()
        if snapshot is not None:
            self._thread = threading.Thread(target=self._write, args=snapshot, daemon=True)
            self._thread.start()

    def close(self):
        """Wait for a write under way, then write what is new (the steps as they stand)."""
        if self._thread is not None:
            self._thread.join()
        snapshot = self._snapshot()
        if snapshot is not None:
            self._write(*snapshot)

    def _snapshot(self):
        from kontur.machining import Job, Result
        from kontur.planner import plan
        motion = self.session.motion
        key = (len(motion.made), len(motion.segments))
        if key == self.written or not motion.made:
            return None
        self.written = key
        segments = list(motion.segments)
        lines = {segment.line for segment in segments}
        moves = [move for move in self.session.moves if move.line in lines]
        machine = self.session.machine
        job = Job("kontur serve", self.session.board, machine, moves, segments,
                  plan(segments, machine), segments[0].start)
        result = Result("model", list(motion.made), list(motion.times), motion.position)
        return job, result, set(motion.cut)

    def _write(self, job, result, cut):
        from kontur.machining import write_outputs
        first = result.times[0]
        result.times = [t - first for t in result.times]
        extra = None
        if self.rtl is not None:
            self.rtl.check(job.segments, cut, len(result.steps))
            extra = {"rtl_check": dict(self.rtl.record)}
        if self.out_dir is None:
            return
        try:
            write_outputs(job, result, self.out_dir, plot=False, extra=extra)
        except OSError as error:
            sys.stderr.write(f"kontur: serve: cannot write {self.out_dir}: "
                             f"{error.strerror or error}\n")


class _Endpoint:
    """A byte stream to a sender: the pseudo-terminal's master, or a TCP client."""

    def __init__(self, fd, sock=None):
        self.fd, self.sock, self.outbox = fd, sock, bytearray()

    def read(self):
        return self.sock.recv(4096) if self.sock else os.read(self.fd, 4096)

    def flush(self):
        while self.outbox:
            try:
                n = self.sock.send(self.outbox) if self.sock else os.write(self.fd, self.outbox)
            except BlockingIOError:
                return
            del self.outbox[:n]


def _pty(link):
    master, slave = os.openpty()
    tty.setraw(slave)
    name = os.ttyname(slave)
    os.close(slave)                 # a sender's open is then seen (POLLHUP ends)
    os.set_blocking(master, False)
    if link:
        link = Path(link)
        temporary = link.with_name(f".{link.name}.{os.getpid()}")
        with contextlib.suppress(FileNotFoundError):
            temporary.unlink()
        temporary.symlink_to(name)
        temporary.replace(link)
    return master, name


def _listener(port):
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    server.bind(("127.0.0.1", port))
    server.listen(4)
    server.setblocking(False)
    return server


def serve(machine, board, *, link=None, tcp=None, out_dir=None, speed=1.0, engine="model",
          machine_file=None, out=sys.stdout, port=None, timeout=10.0):
    """Serve until a signal ends the process (``KeyboardInterrupt``): the outputs are written
    and the link removed on the way out. ``engine`` ``"verilator"`` checks every run of motion
    on the RTL (:class:`RTLCheck`; with ``out_dir``, where its record is written). ``port``:
    an open serial port to a board that makes the moves (:class:`kontur.grbl.board.
    PortMotion`, after ``kontur send``'s handshake, ``timeout`` its)."""
    motion = None
    if port is not None:
        from kontur.grbl.board import PortMotion
        motion = PortMotion(machine, board, port, speed=speed, timeout=timeout, out=sys.stderr)
    master, name = _pty(link)
    server = _listener(tcp) if tcp is not None else None
    pty = _Endpoint(master)
    clients = {}
    connected = [False]

    def send(line):
        data = line.encode("latin-1") + b"\r\n"
        if connected[0]:
            pty.outbox += data
        for client in clients.values():
            client.outbox += data

    session = Session(machine, board, send, speed=speed, machine_file=machine_file,
                      motion=motion)
    if motion is not None:
        motion.say, motion.alarm, motion.more = send, session.board_alarm, session.lines_ahead
    outputs = Outputs(session, out_dir, engine=engine) \
        if out_dir is not None or engine != "model" else None
    out.write(f"{name}\n")
    if server is not None:
        out.write(f"tcp 127.0.0.1:{server.getsockname()[1]}\n")
    out.flush()
    try:
        _loop(session, pty, server, clients, connected, outputs)
    finally:
        if motion is not None:
            motion.close()
        if outputs is not None:
            outputs.close()
        for client in clients.values():
            client.sock.close()
        if server is not None:
            server.close()
        os.close(master)
        if link and Path(link).is_symlink() and os.readlink(link) == name:
            Path(link).unlink()


#: Seconds from a sender's open of the pseudo-terminal to the welcome line, as a Grbl board
#: boots after the open's DTR reset: a sender's serial library empties its input once the port
#: is set up (pyserial's open does), and a welcome written before that would be lost.
BOOT = 0.25


def _loop(session, pty, server, clients, connected, outputs):
    from kontur.grbl.protocol import WELCOME
    hangup = select.poll()
    hangup.register(pty.fd, select.POLLIN)
    welcome = None                  # when the welcome line is due (a connection's boot)
    while True:
        now = not any(event & select.POLLHUP for _, event in hangup.poll(0))
        if now != connected[0]:
            connected[0] = now
            pty.outbox.clear()
            welcome = time.monotonic() + BOOT if now else None
        if welcome is not None and time.monotonic() >= welcome:
            welcome = None
            pty.outbox += WELCOME.encode() + b"\r\n"
        waiting = select.poll()
        if connected[0]:
            waiting.register(pty.fd, select.POLLIN | (select.POLLOUT if pty.outbox else 0))
        if server is not None:
            waiting.register(server.fileno(), select.POLLIN)
        for fd, client in clients.items():
            waiting.register(fd, select.POLLIN | (select.POLLOUT if client.outbox else 0))
        for fd, event in waiting.poll(TICK * 1000):
            if server is not None and fd == server.fileno():
                _accept(server, clients)
                continue
            endpoint = pty if fd == pty.fd else clients.get(fd)
            if endpoint is None or not event & (select.POLLIN | select.POLLHUP | select.POLLERR):
                continue
            try:
                data = endpoint.read()
            except OSError as error:
                if error.errno not in (errno.EIO, errno.EAGAIN, errno.ECONNRESET):
                    raise
                data = b"" if endpoint is not pty else None
            if data:
                session.receive(data)
            elif data == b"" and endpoint is not pty:
                endpoint.sock.close()
                del clients[fd]
        session.poll()
        for endpoint in (pty, *clients.values()):
            try:
                endpoint.flush()
            except OSError:
                endpoint.outbox.clear()
        if outputs is not None:
            outputs.update()


def _accept(server, clients):
    from kontur.grbl.protocol import WELCOME
    try:
        sock, _ = server.accept()
    except BlockingIOError:
        return
    sock.setblocking(False)
    client = _Endpoint(sock.fileno(), sock)
    client.outbox += WELCOME.encode() + b"\r\n"
    clients[sock.fileno()] = client
