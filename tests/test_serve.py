"""``kontur serve``: Grbl 1.1 on a pseudo-terminal, driven by senders someone else wrote.

The expected values come from the Grbl documents (gnea/grbl doc/markdown/interface.md,
commands.md; doc/csv/error_codes_en_US.csv) and from the G-code itself (a program's end is its
last X and Y words); the steps are compared with ``kontur run``'s for the same program. Every
server is a child process in a group of its own (:func:`kontur.sim.processes.child`), ended
with its test; its clock runs 20 times real time (``--speed``), so that the bracket's 26 s of
machining take about 1.3 s.
"""

import json
import re
import select
import sys
import threading
import time
from pathlib import Path

import pytest
import serial

from kontur.machining import execute, prepare
from kontur.sim import processes

from .conftest import selected_simulators

ROOT = Path(__file__).resolve().parent.parent
BRACKET = ROOT / "kontur" / "programs" / "bracket.ngc"
SPEED = 20
WELCOME = re.compile(r"^Grbl 1\.1[a-z] \['\$' for help\]$")       # interface.md
STATUS = re.compile(r"^<(\w+(?::\d)?)\|MPos:(-?[\d.]+),(-?[\d.]+),(-?[\d.]+)\|")
FIELDS = re.compile(r"\|(\w+):([^|>]*)")

#: A short program that ends away from where it starts: a line, a quarter arc, a line.
SHORT = """G21 G90
G0 X5 Y2
G1 X25 Y2 F1200
G3 X35 Y12 I0 J10
G1 X12.5 Y7.25
M30
"""
#: A long move, to be caught half-way: 22 s of machining, 1.1 s at --speed 20.
LONG = "G1 X100 Y50 F300\n"


def program_end(text, axes="XY"):
    """The end of an absolute (G90) program: its last X and Y (and Z: ``axes="XYZ"``) words,
    read from the text."""
    end = dict.fromkeys(axes, 0.0)
    for line in text.splitlines():
        line = re.sub(r"\(.*?\)|;.*", "", line).upper()
        for letter, value in re.findall(rf"([{axes}])\s*([-+]?[\d.]+)", line):
            end[letter] = float(value)
    return tuple(end.values())


def run_steps(text, board="icebreaker"):
    """``kontur run``'s steps of ``text`` on the model (the default machine, on ``board``)."""
    from kontur.machine import Machine
    from kontur.registry import board as item
    job = prepare(text, machine=Machine(clock_hz=item(board).clock_hz), board=board)
    return execute(job, "model").steps


def read_steps(out):
    return [tuple(map(int, line.split())) for line in (out / "steps.txt").read_text()
            .splitlines()]


#: How long a reply may take (s): a read returns at the line's end, so only a missing line waits
#: this long; generous for a machine loaded by the rest of the suite (CI runs two workers).
LINE_WAIT = 30


@pytest.fixture
def server(tmp_path, request):
    """A ``kontur serve`` child: ``(link, out, process)`` (more options, after ``--speed``,
    by indirect parametrisation)."""
    link, out = tmp_path / "grbl", tmp_path / "out"
    args = [sys.executable, "-m", "kontur.cli", "serve", "--link", str(link), "--out",
            str(out), "--speed", str(SPEED), *getattr(request, "param", ())]
    with processes.child(args, stdout=processes.subprocess.PIPE, cwd=tmp_path) as process:
        ready, _, _ = select.select([process.stdout], [], [], 30)
        assert ready, "kontur serve printed no pseudo-terminal"
        name = process.stdout.readline().decode().strip()
        assert name.startswith("/dev/pts/") and link.resolve() == Path(name)
        yield link, out, process
        process.stdout.close()
    assert not link.exists(), "the link outlived the server"


class Port:
    """A plain Grbl client on pyserial: lines, commands, status polls."""

    def __init__(self, path):
        self.serial = serial.Serial(str(path), 115200, timeout=LINE_WAIT)
        self.reports = []                   # the status reports read, whole
        self.states = []                    # the states wait_idle saw


    def line(self):
        text = self.serial.readline().decode()
        assert text.endswith("\r\n"), f"no complete line in time: {text!r}"
        return text.strip()

    def command(self, text):
        """Send a line; return what came back up to and including ``ok``/``error:N``."""
        self.serial.write(text.encode() + b"\n")
        lines = []
        while not (lines and re.match(r"^(ok|error:\d+)$", lines[-1])):
            lines.append(self.line())
        return lines

    def status(self):
        sent = time.monotonic()
        self.serial.write(b"?")
        while True:
            line = self.line()
            match = STATUS.match(line)
            if match:
                self.reports.append(line)
                state, *position = match.groups()
                return state, tuple(float(c) for c in position), time.monotonic() - sent

    def wait_idle(self, timeout=60):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            state, position, _ = self.status()
            self.states.append(state)
            if state == "Idle":
                return position
            time.sleep(0.02)
        raise AssertionError("the machine did not come back to Idle")

    def close(self):
        self.serial.close()


@pytest.fixture
def port(server):
    link, _, _ = server
    port = Port(link)
    assert WELCOME.match(port.line())                  # sent when the port is opened
    yield port
    port.close()


def wait_for_outputs(out, count, timeout=60):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if (out / "summary.json").exists() and len(read_steps(out)) == count:
            return
        time.sleep(0.05)
    raise AssertionError(f"{out}/steps.txt never held {count} steps")


def stream(port, text):
    """Grbl's character-counting protocol (interface.md, stream.py): lines sent while the
    128-byte receive buffer has room; each ok or error frees its line. Returns the answers
    and the states polled meanwhile."""
    lines = [line.strip() + "\n" for line in text.splitlines()]
    answers, states, pending = [], [], []
    polled = time.monotonic()
    for line in lines + [None]:
        while pending and (line is None or sum(map(len, pending)) + len(line) > 128):
            port.serial.timeout = 0.05
            raw = port.serial.readline().decode()
            port.serial.timeout = LINE_WAIT
            if raw.endswith("\r\n"):
                raw = raw.strip()
                if raw == "ok" or raw.startswith("error:"):
                    answers.append(raw)
                    pending.pop(0)
                elif raw.startswith("<"):
                    states.append(STATUS.match(raw).group(1))
                    port.reports.append(raw)
            if time.monotonic() - polled > 0.05:
                port.serial.write(b"?")
                polled = time.monotonic()
        if line is not None:
            port.serial.write(line.encode())
            pending.append(line)
    return answers, states


# ---- streams ------------------------------------------------------------------------------

def test_the_welcome_outlives_the_flush_of_an_open(server):
    """A sender's serial library empties the port's input once it has set it up (pyserial's
    open does, 50 ms here after the open): the welcome line comes after that, as a Grbl board
    boots after the DTR reset, not into the flush."""
    import os
    import termios
    link, _, _ = server
    fd = os.open(link, os.O_RDWR | os.O_NOCTTY)
    try:
        time.sleep(0.05)
        termios.tcflush(fd, termios.TCIFLUSH)
        ready, _, _ = select.select([fd], [], [], LINE_WAIT)
        assert ready, "no welcome line after the flush"
        time.sleep(0.05)
        assert WELCOME.match(os.read(fd, 200).decode().strip())
    finally:
        os.close(fd)


