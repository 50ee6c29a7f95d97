"""The words of a G-code line as LinuxCNC reads them: numbers, parameters, expressions.

:func:`split_line` takes one line of a program and returns its parts: whether it starts with a
block delete ``/``, its comments (``( ... )`` and ``;``), and its code with every space and
tab removed and in lower case, as LinuxCNC's reader has it (so ``X - 1`` is ``X-1`` and
``G 0 1`` is ``G01``). :func:`read_code` reads that code into its O-word, its words and its
parameter settings. A word's value is a :class:`~fractions.Fraction` when it is a number, else
an expression tree that :class:`Evaluator` evaluates when the line runs:

* numbers, ``#n`` (numbered parameters, ``#[expr]`` and ``##n`` indirect), ``#<name>`` (named:
  local, or global when the name starts with ``_``);
* ``[ ... ]`` with LinuxCNC's binary operators and precedences, all left-associative:
  ``**`` (6); ``*``, ``/``, ``MOD`` (5); ``+``, ``-`` (4); ``EQ NE GT GE LT LE`` (3);
  ``AND OR XOR`` (2); a unary ``-`` or ``+`` binds tighter than any of them (``[-2**2]`` is 4);
* the functions ``ABS ACOS ASIN COS EXP FIX FUP LN ROUND SIN SQRT TAN`` (angles in degrees),
  ``ATAN[y]/[x]`` and ``EXISTS[#<name>]``.

Arithmetic on numbers stays exact (fractions) for ``+ - * /`` and integer powers; functions
give floating point (as LinuxCNC's doubles), turned into the exact fraction of that double.
``EQ`` and ``NE`` compare within 0.000001 as LinuxCNC's ``TOLERANCE_EQUAL``.
"""

import math
import re
import sys
from fractions import Fraction

__all__ = ["ExpressionError", "split_line", "read_code", "Evaluator", "FUNCTIONS"]


class ExpressionError(ValueError):
    """A line that cannot be read, or an expression that cannot be evaluated: the reason."""


_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)")
_FAST = re.compile(r"(?:[a-np-z][+-]?(?:\d+\.?\d*|\.\d+))+")
_FAST_WORD = re.compile(r"([a-np-z])([+-]?(?:\d+\.?\d*|\.\d+))")
_NAME = re.compile(r"[a-z]+")
_SPACE = re.compile(r"[ \t\r\f\v]+")
#: Binary operators: their precedence (LinuxCNC's ``precedence()``).
_BINARY = {"**": 6, "*": 5, "/": 5, "mod": 5, "+": 4, "-": 4, "eq": 3, "ne": 3, "gt": 3,
           "ge": 3, "lt": 3, "le": 3, "and": 2, "or": 2, "xor": 2}
_WORDS = ("mod", "eq", "ne", "gt", "ge", "lt", "le", "and", "or", "xor")
FUNCTIONS = ("abs", "acos", "asin", "atan", "cos", "exp", "fix", "fup", "ln", "round", "sin",
             "sqrt", "tan", "exists")
#: LinuxCNC's TOLERANCE_EQUAL (interp_internal.hh), for EQ and NE.
TOLERANCE_EQUAL = 0.000001
#: The numbered parameters LinuxCNC has (RS274NGC_MAX_PARAMETERS).
MAX_PARAMETER = 5601
_CACHE = {}


def number(text):
    """A decimal number's exact value (a short one cached: codes and small numbers repeat)."""
    value = _CACHE.get(text)
    if value is not None:
        return value
    if "." in text:
        whole, _, fraction = text.partition(".")
        sign = -1 if whole.startswith("-") else 1
        digits = (whole.lstrip("+-") or "0") + fraction
        try:
            value = Fraction(sign * int(digits), 10 ** len(fraction))
        except ValueError:                         # beyond Python's int string limit
            raise ExpressionError(f"a number of {len(text)} characters, more than the "
                                  f"{sys.get_int_max_str_digits()} digits a number may "
                                  f"have") from None
    else:
        try:
            value = Fraction(int(text))
        except ValueError:
            raise ExpressionError(f"a number of {len(text)} characters, more than the "
                                  f"{sys.get_int_max_str_digits()} digits a number may "
                                  f"have") from None
    if len(text) <= 4:
        _CACHE[text] = value
    return value


