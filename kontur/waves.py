"""Waveform regression: reduce a VCD dump to a canonical clock-by-clock trace.

Raw dumps are never compared: Amaranth stamps a wall-clock date in the header, the simulators
name scopes differently (Amaranth ``bench.top.engine``, Icarus ``engine``, Verilator
``$rootio`` and ``engine``). :func:`sample_vcd` finds each requested signal by the end of its
hierarchical name (the shallowest match wins) and returns the value every signal had during
each clock, i.e. just before each rising edge of ``clk``. Golden traces live in
``tests/golden/*.trace``; :func:`check_trace` compares with them and rewrites them only on
purpose (``UPDATE_GOLDEN=1``).

:data:`SCENARIOS` names the regression's scenarios: an engine (kind, variant, width), a
:class:`~kontur.sim.stimulus.Job` and the signals to trace (:class:`Column`: the engine's ports and
the cores' elements, named as the patents and the textbook name them). :func:`scenario_trace`
runs one on Amaranth's simulator, Icarus or Verilator, reads the simulator's own dump back and
returns its canonical trace, one row per clock; :func:`trace_difference` names the first clock
and signal where two traces differ. The scenarios cover the patents' cores, the textbook's
(separate steps, the DDA, the bit-serial node) and a compensated corner of the equidistant
engine (a ``profile`` program); another (a part program) is one more :class:`Scenario` in
:data:`SCENARIOS` and one reviewed golden file.
"""

import io
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from vcd.reader import TokenKind, tokenize

__all__ = ["sample_vcd", "format_trace", "check_trace", "read_trace", "trace_difference",
           "Column", "Scenario", "SCENARIOS", "scenario_engine", "scenario_trace",
           "scenario_job", "GTKW_VIEWS", "gtkw_view"]


def _find(by_path, suffix):
    """The id code of the signal named by ``suffix`` (``"core.adder3.q"``): the shallowest
    path ending in it. Amaranth's dump lists a port also in the scope of the module that
    drives it from a submodule's member of the same name, and then renames the module's own
    port ``name$N``: where the exact match is such an alias of a signal of another scope, the
    module's own ``name$N`` is taken."""
    wanted = tuple(suffix.split("."))
    matches = [p for p in by_path if p[-len(wanted):] == wanted]
    if not matches:
        raise KeyError(f"no signal ending in {suffix!r} in the dump")
    path = min(matches, key=len)
    code = by_path[path]
    aliased = any(c == code and p[-1] == path[-1] and p[:-1] != path[:-1]
                  for p, c in by_path.items())
    if aliased:
        own = [p for p in by_path if p[:-1] == path[:-1]
               and re.fullmatch(re.escape(path[-1]) + r"\$\d+", p[-1])
               and not any(c == by_path[p] and q[:-1] != p[:-1] for q, c in by_path.items())]
        if len(own) == 1:
            return by_path[own[0]]
    return code


def sample_vcd(path, signals, *, clock="clk", tail=False):
    """Return one dict per clock of the dump at ``path``: ``{name: value}`` for ``signals``.

    ``signals`` maps result names to hierarchical name suffixes (``"step"``,
    ``"core.adder3.q"``). Values are unsigned integers; an undefined (``x``) value is ``None``;
    a string variable (Amaranth dumps an enumeration's value as its member's name) gives the
    string.
    With ``tail`` the values at the end of the dump are one more row: the clock in which the
    simulation stopped, before its rising edge.
    """
    raw = Path(path).read_bytes()
    # Verilator writes names that start with "$" (its "$rootio" scope, Yosys's internal
    # wires), which pyvcd 0.4 does not accept: drop that "$".
    raw = re.sub(rb"(\$scope\s+\w+\s+)\$", rb"\1", raw)
    raw = re.sub(rb"(\$var\s+\w+\s+\d+\s+\S+\s+)\$", rb"\1", raw)
    tokens = list(tokenize(io.BytesIO(raw)))
    scope = []
    by_path = {}                                     # hierarchical path -> id code
    for token in tokens:
        if token.kind is TokenKind.SCOPE:
            scope.append(token.data.ident)
        elif token.kind is TokenKind.UPSCOPE:
            scope.pop()
        elif token.kind is TokenKind.VAR:
            by_path.setdefault(tuple(scope) + (token.data.reference,), token.data.id_code)
    ids = {name: _find(by_path, suffix) for name, suffix in signals.items()}
    clock_id = _find(by_path, clock)

    values = {}
    pending = {}                                     # changes at the current timestamp
    rows = []

    def close_timestamp():
        if pending.get(clock_id) == 1 and values.get(clock_id) == 0:
            rows.append({name: values.get(code) for name, code in ids.items()})
        values.update(pending)
        pending.clear()

    for token in tokens:
        if token.kind is TokenKind.CHANGE_TIME:
            close_timestamp()
        elif token.kind is TokenKind.CHANGE_SCALAR:
            pending[token.data.id_code] = {"0": 0, "1": 1}.get(token.data.value)
        elif token.kind is TokenKind.CHANGE_VECTOR:
            value = token.data.value
            pending[token.data.id_code] = value if isinstance(value, int) else None
        elif token.kind is TokenKind.CHANGE_STRING:
            pending[token.data.id_code] = token.data.value
    close_timestamp()
    if tail:
        rows.append({name: values.get(code) for name, code in ids.items()})
    return rows


