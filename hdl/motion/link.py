"""The host link: a framed binary protocol over a byte stream, defined once.

A frame is ``SYNC type length payload crc``: the sync byte ``0xA5``, a type byte, the payload
length, the payload (little-endian fields) and the CRC-16/CCITT (polynomial 0x1021, initial
value 0xFFFF, as :func:`binascii.crc_hqx` computes it) of ``type length payload``, most
significant byte first. The constants here are the protocol: the host side
(:mod:`kontur.hdl.motion.protocol`) imports them.

Host to machine. Queued frames (:data:`QUEUED`) go into the frame queue in the order they
arrive and each ends with exactly one ``OUTCOME`` reply, in that order; immediate frames act
at once:

========  ====  =========================================================  ==========
frame     type  payload                                                    queued
========  ====  =========================================================  ==========
LINE      0x10  x, y: int32: a relative move                               yes
ARC       0x11  x0, y0, x1, y1: int32, relative to the centre; cw: uint8   yes
DWELL     0x12  clocks: uint32                                             yes
FEED      0x13  cruise, exit: uint24 step rates (steps a clock, Q0.24);    yes
                decelerate: uint24 (steps before the ramp down to exit);
                flags: uint8 (bit 0: the move is a rapid, G0: the rapid
                override applies to it, not the feed override);
                for the next move (LINE or ARC); a move starts at the
                rate the one before it ended at
STOP      0x14  (none): the end of a program                               yes
CONFIG    0x15  accel: uint32, the rate's change a clock (Q0.40); takes    yes
                effect when dispatched: send it while nothing moves
LINE3     0x18  x, y, z: int32: a relative move on three axes (only a      yes
                3-axis controller knows the type: ERROR 2 on others)
HELIX     0x19  x0, y0, x1, y1: int32, cw: uint8 (ARC's fields); z:       yes
                int32, the Z move; n: uint32, the arc's step count (Z's
                steps are spread over the arc's n steps; |z| > n is
                REFUSED); only on a 3-axis controller. Bits 1-2 of
                the cw byte: the plane, 0 G17, 1 G18, 2 G19 (x, y, z
                are then the plane's first, second and normal axis:
                Z X Y in G18, Y Z X in G19; 3 is REFUSED)
PROFILE   0x16  one frame of the controller's equidistant engine (cutter    yes
                compensation, :class:`kontur.hdl.equidistant.EquidistantEngine`):
                the bits of its ``Frame(formats)`` layout, least
                significant first, in ``ceil(bits / 8)`` bytes (38 at the
                engine's width 16); a move like LINE and ARC, with the
                FEED before it. Only a controller built with a profile
                engine knows the type; to any other it is unknown (ERROR 2)
QUERY     0x20  (none): asks for a STATUS reply                            no
ABORT     0x21  (none): stops the motion at once and ends every queued     no
                frame ABORTED
UNLOCK    0x22  (none): leaves ALARM, unless the e-stop is still active;   no
                answered by a STATUS (whose state says whether it did)
HOLD      0x23  (none): feed hold: the motion ramps down along the path     no
                at the configured acceleration to a standstill (HOLD)
RESUME    0x24  (none): leaves the hold: the motion ramps back up          no
OVERRIDE  0x25  feed: uint16, the feed override as a factor, Q2.7 (128     no
                is 100 %; 13 to 256, 10 % to 200 %); rapid: uint8, the
                rapid override in percent (100, 50 or 25); spindle:
                uint16, the spindle override as a factor, Q2.7 (13 to
                256: S times it, for the tool outputs' PWM); a value
                out of range drops the frame (ERROR 6), nothing changed
========  ====  =========================================================  ==========

Machine to host:

========  ====  ==========================================================
frame     type  payload
========  ====  ==========================================================
OUTCOME   0x80  number: uint8 (the queued frame's, counted from 0 after
                reset); outcome: uint8 (0 done, 1 refused, 2 aborted)
STATUS    0x81  x, y: int32 absolute position (the steps made on the pins;
                on a 3-axis controller x, y, z: 24 bytes in all);
                free: uint8 queue slots; flags: uint8 (bit 0 moving, bit 1
                an error was reported, bit 2 at a standstill under feed
                hold); state: uint8 (:data:`STATES`);
                alarm: uint8, the inputs that tripped since ALARM began
                (bit 0 e-stop, 1 limit X, 2 limit Y, 6 limit Z; 0 out of
                ALARM);
                inputs: uint8, the inputs active now, filtered (bit 0
                e-stop, 1 limit X, 2 limit Y, 3 probe, 4 cycle start, 5
                feed hold, 6 limit Z on 3 axes); rate: uint32, the feed generator's rate
                now (steps a clock, Q0.24); feed: uint16, the feed
                override (Q2.7); rapid: uint8, the rapid override (%)
ERROR     0x82  code: uint8 (:data:`ERRORS`); a frame was dropped, never executed
========  ====  ==========================================================

HOLD, RESUME and OVERRIDE act in the clock their CRC checks, however many frames are queued
(the feed-hold and cycle-start buttons do what HOLD and RESUME do, on their press). A STATUS
answers a QUERY (or an UNLOCK) ahead of any OUTCOME still waiting: it is sent as
soon as the reply being sent is out. In ALARM (an e-stop or a limit switch tripped: see
:mod:`kontur.hdl.motion.alarm`) every queued frame that comes ends ``REFUSED`` without
running (one that came before the trip ends ``ABORTED``).

The length of every frame type is fixed, but PROFILE's, which is the engine's: a decoder knows
the lengths of its controller (:func:`host_lengths`), and a controller without the engine has
no PROFILE type at all, so it is exactly as small as one built before the type existed.

Flow control: the host keeps at most the queue's length (``STATUS.free`` right after reset)
queued frames sent and not yet answered; each is answered by its ``OUTCOME``, or by an
``ERROR`` when it was dropped. The queue can then never overflow, and it never starves while
the host has frames to send. (After serial noise, which also draws an ``ERROR``, the host
resynchronises its count from ``STATUS.free``.)
"""

