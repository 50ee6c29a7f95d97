"""kontur's compensated path against LinuxCNC's (``rs274 -g``) on the corpus of
``tests/programs/comp/`` (tests/programs/SOURCES.md): tangent line-arc joints (rounded
rectangles, slots), kinks, inside and outside, G41 and G42, mm and inches, each entered by a
G41/G42 line from off the part and left by a G40 line. Expected paths are rs274's, not
kontur's: every point the cutter's centre visits within 1.5 steps of rs274's compensated path
and every point of rs274's path within 1.5 steps of a visited point
(:func:`kontur.rs274.compare_steps`). A sample runs here on the model (the whole corpus, and
on Verilator, in ``python -m kontur.bench compensation``); the refusals are LinuxCNC's own."""

from pathlib import Path

import pytest

from kontur.rs274 import (LINUXCNC_EXAMPLES, LINUXCNC_TOOLS, available, check_program,
                          planar_copy)

COMP = Path(__file__).resolve().parent / "programs" / "comp"

#: A sample of the corpus, one of each kind (the rest run in the bench).
SAMPLE = ("rrect_in_g41", "slot_in_cw", "kink20_in", "rrect_inch_in")

#: steps: the issue's bound between kontur's path and rs274's.
BOUND = 1.5


def test_corpus_is_there():
    names = sorted(p.stem for p in COMP.glob("*.ngc"))
    assert len(names) >= 18, names
    sources = (COMP.parent / "SOURCES.md").read_text()
    assert all(f"{name}.ngc" in sources or "comp/*.ngc" in sources for name in names)


@pytest.mark.parametrize("name", SAMPLE)
def test_path_is_linuxcnc_s(name):
    assert available(), "rs274 is missing: run make setup"
    result = check_program((COMP / f"{name}.ngc").read_text(), name=name)
    assert result["rs274"] is None, result
    assert result["kontur"] is None, result           # tangent joints are accepted
    assert result["steps"] > 1000
    assert result["out"] <= BOUND and result["back"] <= BOUND, result


@pytest.mark.parametrize("name", ("random8_kink", "random19_slot", "random20_kink"))
def test_radius_off_the_lattice(name):
    """Random profiles (kontur.profiles, seed 26) whose cutter radius lies about half a step
    off the lattice (109.52, 277.56 and 199.56 steps): rounded to a step, the radius added
    its 0.44-0.48 steps to the lattice's and the engine's errors, 1.84, 1.74 and 1.53 steps
    from rs274's path; taken exactly (the frames carry its fraction) they are within the
    bound."""
    assert available(), "rs274 is missing: run make setup"
    result = check_program((COMP / f"{name}.ngc").read_text(), name=name)
    assert result["rs274"] is None and result["kontur"] is None, result
    assert result["out"] <= BOUND and result["back"] <= BOUND, result


def test_linuxcnc_comp311():
    """LinuxCNC's comp311.ngc (its Z moves dropped), tool 4 of 1 inch: a G41 entry line, a
    lead-in arc tangent to it and to the outline, the outline closing on the lead-in's end.
    Refused before for every radius (the tangent joints); now LinuxCNC's path (at 20
    steps/mm: quicker)."""
    path = LINUXCNC_EXAMPLES / "comp311.ngc"
    assert path.exists(), "LinuxCNC's examples (linuxcnc-uspace) are missing: run make setup"
    result = check_program(planar_copy(path.read_text()), tools=LINUXCNC_TOOLS,
                           steps_per_mm=20)
    assert result["rs274"] is None and result["kontur"] is None, result
    assert result["out"] <= BOUND and result["back"] <= BOUND, result


def test_entry_by_an_arc():
    """A G42 entry by an arc (LinuxCNC's rule: an arc from where the cutter is to the offset
    end, centred on the end's radial line: rs274 prints it centred at (0, -1.8333)), then a
    line and a convex corner."""
    text = ("G21 F600\nG0 X-10 Y0\nG42.1 D4 G3 X0 Y-10 I10 J0\nG1 X20\nG1 Y10\n"
            "G40 G1 X30 Y10\nM2\n")
    result = check_program(text, steps_per_mm=40)
    assert result["rs274"] is None and result["kontur"] is None, result
    assert result["out"] <= BOUND and result["back"] <= BOUND, result


