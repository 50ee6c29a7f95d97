"""The interface every engine speaks (see docs/architecture.md), defined once."""

from amaranth.lib import stream
from amaranth.lib.wiring import In, Out

from .elements._checks import check_width

__all__ = ["engine_members", "frame_coord_width"]


def engine_members(frame_layout):
    """Signature members of an engine whose commands are ``frame_layout``.

    ``cmd``: the command stream; ``tick``: the feed-rate strobe; ``step``, ``dir``: per-axis
    step pulses and directions (bit 0 X, bit 1 Y; ``dir`` 1 = negative); ``busy``; ``done`` and
    ``error``: one of them pulses for every accepted command, in order.
    """
    return {
        "cmd":   In(stream.Signature(frame_layout)),
        "tick":  In(1),
        "step":  Out(2),
        "dir":   Out(2),
        "busy":  Out(1),
        "done":  Out(1),
        "error": Out(1),
    }


def frame_coord_width(width, coord_width):
    """Width of a frame's signed coordinates: ``coord_width``, by default ``max(32, width + 1)``.

    Raises :exc:`TypeError` if it is not an integer of at least 2, :exc:`ValueError` if it
    cannot hold every magnitude the ``width``-bit registers can.
    """
    if coord_width is None:
        coord_width = max(32, width + 1)
    check_width("Coordinate width", coord_width, minimum=2)
    if coord_width < width + 1:
        raise ValueError(f"Coordinate width must be at least {width + 1}, not {coord_width!r}")
    return coord_width
