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

Numbers are exact (:class:`fractions.Fraction`): the reader never rounds, except where an arc
given by its radius needs a square root (its centre is then exact to 40 digits). It accepts
exactly what it can interpret: G0 G1 G2 G3 (arcs by centre, ``I`` and ``J`` relative to the
start, or by radius ``R``, negative for more than a half turn; a full circle by ``I J`` with
the end exactly on the start, and only then), G17, G40 G41 G42, G90 G91, the words X Y I J R, F
(feed, recorded), D (offset number, recorded), N, and M2 M30 (program end). Anything else is
refused with a :exc:`GCodeError` naming the line, as is every malformed line.

Units: with ``units=None`` (``kontur trace profile``) a program is in lattice units (steps) and
G20/G21 are refused; with ``units="mm"`` (the machine controller, ``kontur run``) G21
(millimetres) is the default and G20 switches to inches, and every coordinate and feed of the
moves is given in millimetres (per minute); a feed move (G1, G2, G3) before any F is then
refused, as LinuxCNC refuses it ("Cannot do g1 with zero feed rate").
"""

import decimal
import math
import re
import sys
from dataclasses import dataclass, field
from fractions import Fraction

__all__ = ["GCodeError", "Word", "Block", "Move", "Program", "parse", "interpret", "read",
           "sweep", "modal_state"]


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
    An arc is a full circle exactly when its programmed end is its start (``full``), as
    LinuxCNC decides: an arc whose end is a hair from its start is that hair of a turn, never a
    whole one, however the ends round.
    """
    line: int
    kind: str
    start: tuple
    end: tuple
    centre: tuple = None
    cw: bool = False
    side: str = None
    feed: Fraction = None

    @property
    def full(self):
        """An arc that is a full circle: its programmed end is its start, exactly."""
        return self.kind == "arc" and tuple(self.end) == tuple(self.start)

    @property
    def sweep(self):
        """An arc's programmed sweep (radians, in the direction of motion): in (0, 2π) or
        2π for a full circle, 0 for an end on the start's ray short of a full circle."""
        return sweep(self.start, self.end, self.centre, self.cw, full=self.full)


@dataclass(frozen=True)
class Program:
    """A program read: its blocks and its moves."""
    blocks: tuple
    moves: tuple
    name: str = None


def sweep(start, end, centre, cw, *, full):
    """The sweep (radians) of an arc about ``centre`` from ``start`` to ``end``, clockwise
    with ``cw``: 2π when ``full``, else in [0, 2π) (0 when the end lies on the start's ray).
    The side the end lies on is decided exactly (for exact numbers), the angle in floating
    point (of the two products scaled to the larger, so that numbers of any size fit)."""
    if full:
        return 2 * math.pi
    sx, sy = start[0] - centre[0], start[1] - centre[1]
    ex, ey = end[0] - centre[0], end[1] - centre[1]
    cross = sx * ey - sy * ex
    dot = sx * ex + sy * ey
    if cw:
        cross = -cross
    if cross == 0:
        return 0.0 if dot > 0 else math.pi
    scale = max(abs(cross), abs(dot))
    angle = math.atan2(float(cross / scale), float(dot / scale))
    if cross > 0:
        return max(angle, 0.0)
    return min(angle + 2 * math.pi, math.nextafter(2 * math.pi, 0))


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
            try:
                value = Fraction(digits)
            except ValueError:                 # beyond Python's int string limit
                raise GCodeError(number, f"the number of {letter} has {len(digits)} "
                                         f"characters, more than the "
                                         f"{sys.get_int_max_str_digits()} digits a number may "
                                         f"have", name=name) from None
            words.append(Word(letter, value, f"{letter}{digits}"))
            position = match.end()
        if words:
            blocks.append(Block(number, tuple(words), comment))
    return blocks


_MOTION = {0: "rapid", 1: "line", 2: "arc", 3: "arc"}
_GROUPS = {0: "motion", 1: "motion", 2: "motion", 3: "motion", 17: "plane", 20: "units",
           21: "units", 40: "compensation", 41: "compensation", 42: "compensation",
           90: "distance", 91: "distance"}
_LETTERS = set("GMNXYIJRFD")
_LATTICE = "this program is read in lattice units (steps), without G20/G21"
_ADVICE = {18: "only the XY plane (G17) is supported", 19: "only the XY plane (G17) is supported"}
#: Millimetres per unit of each units code.
_SCALE = {20: Fraction(254, 10), 21: Fraction(1)}
UNITS = (None, "mm")


def _sqrt(value):
    """The square root of a non-negative Fraction, to 40 significant digits."""
    with decimal.localcontext() as context:
        context.prec = 40
        root = (decimal.Decimal(value.numerator) / decimal.Decimal(value.denominator)).sqrt()
    return Fraction(root)


