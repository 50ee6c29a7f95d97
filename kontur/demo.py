"""``kontur demo``: the cores at work on a built-in program, and the machine controller on a
part program.

Every figure printed is measured in this run: the golden models and the RTL (Amaranth's
simulator, Icarus, Verilator) trace the same commands and are compared clock for clock; the
part programs run through the whole controller on Verilator: ``kontur/programs/bracket.ngc``
on the iCEBreaker's, and ``plate.ngc``, with cutter-radius compensation (G42), on the ULX3S's
(which has the equidistant engine); their plots, waveforms and summaries are written into
``build/demo/bracket/`` and ``build/demo/plate/``.
"""

import logging
import math
import time
from pathlib import Path

from kontur.hdl.spec import OCTAGON           # a closed octagon, one segment in each octant

from kontur import registry
from kontur.sim.geometry import radial_error, segment_deviation, walk
from kontur.sim.runners import ROOT, CocotbBuild, run_amaranth
from kontur.sim.stimulus import Job, first_difference, record_moves, run_model

__all__ = ["demo", "ascii_plot", "OCTAGON", "PROGRAM"]


# A slot with a round hole: lines and arcs, each command continuing from where the last ended.
# Lines are relative moves; arcs give the start and end relative to the centre.
PROGRAM = [
    ("line", {"x": 24, "y": 0}),
    ("arc", {"x0": 0, "y0": -7, "x1": 0, "y1": 7, "cw": 0}),      # right end, centre (24, 7)
    ("line", {"x": -24, "y": 0}),
    ("arc", {"x0": 0, "y0": 7, "x1": 0, "y1": -7, "cw": 0}),      # left end, centre (0, 7)
    ("line", {"x": 8, "y": 7}),                                    # to the hole
    ("arc", {"x0": -4, "y0": 0, "x1": -4, "y1": 0, "cw": 1}),     # hole, centre (12, 7)
    ("line", {"x": -8, "y": -7}),                                  # back home
]


def ascii_plot(points, marks=None):
    """Draw lattice ``points`` as ``#`` on a character grid (``marks``: point -> character)."""
    marks = marks or {}
    xs = [x for x, _ in points] + [x for x, _ in marks]
    ys = [y for _, y in points] + [y for _, y in marks]
    x_min, x_max, y_min, y_max = min(xs), max(xs), min(ys), max(ys)
    grid = [[" "] * (x_max - x_min + 1) for _ in range(y_max - y_min + 1)]
    for x, y in points:
        grid[y_max - y][x - x_min] = "#"
    for (x, y), char in marks.items():
        grid[y_max - y][x - x_min] = char
    return "\n".join(" ".join(row).rstrip() for row in grid)


def _moves_by_frame(record):
    """Split a record's moves per frame (a frame ends with ``done``)."""
    frames, current = [], []
    for entry in record:
        if entry["rst"]:
            continue
        if entry["step"]:
            current.append(record_moves([entry])[0])
        if entry["done"]:
            frames.append(current)
            current = []
    return frames


def _linear_section(out):
    job = Job(frames=[{"x": x, "y": y} for x, y in OCTAGON])
    records = {v: run_model(registry.make_model("line", v), job) for v in ("exact", "device")}
    out.write("1. SU 1571551 linear interpolator: an octagon, one segment in each octant\n\n")
    out.write("   segment    steps  clocks   max deviation (steps)   bound 0.5 cos α\n")
    out.write("                               exact     device\n")
    per_frame = {v: _moves_by_frame(records[v]) for v in records}
    position = (0, 0)
    for i, (x, y) in enumerate(OCTAGON):
        end = (position[0] + x, position[1] + y)
        devs = {v: segment_deviation(position, end, walk(position, [(dx, dy) for _, dx, dy in
                                                             per_frame[v][i]]))
                for v in records}
        moves = per_frame["exact"][i]
        bound = 0.5 * max(abs(x), abs(y)) / math.hypot(x, y)
        out.write(f"   ({x:3}, {y:3})  {len(moves):5}  {moves[-1][0] - moves[0][0] + 1:6}"
                  f"   {devs['exact']:7.3f}   {devs['device']:7.3f}      {bound:7.3f}\n")
        position = end
    out.write("\n   one step per clock, no idle clock between segments; the patent's device "
              "exceeds\n   the bound its own patent claims, equation (1) never does\n\n")
    return [(f"line-{v}", "line", v, job, records[v]) for v in ("exact", "device")]


def _circular_section(out):
    out.write("2. SU 1665343 circular interpolator: Table 2's radius, R = 12, a full circle\n\n")
    out.write("   variant    steps  clocks  clocks/step  max radial error\n")
    checks = []
    job = Job(frames=[{"x0": 12, "y0": 0, "x1": 12, "y1": 0, "cw": 0}])
    for variant in ("faithful", "fast"):
        record = run_model(registry.make_model("arc", variant), job)
        moves = record_moves(record)
        points = walk((12, 0), [(dx, dy) for _, dx, dy in moves])
        error = radial_error(points, 144)
        clocks = moves[-1][0] - moves[0][0] + 1
        out.write(f"   {variant:<9} {len(moves):6}  {clocks:6}  {clocks / len(moves):11.2f}"
                  f"  {error:16.3f}\n")
        checks.append((f"circle-{variant}", "arc", variant, job, record))
    out.write("\n   faithful: a step per generator period (4 clocks) and one period for each of\n"
              "   the 4 sector switch-overs; fast: one step per clock, switch-overs included\n\n")
    return checks


