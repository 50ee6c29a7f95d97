"""``kontur build``: a board's bitstream, with the figures of its build.

Two tops (:data:`TOPS`): ``controller``, the machine controller
(:class:`kontur.hdl.top.ControllerTop` around :func:`kontur.registry.make_controller`: frames over the
board's USB serial port, step/dir/enable on its header), and ``player``, the board's demo
(:class:`kontur.hdl.top.DemoTop` on the iCEBreaker: the octagon played in a loop through a line
engine, no host needed). The board's platform comes from the registry
(:data:`kontur.registry.BOARDS`); the tools are those of :func:`kontur.constraints.flow.toolchain_env`
(the yowasp builds from PyPI by default). Nothing is ever programmed.
"""

import sys

from kontur.constraints.flow import ROOT, SEED, ToolchainError, place_and_route

__all__ = ["TOPS", "build", "machine_file", "summary", "main"]

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


def machine_file(board, path):
    """The :class:`~kontur.machine.Machine` of the machine file ``path`` for ``board``'s
    clock, its link and queue checked as the controller takes them (a queue of 2 to 255 frames,
    STATUS's byte; a baud the clock makes within 2 %): the values the bitstream is built
    with.

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
        return machine.check()
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
        build(args.board, build_dir, top=args.top, machine=machine, out=sys.stdout)
    except ToolchainError as error:
        sys.stderr.write(f"kontur build: {error}\n")
        return 1
    if machine is not None:
        sys.stdout.write(f"machine    {args.machine}: {machine.baud} baud, queue of "
                         f"{machine.queue_frames} frames (kontur send --machine "
                         f"{args.machine})\n")
    return 0

if __name__ == "__main__":
    sys.exit(main())
