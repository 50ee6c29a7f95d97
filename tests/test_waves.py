"""Waveform regression: the RTL's dump, reduced to a per-clock trace, against golden traces."""

import unittest

from hdl.linear import LineEngine
from sim.models.codes import from_code
from sim.runners import run_amaranth
from sim.stimulus import Job
from sim.waves import check_trace, sample_vcd

from .utils import BUILD_DIR

GOLDEN = BUILD_DIR.parent / "tests" / "golden"


class LinearTableWaveTestCase(unittest.TestCase):
    def test_patent_table_from_vcd(self):
        width = 16
        vcd = BUILD_DIR / "waves" / "su1571551_table.vcd"
        vcd.parent.mkdir(parents=True, exist_ok=True)
        run_amaranth(LineEngine(variant="device", width=width), Job(frames=[{"x": 7, "y": 3}]),
                     vcd=vcd)
        clocks = sample_vcd(vcd, {"step": "engine.step", "f": "core.adder3.q",
                                  "addend": "core.mux12.o", "c1": "core.counter1.q_next",
                                  "c2": "core.counter2.q_next"})
        rows = []
        for clock in clocks:
            if not clock["step"]:
                continue
            move = "D" if clock["step"] == 0b11 else "P"
            # F after the step: adder 3 plus the multiplexer's code it adds in this clock,
            # plus the half that max = 7 leaves in F0 (adder 3 holds ⌊F⌋).
            f = from_code(clock["f"] + clock["addend"], width + 1) + 0.5
            c1 = from_code(clock["c1"], width + 1)
            c2 = from_code(clock["c2"], width + 1) + 1      # counter 2 holds C2 - 1
            rows.append([move, f, c1, c2])
        check_trace(GOLDEN / "su1571551_table.trace", ["move", "F", "C1", "C2"], rows)


if __name__ == "__main__":
    unittest.main()
