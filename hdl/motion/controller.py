"""The machine controller: frames over a serial line in, step/dir out.

UART (:mod:`.uart`) -> :class:`~.link.FrameDecoder` -> frame queue (block RAM) ->
:class:`~.dispatch.Dispatcher` -> engines (a line engine, an arc engine, and optionally the
equidistant engine of cutter-radius compensation: the rows of an engine table) ->
:class:`~.dispatch.TurnQueue` -> step/dir stage; outcomes, errors and status replies go back
through :class:`~.dispatch.Replies`, :class:`~.link.FrameEncoder` and the UART. The protocol is
:mod:`.link`'s.
"""

from amaranth import *
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from ..elements._checks import check_width
from ..engine import MotionSignature
from .dispatch import (DWELL_UNIT, NONE_UNIT, Dispatcher, EngineUnit, Replies, Turn, TurnQueue,
                       UnitSignature, little, raw_bits)
from .alarm import Alarm
from .homing import connect_homing
from .tools import connect_tools
from .feed import OVERRIDE_ONE, FeedGenerator, rate_limit
from .inputs import Inputs, check_polarity, idle_pins, inputs_of
from .link import (ARC, CONFIG, DWELL, FEED, HELIX, IMMEDIATE, LENGTHS, LINE, LINE3, PROFILE,
                   RAPID_PERCENT, STOP, FrameDecoder, FrameEncoder, profile_bytes)
from .player import check_engine
from .queue import FrameQueue
from .stepdir import StepDirStage
from .uart import UARTReceiver, UARTTransmitter, divisor_for

__all__ = ["MotionController", "EngineUnit", "Turn", "LINE_UNIT", "ARC_UNIT", "PROFILE_UNIT"]

#: The turns of the built-in engines (:data:`~.dispatch.NONE_UNIT` 0 and
#: :data:`~.dispatch.DWELL_UNIT` 3 are no engine's).
LINE_UNIT, ARC_UNIT, PROFILE_UNIT = 1, 2, 4

#: Queued frame types that are no engine's.
_OWN = (DWELL, FEED, STOP, CONFIG)


def _line_cmd(cmd, payload):
    return [cmd.x.eq(little(payload, 0, 4, signed_value=True)),
            cmd.y.eq(little(payload, 4, 4, signed_value=True))]


def _arc_cmd(cmd, payload):
    return [cmd.x0.eq(little(payload, 0, 4, signed_value=True)),
            cmd.y0.eq(little(payload, 4, 4, signed_value=True)),
            cmd.x1.eq(little(payload, 8, 4, signed_value=True)),
            cmd.y1.eq(little(payload, 12, 4, signed_value=True)),
            cmd.cw.eq(payload[16][0])]


def _line3_cmd(cmd, payload):
    return _line_cmd(cmd, payload) + [cmd.z.eq(little(payload, 8, 4, signed_value=True))]


def _helix_cmd(cmd, payload):
    # n is unsigned 32 in the frame; the engine's field is narrower: a larger n is cut, and
    # the host never sends one (it is the arc's step count, below 8·2**w + 8).
    return _arc_cmd(cmd, payload) + [cmd.z.eq(little(payload, 17, 4, signed_value=True)),
                                      cmd.n.eq(little(payload, 21, 4)),
                                      cmd.plane.eq(payload[16][1:3])]


