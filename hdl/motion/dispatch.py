"""The controller's insides: its engine table, the dispatcher, the turn queue and the replies.

:class:`~.controller.MotionController` joins these with :func:`amaranth.lib.wiring.connect`:

    FrameQueue.r ─► Dispatcher ─cmd─► engines (one per :class:`EngineUnit` of the table)
                        │ turn                │ feed, motion, status
                        ▼                     ▼
                    TurnQueue ◄───────────────┘ ─feed, ramp─► FeedGenerator
                        │ outcome             ─motion─► position, StepDirStage
                        ▼
      FrameDecoder.error, query, STATUS ─► Replies ─► FrameEncoder

The engines come from a table: every :class:`EngineUnit` names an engine, the number of its
turns, its frame type and how that frame's payload becomes the engine's command. Nothing else
in these components names an engine.
"""

from dataclasses import dataclass
from typing import Callable

from amaranth import *
from amaranth.lib import data, fifo, stream, wiring
from amaranth.lib.wiring import In, Out

from ..engine import FeedSignature, MotionSignature, Outcome
from .feed import Profile, RampSignature
from .link import CONFIG, DWELL, ERROR, FEED, OUTCOME, STATUS, FrameEncoder

__all__ = ["NONE_UNIT", "DWELL_UNIT", "Turn", "EngineUnit", "little", "raw_bits",
           "UnitSignature", "StatusFields", "Dispatcher", "TurnQueue", "Replies"]

#: Turns that are no engine's: nothing to move (FEED, STOP, CONFIG, an aborted frame), a dwell.
NONE_UNIT, DWELL_UNIT = 0, 3


def Turn(highest=DWELL_UNIT):
    """A queued frame's turn: which unit it runs on (``0`` to ``highest``), whether it was
    aborted before it ran or refused (taken in ALARM), and its argument (a move's feed
    profile, or a dwell's clocks)."""
    return data.StructLayout({"unit": unsigned(highest.bit_length()), "aborted": 1,
                              "refused": 1, "argument": Profile()})


def little(payload, first, count, *, signed_value=False):
    """Bytes ``first`` to ``first + count - 1`` of ``payload`` as one little-endian value."""
    value = Cat(*(payload[i] for i in range(first, first + count)))
    return value.as_signed() if signed_value else value


def raw_bits(cmd, payload):
    """The engine's command is the payload's bits as they came, least significant first (the
    PROFILE frame's decoding, and any engine's whose layout the host packs the same way)."""
    return [cmd.eq(payload.as_value()[:len(cmd.as_value())])]


@dataclass(frozen=True)
class EngineUnit:
    """One row of the controller's engine table.

    Attributes
    ----------
    name : :class:`str`
        The engine's submodule name (and its member in the components' signatures).
    unit : :class:`int`
        The number its turns carry: 1 or more, not :data:`DWELL_UNIT`.
    kind : :class:`int`
        The frame type that carries its commands (a queued type: one ``OUTCOME`` each).
    engine : :class:`~amaranth.lib.wiring.Component`
        The engine (:class:`~kontur.hdl.engine.EngineSignature`).
    length : :class:`int`
        The payload bytes of its frame.
    decode : callable
        ``decode(cmd, payload)``: the statements that form the engine's command ``cmd`` (a
        view of its frame layout) from ``payload`` (the frame's bytes, a view of
        ``data.ArrayLayout(8, n)``); :func:`raw_bits` by default.
    """
    name: str
    unit: int
    kind: int
    engine: object
    length: int
    decode: Callable = raw_bits


class UnitSignature(wiring.Signature):
    """An engine as the turn queue sees it: its :class:`~kontur.hdl.engine.EngineSignature` without the
    command stream (the dispatcher's) and ``busy``.

    Members
    -------
    feed : :py:`Out(FeedSignature(axes))`
    motion : :py:`Out(MotionSignature(axes))`
    status : :py:`Out(stream.Signature(status_layout))`
    abort : :py:`In(1)`
    """

    def __init__(self, status_layout, axes=2):
        super().__init__({
            "feed":   Out(FeedSignature(axes)),
            "motion": Out(MotionSignature(axes)),
            "status": Out(stream.Signature(status_layout)),
            "abort":  In(1),
        })

    @staticmethod
    def of(engine):
        """``engine`` seen through this signature (to :func:`~amaranth.lib.wiring.connect`)."""
        return _UnitPort(engine)


