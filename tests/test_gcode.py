"""The G-code reader: syntax, the modal state, and every refusal with its line."""

import unittest
from fractions import Fraction

from kontur.gcode import GCodeError, Move, interpret, parse, read


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
            ("\nG1 X1 @5\n", r"^line 2: '@5': polar coordinates \(@ and \^\) are not supported$"),
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
            ("G1 X1\nQ3\n", r"^line 2: Q3: no code in this block takes Q \(G64, M61\)$"),
            ("G1 X1\nE3\n", r"^line 2: unknown word E3$"),
            ("G2 X20 R5\n", r"^line 1: the radius 5 is less than half the distance to the end "
                            r"\(10\)$"),
            ("G2 X1 R0\n", r"^line 1: an arc of radius zero \(R0\)$"),
            ("G2 R5\n", r"^line 1: an arc by radius \(R\) cannot end where it starts"),
            ("G2 X2 I1 R1\n", r"^line 1: an arc by its centre \(I, J\) or by its radius \(R\), "
                              r"not both$"),
            ("G1 X1 R2\n", r"^line 1: I, J and R belong to arcs \(G2, G3\), not to G1$"),
            ("G1.5 X1\n", r"^line 1: unknown code G1\.5$"),
            ("G1 X1 X2\n", r"^line 1: X given twice \(X1 and X2\)$"),
            ("G6 X1\n", r"^line 1: unknown code G6$"),
            ("G21\n", r"^line 1: G21: this program is read in lattice units \(steps\), "
                      r"without G20/G21$"),
            ("G18\n", r"^line 1: G18: only the XY plane \(G17\) is supported$"),
            ("G1 G2 X1\n", r"^line 1: two motion codes in one block \(G1 and G2\)$"),
            ("M5.5\n", r"^line 1: unknown code M5\.5$"),
            ("M62\n", r"^line 1: unknown code M62$"),
            ("X1\n", r"^line 1: coordinates without a motion code \(G0, G1, G2 or G3\)$"),
            ("G1 X1 I2\n", r"^line 1: I, J and R belong to arcs \(G2, G3\), not to G1$"),
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