def split_line(raw):
    """``(delete, code, comments)`` of one line: a leading ``/`` (block delete), the code
    without comments, spaces or tabs and in lower case, and the comments' texts (a list).

    Raises
    ------
    ExpressionError
        For a comment not closed, nested, or a ``)`` closing none.
    """
    text = raw.lstrip()
    delete = text.startswith("/")
    if delete:
        text = text[1:]
    if "(" not in text and ")" not in text and ";" not in text:
        return delete, _SPACE.sub("", text).lower(), []
    code, comments = [], []
    i = 0
    while i < len(text):
        ch = text[i]
        if ch == "(":
            end = text.find(")", i + 1)
            if end < 0:
                raise ExpressionError("a comment opened with '(' is not closed")
            inner = text[i + 1:end]
            if "(" in inner:
                raise ExpressionError("comments do not nest")
            comments.append(inner)
            i = end + 1
        elif ch == ")":
            raise ExpressionError("')' closes no comment")
        elif ch == ";":
            comments.append(text[i + 1:])
            break
        else:
            j = i
            while j < len(text) and text[j] not in "();":
                j += 1
            code.append(text[i:j])
            i = j
    return delete, _SPACE.sub("", "".join(code)).lower(), comments


class _Reader:
    """A recursive-descent reader of one line's code (no spaces, lower case)."""

    def __init__(self, code):
        self.s = code
        self.i = 0

    def fail(self, reason):
        raise ExpressionError(reason)

    def peek(self):
        return self.s[self.i] if self.i < len(self.s) else ""

    def rest(self):
        return self.s[self.i:] or "(the end of the line)"

    def expect(self, ch):
        if self.peek() != ch:
            self.fail(f"expected {ch!r} at {self.rest()!r}")
        self.i += 1

    def value(self):
        """A real value: a number, a parameter, ``[expr]``, a function, a signed value."""
        ch = self.peek()
        if ch == "[":
            return self.expression()
        if ch == "#":
            return ("param", self.parameter())
        if ch in "+-":
            self.i += 1
            inner = self.value()
            if ch == "-":
                return ("num", -inner[1]) if inner[0] == "num" else ("neg", inner)
            return inner
        if ch.isalpha():
            match = _NAME.match(self.s, self.i)
            name = match.group()
            if name not in FUNCTIONS:
                self.fail(f"unknown function or value {name!r}")
            self.i = match.end()
            if self.peek() != "[":
                self.fail(f"{name.upper()} needs its argument in [ ]")
            if name == "exists":
                self.i += 1
                if self.peek() != "#":
                    self.fail("EXISTS takes a named parameter, EXISTS[#<name>]")
                self.i += 1
                ref = self._name()
                self.expect("]")
                return ("exists", ref)
            argument = self.expression()
            if name == "atan":
                if self.peek() != "/":
                    self.fail("ATAN takes two arguments: ATAN[y]/[x]")
                self.i += 1
                if self.peek() != "[":
                    self.fail("ATAN takes two arguments: ATAN[y]/[x]")
                return ("atan", argument, self.expression())
            return ("fn", name, argument)
        match = _NUMBER.match(self.s, self.i)
        if match is None:
            self.fail(f"cannot read {self.rest()!r}: a number, #parameter or [expression] "
                      f"is wanted")
        self.i = match.end()
        return ("num", number(match.group()))

    def _name(self):
        if self.peek() != "<":
            self.fail("a named parameter is #<name>")
        end = self.s.find(">", self.i)
        if end < 0:
            self.fail("a named parameter's '<' is not closed by '>'")
        name = self.s[self.i + 1:end]
        if not name:
            self.fail("a named parameter needs a name")
        self.i = end + 1
        return ("name", name)

    def parameter(self):
        """After ``#``: ``("name", str)`` or ``("num", value)``."""
        self.expect("#")
        if self.peek() == "<":
            return self._name()
        return ("num", self.value())

    def operator(self):
        s, i = self.s, self.i
        if s.startswith("**", i):
            self.i += 2
            return "**"
        if i < len(s) and s[i] in "*/+-":
            self.i += 1
            return s[i]
        for word in _WORDS:
            if s.startswith(word, i):
                self.i += len(word)
                return word
        self.fail(f"unknown operator at {self.rest()!r}")

    def expression(self):
        """``[ ... ]``: operands and binary operators by precedence (left to right)."""
        self.expect("[")
        values = [self.value()]
        operators = []
        while True:
            if self.peek() == "]":
                self.i += 1
                break
            if not self.peek():
                self.fail("an expression's '[' is not closed by ']'")
            op = self.operator()
            while operators and _BINARY[operators[-1]] >= _BINARY[op]:
                right = values.pop()
                values.append(("op", operators.pop(), values.pop(), right))
            operators.append(op)
            values.append(self.value())
        while operators:
            right = values.pop()
            values.append(("op", operators.pop(), values.pop(), right))
        (tree,) = values
        return tree


