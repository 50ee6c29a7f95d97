"""``kontur build``: a board's bitstream, with the figures of its build.

Two tops (:data:`TOPS`): ``controller``, the machine controller
(:class:`kontur.hdl.top.ControllerTop` around :func:`kontur.registry.make_controller`: frames over the
board's USB serial port, step/dir/enable on its header), and ``player``, the board's demo
(:class:`kontur.hdl.top.DemoTop` on the iCEBreaker: the octagon played in a loop through a line
engine, no host needed). The board's platform comes from the registry
(:data:`kontur.registry.BOARDS`); the tools are those of :func:`kontur.constraints.flow.toolchain_env`
(the yowasp builds from PyPI by default). Nothing is ever programmed.
"""

import json
import re
import sys
from pathlib import Path

from kontur.constraints.flow import (ROOT, SEED, ToolchainError, parse_critical_path,
                                     place_and_route)

__all__ = ["TOPS", "TARGETS", "build", "machine_file", "summary", "report", "targets",
           "parse_ports", "parse_flip_flops", "main"]

#: What ``kontur build --top`` builds.
TOPS = ("controller", "player")


def _top(item, top, machine):
    if top == "player":
        if item.demo is None:
            raise ValueError(f"The {item.name} has no demo player; build the controller")
        return item.demo()
    from kontur.hdl.top import ControllerTop
    from kontur import registry
    from kontur.machine import Machine
    if machine is None:
        machine = Machine(clock_hz=item.clock_hz)
    return ControllerTop(registry.make_controller(item.name, machine), divide=item.divide)


def build(board, build_dir, *, top="controller", machine=None, seed=SEED, out=None):
    """Build the bitstream of ``top`` (one of :data:`TOPS`) for ``board`` in ``build_dir``;
    return the build's figures.

    ``machine`` (a :class:`kontur.machine.Machine`, clocked as the board) gives the
    controller its serial rate, queue and step/dir timing; by default the
    :class:`~kontur.machine.Machine` defaults. Runs ``platform.build(...,
    do_program=False)`` (Yosys, nextpnr with ``--seed seed``, the packer). Returns
    ``{"board", "top", "bitstream", "log", "logic", "utilisation", "fmax", "seed",
    "seconds"}`` (see :func:`kontur.constraints.flow.place_and_route`); with ``out``, also writes a
    summary there.

    Raises
    ------
    :exc:`ValueError`
        If ``board`` is not a registered board or ``top`` not one of :data:`TOPS`.
    :exc:`kontur.constraints.flow.ToolchainError`
        If a tool is missing or fails.
    """
    from kontur import registry
    item = registry.board(board)
    if top not in TOPS:
        raise ValueError(f"Top must be one of {', '.join(map(repr, TOPS))}, not {top!r}")
    result = place_and_route(item.platform(), _top(item, top, machine), build_dir, seed=seed)
    result["board"] = board
    result["top"] = top
    result["machine"] = machine
    if out is not None:
        out.write(summary(result))
    return result


#: The utilisation lines of a summary: nextpnr's cell type and what it is, per device.
_CELLS = [("ICESTORM_LC", "logic"), ("ICESTORM_RAM", "block RAM"), ("SB_IO", "I/O"),
          ("TRELLIS_COMB", "logic"), ("TRELLIS_FF", "flip-flops"), ("DP16KD", "block RAM"),
          ("TRELLIS_IO", "I/O")]


def summary(result):
    """Return the text :func:`build` writes: bitstream, utilisation, Fmax, seed, time."""
    lines = [f"bitstream  {result['bitstream']}"]
    for cell, what in _CELLS:
        if cell in result["utilisation"]:
            used, available = result["utilisation"][cell]
            lines.append(f"{what:<10} {used}/{available} {cell} ({100 * used / available:.0f}%)")
    for clock, (mhz, verdict, target) in result["fmax"].items():
        constraint = f" ({verdict} at {target:g} MHz)" if target else ""
        lines.append(f"fmax       {mhz:.2f} MHz{constraint}, clock {clock!r}")
    lines += [f"seed       {result['seed']} (nextpnr)",
              f"log        {result['log']}",
              f"time       {result['seconds']:.1f} s"]
    return "\n".join(lines) + "\n"


def parse_ports(text):
    """Return the top's port names, sorted, from the pin file of a build: ``set_io NAME PIN``
    lines (an iCE40 ``.pcf``) or ``LOCATE COMP "NAME" SITE`` lines (an ECP5 ``.lpf``)."""
    names = re.findall(r"^set_io\s+(?:-\S+\s+)*(\S+)\s", text, re.MULTILINE)
    names += re.findall(r'^LOCATE COMP "([^"]+)"', text, re.MULTILINE)
    return sorted(set(names))


