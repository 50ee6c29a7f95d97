# amaranth: UnusedElaboratable=no
"""Homing to the switches (issue 25): the HomingEngine against its model in every clock, with
the bench's switches following the position; where homing ends, from the geometry alone; the
ALARM's mask (the e-stop always trips, a limit only outside the homing axis's pass)."""

import unittest

from kontur.hdl.motion.alarm import Alarm
from kontur.hdl.motion.homing import HomingEngine
from kontur.hdl.motion.inputs import INPUTS
from kontur.sim.models.homing import BenchSwitches, HomingModel, cycle_steps

from .utils import simulate

DONE, REFUSED, ABORTED = 0, 1, 2


def home_pass(axis, negative, until, steps, value=None):
    return {"axis": axis, "negative": int(negative), "until": int(until),
            "set": int(value is not None), "reserved": 0, "steps": steps,
            "value": 0 if value is None else value}


def cycle_passes(axis, *, seek, pull_off, offset):
    """Grbl's cycle for one axis toward its negative switch: seek, back off, approach and set."""
    return [home_pass(axis, True, True, seek), home_pass(axis, False, False, pull_off),
            home_pass(axis, True, True, pull_off, offset)]


def run(passes, *, start, switches, every=3, lag=0, abort_at=None, clocks=None, ready=None):
    """Drive the RTL engine and its model with the same inputs (the switches from the position
    the RTL's steps make, ``lag`` clocks late; a tick every ``every`` clocks) and assert they
    agree in every clock. Returns ``(outcomes, position, counter, steps)``: the outcomes taken,
    the bench's position, the controller's position counter (the steps, and the loads), and the
    steps made on each axis."""
    dut, model = HomingEngine(), HomingModel()
    result = {}

    async def bench(ctx):
        position, counter, steps = list(start), list(start), [0, 0]
        history = [tuple(position)] * (lag + 1)
        outcomes, queue, clock = [], list(passes), 0
        while True:
            limits = switches.levels(history[0])
            tick = int(clock % every == 0)
            abort = int(clock == abort_at)
            status_ready = 1 if ready is None else ready(clock)
            offered = queue[0] if queue else None
            ctx.set(dut.cmd.valid, int(offered is not None))
            if offered is not None:
                ctx.set(dut.cmd.payload, offered)
            ctx.set(dut.feed.tick, tick)
            ctx.set(dut.limits, limits)
            ctx.set(dut.status.ready, status_ready)
            ctx.set(dut.abort, abort)
            want = model.cycle(cmd_valid=int(offered is not None), cmd=offered, tick=tick,
                               limits=limits, status_ready=status_ready, abort=abort)
            got = {"cmd_ready": ctx.get(dut.cmd.ready), "due": ctx.get(dut.feed.due),
                   "step": ctx.get(dut.motion.step), "status_valid": ctx.get(dut.status.valid),
                   "busy": ctx.get(dut.busy), "homing": ctx.get(dut.homing),
                   "mask": ctx.get(dut.mask), "load": ctx.get(dut.load)}
            for name, value in got.items():
                assert value == want[name], (clock, name, value, want[name])
            if got["step"]:
                assert ctx.get(dut.motion.dir) & got["step"] == want["dir"] & got["step"], clock
            if got["status_valid"]:
                payload = ctx.get(dut.status.payload)
                rtl = [payload.number, payload.outcome.value, list(payload.position)]
                assert rtl == want["status"], (clock, rtl, want["status"])
                if status_ready:
                    outcomes.append(rtl[1])
            if got["load"]:
                assert (ctx.get(dut.load_axis), ctx.get(dut.load_value)) == \
                    (want["load_axis"], want["load_value"]), clock
            for axis in range(2):
                if got["step"] >> axis & 1:
                    delta = -1 if want["dir"] >> axis & 1 else 1
                    position[axis] += delta
                    counter[axis] += delta
                    steps[axis] += 1
            if got["load"]:
                counter[want["load_axis"]] = want["load_value"]
            if offered is not None and got["cmd_ready"]:
                queue.pop(0)
            history = history[1:] + [tuple(position)]
            clock += 1
            await ctx.tick()
            finished = not queue and not got["busy"] and len(outcomes) == len(passes)
            if (clocks is None and finished) or clock == (clocks or 200_000):
                break
        result.update(outcomes=outcomes, position=position, counter=counter, steps=steps)

    simulate(dut, bench, name="homing")
    return result["outcomes"], result["position"], result["counter"], result["steps"]