def test_grbl_streamer_runs_the_bracket(server):
    """grbl-streamer (PyPI), character counting and status polling: the bracket ends Idle at
    its end with kontur run's steps.

    grbl-streamer's ``job_run`` fills the receive buffer from the calling thread while its
    reader thread, on every ``ok``, fills it too (``_stream`` on two threads at once, no lock):
    when the answers come fast, a line can be skipped. The job is therefore started from its
    reader thread, in the callback of a ``$G`` report, as a GUI's event loop would."""
    from grbl_streamer import GrblStreamer
    link, out, _ = server
    events, done, start = [], threading.Event(), threading.Event()

    def callback(event, *data):
        events.append((event, data))
        if event == "on_job_completed":
            done.set()
        if event == "on_read" and data[0].startswith("[GC:") and start.is_set():
            start.clear()
            done.clear()
            streamer.job_run()

    streamer = GrblStreamer(callback)
    streamer.poll_interval = 0.05
    try:
        streamer.cnect(str(link))
        deadline = time.monotonic() + 10
        while not (streamer.connected and streamer.cmode == "Idle"):
            assert time.monotonic() < deadline, "grbl-streamer never saw Grbl idle"
            if streamer.connected and streamer._thread_polling is None:
                streamer.poll_start()
            time.sleep(0.05)
        time.sleep(0.3)                       # its boot-time $$, $# and $G answered
        streamer.load_file(str(BRACKET))
        start.set()
        streamer.get_gcode_parser_state()
        deadline = time.monotonic() + 30
        while not (not start.is_set() and done.is_set()):
            assert time.monotonic() < deadline, "the job never completed"
            time.sleep(0.05)
        deadline = time.monotonic() + 10
        while streamer.cmode != "Idle" or streamer.cmpos[:2] != program_end(
                BRACKET.read_text()):
            assert time.monotonic() < deadline, f"ended {streamer.cmode} {streamer.cmpos}"
            time.sleep(0.05)
        states = [data[0] for event, data in events if event == "on_stateupdate"]
        assert "Run" in states
        assert not [data for event, data in events if event == "on_error"]
    finally:
        streamer.disconnect()
    expected = run_steps(BRACKET.read_text())
    wait_for_outputs(out, len(expected))
    assert read_steps(out) == expected


#: bCNC's sender without its window: its ``Sender`` class (the serial thread, character
#: counting, status polls; bCNC's ``Application`` is that class and a Tk window) with the GRBL1
#: controller, opened on the port, the program loaded and compiled into its queue as bCNC's
#: Run does, a WAIT at the end; printed as JSON: what it logged, lines done, state, MPos.
BCNC = """
import json, os, sys, time
import bCNC
for sub in ("", "lib", "plugins", "controllers"):
    sys.path.append(os.path.join(os.path.dirname(bCNC.__file__), sub))
import Helpers  # gettext.install, as bCNC's main does first
import Utils
Utils.loadConfiguration()
from CNC import CNC, WAIT
from Sender import Sender

class Headless(Sender):
    def disable(self):
        pass

sender = Headless()
sender.open(sys.argv[1], 115200)
sender.load(sys.argv[2])
sender.initRun()
sender._runLines, sender._gcount = sys.maxsize, 0
paths = sender.gcode.compile(sender.queue, lambda: False)
sender._runLines = len(paths) + 1
sender.queue.put((WAIT,))
log, deadline = [], time.time() + 30
while sender._gcount < sender._runLines and time.time() < deadline:
    time.sleep(0.05)
time.sleep(0.5)                                    # a status poll after the WAIT
while not sender.log.empty():
    log.append(list(sender.log.get()))
print(json.dumps({"log": log, "done": sender._gcount, "lines": sender._runLines,
                  "state": CNC.vars["state"],
                  "mpos": [CNC.vars["mx"], CNC.vars["my"], CNC.vars["mz"]]}), flush=True)
sender.serial.close()
os._exit(0)
"""


def test_bcnc_streams_a_program(server, tmp_path):
    """bCNC's own sender code (PyPI ``bcnc``, no window) streams a program: every line
    done, no error, Idle at the program's end as bCNC's status parser reads it, the steps
    kontur run's. Its own warnings are its own (PYTHONWARNINGS off for it)."""
    import json
    import os
    import subprocess
    link, out, _ = server
    program = tmp_path / "short.ngc"
    program.write_text(SHORT)
    env = {**os.environ, "HOME": str(tmp_path), "PYTHONWARNINGS": ""}
    done = subprocess.run([sys.executable, "-c", BCNC, str(link), str(program)], env=env,
                          capture_output=True, text=True, timeout=60, check=True)
    report = json.loads(done.stdout.strip().splitlines()[-1])
    errors = [text for kind, text in report["log"] if kind == 4]            # MSG_ERROR
    assert not errors and [kind for kind, _ in report["log"]].count(3) >= 6   # MSG_OK
    assert report["done"] == report["lines"] and report["state"] == "Idle"
    assert tuple(report["mpos"]) == (*program_end(SHORT), 0.0)
    expected = run_steps(SHORT)
    wait_for_outputs(out, len(expected))
    assert read_steps(out) == expected


@pytest.mark.parametrize("server", [("--speed", "2")], indirect=True)
def test_plain_character_counting_stream(port, server):
    """A plain character-counting stream of a program that ends away from its start: every
    line ok, Run then Idle, MPos the program's end, the steps kontur run's. (At 2 times the
    machine's speed the moves take 1.5 s: a loaded machine's polls see them run.)"""
    _, out, _ = server
    answers, states = stream(port, SHORT)
    assert answers == ["ok"] * len(SHORT.splitlines())
    assert port.wait_idle() == (*program_end(SHORT), 0.0)
    assert "Run" in states + port.states
    expected = run_steps(SHORT)
    wait_for_outputs(out, len(expected))
    assert read_steps(out) == expected


@pytest.mark.parametrize("server", [("--engine", "verilator")], indirect=True)
def test_verilator_checks_what_the_model_made(port, server):
    """``--engine verilator``: a tiny program streamed, Idle at its end; once the machine
    rests its run of motion is run on the controller's RTL (Verilator): summary.json's
    rtl_check holds every step checked and no failure, and the steps are kontur run's."""
    if "verilator" not in selected_simulators():
        pytest.skip("SIM selects another simulator")
    _, out, _ = server
    program = "G21 G90\nG1 X2 Y1 F1200\nG2 X4 Y1 I1 J0\nG0 X0 Y0\n"
    answers, _ = stream(port, program)
    assert answers == ["ok"] * 4
    assert port.wait_idle() == (0.0, 0.0, 0.0)
    expected = run_steps(program)
    deadline = time.monotonic() + 600            # a first Verilator build takes minutes
    while time.monotonic() < deadline:
        if (out / "summary.json").exists():
            check = json.loads((out / "summary.json").read_text()).get("rtl_check", {})
            if check.get("steps") == len(expected) or check.get("failures"):
                break
        time.sleep(0.2)
    assert check == {**check, "engine": "verilator", "steps": len(expected), "failures": [],
                     "segments_cut_short": 0}
    assert read_steps(out) == expected


def test_status_during_a_run_and_hold_resume(port, server):
    """``?`` answered at once while the machine runs; ``!`` stops it (Hold:0, MPos still),
    ``~`` resumes; the steps are those of a run with no hold."""
    _, out, _ = server
    assert port.command(LONG.strip()) == ["ok"]
    seen, slowest = [], 0.0
    for _ in range(5):
        state, position, took = port.status()
        seen.append((state, position))
        slowest = max(slowest, took)
        time.sleep(0.01)
    assert seen[0][0] == "Run" and seen[-1][1] != seen[0][1]
    assert slowest < 0.25, f"a status report took {slowest:.3f} s"
    port.serial.write(b"!")
    time.sleep(0.05)
    state, held, _ = port.status()
    time.sleep(0.2)
    assert state == "Hold:0" and port.status()[:2] == ("Hold:0", held)
    assert held != program_end(LONG) + (0.0,)
    port.serial.write(b"~")
    assert port.wait_idle() == (*program_end(LONG), 0.0)
    expected = run_steps(LONG)
    wait_for_outputs(out, len(expected))
    assert read_steps(out) == expected


