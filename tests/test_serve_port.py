# amaranth: UnusedElaboratable=no
"""``kontur serve --port DEVICE``: Grbl 1.1 to a sender, the moves made by a board over
``kontur send``'s protocol, here the fake board of ``tests/test_send.py`` (the protocol's
reference decoder behind a pseudo-terminal). The frames it gets for a streamed program are
the ones ``kontur send`` sends for the same program; the status reports are the board's."""

import select
import sys
import time

import pytest

from kontur.hdl.motion import protocol
from kontur.machining import prepare
from kontur.send import send
from kontur.sim import processes

from .test_send import EagerMachine, FakeMachine, PtyBoard, within
from .test_serve import BRACKET, LONG, SHORT, SPEED, WELCOME, Port, program_end, read_steps, run_steps, \
    stream, wait_for_outputs

#: The default machine's queue (frames).
WINDOW = 32


class Recording(FakeMachine):
    """A :class:`FakeMachine` that keeps every frame it is sent: ``(type, payload)``."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.received = []
        self.recorder = protocol.CommandParser(axes=self.axes)

    def write(self, data):
        for event in self.recorder.feed(data):
            if event[0] == "frame":
                self.received.append(tuple(event[1:]))
        super().write(data)


def _serve(tmp_path, board, *options):
    link, out = tmp_path / "grbl", tmp_path / "out"
    args = [sys.executable, "-m", "kontur.cli", "serve", "--link", str(link), "--out",
            str(out), "--speed", str(SPEED), "--port", board.path, "--timeout", "5", *options]
    return processes.child(args, stdout=processes.subprocess.PIPE, cwd=tmp_path), link, out


def _connect(process, link):
    ready, _, _ = select.select([process.stdout], [], [], 30)
    assert ready, "kontur serve printed no pseudo-terminal"
    assert process.stdout.readline().decode().startswith("/dev/pts/")
    port = Port(link)
    assert WELCOME.match(port.line())
    return port


def _stops(frames):
    return sum(1 for kind, _ in frames if kind == protocol.STOP)


def _moves(frames):
    return [(kind, payload) for kind, payload in frames if kind in (protocol.LINE, protocol.ARC)]


@pytest.mark.parametrize("text", [SHORT, BRACKET.read_text()], ids=["short", "bracket"])
def test_streamed_program_runs_on_the_board(tmp_path, text):
    """The plain character-counting client streams a program: every line ok, Idle at the
    program's end (the board's STATUS), the board got kontur send's frames for the program
    and moved to its end; the steps written are kontur run's. The bracket (17 segments) is
    sent in batches while it streams (more segments than the look-ahead holds back)."""
    job = prepare(text, board="icebreaker")
    reference = Recording(WINDOW)
    within(10, send, job, reference, timeout=1)
    board = PtyBoard(Recording(WINDOW))
    child, link, out = _serve(tmp_path, board)
    with board, child as process:
        port = _connect(process, link)
        answers, _ = stream(port, text)
        assert answers == ["ok"] * len(text.splitlines())
        assert port.wait_idle(30) == (*program_end(text), 0.0)
        port.close()
        received = board.machine.received
        if _stops(received) == _stops(reference.received):
            assert received == reference.received
        else:
            # The client stalled longer than kontur serve's SETTLE (0.25 s, seen on a loaded
            # machine): the run ended at the last line taken, as Grbl's starved planner ends
            # it, and went on with the next; the moves are kontur send's all the same.
            assert _moves(received) == _moves(reference.received)
        assert tuple(board.machine.position) == tuple(job.end)
        expected = run_steps(text)
        wait_for_outputs(out, len(expected), timeout=30)
        assert read_steps(out) == expected
        process.stdout.close()


def test_soft_reset_aborts_the_board(tmp_path):
    """ctrl-X while the board moves (an answer every 0.3 s): the board gets ABORT, ALARM:3 and
    the welcome come back, the position reported is where the board stopped."""
    board = PtyBoard(Recording(WINDOW), pace=0.3)
    child, link, _ = _serve(tmp_path, board)
    with board, child as process:
        port = _connect(process, link)
        assert port.command(LONG.strip()) == ["ok"]
        time.sleep(0.4)
        port.serial.write(b"\x18")
        assert port.line() == "ALARM:3"
        assert WELCOME.match(port.line())
        assert port.line() == "[MSG:'$H'|'$X' to unlock]"
        state, stopped, _ = port.status()
        assert state == "Alarm" and board.machine.aborted
        x, y = board.machine.position
        assert stopped == (x / 80, y / 80, 0.0)
        assert (x, y) != (8000, 4000)                  # LONG's end (100, 50 mm): not reached
        assert port.command("$X") == ["[MSG:Caution: Unlocked]", "ok"]
        assert port.status()[0] == "Idle"
        port.close()
        process.stdout.close()


def test_board_inputs_in_the_status(tmp_path):
    """The board's inputs active now (its STATUS's inputs byte) are the status report's Pn:
    field, in Grbl's letters and order: none, none shown; the probe and Y's limit, Pn:YP;
    the feed-hold and cycle-start buttons, Pn:HS."""
    board = PtyBoard(Recording(WINDOW))
    child, link, _ = _serve(tmp_path, board)
    with board, child as process:
        port = _connect(process, link)
        assert port.command("G1 X1 F600") == ["ok"]
        assert port.wait_idle(30)[:2] == (1.0, 0.0)
        assert "|Pn:" not in port.reports[-1]
        for inputs, letters in ((1 << 2 | 1 << 3, "YP"), (1 << 5 | 1 << 4, "HS")):
            board.machine.inputs = inputs
            _until(lambda: (port.status(), f"|Pn:{letters}|" in port.reports[-1])[1])
        port.close()
        process.stdout.close()


def test_board_alarm_and_unlock(tmp_path):
    """A limit trips on the board while it moves (its STATUS in ALARM, limit_x): Grbl's
    ALARM:1 (hard limit), the board ABORTed, Alarm in the status reports; $X sends the board
    UNLOCK, which leaves its ALARM (the e-stop is not pressed): Idle again."""
    board = PtyBoard(Recording(WINDOW), pace=0.3)
    child, link, _ = _serve(tmp_path, board)
    with board, child as process:
        port = _connect(process, link)
        assert port.command(LONG.strip()) == ["ok"]
        board.machine.state, board.machine.alarm, board.machine.inputs = 4, 2, 2
        assert port.line() == "ALARM:1"
        assert port.status()[0] == "Alarm" and board.machine.aborted
        assert port.command("G1 X0 Y0 F1000") == ["error:9"]
        assert port.command("$X") == ["[MSG:Caution: Unlocked]", "ok"]
        deadline = time.monotonic() + 10
        while port.status()[0] != "Idle" or not board.machine.unlocks:
            assert time.monotonic() < deadline, "the board never left ALARM"
        assert board.machine.unlocks == 1
        port.close()
        process.stdout.close()


def _override_fields(feed, rapid, spindle=100):
    """What the board decodes from an OVERRIDE of ``feed``, ``rapid`` and ``spindle``
    percent: the feed factor, the rapid percent and the spindle factor."""
    (event,) = protocol.CommandParser().feed(protocol.override(feed, rapid, spindle))
    return event[1:]


def _until(condition, seconds=10):
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline
        time.sleep(0.02)


def test_hold_resume_and_overrides_reach_the_board(tmp_path):
    """On the ULX3S (a controller with overrides): ``!`` is the board's HOLD (Hold in the
    status, the board ends no frame while held), ``~`` its RESUME, and the feed, rapid and
    spindle override bytes OVERRIDE frames with all three overrides as they stand (Grbl's
    steps: feed +10 %, rapid 50 %, spindle +10 % and -1 %; the status's Ov: says so); the
    program still ends at its end."""
    board = PtyBoard(Recording(WINDOW, axes=3), pace=0.05)     # the ULX3S's: 3 axes
    child, link, _ = _serve(tmp_path, board, "--board", "ulx3s")
    with board, child as process:
        port = _connect(process, link)
        assert port.command("G1 X20 Y10 F600") == ["ok"]
        port.serial.write(b"!")                 # before the board has ended a frame
        _until(lambda: board.machine.holding)
        assert port.status()[0].startswith("Hold")
        time.sleep(0.5)                         # the move's frames sent meanwhile
        assert board.machine.count > 0 and board.machine.released == 0
        port.serial.write(b"~")
        _until(lambda: not board.machine.holding)
        assert [c for c, _ in board.machine.controls] == ["hold", "resume"]
        # feed +10 %, rapid 50 %, spindle +10 % and -1 % (Grbl's 0x9A, 0x9D)
        port.serial.write(bytes([0x91, 0x96, 0x9A, 0x9D]))
        _until(lambda: len(board.machine.overrides) == 4)
        assert [(o[0], o[1], o[3]) for o in board.machine.overrides] == \
            [_override_fields(110, 100), _override_fields(110, 50),
             _override_fields(110, 50, 110), _override_fields(110, 50, 109)]
        port.status()
        assert "|Ov:110,50,109" in port.reports[-1]
        assert port.wait_idle(60)[:2] == (20.0, 10.0)
        assert tuple(board.machine.position) == (20 * 80, 10 * 80, 0)
        port.close()
        process.stdout.close()


def test_overrides_on_a_board_without_them(tmp_path):
    """The three-axis iCEBreaker's controller has no overrides: a feed or spindle override
    byte is a message, no OVERRIDE reaches the board."""
    board = PtyBoard(Recording(WINDOW, axes=3))
    child, link, _ = _serve(tmp_path, board, "--board", "icebreaker-z")
    with board, child as process:
        port = _connect(process, link)
        for byte in (0x91, 0x9A):               # feed +10 %, spindle +10 %
            port.serial.write(bytes([byte]))
            assert port.line() == "[MSG:the icebreaker-z's controller is built without the " \
                                  "feed, rapid and spindle overrides]"
        assert board.machine.overrides == []
        port.close()
        process.stdout.close()


def test_a_board_that_does_not_answer_ends_the_server(tmp_path):
    """kontur send's handshake first: a board that never answers QUERY is one line and status
    1, before any pseudo-terminal is offered."""
    board = PtyBoard(Recording(WINDOW, mute=True))
    args = [sys.executable, "-m", "kontur.cli", "serve", "--port", board.path,
            "--timeout", "0.3"]
    with board:
        run = processes.run(args, timeout=30, stdout=processes.subprocess.PIPE,
                            stderr=processes.subprocess.PIPE, cwd=tmp_path)
    assert run.returncode == 1 and run.stdout == b""
    assert run.stderr.decode() == ("kontur: SendError: no answer from the board at 115200 "
                                   "baud in 0.3 s (is the baud of the bitstream's machine "
                                   "file the same?)\n")
    assert board.machine.count == 0


def test_server_end_stops_the_board(tmp_path):
    """The server ended (SIGTERM) while the board has frames: it gets ABORT first."""
    board = PtyBoard(Recording(WINDOW), pace=0.5)
    child, link, _ = _serve(tmp_path, board)
    with board:
        with child as process:
            port = _connect(process, link)
            assert port.command(LONG.strip()) == ["ok"]
            time.sleep(0.4)
            assert not board.machine.aborted
            port.close()
            process.stdout.close()
        assert board.machine.aborted


def test_a_refused_frame_is_an_alarm(tmp_path):
    """The board refuses the first move (its OUTCOME REFUSED): kontur send's message, in the
    program's lines as the session numbers them, then ALARM:3 and the alarm lock."""
    board = PtyBoard(Recording(WINDOW, outcome={2: 1}))      # CONFIG, FEED, then the move
    child, link, _ = _serve(tmp_path, board)
    with board, child as process:
        port = _connect(process, link)
        assert port.command("G0 X5 Y2") == ["ok"]
        assert port.line() == "[MSG:the board: line 1: the machine refused this move]"
        assert port.line() == "ALARM:3"
        assert port.status()[0] == "Alarm"
        deadline = time.monotonic() + 10              # the board's thread takes the ABORT
        while not board.machine.aborted:
            assert time.monotonic() < deadline, "no ABORT reached the board"
            time.sleep(0.01)
        assert port.command("G1 X0 Y0 F1000") == ["error:9"]
        port.close()
        process.stdout.close()


#: Short moves, all of them together shorter than the distance to stop from the fastest feed:
#: the planner fills before the look-ahead covers it.
TINY = "G21 G90 F600\n" + "".join(f"G1 X{i / 10:.1f} Y{i % 2 / 10:.1f}\n"
                                  for i in range(1, 61)) + "M30\n"


def test_a_full_planner_of_short_moves(tmp_path):
    """60 moves of 0.14 mm: the segments are sent as the planner fills (no deadlock between a
    full planner and a look-ahead not yet covered); Idle at the end, the board there."""
    job = prepare(TINY, board="icebreaker")
    assert sum(len(s.steps) for s in job.segments) / 80 < 10            # below the reach
    board = PtyBoard(Recording(WINDOW))
    child, link, _ = _serve(tmp_path, board)
    with board, child as process:
        port = _connect(process, link)
        answers, _ = stream(port, TINY)
        assert answers == ["ok"] * len(TINY.splitlines())
        assert port.wait_idle(30) == (*program_end(TINY), 0.0)
        assert tuple(board.machine.position) == tuple(job.end)
        port.close()
        process.stdout.close()


def test_z_and_tools_reach_a_3_axis_board(tmp_path):
    """``--board ulx3s`` on a 3-axis board with tool outputs (the fake board on three axes,
    taking TOOL frames): MILL (a plunge, a helix, M3 S500, M8, M5 M9) streamed; the board gets
    ``kontur send``'s frames for the program (LINE3, HELIX, the TOOL frames between the
    moves), ends at the program's end with its Z, and the status reports are its."""
    from kontur.hdl.motion.tools import TOOL
    from kontur.machine import Machine
    from kontur.registry import board as item

    from .test_serve import MILL

    def machine():
        fake = Recording(WINDOW, axes=3, at=(0, 0, 0))
        fake.parser.lengths[TOOL] = fake.recorder.lengths[TOOL] = 4
        return fake

    job = prepare(MILL, machine=Machine(clock_hz=item("ulx3s").clock_hz), board="ulx3s")
    reference = machine()
    within(10, send, job, reference, timeout=1)
    assert [kind for kind, *_ in reference.received].count(TOOL) == 3
    board = PtyBoard(machine())
    child, link, out = _serve(tmp_path, board, "--board", "ulx3s")
    with board, child as process:
        port = _connect(process, link)
        answers, _ = stream(port, MILL)
        assert answers == ["ok"] * len(MILL.splitlines())
        assert port.wait_idle(30) == program_end(MILL, "XYZ")
        port.close()
        assert board.machine.received == reference.received
        assert tuple(board.machine.position) == tuple(job.end)
        process.stdout.close()


def test_a_slow_sender_never_runs_the_board_dry_at_speed():
    """A sender slower than the machine (a 2 mm line every 60 ms at F3000, which the machine
    makes in 40 ms): the board is never left without frames while its last move was planned
    to go on at speed. Before, kontur serve held the segments within stopping distance of the
    last line back until a line made them final or none came for SETTLE (0.25 s): lines kept
    coming, so the board ran dry at 50 mm/s every line, where the machine stops at once and
    goes on at that speed. Now the run ends (the rest planned to stop at the last, then STOP)
    once the board has less than LOW s of motion left. The board never ends a frame here, so
    its motion is the frames' planned time from the first sent, back to back."""
    import math
    from kontur import registry
    from kontur.grbl.board import PortMotion
    from kontur.grbl.session import Session
    from kontur.machine import Machine
    import io
    now = [0.0]
    board = Recording(WINDOW)
    machine = Machine(clock_hz=registry.board("icebreaker").clock_hz)
    said = io.StringIO()
    motion = PortMotion(machine, "icebreaker", board, clock=lambda: now[0], out=said)
    board.holding = True
    grbl = Session(machine, "icebreaker", lambda line: None, clock=lambda: now[0],
                   motion=motion)
    # The exit of a move planned to stop: the speed one step stops (planner.plan, 3).
    rest = machine.rate(math.sqrt(2 * machine.accel / machine.steps_per_mm))
    started, turns = None, 0
    for line in range(1, 13):
        grbl.receive(f"G1 X{2 * line} F3000\n".encode())
        for _ in range(12):                     # 60 ms, a turn every 5 ms
            grbl.poll()
            feeder = motion.feeder
            if started is None and feeder.sent:
                started = now[0]
            exits = [int.from_bytes(payload[3:6], "little")
                     for kind, payload in board.received if kind == protocol.FEED]
            if started is not None and motion.pending:
                turns += 1
                ends = started + sum(feeder.durations)
                assert now[0] < ends or exits[-1] <= rest, \
                    f"the board ran dry at speed {now[0] - ends:.3f} s ago"
            now[0] += 0.005
    assert turns > 50                           # segments were held back meanwhile
    stops = sum(1 for kind, _ in board.received if kind == protocol.STOP)
    assert stops >= 2                           # the machine stopped and went on
    assert said.getvalue() == ""                # (no frame answered: never run dry)


def test_a_board_run_dry_at_speed_is_said():
    """A board that makes every frame it is sent at once runs dry behind the slow sender
    above: kontur serve holds the segments within stopping distance of the last line back,
    and the board finishes the ones sent, planned to go on at speed, before the next line
    makes those final. Said with the line and the speed: the first 2 mm line at F3000 ends
    at sqrt(2 accel 2 mm), 2683 mm/min, where the next goes on."""
    import io
    import math
    import re
    from kontur import registry
    from kontur.grbl.board import PortMotion
    from kontur.grbl.session import Session
    from kontur.machine import Machine
    now = [0.0]
    machine = Machine(clock_hz=registry.board("icebreaker").clock_hz)
    said = io.StringIO()
    motion = PortMotion(machine, "icebreaker", EagerMachine(WINDOW), clock=lambda: now[0],
                        out=said)
    grbl = Session(machine, "icebreaker", lambda line: None, clock=lambda: now[0],
                   motion=motion)
    for line in range(1, 13):
        grbl.receive(f"G1 X{2 * line} F3000\n".encode())
        for _ in range(12):                     # 60 ms, a turn every 5 ms
            grbl.poll()
            now[0] += 0.005
    lines = said.getvalue().splitlines()
    assert lines
    assert all(re.match(r"^kontur: serve: line \d+: the board's queue ran dry at the end of "
                        r"this move: the machine stopped there at once from \d+ mm/min and "
                        r"goes on at that speed", text) for text in lines)
    speed = round(math.sqrt(2 * machine.accel * 2) * 60)
    assert lines[0].startswith(f"kontur: serve: line 1: ") and f" from {speed} mm/min " in lines[0]
