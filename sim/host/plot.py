"""Plots: ``kontur trace profile ... --plot`` (the profile, its equidistant and the steps) and
``kontur run``'s ``toolpath.png``."""

import math

__all__ = ["plot_profile", "plot_toolpath"]


def _arc_points(centre, radius, start, end, cw, full):
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    a1 = math.atan2(end[1] - centre[1], end[0] - centre[0])
    if full:
        a1 = a0 + (-2 * math.pi if cw else 2 * math.pi)
    elif cw:
        while a1 >= a0:
            a1 -= 2 * math.pi
    else:
        while a1 <= a0:
            a1 += 2 * math.pi
    count = max(8, int(abs(a1 - a0) * max(radius, 1) / 2))
    return [(centre[0] + radius * math.cos(a0 + (a1 - a0) * i / count),
             centre[1] + radius * math.sin(a0 + (a1 - a0) * i / count))
            for i in range(count + 1)]


def plot_profile(prepared, moves, path, *, title=None):
    """Draw the profile (black), the exact equidistant (blue, dashed) and the traced path of
    the cutter's centre (red, a dot per step) into the PNG file ``path``."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib import pyplot

    figure, axes = pyplot.subplots(figsize=(8, 8))
    for seg in prepared.profile.segments:
        if seg.kind == "line":
            xs, ys = zip(seg.start, seg.end)
        else:
            radius = math.sqrt(seg.r2)
            xs, ys = zip(*_arc_points(seg.centre, radius, seg.start, seg.end, seg.cw,
                                      seg.start == seg.end))
        axes.plot(xs, ys, color="black", linewidth=1.5)
    r = prepared.radius
    for number, piece in enumerate(prepared.pieces):
        start = tuple(float(c) for c in piece.start)
        end = tuple(float(c) for c in piece.end)
        if piece.kind == "line":
            xs, ys = zip(start, end)
        else:
            xs, ys = zip(*_arc_points(piece.centre, float(piece.radius(r)), start, end,
                                      piece.cw, piece.start == piece.end))
        axes.plot(xs, ys, color="tab:blue", linestyle="--", linewidth=1,
                  label="equidistant" if number == 0 else None)
    x, y = prepared.start
    points = [(x, y)]
    for _, dx, dy in moves:
        x, y = x + dx, y + dy
        points.append((x, y))
    xs, ys = zip(*points)
    axes.plot(xs, ys, color="tab:red", linewidth=0.8, marker=".", markersize=3,
              label="cutter's centre")
    axes.plot([prepared.start[0]], [prepared.start[1]], marker="o", color="tab:red")
    axes.set_aspect("equal")
    axes.grid(True, linewidth=0.3)
    axes.legend(loc="best")
    axes.set_title(title or f"radius {r}, {prepared.treatment} corners, {len(moves)} steps")
    figure.savefig(path, dpi=120, bbox_inches="tight")
    pyplot.close(figure)


def plot_toolpath(job, steps, speeds, path, *, title=None):
    """``kontur run``'s ``toolpath.png``: the programmed contour (black; rapid moves dotted),
    the offset path of every compensated contour (its exact equidistant, blue, dashed), and
    the traced steps (a line through every point visited) coloured by the feed at each step
    (mm/min), in millimetres."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib import pyplot
    from matplotlib.collections import LineCollection

    spm = job.machine.steps_per_mm
    figure, axes = pyplot.subplots(figsize=(9, 8))
    for number, move in enumerate(job.moves):
        start = tuple(float(c) for c in move.start)
        end = tuple(float(c) for c in move.end)
        if move.kind == "arc":
            centre = tuple(float(c) for c in move.centre)
            radius = math.hypot(start[0] - centre[0], start[1] - centre[1])
            xs, ys = zip(*_arc_points(centre, radius, start, end, move.cw, start == end))
        else:
            xs, ys = zip(start, end)
        axes.plot(xs, ys, color="black", linewidth=1.2,
                  linestyle=":" if move.kind == "rapid" else "-",
                  label="programmed contour" if number == 0 else None)
    for number, contour in enumerate(getattr(job, "contours", ())):
        prepared = contour.prepared
        for index, piece in enumerate(prepared.pieces):
            start = [float(c) / spm for c in contour.on_machine(piece.start)]
            end = [float(c) / spm for c in contour.on_machine(piece.end)]
            if piece.kind == "line":
                xs, ys = zip(start, end)
            else:
                centre = [float(c) / spm for c in contour.on_machine(piece.centre)]
                xs, ys = zip(*_arc_points(centre, float(piece.radius(prepared.radius)) / spm,
                                          start, end, piece.cw, piece.start == piece.end))
            axes.plot(xs, ys, color="tab:blue", linestyle="--", linewidth=1,
                      label="offset path" if number == index == 0 else None)
    x, y = job.start
    points = [(x / spm, y / spm)]
    for dx, dy in steps:
        x, y = x + dx, y + dy
        points.append((x / spm, y / spm))
    if steps:
        segments = [[points[i], points[i + 1]] for i in range(len(steps))]
        finite = [v for v in speeds if v == v]
        lines = LineCollection(segments, cmap="viridis", linewidths=2.0)
        lines.set_array([v if v == v else 0.0 for v in speeds])
        if finite:
            lines.set_clim(0, max(finite))
        axes.add_collection(lines)
        figure.colorbar(lines, ax=axes, label="feed (mm/min)", shrink=0.8)
    axes.plot([points[0][0]], [points[0][1]], marker="o", color="tab:red", label="start")
    axes.plot([points[-1][0]], [points[-1][1]], marker="x", color="tab:red", label="end")
    axes.set_aspect("equal")
    axes.autoscale_view()
    axes.grid(True, linewidth=0.3)
    axes.set_xlabel("X (mm)")
    axes.set_ylabel("Y (mm)")
    axes.legend(loc="best")
    axes.set_title(title or f"{len(steps)} steps")
    figure.savefig(path, dpi=120, bbox_inches="tight")
    pyplot.close(figure)
