# amaranth: UnusedElaboratable=no
"""A machine you can stop: the input stage, the step/dir stage's halt, the ALARM, UNLOCK and
the real-time STATUS, in Amaranth's simulator.

The new blocks are compared clock for clock with their golden models (``sim/models/
motion.py``) under random stimulus; the whole controller is run over its serial pin with the
switch pins scheduled, and checked against what the program and the stated stop bound say:
no rising step edge later than ``input_filter + 2`` clocks after the pin changed, every pulse
its full width, every queued frame ended, the position read back equal to the steps on the
pins, the state and cause reported."""

import random
import unittest

from amaranth.sim import Simulator

from kontur import registry
from kontur.hdl.motion import protocol
from kontur.hdl.motion.alarm import Alarm
from kontur.hdl.motion.controller import MotionController
from kontur.hdl.motion.inputs import INPUTS, InputFilter, pin_levels
from kontur.hdl.motion.link import ERROR, OUTCOME, STATUS
from kontur.hdl.motion.stepdir import StepDirStage
from kontur.sim.models.motion import AlarmModel, InputFilterModel, StepDirModel, safety_run
from kontur.sim.testbench.hostlink import HostLink, run_amaranth, steps_of

CLOCK, BAUD = 1e6, 125_000
BIT = round(CLOCK / BAUD)
Q24 = 1 << 24
FILTER = 3
SETUP, WIDTH = 1, 2


def clocked(dut, body, clocks):
    """Run ``body(ctx, clock)`` for ``clocks`` clocks of a testbench on ``dut``."""
    async def testbench(ctx):
        for clock in range(clocks):
            body(ctx, clock)
            await ctx.tick()
    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(testbench)
    sim.run()


class BlocksTestCase(unittest.TestCase):
    """The new blocks against their models, clock for clock."""

    def test_input_filter(self):
        for filter_ in (1, 2, 5):
            rng = random.Random(filter_)
            dut, model = InputFilter(filter_, init=1), InputFilterModel(filter_, init=1)
            # Runs of random lengths: glitches shorter than the filter and real changes.
            pins = [level for n in range(120) for level in [n % 2] * rng.randrange(1, 9)]
            seen = []

            def body(ctx, clock):
                pin = pins[clock]
                ctx.set(dut.i, pin)
                out = ctx.get(dut.o)
                self.assertEqual(out, model.cycle(pin), f"filter {filter_}, clock {clock}")
                seen.append(out)
            clocked(dut, body, len(pins))
            # Independently: the output changes only to a level the pin has held for
            # `filter` clocks, 2 clocks (the synchroniser) before.
            for c in range(1, len(seen)):
                if seen[c] != seen[c - 1]:
                    held = pins[c - 2 - filter_ + 1 - 1:c - 2]
                    self.assertEqual(set(held), {seen[c]}, f"filter {filter_}, clock {c}")

    def test_step_dir_halt(self):
        rng = random.Random(7)
        dut = StepDirStage(dir_setup=3, step_width=4)
        model = StepDirModel(dir_setup=3, step_width=4)
        gap = 3 + 4 + 1
        steps, halts, last = [], [], [-gap, -gap]
        for clock in range(3000):
            bits = 0
            for axis in range(2):
                if clock - last[axis] >= gap and rng.random() < 0.3:
                    bits |= 1 << axis
                    last[axis] = clock
            steps.append((bits, rng.randrange(4)))
            halts.append(int(clock % 97 < 11 and rng.random() < 0.9))
        out = []

        def body(ctx, clock):
            step, direction = steps[clock]
            ctx.set(dut.i.step, step)
            ctx.set(dut.i.dir, direction)
            ctx.set(dut.halt, halts[clock])
            got = (ctx.get(dut.o.step), ctx.get(dut.o.dir), ctx.get(dut.made))
            self.assertEqual(got, model.cycle(step, direction, halts[clock]), f"clock {clock}")
            out.append(got)
        clocked(dut, body, len(steps))
        for axis in range(2):
            level = [(s >> axis) & 1 for s, _, _ in out]
            for c in range(1, len(level) - 5):
                if level[c] and not level[c - 1]:
                    self.assertEqual(level[c:c + 5], [1, 1, 1, 1, 0])   # never cut short
                    # no pulse begins in a halted clock unless it began its set-up before
                    if halts[c - 1] and halts[c - 2]:
                        self.fail(f"a pulse began at {c} after two halted clocks")
            made = [(m >> axis) & 1 for _, _, m in out]
            self.assertEqual(sum(made), sum(1 for c in range(1, len(level))
                                            if level[c] and not level[c - 1]) + level[0])

    def test_alarm(self):
        rng = random.Random(3)
        dut, model = Alarm(), AlarmModel()
        stimulus = [(rng.choice([0, 0, 0, 1, 2, 4, 6, 8]), int(rng.random() < 0.1),
                     rng.randrange(2)) for _ in range(2000)]
        entered = []

        def body(ctx, clock):
            active, unlock, busy = stimulus[clock]
            ctx.set(dut.active, active)
            ctx.set(dut.unlock, unlock)
            ctx.set(dut.busy, busy)
            want = model.cycle(active, unlock=unlock, busy=busy)
            got = {name: ctx.get(getattr(dut, name)) for name in want}
            got["state"] = got["state"].value
            self.assertEqual(got, want, f"clock {clock}")
            entered.append(got["enter"])
        clocked(dut, body, len(stimulus))
        self.assertGreater(sum(entered), 10)
        # Independently: while the e-stop is active, the state is ALARM a clock later.
        states = []
        dut, seq = Alarm(), [(1, 1), (1, 1), (0, 1), (0, 0), (2, 0), (2, 1), (0, 0)]

        def body2(ctx, clock):
            ctx.set(dut.active, seq[clock][0])
            ctx.set(dut.unlock, seq[clock][1])
            states.append((ctx.get(dut.state).name, ctx.get(dut.cause)))
        clocked(dut, body2, len(seq))
        # e-stop held: UNLOCK refused; released: UNLOCK leaves ALARM; a limit held: it does
        self.assertEqual(states, [("IDLE", 0), ("ALARM", 1), ("ALARM", 1), ("IDLE", 0),
                                  ("IDLE", 0), ("ALARM", 2), ("IDLE", 0)])


