"""The machine controller: frames over a serial line in, step/dir out.

UART (:mod:`.uart`) -> :class:`~.link.FrameDecoder` -> frame queue (block RAM) -> dispatcher ->
engines (a line engine, an arc engine, and optionally the equidistant engine of cutter-radius
compensation) -> step/dir stage; outcomes, errors and status replies go back through
:class:`~.link.FrameEncoder` and the UART. The protocol is :mod:`.link`'s.
"""

from amaranth import *
from amaranth.lib import data, fifo, wiring
from amaranth.lib.wiring import In, Out

from ..elements._checks import check_width
from ..engine import MotionSignature, Outcome
from .feed import FeedGenerator, Profile, rate_limit
from .link import (ARC, CONFIG, DWELL, ERROR, FEED, LINE, OUTCOME, PROFILE, QUEUED, STATUS,
                   FrameDecoder, FrameEncoder, host_lengths, profile_bytes)
from .player import check_engine
from .queue import FrameQueue
from .stepdir import StepDirStage
from .uart import UARTReceiver, UARTTransmitter, divisor_for

__all__ = ["MotionController", "Turn"]

#: What a turn is for: nothing to move (FEED, STOP, CONFIG, an aborted frame), a line, an
#: arc, a dwell, a frame of the profile engine.
NONE_UNIT, LINE_UNIT, ARC_UNIT, DWELL_UNIT, PROFILE_UNIT = 0, 1, 2, 3, 4


def Turn(profile=False):
    """A queued frame's turn: which unit it runs on, whether it was aborted before it ran, and
    its argument (a move's feed profile, or a dwell's clocks). The unit takes a third bit only
    in a controller with a ``profile`` engine."""
    return data.StructLayout({"unit": 3 if profile else 2, "aborted": 1,
                              "argument": Profile()})


def _little(payload, first, count, *, signed_value=False):
    value = Cat(*(payload[i] for i in range(first, first + count)))
    return value.as_signed() if signed_value else value


