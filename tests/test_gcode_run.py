"""``kontur run`` of programs with the words real programs carry: Z refused with its line,
dwells timed as DWELL frames, tool events, pauses and messages in summary.json, the tool table's
radius for each contour (tests/test_gcode_rs274.py holds the reader against rs274)."""

import json
from pathlib import Path

import pytest

from kontur import registry
from kontur.cli import main
from kontur.machine import Machine
from kontur.machining import execute, prepare, summary
from kontur.planner import dwell_clocks

PROGRAMS = Path(__file__).resolve().parent / "programs" / "rs274"


def _run(tmp_path, capsys, *args):
    status = main(["run", *map(str, args), "--out", str(tmp_path / "out")])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_z_change_refused_with_its_line(tmp_path, capsys):
    status, out, err = _run(tmp_path, capsys, PROGRAMS / "zplunge.ngc")
    assert status == 2 and out == ""
    assert err.splitlines() == [f"kontur: {PROGRAMS / 'zplunge.ngc'}: line 5: Z moves need the "
                                f"third axis, which this board's controller does not have (the "
                                f"icebreaker-z's and the ulx3s's have it) (Z from 5 "
                                f"to -2 mm)"]


def test_tools_dwells_pauses_in_the_summary(tmp_path, capsys):
    status, out, err = _run(tmp_path, capsys, PROGRAMS / "tools.ngc")
    assert status == 0, err
    data = json.loads((tmp_path / "out" / "summary.json").read_text())
    # tools.ngc: G4 P0.5, G4 P1 and G4 P0 (lines 10, 13, 26); M0 at 19, M1 at 21.
    assert (data["dwells"], data["dwell_seconds"]) == (3, 1.5)
    assert [(p["line"], p["text"]) for p in data["pauses"]] == [(19, "M0"),
                                                                 (21, "M1 (optional stop)")]
    events = [(e["line"], e["kind"], e["text"]) for e in data["tool_events"]]
    assert events[:6] == [(5, "tool", "T1"), (5, "tool_change", "M6 T1"),
                          (6, "tool_length", "G43 H1"), (7, "speed", "S12000"),
                          (7, "spindle", "M3 S12000"), (8, "coolant", "M8")]
    assert (23, "tool_change", "M6 T2") in events and (22, "spindle", "M5") in events
    assert [m["text"] for m in data["messages"]] == [" tool 0.000000 selected 0.000000",
                                                     " load the 6 mm cutter"]
    assert "dwells     3 (G4, and the P of G82, G89), 1.5 s, as DWELL frames" in out
    assert "pause      line 19: M0, resumed at once (a simulated operator)" in out


@pytest.mark.parametrize("turns, said", [(1, "1 helix (HELIX"), (2, "2 helices (HELIX")])
def test_helices_counted_in_the_summary(tmp_path, capsys, turns, said):
    # Each G2 with Z is one HELIX frame: a quarter turn down 1 mm, twice or once.
    quarters = "".join(f"G2 X{x} Y{y} Z-{n + 1} I{i} J{j}\n" for n, (x, y, i, j) in
                       enumerate([(10, 0, 0, -10), (0, -10, -10, 0)][:turns]))
    program = tmp_path / "helix.ngc"
    program.write_text(f"G21 G90 G17 F600\nG0 X0 Y10 Z0\n{quarters}M2\n")
    status, out, err = _run(tmp_path, capsys, program, "--board", "ulx3s")
    assert status == 0, err
    assert f"steps move Z, {said}" in out


