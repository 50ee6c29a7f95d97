# amaranth: UnusedElaboratable=no
"""``kontur send``: streaming under the flow control, and the machine's answers in program
lines, against a stand-in machine on a fake serial port (the protocol's reference decoder,
answering as the gateware does); the handshake; a misbehaving machine (silent, garbage, bad
CRCs, STATUS only, a port that closes or fails, codes no controller sends), each ending in one
line, status 1 and an ABORT where the link still works, never a hang; signals, which stop the
machine (ABORT) before kontur ends."""

import io
import os
import re
import select
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
import tty
import unittest
from pathlib import Path

import pytest
import serial

from kontur.hdl.motion.link import ARC, HELIX, LINE, LINE3
from kontur import registry
from kontur.hdl.motion import protocol
from kontur.machine import Machine
from kontur.machining import prepare
from kontur.send import SendError, SendInterrupted, send
from kontur.cli import main

#: The iCEBreaker controller's clock (the programs here run on its controller).
CLOCK = registry.board("icebreaker").clock_hz

PROGRAM = "G21 G90\nG1 X10 F600\nG1 Y5\nG2 X15 Y0 R5\nG0 X0 Y0\nM30\n"

#: Short moves (a tenth of a second of motion each at most): the misbehaving machines' tests
#: wait for no long move.
QUICK = "G21 G90\nG1 X1 F3000\nG1 Y1\nG1 X0\nG0 X0 Y0\nM30\n"

ROOT = Path(__file__).resolve().parent.parent


class FakeMachine:
    """A serial port with a machine behind it: frames decoded by
    :class:`kontur.hdl.motion.protocol.CommandParser`, an OUTCOME for each queued frame (``outcome``
    maps frame numbers to other outcomes, ``drop`` answers that frame with an ERROR of
    ``error_code`` instead; numbers counted from ``first``), STATUS with the position the moves
    add up to (``offset`` added once a frame has moved; the board starts ``at``), ``free``
    queue slots when idle (default ``window``) and ``flags``. It checks that the host never has
    more than ``window`` queued frames unanswered. ``ABORT`` ends every frame not yet answered
    ABORTED.

    Once ``after`` answers have been given, it ``misbehave``\\ s: ``"silent"`` (no more
    answers), ``"status"`` (a STATUS at every read, never an OUTCOME), ``"garbage"`` (bytes
    that are no frame at every read), ``"crc"`` (the answers with a bad CRC), ``"eof"`` (the
    port reads nothing), ``"close"`` (reading and writing the port raise), ``"write"``
    (writing the port raises), ``"dead"`` (nothing more at all: no answers, no STATUS, an
    ABORT ends nothing). ``mute``: QUERY is never answered. ``axes=3``: a 3-axis controller's
    (LINE3 and HELIX frames, STATUS with Z; ``at`` then has Z too)."""

    def __init__(self, window, *, outcome=None, drop=None, error_code=1, offset=(0, 0),
                 silent_after=None, profile=None, free=None, flags=0, at=(0, 0), first=0,
                 misbehave=None, after=0, mute=False, state=0, alarm=0, inputs=0, axes=2):
        self.window = window
        self.axes = axes
        self.parser = protocol.CommandParser(profile=profile, axes=axes)
        self.kinds = []
        self.outcome = outcome or {}
        self.drop = drop
        self.error_code = error_code
        self.offset = offset
        if silent_after is not None:
            misbehave, after = "silent", silent_after
        self.misbehave, self.after, self.mute = misbehave, after, mute
        self.free = window if free is None else free
        self.flags = flags
        self.state, self.alarm, self.inputs = state, alarm, inputs
        self.unlocks = 0
        self.overrides = []     # (feed factor, rapid %, frames before it, spindle factor)
        self.holding = False                        # held: no frame ends
        self.controls = []                          # (hold or resume, frames before it)
        self.first = first
        self.pending = bytearray()
        self.later = []
        self.position = list(at) + [0] * (axes - len(at))
        self.count = 0                              # frames received
        self.released = 0                           # answers given
        self.unanswered = 0
        self.most = 0
        self.aborted = False
        self.aborted_frames = 0
        self.queries = 0
        self.closed = False

    @property
    def acting_up(self):
        return self.misbehave is not None and self.released >= self.after

    def status(self):
        position = list(self.position)
        if self.count:
            position = [c + o for c, o in zip(position, self.offset)] + position[len(self.offset):]
        return protocol.frame(0x81, struct.pack("<" + "i" * len(position) + "BBBBBIHB",
                                                *position,
                                                max(self.free - self.unanswered, 0), self.flags,
                                                self.state, self.alarm, self.inputs, 0, 128,
                                                100))

    def write(self, data):
        if self.closed or (self.misbehave == "write" and self.count >= self.after):
            raise serial.SerialException("write failed: the device is gone")
        for event in self.parser.feed(data):
            if event[0] == "frame":
                self.kinds.append(event[1])
                self.unanswered += 1
                self.most = max(self.most, self.unanswered)
                assert self.unanswered <= self.window, "the host overran the window"
                self.later.append((self.count, event[1], event[2]))
                self.count += 1
            elif event[0] == "unlock":
                # Grbl's rule, as the gateware's: not while the e-stop (input 0) is active.
                self.unlocks += 1
                if self.state == 4 and not self.inputs & 1:
                    self.state = self.alarm = 0
                self.pending += self.status()
            elif event[0] == "override":
                self.overrides.append((event[1], event[2], self.count, event[3]))
            elif event[0] in ("hold", "resume"):
                self.holding = event[0] == "hold"
                self.controls.append((event[0], self.count))
            elif event[0] == "query":
                self.queries += 1
                if not (self.mute or self.acting_up and self.misbehave == "dead"):
                    self.pending += self.status()
            elif event[0] == "abort":
                self.aborted = True
                if self.acting_up and self.misbehave == "dead":
                    continue
                for number, _, _ in self.later:
                    self.pending += protocol.frame(0x80, bytes([(number + self.first) % 256, 2]))
                    self.unanswered -= 1
                    self.aborted_frames += 1
                self.later.clear()

    def _release(self, bad_crc=False):
        # Answers wait in `later` until the host reads: the machine is slower than the link.
        number, kind, payload = self.later.pop(0)
        self.unanswered -= 1
        self.released += 1
        if number == self.drop:
            self.pending += protocol.frame(0x82, bytes([self.error_code]))
            return
        outcome = self.outcome.get(number, 0)
        if outcome == 0 and kind == LINE:
            x, y = struct.unpack("<ii", payload)
            self.position = [self.position[0] + x, self.position[1] + y]
        elif outcome == 0 and kind == ARC:
            x0, y0, x1, y1, _ = struct.unpack("<iiiiB", payload)
            self.position = [self.position[0] + x1 - x0, self.position[1] + y1 - y0]
        elif outcome == 0 and kind == LINE3:
            self.position = [c + d for c, d in zip(self.position, struct.unpack("<iii", payload))]
        elif outcome == 0 and kind == HELIX:
            x0, y0, x1, y1, _, z, _ = struct.unpack("<iiiiBiI", payload)
            self.position = [c + d for c, d in zip(self.position, (x1 - x0, y1 - y0, z))]
        reply = protocol.frame(0x80, bytes([(number + self.first) % 256, outcome]))
        if bad_crc:
            reply = reply[:-1] + bytes([reply[-1] ^ 0x5A])
        self.pending += reply

    @property
    def in_waiting(self):
        return len(self.pending)

    def read(self, size):
        acting = self.acting_up
        if acting and self.misbehave == "close":
            self.closed = True
        if self.closed:
            raise serial.SerialException("device reports readiness to read but returned no data")
        if acting and self.misbehave == "eof":
            time.sleep(0.001)
            return b""
        if not self.pending:
            if acting and self.misbehave == "status":
                self.pending += self.status()
            elif acting and self.misbehave == "garbage":
                self.pending += bytes(range(0x30, 0x50))       # no sync byte among them
            elif self.later and not self.holding and not (
                    acting and self.misbehave in ("silent", "status", "garbage", "dead")):
                self._release(bad_crc=acting and self.misbehave == "crc")
        data = bytes(self.pending[:size])
        del self.pending[:size]
        return data


