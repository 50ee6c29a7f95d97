# amaranth: UnusedElaboratable=no
"""``kontur build --machine FILE``: the controller built with a machine file's link and queue
(the tools replaced by a stand-in that keeps the design: nothing is placed or routed here), and
machine files the controller cannot take refused before anything is built."""

import os
import subprocess
from pathlib import Path

import pytest

import kontur.build
from kontur import registry
from kontur.cli import main
from kontur.hdl.spec import SETTLE

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def built(monkeypatch):
    """The designs handed to the tools, instead of placing and routing them."""
    designs = []

    def place_and_route(platform, top, build_dir, *, seed):
        designs.append(top)
        return {"bitstream": str(Path(build_dir) / "top.bin"), "log": "log", "utilisation": {},
                "fmax": {}, "seed": seed, "seconds": 0.0}
    monkeypatch.setattr(kontur.build, "place_and_route", place_and_route)
    return designs


def _machine(tmp_path, text):
    path = tmp_path / "machine.toml"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("board", ["icebreaker", "ulx3s"])
def test_machine_file_sets_the_controllers_link_and_queue(board, built, tmp_path, capsys):
    path = _machine(tmp_path, "baud = 57600\nqueue_frames = 12\n")
    assert main(["build", "--board", board, "--machine", path,
                 "--build-dir", str(tmp_path / "b")]) == 0
    assert main(["build", "--board", board, "--build-dir", str(tmp_path / "d")]) == 0
    custom, default = (top.controller for top in built)
    assert custom.queue_frames == 12 and default.queue_frames == 32
    clock = registry.board(board).clock_hz                 # the bit time, clocks a bit
    assert round(clock / 57600) == custom._divisor != default._divisor == round(clock / 115200)
    out = capsys.readouterr().out
    assert f"machine    {path}: 57600 baud, queue of 12 frames (kontur send --machine {path})\n" \
        in out


#: The iCEBreaker's controller clock, as the registry builds it.
ICEBREAKER_HZ = registry.BOARDS["icebreaker"].clock_hz

BAD = {"queue_frames = 1\n": "queue_frames must be an integer from 2 to 255",
       "queue_frames = 256\n": "queue_frames must be an integer from 2 to 255",
       "baud = 100000000\n": f"baud 1e+08 cannot be made from the {ICEBREAKER_HZ / 1e6:g} MHz "
                              f"clock",
       "bauds = 9600\n": "unknown key 'bauds'",
       "queue_frames = 2.5\n": "queue_frames must be an integer",
       # (drives with 0.2 µs set-up and pulse: 1.7 M steps/s; the arcs' bit-serial node 545 455)
       "dir_setup_us = 0.2\nstep_width_us = 0.2\nsteps_per_mm = 1000\nmax_feed = 40000\n":
           "more than the 545455 the icebreaker's arc engine makes"}


