"""``kontur bench accuracy``: trajectory error and clocks per step, measured on the golden models.

The RTL equals the models clock for clock (the test suite proves it), so these figures hold for
the RTL too. Every number is computed in the run that prints it.
"""

import math
import time

from kontur import registry
from kontur.sim.geometry import radial_error, segment_deviation, walk
from kontur.sim.models.arc import round_sqrt
from kontur.sim.models.circular import native_path
from kontur.sim.models.linear import steps
from kontur.sim.models.textbook import (lattice_line_steps, lattice_native_path, separate_line_steps,
                              separate_native_path)
from kontur.sim.stimulus import Job, record_moves, run_model

__all__ = ["main", "linear_table", "circular_table", "throughput_table", "line_comparison",
           "arc_comparison", "contour_speed", "reference_table", "SPEED_ANGLES",
           "COMPARISON_LINES", "COMPARISON_CIRCLES"]


def linear_table(limit=64):
    """Rows: variant, end points, worst deviation / bound, where, end points over the bound."""
    rows = []
    ends = [(x, y) for x in range(-limit, limit + 1) for y in range(-limit, limit + 1)
            if (x, y) != (0, 0)]
    for variant in ("exact", "device"):
        worst, where, over, dev_max = 0.0, None, 0, 0.0
        for x, y in ends:
            long = max(abs(x), abs(y))
            norm = math.hypot(x, y)
            ratio = dist = 0.0
            for px, py in walk((0, 0), steps(x, y, variant=variant)):
                cross = abs(px * y - py * x)
                ratio = max(ratio, 2 * cross / long)       # deviation / (0.5 cos α)
                dist = max(dist, cross / norm)
            over += ratio > 1
            dev_max = max(dev_max, dist)
            if ratio > worst:
                worst, where = ratio, (x, y)
        rows.append((variant, len(ends), dev_max, worst, where, over))
    return rows


def circular_table(limit=2000):
    """Rows: radii, worst radial error and its radius, over half a step."""
    rows = []
    worst = (0.0, None)
    for r in range(1, limit + 1):
        error = radial_error(native_path(r, 0, r * r), r * r)
        if error > worst[0]:
            worst = (error, r)
    rows.append((f"integer R = 1..{limit}, quadrant", limit, worst[0], worst[1]))
    worst = (0.0, None)
    count = 0
    for r2 in range(2, 4 * limit, 3):
        rn = round_sqrt(r2)
        error = radial_error(native_path(rn, 0, r2), r2)
        if error > worst[0]:
            worst = (error, f"sqrt({r2})")
        count += 1
    rows.append((f"r2 = 2..{4 * limit} step 3, quadrant", count, worst[0], worst[1]))
    return rows


def throughput_table():
    """Rows: engine, command, steps, clocks from first to last step, clocks per step."""
    rows = []
    line = Job(frames=[{"x": 1000, "y": 377}, {"x": -250, "y": 999}])
    for variant in ("exact", "device"):
        moves = record_moves(run_model(registry.make_model("line", variant), line))
        rows.append((f"line {variant}", "2 segments back to back", len(moves),
                     moves[-1][0] - moves[0][0] + 1))
    circle = Job(frames=[{"x0": 1000, "y0": 0, "x1": 1000, "y1": 0, "cw": 0}])
    arcs = Job(frames=[{"x0": 1000, "y0": 0, "x1": 0, "y1": 1000, "cw": 0},
                       {"x0": 0, "y0": 1000, "x1": -1000, "y1": 0, "cw": 0}])
    for variant in ("faithful", "fast"):
        for label, job in (("full circle R 1000", circle), ("2 quarter arcs back to back", arcs)):
            moves = record_moves(run_model(registry.make_model("arc", variant), job))
            rows.append((f"arc {variant}", label, len(moves), moves[-1][0] - moves[0][0] + 1))
    return rows


# ---- every variant on the same segments and arcs (the textbook's methods beside the patents) --

#: Segments of about 1000 steps in seven directions, 0° to 90°, and a few short ones: the
#: commands every line variant is timed on.
COMPARISON_LINES = [(1000, 0), (966, 259), (866, 500), (707, 707), (500, 866), (259, 966),
                    (0, 1000), (-3, 2), (17, -5), (-40, -41)]

#: Full circles every arc variant is timed on.
COMPARISON_CIRCLES = (10, 100, 500)

