"""T. Siimut's interpolator with transition to the equidistant (1963): the golden models.

Three levels, pure Python:

* **geometry** (:func:`profile_from_moves`, :func:`offset_path`): the part's profile (lines and
  arcs on the lattice, one side of compensation), its equidistant at the cutter radius ``r``
  and every corner of it, in exact rationals (square roots to ``2**-96``). Corners where the
  equidistants meet are their intersections (the seed's principle); convex corners are
  extended to the intersection of the equidistants (arcs extended along their tangents) or
  rounded by an arc of radius ``r`` around the profile's vertex (:data:`TREATMENTS`);
  impossible geometry is refused (:class:`ProfileError`, naming the program line).
* **host preparation** (:func:`prepare`): the frames of the hardware: per element the seed's
  numbers (``±k``, ``±b``, ``±1/cos α``, the coordinate-system flag, the direction flag) or an
  arc's centre, ``R²`` and ``2R``, in fixed point with :attr:`Formats.fraction` fractional
  bits; the radius and the start point.
* **step level** (:func:`trace`): the trajectory the hardware makes from those frames, every
  function evaluated afresh at every point (the hardware integrates them).

The cycle level (:class:`EquidistantEngineModel`) mirrors ``kontur.hdl.equidistant`` clock for clock.

One module each, every one importing only those before it: ``geometry`` (the profile, the
exact equidistant, its corners), ``elements`` (the hardware's elements), ``functions`` (the
formats, the functions, the frames), ``steps`` (the step level), ``distances`` (a trace
measured), ``preparation`` (:func:`prepare`), ``cycle`` (the cycle level). This package
re-exports their public names.

Functions of the hardware (the ``V`` of every element, exact integers):

* a line in the ``x, y`` system (``|k| <= 1``), ``s`` its minor direction (``-1`` when the
  direction flag is set): ``T = s·(k·x + b - y) + G·r`` scaled by ``2**F``, ``G = s·side·sec``,
  the deviation of the point from the equidistant along the minor axis; in the ``y, x`` system
  ``T = s·(k·y + b - x) - s·side·sec·r``. In the seed's terms ``T = E + C·x + D·y + G·r`` with
  Table 1's ``C = k, D = -1`` (``C = -1, D = k``) up to the sign ``s``.
* a circle: ``S = (x - x0)² + (y - y0)² - N``, ``N = R² + r² + σ·2R·r`` rounded to an integer,
  ``σ = +1`` where the cutter is outside the circle.
"""

from ..errors import InputError           # (importers take it from here)
from .cycle import EquidistantEngineModel
from .distances import (Report, check_trace, distance_to_path, distance_to_profile,
                        path_points)
from .elements import Element, elements
from .functions import (_FRAME_FIELDS, KIND, CircleFunction, Formats, LineFunction,
                        circle_function, element_frame, line_function)
from .geometry import (DETECTIONS, TREATMENTS, Piece, Profile, ProfileError, Segment,
                       offset_path, profile_from_moves)
from .preparation import PATH_BOUND, Prepared, prepare, program_frames
from .steps import frame_outcomes, trace, trace_elements

__all__ = ["ProfileError", "Segment", "Profile", "Formats", "TREATMENTS", "DETECTIONS", "KIND",
           "PATH_BOUND", "profile_from_moves", "offset_path", "Piece", "Element", "elements",
           "prepare", "program_frames", "Prepared", "frame_outcomes", "trace", "trace_elements",
           "line_function", "circle_function", "LineFunction", "CircleFunction",
           "distance_to_path", "distance_to_profile", "path_points", "check_trace", "Report",
           "EquidistantEngineModel"]