class PtyBoard:
    """A :class:`FakeMachine` at the far end of a pseudo-terminal, in a thread: :attr:`path` is
    the port for ``kontur send``. It gives an answer at most every ``pace`` s; a ``"close"``
    machine closes the terminal once it acts up."""

    def __init__(self, machine, *, pace=0.0):
        self.machine = machine
        self.pace = pace
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        machine, ready_at = self.machine, 0.0
        while True:
            if machine.misbehave == "close" and machine.acting_up:
                os.close(self.master)
                self.master = None
                return
            readable, _, _ = select.select([self.master], [], [], 0.01)
            if self.done.is_set() and not readable:        # what the host sent, taken
                return
            if readable:
                try:
                    data = os.read(self.master, 4096)
                except OSError:
                    data = b""
                machine.write(data)
            if time.monotonic() >= ready_at and not (machine.acting_up and
                                                     machine.misbehave == "eof"):
                data = machine.read(4096)
                if data:
                    os.write(self.master, data)
                    ready_at = time.monotonic() + self.pace

    def close(self):
        self.done.set()
        self.thread.join(5)
        for fd in (self.master, self.slave):
            if fd is not None:
                os.close(fd)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def within(seconds, function, *args, **kwargs):
    """``function(*args, **kwargs)`` in a thread that must end within ``seconds``: a hang is a
    failure, not a test that never ends."""
    result = {}

    def target():
        try:
            result["value"] = function(*args, **kwargs)
        except BaseException as error:              # noqa: B902 (handed to the caller)
            result["error"] = error
    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(seconds)
    assert not thread.is_alive(), f"still running after {seconds} s"
    if "error" in result:
        raise result["error"]
    return result["value"]


def quick_job(**machine):
    return prepare(QUICK, machine=Machine(clock_hz=CLOCK, queue_frames=4, **machine),
                   name="quick.ngc")


def _capture_stderr(function):
    """``(result, what it wrote to sys.stderr)``."""
    import contextlib
    import io
    buffer = io.StringIO()
    with contextlib.redirect_stderr(buffer):
        result = function()
    return result, buffer.getvalue()