#: Directions of the contour-speed table, in degrees from the X axis.
SPEED_ANGLES = (0, 15, 30, 45, 60, 75, 90)


def _period(kind, name, frames, **params):
    """Clocks from the first outcome to the last of ``frames`` played back to back with a
    permission in every clock, and the steps made in between."""
    model = registry.make_model(kind, name, **params)
    record = run_model(model, Job(frames=frames, max_cycles=50_000_000))
    ends = [e["cycle"] for e in record if not e["rst"] and e["status"] is not None]
    steps = sum(1 for e in record if not e["rst"] and e["step"]
                and ends[0] < e["cycle"] <= ends[-1])
    return ends[-1] - ends[0], steps


def line_comparison(limit=64, names=None):
    """Rows per line variant (those of ``names``, every one without): max deviation over every
    end point with ``|X|, |Y| <= limit`` (step model), then steps and clocks per segment on
    :data:`COMPARISON_LINES` (cycle model, back to back, a permission in every clock)."""
    rows = []
    ends = [(x, y) for x in range(-limit, limit + 1) for y in range(-limit, limit + 1)
            if (x, y) != (0, 0)]
    for name in registry.variants("line") if names is None else names:
        worst = 0.0
        for x, y in ends:
            path = registry.steps("line", {"x": x, "y": y}, name)
            worst = max(worst, segment_deviation((0, 0), (x, y), walk((0, 0), path)))
        frames = [{"x": x, "y": y} for x, y in COMPARISON_LINES]
        clocks, moved = _period("line", name, frames[-1:] + frames)
        rows.append((name, len(ends), worst, moved / len(frames), clocks / len(frames),
                     clocks / moved))
    return rows


def arc_comparison(limit=500, names=None):
    """Rows per arc variant (those of ``names``, every one without): max radial error over the full circles of every integer radius up
    to ``limit`` (step model), then steps and clocks per circle on :data:`COMPARISON_CIRCLES`
    (cycle model, back to back, a permission in every clock)."""
    rows = []
    for name in registry.variants("arc") if names is None else names:
        worst = 0.0
        for r in range(1, limit + 1):
            frame = {"x0": r, "y0": 0, "x1": r, "y1": 0, "cw": 0}
            worst = max(worst, radial_error(walk((r, 0), registry.steps("arc", frame, name)),
                                            r * r))
        frames = [{"x0": r, "y0": 0, "x1": r, "y1": 0, "cw": r % 2}
                  for r in COMPARISON_CIRCLES]
        clocks, moved = _period("arc", name, frames[-1:] + frames)
        rows.append((name, limit, worst, moved / len(frames), clocks / len(frames),
                     clocks / moved))
    return rows


def contour_speed(length=1000, angles=SPEED_ANGLES, width=None):
    """Rows per line variant (and the DDA of fixed capacity ``2**width``): the contour speed
    of a segment ``length`` steps long in each direction of ``angles``, relative to the
    first, the spread (largest over smallest) and the speed in the first direction, in steps
    a clock. The speed is the segment's length over its clocks, back to back with a
    permission in every clock; ``width`` is the register width (the kind's default)."""
    rows = []
    segments = [(round(length * math.cos(math.radians(a))),
                 round(length * math.sin(math.radians(a)))) for a in angles]
    cases = []
    for name in registry.variants("line"):
        cases.append((name, {}))
        if name == "dda":                          # the text's DDA: one capacity for all
            cases.append((name, {"capacity": "register"}))
    for name, params in cases:
        speeds = []
        for x, y in segments:
            clocks, _ = _period("line", name, [{"x": x, "y": y}] * 2, width=width, **params)
            speeds.append(math.hypot(x, y) / clocks)
        label = name + (", capacity register" if params else "")
        rows.append((label, [v / speeds[0] for v in speeds], max(speeds) / min(speeds),
                     speeds[0]))
    return rows


