"""Tool changes through `kontur run` on a board with tool outputs (issue 28): where the TOOL
frames go, judged by LinuxCNC's interpreter (``rs274 -g``: the spindle, speed and coolant
calls between its moves), the machine stopping for each, the RTL taking them, and the
refusals."""

import math
import re
from pathlib import Path

import pytest

from kontur import registry
from kontur.machine import Machine
from kontur.machining import execute, prepare, summary, summary_text
from kontur.planner import ProgramError, planned_feed
from kontur.rs274 import available, canonical

from .conftest import selected_simulators

PROGRAMS = Path(__file__).resolve().parent / "programs"
SPM = 80
ULX3S = Machine(clock_hz=registry.board("ulx3s").clock_hz)

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


def test_tool_outputs_on_the_icebreaker():
    """The iCEBreaker has the tool outputs too (issue 28): the TOOL frames go where rs274 makes
    the changes, as on the ULX3S; a board without them lists the tool words, not driven."""
    from dataclasses import replace
    job = prepare(PLASMA, board="icebreaker", name="plasma")
    assert kontur_changes(job) == rs274_changes(PLASMA)
    data = summary(job, execute(job, "model"))
    assert [(f["line"], f["spindle"], f["s"], f["mist"]) for f in data["tool_frames"]] == \
        [(3, "cw", 1000, False), (8, "off", 1000, False), (10, "cw", 400, True),
         (12, "off", 400, False)]
    assert "4 TOOL frames to the tool outputs" in summary_text(data)
    # Its tool outputs have the laser mode (since its arcs run on the bit-serial node): a
    # machine file's laser = true is taken, as on the ULX3S and the three-axis iCEBreaker;
    # on a board built without it, refused.
    from kontur.trace import UsageError
    for board in ("icebreaker", "icebreaker-z"):
        assert prepare(PLASMA, machine=Machine(clock_hz=12e6, laser=True),
                       board=board).machine.laser
    assert prepare(PLASMA, machine=LASER, board="ulx3s").machine.laser
    small = replace(registry.board("icebreaker"), name="small", laser_mode=False)
    with pytest.raises(UsageError, match="the small's tool outputs have no laser mode .*"
                                         "board with it: icebreaker, icebreaker-z, ulx3s$"):
        prepare(PLASMA, machine=Machine(clock_hz=12e6, laser=True), board=small)
    toolless = replace(registry.board("icebreaker"), tools=False)
    job = prepare(PLASMA, board=toolless, name="plasma")
    assert kontur_changes(job) == []
    data = summary(job, execute(job, "model"))
    assert data["tool_frames"] == []
    assert "not driven: the controller has no tool outputs" in summary_text(data)
    # A board with them, given tool words that switch nothing (G43.1), says so, not "none".
    job = prepare("G21 G43.1 Z0 G0 X1\nG49\nM2\n", board="icebreaker", name="tlo")
    text = summary_text(summary(job, execute(job, "model")))
    assert "no TOOL frame: none switches the tool outputs" in text


#: tests/programs/comp/rrect_out_g42.ngc with M3/M5 put where ``{before}``, ``{inside}`` are.
CONTOUR = (PROGRAMS / "comp" / "rrect_out_g42.ngc").read_text() \
    .replace("G42.1 D6", "{before}G42.1 D6").replace("G3 X46.5637", "{inside}G3 X46.5637") \
    .replace("M2", "M5\nM2")


#: A square cut outside (G42: convex corners, which LinuxCNC and the equidistant engine go
#: round on arcs of the cutter's radius) with the flood and the spindle switched at two of them.
SQUARE = """G21 G90 G17 F600
G0 X-10 Y-5
G42.1 D6 G1 X0 Y0
G1 X30 Y0
M8
G1 X30 Y20
M3 S200
G1 X0 Y20
G1 X0 Y0
G40 G1 X-10 Y-5
M5 M9
M2
"""


