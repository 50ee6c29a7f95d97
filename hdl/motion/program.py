"""A program of frames in a ROM, offered as a stream in an endless loop."""

from amaranth import *
from amaranth.hdl import ShapeCastable
from amaranth.lib import data, stream, wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import Out

__all__ = ["ProgramROM", "check_program"]


def check_program(layout, program):
    """Raise unless ``program`` is a non-empty list of frames of ``layout`` (see
    :class:`ProgramROM`)."""
    if not isinstance(program, (list, tuple)) or not program:
        raise TypeError(f"Program must be a non-empty list of frames, not {program!r}")
    for frame in program:
        _check_frame(layout, frame)


def _check_frame(layout, frame):
    """Raise unless ``frame`` (a dict) is a payload of ``layout`` with every value in range."""
    if not isinstance(frame, dict):
        raise TypeError(f"A frame must be a dict of payload fields, not {frame!r}")
    fields = dict(layout)
    for name, value in frame.items():
        if name not in fields:
            raise ValueError(f"Frame {frame!r} has a field {name!r} that the payload "
                             f"({', '.join(fields)}) does not have")
        if not isinstance(value, int):
            raise TypeError(f"Frame field {name!r} must be an integer, not {value!r}")
        shape = fields[name].shape
        if not isinstance(shape, ShapeCastable):        # a plain shape: check the range here
            shape = Shape.cast(shape)
            low = -(1 << (shape.width - 1)) if shape.signed else 0
            high = (1 << (shape.width - shape.signed)) - 1
            if not low <= value <= high:
                raise ValueError(f"Frame field {name!r} = {value!r} does not fit {shape!r}")


class ProgramROM(wiring.Component):
    """Frames from a ROM, offered on :py:`o` one after the other, back to back, in a loop.

    The first frame is offered from the first clock after reset; each transfer offers the next
    one in the same clock; after the last comes the first again.

    Parameters
    ----------
    layout : :class:`~amaranth.lib.data.Layout`
        Layout of a frame.
    program : :class:`list` of :class:`dict`
        The frames, as payload dicts (field name to integer; a missing field is zero).

    Members
    -------
    o : :py:`Out(stream.Signature(layout))`
        The frames.

    Raises
    ------
    :exc:`TypeError`
        If ``program`` is not a non-empty list of dicts, or a value is not an integer.
    :exc:`ValueError`
        If a frame has a field the layout lacks or a value out of its field's range.
    """

    def __init__(self, layout, program):
        layout = data.Layout.cast(layout)
        check_program(layout, program)
        self._layout = layout
        self._program = [dict(frame) for frame in program]
        super().__init__({"o": Out(stream.Signature(layout))})

    @property
    def program(self):
        return [dict(frame) for frame in self._program]

    def elaborate(self, platform):
        m = Module()
        depth = len(self._program)
        m.submodules.rom = rom = Memory(shape=self._layout, depth=depth, init=self._program)
        read = rom.read_port()
        index = Signal(range(depth))
        primed = Signal()                    # the read port holds frame 0 (one clock after reset)
        accept = Signal()
        following = Mux(index == depth - 1, 0, index + 1)
        m.d.sync += primed.eq(1)
        m.d.comb += [
            accept.eq(self.o.valid & self.o.ready),
            read.addr.eq(Mux(accept, following, index)),
            self.o.valid.eq(primed),
            self.o.payload.eq(read.data),
        ]
        with m.If(accept):
            m.d.sync += index.eq(following)
        return m
