"""``kontur bench accuracy``: trajectory error and clocks per step, measured on the golden models.

The RTL equals the models clock for clock (the test suite proves it), so these figures hold for
the RTL too. Every number is computed in the run that prints it.
"""

import math
import time

from . import registry
from .geometry import radial_error, walk
from .models.arc import round_sqrt
from .models.circular import native_path
from .models.linear import steps
from .stimulus import Job, record_moves, run_model

__all__ = ["main", "linear_table", "circular_table", "throughput_table"]


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
    out.write(f"\n(measured in {time.monotonic() - started:.1f} s)\n")
    return 0