class HomingEngineTest(unittest.TestCase):
    def test_homing_from_several_positions(self):
        switches = BenchSwitches((-40, 25))
        offset = (-3, 7)
        for start, lag, every in (((200, 160), 0, 3), ((-40, 25), 2, 3), ((-39, 90), 5, 3),
                                  ((-42, 24), 1, 4)):
            with self.subTest(start=start, lag=lag):
                passes = cycle_passes(0, seek=500, pull_off=20, offset=offset[0]) + \
                    cycle_passes(1, seek=500, pull_off=20, offset=offset[1])
                outcomes, position, counter, _ = run(passes, start=start, switches=switches,
                                                     lag=lag, every=every)
                self.assertEqual(outcomes, [DONE] * 6)
                for axis in range(2):
                    trip = switches.trip[axis]
                    # Stopped at the switch point; a switch seen later than the next permission
                    # (lag 5 at a tick every 3 clocks) lets one more step through.
                    self.assertLessEqual(abs(position[axis] - trip), 1)
                    self.assertLessEqual(abs((counter[axis] - offset[axis]) -
                                             (position[axis] - trip)), 1)
                    if lag < every:                  # seen before the next permission
                        self.assertEqual((position[axis], counter[axis]),
                                         (trip, offset[axis]))

    def test_switch_not_found(self):
        switches = BenchSwitches((-10_000, -10_000))
        outcomes, position, counter, steps = run([home_pass(1, True, True, 57, 0)],
                                                 start=(0, 0), switches=switches, clocks=400)
        self.assertEqual(outcomes, [REFUSED])
        self.assertEqual(steps, [0, 57])              # no step beyond the maximum
        self.assertEqual(position, [0, -57])
        self.assertEqual(counter, [0, -57])           # no position set

    def test_back_off_already_clear_and_seek_already_pressed(self):
        switches = BenchSwitches((0, 0))
        outcomes, position, _, steps = run(
            [home_pass(0, False, False, 30), home_pass(0, True, True, 30, 5)],
            start=(10, 0), switches=switches)
        self.assertEqual(outcomes, [DONE, DONE])
        self.assertEqual(steps, [10, 0])
        self.assertEqual(position, [0, 0])

    def test_abort_and_late_turn(self):
        switches = BenchSwitches((-1000, -1000))
        outcomes, _, _, steps = run([home_pass(0, True, True, 500)], start=(0, 0),
                                    switches=switches, abort_at=40, clocks=80)
        self.assertEqual(outcomes, [ABORTED])
        # Taken at clock 0, running from clock 1: the ticks at clocks 3, 6, ..., 39 are steps.
        self.assertEqual(steps[0], 13)
        # The turn comes late: the steps are made (the feed permits them) but the end waits.
        outcomes, position, _, _ = run([home_pass(0, True, True, 500)], start=(5, 0),
                                       switches=BenchSwitches((0, 0)),
                                       ready=lambda clock: int(clock >= 100))
        self.assertEqual((outcomes, position), ([DONE], [0, 0]))


class AlarmMaskTest(unittest.TestCase):
    def trips(self, changes, clocks=8):
        """The clocks where the ALARM unit enters ALARM, the inputs and mask per clock."""
        dut, entered = Alarm(), []

        async def bench(ctx):
            for clock in range(clocks):
                active, mask = changes(clock)
                ctx.set(dut.active, sum(1 << INPUTS.index(n) for n in active))
                ctx.set(dut.mask, mask)
                if ctx.get(dut.enter):
                    entered.append(clock)
                await ctx.tick()

        simulate(dut, bench, name="alarm_mask")
        return entered

    def test_masked_limit_does_not_trip(self):
        self.assertEqual(self.trips(lambda c: (("limit_x",) if c >= 3 else (), 0b01)), [])

    def test_other_limit_trips_while_homing(self):
        self.assertEqual(self.trips(lambda c: (("limit_y",) if c >= 3 else (), 0b01)), [3])

    def test_limit_trips_outside_homing(self):
        self.assertEqual(self.trips(lambda c: (("limit_x",) if c >= 3 else (), 0)), [3])

    def test_estop_trips_while_homing(self):
        self.assertEqual(self.trips(lambda c: (("estop",) if c >= 2 else (), 0b11)), [2])

    def test_limit_still_pressed_after_homing_does_not_trip(self):
        # The approach ends on the switch: lifting the mask with the switch pressed is no edge.
        self.assertEqual(self.trips(lambda c: (("limit_x",) if c >= 2 else (),
                                               0b01 if c < 5 else 0)), [])


