"""kontur's G-code reader against LinuxCNC's own interpreter, ``rs274 -g`` (linuxcnc-uspace).

For every program of the corpus (``tests/programs/SOURCES.md``: kontur's contour programs, the
programs written for the reader in ``tests/programs/rs274/``, CAM programs' output in
``tests/programs/cam/``, and LinuxCNC's examples as the package installs them), rs274 prints
its canonical machine commands; the reader's moves must be rs274's, one for one: the kind
(STRAIGHT_TRAVERSE a rapid, STRAIGHT_FEED a line, ARC_FEED an arc, DWELL a dwell), the end
point, an arc's centre and direction, the feed, Z where the program gives it, a dwell's
seconds, all in machine coordinates (rs274's program coordinates plus the offsets it reports),
within rs274's printing (four decimals of the program's unit). The tool events (tool changes,
spindle starts, coolant, pauses, messages) must be rs274's too. A program kontur refuses must
be refused with the documented reason (docs/gcode.md) this test names, while rs274 accepts it.

The test fails, never skips, when rs274 is missing: ``make setup`` installs it.

Cutter-radius compensation: rs274 prints the compensated path, the reader the programmed
outline (the gateware compensates). For the outline, rs274 reads a copy whose G41/G42
(G41.1/G42.1) are G40 (their D words dropped); the radius the reader gives each contour is
checked against rs274's compensated path of ``comp_table.ngc`` (test_tool_table_radius).
"""

import re
from fractions import Fraction
from pathlib import Path

import pytest

from kontur.gcode import GCodeError, Z_REFUSAL, planar, read, read_tool_table
from kontur.rs274 import available, inch_table
from kontur.rs274 import canonical as rs274_canonical

HERE = Path(__file__).resolve().parent
PROGRAMS = HERE / "programs"
WRITTEN = PROGRAMS / "rs274"
CAM = PROGRAMS / "cam"
#: Programs as Grbl posts write them, with a zero centre word of the plane's normal axis on
#: their arcs (FreeCAD's grbl_post: K0 on XY arcs), which Grbl ignores, kontur too, and
#: LinuxCNC refuses: rs274 reads a copy without those words (:func:`rs274_text`).
GRBL_POSTS = {"freecad_grbl.ngc"}
#: Programs that stop at their last line, with no program end (M2, M30) or closing ``%``, as
#: Grbl's senders stream them: kontur reads them to their last line, LinuxCNC makes every move
#: and then refuses the file's end ("File ended with no percent sign or program end"): rs274
#: reads a copy with M2 after it (:func:`rs274_text`; test_program_without_end).
NO_END = {"t2laser_raster.nc"}
LINUXCNC = Path("/usr/share/linuxcnc/ncfiles")
TABLE = WRITTEN / "tools.tbl"
#: Programs read with a table of their own (tool lengths: the corpus's tools have none, since
#: rs274's standalone position after a tool change is its own stub's, not a machine's).
TABLES = {"toollength.ngc": WRITTEN / "lengths.tbl"}
Z = re.escape(Z_REFUSAL)

