"""The host side of the link protocol of :mod:`kontur.hdl.motion.link`: frames as bytes, replies back.

The frame types, payload lengths and error codes are :mod:`kontur.hdl.motion.link`'s own constants;
the CRC is :func:`binascii.crc_hqx` (CRC-16/CCITT, initial value 0xFFFF), which the gateware's
``crc16_byte`` reproduces bit for bit. A PROFILE frame (:func:`profile`) packs a frame of the
equidistant engine with the engine's own layout (:meth:`kontur.hdl.equidistant.EquidistantEngine.Frame`),
so host and gateware cannot disagree on a bit of it.

Pure Python beside the gateware it speaks to: the host (:mod:`kontur.send`,
:mod:`kontur.planner`) and the simulated host of the RTL runs (:mod:`kontur.sim.testbench.hostlink`)
both use it, so it stands below both.
"""

import binascii
import struct
from dataclasses import dataclass

from kontur.hdl.motion.link import (ABORT, ARC, CONFIG, DWELL, ERROR, ERRORS, FEED,
                                    FEED_OVERRIDE_RANGE, HELIX, HOLD, LENGTHS, LINE, LINE3,
                                    OUTCOME, OVERRIDE, PROFILE, QUERY, RAPID_PERCENT, RESUME,
                                    STATES, STATUS, STATUS_LENGTHS, STOP, SYNC, UNLOCK,
                                    host_lengths, profile_bytes)

__all__ = ["frame", "line", "arc", "line3", "helix", "dwell", "parse_reply", "feed", "stop", "config", "profile",
           "profile_layout", "query", "abort", "unlock", "hold", "resume", "override",
           "feed_factor", "FEED_PERCENT", "Reply", "ReplyParser", "CommandParser", "crc"]


def crc(body):
    """CRC-16/CCITT of ``body`` (type, length, payload)."""
    return binascii.crc_hqx(bytes(body), 0xFFFF)


def frame(kind, payload=b""):
    """The bytes of a frame of type ``kind`` with ``payload`` (a PROFILE frame's length is its
    engine's: any from 1 to 255 bytes; a STATUS's 20 or 24 bytes, by the controller's axes)."""
    payload = bytes(payload)
    if kind == PROFILE:
        if not 1 <= len(payload) <= 255:
            raise ValueError(f"A PROFILE frame has 1 to 255 payload bytes, not {len(payload)}")
    elif LENGTHS.get(kind) != len(payload) and not (
            kind == STATUS and len(payload) in STATUS_LENGTHS.values()):   # 2 or 3 axes
        raise ValueError(f"A frame of type {kind:#04x} has {LENGTHS.get(kind)} payload bytes, "
                         f"not {len(payload)}")
    body = bytes([kind, len(payload)]) + payload
    return bytes([SYNC]) + body + crc(body).to_bytes(2, "big")


def line(x, y):
    return frame(LINE, struct.pack("<ii", x, y))


def arc(x0, y0, x1, y1, cw):
    return frame(ARC, struct.pack("<iiiiB", x0, y0, x1, y1, int(bool(cw))))


def line3(x, y, z):
    """A LINE3 frame: a relative move on three axes (a 3-axis controller's)."""
    return frame(LINE3, struct.pack("<iii", x, y, z))


def helix(x0, y0, x1, y1, cw, z, n, plane=0):
    """A HELIX frame: an ARC's fields, the Z move ``z`` (steps) and the arc's step count ``n``
    over which the Z steps are spread (a 3-axis controller's; ``|z| > n`` is refused), in
    ``plane`` 0, 1 or 2 (G17, G18, G19: the fields named X, Y, Z are the plane's first,
    second and normal axis, :class:`kontur.hdl.helix.HelixEngine`), in bits 1-2 of the ``cw``
    byte."""
    if plane not in (0, 1, 2):
        raise ValueError(f"A HELIX frame's plane is 0, 1 or 2, not {plane!r}")
    return frame(HELIX, struct.pack("<iiiiBiI", x0, y0, x1, y1, int(bool(cw)) | plane << 1,
                                    z, n))


def dwell(clocks):
    return frame(DWELL, struct.pack("<I", clocks))


