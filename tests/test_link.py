# amaranth: UnusedElaboratable=no
"""The host link: frames decoded and checked as the reference parser does, replies encoded."""

import random
import unittest

from amaranth import Module, Shape
from amaranth.lib import wiring

from kontur.hdl.equidistant import EquidistantEngine, Formats
from kontur.hdl.motion.link import (ABORT, ARC, CONFIG, DWELL, ERROR, FEED, LINE, OUTCOME, OVERRIDE,
                             PAYLOAD_BYTES, PROFILE, QUERY, STATUS, STOP, SYNC, FrameDecoder,
                             FrameEncoder, host_lengths, profile_bytes)
from kontur.hdl.motion.queue import FrameQueue
from kontur.hdl.motion import protocol

from .utils import simulate, used


#: The PROFILE payload of the equidistant engine at width 16 (304 bits).
PROFILE_BYTES = profile_bytes(EquidistantEngine.Frame(Formats(16)))


def random_frames(rng, count, *, profile=None):
    """Bytes of ``count`` frames, good and bad, with noise between some of them (PROFILE
    frames of ``profile`` bytes among them when it is given)."""
    stream = bytearray()
    lengths = host_lengths(profile or PROFILE_BYTES)
    kinds = [LINE, ARC, DWELL, FEED, STOP, CONFIG, QUERY, ABORT] + [PROFILE] * 2 * bool(profile)
    for _ in range(count):
        kind = rng.choice(kinds)
        payload = bytes(rng.randrange(256) for _ in range(lengths[kind]))
        data = bytearray(protocol.frame(kind, payload))
        damage = rng.random()
        if damage < 0.1:
            data[rng.randrange(3, len(data))] ^= 1 << rng.randrange(8)   # payload or CRC
        elif damage < 0.15:
            data[1] = rng.choice([0x00, 0x15, 0x80, 0xFF])                # unknown type
        elif damage < 0.2:
            data[2] ^= 0x40                                               # wrong length
        elif damage < 0.25:
            data = data[:rng.randrange(1, len(data))]                     # cut short
        stream += data
        if rng.random() < 0.2:
            stream += bytes(rng.choice([0x00, 0xFF, 0x13, SYNC]) for _ in range(3))
    return bytes(stream)