from amaranth import *
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from .feed import OVERRIDE_ONE
from .queue import QueueWriteSignature

__all__ = ["SYNC", "LINE", "ARC", "LINE3", "HELIX", "STATUS_LENGTHS", "DWELL", "FEED", "STOP", "CONFIG", "PROFILE", "QUERY",
           "ABORT", "UNLOCK", "HOLD", "RESUME", "OVERRIDE", "IMMEDIATE", "RAPID_PERCENT",
           "FEED_OVERRIDE_RANGE", "OUTCOME", "STATUS", "ERROR", "STATES",
           "QUEUED", "LENGTHS", "ERRORS", "PAYLOAD_BYTES",
           "host_lengths", "profile_bytes", "crc16_byte", "FrameDecoder", "FrameEncoder"]

SYNC = 0xA5
LINE, ARC, DWELL, FEED, STOP, CONFIG, PROFILE = 0x10, 0x11, 0x12, 0x13, 0x14, 0x15, 0x16
#: The third axis's moves (issue 28): known only to a 3-axis controller (its engine table's).
LINE3, HELIX = 0x18, 0x19
QUERY, ABORT, UNLOCK, HOLD, RESUME, OVERRIDE = 0x20, 0x21, 0x22, 0x23, 0x24, 0x25
OUTCOME, STATUS, ERROR = 0x80, 0x81, 0x82

#: Frames that go into the queue.
QUEUED = (LINE, ARC, DWELL, FEED, STOP, CONFIG, PROFILE)

#: Frames that act at once.
IMMEDIATE = (QUERY, ABORT, UNLOCK, HOLD, RESUME, OVERRIDE)

#: OVERRIDE's rapid percentages, by the feed generator's shift (0, 1, 2).
RAPID_PERCENT = (100, 50, 25)

#: OVERRIDE's feed and spindle factors (Q2.7): 10 % to 200 %.
FEED_OVERRIDE_RANGE = (13, 256)