class SendTestCase(unittest.TestCase):
    def job(self, **machine):
        return prepare(PROGRAM, machine=Machine(clock_hz=CLOCK, queue_frames=4, **machine),
                       name="p.ngc")

    def test_streams_the_whole_program(self):
        job = self.job()
        port = FakeMachine(4)
        answered = []
        self.assertEqual(send(job, port, progress=answered.append), tuple(job.end))
        frames, _ = job.frames()
        self.assertEqual(port.count, len(frames))
        self.assertEqual(port.most, 4)                     # the window used, never passed
        self.assertEqual(answered[-1], len(frames))
        self.assertEqual(port.queries, 2)                  # the handshake and the end
        self.assertFalse(port.aborted)

    def test_frame_numbers_from_an_earlier_program(self):
        # A board that ran a program before counts on from that program's frames: the host
        # takes the first number it is given, and checks every one after it.
        job = self.job()
        self.assertEqual(send(job, FakeMachine(4, first=250)), tuple(job.end))
        port = FakeMachine(4, first=250)
        original = port._release

        def skip_one(bad_crc=False):                       # frame 3 numbered as frame 4
            if port.released == 3:
                port.first += 1
            original(bad_crc)
        port._release = skip_one
        with self.assertRaisesRegex(SendError, r"^the machine answered frame 254, expected 253 "):
            send(job, port)
        self.assertTrue(port.aborted)

    def test_refused_move_names_its_line(self):
        job = self.job()
        frames, lines = job.frames()
        index = lines.index(4)                             # the first frame of line 4 (the arc)
        for outcome, word in ((1, "refused"), (2, "aborted")):
            with self.subTest(outcome=outcome):
                port = FakeMachine(4, outcome={index: outcome})
                with self.assertRaisesRegex(SendError, rf"^line 4: the machine {word} this move$"):
                    send(job, port)
                self.assertTrue(port.aborted)

    def test_dropped_frame_and_silence(self):
        job = self.job()
        port = FakeMachine(4, drop=3)
        with self.assertRaisesRegex(SendError, r"dropped a frame \(CRC mismatch\) while frames "
                                               r"from line \d+ to line \d+ were in flight"):
            send(job, port)
        self.assertTrue(port.aborted)
        # Silent after one answer: the second frame (the FEED of line 2, which takes no time)
        # is not answered within the timeout.
        port = FakeMachine(4, silent_after=1)
        started = time.monotonic()
        with self.assertRaisesRegex(SendError, r"^no answer in \d+\.\d s to 4 frames, the first "
                                               r"from line 2 \(planned to take 0.00 s\): the "
                                               r"machine sent nothing$"):
            send(job, port, timeout=0.2)
        self.assertLess(time.monotonic() - started, 2.0)
        self.assertTrue(port.aborted)

    def test_wrong_end(self):
        job = self.job()
        with self.assertRaisesRegex(SendError, r"ended at \(1, 0\) steps, not at the program's "
                                               r"end \(0, 0\)"):
            send(job, FakeMachine(4, offset=(1, 0)))

    def test_three_axes(self):
        # On the ULX3S's 3-axis controller a program that moves Z streams as LINE3 and HELIX
        # frames, and the position read back (X, Y and Z) is its end; a 2-axis board's
        # STATUS (X, Y) is no 3-axis program's start: refused before anything is sent.
        board = registry.board("ulx3s")
        job = prepare((ROOT / "tests" / "programs" / "xyz" / "zaxis.ngc").read_text(),
                      machine=Machine(clock_hz=board.clock_hz, queue_frames=4), board="ulx3s")
        port = FakeMachine(4, axes=3)
        self.assertEqual(send(job, port), (0, 0, 240))
        self.assertEqual(tuple(port.position), (0, 0, 240))
        self.assertEqual({LINE3, HELIX} & set(port.kinds), {LINE3, HELIX})
        self.assertFalse({LINE, ARC} & set(port.kinds))
        with self.assertRaisesRegex(SendError, r"^the board is at \(0, 0\) steps, not at the "
                                               r"program's start \(0, 0, 0\)"):
            send(job, FakeMachine(4))

    def test_compensated_program(self):
        # A G42 contour's PROFILE frames stream under the same window; the machine behind the
        # port moves by their steps (the equidistant engine's, here given as an offset).
        from kontur.hdl.motion.link import PROFILE
        plate = ROOT / "kontur" / "programs" / "plate.ngc"
        board = registry.board("ulx3s")
        job = prepare(plate.read_text(), machine=Machine(clock_hz=board.clock_hz, queue_frames=4,
                                                         cutter_radius=3), board="ulx3s")
        moved = [sum(d[i] for s in job.segments if s.kind == "profile" for d in s.steps)
                 for i in (0, 1)]
        from kontur.hdl.motion.link import profile_bytes
        engine = registry.make_engine("profile", board.profile[0], width=board.profile[1])
        port = FakeMachine(4, profile=profile_bytes(engine.signature.frame), offset=moved,
                           axes=3)
        self.assertEqual(send(job, port), tuple(job.end))
        frames, _ = job.frames()
        self.assertEqual(port.count, len(frames))
        self.assertEqual(port.most, 4)
        self.assertEqual(port.kinds.count(PROFILE),
                         sum(1 for s in job.segments if s.kind == "profile"))
        # To a controller without the engine the PROFILE frames are unknown types.
        first = next(frame for frame in frames if frame[1] == PROFILE)
        self.assertEqual(protocol.CommandParser().feed(first), [("error", 2)])

    def test_dwell_streams_as_dwell_frames(self):
        # G4 P0.05 is one DWELL frame of 0.05 s of the board's clocks between the moves, each
        # frame answered; the plan stops before it (the move's exit rate is its rest rate).
        from kontur.hdl.motion.link import DWELL
        job = prepare("G21 G90\nG1 X10 F600\nG4 P0.05\nG1 Y5\nM30\n",
                      machine=Machine(clock_hz=CLOCK, queue_frames=4), name="d.ngc")
        frames, lines = job.frames()
        dwells = [(f, line) for f, line in zip(frames, lines) if f[1] == DWELL]
        self.assertEqual(dwells, [(protocol.dwell(round(0.05 * CLOCK)), 3)])
        port = FakeMachine(4)
        self.assertEqual(send(job, port), tuple(job.end))
        self.assertEqual(port.count, len(frames))
        self.assertEqual(port.kinds.count(DWELL), 1)

    def test_unhonoured_programs_are_refused(self):
        # The board cannot pause: M6 and M0 are refused before anything is sent (2, naming the
        # line); M5, M9, S and T ask nothing of it. The iCEBreaker has the tool outputs (issue
        # 28): M3 and M8 are TOOL frames there, refused (naming the line) only on a board
        # without them.
        from dataclasses import replace
        from kontur.send import unhonoured
        with tempfile.TemporaryDirectory() as folder:
            for text, line, word in (("T2 M6\nG1 X1 F100\n", 1, "M6 T2"),
                                     ("G1 X1 F100\nM0\nG1 X2\n", 2, "M0")):
                path = Path(folder) / "t.ngc"
                path.write_text(text)
                err = _capture_stderr(lambda: main(["send", str(path), "--port", "loop://"]))
                self.assertEqual(err[0], 2)
                self.assertRegex(err[1].splitlines()[-1],
                                 rf"^kontur: {re.escape(str(path))}: line {line}: "
                                 rf"{re.escape(word)} .*: kontur send cannot honour it "
                                 rf"\(kontur run simulates it\)$")
            path = Path(folder) / "fine.ngc"
            path.write_text("T1 S100 M5 M9\nG1 X1 F100\nG43 H1\nG49\nM61 Q2\n")
            job = prepare(path.read_text(), machine=Machine(clock_hz=CLOCK))
            self.assertIsNone(unhonoured(job))
        toolless = replace(registry.board("icebreaker"), tools=False)
        for text, line, word, outputs in (("G1 X1 F100\nS1000 M3\n", 2, "M3 S1000", "tool"),
                                          ("M8\nG1 X1 F100\n", 1, "M8", "coolant")):
            self.assertIsNone(unhonoured(prepare(text, machine=Machine(clock_hz=CLOCK))))
            refused = unhonoured(prepare(text, machine=Machine(clock_hz=CLOCK), board=toolless))
            self.assertEqual(refused[0], line)
            self.assertRegex(refused[1], rf"^{re.escape(word)} .* the board has no {outputs} "
                                         rf"outputs: kontur send cannot honour it")

    def test_command_line(self):
        # The port is opened through pyserial: a port that does not exist is a failure (1), a
        # program refused before anything moves is 2.
        with tempfile.TemporaryDirectory() as folder:
            good = Path(folder) / "p.ngc"
            good.write_text(PROGRAM)
            bad = Path(folder) / "bad.ngc"
            bad.write_text("G1 X1 F100\nG5\n")
            self.assertEqual(main(["send", str(bad), "--port", "/dev/null-none"]), 2)
            self.assertEqual(main(["send", str(good), "--port", str(Path(folder) / "none")]), 1)
            # An override out of range, or one on a board built without them: 2, one line,
            # before the port is opened.
            for extra, why in ((["--spindle", "5"], "the spindle override must be a whole "
                                                     "percentage from 10 to 200, not 5"),
                               (["--spindle", "50", "--board", "icebreaker-z"],
                                "the icebreaker-z's controller is built without the feed, "
                                "rapid and spindle overrides")):
                status, err = _capture_stderr(lambda: main(
                    ["send", str(good), "--port", "/dev/null-none", *extra]))
                self.assertEqual(status, 2)
                self.assertEqual(len(err.splitlines()), 1)
                self.assertIn(why.replace("the spindle", "The spindle"), err)


