# amaranth: UnusedElaboratable=no
"""``kontur send``: streaming under the flow control, and the machine's answers in program
lines, against a stand-in machine on a fake serial port (the protocol's reference decoder,
answering as the gateware does)."""

import struct
import unittest

from hdl.motion.link import ARC, LINE
from sim import registry
from sim.host import protocol
from sim.host.machine import Machine
from sim.host.machining import prepare
from sim.host.send import SendError, send
from sim.host.cli import main

#: The iCEBreaker controller's clock (the programs here run on its controller).
CLOCK = registry.board("icebreaker").clock_hz

PROGRAM = "G21 G90\nG1 X10 F600\nG1 Y5\nG2 X15 Y0 R5\nG0 X0 Y0\nM30\n"


class FakeMachine:
    """A serial port with a machine behind it: frames decoded by
    :class:`sim.host.protocol.CommandParser`, an OUTCOME for each queued frame (``outcome``
    maps frame numbers to other outcomes, ``drop`` answers that frame with an ERROR instead),
    STATUS with the position the moves add up to (``offset`` added). It checks that the host
    never has more than ``window`` queued frames unanswered."""

    def __init__(self, window, *, outcome=None, drop=None, offset=(0, 0), silent_after=None,
                 profile=None):
        self.window = window
        self.parser = protocol.CommandParser(profile=profile)
        self.kinds = []
        self.outcome = outcome or {}
        self.drop = drop
        self.offset = offset
        self.silent_after = silent_after
        self.pending = bytearray()
        self.later = []
        self.position = [0, 0]
        self.count = 0
        self.unanswered = 0
        self.most = 0
        self.aborted = False

    def write(self, data):
        for event in self.parser.feed(data):
            if event[0] == "frame":
                self.kinds.append(event[1])
                self.unanswered += 1
                self.most = max(self.most, self.unanswered)
                assert self.unanswered <= self.window, "the host overran the window"
                self._answer(event[1], event[2])
            elif event[0] == "query":
                x, y = (p + o for p, o in zip(self.position, self.offset))
                self.pending += protocol.frame(0x81, struct.pack("<iiBB", x, y, self.window, 0))
            elif event[0] == "abort":
                self.aborted = True

    def _answer(self, kind, payload):
        # Answers wait in `later` until the host reads: the machine is slower than the link.
        number = self.count
        self.count += 1
        if self.silent_after is not None and number >= self.silent_after:
            return
        if number == self.drop:
            self.later.append(protocol.frame(0x82, bytes([1])))
            return
        outcome = self.outcome.get(number, 0)
        if outcome == 0 and kind == LINE:
            x, y = struct.unpack("<ii", payload)
            self.position = [self.position[0] + x, self.position[1] + y]
        elif outcome == 0 and kind == ARC:
            x0, y0, x1, y1, _ = struct.unpack("<iiiiB", payload)
            self.position = [self.position[0] + x1 - x0, self.position[1] + y1 - y0]
        self.later.append(protocol.frame(0x80, bytes([number % 256, outcome])))

    @property
    def in_waiting(self):
        return len(self.pending)

    def read(self, size):
        if not self.pending and self.later:
            self.pending += self.later.pop(0)
            self.unanswered -= 1
        data = bytes(self.pending[:size])
        del self.pending[:size]
        return data


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
        self.assertFalse(port.aborted)

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
        port = FakeMachine(4, silent_after=2)
        with self.assertRaisesRegex(SendError, r"silent for 0.2 s with \d+ frames unanswered "
                                               r"\(the first from line"):
            send(job, port, timeout=0.2)

    def test_wrong_end(self):
        job = self.job()
        with self.assertRaisesRegex(SendError, r"ended at \(1, 0\) steps, not at the program's "
                                               r"end \(0, 0\)"):
            send(job, FakeMachine(4, offset=(1, 0)))

    def test_compensated_program(self):
        # A G42 contour's PROFILE frames stream under the same window; the machine behind the
        # port moves by their steps (the equidistant engine's, here given as an offset).
        from hdl.motion.link import PROFILE
        from pathlib import Path
        plate = Path(__file__).resolve().parent.parent / "sim" / "host" / "programs" / "plate.ngc"
        board = registry.board("ulx3s")
        job = prepare(plate.read_text(), machine=Machine(clock_hz=board.clock_hz, queue_frames=4,
                                                         cutter_radius=3), board="ulx3s")
        moved = [sum(d[i] for s in job.segments if s.kind == "profile" for d in s.steps)
                 for i in (0, 1)]
        from hdl.motion.link import profile_bytes
        engine = registry.make_engine("profile", board.profile[0], width=board.profile[1])
        port = FakeMachine(4, profile=profile_bytes(engine.signature.frame), offset=moved)
        self.assertEqual(send(job, port), tuple(job.end))
        frames, _ = job.frames()
        self.assertEqual(port.count, len(frames))
        self.assertEqual(port.most, 4)
        self.assertEqual(port.kinds.count(PROFILE),
                         sum(1 for s in job.segments if s.kind == "profile"))
        # To a controller without the engine the PROFILE frames are unknown types.
        first = next(frame for frame in frames if frame[1] == PROFILE)
        self.assertEqual(protocol.CommandParser().feed(first), [("error", 2)])

    def test_command_line(self):
        # The port is opened through pyserial: a port that does not exist is a failure (1), a
        # program refused before anything moves is 2.
        import tempfile
        from pathlib import Path
        with tempfile.TemporaryDirectory() as folder:
            good = Path(folder) / "p.ngc"
            good.write_text(PROGRAM)
            bad = Path(folder) / "bad.ngc"
            bad.write_text("G1 X1 F100\nG5\n")
            self.assertEqual(main(["send", str(bad), "--port", "/dev/null-none"]), 2)
            self.assertEqual(main(["send", str(good), "--port", str(Path(folder) / "none")]), 1)


if __name__ == "__main__":
    unittest.main()