def format_trace(columns, rows):
    """Text of a trace: a header line of ``columns``, then one line per row."""
    return "".join(" ".join(str(v) for v in row) + "\n" for row in [columns, *rows])


def read_trace(text):
    """``(columns, rows)`` of a trace's text (comment lines ``#`` ignored)."""
    lines = [l.split() for l in text.splitlines() if l.strip() and not l.startswith("#")]
    if not lines:
        return [], []
    return lines[0], lines[1:]


def trace_difference(columns, expected, actual, *, expected_name="golden",
                     actual_name="trace"):
    """Describe the first clock (row) and signal (column) where two traces differ, or
    return ``None``; rows are lists of strings or values."""
    for index, (want, got) in enumerate(zip(expected, actual)):
        want, got = [str(v) for v in want], [str(v) for v in got]
        for column, a, b in zip(columns, want, got):
            if a != b:
                return (f"row {index} ({columns[0]} {want[0]}), signal {column}: "
                        f"{expected_name} {a}, {actual_name} {b}")
        if len(want) != len(got):
            return f"row {index}: {len(want)} values in the {expected_name}, {len(got)} here"
    if len(expected) != len(actual):
        return (f"{len(expected)} rows in the {expected_name}, {len(actual)} in the "
                f"{actual_name} (first extra row {min(len(expected), len(actual))})")
    return None


def check_trace(path, columns, rows):
    """Compare ``rows`` with the golden trace at ``path`` (comment lines ``#`` ignored); on a
    difference raise :exc:`AssertionError` naming the first differing clock and signal.

    ``UPDATE_GOLDEN=1`` rewrites the file instead (keeping its comment lines); use it only on
    purpose, after checking the waveform, and review the change in the diff.
    """
    path = Path(path)
    text = format_trace(columns, rows)
    if os.environ.get("UPDATE_GOLDEN") == "1":
        comments = ""
        if path.exists():
            comments = "".join(l for l in path.read_text().splitlines(True) if l.startswith("#"))
        path.write_text(comments + text)
    if not path.exists():
        raise AssertionError(f"no golden trace {path}; rerun with UPDATE_GOLDEN=1")
    golden_columns, golden_rows = read_trace(path.read_text())
    if [str(c) for c in columns] != golden_columns:
        raise AssertionError(f"{path.name}: columns {' '.join(map(str, columns))} differ from "
                             f"the golden's {' '.join(golden_columns)}")
    difference = trace_difference(golden_columns, golden_rows,
                                  [[str(v) for v in row] for row in rows])
    if difference is not None:
        raise AssertionError(f"{path.name} differs at {difference} (inspect the VCD; if the "
                             f"change is meant, rerun with UPDATE_GOLDEN=1 and review the "
                             f"diff)")


# ---- scenarios -------------------------------------------------------------------------