#: The controller's bench: tests/test_controller.py's controller with the homing row.
Q24 = 1 << 24


def status_of(replies):
    (status,) = [r for r in replies if r.kind == 0x81]
    return status


def controller_run(frames, *, trip, clocks, inject=None, name, negative=(True, True),
                   estop_at=None, with_steps=False):
    """Run ``frames`` through a controller with a homing engine in Amaranth's simulator; the
    limit pins follow the pulses on the step pins (:class:`BenchSwitches` at ``trip``,
    toward the negative side; the e-stop pressed from clock ``estop_at`` on); with three
    ``trip`` points the controller has Z. Returns ``(replies, position)``: the replies and the
    bench's position (the pulses made)."""
    from kontur.hdl.helix import HelixEngine
    from kontur.hdl.line import LineEngine
    from kontur.hdl.spatial import SpatialLineCore
    from kontur.hdl.motion.homing import homing_row
    from kontur.hdl.motion.inputs import inputs_of
    from kontur.sim.testbench.hostlink import run_amaranth

    from kontur import registry
    from kontur.hdl.motion.controller import MotionController

    # tests/test_controller.py's controller, at a bit every 4 clocks (the UART's least): the
    # serial line is most of a homing run's time.
    axes = len(trip)
    line = LineEngine(SpatialLineCore(width=12, axes=3)) if axes == 3 else \
        registry.make_engine("line", width=12)
    arc = registry.make_engine("arc", "fast", width=12)
    dut, bit = MotionController(line=line, arc=HelixEngine(arc) if axes == 3 else arc,
                                clock_hz=1e6, baud=250_000, dir_setup=1, step_width=2,
                                queue_frames=8, engines=[homing_row(axes=axes)]), 4
    switches = BenchSwitches(trip, negative=negative)
    position, before, steps = [0] * axes, [0], []
    names = inputs_of(axes)

    def each(ctx, clock):
        step, direction = ctx.get(dut.motion.step), ctx.get(dut.motion.dir)
        for axis in range(axes):
            if step >> axis & 1 and not before[0] >> axis & 1:    # a pulse's first clock
                position[axis] += -1 if direction >> axis & 1 else 1
                if axes == 2:
                    steps.append((-1 if direction & 1 else 1, 0) if axis == 0 else
                                 (0, -1 if direction >> 1 & 1 else 1))
        before[0] = step
        pins = dut.idle_inputs
        for axis in range(axes):
            if switches.active(axis, position[axis]):
                pins ^= 1 << names.index(("limit_x", "limit_y", "limit_z")[axis])
        if estop_at is not None and clock >= estop_at:
            pins ^= 1 << INPUTS.index("estop")
        ctx.set(dut.inputs, pins)

    result = run_amaranth(dut, frames, divisor=bit, window=8, max_clocks=clocks, inject=inject,
                          each=each)
    replies = [reply for _, reply in result.replies]
    return (replies, position, steps) if with_steps else (replies, position)