def test_soft_reset_in_motion(port):
    """ctrl-X while moving: motion stops where it is, ALARM:3, the welcome again, the alarm
    lock (G-code error:9) until $X (interface.md)."""
    assert port.command(LONG.strip()) == ["ok"]
    time.sleep(0.05)
    port.serial.write(b"\x18")
    assert port.line() == "ALARM:3"
    assert WELCOME.match(port.line())
    assert port.line() == "[MSG:'$H'|'$X' to unlock]"
    state, stopped, _ = port.status()
    time.sleep(0.1)
    assert state == "Alarm" and port.status()[1] == stopped
    assert 0 < stopped[0] < 100
    assert port.command("G1 X0 Y0 F1000") == ["error:9"]
    assert port.command("$X") == ["[MSG:Caution: Unlocked]", "ok"]
    assert port.status()[0] == "Idle"
    port.serial.write(b"\x18")                       # at rest: no alarm
    assert WELCOME.match(port.line())
    assert port.status()[:2] == ("Idle", stopped)


# ---- lines and $ commands -----------------------------------------------------------------

def test_an_error_line(port):
    """A refused line is answered with Grbl's code after a [MSG:] of kontur's reason, and the
    stream goes on (the codes themselves: test_error_codes)."""
    answer = port.command("G1 X1 Y1 Q5 F100")
    assert answer[-1] == "error:20" and answer[0].startswith("[MSG:line ")
    assert port.command("G0 X1") == ["ok"]


def session(board="icebreaker", machine=None, **options):
    """A session alone (no pseudo-terminal) on ``machine`` (default: the default machine) and
    ``board``, its clock standing still unless ``clock`` is given; returns it and the list of
    what it says."""
    from kontur.grbl.session import Session
    from kontur.machine import Machine
    from kontur.registry import board as item
    said = []
    options.setdefault("clock", lambda: 0.0)
    machine = Machine(clock_hz=item(board).clock_hz) if machine is None else machine
    return Session(machine, board, said.append, **options), said


@pytest.mark.parametrize("line, code", [
    ("G1 X1 Y1 Q5 F100", 20),       # a word Grbl does not know
    ("G0 G1 X1", 21),               # two codes of one modal group
    ("G1 X1", 22),                  # no feed rate yet
    ("G1.5 X1 F100", 23),           # a command value that is not an integer
    ("G1 X1 X2 F100", 25),          # a word repeated
    ("G2 X10 Y0 F100", 35),         # an arc with no offset in its plane
    ("G2 X10 Y0 R2 F100", 34),      # a radius that cannot reach the end
    ("G0 X1 I2", 36),               # a word no command uses
    ("G1 X1 F-5", 4),               # a negative value
    ("G1 X F100", 2),               # a letter with no number
    ("1.5", 1),                     # no letter
    ("G1 X" + "1" * 90 + " F100", 11),   # beyond the line buffer
    ("$Q", 3),                      # no such $ command
    ("$100=abc", 2),                # a setting's value that is no number
    ("$J=X10", 22),                 # a jog needs F
    ("$J=G1 X10 F100", 16),         # a jog takes no motion code
    ("G1 G92 X0 F100", 24),         # two commands that both use the axis words
    ("G4", 28),                     # a value word missing (G4 P)
    ("G53 G2 X1 I1 F100", 30),      # G53 with another motion than G0/G1
    ("G80 X5", 31),                 # axis words no command uses
    ("S-5", 4),                     # a negative spindle speed
    ("G18 G2 X4 I2 J1 F100", 36),   # J in the XZ plane: a word no command uses
    ("G18 G2 X4 F100", 35),         # an arc in XZ with no offset in its plane (I, K)
    ("G18 G2 X4 I2 F100", 20),      # an arc in XZ on two axes: it moves Z
])
def test_error_codes(line, code):
    """Grbl's codes for each kind of refusal (interface.md's table), then the next line
    taken as usual."""
    grbl, said = session()
    grbl.receive(line.encode() + b"\n" + b"G0 X1\n")
    grbl.poll()
    assert [s for s in said if s == "ok" or s.startswith("error")] == [f"error:{code}", "ok"]


def test_settings_and_queries(port):
    """$$ lists the machine file as Grbl's settings (defaults of docs/controller.md: 80
    steps/mm, 3000 mm/min, 500 mm/s²); $100= writes steps/mm for X and Y; $G, $#, $I and the
    check mode answer as interface.md shows."""
    settings = port.command("$$")
    assert settings[-1] == "ok"
    table = dict(line.split("=") for line in settings[:-1])
    assert (table["$100"], table["$101"], table["$110"], table["$120"]) == \
        ("80.000", "80.000", "3000.000", "500.000")
    assert port.command("$100=100") == ["ok"]
    assert dict(line.split("=") for line in port.command("$$")[:-1])["$101"] == "100.000"
    assert port.command("$20=1") == ["error:10"]       # soft limits need homing
    assert re.match(r"^\[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0\]$", port.command("$G")[0])
    assert port.command("$#")[0] == "[G54:0.000,0.000,0.000]"
    assert port.command("$I")[0].startswith("[VER:1.1")
    assert port.command("$C") == ["[MSG:Enabled]", "ok"]
    assert port.command("G1 X10 F600") == ["ok"]
    assert port.status()[:2] == ("Check", (0.0, 0.0, 0.0))
    assert port.command("$C") == ["[MSG:Disabled]", "ok"]
    assert WELCOME.match(port.line())
    assert port.command("$J=G91 X2 Y-1 F600") == ["ok"]
    assert port.wait_idle() == (2.0, -1.0, 0.0)
    assert re.match(r"^\[GC:G0 .*G90 ", port.command("$G")[0])   # the jog left G90


def test_overrides(port):
    """The override bytes are taken at once (interface.md's Ov: feed, rapid, spindle, in
    percent; feed within 10-200 %): a feed move at F300 runs at 200 % reports FS:600, the
    steps unchanged (the hold test shows that timing never moves a step)."""
    def fields():
        port.serial.write(b"?")
        while True:
            line = port.line()
            if line.startswith("<"):
                return dict(FIELDS.findall(line))

    port.serial.write(bytes([0x91, 0x91, 0x93, 0x96, 0x9B]))
    assert fields()["Ov"] == "121,50,90"
    port.serial.write(bytes([0x91] * 12 + [0x97]))
    assert fields()["Ov"] == "200,25,90"
    assert port.command(LONG.strip()) == ["ok"]
    time.sleep(0.05)
    report = fields()
    assert report["FS"] == "600,0", report
    port.serial.write(bytes([0x90, 0x95, 0x99]))
    assert fields()["Ov"] == "100,100,100"


def test_tcp(tmp_path):
    """``--tcp 0``: a free localhost port, named on the second line of standard output; a
    connection gets the welcome and is answered like the pseudo-terminal."""
    import socket
    args = [sys.executable, "-m", "kontur.cli", "serve", "--tcp", "0", "--speed", str(SPEED)]
    with processes.child(args, stdout=processes.subprocess.PIPE, cwd=tmp_path) as process:
        ready, _, _ = select.select([process.stdout], [], [], 30)
        assert ready, "kontur serve printed nothing"
        assert process.stdout.readline().decode().startswith("/dev/pts/")
        host, port = re.match(r"^tcp (127\.0\.0\.1):(\d+)$",
                              process.stdout.readline().decode().strip()).groups()
        with socket.create_connection((host, int(port)), timeout=5) as connection:
            reader = connection.makefile("rb")
            assert WELCOME.match(reader.readline().decode().strip())
            connection.sendall(b"G0 X3 Y4\n")
            assert reader.readline() == b"ok\r\n"
            time.sleep(0.2)
            connection.sendall(b"?")
            assert reader.readline().decode().startswith("<Idle|MPos:3.000,4.000,0.000|")
        process.stdout.close()