# ---- the handshake ---------------------------------------------------------------------------

#: Boards that must get no frame, and the message each gives (one line).
HANDSHAKES = {
    "mute": (dict(mute=True), r"^no answer from the board at 115200 baud in 0.3 s \(is the baud "
                              r"of the bitstream's machine file the same\?\)$"),
    "wrong baud": (dict(mute=True, misbehave="garbage"),
                   r"^no answer from the board at 115200 baud in 0.3 s; \d+ bytes came that were "
                   r"no frame \(is the baud of the bitstream's machine file the same\?\)$"),
    "other queue": (dict(free=8), r"^the board's queue holds 8 frames, the machine file says 4: "
                                  r"build the bitstream with --machine FILE"),
    "smaller queue": (dict(free=2), r"^the board's queue holds 2 frames, the machine file "
                                    r"says 4: "),
    "moving": (dict(flags=1, free=2), r"^the board is moving \(at \(0, 0\) steps, 2 queue slots "
                                      r"free\): it is running another program"),
    "moved": (dict(at=(80, -3)), r"^the board is at \(80, -3\) steps, not at the program's start "
                                 r"\(0, 0\): its coordinates count from where the board was "
                                 r"reset"),
    "no controller": (dict(flags=0x40), r"^the board sent a STATUS with flags 0x40, which no "
                                        r"controller sets"),
    "unknown state": (dict(state=7), r"^the board sent a STATUS with state 7, which no "
                                     r"controller sets"),
    "alarm": (dict(state=4, alarm=3, inputs=1),
              r"^the board is in ALARM \(tripped: estop, limit_x; inputs active now: estop\) "
              r"at \(0, 0\) steps: release the e-stop, then send with --unlock"),
}