class MotionController(wiring.Component):
    """The machine: a frame queue fed over a serial line, two or three engines, a feed, step/dir
    pins.

    Frames (:mod:`hdl.motion.link`) arrive on :py:`rx`. A checked queued frame goes into the
    frame queue (``queue_frames`` of them, in block RAM); the dispatcher hands each to its unit in
    order as soon as the unit can take it (a line or arc to its engine, which may prepare it
    while the move before runs: an arc is planned while the line before it is still moving),
    and records its *turn*. Turns are taken in order: only the engine whose turn it is gets
    the feed's permissions, so moves on different engines follow the program exactly, with no
    idle clock at a joint when the next move is prepared in time. A FEED frame sets the
    profile (cruise and exit rates, ramp-down point) of the move after it, CONFIG the
    acceleration; a DWELL waits its clocks; STOP marks the end of a program.

    With a ``profile`` engine (:class:`hdl.equidistant.EquidistantEngine`, cutter-radius
    compensation) a PROFILE frame carries one of its frames (``RADIUS``, ``START``, an element,
    ``CLOSE``); the dispatcher hands it over as soon as the engine takes it and records its
    turn like a move's, so the engine reads its elements two ahead (its memory) while the
    moves before them still run, and each frame's turn lasts from the end of the turn before
    to the frame's outcome: an element's steps are made in its own turn, under its FEED's
    profile. The engine takes ``RADIUS`` and ``START`` only when idle (every frame it took
    before has its outcome), so the host sends ``START`` before the move that brings the
    cutter there. Without ``profile`` nothing of it is built: PROFILE is an unknown type
    (``ERROR`` 2) and the controller is the two-engine one, gate for gate.

    Every queued frame ends, in order, with an ``OUTCOME`` reply (its number and outcome); a corrupt frame is dropped with
    an ``ERROR`` reply; ``QUERY`` answers ``STATUS`` (position, free queue slots, flags);
    ``ABORT`` stops the motion at once (the engines' abort) and ends every frame queued before
    it ``ABORTED``.

    The engines' steps go through :class:`~hdl.motion.stepdir.StepDirStage` (``dir_setup``,
    ``step_width``); the feed never permits steps closer than ``dir_setup + step_width + 1``
    clocks, so the pulses always fit. The maximum step rate is therefore ``clock_hz /
    (dir_setup + step_width + 1)``.

    Parameters
    ----------
    line, arc : :class:`~amaranth.lib.wiring.Component`
        The engines (``LineEngine`` and ``ArcEngine`` with 32-bit frame coordinates).
    profile : :class:`~amaranth.lib.wiring.Component` or ``None``
        The equidistant engine (or any engine: its frame layout's bits are the PROFILE
        payload, :func:`~.link.profile_bytes`), or ``None`` (the default) for none.
    clock_hz : :class:`float`
        Clock frequency.
    baud : :class:`int`
        Serial rate (8N1).
    queue_frames : :class:`int`
        Frames the queue holds (its bytes are in block RAM).
    dir_setup, step_width : :class:`int`
        Step/dir timing in clocks (see :class:`~hdl.motion.stepdir.StepDirStage`).

    Members
    -------
    rx : :py:`In(1, init=1)`
        Serial line from the host.
    tx : :py:`Out(1, init=1)`
        Serial line to the host.
    motion : :py:`Out(MotionSignature(2))`
        Step/dir pins, timed for drivers.
    enable : :py:`Out(1)`
        Driver enable (high once out of reset).
    position : :py:`Out(data.ArrayLayout(signed(32), 2))`
        Absolute position, steps per axis since reset.
    busy : :py:`Out(1)`
        Frames are queued or running.
    error : :py:`Out(1)`
        A frame has been dropped since reset (sticky).

    Raises
    ------
    :exc:`TypeError`
        If an engine lacks the engine signature, or a number is not a positive integer.
    :exc:`ValueError`
        If the clock cannot make the baud rate.
    """

    def __init__(self, *, line, arc, profile=None, clock_hz=12e6, baud=115200, queue_frames=32,
                 dir_setup=12, step_width=24):
        check_engine(line)
        check_engine(arc)
        if profile is not None:
            check_engine(profile)
        check_width("Queue length", queue_frames, minimum=2)
        check_width("Direction setup", dir_setup, minimum=0)
        check_width("Step pulse width", step_width)
        divisor = divisor_for(clock_hz, baud)
        self._line, self._arc, self._profile = line, arc, profile
        self._queue_frames = queue_frames
        self._clock_hz = clock_hz
        self._min_interval = dir_setup + step_width + 1
        self._divisor = divisor
        self._dir_setup, self._step_width = dir_setup, step_width
        self._profile_bytes = None if profile is None else profile_bytes(profile.signature.frame)
        self._lengths = {kind: count for kind, count in host_lengths(self._profile_bytes).items()
                         if kind in QUEUED}
        super().__init__({
            "rx":       In(1, init=1),
            "tx":       Out(1, init=1),
            "motion":   Out(MotionSignature(2)),
            "enable":   Out(1),
            "position": Out(data.ArrayLayout(signed(32), 2)),
            "busy":     Out(1),
            "error":    Out(1),
        })

    @property
    def queue_frames(self):
        return self._queue_frames

    @property
    def profile(self):
        """The profile engine, or ``None``."""
        return self._profile

    @property
    def max_step_rate(self):
        """Steps a second at most, per axis (the step/dir timing's limit)."""
        return self._clock_hz / self._min_interval

    def elaborate(self, platform):
        m = Module()
        line, arc, equidistant = self._line, self._arc, self._profile
        # The parts are made here, not in __init__: a controller only asked for its figures
        # (or refused) leaves no unused elaboratable behind.
        longest = 1 + max(self._lengths.values())
        self.uart_rx = UARTReceiver(self._divisor)
        self.uart_tx = UARTTransmitter(self._divisor)
        self.decoder = FrameDecoder(profile=self._profile_bytes)
        self.queue = FrameQueue(1 << (self._queue_frames * longest - 1).bit_length())
        self.encoder = FrameEncoder()
        self.feed = FeedGenerator(max_rate=rate_limit(self._min_interval))
        self.stepdir = StepDirStage(dir_setup=self._dir_setup, step_width=self._step_width)
        for name in ("uart_rx", "uart_tx", "decoder", "queue", "encoder", "feed", "stepdir"):
            m.submodules[name] = getattr(self, name)
        m.submodules.line = line
        m.submodules.arc = arc
        if equidistant is not None:
            m.submodules.profile = equidistant
        engines = {LINE_UNIT: line, ARC_UNIT: arc}          # the move units, by turn
        if equidistant is not None:
            engines[PROFILE_UNIT] = equidistant
        decoder, queue, feed = self.decoder, self.queue, self.feed

        # ---- serial line in, checked frames into the queue ----------------------------------
        m.d.comb += [
            self.uart_rx.rx.eq(self.rx),
            decoder.line_error.eq(self.uart_rx.error | self.uart_rx.overrun),
            queue.w_data.eq(decoder.q_data),
            queue.w_en.eq(decoder.q_en),
            queue.commit.eq(decoder.q_commit),
            queue.rollback.eq(decoder.q_rollback),
            decoder.q_room.eq(queue.w_room),
        ]
        wiring.connect(m, self.uart_rx.o, decoder.i)
        queued = Signal(range(self._queue_frames + 2))      # whole frames in the queue

        # ---- dispatcher: a frame from the queue into the frame register, then to its unit ---
        longest = max(self._lengths.values())
        kind = Signal(8)
        payload = Signal(data.ArrayLayout(8, longest))
        length = Signal(range(longest + 1))
        index = Signal(range(longest + 1))
        lengths = Signal(range(longest + 1))
        with m.Switch(queue.r.payload):
            for frame_type, count in self._lengths.items():
                with m.Case(frame_type):
                    m.d.comb += lengths.eq(count)
        held = Signal()                                     # the frame register holds a frame
        take = Signal()
        frame_start = Signal()                              # a frame's type byte is read
        with m.FSM(name="dispatch"):
            with m.State("Kind"):
                m.d.comb += [queue.r.ready.eq(1), frame_start.eq(queue.r.valid)]
                with m.If(queue.r.valid):
                    m.d.sync += [kind.eq(queue.r.payload), length.eq(lengths), index.eq(0)]
                    m.next = "Payload"
            with m.State("Payload"):
                with m.If(index == length):
                    m.d.sync += held.eq(1)
                    m.next = "Ready"
                with m.Else():
                    m.d.comb += queue.r.ready.eq(1)
                    with m.If(queue.r.valid):
                        m.d.sync += [payload[index].eq(queue.r.payload), index.eq(index + 1)]
            with m.State("Ready"):
                with m.If(take):
                    m.d.sync += held.eq(0)
                    m.next = "Kind"
        m.d.sync += queued.eq(queued + decoder.q_commit - frame_start)

        layout = Turn(equidistant is not None)
        m.submodules.turns = turns = fifo.SyncFIFOBuffered(width=layout.size, depth=16)
        profile = Signal(Profile())                 # the last FEED's: for the next move
        accel = Signal(32)                          # CONFIG: the acceleration
        flush = Signal(range(self._queue_frames + 3))   # frames before an abort still to end
        aborting = flush != 0
        unit = Signal(layout["unit"].shape)
        with m.Switch(kind):
            with m.Case(LINE):
                m.d.comb += unit.eq(LINE_UNIT)
            with m.Case(ARC):
                m.d.comb += unit.eq(ARC_UNIT)
            with m.Case(DWELL):
                m.d.comb += unit.eq(DWELL_UNIT)
            if equidistant is not None:
                with m.Case(PROFILE):
                    m.d.comb += unit.eq(PROFILE_UNIT)
        offer = held & turns.w_rdy & ~aborting
        m.d.comb += [
            line.cmd.payload.x.eq(_little(payload, 0, 4, signed_value=True)),
            line.cmd.payload.y.eq(_little(payload, 4, 4, signed_value=True)),
            line.cmd.valid.eq(offer & (unit == LINE_UNIT)),
            arc.cmd.payload.x0.eq(_little(payload, 0, 4, signed_value=True)),
            arc.cmd.payload.y0.eq(_little(payload, 4, 4, signed_value=True)),
            arc.cmd.payload.x1.eq(_little(payload, 8, 4, signed_value=True)),
            arc.cmd.payload.y1.eq(_little(payload, 12, 4, signed_value=True)),
            arc.cmd.payload.cw.eq(payload[16][0]),
            arc.cmd.valid.eq(offer & (unit == ARC_UNIT)),
        ]
        ready = Mux(unit == LINE_UNIT, line.cmd.ready, Mux(unit == ARC_UNIT, arc.cmd.ready, 1))
        if equidistant is not None:
            # The engine's frame is the payload's bits as they came (least significant first).
            m.d.comb += [
                equidistant.cmd.payload.eq(payload.as_value()[:equidistant.signature.frame.size]),
                equidistant.cmd.valid.eq(offer & (unit == PROFILE_UNIT)),
            ]
            ready = Mux(unit == PROFILE_UNIT, equidistant.cmd.ready, ready)
        m.d.comb += [
            take.eq(held & turns.w_rdy & (aborting | ready)),
            turns.w_en.eq(take),
        ]
        turn_in = layout(turns.w_data)
        m.d.comb += [
            turn_in.unit.eq(Mux(aborting, NONE_UNIT, unit)),
            turn_in.aborted.eq(aborting),
            turn_in.argument.eq(Mux(unit == DWELL_UNIT, _little(payload, 0, 4), profile)),
        ]
        with m.If(take & ~aborting & (kind == FEED)):
            m.d.sync += profile.eq(_little(payload, 0, 9))
        with m.If(take & ~aborting & (kind == CONFIG)):
            m.d.sync += accel.eq(_little(payload, 0, 4))
        with m.If(decoder.abort):
            # The frames queued before the abort: those in the queue, and one being read.
            m.d.sync += flush.eq(queued + Mux(held | (index != length), 1, 0))
        with m.Elif(take & aborting):
            m.d.sync += flush.eq(flush - 1)
        # ---- turns: one unit moves at a time, in order --------------------------------------
        current = layout(turns.r_data)
        turn = Signal(layout["unit"].shape)
        m.d.comb += turn.eq(Mux(turns.r_rdy, current.unit, NONE_UNIT))
        started = Signal()
        first = turns.r_rdy & ~started
        # Outcomes wait here for the serial line: their numbers count every queued frame.
        m.submodules.outcomes = outcomes = fifo.SyncFIFOBuffered(width=2, depth=16)
        room = outcomes.w_rdy

        dwell_left = Signal(32)
        complete = Signal()
        outcome = Signal(Outcome)
        line_ends = line.status.valid & line.status.ready
        arc_ends = arc.status.valid & arc.status.ready
        m.d.comb += [
            line.status.ready.eq(room & (turn == LINE_UNIT)),
            arc.status.ready.eq(room & (turn == ARC_UNIT)),
            line.abort.eq(decoder.abort),
            arc.abort.eq(decoder.abort),
        ]
        if equidistant is not None:
            m.d.comb += [
                equidistant.status.ready.eq(room & (turn == PROFILE_UNIT)),
                equidistant.abort.eq(decoder.abort),
            ]
        with m.Switch(turn):
            with m.Case(LINE_UNIT):
                m.d.comb += [complete.eq(line_ends), outcome.eq(line.status.payload.outcome)]
            with m.Case(ARC_UNIT):
                m.d.comb += [complete.eq(arc_ends), outcome.eq(arc.status.payload.outcome)]
            if equidistant is not None:
                with m.Case(PROFILE_UNIT):
                    m.d.comb += [
                        complete.eq(equidistant.status.valid & equidistant.status.ready),
                        outcome.eq(equidistant.status.payload.outcome),
                    ]
            with m.Case(DWELL_UNIT):
                m.d.comb += [
                    complete.eq(room & started & ((dwell_left == 0) | decoder.abort)),
                    outcome.eq(Mux(decoder.abort, Outcome.ABORTED, Outcome.DONE)),
                ]
            with m.Default():
                m.d.comb += [
                    complete.eq(room & turns.r_rdy),
                    outcome.eq(Mux(current.aborted, Outcome.ABORTED, Outcome.DONE)),
                ]
        m.d.comb += [
            turns.r_en.eq(complete),
            outcomes.w_en.eq(complete),
            outcomes.w_data.eq(outcome),
        ]
        with m.If(complete):
            m.d.sync += started.eq(0)
        with m.Elif(turns.r_rdy):
            m.d.sync += started.eq(1)
        with m.If(first):
            m.d.sync += dwell_left.eq(current.argument.as_value()[:32])
        with m.Elif(dwell_left != 0):
            m.d.sync += dwell_left.eq(dwell_left - 1)

        # ---- the feed: permissions for the engine whose turn it is --------------------------
        moving = (turn == LINE_UNIT) | (turn == ARC_UNIT)
        due = Mux(turn == ARC_UNIT, arc.feed.due, Mux(turn == LINE_UNIT, line.feed.due, 0))
        diagonal = Mux(turn == ARC_UNIT, arc.feed.diagonal, line.feed.diagonal)
        steps = line.motion.step | arc.motion.step
        ways = Mux(turn == ARC_UNIT, arc.motion.dir, line.motion.dir)
        if equidistant is not None:
            # Every profile frame's turn is a move's: its FEED's profile, a ramp from the rate
            # the turn before ended at (a frame without steps holds the rate: the host sends
            # it a FEED whose cruise and exit are that rate).
            mine = turn == PROFILE_UNIT
            moving = moving | mine
            due = Mux(mine, equidistant.feed.due, due)
            diagonal = Mux(mine, equidistant.feed.diagonal, diagonal)
            steps = steps | equidistant.motion.step
            ways = Mux(mine, equidistant.motion.dir, ways)
            m.d.comb += equidistant.feed.tick.eq(feed.feed.tick & mine)
        m.d.comb += [
            # Only a move's turn has a profile (a dwell's argument is its clocks, and with no
            # turn the FIFO's output is undefined): otherwise the rate ramps down to rest.
            feed.profile.eq(Mux(moving, current.argument, 0)),
            feed.accel.eq(accel),
            feed.start.eq(first & moving),
            feed.feed.due.eq(due),
            feed.feed.diagonal.eq(diagonal),
            line.feed.tick.eq(feed.feed.tick & (turn == LINE_UNIT)),
            arc.feed.tick.eq(feed.feed.tick & (turn == ARC_UNIT)),
        ]

        # ---- motion: the position, and the pins --------------------------------------------
        step = Signal(2)
        direction = Signal(2)
        m.d.comb += [
            step.eq(steps),
            direction.eq(ways),
            self.stepdir.i.step.eq(step),
            self.stepdir.i.dir.eq(direction),
        ]
        wiring.connect(m, self.stepdir.o, wiring.flipped(self.motion))
        for axis in range(2):
            with m.If(step[axis]):
                m.d.sync += self.position[axis].eq(
                    self.position[axis] + Mux(direction[axis], -1, 1))
        m.d.sync += self.enable.eq(1)

        # ---- replies: outcomes first, then errors, then status ------------------------------
        reply = FrameEncoder.Reply()(self.encoder.i.payload)
        number = Signal(8)
        query = Signal()
        error_sent = Signal()
        with m.If(decoder.query):
            m.d.sync += query.eq(1)
        sending = self.encoder.i.valid & self.encoder.i.ready
        with m.If(outcomes.r_rdy):
            m.d.comb += [
                reply.kind.eq(OUTCOME),
                reply.payload[0].eq(number),
                reply.payload[1].eq(outcomes.r_data),
                self.encoder.i.valid.eq(1),
                outcomes.r_en.eq(self.encoder.i.ready),
            ]
            with m.If(sending):
                m.d.sync += number.eq(number + 1)
        with m.Elif(decoder.error.valid):
            m.d.comb += [
                reply.kind.eq(ERROR),
                reply.payload[0].eq(decoder.error.payload),
                self.encoder.i.valid.eq(1),
                decoder.error.ready.eq(self.encoder.i.ready),
            ]
            with m.If(sending):
                m.d.sync += error_sent.eq(1)
        with m.Elif(query):
            free = Signal(8)                    # a byte, as the protocol has it
            m.d.comb += free.eq(self._queue_frames - queued - held)
            status = Cat(self.position[0], self.position[1], free, turns.r_rdy, error_sent)
            m.d.comb += [
                reply.kind.eq(STATUS),
                reply.payload.as_value().eq(status),
                self.encoder.i.valid.eq(1),
            ]
            with m.If(sending):
                m.d.sync += query.eq(0)
        m.d.comb += [
            self.busy.eq(held | (queued != 0) | turns.r_rdy),
            self.error.eq(error_sent),
        ]
        wiring.connect(m, self.encoder.o, self.uart_tx.i)
        m.d.comb += self.tx.eq(self.uart_tx.tx)
        return m
