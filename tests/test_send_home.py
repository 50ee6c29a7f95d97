# amaranth: UnusedElaboratable=no
"""``kontur send --home``: the homing cycle streamed to a board, then the program from where
the cycle left the machine; a pass that never finds its switch ends the send in one line.

The board is ``tests/test_send.py``'s stand-in (the protocol's reference decoder behind a
pseudo-terminal) with limit switches at given positions: a HOME pass steps its axis until
the switch is at the level it waits for, or its most steps (``REFUSED``), and a pass that ends
on its switch with bit 3 sets the axis's position, as the gateware's homing engine does (its
steps against this model: tests/test_homing.py). The expected positions are worked out here
from the machine file's numbers, not from kontur.homing.
"""

import struct

import pytest

from kontur.cli import main
from kontur.hdl.motion import protocol
from kontur.hdl.motion.homing import HOME
from kontur.sim.models.homing import BenchSwitches, pass_steps

from .test_send import FakeMachine, PtyBoard, _machine_file, within

#: 80 steps/mm; X travels 0-200 mm with its switch at the + end, Y 0-100 mm at the - end;
#: a pull-off of 1 mm.
MACHINE = {"steps_per_mm": 80, "travel_x": "[0, 200]", "travel_y": "[0, 100]",
           "homing_dir": '["+", "-"]', "homing_pulloff": 1.0, "homing_debounce_ms": 1,
           "homing_seek": 3000, "homing_feed": 300}

#: Where the cycle leaves the machine: X at 200 mm less the pull-off, Y at 0 plus it (steps).
HOMED = (200 * 80 - 80, 0 + 80)


class SwitchedMachine(FakeMachine):
    """A :class:`FakeMachine` that takes HOME frames: the switches (``switches``, a
    :class:`BenchSwitches` at the board's own step count) follow the axes' steps, which start
    at ``at`` (where the board was switched on: its counters read 0 there)."""

    def __init__(self, *args, switches, **kwargs):
        super().__init__(*args, **kwargs)
        self.parser.lengths[HOME] = 9
        self.switches = switches
        self.steps = [0, 0]                      # the axes' steps since switch-on
        self.homes = 0

    def _release(self, bad_crc=False):
        number, kind, payload = self.later[0]
        if kind != HOME:
            before = list(self.position)
            super()._release(bad_crc)
            self.steps = [s + p - b for s, p, b in zip(self.steps, self.position, before)]
            return
        self.later.pop(0)
        self.unanswered -= 1
        self.released += 1
        self.homes += 1
        flags, most, value = struct.unpack("<BIi", payload)
        item = {"axis": flags & 1, "negative": flags >> 1 & 1, "until": flags >> 2 & 1,
                "steps": most}
        made, outcome = pass_steps(self.steps, item, self.switches)
        for dx, dy in made:
            self.steps = [self.steps[0] + dx, self.steps[1] + dy]
            self.position = [self.position[0] + dx, self.position[1] + dy,
                             *self.position[2:]]
        if outcome == 0 and flags & 8:
            self.position[item["axis"]] = value
        self.pending += protocol.frame(0x80, bytes([(number + self.first) % 256, outcome]))


def _board(**options):
    # X's switch 5000 steps from where the board starts (+), Y's 3000 below it (-).
    # (the ULX3S's controller: three axes, Z never moved here)
    return SwitchedMachine(32, switches=BenchSwitches((5000, -3000), negative=(False, True)),
                           axes=3, **options)


PROGRAM = "G21 G90\nG0 X10 Y10\nG1 X20 F600\nG1 Y20\nM30\n"


def _send_home(tmp_path, machine):
    # `kontur send PROGRAM --home` to the stand-in board on a pseudo-terminal; its status.
    path = tmp_path / "p.ngc"
    path.write_text(PROGRAM)
    with PtyBoard(machine) as board:
        return within(30, main, ["send", str(path), "--port", board.path, "--board", "ulx3s",
                                 "--machine", _machine_file(tmp_path, **MACHINE), "--home",
                                 "--timeout", "2"])


def test_home_then_the_program(tmp_path, capsys):
    """The cycle homes both axes (six passes), the board's counters become the machine
    coordinates of the switch points less the pull-off, and the program starts there: its
    G0 X10 Y10 goes from the homed point, and it ends at (20, 20) mm."""
    machine = _board()
    status = _send_home(tmp_path, machine)
    captured = capsys.readouterr()
    assert status == 0, captured.err
    lines = captured.out.splitlines()
    assert lines[0] == f"homed: the machine at {HOMED} steps"
    assert lines[1].startswith("sent ") and "ended at (1600, 1600) steps" in lines[1]
    assert machine.homes == 6
    assert tuple(machine.position) == (1600, 1600, 0)
    # The axes really went to their switches and back off by the pull-off.
    assert machine.steps[0] == 5000 - 80 + (1600 - HOMED[0])
    assert machine.steps[1] == -3000 + 80 + (1600 - HOMED[1])