def test_overrides_sent_after_the_handshake():
    # --feed 150 --rapid 50: one OVERRIDE (factor 150 * 128 / 100 = 192, rapid 50 %) after
    # the handshake's QUERY, before the first queued frame; none at 100 %.
    port = FakeMachine(4)
    within(10, send, quick_job(), port, timeout=0.3, feed=150, rapid=50)
    assert port.overrides == [(192, 50, 0, 128)] and port.count > 0
    port = FakeMachine(4)
    within(10, send, quick_job(), port, timeout=0.3)
    assert port.overrides == []
    # --spindle 50 alone: the feed and rapid at 100 %, the spindle factor 64.
    port = FakeMachine(4)
    within(10, send, quick_job(), port, timeout=0.3, spindle=50)
    assert port.overrides == [(128, 100, 0, 64)]
    with pytest.raises(ValueError, match="feed override must be a whole percentage"):
        send(quick_job(), FakeMachine(4), feed=250)
    with pytest.raises(ValueError, match="spindle override must be a whole percentage"):
        send(quick_job(), FakeMachine(4), spindle=5)


def test_operator_holds_resumes_and_overrides_while_streaming():
    # The operator's controls: a hold after the second frame is sent, held for 1 s (more than
    # the 0.3 s timeout and the frames' planned times: no frame is overdue while held), then
    # resume and 50 %. Each is sent at once; the program ends where it should.
    script, started = [], time.monotonic()

    def controls():
        sent = port.count
        if not script and sent >= 2:
            script.append(time.monotonic())
            return ["hold"]
        if len(script) == 1 and time.monotonic() - script[0] > 1.0:
            script.append(time.monotonic())
            return ["resume", ("feed", 50)]
        return []
    port = FakeMachine(4)
    job = quick_job()
    assert within(10, send, job, port, timeout=0.3, controls=controls) == tuple(job.end)
    assert [what for what, _ in port.controls] == ["hold", "resume"]
    assert port.controls[0][1] >= 2 and port.overrides == [(64, 100, port.controls[1][1], 128)]
    assert time.monotonic() - started > 1.0


def test_unlock_leaves_alarm_unless_the_estop_is_pressed():
    # The e-stop released, a limit still pressed: --unlock's UNLOCK leaves ALARM, the program
    # runs. The e-stop still pressed: the UNLOCK's STATUS shows ALARM, nothing is sent.
    port = FakeMachine(4, state=4, alarm=2, inputs=2)
    within(10, send, quick_job(), port, timeout=0.3, unlock=True)
    assert port.unlocks == 1 and port.count > 0
    port = FakeMachine(4, state=4, alarm=1, inputs=1)
    with pytest.raises(SendError, match=r"^the board is in ALARM \(tripped: estop;"):
        within(10, send, quick_job(), port, timeout=0.3, unlock=True)
    assert port.unlocks == 1 and port.count == 0


@pytest.mark.parametrize("case", HANDSHAKES)
def test_handshake_refuses_a_board_before_any_frame(case):
    options, message = HANDSHAKES[case]
    port = FakeMachine(4, **options)
    with pytest.raises(SendError, match=message):
        within(10, send, quick_job(), port, timeout=0.3)
    assert port.count == 0                                  # no frame reached the board
    assert port.queries == 1 and not port.aborted          # nor an ABORT


def test_the_gateware_reports_its_queue_length_when_idle():
    # What the handshake relies on, on the RTL (Amaranth's simulator, a QUERY right after
    # reset): STATUS.free is the frames the queue holds, queue_frames itself, not its block
    # RAM's bytes (a power of two); not moving, at (0, 0).
    from kontur.hdl.motion.controller import MotionController
    from kontur.sim.testbench.hostlink import run_amaranth
    clock, baud = 1e6, 125_000                              # 8 clocks a bit
    for frames in (12, 5):
        controller = MotionController(line=registry.make_engine("line", width=12),
                                      arc=registry.make_engine("arc", "fast", width=12),
                                      clock_hz=clock, baud=baud, dir_setup=1, step_width=2,
                                      queue_frames=frames)
        run = run_amaranth(controller, [protocol.query()], divisor=8, window=frames,
                           max_clocks=5000)
        assert [reply.fields[:7] for _, reply in run.replies] == [(0, 0, frames, 0, 0, 0, 0)]


