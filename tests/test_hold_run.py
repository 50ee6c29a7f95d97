# amaranth: UnusedElaboratable=no
"""Feed hold, resume and the overrides in the whole controller (issue 25), in Amaranth's
simulator, over its serial pin and its switch pins.

In every clock of every run the controller's feed generator is compared with its golden model
(:class:`kontur.sim.models.motion.FeedGeneratorModel`) driven by the generator's inputs as the
controller wires them (the running move's profile and rapid flag, the engines' due and
diagonal, the hold, the overrides): its permissions, rate and ``held`` must be the model's.
Independently of any model: the steps of a held and resumed run, of an overridden run and of a
run held by the buttons are those of the uninterrupted run (and of the engines' step-level
models), step for step; no step comes while the generator is held; the hold took effect (a
pause in the steps as long as the hold, less the braking); STATUS reports HOLD with the
standstill flag, the rate 0, and the overrides sent."""

import math
import unittest

from kontur import registry
from kontur.hdl.motion import protocol
from kontur.hdl.motion.controller import MotionController
from kontur.hdl.motion.inputs import pin_levels
from kontur.hdl.motion.link import ERROR, OUTCOME, STATUS
from kontur.sim.models.motion import FeedGeneratorModel
from kontur.sim.testbench.hostlink import run_amaranth, steps_of

CLOCK, BAUD = 1e6, 125_000
BIT = round(CLOCK / BAUD)
Q24 = 1 << 24
A = 2e-4                                  # steps a clock², braking from 0.05 in 250 clocks
ACCEL = round(A * (1 << 40))


def controller():
    return MotionController(line=registry.make_engine("line", width=12),
                            arc=registry.make_engine("arc", "fast", width=12),
                            clock_hz=CLOCK, baud=BAUD, dir_setup=1, step_width=2,
                            queue_frames=8, input_filter=3)


def planned(steps, cruise, exit, rapid=False):
    """A FEED for a move of ``steps`` (axial) steps ramping down so as to reach ``exit`` from
    ``cruise`` at ``A`` two steps before its end (the kinematics: (c² - e²) / 2A)."""
    down = math.ceil((cruise ** 2 - exit ** 2) / (2 * A)) + 2
    return protocol.feed(round(cruise * Q24), round(exit * Q24), max(steps - down, 0),
                         rapid=rapid)


LINE = {"x": 240, "y": 80}
ARC = {"x0": 0, "y0": -100, "x1": 100, "y1": 0, "cw": 0}
RAPID = {"x": -40, "y": 0}


def program():
    """A line, an arc and a rapid (flagged in its FEED); the steps they make (step-level
    models)."""
    line = registry.steps("line", LINE, width=12)
    arc = registry.steps("arc", ARC, "fast", width=12)
    rapid = registry.steps("line", RAPID, width=12)
    frames = [protocol.config(ACCEL),
              planned(len(line), 0.05, 0.03), protocol.line(*LINE.values()),
              planned(len(arc), 0.04, 0.01), protocol.arc(*ARC.values()),
              planned(len(rapid), 0.08, 0.01, rapid=True), protocol.line(*RAPID.values()),
              protocol.stop()]
    return frames, line + arc + rapid


class Watch:
    """The controller's feed generator against its model, clock by clock (``each`` of
    :func:`~kontur.sim.testbench.hostlink.run_amaranth`); records the clocks it is held and
    steps."""

    def __init__(self, dut):
        self.dut = dut
        self.model = None                     # made once the controller is elaborated
        self.held = []
        self.changes = []                     # (clock, input, value) as the inputs change
        self.last = {}

    def __call__(self, ctx, clock):
        feed = self.dut.feed
        if self.model is None:
            self.model = FeedGeneratorModel(max_rate=feed.max_rate)
        p = {name: ctx.get(getattr(feed.ramp.profile, name))
             for name in ("cruise", "exit", "decelerate")}
        inputs = {name: ctx.get(getattr(feed, name))
                  for name in ("hold", "feed_override", "rapid_override", "rapid")}
        for name, value in inputs.items():
            if self.last.get(name, getattr(feed, name).init) != value:
                self.changes.append((clock, name, value))
            self.last[name] = value
        rate = self.model.rate >> 16
        tick = self.model.cycle(profile=p, accel=ctx.get(feed.accel),
                                start=ctx.get(feed.ramp.start), due=ctx.get(feed.feed.due),
                                diagonal=ctx.get(feed.feed.diagonal), **inputs)
        got = (ctx.get(feed.feed.tick), ctx.get(feed.rate), ctx.get(feed.held))
        assert got == (tick, rate, int(self.model.held)), \
            f"clock {clock}: RTL (tick, rate, held) {got}, model {(tick, rate, self.model.held)}"
        if self.model.held:
            self.held.append(clock)


