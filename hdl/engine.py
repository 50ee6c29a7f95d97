"""The engine interface, defined once: motion, feed, outcomes, and the status unit.

Every engine (:class:`~hdl.line.LineEngine`, :class:`~hdl.arc.ArcEngine`, and any later one)
has the signature :class:`EngineSignature`: a command stream in, a feed interface, the motion
outputs, a status stream of outcomes, an abort input. A top level connects the pieces with
:func:`amaranth.lib.wiring.connect`: the motion outputs to a step/dir stage
(:class:`MotionSignature`), the feed interface to a feed generator (:class:`FeedSignature`).
"""

from amaranth import *
from amaranth.lib import data, enum, fifo, stream, wiring
from amaranth.lib.wiring import In, Out

from .elements._checks import check_width

__all__ = ["Outcome", "MotionSignature", "FeedSignature", "StatusLayout", "EngineSignature",
           "StatusUnit", "frame_coord_width", "permit"]


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

    Members
    -------
    tick : :py:`In(1)`
        Permission for one step.
    due : :py:`Out(1)`
        A step waits for permission.
    diagonal : :py:`Out(1)`
        The waiting step moves every axis (valid with :py:`due`).
    """

    def __init__(self):
        super().__init__({"tick": In(1), "due": Out(1), "diagonal": Out(1)})

    def __eq__(self, other):
        return type(other) is type(self)

    def __hash__(self):
        return hash(type(self))

    def __repr__(self):
        return "FeedSignature()"


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
    commands were accepted; an engine never loses an outcome: while its outcomes are not taken
    it stops taking commands. In a clock where :py:`abort` is high no step is made, the
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
    feed : :py:`Out(FeedSignature())`
        Step permission and the kind of the next step.
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
            "feed":   Out(FeedSignature()),
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
    """Outcomes of an engine's commands, numbered, positioned and queued on a status stream.

    Every front end reports through one of these. It counts the commands in flight (accepted,
    not ended), the steps of the running command on each axis (from the engine's own
    :py:`motion`), and queues the outcomes in a FIFO of ``depth`` entries that a consumer
    reads from :py:`status`. An outcome reported in a clock is offered on :py:`status` in that
    same clock when nothing is queued before it.

    No outcome is ever lost: :py:`room` is high only while the commands in flight and the
    outcomes queued, less the one transferred in this clock, are fewer than ``depth``; a front
    end takes a command only when :py:`room` is high. With the status stream always ready
    this never holds a command back for an engine that keeps at most ``depth`` commands in
    flight.

    Parameters
    ----------
    axes, position_width, number_width : :class:`int`
        As :class:`StatusLayout`.
    depth : :class:`int`
        Outcomes that can be queued.

    Members
    -------
    motion : :py:`In(MotionSignature(axes))`
        The engine's steps.
    accept : :py:`In(1)`
        A command is accepted in this clock.
    end : :py:`In(1)`
        A command ends in this clock with :py:`outcome`; its position is the steps counted
        since the previous end, this clock's included. It must not depend on :py:`room` in the
        same clock (:py:`room` counts the outcome transferred in this clock).
    outcome : :py:`In(Outcome)`
        Its outcome.
    flush : :py:`In(1)`
        Abort: every command in flight after this clock ends :attr:`Outcome.ABORTED` at
        position zero, one per clock from the next (as queue space allows).
    room : :py:`Out(1)`
        A command may be accepted in this clock.
    flushing : :py:`Out(1)`
        Aborted commands are still being reported.
    busy : :py:`Out(1)`
        A command is in flight or an outcome is queued.
    status : :py:`Out(stream.Signature(StatusLayout(...)))`
        The outcomes.

    Raises
    ------
    :exc:`TypeError`
        If a width, the axis count or the depth is not a positive integer.
    """

    def __init__(self, *, axes=2, position_width=32, number_width=8, depth=2):
        check_width("Status queue depth", depth)
        self._layout = StatusLayout(axes=axes, position_width=position_width,
                                    number_width=number_width)
        self._depth = depth
        super().__init__({
            "motion":   In(MotionSignature(axes)),
            "accept":   In(1),
            "end":      In(1),
            "outcome":  In(Outcome),
            "flush":    In(1),
            "room":     Out(1),
            "flushing": Out(1),
            "busy":     Out(1),
            "status":   Out(stream.Signature(self._layout)),
        })

    @property
    def layout(self):
        return self._layout

    @property
    def depth(self):
        return self._depth

    def elaborate(self, platform):
        m = Module()
        layout, depth = self._layout, self._depth
        axes, width = layout.axes, layout.position_width

        # Steps of the running command, per axis; what it reports includes this clock's step.
        moved = Signal(data.ArrayLayout(signed(width), axes))
        position = Signal(data.ArrayLayout(signed(width), axes))
        for axis in range(axes):
            delta = Mux(self.motion.step[axis], Mux(self.motion.dir[axis], -1, 1), 0)
            m.d.comb += position[axis].eq(moved[axis] + delta)
            m.d.sync += moved[axis].eq(Mux(self.end, 0, position[axis]))

        entry = data.StructLayout({"outcome": Outcome,
                                   "position": data.ArrayLayout(signed(width), axes)})
        m.submodules.queue = queue = fifo.SyncFIFO(width=entry.size, depth=depth)
        inflight = Signal(range(depth + 2))
        flushing = Signal()
        number = Signal(layout.number_width)

        flushed = Signal()                  # an aborted command reported by the flush
        write = Signal()
        event = Signal(entry)
        m.d.comb += [
            flushed.eq(flushing & (inflight != 0) & queue.w_rdy & ~self.end),
            write.eq(self.end | flushed),
            event.outcome.eq(Mux(self.end, self.outcome, Outcome.ABORTED)),
        ]
        with m.If(self.end):
            m.d.comb += event.position.eq(position)

        head = Signal(entry)
        bypass = Signal()                   # nothing queued: the new outcome goes straight out
        m.d.comb += [
            head.eq(queue.r_data),
            bypass.eq(~queue.r_rdy),
            self.status.valid.eq(queue.r_rdy | write),
            self.status.p.number.eq(number),
            self.status.p.outcome.eq(Mux(bypass, event.outcome, head.outcome)),
            self.status.p.position.eq(Mux(bypass, event.position, head.position)),
            queue.r_en.eq(self.status.ready),
            queue.w_data.eq(event),
            queue.w_en.eq(write & ~(bypass & self.status.ready)),
        ]
        transfer = self.status.valid & self.status.ready
        with m.If(transfer):
            m.d.sync += number.eq(number + 1)

        m.d.sync += inflight.eq(inflight + self.accept - write)
        with m.If(self.flush):
            m.d.sync += flushing.eq(1)
        with m.Elif(flushing & ((inflight == 0) | ((inflight == 1) & flushed))):
            m.d.sync += flushing.eq(0)

        m.d.comb += [
            self.room.eq(~flushing & (inflight + queue.level - transfer < depth)),
            self.flushing.eq(flushing),
            self.busy.eq((inflight != 0) | queue.r_rdy),
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


def permit(m, feed, *, armed, running, free=0, abort=0):
    """Turn a feed permission into the enable of a core's generator: one step per :py:`tick`.

    A core's generator (a :class:`~hdl.elements.PulseGenerator`, whose enable is the core's
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