_KEYWORDS = ("sub", "endsub", "call", "return", "if", "elseif", "else", "endif", "while",
             "endwhile", "do", "repeat", "endrepeat", "break", "continue")


def _constant(tree):
    return tree[1] if tree[0] == "num" else tree


def read_code(code):
    """Read a line's code: ``(oword, words, settings)``.

    ``oword`` is ``None`` or ``(label, keyword, arguments)`` (``label`` an int or
    ``"<name>"``, ``arguments`` a tuple of expression trees); ``words`` a list of ``(letter,
    value, text)`` (``value`` a Fraction or a tree); ``settings`` a list of ``(reference,
    value)`` (``#n = value``, ``#<name> = value``).

    Raises
    ------
    ExpressionError
        For anything that is not a word, a setting or an O-word.
    """
    if "#" not in code and "[" not in code and "o" not in code:
        if _FAST.fullmatch(code):
            return None, [(letter, number(digits), letter.upper() + digits)
                          for letter, digits in _FAST_WORD.findall(code)], []
    reader = _Reader(code)
    words, settings, oword = [], [], None
    s = code
    while reader.i < len(s):
        start = reader.i
        ch = s[start]
        if ch == "o":
            reader.i += 1
            if reader.peek() == "<":
                end = s.find(">", reader.i)
                if end < 0:
                    reader.fail("an O-word's '<' is not closed by '>'")
                label = s[reader.i:end + 1]
                reader.i = end + 1
            else:
                match = re.compile(r"\d+").match(s, reader.i)
                if match is None:
                    reader.fail(f"cannot read {s[start:]!r}: an O-word is o<name> or o and a "
                                f"number")
                label = int(match.group())
                reader.i = match.end()
            match = _NAME.match(s, reader.i)
            keyword = match.group() if match else ""
            keyword = next((k for k in sorted(_KEYWORDS, key=len, reverse=True)
                            if keyword.startswith(k)), keyword)
            if keyword not in _KEYWORDS:
                reader.fail(f"o{label if isinstance(label, int) else label}: unknown O-word "
                            f"command {keyword or s[reader.i:]!r} (sub, endsub, call, "
                            f"return, if, elseif, else, endif, while, endwhile, do, repeat, "
                            f"endrepeat, break, continue)")
            reader.i += len(keyword)
            arguments = []
            while reader.peek() == "[":
                arguments.append(reader.expression())
            if reader.i < len(s):
                reader.fail(f"cannot read {s[reader.i:]!r} after o{label} {keyword}")
            if words or settings:
                if any(letter != "n" for letter, _, _ in words) or settings:
                    reader.fail("an O-word must stand alone on its line")
            oword = (label, keyword, tuple(arguments))
            continue
        if ch == "#":
            reference = reader.parameter()
            if reader.peek() != "=":
                reader.fail(f"a parameter ({s[start:reader.i]}) stands alone: set it with "
                            f"'=', or give it as a word's value")
            reader.i += 1
            settings.append((reference, reader.value()))
            continue
        if ch == "$":
            reader.fail(f"{s[start:]!r}: spindle selection ($) is not supported: this "
                        f"controller has one tool")
        if not ch.isalpha() and ch not in "@^":     # (@ ^: polar coordinates' words)
            reader.fail(f"cannot read {s[start:]!r}: a word is a letter and a number")
        reader.i += 1
        if reader.i >= len(s):
            reader.fail(f"cannot read {ch.upper()!r}: a word is a letter and a number")
        nxt = s[reader.i]
        if not (nxt.isdigit() or nxt in "+-.#[" or nxt.isalpha()):
            reader.fail(f"cannot read {s[start:]!r}: a word is a letter and a number")
        try:
            tree = reader.value()
        except ExpressionError as error:
            if nxt.isalpha():
                raise ExpressionError(f"cannot read {s[start:]!r}: a word is a letter and a "
                                      f"number") from None
            raise error
        words.append((ch, _constant(tree), ch.upper() + s[start + 1:reader.i]))
    return oword, words, settings


def _float(value):
    return float(value)


def _exact(value):
    """A float result as the exact fraction of that double; refuse NaN and infinities."""
    if isinstance(value, Fraction):
        return value
    if math.isnan(value) or math.isinf(value):
        raise ExpressionError("an expression's value is not a finite number")
    return Fraction(value)


