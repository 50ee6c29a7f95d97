"""Line segments: the core signature every line interpolator has, and the engine around it."""

from amaranth import *
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from .elements import magnitude
from .elements._checks import check_width
from .engine import (EngineSignature, FeedSignature, Outcome, StatusUnit, frame_coord_width)

__all__ = ["LineCoreSignature", "LineEngine", "AXIS_NAMES"]

#: The frames' coordinate names, axis by axis.
AXIS_NAMES = ("x", "y", "z")


def _axis_names(axes):
    check_width("Axis count", axes, minimum=2)
    if axes > len(AXIS_NAMES):
        raise ValueError(f"Axis count must be at most {len(AXIS_NAMES)}, not {axes!r}")
    return AXIS_NAMES[:axes]


def _any(values):
    values = list(values)
    result = values[0]
    for value in values[1:]:
        result = result | value
    return result


def _all(values):
    values = list(values)
    result = values[0]
    for value in values[1:]:
        result = result & value
    return result


class LineCoreSignature(wiring.Signature):
    """What a line interpolator core offers its front end: magnitudes in, steps out.

    A core traces segments from the origin to ``(x, y)``, ``x, y >= 0``: its steps move X or
    Y (or both) up by one. It holds one segment prepared while another runs, so that segments
    follow one another with no idle clock.

    With ``axes=3`` a segment ends at ``(x, y, z)`` and a step moves any of the three axes
    up by one; :py:`feed` is then :py:`FeedSignature(3)`, whose ``diagonal`` counts the axes a
    step moves beyond the first.

    Parameters
    ----------
    width : :class:`int`
        Register width: magnitudes up to ``2**width - 1``.
    axes : :class:`int`
        Number of axes, 2 (X, Y) or 3 (X, Y, Z).

    Members
    -------
    cmd : :py:`In(stream.Signature(LineCoreSignature.Frame(width, axes)))`
        Segments, ``x`` and ``y`` (and ``z``) magnitudes. A segment transferred in clock ``k`` may start in
        clock ``k + 1`` at the earliest.
    feed : :py:`Out(FeedSignature())`
        Permission for each step (:class:`~kontur.hdl.engine.FeedSignature`).
    abort : :py:`In(1)`
        No step in this clock; the running segment ends (:py:`done`) and the prepared one is
        dropped.
    step : :py:`Out(axes)`
        Step pulses, bit 0 X, bit 1 Y, bit 2 Z.
    start : :py:`Out(1)`
        The prepared segment starts in this clock (its steps from the next clock; a segment of
        length zero ends in this same clock, with :py:`done`).
    done : :py:`Out(1)`
        The running segment ends in this clock (with its last step, if any).
    busy : :py:`Out(1)`
        A segment is prepared or running.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2.
    """

    @staticmethod
    def Frame(width, axes=2):
        return data.StructLayout({name: unsigned(width) for name in _axis_names(axes)})

    def __init__(self, width, axes=2):
        check_width("Register width", width, minimum=2)
        _axis_names(axes)
        self._width = width
        self._axes = axes
        super().__init__({
            "cmd":   In(stream.Signature(self.Frame(width, axes))),
            "feed":  Out(FeedSignature(axes)),
            "abort": In(1),
            "step":  Out(axes),
            "start": Out(1),
            "done":  Out(1),
            "busy":  Out(1),
        })

    @property
    def width(self):
        return self._width

    @property
    def axes(self):
        return self._axes

    def __eq__(self, other):
        return (type(other) is type(self) and other.width == self.width
                and other.axes == self.axes)

    def __hash__(self):
        return hash((type(self), self._width, self._axes))

    def __repr__(self):
        if self._axes == 2:
            return f"LineCoreSignature({self._width})"
        return f"LineCoreSignature({self._width}, axes={self._axes})"