#: The programs and what kontur does with each: ``None`` (runs), or the regular expression of
#: its documented refusal (the reader's, or :func:`kontur.gcode.planar`'s for Z).
CORPUS = {
    **{PROGRAMS / f"{name}.ngc": None for name in
       ("bite", "circle", "lens", "pie", "polygon", "rounded", "square", "triangle", "zigzag")},
    **{WRITTEN / f"{name}.ngc": None for name in
       ("params", "owords", "offsets", "home", "arcs", "tools", "modes", "inch", "laser",
        "plasma", "zconst", "comp_table")},
    WRITTEN / "zplunge.ngc": rf"^line 5: {Z} \(Z from 5 to -2 mm\)$",
    WRITTEN / "helix.ngc": rf"^line 4: {Z} \(Z from 0 to -1 mm\)$",
    PROGRAMS / "xyz" / "zaxis.ngc": rf"^line 5: {Z} \(Z from 2 to 0.5 mm\)$",
    PROGRAMS / "xyz" / "planes.ngc": rf"^line 6: {Z} \(Z from 5 to 0 mm\)$",
    PROGRAMS / "xyz" / "turns.ngc": rf"^line 4: {Z} \(Z from 2 to 0 mm\)$",
    WRITTEN / "inverse.ngc": r"^line 2: G93: inverse-time feed \(G93\) is not supported",
    WRITTEN / "drill.ngc": rf"^line 4: {Z} \(Z from 5 to 2 mm\)$",
    WRITTEN / "cycles.ngc": rf"^line 9: {Z} \(Z from 15 to 2 mm\)$",
    WRITTEN / "cycleplanes.ngc": rf"^line 5: {Z} \(Z from 0 to 5 mm\)$",
    WRITTEN / "cycleseries.ngc": r"^line 13: G81 in G18 continues a series of canned cycles "
                                 r"begun in G17: end it with G80 first$",
    WRITTEN / "toollength.ngc": rf"^line 9: {Z} \(Z from 17.5 to 11.5 mm\)$",
    CAM / "freecad_grbl.ngc": rf"^line 15: {Z} \(Z from 5 to 3 mm\)$",
    CAM / "estlcam_engrave.nc": rf"^line 16: {Z} \(Z from 5 to 0.5 mm\)$",
    CAM / "jscut_engrave.nc": rf"^line 20: {Z} \(Z from 2.54 to 0 mm\)$",
    CAM / "fusion360_contour.nc": rf"^line 14: {Z} \(Z from 0 to 20 mm\)$",
    CAM / "t2laser_raster.nc": None,
    WRITTEN / "plane.ngc": rf"^line 3: {Z} \(an arc in the XZ plane, G18\)$",
    WRITTEN / "rotary.ngc": r"^line 3: A90: this controller has the axes X and Y \(and reads "
                            r"Z\), not A$",
    WRITTEN / "nosub.ngc": r"^line 3: o<elsewhere> call: no subroutine o<elsewhere> in this "
                           r"program",
    LINUXCNC / "plasmatest.ngc": None,
    LINUXCNC / "factorial.ngc": None,
    LINUXCNC / "retval.ngc": None,
    LINUXCNC / "flowsnake.ngc": rf"^line 34: {Z}",
    LINUXCNC / "arcspiral.ngc": rf"^line 6: {Z}",
    LINUXCNC / "cds.ngc": rf"^line 17: {Z}",
    LINUXCNC / "skeleton.ngc": rf"^line 13: {Z}",
    LINUXCNC / "useful-subroutines.ngc": rf"^line 27: {Z}",
    LINUXCNC / "gmoccapy_2_tools_with_cutter_radius_compensation.ngc": rf"^line 31: {Z}",
    LINUXCNC / "comp-g1.ngc": rf"^line 13: {Z}",
    LINUXCNC / "comp311.ngc": rf"^line 10: {Z}",
    LINUXCNC / "b-index.ngc": r"^line 4: B0: this controller has the axes X and Y",
    LINUXCNC / "comp.ngc": r"^line 40: G42: cutter-radius compensation is in the XY plane "
                           r"\(G17\) only, not G18$",
    LINUXCNC / "mmount.ngc": r"^line 200: G43 H5: tool 5 is not in the tool table$",
    LINUXCNC / "systems.ngc": r"^line 15: G5.1: splines \(G5.1\) are not supported$",
    LINUXCNC / "polar.ngc": rf"^line 9: {Z} \(Z from 0 to 2.54 mm\)$",
    LINUXCNC / "hole-circle.ngc": rf"^line 10: {Z} \(Z from 0 to 2.54 mm\)$",
    LINUXCNC / "spiral.ngc": rf"^line 6: {Z} \(Z from 25.4 to -2.54 mm\)$",
    LINUXCNC / "tort.ngc": rf"^line 6: {Z} \(Z from 20 to 16 mm\)$",
    LINUXCNC / "gridprobe.ngc": r"^line 35: G38.2: probing \(G38.x\) is not supported$",
}


def _uncompensated(text):
    """The program with cutter-radius compensation off: G41/G42 (and .1) become G40, their D
    words go (in the code, not in comments)."""
    out = []
    for line in text.splitlines():
        cut = min([i for i in (line.find("("), line.find(";")) if i >= 0], default=len(line))
        code, rest = line[:cut], line[cut:]
        if re.search(r"(?i)g\s*4\s*[12]", code):
            code = re.sub(r"(?i)g\s*4\s*[12](\s*\.\s*1)?(?!\d)", "G40", code)
            code = re.sub(r"(?i)d\s*[-+]?[\d.]+", "", code)
        out.append(code + rest)
    return "\n".join(out) + "\n"


def tools_of(path=None):
    """The tool table a corpus program is read with (:data:`TABLES`, else the corpus's)."""
    name = getattr(path, "name", None)
    return read_tool_table(TABLES.get(name, TABLE).read_text())


def rs274_text(path, text):
    """What rs274 reads of the corpus program ``path`` (``text``): its compensation off
    (:func:`_uncompensated`), for :data:`GRBL_POSTS` its zero K words dropped, and for
    :data:`NO_END` an M2 after its last line."""
    text = _uncompensated(text)
    if getattr(path, "name", None) in GRBL_POSTS:
        text = re.sub(r"(?i)\s*K\s*[-+]?0*\.?0*(?![\d.])", "", text)
    if getattr(path, "name", None) in NO_END:
        text += "M2\n"
    return text


