"""Binary number codes used by the patents' registers, as pure-Python integer functions.

A *code* is the unsigned integer read off a register's ``width`` bits; a *value* is the signed
number it stands for. Two's complement is the usual binary code. Ones' complement (обратный код)
writes a negative number as its magnitude with every bit inverted, so it has two zeros: +0
(``0…0``) and −0 (``1…1``).

The arithmetic here defines what the gateware elements do, bit for bit:

* :func:`ones_add` is the accumulating adder of SU 1665343: ones'-complement addition with an
  end-around carry, formed as a subtraction of the complemented operand so that a zero result is
  always +0 (a plain adder turns 3 + (−3) into −0, whose sign bit reads as negative);
* :func:`ones_count` is its counter 8: counting up adds with an end-around carry (−1 + 1 = −0),
  counting down subtracts with an end-around borrow (2 − 2 = +0, never −0).
"""

__all__ = [
    "mask", "from_code", "ones_encode", "ones_decode", "ones_add", "ones_sub", "ones_count",
    "shift_code", "sign_extend",
]


def mask(width):
    return (1 << width) - 1


def from_code(code, width):
    """Signed value of a two's complement ``code``."""
    code &= mask(width)
    return code - (1 << width) if code >> (width - 1) else code


def ones_encode(value, width):
    """Ones' complement code of ``value`` (zero is encoded as +0)."""
    if abs(value) > mask(width - 1):
        raise OverflowError(f"{value} does not fit in {width}-bit ones' complement")
    return value if value >= 0 else (~(-value)) & mask(width)


def ones_decode(code, width):
    """Signed value of a ones' complement ``code`` (both zeros decode to 0)."""
    code &= mask(width)
    return -((~code) & mask(width)) if code >> (width - 1) else code


def _minus(a, b, width):
    """``a - b`` on codes with the borrow fed back to bit 0 (end-around borrow)."""
    diff = a - b
    if diff < 0:
        diff = (diff + (1 << width) - 1) & mask(width)
    return diff


def ones_add(a, b, width):
    """Accumulating-adder sum of two ones' complement codes; returns a code (zero is +0)."""
    return _minus(a & mask(width), (~b) & mask(width), width)


def ones_sub(a, b, width):
    """Accumulating-adder difference ``a - b`` of two ones' complement codes."""
    return _minus(a & mask(width), b & mask(width), width)


def ones_count(code, delta, width):
    """Counter-8 count of a ones' complement ``code`` by ``delta`` (−3 … +1); returns a code."""
    code &= mask(width)
    if delta > 0:
        total = code + delta
        return (total & mask(width)) + (total >> width)       # end-around carry
    return _minus(code, -delta, width)


def shift_code(code, lsb, width):
    """``code`` shifted one bit towards the MSB with ``lsb`` in bit 0 (``width`` + 1 bits)."""
    return ((code & mask(width)) << 1) | (lsb & 1)


def sign_extend(code, width, new_width):
    """Extend ``code`` from ``width`` to ``new_width`` bits, copying the sign bit."""
    code &= mask(width)
    if code >> (width - 1):
        code |= mask(new_width) & ~mask(width)
    return code