def reference_table(limit=64, r2_limit=20000):
    """The text's rule taken literally (F at the point reached, not at the midpoint): the
    largest deviation of its lines with ``|X|, |Y| <= limit``, and how many quadrants from
    ``(Rn, 0)`` with ``r2 <= r2_limit`` end off the arc engine's axis point ``(0, Rn)``
    (against the same figures for the midpoint rule)."""
    ends = [(x, y) for x in range(-limit, limit + 1) for y in range(-limit, limit + 1)
            if (x, y) != (0, 0)]
    rows = []
    for label, line, quadrant in (
            ("F at the midpoint (cores)", separate_line_steps, separate_native_path),
            ("F at the point (reference)", lambda x, y, width=16: lattice_line_steps(x, y),
             lattice_native_path)):
        worst = max(segment_deviation((0, 0), (x, y), walk((0, 0), line(x, y)))
                    for x, y in ends)
        off = sum(quadrant(round_sqrt(r2), 0, r2)[-1] != (0, round_sqrt(r2))
                  for r2 in range(1, r2_limit + 1))
        rows.append((label, worst, off, r2_limit))
    return rows


def main(out):
    started = time.monotonic()
    out.write("Linear interpolator (SU 1571551), every end point with |X|, |Y| <= 64\n")
    out.write("deviation = distance of a visited point from the segment; bound = 0.5 cos α\n\n")
    out.write("variant  end points  max deviation  worst deviation/bound  at          "
              "over bound\n")
    for variant, count, dev, ratio, where, over in linear_table():
        out.write(f"{variant:<8} {count:10}  {dev:13.4f}  {ratio:21.4f}  {str(where):<10}  "
                  f"{over:10}\n")
    out.write("\nCircular interpolator (SU 1665343), radial error of every visited point\n\n")
    out.write("circles                              count  max radial error  at\n")
    for label, count, error, where in circular_table():
        out.write(f"{label:<36} {count:5}  {error:16.6f}  {where}\n")
    out.write("\nThroughput: clocks from the first step to the last (tick always high)\n\n")
    out.write("engine         command                       steps   clocks  clocks/step\n")
    for engine, label, n, clocks in throughput_table():
        out.write(f"{engine:<14} {label:<28} {n:6} {clocks:8}  {clocks / n:11.3f}\n")
    out.write("\nEvery variant on the same commands: the textbook's methods beside the patents\n"
              "deviation: max distance of a visited point from the segment, every end point "
              "with |X|, |Y| <= 64;\nsteps and clocks per segment: the segments of about 1000 "
              "steps at 0°, 15°, ... 90° and\n3 short ones, back to back, tick always high "
              "(cycle model)\n\n")
    out.write("line variant  end points  max deviation  steps/segment  clocks/segment  "
              "clocks/step\n")
    for name, count, worst, steps_per, clocks_per, per_step in line_comparison():
        out.write(f"{name:<12}  {count:10}  {worst:13.4f}  {steps_per:13.1f}  "
                  f"{clocks_per:14.1f}  {per_step:11.3f}\n")
    out.write("\nradial error: every full circle of integer radius R = 1..500; steps and clocks "
              "per circle:\nfull circles R = 10, 100, 500 back to back, tick always high "
              "(cycle model)\n\n")
    out.write("arc variant   circles  max radial error  steps/circle  clocks/circle  "
              "clocks/step\n")
    for name, count, worst, steps_per, clocks_per, per_step in arc_comparison():
        out.write(f"{name:<12}  {count:7}  {worst:16.4f}  {steps_per:12.1f}  "
                  f"{clocks_per:13.1f}  {per_step:11.3f}\n")
    out.write("\nContour speed of a segment 1000 steps long in each direction, relative to 0°"
              "\n(length over clocks, back to back, tick always high; the text: constant for "
              "the DDA,\n1 : sqrt(2) for the estimating function)\n\n")
    header = "".join(f"{a:>6}°" for a in SPEED_ANGLES)
    out.write(f"line variant            {header}  spread  steps/clock at 0°\n")
    for label, relative, spread, base in contour_speed():
        cells = "".join(f"{v:7.3f}" for v in relative)
        out.write(f"{label:<24}{cells}  {spread:6.3f}  {base:17.4f}\n")
    out.write("\nSeparate steps: the text's estimating function at the midpoint of the two "
              "candidate points\n(the cores) or at the point reached (the text taken "
              "literally, a reference)\n\n")
    out.write("rule                         line max deviation  quadrants off (0, Rn)\n")
    for label, worst, off, r2_limit in reference_table():
        out.write(f"{label:<29}{worst:18.4f}  {off:6} of r2 <= {r2_limit}\n")
    out.write(f"\n(measured in {time.monotonic() - started:.1f} s)\n")
    return 0
