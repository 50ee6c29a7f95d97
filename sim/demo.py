"""``kontur demo``: the cores at work on a built-in program.

Every figure printed is measured in this run: the golden model and the RTL (Amaranth's
simulator, Icarus, Verilator) trace the same program and are compared clock for clock.
"""

import math
import time

from .models.linear import LineEngineModel
from .runners import ROOT, CocotbBuild, run_amaranth
from .stimulus import Job, first_difference, record_moves, record_steps, run_model

__all__ = ["demo", "ascii_plot", "deviation"]

# A closed octagon: one segment in each octant, chosen where the patent's device strays.
OCTAGON = [(14, 4), (9, 11), (-9, 11), (-14, 4), (-14, -4), (-9, -11), (9, -11), (14, -4)]


def deviation(start, end, points):
    """Largest distance, in steps, of ``points`` from the segment ``start``-``end``."""
    (x0, y0), (x1, y1) = start, end
    length = math.hypot(x1 - x0, y1 - y0)
    return max(abs((x - x0) * (y1 - y0) - (y - y0) * (x1 - x0)) / length for x, y in points)


def walk(start, moves):
    """Points visited from ``start`` by ``moves`` (``(dx, dy)`` pairs)."""
    x, y = start
    points = []
    for dx, dy in moves:
        x, y = x + dx, y + dy
        points.append((x, y))
    return points


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


def _line_section(out):
    frames = [{"x": x, "y": y} for x, y in OCTAGON]
    job = Job(frames=frames)
    out.write("SU 1571551 linear interpolator: an octagon, one segment in each octant\n\n")
    out.write("  segment    steps  clocks  max deviation (steps)     bound 0.5·cos α\n")
    out.write("                            exact      device\n")
    records = {v: run_model(LineEngineModel(variant=v), job) for v in ("exact", "device")}
    position = (0, 0)
    moves = {v: record_moves(records[v]) for v in records}
    index = {v: 0 for v in records}
    path = []
    for x, y in OCTAGON:
        end = (position[0] + x, position[1] + y)
        n = max(abs(x), abs(y))
        devs = {}
        for variant in ("exact", "device"):
            chunk = moves[variant][index[variant]:index[variant] + n]
            index[variant] += n
            points = walk(position, [(dx, dy) for _, dx, dy in chunk])
            devs[variant] = deviation(position, end, points)
            if variant == "exact":
                clocks = chunk[-1][0] - chunk[0][0] + 1
                path += points
        bound = 0.5 * n / math.hypot(x, y)
        out.write(f"  ({x:3}, {y:3})  {n:5}  {clocks:6}  {devs['exact']:9.3f}  "
                  f"{devs['device']:9.3f}   {bound:10.3f}\n")
        position = end
    out.write(f"\n  back at the start: {position == (0, 0)}; "
              f"one step per clock, no idle clock between segments\n\n")
    out.write(ascii_plot(path, {(0, 0): "o"}) + "\n\n")
    return job, records


def _rtl_checks(out, checks):
    out.write("RTL against the golden cycle model, clock for clock:\n")
    all_equal = True
    for label, make_engine, job, expected in checks:
        for simulator in ("amaranth", "icarus", "verilator"):
            started = time.monotonic()
            engine = make_engine()
            if simulator == "amaranth":
                actual = run_amaranth(engine, job)
            else:
                build = CocotbBuild(engine, simulator,
                                    ROOT / "build" / "demo" / simulator / label)
                actual = build.run(job, name="demo")
            difference = first_difference(expected, actual)
            all_equal &= difference is None
            verdict = "identical" if difference is None else f"DIFFERENT: {difference}"
            out.write(f"  {label:<22} {simulator:<10} {len(actual):6} clocks  {verdict}"
                      f"  ({time.monotonic() - started:.1f} s)\n")
    return all_equal


def demo(out):
    """Run the demo, writing to ``out``; return the exit status (0: everything agreed)."""
    import logging
    logging.getLogger().setLevel(logging.ERROR)
    from hdl.linear import LineEngine
    job, records = _line_section(out)
    checks = [(f"line-{variant}", (lambda v=variant: LineEngine(variant=v)), job,
               records[variant]) for variant in ("exact", "device")]
    ok = _rtl_checks(out, checks)
    out.write("\nall engines agree\n" if ok else "\nTHE ENGINES DISAGREE\n")
    return 0 if ok else 1
