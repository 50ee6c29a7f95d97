# amaranth: UnusedElaboratable=no
"""The machine controller end to end in Amaranth's simulator: frames over the serial pin,
steps on the step/dir pins, replies back; against the step-level models."""

import binascii
import struct
import unittest

from kontur.hdl.motion.controller import MotionController
from kontur.hdl.motion.dispatch import EngineUnit, raw_bits
from kontur.hdl.motion.link import ERROR, LINE, OUTCOME, QUERY, STATUS
from kontur import registry
from kontur.hdl.motion import protocol

from kontur.sim.testbench.hostlink import run_amaranth, steps_of

from .utils import waves_path

CLOCK, BAUD = 1e6, 125_000                 # 8 clocks a bit: quick to simulate
BIT = round(CLOCK / BAUD)
Q24 = 1 << 24


def controller(**kwargs):
    return MotionController(line=registry.make_engine("line", width=12),
                            arc=registry.make_engine("arc", "fast", width=12),
                            clock_hz=CLOCK, baud=BAUD, dir_setup=1, step_width=2,
                            **kwargs)


def run(frames, *, clocks, depth=8, inject=None, name, engines=()):
    """Send ``frames`` (bytes each) as a host would (at most ``depth`` unanswered queued
    frames), and ``inject`` (clock to bytes) at those clocks; collect the pins and replies.
    Returns ``(moves, replies, trace)``: the ``(clock, dx, dy)`` of every step pulse, the
    replies, and ``(step, dir)`` per clock."""
    trace = []
    result = run_amaranth(controller(queue_frames=depth, engines=engines), frames, divisor=BIT,
                          window=depth,
                          max_clocks=clocks, inject=inject, levels=trace,
                          vcd=waves_path(name))
    moves = [(clock, dx, dy) for (clock, _, _), (dx, dy) in zip(result.steps,
                                                                steps_of(result))]
    return moves, [reply for _, reply in result.replies], trace


def expected(program):
    """The steps of a program of ("line", payload) / ("arc", payload) items."""
    steps = []
    for kind, payload in program:
        steps += registry.steps(kind, payload, registry.KINDS[kind].default_variant
                                if kind == "line" else "fast", width=12)
    return steps


