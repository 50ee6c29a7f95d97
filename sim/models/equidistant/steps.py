"""The step level (:func:`frame_outcomes`, :func:`trace`): the trajectory the hardware makes
from the frames alone, every function evaluated afresh at every point from the frame's
numbers (the hardware integrates them)."""

from dataclasses import dataclass

from kontur.hdl.spec import Formats

from ..arc import real_step
from ..circular import native_moves
from ..errors import InputError
from .functions import (DONE_CODE, KIND, REFUSED_CODE, CircleFunction, LineFunction,
                        _frame_defaults, _native_start, line_step, threshold)

__all__ = ["frame_outcomes", "trace_elements", "trace"]


def _ends(target, h, point, tau2, r):
    return 2 * h * target.value(point, r) + tau2 >= 0


@dataclass(frozen=True)
class _Traced:
    """An element as its frame gives it to the step level."""
    kind: str
    own: object
    target: object              # the function that ends the element *before* this one
    h: int
    last: bool
    centre: tuple = None
    cw: bool = False


def _from_frame(frame, formats):
    one = formats.one
    if frame["kind"] == KIND["line"]:
        own = LineFunction(frame["swap"], frame["minor"], frame["k"], frame["b"], frame["sec"],
                           frame["side"] * frame["sec"], one)
        traced = dict(kind="line", own=own)
    else:
        sigma = 1 if (frame["side"] == 1) == bool(frame["cw"]) else -1
        own = CircleFunction((frame["x"], frame["y"]), frame["e"], frame["g"], sigma,
                             formats.fraction)
        traced = dict(kind="arc", own=own, centre=(frame["x"], frame["y"]),
                      cw=bool(frame["cw"]))
    target = own
    if frame["entry"]:
        target = LineFunction(frame["eswap"], frame["eminor"], frame["ek"], frame["eb"], 0,
                              frame["eg"], one)
    return _Traced(target=target, h=-1 if frame["h"] else 1, last=bool(frame["last"]),
                   **traced)


def _trace_contour(traced, point, r):
    """The steps of every element of a contour from ``point``: ``(steps per element,
    end point)``."""
    out = []
    for i in range(len(traced) - 1):
        element, after = traced[i], traced[i + 1]
        own, target, h = element.own, after.target, after.h
        steps = []

        def move(step):
            nonlocal point
            point = (point[0] + step[0], point[1] + step[1])
            steps.append(step)

        if element.kind == "line":
            while True:
                tau2 = threshold(target, element, own, point, r)
                if _ends(target, h, point, tau2, r):
                    break
                move(line_step(own, own.value(point, r)))
        else:
            n = own.n(r)
            ended = False
            while not ended:
                tau2 = threshold(target, element, own, point, r)
                if _ends(target, h, point, tau2, r) or n <= 0 or point == own.centre:
                    break
                q, (x, y) = _native_start(point, own.centre, element.cw)
                for kind, _ in native_moves(x, y, n):
                    tau2 = threshold(target, element, own, point, r)
                    if _ends(target, h, point, tau2, r):
                        ended = True
                        break
                    move(real_step(int(kind in "DX"), int(kind in "DY"), q, element.cw))
        out.append(steps)
    out.append([])                               # the terminal: aimed at, not traced
    return out, point


def frame_outcomes(frames, formats=None):
    """What the hardware makes of ``frames``, frame by frame (step level): a list of
    ``(outcome, steps)``, ``outcome`` 0 (done) or 1 (refused), as
    :class:`EquidistantEngineModel` and the RTL have them with no abort.

    Every function is evaluated afresh at every point from the frame's numbers (the
    hardware integrates them). Refused: an element with no contour open, an unknown kind, a
    negative radius.

    Raises
    ------
    InputError
        For a program the hardware would wait on for ever: a radius, start or return frame
        inside a contour (before its terminal), or a contour that never ends.
    """
    formats = formats or Formats()
    out = []
    r = 0
    point = start = (0, 0)
    contour = None                               # indices and elements of an open contour
    for frame in frames:
        frame = _frame_defaults(frame)
        kind = frame["kind"]
        if kind in (KIND["line"], KIND["arc"]):
            if contour is None:
                out.append((REFUSED_CODE, []))
                continue
            contour.append((len(out), _from_frame(frame, formats)))
            out.append(None)
            if frame["last"]:
                traced, point = _trace_contour([e for _, e in contour], point, r)
                for (index, _), steps in zip(contour, traced):
                    out[index] = (DONE_CODE, steps)
                contour = None
            continue
        if contour is not None and kind <= KIND["close"]:
            raise InputError("a radius, start or return frame inside a contour (before its "
                             "terminal): the engine would wait for ever")
        if kind > KIND["close"] or (kind == KIND["radius"] and frame["x"] < 0):
            out.append((REFUSED_CODE, []))
        elif kind == KIND["radius"]:
            r = frame["x"]
            out.append((DONE_CODE, []))
        elif kind == KIND["start"]:
            point = start = (frame["x"], frame["y"])
            contour = []
            out.append((DONE_CODE, []))
        else:
            steps = []
            while point != start:
                step = tuple((t > p) - (t < p) for p, t in zip(point, start))
                point = (point[0] + step[0], point[1] + step[1])
                steps.append(step)
            out.append((DONE_CODE, steps))
    if contour is not None and contour:
        raise InputError("the contour has no terminal frame: the engine would wait for ever")
    return out


def trace_elements(prepared):
    """The steps of every element of a prepared profile: a list of ``(element, steps)``,
    then ``(None, steps)`` for the return to the start of a closed profile."""
    outcomes = frame_outcomes(prepared.frames, prepared.formats)
    parts = [(element, steps) for element, (_, steps)
             in zip(prepared.elements, outcomes[2:2 + len(prepared.elements)])]
    parts = parts[:-1]                           # (the terminal makes no step)
    if prepared.closed:
        parts.append((None, outcomes[-1][1]))
    return parts


def trace(prepared):
    """The steps ``(dx, dy)`` of the cutter's centre from the start point (step level)."""
    return [step for _, steps in trace_elements(prepared) for step in steps]