class MotionController(wiring.Component):
    """The machine: a frame queue fed over a serial line, two or three engines, a feed, step/dir
    pins.

    Frames (:mod:`kontur.hdl.motion.link`) arrive on :py:`rx`. A checked queued frame goes into the
    frame queue (``queue_frames`` of them, in block RAM); the dispatcher hands each to its unit in
    order as soon as the unit can take it (a line or arc to its engine, which may prepare it
    while the move before runs: an arc is planned while the line before it is still moving),
    and records its *turn*. Turns are taken in order: only the engine whose turn it is gets
    the feed's permissions, so moves on different engines follow the program exactly, with no
    idle clock at a joint when the next move is prepared in time. A FEED frame sets the
    profile (cruise and exit rates, ramp-down point) of the move after it, CONFIG the
    acceleration; a DWELL waits its clocks; STOP marks the end of a program.

    With a ``profile`` engine (:class:`kontur.hdl.equidistant.EquidistantEngine`, cutter-radius
    compensation) a PROFILE frame carries one of its frames (``RADIUS``, ``START``, an element,
    ``CLOSE``); the dispatcher hands it over as soon as the engine takes it and records its
    turn like a move's, so the engine reads its elements two ahead (its memory) while the
    moves before them still run, and each frame's turn lasts from the end of the turn before
    to the frame's outcome: an element's steps are made in its own turn, under its FEED's
    profile. The engine takes ``RADIUS`` and ``START`` only when idle (every frame it took
    before has its outcome), so the host sends ``START`` before the move that brings the
    cutter there. Without ``profile`` nothing of it is built: PROFILE is an unknown type
    (``ERROR`` 2) and the controller is the two-engine one, gate for gate.

    Every queued frame ends, in order, with an ``OUTCOME`` reply (its number and outcome); a
    corrupt frame is dropped with an ``ERROR`` reply; ``QUERY`` answers ``STATUS`` (position,
    free queue slots, flags);
    ``ABORT`` stops the motion at once (the engines' abort) and ends every frame queued before
    it ``ABORTED``.

    The switch inputs (:py:`inputs`: e-stop, limits, probe, cycle start, feed hold;
    :class:`~.inputs.Inputs`) are synchronised and filtered (``input_filter`` clocks,
    ``polarity``).

    **Feed hold.** A HOLD frame or a press of the feed-hold button holds the feed (state HOLD):
    the feed generator ramps the rate down along the path at the configured acceleration to
    a standstill (STATUS flag ``held``), and gives no permission until a RESUME frame or a
    press of the cycle-start button, when it ramps back up; the steps are the engines', so a
    held and resumed program makes the same steps as an uninterrupted one. An OVERRIDE frame
    sets the feed override (the cruise of every move but a rapid) and the rapid override (a
    rapid's, the FEED frame's flag), applied by the feed generator within the acceleration,
    and the spindle override (S in the tool outputs' duty, from their next PWM period:
    :class:`~.tools.ToolOutputs`). These act when their frame ends, queued frames or not.
    Entering ALARM ends a hold.

    A tripped e-stop or limit switch (:class:`~.alarm.Alarm`) is an ABORT in the
    clock its filtered level changes, and ALARM from then on: the step/dir stage drops every
    step still in its direction set-up (a pulse on its pin is finished), every queued frame
    ends ``ABORTED``, every queued frame that comes in ALARM ends ``REFUSED``; UNLOCK
    leaves ALARM unless the e-stop is still active. The position counts the pulses on the step
    pins: the steps actually made.

    The engines' steps go through :class:`~kontur.hdl.motion.stepdir.StepDirStage` (``dir_setup``,
    ``step_width``); the feed never permits steps closer than ``dir_setup + step_width + 1``
    clocks, so the pulses always fit. The maximum step rate is therefore ``clock_hz /
    (dir_setup + step_width + 1)``.

    The engines are the rows of a table (:attr:`table`, :class:`~.dispatch.EngineUnit`): the
    line engine (turn 1, LINE frames), the arc engine (turn 2, ARC), the profile engine if any
    (turn 4, PROFILE), then the rows of ``engines``. The frame decoder knows the table's frame
    types and lengths, the dispatcher offers each such frame to its row's engine, and the turn
    queue gives that engine the feed in its turn; nothing else names an engine.

    **Three axes.** With a line engine on three axes (``LineEngine(SpatialLineCore(axes=3))``)
    the controller is a 3-axis one: its arc engine must be a :class:`~kontur.hdl.helix.
    HelixEngine`, the line and arc rows take LINE3 and HELIX frames (not LINE and ARC), the
    feed generator knows a step of √3, the step/dir stage, the position and STATUS (24 bytes)
    have Z, and Z's limit switch is input bit 6.

    Parameters
    ----------
    line, arc : :class:`~amaranth.lib.wiring.Component`
        The engines (``LineEngine`` and ``ArcEngine`` with 32-bit frame coordinates; on three
        axes a 3-axis ``LineEngine`` and a ``HelixEngine``).
    profile : :class:`~amaranth.lib.wiring.Component` or ``None``
        The equidistant engine (or any engine: its frame layout's bits are the PROFILE
        payload, :func:`~.link.profile_bytes`), or ``None`` (the default) for none.
    engines : sequence of :class:`~.dispatch.EngineUnit`
        Further rows of the table (none by default): engines under turn numbers and frame
        types of their own.
    clock_hz : :class:`float`
        Clock frequency.
    baud : :class:`int`
        Serial rate (8N1).
    queue_frames : :class:`int`
        Frames the queue holds (its bytes are in block RAM), 2 to 255 (``STATUS`` reports the
        free slots in a byte).
    dir_setup, step_width : :class:`int`
        Step/dir timing in clocks (see :class:`~kontur.hdl.motion.stepdir.StepDirStage`).
    input_filter : :class:`int`
        Clocks an input's new level must hold (:class:`~.inputs.InputFilter`; default 1).
    polarity : :class:`dict`
        ``"nc"`` or ``"no"`` per input (:data:`~.inputs.DEFAULT_POLARITY` for the others).
    overrides : :class:`bool`
        Build the feed generator's overrides and the tool outputs' spindle override
        (default); without them OVERRIDE frames are taken (and reported) but the rates and S
        stay at 100 % (:class:`~.feed.FeedGenerator`).

    Members
    -------
    rx : :py:`In(1, init=1)`
        Serial line from the host.
    inputs : :py:`In(6, init=idle)` (7 on three axes)
        The switch pins (:data:`~.inputs.INPUTS`, :data:`~.inputs.INPUTS3`), every one idle by
        default.
    tx : :py:`Out(1, init=1)`
        Serial line to the host.
    motion : :py:`Out(MotionSignature(axes))`
        Step/dir pins, timed for drivers.
    enable : :py:`Out(1)`
        Driver enable (high once out of reset).
    position : :py:`Out(data.ArrayLayout(signed(32), axes))`
        Absolute position, steps per axis since reset.
    busy : :py:`Out(1)`
        Frames are queued or running.
    error : :py:`Out(1)`
        A frame has been dropped since reset (sticky).
    alarm : :py:`Out(1)`
        In ALARM.

    Raises
    ------
    :exc:`TypeError`
        If an engine lacks the engine signature, a row of ``engines`` is not an
        :class:`~.dispatch.EngineUnit`, or a number is not a positive integer.
    :exc:`ValueError`
        If a row's name, turn number or frame type is another row's or the controller's own,
        or the clock cannot make the baud rate.
    """

    def __init__(self, *, line, arc, profile=None, engines=(), clock_hz=12e6, baud=115200,
                 queue_frames=32, dir_setup=12, step_width=24, input_filter=1,
                 polarity=None, overrides=True):
        check_engine(line)
        check_engine(arc)
        if profile is not None:
            check_engine(profile)
        axes = line.signature.axes
        if axes == 3:
            from ..helix import HelixEngine
            if not isinstance(arc, HelixEngine):
                raise TypeError(f"A 3-axis controller's arc engine must be a HelixEngine, "
                                f"not {arc!r}")
            table = [EngineUnit("line", LINE_UNIT, LINE3, line, LENGTHS[LINE3], _line3_cmd),
                     EngineUnit("arc", ARC_UNIT, HELIX, arc, LENGTHS[HELIX], _helix_cmd)]
        else:
            if arc.signature.axes != 2:
                raise TypeError(f"A 2-axis controller's arc engine must be on two axes, "
                                f"not {arc!r}")
            table = [EngineUnit("line", LINE_UNIT, LINE, line, LENGTHS[LINE], _line_cmd),
                     EngineUnit("arc", ARC_UNIT, ARC, arc, LENGTHS[ARC], _arc_cmd)]
        self._axes = axes
        if profile is not None:
            table.append(EngineUnit("profile", PROFILE_UNIT, PROFILE, profile,
                                    profile_bytes(profile.signature.frame), raw_bits))
        for row in engines:
            if not isinstance(row, EngineUnit):
                raise TypeError(f"An engine table row must be an EngineUnit, not {row!r}")
            check_engine(row.engine)
            table.append(row)
        _check_table(table)
        check_width("Queue length", queue_frames, minimum=2)
        if queue_frames > 255:
            raise ValueError(f"Queue length must be at most 255 (STATUS reports the free "
                             f"slots in a byte), not {queue_frames}")
        check_width("Direction setup", dir_setup, minimum=0)
        check_width("Step pulse width", step_width)
        divisor = divisor_for(clock_hz, baud)
        check_width("Input filter", input_filter)
        self._input_filter = input_filter
        if not isinstance(overrides, bool):
            raise TypeError(f"Overrides must be True or False, not {overrides!r}")
        self._overrides = overrides
        self._polarity = check_polarity(polarity)
        self._idle = idle_pins(self._polarity, axes)
        self._table = tuple(table)
        self._profile = profile
        self._queue_frames = queue_frames
        self._clock_hz = clock_hz
        self._min_interval = dir_setup + step_width + 1
        self._divisor = divisor
        self._dir_setup, self._step_width = dir_setup, step_width
        lengths = {kind: LENGTHS[kind] for kind in _OWN} | {row.kind: row.length for row in table}
        self._lengths = dict(sorted(lengths.items()))       # the queued types, by type
        super().__init__({
            "rx":       In(1, init=1),
            "inputs":   In(len(inputs_of(axes)), init=self._idle),
            "tx":       Out(1, init=1),
            "motion":   Out(MotionSignature(axes)),
            "enable":   Out(1),
            "position": Out(data.ArrayLayout(signed(32), axes)),
            "busy":     Out(1),
            "error":    Out(1),
            "alarm":    Out(1),
        })

    @property
    def axes(self):
        """2 or 3 (the line engine's)."""
        return self._axes

    @property
    def queue_frames(self):
        return self._queue_frames

    @property
    def profile(self):
        """The profile engine, or ``None``."""
        return self._profile

    @property
    def table(self):
        """The engine table: one :class:`~.dispatch.EngineUnit` for each engine."""
        return self._table

    @property
    def idle_inputs(self):
        """The pin word of :py:`inputs` with every input idle."""
        return self._idle

    @property
    def input_filter(self):
        return self._input_filter

    @property
    def polarity(self):
        return dict(self._polarity)

    @property
    def overrides(self):
        return self._overrides

    @property
    def max_step_rate(self):
        """Steps a second at most, per axis (the step/dir timing's limit)."""
        return self._clock_hz / self._min_interval

    def elaborate(self, platform):
        m = Module()
        # The parts are made here, not in __init__: a controller only asked for its figures
        # (or refused) leaves no unused elaboratable behind.
        longest = 1 + max(self._lengths.values())
        self.uart_rx = UARTReceiver(self._divisor)
        self.uart_tx = UARTTransmitter(self._divisor)
        self.decoder = FrameDecoder(queued=self._lengths, overrides=self._overrides)
        self.queue = FrameQueue(1 << (self._queue_frames * longest - 1).bit_length())
        self.dispatcher = Dispatcher(self._table, self._lengths, queue_frames=self._queue_frames)
        axes = self._axes
        self.turns = TurnQueue(self._table, axes)
        self.replies = Replies(axes)
        self.encoder = FrameEncoder(axes)
        self.feed = FeedGenerator(max_rate=rate_limit(self._min_interval),
                                  overrides=self._overrides, axes=axes)
        self.stepdir = StepDirStage(axes=axes, dir_setup=self._dir_setup,
                                    step_width=self._step_width)
        self.input_stage = Inputs(filter=self._input_filter, polarity=self._polarity, axes=axes)
        self.alarm_unit = Alarm(axes)
        self.spindle_override = Signal(9, init=OVERRIDE_ONE)   # the tool engine's (.tools)
        for name in ("uart_rx", "uart_tx", "decoder", "queue", "dispatcher", "turns", "replies",
                     "encoder", "feed", "stepdir", "input_stage", "alarm_unit"):
            m.submodules[name] = getattr(self, name)
        decoder, dispatcher, turns, replies = self.decoder, self.dispatcher, self.turns, \
            self.replies

        # Serial line in, checked frames into the queue, then to the dispatcher.
        m.d.comb += [
            self.uart_rx.rx.eq(self.rx),
            decoder.line_error.eq(self.uart_rx.error | self.uart_rx.overrun),
        ]
        wiring.connect(m, self.uart_rx.o, decoder.i)
        wiring.connect(m, decoder.q, self.queue.w)
        wiring.connect(m, self.queue.r, dispatcher.r)
        # An ABORT: the host's, or an input tripped (ALARM).
        abort = Signal()
        m.d.comb += [abort.eq(decoder.abort | self.alarm_unit.enter),
                     dispatcher.commit.eq(decoder.q.commit), dispatcher.abort.eq(abort)]

        # The engines, from the table: commands from the dispatcher, turns in the turn queue.
        for row in self._table:
            m.submodules[row.name] = row.engine
            wiring.connect(m, getattr(dispatcher.cmd, row.name), row.engine.cmd)
            wiring.connect(m, UnitSignature.of(row.engine), getattr(turns.units, row.name))
        wiring.connect(m, dispatcher.turn, turns.i)
        m.d.comb += turns.abort.eq(abort)

        # The feed: permissions for the engine whose turn it is.
        wiring.connect(m, turns.feed, self.feed.feed)
        wiring.connect(m, turns.ramp, self.feed.ramp)
        m.d.comb += self.feed.accel.eq(dispatcher.accel)

        # Motion: the pins, and the position: the pulses on them.
        wiring.connect(m, turns.motion, self.stepdir.i)
        wiring.connect(m, self.stepdir.o, wiring.flipped(self.motion))
        for axis in range(axes):
            with m.If(self.stepdir.made[axis]):
                m.d.sync += self.position[axis].eq(
                    self.position[axis] + Mux(self.stepdir.o.dir[axis], -1, 1))
        m.d.sync += self.enable.eq(1)
        self._safety(m)
        connect_homing(m, self)             # homing rows of the table, if any (.homing)
        connect_tools(m, self)              # the tool outputs' row, if any (.tools)

        # Replies: outcomes, errors, status.
        wiring.connect(m, turns.outcome, replies.outcome)
        wiring.connect(m, decoder.error, replies.error)
        m.d.comb += [
            replies.query.eq(decoder.query | decoder.unlock),
            replies.status.position.eq(self.position),
            replies.status.free.eq(dispatcher.free),
            replies.status.moving.eq(turns.busy),
            replies.status.state.eq(self.alarm_unit.state),
            replies.status.cause.eq(self.alarm_unit.cause),
            replies.status.inputs.eq(self.input_stage.active),
            replies.status.held.eq(self.feed.held),
            replies.status.rate.eq(self.feed.rate),
            replies.status.feed.eq(self.feed.feed_override),
            replies.status.rapid.eq(Mux(self.feed.rapid_override == 0, RAPID_PERCENT[0],
                                        Mux(self.feed.rapid_override == 1, RAPID_PERCENT[1],
                                            RAPID_PERCENT[2]))),
            self.busy.eq(dispatcher.pending | turns.busy),
            self.error.eq(replies.error_sent),
        ]
        wiring.connect(m, replies.o, self.encoder.i)
        wiring.connect(m, self.encoder.o, self.uart_tx.i)
        m.d.comb += self.tx.eq(self.uart_tx.tx)
        return m

    def _safety(self, m):
        """The inputs and the ALARM: the e-stop and limits stop the pins and the frames."""
        stage, alarm = self.input_stage, self.alarm_unit
        m.d.comb += [
            stage.pins.eq(self.inputs),
            alarm.active.eq(stage.active),
            alarm.unlock.eq(self.decoder.unlock),
            alarm.busy.eq(self.dispatcher.pending | self.turns.busy),
            self.stepdir.halt.eq(alarm.halt),
            self.dispatcher.alarm.eq(alarm.halt),
            self.alarm.eq(alarm.alarm),
        ]
        self._hold(m)

    def _hold(self, m):
        """Feed hold and the overrides: the HOLD, RESUME and OVERRIDE frames, the feed-hold and
        cycle-start buttons (their presses), to the feed generator."""
        decoder, feed, active = self.decoder, self.feed, self.input_stage.active
        names = inputs_of(self._axes)
        buttons = Cat(active[names.index("feed_hold")], active[names.index("cycle_start")])
        before = Signal(2)                          # the buttons' levels a clock before
        m.d.sync += before.eq(buttons)
        pressed = buttons & ~before
        hold = Signal()
        with m.If(self.alarm_unit.enter):
            m.d.sync += hold.eq(0)
        with m.Elif(decoder.hold | pressed[0]):
            m.d.sync += hold.eq(1)
        with m.Elif(decoder.resume | pressed[1]):
            m.d.sync += hold.eq(0)
        feed_override = Signal(9, init=OVERRIDE_ONE)
        rapid_override = Signal(2)
        with m.If(decoder.override):
            m.d.sync += [feed_override.eq(decoder.feed_override),
                         rapid_override.eq(decoder.rapid_override)]
            if self._overrides:
                m.d.sync += self.spindle_override.eq(decoder.spindle_override)
        m.d.comb += [
            feed.hold.eq(hold),
            feed.feed_override.eq(feed_override),
            feed.rapid_override.eq(rapid_override),
            feed.rapid.eq(self.turns.ramp.profile.rapid),
            self.alarm_unit.hold.eq(hold),
        ]