class ControllerTestCase(unittest.TestCase):
    def program(self):
        moves = [("line", {"x": 7, "y": -3}),
                 ("arc", {"x0": 0, "y0": -6, "x1": 6, "y1": 0, "cw": 0}),
                 ("line", {"x": -5, "y": 12}),
                 ("arc", {"x0": 4, "y0": 3, "x1": 4, "y1": 3, "cw": 1})]
        rate = round(0.05 * Q24)                          # a step every 20 clocks
        frames = [protocol.config((1 << 32) - 1)]
        for kind, p in moves:
            frames.append(protocol.feed(rate, rate, 1 << 20))
            frames.append(protocol.line(p["x"], p["y"]) if kind == "line" else
                          protocol.arc(p["x0"], p["y0"], p["x1"], p["y1"], p["cw"]))
        frames.insert(5, protocol.dwell(200))
        frames.append(protocol.stop())
        frames.append(protocol.query())
        return moves, frames

    def test_program(self):
        moves, frames = self.program()
        pins, replies, trace = run(frames, clocks=60_000, name="controller_program")
        self.assertEqual([(dx, dy) for _, dx, dy in pins], expected(moves))
        outcomes = [r.fields for r in replies if r.kind == OUTCOME]
        queued = len(frames) - 1                                   # all but the QUERY
        self.assertEqual(outcomes, [(n, 0) for n in range(queued)])
        (status,) = [r.fields for r in replies if r.kind == STATUS]
        self.assertEqual(status[:2], (sum(dx for _, dx, _ in pins), sum(dy for _, _, dy in pins)))
        self.assertEqual(status[2], 8)                             # the queue is empty again
        # Step pulses 2 clocks long, directions set up 1 clock before and held through them,
        # and never two pulses of an axis closer than the feed allows (20 clocks).
        for axis in range(2):
            level = [(s >> axis) & 1 for s, _ in trace]
            ways = [(d >> axis) & 1 for _, d in trace]
            edges = [c for c in range(1, len(level)) if level[c] and not level[c - 1]]
            for c in edges:
                self.assertEqual(level[c:c + 3], [1, 1, 0])
                self.assertEqual(len(set(ways[c - 1:c + 2])), 1)
            self.assertGreaterEqual(min(b - a for a, b in zip(edges, edges[1:])), 19)

    def test_corrupt_frame_is_dropped(self):
        moves, frames = self.program()
        bad = bytearray(frames[2])                                 # the first LINE
        bad[5] ^= 0x10
        frames[2] = bytes(bad)
        pins, replies, _ = run(frames[:5] + [protocol.query()], clocks=20_000,
                               name="controller_corrupt")
        errors = [r.fields for r in replies if r.kind == 0x82]
        self.assertEqual(errors, [(1,)])                           # CRC mismatch
        # The corrupt line never moved; the arc after it did, from where the machine was.
        self.assertEqual([(dx, dy) for _, dx, dy in pins], expected(moves[1:2]))

    def test_refused_and_abort(self):
        rate = round(0.02 * Q24)
        frames = [protocol.config((1 << 32) - 1), protocol.feed(rate, rate, 1 << 20),
                  protocol.line(5000, 1),                           # too wide for 12 bits
                  protocol.feed(rate, rate, 1 << 20), protocol.line(400, 100),
                  protocol.feed(rate, rate, 1 << 20), protocol.line(3, 3)]
        pins, replies, _ = run(frames, clocks=40_000, name="controller_abort",
                               inject={12_000: protocol.abort(), 30_000: protocol.query()})
        outcomes = [r.fields for r in replies if r.kind == OUTCOME]
        self.assertEqual([n for n, _ in outcomes], list(range(len(frames))))
        self.assertEqual(outcomes[2], (2, 1))                      # refused
        self.assertEqual(outcomes[4][1], 2)                        # the long line aborted
        self.assertEqual(outcomes[6], (6, 2))                      # and the one after it
        self.assertLess(len(pins), 400)
        (status,) = [r.fields for r in replies if r.kind == STATUS]
        self.assertEqual(status[:2], (sum(dx for _, dx, _ in pins), sum(dy for _, _, dy in pins)))


def controller3(**kwargs):
    """A 3-axis controller (issue 28): the spatial line core on X, Y, Z and the helix engine
    around the fast arc engine, 12 bits wide."""
    from kontur.hdl.helix import HelixEngine
    from kontur.hdl.line import LineEngine
    from kontur.hdl.spatial import SpatialLineCore
    return MotionController(line=LineEngine(SpatialLineCore(width=12, axes=3)),
                            arc=HelixEngine(registry.make_engine("arc", "fast", width=12)),
                            clock_hz=CLOCK, baud=BAUD, dir_setup=1, step_width=2, **kwargs)


def run3(frames, *, clocks, depth=8, name, schedule=(), polarity=None):
    """:func:`run` on :func:`controller3`: ``(clock, dx, dy, dz)`` for every step pulse."""
    trace = []
    result = run_amaranth(controller3(queue_frames=depth, polarity=polarity), frames, divisor=BIT, window=depth,
                          max_clocks=clocks, levels=trace, vcd=waves_path(name),
                          schedule=schedule)
    moves = [(clock, *step) for (clock, _, _), step in zip(result.steps, steps_of(result, 3))]
    return moves, [reply for _, reply in result.replies], trace