def _refused_by_both(text, rs274_reason, kontur_reason):
    result = check_program(text)
    assert result["rs274"] is not None and rs274_reason in result["rs274"], result
    assert result["kontur"] is not None and kontur_reason in result["kontur"], result


def test_cutter_too_large_for_an_inside_arc():
    """The slot's arcs have radius 7 mm; a 16 mm cutter inside them gouges."""
    text = (COMP / "slot_in.ngc").read_text().replace("D10", "D16")
    _refused_by_both(text, "Tool radius not less than arc radius with comp",
                     "is too large for the arc of radius")


def test_entry_move_not_longer_than_the_radius():
    """LinuxCNC's entry rule: the G41/G42 line must be longer than the cutter radius."""
    text = ("G21 G90 F600\nG0 X0 Y-3\nG41.1 D8 G1 X0 Y0\nG1 X30\nG1 Y20\nG1 X0\nG1 Y0\n"
            "G40 G1 X-5 Y-5\nM2\n")
    _refused_by_both(text, "entry move is not greater than the tool radius",
                     "the entry move (the first move with G41/G42) is not longer than the "
                     "cutter radius")


@pytest.mark.cocotb
def test_rrect_square_on_verilator():
    """One corpus program through the ULX3S controller's RTL on Verilator: the run is checked
    against the model (``execute`` raises when a step, an outcome or the position differs)
    and its path against rs274's (the rest of the Verilator third: the bench)."""
    from .conftest import selected_simulators
    if "verilator" not in selected_simulators():
        pytest.skip("SIM selects another simulator")
    result = check_program((COMP / "rrect_square.ngc").read_text(), engine="verilator",
                           steps_per_mm=40)          # (half the steps: quicker)
    assert result["rs274"] is None and result["kontur"] is None, result
    assert result["out"] <= BOUND and result["back"] <= BOUND, result


def test_gouge_in_a_notch():
    """A notch 2 mm wide in a plate cut outside with a 6 mm cutter: the cutter cannot reach
    its bottom without cutting its sides. rs274 refuses it at the notch's far side, kontur at
    its bottom (whose equidistant would run backwards between its corners)."""
    text = ("G21 G90 F600\nG0 X-10 Y0\nG42.1 D6 G1 X0 Y0\nG1 X30\nG1 Y20\nG1 X16\nG1 Y15\n"
            "G1 X14\nG1 Y20\nG1 X0\nG1 Y0\nG40 G1 X-10 Y-5\nM2\n")
    _refused_by_both(text, "cannot be reached by the tool without gouging",
                     "line 8: the cutter (radius 240) is too large: the equidistant of this "
                     "segment would run backwards")


def test_equidistant_running_backwards():
    """A random kinked profile (kontur.profiles, seed 26, random32_kink) whose first chamfer
    after the G42 entry is shorter than its equidistant's corners are apart: rs274 takes it
    and makes that chamfer's compensated move backwards, against the chamfer (0.06 mm from
    the entry's end); kontur refuses it, naming the line: the engine's line elements step
    along their segment (block 3's major axis moves forward at every step), so a piece of
    equidistant running against its segment cannot be traced (docs/equidistant.md)."""
    from kontur.profiles import random_programs
    from kontur.rs274 import canonical
    text = dict(random_programs(33))["random32_kink"]
    moves, _, run = canonical(text)
    assert run.returncode == 0, run.stderr
    assert text.splitlines()[5] == "G1 X8.1092 Y13.7616"   # line 6, from (6.2472, 11.6006)
    d = (8.1092 - 6.2472, 13.7616 - 11.6006)
    feeds = [m for m in moves if m["kind"] == "line"]
    (entry_end, chamfer_end) = feeds[0]["end"], feeds[1]["end"]
    moved = (chamfer_end[0] - entry_end[0], chamfer_end[1] - entry_end[1])
    assert moved[0] * d[0] + moved[1] * d[1] < 0, (entry_end, chamfer_end)   # backwards
    result = check_program(text)
    assert result["kontur"] is not None and result["kontur"].startswith(
        "line 6: the cutter (radius 232.96) is too large: the equidistant of this segment "
        "would run backwards"), result