class ControllerHomingTest(unittest.TestCase):
    def setUp(self):
        from kontur.hdl.motion import protocol
        from kontur.hdl.motion.homing import home_frame
        self.protocol, self.home = protocol, home_frame
        self.rate = round(0.05 * Q24)                     # a step every 20 clocks

    def feed(self):
        return self.protocol.feed(self.rate, self.rate, 1 << 20)

    def test_homing_x_sets_the_position_and_masks_the_limit(self):
        p, home = self.protocol, self.home
        frames = [p.config((1 << 32) - 1), self.feed(), home(0, True, True, 800),
                  self.feed(), home(0, False, False, 20), home(0, True, True, 20, 11),
                  self.feed(), p.line(5, 0), p.query()]
        replies, position = controller_run(frames, trip=(-400, -1000), clocks=60_000,
                                           inject={c: p.query() for c in (6000, 8000)}, name="controller_homing")
        outcomes = [r.fields[1] for r in replies if r.kind == 0x80]
        self.assertEqual(outcomes, [DONE] * 8)
        *during, last = [r for r in replies if r.kind == 0x81]
        self.assertIn("HOMING", [r.state for r in during])  # seeking, no ALARM
        self.assertNotIn("ALARM", [r.state for r in during])
        # Homed at the switch (X -400 is the machine's 11), then 5 steps off it.
        self.assertEqual(position, [-395, 0])
        self.assertEqual(last.fields[:2], (16, 0))
        self.assertEqual(last.state, "IDLE")

    def test_switch_not_found_is_refused(self):
        p, home = self.protocol, self.home
        frames = [p.config((1 << 32) - 1), self.feed(), home(1, True, True, 40), p.query()]
        replies, position = controller_run(frames, trip=(-1000, -1000), clocks=20_000,
                                           name="controller_homing_fail")
        self.assertEqual([r.fields[1] for r in replies if r.kind == 0x80], [DONE, DONE, REFUSED])
        self.assertEqual(position, [0, -40])

    def test_estop_during_homing_trips(self):
        p, home = self.protocol, self.home
        frames = [p.config((1 << 32) - 1), self.feed(), home(0, True, True, 800), p.query()]
        replies, position = controller_run(frames, trip=(-400, -1000), clocks=20_000,
                                           estop_at=4000, name="controller_homing_estop")
        self.assertEqual([r.fields[1] for r in replies if r.kind == 0x80],
                         [DONE, DONE, ABORTED])
        (status,) = [r for r in replies if r.kind == 0x81]
        self.assertEqual((status.state, status.fields[5]), ("ALARM", 1))   # cause: e-stop
        self.assertGreater(position[0], -400)           # stopped before the switch

    def test_limit_during_a_move_trips(self):
        p = self.protocol
        frames = [p.config((1 << 32) - 1), self.feed(), p.line(-50, 0), p.query()]
        replies, position = controller_run(frames, trip=(-30, -1000), clocks=20_000,
                                           name="controller_limit")
        self.assertEqual([r.fields[1] for r in replies if r.kind == 0x80], [DONE, DONE, ABORTED])
        (status,) = [r for r in replies if r.kind == 0x81]
        self.assertEqual(status.state, "ALARM")
        self.assertEqual(position, [-30, 0])


