"""``kontur bench area|speed``: area and speed of every core and engine, by real tool runs.

Every figure printed comes from a tool run made in the same call (:mod:`constraints.flow`).
The designs are every variant of every kind in :mod:`sim.registry`: each core alone and its
engine for :func:`area`, each engine in :class:`~hdl.top.ShiftInTop` placed and routed on the
iCEBreaker's UP5K for :func:`speed`.
"""

import re
import sys
from pathlib import Path

from .flow import (ROOT, SEED, ToolchainError, measure_area, measure_speed, tool_versions)

__all__ = ["area", "speed", "main", "area_designs", "speed_designs"]

BUILD_ROOT = ROOT / "build" / "bench"


def _widths(kind):
    """The widths a kind is measured at: its default, and 32 for lines (as before)."""
    from sim import registry
    default = registry.KINDS[kind].default_width
    return (default, 32) if kind == "line" else (default,)


def area_designs():
    """``(label, width, variant, factory)`` rows of :func:`area`: every registered variant's
    core alone, then its engine."""
    from sim import registry
    rows = []
    for kind in registry.KINDS:
        for what in ("core", "engine"):
            for width in _widths(kind):
                for name in registry.variants(kind):
                    label = f"{kind} {what}"
                    if what == "core":
                        factory = (lambda k=kind, n=name, w=width:
                                   registry.variant(k, n).core(width=w))
                    else:
                        factory = (lambda k=kind, n=name, w=width:
                                   registry.make_engine(k, n, width=w))
                    rows.append((label, width, name, factory))
    return rows


def speed_designs():
    """``(label, width, variant, factory)`` rows of :func:`speed`: every registered engine but
    those of program kinds (the equidistant engine does not meet the iCEBreaker's 12 MHz yet,
    and nextpnr fails a build that misses it; ``python -m sim.host.equidistant_figures fpga``
    reports its routed speed)."""
    from sim import registry
    return [(f"{kind} engine", width, name,
             (lambda k=kind, n=name, w=width: registry.make_engine(k, n, width=w)))
            for kind in registry.KINDS if not registry.KINDS[kind].program
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
                                                    f"{variant}", seed=seed)
        # One clock domain here; were there several, the slowest would bound the design.
        _, (mhz, verdict, target) = min(result["fmax"].items(), key=lambda item: item[1][0])
        used, available = result["lc"]
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


def main(argv=None, out=None):
    """``kontur bench area|speed``: print the table; return the exit status (0, or 1 with the
    reason on standard error when a tool is missing or fails)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    out = sys.stdout if out is None else out
    tables = {"area": area, "speed": speed}
    if len(argv) != 1 or argv[0] not in tables:
        sys.stderr.write(f"usage: python -m constraints.bench area|speed, not "
                         f"{' '.join(argv)!r}\n")
        return 2
    try:
        tables[argv[0]](out)
    except ToolchainError as error:
        sys.stderr.write(f"kontur bench: {error}\n")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