@dataclass(frozen=True)
class Column:
    """A traced signal: its ``name`` in the trace, the suffix of its hierarchical ``path`` in
    the dump, and how to print it: ``"u"`` unsigned, ``"s"`` two's complement, ``"o"`` ones'
    complement (``-0`` for every bit set), ``"b"`` binary, ``"e"`` an enumeration (the member
    of ``names`` the value numbers, or the name Amaranth's dump gives); ``width``, the
    signal's bits, for ``s``, ``o``, ``b`` and the GTKWave views. With ``offset`` the column is
    the field of ``width`` bits from that bit of the signal (a field of a
    :class:`~amaranth.lib.data.StructLayout` signal, which the Verilog dumps hold as one
    vector)."""
    name: str
    path: str
    fmt: str = "u"
    width: int = 1
    names: tuple = ()
    offset: int = None

    def format(self, value):
        if value is None:
            return "x"
        if self.fmt == "e":
            if isinstance(value, str):
                return value
            return self.names[value] if value < len(self.names) else str(value)
        if self.offset is not None:
            value = (value >> self.offset) & ((1 << self.width) - 1)
        if self.fmt == "s":
            return str(value - (1 << self.width) if value >> (self.width - 1) else value)
        if self.fmt == "o":
            if value == (1 << self.width) - 1:
                return "-0"
            return str(value - (1 << self.width) + 1 if value >> (self.width - 1) else value)
        if self.fmt == "b":
            return format(value, f"0{self.width}b")
        return str(value)


def _engine_columns():
    return (Column("valid", "engine.cmd__valid"), Column("ready", "engine.cmd__ready"),
            Column("tick", "engine.feed__tick"), Column("due", "engine.feed__due"),
            Column("step", "engine.motion__step", "b", 2),
            Column("dir", "engine.motion__dir", "b", 2),
            Column("status", "engine.status__valid"))


def _linear_columns(width):
    ip = "engine.core.interpolator"
    return _engine_columns() + (
        Column("in26", f"{ip}.in26"), Column("t14", f"{ip}.trigger14.q"),
        Column("t15", f"{ip}.trigger15.q"),
        Column("c1", f"{ip}.counter1.q", "s", width + 1),
        Column("c2", f"{ip}.counter2.q", "s", width + 1),
        Column("F", f"{ip}.adder3.q", "s", width + 1))


def _faithful_columns(width):
    ip = "engine.core.interpolator"
    return _engine_columns() + (
        Column("in33", f"{ip}.in33"), Column("t4", f"{ip}.trigger4.q"),
        Column("t16", f"{ip}.trigger16.q"), Column("e25", f"{ip}.extender25.o"),
        Column("ct7", f"{ip}.counter7.q", "s", width + 1),
        Column("ct8", f"{ip}.counter8.q", "o", width + 1),
        Column("A", f"{ip}.commutator6.o", "o", width + 4),
        Column("F", f"{ip}.adder1.q", "o", width + 4))


def _fast_columns(width):
    ip = "engine.core.interpolator"
    return _engine_columns() + (
        Column("in33", f"{ip}.in33"), Column("t4", f"{ip}.trigger4.q"),
        Column("t16", f"{ip}.trigger16.q"),
        Column("ct7", f"{ip}.counter7.q", "s", width + 1),
        Column("ct8", f"{ip}.counter8.q", "s", width + 1),
        Column("F", f"{ip}.adder1.q", "s", width + 4))


def _separate_line_columns(width):
    core = "engine.core"
    return _engine_columns() + (
        Column("run", f"{core}.trigger.q"),
        Column("ctrX", f"{core}.counter_x.q", "s", width + 1),
        Column("ctrY", f"{core}.counter_y.q", "s", width + 1),
        Column("comm", f"{core}.commutator.o", "u", width + 2),
        Column("D", f"{core}.adder.q", "s", width + 2))


def _separate_arc_columns(width):
    core = "engine.core"
    return _engine_columns() + (
        Column("run", f"{core}.trigger.q"),
        Column("ctrX", f"{core}.counter_x.q", "s", width + 1),
        Column("ctrY", f"{core}.counter_y.q", "s", width + 2),
        Column("comm", f"{core}.commutator.o", "u", width + 2),
        Column("G", f"{core}.adder.q", "s", width + 2))


def _dda_columns(width):
    core = "engine.core"
    return _engine_columns() + (
        Column("diag", "engine.feed__diagonal"),
        Column("run", f"{core}.trigger.q"),
        Column("mask", f"{core}.register_x.capacity", "u", width),
        Column("ctr", f"{core}.counter.q", "s", width + 1),
        Column("regX", f"{core}.register_x.q", "u", width),
        Column("ovX", f"{core}.register_x.overflow"),
        Column("regY", f"{core}.register_y.q", "u", width),
        Column("ovY", f"{core}.register_y.overflow"))