def test_a_switch_never_found(tmp_path, capsys):
    """Y's switch beyond 1.5 travels: its seek ends REFUSED, the send ends in one line naming
    the pass (status 1), the program is never sent."""
    machine = SwitchedMachine(32, switches=BenchSwitches((5000, -20000), negative=(False, True)),
                              axes=3)
    status = _send_home(tmp_path, machine)
    captured = capsys.readouterr()
    assert status == 1 and captured.out == ""
    assert captured.err.splitlines() == [
        "kontur: SendError: homing failed: the Y switch was not active within 150 mm (seek)"]
    assert machine.homes == 4 and machine.aborted
    assert machine.steps[1] == -round(1.5 * 100 * 80)


@pytest.mark.parametrize("board, keys, message", [
    ("icebreaker", {}, "homing: the icebreaker's controller is built without the homing engine"),
    ("ulx3s", {"homing_order": '["y"]'}, "--home homes X and Y (and Z where homing_order has "
                                         "it), and the machine file's "
                                         "homing_order is ['y']"),
    ("ulx3s", {"travel_x": None}, "--home: homing needs travel_x"),
])
def test_refused_before_anything_moves(tmp_path, capsys, board, keys, message):
    keys = {key: value for key, value in {**MACHINE, **keys}.items() if value is not None}
    path = tmp_path / "p.ngc"
    path.write_text(PROGRAM)
    status = main(["send", str(path), "--port", "/dev/null-none", "--board", board,
                   "--machine", _machine_file(tmp_path, **keys), "--home"])
    err = capsys.readouterr().err.splitlines()
    assert status == 2 and len(err) == 1 and err[0].startswith(f"kontur: {message}"), err


def test_a_program_leaving_the_travel_from_the_homed_point(tmp_path, capsys):
    """The program is checked from where homing will leave the machine, before anything
    moves: G91 G1 X5 from X 199 mm leaves the 200 mm travel."""
    path = tmp_path / "p.ngc"
    path.write_text("G21 G91\nG1 X5 F600\nM30\n")
    status = main(["send", str(path), "--port", "/dev/null-none", "--board", "ulx3s",
                   "--machine", _machine_file(tmp_path, **MACHINE), "--home"])
    err = capsys.readouterr().err.splitlines()
    assert status == 2 and len(err) == 1 and "line 2" in err[0], err


# ---- $H in kontur serve --port ----------------------------------------------------------------

def _serve_home(tmp_path, machine):
    from .test_serve_port import _connect, _serve
    board = PtyBoard(machine)
    child, link, _ = _serve(tmp_path, board, "--board", "ulx3s", "--machine",
                            _machine_file(tmp_path, **MACHINE))
    return board, child, link, _connect


def test_serve_home_then_a_move(tmp_path):
    """``$22=1``, ``$H``: ``ok`` once the board has made the cycle; the status reports the
    homed point (mm, machine coordinates) and Idle; a G0 then goes from there on the board."""
    machine = _board()
    board, child, link, connect = _serve_home(tmp_path, machine)
    with board, child as process:
        port = connect(process, link)
        assert port.command("$H") == [
            "[MSG:line 1: homing is off: $22=1 turns it on]", "error:5"]
        assert port.command("$22=1") == ["ok"]
        assert port.command("$H") == ["ok"]
        assert machine.homes == 6
        assert port.wait_idle(10) == (HOMED[0] / 80, HOMED[1] / 80, 0.0)
        assert port.command("G0 X10 Y10") == ["ok"]
        assert port.wait_idle(10) == (10.0, 10.0, 0.0)
        assert tuple(machine.position) == (800, 800, 0)
        assert machine.steps == [5000 - 80 + (800 - HOMED[0]), -3000 + 80 + (800 - HOMED[1])]
        port.close()
        process.stdout.close()


def test_serve_home_without_the_switch(tmp_path):
    """Y's switch never found: ``ALARM:9`` with the pass named, the board ABORTed; ``$X``
    leaves the lock."""
    machine = SwitchedMachine(32, switches=BenchSwitches((5000, -20000), negative=(False, True)),
                              axes=3)
    board, child, link, connect = _serve_home(tmp_path, machine)
    with board, child as process:
        port = connect(process, link)
        assert port.command("$22=1") == ["ok"]
        port.serial.write(b"$H\n")
        assert port.line() == "[MSG:homing failed: the Y switch was not active within 150 mm " \
                              "(seek)]"
        assert port.line() == "ALARM:9"
        assert port.status()[0] == "Alarm" and machine.aborted
        assert port.command("$X") == ["[MSG:Caution: Unlocked]", "ok"]
        assert port.wait_idle(10)[1] == -round(1.5 * 100 * 80) / 80
        port.close()
        process.stdout.close()


def test_the_virtual_machine_does_not_home():
    """The model engine's machine has no switches: ``$22=1`` and ``$H`` refused with why."""
    from kontur import registry
    from kontur.grbl.session import Session
    from kontur.machine import Machine
    said = []
    grbl = Session(Machine(clock_hz=registry.board("ulx3s").clock_hz), "ulx3s", said.append)
    for line in ("$22=1", "$H"):
        said.clear()
        grbl.receive(line.encode() + b"\n")
        grbl.poll()
        assert said[-1] in ("error:3", "error:5") and "virtual machine has no limit switches" \
            in said[0], said