@pytest.mark.parametrize("seed", range(3))
def test_session_under_a_jumping_clock(seed):
    """The session alone (no pseudo-terminal), its clock a stand-in that jumps: lines arrive
    at random turns while the machine runs, the clock leaps up to 0.3 s between turns (a
    loaded host), each burst re-plans what is not yet made; the steps are still kontur run's,
    every line answered ok, the end the program's."""
    import random

    rng = random.Random(seed)
    text = BRACKET.read_text()
    now = [0.0]
    grbl, said = session(speed=SPEED, clock=lambda: now[0])
    lines = text.encode().splitlines(keepends=True)
    sent = 0
    while sent < len(lines) or grbl.motion.busy or grbl.rx:
        if sent < len(lines) and rng.random() < 0.5:
            grbl.receive(lines[sent])
            sent += 1
        grbl.poll()
        now[0] += rng.choice([0.005, 0.005, 0.1, 0.3])
    grbl.poll()
    assert grbl.motion.made == run_steps(text)
    assert [line for line in said if line in ("ok",) or line.startswith("error")] == \
        ["ok"] * len(lines)
    spm = grbl.machine.steps_per_mm
    assert tuple(c / spm for c in grbl.motion.position) == program_end(text)


def serve_lines(text, **options):
    """``text`` through a session alone, one line a turn, its clock moving 0.1 s a turn, until
    the machine rests; returns the session and what it said."""
    now = [0.0]
    grbl, said = session(speed=SPEED, clock=lambda: now[0], **options)
    for line in text.encode().splitlines(keepends=True):
        grbl.receive(line)
        grbl.poll()
        now[0] += 0.1
    while grbl.motion.busy or grbl.rx or grbl._waiting is not None:
        grbl.poll()
        now[0] += 0.1
    return grbl, said


#: Work offsets, G92 and parameters set on one line and used on the next (LinuxCNC's reader,
#: gnea/grbl's $# and WCO). By hand: G54 is at (10, 5); X#1 Y[#1*2] is machine (13, 11); G92
#: makes that work (0, 0), a G92 offset of (3, 6); X5 then is machine 10 + 3 + 5 = 18.
OFFSETS = """G21 G90
G10 L2 P1 X10 Y5
#1=3
G0 X#1 Y[#1*2]
G92 X0 Y0
G1 X5 F600
"""


def test_offsets_and_parameters_across_lines():
    """The reader's state lives from line to line: G10 L2, a parameter, G92 given on earlier
    lines move the later ones; MPos is machine coordinates, WPos and WCO the work offset,
    ``$#`` lists G54 and G92; the steps are kontur run's of the same program."""
    grbl, said = serve_lines(OFFSETS)
    assert [s for s in said if s == "ok" or s.startswith("error")] == ["ok"] * 6
    spm = grbl.machine.steps_per_mm
    assert tuple(c / spm for c in grbl.motion.position) == (18.0, 11.0)
    assert grbl.motion.made == run_steps(OFFSETS)
    grbl.settings.write(10, 0)                        # $10=0: WPos, as interface.md has it
    grbl._reports = 0                                 # the next report carries WCO
    fields = dict(FIELDS.findall(grbl.status()))
    assert fields["WPos"] == "5.000,0.000,0.000" and fields["WCO"] == "13.000,11.000,0.000"
    said.clear()
    grbl.receive(b"$#\n$G\n")
    grbl.poll()
    assert "[G54:10.000,5.000,0.000]" in said and "[G92:3.000,6.000,0.000]" in said
    assert "[G55:0.000,0.000,0.000]" in said
    assert re.match(r"^\[GC:G1 G54 G17 G21 G90 G94 M5 M9 T0 F600 S0\]$", said[-2])


def test_refused_line_leaves_the_state():
    """A line refused changes nothing: its G91 and its parameter are not kept (the next
    absolute move goes where G90 says), and Z stays where the program first put it, as
    kontur run refuses a Z move."""
    grbl, said = serve_lines("G0 Z5\nG91 #2=7 G1 X1 Q5 F100\nG0 X#2\nG1 X2 Z1 F100\nG0 Y4\n")
    assert [s for s in said if s == "ok" or s.startswith("error")] == \
        ["ok", "error:20", "ok", "error:20", "ok"]
    spm = grbl.machine.steps_per_mm
    assert tuple(c / spm for c in grbl.motion.position) == (0.0, 4.0)   # #2 never set: X0
    assert re.match(r"^<Idle\|MPos:0\.000,4\.000,5\.000\|", grbl.status())
    said.clear()
    grbl.receive(b"$G\n")
    grbl.poll()
    assert " G90 " in said[0] and said[0].startswith("[GC:G0 ")


def test_program_end_and_messages():
    """``(MSG,...)`` is said as ``[MSG:...]``; M30's ok waits for the motion's end, after
    ``[MSG:Pgm End]``; the modes after it are Grbl's program end (G1 G54 G90), the spindle
    off; M3 S1000 shows in ``$G`` before."""
    grbl, said = serve_lines("G55 G91 M3 S1000\n(MSG, half way)\nG1 X2 F600\nM30\n",
                             board="ulx3s")
    assert "[MSG:half way]" in said
    assert said[-2:] == ["[MSG:Pgm End]", "ok"]
    assert grbl.motion.position == (2 * grbl.machine.steps_per_mm, 0, 0)
    # M30 switched the spindle off: a TOOL stop after the move, the machine's state off
    assert [s.payload["tool"]["spindle"].name for s in grbl.motion.segments
            if s.kind == "dwell"] == ["CW", "OFF"]
    assert "A" not in dict(FIELDS.findall(grbl.status()))
    said.clear()
    grbl.receive(b"$G\n")
    grbl.poll()
    assert re.match(r"^\[GC:G1 G54 G17 G21 G90 G94 M5 M9 T0 F600 S1000\]$", said[0]), said


def test_m0_pauses_until_resume():
    """M0 (interface.md, commands.md: a program pause) waits for the motion before it, then
    holds (Hold:0) with its ok kept back; ``~`` sends the ok and the stream goes on. The
    accessory field and FS show the spindle and coolant a program switched on (M3 S1000,
    M8: ``A:SF``, ``FS:..,1000``) on a board with tool outputs (the ULX3S's)."""
    now = [0.0]
    grbl, said = session("ulx3s", speed=SPEED, clock=lambda: now[0])
    grbl.receive(b"M3 S1000 M8\nG1 X2 F600\nM0\nG1 X4\n")
    for _ in range(100):
        grbl.poll()
        now[0] += 0.1
    spm = grbl.machine.steps_per_mm
    assert grbl.state() == "Hold:0" and grbl.motion.position == (2 * spm, 0, 0)
    assert said.count("ok") == 2
    fields = dict(FIELDS.findall(grbl.status()))
    assert fields["A"] == "SF" and fields["FS"] == "0,1000"
    grbl.receive(b"~")
    for _ in range(100):
        grbl.poll()
        now[0] += 0.1
    assert said.count("ok") == 4 and grbl.state() == "Idle"
    assert grbl.motion.position == (4 * spm, 0, 0)
    assert grbl.motion.made == run_steps("M3 S1000 M8\nG1 X2 F600\nM0\nG1 X4\n", "ulx3s")


def test_feed_override_changes_time_not_steps():
    """Feed override at 50 % (0x90 then five 0x92, interface.md): a feed-only program takes
    twice the time on the session's clock, with the same steps (kontur run's)."""
    program = "G1 X20 Y5 F1200\nG1 X0 Y10\n"

    def served(override):
        now = [0.0]
        grbl, _ = session(speed=SPEED, clock=lambda: now[0])
        grbl.receive(override + program.encode())
        grbl.poll()
        while grbl.motion.busy:
            now[0] += 0.001
            grbl.poll()
        return grbl.motion.made, now[0]

    steps, fast = served(b"")
    slow_steps, slow = served(bytes([0x90] + [0x92] * 5))
    assert steps == slow_steps == run_steps(program)
    assert slow == pytest.approx(2 * fast, rel=0.02)