def _check_table(table):
    """Raise :exc:`ValueError` unless every row's name, turn number and frame type is its own
    and the number and type are free (not the controller's own)."""
    units = {NONE_UNIT: "the controller (0: nothing to move)",
             DWELL_UNIT: "the controller (DWELL)"}
    kinds = {kind: "the controller" for kind in _OWN + IMMEDIATE}
    names = set()
    for row in table:
        if row.name in names:
            raise ValueError(f"Engine name {row.name!r} is used twice")
        names.add(row.name)
        if isinstance(row.unit, bool) or not isinstance(row.unit, int) or row.unit < 1:
            raise ValueError(f"Turn number of engine {row.name!r} must be a positive integer, "
                             f"not {row.unit!r}")
        if row.unit in units:
            raise ValueError(f"Turn number {row.unit} of engine {row.name!r} is already used by "
                             f"{units[row.unit]}")
        if isinstance(row.kind, bool) or not isinstance(row.kind, int) or \
                not 0x10 <= row.kind <= 0x7F:
            raise ValueError(f"Frame type of engine {row.name!r} must be a host frame type "
                             f"(0x10 to 0x7f), not {row.kind!r}")
        if row.kind in kinds:
            raise ValueError(f"Frame type {row.kind:#04x} of engine {row.name!r} is already used "
                             f"by {kinds[row.kind]}")
        units[row.unit] = kinds[row.kind] = f"engine {row.name!r}"
