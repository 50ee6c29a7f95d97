"""The G-code reader: syntax, the modal state, and every refusal with its line."""

import unittest
from fractions import Fraction

from kontur.gcode import (GCodeError, Move, ToolTableError, interpret, parse, planar, read,
                          read_tool_table)


class ParseTestCase(unittest.TestCase):
    def test_words_comments_and_numbers(self):
        blocks = parse("%\n(header only)\n\nN10 g1 x-1.5 Y.25 ; to here\nG0X3(inline)Y+4\n%\n")
        self.assertEqual([b.line for b in blocks], [4, 5])
        self.assertEqual([w.text for w in blocks[0].words], ["N10", "G1", "X-1.5", "Y.25"])
        self.assertEqual(blocks[0].value("X"), Fraction(-3, 2))
        self.assertEqual(blocks[0].value("Y"), Fraction(1, 4))
        self.assertEqual(blocks[0].comment, "to here")
        self.assertEqual(blocks[1].comment, "inline")
        self.assertEqual([w.code for w in blocks[1].codes("G")], [0])
        self.assertIsNone(blocks[1].value("I"))

    def test_errors_name_the_line(self):
        cases = [
            ("G1 X1\nG1 X (\n", r"^line 2: a comment opened with '\(' is not closed$"),
            ("G1 (a (b) c)\n", r"^line 1: comments do not nest$"),
            ("G1 X1 )\n", r"^line 1: '\)' closes no comment$"),
            ("\nG1 X1 %5\n", r"^line 2: cannot read '%5': a word is a letter and a number$"),
            ("G1 X\n", r"^line 1: cannot read 'X': a word is a letter and a number$"),
        ]
        for text, message in cases:
            with self.subTest(text=text), self.assertRaisesRegex(GCodeError, message):
                parse(text)

    def test_file_name_in_messages(self):
        with self.assertRaisesRegex(GCodeError, r"^part\.ngc:1: comments do not nest$") as cm:
            parse("(()", name="part.ngc")
        self.assertEqual((cm.exception.line, cm.exception.reason),
                         (1, "comments do not nest"))

    def test_text_wrong(self):
        with self.assertRaisesRegex(TypeError, r"^Program text must be a string, not b'G1'$"):
            parse(b"G1")