def _serial_columns(width):
    from kontur.hdl.serial import Phase, word_length
    node = "engine.core.node"
    word = word_length(width)
    return _engine_columns() + (
        Column("phase", f"{node}.phase", "e", 2, names=tuple(p.name for p in Phase)),
        Column("bit", f"{node}.bit", "u", (word - 1).bit_length()),
        *(Column(f"pr{n}", f"{node}.pr{n}.q", "b", word) for n in range(1, 6)),
        Column("pr6", f"{node}.pr6.q"), Column("pr7", f"{node}.pr7.q"),
        Column("sm1", f"{node}.sm1.s"), Column("c1", f"{node}.sm1.carry"),
        Column("sm2", f"{node}.sm2.s"), Column("c2", f"{node}.sm2.carry"),
        *(Column(f"e{n}", f"{node}.e{n}") for n in range(1, 8)),
        Column("mism", f"{node}.mismatch"))


def _profile_columns(width):
    from amaranth import Shape
    from kontur.hdl.equidistant import EquidistantEngine, Formats
    formats = Formats(width)
    slot = EquidistantEngine.Slot(formats)

    def field(name, slot_name, member, fmt="u"):
        item = slot[member]
        return Column(name, f"engine.{slot_name}", fmt, Shape.cast(item.shape).width,
                      offset=item.offset)

    return _engine_columns() + (
        Column("x", "engine.block12.q", "s", formats.position),
        Column("y", "engine.block13.q", "s", formats.position),
        Column("r", "engine.radius", "u", width),
        Column("r2", "engine.radius2", "u", 2 * width),
        Column("unit", "engine.unit", "u", 3),
        field("own", "own", "valid"), field("cmp", "cmp", "valid"),
        field("prep", "prep", "valid"),
        field("ownV", "own", "v", "s"), field("cmpV", "cmp", "v", "s"),
        field("cmpW", "cmp", "w", "s"),
        Column("end", "engine.element_end"))


def _profile_frames(text, radius, width):
    """The frames of a G-code program prepared at the cutter ``radius`` (the host's
    :func:`~kontur.sim.models.equidistant.prepare`)."""
    from kontur.gcode import read
    from kontur.sim.models.equidistant import Formats, prepare, profile_from_moves
    shape = profile_from_moves(read(text).moves)
    return prepare(shape, radius, formats=Formats(width)).frames


@dataclass(frozen=True)
class Scenario:
    """A named waveform scenario: the engine of ``kind`` around the core of ``variant`` at
    ``width``, the frames (sent back to back) and the traced columns; ``help`` says what it
    shows."""
    name: str
    help: str
    kind: str
    variant: str
    width: int
    frames: tuple
    columns: tuple = field(default=(), compare=False)


