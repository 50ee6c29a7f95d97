"""``kontur send FILE.ngc --port DEVICE``: a program streamed to a board's controller.

The program is prepared as for ``kontur run`` (:func:`kontur.machining.prepare`: read,
on the lattice, planned, its frames), checked whole before anything moves, then:

1. The handshake: a ``QUERY`` (an ``UNLOCK`` with ``unlock``), whose ``STATUS`` must come within
   the timeout and show the board idle (not moving, not in ALARM: an e-stop or a limit switch
   tripped), with as many free queue slots as the machine file's ``queue_frames`` (an
   idle controller reports its whole queue free: the frames it holds, not the bytes of its
   block RAM) and at the program's start (the position since reset). A board that does not
   answer, or answers otherwise, was built for another machine file, is busy, or has moved:
   nothing is sent.
2. The stream, under the protocol's flow control: at most ``queue_frames`` frames unanswered,
   an ``OUTCOME`` (or an ``ERROR``) answering each. A frame the machine refuses or aborts, and
   every error it reports, is shown in the program's terms (its line), and the stream stops.
3. At the end the position is read back (``QUERY``) and compared with the program's end.

Every reply is untrusted: an outcome or error code the host does not know, a frame number out
of turn, a ``STATUS`` with flags or a free count no controller gives, are failures like the
others. The machine must make progress: the oldest unanswered frame must be answered within
its planned time (times :data:`PACE`) and the timeout, whatever else arrives (``STATUS``
replies, bytes that are no frame). After every failure once the stream has begun an ``ABORT``
is sent, so nothing queued moves on (a failed handshake sends nothing: the board may be running
another program). A signal (:class:`Stop`: ``SIGINT``, ``SIGTERM``, ``SIGHUP``) stops
the stream the same way, then waits (:data:`ABORT_WAIT` s at most) for the outcomes of the
frames in flight and reads where the machine stopped.
"""

import math
import signal
import time
import types

from kontur import registry
from kontur.hdl.motion import protocol
from kontur.hdl.motion.link import ERROR, ERRORS, OUTCOME, STATES, STATUS
from kontur.sim import processes

__all__ = ["send", "SendError", "SendInterrupted", "Stop", "open_port", "PACE", "ABORT_WAIT",
           "unhonoured", "UNHONOURED", "Feeder"]

OUTCOMES = ("done", "refused", "aborted")
DONE, REFUSED, ABORTED = range(3)

#: The flags a STATUS may carry: bit 0 moving, bit 1 an error reported since reset, bit 2 at
#: a standstill under feed hold.
MOVING, ERRORED, HELD = 1, 2, 4

#: A frame may take this many times its planned time (and the timeout besides).
PACE = 1.25

#: At most this long (s) an interrupted send waits for the outcomes after its ABORT, and as
#: long again for the position.
ABORT_WAIT = 3.0


class SendError(RuntimeError):
    """The machine did not run the program through: the message says where, in program
    lines."""


class SendInterrupted(SendError):
    """A signal (:attr:`signum`) stopped the send; the message says what the machine did."""

    def __init__(self, message, signum):
        super().__init__(message)
        self.signum = signum


class _LinkDown(Exception):
    """The port itself failed (read or write)."""


class Stop:
    """The signals that stop a send: while entered (in the main thread), ``SIGINT``,
    ``SIGTERM`` and ``SIGHUP`` are recorded (:attr:`signum`, the first; :attr:`count`) instead
    of ending the process, and :func:`send` stops the machine before it returns; a signal
    ignored when entered (``nohup``'s ``SIGHUP``) stays ignored. The previous handlers come
    back on exit. Called, it returns :attr:`signum` (``None`` until a signal)."""

    SIGNALS = processes.SIGNALS

    def __init__(self):
        self.signum = None
        self.count = 0
        self._saved = {}

    def __call__(self):
        return self.signum

    def _caught(self, signum, frame):
        self.signum = self.signum or signum
        self.count += 1

    def __enter__(self):
        self._saved = processes.catch(self._caught)         # nohup's SIGHUP stays ignored
        return self

    def __exit__(self, *exc):
        processes.restore(self._saved)
        self._saved = {}
        return False