class _UnitPort:
    def __init__(self, engine):
        self.signature = UnitSignature(engine.signature.status_layout, engine.signature.axes)
        for name in self.signature.members:
            setattr(self, name, getattr(engine, name))


def StatusFields(axes=2):
    """The STATUS reply's fields that come from outside the replies: the position (``axes``
    of them), the free
    queue slots, whether a turn is queued or running; the state, the alarm's cause and the
    inputs active (their bytes, as the reply has them); whether the feed is held at a
    standstill, the feed generator's rate (Q0.24), the feed override (Q2.7) and the rapid
    override (percent)."""
    return data.StructLayout({"position": data.ArrayLayout(signed(32), axes), "free": 8,
                              "moving": 1, "state": 8, "cause": 8, "inputs": 8, "held": 1,
                              "rate": 24, "feed": 9, "rapid": 8})


class Dispatcher(wiring.Component):
    """Frames from the queue into the frame register, then each to its unit.

    The dispatcher reads a frame's type byte, then its payload, off the queue's byte stream
    :py:`r` into its frame register. A frame of an engine's type is offered on that engine's
    :py:`cmd` stream (decoded by its table row) while a turn can be written; it is taken, and
    its turn written on :py:`turn`, when the engine takes it. Any other frame is taken at once:
    FEED sets the profile of the turns after it, CONFIG :py:`accel`, DWELL's turn carries its
    clocks. After :py:`abort` every frame queued before it (in the queue, or being read) is
    taken without being offered, its turn marked aborted. While :py:`alarm` is high every
    other frame is taken without being offered too, its turn marked refused.

    Parameters
    ----------
    units : :class:`list` of :class:`EngineUnit`
        The engine table.
    lengths : :class:`dict`
        The payload length of every queued frame type.
    queue_frames : :class:`int`
        Frames the queue holds.

    Members
    -------
    r : :py:`In(stream.Signature(8))`
        The queue's committed bytes.
    commit : :py:`In(1)`
        A frame was committed into the queue in this clock.
    abort : :py:`In(1)`
        A checked ABORT frame ended in this clock.
    alarm : :py:`In(1)`
        The controller is in ALARM (or entering it): refuse the frames.
    cmd : :py:`Out(Signature({name: Out(stream.Signature(frame))}))`
        The engines' commands, one stream for each row of the table.
    turn : :py:`Out(stream.Signature(Turn(highest)))`
        The turns, one for each frame taken.
    accel : :py:`Out(32)`
        The acceleration (the last CONFIG's).
    free : :py:`Out(8)`
        Frames the queue can still take.
    pending : :py:`Out(1)`
        A frame is in the queue or the frame register.
    """

    def __init__(self, units, lengths, *, queue_frames):
        self._units = list(units)
        self._lengths = dict(lengths)
        self._queue_frames = queue_frames
        highest = max([DWELL_UNIT] + [unit.unit for unit in self._units])
        super().__init__({
            "r":       In(stream.Signature(8)),
            "commit":  In(1),
            "abort":   In(1),
            "alarm":   In(1),
            "cmd":     Out(wiring.Signature({
                unit.name: Out(stream.Signature(unit.engine.signature.frame))
                for unit in self._units})),
            "turn":    Out(stream.Signature(Turn(highest))),
            "accel":   Out(32),
            "free":    Out(8),
            "pending": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        r, turn = self.r, self.turn
        longest = max(self._lengths.values())
        kind = Signal(8)
        payload = Signal(data.ArrayLayout(8, longest))
        length = Signal(range(longest + 1))
        index = Signal(range(longest + 1))
        lengths = Signal(range(longest + 1))
        with m.Switch(r.payload):
            for frame_type, count in self._lengths.items():
                with m.Case(frame_type):
                    m.d.comb += lengths.eq(count)
        queued = Signal(range(self._queue_frames + 2))      # whole frames in the queue
        held = Signal()                                     # the frame register holds a frame
        take = Signal()
        frame_start = Signal()                              # a frame's type byte is read
        with m.FSM(name="dispatch"):
            with m.State("Kind"):
                m.d.comb += [r.ready.eq(1), frame_start.eq(r.valid)]
                with m.If(r.valid):
                    m.d.sync += [kind.eq(r.payload), length.eq(lengths), index.eq(0)]
                    m.next = "Payload"
            with m.State("Payload"):
                with m.If(index == length):
                    m.d.sync += held.eq(1)
                    m.next = "Ready"
                with m.Else():
                    m.d.comb += r.ready.eq(1)
                    with m.If(r.valid):
                        m.d.sync += [payload[index].eq(r.payload), index.eq(index + 1)]
            with m.State("Ready"):
                with m.If(take):
                    m.d.sync += held.eq(0)
                    m.next = "Kind"
        m.d.sync += queued.eq(queued + self.commit - frame_start)

        profile = Signal(Profile())                 # the last FEED's: for the next move
        flush = Signal(range(self._queue_frames + 3))   # frames before an abort still to end
        aborting = flush != 0
        unit = Signal(turn.payload.unit.shape())
        units = {DWELL: DWELL_UNIT} | {row.kind: row.unit for row in self._units}
        with m.Switch(kind):
            for frame_type in sorted(units):
                with m.Case(frame_type):
                    m.d.comb += unit.eq(units[frame_type])
        refusing = ~aborting & self.alarm
        # Nothing is handed over in an abort's clock: the frame waits, and is aborted next.
        offer = held & turn.ready & ~aborting & ~self.alarm & ~self.abort
        ready = C(1)
        for row in self._units:
            cmd = getattr(self.cmd, row.name)
            m.d.comb += row.decode(cmd.payload, payload)
            m.d.comb += cmd.valid.eq(offer & (unit == row.unit))
            ready = Mux(unit == row.unit, cmd.ready, ready)
        m.d.comb += [
            turn.valid.eq(held & ~self.abort & (aborting | self.alarm | ready)),
            take.eq(turn.valid & turn.ready),
            turn.payload.unit.eq(Mux(aborting | self.alarm, NONE_UNIT, unit)),
            turn.payload.aborted.eq(aborting),
            turn.payload.refused.eq(refusing),
            turn.payload.argument.eq(Mux(unit == DWELL_UNIT, little(payload, 0, 4), profile)),
        ]
        with m.If(take & ~aborting & ~self.alarm & (kind == FEED)):
            m.d.sync += profile.eq(little(payload, 0, 10))
        with m.If(take & ~aborting & ~self.alarm & (kind == CONFIG)):
            m.d.sync += self.accel.eq(little(payload, 0, 4))
        with m.If(self.abort):
            # The frames queued before the abort: those in the queue, and one being read or
            # held (none is taken in this clock).
            m.d.sync += flush.eq(queued + Mux(held | (index != length), 1, 0))
        with m.Elif(take & aborting):
            m.d.sync += flush.eq(flush - 1)
        m.d.comb += [
            self.free.eq(self._queue_frames - queued - held),   # a byte, as the protocol has it
            self.pending.eq(held | (queued != 0)),
        ]
        return m


class TurnQueue(wiring.Component):
    """The turns, in order: one unit moves at a time.

    Turns written on :py:`i` wait in a FIFO; the first is the current turn. Only the engine
    whose turn it is gets the feed's permissions (:py:`feed`, toward the feed generator, stands
    for that engine) and may end a command: its outcome goes out on :py:`outcome` and ends the
    turn. A dwell's turn ends after its clocks (or at :py:`abort`), any other turn at once,
    ``ABORTED`` if the dispatcher marked it so. A move's turn starts the feed generator's ramp
    toward its profile (:py:`ramp`); outside a move's turn the profile is zero (the rate ramps
    down to rest). At :py:`abort` every turn in the FIFO ends ``ABORTED`` (an engine's through
    the engine's abort). The engines' steps are merged on :py:`motion` (the directions of the engine
    whose turn it is, or of the table's first engine).

    Parameters
    ----------
    units : :class:`list` of :class:`EngineUnit`
        The engine table.
    axes : :class:`int`
        The controller's axes, 2 (default) or 3: a 2-axis engine's steps on three axes leave
        Z still (its diagonal, one bit, means the same there: √2).

    Members
    -------
    i : :py:`In(stream.Signature(Turn(highest)))`
        Turns from the dispatcher.
    units : :py:`In(Signature({name: Out(UnitSignature(...))}))`
        The engines, one for each row of the table.
    abort : :py:`In(1)`
        Stop now: to every engine, and the end of a dwell.
    outcome : :py:`Out(stream.Signature(Outcome))`
        The outcome of each turn, in order.
    feed : :py:`Out(FeedSignature(axes))`
        To the feed generator: the engine whose turn it is.
    ramp : :py:`Out(RampSignature())`
        To the feed generator (:class:`~.feed.RampSignature`): the running move's profile,
        and its start.
    motion : :py:`Out(MotionSignature(axes))`
        The engines' steps.
    busy : :py:`Out(1)`
        A turn is queued or running.
    """

    def __init__(self, units, axes=2):
        self._units = list(units)
        highest = max([DWELL_UNIT] + [unit.unit for unit in self._units])
        self._layout = Turn(highest)
        super().__init__({
            "i":       In(stream.Signature(self._layout)),
            "units":   In(wiring.Signature({
                unit.name: Out(UnitSignature(unit.engine.signature.status_layout,
                                             unit.engine.signature.axes))
                for unit in self._units})),
            "abort":   In(1),
            "outcome": Out(stream.Signature(Outcome)),
            "feed":    Out(FeedSignature(axes)),
            "ramp":    Out(RampSignature()),
            "motion":  Out(MotionSignature(axes)),
            "busy":    Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        layout = self._layout
        m.submodules.fifo = turns = fifo.SyncFIFOBuffered(width=layout.size, depth=16)
        wiring.connect(m, wiring.flipped(self.i), turns.w_stream)
        current = layout(turns.r_data)
        turn = Signal(layout["unit"].shape)
        m.d.comb += turn.eq(Mux(turns.r_rdy, current.unit, NONE_UNIT))
        started = Signal()
        first = turns.r_rdy & ~started
        room = self.outcome.ready
        rows = [(row.unit, getattr(self.units, row.name)) for row in self._units]
        dwell_left = Signal(32)
        flush = Signal(range(turns.depth + 2))
        flushing = flush != 0
        stopped = self.abort | flushing
        for number, port in rows:
            m.d.comb += [port.status.ready.eq(room & (turn == number)),
                         port.abort.eq(self.abort)]
        with m.Switch(turn):
            for number, port in rows:
                with m.Case(number):
                    m.d.comb += [self.outcome.valid.eq(port.status.valid),
                                 self.outcome.payload.eq(port.status.payload.outcome)]
            with m.Case(DWELL_UNIT):
                m.d.comb += [
                    self.outcome.valid.eq(started & ((dwell_left == 0) | stopped)),
                    self.outcome.payload.eq(Mux(stopped, Outcome.ABORTED, Outcome.DONE)),
                ]
            with m.Default():
                m.d.comb += [
                    self.outcome.valid.eq(turns.r_rdy),
                    self.outcome.payload.eq(
                        Mux(current.refused & ~flushing, Outcome.REFUSED,
                            Mux(current.aborted | flushing, Outcome.ABORTED, Outcome.DONE))),
                ]
        complete = self.outcome.valid & self.outcome.ready
        # An abort ends every turn queued before it ABORTED (an engine's by the engine's abort,
        # the others here): those in the FIFO (the dispatcher writes none in that clock).
        with m.If(self.abort):
            m.d.sync += flush.eq(turns.r_level)
        with m.Elif(complete & flushing):
            m.d.sync += flush.eq(flush - 1)
        m.d.comb += turns.r_en.eq(complete)
        with m.If(complete):
            m.d.sync += started.eq(0)
        with m.Elif(turns.r_rdy):
            m.d.sync += started.eq(1)
        with m.If(first):
            m.d.sync += dwell_left.eq(current.argument.as_value()[:32])
        with m.Elif(dwell_left != 0):
            m.d.sync += dwell_left.eq(dwell_left - 1)

        # The feed: permissions for the engine whose turn it is. Every engine's turn is a
        # move's: its FEED's profile, a ramp from the rate the turn before ended at (a frame
        # without steps holds the rate: the host sends it a FEED whose cruise and exit are that
        # rate). Outside any engine's turn the first engine's diagonal and directions stand.
        moving, due = C(0), C(0)
        (_, base), *others = rows
        diagonal, ways, steps = base.feed.diagonal, base.motion.dir, base.motion.step
        for number, port in rows:
            moving = moving | (turn == number)
            due = Mux(turn == number, port.feed.due, due)
            m.d.comb += port.feed.tick.eq(self.feed.tick & (turn == number))
        for number, port in others:
            diagonal = Mux(turn == number, port.feed.diagonal, diagonal)
            ways = Mux(turn == number, port.motion.dir, ways)
            steps = steps | port.motion.step
        m.d.comb += [
            # Only a move's turn has a profile (a dwell's argument is its clocks, and with no
            # turn the FIFO's output is undefined): otherwise the rate ramps down to rest.
            self.ramp.profile.eq(Mux(moving, current.argument, 0)),
            self.ramp.start.eq(first & moving),
            self.feed.due.eq(due),
            self.feed.diagonal.eq(diagonal),
            self.motion.step.eq(steps),
            self.motion.dir.eq(ways),
            self.busy.eq(turns.r_rdy),
        ]
        return m


class Replies(wiring.Component):
    """The replies to the host: status first, then outcomes, then errors.

    A query is answered ``STATUS`` as soon as the reply being sent is out, ahead of any
    outcome waiting (queries that come meanwhile are answered by that one ``STATUS``).
    Outcomes wait in a FIFO for the serial line; each goes out as ``OUTCOME`` with its number
    (every queued frame's, counted from reset). An error code from the decoder goes out as
    ``ERROR`` when no outcome waits.

    Members
    -------
    outcome : :py:`In(stream.Signature(Outcome))`
        The turns' outcomes.
    error : :py:`In(stream.Signature(8))`
        The decoder's error codes.
    query : :py:`In(1)`
        A checked QUERY frame ended in this clock.
    status : :py:`In(StatusFields(axes))`
        What a STATUS reply carries (but the error flag, :py:`error_sent`); on three axes
        the position has Z too (STATUS is 24 bytes).
    o : :py:`Out(stream.Signature(FrameEncoder.Reply(axes)))`
        To the frame encoder.
    error_sent : :py:`Out(1)`
        An ``ERROR`` has been sent since reset (sticky).
    """

    def __init__(self, axes=2):
        super().__init__({
            "outcome":    In(stream.Signature(Outcome)),
            "error":      In(stream.Signature(8)),
            "query":      In(1),
            "status":     In(StatusFields(axes)),
            "o":          Out(stream.Signature(FrameEncoder.Reply(axes))),
            "error_sent": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        m.submodules.outcomes = outcomes = fifo.SyncFIFOBuffered(width=2, depth=16)
        wiring.connect(m, wiring.flipped(self.outcome), outcomes.w_stream)
        reply = self.o.payload
        number = Signal(8)
        query = Signal()
        with m.If(self.query):
            m.d.sync += query.eq(1)
        sending = self.o.valid & self.o.ready
        status = self.status
        with m.If(query):
            m.d.comb += [
                reply.kind.eq(STATUS),
                reply.payload.as_value().eq(Cat(status.position, status.free, status.moving,
                                                self.error_sent, status.held, C(0, 5),
                                                status.state, status.cause, status.inputs,
                                                status.rate, C(0, 8), status.feed, C(0, 7),
                                                status.rapid)),
                self.o.valid.eq(1),
            ]
            with m.If(sending):
                m.d.sync += query.eq(0)
        with m.Elif(outcomes.r_rdy):
            m.d.comb += [
                reply.kind.eq(OUTCOME),
                reply.payload[0].eq(number),
                reply.payload[1].eq(outcomes.r_data),
                self.o.valid.eq(1),
                outcomes.r_en.eq(self.o.ready),
            ]
            with m.If(sending):
                m.d.sync += number.eq(number + 1)
        with m.Elif(self.error.valid):
            m.d.comb += [
                reply.kind.eq(ERROR),
                reply.payload[0].eq(self.error.payload),
                self.o.valid.eq(1),
                self.error.ready.eq(self.o.ready),
            ]
            with m.If(sending):
                m.d.sync += self.error_sent.eq(1)
        return m