def controller():
    return MotionController(line=registry.make_engine("line", width=12),
                            arc=registry.make_engine("arc", "fast", width=12),
                            clock_hz=CLOCK, baud=BAUD, dir_setup=SETUP, step_width=WIDTH,
                            queue_frames=8, input_filter=FILTER)


def program():
    """A line and a long arc at a step every 20 clocks; the steps they make (model)."""
    rate = round(0.05 * Q24)
    frames = [protocol.config((1 << 32) - 1),
              protocol.feed(rate, rate, 1 << 20), protocol.line(30, -10),
              protocol.feed(rate, rate, 1 << 20), protocol.arc(0, -200, 200, 0, 0),
              protocol.stop()]
    steps = registry.steps("line", {"x": 30, "y": -10}, width=12) + registry.steps(
        "arc", {"x0": 0, "y0": -200, "x1": 200, "y1": 0, "cw": 0}, "fast", width=12)
    return frames, steps


def pins(*active):
    return ("pins", pin_levels(active))


def run(frames, schedule, *, clocks=80_000):
    trace = []
    result = run_amaranth(controller(), frames + [protocol.query()], divisor=BIT, window=8,
                          max_clocks=clocks, levels=trace, schedule=schedule)
    return result, trace


def statuses(result):
    return [(clock, r.fields) for clock, r in result.replies if r.kind == STATUS]