class HostCycleTest(unittest.TestCase):
    """kontur.homing's cycle on the controller, the switches following the pulses."""

    def machine(self, **keys):
        from kontur.machine import Machine
        return Machine(**{"clock_hz": 1e6, "baud": 125_000, "steps_per_mm": 10,
                          "dir_setup_us": 1, "step_width_us": 2, "travel_x": (0, 20),
                          "travel_y": (-5, 10), "homing_dir": ("-", "+"),
                          "homing_seek": 30_000, "homing_feed": 6000, "homing_debounce_ms": 1,
                          "accel": 200_000, "input_filter_us": 10, **keys})

    def test_cycle_homes_both_axes(self):
        from kontur.homing import homing_frames
        machine = self.machine()
        frames, names = homing_frames(machine)
        # Two axes: 3 passes (FEED, HOME, DWELL) and the pull-off (FEED, LINE) each.
        self.assertEqual(len(frames), 2 + 2 * (3 * 3 + 2))
        # X's switch closes at or below -23 steps, Y's (toward "+") at or above 17.
        replies, position, steps = controller_run(
            frames + [self.protocol_query()], trip=(-23, 17), negative=(True, False),
            clocks=200_000, name="controller_homing_cycle", with_steps=True)
        # The cycle's step-level model, its passes read off the frames' bytes here.
        items = []
        for frame in frames:
            kind, payload = frame[1], frame[3:-2]
            if kind == 0x17:                               # HOME
                items.append(("home", {"axis": payload[0] & 1, "negative": payload[0] >> 1 & 1,
                                       "until": payload[0] >> 2 & 1,
                                       "set": payload[0] >> 3 & 1,
                                       "steps": int.from_bytes(payload[1:5], "little"),
                                       "value": int.from_bytes(payload[5:9], "little",
                                                               signed=True)}))
            elif kind == 0x10:                             # LINE
                items.append(("line", int.from_bytes(payload[0:4], "little", signed=True),
                              int.from_bytes(payload[4:8], "little", signed=True)))
        want = cycle_steps(items, (0, 0), BenchSwitches((-23, 17), negative=(True, False)))
        self.assertEqual(steps, want[0])
        self.assertEqual((position, list(status_of(replies).fields[:2])), (want[2], want[3]))
        self.assertEqual([r.fields[1] for r in replies if r.kind == 0x80],
                         [DONE] * (len(frames)))
        status = status_of(replies)
        # X's switch point is its travel's low end, 0 mm; Y's its high end, 10 mm = 100
        # steps; each then pulled 1 mm (10 steps) off.
        self.assertEqual(status.fields[:2], (10, 90))
        self.assertEqual(position, [-23 + 10, 17 - 10])

    def protocol_query(self):
        from kontur.hdl.motion import protocol
        return protocol.query()

    def test_cycle_homes_z_first(self):
        """A 3-axis machine homing Z first (Grbl's cycle 0), up to its switch at the top, then
        X and Y: Z's passes move Z alone, its switch sets its position, the pull-off brings it
        down off the switch."""
        from kontur.homing import homing_frames
        machine = self.machine(homing_order=("z", "x"), homing_dir=("-", "+", "+"),
                               travel_z=(-8, 2))
        frames, names = homing_frames(machine, axes=3)
        self.assertEqual(names[1:12:4], ["z seek", "z back-off", "z approach"])
        replies, position = controller_run(
            frames + [self.protocol_query()], trip=(-23, 17, 31), negative=(True, False, False),
            clocks=200_000, name="controller_homing_cycle_z")
        self.assertEqual([r.fields[1] for r in replies if r.kind == 0x80],
                         [DONE] * len(frames))
        # Z's switch point is its travel's top, 2 mm = 20 steps, pulled 1 mm (10 steps) down;
        # X as in test_cycle_homes_both_axes; Y not homed, not moved.
        self.assertEqual(status_of(replies).position, (10, 0, 10))
        self.assertEqual(position, [-23 + 10, 0, 31 - 10])

    def test_z_needs_three_axes_and_its_travel(self):
        from kontur.homing import homing_frames
        from kontur.machine import MachineError
        with self.assertRaisesRegex(MachineError, "^homing_order homes Z, and the controller "
                                                  "has two axes"):
            homing_frames(self.machine(homing_order=("z", "x", "y"), travel_z=(-8, 2)))
        with self.assertRaisesRegex(MachineError, "^homing needs travel_z"):
            homing_frames(self.machine(homing_order=("z", "x", "y")), axes=3)
        with self.assertRaisesRegex(MachineError, "^homing_offset must give Z's switch point"):
            self.machine(homing_order=("z", "x"), homing_offset=(0, 0))

    def test_no_travel_is_refused(self):
        from kontur.homing import homing_frames
        from kontur.machine import Machine, MachineError
        with self.assertRaisesRegex(MachineError, "^homing needs travel_x"):
            homing_frames(Machine(clock_hz=1e6))

    def test_failure_words(self):
        from kontur.homing import failure
        self.assertEqual(failure(self.machine(), "x seek"),
                         "homing failed: the X switch was not active within 30 mm (seek)")


class BoardTest(unittest.TestCase):
    def test_boards(self):
        from kontur import registry
        from kontur.homing import check_board
        from kontur.machine import Machine
        from kontur.trace import UsageError
        rows = {name: [row.name for row in registry.make_controller(
            name, Machine(clock_hz=registry.board(name).clock_hz)).table]
            for name in ("icebreaker", "ulx3s")}
        self.assertIn("homing", rows["ulx3s"])
        self.assertNotIn("homing", rows["icebreaker"])
        check_board("ulx3s")
        with self.assertRaisesRegex(UsageError, "^homing: the icebreaker's controller is built "
                                                "without the homing engine .*: ulx3s$"):
            check_board("icebreaker")


class GrblSettingsTest(unittest.TestCase):
    def test_homing_settings_are_the_machine_files(self):
        """Grbl's $24-$27 (its defaults 25, 500, 250, 1.0: Grbl's settings document) are the
        machine keys homing_feed, homing_seek, homing_debounce_ms, homing_pulloff."""
        from kontur.grbl.settings import Settings
        from kontur.machine import Machine
        settings = Settings(Machine())
        lines = dict(line.split("=") for line in settings.lines())
        self.assertEqual([lines[f"${n}"] for n in (24, 25, 26, 27)],
                         ["25.000", "500.000", "250", "1.000"])
        self.assertEqual(settings.write(27, 2.5).homing_pulloff, 2.5)