def test_g4_dwell_is_waited_out():
    """G4 P2 (commands.md: Grbl waits for the motion, dwells, then answers ok): its ok comes
    two seconds of machine time after the move before it ends, and the next line only
    then; the steps are kontur run's."""
    program = "G1 X2 F600\nG4 P2\nG1 X4\n"

    def served(text):
        now = [0.0]
        grbl, said = session(speed=SPEED, clock=lambda: now[0])
        grbl.receive(text.encode())
        grbl.poll()
        while grbl.motion.busy or grbl._waiting is not None or grbl.rx:
            now[0] += 0.001
            grbl.poll()
        return grbl.motion.made, now[0], said

    steps, dwelling, said = served(program)
    same, plain, _ = served(program.replace("G4 P2\n", ""))
    assert steps == same == run_steps(program)
    assert said.count("ok") == 3
    assert dwelling - plain == pytest.approx(2 / SPEED, abs=0.01)


def test_hold_ramps_down_and_resume_ramps_up():
    """``!`` at F600 (10 mm/s) on the default machine (500 mm/s², docs/controller.md): Hold:1
    while the machine slows (interface.md), then Hold:0 once stopped, v²/2a = 0.1 mm (8
    steps at 80 steps/mm, give or take one) after the hold; ``~`` starts from rest, the
    first 0.1 mm in sqrt(2 * 0.1 / 500) = 0.02 s of machine time (at cruise: 0.01 s); the
    steps are kontur run's."""
    now = [0.0]
    grbl, _ = session(speed=1, clock=lambda: now[0])
    grbl.receive(LONG.replace("F300", "F600").encode())
    grbl.poll()
    now[0] = 1.0                                    # cruising, far from either end
    grbl.poll()
    made = len(grbl.motion.made)
    grbl.receive(b"!")
    assert grbl.state() == "Hold:1"
    for _ in range(100):
        now[0] += 0.001
        grbl.poll()
    assert grbl.state() == "Hold:0"
    spm = grbl.machine.steps_per_mm
    stopped = grbl.motion.made[made:]
    length = sum((2 ** 0.5 if dx and dy else 1) for dx, dy in stopped) / spm
    assert length == pytest.approx(0.1, abs=1.5 / spm)
    now[0] += 1.0
    grbl.poll()
    assert len(grbl.motion.made) == made + len(stopped)        # held: not a step more
    grbl.receive(b"~")
    resumed, start = len(grbl.motion.made), grbl.motion.now
    for _ in range(40):
        now[0] += 0.001
        grbl.poll()
    steps, times = grbl.motion.made[resumed:], grbl.motion.times[resumed:]
    covered, at = 0.0, None
    for (dx, dy), t in zip(steps, times):
        covered += (2 ** 0.5 if dx and dy else 1) / spm
        if covered >= 0.1:
            at = t - start
            break
    assert at == pytest.approx(0.02, abs=0.003)
    while grbl.motion.busy:
        now[0] += 0.05
        grbl.poll()
    assert grbl.motion.made == run_steps(LONG.replace("F300", "F600"))


@pytest.mark.parametrize("wait, alarm", [(0.0, True), (0.1, False)])
def test_reset_during_a_hold(wait, alarm):
    """interface.md: a reset in Hold:1 (the hold in progress) throws an alarm (ALARM:3); in
    Hold:0 (complete) it does not; the position is kept either way."""
    now = [0.0]
    grbl, said = session(speed=1, clock=lambda: now[0])
    grbl.receive(LONG.encode())
    grbl.poll()
    now[0] = 1.0
    grbl.poll()
    grbl.receive(b"!")
    now[0] += wait
    grbl.poll()
    assert grbl.state() == ("Hold:1" if alarm else "Hold:0")
    position = grbl.motion.position
    grbl.receive(b"\x18")
    assert ("ALARM:3" in said) == alarm
    assert grbl.state() == ("Alarm" if alarm else "Idle")
    assert grbl.motion.position == position


def corpus():
    """The rs274 corpus programs (tests/programs/rs274) that kontur reads whole and that have
    no O-words (which a line-by-line reader cannot take)."""
    from kontur.gcode import GCodeError, read
    for path in sorted((ROOT / "tests" / "programs" / "rs274").glob("*.ngc")):
        text = path.read_text()
        try:
            program = read(text, units="mm")
        except GCodeError:
            continue
        if not any(block.oword for block in program.blocks):
            yield pytest.param(text, program, id=path.stem)


@pytest.mark.parametrize("text, whole", list(corpus()))
def test_stream_reads_line_by_line_as_whole(text, whole):
    """kontur.gcode.Stream (the reader kontur serve keeps from line to line) fed one block at
    a time gives the moves and events the reader gives the whole program (which
    test_gcode_rs274 holds against LinuxCNC's own interpreter)."""
    from kontur.gcode import Stream, parse
    stream = Stream(units="mm")
    moves, events = [], []
    for block in parse(text):
        more, said = stream.feed([block])
        moves += more
        events += [(e.line, e.kind, e.text, e.value) for e in said]
        if stream.ended:
            break
    assert moves == list(whole.moves)
    assert events == [(e.line, e.kind, e.text, e.value) for e in whole.events]


def test_rtl_check_catches_a_wrong_step():
    """The RTL check of ``--engine verilator`` is a check: the model's steps of a served move
    with one step changed (a stand-in for a model that is wrong) are not what the RTL makes,
    and the failure is recorded (summary.json's rtl_check.failures; the true ones pass:
    test_verilator_checks_what_the_model_made)."""
    if "verilator" not in selected_simulators():
        pytest.skip("SIM selects another simulator")
    from dataclasses import replace

    from kontur.grbl.server import RTLCheck
    grbl, _ = serve_lines("G1 X3 Y1 F1200\n")
    segments = grbl.motion.segments
    steps = list(segments[0].steps)
    steps[5] = (steps[5][0], 1 - steps[5][1])               # a diagonal for an axial step
    bad = RTLCheck(grbl, "verilator")
    bad.check([replace(segments[0], steps=steps)], set(), len(grbl.motion.made))
    assert bad.record["steps"] == 0 and len(bad.record["failures"]) == 1
    assert "differ" in bad.record["failures"][0]


def test_settings_kept_in_the_machine_file(tmp_path):
    """With a machine file, ``$100=`` and ``$120=`` rewrite its keys in place (their comments
    kept), ``$11=`` adds the key it lacks, ``$RST=$`` writes the values it had back; the file
    read again is the machine the session runs. The other settings stay in memory."""
    from kontur.grbl.session import Session
    from kontur.machine import Machine
    from kontur.registry import board
    path = tmp_path / "mill.toml"
    path.write_text("steps_per_mm = 80   # the leadscrew's\naccel = 400\n")
    clock = board("icebreaker").clock_hz
    said = []
    grbl = Session(Machine.from_toml(path, clock_hz=clock), "icebreaker", said.append,
                   clock=lambda: 0.0, machine_file=path)
    grbl.receive(b"$100=100\n$120=300\n$11=0.02\n$13=1\n")
    grbl.poll()
    assert said.count("ok") == 4
    assert path.read_text() == ("steps_per_mm = 100   # the leadscrew's\naccel = 300\n"
                                "junction_deviation = 0.02\n")
    again = Machine.from_toml(path, clock_hz=clock)
    assert (again.steps_per_mm, again.accel, again.junction_deviation) == (100, 300, 0.02)
    assert again == grbl.machine
    grbl.receive(b"$RST=$\n")
    grbl.poll()
    assert path.read_text() == ("steps_per_mm = 80   # the leadscrew's\naccel = 400\n"
                                "junction_deviation = 0.01\n")
    assert Machine.from_toml(path, clock_hz=clock) == Machine(clock_hz=clock, accel=400)


