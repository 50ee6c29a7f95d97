"""Host preparation (:func:`prepare`): a profile checked at one cutter radius, its frames (the
radius, the start point, the program of :func:`program_frames`, the return), the start placed
where a closed contour closes, and the step level verified against the exact geometry
(:data:`PATH_BOUND`)."""

import math
from dataclasses import dataclass
from fractions import Fraction

from kontur.hdl.spec import Formats

from .distances import distance_to_path, distance_to_profile, path_points
from .elements import elements
from .functions import KIND, _round, element_frame
from .geometry import SMOOTH_GAP, Profile, ProfileError, _radius, _shown, _sqrt, offset_path
from .steps import trace_elements

__all__ = ["Prepared", "program_frames", "prepare", "PATH_BOUND", "NEAR_BOUND"]

_START_ROUNDS = 4                  # rounds of the search for a closed profile's start


@dataclass(frozen=True)
class Prepared:
    """A profile prepared for the hardware at one radius: ``frames`` (the radius, the start
    point, one per element, and the return to the start for a closed profile), the
    ``elements`` behind them, the ``start`` point, and the exact equidistant (``pieces``)."""
    profile: Profile
    radius: int
    treatment: str
    detection: str
    formats: Formats
    elements: tuple
    start: tuple
    pieces: tuple
    frames: tuple

    @property
    def closed(self):
        return self.profile.closed


def program_frames(profile, *, treatment="extend", detection="normal", formats=Formats()):
    """The frames of the profile's elements: the program, the same for every radius."""
    return [element_frame(e, formats)
            for e in elements(profile, treatment=treatment, detection=detection)]


def prepare(profile, radius, *, treatment="extend", detection="normal", formats=Formats(),
            verify=True):
    """Check ``profile`` at the cutter radius ``radius`` and prepare the hardware's frames.

    The element frames do not depend on the radius (:func:`program_frames`); the radius frame
    and the start point do: the start is the lattice point nearest where the equidistant
    begins (halves rounded up). ``radius`` (steps) is an integer or a rational (a
    :class:`~fractions.Fraction`: a radius in millimetres on a lattice of steps): the radius
    frame dials its whole steps (rounded down) and the rest is taken into the elements'
    frames (:func:`~.functions.element_frame`), so the path follows the equidistant at the
    whole radius, not at a radius up to half a step off; the frames of an integer radius are
    the program's (:func:`program_frames`).

    With ``verify`` (the default) the step level is run and every point the cutter's centre
    would visit is measured against the exact geometry: farther than :data:`PATH_BOUND` from
    the equidistant, or nearer the profile than ``radius - PATH_BOUND`` (where the
    equidistant of one part of the profile comes too near another: a slot narrower than the
    cutter; :data:`NEAR_BOUND`), and the profile is refused before anything moves.

    Raises
    ------
    ProfileError
        For impossible geometry (:func:`offset_path`), numbers beyond the formats (a
        coordinate or centre beyond ``±(2**width - 1)``, the radius beyond ``2**width - 1``,
        the cutter's path out of range), or
        a path that would leave the equidistant or cut into the part (``verify``).
    """
    limit = (1 << formats.width) - 1
    radius = _radius(radius)
    dial = math.floor(radius)            # the RADIUS frame's whole steps; the rest in the frames
    if radius > limit:
        raise ProfileError(f"the cutter radius {float(radius):g} is too wide for the "
                           f"{formats.width}-bit "
                           f"registers (at most {limit})")
    for seg in profile.segments:
        for name, point in (("start", seg.start), ("end", seg.end), ("centre", seg.centre)):
            if point is not None and max(abs(point[0]), abs(point[1])) > limit:
                raise ProfileError(f"line {seg.line}: the {name} {point} is beyond the "
                                   f"{formats.width}-bit registers (at most {limit})")
        if max(abs(seg.start[0]), abs(seg.start[1]), abs(seg.end[0]), abs(seg.end[1])) \
                + radius + 2 > limit:
            raise ProfileError(f"line {seg.line}: the cutter's path would leave the "
                               f"{formats.width}-bit registers (at most {limit}) here")
        if seg.kind == "arc":
            rho = _sqrt(seg.r2) + radius
            if max(abs(seg.centre[0]), abs(seg.centre[1])) + rho + 2 > limit:
                raise ProfileError(f"line {seg.line}: the cutter's path would leave the "
                                   f"{formats.width}-bit registers (at most {limit}) here")
    pieces = offset_path(profile, radius, treatment=treatment)
    found = tuple(elements(profile, treatment=treatment, detection=detection, radius=radius))
    body = [element_frame(e, formats, radius - dial) for e in found]

    def made(start):
        frames = [{"kind": KIND["radius"], "x": dial},
                  {"kind": KIND["start"], "x": start[0], "y": start[1]}, *body]
        if profile.closed:
            frames.append({"kind": KIND["close"]})
        return Prepared(profile, radius, treatment, detection, formats, found, start,
                        tuple(pieces), tuple(frames))

    # The start: where the equidistant begins, or with an entry move (``profile.lead``) where
    # its equidistant ends, at its corner with the first element of the part.
    first = pieces[0].start
    if profile.lead:                     # the end of the entry's own pieces (an arc's several)
        own = profile.segments[0].line
        for piece in pieces:
            if piece.line != own or piece.what not in ("line", "arc"):
                break
            first = piece.end
    start = tuple(_round(c) for c in first)
    prepared = made(start)
    # A closed profile starts where its last element ends (the corner it closes on), so that
    # the return to the start is empty: found by running the step level from the nearest
    # lattice point, at most a few times (it settles at once unless the first element is
    # too short to forget its start).
    for _ in range(_START_ROUNDS if profile.closed else 0):
        parts = trace_elements(prepared)
        end = path_points(start, [s for _, steps in parts[:-1] for s in steps])[-1]
        if end == start:
            break
        start = end
        prepared = made(start)
    if verify:
        _verify(prepared)
    return prepared


#: Every point the cutter's centre visits lies within this distance of the exact equidistant
#: (and no nearer the profile than the radius less it): checked on every profile prepared.
PATH_BOUND = Fraction(17, 20)
#: ... and no nearer the profile than the radius less this: the path's bound and the gap of a
#: joint tangent up to the lattice's rounding (:data:`~.geometry.SMOOTH_GAP`), where the
#: equidistant of one element runs up to that gap nearer the next than r.
NEAR_BOUND = PATH_BOUND + SMOOTH_GAP


def _verify(prepared):
    """Refuse a prepared profile whose trace leaves the equidistant or cuts into the part."""
    r = prepared.radius
    point = prepared.start
    for element, steps in trace_elements(prepared):
        line = element.line if element is not None else prepared.profile.segments[0].line
        for step in [None, *steps]:
            if step is not None:
                point = (point[0] + step[0], point[1] + step[1])
            off = distance_to_path(point, prepared.pieces, r)
            if off > PATH_BOUND:
                raise ProfileError(f"line {line}: the cutter's centre would pass {float(off):.3g}"
                                   f" steps from the equidistant at {point}: the interpolator "
                                   f"cannot follow this corner")
            near = distance_to_profile(point, prepared.profile)
            if near < r - NEAR_BOUND:
                seg = min(prepared.profile.part, key=lambda g: distance_to_profile(
                    point, Profile((g,), prepared.profile.side)))
                raise ProfileError(f"line {line}: the cutter (radius {_shown(r)}) would cut "
                                   f"{float(r - near):.3g} steps into the part at line "
                                   f"{seg.line} (its centre at {point})")
