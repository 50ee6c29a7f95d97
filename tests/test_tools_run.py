"""Tool changes through `kontur run` on a board with tool outputs (issue 28): where the TOOL
frames go, judged by LinuxCNC's interpreter (``rs274 -g``: the spindle, speed and coolant
calls between its moves), the machine stopping for each, the RTL taking them, and the
refusals."""

import math
import re
from pathlib import Path

import pytest

from kontur.machine import Machine
from kontur.machining import execute, prepare, summary, summary_text
from kontur.planner import ProgramError
from kontur.rs274 import available, canonical

from .conftest import selected_simulators

PROGRAMS = Path(__file__).resolve().parent / "programs"
SPM = 80
ULX3S = Machine(clock_hz=12.5e6)

#: The rs274 calls that set the tool state (spindle, S, coolant), and how.
_CALLS = {
    "START_SPINDLE_CLOCKWISE": {"spindle": "cw"},
    "START_SPINDLE_COUNTERCLOCKWISE": {"spindle": "ccw"},
    "STOP_SPINDLE_TURNING": {"spindle": "off"},
    "MIST_ON": {"mist": True}, "MIST_OFF": {"mist": False},
    "FLOOD_ON": {"flood": True}, "FLOOD_OFF": {"flood": False},
}


def _pins(state):
    # What the pins show: S matters only while the spindle is on.
    return (state["spindle"], state["s"] if state["spindle"] != "off" else None,
            state["mist"], state["flood"])


def rs274_changes(text):
    """The tool changes rs274 makes between its moves: ``[(point in steps, pins)]``, a change
    where the pins' state before a move (or at the program's end, where LinuxCNC's M2 turns the
    spindle and coolant off) differs from the one before the move before."""
    _, _, run = canonical(text)
    assert run.returncode == 0, run.stderr
    state = {"spindle": "off", "s": 0, "mist": False, "flood": False}
    shown, here, out = _pins(state), (0, 0), []
    for line in run.stdout.splitlines():
        match = re.search(r"N\.+ (\w+)\((.*)\)", line)
        if not match:
            continue
        call, args = match.groups()
        if call in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED", "PROGRAM_END"):
            if call == "PROGRAM_END":
                state.update(spindle="off", mist=False, flood=False)
            if _pins(state) != shown:
                out.append((here, _pins(state)))
                shown = _pins(state)
            if call != "PROGRAM_END":
                x, y = (float(v) for v in args.split(",")[:2])
                here = (round(x * SPM), round(y * SPM))
        elif call == "SET_SPINDLE_SPEED":
            state["s"] = round(float(args.split(",")[1]))
        elif call in _CALLS:
            state.update(_CALLS[call])
    return out


def kontur_changes(job):
    return [(tuple(segment.start[:2]), _pins({**segment.payload["tool"],
                                   "spindle": segment.payload["tool"]["spindle"].name.lower()}))
            for segment in job.segments if "tool" in segment.payload]


PLASMA = """G21 G90 F1200
G0 X5 Y5
M3 S1000
G1 X40
G1 Y30
G1 X5
G1 Y5
M5
G0 X50 Y5
M7 M3 S400
G2 X70 Y5 I10 J0
M9
M2
"""


@pytest.mark.parametrize("name, text", [
    ("laser", (PROGRAMS / "rs274" / "laser.ngc").read_text()),
    ("plasma", PLASMA),
])
def test_changes_where_rs274_makes_them(name, text):
    assert available(), "rs274 is missing: run make setup"
    job = prepare(text, machine=ULX3S, board="ulx3s", name=name)
    expected = rs274_changes(text)
    assert len(expected) >= 3
    assert kontur_changes(job) == expected
    # The machine stops for each: the move before ends at rest (the plan's exit from which one
    # step stops it), the move after starts from rest.
    rest = math.sqrt(2 * ULX3S.accel / ULX3S.steps_per_mm) + 1e-9
    for n, segment in enumerate(job.segments):
        if "tool" in segment.payload:
            if n:
                assert job.items[n - 1].exit <= rest
            if n + 1 < len(job.segments):
                assert job.items[n + 1].entry == 0


def test_summary_and_on_verilator():
    text = PLASMA
    job = prepare(text, machine=ULX3S, board="ulx3s", name="plasma")
    data = summary(job, execute(job, "model"))
    assert [(f["line"], f["spindle"], f["s"], f["mist"]) for f in data["tool_frames"]] == \
        [(3, "cw", 1000, False), (8, "off", 1000, False), (10, "cw", 400, True),
         (12, "off", 400, False)]
    assert "4 TOOL frames to the tool outputs" in summary_text(data)
    if "verilator" not in selected_simulators():
        pytest.skip("SIM selects another simulator")
    result = execute(job, "verilator")     # every frame DONE, the steps the model's (checked)
    assert result.steps == job.steps and result.end == job.end


def test_no_tool_outputs_on_the_icebreaker():
    job = prepare(PLASMA, board="icebreaker", name="plasma")
    assert kontur_changes(job) == []
    data = summary(job, execute(job, "model"))
    assert data["tool_frames"] == []
    assert "not driven: the controller has no tool outputs" in summary_text(data)


#: tests/programs/comp/rrect_out_g42.ngc with M3/M5 put where ``{before}``, ``{inside}`` are.
CONTOUR = (PROGRAMS / "comp" / "rrect_out_g42.ngc").read_text() \
    .replace("G42.1 D6", "{before}G42.1 D6").replace("G3 X46.5637", "{inside}G3 X46.5637") \
    .replace("M2", "M5\nM2")


def test_a_change_inside_a_contour_is_refused():
    with pytest.raises(ProgramError) as error:
        prepare(CONTOUR.format(before="", inside="M3 S100\n"), machine=ULX3S, board="ulx3s")
    assert error.value.line == 7
    assert "inside the compensated contour of lines" in error.value.reason


def test_a_change_before_a_contour():
    job = prepare(CONTOUR.format(before="M3 S100\n", inside=""), machine=ULX3S, board="ulx3s")
    (contour,) = job.contours
    on, off = [n for n, s in enumerate(job.segments) if "tool" in s.payload]
    assert on < contour.first and off >= contour.first + contour.count
    assert job.segments[contour.first].kind == "profile"
    result = execute(job, "model")
    assert result.end == job.end


def test_send_streams_the_tool_frames():
    """`kontur send` to a board with tool outputs: M3 and M7 are honoured (not refused), the
    TOOL frames go in the stream between the moves, in the job's order."""
    from kontur.hdl.motion.tools import TOOL
    from kontur.send import send, unhonoured

    from .test_send import FakeMachine

    job = prepare(PLASMA, machine=ULX3S, board="ulx3s", name="plasma")
    assert unhonoured(job) is None
    frames, _ = job.frames()
    port = FakeMachine(ULX3S.queue_frames, axes=3)
    port.parser.lengths[TOOL] = 4
    assert send(job, port) == tuple(job.end)
    assert port.kinds == [frame[1] for frame in frames]
    assert port.kinds.count(TOOL) == 4
    # On the iCEBreaker M3 is still refused by kontur send.
    assert "no tool outputs" in unhonoured(prepare(PLASMA, board="icebreaker"))[1]