def _points_before(job, steps, which=lambda segment: "tool" in segment.payload):
    """Where the machine is (steps, from the steps made) when each segment ``which`` picks
    (a TOOL frame's, by default) takes effect."""
    x, y = job.start[:2]
    index, out = 0, []
    for segment in job.segments:
        if which(segment):
            out.append((x, y))
        for dx, dy, *_ in steps[index:index + len(segment.steps)]:
            x, y = x + dx, y + dy
        index += len(segment.steps)
    return out


@pytest.mark.parametrize("name, text", [("rrect", CONTOUR.format(before="", inside="M3 S100\n")),
                                        ("square", SQUARE)])
def test_a_change_inside_a_contour(name, text):
    """A spindle or coolant change between two compensated moves (LinuxCNC runs it): the TOOL
    frame goes between the equidistant engine's elements, and the machine is where rs274's
    compensated move before the change ends (within 1.5 steps: the lattice's rounding of the
    equidistant) when it takes effect, with rs274's pins; the machine stops for it; on
    Verilator the RTL makes the model's steps with every frame DONE."""
    assert available(), "rs274 is missing: run make setup"
    job = prepare(text, machine=ULX3S, board="ulx3s", name=name)
    (contour,) = job.contours
    tools = [n for n, s in enumerate(job.segments) if "tool" in s.payload]
    assert any(contour.first < n < contour.first + contour.count for n in tools)
    expected = rs274_changes(text)
    made = _points_before(job, job.steps)
    assert [pins for _, pins in kontur_changes(job)] == [pins for _, pins in expected]
    for (x, y), (point, _) in zip(made, expected):
        assert math.hypot(x - point[0], y - point[1]) <= 1.5, (made, expected)
    rest = math.sqrt(2 * ULX3S.accel / ULX3S.steps_per_mm) + 1e-9
    for n in tools:
        assert job.items[n - 1].exit <= rest
        assert n + 1 == len(job.segments) or job.items[n + 1].entry == 0
    if name == "square" or "verilator" not in selected_simulators():
        return
    result = execute(job, "verilator")     # every frame DONE, the steps the model's (checked)
    assert result.steps == job.steps and tuple(result.end) == tuple(job.end)


def test_a_dwell_inside_a_contour():
    """G4 between two compensated moves (LinuxCNC runs it; it was refused): a dwell segment
    between the equidistant engine's elements, the machine at rest around it, where the
    element before ends on its equidistant, the time waited; on Verilator the RTL's steps are
    the model's, every frame DONE."""
    text = CONTOUR.format(before="", inside="G4 P0.25\n")
    job = prepare(text, machine=ULX3S, board="ulx3s", name="dwell")
    (contour,) = job.contours
    (n,) = [n for n, s in enumerate(job.segments) if s.kind == "dwell" and s.payload["seconds"]]
    assert contour.first < n < contour.first + contour.count
    assert job.items[n - 1].exit <= math.sqrt(2 * ULX3S.accel / ULX3S.steps_per_mm) + 1e-9
    assert job.items[n + 1].entry == 0
    assert job.items[n].seconds == pytest.approx(0.25)
    plain = prepare(CONTOUR.format(before="", inside=""), machine=ULX3S, board="ulx3s")
    assert job.steps == plain.steps                  # the path is the contour's without it
    # Where it waits: within 1.5 steps of the end of rs274's compensated move before its DWELL.
    theirs, _, run = canonical(text)
    assert run.returncode == 0, run.stderr
    (k,) = [k for k, move in enumerate(theirs) if move["kind"] == "dwell"]
    (x, y), = _points_before(job, job.steps, lambda segment: segment is job.segments[n])
    ex, ey = (c * SPM for c in theirs[k - 1]["end"])
    assert math.hypot(x - ex, y - ey) <= 1.5
    if "verilator" not in selected_simulators():
        return
    result = execute(job, "verilator")
    assert result.steps == job.steps and tuple(result.end) == tuple(job.end)


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
    # The iCEBreaker has the tool outputs too (issue 28): M3 and M7 are honoured there; a
    # board without them refuses M3.
    from dataclasses import replace
    assert unhonoured(prepare(PLASMA, board="icebreaker")) is None
    toolless = replace(registry.board("icebreaker"), tools=False)
    assert "no tool outputs" in unhonoured(prepare(PLASMA, board=toolless))[1]