#: Payload length of every frame type of fixed length, both directions (PROFILE's is the
#: controller's: :func:`host_lengths`).
LENGTHS = {LINE: 8, ARC: 17, DWELL: 4, FEED: 10, STOP: 0, CONFIG: 4, QUERY: 0, ABORT: 0,
           UNLOCK: 0, HOLD: 0, RESUME: 0, OVERRIDE: 5, OUTCOME: 2, STATUS: 20, ERROR: 1,
           LINE3: 12, HELIX: 25}

#: STATUS's payload length by the controller's axes (a position of 4 bytes per axis).
STATUS_LENGTHS = {2: 20, 3: 24}

#: STATUS's state codes (:class:`kontur.hdl.motion.alarm.State`).
STATES = ("IDLE", "RUN", "HOLD", "HOMING", "ALARM")

#: ERROR codes.
ERRORS = {1: "CRC mismatch", 2: "unknown frame type", 3: "wrong payload length",
          4: "serial framing error or overrun", 5: "frame queue full",
          6: "override out of range"}



def host_lengths(profile=None):
    """The payload length of every frame type from the host to a controller whose PROFILE
    frames carry ``profile`` bytes (``None``: a controller without a profile engine, which
    does not know the type); a dict: the fixed types in the order of :data:`QUEUED`, then
    :data:`IMMEDIATE`, then PROFILE.

    Raises
    ------
    :exc:`ValueError`
        If ``profile`` is not an integer from 1 to 255 (a length byte).
    """
    table = {kind: LENGTHS[kind] for kind in QUEUED + IMMEDIATE if kind in LENGTHS}
    if profile is not None:
        if isinstance(profile, bool) or not isinstance(profile, int) or not 1 <= profile <= 255:
            raise ValueError(f"A PROFILE payload must be 1 to 255 bytes, not {profile!r}")
        table[PROFILE] = profile
    return table


def profile_bytes(layout):
    """The PROFILE payload length (bytes) for an engine frame of ``layout``: its bits, least
    significant first, in whole bytes."""
    return (data.Layout.cast(layout).size + 7) // 8


#: The longest payload of a frame from the host (without PROFILE: :func:`host_lengths`).
PAYLOAD_BYTES = max(host_lengths().values())


def crc16_byte(m, crc, byte):
    """The CRC-16/CCITT (polynomial 0x1021) of ``crc`` followed by ``byte``, formed in ``m``'s
    combinational domain, one bit at a time (most significant first); returns the signal."""
    for i in range(7, -1, -1):
        top = Signal(name=f"crc_top{i}")
        following = Signal(16, name=f"crc_bit{i}")
        m.d.comb += [
            top.eq(crc[15] ^ byte[i]),
            following.eq(Cat(top, crc[:15]) ^ Mux(top, 0x1020, 0)),   # shift, feed back 0x1021
        ]
        crc = following
    return crc