class ThreeAxesTestCase(unittest.TestCase):
    """The controller on three axes: LINE3 and HELIX frames, Z on the pins, STATUS of 24
    bytes, Z's limit (input bit 6); against the step-level models of the spatial line core
    and the helix (sim/models/spatial.py, sim/models/helix.py), which are checked against
    geometry in tests/test_spatial.py and tests/test_helix.py."""

    def test_lines_and_helices(self):
        from kontur.sim.models.helix import helix_frame, helix_steps
        from kontur.sim.models.spatial import line_steps
        rate = round(0.05 * Q24)
        feed = protocol.feed(rate, rate, 1 << 20)
        lines = [(7, -3, 5), (0, 0, -9), (-6, 11, 2)]
        helices = [helix_frame(0, -6, 6, 0, 5, cw=0, width=12),        # a quarter, Z up
                   helix_frame(4, 3, 4, 3, -20, cw=1, width=12)]       # a turn, Z down
        steep = {**helix_frame(0, 5, 5, 0, 0, cw=1, width=12), "z": 40}   # |z| > n
        frames = [protocol.config((1 << 32) - 1),
                  feed, protocol.line3(*lines[0]), feed, protocol.helix(**helices[0]),
                  feed, protocol.line3(*lines[1]), protocol.dwell(100),
                  feed, protocol.helix(**steep),
                  feed, protocol.helix(**helices[1]), feed, protocol.line3(*lines[2]),
                  protocol.stop(), protocol.query()]
        pins, replies, trace = run3(frames, clocks=80_000, name="controller3_program")
        expected = (line_steps(*lines[0], width=12) + helix_steps(**helices[0], width=12)
                    + line_steps(*lines[1], width=12) + helix_steps(**helices[1], width=12)
                    + line_steps(*lines[2], width=12))
        self.assertEqual([tuple(step) for _, *step in pins], [tuple(s) for s in expected])
        self.assertEqual(sum(1 for _, _, _, dz in pins if dz), 5 + 5 + 9 + 20 + 2)
        refused = frames.index(protocol.helix(**steep))
        self.assertEqual([r.fields for r in replies if r.kind == OUTCOME],
                         [(n, 1 if n == refused else 0) for n in range(len(frames) - 1)])
        (status,) = [r for r in replies if r.kind == STATUS]
        self.assertEqual(status.position, tuple(sum(step[axis] for _, *step in pins)
                                                for axis in range(3)))
        self.assertEqual(status.position[2], 5 + 5 - 9 - 20 + 2)
        self.assertEqual(status.fields[2], 8)
        # Z's pulses are timed as X's and Y's: 2 clocks, the direction set up a clock before.
        level = [(s >> 2) & 1 for s, _ in trace]
        ways = [(d >> 2) & 1 for _, d in trace]
        edges = [c for c in range(1, len(level)) if level[c] and not level[c - 1]]
        self.assertEqual(len(edges), 41)
        for c in edges:
            self.assertEqual(level[c:c + 3], [1, 1, 0])
            self.assertEqual(len(set(ways[c - 1:c + 2])), 1)

    def test_z_limit_trips(self):
        # Z's limit switch (input bit 6; normally closed, or normally open as the machine
        # file's limit_z says) trips the ALARM like X's and Y's: the move stops, STATUS says
        # ALARM with bit 6 in its cause and its inputs.
        from kontur.hdl.motion.inputs import pin_levels
        rate = round(0.05 * Q24)
        frames = [protocol.config((1 << 32) - 1), protocol.feed(rate, rate, 1 << 20),
                  protocol.line3(0, 0, 200), protocol.stop(), protocol.query()]
        for kind in ("nc", "no"):
            with self.subTest(limit_z=kind):
                polarity = {"limit_z": kind}
                tripped = pin_levels(("limit_z",), polarity, axes=3)
                # Normally open: the pin idles high (pulled up) and the closed switch is low.
                self.assertEqual(tripped >> 6 & 1, int(kind == "nc"))
                pins, replies, _ = run3(frames, clocks=40_000, name=f"controller3_limit_{kind}",
                                        schedule=[(400, ("pins", tripped))], polarity=polarity)
                self.assertLess(len(pins), 200)
                status = [r for r in replies if r.kind == STATUS][-1]
                self.assertEqual((status.state, status.fields[5], status.fields[6]),
                                 ("ALARM", 1 << 6, 1 << 6))
                self.assertEqual(status.position, (0, 0, len(pins)))

    def test_frames_of_the_other_axes_are_unknown(self):
        # A 3-axis controller takes LINE3 and HELIX, not LINE and ARC (ERROR 2), and a 2-axis
        # one the reverse.
        rate = round(0.05 * Q24)
        frames = [protocol.feed(rate, rate, 1 << 20), protocol.line(3, 4), protocol.query()]
        _, replies, _ = run3(frames, clocks=20_000, name="controller3_unknown")
        self.assertEqual([r.fields for r in replies if r.kind == ERROR], [(2,)])
        _, replies, _ = run([protocol.line3(1, 2, 3), protocol.query()], clocks=20_000,
                            name="controller_unknown3")
        self.assertEqual([r.fields for r in replies if r.kind == ERROR], [(2,)])
        self.assertIsNone([r for r in replies if r.kind == STATUS][0].z)