def test_soft_limit():
    """A machine file's travel (travel_x, travel_y: kontur run's soft limits) on a served
    line: Grbl's soft limit (interface.md, alarm_codes: ALARM:2, the machine stopped and its
    queue dropped, position kept, nothing answered until ctrl-X, then the alarm lock until
    $X); a jog beyond it is error:15 and nothing else."""
    from kontur.grbl.session import Session
    from kontur.machine import Machine
    from kontur.registry import board
    now = [0.0]
    said = []
    machine = Machine(clock_hz=board("icebreaker").clock_hz, travel_x=(0, 50), travel_y=(0, 50))
    grbl = Session(machine, "icebreaker", said.append, clock=lambda: now[0])
    grbl.receive(b"$J=X60 F600\nG1 X10 F600\n")
    grbl.poll()
    assert [s for s in said if s == "ok" or s.startswith(("error", "ALARM"))] == \
        ["error:15", "ok"]
    now[0] += 0.5                                   # half-way along X10
    grbl.poll()
    said.clear()
    grbl.receive(b"G1 X60\nG0 X0\n")
    grbl.poll()
    assert said[-2:] == ["ALARM:2", "[MSG:Reset to continue]"]
    assert said[0].startswith("[MSG:line 3:") and "travel" in said[0]
    for _ in range(50):
        now[0] += 0.01
        grbl.poll()
    stopped = grbl.motion.position
    assert 0 < stopped[0] < 10 * machine.steps_per_mm and grbl.state() == "Alarm"
    assert not grbl.motion.busy and said[-1] == "[MSG:Reset to continue]"
    said.clear()
    grbl.receive(b"\x18")
    assert "ALARM:3" not in said and said[-1] == "[MSG:'$H'|'$X' to unlock]"
    grbl.receive(b"G0 X0\n$X\nG0 X0\n")
    grbl.poll()
    assert [s for s in said if s == "ok" or s.startswith("error")] == ["error:9", "ok", "ok"]
    assert grbl.motion.position == stopped


@pytest.mark.parametrize("name", ["arcs", "home", "offsets", "params", "inch"])
def test_corpus_served_as_run(name):
    """rs274 corpus programs (work offsets, G28/G30 with their intermediate points, G92,
    parameters, inches, arcs) served line by line make kontur run's steps. (modes.ngc has
    lines after its M2 and its closing %, which a file reader stops at and a sender streams
    on, as Grbl runs them.)"""
    text = (ROOT / "tests" / "programs" / "rs274" / f"{name}.ngc").read_text()
    grbl, said = serve_lines(text)
    assert not [s for s in said if s.startswith("error")], said
    assert grbl.motion.made == run_steps(text)


def test_soft_limits_setting():
    """``$20`` (soft limits) shows whether the machine file gives a travel; it cannot be
    turned on without one (error:10, as Grbl without homing) nor off with one."""
    from kontur.grbl.session import Session
    from kontur.machine import Machine
    from kontur.registry import board
    for travel, shown, refused in ((None, "$20=0", b"$20=1\n"), ((0, 50), "$20=1", b"$20=0\n")):
        said = []
        grbl = Session(Machine(clock_hz=board("icebreaker").clock_hz, travel_x=travel),
                       "icebreaker", said.append, clock=lambda: 0.0)
        grbl.receive(b"$$\n" + refused + shown.encode() + b"\n")
        grbl.poll()
        assert shown in said
        assert [s for s in said if s == "ok" or s.startswith("error")] == \
            ["ok", "error:10" if travel is None else "error:3", "ok"]


def test_max_rate_setting_within_the_engines():
    """``$110`` (the highest feed) above what the board's slowest engine makes is Grbl's
    error:12 (step rate exceeded), as above what the step/dir timing allows: the
    iCEBreaker's arcs on the bit-serial node at 20 bits make a step every 22 clocks, 545 455
    steps a second at 12 MHz; drives with 0.2 µs set-up and pulse would allow 1.7 M."""
    from kontur.grbl.session import Session
    from kontur.machine import Machine
    said = []
    grbl = Session(Machine(clock_hz=12e6, dir_setup_us=0.2, step_width_us=0.2,
                           steps_per_mm=1000), "icebreaker", said.append, clock=lambda: 0.0)
    grbl.receive(b"$110=30000\n$110=40000\n$110=200000\n$$\n")
    grbl.poll()
    assert [s for s in said if s == "ok" or s.startswith("error")][:3] == \
        ["ok", "error:12", "error:12"]
    assert "$110=30000.000" in said


def test_g28_1_kept_in_the_machine_file(tmp_path):
    """G28.1 and G30.1 (commands.md: stored in EEPROM) keep the position in the machine file
    as g28_position/g30_position (X, Y); the file read again gives kontur run the same G28;
    ``$#`` shows it."""
    from kontur.grbl.session import Session
    from kontur.machine import Machine
    from kontur.registry import board
    path = tmp_path / "mill.toml"
    path.write_text("g28_position = [0, 0]   # where G28 goes\n")
    clock = board("icebreaker").clock_hz
    now = [0.0]
    said = []
    grbl = Session(Machine.from_toml(path, clock_hz=clock), "icebreaker", said.append,
                   speed=SPEED, clock=lambda: now[0], machine_file=path)
    grbl.receive(b"G0 X12.5 Y4\nG28.1\nG0 X1 Y1\nG30.1\n")
    for _ in range(100):
        now[0] += 0.1
        grbl.poll()
    grbl.receive(b"$#\n")                           # idle only, as Grbl's
    grbl.poll()
    assert path.read_text() == ("g28_position = [12.5, 4]   # where G28 goes\n"
                                "g30_position = [1, 1]\n")
    assert Machine.from_toml(path, clock_hz=clock).g28_position == (12.5, 4)
    assert "[G28:12.500,4.000,0.000]" in said and "[G30:1.000,1.000,0.000]" in said


@pytest.mark.parametrize("override", [bytes([0x91] * 10), bytes([0x92] * 5)])
def test_override_ramps(override):
    """An override during a feed move (200 %, or 50 %) changes the speed at the machine's
    acceleration, as the feed generator ramps its rate (never at once): from 10 mm/s (F600)
    to 20 or 5 mm/s at 500 mm/s² takes 0.02 or 0.01 s, over the steps of (v1² - v0²) / 2a =
    0.3 mm (faster) or 0.075 mm (slower); the steps are kontur run's."""
    now = [0.0]
    program = LONG.replace("F300", "F600")
    grbl, _ = session(speed=1, clock=lambda: now[0])
    grbl.receive(program.encode())
    grbl.poll()
    now[0] = 1.0
    grbl.poll()
    made = len(grbl.motion.made)
    grbl.receive(override)
    target = 20.0 if len(override) == 10 else 5.0
    for _ in range(60):
        now[0] += 0.001
        grbl.poll()
    spm = grbl.machine.steps_per_mm
    speeds = []                                   # machine mm/s of each step since the change
    for (dx, dy), before, at in zip(grbl.motion.made[made:], grbl.motion.times[made - 1:],
                                    grbl.motion.times[made:]):
        factor = target / 10
        speeds.append((2 ** 0.5 if dx and dy else 1) / spm / (at - before) * factor)
    ramp = abs(target ** 2 - 10 ** 2) / 1000      # mm
    first = round(ramp / 2 * spm * 0.85)          # steps well inside the ramp, and after it
    assert min(speeds[:first], key=lambda v: abs(v - target)) != pytest.approx(target, rel=0.05)
    assert speeds[-5:] == pytest.approx([target] * 5, rel=0.05)
    while grbl.motion.busy:
        now[0] += 0.05
        grbl.poll()
    assert grbl.motion.made == run_steps(program)


# ---- Z and the tool outputs (issue 28): a 3-axis board with them, the ULX3S's ----------------

#: A plunge, a helix (G2 with Z), spindle and flood on around them, both off on one line; the
#: moves long enough (about 9 s of machining, 0.45 s at --speed 20) for polls to see them on.
#: By hand: it ends at X40 Y5 Z5.
MILL = """G21 G90
G0 X5 Y5 Z2
M3 S500
G1 Z-1 F300
M8
G2 X15 Y5 Z-3 I5 J0 F300
G1 X40 F300
M5 M9
G0 Z5
"""