class Evaluator:
    """Evaluates expression trees against parameters: ``numbered(n)`` and ``named(name)``
    (callables that raise :exc:`ExpressionError` for one that does not exist) and
    ``exists(name)``."""

    def __init__(self, numbered, named, exists):
        self.numbered, self.named, self.exists = numbered, named, exists

    def __call__(self, tree):
        if isinstance(tree, Fraction):
            return tree
        kind = tree[0]
        if kind == "num":
            return tree[1]
        if kind == "param":
            return self.read(tree[1])
        if kind == "neg":
            return -self(tree[1])
        if kind == "op":
            return self.binary(tree[1], self(tree[2]), self(tree[3]))
        if kind == "fn":
            return self.function(tree[1], self(tree[2]))
        if kind == "atan":
            return _exact(math.degrees(math.atan2(_float(self(tree[1])),
                                                  _float(self(tree[2])))))
        if kind == "exists":
            return Fraction(int(self.exists(tree[1][1])))
        raise AssertionError(tree)

    def index(self, tree):
        """A numbered parameter's number from its tree."""
        value = self(tree)
        n = round(value)
        if abs(value - n) > Fraction(1, 10 ** 4):
            raise ExpressionError(f"parameter number {float(value):g} is not an integer")
        if not 1 <= n <= MAX_PARAMETER:
            raise ExpressionError(f"parameter number {n} is out of range (1 to "
                                  f"{MAX_PARAMETER})")
        return n

    def read(self, reference):
        if reference[0] == "name":
            return self.named(reference[1])
        return self.numbered(self.index(reference[1]))

    @staticmethod
    def binary(op, a, b):
        if op == "+":
            return a + b
        if op == "-":
            return a - b
        if op == "*":
            return a * b
        if op == "/":
            if b == 0:
                raise ExpressionError("division by zero in an expression")
            return a / b
        if op == "**":
            if isinstance(b, Fraction) and b.denominator == 1 and abs(b) <= 64 and \
                    isinstance(a, Fraction) and (a != 0 or b > 0):
                return a ** int(b)
            if a < 0 and Fraction(b).denominator != 1:
                raise ExpressionError("a negative number to a non-integer power")
            try:
                return _exact(_float(a) ** _float(b))
            except (OverflowError, ZeroDivisionError):
                raise ExpressionError("a power out of range") from None
        if op == "mod":
            if b == 0:
                raise ExpressionError("MOD by zero")
            result = _exact(math.fmod(_float(a), _float(b))) if not (
                isinstance(a, Fraction) and isinstance(b, Fraction)) else \
                a - b * math.trunc(a / b)
            return result + abs(b) if result < 0 else result
        if op == "eq":
            return Fraction(int(abs(a - b) < TOLERANCE_EQUAL))
        if op == "ne":
            return Fraction(int(abs(a - b) >= TOLERANCE_EQUAL))
        if op == "gt":
            return Fraction(int(a > b))
        if op == "ge":
            return Fraction(int(a >= b))
        if op == "lt":
            return Fraction(int(a < b))
        if op == "le":
            return Fraction(int(a <= b))
        if op == "and":
            return Fraction(int(a != 0 and b != 0))
        if op == "or":
            return Fraction(int(a != 0 or b != 0))
        if op == "xor":
            return Fraction(int((a != 0) != (b != 0)))
        raise AssertionError(op)

    @staticmethod
    def function(name, a):
        if name == "abs":
            return abs(a)
        if name == "fix":
            return Fraction(math.floor(a))
        if name == "fup":
            return Fraction(math.ceil(a))
        if name == "round":
            return Fraction(math.floor(a + Fraction(1, 2)) if a >= 0
                            else -math.floor(-a + Fraction(1, 2)))
        x = _float(a)
        if name in ("acos", "asin"):
            if not -1 <= x <= 1:
                raise ExpressionError(f"{name.upper()} of {x:g}, outside [-1, 1]")
            return _exact(math.degrees(math.acos(x) if name == "acos" else math.asin(x)))
        if name == "sqrt":
            if x < 0:
                raise ExpressionError(f"SQRT of a negative number ({x:g})")
            return _exact(math.sqrt(x))
        if name == "ln":
            if x <= 0:
                raise ExpressionError(f"LN of {x:g}: zero or negative")
            return _exact(math.log(x))
        if name == "exp":
            try:
                return _exact(math.exp(x))
            except OverflowError:
                raise ExpressionError(f"EXP of {x:g} out of range") from None
        if name in ("sin", "cos", "tan"):
            return _exact(getattr(math, name)(math.radians(x)))
        raise AssertionError(name)