def _inch_table(tmp_path, path=None):
    """A program's tool table for rs274, which reads diameters and lengths in inches (its
    default machine units)."""
    out = tmp_path / "tools-inch.tbl"
    out.write_text(inch_table(tools_of(path)))
    return out


def canonical(text, tmp_path, path=None):
    """rs274's canonical commands for ``text`` (:func:`kontur.rs274.canonical`, with the
    tool table of the corpus program ``path``): its moves (in mm, machine coordinates), its
    events, and its output."""
    assert available(), \
        "rs274 (LinuxCNC's interpreter, package linuxcnc-uspace) is missing: run make setup"
    return rs274_canonical(text, tools_of(path), folder=tmp_path)


def _events(program):
    """The reader's events in rs274's terms (as :func:`canonical` lists them)."""
    out = []
    for event in program.events:
        if event.kind == "tool_change":
            out.append(("tool_change", event.value))
        elif event.kind == "spindle" and event.text[:2] in ("M3", "M4"):
            out.append(("spindle", int(event.text[1])))
        elif event.kind == "coolant" and event.text in ("M7", "M8"):
            out.append(("coolant", int(event.text[1])))
        elif event.kind == "pause":
            out.append(("pause", int(event.text[1])))
        elif event.kind == "message":
            out.append(("message", event.text))
    return out


def compare(mine, theirs):
    """Assert the reader's moves are rs274's, one for one."""
    assert len(mine) == len(theirs), (len(mine), len(theirs))
    for number, (move, ref) in enumerate(zip(mine, theirs)):
        where = f"move {number} (line {move.line}): {move} against rs274's {ref}"
        assert move.kind == ref["kind"], where
        if move.kind == "dwell":
            assert abs(float(move.seconds) - ref["seconds"]) < 1e-4, where
            continue
        tolerance = 1.5e-4 * ref["unit"] + 1e-9 * max(1.0, *map(abs, ref["end"]))
        assert max(abs(float(a) - b) for a, b in zip(move.end, ref["end"])) < tolerance, where
        if move.kind == "arc":
            assert move.plane == ref.get("plane", 17), where
            assert len(move.centre) == len(ref["centre"]), where
            assert max(abs(float(a) - b) for a, b in zip(move.centre, ref["centre"])) \
                < tolerance, where
            assert move.cw == ref["cw"] and move.turns == ref["turns"], where
        if move.kind != "rapid":
            assert abs(float(move.feed) - ref["feed"]) < 1.5e-4 * ref["unit"], where
        if move.z is not None:
            assert abs(float(move.z) - ref["z"]) < tolerance, where


def _read(path, text):
    return read(text, name=path.name, units="mm", tools=tools_of(path))


def _text(path):
    text = path.read_text(encoding="utf-8", errors="replace")
    if path.parent == PROGRAMS:           # kontur's contour programs: no units, feed or end
        text = "G21 F100\n" + text + ("" if "M30" in text else "M2\n")
    return text