LASER = Machine(clock_hz=ULX3S.clock_hz, laser=True)


def rs274_laser_power(text):
    """The power a laser in Grbl's laser mode burns with in each of rs274's moves (of some
    length): ``[(end in steps, S)]``, S the speed rs274 has set while its spindle is on, in a feed move
    (STRAIGHT_FEED, ARC_FEED), 0 in a STRAIGHT_TRAVERSE (G0) or with the spindle off."""
    _, _, run = canonical(text)
    assert run.returncode == 0, run.stderr
    s, on, here, out = 0, False, (0, 0), []
    for line in run.stdout.splitlines():
        match = re.search(r"N\.+ (\w+)\((.*)\)", line)
        if not match:
            continue
        call, args = match.groups()
        if call in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED"):
            x, y = (float(v) for v in args.split(",")[:2])
            if (round(x * SPM), round(y * SPM)) != here:        # (none of no length)
                here = (round(x * SPM), round(y * SPM))
                out.append((here, s if on and call != "STRAIGHT_TRAVERSE" else 0))
        elif call == "SET_SPINDLE_SPEED":
            s = round(float(args.split(",")[1]))
        elif call.startswith("START_SPINDLE"):
            on = True
        elif call == "STOP_SPINDLE_TURNING":
            on = False
    return out


def kontur_laser_power(job):
    """The power of each of ``job``'s moves: the TOOL frame in force as it runs."""
    from kontur.hdl.motion.tools import Spindle
    state, out = None, []
    for segment in job.segments:
        if "tool" in segment.payload:
            state = segment.payload["tool"]
        elif segment.kind != "dwell":
            on = state is not None and state["spindle"] != Spindle.OFF
            out.append((tuple(segment.end[:2]), state["s"] if on else 0))
    return out


def test_laser_mode_as_grbl():
    """Grbl's laser mode (laser_mode.md) on the LightBurn-style laser.ngc: each move burns with
    the power rs274 has set for it, none in a G0 though M4 is on; the machine stops only for
    M4/M5 and M8/M9 (the move before ends at rest, the one after starts from it) and runs
    through every change of power alone (the plan's speed the same on both sides)."""
    assert available(), "rs274 is missing: run make setup"
    text = (PROGRAMS / "rs274" / "laser.ngc").read_text()
    job = prepare(text, machine=LASER, board="ulx3s", name="laser")
    assert kontur_laser_power(job) == rs274_laser_power(text)
    assert {power for _, power in kontur_laser_power(job)} == {0, 300, 600}
    rest = math.sqrt(2 * LASER.accel / LASER.steps_per_mm) + 1e-9
    stops = flying = 0
    before = {"spindle": None, "mist": None, "flood": None}
    for n, segment in enumerate(job.segments):
        if "tool" not in segment.payload:
            continue
        state = segment.payload["tool"]
        stop = any(state[key] != before[key] for key in before)
        before = {key: state[key] for key in before}
        assert segment.payload["stop"] == stop
        if stop:
            stops += 1
            assert n == 0 or job.items[n - 1].exit <= rest
            assert n + 1 == len(job.segments) or job.items[n + 1].entry == 0
        else:
            flying += 1
            assert job.items[n - 1].exit == job.items[n + 1].entry > 0      # the corner's
    assert (stops, flying) == (3, 3)       # M4 M8, M9, M5; S600, the G0 between, S300
    # The same program without laser mode stops for each of its changes, and the spindle
    # (a router's) turns in the G0s.
    plain = prepare(text, machine=ULX3S, board="ulx3s", name="laser")
    assert all(segment.payload["stop"] for segment in plain.segments if "tool" in
               segment.payload)
    assert plain.seconds > job.seconds
    assert execute(job, "model").end == job.end
    if "verilator" in selected_simulators():   # the RTL takes the changes on the fly too
        result = execute(job, "verilator")     # every frame DONE, the steps the model's
        assert result.steps == job.steps and result.end == job.end


