"""ULX3S with the ECP5-85F (LFE5U-85F-6BG381C): the board's platform for the benchmarks.

Only the place-and-route benchmarks build for it: a ``shift_in`` resource for any
:class:`~hdl.top.ShiftInTop` on the first pins of the GPIO header (``gpio`` connector 0,
``0+``, ``0-``, ``1+``, ...), LVCMOS33. The board's clock is 25 MHz. Amaranth's ULX3S platform
asks for ``OPENFPGALOADER`` even when it only builds; :func:`bench_platform` never programs.
"""

from amaranth.build import Attrs
from amaranth_boards.ulx3s import ULX3S_85F_Platform

__all__ = ["ULX3S_85F_Platform", "FREE_PINS", "bench_platform"]

_GPIO = ("gpio", 0)

#: The pins a ``shift_in`` resource takes, in order: the GPIO header's pairs 0 to 13.
FREE_PINS = [ULX3S_85F_Platform().connectors[_GPIO].mapping[f"{n}{side}"]
             for n in range(14) for side in "+-"]


def bench_platform(top):
    """Return a new :class:`ULX3S_85F_Platform` with a ``shift_in`` resource for ``top``."""
    from .shift_in import resource
    board = ULX3S_85F_Platform()
    board.add_resources(resource(top, FREE_PINS, Attrs(IO_TYPE="LVCMOS33")))
    return board