def open_port(device, baud, *, timeout=0.05, write_timeout=None):
    """Open ``device`` (a path, or any pyserial URL) at ``baud``, 8N1; a write that the port
    does not take within ``write_timeout`` s raises (``None``: waits)."""
    import serial
    return serial.serial_for_url(device, baudrate=baud, timeout=timeout,
                                 write_timeout=write_timeout)


def _where(lines, index):
    line = lines[index] if 0 <= index < len(lines) else None
    if isinstance(line, str):                  # a homing cycle's pass (kontur.homing)
        return f"the homing cycle's {line}"
    return f"line {line}" if line is not None else "the program's set-up (no program line)"


#: What the board cannot do, by event kind (:class:`kontur.gcode.Event`): the reason a program
#: asking for it is refused by ``kontur send`` (``kontur run`` simulates it).
UNHONOURED = {
    "spindle": "switches the spindle (or laser, torch) on, but the board has no tool outputs",
    "coolant": "switches coolant on, but the board has no coolant outputs",
    "tool_change": "changes the tool, which needs a pause for the operator, and the board "
                   "cannot pause a program",
    "pause": "pauses the program until cycle start, and the board cannot pause a program",
}


def unhonoured(job):
    """``(line, reason)`` of the first event of ``job`` the board cannot honour (M3, M4, M7,
    M8 on a board without tool outputs, M6, M0, M1; :data:`UNHONOURED`), or ``None``. M5, M9, M61, S, T, G43/G49 and messages
    ask nothing of the board."""
    tools = registry.board(job.board).tools       # TOOL frames: the spindle and coolant
    for event in job.events:
        if event.text.split()[0] in ("M5", "M9", "M61"):     # off, or a tool number set
            continue
        if tools and event.kind in ("spindle", "coolant"):
            continue
        if event.kind in UNHONOURED:
            return event.line, (f"{event.text.split(' (')[0]} {UNHONOURED[event.kind]}: "
                                f"kontur send cannot honour it (kontur run simulates it)")
    return None


def _frame_plan(job, count):
    """The planned time (s) of each of the job's ``count`` frames, and the speed (mm/s) the
    plan leaves each move frame at (its exit; ``None`` for the other frames): the move frames'
    their plan's, a dwell's its share of the dwell, the others' none (CONFIG, FEED and a move
    each, DWELL and TOOL frames, STOP; for any other layout every frame gets the whole
    program's time, and no exit)."""
    from kontur.planner import dwell_frames
    given = getattr(job, "durations", None)   # the frames' own (a homing cycle's)
    if given is not None and len(given) == count:
        return list(given), [None] * count
    seconds, exits = [0.0], [None]
    for segment, item in zip(job.segments, job.items):
        if segment.kind == "dwell":
            parts = len(dwell_frames(segment, job.machine))
            seconds += [item.seconds / parts] * parts
            exits += [None] * parts
        else:
            seconds += [0.0, item.seconds]
            exits += [None, item.exit]
    seconds.append(0.0)
    exits.append(None)
    if count != len(seconds):
        return [job.seconds] * count, [None] * count
    return seconds, exits


def _mm(point, spm):
    return f"({point[0] / spm:.4f}, {point[1] / spm:.4f}) mm"