class LineEngine(wiring.Component):
    """Signed line segments in, step/dir out: the front end of any line core.

    Each transfer on :py:`cmd` is one segment, relative to the current position: the end point
    ``(x, y)``. The front end takes it into a stage register as signs, magnitudes and checks,
    and hands the magnitudes to the core from there, in the next clock at the earliest; the
    signs become the directions from the segment's first step. Segments follow one another
    with no idle clock between the last step of one and the first step of the next (the stage
    and the core each hold one while another runs). A segment offered at clock ``k`` to an
    idle engine makes its first step at ``k + 3`` at the earliest.

    The engine has as many axes as its core (:py:`core.signature.axes`): a three-axis core
    makes a three-axis engine, whose segments end at ``(x, y, z)``.

    A segment with a magnitude above ``2**width - 1`` is refused (:attr:`~kontur.hdl.engine.Outcome.
    REFUSED`, nothing moves) from the stage, one clock after it is taken at the earliest; it
    leaves the stage, as does a segment of length zero, only when it is the one command in
    flight and no outcome waits, so outcomes stay in order. Everything else is the common
    interface (:class:`~kontur.hdl.engine.EngineSignature`): one outcome per segment on
    :py:`status`, with the steps made; :py:`abort`.

    Parameters
    ----------
    core : :class:`~amaranth.lib.wiring.Component`
        A line core, whose signature is a :class:`LineCoreSignature`. It becomes the submodule
        ``core``.
    coord_width : :class:`int`
        Width of the signed coordinates of a segment; default ``max(32, width + 1)``.

    Members
    -------
    cmd : :py:`In(stream.Signature(LineEngine.Frame(coord_width)))`
        Segments.
    feed, motion, status, abort, busy
        As :class:`~kontur.hdl.engine.EngineSignature`; status positions are ``width + 1`` bits.

    Raises
    ------
    :exc:`TypeError`
        If ``core`` is not a component with a :class:`LineCoreSignature`, or ``coord_width``
        not an integer of at least 2.
    :exc:`ValueError`
        If ``coord_width`` is smaller than ``width + 1``.
    """

    @staticmethod
    def Frame(coord_width, axes=2):
        return data.StructLayout({name: signed(coord_width) for name in _axis_names(axes)})

    def __init__(self, core, *, coord_width=None):
        if (not isinstance(core, wiring.Component)
                or not isinstance(core.signature, LineCoreSignature)):
            raise TypeError(f"Core must be a component with a LineCoreSignature, not {core!r}")
        width = core.signature.width
        self._coord_width = frame_coord_width(width, coord_width)
        self._core = core
        axes = core.signature.axes
        super().__init__(EngineSignature(self.Frame(self._coord_width, axes), axes=axes,
                                         position_width=width + 1))

    @property
    def core(self):
        return self._core

    @property
    def width(self):
        return self._core.signature.width

    @property
    def coord_width(self):
        return self._coord_width

    @property
    def axes(self):
        return self._core.signature.axes

    def elaborate(self, platform):
        m = Module()
        w = self.width
        m.submodules.core = core = self._core
        names = _axis_names(self.axes)
        m.submodules.status = status = StatusUnit(axes=self.axes, position_width=w + 1,
                                                  number_width=self.signature.number_width)

        coords = [self.cmd.payload[name] for name in names]

        # Every segment goes first into a stage register holding its magnitudes, its signs
        # and whether it is too wide or of length zero; from there a segment goes to the core,
        # a refused one to its outcome. So the magnitudes' carry chains and the checks are
        # never in one clock with the core's own preparation or with the decision to take the
        # next segment. A refused segment, or one of length zero (which ends without a step),
        # leaves the stage only when it is the one command in flight and no outcome waits, so
        # that its outcome follows the others'.
        staged = Signal()                     # the stage holds a segment
        stages = [Signal(w, name=f"stage_{name}", reset_less=True) for name in names]
        stage_dir = Signal(self.axes, reset_less=True)
        stage_zero = Signal(reset_less=True)
        stage_wide = Signal(reset_less=True)
        handover = Signal()
        refuse = Signal()
        m.d.comb += [
            core.cmd.valid.eq(staged & ~stage_wide & (~stage_zero | status.alone) & ~self.abort),
            *(core.cmd.payload[name].eq(stage) for name, stage in zip(names, stages)),
            handover.eq(core.cmd.valid & core.cmd.ready),
            refuse.eq(staged & stage_wide & status.alone & ~self.abort),
            self.cmd.ready.eq(~self.abort & ~status.flushing & (~staged | handover | refuse)),
        ]
        with m.If(self.cmd.valid & self.cmd.ready):
            m.d.sync += staged.eq(1)
        with m.Elif(handover | refuse | self.abort):
            m.d.sync += staged.eq(0)
        # The stage's registers follow cmd whenever it may be taken (``staged`` says whether
        # they count), so that their load enable does not wait for cmd.valid.
        magnitudes = [magnitude(m, coord, w) for coord in coords]
        with m.If(self.cmd.ready):
            m.d.sync += [
                *(stage.eq(value) for stage, (value, _) in zip(stages, magnitudes)),
                stage_dir.eq(Cat(*(coord[-1] for coord in coords))),
                stage_wide.eq(_any(beyond for _, beyond in magnitudes)),
                # The magnitudes' low bits are zero exactly when the coordinates' are.
                stage_zero.eq(_all(~coord[:w].any() for coord in coords)),
            ]

        # Directions: those of the prepared segment, from its start those of the running one.
        # A segment of length zero leaves them as they are.
        prepared_dir = Signal(self.axes)
        prepared_moves = Signal()
        direction = Signal(self.axes)
        with m.If(handover):
            m.d.sync += [
                prepared_dir.eq(stage_dir),
                prepared_moves.eq(~stage_zero),
            ]
        with m.If(core.start & prepared_moves):
            m.d.sync += direction.eq(prepared_dir)

        m.d.comb += [
            core.feed.tick.eq(self.feed.tick & ~status.hold),
            self.feed.due.eq(core.feed.due & ~status.hold),
            self.feed.diagonal.eq(core.feed.diagonal),
            core.abort.eq(self.abort),
            self.motion.step.eq(core.step),
            self.motion.dir.eq(direction),

            status.motion.step.eq(core.step),
            status.motion.dir.eq(direction),
            status.accept.eq(self.cmd.valid & self.cmd.ready),
            status.end.eq((core.done & ~self.abort) | refuse),
            status.outcome.eq(Mux(refuse, Outcome.REFUSED, Outcome.DONE)),
            status.flush.eq(self.abort),
            self.busy.eq(status.busy),
        ]
        wiring.connect(m, wiring.flipped(self.status), status.status)
        return m