class DecoderTestCase(unittest.TestCase):
    def decode(self, data, *, seed, depth=512, profile=None):
        """Decode ``data`` into a frame queue read with random stalls (a decoder whose PROFILE
        frames have ``profile`` bytes); return the events: the frames read back from the
        queue, and the query, abort and error signals."""
        rng = random.Random(seed)
        lengths = host_lengths(profile)
        m = Module()
        m.submodules.decoder = dut = FrameDecoder(profile=profile)
        m.submodules.queue = queue = FrameQueue(depth)
        wiring.connect(m, dut.q, queue.w)
        frames, signals = [], []

        async def testbench(ctx):
            pending = list(data)
            current = []
            for _ in range(len(data) * 4 + 200):
                ctx.set(dut.i.valid, bool(pending) and rng.random() < 0.7)
                if pending:
                    ctx.set(dut.i.payload, pending[0])
                ready = rng.random() < 0.6
                ctx.set(queue.r.ready, ready)
                ctx.set(dut.error.ready, 1)
                if ctx.get(queue.r.valid) and ready:
                    current.append(ctx.get(queue.r.payload))
                    if len(current) == 1 + lengths[current[0]]:
                        frames.append(("frame", current[0], bytes(current[1:])))
                        current = []
                if ctx.get(dut.query):
                    signals.append(("query",))
                if ctx.get(dut.abort):
                    signals.append(("abort",))
                if ctx.get(dut.error.valid):
                    signals.append(("error", ctx.get(dut.error.payload)))
                if pending and ctx.get(dut.i.valid) and ctx.get(dut.i.ready):
                    pending.pop(0)
                await ctx.tick()
            self.assertEqual((pending, current), ([], []))

        simulate(m, testbench, name=f"link_decoder_{seed}")
        return frames, signals

    def test_random_frames_as_the_reference(self):
        for seed in range(3):
            data = random_frames(random.Random(seed), 150)
            expected = protocol.CommandParser().feed(data)
            frames, signals = self.decode(data, seed=seed)
            self.assertEqual(frames, [e for e in expected if e[0] == "frame"])
            self.assertEqual(signals, [e for e in expected if e[0] != "frame"])
            self.assertGreater(sum(e[0] == "error" for e in expected), 10)
            self.assertGreater(sum(e[0] == "frame" for e in expected), 50)

    def test_profile_frames_as_the_reference(self):
        # A controller with the equidistant engine takes PROFILE frames of its engine's length
        # among the others, damaged ones dropped, exactly as the reference parser does.
        data = random_frames(random.Random(11), 120, profile=PROFILE_BYTES)
        expected = protocol.CommandParser(profile=PROFILE_BYTES).feed(data)
        frames, signals = self.decode(data, seed=11, depth=1024, profile=PROFILE_BYTES)
        self.assertEqual(frames, [e for e in expected if e[0] == "frame"])
        self.assertEqual(signals, [e for e in expected if e[0] != "frame"])
        self.assertGreater(sum(e[0] == "frame" and e[1] == PROFILE for e in expected), 15)
        self.assertGreater(sum(e[0] == "error" for e in expected), 10)

    def test_profile_is_unknown_without_the_engine(self):
        # To a controller without the engine a PROFILE frame is an unknown type (ERROR 2):
        # nothing of it reaches the queue, and the frame after it is taken.
        good = protocol.profile({"kind": 2, "k": -5, "b": 1 << 30, "side": -1}, width=16)
        data = good + protocol.line(3, -4) + good + protocol.stop()
        expected = [("error", 2), ("frame", LINE, protocol.line(3, -4)[3:-2]), ("error", 2),
                    ("frame", STOP, b"")]
        self.assertEqual(protocol.CommandParser().feed(data), expected)
        frames, signals = self.decode(data, seed=1)
        self.assertEqual(frames, [e for e in expected if e[0] == "frame"])
        self.assertEqual(signals, [("error", 2), ("error", 2)])
        plain, with_profile = FrameDecoder(), FrameDecoder(profile=38)
        used(plain, with_profile)
        self.assertEqual(plain.lengths, host_lengths())
        self.assertNotIn(PROFILE, host_lengths())
        self.assertEqual(with_profile.lengths[PROFILE], 38)

    def test_queued_types_from_a_table(self):
        # A controller's decoder takes its queued types and lengths from the engine table: a
        # new type (0x17, 8 bytes) is known and queued, PROFILE unknown when not listed; the
        # fixed types keep host_lengths()'s order, QUERY and ABORT included.
        queued = {kind: host_lengths()[kind] for kind in (LINE, ARC, DWELL, FEED, STOP, CONFIG)}
        dut = FrameDecoder(queued=queued | {0x17: 8})
        used(dut)
        self.assertEqual(dut.lengths, host_lengths() | {0x17: 8})
        with self.assertRaisesRegex(ValueError, r"^A payload length must be 0 to 255 bytes, "
                                                r"not 256 \(type 0x17\)$"):
            FrameDecoder(queued={0x17: 256})
        with self.assertRaisesRegex(ValueError, r"^A decoder takes a PROFILE length or the "
                                                r"queued types' lengths, not both$"):
            FrameDecoder(profile=38, queued=queued)

    def test_queue_depth_wrong(self):
        # The room the decoder sees is 16 bits wide: a queue holds at most 32768 bytes.
        for depth in (48, 1 << 16):
            with self.assertRaisesRegex(TypeError, rf"^Queue depth must be a power of 2 up to "
                                                   rf"32768, not {depth}$"):
                FrameQueue(depth)

    def test_queue_full_drops_and_reports(self):
        # A 32-byte queue nobody reads: frames fit until one does not; that one is dropped
        # whole (code 5), and nothing of it is readable.
        data = b"".join(protocol.line(i, -i) for i in range(5))
        m = Module()
        m.submodules.decoder = dut = FrameDecoder()
        m.submodules.queue = queue = FrameQueue(32)
        wiring.connect(m, dut.q, queue.w)
        codes, levels = [], []

        async def testbench(ctx):
            for byte in data:
                ctx.set(dut.i.valid, 1)
                ctx.set(dut.i.payload, byte)
                ctx.set(dut.error.ready, 1)
                while not ctx.get(dut.i.ready):
                    await ctx.tick()
                if ctx.get(dut.error.valid):
                    codes.append(ctx.get(dut.error.payload))
                await ctx.tick()
            for _ in range(4):
                if ctx.get(dut.error.valid):
                    codes.append(ctx.get(dut.error.payload))
                levels.append(ctx.get(queue.r_level))
                await ctx.tick()

        simulate(m, testbench, name="link_queue_full")
        self.assertEqual(levels[-1], 3 * 9)                 # three whole frames of 9 bytes
        self.assertEqual(codes.count(5), 2)

