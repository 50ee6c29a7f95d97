"""A G-code reader: the text of a program in, its blocks, moves and events out, every word
with LinuxCNC's meaning (docs/gcode.md has the table; tests/test_gcode_rs274.py holds the
reader against LinuxCNC's own interpreter, ``rs274``).

The reader has two layers, so that a machine controller can take over either one:

* :func:`parse` reads the text into :class:`Block` objects: the words of each line (a letter
  and an exact number, or an expression to evaluate when the line runs), its parameter
  settings, its O-word, its comment and ``(MSG,...)``/``(DEBUG,...)``, its line number, as
  LinuxCNC reads a line (:mod:`kontur.gcode_expr`: spaces removed, letters case-blind, a
  leading ``/`` a block delete). Comment-only, blank and ``%`` lines are skipped.
* :func:`interpret` runs LinuxCNC's interpreter over the blocks: the modal state (motion,
  plane, units, distance and arc distance modes, compensation, tool length, work coordinate
  systems G54-G59.3 with G10 L2/L20 and G92, path control, feed and retract modes), the
  parameters (numbered, named, global), the O-word control flow (subroutines, if, loops), each
  block's words in LinuxCNC's order of execution. It returns the :class:`Move` objects (rapid
  moves, lines, arcs, dwells) in machine coordinates, with the cutter-radius compensation in
  effect and its radius where the program gives it, and gathers the :class:`Event` objects
  (tools, spindle, coolant, pauses, messages).

Numbers are exact (:class:`fractions.Fraction`): the reader never rounds, except where an arc
given by its radius needs a square root (its centre is then exact to 40 digits) and in the
expressions' functions (LinuxCNC's doubles). Anything it cannot interpret is refused with a
:exc:`GCodeError` naming the line and the word, as is every malformed line. Z is read: the
moves carry it, and :func:`planar` refuses a move that changes it.

Units: with ``units=None`` (``kontur trace profile``) a program is in lattice units (steps) and
G20/G21 are refused; with ``units="mm"`` (the machine controller, ``kontur run``) G21
(millimetres) is the default and G20 switches to inches, and every coordinate and feed of the
moves is given in millimetres (per minute); a feed move (G1, G2, G3) before any F is then
refused, as LinuxCNC refuses it ("Cannot do g1 with zero feed rate").
"""

import decimal
import math
import re
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import NamedTuple

from kontur.gcode_expr import Evaluator, ExpressionError, read_code, split_line

__all__ = ["GCodeError", "Word", "Block", "Move", "Event", "Program", "parse", "interpret",
           "read", "Stream", "sweep", "planar", "read_tool_table", "ToolTable", "ToolTableError",
           "Z_REFUSAL", "Z_COMPENSATED", "plane_arc"]


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


class Word(NamedTuple):
    """One word: a letter (upper case) and its number (or an expression tree, evaluated when
    its line runs), with the text as written."""
    letter: str
    value: Fraction
    text: str

    @property
    def code(self):
        """The value as an integer code (``G1``, ``M30``) or ``None`` when it is not one (or
        not a number but an expression)."""
        if not isinstance(self.value, Fraction):
            return None
        return int(self.value) if self.value.denominator == 1 else None