def _program_section(out):
    out.write("3. A program: a slot with a round hole, lines (exact) and arcs (faithful)\n\n")
    out.write("   command                                steps  max error (steps)\n")
    position = (0, 0)
    path = []
    line_frames, arc_frames = [], []
    for kind, payload in PROGRAM:
        if kind == "line":
            record = run_model(registry.make_model("line"), Job(frames=[payload]))
            end = (position[0] + payload["x"], position[1] + payload["y"])
            points = walk(position, [(dx, dy) for _, dx, dy in record_moves(record)])
            error = segment_deviation(position, end, points)
            text = f"line to ({payload['x']:+}, {payload['y']:+})"
            line_frames.append(payload)
        else:
            record = run_model(registry.make_model("arc"), Job(frames=[payload]))
            centre = (position[0] - payload["x0"], position[1] - payload["y0"])
            points = walk(position, [(dx, dy) for _, dx, dy in record_moves(record)])
            radius = math.hypot(payload["x0"], payload["y0"])
            error = radial_error(points, radius ** 2, centre)
            turn = "cw" if payload["cw"] else "ccw"
            text = (f"arc {turn} about ({centre[0]}, {centre[1]}), "
                    f"R {radius:g}" + (" (full circle)" if payload["x0"] == payload["x1"]
                                       and payload["y0"] == payload["y1"] else ""))
            arc_frames.append(payload)
        out.write(f"   {text:<38} {len(points):5}  {error:17.3f}\n")
        path += points
        position = points[-1]
    out.write(f"\n   back at the start: {position == (0, 0)}\n\n")
    out.write("   " + ascii_plot(path, {(0, 0): "o"}).replace("\n", "\n   ") + "\n\n")
    checks = []
    for variant in ("exact", "device"):
        job = Job(frames=line_frames)
        checks.append((f"program-lines-{variant}", "line", variant, job,
                       run_model(registry.make_model("line", variant), job)))
    for variant in ("faithful", "fast"):
        job = Job(frames=arc_frames)
        checks.append((f"program-arcs-{variant}", "arc", variant, job,
                       run_model(registry.make_model("arc", variant), job)))
    return checks


def _rtl_section(out, checks):
    out.write("4. The RTL against the golden cycle model, clock for clock\n\n")
    all_equal = True
    for label, kind, variant, job, expected in checks:
        row = []
        for simulator in ("amaranth", "icarus", "verilator"):
            started = time.monotonic()
            engine = registry.make_engine(kind, variant)
            if simulator == "amaranth":
                actual = run_amaranth(engine, job)
            else:
                build = CocotbBuild(engine, simulator, ROOT / "build" / "demo", quiet=True)
                actual = build.run(job)
            difference = first_difference(expected, actual)
            all_equal &= difference is None
            verdict = "same" if difference is None else f"DIFFERENT ({difference})"
            row.append(f"{simulator} {verdict} ({time.monotonic() - started:.1f} s)")
        out.write(f"   {label:<24} {len(expected):6} clocks: " + ", ".join(row) + "\n")
    return all_equal


def demo(out):
    """Run the demo, writing to ``out``; return the exit status (0: everything agreed)."""
    logging.getLogger().setLevel(logging.ERROR)
    checks = _linear_section(out)
    checks += _circular_section(out)
    checks += _program_section(out)
    ok = _rtl_section(out, checks)
    ok &= _controller_section(out)
    ok &= _controller_section(out, COMPENSATED, "ulx3s", number=6, radius=COMPENSATED_RADIUS)
    out.write("\nall engines agree with the golden models\n" if ok else
              "\nTHE ENGINES DISAGREE\n")
    return 0 if ok else 1


#: The demo's part program, and the clocks of its waveform (the first frames arriving and the
#: first moves: the whole run would be gigabytes).
PART = Path(__file__).resolve().parent / "programs" / "bracket.ngc"
PART_VCD_CLOCKS = 60_000
#: The compensated part (G42 around a plate's outline), and its cutter radius (mm), on the
#: board whose controller has the equidistant engine.
COMPENSATED = PART.parent / "plate.ngc"
COMPENSATED_RADIUS = 3


def _controller_section(out, program=PART, board="icebreaker", *, number=5, radius=None,
                        out_dir=None):
    """The machine controller on Verilator: a part program through ``board``'s whole top level
    (with cutter-radius compensation at ``radius`` mm when it is given)."""
    from kontur.machine import Machine
    from kontur.machining import RunError, execute, prepare, summary_text, write_outputs
    item = registry.board(board)
    out_dir = Path(out_dir or ROOT / "build" / "demo" / program.stem)
    what = "" if radius is None else f", cutter compensation at R{radius:g}"
    out.write(f"\n{number}. The machine controller: {program.name}{what}, G-code in, step/dir "
              f"out,\n   on the controller of the {item.help} in Verilator (frames over its "
              f"serial pin, checked against the models)\n\n")
    job = prepare(program.read_text(), name=program.name, board=board,
                  machine=Machine(clock_hz=item.clock_hz, cutter_radius=radius))
    out_dir.mkdir(parents=True, exist_ok=True)
    try:
        result = execute(job, "verilator", vcd=out_dir / "run.vcd",
                         vcd_clocks=PART_VCD_CLOCKS)
    except RunError as error:
        out.write(f"   THE CONTROLLER DISAGREES: {error}\n")
        return False
    data = write_outputs(job, result, out_dir)
    text = summary_text(data, out_dir)
    text += f"waveform   {out_dir / 'run.vcd'} (the first {PART_VCD_CLOCKS:,} clocks)\n"
    out.write("   " + text.rstrip("\n").replace("\n", "\n   ") + "\n")
    return True
