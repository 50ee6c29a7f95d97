"""A G-code reader: the text of a program in, its blocks and its moves out.

The reader has two layers, so that a machine controller can take over either one:

* :func:`parse` reads the text into :class:`Block` objects: the words of each line (a letter
  and an exact number), its comment, its line number. Comments are ``( ... )`` and ``;`` to the
  end of the line; ``%`` lines and blank lines are skipped; ``N`` words are sequence numbers.
  It knows nothing of what the words mean beyond their syntax.
* :func:`interpret` runs the modal state machine over the blocks and returns the
  :class:`Move` objects: rapid moves (G0), lines (G1) and arcs (G2 clockwise, G3
  counter-clockwise, the centre given by ``I`` and ``J`` relative to the start), each with its
  start and end in absolute coordinates and the cutter-radius compensation in effect (G41 left,
  G42 right, G40 off).

Numbers are exact (:class:`fractions.Fraction`): the reader never rounds. Distances are in the
program's units; this project's programs are in lattice units (steps), and the reader accepts
exactly what it can interpret: G0 G1 G2 G3, G17, G40 G41 G42, G90 G91, the words X Y I J, F
(feed, recorded), D (offset number, recorded), N, and M2 M30 (program end). Anything else is
refused with a :exc:`GCodeError` naming the line, as is every malformed line. Units (G20/G21),
arcs by radius (``R``) and the other planes are left to the controller that extends this
reader.
"""

import re
from dataclasses import dataclass, field
from fractions import Fraction

__all__ = ["GCodeError", "Word", "Block", "Move", "Program", "parse", "interpret", "read"]


class GCodeError(ValueError):
    """A program the reader refuses: the message names the line.

    Attributes
    ----------
    line : :class:`int`
        The line number (from 1).
    reason : :class:`str`
        What is wrong, without the line number.
    """

    def __init__(self, line, reason, *, name=None):
        self.line = line
        self.reason = reason
        self.name = name
        where = f"{name}:{line}" if name else f"line {line}"
        super().__init__(f"{where}: {reason}")


@dataclass(frozen=True)
class Word:
    """One word: a letter (upper case) and its number, with the text as written."""
    letter: str
    value: Fraction
    text: str

    @property
    def code(self):
        """The value as an integer code (``G1``, ``M30``) or ``None`` when it is not one."""
        return int(self.value) if self.value.denominator == 1 else None


@dataclass(frozen=True)
class Block:
    """One line of the program: its number (from 1), its words in order, its comment."""
    line: int
    words: tuple
    comment: str = ""

    def codes(self, letter):
        """The words with ``letter`` (``"G"``, ``"M"``)."""
        return [word for word in self.words if word.letter == letter]

    def value(self, letter):
        """The number of the word with ``letter`` (at most one), or ``None``."""
        for word in self.words:
            if word.letter == letter:
                return word.value
        return None


@dataclass(frozen=True)
class Move:
    """One move in absolute coordinates.

    ``kind`` is ``"rapid"``, ``"line"`` or ``"arc"``; ``start`` and ``end`` are ``(x, y)``;
    for an arc ``centre`` is ``(x, y)`` and ``cw`` says clockwise; ``side`` is the cutter-radius
    compensation in effect (``"left"``, ``"right"`` or ``None``); ``line`` is the program line.
    """
    line: int
    kind: str
    start: tuple
    end: tuple
    centre: tuple = None
    cw: bool = False
    side: str = None
    feed: Fraction = None


@dataclass(frozen=True)
class Program:
    """A program read: its blocks and its moves."""
    blocks: tuple
    moves: tuple
    name: str = None


_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)"
_WORD = re.compile(rf"\s*([A-Za-z])\s*({_NUMBER})")


def _strip_comments(text, number, name):
    """The line without its comments, and the comments' text."""
    code, comments = [], []
    i = 0
    while i < len(text):
        ch = text[i]
        if ch == "(":
            end = text.find(")", i + 1)
            if end < 0:
                raise GCodeError(number, "a comment opened with '(' is not closed", name=name)
            inner = text[i + 1:end]
            if "(" in inner:
                raise GCodeError(number, "comments do not nest", name=name)
            comments.append(inner.strip())
            code.append(" ")
            i = end + 1
        elif ch == ")":
            raise GCodeError(number, "')' closes no comment", name=name)
        elif ch == ";":
            comments.append(text[i + 1:].strip())
            break
        else:
            code.append(ch)
            i += 1
    return "".join(code), " ".join(c for c in comments if c)


def parse(text, *, name=None):
    """Read the text of a program into its blocks (syntax only).

    Parameters
    ----------
    text : :class:`str`
        The program.
    name : :class:`str`
        The file name, for messages.

    Returns
    -------
    list of :class:`Block`
        One per line that holds a word (comment-only, blank and ``%`` lines are skipped).

    Raises
    ------
    :exc:`GCodeError`
        For a malformed line: text that is not a word, an unclosed comment.
    """
    if not isinstance(text, str):
        raise TypeError(f"Program text must be a string, not {text!r}")
    blocks = []
    for number, raw in enumerate(text.splitlines(), start=1):
        if raw.strip() == "%":
            continue
        code, comment = _strip_comments(raw, number, name)
        words = []
        position = 0
        stripped = code.rstrip()
        while position < len(stripped):
            match = _WORD.match(stripped, position)
            if match is None:
                rest = stripped[position:].strip()
                raise GCodeError(number, f"cannot read {rest.split()[0]!r}: a word is a "
                                         f"letter and a number", name=name)
            letter, digits = match.group(1).upper(), match.group(2)
            words.append(Word(letter, Fraction(digits), f"{letter}{digits}"))
            position = match.end()
        if words:
            blocks.append(Block(number, tuple(words), comment))
    return blocks