def parse_flip_flops(text):
    """Return the flip-flops of Yosys's last ``stat`` in a log (``SB_DFF*`` or ``TRELLIS_FF``
    cells: a count, then the cell's name, on a line), or ``None`` without one."""
    cells = {}
    for count, name in re.findall(r"^\s+(\d+)\s+(SB_DFF\w*|TRELLIS_FF)\s*$", text, re.MULTILINE):
        cells[name] = int(count)                           # the last stat's figure wins
    return sum(cells.values()) if cells else None


def _clock_path(log, clock):
    """The critical path of ``clock`` (:func:`~kontur.constraints.flow.parse_critical_path`
    of its own report in the nextpnr log, not the last clock's)."""
    head = f"Critical path report for clock '{clock}'"
    if head not in log:
        return None
    section = log.split(head, 1)[1].split("Critical path report for", 1)[0]
    return parse_critical_path("Critical path report for clock" + section)


#: What each device's controller is to reach (issue 27, docs/controller.md "The boards"): the
#: step rate per axis with a class of drives' step/dir timing (set-up, pulse, µs), and what the
#: full controller holds. For a target a build does not reach, ``limit`` says what stands in
#: the way and ``tried`` what was done about it, with the figures and the commands that measured
#: them.
TARGETS = {
    "iCE40UP5K": {
        "rate": (200_000, (1.0, 2.0), "A4988-class drives"),
        "axes": 3,
        "profile_width": 16,
        "limits": {
            "axes": "this is the two-axis build (lasers, plasma, plotters); the three-axis one "
                    "is icebreaker-z",
            "profile": "the equidistant engine alone is 6464 LC at 16 bits and 4015 at 8 "
                       "(python -m kontur.equidistant_figures fpga; the UP5K has 5280), next "
                       "to a controller of 4950 LC without it (where they go: python -m "
                       "kontur.bench cells)",
        },
        "tried": {
            "profile": "block 11's test and block 3's step kinds registered, the tests for "
                       "every step the element could make dropped: 9169 -> 7520 LC at 16 "
                       "bits; the slots a clock behind the position, block 11 and blocks 7 "
                       "and 8 in two registered stages, every sum one carry chain: 6657 LC; "
                       "block 11 in three stages, the slots' step terms and the multipliers' "
                       "operands registered: 6464 LC; "
                       "what would fit is a serial equidistant engine (the slots in "
                       "block RAM, one adder shared by the six integrators, the step's "
                       "settling clocks spent on it), a redesign with its model",
        },
    },
    "LFE5U-85F": {
        "rate": (1_000_000, (0.2, 0.2), "servo drives with fast pulse inputs"),
        "axes": 3,
        "profile_width": 16,
        "limits": {}, "tried": {},
    },
}


def step_rate(item, machine):
    """``(steps a second per axis at most, clocks a step)`` of board ``item``'s controller with
    ``machine``'s step/dir timing: the longer of the step/dir stage's clocks
    (:attr:`kontur.machine.Machine.step_dir_clocks`) and its slowest engine's
    (:meth:`kontur.registry.Board.slowest`)."""
    clocks = max(machine.step_dir_clocks, item.slowest()[0])
    return machine.clock_hz / clocks, clocks


