"""The engine interface, defined once: motion, feed, outcomes, and the status unit.

Every engine (:class:`~kontur.hdl.line.LineEngine`, :class:`~kontur.hdl.arc.ArcEngine`, and any later one)
has the signature :class:`EngineSignature`: a command stream in, a feed interface, the motion
outputs, a status stream of outcomes, an abort input. A top level connects the pieces with
:func:`amaranth.lib.wiring.connect`: the motion outputs to a step/dir stage
(:class:`MotionSignature`), the feed interface to a feed generator (:class:`FeedSignature`).
"""

from amaranth import *
from amaranth.lib import data, enum, stream, wiring
from amaranth.lib.wiring import In, Out

from .elements._checks import check_width

__all__ = ["Outcome", "MotionSignature", "FeedSignature", "StatusLayout", "EngineSignature",
           "StatusUnit", "frame_coord_width", "permit", "step_delta"]


class Outcome(enum.Enum, shape=2):
    """How a command ended; every accepted command ends with exactly one, in order."""
    #: Made: every step of the command (possibly none, for a zero-length move).
    DONE = 0
    #: Refused before any step (bad input): nothing moved.
    REFUSED = 1
    #: Stopped by ``abort`` at a step boundary (possibly before its first step).
    ABORTED = 2


class MotionSignature(wiring.Signature):
    """Step and direction per axis: what a step/dir stage takes from an engine.

    Parameters
    ----------
    axes : :class:`int`
        Number of axes.

    Members
    -------
    step : :py:`Out(axes)`
        One-clock step pulses, bit ``n`` for axis ``n`` (0: X, 1: Y).
    dir : :py:`Out(axes)`
        Directions, 1 for the negative direction; valid in every clock with a step on that
        axis.

    Raises
    ------
    :exc:`TypeError`
        If ``axes`` is not a positive integer.
    """

    def __init__(self, axes=2):
        check_width("Axis count", axes)
        self._axes = axes
        super().__init__({"step": Out(axes), "dir": Out(axes)})

    @property
    def axes(self):
        return self._axes

    def __eq__(self, other):
        return type(other) is type(self) and other.axes == self.axes

    def __hash__(self):
        return hash((type(self), self._axes))

    def __repr__(self):
        return f"MotionSignature({self._axes})"


class FeedSignature(wiring.Signature):
    """Feed interface: permission for steps one at a time, and what the next step will be.

    The engine raises :py:`due` while a step is waiting for its permission and shows on
    :py:`diagonal` whether that step moves every axis (a diagonal, ``√2`` steps long on two
    axes) or one; both are valid in the same clock, before the step is made. A step is made
    in exactly the clocks where :py:`tick` and :py:`due` are both high, and in no other: a
    feed generator raises :py:`tick` when the step's time has come (from :py:`diagonal` it
    knows its length) and holds it until :py:`due` takes it. Cores with a timing of their own
    (the faithful SU 1665343 core, four clocks a step) keep it inside: :py:`due` rises only
    when the core can make the step.

    With more than two axes a step is one of ``axes`` length classes (1, √2, √3 on three
    axes): :py:`diagonal` widens to the number of axes the waiting step moves beyond the first
    (0 for one axis, 1 for two, 2 for three). On two axes that is the one bit above, so a
    two-axis engine's feed interface is the same as before.

    Parameters
    ----------
    axes : :class:`int`
        Number of axes of the engine (at least 2).

    Members
    -------
    tick : :py:`In(1)`
        Permission for one step.
    due : :py:`Out(1)`
        A step waits for permission.
    diagonal : :py:`Out((axes - 1).bit_length())`
        The waiting step moves that many axes beyond one (valid with :py:`due`); on two axes,
        one bit: it moves every axis.
    """

    def __init__(self, axes=2):
        check_width("Axis count", axes, minimum=2)
        self._axes = axes
        super().__init__({"tick": In(1), "due": Out(1),
                          "diagonal": Out((axes - 1).bit_length())})

    @property
    def axes(self):
        return self._axes

    def __eq__(self, other):
        return type(other) is type(self) and other.axes == self.axes

    def __hash__(self):
        return hash((type(self), self._axes))

    def __repr__(self):
        return "FeedSignature()" if self._axes == 2 else f"FeedSignature({self._axes})"