def run(schedule=(), *, before=(), clocks=60_000):
    """The program (after the frames ``before``) with ``schedule``'s events."""
    dut = controller()
    frames, _ = program()
    watch = Watch(dut)
    result = run_amaranth(dut, list(before) + frames + [protocol.query()], divisor=BIT,
                          window=8, max_clocks=clocks, schedule=schedule, each=watch)
    return result, watch


def statuses(result):
    return [(clock, reply.fields) for clock, reply in result.replies if reply.kind == STATUS]


_BASE = {}


def uninterrupted():
    """The run without events (once for the module)."""
    if "run" not in _BASE:
        _BASE["run"] = run()
    return _BASE["run"]


class HoldRunTestCase(unittest.TestCase):
    def check_complete(self, result, watch):
        _, expected = program()
        self.assertEqual(steps_of(result), expected)                   # the same steps
        outcomes = [reply.fields for _, reply in result.replies if reply.kind == OUTCOME]
        self.assertEqual(outcomes, [(n, 0) for n in range(len(program()[0]))])   # all DONE
        self.assertEqual([r for _, r in result.replies if r.kind == ERROR], [])
        stepped = {clock for clock, _, _ in result.steps}
        # A permission in clock c is a step on the pins at c + 1 + dir_setup (the stage).
        self.assertEqual({c + 2 for c in watch.held} & stepped, set())    # none while held
        final = statuses(result)[-1][1]
        x, y = sum(dx for dx, _ in expected), sum(dy for _, dy in expected)
        self.assertEqual(final[:2], (x, y))

    def test_uninterrupted(self):
        result, watch = uninterrupted()
        self.check_complete(result, watch)
        self.assertEqual(watch.held, [])
        self.assertEqual(statuses(result)[-1][1][4:], (0, 0, 0, 0, 128, 100))  # IDLE, 100 %

    def test_hold_in_the_line_and_in_the_arc(self):
        base, _ = uninterrupted()
        # At 1500 clocks the line cruises at 0.05 (a step every 20 clocks); at 10 000 the
        # arc runs. Each hold lasts 2000 clocks; a QUERY in each hold after the standstill (250
        # clocks of braking from 0.05) and one after the resume.
        hold, resume = protocol.hold(), protocol.resume()
        schedule = [(1500, ("frame", hold)), (2500, ("frame", protocol.query())),
                    (3500, ("frame", resume)), (3700, ("frame", protocol.query())),
                    (10_000, ("frame", hold)), (11_000, ("frame", protocol.query())),
                    (12_000, ("frame", resume))]
        result, watch = run(schedule)
        self.check_complete(result, watch)
        # The frames reach the controller after the bytes on the line before them: the
        # generator's hold input rises and falls twice, and each time comes to a standstill
        # within the braking from at most 0.05 (250 clocks) and stays there until the fall.
        edges = [(clock, value) for clock, name, value in watch.changes if name == "hold"]
        self.assertEqual([value for _, value in edges], [1, 0, 1, 0])
        runs = _runs(watch.held)
        self.assertEqual(len(runs), 2)
        # The first hold stands still in the line, the second in the arc.
        line = len(registry.steps("line", LINE, width=12))
        arc = len(registry.steps("arc", ARC, "fast", width=12))
        made = [sum(1 for c, _, _ in result.steps if c <= first) for first, _ in runs]
        self.assertTrue(0 < made[0] < line and line < made[1] < line + arc, made)
        for (first, last), (rise, _), (fall, _) in zip(runs, edges[::2], edges[1::2]):
            self.assertLess(first - rise, 260)
            self.assertEqual(last, fall - 1)
        # The hold is a pause: the run takes about the holds' time longer (each hold's
        # braking and ramp back, 250 clocks each, lose about half their time).
        delay = result.steps[-1][0] - base.steps[-1][0]
        held = sum(fall - rise for (rise, _), (fall, _) in zip(edges[::2], edges[1::2]))
        self.assertLess(abs(delay - held), 2 * 300)
        # The STATUS replies: HOLD at a standstill (flag 4, rate 0); RUN after the resume.
        (_, in_line), (_, resumed), (_, in_arc), (_, final) = statuses(result)
        self.assertEqual((in_line[4], in_line[3] & 4, in_line[7]), (2, 4, 0))
        self.assertEqual((resumed[4], resumed[3] & 4), (1, 0))
        self.assertGreater(resumed[7], 0)
        self.assertEqual((in_arc[4], in_arc[3] & 4, in_arc[7]), (2, 4, 0))
        self.assertEqual(final[4], 0)

    def test_buttons_hold_and_resume(self):
        # The feed-hold button (normally closed: its pin goes high when pressed) pressed and
        # released, then cycle start (normally open: low when pressed) pressed and released.
        idle = pin_levels(())
        schedule = [(2000, ("pins", pin_levels({"feed_hold"}))), (2100, ("pins", idle)),
                    (4000, ("pins", pin_levels({"cycle_start"}))), (4100, ("pins", idle))]
        result, watch = run(schedule)
        self.check_complete(result, watch)
        (first, last), = _runs(watch.held)
        self.assertLess(abs(first - (2000 + 3 + 2 + 250) - _first_step(result)), 60)
        self.assertLess(abs(last - (4000 + 3 + 2) - _first_step(result)), 10)

    def test_overrides_change_only_the_timing(self):
        base, _ = uninterrupted()
        # 150 % from the start of the line, 50 % in the arc; the rapid at 25 %.
        schedule = [(0, ("frame", protocol.override(150, 25))),
                    (5000, ("frame", protocol.override(50, 25))),
                    (5100, ("frame", protocol.query()))]
        result, watch = run(schedule)
        self.check_complete(result, watch)
        (_, status), _ = statuses(result)
        self.assertEqual(status[8:], (64, 25))                    # 50 % (Q2.7), 25 %
        self.assertNotEqual([c for c, _, _ in result.steps], [c for c, _, _ in base.steps])
        # The line at 150 %: its cruise 0.075 step lengths a clock (a diagonal step is √2
        # long), measured from 300 clocks after the factor changed (the ramp from 0.05 takes
        # 125) to 40 steps before the line's end (its ramp-down, early above 100 %).
        (changed, _, factor), = [c for c in watch.changes if c[1] == "feed_override"][:1]
        self.assertEqual(factor, 192)
        _, expected = program()
        length = [math.sqrt(2) if dx and dy else 1.0 for dx, dy in expected]
        line = len(registry.steps("line", LINE, width=12))
        clocks = [c for c, _, _ in result.steps]
        first = next(i for i, c in enumerate(clocks) if c > changed + 300)
        last = line - 40
        self.assertGreater(last - first, 20)
        self.assertAlmostEqual(sum(length[first + 1:last + 1]) / (clocks[last] - clocks[first]),
                               0.075, delta=0.002)
        # The rapid at 25 % of 0.08: 0.02 from its 5th to its 15th step (before its
        # ramp-down, about 18 steps before its end).
        rapid = len(registry.steps("line", RAPID, width=12))
        first = len(clocks) - rapid
        self.assertAlmostEqual(10 / (clocks[first + 15] - clocks[first + 5]), 0.02,
                               delta=0.002)

    def test_override_out_of_range_is_dropped(self):
        # A feed factor above 256 (200 %) or below 13, a rapid of 75 %, a spindle factor
        # above 256 or below 13: ERROR 6, the overrides unchanged.
        # (Sent ahead of the program: the simulated host counts each ERROR as its answer.)
        def override(feed, rapid, spindle=128):
            return protocol.frame(0x25, feed.to_bytes(2, "little") + bytes([rapid])
                                  + spindle.to_bytes(2, "little"))
        bad = [override(300, 100), override(128, 75), override(12, 50),
               override(128, 100, 257), override(128, 100, 12)]
        result, watch = run(before=bad)
        errors = [r.fields for _, r in result.replies if r.kind == ERROR]
        self.assertEqual(errors, [(6,)] * 5)
        (_, status), = statuses(result)
        self.assertEqual(status[8:], (128, 100))
        _, expected = program()
        self.assertEqual(steps_of(result), expected)