class _Sender:
    """One send: the port, the frames, what is sent and answered."""

    #: Who says what is written on ``out``.
    NAME = "kontur send"

    def __init__(self, job, port, *, progress, timeout, out, stop):
        self.job = job
        self.port = port
        self.progress = progress
        self.timeout = timeout
        self.out = out
        self.stop = stop if stop is not None else (lambda: None)
        self.frames, self.lines = job.frames()
        self.durations, self.exits = _frame_plan(job, len(self.frames))
        self.starved = []                      # the move frames the queue ran dry after
        self.controls = lambda: ()                # the operator's (send's ``controls``)
        self.held, self.feed, self.rapid, self.spindle = False, 100, 100, 100
        self.parser = protocol.ReplyParser()
        self.window = job.machine.queue_frames
        self.sent = self.answered = 0
        self.sent_at = []
        self.heard = 0.0                       # when the last frame was answered
        self.base = None                       # the number of the first frame (the board's)
        self.statuses = 0                      # STATUS replies since the last progress
        self.garbage = 0                       # parser.dropped at the last progress

    # ---- the port -------------------------------------------------------------------------

    def write(self, data):
        try:
            self.port.write(data)
        except OSError as error:               # serial.SerialException is an OSError
            raise _LinkDown(f"writing to the port failed ({error})") from None

    def read(self):
        """The replies the port has now: ``(reply, dropped)`` each, ``dropped`` the bytes that
        were no frame before it (the parser takes the bytes one at a time, so the bytes after
        a reply in the same read are not counted before it)."""
        try:
            waiting = getattr(self.port, "in_waiting", 0)
            data = self.port.read(waiting or 1)
        except OSError as error:
            raise _LinkDown(f"reading from the port failed ({error})") from None
        replies = []
        for index in range(len(data)):
            for reply in self.parser.feed(data[index:index + 1]):
                replies.append((reply, self.parser.dropped))
        return replies

    def abort(self):
        """Send ABORT; return what to add to a message when it could not be sent."""
        try:
            self.write(protocol.abort())
        except _LinkDown as error:
            return f"; the ABORT could not be sent ({error}): the machine may still be moving"
        return ""

    def fail(self, message, *, abort=True):
        raise SendError(message + (self.abort() if abort else ""))

    def check_interrupt(self):
        if self.stop():
            self.interrupted(self.stop())

    # ---- untrusted replies ----------------------------------------------------------------

    def check_flags(self, fields, *, abort=True):
        x, y, free, flags, state = fields[:5]
        if flags & ~(MOVING | ERRORED | HELD) or state >= len(STATES):
            what = f"flags {flags:#04x}" if flags & ~(MOVING | ERRORED | HELD) \
                else f"state {state}"
            self.fail(f"the board sent a STATUS with {what}, which no controller "
                      f"sets (at ({x}, {y}), {free} slots free): is it a kontur controller?",
                      abort=abort)

    def check_status(self, fields):
        self.check_flags(fields)
        free = fields[2]
        if free > self.window % 256:
            self.fail(f"the board sent a STATUS with {free} free queue slots, more than the "
                      f"{self.window} of the machine file: build the bitstream with its "
                      f"machine file (kontur build --machine FILE)")

    def outcome(self, number, code, dropped=0):
        if self.answered >= self.sent:
            self.fail(f"the machine answered frame {number}, and no frame was waiting for an "
                      f"answer")
        where = _where(self.lines, self.answered)
        if self.base is None:
            self.base = (number - self.answered) % 256
        expected = (self.base + self.answered) % 256
        if number != expected:
            self.fail(f"the machine answered frame {number}, expected {expected} ({where})")
        if code not in (DONE, REFUSED, ABORTED):
            self.fail(f"the machine answered frame {number} ({where}) with outcome code "
                      f"{code}, which no controller sends")
        if code != DONE:
            self.refused(code, where)
        self.answered += 1
        self.heard = time.monotonic()
        self.statuses, self.garbage = 0, dropped
        if self.progress is not None:
            self.progress(self.answered)

    def refused(self, code, where):
        """The oldest frame came back not done (``code``): the send fails, in the program's
        words (a homing pass's, :func:`kontur.homing.homing_job`'s ``explain``)."""
        explain = getattr(self.job, "explain", None)
        reason = explain(self.lines[self.answered], code) if explain else None
        self.fail(reason or f"{where}: the machine {OUTCOMES[code]} this move")

    def error(self, code):
        name = ERRORS.get(code)
        what = name if name else f"error code {code}, which no controller sends"
        first, last = _where(self.lines, self.answered), _where(self.lines, self.sent - 1)
        self.fail(f"the machine dropped a frame ({what}) while frames from {first} to {last} "
                  f"were in flight; the rest is aborted")

    def heard_else(self):
        """What the machine sent since the last progress, besides answers."""
        parts = []
        if self.statuses:
            parts.append(f"{self.statuses} STATUS replies")
        garbage = self.parser.dropped - self.garbage
        if garbage:
            parts.append(f"{garbage} bytes that were no frame (bad CRCs or noise: is the "
                         f"bitstream's baud {self.job.machine.baud}?)")
        return "only " + " and ".join(parts) if parts else "nothing"

    # ---- the three steps ------------------------------------------------------------------

    def handshake(self, unlock=False):
        baud = self.job.machine.baud
        self.write(protocol.unlock() if unlock else protocol.query())
        deadline = time.monotonic() + self.timeout
        while True:
            self.check_interrupt()
            for reply, _ in self.read():
                if reply.kind == STATUS:
                    return self.check_board(reply.fields, reply.position)
                if reply.kind == OUTCOME:
                    self.fail("the board answered a frame before any was sent: it is running "
                              "another program; wait for its end or reset the board",
                              abort=False)
                if reply.kind == ERROR and self.out is not None:
                    self.out.write(f"kontur send: before the program: {reply}\n")
            if time.monotonic() > deadline:
                garbage = self.parser.dropped
                heard = f"; {garbage} bytes came that were no frame" if garbage else ""
                self.fail(f"no answer from the board at {baud} baud in {self.timeout:g} s{heard} "
                          f"(is the baud of the bitstream's machine file the same?)", abort=False)

    def check_board(self, fields, position=None):
        # (the position by the board's axes: a 3-axis controller's STATUS has Z too)
        x, y, free, flags = fields[:4]
        position = tuple(fields[:2]) if position is None else tuple(position)
        self.check_flags(fields, abort=False)
        if STATES[fields[4]] == "ALARM":
            tripped = ", ".join(protocol.input_names(fields[5])) or "nothing"
            active = ", ".join(protocol.input_names(fields[6])) or "none"
            self.fail(f"the board is in ALARM (tripped: {tripped}; inputs active now: "
                      f"{active}) at ({x}, {y}) steps: release the e-stop, then send with "
                      f"--unlock (a limit may stay pressed); nothing was sent", abort=False)
        if flags & MOVING:
            self.fail(f"the board is moving (at ({x}, {y}) steps, {free} queue slots free): it "
                      f"is running another program; wait for its end or reset the board",
                      abort=False)
        self.check_flags(fields, abort=False)
        if free != self.window % 256:
            self.fail(f"the board's queue holds {free} frames, the machine file says "
                      f"{self.window}: build the bitstream with --machine FILE (kontur build "
                      f"--machine FILE, make bitstream MACHINE=FILE)", abort=False)
        start = self.job.start                  # None: anywhere (a homing cycle)
        if start is not None and position != tuple(start):
            self.fail(f"the board is at {position} steps, not at the program's start {tuple(start)}: "
                      f"its coordinates count from where the board was reset; reset it there",
                      abort=False)

    def control(self):
        """The operator's controls (``controls``: ``"hold"``, ``"resume"``, ``("feed", PCT)``,
        ``("rapid", PCT)``, ``("spindle", PCT)``), sent at once as HOLD, RESUME, OVERRIDE (with
        all three overrides as they stand). While held no frame is
        overdue; a resume counts as an answer (the oldest frame's time starts again)."""
        for command in self.controls() or ():
            self.command(command)

    def command(self, command):
        """One of the operator's controls (as :meth:`control` takes them), sent at once."""
        if command == "hold":
            self.write(protocol.hold())
            self.held = True
        elif command == "resume":
            self.write(protocol.resume())
            self.held = False
            self.heard = time.monotonic()
        else:
            what, percent = command
            setattr(self, what, percent)        # feed, rapid or spindle
            self.write(protocol.override(self.feed, self.rapid, self.spindle))

    def deadline(self):
        """When the oldest unanswered frame is overdue (never while held)."""
        if self.held:
            return math.inf
        index = self.answered
        begun = max(self.heard, self.sent_at[index])
        slower = 100 / min(self.feed, 100, self.rapid)     # the overrides below 100 %
        return begun + PACE * self.durations[index] * slower + self.timeout

    def stream(self):
        count = len(self.frames)
        self.heard = time.monotonic()
        while self.answered < count:
            self.check_interrupt()
            self.control()
            self.pump()

    def _homing_waits(self):
        """Whether the next frame is a homing cycle's (its line a pass's name) with one of the
        cycle's before it unanswered: the cycle goes a frame at a time, so that a pass that
        fails (``REFUSED``: its switch not found) has no pass queued behind it on the board
        to run before the host's ``ABORT`` arrives."""
        following = self.lines[self.sent] if self.sent < len(self.lines) else None
        return (isinstance(following, str)
                and any(isinstance(line, str) for line in self.lines[self.answered:self.sent]))

    def ran_dry(self):
        """Every frame sent is answered and the next is not written yet: the board's queue ran
        dry. Where the last move sent was planned to go on at speed (its exit above the speed
        of a planned stop, :func:`kontur.planner.rest_speed`), the machine stopped at its end
        at once, at that speed, and goes on at it when the next move comes (the feed generator
        keeps the rate of the move before): said on ``out`` with the move's line, and kept in
        :attr:`starved`. A move's ``OUTCOME`` comes at its end, so a queue said to have run
        dry did; one may run dry unseen here (an answer read only after the next frame is
        written). Not under a feed hold, which ramps the machine down to rest."""
        from kontur.planner import rest_speed
        if self.held:
            return
        move = next((index for index in range(min(self.sent, len(self.exits)) - 1, -1, -1)
                     if self.exits[index] is not None), None)
        if move is None or (self.starved and self.starved[-1] == move):
            return
        speed = self.exits[move]
        if speed <= rest_speed(self.job.machine) * (1 + 1e-9):
            return
        self.starved.append(move)
        if self.out is not None:
            self.out.write(f"{self.NAME}: {_where(self.lines, move)}: the board's queue ran dry "
                           f"at the end of this move: the machine stopped there at once from "
                           f"{speed * 60:.0f} mm/min and goes on at that speed (this computer or "
                           f"the link fell behind the motion)\n")

    def pump(self):
        """One turn of the stream: frames sent while the window has room (a homing cycle's a
        frame at a time), the replies there are read, the oldest unanswered frame's deadline
        checked."""
        count = len(self.frames)
        while (self.sent < count and self.sent - self.answered < self.window
               and not self._homing_waits()):
            if self.sent and self.answered == self.sent:
                self.ran_dry()
            self.write(self.frames[self.sent])
            self.sent_at.append(time.monotonic())
            self.sent += 1
        for reply, dropped in self.read():
            if reply.kind == OUTCOME:
                self.outcome(*reply.fields, dropped)
            elif reply.kind == ERROR:
                self.error(*reply.fields)
            else:
                self.z = reply.z                # a 3-axis board's Z (None on two axes)
                self.check_status(reply.fields)
                self.statuses += 1
        # (the oldest frame not yet answered, once it is sent: every frame sent may be answered
        # while the next waits to be sent)
        if self.answered < min(count, self.sent) and time.monotonic() > self.deadline():
            index = self.answered
            waited = time.monotonic() - max(self.heard, self.sent_at[index])
            self.fail(f"no answer in {waited:.1f} s to {self.sent - index} frames, the "
                      f"first from {_where(self.lines, index)} (planned to take "
                      f"{self.durations[index]:.2f} s): the machine sent "
                      f"{self.heard_else()}")

    def finish(self):
        self.write(protocol.query())
        asked = time.monotonic()
        self.statuses, self.garbage = 0, self.parser.dropped
        while True:
            self.check_interrupt()
            for reply, _ in self.read():
                if reply.kind == STATUS:
                    self.check_status(reply.fields)
                    position = reply.position
                    if position != tuple(self.job.end):
                        raise SendError(f"the machine ended at {position} steps, not at the "
                                        f"program's end {tuple(self.job.end)}")
                    return position
                if reply.kind == OUTCOME:
                    self.outcome(*reply.fields)        # fails: every frame was answered
                elif reply.kind == ERROR:
                    self.error(*reply.fields)
            if time.monotonic() - asked > self.timeout:
                self.fail(f"no STATUS in {self.timeout:g} s after the program's last frame was "
                          f"answered: the machine sent {self.heard_else()}")

    # ---- a signal -------------------------------------------------------------------------

    def interrupted(self, signum):
        name = signal.Signals(signum).name
        flight = self.sent - self.answered
        trouble = self.abort()
        if trouble:
            raise SendInterrupted(f"interrupted ({name}){trouble}", signum)
        wait = min(self.timeout, ABORT_WAIT)
        counts = [0, 0, 0, 0]                  # done, refused, aborted, other
        deadline = time.monotonic() + wait
        status = None
        try:
            while sum(counts) < flight and time.monotonic() < deadline \
                    and getattr(self.stop, "count", 1) < 2:
                for reply, _ in self.read():
                    if reply.kind == OUTCOME:
                        counts[min(reply.fields[1], 3)] += 1
            self.write(protocol.query())
            deadline = time.monotonic() + wait
            while status is None and time.monotonic() < deadline \
                    and getattr(self.stop, "count", 1) < 2:
                for reply, _ in self.read():
                    if reply.kind == STATUS:
                        status = reply.fields
        except _LinkDown as error:
            trouble = f"; then {error}"
        done, refused, aborted, other = counts
        message = f"interrupted ({name}): ABORT sent, {aborted} frames aborted"
        if done:
            message += f", {done} done before it"
        if refused + other:
            message += f", {refused + other} refused or unknown"
        if flight - sum(counts) > 0:
            message += f", {flight - sum(counts)} unanswered after {wait:g} s"
        if status is None:
            message += f"; no STATUS: where the machine stopped is unknown{trouble}"
        else:
            x, y, _, flags = status[:4]
            spm = self.job.machine.steps_per_mm
            verb = "is still moving, at" if flags & MOVING else "stopped at"
            message += f"; the machine {verb} ({x}, {y}) steps = {_mm((x, y), spm)}"
        if self.sent == 0:
            message += " (before the program's first frame)"
        elif self.answered < len(self.lines):
            message += f" (the program had reached {_where(self.lines, self.answered)})"
        raise SendInterrupted(message, signum)