@pytest.mark.parametrize("text", BAD)
def test_bad_machine_file_refused_before_building(text, built, tmp_path, capsys):
    path = _machine(tmp_path, text)
    assert main(["build", "--machine", path]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and BAD[text] in err, err
    assert built == []                                      # nothing went to the tools
    assert main(["build", "--machine", str(tmp_path / "none.toml")]) == 2
    assert "cannot read the machine file" in capsys.readouterr().err
    assert main(["build", "--top", "player", "--machine", path]) == 2
    assert built == []


def test_make_bitstream_passes_the_machine_file():
    # make -n prints the recipe: the machine file reaches kontur build.
    # (Under `make test` the outer make's level and flags would add "Entering directory" lines.)
    env = {k: v for k, v in os.environ.items() if k not in ("MAKELEVEL", "MAKEFLAGS", "MFLAGS")}
    run = subprocess.run(["make", "-n", "--no-print-directory", "-o", "setup", "bitstream",
                          "BOARD=ulx3s", "MACHINE=m.toml"], cwd=ROOT, capture_output=True,
                         text=True, timeout=30, env=env)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip().splitlines()[-1].endswith(
        "kontur build --board ulx3s --top controller --machine m.toml")


# The build record (`kontur build --report`), read from the logs of a real build: the files under
# tests/golden/build_icebreaker_seed1/ are those `kontur build --board icebreaker --seed 1` wrote
# (nextpnr's top.tim and the pin file top.pcf, copied unchanged; top.stat is the tail of Yosys's
# top.rpt from its last "Printing statistics." on), not written by hand: regenerated from
# build/bench-controllers/icebreaker-s1 when the iCEBreaker went to 12 MHz (issue 27), again
# when its arcs moved to the bit-serial node beside the overrides and the laser mode, and when
# the iCE40 builds took `synth_ice40 -dsp` (the spindle override on a multiplier block).
REAL = ROOT / "tests" / "golden" / "build_icebreaker_seed1"


def _real_result(where, seed=1):
    """The result :func:`kontur.build.build` gave for the real build, its logs copied to
    ``where``."""
    where.mkdir(parents=True, exist_ok=True)
    for name in ("top.tim", "top.pcf"):
        (where / name).write_text((REAL / name).read_text())
    (where / "top.rpt").write_text((REAL / "top.stat").read_text())
    from kontur.constraints.flow import parse_fmax, parse_utilisation
    log = (REAL / "top.tim").read_text()
    return {"board": "icebreaker", "top": "controller", "log": where / "top.tim",
            "utilisation": parse_utilisation(log), "fmax": parse_fmax(log), "seed": seed,
            "seconds": 0.0, "machine": None}


def test_report_of_a_real_icebreaker_build(tmp_path):
    rec = kontur.build.report(_real_result(tmp_path))
    assert rec["device"] == "iCE40UP5K" and rec["logic_cell"] == "ICESTORM_LC"
    assert rec["cells_available"] == 5280                 # the UP5K's logic cells
    assert 0 < rec["cells_used"] <= 5280
    assert rec["clock_mhz"] == ICEBREAKER_HZ / 1e6         # the board's 12 MHz, undivided
    assert rec["fmax_mhz"] > rec["clock_mhz"]
    # Defaults: 1 µs set-up and 2 µs width, one clock more between pulses (at 12 MHz, 12 + 24
    # + 1 clocks).
    clocks = round(1e-6 * ICEBREAKER_HZ) + round(2e-6 * ICEBREAKER_HZ) + 1
    assert rec["clocks_per_step"] == rec["step_dir_clocks"] == clocks
    assert round(rec["steps_per_s"]) == round(ICEBREAKER_HZ / clocks)
    assert rec["axes"] == 2                                # X and Y step pins
    assert "uart_0__rx__io" in rec["ports"] and "stepper_0__enable__io" in rec["ports"]
    assert [e["kind"] for e in rec["engines"]] == ["line", "arc"]
    # (the arcs on the bit-serial node at 20 bits: a word of 22 clocks a step, separate steps
    # within half a diagonal of the arc where the line core is within half a step)
    assert [e["clocks_per_step"] for e in rec["engines"]] == [1, 22]
    assert [e["accuracy_steps"] for e in rec["engines"]] == [0.5, pytest.approx(0.5 ** 0.5)]
    assert "engines    line exact 16 bits (1 clock a step, within 0.5 steps of the path), arc " \
        "serial 20 bits (22 clocks a step, within 0.707 steps of the path)\n" \
        in kontur.build.report_table(rec)
    assert rec["critical_path"]["from"] and rec["critical_path"]["to"]
    assert 0 < rec["flip_flops"] < rec["cells_used"]
    assert rec["block_ram"][1] == 30 and rec["dsp"][1] == 8
    assert rec["seed"] == 1


@pytest.mark.parametrize("board, engines", [
    ("icebreaker", [("line", "exact", 16), ("arc", "serial", 20)]),
    ("icebreaker-z", [("line", "spatial", 16), ("arc", "serial", 16)]),
    ("ulx3s", [("line", "spatial", 16), ("arc", "fast", 24), ("profile", "fast", 16)])])
def test_report_names_the_cores_each_board_is_built_with(board, engines, tmp_path):
    # (the real build's logs stand in for each board's: only the engines are looked at)
    result = _real_result(tmp_path) | {"board": board}
    rec = kontur.build.report(result)
    assert [(e["kind"], e["variant"], e["width"]) for e in rec["engines"]] == engines


def _targets(rec):
    return {t["target"].split(" (")[0].split(":")[0]: t for t in rec["targets"]}


def test_report_rate_of_drives_faster_than_the_serial_node(tmp_path):
    # Drives with 0.2 µs set-up and pulse: the step/dir stage takes 3 + 3 + 1 clocks at 12 MHz,
    # the arcs' bit-serial node a word of 22: the record's rate is the node's.
    from kontur.machine import Machine
    fast = Machine(clock_hz=ICEBREAKER_HZ, dir_setup_us=0.2, step_width_us=0.2)
    rec = kontur.build.report(_real_result(tmp_path) | {"machine": fast})
    assert (rec["step_dir_clocks"], rec["clocks_per_step"]) == (7, 22)
    assert round(rec["steps_per_s"]) == round(ICEBREAKER_HZ / 22)
    assert "545455 steps/s (22 clocks a step)" in kontur.build.report_table(rec)


def test_report_says_which_targets_the_icebreaker_meets(tmp_path):
    rec = kontur.build.report(_real_result(tmp_path))
    targets = _targets(rec)
    clock = targets["the board's 12 MHz, undivided"]
    assert clock["met"] and clock["measured"] == f"12 MHz, routed at {rec['fmax_mhz']:.2f} MHz"
    assert rec["fmax_mhz"] > 12
    # A4988-class drives: 1 µs set-up (12 clocks), 2 µs pulse (24), one clock more.
    rate = targets["at least 200,000 steps/s per axis with A4988-class drives"]
    assert rate["met"] and rate["measured"] == (
        f"{12e6 / 37:,.0f} (37 clocks a step: the step/dir stage's 37, the arc engine's 22 on "
        f"the serial core at 20 bits)")
    assert targets["tool outputs"] == {"target": "tool outputs", "met": True,
                                       "measured": "5 pins"}          # top.pcf's tool_0
    assert targets["safety inputs"]["met"] and targets["safety inputs"]["measured"] == "6 pins"
    axes = targets["3 axes"]                                  # the two-axis build
    assert not axes["met"] and "icebreaker-z" in axes["limit"]
    profile = targets["cutter compensation"]
    assert not profile["met"] and profile["measured"] == "none"
    assert "LC" in profile["limit"] and "serial equidistant engine" in profile["tried"]
    table = kontur.build.report_table(rec)
    assert "target     NOT MET cutter compensation (G41/G42) at 16 bits: none" in table
    assert "           limit: the equidistant engine alone" in table


def test_report_targets_of_the_ulx3s(tmp_path):
    # (the iCEBreaker's logs stand in: routed below the ULX3S's 25 MHz)
    rec = kontur.build.report(_real_result(tmp_path) | {"board": "ulx3s"})
    targets = _targets(rec)
    clock = targets["the board's 25 MHz, undivided"]
    assert rec["fmax_mhz"] < 25 and not clock["met"]
    path = rec["critical_path"]
    assert clock["limit"] == f"{path['from']} -> {path['to']}"   # the path that limits it
    # 0.2 µs at 25 MHz is 5 clocks each, and one more: 11 clocks, 2.27 M steps/s; the profile
    # engine steps every SETTLE + 1 clocks at most (4), fewer.
    rate = targets["at least 1,000,000 steps/s per axis with servo drives with fast pulse inputs"]
    assert SETTLE + 1 < 11
    assert rate["met"] and rate["measured"] == (
        f"{25e6 / 11:,.0f} (11 clocks a step: the step/dir stage's 11, the profile engine's "
        f"{SETTLE + 1} on the fast core at 16 bits)")
    profile = targets["cutter compensation"]
    assert profile["met"] and "16 bits" in profile["measured"] and "limit" not in profile


def test_seed_reaches_nextpnr(monkeypatch, tmp_path):
    seeds = []

    def place_and_route(platform, top, build_dir, *, seed):
        seeds.append(seed)
        return {"bitstream": "top.bin", "log": "log", "utilisation": {}, "fmax": {},
                "seed": seed, "seconds": 0.0}
    monkeypatch.setattr(kontur.build, "place_and_route", place_and_route)
    assert main(["build", "--seed", "3", "--build-dir", str(tmp_path / "b")]) == 0
    assert main(["build", "--build-dir", str(tmp_path / "b")]) == 0
    assert seeds == [3, 1]


def test_flip_flops_of_the_last_stat():
    text = "   7   SB_DFF\n   2   SB_DFFE\n   9 cells\n   5   SB_DFF\n   1   SB_LUT4\n"
    assert kontur.build.parse_flip_flops(text) == 5 + 2
    assert kontur.build.parse_flip_flops("no stat here") is None


def test_bench_controllers_table_into_benchmarks(tmp_path):
    import kontur.bench
    calls = []

    def builder(board, build_dir, *, seed):
        calls.append((board, seed))
        return _real_result(Path(build_dir), seed)
    rows = kontur.bench.controllers(boards=("icebreaker",), seeds=(1, 2), build_root=tmp_path,
                                    builder=builder)
    assert calls == [("icebreaker", 1), ("icebreaker", 2)]
    kontur.bench.controllers(runs=[("icebreaker", 3)], build_root=tmp_path, builder=builder)
    assert calls[-1] == ("icebreaker", 3)
    del calls[:]                            # no boards named: every registered one
    kontur.bench.controllers(seeds=(1,), build_root=tmp_path / "all", builder=builder)
    assert calls == [(board, 1) for board in registry.BOARDS] and len(calls) == 3
    table = kontur.bench.controllers_table(rows)
    lines = table.splitlines()
    assert len(lines) == 2 + 2 and "| icebreaker | iCE40UP5K | 2 |" in lines[3]
    md = tmp_path / "B.md"
    md.write_text("# Benchmarks\n\n## Area\n\nx\n\n## How\n\ny\n")
    kontur.bench._write_controllers(md, rows, "cmd")
    kontur.bench._write_controllers(md, rows[:1], "cmd")     # replaced, not added twice
    text = md.read_text()
    assert text.count(kontur.bench.CONTROLLERS_HEADING) == 1
    assert text.index("## Area") < text.index(kontur.bench.CONTROLLERS_HEADING) \
        < text.index("## How")
    assert "| icebreaker | iCE40UP5K | 1 |" in text and "| 2 |" not in text


def test_bench_controllers_row_of_a_seed_that_does_not_place(tmp_path):
    import kontur.bench
    from kontur.constraints.flow import ToolchainError

    from kontur.constraints.flow import parse_error
    log = ("Info: placing\nERROR: Unable to find legal placement for all cells\n"
           "0 warnings, 1 error\n")
    assert parse_error(log) == "Unable to find legal placement for all cells"
    assert parse_error("Info: Max frequency for clock 'clk': 17.23 MHz\n") is None

    def builder(board, build_dir, *, seed):
        if seed == 3:
            raise ToolchainError("the build of top failed", reason=parse_error(log))
        return _real_result(Path(build_dir), seed)
    rows = kontur.bench.controllers(boards=("icebreaker",), seeds=(1, 3), build_root=tmp_path,
                                    builder=builder)
    assert rows[1] == {"board": "icebreaker", "seed": 3,
                       "failed": "Unable to find legal placement for all cells"}
    lines = kontur.bench.controllers_table(rows).splitlines()
    assert "| icebreaker | iCE40UP5K | 1 |" in lines[2]
    assert lines[3].startswith("| icebreaker | - | 3 |")
    assert "did not build: Unable to find legal placement for all cells" in lines[3]
    # Every build failing is the toolchain's failure, not a table of failures.
    with pytest.raises(ToolchainError):
        kontur.bench.controllers(runs=[("icebreaker", 3)], build_root=tmp_path / "b",
                                 builder=builder)


def test_a_build_that_does_not_place_says_what_to_try(monkeypatch, tmp_path):
    # nextpnr's placement failure (the device nearly full): the message gives its reason and
    # suggests another seed; any other failure gets no such hint.
    from amaranth import Elaboratable, Module, Signal

    from kontur.constraints import flow, icebreaker
    from kontur.sim import processes

    class Count(Elaboratable):              # (the tools are not run: any design will do)
        def elaborate(self, platform):
            m = Module()
            count = Signal(4)
            m.d.sync += count.eq(count + 1)
            return m

    def failing(error):
        def run(script, *, cwd, env):
            (Path(cwd) / "top.tim").write_text(f"Info: placing\nERROR: {error}\n")
            return subprocess.CompletedProcess(script, 1)
        return run

    for error, hint in (("Unable to find legal placement for all cells, design is probably "
                         "at utilisation limit.", True), ("Max frequency not met", False)):
        monkeypatch.setattr(processes, "run", failing(error))
        with pytest.raises(flow.ToolchainError) as failure:
            flow.place_and_route(icebreaker.platform(), Count(), tmp_path / "b", seed=1)
        assert failure.value.reason == error
        assert str(failure.value).startswith(f"the build of top failed ({error}); see the logs")
        assert str(failure.value).endswith("another nextpnr seed may place it (kontur build "
                                           "--seed N, make bitstream SEED=N)") == hint