@dataclass(frozen=True)
class Block:
    """One line of the program: its number (from 1), its words in order (a word's value is a
    Fraction, or an expression tree evaluated when the line runs), its comment; ``delete``
    for a line starting with ``/``, its O-word (``(label, keyword, arguments)``) or ``None``,
    its parameter settings (``(reference, value)``), its ``(MSG,...)`` text or ``None``."""
    line: int
    words: tuple
    comment: str = ""
    delete: bool = False
    oword: tuple = None
    settings: tuple = ()
    message: str = None

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

    ``kind`` is ``"rapid"``, ``"line"``, ``"arc"`` or ``"dwell"`` (G4: ``seconds``, ``start``
    and ``end`` where the machine waits); ``start`` and ``end`` are ``(x, y)`` in machine
    coordinates (the work offsets applied); ``z`` is the Z where the move ends (machine
    coordinates; ``None`` before the program's first Z word);
    for an arc ``centre`` is ``(x, y)`` and ``cw`` says clockwise; ``side`` is the cutter-radius
    compensation in effect (``"left"``, ``"right"`` or ``None``); ``line`` is the program line.
    An arc in the XZ or YZ plane (G18, G19: ``plane`` 18 or 19, 17 for every other move) has
    ``start_z``, the Z it starts at, and its ``centre`` is ``(x, y, z)`` (its coordinate on
    the plane's normal axis the start's); :attr:`in_plane` gives it in the plane's own
    coordinates (LinuxCNC's: first and second axis Z, X in G18, Y, Z in G19), where
    ``cw`` says clockwise as for G17 arcs.
    ``turns`` (G2/G3 P) is how many times an arc passes its end's angle: ``turns - 1`` whole
    turns, then its sweep (:attr:`sweep`, one turn's) to the end, the normal axis moving
    evenly over the whole angle (:attr:`total_sweep`).
    An arc is a full circle exactly when its programmed end is its start (``full``), as
    LinuxCNC decides: an arc whose end is a hair from its start is that hair of a turn, never a
    whole one, however the ends round. ``radius`` (mm) is the cutter radius the program
    itself gives a compensated move (G41.1/G42.1 D, or a D word or the loaded tool looked up in
    the tool table), with ``radius_source`` saying which; ``None``: the machine's.
    """
    line: int
    kind: str
    start: tuple
    end: tuple
    centre: tuple = None
    cw: bool = False
    side: str = None
    feed: Fraction = None
    z: Fraction = None
    radius: Fraction = None
    radius_source: str = None
    seconds: Fraction = None
    plane: int = 17
    start_z: Fraction = None
    turns: int = 1

    @property
    def in_plane(self):
        """The move in its plane's coordinates: a G17 arc as it is; a G18 or G19 arc as a G17
        one whose ``start``, ``end`` and ``centre`` are the plane's first and second axis and
        whose ``start_z`` and ``z`` are its normal axis (:data:`PLANE_AXES`)."""
        if self.plane == 17:
            return self
        first, second, normal = PLANE_AXES[self.plane]
        start = (*self.start, self.start_z)
        end = (*self.end, self.z)
        return replace(self, start=(start[first], start[second]),
                       end=(end[first], end[second]),
                       centre=(self.centre[first], self.centre[second]), plane=17,
                       start_z=start[normal], z=end[normal])

    @property
    def total_sweep(self):
        """The whole angle an arc turns (radians): its ``turns - 1`` whole turns and
        :attr:`sweep`."""
        return (self.turns - 1) * 2 * math.pi + self.sweep

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
class Event:
    """Something a program does besides moving: ``kind`` is ``"tool"`` (T: a tool selected),
    ``"tool_change"`` (M6), ``"spindle"`` (M3, M4, M5), ``"speed"`` (S), ``"coolant"`` (M7,
    M8, M9), ``"tool_length"`` (G43, G43.1, G49), ``"pause"`` (M0, M1) or ``"message"``
    (``(MSG,...)``); ``text`` says it (``"M3 S1000"``), ``value`` its number (the tool, the
    speed) or ``None``; ``move`` is how many moves came before it."""
    line: int
    kind: str
    text: str
    value: object = None
    move: int = 0

    def as_dict(self):
        return {"line": self.line, "kind": self.kind, "text": self.text,
                "value": None if self.value is None else float(self.value),
                "after_move": self.move}


@dataclass(frozen=True)
class Program:
    """A program read: its blocks, its moves and its events (:class:`Event`)."""
    blocks: tuple
    moves: tuple
    name: str = None
    events: tuple = ()


#: The machine axes (0 X, 1 Y, 2 Z) of each plane's first and second axis and of its normal,
#: as LinuxCNC's canonical arcs name them (ARC_FEED's first and second coordinates).
PLANE_AXES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}


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


def _message(comments):
    """LinuxCNC's message of a line: ``("msg", text)`` for ``(MSG,text)``, ``("debug",
    text)`` for ``(DEBUG,text)`` (its parameters shown with their values when it runs), or
    ``None``."""
    for comment in comments:
        stripped = comment.lstrip()
        if stripped[:4].lower() == "msg,":
            return "msg", stripped[4:]
        if stripped[:6].lower() == "debug,":
            return "debug", stripped[6:]
    return None


_DEBUG = re.compile(r"#<[^>]*>|#\d+")


def parse(text, *, name=None):
    """Read the text of a program into its blocks (syntax only).

    Every line is read as LinuxCNC reads it: a leading ``/`` marks a block delete, comments
    go, spaces and tabs are removed, letters are case-blind. A ``%`` line opens the program
    and a second one ends it (lines after it are not read).

    Parameters
    ----------
    text : :class:`str`
        The program.
    name : :class:`str`
        The file name, for messages.

    Returns
    -------
    list of :class:`Block`
        One per line that holds a word, an O-word, a parameter setting or a ``(MSG,...)``
        (comment-only, blank and ``%`` lines are skipped).

    Raises
    ------
    :exc:`GCodeError`
        For a malformed line: text that is not a word, an unclosed comment.
    """
    if not isinstance(text, str):
        raise TypeError(f"Program text must be a string, not {text!r}")
    blocks = []
    percent = False
    for number, raw in enumerate(text.splitlines(), start=1):
        if raw.strip() == "%":
            if percent:
                break
            percent = True
            continue
        try:
            delete, code, comments = split_line(raw)
            oword, words, settings = read_code(code) if code else (None, [], [])
        except ExpressionError as error:
            raise GCodeError(number, str(error), name=name) from None
        message = _message(comments) if comments else None
        if words or oword or settings or message is not None:
            blocks.append(Block(number, tuple(Word(word[0].upper(), word[1], word[2]) for word in words),
                                " ".join(c.strip() for c in comments if c.strip()),
                                delete, oword, tuple(settings), message))
    return blocks


#: The canned cycles kontur runs (code times ten), as LinuxCNC's interp_cycles.cc makes them
#: (:meth:`_Interpreter.canned_cycle`), and the words each needs the first time (after another
#: motion mode) beside R and Z: P the dwell, Q the peck.
_CYCLES = {730: "Q", 810: "", 820: "P", 830: "Q", 850: "", 890: "P"}
#: G83's and G73's back-off above the last depth before the next peck: 0.010 inch (LinuxCNC's
#: G83_RAPID_DELTA), in millimetres.
PECK_CLEARANCE = Fraction(254, 1000)

#: Modal groups of the G codes kontur takes, by code times ten (G91.1 is 911), as LinuxCNC's.
_G_GROUPS = {0: "motion", 10: "motion", 20: "motion", 30: "motion", 800: "motion",
             **{code: "motion" for code in _CYCLES},
             40: "non-modal", 100: "non-modal", 280: "non-modal", 281: "non-modal",
             300: "non-modal", 301: "non-modal", 530: "non-modal", 920: "non-modal",
             921: "non-modal", 922: "non-modal", 923: "non-modal",
             170: "plane", 180: "plane", 190: "plane", 200: "units", 210: "units",
             400: "compensation", 410: "compensation", 420: "compensation",
             411: "compensation", 421: "compensation",
             430: "tool length", 431: "tool length", 490: "tool length",
             **{code: "coordinate system" for code in (540, 550, 560, 570, 580, 590, 591, 592,
                                                       593)},
             610: "path control", 611: "path control", 640: "path control",
             900: "distance", 910: "distance", 901: "arc distance", 911: "arc distance",
             940: "feed mode", 980: "retract mode", 990: "retract mode"}
_MOTION = {0: "rapid", 10: "line", 20: "arc", 30: "arc"}
_PLANE_NAMES = {17: "XY", 18: "XZ", 19: "YZ"}
_CANNED = ("spindle-synchronised and oriented cycles (G74, G84 tapping, G76 threading, G86-G88 "
           "boring with the spindle stopped) are not supported: the drilling and boring cycles "
           "G73, G81-G83, G85 and G89 are")
#: G codes LinuxCNC knows that kontur refuses, and why.
_G_REFUSED = {**{code: "the UVW planes (G17.1, G18.1, G19.1) are not supported: arcs are in "
                       "XY (G17), XZ (G18) or YZ (G19)" for code in (171, 181, 191)},
              930: "inverse-time feed (G93) is not supported: give feeds in units a minute "
                   "(G94)",
              950: "feed per revolution (G95) is not supported: give feeds in units a minute "
                   "(G94)",
              50: "splines (G5) are not supported", 51: "splines (G5.1) are not supported",
              52: "NURBS (G5.2) are not supported", 70: "lathe diameter mode (G7) is not "
              "supported", 330: "spindle-synchronised motion (G33) is not supported",
              331: "rigid tapping (G33.1) is not supported",
              432: "G43.2 (added tool length) is not supported",
              **{code: "probing (G38.x) is not supported" for code in (382, 383, 384, 385)},
              **{code: _CANNED for code in (740, 760, 840, 860, 870, 880)}}
_M_GROUPS = {0: "stopping", 1: "stopping", 2: "stopping", 30: "stopping", 6: "tool change",
             61: "tool change",
             3: "spindle", 4: "spindle", 5: "spindle", 7: "coolant", 8: "coolant",
             9: "coolant"}
_LETTERS = set("DFGHIJKLMNPQRSTXYZ@^")
_AXES_NOT_HERE = set("ABCUVW")
_LATTICE = "this program is read in lattice units (steps), without G20/G21"
#: Millimetres per unit of each units code.
_SCALE = {200: Fraction(254, 10), 210: Fraction(1)}
UNITS = (None, "mm")
#: Why a move that changes Z is refused (:func:`planar`).
Z_REFUSAL = ("Z moves need the third axis, which this board's controller does not have "
             "(the icebreaker-z's and the ulx3s's have it)")

#: A 3-axis board's refusal of Z moves in a program with cutter-radius compensation.
Z_COMPENSATED = ("Z moves in a program with cutter-radius compensation (G41/G42), whose "
                 "contours the equidistant engine traces on X and Y only")
#: Blocks a program may run at most (loops and subroutines): about a minute of reading.
MAX_BLOCKS = 5_000_000
#: Subroutine calls nested at most.
MAX_CALLS = 100


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


class _Frame:
    """A subroutine call in progress (the main program is the first)."""

    def __init__(self, back=None, label=None, saved=None):
        self.back, self.label, self.saved = back, label, saved
        self.named = {}
        self.repeats = {}


class _Structure:
    """The O-words of a program matched: subroutines by label, and for each O-word line its
    partners (an ``if``'s next branch and end, a loop's end and head)."""

    def __init__(self, blocks, fail):
        self.subs, self.links = {}, {}
        stack = []
        for index, block in enumerate(blocks):
            if block.oword is None:
                continue
            label, keyword, _ = block.oword
            name = f"o{label}"
            top = stack[-1] if stack else None

            def close(kinds, opener):
                if top is None or top[0] not in kinds or top[1] != label:
                    fail(block.line, f"{name} {keyword} closes no {name} {opener}")
                stack.pop()
                return top
            if keyword == "sub":
                if stack:
                    fail(block.line, f"{name} sub inside {'o' + str(top[1])} {top[0]}: define "
                                     f"subroutines at the program's top level")
                if label in self.subs:
                    fail(block.line, f"subroutine {name} defined twice")
                self.subs[label] = index
                stack.append(["sub", label, index, None, block.line])
            elif keyword == "endsub":
                opened = close(("sub",), "sub")
                self.links[opened[2]] = {"end": index}
                self.links[index] = {"sub": opened[2]}
            elif keyword == "return":
                sub = next((entry for entry in reversed(stack) if entry[0] == "sub"), None)
                if sub is None:
                    fail(block.line, f"{name} return outside a subroutine")
                self.links[index] = {"sub": sub[2]}
            elif keyword == "if":
                stack.append(["if", label, index, [index], block.line])
            elif keyword in ("elseif", "else"):
                if top is None or top[0] != "if" or top[1] != label:
                    fail(block.line, f"{name} {keyword} without {name} if")
                top[3].append(index)
            elif keyword == "endif":
                branches = close(("if",), "if")[3] + [index]
                for here, following in zip(branches, branches[1:]):
                    self.links[here] = {"next": following, "end": index}
            elif keyword == "do":
                stack.append(["do", label, index, None, block.line])
            elif keyword == "while":
                if top is not None and top[0] == "do" and top[1] == label:
                    stack.pop()
                    self.links[top[2]] = {"end": index, "kind": "do"}
                    self.links[index] = {"do": top[2]}
                else:
                    stack.append(["while", label, index, None, block.line])
            elif keyword == "endwhile":
                opened = close(("while",), "while")
                self.links[opened[2]] = {"end": index, "kind": "while"}
                self.links[index] = {"head": opened[2]}
            elif keyword == "repeat":
                stack.append(["repeat", label, index, None, block.line])
            elif keyword == "endrepeat":
                opened = close(("repeat",), "repeat")
                self.links[opened[2]] = {"end": index, "kind": "repeat"}
                self.links[index] = {"head": opened[2]}
            elif keyword in ("break", "continue"):
                loop = next((entry for entry in reversed(stack)
                             if entry[0] in ("while", "do", "repeat") and entry[1] == label),
                            None)
                if loop is None:
                    fail(block.line, f"{name} {keyword} outside loop {name}")
                self.links[index] = {"loop": loop[2]}
        if stack:
            kind, label, _, _, line = stack[-1]
            ends = {"sub": "endsub", "if": "endif", "while": "endwhile", "do": "while",
                    "repeat": "endrepeat"}
            fail(line, f"o{label} {kind} is not closed (no o{label} {ends[kind]})")


_PREDEFINED = ("_x", "_y", "_z", "_metric", "_imperial", "_absolute", "_incremental",
               "_current_tool", "_selected_tool", "_feed", "_rpm", "_coord_system",
               "_value", "_value_returned", "_line", "_motion_mode", "_plane")


class _Interpreter:
    """The modal state of LinuxCNC's interpreter, its parameters and O-word control flow,
    over a program's blocks: :meth:`run` gives the moves and events."""

    def __init__(self, blocks, *, start, name, units, tools, parameters, block_delete):
        self.blocks = list(blocks)
        self.name, self.units, self.tools = name, units, tools
        self.block_delete = block_delete
        zero = Fraction(0)
        self.pos = [Fraction(start[0]), Fraction(start[1]), zero]
        self.z_given = False
        self.motion = None
        self.absolute = True
        self.arc_absolute = False
        self.plane = 170
        self.r_plane = True               # G99 (the retract to R), as rs274 starts
        self.cycle = None                 # the canned cycle last made, and its sticky words
        self.cycle_words = {}
        self.cycle_level = None           # the height the series of cycles began at (G98's)
        self.cycle_plane = None           # ... and its plane (G17, G18, G19)
        self.side = None
        self.radius = None
        self.radius_source = None
        self.feed = None
        self.offset = None
        self.scale = Fraction(1)
        self.cs = 1
        self.g5x = {k: [zero, zero, zero] for k in range(1, 10)}
        self.g92 = [zero, zero, zero]
        self.g92_saved = [zero, zero, zero]
        self.g92_on = False
        self.tlo = [zero, zero, zero]         # the tool length offset (G43, G43.1; mm)
        self.home = {28: [zero, zero, zero], 30: [zero, zero, zero]}
        self.selected = 0
        self.tool = 0
        self.speed = zero
        self.numbered = {}
        self.globals = {"_value": zero, "_value_returned": zero}
        for number, value in (parameters or {}).items():
            self.set_numbered(number, Fraction(value))
        self.frames = [_Frame()]
        self.moves, self.events = [], []
        self.line = None
        self.ended = False
        self.m61 = False
        self.evaluate = Evaluator(self.get_numbered, self.get_named, self.exists)

    # ---- errors and parameters ---------------------------------------------------------

    def fail(self, reason, line=None):
        raise GCodeError(self.line if line is None else line, reason, name=self.name)

    def offset_of(self, axis):
        """Where the program's zero of ``axis`` is in machine coordinates: the work offset,
        G92's and the tool length offset (G43, G43.1), as LinuxCNC adds them."""
        return self.g5x[self.cs][axis] + self.g92[axis] + self.tlo[axis]

    def _virtual(self, n):
        """Where numbered parameter ``n`` lives in the state, if it is one of LinuxCNC's
        stored positions and offsets (in the machine's units, millimetres, as LinuxCNC keeps
        them): ``(list, index)``."""
        if 5161 <= n <= 5163:
            return self.home[28], n - 5161
        if 5181 <= n <= 5183:
            return self.home[30], n - 5181
        if 5211 <= n <= 5213:
            return self.g92_saved, n - 5211
        if 5221 <= n <= 5400 and (n - 5221) % 20 < 3:
            return self.g5x[(n - 5221) // 20 + 1], (n - 5221) % 20
        return None

    def get_numbered(self, n):
        place = self._virtual(n)
        if place is not None:
            return place[0][place[1]]
        if n == 5210:
            return Fraction(int(self.g92_on))
        if n == 5220:
            return Fraction(self.cs)
        if n == 5400:
            return Fraction(self.tool)
        if 5420 <= n <= 5422:
            axis = n - 5420
            return (self.pos[axis] - self.offset_of(axis)) / self.scale
        return self.numbered.get(n, Fraction(0))

    def set_numbered(self, n, value):
        place = self._virtual(n)
        if place is not None:
            place[0][place[1]] = value
        elif n == 5220:
            self.fail("#5220 (the coordinate system) is set by G54-G59.3, not by a setting")
        else:
            self.numbered[n] = value

    def get_named(self, name):
        if name.startswith("_"):
            if name in self.globals:
                return self.globals[name]
            if name in _PREDEFINED:
                return self.predefined(name)
            raise ExpressionError(f"named parameter #<{name}> is not defined")
        value = self.frames[-1].named.get(name)
        if value is None:
            raise ExpressionError(f"named parameter #<{name}> is not defined")
        return value

    def exists(self, name):
        if name.startswith("_"):
            return name in self.globals or name in _PREDEFINED
        return name in self.frames[-1].named

    def predefined(self, name):
        metric = self.scale == 1
        values = {"_x": lambda: self.get_numbered(5420), "_y": lambda: self.get_numbered(5421),
                  "_z": lambda: self.get_numbered(5422), "_metric": lambda: int(metric),
                  "_imperial": lambda: int(not metric),
                  "_absolute": lambda: int(self.absolute),
                  "_incremental": lambda: int(not self.absolute),
                  "_current_tool": lambda: self.tool, "_selected_tool": lambda: self.selected,
                  "_feed": lambda: (self.feed or 0) / self.scale, "_rpm": lambda: self.speed,
                  "_coord_system": lambda: 530 + 10 * self.cs if self.cs <= 6 else
                  [591, 592, 593][self.cs - 7],
                  "_line": lambda: self.line or 0,
                  "_motion_mode": lambda: -10 if self.motion is None else self.motion,
                  "_plane": lambda: self.plane}
        return Fraction(values[name]())

    def set_named(self, name, value):
        if name.startswith("_"):
            if name in _PREDEFINED and name not in self.globals:
                self.fail(f"#<{name}> is read-only")
            self.globals[name] = value
        else:
            self.frames[-1].named[name] = value

    def value(self, tree):
        try:
            return self.evaluate(tree)
        except ExpressionError as error:
            self.fail(str(error))

    # ---- the program ---------------------------------------------------------------------

    def run(self):
        blocks = self.blocks
        structure = _Structure(blocks, lambda line, reason: self.fail(reason, line))
        self.structure = structure
        budget = MAX_BLOCKS
        pc = 0
        count = len(blocks)
        while pc < count:
            block = blocks[pc]
            budget -= 1
            if budget < 0:
                self.fail(f"the program runs more than {MAX_BLOCKS:,} blocks (an endless "
                          f"loop?)", block.line)
            if block.delete and self.block_delete:
                pc += 1
                continue
            self.line = block.line
            if block.oword is not None:
                pc = self.control(pc, block)
                continue
            if self.block(block):
                self.ended = True
                break
            pc += 1
        return self.moves

    def condition(self, block):
        label, keyword, arguments = block.oword
        if len(arguments) != 1:
            self.fail(f"o{label} {keyword} needs one condition in [ ]")
        return self.value(arguments[0]) != 0

    def control(self, pc, block):
        """Run an O-word; return the next block's index."""
        label, keyword, arguments = block.oword
        links = self.structure.links
        frame = self.frames[-1]
        if keyword == "sub":
            return links[pc]["end"] + 1
        if keyword in ("endsub", "return"):
            if len(self.frames) == 1:
                self.fail(f"o{label} {keyword} with no call")
            if arguments:
                self.globals["_value"] = self.value(arguments[0])
                self.globals["_value_returned"] = Fraction(1)
            else:                             # LinuxCNC: no value, #<_value> is 0
                self.globals["_value"] = Fraction(0)
                self.globals["_value_returned"] = Fraction(0)
            self.frames.pop()
            for n, value in frame.saved.items():
                self.numbered[n] = value
            return frame.back
        if keyword == "call":
            if label not in self.structure.subs:
                self.fail(f"o{label} call: no subroutine o{label} in this program (kontur reads "
                          f"one file; LinuxCNC would search its subroutine path)")
            if len(self.frames) > MAX_CALLS:
                self.fail(f"o{label} call: more than {MAX_CALLS} calls nested")
            if len(arguments) > 30:
                self.fail(f"o{label} call: more than 30 arguments")
            values = [self.value(argument) for argument in arguments]
            saved = {n: self.numbered.get(n, Fraction(0)) for n in range(1, 31)}
            for n in range(1, 31):
                self.numbered[n] = values[n - 1] if n <= len(values) else Fraction(0)
            self.frames.append(_Frame(pc + 1, label, saved))
            return self.structure.subs[label] + 1
        if keyword == "if":
            index = pc
            while True:
                here = self.blocks[index].oword[1]
                if here in ("if", "elseif"):
                    self.line = self.blocks[index].line
                    if self.condition(self.blocks[index]):
                        return index + 1
                    index = links[index]["next"]
                else:
                    return index + 1
        if keyword in ("elseif", "else"):
            return links[pc]["end"] + 1
        if keyword == "endif" or keyword == "do":
            return pc + 1
        if keyword == "while":
            if "do" in links.get(pc, {}):
                return links[pc]["do"] + 1 if self.condition(block) else pc + 1
            return pc + 1 if self.condition(block) else links[pc]["end"] + 1
        if keyword in ("endwhile", "endrepeat"):
            return links[pc]["head"]
        if keyword == "repeat":
            if pc not in frame.repeats:
                if len(arguments) != 1:
                    self.fail(f"o{label} repeat needs a count in [ ]")
                frame.repeats[pc] = math.floor(self.value(arguments[0]))
            if frame.repeats[pc] <= 0:
                del frame.repeats[pc]
                return links[pc]["end"] + 1
            frame.repeats[pc] -= 1
            return pc + 1
        loop = links[pc]["loop"]
        kind = links[loop]["kind"]
        if keyword == "break":
            frame.repeats.pop(loop, None)
            return links[loop]["end"] + 1
        return links[loop]["end"] if kind == "do" else loop       # continue

    # ---- one block -----------------------------------------------------------------------

    def code(self, word, value):
        """A G or M code as ten times its number (G91.1 is 911)."""
        tenfold = value * 10
        code = round(tenfold)
        if abs(tenfold - code) > Fraction(1, 10 ** 4):
            self.fail(f"unknown code {word.text}")
        return code

    def block(self, block):
        """Run one block; return True at the program's end."""
        values, texts, gcodes, mcodes = {}, {}, [], []
        for word in block.words:
            letter = word.letter
            value = word.value if isinstance(word.value, Fraction) else self.value(word.value)
            if letter == "G":
                gcodes.append((self.code(word, value), word.text))
                continue
            if letter == "M":
                code = self.code(word, value)
                if code % 10:
                    self.fail(f"unknown code {word.text}")
                mcodes.append((code // 10, word.text))
                continue
            if letter in _AXES_NOT_HERE:
                self.fail(f"{word.text}: this controller has the axes X and Y (and reads Z), "
                          f"not {letter}")
            if letter not in _LETTERS:
                self.fail(f"unknown word {word.text}")
            if letter in values:
                self.fail(f"{letter} given twice ({texts[letter]} and {word.text})")
            values[letter] = value
            texts[letter] = word.text
        if block.settings:
            settings = [(reference, self.value(tree)) for reference, tree in block.settings]
            for reference, value in settings:
                if reference[0] == "name":
                    self.set_named(reference[1], value)
                else:
                    try:
                        self.set_numbered(self.evaluate.index(reference[1]), value)
                    except ExpressionError as error:
                        self.fail(str(error))
        groups, gs, ms = {}, {}, {}
        for code, text in gcodes:
            if code in _G_REFUSED:
                self.fail(f"{text}: {_G_REFUSED[code]}")
            group = _G_GROUPS.get(code)
            if group is None:
                self.fail(f"unknown code {text}")
            if code in _SCALE and self.units is None:
                self.fail(f"{text}: {_LATTICE}")
            if group in groups:
                if group == "motion" and 800 in (code, gs[group]):
                    code = code if gs[group] == 800 else gs[group]   # G80 with G0-G3: G0-G3
                else:
                    self.fail(f"two {group} codes in one block ({groups[group]} and {text})")
            groups[group] = text
            gs[group] = code
        mgroups = {}
        for code, text in mcodes:
            group = _M_GROUPS.get(code)
            if group is None:
                self.fail(f"unknown code {text}" if code not in (60,) else
                          f"{text}: a pallet change is not supported")
            if group in mgroups and group != "coolant":
                self.fail(f"two {group} codes in one block ({mgroups[group]} and {text})")
            mgroups[group] = text
            ms.setdefault(group, []).append(code)
        self.m61 = 61 in ms.get("tool change", ())
        if self.m61 and "Q" not in values:
            self.fail("M61 needs Q: the tool now in the spindle")
        self.check_letters(values, texts, gs)
        return self.execute(block, values, texts, gs, ms)

    def check_letters(self, values, texts, gs):
        """Refuse a word no code of the block takes, naming it and the codes that take it."""
        nonmodal = gs.get("non-modal")
        motion = gs.get("motion", self.motion)
        if "P" in values and not (nonmodal in (40, 100) or gs.get("path control") == 640
                                  or motion in (20, 30, 820, 890)):
            self.fail(f"{texts['P']}: no code in this block takes P (G4 dwell, G10, G64, "
                      f"G2/G3 turns, G82/G89 dwell)")
        if "Q" in values and gs.get("path control") != 640 and not self.m61 \
                and motion not in (730, 830):
            self.fail(f"{texts['Q']}: no code in this block takes Q (G64, M61, G73/G83 peck)")
        if "L" in values and nonmodal != 100 and motion not in _CYCLES:
            self.fail(f"{texts['L']}: no code in this block takes L (G10, a canned cycle's "
                      f"repeats)")
        if "H" in values and gs.get("tool length") != 430:
            self.fail(f"{texts['H']}: no code in this block takes H (G43)")
        if nonmodal == 100 and "L" not in values:
            self.fail("G10 needs L (L2 or L20: a work offset)")
        if nonmodal == 40 and "P" not in values:
            self.fail("G4 needs P: the dwell in seconds")

    def event(self, kind, text, value=None):
        self.events.append(Event(self.line, kind, text, value, len(self.moves)))

    def execute(self, block, values, texts, gs, ms):
        scale = self.scale
        if block.message is not None:
            kind, text = block.message
            if kind == "debug":
                text = _DEBUG.sub(lambda m: f"{float(self.debug_value(m.group())):f}", text)
            self.event("message", text)
        if "F" in values:                     # before G20/G21 of the block, as LinuxCNC
            if values["F"] <= 0:
                self.fail(f"the feed must be positive, not {texts['F']}")
            self.feed = values["F"] * scale
        if "S" in values:
            if values["S"] < 0:
                self.fail(f"the spindle speed must not be negative, not {texts['S']}")
            self.speed = values["S"]
            self.event("speed", texts["S"], values["S"])
        if "T" in values:
            tool = values["T"]
            if tool < 0 or tool.denominator != 1:
                self.fail(f"{texts['T']}: a tool number is a whole number")
            self.selected = int(tool)
            self.event("tool", texts["T"], self.selected)
        if self.m61:
            tool = values["Q"]
            if tool < 0 or tool.denominator != 1:
                self.fail(f"M61 {texts['Q']}: a tool number is a whole number")
            self.tool = int(tool)
            self.event("tool_change", f"M61 Q{self.tool}", self.tool)
        elif "tool change" in ms:
            self.tool = self.selected
            self.event("tool_change", f"M6 T{self.selected}", self.selected)
        for code in ms.get("spindle", ()):
            text = f"M{code}" + (f" S{float(self.speed):g}" if code != 5 else "")
            self.event("spindle", text, self.speed if code != 5 else 0)
        for code in ms.get("coolant", ()):
            self.event("coolant", f"M{code}")
        nonmodal = gs.get("non-modal")
        if nonmodal == 40:
            seconds = values["P"]
            if seconds < 0:
                self.fail(f"a dwell must not be negative, not {texts['P']}")
            self.dwell(seconds)
        if "units" in gs:
            self.scale = scale = _SCALE[gs["units"]]
        if "D" in values:
            self.offset = values["D"]
        if "plane" in gs:
            if self.side is not None and gs["plane"] != self.plane:
                self.fail(f"{_code_text(gs, 'plane')} with cutter-radius compensation on: "
                          f"turn it off (G40) before changing the plane")
            self.plane = gs["plane"]
        if "compensation" in gs:
            self.compensation(gs["compensation"], values, texts)
        if "tool length" in gs:
            code = gs["tool length"]
            # The tool length offset shifts the program's zero (offset_of): the machine does
            # not move now, the next position given in the program lands that much higher.
            if code == 430:
                tool = values.get("H", self.tool)
                if tool < 0 or tool.denominator != 1:
                    self.fail(f"G43 {texts.get('H', '')}: a tool number is a whole number")
                tool = int(tool)
                if self.tools is not None and tool not in self.tools:
                    self.fail(f"G43 H{tool}: tool {tool} is not in the tool table")
                length = getattr(self.tools, "lengths", {}).get(tool, Fraction(0))
                self.tlo = [Fraction(0), Fraction(0), length]
                self.event("tool_length", f"G43 H{tool}", tool)
            elif code == 431:
                self.tlo = [values.get(a, Fraction(0)) * scale for a in "XYZ"]
                self.event("tool_length", "G43.1" + "".join(
                    f" {texts[a]}" for a in "XYZ" if a in values), values.get("Z"))
            else:
                self.tlo = [Fraction(0)] * 3
                self.event("tool_length", "G49")
        if "coordinate system" in gs:
            code = gs["coordinate system"]
            self.cs = {540: 1, 550: 2, 560: 3, 570: 4, 580: 5, 590: 6, 591: 7, 592: 8,
                       593: 9}[code]
        if "path control" in gs and gs["path control"] == 640:
            for letter in "PQ":
                if letter in values and values[letter] < 0:
                    self.fail(f"G64 {texts[letter]}: a tolerance must not be negative")
        if "retract mode" in gs:
            self.r_plane = gs["retract mode"] == 990
        if "distance" in gs:
            self.absolute = gs["distance"] == 900
        if "arc distance" in gs:
            self.arc_absolute = gs["arc distance"] == 901
        if "motion" in gs:
            self.motion = None if gs["motion"] == 800 else gs["motion"]
            if self.motion not in _CYCLES:
                self.cycle = self.cycle_level = None
        axes = any(a in values for a in "XYZ@^") and gs.get("tool length") != 431
        if nonmodal in (100, 280, 300, 920):
            if "motion" in gs and gs["motion"] != 800 and axes:
                self.fail(f"{_code_text(gs, 'non-modal')} and "
                          f"{_code_text(gs, 'motion')} both use the axis words")
            self.nonmodal(nonmodal, values, texts)
        elif nonmodal in (281, 301, 921, 922, 923):
            self.nonmodal(nonmodal, values, texts)
        elif axes or any(a in values for a in "IJKR") and nonmodal != 40:
            self.move(values, texts, machine=nonmodal == 530)
        elif gs.get("motion") in (0, 10):
            self.move(values, texts)          # LinuxCNC moves to where it is: a move of zero
        stop = ms.get("stopping", ())
        for code in stop:
            if code in (0, 1):
                self.event("pause", f"M{code}" + (" (optional stop)" if code == 1 else ""))
        return any(code in (2, 30) for code in stop)

    def debug_value(self, text):
        """A parameter's value in a ``(DEBUG,...)`` text."""
        try:
            if text.startswith("#<"):
                return self.get_named(text[2:-1].lower().replace(" ", ""))
            return self.get_numbered(int(text[1:]))
        except (ExpressionError, ValueError) as error:
            self.fail(f"(DEBUG,...): {error}")

    def compensation(self, code, values, texts):
        if code == 400:
            self.side = None
            self.radius = self.radius_source = None
            return
        if self.plane != 170:
            self.fail(f"G{code / 10:g}: cutter-radius compensation is in the XY plane (G17) "
                      f"only, not G{self.plane // 10}")
        self.side = "left" if code in (410, 411) else "right"
        self.radius = self.radius_source = None
        if code in (411, 421):
            if "D" not in values:
                self.fail(f"G{code / 10:g} needs D: the cutter's diameter")
            if values["D"] < 0:
                self.fail(f"G{code / 10:g} {texts['D']}: a diameter must not be negative")
            self.radius = values["D"] * self.scale / 2
            self.radius_source = f"G{code / 10:g} {texts['D']} (diameter, line {self.line})"
            return
        if self.tools is None:
            return
        if "D" in values:
            number = values["D"]
            if number < 0 or number.denominator != 1:
                self.fail(f"{texts['D']}: a tool number is a whole number")
            number = int(number)
            if number not in self.tools:
                self.fail(f"{texts['D']}: tool {number} is not in the tool table")
            where = f"D{number}"
        else:
            number = self.tool
            if number not in self.tools:
                return
            where = f"the loaded tool T{number}"
        self.radius = Fraction(self.tools[number]) / 2
        self.radius_source = f"tool table: {where}, diameter {float(self.tools[number]):g} mm"

    def z(self):
        return self.pos[2] if self.z_given else None

    def polar(self, values, texts, *, increments=None):
        """X and Y of the block's polar words (``@`` the distance from the program's origin,
        ``^`` the angle in degrees from +X), as LinuxCNC's find_ends: in G90 a word not given
        keeps the current one; in G91 they are added to the current distance and angle (or,
        with ``increments``, to those of that point: a canned cycle's repeats). Program
        coordinates; the block has ``@`` or ``^``."""
        if "X" in values or "Y" in values:
            letter = "X" if "X" in values else "Y"
            self.fail(f"{texts.get(letter, letter)}: polar coordinates (@, ^) or X and Y, "
                      f"not both")
        if self.plane != 170:
            self.fail("polar coordinates (@, ^) are in the XY plane (G17) only")
        x, y = increments if increments is not None else \
            (self.pos[0] - self.offset_of(0), self.pos[1] - self.offset_of(1))
        x, y = float(x), float(y)
        radius, theta = math.hypot(x, y), math.atan2(y, x)
        r_word = float(values.get("@", 0) * self.scale)
        t_word = math.radians(float(values.get("^", 0)))
        if self.absolute and increments is None:
            radius = r_word if "@" in values else radius
            theta = t_word if "^" in values else theta
        else:
            if x == 0 and y == 0:
                self.fail("incremental polar coordinates (G91 @, ^) at the program's origin "
                          "have no angle to add to")
            radius, theta = radius + r_word, theta + t_word
        return Fraction(radius * math.cos(theta)), Fraction(radius * math.sin(theta))

    def target(self, values, machine=False, absolute=None, texts=None):
        """Where the axis words go, in machine coordinates (polar words: :meth:`polar`)."""
        absolute = self.absolute if absolute is None else absolute
        out = list(self.pos)
        scale = self.scale
        if "@" in values or "^" in values:
            if machine:
                self.fail("G53 (machine coordinates) with polar coordinates (@, ^)")
            x, y = self.polar(values, texts or {})       # (refuses X and Y beside)
            out[0], out[1] = x + self.offset_of(0), y + self.offset_of(1)
        for axis, letter in enumerate("XYZ"):
            if letter in values:
                v = values[letter]
                if scale != 1:
                    v = v * scale
                if machine:
                    out[axis] = v
                elif absolute:
                    offset = self.offset_of(axis)
                    out[axis] = v + offset if offset else v
                else:
                    out[axis] = self.pos[axis] + v
        return out

    def go(self, kind, end, feed=None, centre=None, cw=False, z_word=False, **arc):
        """A move to ``end`` (machine coordinates); ``arc``: an arc's ``plane``, ``start_z``
        and ``turns`` (:class:`Move`)."""
        start = (self.pos[0], self.pos[1])
        if z_word:
            self.z_given = True
        self.pos = list(end)
        self.moves.append(Move(self.line, kind, start, (end[0], end[1]), centre=centre, cw=cw,
                               side=self.side, feed=feed, z=self.z(), radius=self.radius,
                               radius_source=self.radius_source, **arc))

    def dwell(self, seconds):
        """A dwell (G4, a cycle's P) where the machine is."""
        here = (self.pos[0], self.pos[1])
        self.moves.append(Move(self.line, "dwell", here, here, side=self.side, feed=self.feed,
                               z=self.z(), seconds=seconds))

    def nonmodal(self, code, values, texts):
        scale = self.scale
        if code in (280, 300):
            home = self.home[code // 10]
            given = [letter in values for letter in "XYZ"]
            if any(given):
                self.go("rapid", self.target(values, texts=texts), z_word="Z" in values)
                end = [home[a] if given[a] else self.pos[a] for a in range(3)]
            else:
                self.go("rapid", list(self.pos))
                end = list(home)
            self.go("rapid", end, z_word=given[2] or not any(given))
        elif code in (281, 301):
            self.home[code // 10][:] = self.pos
        elif code == 100:
            level = values["L"]
            if level not in (2, 20):
                self.fail(f"G10 {texts['L']}: only L2 and L20 (work offsets) are supported"
                          + (": give the tool table with --tool-table" if level in (1, 10, 11)
                             else ""))
            number = values.get("P")
            if number is None or number.denominator != 1 or not 0 <= number <= 9:
                self.fail("G10 needs P: the coordinate system, 0 (the current one) to 9")
            system = self.g5x[int(number) or self.cs]
            if values.get("R", 0) != 0:
                self.fail(f"G10 {texts['R']}: rotated coordinate systems are not supported")
            for axis, letter in enumerate("XYZ"):
                if letter in values:
                    v = values[letter] * scale
                    system[axis] = v if level == 2 else \
                        self.pos[axis] - self.g92[axis] - self.tlo[axis] - v
        elif code == 920:
            if not any(letter in values for letter in "XYZ"):
                self.fail("G92 needs an axis word")
            for axis, letter in enumerate("XYZ"):
                if letter in values:
                    self.g92[axis] = (self.pos[axis] - self.g5x[self.cs][axis]
                                      - self.tlo[axis] - values[letter] * scale)
            self.g92_saved[:] = self.g92
            self.g92_on = True
        elif code == 921:
            self.g92[:] = self.g92_saved[:] = [Fraction(0)] * 3
            self.g92_on = False
        elif code == 922:
            self.g92[:] = [Fraction(0)] * 3
            self.g92_on = False
        elif code == 923:
            self.g92[:] = self.g92_saved
            self.g92_on = True

    def move(self, values, texts, machine=False):
        motion = self.motion
        if motion is None:
            self.fail("coordinates without a motion code (G0, G1, G2 or G3)")
        if motion in _CYCLES:
            if machine:
                self.fail(f"G53 (machine coordinates) takes G0 or G1, not G{motion / 10:g}")
            self.canned_cycle(motion, values, texts)
            return
        kind = _MOTION[motion]
        if machine:
            if kind == "arc":
                self.fail("G53 (machine coordinates) takes G0 or G1, not an arc")
            if self.side is not None:
                self.fail("G53 (machine coordinates) with cutter-radius compensation on")
        end = self.target(values, machine=machine, absolute=True if machine else None,
                          texts=texts)
        if kind != "rapid" and self.feed is None and self.units is not None:
            self.fail(f"G{motion // 10} with no feed rate: give an F before the first feed "
                      f"move (G1, G2, G3)")
        r = values.get("R")
        if kind != "arc":
            if any(letter in values for letter in "IJKR"):
                self.fail(f"I, J, K and R belong to arcs (G2, G3), not to G{motion // 10}")
            self.go(kind, end, feed=None if kind == "rapid" else self.feed,
                    z_word="Z" in values)
            if kind == "rapid":
                self._rapid_feed()
            return
        turns = values.get("P", 1)
        if turns < 1 or turns.denominator != 1:
            self.fail(f"{texts['P']}: an arc's turns are a whole number, 1 or more")
        if turns > 1 and self.side is not None:
            self.fail(f"{texts['P']}: an arc of more than one turn with cutter-radius "
                      f"compensation on (the equidistant engine traces one turn at most)")
        # The plane's first and second axis (X Y, Z X, Y Z) and their centre words (I J, K I,
        # J K: the centre word of axis n is "IJK"[n]); the word of the normal axis is refused,
        # as LinuxCNC refuses it, unless it is zero: Grbl ignores it, and FreeCAD's Grbl post
        # writes K0 on every XY arc.
        plane = self.plane // 10
        first, second, normal = PLANE_AXES[plane]
        words = "IJK"[first] + "IJK"[second]
        if values.get("IJK"[normal], 0) != 0:
            self.fail(f"{texts['IJK'[normal]]}: an arc in the {_PLANE_NAMES[plane]} plane "
                      f"(G{plane}) takes {words[0]} and {words[1]}, not {'IJK'[normal]}")
        i, j = (values.get(letter) for letter in words)
        x0, y0 = self.pos[first], self.pos[second]
        scale = self.scale
        cw = motion == 20
        if r is not None:
            if i is not None or j is not None:
                self.fail(f"an arc by its centre ({words[0]}, {words[1]}) or by its radius "
                          f"(R), not both")
            centre = _radius_centre((x0, y0), (end[first], end[second]), r * scale, cw,
                                    self.fail)
        elif i is None and j is None:
            self.fail(f"G{motion // 10} needs the centre: {words[0]} and {words[1]} "
                      f"(relative to the start) or R")
        elif self.arc_absolute:
            centre = ((i or 0) * scale + self.offset_of(first),
                      (j or 0) * scale + self.offset_of(second))
        elif scale == 1:
            centre = (x0 + i if i else x0, y0 + j if j else y0)
        else:
            centre = (x0 + (i or 0) * scale, y0 + (j or 0) * scale)
        if plane == 17:
            self.go("arc", end, feed=self.feed, centre=centre, cw=cw, z_word="Z" in values,
                    turns=int(turns))
            return
        # In XZ and YZ the arc moves Z (its centre is where the start is on the normal axis).
        point = list(self.pos)
        point[first], point[second] = centre
        self.go("arc", end, feed=self.feed, centre=tuple(point), cw=cw, z_word=True,
                plane=plane, start_z=self.pos[2], turns=int(turns))

    def canned_cycle(self, motion, values, texts):
        """A drilling or boring cycle (G73, G81-G83, G85, G89) at the block's hole position,
        as LinuxCNC's interpreter makes it (interp_cycles.cc), along the plane's normal axis
        (G17: Z, the hole at X Y; G18: Y, the hole at Z X; G19: X, the hole at Y Z; R and the
        depth are that axis's): up to R first if the series began below it, then for each of
        L repeats a rapid in the plane (the first from the current height when that is above
        R, the others at the clearance height: R with G99, the height the cycles began at with
        G98) and down to R, the hole, and the retract. In
        G91 the plane's words are increments repeated L times, R an increment from the
        series' first height, the depth one from R. R, the depth, P, Q are kept for the same
        cycle's next blocks; the first height of a series of cycles (until another motion mode
        or G80) is where G98 retracts to. A series is in one plane: a cycle block after a
        change of plane (G17, G18, G19 with no G80 or other motion mode since the series'
        last block) is refused, where LinuxCNC keeps the first height, measured on the old
        plane's normal axis, and retracts the new one to it."""
        name = f"G{motion / 10:g}"
        first, second, normal = PLANE_AXES[self.plane // 10]
        depth_letter = "XYZ"[normal]
        if self.side is not None:
            self.fail(f"{name} with cutter-radius compensation on: turn it off (G40) first")
        if self.feed is None and self.units is not None:
            self.fail(f"{name} with no feed rate: give an F before the cycle")
        if self.cycle is not None and self.cycle_plane != self.plane:
            self.fail(f"{name} in G{self.plane // 10} continues a series of canned cycles "
                      f"begun in G{self.cycle_plane // 10}: end it with G80 first")
        same = self.cycle == motion
        words = dict(self.cycle_words) if same else {}
        for letter in "R" + depth_letter + _CYCLES[motion]:
            if letter in values:
                words[letter] = values[letter]
            elif letter not in words:
                what = {"R": "the retract plane", depth_letter: "the depth",
                        "P": "the dwell, seconds", "Q": "the peck, the depth of each"}[letter]
                self.fail(f"{name} needs {letter}: {what}")
        if "Q" in words and words["Q"] <= 0:
            self.fail(f"{name} Q{float(words['Q']):g}: a peck must be positive")
        if "P" in words and words["P"] < 0:
            self.fail(f"{name} P{float(words['P']):g}: a dwell must not be negative")
        repeats = values.get("L", 1)
        if repeats < 1 or repeats.denominator != 1:
            self.fail(f"{name} {texts['L']}: the repeats are a whole number, 1 or more")
        scale = self.scale
        # The height the series of cycles began at (LinuxCNC's "initial level", kept through
        # cycles of any kind until another motion mode or G80; a series continued in another
        # plane is refused above): G91's R is from it, the machine goes up to R first when it
        # is below R, G98 retracts to it.
        if self.cycle_level is None:
            self.cycle_level = self.pos[normal]
        a, b = self.pos[first], self.pos[second]
        start = self.cycle_level
        if self.absolute:
            end = self.target(values, texts=texts)
            a, b = end[first], end[second]
            step = (0, 0)
            offset = self.offset_of(normal)
            r, depth = words["R"] * scale + offset, words[depth_letter] * scale + offset
        else:
            step = (values.get("XYZ"[first], 0) * scale, values.get("XYZ"[second], 0) * scale)
            r = start + words["R"] * scale
            depth = r + words[depth_letter] * scale
        if r < depth:
            self.fail(f"{name}: R ({float(r):g} mm) is below {depth_letter} "
                      f"({float(depth):g} mm)")

        def at(a, b, height):
            """The machine point of hole position ``(a, b)`` at ``height`` on the normal."""
            point = [0, 0, 0]
            point[first], point[second], point[normal] = a, b, height
            return point

        height = self.pos[normal]
        if start < r:                     # up to R first, where the machine is
            self._cycle_rapid(at(self.pos[first], self.pos[second], r))
            start = height = r
        clear = r if self.r_plane else start
        polar = not self.absolute and ("@" in values or "^" in values)
        for repeat in range(int(repeats)):
            a, b = a + step[0], b + step[1]
            if polar:                     # G91 @ ^: turned and stretched about the origin
                a, b = self.polar(values, texts, increments=(a - self.offset_of(0),
                                                              b - self.offset_of(1)))
                a, b = a + self.offset_of(0), b + self.offset_of(1)
            # The first hole from where the machine is when that is above R, the others (and
            # the first from R or below) from the clearance height (CYCLE_MACRO's rule).
            level = height if repeat == 0 and height > r else clear
            self._cycle_rapid(at(a, b, level))
            if level > r:
                self._cycle_rapid(at(a, b, r))
            self._hole(motion, lambda h, a=a, b=b: at(a, b, h), r, clear, depth, words)
        self.cycle, self.cycle_words, self.cycle_plane = motion, words, self.plane

    def _rapid_feed(self):
        self.moves[-1] = _with_feed(self.moves[-1], self.feed)

    def _cycle_rapid(self, point):
        self.go("rapid", point, z_word=True)
        self._rapid_feed()

    def _hole(self, motion, at, r, clear, depth, words):
        """The moves of one hole from the R plane (interp_cycles.cc's convert_cycle_g*);
        ``at(height)`` is the hole's point at a height on the plane's normal axis."""
        def feed(height):
            self.go("line", at(height), feed=self.feed, z_word=True)

        if motion in (730, 830):          # pecks: back to R (G83) or a hair (G73) between
            peck = words["Q"] * self.scale
            below = r - peck
            while below > depth:
                feed(below)
                if motion == 830:
                    self._cycle_rapid(at(r))
                self._cycle_rapid(at(below + PECK_CLEARANCE))
                below -= peck
        feed(depth)
        if motion in (820, 890):
            self.dwell(words["P"])
        if motion == 850:                 # bore: out at the feed to R, then up
            feed(r)
        if motion == 890:                 # bore with a dwell: out at the feed to clearance
            feed(clear)
        else:
            self._cycle_rapid(at(clear))


def _with_feed(move, feed):
    """A rapid move carries the feed in force (as the reader always gave it)."""
    return replace(move, feed=feed)


def _code_text(gs, group):
    """The G code of ``group`` in a block's codes ``gs`` (ten times its number), as written."""
    return f"G{gs[group] / 10:g}"


def interpret(blocks, *, start=(0, 0), name=None, units=None, tools=None, parameters=None,
              block_delete=False, events=None):
    """Run the blocks through LinuxCNC's modal state, parameters and O-word control flow;
    return the moves (:class:`Move`; with ``events``, a list, the :class:`Event` objects are
    appended to it).

    The position starts at ``start`` (the origin by default, in the moves' units); motion,
    distance (G90 absolute, the default, or G91 incremental), arc distance (G91.1, the
    default, or G90.1), units, compensation, the work offsets (G54-G59.3, G10 L2/L20, G92)
    are modal. ``units`` is ``None`` (lattice units, no G20/G21) or ``"mm"`` (G21 by default,
    G20 inches; the moves in millimetres). ``tools`` is the tool table, ``{tool: diameter
    (mm)}`` (:func:`read_tool_table`), ``parameters`` numbered parameters to start with (in
    millimetres: 5161-5163 the G28 position, 5181-5183 G30's). With ``block_delete`` the
    lines starting with ``/`` are skipped (LinuxCNC's block delete switch, off by default).

    Raises
    ------
    :exc:`GCodeError`
        For a word or code the reader does not interpret, two codes of one modal group in a
        block, a word no code of its block takes, a feed move (G1, G2, G3) with no F in force
        (with ``units``, as LinuxCNC refuses it), a word given twice, coordinates without a
        motion mode, an arc without its centre (``I``/``J`` or ``R``, not both), an arc by
        radius that cannot reach its end, an expression that cannot be evaluated, O-words that
        do not match, a call of a subroutine the program does not define.
    """
    if units not in UNITS:
        raise ValueError(f"Units must be one of {', '.join(map(repr, UNITS))}, not {units!r}")
    interpreter = _Interpreter(blocks, start=start, name=name, units=units, tools=tools,
                               parameters=parameters, block_delete=block_delete)
    moves = interpreter.run()
    if events is not None:
        events.extend(interpreter.events)
    return moves


class Stream:
    """A program read a few blocks at a time (``kontur serve``: the lines a G-code sender
    streams): one interpreter whose modal state, offsets and parameters carry from one
    :meth:`feed` to the next, so that a program read line by line reads as it does whole.
    The arguments are :func:`interpret`'s. O-words must be matched within the blocks of one
    :meth:`feed` (a subroutine defined in an earlier one is not known).

    The state may be copied (:func:`copy.deepcopy`) to try a line and keep it only if the
    machine takes its moves; :attr:`ended` says a feed ended the program (M2, M30), and
    :meth:`program_end` then sets the modes a program end sets."""

    def __init__(self, *, start=(0, 0), name=None, units=None, tools=None, parameters=None,
                 block_delete=False):
        if units not in UNITS:
            raise ValueError(f"Units must be one of {', '.join(map(repr, UNITS))}, "
                             f"not {units!r}")
        self.state = _Interpreter((), start=start, name=name, units=units, tools=tools,
                                  parameters=parameters, block_delete=block_delete)

    def feed(self, blocks):
        """Run ``blocks`` on the state the earlier ones left; return their moves and events
        (:class:`Event`, ``move`` counting this feed's moves).

        Raises
        ------
        :exc:`GCodeError`
            As :func:`interpret` does; the state is then part-way through the block refused
            (run a copy to keep it unchanged)."""
        state = self.state
        state.blocks, state.moves, state.events = list(blocks), [], []
        state.ended = False
        state.run()
        return state.moves, state.events

    @property
    def ended(self):
        """The last feed ended the program (M2, M30)."""
        return self.state.ended

    def program_end(self):
        """The modes after M2/M30 (LinuxCNC's and Grbl's): G1, G90, G54, G40; the
        position, offsets and parameters kept."""
        state = self.state
        state.ended = False
        state.motion, state.absolute, state.cs = 10, True, 1
        state.side = state.radius = state.radius_source = None

    @property
    def position(self):
        """Where the moves so far end: ``(x, y, z)`` in machine coordinates."""
        return tuple(self.state.pos)

    def move_to(self, x, y, z=None):
        """Put the reader at machine ``(x, y)`` (where the machine is after a stop), and at
        ``z`` when given (a 3-axis machine's)."""
        self.state.pos[0], self.state.pos[1] = Fraction(x), Fraction(y)
        if z is not None:
            self.state.pos[2] = Fraction(z)

    def modes(self):
        """The modal state as a dict: ``motion`` (ten times the G code, ``None`` after G80),
        ``plane`` (ten times its G code), ``absolute``, ``arc_absolute``, ``inches``, ``feed`` (in
        the program's units), ``side``, ``coordinate_system`` (1-9: G54-G59.3), ``tool``, ``speed``,
        and the offset in force (``offset``: G5x, G92 and the tool length offset, machine
        units) with each system's (``systems``), G92's, the tool length offset and the G28/G30
        positions (``g92``, ``tlo``, ``home``)."""
        state = self.state
        return {"motion": state.motion, "absolute": state.absolute,
                "arc_absolute": state.arc_absolute, "inches": state.scale != 1,
                "feed": None if state.feed is None else state.feed / state.scale,
                "plane": state.plane,
                "side": state.side, "coordinate_system": state.cs, "tool": state.tool,
                "speed": state.speed,
                "offset": tuple(state.offset_of(axis) for axis in range(3)),
                "systems": {n: tuple(v) for n, v in state.g5x.items()},
                "g92": tuple(state.g92), "tlo": tuple(state.tlo),
                "home": {n: tuple(v) for n, v in state.home.items()}}


def plane_arc(move):
    """How a refusal names an arc in the XZ or YZ plane: "an arc in the XZ plane, G18"."""
    return f"an arc in the {_PLANE_NAMES[move.plane]} plane, G{move.plane}"


def planar(moves, *, name=None, unit="mm", axes=2):
    """Raise :exc:`GCodeError` (naming its line, :data:`Z_REFUSAL`, the Z values in ``unit``)
    at the first move that changes Z from where the program first put it: a 2-axis controller
    drives X and Y only; Z is read, and where the program first gives it is where the operator
    has set the tool; an arc in the XZ or YZ plane (G18, G19) is refused wherever it ends.
    With ``axes=3`` (a compensated program on a 3-axis board) the message is
    :data:`Z_COMPENSATED`."""
    z = None
    for move in moves:
        if move.plane != 17:              # it moves Z on its way, wherever it ends
            raise GCodeError(move.line, f"{Z_REFUSAL if axes == 2 else Z_COMPENSATED} "
                                        f"({plane_arc(move)})", name=name)
        if move.z is None:
            continue
        if z is not None and move.z != z:
            raise GCodeError(move.line, f"{Z_REFUSAL if axes == 2 else Z_COMPENSATED} "
                                        f"(Z from {float(z):g} to "
                                        f"{float(move.z):g} {unit})", name=name)
        z = move.z


def read(text, *, name=None, start=(0, 0), units=None, tools=None, parameters=None,
         block_delete=False):
    """:func:`parse` and :func:`interpret` a program; return the :class:`Program`."""
    blocks = parse(text, name=name)
    events = []
    moves = interpret(blocks, start=start, name=name, units=units, tools=tools,
                      parameters=parameters, block_delete=block_delete, events=events)
    return Program(tuple(blocks), tuple(moves), name, tuple(events))


class ToolTableError(ValueError):
    """A tool table that cannot be read: the message names the line."""


class ToolTable(dict):
    """A tool table: ``{tool: diameter in mm}``, and :attr:`lengths`, ``{tool: its Z length
    offset in mm}`` (what G43 applies)."""

    def __init__(self, *args, lengths=None, **kwargs):
        super().__init__(*args, **kwargs)
        self.lengths = dict(lengths or {})


def read_tool_table(text, *, name=None, units="mm"):
    """LinuxCNC's tool table (``T1 P1 D6.0 Z0 ;comment``, one tool a line): a
    :class:`ToolTable`, ``{tool: diameter in mm}`` with the Z lengths (``Z``, for G43) in
    :attr:`~ToolTable.lengths`. Both are in ``units`` (``"mm"``, the machine's units, as
    LinuxCNC reads a table on a metric machine; or ``"inch"``); the other words (P, X, Y,
    A-W, I, J, Q) are read and not used.

    Raises
    ------
    ToolTableError
        For a line that is not a tool: no T, a word that is not a number, a tool twice.
    """
    factor = {"mm": Fraction(1), "inch": Fraction(254, 10)}[units]
    tools = ToolTable()
    for number, raw in enumerate(text.splitlines(), start=1):
        code = raw.split(";", 1)[0].strip()
        if not code:
            continue
        where = f"{name}:{number}" if name else f"line {number}"
        fields = {}
        for item in code.split():
            letter, digits = item[0].upper(), item[1:]
            try:
                fields[letter] = Fraction(digits)
            except (ValueError, ZeroDivisionError):
                raise ToolTableError(f"{where}: cannot read {item!r}: a word is a letter and "
                                     f"a number") from None
            if letter not in "TPDXYZABCUVWIJQ":
                raise ToolTableError(f"{where}: unknown word {item!r}")
        if "T" not in fields or fields["T"].denominator != 1 or fields["T"] < 0:
            raise ToolTableError(f"{where}: a tool line starts with T and the tool number")
        tool = int(fields["T"])
        if tool in tools:
            raise ToolTableError(f"{where}: tool {tool} given twice")
        diameter = fields.get("D", Fraction(0))
        if diameter < 0:
            raise ToolTableError(f"{where}: tool {tool}'s diameter is negative")
        tools[tool] = diameter * factor
        tools.lengths[tool] = fields.get("Z", Fraction(0)) * factor
    return tools
