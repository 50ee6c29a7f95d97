"""The ``kontur`` command line.

``kontur trace line X Y`` and ``kontur trace arc X0 Y0 X1 Y1`` print the steps of a segment
or an arc, ``kontur trace profile FILE --radius R`` those of the cutter's centre round the
compensated contour of a G-code program, one ``dx dy`` line per step and nothing else on
standard output (with ``--cycles``: ``cycle dx dy``). Exit status: 0 when the command was
traced; 2 for a refused command or any bad input or option (the reason is the last line on
standard error, nothing is printed on standard output); 1 when a tool itself failed (its cause
in one line); 130 on an interrupt.

``kontur run FILE.ngc`` runs a G-code program through the whole machine controller (the model,
or its RTL on a simulator) and writes its steps, plot and summary; ``kontur send FILE.ngc
--port DEVICE`` streams it to a board; ``kontur serve`` is a Grbl 1.1 device on a
pseudo-terminal for any G-code sender (:mod:`kontur.grbl`); ``kontur build`` makes a board's
bitstream. Their
statuses are the same: 2 for a program refused (its line named), 1 for a failure.
"""

import argparse
import signal
import sys

from kontur import registry

__all__ = ["main"]

_ENGINES_HELP = ("golden model (default), or the RTL in Amaranth's simulator, Icarus or "
                 "Verilator")


class _Parser(argparse.ArgumentParser):
    """argparse with its usage errors ending in one reason line, status 2 (as argparse
    does)."""

    def error(self, message):
        self.print_usage(sys.stderr)
        sys.stderr.write(f"kontur: {message}\n")
        raise SystemExit(2)


def _limits_epilog(kind):
    from kontur.trace import MAX_CLOCKS, MAX_STEPS, SPEED, STEP_MODEL_SPEED, WIDTHS
    default = registry.KINDS[kind].default_width
    engines = ", ".join(f"{engine} {MAX_CLOCKS[engine]:,} clocks (~{SPEED[engine]:,}/s)"
                        for engine in MAX_CLOCKS)
    return (f"limits: --width {WIDTHS.start}..{WIDTHS.stop - 1} (default {default}): "
            f"coordinates up to 2**width - 1; the frame holds signed max(32, width + 1)-bit "
            f"numbers. A run is refused up front (status 2) when its clocks could exceed "
            f"--max-clocks, by default {engines}; the model without --cycles counts steps "
            f"instead ({MAX_STEPS:,}, ~{STEP_MODEL_SPEED:,}/s). An arc of radius R has at "
            f"most 8R + 8 steps; the faithful arc core takes 4 clocks a step.")


def _add_kind(kinds, kind):
    item = registry.KINDS[kind]
    variants = registry.variants(kind)
    parser = kinds.add_parser(kind, help=item.help, description=item.help,
                              epilog=_limits_epilog(kind))
    for name in item.fields:
        if name == "cw":
            rotation = parser.add_mutually_exclusive_group()
            rotation.add_argument("--ccw", dest="cw", action="store_false",
                                  help="counter-clockwise (default)")
            rotation.add_argument("--cw", dest="cw", action="store_true", help="clockwise")
            parser.set_defaults(cw=False)         # store_false alone would default to True
        else:
            parser.add_argument(name, type=int, metavar=name.upper())
    helps = "; ".join(f"{name}: {registry.variant(kind, name).help}" for name in variants)
    parser.add_argument("--variant", choices=variants, default=item.default_variant,
                        help=f"core variant (default {item.default_variant}; {helps})")
    from kontur.sim.runners import ENGINES
    parser.add_argument("--engine", choices=ENGINES, default="model", help=_ENGINES_HELP)
    parser.add_argument("--width", type=int, default=None, help="register width in bits")
    parser.add_argument("--vcd", metavar="FILE", default=None,
                        help="write the waveform of the RTL run to FILE")
    parser.add_argument("--cycles", action="store_true",
                        help="prefix every step with its clock number (the cycle model, for "
                             "--engine model)")
    parser.add_argument("--max-clocks", type=int, default=None, metavar="N",
                        help="trace runs of up to N clocks (see the limits below)")


