"""``kontur build``: the demo bitstream for a board, with the figures of its build.

The top is :class:`hdl.top.DemoTop` (the octagon played in a loop through ``LineEngine``, on
PMOD1A and the LEDs); the platform comes from ``constraints/``; the tools are those of
:func:`sim.bench.toolchain_env` (the yowasp builds from PyPI by default). Nothing is ever
programmed.
"""

import sys
from pathlib import Path

from .bench import SEED, ToolchainError, place_and_route

__all__ = ["build", "summary", "main", "BOARDS"]

ROOT = Path(__file__).resolve().parent.parent

#: Boards with a demo top.
BOARDS = ("icebreaker",)


def build(board, build_dir, *, seed=SEED, out=None):
    """Build the demo bitstream for ``board`` in ``build_dir``; return the build's figures.

    Runs ``platform.build(DemoTop(), name="top", build_dir=build_dir, do_program=False)``
    (Yosys, nextpnr-ice40 with ``--seed seed``, icepack). Returns ``{"board", "bitstream",
    "log", "lc", "utilisation", "fmax", "seed", "seconds"}`` (see
    :func:`sim.bench.place_and_route`); with ``out``, also writes a summary there.

    Raises
    ------
    :exc:`ValueError`
        If ``board`` is not one of :data:`BOARDS`.
    :exc:`sim.bench.ToolchainError`
        If a tool is missing or fails.
    """
    if board not in BOARDS:
        options = ", ".join(repr(name) for name in BOARDS)
        raise ValueError(f"Board must be one of {options}, not {board!r}")
    import constraints
    from hdl.top import DemoTop

    result = place_and_route(constraints.platform(board), DemoTop(), build_dir, seed=seed)
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
    """``python -m sim.build [--board icebreaker] [--build-dir DIR]``; returns the exit status."""
    import argparse
    parser = argparse.ArgumentParser(prog="python -m sim.build",
                                     description="Build the demo bitstream (never programs).")
    parser.add_argument("--board", choices=BOARDS, default="icebreaker")
    parser.add_argument("--build-dir", default=None,
                        help="build directory (default build/<board>)")
    args = parser.parse_args(argv)
    build_dir = args.build_dir or ROOT / "build" / args.board
    try:
        build(args.board, build_dir, out=sys.stdout)
    except ToolchainError as error:
        sys.stderr.write(f"kontur build: {error}\n")
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