def test_laser_raster_runs_through():
    """A raster row as image engravers write it, an S on every G1 along one line: in laser
    mode the row runs at its feed from end to end (no stop at a change), without it the
    machine stops at each, as Grbl and LinuxCNC do for a spindle."""
    row = "".join(f"G1 X{x} S{s}\n" for x, s in zip(range(2, 42, 2), [100, 800, 0, 450] * 5))
    text = f"G21 G90\nG0 X0 Y5\nM4 S0\nF1200\n{row}M5\nM2\n"
    job = prepare(text, machine=LASER, board="ulx3s", name="raster")
    lines = [item for s, item in zip(job.segments, job.items) if s.kind == "line"]
    # Up to speed within the first moves, down in the last: between, at the feed through
    # every change.
    middle = lines[4:-4]
    assert {(item.entry, item.cruise, item.exit) for item in middle} == \
        {(planned_feed(1200, LASER) / 60,) * 3}
    # The first power goes with M4 (a stop, the machine at rest there anyway), the other 19
    # on the fly.
    assert [s.payload["stop"] for s in job.segments if "tool" in s.payload] == \
        [True] + [False] * 19 + [True]
    plain = prepare(text, machine=ULX3S, board="ulx3s", name="raster")
    assert all(s.payload["stop"] for s in plain.segments if "tool" in s.payload)
    assert plain.seconds > 1.25 * job.seconds


#: Laser mode with M3 (constant power): each feed move's power its S, none in the G0.
CONSTANT = """G21 G90 F600
G0 X5 Y5
M3 S250
G1 X25
G1 Y15 S750
G0 X5 Y25
G1 X25 S500
M5
M2
"""


@pytest.mark.parametrize("board, spindle", [("ulx3s", 100), ("ulx3s", 50),
                                            ("icebreaker-z", 100)])
def test_the_pins_on_verilator(board, spindle):
    """The tool pins as the RTL drives them (Verilator, `fastrun` recording them): in each
    move, the PWM's share of high time is the S rs274 sets for it over s_max (laser mode, M3:
    constant power), none in the G0 though the laser stays enabled; all off after M5. With
    a spindle override of 50 % from the start (``--event spindle=50@0``: an OVERRIDE frame)
    half of it. On the ULX3S and the three-axis iCEBreaker (whose tool outputs have the laser
    mode too)."""
    if "verilator" not in selected_simulators():
        pytest.skip("SIM selects another simulator")
    from kontur.hdl.motion.tools import TOOL_PINS
    machine = Machine(clock_hz=registry.board(board).clock_hz, laser=True, pwm_hz=5000)
    job = prepare(CONSTANT, machine=machine, board=board, name="constant")
    events = [(0.0, f"spindle={spindle}")] if spindle != 100 else []
    result = execute(job, "verilator", events=events)
    assert result.steps == job.steps and result.tool_pins
    enable, pwm = (1 << TOOL_PINS.index(name) for name in ("enable", "pwm"))
    period = machine.pwm_period * result.compress / machine.clock_hz      # machining s

    def share(t0, t1, bit):
        """The time ``bit`` is high within [t0, t1], over t1 - t0."""
        high, level, since = 0.0, 0, t0
        for at, word in result.tool_pins + [(t1, 0)]:
            at = min(max(at, t0), t1)
            high += (at - since) * level
            level, since = bool(word & bit), at
        return high / (t1 - t0)

    expected = rs274_laser_power(CONSTANT)
    moves = [s for s in job.segments if s.kind != "dwell"]
    assert len(moves) == len(expected) == 5
    index = 0
    for n, (segment, (end, power)) in enumerate(zip(moves, expected)):
        assert tuple(segment.end[:2]) == end
        t0, t1 = result.times[index], result.times[index + len(segment.steps) - 1]
        index += len(segment.steps)
        assert t1 - t0 > 10 * period
        assert share(t0, t1, enable) == (0.0 if n == 0 else 1.0)     # M3 after the first
        assert share(t0, t1, pwm) == pytest.approx(power * spindle / 100 / machine.s_max,
                                                   abs=2 * period / (t1 - t0))
    assert result.tool_pins[-1][1] == 0                 # M5: everything off