def _runs(clocks):
    runs = []
    for clock in clocks:
        if runs and runs[-1][1] == clock - 1:
            runs[-1][1] = clock
        else:
            runs.append([clock, clock])
    return [tuple(r) for r in runs]


def _first_step(result):
    return result.steps[0][0]


if __name__ == "__main__":
    unittest.main()


# ---- kontur run --event hold|resume|feed=PCT|rapid=PCT ---------------------------------------

#: A rapid, a line and an arc, quick on Amaranth's simulator (10 steps/mm, a fast link).
TINY = "G21 G90\nG0 X2 Y0\nG1 X3 Y0 F3000\nG3 X0 Y3 I-3 J0\n"

#: A compensated contour (the ULX3S's equidistant engine), as tests/test_compensation_run.py's.
CONTOUR = """G21 G90
G0 X0 Y0
G42 G1 X2 Y0 F3000
G1 X2 Y1
G3 X1 Y2 I-1 J0
G1 X0 Y2
G1 X0 Y0
G40 G0 X0 Y-1
"""


def machine(board="icebreaker", **keys):
    from kontur.machine import Machine
    return Machine(clock_hz=registry.board(board).clock_hz, steps_per_mm=10, accel=5000,
                   **({"baud": 1_000_000} | keys))


class EventsTestCase(unittest.TestCase):
    def test_model_hold_resume_and_never_resumed(self):
        from kontur.machining import execute, prepare
        job = prepare(TINY, machine=machine(), name="tiny.ngc")
        plain = execute(job, "model")
        half = job.seconds / 2
        run = execute(job, "model", events=[(half, "hold"), (half + 0.5, "resume"),
                                            (half + 0.6, "feed=150"), (0.01, "rapid=25")])
        self.assertEqual(run.steps, job.steps)                 # every step, in order
        self.assertEqual(run.final_state, "IDLE")
        self.assertEqual([(e["event"], e["hold"]) for e in run.events],
                         [("rapid=25", False), ("hold", True), ("resume", False),
                          ("feed=150", False)])
        # The steps after the hold come the hold's 0.5 s later; those before it unchanged.
        late = [b - a for a, b in zip(plain.times, run.times)]
        self.assertEqual({round(d, 9) for d in late if abs(d) > 1e-9}, {0.5})
        self.assertEqual(sum(1 for a in plain.times if a <= half),
                         sum(1 for d in late if abs(d) < 1e-9))
        # Never resumed: the program stops after the braking, in HOLD.
        held = execute(job, "model", events=[(half, "hold")])
        self.assertEqual(held.final_state, "HOLD")
        self.assertEqual(held.steps, job.steps[:len(held.steps)])
        before = sum(1 for t in plain.times if t <= half)
        self.assertGreaterEqual(len(held.steps), before)
        self.assertLess(len(held.steps), before + 10)

    def test_amaranth_held_resumed_and_overridden(self):
        # Checked inside execute against the model (every step, every frame DONE, the end and
        # the state); and here: the run is longer by about the hold, the state reported.
        from kontur.machining import execute, prepare
        # (the iCEBreaker's controller, with the overrides since its arcs run on the bit-serial
        # node: a feed override of 50 % before the hold)
        job = prepare(TINY, machine=machine(), name="tiny.ngc")
        half = job.seconds / 2
        events = [(0.0, "estop-release"), (half / 2, "feed=50"), (half, "hold"),
                  (half + 0.2, "resume")]
        rtl = execute(job, "amaranth", events=events)
        self.assertEqual(rtl.steps, job.steps)
        self.assertEqual((rtl.final_state, rtl.end), ("IDLE", job.end))
        self.assertEqual([e["hold"] for e in rtl.events], [False, False, True, False])
        plain = execute(job, "model")
        self.assertGreater(rtl.times[-1], plain.times[-1] + 0.1)
        # The half speed from a quarter of the plan on: longer than the same hold alone (the
        # model's times, which take the hold and not the override) by more than a quarter of
        # the plan (three quarters of it at half speed: about as much again, less the ramps).
        held = execute(job, "model", events=[e for e in events if e[1] != "feed=50"])
        self.assertGreater(rtl.times[-1], held.times[-1] + job.seconds / 4)

    def test_amaranth_hold_never_resumed(self):
        from kontur.machining import execute, prepare
        job = prepare(TINY, machine=machine(), name="tiny.ngc")
        half = job.seconds / 2
        model = execute(job, "model", events=[(half, "hold")])
        rtl = execute(job, "amaranth", events=[(half, "hold")])
        self.assertEqual(rtl.final_state, "HOLD")
        self.assertEqual(rtl.steps, job.steps[:len(rtl.steps)])
        self.assertLess(len(rtl.steps), len(job.steps))
        self.assertLessEqual(abs(len(rtl.steps) - len(model.steps)), 3)
        self.assertEqual(rtl.end, (job.start[0] + sum(dx for dx, _ in rtl.steps),
                                   job.start[1] + sum(dy for _, dy in rtl.steps)))

    def test_amaranth_estop_in_a_hold_ends_it(self):
        # Held, then the e-stop: ALARM (the hold ends with it), released and unlocked: IDLE,
        # the program stopped where the hold stood.
        from kontur.machining import execute, prepare
        job = prepare(TINY, machine=machine(), name="tiny.ngc")
        half = job.seconds / 2
        events = [(half, "hold"), (half + 0.1, "estop"), (half + 0.15, "estop-release"),
                  (half + 0.2, "unlock")]
        model = execute(job, "model", events=events)
        rtl = execute(job, "amaranth", events=events)
        self.assertEqual((model.final_state, rtl.final_state), ("IDLE", "IDLE"))
        self.assertEqual([(e["alarm"], e["hold"]) for e in rtl.events],
                         [(False, True), (True, False), (True, False), (False, False)])
        self.assertEqual(rtl.steps, job.steps[:len(rtl.steps)])
        self.assertLessEqual(abs(len(rtl.steps) - len(model.steps)), 3)

    def test_compensated_contour_held_on_verilator(self):
        # A hold in the middle of the compensated contour (PROFILE frames through the
        # equidistant engine), resumed, then 50 %: the model's steps exactly.
        from kontur.machining import execute, prepare
        from .conftest import selected_simulators
        if "verilator" not in selected_simulators():
            self.skipTest("SIM selects another simulator")
        # (The default link: the controller tests/test_compensation_run.py builds for the
        # plate, so the Verilator build is shared.)
        job = prepare(CONTOUR, machine=machine("ulx3s", cutter_radius=0.3, baud=115200),
                      board="ulx3s", name="contour.ngc")
        self.assertTrue(job.contours)
        half = job.seconds / 2
        # The hold comes in the contour: the step planned at that time is a PROFILE frame's.
        from kontur.machining import _plan_times
        index = sum(1 for t in _plan_times(job) if t <= half)
        kinds = [s.kind for s in job.segments for _ in s.steps]
        self.assertEqual(kinds[index], "profile")
        rtl = execute(job, "verilator", events=[(half, "hold"), (half + 0.3, "resume"),
                                                (half + 0.35, "feed=50")])
        self.assertEqual(rtl.steps, job.steps)
        self.assertEqual((rtl.final_state, rtl.end), ("IDLE", job.end))
        self.assertGreater(rtl.times[-1], execute(job, "model").times[-1] + 0.2)

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
                                   "10", "--event", "hold@0.1", "--event", "feed=120@0.05",
                                   "--board", "ulx3s"]), 0)
            data = json.loads((out / "summary.json").read_text())
            self.assertEqual(data["final_state"], "HOLD")
            self.assertEqual([(e["event"], e["at"], e["hold"]) for e in data["events"]],
                             [("feed=120", 0.05, False), ("hold", 0.1, True)])
            self.assertLess(data["steps"], 30 + 10 + 24)
            for bad in ("feed=5@1", "feed=201@1", "feed=x@1", "rapid=75@1", "rapid=@1",
                        "spindle=9@1", "spindle=201@1", "hold", "resume@-1"):
                with self.subTest(bad=bad):
                    self.assertEqual(main(["run", str(program), "--out", str(out),
                                           "--event", bad]), 2)
            # The three-axis iCEBreaker's controller is built without the overrides:
            # refused, one line.
            import contextlib
            import io
            for event in ("feed=120", "spindle=50"):
                err = io.StringIO()
                with contextlib.redirect_stderr(err):
                    self.assertEqual(main(["run", str(program), "--out", str(out), "--event",
                                           f"{event}@0.05", "--board", "icebreaker-z"]), 2)
                self.assertEqual(err.getvalue().splitlines(), [
                    f"kontur: --event {event}: the icebreaker-z's controller is built without "
                    "the feed, rapid and spindle overrides (no room for them on the iCEBreaker "
                    "(iCE40UP5K-SG48), three axes (Z on PMOD2)); boards with them: icebreaker, "
                    "ulx3s"])