class StopTestCase(unittest.TestCase):
    def check_stop(self, result, trace, expected, trip_clock):
        """No rising step edge after the bound, every pulse whole, the steps a prefix of the
        program's, the position read back the steps on the pins."""
        made = steps_of(result)
        self.assertEqual(made, expected[:len(made)])
        self.assertLess(len(made), len(expected))
        bound = trip_clock + FILTER + 2
        self.assertLessEqual(result.steps[-1][0], bound)
        for axis in range(2):
            level = [(s >> axis) & 1 for s, _ in trace]
            for c in range(1, len(level) - WIDTH):
                if level[c] and not level[c - 1]:
                    self.assertEqual(level[c:c + WIDTH + 1], [1] * WIDTH + [0])
        x, y = sum(dx for dx, _ in made), sum(dy for _, dy in made)
        for _, fields in statuses(result):
            self.assertEqual(fields[:2], (x, y))
        return made

    def test_estop_mid_arc(self):
        frames, expected = program()
        # (The frames are all in by about 3500 clocks after the first step.)
        schedule = [(4500, pins("estop")), (5500, ("unlock",)), (6500, pins()),
                    (7500, ("unlock",))]
        result, trace = run(frames, schedule)
        trip = result.applied[0][0]
        made = self.check_stop(result, trace, expected, trip)
        self.assertGreater(len(made), 40 + 10)                     # stopped in the arc
        outcomes = [r.fields for _, r in result.replies if r.kind == OUTCOME]
        self.assertEqual([n for n, _ in outcomes], list(range(len(frames))))
        self.assertEqual([o for _, o in outcomes], [0, 0, 0, 0, 2, 2])   # the arc on: ABORTED
        self.assertEqual([r for _, r in result.replies if r.kind == ERROR], [])
        # The UNLOCK while the e-stop is held is refused (ALARM, e-stop tripped and active);
        # the one after its release is taken; the last QUERY finds the machine idle.
        (_, refused), (_, taken), (_, final) = statuses(result)
        estop = 1 << INPUTS.index("estop")
        self.assertEqual(refused[4:7], (4, estop, estop))          # ALARM, cause, inputs
        self.assertEqual(taken[4:7], (0, 0, 0))
        self.assertEqual(final[2:], (8, 0, 0, 0, 0, 0, 128, 100))   # rate 0, 100 %
        # The model: the same stop, the same final state.
        model = safety_run([0] * 0, [(2, "estop"), (3, "unlock"), (4, "estop-release"),
                                     (5, "unlock")])
        self.assertEqual((model["state"], [e["alarm"] for e in model["events"]]),
                         ("IDLE", [True, True, True, False]))

    def test_limit_trip_and_unlock_while_pressed(self):
        frames, expected = program()
        schedule = [(4000, pins("limit_y")), (5000, ("unlock",))]
        result, trace = run(frames, schedule)
        self.check_stop(result, trace, expected, result.applied[0][0])
        outcomes = [o for _, r in result.replies if r.kind == OUTCOME for o in r.fields[1:]]
        self.assertIn(2, outcomes)
        self.assertEqual(outcomes[outcomes.index(2):], [2] * (len(outcomes) - outcomes.index(2)))
        limit_y = 1 << INPUTS.index("limit_y")
        (_, unlocked), (_, final) = statuses(result)
        self.assertEqual(unlocked[4:7], (0, 0, limit_y))           # left ALARM, still pressed
        self.assertEqual(final[4:7], (0, 0, limit_y))

    def test_frames_refused_in_alarm(self):
        # The e-stop pressed at the first step: the line ends ABORTED after a step or two,
        # the frames that come after the trip end REFUSED, the host sends no more.
        frames, expected = program()
        result, _ = run(frames, [(0, pins("estop"))], clocks=30_000)
        self.assertEqual(steps_of(result), expected[:len(result.steps)])
        self.assertLessEqual(len(result.steps), 2)
        outcomes = [r.fields for _, r in result.replies if r.kind == OUTCOME]
        self.assertEqual(outcomes[:3], [(0, 0), (1, 0), (2, 2)])  # CONFIG, FEED; LINE aborted
        self.assertGreater(len(outcomes), 3)
        self.assertEqual({o for _, o in outcomes[3:]}, {1})      # refused
        self.assertEqual([r for _, r in result.replies if r.kind == ERROR], [])
        (_, status), = statuses(result)
        self.assertEqual(status[4:6], (4, 1))                     # ALARM, the e-stop

    def test_unlock_then_frames_run(self):
        # The e-stop pressed before anything is sent, released, unlocked: the program sent
        # then runs whole.
        rate = round(0.05 * Q24)
        frames = [protocol.query(), protocol.config((1 << 32) - 1),
                  protocol.feed(rate, rate, 1 << 20), protocol.line(30, -10), protocol.stop()]
        result, _ = run(frames, [(0, pins("estop")), (100, pins()), (200, ("unlock",))],
                        clocks=30_000)
        self.assertEqual(steps_of(result), registry.steps("line", {"x": 30, "y": -10},
                                                          width=12))
        self.assertEqual([r.fields for _, r in result.replies if r.kind == OUTCOME],
                         [(n, 0) for n in range(4)])
        states = [(f[4], f[5]) for _, f in statuses(result)]
        self.assertEqual(states, [(0, 0), (0, 0), (0, 0)])         # IDLE after the UNLOCK
        self.assertEqual(statuses(result)[-1][1][:2], (30, -10))

    def test_status_ahead_of_outcomes_and_its_latency(self):
        # QUERYs every 500 clocks while the arc runs: each answered STATUS (RUN) within
        # the time of one reply on the line (the longest, STATUS's 25 bytes) and a few clocks.
        frames, expected = program()
        dut = controller()
        host = HostLink(frames + [protocol.query()], divisor=BIT, window=8,
                        inject={c: protocol.query() for c in range(7000, 11_000, 500)})
        asked, answered = [], []

        async def testbench(ctx):
            for clock in range(60_000):
                ctx.set(dut.rx, host.cycle(tx=ctx.get(dut.tx), step=ctx.get(dut.motion.step),
                                           direction=ctx.get(dut.motion.dir)))
                if ctx.get(dut.decoder.query):
                    asked.append(clock)
                encoder = dut.encoder.i
                if ctx.get(encoder.valid) and ctx.get(encoder.ready) and \
                        ctx.get(encoder.payload.kind) == STATUS:
                    answered.append(clock)
                if host.done:
                    return
                await ctx.tick()
        sim = Simulator(dut)
        sim.add_clock(1e-6)
        sim.add_testbench(testbench)
        sim.run()
        self.assertTrue(host.done)
        self.assertEqual(steps_of(host.run()), expected)
        # Queries that come while a STATUS is on the line are answered by the next one.
        self.assertGreater(len(answered), 2)
        latency = max(min(a for a in answered if a > q) - q for q in asked)
        self.assertLessEqual(latency, (5 + 20) * 10 * BIT + 2)     # a STATUS: 25 bytes
        running = [r.fields[4] for _, r in host.replies if r.kind == STATUS]
        self.assertEqual(running[:-1], [1] * (len(running) - 1))     # RUN
        self.assertEqual(running[-1], 0)
        print(f"status latency: at most {latency} clocks from QUERY to STATUS taken "
              f"({latency / BIT:.0f} bit times)")