# ---- a misbehaving machine -------------------------------------------------------------------

#: After two answers (the CONFIG's and the first FEED's) the machine misbehaves so; the
#: message (one line) and whether the ABORT can reach it.
MISBEHAVIOURS = {
    "silent": (dict(misbehave="silent", after=2),
               r"^no answer in \d+\.\d s to 4 frames, the first from line 2 \(planned to take "
               r"0.\d\d s\): the machine sent nothing$", True),
    "status only": (dict(misbehave="status", after=2),
                    r"^no answer in \d+\.\d s to 4 frames, the first from line 2 .*: the machine "
                    r"sent only \d+ STATUS replies$", True),
    "garbage": (dict(misbehave="garbage", after=2),
                r"^no answer in \d+\.\d s to 4 frames, the first from line 2 .*: the machine sent "
                r"only \d+ bytes that were no frame \(bad CRCs or noise: is the bitstream's "
                r"baud 115200\?\)$", True),
    "bad crc": (dict(misbehave="crc", after=2),
                r"^no answer in \d+\.\d s to 4 frames, the first from line 2 .*: the machine sent "
                r"only \d+ bytes that were no frame", True),
    "reads nothing": (dict(misbehave="eof", after=2),
                      r"^no answer in \d+\.\d s to 4 frames, the first from line 2 .*: the machine "
                      r"sent nothing$", True),
    "closed": (dict(misbehave="close", after=2),
               r"^reading from the port failed \(device reports readiness to read but returned "
               r"no data\) with 4 frames unanswered \(the first from line 2\); the ABORT could "
               r"not be sent \(writing to the port failed \(write failed: the device is gone\)\)"
               r": the machine may still be moving$", False),
    "write fails": (dict(misbehave="write", after=3),
                    r"^writing to the port failed \(write failed: the device is gone\) with 3 "
                    r"frames unanswered \(the first from the program's set-up \(no program "
                    r"line\)\); the ABORT could not be sent", False),
    "unknown outcome": (dict(outcome={3: 7}),
                        r"^the machine answered frame 3 \(line 3\) with outcome code 7, which no "
                        r"controller sends$", True),
    "unknown error": (dict(drop=3, error_code=99),
                      r"^the machine dropped a frame \(error code 99, which no controller "
                      r"sends\) while frames from line 3 to line \d were in flight", True),
    "absurd status": (dict(misbehave="status", after=2, flags=0x81),
                      r"^the board sent a STATUS with flags 0x81, which no controller sets", True),
}


@pytest.mark.parametrize("case", MISBEHAVIOURS)
def test_misbehaving_machine(case):
    options, message, reachable = MISBEHAVIOURS[case]
    if case == "absurd status":                            # a sane STATUS at the handshake
        port = FakeMachine(4, **options)
        port.flags = 0
        original = port.status

        def status():
            port.flags = 0x81 if port.count else 0
            return original()
        port.status = status
    else:
        port = FakeMachine(4, **options)
    job = quick_job()
    started = time.monotonic()
    with pytest.raises(SendError, match=message) as raised:
        within(10, send, job, port, timeout=0.3)
    assert "\n" not in str(raised.value)
    assert port.aborted == reachable                       # ABORT sent where the link works
    assert time.monotonic() - started < 2                  # the timeout, the planned time
    if reachable:
        assert port.unanswered == 0                        # every frame ended (aborted)


def test_interrupted_send_stops_the_machine():
    # A signal (here given as the stop callable's answer once three frames are answered): ABORT, the
    # frames in flight end ABORTED, the position is read back and named. The board moved by
    # the frames it finished: CONFIG, FEED and line 2's G1 X1 (80 steps at 80 steps/mm).
    job = quick_job()
    port = FakeMachine(4)
    caught = []

    def stop():
        return signal.SIGINT if len(caught) >= 3 else None
    stop.count = 1
    with pytest.raises(SendInterrupted) as raised:
        within(10, send, job, port, timeout=0.3, stop=stop, progress=caught.append)
    assert port.aborted and port.released == 3
    assert port.aborted_frames == port.count - port.released >= 1     # all in flight
    assert raised.value.signum == signal.SIGINT
    assert port.position == [80, 0]
    assert str(raised.value) == (f"interrupted (SIGINT): ABORT sent, {port.aborted_frames} "
                                 f"frames aborted; the machine stopped at (80, 0) steps = "
                                 f"(1.0000, 0.0000) mm (the program had reached line 3)")