@pytest.mark.parametrize("path", list(CORPUS), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_reader_is_rs274(path, tmp_path):
    text = _text(path)
    theirs, events, run = canonical(rs274_text(path, text), tmp_path, path)
    refusal = CORPUS[path]
    try:
        program = _read(path, text)
    except GCodeError as error:
        assert refusal is not None, f"refused: {error}"
        assert re.search(refusal, f"line {error.line}: {error.reason}"), str(error)
        return
    assert run.returncode == 0, f"rs274 refuses what kontur reads: {run.stderr[-300:]}"
    compare(program.moves, theirs)
    assert _events(program) == events
    if refusal is None:
        planar(program.moves)
        return
    with pytest.raises(GCodeError) as caught:
        planar(program.moves)
    assert re.search(refusal, f"line {caught.value.line}: {caught.value.reason}"), \
        str(caught.value)


def test_cycle_series_across_planes(tmp_path):
    """cycleseries.ngc, which kontur refuses at line 13 (:data:`CORPUS`): a G81 in G18
    continuing the series of cycles begun in G17 at line 11. rs274 reads it whole, keeping the
    series' first height, Z10, and drilling along Y with it: a rapid to Y10 and G98's retract
    to Y10, a height measured on Z. Up to that line (series ended by G80 and by G0 before
    the plane changes) kontur's moves are rs274's."""
    path = WRITTEN / "cycleseries.ngc"
    text = _text(path)
    theirs, _, run = canonical(text, tmp_path, path)
    assert run.returncode == 0, run.stderr[-300:]
    lines = text.splitlines()
    assert lines[11:13] == ["G18", "G81 X6 Z3 Y-1 R2"]
    before = _read(path, "\n".join(lines[:12]) + "\nG80\nM2\n").moves
    assert len(before) == 22
    compare(before, theirs[:len(before)])
    assert [(m["kind"], m["end"], m["z"]) for m in theirs[len(before):]] == [
        ("rapid", (6, 10), 3), ("rapid", (6, 2), 3), ("line", (6, -1), 3),
        ("rapid", (6, 10), 3)]


def test_program_without_end(tmp_path):
    """t2laser_raster.nc (:data:`NO_END`) stops after its last raster line, with no M2, M30
    or closing ``%``. kontur reads it to that line, as Grbl runs it; rs274 makes every move of
    it and then refuses the end of the file. Its moves before that refusal are kontur's, and
    those of the copy with M2 that the corpus test gives it."""
    path = CAM / "t2laser_raster.nc"
    text = _text(path)
    assert not re.search(r"(?im)^\s*%|\bM0*(?:2|30)\b", text)
    theirs, events, run = canonical(text, tmp_path, path)
    assert run.returncode != 0
    assert "File ended with no percent sign or program end" in run.stderr
    program = _read(path, text)
    assert len(program.moves) == 33
    compare(program.moves, theirs)
    assert _events(program) == events
    ended, _, run = canonical(rs274_text(path, text), tmp_path, path)
    assert run.returncode == 0, run.stderr[-300:]
    assert ended == theirs


def test_corpus_is_large_enough():
    written = [p for p in CORPUS if p.parent == WRITTEN]
    linuxcnc = [p for p in CORPUS if p.parent == LINUXCNC]
    cam = [p for p in CORPUS if p.parent == CAM]
    assert all("K" not in line.upper().split("(")[0] for path in CORPUS
               if path.name in GRBL_POSTS for line in rs274_text(path, _text(path)).splitlines())
    assert all(rs274_text(path, _text(path)).endswith("M2\n") for path in CORPUS
               if path.name in NO_END)
    assert len(CORPUS) >= 30 and len(written) >= 15 and len(linuxcnc) >= 10 and len(cam) >= 5
    assert all(path.exists() for path in CORPUS), [p for p in CORPUS if not p.exists()]
    sources = (PROGRAMS / "SOURCES.md").read_text()
    for path in CORPUS:
        assert path.name in sources, f"{path.name} is not in tests/programs/SOURCES.md"


def test_tool_table_radius(tmp_path):
    """The radius the reader gives each contour of comp_table.ngc is the one rs274
    compensates with: G41 D1 (tool 1 of the table, 6 mm), G42 with the loaded tool T2
    (3.175 mm), G41.1 D4 (a 4 mm diameter in the program). rs274 reads the table's diameters
    in inches (the corpus's table is in mm, converted for it); kontur reads them in mm."""
    path = WRITTEN / "comp_table.ngc"
    program = _read(path, path.read_text())
    theirs, _, _ = canonical(path.read_text(), tmp_path)
    compensated = [m for m in program.moves if m.side is not None]
    radii = {}
    for move in compensated:
        radii.setdefault(move.radius_source, move.radius)
    assert list(radii.values()) == [3, Fraction(3175, 2000), 2]
    # Each contour's first X-running edge (programmed at y = 0, 0, 70), offset by the radius
    # to the side of the motion: rs274's compensated path runs along it.
    feeds = [m["end"] for m in theirs if m["kind"] == "line"]
    for (y0, sign), radius in zip(((0, 1), (0, -1), (70, 1)), radii.values()):
        assert any(abs(y - (y0 + sign * float(radius))) < 1e-4 for _, y in feeds), \
            (y0, radius, feeds)
    # Without the table: D is recorded, the radius is the machine's (None here).
    plain = read(path.read_text(), units="mm")
    assert {m.radius for m in plain.moves if m.side == "right"} == {None}
    assert {m.radius for m in plain.moves if m.side == "left" and m.radius_source
            and m.radius_source.startswith("G41.1")} == {2}


def test_inch_table(tmp_path):
    """A table in inches (as rs274's) gives the same radius and length, converted."""
    table = read_tool_table(_inch_table(tmp_path, WRITTEN / "toollength.ngc").read_text(),
                            units="inch")
    assert table[1] == pytest.approx(6, abs=1e-4)
    assert table.lengths == {1: pytest.approx(12.5, abs=1e-4), 2: pytest.approx(-3.2, abs=1e-4)}