#: The stand-in engine's frame type and turn number: free ones (the protocol's next type).
STANDIN, STANDIN_UNIT = 0x17, 5


def standin_frame(x, y):
    """A frame of the stand-in's type, written here from the protocol's definition (sync,
    type, length, little-endian payload, CRC-16/CCITT of type, length and payload, high byte
    first), not by the host's code, which knows no such type."""
    body = bytes([STANDIN, 8]) + struct.pack("<ii", x, y)
    return bytes([0xA5]) + body + binascii.crc_hqx(body, 0xFFFF).to_bytes(2, "big")


class EngineTableTestCase(unittest.TestCase):
    def test_standin_engine_by_its_row_alone(self):
        # A second line engine, 6 bits wide (moves up to 63 steps), added as one row of the
        # engine table: turn 5, frame type 0x17, the payload's bits as its command. Its frames
        # reach it (a short move is made, by the step-level model's steps; a move too long for
        # 6 bits but not for the 12-bit line engine is refused, so it went to the stand-in)
        # and every outcome comes back in order among the line engine's.
        row = EngineUnit("standin", STANDIN_UNIT, STANDIN, registry.make_engine("line", width=6),
                         8, raw_bits)
        rate = round(0.05 * Q24)
        feed = protocol.feed(rate, rate, 1 << 20)
        frames = [protocol.config((1 << 32) - 1),
                  feed, protocol.line(7, -3),
                  feed, standin_frame(5, 2),
                  feed, protocol.line(70, 1),
                  feed, standin_frame(70, 1),            # too long for 6 bits
                  feed, standin_frame(-4, 6),
                  protocol.stop(), protocol.query()]
        pins, replies, _ = run(frames, clocks=30_000, name="controller_standin", engines=[row])
        moves = [(7, -3, 12), (5, 2, 6), (70, 1, 12), (-4, 6, 6)]      # x, y, engine's width
        self.assertEqual([(dx, dy) for _, dx, dy in pins],
                         [step for x, y, width in moves for step in registry.steps(
                             "line", {"x": x, "y": y}, width=width)])
        refused = frames.index(standin_frame(70, 1))
        self.assertEqual([r.fields for r in replies if r.kind == OUTCOME],
                         [(n, 1 if n == refused else 0) for n in range(len(frames) - 1)])
        self.assertEqual([r for r in replies if r.kind == ERROR], [])
        (status,) = [r.fields for r in replies if r.kind == STATUS]
        self.assertEqual(status[:2], (7 + 5 + 70 - 4, -3 + 2 + 1 + 6))

    def test_table_rows_must_be_their_own(self):
        line = registry.make_engine("line", width=6)
        for row, message in [
                (EngineUnit("standin", 2, STANDIN, line, 8),
                 r"^Turn number 2 of engine 'standin' is already used by engine 'arc'$"),
                (EngineUnit("standin", 3, STANDIN, line, 8),
                 r"^Turn number 3 of engine 'standin' is already used by the controller "
                 r"\(DWELL\)$"),
                (EngineUnit("standin", STANDIN_UNIT, LINE, line, 8),
                 r"^Frame type 0x10 of engine 'standin' is already used by engine 'line'$"),
                (EngineUnit("standin", STANDIN_UNIT, QUERY, line, 8),
                 r"^Frame type 0x20 of engine 'standin' is already used by the controller$"),
                (EngineUnit("arc", STANDIN_UNIT, STANDIN, line, 8),
                 r"^Engine name 'arc' is used twice$")]:
            with self.assertRaisesRegex(ValueError, message):
                controller(engines=[row])


if __name__ == "__main__":
    unittest.main()