class StatusLayout(data.StructLayout):
    """Payload of an engine's status stream: one transfer per accepted command, in order.

    Parameters
    ----------
    axes : :class:`int`
        Number of axes of :py:`position`.
    position_width : :class:`int`
        Width of each signed position coordinate.
    number_width : :class:`int`
        Width of :py:`number`.

    Fields
    ------
    number : :py:`unsigned(number_width)`
        The command's number: commands are numbered from 0 after reset in the order they were
        accepted (modulo ``2**number_width``).
    outcome : :class:`Outcome`
        How it ended.
    position : :py:`data.ArrayLayout(signed(position_width), axes)`
        Where it ended, in steps along each axis from where it started: the whole move for
        :attr:`Outcome.DONE`, zero for :attr:`Outcome.REFUSED`, the steps made before the stop
        for :attr:`Outcome.ABORTED`.
    """

    def __init__(self, *, axes=2, position_width=32, number_width=8):
        check_width("Axis count", axes)
        check_width("Position width", position_width, minimum=2)
        check_width("Command number width", number_width)
        self._axes = axes
        self._position_width = position_width
        self._number_width = number_width
        super().__init__({
            "number": unsigned(number_width),
            "outcome": Outcome,
            "position": data.ArrayLayout(signed(position_width), axes),
        })

    @property
    def axes(self):
        return self._axes

    @property
    def position_width(self):
        return self._position_width

    @property
    def number_width(self):
        return self._number_width

    def __repr__(self):
        return (f"StatusLayout(axes={self._axes}, position_width={self._position_width}, "
                f"number_width={self._number_width})")


class EngineSignature(wiring.Signature):
    """The interface every engine speaks.

    Commands arrive on :py:`cmd`, one per transfer; the engine takes a command while it can
    hold it (back-pressure otherwise). Steps are made one at a time under the feed interface's
    permission (:class:`FeedSignature`) and appear on :py:`motion` (:class:`MotionSignature`).
    Every accepted command ends with exactly one transfer on :py:`status`
    (:class:`StatusLayout`: its number, its :class:`Outcome`, where it ended), in the order the
    commands were accepted; an engine never loses an outcome: while one is not taken it makes
    no step and ends no command (the feed sees no step due). In a clock where :py:`abort` is
    high no step is made, the
    running command ends :attr:`~Outcome.ABORTED` where it is, and every command accepted
    before ends :attr:`~Outcome.ABORTED` with no step, one per clock after it; no command is
    taken until they have all ended.

    Parameters
    ----------
    frame : :class:`~amaranth.lib.data.Layout`
        Layout of a command.
    axes : :class:`int`
        Number of axes.
    position_width : :class:`int`
        Width of the status stream's position coordinates.
    number_width : :class:`int`
        Width of the status stream's command numbers.

    Members
    -------
    cmd : :py:`In(stream.Signature(frame))`
        Commands.
    feed : :py:`Out(FeedSignature(axes))`
        Step permission and the kind of the next step (its length class).
    motion : :py:`Out(MotionSignature(axes))`
        Step pulses and directions.
    status : :py:`Out(stream.Signature(StatusLayout(...)))`
        Outcomes.
    abort : :py:`In(1)`
        Stop now (see above).
    busy : :py:`Out(1)`
        A command has been accepted whose outcome has not been transferred yet.

    Raises
    ------
    :exc:`TypeError`
        If ``frame`` is not a data layout, or a width or the axis count not a positive
        integer (position width at least 2).
    """

    def __init__(self, frame, *, axes=2, position_width=32, number_width=8):
        try:
            frame = data.Layout.cast(frame)
        except TypeError:
            raise TypeError(f"Frame layout must be a data layout, not {frame!r}") from None
        status = StatusLayout(axes=axes, position_width=position_width,
                              number_width=number_width)
        self._frame = frame
        self._status_layout = status
        super().__init__({
            "cmd":    In(stream.Signature(frame)),
            "feed":   Out(FeedSignature(max(axes, 2))),
            "motion": Out(MotionSignature(axes)),
            "status": Out(stream.Signature(status)),
            "abort":  In(1),
            "busy":   Out(1),
        })

    @property
    def frame(self):
        return self._frame

    @property
    def status_layout(self):
        return self._status_layout

    @property
    def axes(self):
        return self._status_layout.axes

    @property
    def position_width(self):
        return self._status_layout.position_width

    @property
    def number_width(self):
        return self._status_layout.number_width

    def _params(self):
        return (self._frame, self.axes, self.position_width, self.number_width)

    def __eq__(self, other):
        return type(other) is type(self) and other._params() == self._params()

    def __hash__(self):
        return hash((type(self), self.axes, self.position_width, self.number_width))

    def __repr__(self):
        return (f"EngineSignature({self._frame!r}, axes={self.axes}, "
                f"position_width={self.position_width}, number_width={self.number_width})")