def send(job, port, *, progress=None, timeout=10.0, out=None, stop=None, unlock=False,
         feed=100, rapid=100, spindle=100, controls=None):
    """Stream ``job``'s frames to the controller on ``port`` (an open pyserial port, or
    anything with ``write``, ``read`` and ``in_waiting``) after the handshake; return the final
    position read back (steps).

    ``progress``, if given, is called with the number of frames answered so far. ``timeout``
    (s) is how long the board may take to answer the handshake's and the last ``QUERY``, and
    how much longer than :data:`PACE` times its planned time a frame may take to be answered;
    ``out`` where to write what the machine says besides (a file). ``stop`` (a :class:`Stop`,
    or any callable) returns a signal number once the send must stop. ``unlock``: the
    handshake sends UNLOCK instead of QUERY (its STATUS must then show the ALARM left).
    ``feed``, ``rapid`` and ``spindle``: the overrides (percent: 10-200; 100, 50 or 25;
    10-200), sent in an OVERRIDE frame after the handshake when any is not 100 (a frame's
    allowed time then stretched by ``100 / feed`` below 100 %). ``controls``, if given, is
    called while the frames stream and returns the operator's commands since (``"hold"``,
    ``"resume"``, ``("feed", PCT)``, ``("rapid", PCT)``, ``("spindle", PCT)``), each sent at
    once (HOLD, RESUME, OVERRIDE); no frame is overdue while held.

    Raises
    ------
    SendError
        The handshake failed, a frame refused or aborted, an error reply, a reply no controller
        sends, no progress, the port failed, or a final position that is not the program's
        end; the message names the program line.
    SendInterrupted
        ``stop`` returned a signal: ABORT was sent, the message says what the machine did.
    """
    if not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and timeout > 0):
        raise ValueError(f"The timeout must be a positive number of seconds, not {timeout!r}")
    frame = protocol.override(feed, rapid, spindle) if (feed, rapid, spindle) != (100,) * 3 \
        else None
    sender = _Sender(job, port, progress=progress, timeout=timeout, out=out, stop=stop)
    sender.controls = controls or (lambda: ())
    sender.feed, sender.rapid, sender.spindle = feed, rapid, spindle
    try:
        sender.handshake(unlock)
        if frame is not None:
            sender.write(frame)
        sender.stream()
        return sender.finish()
    except _LinkDown as error:
        unanswered = sender.sent - sender.answered
        where = (f" with {unanswered} frames unanswered (the first from "
                 f"{_where(sender.lines, sender.answered)})" if unanswered else "")
        raise SendError(f"{error}{where}{sender.abort()}") from None