class InterpretTestCase(unittest.TestCase):
    def moves(self, text):
        return interpret(parse(text))

    def test_absolute_incremental_and_modal_motion(self):
        moves = self.moves("G90 G0 X10 Y5\nG1 X20\nY15\nG91 X-5 Y-5\nG90 G1 X0 Y0 F100\n")
        self.assertEqual([(m.kind, m.start, m.end) for m in moves], [
            ("rapid", (0, 0), (10, 5)), ("line", (10, 5), (20, 5)), ("line", (20, 5), (20, 15)),
            ("line", (20, 15), (15, 10)), ("line", (15, 10), (0, 0))])
        self.assertEqual(moves[-1].feed, 100)
        self.assertEqual([m.line for m in moves], [1, 2, 3, 4, 5])

    def test_arcs_and_compensation(self):
        moves = self.moves("G0 X5 Y0\nG41 G3 X0 Y5 I-5 J0\nG42 G2 X5 Y0 I0 J-5\nG40 G1 X0\n"
                           "G41 G3 I-5\n")
        self.assertEqual(moves[1], Move(2, "arc", (5, 0), (0, 5), centre=(0, 0), cw=False,
                                        side="left"))
        self.assertEqual((moves[2].centre, moves[2].cw, moves[2].side), ((0, 0), True, "right"))
        self.assertEqual(moves[3].side, None)
        self.assertEqual((moves[4].start, moves[4].end, moves[4].centre), ((0, 0), (0, 0),
                                                                          (-5, 0)))

    def test_start_and_program_end(self):
        moves = interpret(parse("G1 X1\nM30\n"), start=(3, 4))
        self.assertEqual(moves[0].start, (3, 4))

    def test_refusals_name_the_line(self):
        cases = [
            ("G1 X1\nQ3\n", r"^line 2: Q3: no code in this block takes Q \(G64, M61, G73/G83 "
                          r"peck\)$"),
            ("G1 X1\nE3\n", r"^line 2: unknown word E3$"),
            ("G2 X20 R5\n", r"^line 1: the radius 5 is less than half the distance to the end "
                            r"\(10\)$"),
            ("G2 X1 R0\n", r"^line 1: an arc of radius zero \(R0\)$"),
            ("G2 R5\n", r"^line 1: an arc by radius \(R\) cannot end where it starts"),
            ("G2 X2 I1 R1\n", r"^line 1: an arc by its centre \(I, J\) or by its radius \(R\), "
                              r"not both$"),
            ("G1 X1 R2\n", r"^line 1: I, J, K and R belong to arcs \(G2, G3\), not to G1$"),
            ("G1.5 X1\n", r"^line 1: unknown code G1\.5$"),
            ("G1 X1 X2\n", r"^line 1: X given twice \(X1 and X2\)$"),
            ("G6 X1\n", r"^line 1: unknown code G6$"),
            ("G21\n", r"^line 1: G21: this program is read in lattice units \(steps\), "
                      r"without G20/G21$"),
            ("G18.1\n", r"^line 1: G18.1: the UVW planes \(G17.1, G18.1, G19.1\) are not "
                         r"supported"),
            ("G41.1 D2\nG18\n", r"^line 2: G18 with cutter-radius compensation on"),
            ("G19 G42.1 D2\n", r"^line 1: G42.1: cutter-radius compensation is in the XY "
                                r"plane \(G17\) only, not G19$"),
            ("G18 G2 X1 I1 J1 F10\n", r"^line 1: J1: an arc in the XZ plane \(G18\) takes K "
                                      r"and I, not J$"),
            ("G19 G3 Y1 I1 F10\n", r"^line 1: I1: an arc in the YZ plane \(G19\) takes J and "
                                   r"K, not I$"),
            ("G18 G2 X1 F10\n", r"^line 1: G2 needs the centre: K and I \(relative to the "
                                r"start\) or R$"),
            # canned cycles: what LinuxCNC refuses, and the cycles kontur does not make
            ("F100 G81 X1 Z-1\n", r"^line 1: G81 needs R: the retract plane$"),
            ("F100 G81 X1 R1\n", r"^line 1: G81 needs Z: the depth$"),
            ("F100 G83 X1 Z-1 R1\n", r"^line 1: G83 needs Q: the peck, the depth of each$"),
            ("F100 G73 X1 Z-1 R1 Q-1\n", r"^line 1: G73 Q-1: a peck must be positive$"),
            ("F100 G82 X1 Z-1 R1\n", r"^line 1: G82 needs P: the dwell, seconds$"),
            ("F100 G81 X1 Z-1 R1\nG82 X2\n", r"^line 2: G82 needs R: the retract plane$"),
            ("F100 G81 X1 Z2 R1\n", r"^line 1: G81: R \(1 mm\) is below Z \(2 mm\)$"),
            ("F100 G81 X1 Z-1 R1 L0\n", r"^line 1: G81 L0: the repeats are a whole number"),
            ("F100 G18 G81 X1 Z-1 R1\n", r"^line 1: G81 needs Y: the depth$"),
            # a series of cycles continued in another plane (LinuxCNC would keep its first
            # height, measured on the old plane's normal axis): G80 (or G0...) first
            ("F100 G0 Z10\nG98 G81 X1 Y1 Z-1 R2\nG18\nG81 X2 Z3 Y-1 R2\n",
             r"^line 4: G81 in G18 continues a series of canned cycles begun in G17: end it "
             r"with G80 first$"),
            ("F100 G0 Z10\nG98 G81 X1 Y1 Z-1 R2\nG18\nX2 Z3\n",
             r"^line 4: G81 in G18 continues a series of canned cycles begun in G17"),
            ("F100 G0 Z10\nG81 X1 Y1 Z-1 R2\nG19 G82 Y2 Z3 X-1 R2 P1\n",
             r"^line 3: G82 in G19 continues a series of canned cycles begun in G17: end it "
             r"with G80 first$"),
            ("F100 G18 G0 Y10\nG81 X1 Z1 Y-1 R2\nX2\nG17 G81 X1 Y1 Z-1 R2\n",
             r"^line 4: G81 in G17 continues a series of canned cycles begun in G18: end it "
             r"with G80 first$"),
            ("F100 G41.1 D2 G81 X1 Z-1 R1\n", r"^line 1: G81 with cutter-radius compensation "
                                              r"on"),
            ("F100 G84 X1 Z-1 R1\n", r"^line 1: G84: spindle-synchronised and oriented "
                                     r"cycles \(G74, G84 tapping"),
            ("F100 G81 X1 Z-1 R1 Q2\n", r"^line 1: Q2: no code in this block takes Q"),
            ("G1 X1 @5\n", r"^line 1: X1: polar coordinates \(@, \^\) or X and Y, not both$"),
            ("G91 G1 ^30\n", r"^line 1: incremental polar coordinates \(G91 @, \^\) at the "
                              r"program's origin"),
            ("G18 G1 @2\n", r"^line 1: polar coordinates \(@, \^\) are in the XY plane"),
            ("G2 X2 I1 P0\n", r"^line 1: P0: an arc's turns are a whole number, 1 or more$"),
            ("G2 X2 I1 P1.5\n", r"^line 1: P1.5: an arc's turns are a whole number"),
            ("G41.1 D1 G1 X5\nG2 X7 I1 P2\n", r"^line 2: P2: an arc of more than one turn "
                                                 r"with cutter-radius compensation on"),
            ("G1 G2 X1\n", r"^line 1: two motion codes in one block \(G1 and G2\)$"),
            ("M5.5\n", r"^line 1: unknown code M5\.5$"),
            ("M62\n", r"^line 1: unknown code M62$"),
            ("X1\n", r"^line 1: coordinates without a motion code \(G0, G1, G2 or G3\)$"),
            ("G1 X1 I2\n", r"^line 1: I, J, K and R belong to arcs \(G2, G3\), not to G1$"),
            ("G3 X1 Y1\n", r"^line 1: G3 needs the centre: I and J \(relative to the start\) "
                           r"or R$"),
            ("G1 X1 F0\n", r"^line 1: the feed must be positive, not F0$"),
        ]
        for text, message in cases:
            with self.subTest(text=text), self.assertRaisesRegex(GCodeError, message):
                self.moves(text)

    def test_units(self):
        # Lattice units refuse G20/G21 (above); millimetres take them, inches scale by 25.4.
        # F is read before the block's G20/G21 (LinuxCNC's order of execution, as rs274
        # prints it: SET_FEED_RATE before USE_LENGTH_UNITS): "G20 F10" is 10 mm/min, a
        # later F10 in inches 254 mm/min, kept in mm across G21.
        moves = interpret(parse("G1 X1 F10\nG20 G1 X1 Y2 F10\nG1 X2 F10\nG21 G91 G1 X1\n"),
                          units="mm")
        self.assertEqual([m.end for m in moves],
                         [(1, 0), (Fraction(254, 10), Fraction(508, 10)),
                          (Fraction(508, 10), Fraction(508, 10)),
                          (Fraction(518, 10), Fraction(508, 10))])
        self.assertEqual([m.feed for m in moves], [10, 10, 254, 254])
        moves = interpret(parse("G20 G0 X1\nG3 X0 Y1 I-1 F10\n"), units="mm")
        self.assertEqual(moves[1].centre, (0, 0))
        with self.assertRaisesRegex(GCodeError, r"^line 1: two units codes in one block "
                                                r"\(G20 and G21\)$"):
            interpret(parse("G20 G21\n"), units="mm")
        with self.assertRaisesRegex(ValueError, "Units must be one of"):
            interpret(parse("G1 X1\n"), units="inch")

    def test_arcs_by_radius(self):
        # Each case: the arc, then the centre it must have: on both ends' circle of |R|, on
        # the side RS274 gives (positive R: at most a half turn).
        cases = [("G2 X1 Y1 R1", (1, 0)), ("G3 X1 Y1 R1", (0, 1)),
                 ("G2 X1 Y1 R-1", (0, 1)), ("G3 X1 Y1 R-1", (1, 0)),
                 ("G2 X10 R5", (5, 0)), ("G3 X6 Y8 R5", (3, 4))]
        for text, centre in cases:
            with self.subTest(text=text):
                (move,) = self.moves(text + "\n")
                self.assertTrue(all(abs(float(c) - e) < 1e-30 for c, e in zip(move.centre,
                                                                              centre)),
                                move.centre)
                radius = abs(Fraction(text.split("R")[1]))
                for point in (move.start, move.end):
                    radius2 = sum((p - c) ** 2 for p, c in zip(point, move.centre))
                    self.assertLess(abs(radius2 - radius * radius), Fraction(1, 10 ** 30))
        # An arc by radius turns the way it says: the cross product of start and end about
        # the centre is negative for G2 (clockwise), positive for G3.
        for code, sign in (("G2", -1), ("G3", 1)):
            for radius in ("R5", "R-5"):
                (move,) = self.moves(f"{code} X6 Y2 {radius}\n")
                (ax, ay), (bx, by) = [(p[0] - move.centre[0], p[1] - move.centre[1])
                                      for p in (move.start, move.end)]
                cross = ax * by - ay * bx
                self.assertEqual(cross > 0, sign > 0 if radius == "R5" else sign < 0,
                                 (code, radius))

    def test_full_circle(self):
        (move,) = self.moves("G0 X5\nG2 I-5\n")[1:]
        self.assertEqual((move.start, move.end, move.centre, move.cw), ((5, 0), (5, 0), (0, 0),
                                                                        True))

    def test_read(self):
        program = read("G17 G90\nG1 X2 Y2 D1\n", name="p.ngc")
        self.assertEqual((program.name, len(program.blocks), len(program.moves)), ("p.ngc", 2, 1))