def _add_program(kinds, kind):
    """``kontur trace profile FILE --radius R``: a contour of a G-code program."""
    from kontur.sim.models.equidistant import DETECTIONS, TREATMENTS
    from kontur.sim.runners import ENGINES
    item = registry.KINDS[kind]
    variants = registry.variants(kind)
    parser = kinds.add_parser(kind, help=item.help, description=item.help,
                              epilog="FILE is in lattice units: G90/G91, G0 G1 G2 G3 with X Y "
                                     "(and I J for arcs), G41/G42/G40; the compensated moves "
                                     "are the contour. The output starts where the cutter's "
                                     "centre starts on the equidistant.")
    parser.add_argument("file", metavar="FILE", help="the G-code program")
    parser.add_argument("--radius", type=int, required=True, metavar="R",
                        help="cutter radius in steps (the dial)")
    helps = "; ".join(f"{name}: {registry.variant(kind, name).help}" for name in variants)
    parser.add_argument("--variant", choices=variants, default=item.default_variant,
                        help=f"arc core (default {item.default_variant}; {helps})")
    parser.add_argument("--engine", choices=ENGINES, default="model", help=_ENGINES_HELP)
    parser.add_argument("--width", type=int, default=None, help="coordinate width in bits")
    parser.add_argument("--corner", choices=TREATMENTS, default=TREATMENTS[0],
                        help="convex corners: extend the equidistants to their intersection "
                             "(default), go round on an arc of radius R, or miter: extend "
                             "up to 2 R from the vertex, round beyond")
    parser.add_argument("--detect", choices=DETECTIONS, default=DETECTIONS[0],
                        help="what ends a line at a corner with a line: the normal through "
                             "the intersection (default) or the seed's next equidistant")
    parser.add_argument("--vcd", metavar="FILE", default=None,
                        help="write the waveform of the RTL run to FILE")
    parser.add_argument("--cycles", action="store_true",
                        help="prefix every step with its clock number")
    parser.add_argument("--max-clocks", type=int, default=None, metavar="N",
                        help="trace runs of up to N clocks")
    parser.add_argument("--plot", metavar="FILE.png", default=None,
                        help="draw the profile, its equidistant and the steps (matplotlib)")


