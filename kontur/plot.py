"""Plots: ``kontur trace profile ... --plot`` (the profile, its equidistant and the steps) and
``kontur run``'s ``toolpath.png``."""

import math
from dataclasses import replace

__all__ = ["plot_profile", "plot_toolpath", "decimate", "MAX_POINTS"]


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
    axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.05), ncol=3, fontsize="small")
    axes.set_title(title or f"radius {r}, {prepared.treatment} corners, {len(moves)} steps")
    figure.savefig(path, dpi=120, bbox_inches="tight")
    pyplot.close(figure)


#: Points a drawn collection holds at most: a path with more is decimated (:func:`decimate`)
#: before it is drawn; the figure, about 1000 pixels across, cannot show more.
MAX_POINTS = 4000


def decimate(points, limit=MAX_POINTS):
    """At most ``limit`` of ``points`` (a sequence of ``(x, y)``), the first and the last among
    them, in order: every ``k``-th point, ``k`` the smallest stride that keeps within the
    limit (all of them when they are few enough). Returns a list."""
    points = list(points)
    if len(points) <= limit:
        return points
    stride = -(-(len(points) - 1) // (limit - 1))
    kept = points[::stride]
    if kept[-1] != points[-1] or (len(points) - 1) % stride:
        kept.append(points[-1])
    return kept


def _polylines(paths, limit=MAX_POINTS):
    """Paths (lists of points) joined where one starts at the previous one's end, the whole
    decimated to about ``limit`` points: a list of polylines for one LineCollection."""
    joined = []
    for path in paths:
        if joined and joined[-1][-1] == path[0]:
            joined[-1].extend(path[1:])
        else:
            joined.append(list(path))
    total = sum(len(line) for line in joined)
    if total <= limit:
        return joined
    share = limit / total
    return [decimate(line, max(2, int(len(line) * share))) for line in joined]


def _move_path(move):
    """The move's path in XY: an arc of several turns (G2/G3 P) with its whole turns first; an
    arc in XZ or YZ (G18, G19) drawn in its plane and seen from above (its normal axis moving
    evenly along it)."""
    if move.kind == "arc" and (move.plane != 17 or move.turns > 1):
        from kontur.gcode import PLANE_AXES
        native = move.in_plane
        last = _move_path(replace(native, turns=1))
        centre = tuple(float(c) for c in native.centre)
        whole = _arc_points(centre, math.dist(last[0], centre), last[0], last[0], native.cw,
                            True)
        arc = whole * (move.turns - 1) + last
        if move.plane == 17:
            return arc
        c0, c1 = float(native.start_z), float(native.z)
        first, second, normal = PLANE_AXES[move.plane]
        out = []
        for i, point in enumerate(arc):
            p = [0.0] * 3
            p[first], p[second] = point
            p[normal] = c0 + (c1 - c0) * i / (len(arc) - 1)
            out.append((p[0], p[1]))
        return out
    start = tuple(float(c) for c in move.start)
    end = tuple(float(c) for c in move.end)
    if move.kind == "arc":
        centre = tuple(float(c) for c in move.centre)
        radius = math.hypot(start[0] - centre[0], start[1] - centre[1])
        return _arc_points(centre, radius, start, end, move.cw, start == end)
    return [start, end]


def tool_states(moves, events):
    """For each move, whether the spindle (laser, torch) is on as it runs: M3 or M4 in force
    (not yet M5) at a speed (power) above zero, as a laser in Grbl's laser mode. ``None`` for
    a program that never switches it."""
    switches = [e for e in events if e.kind in ("spindle", "speed")]
    if not any(e.kind == "spindle" for e in switches):
        return None
    states, on, speed, taken = [], False, None, 0
    for n in range(len(moves)):
        while taken < len(switches) and switches[taken].move <= n:
            event = switches[taken]
            if event.kind == "spindle":
                on = event.text[:2] in ("M3", "M4")
            if event.value is not None and (event.kind == "speed" or on):
                speed = event.value
            taken += 1
        states.append(on and (speed is None or speed > 0))
    return states


def plot_toolpath(job, steps, speeds, path, *, title=None):
    """``kontur run``'s ``toolpath.png``: the programmed contour (black; rapid moves dotted;
    in a program that switches the spindle, laser or torch, its feed moves with the tool off
    grey), the offset path of every compensated contour (its exact equidistant, blue,
    dashed), and the traced steps (a line through the points visited) coloured by the feed
    (mm/min), in millimetres. On a 3-axis board (steps ``(dx, dy, dz)``) a second view below
    shows Z (mm) against the steps, coloured by the feed likewise.

    Drawn in bounded time and memory whatever the program's length: one collection for each
    class (feed moves, rapid moves, offset paths, steps), each of at most about
    :data:`MAX_POINTS` points (decimated: the steps in runs of equal length, each run one
    segment coloured by its slowest feed), the legend in a fixed place below the axes."""
    import matplotlib
    matplotlib.use("Agg")
    import numpy
    from matplotlib import pyplot
    from matplotlib.collections import LineCollection

    spm = job.machine.steps_per_mm
    width = len(job.start)
    if width == 3:
        figure, (axes, z_axes) = pyplot.subplots(
            2, 1, figsize=(9, 10), gridspec_kw={"height_ratios": (4, 1)})
    else:
        figure, axes = pyplot.subplots(figsize=(9, 8))
        z_axes = None
    tool = tool_states(job.moves, getattr(job, "events", ()))
    for kind, style, colour, label in (
            ("feed", "-", "black", "programmed contour" if tool is None else
             "programmed contour, tool on (M3/M4)"),
            ("off", "-", "tab:gray", "feed moves, tool off"),
            ("rapid", ":", "black", "rapid moves")):
        paths = [_move_path(move) for n, move in enumerate(job.moves)
                 if move.kind != "dwell" and (move.kind == "rapid") == (kind == "rapid")
                 and (kind == "rapid" or tool is None or tool[n] == (kind == "feed"))]
        if paths:
            axes.add_collection(LineCollection(_polylines(paths), colors=colour,
                                               linewidths=1.2, linestyles=style, label=label))
    offsets = []
    for contour in getattr(job, "contours", ()):
        prepared = contour.prepared
        for piece in prepared.pieces:
            start = [float(c) / spm for c in contour.on_machine(piece.start)]
            end = [float(c) / spm for c in contour.on_machine(piece.end)]
            if piece.kind == "line":
                offsets.append([tuple(start), tuple(end)])
            else:
                centre = [float(c) / spm for c in contour.on_machine(piece.centre)]
                offsets.append(_arc_points(centre, float(piece.radius(prepared.radius)) / spm,
                                           start, end, piece.cw, piece.start == piece.end))
    if offsets:
        axes.add_collection(LineCollection(_polylines(offsets), colors="tab:blue",
                                           linestyles="--", linewidths=1,
                                           label="offset path"))
    import itertools
    moves = numpy.fromiter(itertools.chain.from_iterable(steps), dtype=numpy.int8,
                           count=width * len(steps)).reshape(-1, width)
    positions = numpy.cumsum(moves, axis=0, dtype=numpy.int64)
    del moves
    start = numpy.array([job.start], dtype=numpy.int64)
    points = numpy.vstack([start, start + positions[[-1]]]) / spm if len(steps) else start / spm
    if len(steps):
        stride = max(1, -(-len(steps) // MAX_POINTS))
        ends = numpy.append(numpy.arange(0, len(steps), stride), len(steps))
        kept = numpy.vstack([start, start + positions[ends[1:] - 1]]) / spm
        del positions
        segments = numpy.stack([kept[:-1, :2], kept[1:, :2]], axis=1)
        feed = numpy.nan_to_num(numpy.asarray(speeds, dtype=float), nan=0.0)
        colours = numpy.minimum.reduceat(feed, ends[:-1]) if len(feed) else \
            numpy.zeros(len(segments))
        lines = LineCollection(segments, cmap="viridis", linewidths=2.0)
        lines.set_array(colours)
        finite = feed[numpy.isfinite(numpy.asarray(speeds, dtype=float))] if len(feed) else feed
        if len(finite):
            lines.set_clim(0, finite.max())
        axes.add_collection(lines)
        figure.colorbar(lines, ax=axes, label="feed (mm/min)", shrink=0.8)
        if z_axes is not None:
            z_lines = LineCollection(numpy.stack([numpy.column_stack([ends[:-1], kept[:-1, 2]]),
                                                  numpy.column_stack([ends[1:], kept[1:, 2]])],
                                                 axis=1), cmap="viridis", linewidths=2.0)
            z_lines.set_array(colours)
            z_lines.set_clim(*lines.get_clim())
            z_axes.add_collection(z_lines)
    if z_axes is not None:
        z_axes.autoscale_view()
        z_axes.grid(True, linewidth=0.3)
        z_axes.set_xlabel("step")
        z_axes.set_ylabel("Z (mm)")
    axes.plot([points[0][0]], [points[0][1]], marker="o", color="tab:red", label="start")
    axes.plot([points[-1][0]], [points[-1][1]], marker="x", color="tab:red", label="end")
    axes.set_aspect("equal")
    axes.autoscale_view()
    axes.grid(True, linewidth=0.3)
    axes.set_xlabel("X (mm)")
    axes.set_ylabel("Y (mm)")
    axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=3, fontsize="small")
    axes.set_title(title or f"{len(steps)} steps")
    figure.savefig(path, dpi=120, bbox_inches="tight")
    pyplot.close(figure)