def _accessories(reports):
    """The ``A:`` field of each status report ('' when absent), repeats dropped."""
    out = []
    for report in reports:
        field = dict(FIELDS.findall(report)).get("A", "")
        if not out or out[-1] != field:
            out.append(field)
    return out


@pytest.mark.parametrize("board", ["ulx3s", "icebreaker-z"])
def test_z_and_tools_served_as_rs274_orders_them(board):
    """On the ULX3S's configuration (and the three-axis iCEBreaker's) a served program moves Z (a plunge, a helix: LINE3 and
    HELIX frames) and switches the spindle and flood (TOOL frames): MPos ends at the program's
    own end, Z included; the steps are ``kontur run``'s; the TOOL frames sit between the moves
    where LinuxCNC's interpreter (``rs274 -g``) makes its spindle and coolant calls; the
    accessory field shows ``S``, then ``SF``, and nothing after M5 M9; ``$G`` the modal
    state, ``$#`` and G92 offsets for Z as for X and Y."""
    import types

    from kontur.hdl.motion import protocol
    from kontur.hdl.motion.tools import TOOL
    from kontur.planner import frames, plan
    from kontur.rs274 import available

    from .test_tools_run import kontur_changes, rs274_changes

    now, reports = [0.0], []
    grbl, said = session(board, speed=SPEED, clock=lambda: now[0])
    for line in MILL.encode().splitlines(keepends=True):
        grbl.receive(line)
        for _ in range(3):
            grbl.poll()
            now[0] += 0.02
            reports.append(grbl.status())
    while grbl.motion.busy or grbl.rx:
        grbl.poll()
        now[0] += 0.02
        reports.append(grbl.status())
    assert [s for s in said if s == "ok" or s.startswith("error")] == \
        ["ok"] * len(MILL.splitlines())
    assert STATUS.match(reports[-1]).groups()[1:] == \
        tuple(f"{c:.3f}" for c in program_end(MILL, "XYZ"))
    assert grbl.motion.made == run_steps(MILL, board)
    assert _accessories(reports) == ["", "S", "SF", ""]
    assert dict(FIELDS.findall(reports[-1]))["FS"] == "0,0"
    # the frames of what was made: LINE3, HELIX, the TOOL frames between the moves
    segments = grbl.motion.segments
    sent, lines = frames(segments, plan(segments, grbl.machine), grbl.machine)
    kinds = [(frame[1], line) for frame, line in zip(sent, lines)
             if frame[1] in (protocol.LINE3, protocol.HELIX, TOOL)]
    assert [line for kind, line in kinds if kind == TOOL] == [3, 5, 8]
    assert [line for kind, line in kinds] == sorted(line for kind, line in kinds)
    assert [kind for kind, line in kinds if line != 6] == \
        [protocol.LINE3, TOOL, protocol.LINE3, TOOL, protocol.LINE3, TOOL, protocol.LINE3]
    assert [kind for kind, line in kinds if line == 6][0] == protocol.HELIX
    assert available(), "rs274 is missing: run make setup"
    assert kontur_changes(types.SimpleNamespace(segments=segments)) == \
        rs274_changes(MILL + "M2\n")
    said.clear()
    grbl.receive(b"G92 Z1\n$#\nM3 S700 M7\nM4\n$G\n")
    for _ in range(5):
        grbl.poll()
    assert "[G92:0.000,0.000,4.000]" in said
    assert re.match(r"^\[GC:G0 G54 G17 G21 G90 G94 M4 M7 T0 F300 S700\]$", said[-2]), said
    grbl.settings.write(10, 0)                        # $10=0: WPos
    grbl._reports = 1
    fields = dict(FIELDS.findall(grbl.status()))
    assert fields["WPos"] == "40.000,5.000,1.000" and fields["A"] == "CM"
    assert fields["FS"] == "0,700"


def test_soft_reset_switches_the_tools_off():
    """ctrl-X with the spindle and mist on (Grbl's reset switches them off; a board's ABORT
    leaves its tool outputs as they are): a TOOL frame with everything off follows, and the
    accessory field is gone."""
    now = [0.0]
    grbl, said = session("ulx3s", speed=SPEED, clock=lambda: now[0])
    grbl.receive(b"M4 S300 M7\nG1 X50 Z-2 F300\n")
    for _ in range(5):
        grbl.poll()
        now[0] += 0.1
    assert grbl.state() == "Run" and dict(FIELDS.findall(grbl.status()))["A"] == "CM"
    grbl.receive(b"\x18")
    grbl.poll()
    assert "ALARM:3" in said and "A" not in dict(FIELDS.findall(grbl.status()))
    tools = [s.payload["tool"] for s in grbl.motion.segments if s.kind == "dwell"]
    assert [(t["spindle"].name, t["mist"]) for t in tools] == [("CCW", True), ("OFF", False)]


def test_z_refused_on_the_icebreaker_and_tools_on_a_board_without():
    """The iCEBreaker's controller has two axes: a Z move (after the first Z, where the
    operator has set the tool) is refused with one line of reason and ``error:20``; its tool
    outputs take M3 and M8 (a TOOL frame each). On a board without tool outputs a spindle or
    coolant switched on is refused so; M5, M9 and S, which switch nothing on, are taken."""
    from dataclasses import replace

    from kontur import registry

    def lines(grbl, said, pairs):
        for line, answer in pairs:
            said.clear()
            grbl.receive(line.encode() + b"\n")
            grbl.poll()
            assert said == answer, line

    grbl, said = session()
    lines(grbl, said, (("G0 Z5", ["ok"]),
                       ("G1 X1 Z-1 F100", ["[MSG:line 2: Z moves need the third axis, which "
                                           "this board's controller does not have (the "
                                           "icebreaker-z's and the ulx3s's have it) (Z from 5 "
                                           "to -1 mm)]",
                                           "error:20"]),
                       ("M3 S500", ["ok"]), ("G1 X2 F100", ["ok"]), ("M8", ["ok"]),
                       ("M5 M9 S200", ["ok"])))
    tools = [s.payload["tool"] for s in grbl.motion.segments if s.kind == "dwell"]
    assert [(t["spindle"].name, t["s"], t["flood"]) for t in tools][:1] == \
        [("CW", 500, False)]                      # (M8's goes before the next move)
    grbl, said = session(replace(registry.board("icebreaker"), tools=False))
    refusal = "the icebreaker's controller has no tool outputs (spindle, coolant; the ulx3s's " \
              "has them)"
    lines(grbl, said, (("M3 S500", [f"[MSG:line 1: M3 S500: {refusal}]", "error:20"]),
                       ("M8", [f"[MSG:line 2: M8: {refusal}]", "error:20"]),
                       ("M5 M9 S200", ["ok"])))
    assert "A" not in dict(FIELDS.findall(grbl.status()))


@pytest.mark.parametrize("server", [("--board", "ulx3s")], indirect=True)
def test_a_sender_streams_z_and_tools(port, server):
    """The plain character-counting client streams MILL to ``kontur serve --board ulx3s``:
    every line ok, MPos the program's end with its Z, the accessory field on (S, then SF) while
    the moves run and gone after M5 M9; the steps written are ``kontur run``'s."""
    _, out, _ = server
    answers, _ = stream(port, MILL)
    assert answers == ["ok"] * len(MILL.splitlines())
    assert port.wait_idle() == program_end(MILL, "XYZ")
    seen = [field for field in _accessories(port.reports) if field]
    assert "SF" in seen and set(seen) <= {"S", "SF"}
    assert "A" not in dict(FIELDS.findall(port.reports[-1]))
    expected = run_steps(MILL, "ulx3s")
    wait_for_outputs(out, len(expected))
    assert read_steps(out) == expected


@pytest.mark.parametrize("server", [("--board", "ulx3s", "--engine", "verilator")],
                         indirect=True)