class FrameDecoder(wiring.Component):
    """Bytes from the host in, checked frames into the frame queue; a corrupt frame dropped.

    The decoder hunts for the sync byte and takes the type and the length: an unknown type or
    a length that is not the type's drops the frame at once (``ERROR`` codes 2 and 3). A
    queued type is written into the frame queue (:class:`~kontur.hdl.motion.queue.FrameQueue`) as it
    arrives, its type byte then its payload, and committed only when its CRC checks; a frame
    whose CRC does not check is rolled back (code 1), one the queue has no room for is dropped
    (code 5), so the reader never sees a byte of a dropped frame. An immediate type signals
    on :py:`query`, :py:`abort`, :py:`unlock`, :py:`hold`, :py:`resume` or :py:`override`
    when its CRC checks (an OVERRIDE with its values, or dropped with code 6 if one is out
    of range). :py:`error` carries the code of each
    dropped frame (and of the serial errors given on :py:`line_error`, code 4).

    Parameters
    ----------
    profile : :class:`int` or ``None``
        The PROFILE payload length of the controller's profile engine (:func:`profile_bytes`);
        ``None`` (the default): the controller has none, and PROFILE is an unknown type.
    queued : :class:`dict` or ``None``
        Instead of ``profile``: the payload length of every queued frame type the controller
        knows (its engine table's types and the fixed ones); the immediate types
        (:data:`IMMEDIATE`) are added.
    overrides : :class:`bool`
        With ``False`` (a controller built without the overrides) an OVERRIDE frame is taken
        but none of its values is read or checked: :py:`override` signals with 100 % (feed
        and spindle factors 128, rapid shift 0).

    Members
    -------
    i : :py:`In(stream.Signature(8))`
        Bytes from the host.
    line_error : :py:`In(1)`
        A character was lost on the line (framing error or overrun).
    q : :py:`Out(QueueWriteSignature())`
        To the frame queue's write side (bytes, commit, rollback; the room left).
    query, abort, unlock, hold, resume, override : :py:`Out(1)`
        A checked QUERY, ABORT, UNLOCK, HOLD, RESUME or OVERRIDE frame (its values in range)
        ended in this clock.
    feed_override : :py:`Out(9)`
        The OVERRIDE's feed factor (Q2.7), valid with :py:`override`.
    rapid_override : :py:`Out(2)`
        The OVERRIDE's rapid override as the feed generator's shift (0, 1, 2 for 100, 50,
        25 %), valid with :py:`override`.
    spindle_override : :py:`Out(9)`
        The OVERRIDE's spindle factor (Q2.7), valid with :py:`override`.
    error : :py:`Out(stream.Signature(8))`
        Codes of dropped frames (:data:`ERRORS`); a code not yet taken is replaced by the
        next.

    Raises
    ------
    :exc:`ValueError`
        If ``profile`` is not a length byte (1 to 255), a length of ``queued`` not a byte
        (0 to 255), or both are given.
    """

    def __init__(self, *, profile=None, queued=None, overrides=True):
        if not isinstance(overrides, bool):
            raise TypeError(f"Overrides must be True or False, not {overrides!r}")
        self._overrides = overrides
        if queued is None:
            self._lengths = host_lengths(profile)
            self._queued = frozenset(QUEUED)
        else:
            if profile is not None:
                raise ValueError("A decoder takes a PROFILE length or the queued types' "
                                 "lengths, not both")
            for kind, count in queued.items():
                if isinstance(count, bool) or not isinstance(count, int) or \
                        not 0 <= count <= 255:
                    raise ValueError(f"A payload length must be 0 to 255 bytes, not {count!r} "
                                     f"(type {kind:#04x})")
            # The fixed types first, in the order of host_lengths(), then the others.
            self._lengths = {kind: queued.get(kind, count)
                             for kind, count in host_lengths().items()
                             if kind in queued or kind not in QUEUED}
            self._lengths.update(queued)
            self._queued = frozenset(queued)
        super().__init__({
            "i":          In(stream.Signature(8)),
            "line_error": In(1),
            "q":          Out(QueueWriteSignature()),
            "query":      Out(1),
            "abort":      Out(1),
            "unlock":     Out(1),
            "hold":       Out(1),
            "resume":     Out(1),
            "override":   Out(1),
            "feed_override":  Out(9),
            "rapid_override": Out(2),
            "spindle_override": Out(9),
            "error":      Out(stream.Signature(8)),
        })

    @property
    def lengths(self):
        """The payload length of every frame type it takes (:func:`host_lengths`)."""
        return dict(self._lengths)

    def elaborate(self, platform):
        m = Module()
        longest = max(self._lengths.values())
        byte = self.i.payload
        kind = Signal(8)
        queued = Signal()                       # the frame goes into the queue
        length = Signal(range(longest + 1))
        index = Signal(range(longest + 1))
        crc = Signal(16)
        received = Signal(8)                    # the CRC's first (high) byte
        crc_next = crc16_byte(m, crc, byte)
        # An OVERRIDE's payload: the last five payload bytes taken, shifted in as they pass
        # (without the overrides none is kept: the frame is taken, its values 100 %).
        values = Signal(40 if self._overrides else 0)
        in_range = Signal()
        if self._overrides:
            feed_factor = values[:16]
            rapid_percent = values[16:24]
            spindle_factor = values[24:]
            m.d.comb += [
                in_range.eq((feed_factor >= FEED_OVERRIDE_RANGE[0]) &
                            (feed_factor <= FEED_OVERRIDE_RANGE[1]) &
                            (spindle_factor >= FEED_OVERRIDE_RANGE[0]) &
                            (spindle_factor <= FEED_OVERRIDE_RANGE[1]) &
                            ((rapid_percent == RAPID_PERCENT[0]) |
                             (rapid_percent == RAPID_PERCENT[1]) |
                             (rapid_percent == RAPID_PERCENT[2]))),
                self.feed_override.eq(feed_factor),
                self.spindle_override.eq(spindle_factor),
                self.rapid_override.eq(Mux(rapid_percent == RAPID_PERCENT[0], 0,
                                           Mux(rapid_percent == RAPID_PERCENT[1], 1, 2))),
            ]
        else:
            m.d.comb += [in_range.eq(1), self.feed_override.eq(OVERRIDE_ONE),
                         self.spindle_override.eq(OVERRIDE_ONE), self.rapid_override.eq(0)]
        take = self.i.valid & self.i.ready
        m.d.comb += self.q.data.eq(byte)

        code = Signal(8)                        # an error to report; 0: none
        m.d.comb += [self.error.valid.eq(code != 0), self.error.payload.eq(code)]
        with m.If(self.error.ready):
            m.d.sync += code.eq(0)

        known = Signal()
        queued_type = Signal()
        expected = Signal(range(longest + 1))
        with m.Switch(byte):
            for frame_type, count in self._lengths.items():
                with m.Case(frame_type):
                    m.d.comb += [known.eq(1), expected.eq(count),
                                 queued_type.eq(frame_type in self._queued)]

        def drop(error_code, rollback):
            m.d.sync += code.eq(error_code)
            if rollback:
                m.d.comb += self.q.rollback.eq(queued)
            m.next = "Hunt"

        with m.FSM(name="decoder") as fsm:
            with m.State("Hunt"):
                with m.If(take & (byte == SYNC)):
                    m.d.sync += crc.eq(0xFFFF)
                    m.next = "Type"
            with m.State("Type"):
                with m.If(take):
                    with m.If(~known):
                        drop(2, rollback=False)
                    with m.Elif(queued_type & (self.q.room < expected + 1)):
                        drop(5, rollback=False)
                    with m.Else():
                        m.d.comb += self.q.en.eq(queued_type)
                        m.d.sync += [kind.eq(byte), queued.eq(queued_type),
                                     length.eq(expected), crc.eq(crc_next)]
                        m.next = "Length"
            with m.State("Length"):
                with m.If(take):
                    with m.If(byte == length):
                        m.d.sync += [crc.eq(crc_next), index.eq(0)]
                        m.next = "Payload"
                    with m.Else():
                        drop(3, rollback=True)
            with m.State("Payload"):
                with m.If(index == length):
                    m.next = "CRC high"
                with m.Elif(self.i.valid):          # (ready here)
                    m.d.comb += self.q.en.eq(queued)
                    m.d.sync += [index.eq(index + 1), crc.eq(crc_next)]
                    if OVERRIDE in self._lengths and self._overrides:
                        m.d.sync += values.eq(Cat(values[8:], byte))
            with m.State("CRC high"):
                with m.If(take):
                    m.d.sync += received.eq(byte)
                    m.next = "CRC low"
            with m.State("CRC low"):
                with m.If(take):
                    with m.If(Cat(byte, received) != crc):
                        drop(1, rollback=True)
                    with m.Elif((kind == OVERRIDE) & ~in_range):
                        drop(6, rollback=False)
                    with m.Else():
                        m.d.comb += [
                            self.q.commit.eq(queued),
                            self.query.eq(kind == QUERY),
                            self.abort.eq(kind == ABORT),
                            self.unlock.eq(kind == UNLOCK),
                            self.hold.eq(kind == HOLD),
                            self.resume.eq(kind == RESUME),
                            self.override.eq(kind == OVERRIDE),
                        ]
                        m.next = "Hunt"
        # Every byte is taken at once, but in the clock between a payload and its CRC.
        m.d.comb += self.i.ready.eq(~(fsm.ongoing("Payload") & (index == length)))
        # A serial error is the newest news (after this clock's frame error, if any).
        with m.If(self.line_error):
            m.d.sync += code.eq(4)
        return m