def test_interrupted_send_to_a_board_gone_wrong():
    # The board dead (it takes the ABORT and answers nothing): kontur waits for the outcomes
    # and the position no longer than the timeout (3 s at most), and says what it does not
    # know. The port gone: the ABORT cannot be sent, and kontur says the machine may move on.
    job = quick_job()
    port = FakeMachine(4, misbehave="dead", after=2)
    answered = []
    started = time.monotonic()
    with pytest.raises(SendInterrupted) as raised:
        within(10, send, job, port, timeout=0.3, progress=answered.append,
               stop=lambda: signal.SIGHUP if len(answered) == 2 else None)
    assert port.aborted and 0.6 <= time.monotonic() - started < 3
    assert str(raised.value) == (f"interrupted (SIGHUP): ABORT sent, 0 frames aborted, "
                                 f"{port.count - port.released} unanswered after 0.3 s; no "
                                 f"STATUS: where the machine stopped is unknown (the program "
                                 f"had reached line 2)")
    port = FakeMachine(4)

    def stop():
        if port.released >= 2:
            port.closed = True
            return signal.SIGINT
    with pytest.raises(SendInterrupted, match=r"^interrupted \(SIGINT\); the ABORT could not be "
                                              r"sent \(writing to the port failed \(write failed: "
                                              r"the device is gone\)\): the machine may still be "
                                              r"moving$"):
        within(10, send, job, port, timeout=0.3, stop=stop)
    assert not port.aborted


def test_interrupted_before_the_first_frame():
    port = FakeMachine(4)
    with pytest.raises(SendInterrupted, match=r"^interrupted \(SIGTERM\): ABORT sent, 0 frames "
                                              r"aborted; the machine stopped at \(0, 0\) steps = "
                                              r"\(0.0000, 0.0000\) mm \(before the program's "
                                              r"first frame\)$"):
        within(10, send, quick_job(), port, timeout=0.3, stop=lambda: signal.SIGTERM)
    assert port.count == 0 and port.aborted


def test_stop_catches_the_signals_and_gives_them_back():
    from kontur.send import Stop
    before = {number: signal.getsignal(number) for number in Stop.SIGNALS}
    signal.signal(signal.SIGINT, signal.default_int_handler)   # as from a terminal (a test
    signal.signal(signal.SIGTERM, signal.SIG_DFL)              # worker may ignore SIGINT)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)               # as under nohup
    try:
        with Stop() as stop:
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
            assert stop() is None
            signal.raise_signal(signal.SIGTERM)                 # recorded, not the end
            signal.raise_signal(signal.SIGINT)
            assert stop() == signal.SIGTERM and stop.count == 2
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        for number, handler in before.items():
            signal.signal(number, handler)


# ---- the command line --------------------------------------------------------------------


def _send_command(tmp_path, board, *extra, program=QUICK, timeout="0.3"):
    path = tmp_path / "quick.ngc"
    path.write_text(program)
    return ["send", str(path), "--port", board.path, "--timeout", timeout, *extra]


def _machine_file(tmp_path, **keys):
    path = tmp_path / "machine.toml"
    path.write_text("".join(f"{key} = {value}\n" for key, value in keys.items()))
    return str(path)


@pytest.mark.parametrize("case", ["silent", "status only", "garbage", "bad crc", "closed",
                                  "unknown outcome"])
def test_command_line_against_a_misbehaving_board(case, tmp_path, capsys):
    options, message, reachable = MISBEHAVIOURS[case]
    machine = FakeMachine(32, **options)
    with PtyBoard(machine) as board:
        status = within(15, main, _send_command(tmp_path, board))
    captured = capsys.readouterr()
    assert status == 1 and captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("kontur: SendError: "), captured.err
    body = lines[0].removeprefix("kontur: SendError: ")
    if case == "closed":          # pyserial's words for a closed pty; a read or a write first
        # The ABORT's write may fail too (said), or reach the kernel's buffer first (silent, as
        # every ABORT that is sent).
        assert re.match(r"^(reading from|writing to) the port failed \(.*\) with \d+ frames "
                        r"unanswered [^;]*(; the ABORT could not be sent \(writing to the port "
                        r"failed \(.*\)\): the machine may still be moving)?$", body), body
    else:
        assert re.match(message.replace("4 frames", r"\d+ frames"), body), body
    assert machine.aborted == reachable


def test_command_line_handshake(tmp_path, capsys):
    # The board's queue is the default machine's (32 frames); a machine file of 16 is refused
    # before any frame, as is a board that does not answer; the right file streams.
    with PtyBoard(FakeMachine(32)) as board:
        command = _send_command(tmp_path, board, "--machine",
                                _machine_file(tmp_path, queue_frames=16))
        assert within(15, main, command) == 1
        assert board.machine.count == 0
    err = capsys.readouterr().err
    assert err == ("kontur: SendError: the board's queue holds 32 frames, the machine file says "
                   "16: build the bitstream with --machine FILE (kontur build --machine FILE, "
                   "make bitstream MACHINE=FILE)\n")
    with PtyBoard(FakeMachine(32, mute=True)) as board:
        assert within(15, main, _send_command(tmp_path, board)) == 1
    assert capsys.readouterr().err == (
        "kontur: SendError: no answer from the board at 115200 baud in 0.3 s (is the baud of "
        "the bitstream's machine file the same?)\n")
    with PtyBoard(FakeMachine(16)) as board:
        command = _send_command(tmp_path, board, "--machine",
                                _machine_file(tmp_path, queue_frames=16))
        assert within(15, main, command) == 0
    out = capsys.readouterr().out                  # 4 moves: CONFIG, a FEED and a move each, STOP
    assert out.startswith(f"sent {1 + 2 * 4 + 1} frames of quick.ngc; the machine ended at "
                          f"(0, 0) steps")