class OverrideTestCase(unittest.TestCase):
    def overrides(self, data, overrides):
        """The (feed factor, rapid percent, spindle factor) of each OVERRIDE the decoder
        signals and the codes of its errors, for ``data`` fed a byte a clock."""
        dut = FrameDecoder(overrides=overrides)
        m = Module()
        m.submodules.decoder = dut
        m.submodules.queue = queue = FrameQueue(256)
        wiring.connect(m, dut.q, queue.w)
        events = []

        async def testbench(ctx):
            ctx.set(dut.error.ready, 1)
            pending = list(data)
            for _ in range(2 * len(data) + 8):
                ctx.set(dut.i.valid, bool(pending))
                ctx.set(dut.i.payload, pending[0] if pending else 0)
                if pending and ctx.get(dut.i.ready):
                    pending.pop(0)
                if ctx.get(dut.override):
                    events.append(("override", ctx.get(dut.feed_override),
                                   (100, 50, 25)[ctx.get(dut.rapid_override)],
                                   ctx.get(dut.spindle_override)))
                if ctx.get(dut.error.valid):
                    events.append(("error", ctx.get(dut.error.payload)))
                await ctx.tick()

        simulate(m, testbench, name=f"link_overrides_{overrides}")
        return events

    def test_overrides_as_the_reference(self):
        # All three values, and out-of-range ones dropped (ERROR 6); built without the
        # overrides, every OVERRIDE is taken at 100 % whatever it carries, none dropped.
        def frame(feed, rapid, spindle):
            return protocol.frame(OVERRIDE, feed.to_bytes(2, "little") + bytes([rapid])
                                  + spindle.to_bytes(2, "little"))
        data = (protocol.override(150, 50, 80) + frame(300, 100, 128) + frame(128, 25, 256)
                + frame(128, 100, 12) + protocol.override(10, 25, 200))
        for overrides in (True, False):
            with self.subTest(overrides=overrides):
                expected = protocol.CommandParser(overrides=overrides).feed(data)
                self.assertEqual(self.overrides(data, overrides), expected)
                if overrides:
                    self.assertEqual(expected, [("override", 192, 50, 102), ("error", 6),
                                                ("override", 128, 25, 256), ("error", 6),
                                                ("override", 13, 25, 256)])
                else:
                    self.assertEqual(expected, [("override", 128, 100, 128)] * 5)