def _scenarios():
    items = []

    def add(name, help, kind, variant, width, frames, columns):
        items.append(Scenario(name, help, kind, variant, width, tuple(frames), columns))

    for variant in ("exact", "device"):
        add(f"line_{variant}_back_to_back",
            f"SU 1571551 {variant}: four segments back to back, the first a tie at F = 0 "
            "(4, 2), a steep one, a zero-length one between two others",
            "line", variant, 8, [{"x": 4, "y": 2}, {"x": -3, "y": 5}, {"x": 0, "y": 0},
                                 {"x": 7, "y": -3}], _linear_columns(8))
    add("line_refused", "SU 1571551 exact: a segment too wide for 8 bits (300, 1) is refused "
        "and moves nothing; the next one runs", "line", "exact", 8,
        [{"x": 300, "y": 1}, {"x": 3, "y": 1}], _linear_columns(8))
    arc = lambda x0, y0, x1, y1, cw=0: {"x0": x0, "y0": y0, "x1": x1, "y1": y1, "cw": cw}
    for variant, columns in (("faithful", _faithful_columns), ("fast", _fast_columns)):
        add(f"arc_{variant}_switch_x_eq_y",
            f"SU 1665343 {variant}: the quadrant of R = 10, whose switch-over is the X = Y "
            "kind (at (7, 7), reached by a diagonal: the transfer the patent leaves open)",
            "arc", variant, 8, [arc(10, 0, 0, 10)], columns(8))
        add(f"arc_{variant}_switch_x_minus_y",
            f"SU 1665343 {variant}: the quadrant of R = 12 (the patent's Table 2), whose "
            "switch-over is the X - Y = -1 kind (from (9, 8) to (8, 9))",
            "arc", variant, 8, [arc(12, 0, 0, 12)], columns(8))
    add("arc_fast_quadrant_crossing", "SU 1665343 fast: an arc of R = 5 from (3, 4) through "
        "quadrants II and III to (3, -4), and a clockwise one back, back to back",
        "arc", "fast", 8, [arc(3, 4, 3, -4), arc(3, -4, 3, 4, 1)], _fast_columns(8))
    add("arc_fast_refused", "SU 1665343 fast: an end point off the circle, (4, 0) to (2, 4), "
        "is refused and moves nothing; the next arc runs", "arc", "fast", 8,
        [arc(4, 0, 2, 4), arc(4, 0, 0, 4)], _fast_columns(8))

    # The textbook's cores (docs/textbook.md).
    add("line_separate_back_to_back", "textbook, separate steps: (3, 3), whose every other "
        "step is a tie at D = 0 (an X step), (-4, 1), (0, 0) and (2, -5) back to back, one "
        "axis a step", "line", "separate", 8,
        [{"x": 3, "y": 3}, {"x": -4, "y": 1}, {"x": 0, "y": 0}, {"x": 2, "y": -5}],
        _separate_line_columns(8))
    for variant, preset in (("dda", "half"), ("dda-zero", "zero")):
        add(f"line_{variant.replace('-', '_')}_back_to_back",
            f"textbook, DDA, registers preset to {preset}: (5, 2), (-3, 6), (0, 0), (4, -4) "
            "back to back, N = 8 iterations each, the overflow pulses the steps, the "
            "iterations without one free-running", "line", variant, 8,
            [{"x": 5, "y": 2}, {"x": -3, "y": 6}, {"x": 0, "y": 0}, {"x": 4, "y": -4}],
            _dda_columns(8))
    add("line_serial_back_to_back", "textbook, the bit-serial node as a line core: (2, -1), "
        "(0, 0) and (-3, 3) (ties at D = 0) back to back, a word of 10 clocks a step",
        "line", "serial", 8, [{"x": 2, "y": -1}, {"x": 0, "y": 0}, {"x": -3, "y": 3}],
        _serial_columns(8))
    add("arc_separate_quadrant_crossing", "textbook, separate steps: the arcs of "
        "arc_fast_quadrant_crossing, R = 5 from (3, 4) through quadrants II and III to "
        "(3, -4) and clockwise back, one axis a step", "arc", "separate", 8,
        [arc(3, 4, 3, -4), arc(3, -4, 3, 4, 1)], _separate_arc_columns(8))
    add("arc_serial_quadrant_crossing", "textbook, the bit-serial node as a quadrant core: "
        "R = 5 from (3, 4) across the Y axis to (-4, 3), two quadrant runs of two "
        "initialisation words and a word a step", "arc", "serial", 8,
        [arc(3, 4, -4, 3)], _serial_columns(8))

    # The equidistant engine (docs/equidistant.md): a program with one compensated corner.
    add("profile_fast_corner", "equidistant engine, fast core: the open profile (0, 0) - "
        "(12, 4) - (6, 10) with the cutter of radius 2 on its right (G42): the convex corner "
        "extended to the intersection of the equidistants, ended on the second line's normal",
        "profile", "fast", 8, _profile_frames(_CORNER_PROGRAM, 2, 8), _profile_columns(8))
    return {item.name: item for item in items}


#: The G-code of ``profile_fast_corner``.
_CORNER_PROGRAM = """( Two lines, a left turn: the cutter on the right, G42, round the outside )
G90
G0 X0 Y0
G42 G1 X12 Y4
G1 X6 Y10
G40
M30
"""


SCENARIOS = _scenarios()


def scenario_job(scenario):
    """The :class:`~kontur.sim.stimulus.Job` of a scenario: its frames back to back, every step
    permitted, every outcome taken at once."""
    from kontur.sim.stimulus import Job
    return Job(frames=[dict(f) for f in scenario.frames], max_cycles=20_000)