class FrameEncoder(wiring.Component):
    """Replies out as frames: one reply in, its bytes (sync, type, length, payload, CRC) out.

    ``axes`` (2 or 3) sets STATUS's length (:data:`STATUS_LENGTHS`).

    Members
    -------
    i : :py:`In(stream.Signature(Reply(axes)))`
        A reply: its type and payload bytes (only the type's length of them is sent).
    o : :py:`Out(stream.Signature(8))`
        The bytes, one frame after another.
    """

    @staticmethod
    def Reply(axes=2):
        return data.StructLayout({"kind": 8, "payload": data.ArrayLayout(
            8, max(LENGTHS[OUTCOME], STATUS_LENGTHS[axes], LENGTHS[ERROR]))})

    def __init__(self, axes=2):
        if axes not in STATUS_LENGTHS:
            raise ValueError(f"Axes must be 2 or 3, not {axes!r}")
        self._axes = axes
        super().__init__({"i": In(stream.Signature(self.Reply(axes))),
                          "o": Out(stream.Signature(8))})

    def elaborate(self, platform):
        m = Module()
        reply = Signal(self.Reply(self._axes))
        length = Signal(8)
        index = Signal(range(len(reply.payload) + 1))
        crc = Signal(16)
        sent = self.o.valid & self.o.ready
        crc_next = crc16_byte(m, crc, self.o.payload)
        lengths = {OUTCOME: LENGTHS[OUTCOME], STATUS: STATUS_LENGTHS[self._axes],
                   ERROR: LENGTHS[ERROR]}
        length_of = Signal(8)
        with m.Switch(self.i.payload.kind):
            for kind, count in lengths.items():
                with m.Case(kind):
                    m.d.comb += length_of.eq(count)

        with m.FSM(name="encoder"):
            with m.State("Idle"):
                m.d.comb += self.i.ready.eq(1)
                with m.If(self.i.valid):
                    m.d.sync += [reply.eq(self.i.payload), length.eq(length_of),
                                 crc.eq(0xFFFF)]
                    m.next = "Sync"
            with m.State("Sync"):
                m.d.comb += [self.o.valid.eq(1), self.o.payload.eq(SYNC)]
                with m.If(sent):
                    m.next = "Type"
            with m.State("Type"):
                m.d.comb += [self.o.valid.eq(1), self.o.payload.eq(reply.kind)]
                with m.If(sent):
                    m.d.sync += crc.eq(crc_next)
                    m.next = "Length"
            with m.State("Length"):
                m.d.comb += [self.o.valid.eq(1), self.o.payload.eq(length)]
                with m.If(sent):
                    m.d.sync += [crc.eq(crc_next), index.eq(0)]
                    m.next = "Payload"
            with m.State("Payload"):
                with m.If(index == length):
                    m.next = "CRC high"
                with m.Else():
                    byte = reply.payload[index]
                    m.d.comb += [self.o.valid.eq(1), self.o.payload.eq(byte)]
                    with m.If(sent):
                        m.d.sync += [crc.eq(crc_next), index.eq(index + 1)]
            with m.State("CRC high"):
                m.d.comb += [self.o.valid.eq(1), self.o.payload.eq(crc[8:])]
                with m.If(sent):
                    m.next = "CRC low"
            with m.State("CRC low"):
                m.d.comb += [self.o.valid.eq(1), self.o.payload.eq(crc[:8])]
                with m.If(sent):
                    m.next = "Idle"
        return m