def _check_plot(path):
    """Raise :exc:`UsageError` unless matplotlib can write a figure to ``path``: its folder
    exists and is writable, its extension is a format matplotlib writes (checked before
    anything runs)."""
    import os
    from pathlib import Path

    from matplotlib.figure import Figure

    from kontur.trace import UsageError
    path = Path(path)
    formats = Figure().canvas.get_supported_filetypes()
    extension = path.suffix[1:].lower()
    if extension not in formats:
        raise UsageError(f"--plot {path}: unknown extension {path.suffix or '(none)'!r}; "
                         f"matplotlib writes {', '.join(sorted(formats))}")
    parent = path.parent
    if path.is_dir():
        raise UsageError(f"--plot {path}: is a directory")
    if not parent.is_dir():
        raise UsageError(f"--plot {path}: no directory {parent}")
    if not os.access(parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise UsageError(f"--plot {path}: not writable")


def _read_program(path):
    """The text of the G-code program ``path``; :exc:`~kontur.trace.UsageError` (status 2) for
    one that cannot be read or is not UTF-8 text."""
    from kontur.trace import UsageError
    try:
        with open(path, encoding="utf-8") as handle:
            return handle.read()
    except UnicodeDecodeError as error:
        raise UsageError(f"{path}: not a text file (not UTF-8: {error.reason} at byte "
                         f"{error.start})") from None
    except OSError as error:
        raise UsageError(f"{path}: {error.strerror or error}") from None


def _trace_program(args, out):
    from kontur.trace import trace_profile
    text = _read_program(args.file)
    if args.plot:
        _check_plot(args.plot)
    run = trace_profile(text, radius=args.radius, name=args.file, variant=args.variant,
                        engine=args.engine, width=args.width, vcd=args.vcd, cycles=args.cycles,
                        max_clocks=args.max_clocks, treatment=args.corner,
                        detection=args.detect)
    if args.plot:
        from kontur.plot import plot_profile
        plot_profile(run.prepared, run.moves, args.plot)
    lines = [f"{cycle} {dx} {dy}" if args.cycles else f"{dx} {dy}" for cycle, dx, dy in run.moves]
    if lines:
        out.write("\n".join(lines) + "\n")
    return 0


def _parser():
    parser = _Parser(
        prog="kontur",
        description="CNC contour interpolators of Soviet patents, as RTL and golden models.")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    trace = commands.add_parser("trace", help="print the steps of one command")
    kinds = trace.add_subparsers(dest="kind", required=True, parser_class=_Parser)
    for kind in registry.KINDS:
        (_add_program if registry.KINDS[kind].program else _add_kind)(kinds, kind)

    commands.add_parser("demo", help="show the cores at work on a built-in program")
    bench = commands.add_parser("bench", help="measure accuracy (models), area and speed "
                                              "(Yosys, nextpnr on the iCE40UP5K); print tables")
    bench.add_argument("what", nargs="?", choices=("accuracy", "area", "speed"),
                       help="one table only (default: all three)")
    build = commands.add_parser("build", help="build a board's bitstream (never programs): "
                                              "the machine controller, or the demo player")
    build.add_argument("--board", choices=list(registry.BOARDS), default="icebreaker")
    build.add_argument("--top", choices=("controller", "player"), default="controller",
                       help="the machine controller (default), or the program played in a "
                            "loop with no host")
    build.add_argument("--build-dir", default=None, help="default: build/<board>-<top>")
    build.add_argument("--machine", metavar="FILE.toml", default=None,
                       help="the machine file (docs/controller.md) whose baud, queue_frames "
                            "and step/dir timing the controller is built with (default: the "
                            "defaults); kontur send checks the queue in its handshake, so "
                            "send with the same file")
    build.add_argument("--seed", type=int, default=None, help="nextpnr's seed (default 1)")
    build.add_argument("--report", metavar="FILE.json", default=None,
                       help="where the controller's build record goes (default "
                            "<build dir>/report.json)")
    _add_machining(commands)
    _add_serve(commands)
    return parser


def _machine_options(parser):
    parser.add_argument("file", metavar="FILE.ngc", help="the G-code program (millimetres)")
    parser.add_argument("--board", choices=list(registry.BOARDS), default="icebreaker",
                        help="the board whose controller runs it (its engines and clock; "
                             "default icebreaker)")
    parser.add_argument("--machine", metavar="FILE.toml", default=None,
                        help="the machine's configuration (steps/mm, feeds, acceleration, "
                             "timing; see docs/controller.md)")
    parser.add_argument("--steps-per-mm", type=float, default=None, metavar="N",
                        help="steps per millimetre, X and Y (overrides the machine file)")
    parser.add_argument("--radius", type=float, default=None, metavar="MM",
                        help="the cutter radius for G41/G42, mm (overrides the machine file's "
                             "cutter_radius); compensation runs on a board whose controller "
                             "has the equidistant engine")
    parser.add_argument("--tool-table", metavar="FILE", default=None,
                        help="LinuxCNC's tool table (T1 P1 D6.0 ;comment), diameters in mm: "
                             "G41/G42 take the radius of their D word's tool, or of the tool "
                             "loaded by M6, before --radius (G41.1/G42.1 D, a diameter in the "
                             "program, before both)")


def _add_machining(commands):
    from kontur.machining import ENGINES
    run = commands.add_parser(
        "run", help="run a G-code program through the whole machine controller",
        description="Run a G-code program through the whole machine controller (over its "
                    "serial pin in the RTL engines); write steps.txt, toolpath.png and "
                    "summary.json, print the summary.",
        epilog="The RTL engines are checked against the model: the same steps, every frame "
               "DONE, the position read back equal to the program's end. Exit status 0 "
               "when run and checked, 2 for a program or option refused (the reason, with "
               "the program line, last on standard error), 1 when a tool failed or the RTL "
               "differs from the model.")
    _machine_options(run)
    run.add_argument("--engine", choices=ENGINES, default="model",
                     help="golden models (default), or the controller's RTL in Amaranth's "
                          "simulator, Icarus, or Verilator (a C++ testbench: millions of "
                          "clocks a second)")
    run.add_argument("--out", metavar="DIR", default=None,
                     help="where the outputs go (default build/run/<program>)")
    run.add_argument("--vcd", action="store_true", help="write DIR/run.vcd (RTL engines)")
    run.add_argument("--event", action="append", default=[], metavar="WHAT@SECONDS",
                     help="a scripted event at that much machining time after the first step "
                          "(repeatable): estop, estop-release, limit-x, limit-y, "
                          "limit-x-release, limit-y-release, limit-z, limit-z-release "
                          "(ulx3s) (the switch inputs), unlock (an "
                          "UNLOCK frame), hold, resume (feed hold: HOLD, RESUME frames), "
                          "feed=PCT (feed override, 10-200), rapid=PCT (rapid override: 25, "
                          "50, 100), spindle=PCT (spindle override, 10-200: S in the tool "
                          "outputs' PWM); the e-stop or a limit stops the program in ALARM, a hold "
                          "never resumed in HOLD")
    run.add_argument("--compress", type=int, default=None, metavar="N",
                     help="time compression of an RTL run: rates N times the planned ones "
                          "(default: the largest power of two the step timing and the link "
                          "allow; the steps do not change). Checked on every engine, the "
                          "model's too: more than the step/dir timing, the acceleration's "
                          "field or the link allows is refused with the largest allowed")
    from kontur.machining import BYTES_PER_STEP, MAX_CLOCKS, MAX_STEPS
    run.add_argument("--max-steps", type=int, default=None, metavar="N",
                     help=f"refuse a program whose steps, estimated from the G-code before "
                          f"any is computed (a line |dx| + |dy|, an arc its share of 8R + 8), "
                          f"exceed N (default {MAX_STEPS:,}: about "
                          f"{MAX_STEPS * BYTES_PER_STEP / 1e9:g} GB at ~{BYTES_PER_STEP} "
                          f"bytes a step). The RTL engines also refuse a run whose planned "
                          f"clocks exceed "
                          + ", ".join(f"{e} {n:,}" for e, n in MAX_CLOCKS.items()))
    send = commands.add_parser(
        "send", help="stream a G-code program to a board over its serial port",
        epilog="Before the first frame the board must answer a QUERY idle, at the program's "
               "start, with as many free queue slots as the machine file's queue_frames (a "
               "bitstream built with the same file: kontur build --machine). Exit status 0 "
               "when the machine ran the whole program and ended on its end, 2 for a program "
               "or option refused before anything moved, 1 when the handshake failed, the "
               "machine refused or aborted a move, reported an error, sent a reply no "
               "controller sends, made no progress, or the port failed (the program line "
               "named; an ABORT sent); 128 + the signal on SIGINT, SIGTERM or SIGHUP, after an "
               "ABORT and the position read back.")
    _machine_options(send)
    send.add_argument("--port", required=True, metavar="DEVICE",
                      help="the serial port (a device, or a pyserial URL)")
    send.add_argument("--unlock", action="store_true",
                      help="leave ALARM first (an UNLOCK instead of the handshake's QUERY; "
                           "refused while the e-stop is pressed)")
    send.add_argument("--home", action="store_true",
                      help="run the homing cycle first (Grbl's $H: the machine file's "
                           "homing_* keys, every axis), then the program from where it left "
                           "the machine; on a board with the homing engine (the ULX3S)")
    send.add_argument("--feed", type=int, default=100, metavar="PCT",
                      help="feed override, 10-200 %% (an OVERRIDE frame after the handshake; "
                           "default 100)")
    send.add_argument("--rapid", type=int, default=100, metavar="PCT",
                      help="rapid override: 100, 50 or 25 %% (default 100)")
    send.add_argument("--spindle", type=int, default=100, metavar="PCT",
                      help="spindle override, 10-200 %%: S in the tool outputs' PWM "
                           "(default 100)")
    send.add_argument("--timeout", type=float, default=10.0, metavar="SECONDS",
                      help="how long the board may take to answer a QUERY, and to answer a "
                           "frame beyond its planned time (default 10)")


def _add_serve(commands):
    serve = commands.add_parser(
        "serve", help="be a Grbl 1.1 device on a pseudo-terminal: any G-code sender drives "
                      "kontur's virtual machine",
        description="Present a Grbl 1.1-compatible device on a pseudo-terminal (its path "
                    "the first line of standard output) and, with --tcp, on a localhost TCP "
                    "port; run what a sender streams on the virtual machine in real time "
                    "(and, with --port, on a board over kontur send's protocol), its steps "
                    "written to --out DIR as kontur run writes them. See docs/grbl.md.",
        epilog="Runs until SIGINT, SIGTERM or SIGHUP (status 128 + the signal, the outputs "
               "written first); 2 for an option refused.")
    serve.add_argument("--link", metavar="PATH", default=None,
                       help="keep a symlink to the pseudo-terminal at PATH (a stable name to "
                            "point a sender at); removed at the end")
    serve.add_argument("--tcp", type=int, default=None, metavar="PORT",
                       help="also listen on 127.0.0.1:PORT (0: any free port; its number is "
                            "the second line of standard output)")
    serve.add_argument("--engine", choices=("model", "verilator"), default="model",
                       help="what runs the moves: the golden models in real time (default); "
                            "verilator: the models in real time, and every run of motion "
                            "run again, once the machine rests, on the controller's RTL under "
                            "Verilator, its steps checked against the model's (summary.json's "
                            "rtl_check)")
    serve.add_argument("--port", metavar="DEVICE", default=None,
                       help="a board's serial port (or pyserial URL): the moves are also made "
                            "by its controller, over kontur send's protocol and handshake; "
                            "status reports give the board's position and state")
    serve.add_argument("--timeout", type=float, default=10.0, metavar="SECONDS",
                       help="with --port: as kontur send's (default 10)")
    serve.add_argument("--out", metavar="DIR", default=None,
                       help="write steps.txt and summary.json of the steps made since the "
                            "start to DIR after every run of motion and at the end")
    serve.add_argument("--board", choices=list(registry.BOARDS), default="icebreaker",
                       help="the board whose controller it is (its engines and clock; default "
                            "icebreaker)")
    serve.add_argument("--machine", metavar="FILE.toml", default=None,
                       help="the machine's configuration, as for kontur run; $$ shows it as "
                            "Grbl's settings, and a $N= write of one of them is kept in it")
    serve.add_argument("--steps-per-mm", type=float, default=None, metavar="N",
                       help="steps per millimetre, X and Y (overrides the machine file)")
    serve.add_argument("--speed", type=float, default=1.0, metavar="N",
                       help="run the virtual machine's clock N times faster than real time "
                            "(default 1; the steps do not change)")


def _serve(args, out):
    import math

    from kontur.grbl.server import serve
    from kontur.trace import UsageError
    if not (math.isfinite(args.speed) and args.speed > 0):
        raise UsageError(f"--speed must be a positive number, not {args.speed:g}")
    if args.tcp is not None and not 0 <= args.tcp < 65536:
        raise UsageError(f"--tcp must be a port from 0 to 65535, not {args.tcp}")
    args.radius = None
    machine = _machine(args)
    if args.engine == "verilator":
        from kontur.sim.runners import ensure_simulator
        ensure_simulator("verilator")          # before any sender connects: status 1
    port = None
    if args.port is not None:
        if not (math.isfinite(args.timeout) and args.timeout > 0):
            raise UsageError(f"--timeout must be a positive number of seconds, not "
                             f"{args.timeout:g}")
        from kontur.send import open_port
        try:
            port = open_port(args.port, machine.baud, write_timeout=args.timeout)
        except Exception as error:                 # pyserial: SerialException, ValueError
            sys.stderr.write(f"kontur: cannot open {args.port}: {error}\n")
            return 1
    try:
        serve(machine, args.board, link=args.link, tcp=args.tcp, out_dir=args.out,
              speed=args.speed, engine=args.engine, machine_file=args.machine, out=out,
              port=port, timeout=args.timeout)
    finally:
        if port is not None:
            port.close()
    return 0


def _machine(args):
    """The machine of ``--board``, ``--machine``, ``--steps-per-mm`` (and ``--radius``)."""
    from kontur.machine import Machine, MachineError
    from kontur.trace import UsageError
    board = registry.board(args.board)
    try:
        if args.machine:
            machine = Machine.from_toml(args.machine, clock_hz=board.clock_hz,
                                        steps_per_mm=args.steps_per_mm,
                                        cutter_radius=args.radius)
        else:
            overrides = {key: value for key, value in (("steps_per_mm", args.steps_per_mm),
                                                       ("cutter_radius", args.radius))
                         if value is not None}
            machine = Machine(clock_hz=board.clock_hz, **overrides)
        return registry.check_machine(board, machine.check())
    except MachineError as error:
        raise UsageError(str(error)) from None


def _job(args, start=(0, 0)):
    from kontur.machining import prepare
    from kontur.trace import UsageError
    text = _read_program(args.file)
    machine = _machine(args)
    tools = None
    if args.tool_table:
        from kontur.gcode import ToolTableError, read_tool_table
        try:
            tools = read_tool_table(_read_program(args.tool_table), name=args.tool_table)
        except ToolTableError as error:
            raise UsageError(f"--tool-table: {error}") from None
    from pathlib import Path
    return prepare(text, machine=machine, board=args.board, name=Path(args.file).name,
                   max_steps=getattr(args, "max_steps", None), tools=tools, start=start)


def _progress(total, what):
    """A progress bar on standard error, shown once a run has taken two seconds."""
    from tqdm import tqdm
    return tqdm(total=total, unit=what, delay=2, leave=False, file=sys.stderr,
                dynamic_ncols=True)


def _run(args, out):
    import shutil
    from pathlib import Path

    from kontur.machining import check_compress, execute, staging_dir, summary_text, write_outputs
    from kontur.trace import UsageError
    if args.compress is not None and args.compress < 1:
        raise UsageError(f"--compress must be a positive integer, not {args.compress}")
    if args.max_steps is not None and args.max_steps < 1:
        raise UsageError(f"--max-steps must be a positive integer, not {args.max_steps}")
    if args.vcd and args.engine == "model":
        raise UsageError("--vcd needs an RTL engine (amaranth, icarus, verilator)")
    events = _events(args.event)
    from kontur.sim.models.motion import Z_EVENTS
    if registry.board(args.board).axes == 2 and any(name in Z_EVENTS for _, name in events):
        raise UsageError(f"--event {next(n for _, n in events if n in Z_EVENTS)}: the "
                         f"{args.board}'s controller has no Z axis (no Z limit switch)")
    overridden = ("feed=", "rapid=", "spindle=")
    if any(name.startswith(overridden) for _, name in events):
        _check_overrides(args.board, "--event " + next(
            name for _, name in events if name.startswith(overridden)))
    job = _job(args)
    if args.compress is not None:
        check_compress(job, args.compress)
    out_dir = Path(args.out) if args.out else Path("build") / "run" / Path(args.file).stem
    # The outputs go into a fresh folder beside DIR, moved into place at the end: made now,
    # so that a DIR that cannot be written is refused before the run.
    try:
        staging = staging_dir(out_dir)
    except OSError as error:
        raise UsageError(f"--out {out_dir}: {error.strerror or error}") from None
    try:
        with _progress(sum(len(s.steps) for s in job.segments), "steps") as bar:
            def progress(made):
                bar.update(made - bar.n)
            result = execute(job, args.engine, compress=args.compress,
                             vcd=staging / "run.vcd" if args.vcd else None, progress=progress,
                             events=events)
        data = write_outputs(job, result, out_dir, staging=staging)
    finally:
        shutil.rmtree(staging, ignore_errors=True)      # gone already when moved into place
    out.write(summary_text(data, out_dir))
    return 0


def _check_overrides(board_name, what):
    """Refuse (status 2) an override on a board whose controller is built without them."""
    from kontur.trace import UsageError
    item = registry.board(board_name)
    if not item.overrides:
        others = [b.name for b in registry.BOARDS.values() if b.overrides]
        raise UsageError(f"{what}: the {item.name}'s controller is built without the feed, "
                         f"rapid and spindle overrides (no room for them on the {item.help}); "
                         f"boards with them: {', '.join(others)}")


def _events(texts):
    """``(seconds, name)`` of each ``--event WHAT@SECONDS`` (:exc:`kontur.trace.UsageError`
    for one that is not)."""
    import math

    from kontur.sim.models.motion import EVENTS, FRAME_EVENTS, event_kind
    from kontur.trace import UsageError
    events = []
    for text in texts:
        name, _, at = text.partition("@")
        try:
            seconds = float(at)
        except ValueError:
            seconds = math.nan
        try:
            event_kind(name)
            problem = None
        except ValueError as error:
            problem = str(error)
        if problem is not None and "override" in problem:      # feed=, rapid=, spindle=PCT
            raise UsageError(f"--event {text}: {problem.partition(': ')[2]}")
        if problem is not None or not (math.isfinite(seconds) and seconds >= 0):
            raise UsageError(f"--event {text}: expected WHAT@SECONDS, WHAT one of "
                             f"{', '.join(list(EVENTS) + list(FRAME_EVENTS))} and SECONDS a "
                             f"time of at least 0")
        events.append((seconds, name))
    return events


def _homing(args):
    """``kontur send --home``: the homing cycle's job (:func:`kontur.homing.homing_job`) for a
    board with the homing engine, every axis homed, with ``start_mm``: where it leaves the
    machine (mm), the program's start."""
    from fractions import Fraction

    from kontur.homing import check_board, homing_job
    from kontur.machine import MachineError
    from kontur.trace import UsageError
    check_board(args.board)
    machine = _machine(args)
    if not {"x", "y"} <= set(machine.homing_order):
        raise UsageError(f"--home homes X and Y (and Z where homing_order has it), and the "
                         f"machine file's homing_order is {list(machine.homing_order)}: the "
                         f"program would start where the axes not homed happen to be")
    try:
        job = homing_job(machine, (0,) * registry.board(args.board).axes)
    except MachineError as error:
        raise UsageError(f"--home: {error}") from None
    spm = Fraction(machine.steps_per_mm)
    job.start_mm = tuple(Fraction(c) / spm for c in job.end)
    return job


class _keys:
    """The operator's keys while ``kontur send`` streams, when standard input is a terminal
    (Grbl's): ``!`` or ``h`` feed hold, ``~`` or ``r`` resume, ``+`` and ``-`` the feed
    override up and down by 10 % (10 to 200). The terminal is in cbreak mode meanwhile
    (Ctrl-C still stops the machine), restored on the way out; the context gives the
    ``controls`` callable of :func:`kontur.send.send` (``None`` without a terminal). On a
    board built without the overrides (``overrides`` false) ``+`` and ``-`` do nothing."""

    def __init__(self, feed, overrides=True):
        self.feed = feed
        self.overrides = overrides
        self.saved = None

    def __enter__(self):
        if not sys.stdin.isatty():
            return None
        import termios
        import tty
        self.saved = termios.tcgetattr(sys.stdin)
        tty.setcbreak(sys.stdin)
        sys.stderr.write("keys: ! or h hold, ~ or r resume" + (
            ", + and - feed override by 10 %\n" if self.overrides else "\n"))
        return self.poll

    def poll(self):
        import os
        import select
        commands = []
        while select.select([sys.stdin], [], [], 0)[0]:
            key = os.read(sys.stdin.fileno(), 1).decode(errors="replace")
            if key in "!h":
                commands.append("hold")
            elif key in "~r":
                commands.append("resume")
            elif key in "+-" and self.overrides:
                self.feed = min(200, max(10, self.feed + (10 if key == "+" else -10)))
                commands.append(("feed", self.feed))
        return commands

    def __exit__(self, *exc):
        if self.saved is not None:
            import termios
            termios.tcsetattr(sys.stdin, termios.TCSADRAIN, self.saved)
        return False


def _send(args, out):
    import math

    from kontur.send import SendInterrupted, Stop, open_port, send
    from kontur.trace import UsageError
    if not (math.isfinite(args.timeout) and args.timeout > 0):
        raise UsageError(f"--timeout must be a positive number of seconds, not {args.timeout:g}")
    from kontur.hdl.motion.protocol import override
    given = f"--feed {args.feed} --rapid {args.rapid} --spindle {args.spindle}"
    try:
        override(args.feed, args.rapid, args.spindle)
    except ValueError as error:
        raise UsageError(f"{given}: {error}") from None
    if (args.feed, args.rapid, args.spindle) != (100, 100, 100):
        _check_overrides(args.board, given)
    homing = _homing(args) if args.home else None
    job = _job(args, start=homing.start_mm if homing else (0, 0))
    from kontur.send import unhonoured
    from kontur.planner import ProgramError
    refusal = unhonoured(job)
    if refusal is not None:
        raise ProgramError(*refusal)
    frames, _ = job.frames()
    try:
        port = open_port(args.port, job.machine.baud, write_timeout=args.timeout)
    except Exception as error:                     # pyserial: SerialException, ValueError
        sys.stderr.write(f"kontur: cannot open {args.port}: {error}\n")
        return 1
    try:
        # SIGINT, SIGTERM and SIGHUP stop the machine (ABORT) before kontur ends.
        with Stop() as stop, port, _progress(len(frames), "frames") as bar, \
                _keys(args.feed, registry.board(args.board).overrides) as controls:
            unlock = args.unlock
            if homing is not None:
                at = send(homing, port, out=sys.stderr, timeout=args.timeout, stop=stop,
                          unlock=unlock, controls=controls)
                out.write(f"homed: the machine at ({at[0]}, {at[1]}) steps\n")
                out.flush()
                unlock = False
            end = send(job, port, progress=lambda n: bar.update(n - bar.n), out=sys.stderr,
                       timeout=args.timeout, stop=stop, unlock=unlock, feed=args.feed,
                       rapid=args.rapid, spindle=args.spindle, controls=controls)
    except SendInterrupted as error:
        sys.stderr.write(f"kontur: {error}\n")
        return 128 + error.signum
    spm = job.machine.steps_per_mm
    out.write(f"sent {len(frames)} frames of {job.name}; the machine ended at ({end[0]}, "
              f"{end[1]}) steps = ({end[0] / spm:.4f}, {end[1] / spm:.4f}) mm, the "
              f"program's end\n")
    return 0


def _trace(args, out):
    if registry.KINDS[args.kind].program:
        return _trace_program(args, out)
    from kontur.trace import trace
    fields = registry.KINDS[args.kind].fields
    payload = {name: int(getattr(args, name)) for name in fields}
    moves = trace(args.kind, payload, variant=args.variant, engine=args.engine,
                  width=args.width, vcd=args.vcd, cycles=args.cycles,
                  max_clocks=args.max_clocks)
    lines = [f"{cycle} {dx} {dy}" if args.cycles else f"{dx} {dy}" for cycle, dx, dy in moves]
    if lines:
        out.write("\n".join(lines) + "\n")
    return 0


def _bench(args, out):
    status = 0
    if args.what in (None, "accuracy"):
        from kontur.accuracy import main as accuracy
        status |= accuracy(out)
    for what in ("area", "speed"):
        if args.what in (None, what):
            from kontur.bench import main as bench
            if args.what is None:
                out.write("\n")
            status |= bench([what], out)
    return status


def _build(args, out):
    from kontur.build import main as build
    return build(["--board", args.board, "--top", args.top]
                 + (["--build-dir", args.build_dir] if args.build_dir else [])
                 + (["--machine", args.machine] if args.machine else [])
                 + (["--seed", str(args.seed)] if args.seed is not None else [])
                 + (["--report", args.report] if args.report else []))


def main(argv=None):
    """Run the command line; return the exit status.

    ``SIGINT``, ``SIGTERM`` and ``SIGHUP`` end the command the same way (every child process's
    group ended, :mod:`kontur.sim.processes`) with status ``128 +`` the signal's number and one line.
    """
    from kontur.sim import processes
    with processes.signals_handled():
        try:
            return _main(argv)
        except KeyboardInterrupt as error:       # SIGINT, or sim.processes.Interrupted
            processes.hold()                     # ending: a further signal changes nothing
            processes.stop_all()
            signum = getattr(error, "signum", signal.SIGINT)
            sys.stderr.write("kontur: interrupted\n" if signum == signal.SIGINT
                             else f"kontur: stopped by {signum.name}\n")
            return 128 + signum


def _main(argv):
    import logging
    logging.getLogger().setLevel(logging.ERROR)    # the simulator runners' chatter off stderr
    args = None
    try:
        parser = _parser()
        args = parser.parse_args(argv)
        # argparse (3.11) leaves a positional given only as "--" unconverted, an empty list:
        # a missing argument, a usage error like any other.
        for name, value in vars(args).items():
            if isinstance(value, list) and name != "event":
                parser.error(f"argument {name.upper()}: expected an integer")
        if args.command == "trace":
            return _trace(args, sys.stdout)
        if args.command == "demo":
            from kontur.demo import demo
            return demo(sys.stdout)
        if args.command == "bench":
            return _bench(args, sys.stdout)
        if args.command == "run":
            return _run(args, sys.stdout)
        if args.command == "send":
            return _send(args, sys.stdout)
        if args.command == "serve":
            return _serve(args, sys.stdout)
        return _build(args, sys.stdout)
    except SystemExit as stop:             # argparse: --help (0) or a usage error (2)
        return stop.code if isinstance(stop.code, int) else 2
    except Exception as error:
        from kontur.sim.models.errors import InputError
        from kontur.planner import ProgramError
        from kontur.trace import UsageError
        if isinstance(error, ProgramError):
            sys.stderr.write(f"kontur: {getattr(args, 'file', None) or 'program'}: {error}\n")
            return 2
        if isinstance(error, InputError):
            sys.stderr.write(f"kontur: refused: {error}\n")
            return 2
        if isinstance(error, UsageError):
            sys.stderr.write(f"kontur: {error}\n")
            return 2
        reason = str(error).strip().splitlines()
        sys.stderr.write(f"kontur: {type(error).__name__}: "
                         f"{reason[-1] if reason else 'failed'}\n")
        return 1


if __name__ == "__main__":
    sys.exit(main())
