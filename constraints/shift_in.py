"""The ``shift_in`` resource of any :class:`~kontur.hdl.top.ShiftInTop`, on a board's free pins.

:class:`~kontur.hdl.top.ShiftInTop` has a member per port of the design it wraps (an engine, a core,
the bare accumulator); :class:`~kontur.hdl.top.PinnedTop` puts each member on the same-named
subsignal of a resource. :func:`resource` makes that resource for a given wrapper, taking the
board's pins in order, so that every design of the benchmarks fits the same boards.
"""

from amaranth.build import Pins, Resource, Subsignal
from amaranth.hdl import Shape
from amaranth.lib import wiring

__all__ = ["resource"]


def resource(top, pins, attrs, *, name="shift_in"):
    """Return ``[Resource(name, 0, ...)]`` with a subsignal per member of ``top``.

    ``pins`` is a list of the board's pin names, taken in order (a member ``n`` bits wide takes
    ``n``); ``attrs`` are the I/O attributes of every pin.

    Raises
    ------
    :exc:`TypeError`
        If ``top`` is not a component.
    :exc:`ValueError`
        If the board has too few pins for it.
    """
    if not isinstance(top, wiring.Component):
        raise TypeError(f"Top must be a wiring.Component, not {top!r}")
    needed = sum(Shape.cast(member.shape).width for member in top.signature.members.values())
    if needed > len(pins):
        raise ValueError(f"The design needs {needed} pins, the board has {len(pins)} for it")
    subsignals, taken = [], 0
    for member_name, member in top.signature.members.items():
        width = Shape.cast(member.shape).width
        direction = "i" if member.flow == wiring.In else "o"
        subsignals.append(Subsignal(member_name, Pins(" ".join(pins[taken:taken + width]),
                                                      dir=direction)))
        taken += width
    return [Resource(name, 0, *subsignals, attrs)]