def test_verilator_checks_z_and_tools(port, server):
    """``--engine verilator --board ulx3s``: MILL's run of motion (LINE3, HELIX and its three
    TOOL frames) run on the ULX3S controller's RTL once the machine rests: every step checked,
    every frame DONE, no failure; summary.json lists the TOOL frames."""
    if "verilator" not in selected_simulators():
        pytest.skip("SIM selects another simulator")
    _, out, _ = server
    answers, _ = stream(port, MILL)
    assert answers == ["ok"] * len(MILL.splitlines())
    assert port.wait_idle() == program_end(MILL, "XYZ")
    expected = run_steps(MILL, "ulx3s")
    deadline = time.monotonic() + 600            # a first Verilator build takes minutes
    while time.monotonic() < deadline:
        if (out / "summary.json").exists():
            data = json.loads((out / "summary.json").read_text())
            check = data.get("rtl_check", {})
            if check.get("steps") == len(expected) or check.get("failures"):
                break
        time.sleep(0.2)
    assert check == {**check, "engine": "verilator", "steps": len(expected), "failures": [],
                     "segments_cut_short": 0}
    assert [(f["line"], f["spindle"], f["flood"]) for f in data["tool_frames"]] == \
        [(3, "cw", False), (5, "cw", True), (8, "off", False)]


def _tool_per_move(segments):
    """The tool state (pins: spindle, S while on, mist, flood) in force during each move of
    ``segments``, and the lines of the stops the machine makes for a change."""
    state, during, stops = None, [], []
    for segment in segments:
        if "tool" in segment.payload:
            tool = segment.payload["tool"]
            state = (tool["spindle"].name, tool["s"] if tool["spindle"].value else None,
                     tool["mist"], tool["flood"])
            if segment.payload.get("stop", True):
                stops.append(segment.line)
        elif segment.steps:
            during.append((segment.line, state))
    return during, stops


def test_laser_mode_served_as_run():
    """A laser program (tests/programs/rs274/laser.ngc, LightBurn's style) served line by line
    with the machine's laser mode on: during every move the tool outputs are what ``kontur
    run`` gives them (the power 0 in G0, the S of each G1), and the machine stops only where
    the spindle or the coolant changes (a change of power alone taken on the fly)."""
    from kontur.machine import Machine
    from kontur.registry import board

    text = (ROOT / "tests" / "programs" / "rs274" / "laser.ngc").read_text()
    machine = Machine(clock_hz=board("ulx3s").clock_hz, laser=True)
    grbl, said = serve_lines(text, board="ulx3s", machine=machine)
    assert said.count("ok") == len(text.splitlines())
    served, served_stops = _tool_per_move(grbl.motion.segments)
    run, run_stops = _tool_per_move(prepare(text, machine=machine, board="ulx3s").segments)
    assert served == run
    assert ("CCW", 0, False, True) in {state for _, state in served}       # G0: power 0
    # M4 and M8 before the first move, M9 and M5 at the end: stops; the S changes are not
    # (kontur run makes one stop of the changes between the same two moves: 6, then 18-19)
    assert served_stops == [4, 6, 17, 19] and run_stops[0] == 6 and run_stops[-1] == 19
    assert grbl.motion.tool["spindle"].name == "OFF" and not grbl.motion.tool["flood"]


#: Arcs in XZ and YZ (G18, G19) as a Grbl sender streams them: a half round groove across X,
#: back by a radius, a quarter in YZ with Y advancing. By hand: it ends at X-6 Y6 Z-6.
PLANES = """G21 G90
G0 X-6 Y0 Z0
G18 G2 X6 Z0 I6 K0 F600
G3 X-6 Z0 R8
G19 G2 Y6 Z-6 J0 K-6
"""


@pytest.mark.parametrize("board", ["ulx3s", "icebreaker-z"])
def test_planes_served(board):
    """A served program's arcs in XZ and YZ are ``kontur run``'s steps (HELIX frames with
    their plane), MPos ends at the program's end, ``$G`` reports the plane in force (G19)."""
    from kontur.hdl.motion import protocol

    grbl, said = serve_lines(PLANES, board=board)
    assert [s for s in said if s == "ok" or s.startswith("error")] == \
        ["ok"] * len(PLANES.splitlines())
    assert STATUS.match(grbl.status()).groups()[1:] == ("-6.000", "6.000", "-6.000")
    assert grbl.motion.made == run_steps(PLANES, board)
    helices = [s.payload for s in grbl.motion.segments if s.kind == "arc"]
    assert [h["plane"] for h in helices] == [1, 1, 2]
    # (the frame: sync, type, length, then the payload; the cw byte's bits 1-2 the plane)
    assert [protocol.helix(**h)[1] for h in helices] == [protocol.HELIX] * 3
    assert [protocol.helix(**h)[3 + 16] >> 1 for h in helices] == [1, 1, 2]
    said.clear()
    grbl.receive(b"$G\n")
    grbl.poll()
    assert re.match(r"^\[GC:G2 G54 G19 G21 G90 G94 ", said[0]), said


def test_tool_length_offset():
    """G43.1 Z (Grbl's dynamic tool length offset) shifts Z's program zero: ``$#`` reports it
    as ``[TLO:]``, the status's WCO has it in Z, the machine does not move for it, and the
    next Z word lands that much higher (the ULX3S's three axes); G49 takes it back."""
    now = [0.0]
    grbl, said = session("ulx3s", speed=SPEED, clock=lambda: now[0])
    def run(*lines):
        for line in lines:
            grbl.receive(line)
            grbl.poll()
        while grbl.motion.busy or grbl.rx:
            grbl.poll()
            now[0] += 0.02

    run(b"G21 G90 G0 Z1\n", b"G43.1 Z2.5\n")
    assert STATUS.match(grbl.status()).groups()[1:] == ("0.000", "0.000", "1.000")
    run(b"$#\n", b"G0 Z3\n")
    assert "[TLO:2.500]" in said
    assert STATUS.match(grbl.status()).groups()[1:] == ("0.000", "0.000", "5.500")
    grbl._reports = 0                                 # the next report carries WCO
    fields = dict(FIELDS.findall(grbl.status()))
    assert fields["WCO"] == "0.000,0.000,2.500"
    said.clear()
    grbl.receive(b"G49\n$#\n")
    grbl.poll()
    assert "[TLO:0.000]" in said


#: A drilling cycle as a sender streams it (grblHAL has them; Grbl 1.1 has not): G81 at two
#: holes, R and Z kept from the first block to the second. By hand: it ends at X20 Y10 Z2 (G99).
DRILL = """G21 G90 G0 X0 Y0 Z10
G99 G81 X10 Y10 Z-2 R2 F300
X20
G80
"""

#: The same cycle in the XZ plane (G18): drilled along Y, the holes at Z X. By hand: it ends
#: at X20 Y2 Z10 (G99: back to R along Y).
DRILL_XZ = """G21 G90 G0 X0 Y10 Z10
G18 G99 G81 X10 Z10 Y-2 R2 F300
X20
G80
"""


@pytest.mark.parametrize("program, board, end", [
    (DRILL, "ulx3s", ("20.000", "10.000", "2.000")),
    (DRILL, "icebreaker", None),
    (DRILL_XZ, "ulx3s", ("20.000", "2.000", "10.000")),
])
def test_drilling_cycle_served(program, board, end):
    """A served canned cycle makes ``kontur run``'s steps on a three-axis board (the cycle's
    words kept from line to line as the reader keeps them; in G18 too); on the two-axis
    iCEBreaker its Z moves are ``error:20``."""
    grbl, said = serve_lines(program, board=board)
    answers = [s for s in said if s == "ok" or s.startswith("error")]
    if end is None:             # (the refused line changes nothing: X20 is then a G0)
        assert answers == ["ok", "error:20", "ok", "ok"], said
        return
    assert answers == ["ok"] * 4, said
    assert STATUS.match(grbl.status()).groups()[1:] == end
    assert grbl.motion.made == run_steps(program, board)