def test_dwell_in_the_plan_and_the_frames():
    board = registry.board("icebreaker")
    machine = Machine(clock_hz=board.clock_hz)
    plain = prepare("G1 X10 F600\nG1 Y10\n", machine=machine)
    dwelt = prepare("G1 X10 F600\nG4 P2.5\nG1 Y10\n", machine=machine)
    # The dwell adds its time, and the moves around it stop and start: no faster than the
    # program without it, which goes round the corner.
    assert dwelt.seconds >= plain.seconds + 2.5
    item = dwelt.items[[s.kind for s in dwelt.segments].index("dwell") - 1]
    assert item.exit <= (2 * machine.accel / machine.steps_per_mm) ** 0.5 + 1e-9
    times = execute(dwelt).times
    split = len(dwelt.segments[0].steps)
    assert times[split] - times[split - 1] > 2.5
    # A dwell longer than a DWELL frame's 32 bits of clocks is several frames.
    long = 2 * ((1 << 32) - 1) / machine.clock_hz + 1
    assert dwell_clocks(long, machine) == [(1 << 32) - 1] * 2 + [round(machine.clock_hz)]
    assert dwell_clocks(0, machine) == []


def test_tool_table_radius_for_each_contour(tmp_path, capsys):
    status, out, err = _run(tmp_path, capsys, PROGRAMS / "comp_table.ngc", "--board", "ulx3s",
                            "--tool-table", PROGRAMS / "tools.tbl", "--radius", "9")
    assert status == 0, err
    data = json.loads((tmp_path / "out" / "summary.json").read_text())
    # G41 D1: tool 1 (6 mm) before --radius; G42 with T2 loaded (3.175 mm); G41.1 D4.
    assert [(c["radius_mm"], c["radius_steps"], c["radius_from"]) for c in data["contours"]] == [
        (3.0, 240, "tool table: D1, diameter 6 mm"),
        (1.5875, 127, "tool table: the loaded tool T2, diameter 3.175 mm"),
        (2.0, 160, "G41.1 D4 (diameter, line 15)")]
    # Without the table: --radius for the first two, the program's G41.1 D for the third.
    status, out, err = _run(tmp_path, capsys, PROGRAMS / "comp_table.ngc", "--board", "ulx3s",
                            "--radius", "1")
    assert status == 0, err
    data = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert [c["radius_steps"] for c in data["contours"]] == [80, 80, 160]


@pytest.mark.parametrize("table, message", [
    ("T1 D3\nT1 D4\n", r"--tool-table: .*tools\.tbl:2: tool 1 given twice$"),
    ("X1\n", r"--tool-table: .*tools\.tbl:1: a tool line starts with T"),
])
def test_bad_tool_table(tmp_path, capsys, table, message):
    path = tmp_path / "tools.tbl"
    path.write_text(table)
    status, out, err = _run(tmp_path, capsys, PROGRAMS / "laser.ngc", "--tool-table", path)
    assert status == 2 and out == ""
    import re
    assert re.search(message, err.splitlines()[-1]), err


def test_machine_file_home_positions(tmp_path):
    machine = Machine(clock_hz=registry.board("icebreaker").clock_hz, g28_position=[5, 7],
                      g30_position=(1, 2, 0))
    job = prepare("G0 X1 Y1\nG28\nG30\n", machine=machine)
    assert [tuple(m.end) for m in job.moves] == [(1, 1), (1, 1), (5, 7), (5, 7), (1, 2)]
    path = tmp_path / "m.toml"
    path.write_text("g28_position = [1, 2, 3, 4]\n")
    from kontur.machine import MachineError
    with pytest.raises(MachineError, match=r"^g28_position must be \[X, Y\] or \[X, Y, Z\]"):
        Machine.from_toml(path, clock_hz=12e6)


def test_tool_on_and_off_moves():
    """toolpath.png greys the feed moves made with the tool off: in the LightBurn-style laser
    program, M4 with S0 switches nothing on, the two squares (lines 8-11 at S600, 13-16 at S300)
    are cut, the G1 S0 of line 18 is not; a program with no M3/M4/M5 has no tool states."""
    from kontur.gcode import read
    from kontur.plot import tool_states
    program = read((PROGRAMS / "laser.ngc").read_text(), units="mm")
    cut = {move.line for move, on in zip(program.moves,
                                         tool_states(program.moves, program.events))
           if on and move.kind != "rapid"}
    assert cut == {8, 9, 10, 11, 13, 14, 15, 16}
    plain = read("G21 G90\nG1 X1 F100\n", units="mm")
    assert tool_states(plain.moves, plain.events) is None