class ProtocolTestCase(unittest.TestCase):
    def test_status_and_unlock_frames(self):
        # A STATUS written here from the protocol's table (sync, type 0x81, length 20, the
        # fields little-endian, CRC-16/CCITT of type, length and payload, high byte first):
        # ..., the rate 0.25 steps a clock (Q0.24), the feed override 1.5 (Q2.7), rapid 50 %.
        import binascii
        import struct
        body = bytes([0x81, 20]) + struct.pack("<iiBBBBB", -5, 7, 3, 1, 4, 0b101, 0b100001) \
            + bytes([0, 0, 0x40, 0, 192, 0, 50])
        frame = bytes([0xA5]) + body + binascii.crc_hqx(body, 0xFFFF).to_bytes(2, "big")
        (reply,) = protocol.ReplyParser().feed(frame)
        self.assertEqual(reply.fields, (-5, 7, 3, 1, 4, 5, 33, 1 << 22, 192, 50))
        self.assertEqual(reply.state, "ALARM")
        self.assertEqual(str(reply), "ALARM at (-5, 7), 3 queue slots free, flags 0x01, "
                                     "rate 0.250000 steps/clock, feed 150 %, rapid 50 %, "
                                     "tripped: estop, limit_y, active: estop, feed_hold")
        unlock = bytes([0xA5, 0x22, 0]) + binascii.crc_hqx(bytes([0x22, 0]), 0xFFFF) \
            .to_bytes(2, "big")
        self.assertEqual(protocol.unlock(), unlock)
        self.assertEqual(protocol.CommandParser().feed(unlock), [("unlock",)])