def scenario_engine(scenario, core=None):
    """The RTL engine of a scenario; ``core`` replaces the variant's core (a test's broken
    one)."""
    from kontur import registry
    if core is None:
        return registry.make_engine(scenario.kind, scenario.variant, width=scenario.width)
    return registry.KINDS[scenario.kind].engine(core)


def scenario_trace(scenario, simulator, vcd, *, core=None, build_root=None):
    """Run ``scenario`` on ``simulator`` (``"amaranth"``, ``"icarus"``, ``"verilator"``),
    dumping to ``vcd``; return ``(record, columns, rows)``: the run's record and its canonical
    trace (``clock`` first, one row per clock of the record)."""
    from kontur.sim.runners import CocotbBuild, run_amaranth

    engine = scenario_engine(scenario, core)
    job = scenario_job(scenario)
    vcd = Path(vcd)
    vcd.parent.mkdir(parents=True, exist_ok=True)
    if simulator == "amaranth":
        record = run_amaranth(engine, job, vcd=vcd)
    else:
        build = CocotbBuild(engine, simulator, build_root, waves=True, quiet=True)
        record = build.run(job, vcd=vcd)
    clocks = sample_vcd(vcd, {c.name: c.path for c in scenario.columns}, tail=True)
    if len(clocks) < len(record):
        raise AssertionError(f"{vcd}: {len(clocks)} clocks in the dump, {len(record)} run")
    columns = ["clock", *(c.name for c in scenario.columns)]
    rows = [[index, *(c.format(clock[c.name]) for c in scenario.columns)]
            for index, clock in enumerate(clocks[:len(record)])]
    return record, columns, rows


# ---- GTKWave views -----------------------------------------------------------------------

#: The saved views ``docs/<name>.gtkw``: the signals of each core, named by element as the
#: patents and the textbook name them, at the widths ``kontur trace`` uses by default (line 16,
#: arc 24), for the dumps of ``kontur trace ... --engine icarus|verilator --vcd FILE`` (their
#: top scope is ``engine``): ``(title, columns, the label of the core's group)``.
GTKW_VIEWS = {
    "linear": ("SU 1571551: LinearCore in LineEngine", _linear_columns(16), "patent elements"),
    "circular_faithful": ("SU 1665343: CircularInterpolator (faithful) in ArcEngine",
                          _faithful_columns(24), "patent elements"),
    "circular_fast": ("SU 1665343: CircularInterpolatorFast in ArcEngine", _fast_columns(24),
                      "patent elements"),
    "separate_line": ("Textbook: SeparateLineCore (separate steps) in LineEngine",
                      _separate_line_columns(16), "textbook elements"),
    "separate_arc": ("Textbook: SeparateArcCore (separate steps) in ArcEngine",
                     _separate_arc_columns(24), "textbook elements"),
    "dda": ("Textbook: DdaCore (dda, dda-zero) in LineEngine", _dda_columns(16),
            "textbook elements"),
    "serial_line": ("Textbook: SerialNode as SerialLineCore in LineEngine",
                    _serial_columns(16), "textbook elements (Fig. 12)"),
    "serial_arc": ("Textbook: SerialNode as SerialArcCore in ArcEngine", _serial_columns(24),
                   "textbook elements (Fig. 12)"),
}


def gtkw_view(name):
    """The text of the GTKWave save file ``docs/<name>.gtkw`` (:data:`GTKW_VIEWS`): the
    engine's ports (the signals of its own scope), then the core's elements."""
    title, columns, label = GTKW_VIEWS[name]
    lines = [f"[*] kontur: {title}", "[*] made by kontur.waves.gtkw_view; open with "
             "gtkwave FILE.vcd docs/" + name + ".gtkw", "@28", "engine.clk"]
    ports = [c for c in columns if c.path.count(".") == 1]
    groups = (("engine ports", ports), (label, [c for c in columns if c not in ports]))
    for label, group in groups:
        lines += ["@200", f"-{label}"]
        for column in group:
            if column.offset is not None:
                raise ValueError(f"{column.name}: a field of a vector has no view")
            flags = {"u": "@24", "b": "@28", "s": "@424", "o": "@22", "e": "@24"}[column.fmt]
            if column.width == 1:
                flags, ref = "@28", column.path
            else:
                ref = f"{column.path}[{column.width - 1}:0]"
            lines += [flags, ref]
    return "\n".join(lines) + "\n"