def targets(rec):
    """The targets (:data:`TARGETS`) of a build's record (:func:`report`), each
    ``{"target", "met", "measured"}`` and, where not met, ``"limit"`` (what stands in the way:
    for the clock, its critical path) and ``"tried"``. The rate is the controller clock over the
    step/dir stage's clocks at the drives' timing (the stage is built for the machine file's
    timing: ``kontur build --machine`` with those ``dir_setup_us`` and ``step_width_us``), or
    over the slowest engine's clocks a step where that is longer
    (:meth:`kontur.registry.Board.slowest`: the bit-serial node's word, 22 clocks at 20
    bits)."""
    from kontur import registry
    from kontur.machine import Machine
    goal = TARGETS.get(rec["device"])
    if goal is None:
        return []
    item = registry.board(rec["board"])
    rows = []

    def row(target, met, measured, key=None):
        entry = {"target": target, "met": bool(met), "measured": measured}
        if not met and key in goal["limits"]:
            entry["limit"] = goal["limits"][key]
        if not met and key in goal["tried"]:
            entry["tried"] = goal["tried"][key]
        rows.append(entry)

    clock = rec["clock_mhz"]
    board_mhz = clock * item.divide
    met = item.divide == 1 and rec["fmax_mhz"] >= clock
    row(f"the board's {board_mhz:g} MHz, undivided", met,
        f"{clock:g} MHz, routed at {rec['fmax_mhz']:.2f} MHz")
    if not met and rec["critical_path"]:
        path = rec["critical_path"]
        rows[-1]["limit"] = f"{path['from']} -> {path['to']}"
    least, (setup, pulse), drives = goal["rate"]
    machine = Machine(clock_hz=item.clock_hz, dir_setup_us=setup, step_width_us=pulse)
    slowest, kind, name, width = item.slowest()
    rate, clocks = step_rate(item, machine)
    stage = machine.step_dir_clocks
    row(f"at least {least:,} steps/s per axis with {drives} ({setup:g} µs set-up, "
        f"{pulse:g} µs pulse)", rate >= least,
        f"{rate:,.0f} ({clocks} clocks a step: the step/dir stage's {stage}, the {kind} "
        f"engine's {slowest} on the {name} core at {width} bits)")
    axes = goal["axes"]
    row(f"{axes} axes", rec["axes"] >= axes, f"{rec['axes']}", "axes")
    for target, prefix in (("tool outputs", "tool_"),
                           ("safety inputs (e-stop, limits, probe, cycle start, feed hold)",
                            "switches_")):
        pins = sum(1 for p in rec["ports"] if p.startswith(prefix))
        row(target, pins > 0, f"{pins} pins", target)
    width = goal["profile_width"]
    profile = [e for e in rec["engines"] if e["kind"] == "profile"]
    row(f"cutter compensation (G41/G42) at {width} bits",
        bool(profile) and profile[0]["width"] >= width,
        f"the equidistant engine at {profile[0]['width']} bits" if profile else "none",
        "profile")
    return rows


def report(result):
    """Return the JSON-ready record of a controller's build (``result`` as :func:`build` returns
    it): board, device, controller clock, routed Fmax of that clock, critical path, cells,
    flip-flops, block RAM, DSPs, engines (each with its clocks a step and its path's accuracy
    in steps, :class:`kontur.registry.Variant`: what the board's choice of cores costs), axes,
    ports, the step-rate limit and the seed."""
    from kontur import registry
    from kontur.machine import Machine
    item = registry.board(result["board"])
    log = Path(result["log"]).read_text()
    build_dir = Path(result["log"]).parent
    pins = [p for p in build_dir.glob("top.pcf")] + [p for p in build_dir.glob("top.lpf")]
    ports = parse_ports(pins[0].read_text()) if pins else []
    rpt = build_dir / "top.rpt"
    util = result["utilisation"]
    ecp5 = "TRELLIS_COMB" in util
    logic = util["TRELLIS_COMB" if ecp5 else "ICESTORM_LC"]
    # The controller's clock is the slowest constrained one (the board's divided by divide).
    clock, (fmax, verdict, target) = min(result["fmax"].items(),
                                         key=lambda kv: kv[1][2] or float("inf"))
    machine = result.get("machine") or Machine(clock_hz=item.clock_hz)
    path = _clock_path(log, clock)
    engines = [{"kind": kind, "variant": name, "width": width,
                "clocks_per_step": registry.step_clocks(kind, name, width),
                "accuracy_steps": registry.variant(kind, name).accuracy}
               for kind, name, width in item.engines]
    rate, clocks = step_rate(item, machine)
    rec = {
        "board": result["board"],
        "device": str(getattr(item.platform(), "device", "")),
        "top": result["top"],
        "clock_mhz": item.clock_hz / 1e6,
        "clock_name": clock,
        "fmax_mhz": fmax, "fmax_verdict": verdict, "fmax_target_mhz": target,
        "critical_path": path,
        "logic_cell": "TRELLIS_COMB" if ecp5 else "ICESTORM_LC",
        "cells_used": logic[0], "cells_available": logic[1],
        "flip_flops": (util["TRELLIS_FF"][0] if "TRELLIS_FF" in util
                       else parse_flip_flops(rpt.read_text()) if rpt.exists() else None),
        "block_ram": list(util.get("DP16KD" if ecp5 else "ICESTORM_RAM", (0, 0))),
        "dsp": list(util.get("MULT18X18D" if ecp5 else "ICESTORM_DSP", (0, 0))),
        "engines": engines,
        "axes": sum(1 for p in ports if re.match(r"stepper_0__step__io", p)),
        "ports": ports,
        "step_dir_clocks": machine.step_dir_clocks,
        "clocks_per_step": clocks,
        "steps_per_s": rate,
        "seed": result["seed"],
        "seconds": result["seconds"],
    }
    rec["targets"] = targets(rec)
    return rec