_MOTION = {0: "rapid", 1: "line", 2: "arc", 3: "arc"}
_GROUPS = {0: "motion", 1: "motion", 2: "motion", 3: "motion", 17: "plane", 40: "compensation",
           41: "compensation", 42: "compensation", 90: "distance", 91: "distance"}
_LETTERS = set("GMNXYIJFD")
_ADVICE = {20: "units (G20/G21) are not read yet: write the program in lattice units",
           21: "units (G20/G21) are not read yet: write the program in lattice units",
           18: "only the XY plane (G17) is supported", 19: "only the XY plane (G17) is supported"}


@dataclass
class _State:
    position: tuple = (Fraction(0), Fraction(0))
    motion: int = None
    absolute: bool = True
    side: str = None
    feed: Fraction = None
    ended: bool = False
    offset: Fraction = None
    extra: dict = field(default_factory=dict)


def interpret(blocks, *, start=(0, 0), name=None):
    """Run the blocks through the modal state; return the moves.

    The position starts at ``start`` (the origin by default); motion, distance (G90 absolute,
    the default, or G91 incremental) and compensation are modal.

    Raises
    ------
    :exc:`GCodeError`
        For a word the reader does not interpret, two codes of one modal group in a block,
        a word given twice, coordinates without a motion mode, an arc without ``I``/``J``, a
        block after the program's end, or a code without an integer value.
    """
    state = _State(position=(Fraction(start[0]), Fraction(start[1])))
    moves = []
    for block in blocks:
        line = block.line

        def fail(reason):
            raise GCodeError(line, reason, name=name)

        if state.ended:
            fail("a block after the end of the program (M2/M30)")
        seen = {}
        groups = {}
        for word in block.words:
            if word.letter not in _LETTERS:
                if word.letter == "R":
                    fail(f"arcs by radius ({word.text}) are not read yet: give the centre with I "
                         f"and J")
                fail(f"unknown word {word.text}")
            if word.letter in "GM":
                if word.code is None:
                    fail(f"{word.text}: a code must be an integer")
                continue
            if word.letter in seen:
                fail(f"{word.letter} given twice ({seen[word.letter]} and {word.text})")
            seen[word.letter] = word.text
        for word in block.codes("G"):
            code = word.code
            if code not in _GROUPS:
                fail(_ADVICE.get(code, f"unknown code {word.text}"))
            group = _GROUPS[code]
            if group in groups:
                fail(f"two {group} codes in one block ({groups[group]} and {word.text})")
            groups[group] = word.text
        for word in block.codes("M"):
            if word.code not in (2, 30):
                fail(f"unknown code {word.text}")
            state.ended = True

        for word in block.codes("G"):
            code = word.code
            if code in _MOTION:
                state.motion = code
            elif code == 90:
                state.absolute = True
            elif code == 91:
                state.absolute = False
            elif code == 40:
                state.side = None
            elif code == 41:
                state.side = "left"
            elif code == 42:
                state.side = "right"
        if block.value("F") is not None:
            if block.value("F") <= 0:
                fail(f"the feed must be positive, not {seen['F']}")
            state.feed = block.value("F")
        if block.value("D") is not None:
            state.offset = block.value("D")

        x, y = block.value("X"), block.value("Y")
        i, j = block.value("I"), block.value("J")
        if x is None and y is None and i is None and j is None:
            continue
        if state.motion is None:
            fail("coordinates without a motion code (G0, G1, G2 or G3)")
        x0, y0 = state.position
        if state.absolute:
            end = (x0 if x is None else x, y0 if y is None else y)
        else:
            end = (x0 + (x or 0), y0 + (y or 0))
        kind = _MOTION[state.motion]
        if kind != "arc":
            if i is not None or j is not None:
                fail(f"I and J belong to arcs (G2, G3), not to G{state.motion}")
            moves.append(Move(line, kind, (x0, y0), end, side=state.side, feed=state.feed))
        else:
            if i is None and j is None:
                fail(f"G{state.motion} needs the centre: I and J (relative to the start)")
            centre = (x0 + (i or 0), y0 + (j or 0))
            moves.append(Move(line, "arc", (x0, y0), end, centre=centre,
                              cw=state.motion == 2, side=state.side, feed=state.feed))
        state.position = end
    return moves


def read(text, *, name=None, start=(0, 0)):
    """:func:`parse` and :func:`interpret` a program; return the :class:`Program`."""
    blocks = parse(text, name=name)
    return Program(tuple(blocks), tuple(interpret(blocks, start=start, name=name)), name)