def _radius_centre(start, end, radius, cw, fail):
    """The centre of the arc from ``start`` to ``end`` of signed ``radius`` (RS274: positive
    for at most a half turn, negative for more)."""
    (x0, y0), (x1, y1) = start, end
    dx, dy = x1 - x0, y1 - y0
    chord2 = dx * dx + dy * dy
    if radius == 0:
        fail("an arc of radius zero (R0)")
    if chord2 == 0:
        fail("an arc by radius (R) cannot end where it starts: give a full circle by I and J")
    rest = radius * radius - chord2 / 4
    if rest < 0:
        if -rest > radius * radius * Fraction(1, 10 ** 12):
            fail(f"the radius {float(abs(radius)):g} is less than half the distance to the end "
                 f"({float(_sqrt(chord2)) / 2:g})")
        rest = Fraction(0)
    h_over_d = _sqrt(rest / chord2)                     # h / d
    side = (1 if cw else -1) * (1 if radius > 0 else -1)  # +1: the centre right of the chord
    return (x0 + dx / 2 + side * h_over_d * dy, y0 + dy / 2 - side * h_over_d * dx)


@dataclass
class _State:
    position: tuple = (Fraction(0), Fraction(0))
    motion: int = None
    absolute: bool = True
    side: str = None
    feed: Fraction = None
    ended: bool = False
    offset: Fraction = None
    scale: Fraction = Fraction(1)
    extra: dict = field(default_factory=dict)


def modal_state(start=(0, 0)):
    """A fresh modal state at ``start`` (the reader's own, as :func:`interpret` begins with), to
    be carried from one call of :func:`interpret` to the next by a reader that takes a program
    line by line (``kontur serve``)."""
    return _State(position=(Fraction(start[0]), Fraction(start[1])))


def interpret(blocks, *, start=(0, 0), name=None, units=None, state=None):
    """Run the blocks through the modal state; return the moves.

    ``state`` (from :func:`modal_state`) is the modal state to start from, updated in place
    (``start`` is then its position): a program read line by line reads as it does whole.

    The position starts at ``start`` (the origin by default, in the moves' units); motion,
    distance (G90 absolute, the default, or G91 incremental), units and compensation are
    modal. ``units`` is ``None`` (lattice units, no G20/G21) or ``"mm"`` (G21 by default, G20
    inches; the moves in millimetres).

    Raises
    ------
    :exc:`GCodeError`
        For a word the reader does not interpret, two codes of one modal group in a block,
        a feed move (G1, G2, G3) with no F in force (with ``units``, as LinuxCNC refuses it),
        a word given twice, coordinates without a motion mode, an arc without its centre
        (``I``/``J`` or ``R``, not both), an arc by radius that cannot reach its end, a block
        after the program's end, or a code without an integer value.
    """
    if units not in UNITS:
        raise ValueError(f"Units must be one of {', '.join(map(repr, UNITS))}, not {units!r}")
    state = modal_state(start) if state is None else state
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
            if code in _SCALE and units is None:
                fail(f"{word.text}: {_LATTICE}")
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
            elif code in _SCALE:
                state.scale = _SCALE[code]
        scale = state.scale
        if block.value("F") is not None:
            if block.value("F") <= 0:
                fail(f"the feed must be positive, not {seen['F']}")
            state.feed = block.value("F") * scale
        if block.value("D") is not None:
            state.offset = block.value("D")

        x, y, i, j, r = (None if block.value(letter) is None else block.value(letter) * scale
                         for letter in "XYIJR")
        if x is None and y is None and i is None and j is None and r is None:
            continue
        if state.motion is None:
            fail("coordinates without a motion code (G0, G1, G2 or G3)")
        x0, y0 = state.position
        if state.absolute:
            end = (x0 if x is None else x, y0 if y is None else y)
        else:
            end = (x0 + (x or 0), y0 + (y or 0))
        kind = _MOTION[state.motion]
        if kind != "rapid" and state.feed is None and units is not None:
            fail(f"G{state.motion} with no feed rate: give an F before the first feed move "
                 f"(G1, G2, G3)")
        if kind != "arc":
            if i is not None or j is not None or r is not None:
                fail(f"I, J and R belong to arcs (G2, G3), not to G{state.motion}")
            moves.append(Move(line, kind, (x0, y0), end, side=state.side, feed=state.feed))
        else:
            if r is not None:
                if i is not None or j is not None:
                    fail("an arc by its centre (I, J) or by its radius (R), not both")
                centre = _radius_centre((x0, y0), end, r, state.motion == 2, fail)
            elif i is None and j is None:
                fail(f"G{state.motion} needs the centre: I and J (relative to the start) or R")
            else:
                centre = (x0 + (i or 0), y0 + (j or 0))
            moves.append(Move(line, "arc", (x0, y0), end, centre=centre,
                              cw=state.motion == 2, side=state.side, feed=state.feed))
        state.position = end
    return moves


def read(text, *, name=None, start=(0, 0), units=None):
    """:func:`parse` and :func:`interpret` a program; return the :class:`Program`."""
    blocks = parse(text, name=name)
    return Program(tuple(blocks), tuple(interpret(blocks, start=start, name=name, units=units)),
                   name)