class StatusUnit(wiring.Component):
    """Outcomes of an engine's commands, numbered, with their positions, on a status stream.

    Every front end reports through one of these. It counts the commands in flight (accepted,
    not ended) and the steps of the running command on each axis (from the engine's own
    :py:`motion`); an outcome is offered on :py:`status` in the clock its command ends, with
    the steps counted, this clock's included. An outcome the consumer does not take in that
    clock waits in the unit, and the step counters wait with it: while it waits (:py:`hold`)
    the front end withholds every step and ends no command, so nothing can overtake it. Taking
    an outcome clears the counters for the next command. With the status stream always ready
    nothing is ever held back.

    Parameters
    ----------
    axes, position_width, number_width : :class:`int`
        As :class:`StatusLayout`.

    Members
    -------
    motion : :py:`In(MotionSignature(axes))`
        The engine's steps.
    accept : :py:`In(1)`
        A command is accepted in this clock.
    end : :py:`In(1)`
        A command ends in this clock with :py:`outcome` (never while :py:`hold` is high).
    outcome : :py:`In(Outcome)`
        Its outcome.
    flush : :py:`In(1)`
        Abort: every command in flight after this clock ends :attr:`Outcome.ABORTED`, one per
        clock from the next (once no outcome waits), each at the steps counted for it (the
        running command's, zero for those that never ran).
    hold : :py:`Out(1)`
        An outcome waits to be transferred: no step, no end.
    idle : :py:`Out(1)`
        No command in flight and no outcome waiting.
    alone : :py:`Out(1)`
        Exactly one command in flight and no outcome waiting.
    flushing : :py:`Out(1)`
        Aborted commands are still being reported.
    busy : :py:`Out(1)`
        A command is in flight or its outcome waits.
    status : :py:`Out(stream.Signature(StatusLayout(...)))`
        The outcomes.

    Raises
    ------
    :exc:`TypeError`
        If a width or the axis count is not a positive integer.
    """

    def __init__(self, *, axes=2, position_width=32, number_width=8):
        self._layout = StatusLayout(axes=axes, position_width=position_width,
                                    number_width=number_width)
        super().__init__({
            "motion":   In(MotionSignature(axes)),
            "accept":   In(1),
            "end":      In(1),
            "outcome":  In(Outcome),
            "flush":    In(1),
            "hold":     Out(1),
            "idle":     Out(1),
            "alone":    Out(1),
            "flushing": Out(1),
            "busy":     Out(1),
            "status":   Out(stream.Signature(self._layout)),
        })

    @property
    def layout(self):
        return self._layout

    def elaborate(self, platform):
        m = Module()
        layout = self._layout
        axes, width = layout.axes, layout.position_width

        # Steps of the running command per axis; what an outcome reports includes this
        # clock's step (there is none while an outcome waits). A transfer clears the counters
        # and counts the number up through a flip-flop (``taken``: the counters read zero in
        # the next clock, the number one more), so that the late decision to transfer reaches
        # one flip-flop, not the enables of every counter.
        taken = Signal()
        moved = Signal(data.ArrayLayout(signed(width), axes))
        position = Signal(data.ArrayLayout(signed(width), axes))
        for axis in range(axes):
            delta = step_delta(self.motion.step[axis], self.motion.dir[axis])
            m.d.comb += position[axis].eq(Mux(taken, 0, moved[axis]) + delta)

        waiting = Signal()                  # an outcome waits for the consumer
        waiting_outcome = Signal(Outcome)
        inflight = Signal(range(4))
        flushing = Signal()
        counted = Signal(layout.number_width)   # the number, less one after a transfer
        number = Signal(layout.number_width)
        m.d.comb += number.eq(counted + taken)
        flushed = Signal()                  # an aborted command reported by the flush
        event = Signal()
        event_outcome = Signal(Outcome)
        m.d.comb += [
            flushed.eq(flushing & (inflight != 0) & ~waiting & ~self.end),
            event.eq(self.end | flushed),
            event_outcome.eq(Mux(self.end, self.outcome, Outcome.ABORTED)),
            self.status.valid.eq(waiting | event),
            self.status.p.number.eq(number),
            self.status.p.outcome.eq(Mux(waiting, waiting_outcome, event_outcome)),
            self.status.p.position.eq(position),
        ]
        transfer = self.status.valid & self.status.ready
        m.d.sync += [taken.eq(transfer), counted.eq(number), moved.eq(position)]
        with m.If(transfer):
            m.d.sync += waiting.eq(0)
        with m.Elif(event):
            m.d.sync += [waiting.eq(1), waiting_outcome.eq(event_outcome)]

        m.d.sync += inflight.eq(inflight + self.accept - event)
        with m.If(self.flush):
            m.d.sync += flushing.eq(1)
        with m.Elif(flushing & ((inflight == 0) | ((inflight == 1) & flushed))):
            m.d.sync += flushing.eq(0)

        m.d.comb += [
            self.hold.eq(waiting),
            self.idle.eq((inflight == 0) & ~waiting),
            self.alone.eq((inflight == 1) & ~waiting),
            self.flushing.eq(flushing),
            self.busy.eq((inflight != 0) | waiting),
        ]
        return m


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


def step_delta(step, negative):
    """A step as a number in {-1, 0, +1}, from its :py:`step` and direction (:py:`negative`)
    bits (a position's change in a clock)."""
    return Mux(step, Mux(negative, -1, 1), 0)


def permit(m, feed, *, armed, running, free=0, abort=0):
    """Turn a feed permission into the enable of a core's generator: one step per :py:`tick`.

    A core's generator (a :class:`~kontur.hdl.elements.PulseGenerator`, whose enable is the core's
    own ``tick`` input) pulses on the first enabled clock of each period. Between permissions
    it waits there (``armed``); a permission (:py:`feed.tick` while :py:`feed.due`) enables it
    for the pulse, and it then runs freely through the rest of its period, so a core keeps its
    own timing inside a step. With a period of 1 the enable is the permission itself.
    ``running`` says the core steps at a pulse now; ``free`` lets the generator run through a
    pulse that makes no step (the faithful circular core's switch-over period) without waiting
    for a permission; ``abort`` withholds every pulse.

    Drives :py:`feed.due`; returns the enable.
    """
    enable = Signal()
    m.d.comb += [
        feed.due.eq(running & armed & ~abort),
        enable.eq(~abort & (~armed | feed.tick | free)),
    ]
    return enable