class ReferenceTestCase(unittest.TestCase):
    def test_reference_never_passes_a_damaged_frame(self):
        rng = random.Random(7)
        for _ in range(300):
            kind = rng.choice([LINE, ARC, FEED, CONFIG])
            payload = bytes(rng.randrange(256) for _ in range(protocol.LENGTHS[kind]))
            good = protocol.frame(kind, payload)
            self.assertEqual(protocol.CommandParser().feed(good), [("frame", kind, payload)])
            bad = bytearray(good)
            bad[rng.randrange(1, len(bad))] ^= 1 << rng.randrange(8)
            events = protocol.CommandParser().feed(bytes(bad) + protocol.stop())
            self.assertNotIn(("frame", kind, payload), events)
            self.assertEqual(events[-1], ("frame", STOP, b""))          # and recovers
            self.assertTrue(any(e[0] == "error" for e in events))

    def test_profile_packs_the_engines_layout(self):
        # A PROFILE payload is the engine frame's bits, least significant first: unpacked with
        # the layout it gives every field back; its length is the layout's in whole bytes.
        rng = random.Random(5)
        for width in (12, 16):
            layout = EquidistantEngine.Frame(Formats(width))
            self.assertEqual(profile_bytes(layout), (layout.size + 7) // 8)
            shapes = {name: Shape.cast(field.shape) for name, field in layout}
            for _ in range(20):
                fields = {}
                for name, shape in shapes.items():
                    low = -(1 << (shape.width - 1)) if shape.signed else 0
                    fields[name] = rng.randrange(low, low + (1 << shape.width))
                data = protocol.profile(fields, width=width)
                self.assertEqual(data[:3], bytes([SYNC, PROFILE, profile_bytes(layout)]))
                bits = int.from_bytes(data[3:-2], "little")
                back = {}
                for name, field in layout:
                    value = (bits >> field.offset) & ((1 << field.width) - 1)
                    if shapes[name].signed and value >> (field.width - 1):
                        value -= 1 << field.width
                    back[name] = value
                self.assertEqual(back, fields)
        self.assertEqual(PROFILE_BYTES, 38)
        self.assertEqual(len(protocol.profile({"kind": 1, "x": -3, "y": 4}, width=16)), 43)
        with self.assertRaisesRegex(ValueError, r"^PROFILE field x must be an integer from "
                                                r"-65536 to 65535, not 65536$"):
            protocol.profile({"kind": 1, "x": 1 << 16}, width=16)
        with self.assertRaisesRegex(ValueError, r"no field 'z'"):
            protocol.profile({"z": 1}, width=16)
        with self.assertRaisesRegex(ValueError, r"1 to 255 bytes, not 0"):
            host_lengths(0)

    def test_frames_and_their_checks(self):
        self.assertEqual(PAYLOAD_BYTES, 17)
        with self.assertRaisesRegex(ValueError,
                r"^A frame of type 0x10 has 8 payload bytes, not 3$"):
            protocol.frame(LINE, b"abc")
        with self.assertRaisesRegex(ValueError,
                r"^FEED exit must be an unsigned 24-bit integer, not 16777216$"):
            protocol.feed(0, 1 << 24, 0)
        with self.assertRaisesRegex(ValueError,
                r"^CONFIG accel must be an unsigned 32-bit integer, not -1$"):
            protocol.config(-1)
        self.assertEqual(protocol.feed(1, 2, 3)[3:12], bytes([1, 0, 0, 2, 0, 0, 3, 0, 0]))


class EncoderTestCase(unittest.TestCase):
    def test_replies_parse_back(self):
        rng = random.Random(3)
        replies = []
        for _ in range(40):
            kind = rng.choice([OUTCOME, STATUS, ERROR])
            replies.append((kind, [rng.randrange(256) for _ in range(protocol.LENGTHS[kind])]))
        dut = FrameEncoder()
        out = bytearray()

        async def testbench(ctx):
            queue = list(replies)
            for _ in range(2000):
                ctx.set(dut.i.valid, bool(queue))
                if queue:
                    kind, payload = queue[0]
                    ctx.set(dut.i.payload, {"kind": kind, "payload": payload
                                            + [0] * (10 - len(payload))})
                ready = rng.random() < 0.5
                ctx.set(dut.o.ready, ready)
                if ctx.get(dut.o.valid) and ready:
                    out.append(ctx.get(dut.o.payload))
                if queue and ctx.get(dut.i.ready):
                    queue.pop(0)
                await ctx.tick()

        simulate(dut, testbench, name="link_encoder")
        parser = protocol.ReplyParser()
        got = parser.feed(bytes(out))
        self.assertEqual(parser.dropped, 0)
        self.assertEqual(out, b"".join(protocol.frame(k, bytes(p)) for k, p in replies))
        self.assertEqual(len(got), len(replies))


if __name__ == "__main__":
    unittest.main()