class Feeder(_Sender):
    """The frames of a program that is still being written, sent as they come (``kontur
    serve --port``): the same handshake, flow control, checks of every reply and deadlines as
    :func:`send`, one turn at a time (:meth:`pump`, from the caller's loop). :meth:`extend`
    adds frames (with their program lines and planned seconds); :attr:`status` is the last
    ``STATUS`` fields; :meth:`query` asks for another; :meth:`reset` sends ``ABORT`` and drops
    the frames not yet sent. The board may be anywhere at the handshake (:attr:`status`
    says where). A failure raises :class:`SendError` (an ``ABORT`` sent). ``out``: where a
    queue run dry at speed is said (:meth:`ran_dry`; the frames' exits given to
    :meth:`extend`)."""

    NAME = "kontur: serve"

    def __init__(self, machine, port, *, timeout=10.0, out=None):
        job = types.SimpleNamespace(machine=machine, start=None, end=None, segments=[],
                                    items=[], seconds=0.0, frames=lambda: ([], []))
        super().__init__(job, port, progress=None, timeout=timeout, out=out, stop=None)
        self.status = None
        self.z = None                           # the last STATUS's Z (a 3-axis board's)
        self.reports = 0                        # STATUS replies taken
        self.aborting = False
        self.homing = None                      # the homing cycle's job while it runs
        self.homing_failed = None               # why the homing cycle failed (a pass)

    def check_board(self, fields, position=None):
        position = tuple(fields[:2]) if position is None else tuple(position)
        self.job.start = position               # wherever it is: the session starts there
        self.z = position[2] if len(position) > 2 else None
        self.check_flags(fields, abort=False)
        if STATES[fields[4]] != "ALARM":        # in ALARM: the caller's to say (and unlock)
            super().check_board(fields, position)
        self.status = fields
        self.reports += 1

    def check_status(self, fields):
        super().check_status(fields)
        self.status = fields
        self.reports += 1

    def read(self):
        """As :meth:`_Sender.read`, but never waiting: nothing when the port has nothing (the
        caller's loop has senders to serve)."""
        try:
            waiting = getattr(self.port, "in_waiting", 1)
        except OSError as error:
            raise _LinkDown(f"reading from the port failed ({error})") from None
        return super().read() if waiting else []

    def extend(self, frames, lines, durations, exits=None):
        """Frames to send, with their program lines, planned seconds and (for the move
        frames) the speeds their plan leaves them at (:func:`_frame_plan`; none given: no
        queue run dry is said after them)."""
        self.frames += frames
        self.lines += lines
        self.durations += durations
        self.exits += [None] * len(frames) if exits is None else exits

    @property
    def in_flight(self):
        """Frames sent or to send and not yet answered."""
        return len(self.frames) - self.answered

    def _link(self, method, *args):
        """``method(*args)``, a failed port a :class:`SendError` (as :func:`send` says it)."""
        try:
            return method(*args)
        except _LinkDown as error:
            raise SendError(f"{error}{self.abort()}") from None

    def handshake(self, unlock=False):
        return self._link(super().handshake, unlock)

    def pump(self):
        return self._link(super().pump)

    def query(self, unlock=False):
        self._link(self.write, protocol.unlock() if unlock else protocol.query())

    def command(self, command):
        self._link(super().command, command)

    def home(self, job):
        """Send the homing cycle's frames (:func:`kontur.homing.homing_job`): a pass that
        does not find its switch is no failure of the link but :attr:`homing_failed` (the
        caller aborts the rest, :meth:`reset`)."""
        frames, names = job.frames()
        self.homing, self.homing_failed = job, None
        self.extend(frames, names, list(job.durations))

    def refused(self, code, where):
        line = self.lines[self.answered]
        reason = self.homing.explain(line, code) if self.homing is not None and \
            isinstance(line, str) else None
        if reason is None:
            super().refused(code, where)
        self.homing_failed = reason

    def outcome(self, number, code, dropped=0):
        if not self.aborting:
            return super().outcome(number, code, dropped)
        self.answered += 1                      # after an ABORT: every outcome is expected
        self.heard = time.monotonic()
        self.aborting = self.answered < self.sent
        return None

    def reset(self):
        """``ABORT``: the board stops, the frames not yet sent are dropped."""
        self._link(self.write, protocol.abort())
        del self.frames[self.sent:], self.lines[self.sent:], self.durations[self.sent:]
        del self.exits[self.sent:]
        self.aborting = self.answered < self.sent
