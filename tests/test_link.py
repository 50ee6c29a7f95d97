"""The host link: frames decoded and checked as the reference parser does, replies encoded."""

import random
import unittest

from hdl.motion.link import (ABORT, ARC, DWELL, FEED, LINE, OUTCOME, PAYLOAD_BYTES, QUERY,
                             STATUS, STOP, SYNC, ERROR, FrameDecoder, FrameEncoder)
from sim.host import protocol

from .utils import simulate


def random_frames(rng, count):
    """Bytes of ``count`` frames, good and bad, with noise between some of them."""
    stream = bytearray()
    for _ in range(count):
        kind = rng.choice([LINE, ARC, DWELL, FEED, STOP, QUERY, ABORT])
        payload = bytes(rng.randrange(256) for _ in range(protocol.LENGTHS[kind]))
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
    def decode(self, data, *, seed):
        rng = random.Random(seed)
        dut = FrameDecoder()
        events = []

        async def testbench(ctx):
            queue = list(data)
            for _ in range(len(data) * 4 + 100):
                ctx.set(dut.i.valid, bool(queue) and rng.random() < 0.7)
                if queue:
                    ctx.set(dut.i.payload, queue[0])
                ready = rng.random() < 0.6
                ctx.set(dut.o.ready, ready)
                ctx.set(dut.error.ready, 1)
                if ctx.get(dut.o.valid) and ready:
                    command = ctx.get(dut.o.payload)
                    length = protocol.LENGTHS[command.kind]
                    events.append(("frame", command.kind,
                                   bytes(command.payload[i] for i in range(length))))
                if ctx.get(dut.query):
                    events.append(("query",))
                if ctx.get(dut.abort):
                    events.append(("abort",))
                if ctx.get(dut.error.valid):
                    events.append(("error", ctx.get(dut.error.payload)))
                if queue and ctx.get(dut.i.valid) and ctx.get(dut.i.ready):
                    queue.pop(0)
                await ctx.tick()
            self.assertEqual(queue, [])

        simulate(dut, testbench, name=f"link_decoder_{seed}")
        return events

    def test_random_frames_as_the_reference(self):
        for seed in range(3):
            data = random_frames(random.Random(seed), 150)
            expected = protocol.CommandParser().feed(data)
            self.assertEqual(self.decode(data, seed=seed), expected)
            self.assertGreater(sum(e[0] == "error" for e in expected), 10)
            self.assertGreater(sum(e[0] == "frame" for e in expected), 50)

    def test_reference_never_passes_a_damaged_frame(self):
        rng = random.Random(7)
        for _ in range(300):
            kind = rng.choice([LINE, ARC, FEED])
            payload = bytes(rng.randrange(256) for _ in range(protocol.LENGTHS[kind]))
            good = protocol.frame(kind, payload)
            self.assertEqual(protocol.CommandParser().feed(good), [("frame", kind, payload)])
            bad = bytearray(good)
            bad[rng.randrange(1, len(bad))] ^= 1 << rng.randrange(8)
            events = protocol.CommandParser().feed(bytes(bad) + protocol.stop())
            self.assertNotIn(("frame", kind, payload), events)
            self.assertEqual(events[-1], ("frame", STOP, b""))          # and recovers
            self.assertTrue(any(e[0] == "error" for e in events))

    def test_payload_bytes(self):
        self.assertEqual(PAYLOAD_BYTES, 17)
        with self.assertRaisesRegex(ValueError,
                r"^A frame of type 0x10 has 8 payload bytes, not 3$"):
            protocol.frame(LINE, b"abc")


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
