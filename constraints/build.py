"""``kontur build``: the demo bitstream for a board, with the figures of its build.

The board's platform and demo top come from the registry (:data:`sim.registry.BOARDS`; the
iCEBreaker's demo is :class:`hdl.top.DemoTop`, the octagon played in a loop through a line
engine, on PMOD1A and the LEDs); the tools are those of :func:`constraints.flow.toolchain_env`
(the yowasp builds from PyPI by default). Nothing is ever programmed.
"""

import sys

from .flow import ROOT, SEED, ToolchainError, place_and_route

__all__ = ["build", "summary", "main"]


def build(board, build_dir, *, seed=SEED, out=None):
    """Build the demo bitstream for ``board`` in ``build_dir``; return the build's figures.

    Runs ``platform.build(DemoTop(), name="top", build_dir=build_dir, do_program=False)``
    (Yosys, nextpnr-ice40 with ``--seed seed``, icepack). Returns ``{"board", "bitstream",
    "log", "lc", "utilisation", "fmax", "seed", "seconds"}`` (see
    :func:`constraints.flow.place_and_route`); with ``out``, also writes a summary there.

    Raises
    ------
    :exc:`ValueError`
        If ``board`` is not a registered board.
    :exc:`constraints.flow.ToolchainError`
        If a tool is missing or fails.
    """
    from sim import registry
    if board not in registry.BOARDS:
        options = ", ".join(repr(name) for name in registry.BOARDS)
        raise ValueError(f"Board must be one of {options}, not {board!r}")
    item = registry.BOARDS[board]
    result = place_and_route(item.platform(), item.demo(), build_dir, seed=seed)
    result["board"] = board
    if out is not None:
        out.write(summary(result))
    return result


def summary(result):
    """Return the text :func:`build` writes: bitstream, logic cells, Fmax, seed, time."""
    used, available = result["lc"]
    lines = [f"bitstream  {result['bitstream']}",
             f"logic      {used}/{available} ICESTORM_LC ({100 * used / available:.0f}%)"]
    for clock, (mhz, verdict, target) in result["fmax"].items():
        constraint = f" ({verdict} at {target:g} MHz)" if target else ""
        lines.append(f"fmax       {mhz:.2f} MHz{constraint}, clock {clock!r}")
    lines += [f"seed       {result['seed']} (nextpnr)",
              f"log        {result['log']}",
              f"time       {result['seconds']:.1f} s"]
    return "\n".join(lines) + "\n"


def main(argv=None):
    """``python -m constraints.build [--board B] [--build-dir DIR]``; returns the exit
    status."""
    import argparse
    from sim import registry
    parser = argparse.ArgumentParser(prog="python -m constraints.build",
                                     description="Build the demo bitstream (never programs).")
    parser.add_argument("--board", choices=list(registry.BOARDS), default="icebreaker")
    parser.add_argument("--build-dir", default=None,
                        help="build directory (default build/<board>)")
    args = parser.parse_args(argv)
    build_dir = args.build_dir or ROOT / "build" / args.board
    try:
        build(args.board, build_dir, out=sys.stdout)
    except ToolchainError as error:
        sys.stderr.write(f"kontur build: {error}\n")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
