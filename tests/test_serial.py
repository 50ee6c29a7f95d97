# amaranth: UnusedElaboratable=no
"""The bit-serial linear-circular node against its cycle model, clock for clock: the node on its
own (Ро, refusals, stops, permissions) and as line and quadrant cores of the engines."""

import random
import unittest

from kontur.hdl.serial import SerialArcCore, SerialLineCore, SerialNode, word_length
from kontur import registry
from kontur.sim.models.arc import points_ahead
from kontur.sim.models.errors import InputError
from kontur.sim.models.serial import SerialNodeModel
from kontur.sim.models.serial import word_length as model_word_length
from kontur.sim.runners import run_amaranth
from kontur.sim.stimulus import Job, first_difference, record_moves, record_steps, run_model

from .utils import compare_core, used


def line_frame(x, y):
    return {"circle": 0, "x0": 0, "y0": 0, "f0": y, "xk": x, "yk": y}


def circle_frame(x, y, r2):
    return {"circle": 1, "x0": x, "y0": y, "f0": r2 - x * x - y * y, "xk": 0, "yk": 0}


def node_schedule(frames, clocks, *, seed, refusals=0.02, stops=0.0):
    """Per-clock inputs for the node: each frame loaded by Ро as soon as the node is ready (a
    model decides when), Ро also now and then while it is busy (refused), permissions at
    random, and for circles :py:`stop` at random while it runs. Inputs stay until the next
    load."""
    rng = random.Random(seed)
    model = SerialNodeModel(8)
    pending = list(frames)
    current = line_frame(0, 0)
    rows = []
    for _ in range(clocks):
        row = dict(current, tick=int(rng.random() < 0.7), stop=int(rng.random() < stops))
        ready = model.outputs(tick=row["tick"], stop=row["stop"])["ready"]
        if pending and ready:
            current = pending.pop(0)
            row.update(current, po=1)
        elif model.phase != "Idle" and rng.random() < refusals:
            row["po"] = 1                               # refused: the node is busy
        rows.append(row)
        model.cycle(**row)
    return rows


class NodeTestCase(unittest.TestCase):
    """The node alone, its ports driven directly, against :class:`SerialNodeModel`."""

    def run_node(self, rows, name):
        dut = SerialNode(width=8)
        model = SerialNodeModel(8)
        state = {f"pr{k}": getattr(dut, f"pr{k}").q for k in range(1, 8)}
        state["bit"] = dut.bit
        return compare_core(self, dut, model, rows, state=state, name=name)

    def test_lines_and_refusals(self):
        rng = random.Random(1)
        frames = [line_frame(rng.randint(0, 30), rng.randint(0, 30)) for _ in range(14)]
        frames[3] = line_frame(0, 0)                    # ends with its start, no step
        frames[4] = line_frame(255, 0)
        frames[5] = line_frame(0, 255)
        outputs = self.run_node(node_schedule(frames, 12000, seed=1), "serial_node_lines")
        self.assertGreater(sum(o["error"] for o in outputs), 10)
        self.assertEqual(sum(o["done"] for o in outputs), len(frames))
        self.assertEqual(sum(bool(o["step"]) for o in outputs),
                         sum(f["xk"] + f["yk"] for f in frames))

    def test_circles_stops_and_refusals(self):
        rng = random.Random(2)
        frames = []
        for _ in range(12):
            x, y = rng.randint(1, 60), rng.randint(0, 60)
            frames.append(circle_frame(x, y, x * x + y * y))
        frames += [circle_frame(100, 0, 10000 + 77), circle_frame(1, 0, 1), circle_frame(255, 0,
                                                                                     255 * 255)]
        outputs = self.run_node(node_schedule(frames, 20000, seed=2, stops=0.002),
                                "serial_node_circles")
        self.assertGreater(sum(o["error"] for o in outputs), 10)
        self.assertEqual(sum(o["done"] for o in outputs), len(frames))

    def test_one_word_per_step(self):
        # With a permission in every clock: the line's initialisation word, then a step every
        # W = width + 2 clocks; it ends W - 1 clocks after its last step.
        model = SerialNodeModel(8)
        word = model.word
        outputs = [model.cycle(**line_frame(5, 3), po=int(clock == 0), tick=1)[0]
                   for clock in range(200)]
        steps = [c for c, o in enumerate(outputs) if o["step"]]
        starts = [c for c, o in enumerate(outputs) if o["start"]]
        dones = [c for c, o in enumerate(outputs) if o["done"]]
        self.assertEqual(starts, [word])
        self.assertEqual(steps, [word + 1 + k * word for k in range(8)])
        self.assertEqual(dones, [steps[-1] + word - 1])
        self.assertEqual(word, 10)
        self.assertEqual(word_length(8), model_word_length(8))

    def test_strict_model_raises(self):
        model = SerialNodeModel(8, strict=True)
        model.cycle(**line_frame(5, 3), po=1)
        model.cycle(**line_frame(5, 3))
        with self.assertRaisesRegex(InputError,
                r"^load \(Ро\) while a frame is in progress and not ending in this clock: "
                r"refused$"):
            model.cycle(**line_frame(5, 3), po=1)

    def test_parameters_wrong(self):
        for make in (SerialNode, SerialLineCore, SerialArcCore):
            with self.assertRaisesRegex(TypeError,
                    r"^Register width must be an integer of at least 2, not 1$"):
                make(width=1)
        node = SerialNode(width=12)
        self.assertEqual((node.width, node.word), (12, 14))
        used(node)


