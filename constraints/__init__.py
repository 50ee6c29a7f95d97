"""Board platforms: ``amaranth_boards`` classes with the pin maps of kontur's tops.

Pin maps live here and only here; ``hdl/top.py`` requests resources by name.
"""

from . import icebreaker

__all__ = ["BOARDS", "platform"]

#: Board name to a function returning a new platform for it.
BOARDS = {
    "icebreaker": icebreaker.platform,
}


def platform(board):
    """Return a new platform for ``board`` (one of :data:`BOARDS`)."""
    if board not in BOARDS:
        options = ", ".join(repr(name) for name in BOARDS)
        raise ValueError(f"Board must be one of {options}, not {board!r}")
    return BOARDS[board]()