if __name__ == "__main__":
    unittest.main()


class LinuxCNCWordsTestCase(unittest.TestCase):
    """The words real programs carry, each with LinuxCNC's meaning (the values expected here
    are worked out by hand from LinuxCNC's documentation; tests/test_gcode_rs274.py holds the
    reader against rs274 itself)."""

    def read(self, text, **options):
        return read(text, units="mm", **options)

    def ends(self, text, **options):
        return [tuple(float(c) for c in m.end) for m in self.read(text, **options).moves
                if m.kind != "dwell"]

    def test_zero_normal_word_on_an_arc(self):
        """K0 on an XY arc (FreeCAD's grbl post writes it; Grbl ignores it) is the arc without
        it; J0 on an XZ arc likewise; K1 is refused (above)."""
        plain = self.read("G21 F100\nG2 X2 Y0 I1 J0\nG18 G2 X4 Z0 I1\n").moves
        zero = self.read("G21 F100\nG2 X2 Y0 I1 J0 K0.000\nG18 G2 X4 Z0 I1 J-0\n").moves
        self.assertEqual(plain, zero)

    def test_polar_coordinates(self):
        """@ and ^ by hand from LinuxCNC's documentation: G90 @ the distance from the origin,
        ^ the angle from +X (a word not given keeps the current one); G91 adds to them."""
        ends = self.ends("G21 F100\nG1 @10 ^90\nG1 ^180\nG91 G1 @5\nG1 ^-90\n")
        expected = [(0, 10), (-10, 0), (-15, 0), (0, 15)]
        for (x, y), (ex, ey) in zip(ends, expected):
            self.assertAlmostEqual(x, ex, places=9)
            self.assertAlmostEqual(y, ey, places=9)

    def test_cycle_series_and_planes(self):
        """A series of cycles ended (G80, or another motion mode) before the plane changes:
        the next cycle begins a series of its own, its first height on the new plane's normal
        axis (by hand: G18 from Y1, below R2, up to R first, G98 back to Y2, not to the G17
        series' Z10). A plane changed and changed back between two cycle blocks is the same
        series (G98 back to Z10). A series continued in another plane is refused (above)."""
        def points(text):
            return [(m.kind[0], *(float(c) for c in m.end), float(m.z))
                    for m in self.read(text).moves]

        g17 = [("r", 0, 0, 10), ("r", 1, 1, 10), ("r", 1, 1, 2), ("l", 1, 1, -1),
               ("r", 1, 1, 10)]
        g18 = [("r", 1, 2, 10), ("r", 2, 2, 3), ("l", 2, -1, 3), ("r", 2, 2, 3)]
        # (G0 or G1 with no axis word is a move to where the machine is, as rs274's)
        for end, moved in (("G80", []), ("G0", [("r", 1, 1, 10)]), ("G1", [("l", 1, 1, 10)]),
                           ("G80 G18", [])):
            with self.subTest(end=end):
                self.assertEqual(points(f"G21 F100\nG0 X0 Y0 Z10\nG98 G81 X1 Y1 Z-1 R2\n"
                                        f"{end}\nG18 G98 G81 X2 Z3 Y-1 R2\n"),
                                 g17 + moved + g18)
        self.assertEqual(points("G21 F100\nG0 X0 Y0 Z10\nG98 G81 X1 Y1 Z-1 R2\nG18\nG17\n"
                                "X3 Y3\n")[5:],
                         [("r", 3, 3, 10), ("r", 3, 3, 2), ("l", 3, 3, -1), ("r", 3, 3, 10)])

    def test_peck_drilling(self):
        """G83 by hand from LinuxCNC's documentation: down to R, pecks of Q each back out to
        R and down again to 0.254 mm (0.010 inch) above the last depth, the last peck to Z,
        the retract to R (G99)."""
        moves = self.read("G21 F100\nG0 Z10\nG99 G83 X1 Z-3 R2 Q2\n").moves
        self.assertEqual([(m.kind[0], float(m.end[0]), float(m.z)) for m in moves],
                         [("r", 0, 10), ("r", 1, 10), ("r", 1, 2), ("l", 1, 0), ("r", 1, 2),
                          ("r", 1, 0.254), ("l", 1, -2), ("r", 1, 2), ("r", 1, -1.746),
                          ("l", 1, -3), ("r", 1, 2)])

    def test_messages_name_the_right_word(self):
        cases = [
            ("G1 X1 F10\nG1 X2 P0.05\n", r"^line 2: P0\.05: no code in this block takes P"),
            ("G1 X1 F10 H1\n", r"^line 1: H1: no code in this block takes H \(G43\)$"),
            ("G81 X1 Z-1 R1\n", r"^line 1: G81 with no feed rate: give an F before the cycle$"),
            ("G1 X1 F10 L2\n", r"^line 1: L2: no code in this block takes L \(G10, a canned "
                                r"cycle's repeats\)$"),
            ("G4\n", r"^line 1: G4 needs P: the dwell in seconds$"),
            ("G10 P1 X1\n", r"^line 1: G10 needs L"),
            ("G10 L1 P1 R1\n", r"^line 1: G10 L1: only L2 and L20 \(work offsets\) are "
                               r"supported: give the tool table with --tool-table$"),
            ("G92\n", r"^line 1: G92 needs an axis word$"),
            ("G93 G1 X1 F1\n", r"^line 1: G93: inverse-time feed"),
            ("G1 X1 F10\nG2 X2 Y1 I1 Z1 K2\n", r"^line 2: K2: an arc in the XY plane \(G17\) "
                                                r"takes I and J, not K$"),
            ("G53 G2 X1 Y1 R1 F10\n", r"^line 1: G53 \(machine coordinates\) takes G0 or G1"),
            ("G41.1 G1 X1 F10\n", r"^line 1: G41\.1 needs D: the cutter's diameter$"),
            ("M6 M61 Q1\n", r"^line 1: two tool change codes in one block \(M6 and M61\)$"),
            ("G1 X1 F10 B2\n", r"^line 1: B2: this controller has the axes X and Y"),
            ("#<x> = 1\nG1 X#<y> F10\n", r"^line 2: named parameter #<y> is not defined$"),
            ("G1 X[1/0] F10\n", r"^line 1: division by zero in an expression$"),
            ("G1 X[SQRT[-1]] F10\n", r"^line 1: SQRT of a negative number"),
            ("G1 X[1 + ] F10\n", r"^line 1: cannot read '\] ?f10'|^line 1: cannot read"),
            ("#1 = [1 + 2\n", r"^line 1: an expression's '\[' is not closed by '\]'$"),
            ("o100 if [1]\nG1 X1 F10\n", r"^line 1: o100 if is not closed \(no o100 endif\)$"),
            ("o100 endif\n", r"^line 1: o100 endif closes no o100 if$"),
            ("o100 while [1]\no101 break\no100 endwhile\n",
             r"^line 2: o101 break outside loop o101$"),
            ("o<a> sub\no<a> endsub\no<a> sub\no<a> endsub\n",
             r"^line 3: subroutine o<a> defined twice$"),
            ("o<a> call\n", r"^line 1: o<a> call: no subroutine o<a> in this program"),
            ("o100 foo\n", r"^line 1: o100: unknown O-word command 'foo'"),
            ("#5220 = 2\n", r"^line 1: #5220 \(the coordinate system\) is set by G54-G59\.3"),
        ]
        for text, message in cases:
            with self.subTest(text=text), self.assertRaisesRegex(GCodeError, message):
                self.read(text)

    def test_words_real_programs_carry_are_accepted(self):
        program = self.read("%\nG17 G21 G40 G49 G54 G64 P0.05 Q0.01 G80 G90 G91.1 G94 G98\n"
                            "G43 H1\nG61.1\nG90.1\nG99\nG64\nT1 M6\nS1000 M3\nM7 M8\nM9\nM5\n"
                            "G1 X - 1 Y + 2 F100\nM2\nG1 X99 Y99\n")
        self.assertEqual([tuple(m.end) for m in program.moves], [(-1, 2)])
        self.assertEqual([(e.line, e.kind, e.text) for e in program.events], [
            (2, "tool_length", "G49"), (3, "tool_length", "G43 H1"), (8, "tool", "T1"), (8, "tool_change", "M6 T1"),
            (9, "speed", "S1000"), (9, "spindle", "M3 S1000"), (10, "coolant", "M7"),
            (10, "coolant", "M8"), (11, "coolant", "M9"), (12, "spindle", "M5")])

    def test_expressions(self):
        # Each value worked out by hand with LinuxCNC's precedences (all left-associative;
        # unary minus binds tightest), degrees for angles, MOD's result made non-negative.
        cases = [("[1 + 2 * 3]", 7), ("[2 ** 3 ** 2]", 64), ("[-2 ** 2]", 4),
                 ("[7 MOD 3]", 1), ("[-7 MOD 3]", 2), ("[10 - 4 - 3]", 3), ("[12 / 2 / 3]", 2),
                 ("[1 EQ 1.0000001]", 1), ("[1 NE 1.1]", 1), ("[2 GT 1 AND 0]", 0),
                 ("[0 OR 2]", 1), ("[1 XOR 1]", 0), ("[3 LE 3]", 1), ("[3 LT 3]", 0),
                 ("[ROUND[2.5]]", 3), ("[ROUND[-2.5]]", -3), ("[FIX[-2.5]]", -3),
                 ("[FUP[-2.5]]", -2), ("[ABS[-4]]", 4), ("[SQRT[16]]", 4),
                 ("[ATAN[1]/[-1]]", 135), ("[SIN[90]]", 1), ("[COS[180]]", -1),
                 ("[ASIN[1]]", 90), ("[ACOS[0]]", 90), ("[TAN[45]]", 1), ("[LN[EXP[2]]]", 2),
                 ("[1 + 2 EQ 3]", 1)]
        for expression, value in cases:
            with self.subTest(expression=expression):
                (end,) = self.ends(f"G1 X{expression} F1\n")
                self.assertAlmostEqual(end[0], value, places=9)

    def test_parameters(self):
        # Settings take effect after the line: X#1 reads the #1 before it.
        ends = self.ends("#1 = 3\n#2 = 4 G1 X#1 Y#2 F10\n#5 = 1\nG1 X#2 Y##5\n#<_g> = 5\n"
                         "#<l> = #<_g>\nG1 X#<l> Y#<_g>\nG1 X[#1 + #<l>]\n")
        self.assertEqual(ends, [(3, 0), (4, 3), (5, 5), (8, 5)])

    def test_subroutines_locals_and_return(self):
        program = ("o<f> sub\n#<a> = [#1 * 2]\nG1 X#<a> F10\no<f> endsub [#<a> + 1]\n"
                   "#<a> = 100\n#1 = 7\no<f> call [3]\nG1 Y#<_value>\nG1 X#<a> Y#1\n"
                   "o<g> sub\no<g> call [#1 - 1]\no<g> endsub\n")
        # #<a> and #1 are the caller's again after the call; the sub's value is 3 * 2 + 1.
        self.assertEqual(self.ends(program), [(6, 0), (6, 7), (100, 7)])
        with self.assertRaisesRegex(GCodeError, r"^line 2: o<g> call: more than 100 calls"):
            self.read("o<g> sub\no<g> call\no<g> endsub\no<g> call\n")

    def test_endless_loop_is_refused(self):
        import kontur.gcode as gcode
        saved = gcode.MAX_BLOCKS
        gcode.MAX_BLOCKS = 1000
        try:
            with self.assertRaisesRegex(GCodeError, r"^line \d: the program runs more than "
                                                    r"1,000 blocks \(an endless loop\?\)$"):
                self.read("o1 while [1]\nG1 X1 F1\no1 endwhile\n")
        finally:
            gcode.MAX_BLOCKS = saved

    def test_offsets(self):
        # G54 at (10, 5): X1 is machine 11; G92 makes here (11, 5) the point (0, 0); G53 is
        # the machine's own coordinates whatever the offsets.
        ends = self.ends("G10 L2 P1 X10 Y5\nG0 X1 Y0\nG92 X0 Y0\nG1 X1 F10\nG53 G0 X2 Y3\n"
                         "G92.1\nG1 X0 Y0\nG55 G1 X0 Y0\nG10 L20 P2 X1 Y1\nG1 X0 Y0\n")
        self.assertEqual(ends, [(11, 5), (12, 5), (2, 3), (10, 5), (0, 0), (-1, -1)])

    def test_home_positions_from_the_parameters(self):
        program = self.read("G0 X5 Y5\nG28\nG28 X20\nG30 Y1\n",
                            parameters={5161: 1, 5162: 2, 5181: 7, 5182: 8})
        self.assertEqual([tuple(m.end) for m in program.moves],
                         [(5, 5), (5, 5), (1, 2), (20, 2), (1, 2), (1, 1), (1, 8)])

    def test_arc_centre_modes(self):
        moves = self.read("G0 X10 Y5\nG90.1 G2 X0 Y5 I5 J5 F10\nG91.1 G3 X10 Y5 I5 J0\n").moves
        self.assertEqual([m.centre for m in moves[1:]], [(5, 5), (5, 5)])

    def test_dwells_and_z(self):
        program = self.read("G0 X1 Z2\nG4 P0.25\nG1 X2 F10\nG1 Z3\n")
        self.assertEqual([(m.kind, m.z, m.seconds) for m in program.moves],
                         [("rapid", 2, None), ("dwell", 2, Fraction(1, 4)), ("line", 2, None),
                          ("line", 3, None)])
        with self.assertRaisesRegex(GCodeError, r"^line 4: Z moves need the third axis, which "
                                                r"this board's controller does not have \(the icebreaker-z's and the ulx3s's have it\) \(Z from 2 "
                                                r"to 3 mm\)$"):
            planar(program.moves)
        planar(self.read("G1 X1 F10\nG0 Z-1\nG1 X2 Z-1\nG54 G1 X3\n").moves)

    def test_block_delete_and_percent(self):
        text = "%\nG1 X1 F10\n/G1 X2\n%\nG1 X3\n"
        self.assertEqual(self.ends(text), [(1, 0), (2, 0)])
        self.assertEqual(self.ends(text, block_delete=True), [(1, 0)])

    def test_program_without_end(self):
        # A program that stops at its last line, with no M2, M30 or closing %, as Grbl's
        # senders stream it (T2Laser's raster output, tests/programs/cam/t2laser_raster.nc):
        # read to that line, its events with it; LinuxCNC refuses the file's end
        # (test_gcode_rs274.test_program_without_end). With M2 the same moves, and the lines
        # after the M2 unread.
        text = ("M6 T1\nF750\nG92X1Y2\nG00 X0 Y0\nG01\nM03 S0\nX5.2 Y0.2 M03 S0\n"
                "X5.3 Y0.1 M03 S1000")
        program = self.read(text)
        self.assertEqual([(m.kind, tuple(m.end), m.line) for m in program.moves],
                         [("rapid", (-1, -2), 4), ("line", (-1, -2), 5),
                          ("line", (Fraction(42, 10), Fraction(-18, 10)), 7),
                          ("line", (Fraction(43, 10), Fraction(-19, 10)), 8)])
        self.assertEqual([e.text[:2] for e in program.events if e.kind == "spindle"],
                         ["M3"] * 3)
        ended = self.read(text + "\nM2\nG0 X9\n")
        self.assertEqual([tuple(m.end) for m in ended.moves],
                         [tuple(m.end) for m in program.moves])

    def test_messages_and_pauses(self):
        program = self.read("(MSG, hello)\n#1 = 2\n(DEBUG, one #1 two #<_value>)\nM0\nM1\n")
        self.assertEqual([(e.kind, e.text) for e in program.events],
                         [("message", " hello"), ("message", " one 2.000000 two 0.000000"),
                          ("pause", "M0"), ("pause", "M1 (optional stop)")])

    def test_compensation_radius_from_the_tools(self):
        tools = read_tool_table("T1 P1 D6 ;six\nT2 P2 D4 Z1\n\n; comment line\n")
        self.assertEqual(tools, {1: 6, 2: 4})
        moves = self.read("G0 X0\nG41 D1 G1 X1 F10\nG40 G1 X2\nT2 M6\nG42 G1 X3\n"
                          "G41.1 D3 G1 X4\nG40 G1 X5\n", tools=tools).moves
        self.assertEqual([m.radius for m in moves], [None, 3, None, 2, Fraction(3, 2), None])
        self.assertEqual(moves[1].radius_source, "tool table: D1, diameter 6 mm")
        with self.assertRaisesRegex(GCodeError, r"^line 1: D9: tool 9 is not in the tool "
                                                r"table$"):
            self.read("G41 D9 G1 X1 F10\n", tools=tools)
        for text, message in (("T1 D6\nT1 D3\n", r"^line 2: tool 1 given twice$"),
                              ("P1 D3\n", r"^line 1: a tool line starts with T"),
                              ("T1 Dx\n", r"^line 1: cannot read 'Dx'")):
            with self.subTest(text=text), self.assertRaisesRegex(ToolTableError, message):
                read_tool_table(text)
        self.assertEqual(read_tool_table("T1 D0.25\n", units="inch"), {1: Fraction(635, 100)})