class EngineTestCase(unittest.TestCase):
    """The serial cores in the line and arc engines against the engine models."""

    def check(self, kind, job, width, *, state=True):
        engine = registry.make_engine(kind, "serial", width=width)
        model = registry.make_model(kind, "serial", width=width)
        node = engine.core.node
        signals = ({f"pr{k}": getattr(node, f"pr{k}").q for k in range(1, 8)} | {"bit": node.bit}
                   if state else None)
        expected = run_model(model, job, state=state)
        actual = run_amaranth(engine, job, state=signals)
        self.assertIsNone(first_difference(expected, actual))
        return actual

    def expected(self, kind, frames, width):
        moves = []
        for frame in frames:
            try:
                moves += registry.steps(kind, frame, "serial", width=width)
            except registry.InputError:
                pass
        return moves

    def test_lines(self):
        rng = random.Random(3)
        frames = [{"x": x, "y": y} for x in range(-4, 5) for y in range(-4, 5)]
        rng.shuffle(frames)
        frames += [{"x": 255, "y": -1}, {"x": 256, "y": 0}, {"x": -3, "y": -255}]
        record = self.check("line", Job(frames=frames), 8)
        self.assertEqual(record_steps(record), self.expected("line", frames, 8))
        self.assertEqual(sum(e.get("error", 0) for e in record), 1)

    def test_lines_gaps_stalls_aborts_resets(self):
        rng = random.Random(4)
        frames = [{"x": rng.randint(-12, 12), "y": rng.randint(-12, 12)} for _ in range(20)]
        frames[5] = {"x": 0, "y": 0}
        job = Job(frames=frames, gaps=[rng.choice([0, 0, 3, 20]) for _ in frames],
                  tick=[1, 0, 1, 1, 0, 1, 1], status_ready=[1, 1, 0],
                  resets={700: 1}, aborts={300: 1, 1500: 2})
        record = self.check("line", job, 8)
        self.assertGreaterEqual(sum(e.get("aborted", 0) for e in record), 1)

    def test_circles_and_arcs(self):
        rng = random.Random(5)
        frames = [{"x0": r, "y0": 0, "x1": r, "y1": 0, "cw": r % 2} for r in (1, 2, 3, 5, 8)]
        frames += [{"x0": 2, "y0": 3, "x1": 2, "y1": 3, "cw": 0},       # radius sqrt(13)
                   {"x0": 5, "y0": 0, "x1": 2, "y1": 4, "cw": 0}]       # refused: off the circle
        for _ in range(6):
            x0, y0 = rng.randint(-12, 12), rng.randint(1, 12)
            cw = rng.randrange(2)
            x1, y1 = points_ahead(x0, y0, rng.randint(1, 60), cw=cw, width=8)[-1]
            frames.append({"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw})
        record = self.check("arc", Job(frames=frames, tick=[1, 1, 0]), 8)
        self.assertEqual(record_steps(record), self.expected("arc", frames, 8))
        self.assertEqual(sum(e.get("error", 0) for e in record), 1)

    def test_arcs_stalls_aborts(self):
        frames = [{"x0": r, "y0": 0, "x1": 0, "y1": r, "cw": 0} for r in (6, 4, 9, 3)]
        job = Job(frames=frames, status_ready=[1, 0, 1], aborts={400: 1}, resets={900: 1})
        record = self.check("arc", job, 8, state=False)
        self.assertGreaterEqual(sum(e.get("aborted", 0) for e in record), 1)

    def test_wide_registers(self):
        # Width 24: a 26-bit word; a large radius near an axis, a few hundred steps of it.
        x0, y0 = 9_000_000, 1234
        x1, y1 = points_ahead(x0, y0, 150, width=24)[-1]
        frames = [{"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": 0}]
        record = self.check("arc", Job(frames=frames), 24, state=False)
        self.assertEqual(record_steps(record), self.expected("arc", frames, 24))
        moves = record_moves(record)
        self.assertEqual(moves[1][0] - moves[0][0], word_length(24))


if __name__ == "__main__":
    unittest.main()
