"""The ``kontur`` command line.

``kontur trace line X Y`` and ``kontur trace arc X0 Y0 X1 Y1`` print the steps of a segment
or an arc, one ``dx dy`` line per step and nothing else on standard output (with ``--cycles``:
``cycle dx dy``). Messages, refusals included, go to standard error; a refused command exits
with status 2.
"""

import argparse
import sys

from .models.errors import InputError
from .runners import ENGINES
from .stimulus import record_moves

__all__ = ["main"]


def _add_engine_options(parser, variants, default_variant):
    parser.add_argument("--variant", choices=variants, default=default_variant,
                        help=f"core variant (default {default_variant})")
    parser.add_argument("--engine", choices=ENGINES, default="model",
                        help="golden model, or the RTL in Amaranth's simulator, Icarus or "
                             "Verilator (default model)")
    parser.add_argument("--width", type=int, default=None,
                        help="register width in bits")
    parser.add_argument("--vcd", metavar="FILE", default=None,
                        help="write the waveform of the RTL run to FILE")
    parser.add_argument("--cycles", action="store_true",
                        help="prefix every step with its clock number")


def _parser():
    parser = argparse.ArgumentParser(
        prog="kontur",
        description="CNC contour interpolators of Soviet patents, as RTL and golden models.")
    commands = parser.add_subparsers(dest="command", required=True)

    trace = commands.add_parser("trace", help="print the steps of one command")
    kinds = trace.add_subparsers(dest="kind", required=True)
    line = kinds.add_parser("line", help="segment from the origin to (X, Y) (SU 1571551)")
    line.add_argument("x", type=int, metavar="X")
    line.add_argument("y", type=int, metavar="Y")
    _add_engine_options(line, ("device", "exact"), "exact")
    arc = kinds.add_parser("arc", help="arc around the origin from (X0, Y0) to (X1, Y1), a full "
                                       "circle when they are equal (SU 1665343)")
    for name in ("x0", "y0", "x1", "y1"):
        arc.add_argument(name, type=int, metavar=name.upper())
    rotation = arc.add_mutually_exclusive_group()
    rotation.add_argument("--ccw", dest="cw", action="store_false",
                          help="counter-clockwise (default)")
    rotation.add_argument("--cw", dest="cw", action="store_true", help="clockwise")
    arc.set_defaults(cw=False)            # store_false alone would default to True
    _add_engine_options(arc, ("faithful", "fast"), "faithful")

    commands.add_parser("demo", help="show the cores at work on a built-in program")
    bench = commands.add_parser("bench", help="measure accuracy (models), area and speed "
                                              "(Yosys, nextpnr on the iCE40UP5K); print tables")
    bench.add_argument("what", nargs="?", choices=("accuracy", "area", "speed"),
                       help="one table only (default: all three)")
    build = commands.add_parser("build", help="build the demo bitstream (never programs)")
    build.add_argument("--board", choices=("icebreaker",), default="icebreaker")
    build.add_argument("--build-dir", default=None, help="default: build/<board>")
    return parser


def _print_moves(record, cycles, out):
    lines = []
    for cycle, dx, dy in record_moves(record):
        lines.append(f"{cycle} {dx} {dy}" if cycles else f"{dx} {dy}")
    if lines:
        out.write("\n".join(lines) + "\n")


def main(argv=None):
    args = _parser().parse_args(argv)
    import logging
    logging.getLogger().setLevel(logging.ERROR)    # the simulator runners' chatter off stderr
    try:
        if args.command == "trace":
            from .trace import trace
            if args.kind == "line":
                payload = {"x": args.x, "y": args.y}
            else:
                payload = {"x0": args.x0, "y0": args.y0, "x1": args.x1, "y1": args.y1,
                           "cw": int(args.cw)}
            record = trace(args.kind, payload, variant=args.variant, engine=args.engine,
                           width=args.width, vcd=args.vcd)
            _print_moves(record, args.cycles, sys.stdout)
        elif args.command == "demo":
            from .demo import demo
            return demo(sys.stdout)
        elif args.command == "bench":
            from .bench import main as bench
            return bench([args.what] if args.what else [])
        elif args.command == "build":
            from .build import main as build
            return build(["--board", args.board]
                         + (["--build-dir", args.build_dir] if args.build_dir else []))
    except InputError as error:
        print(f"kontur: refused: {error}", file=sys.stderr)
        return 2
    except (ValueError, RuntimeError) as error:
        print(f"kontur: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