def test_command_line_timeout_refused(tmp_path, capsys):
    for value in ("0", "-1", "nan", "inf"):
        assert main(["send", "x.ngc", "--port", "/dev/null-none", "--timeout", value]) == 2
        assert capsys.readouterr().err.splitlines()[-1] == (
            f"kontur: --timeout must be a positive number of seconds, not {float(value):g}")


#: Line after line of short moves: a slow board is still running them when the signal comes.
LONG = "G21 G90 F3000\n" + "".join(f"G1 X{i % 2} Y{i / 10:.1f}\n" for i in range(1, 30)) \
       + "G0 X0 Y0\nM30\n"


def _default_signals():
    # As from a terminal: the signals at their defaults, whatever the test worker inherited
    # (nohup's SIGHUP ignored stays ignored, and a worker may run with SIGINT ignored).
    for number in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(number, signal.SIG_DFL)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_signal_stops_the_machine(signum, tmp_path):
    # kontur send as a process against a board that answers a frame every 0.1 s: the signal
    # comes after four answers; the board gets the ABORT, every frame in flight ends ABORTED,
    # and kontur says so (with the position the board reports) and ends with 128 + signal.
    machine = FakeMachine(32)
    with PtyBoard(machine, pace=0.1) as board:
        command = [sys.executable, "-m", "kontur.cli"] + _send_command(
            tmp_path, board, program=LONG, timeout="5")
        run = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, cwd=ROOT, preexec_fn=_default_signals)
        try:
            deadline = time.monotonic() + 30
            while machine.released < 4:
                assert run.poll() is None and time.monotonic() < deadline, run.stderr.read()
                time.sleep(0.02)
            run.send_signal(signum)
            stdout, stderr = run.communicate(timeout=20)
        finally:
            if run.poll() is None:
                run.kill()
    assert run.returncode == 128 + signum, stderr
    assert machine.aborted and machine.aborted_frames >= 1
    x, y = machine.position
    name = signal.Signals(signum).name
    assert stdout == ""
    assert re.fullmatch(rf"kontur: interrupted \({name}\): ABORT sent, "
                        rf"{machine.aborted_frames} frames aborted(, 1 done before it)?; the "
                        rf"machine stopped at "
                        rf"\({x}, {y}\) steps = \({x / 80:.4f}, {y / 80:.4f}\) mm \(the "
                        rf"program had reached line \d+\)\n", stderr), stderr


if __name__ == "__main__":
    unittest.main()


def test_send_keys_on_a_terminal(monkeypatch):
    # kontur send's keys (Grbl's): on a terminal, ! hold, + 10 % more, ~ resume, - 10 % less,
    # anything else nothing; the terminal's mode restored after.
    import termios

    from kontur.cli import _keys
    master, slave = os.openpty()
    with os.fdopen(slave, "r") as stdin:
        monkeypatch.setattr(sys, "stdin", stdin)
        before = termios.tcgetattr(stdin)
        with _keys(100) as poll:
            os.write(master, b"!+~-x")
            time.sleep(0.1)
            assert poll() == ["hold", ("feed", 110), "resume", ("feed", 100)]
            assert poll() == []
        assert termios.tcgetattr(stdin) == before
    os.close(master)


class EagerMachine(FakeMachine):
    """A board that makes every queued frame at once: a read answers them all."""

    def read(self, size):
        while self.later:
            self._release()
        data = bytes(self.pending[:size])
        del self.pending[:size]
        return data


def test_a_queue_run_dry_at_speed_is_said():
    # Thirty moves of 1 mm along X at F600: every junction straight, so a move in the middle
    # goes on into the next at its feed, 600 mm/min. The board answers every frame the host
    # has sent before the host sends the next (its queue of 4 runs dry): the move behind the
    # last frame sent is named with that speed wherever it was planned to go on at speed,
    # and the moves planned to stop (the last) are not.
    text = "G21 G90 F600\n" + "".join(f"G1 X{k}\n" for k in range(1, 31)) + "M2\n"
    job = prepare(text, machine=Machine(clock_hz=CLOCK, queue_frames=4), name="row.ngc")
    out = io.StringIO()
    assert send(job, EagerMachine(4), out=out) == tuple(job.end)
    said = out.getvalue().splitlines()
    assert said and all(line.endswith(": the board's queue ran dry at the end of this move: "
                                      "the machine stopped there at once from 600 mm/min and "
                                      "goes on at that speed (this computer or the link fell "
                                      "behind the motion)") for line in said)
    lines = [int(re.match(r"^kontur send: line (\d+): ", line).group(1)) for line in said]
    assert lines == sorted(set(lines)) and 31 not in lines and set(lines) <= set(range(2, 31))
    assert len(lines) > 10
    # A board that keeps up (the window full all along): nothing said.
    out = io.StringIO()
    assert send(job, FakeMachine(4), out=out) == tuple(job.end)
    assert out.getvalue() == ""