def _unsigned(name, value, bits):
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 1 << bits:
        raise ValueError(f"{name} must be an unsigned {bits}-bit integer, not {value!r}")
    return value.to_bytes(bits // 8, "little")


def feed(cruise, exit, decelerate, *, rapid=False):
    """A FEED frame for the next move: its cruise and exit rates in steps a clock (Q0.24
    integers), the steps it makes before ramping down to the exit rate, and whether it is a
    rapid (G0: the rapid override applies to it, not the feed override)."""
    return frame(FEED, _unsigned("FEED cruise", cruise, 24) + _unsigned("FEED exit", exit, 24)
                 + _unsigned("FEED decelerate", decelerate, 24) + bytes([int(bool(rapid))]))


def config(accel):
    """A CONFIG frame: the acceleration, the rate's change a clock (Q0.40 integer)."""
    return frame(CONFIG, _unsigned("CONFIG accel", accel, 32))


def stop():
    return frame(STOP)


def profile_layout(width, fraction=None):
    """The frame layout of the equidistant engine of coordinate width ``width`` (and
    ``fraction`` fractional bits, default ``width + 4``): what a PROFILE frame carries."""
    from kontur.hdl.equidistant import EquidistantEngine, Formats
    return EquidistantEngine.Frame(Formats(width, fraction))


def profile(fields, *, width, fraction=None):
    """A PROFILE frame: one frame of the equidistant engine (``fields``: a dict of the frame's
    fields, as :func:`kontur.sim.models.equidistant.prepare` gives them, missing ones zero) for an
    engine of ``width`` (and ``fraction``); its layout's bits, least significant first, in
    :func:`~kontur.hdl.motion.link.profile_bytes` bytes.

    Raises
    ------
    :exc:`ValueError`
        For a field the layout does not have, or a value that does not fit its field.
    """
    from amaranth import Shape
    layout = profile_layout(width, fraction)
    names = {name for name, _ in layout}
    for name, value in fields.items():
        if name not in names:
            raise ValueError(f"The equidistant engine's frame has no field {name!r}")
        shape = Shape.cast(layout[name].shape)
        low = -(1 << (shape.width - 1)) if shape.signed else 0
        high = (1 << (shape.width - 1 if shape.signed else shape.width)) - 1
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise ValueError(f"PROFILE field {name} must be an integer from {low} to {high}, "
                             f"not {value!r}")
    bits = layout.const(dict(fields)).as_bits()
    return frame(PROFILE, bits.to_bytes(profile_bytes(layout), "little"))


def query():
    return frame(QUERY)


def abort():
    return frame(ABORT)


def unlock():
    return frame(UNLOCK)


def hold():
    return frame(HOLD)


def resume():
    return frame(RESUME)


#: The feed override a host may ask for, percent (OVERRIDE's factor range).
FEED_PERCENT = (10, 200)


def feed_factor(percent, what="feed"):
    """OVERRIDE's feed (or spindle: ``what``) factor (Q2.7, 128 is 100 %) nearest
    ``percent`` (a whole number from 10 to 200)."""
    if isinstance(percent, bool) or not isinstance(percent, int) or \
            not FEED_PERCENT[0] <= percent <= FEED_PERCENT[1]:
        raise ValueError(f"The {what} override must be a whole percentage from "
                         f"{FEED_PERCENT[0]} to {FEED_PERCENT[1]}, not {percent!r}")
    factor = (percent * 128 + 50) // 100
    assert FEED_OVERRIDE_RANGE[0] <= factor <= FEED_OVERRIDE_RANGE[1]
    return factor


def override(feed=100, rapid=100, spindle=100):
    """An OVERRIDE frame: the feed override (percent, 10 to 200, sent as its factor:
    :func:`feed_factor`), the rapid override (percent: 100, 50 or 25) and the spindle
    override (percent, 10 to 200, sent as its factor)."""
    if rapid not in RAPID_PERCENT or isinstance(rapid, bool):
        raise ValueError(f"The rapid override must be 100, 50 or 25 %, not {rapid!r}")
    return frame(OVERRIDE, feed_factor(feed).to_bytes(2, "little") + bytes([rapid])
                 + feed_factor(spindle, "spindle").to_bytes(2, "little"))


#: The bits of STATUS's inputs byte and alarm byte (:data:`kontur.hdl.motion.inputs.INPUTS3`:
#: bit 6 is Z's limit, on a 3-axis controller).
INPUT_NAMES = ("estop", "limit_x", "limit_y", "probe", "cycle_start", "feed_hold", "limit_z")


def input_names(bits):
    """The names of the inputs set in a STATUS's inputs (or alarm) byte."""
    return [name for bit, name in enumerate(INPUT_NAMES) if bits >> bit & 1]


@dataclass(frozen=True)
class Reply:
    """A reply from the machine: ``kind`` (OUTCOME, STATUS, ERROR) and its fields (a STATUS's:
    ``x, y, free, flags, state, alarm, inputs, rate, feed, rapid``); a 3-axis controller's
    STATUS (24 bytes) has ``z`` too, apart, so the fields are the same on both."""
    kind: int
    fields: tuple
    z: int = None

    @property
    def position(self):
        """A STATUS's position: ``(x, y)``, or ``(x, y, z)`` from a 3-axis controller."""
        return tuple(self.fields[:2]) + (() if self.z is None else (self.z,))

    def payload(self):
        """The reply's payload bytes (the inverse of :func:`parse_reply`)."""
        if self.kind == STATUS and self.z is not None:
            return struct.pack(STATUS3_FORMAT, *self.fields[:2], self.z, *self.fields[2:])
        return struct.pack(ReplyParser.FORMATS[self.kind], *self.fields)

    @property
    def state(self):
        """A STATUS's state, by name (``"IDLE"``, ``"RUN"``, ``"HOLD"``, ``"HOMING"``,
        ``"ALARM"``; ``"state N"`` for a code no controller sends)."""
        code = self.fields[4]
        return STATES[code] if code < len(STATES) else f"state {code}"

    def __str__(self):
        if self.kind == OUTCOME:
            number, outcome = self.fields
            return f"frame {number}: {('done', 'refused', 'aborted')[outcome]}"
        if self.kind == STATUS:
            x, y, free, flags, _, alarm, inputs, rate, feed, rapid = self.fields
            at = f"({x}, {y})" if self.z is None else f"({x}, {y}, {self.z})"
            text = f"{self.state} at {at}, {free} queue slots free, flags {flags:#04x}"
            text += f", rate {rate / (1 << 24):.6f} steps/clock, feed {feed * 100 / 128:.0f} %" \
                    f", rapid {rapid} %"
            if alarm:
                text += f", tripped: {', '.join(input_names(alarm))}"
            if inputs:
                text += f", active: {', '.join(input_names(inputs))}"
            return text
        return f"error: {ERRORS.get(self.fields[0], self.fields[0])}"


#: A 3-axis controller's STATUS: ``x, y, z`` then the rest as on two axes.
STATUS3_FORMAT = "<iiiBBBBBIHB"


def parse_reply(kind, payload):
    """The :class:`Reply` of type ``kind`` with ``payload`` (bytes; a STATUS of 20 or 24)."""
    if kind == STATUS and len(payload) == STATUS_LENGTHS[3]:
        x, y, z, *rest = struct.unpack(STATUS3_FORMAT, payload)
        return Reply(kind, (x, y, *rest), z)
    return Reply(kind, struct.unpack(ReplyParser.FORMATS[kind], payload))


class ReplyParser:
    """Bytes from the machine in (:meth:`feed`), :class:`Reply` objects out.

    Bytes that do not form a frame with a good CRC are skipped (counted in :attr:`dropped`),
    so a reply stream joined in the middle resynchronises at the next good frame.
    """

    FORMATS = {OUTCOME: "<BB", STATUS: "<iiBBBBBIHB", ERROR: "<B"}

    def __init__(self):
        self.buffer = bytearray()
        self.dropped = 0

    def feed(self, data):
        """Take ``data``; return the replies completed by it."""
        self.buffer += data
        replies = []
        while True:
            start = self.buffer.find(bytes([SYNC]))
            if start < 0:
                self.dropped += len(self.buffer)
                self.buffer.clear()
                return replies
            self.dropped += start
            del self.buffer[:start]
            if len(self.buffer) < 3:
                return replies
            kind, length = self.buffer[1], self.buffer[2]
            if kind not in self.FORMATS or (LENGTHS[kind] != length and not (
                    kind == STATUS and length in STATUS_LENGTHS.values())):
                self.dropped += 1
                del self.buffer[:1]
                continue
            if len(self.buffer) < 5 + length:
                return replies
            body = bytes(self.buffer[1:3 + length])
            received = int.from_bytes(self.buffer[3 + length:5 + length], "big")
            if crc(body) != received:
                self.dropped += 1
                del self.buffer[:1]
                continue
            replies.append(parse_reply(kind, body[2:]))
            del self.buffer[:5 + length]


class CommandParser:
    """The machine's frame decoder (:class:`kontur.hdl.motion.link.FrameDecoder`), byte for byte.

    :meth:`feed` returns the events the bytes complete: ``("frame", kind, payload)`` for a
    queued frame, ``("query",)``, ``("abort",)``, ``("unlock",)``, ``("hold",)``,
    ``("resume",)``, ``("override", feed factor, rapid percent, spindle factor)``,
    ``("error", code)`` for a
    dropped frame (code 6 for an OVERRIDE out of range). Like
    the gateware it hunts for the sync byte, drops a frame at its first bad byte (an unknown
    type, a wrong length) or at a bad CRC, and hunts again from the next byte. ``profile`` is
    the PROFILE payload length of the controller decoded (``None``: it has no profile engine,
    and PROFILE is unknown), as :class:`~kontur.hdl.motion.link.FrameDecoder` takes it;
    ``axes=3`` a 3-axis controller's (LINE3 and HELIX known, LINE and ARC not);
    ``overrides=False`` a controller's built without the overrides (an OVERRIDE's values
    neither read nor checked: ``("override", 128, 100, 128)``).
    """

    def __init__(self, *, profile=None, axes=2, overrides=True):
        self.overrides = overrides
        self.lengths = host_lengths(profile)
        if axes == 3:
            del self.lengths[LINE], self.lengths[ARC]
            self.lengths |= {LINE3: LENGTHS[LINE3], HELIX: LENGTHS[HELIX]}
        self.state = "hunt"
        self.kind = self.length = 0
        self.body = bytearray()

    def feed(self, data):
        events = []
        for byte in bytes(data):
            event = self._byte(byte)
            if event is not None:
                events.append(event)
        return events

    def _byte(self, byte):
        if self.state == "hunt":
            if byte == SYNC:
                self.state, self.body = "type", bytearray()
        elif self.state == "type":
            if byte in self.lengths:
                self.kind, self.length = byte, self.lengths[byte]
                self.body.append(byte)
                self.state = "length"
            else:
                self.state = "hunt"
                return ("error", 2)
        elif self.state == "length":
            if byte == self.length:
                self.body.append(byte)
                self.state = "payload" if self.length else "crc high"
            else:
                self.state = "hunt"
                return ("error", 3)
        elif self.state == "payload":
            self.body.append(byte)
            if len(self.body) == 2 + self.length:
                self.state = "crc high"
        elif self.state == "crc high":
            self.high = byte
            self.state = "crc low"
        else:
            self.state = "hunt"
            if (self.high << 8 | byte) != crc(self.body):
                return ("error", 1)
            if self.kind == OVERRIDE and not self.overrides:
                return ("override", 128, RAPID_PERCENT[0], 128)
            if self.kind == OVERRIDE:
                factor, rapid = int.from_bytes(self.body[2:4], "little"), self.body[4]
                spindle = int.from_bytes(self.body[5:7], "little")
                if not FEED_OVERRIDE_RANGE[0] <= factor <= FEED_OVERRIDE_RANGE[1] or \
                        not FEED_OVERRIDE_RANGE[0] <= spindle <= FEED_OVERRIDE_RANGE[1] or \
                        rapid not in RAPID_PERCENT:
                    return ("error", 6)
            if self.kind == QUERY:
                return ("query",)
            if self.kind == ABORT:
                return ("abort",)
            if self.kind == UNLOCK:
                return ("unlock",)
            if self.kind in (HOLD, RESUME):
                return ("hold",) if self.kind == HOLD else ("resume",)
            if self.kind == OVERRIDE:
                return ("override", int.from_bytes(self.body[2:4], "little"), self.body[4],
                        int.from_bytes(self.body[5:7], "little"))
            return ("frame", self.kind, bytes(self.body[2:]))
        return None