def report_table(rec):
    """The short table of :func:`report` that ``kontur build --report`` prints."""
    return (f"report     {rec['board']} {rec['device']}: {rec['cells_used']}/"
            f"{rec['cells_available']} {rec['logic_cell']}, {rec['flip_flops']} FF, "
            f"BRAM {rec['block_ram'][0]}, DSP {rec['dsp'][0]}\n"
            f"           clock {rec['clock_mhz']:g} MHz, Fmax {rec['fmax_mhz']:.2f} MHz, "
            f"{rec['steps_per_s']:.0f} steps/s ({rec['clocks_per_step']} clocks a step), "
            f"seed {rec['seed']}\n"
            f"engines    " + ", ".join(
                f"{e['kind']} {e['variant']} {e['width']} bits ({e['clocks_per_step']} "
                f"clock{'s' if e['clocks_per_step'] > 1 else ''} a step"
                + (f", within {e['accuracy_steps']:.3g} steps of the path"
                   if e.get("accuracy_steps") is not None else "") + ")"
                for e in rec["engines"]) + "\n"
            + "".join(f"target     {'met    ' if t['met'] else 'NOT MET'} {t['target']}: "
                      f"{t['measured']}\n"
                      + (f"           limit: {t['limit']}\n" if "limit" in t else "")
                      + (f"           tried: {t['tried']}\n" if "tried" in t else "")
                      for t in rec.get("targets", ())))


def machine_file(board, path):
    """The :class:`~kontur.machine.Machine` of the machine file ``path`` for ``board``'s
    clock, its link and queue checked as the controller takes them (a queue of 2 to 255 frames,
    STATUS's byte; a baud the clock makes within 2 %; a ``max_feed`` the board's engines make,
    :func:`kontur.registry.check_machine`): the values the bitstream is built with.

    Raises
    ------
    :exc:`kontur.machine.MachineError`
        For a file that cannot be read, an unknown key or a value the machine or its controller
        cannot take (the message names the file and the key).
    """
    from kontur import registry
    from kontur.machine import Machine, MachineError
    item = registry.board(board)
    machine = Machine.from_toml(path, clock_hz=item.clock_hz)
    try:
        return registry.check_machine(item, machine.check())
    except MachineError as error:
        raise MachineError(f"{path}: {error}") from None


def main(argv=None):
    """``python -m kontur.build [--board B] [--top T] [--build-dir DIR] [--machine
    FILE]``; returns the exit status: 0 built, 2 for a bad option or machine file (one line on
    standard error, nothing built), 1 when a tool failed."""
    import argparse
    from kontur import registry
    from kontur.machine import MachineError
    parser = argparse.ArgumentParser(prog="python -m kontur.build",
                                     description="Build a board's bitstream (never programs).")
    parser.add_argument("--board", choices=list(registry.BOARDS), default="icebreaker")
    parser.add_argument("--top", choices=TOPS, default="controller")
    parser.add_argument("--build-dir", default=None,
                        help="build directory (default build/<board>-<top>)")
    parser.add_argument("--machine", metavar="FILE.toml", default=None,
                        help="the machine file whose link, queue and step/dir timing the "
                             "controller is built with (default: the defaults)")
    parser.add_argument("--seed", type=int, default=SEED, help="nextpnr's seed")
    parser.add_argument("--report", metavar="FILE.json", default=None,
                        help="the build's record (default build/<board>-<top>/report.json)")
    args = parser.parse_args(argv)
    machine = None
    if args.machine is not None:
        if args.top != "controller":
            sys.stderr.write("kontur build: --machine is for the controller (--top "
                             "controller); the player takes no machine file\n")
            return 2
        try:
            machine = machine_file(args.board, args.machine)
        except MachineError as error:
            sys.stderr.write(f"kontur build: {error}\n")
            return 2
    build_dir = args.build_dir or ROOT / "build" / f"{args.board}-{args.top}"
    try:
        result = build(args.board, build_dir, top=args.top, machine=machine, seed=args.seed,
                       out=sys.stdout)
    except ToolchainError as error:
        sys.stderr.write(f"kontur build: {error}\n")
        return 1
    if args.top == "controller" and result.get("fmax"):
        rec = report(result)
        path = Path(args.report or Path(build_dir) / "report.json")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(rec, indent=1) + "\n")
        sys.stdout.write(report_table(rec) + f"           written to {path}\n")
    if machine is not None:
        sys.stdout.write(f"machine    {args.machine}: {machine.baud} baud, queue of "
                         f"{machine.queue_frames} frames (kontur send --machine "
                         f"{args.machine})\n")
    return 0

if __name__ == "__main__":
    sys.exit(main())