class ModelTestCase(unittest.TestCase):
    def test_safety_run(self):
        times = [0.1 * n for n in range(1, 101)]                  # 100 steps over 10 s
        run = safety_run(times, [(2.05, "estop"), (3, "unlock"), (4, "estop-release"),
                                 (5, "unlock")])
        self.assertEqual((run["steps"], run["stopped"], run["state"], run["alarm"]),
                         (20, 2.05, "IDLE", []))
        run = safety_run(times, [(1.0, "limit-x"), (1.5, "unlock"), (2.0, "limit-x")])
        # A limit still pressed does not trip again; the first trip stopped the program.
        self.assertEqual((run["steps"], run["state"], run["alarm"]), (10, "IDLE", []))
        run = safety_run(times, [(20, "limit-y")])                 # after the end: ALARM
        self.assertEqual((run["steps"], run["state"], run["alarm"]),
                         (100, "ALARM", ["limit_y"]))
        with self.assertRaisesRegex(ValueError, "Event must be one of"):
            safety_run(times, [(1, "jog")])


#: A line and an arc, quick on Amaranth's simulator (10 steps/mm, a fast link).
TINY = "G21 G90\nG1 X3 Y0 F3000\nG3 X0 Y3 I-3 J0\n"


class RunTestCase(unittest.TestCase):
    def machine(self):
        from kontur.machine import Machine
        return Machine(clock_hz=registry.board("icebreaker").clock_hz, steps_per_mm=10,
                       baud=1_000_000, accel=5000, input_filter_us=5)

    def test_events_on_amaranth_against_the_model(self):
        # The e-stop part-way through the arc, an UNLOCK refused while it is pressed, then
        # released and unlocked; a limit on the way back trips again and stays the cause.
        from kontur.machining import execute, prepare
        job = prepare(TINY, machine=self.machine(), name="tiny.ngc")
        half = job.seconds / 2
        events = [(half, "estop"), (half + 0.05, "unlock"), (half + 0.1, "estop-release"),
                  (half + 0.15, "unlock"), (half + 0.2, "limit-y")]
        model = execute(job, "model", events=events)
        rtl = execute(job, "amaranth", events=events)          # checked inside, and here:
        self.assertEqual(rtl.steps, job.steps[:len(rtl.steps)])
        self.assertLess(abs(len(rtl.steps) - len(model.steps)), 0.05 * len(job.steps))
        self.assertEqual((model.final_state, model.alarm), ("ALARM", ["limit_y"]))
        self.assertEqual((rtl.final_state, rtl.alarm), ("ALARM", ["limit_y"]))
        self.assertEqual([e["alarm"] for e in rtl.events], [True, True, True, False, True])
        x = sum(dx for dx, _ in rtl.steps)
        self.assertEqual(rtl.end[0], x)

    def test_command_line(self):
        import json
        import tempfile
        from pathlib import Path

        from kontur.cli import main
        with tempfile.TemporaryDirectory() as folder:
            program = Path(folder) / "tiny.ngc"
            program.write_text(TINY)
            out = Path(folder) / "out"
            self.assertEqual(main(["run", str(program), "--out", str(out), "--steps-per-mm",
                                   "10", "--event", "limit-x@0.05"]), 0)
            data = json.loads((out / "summary.json").read_text())
            self.assertEqual((data["final_state"], data["alarm"]), ("ALARM", ["limit_x"]))
            self.assertEqual(data["events"], [{"at": 0.05, "event": "limit-x", "alarm": True,
                                               "hold": False}])
            steps = (out / "steps.txt").read_text().splitlines()
            self.assertEqual(len(steps), data["steps"])
            self.assertLess(len(steps), 30 + 24)              # stopped before the end
            for bad in ("jog@1", "estop", "estop@-1", "estop@x", "feed=5@1", "rapid=75@1"):
                self.assertEqual(main(["run", str(program), "--out", str(out),
                                       "--event", bad]), 2)


if __name__ == "__main__":
    unittest.main()
