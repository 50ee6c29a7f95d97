"""Helpers shared by the property harnesses."""

from amaranth import *
from amaranth.asserts import AnySeq

__all__ = ["free", "ones_value", "minus_zero", "past", "state_register", "state_registers"]


def free(m, *signals):
    """Drive every one of ``signals`` from a free input (a new value in every clock)."""
    for signal in signals:
        m.d.comb += signal.eq(AnySeq(signal.shape()))


def ones_value(code, width):
    """The number a ``width``-bit ones'-complement ``code`` stands for (``1…1`` is zero), as a
    two's complement value one bit wider."""
    code = code.as_signed()
    return Mux(code[-1], code + 1, code)


def minus_zero(code):
    """``code`` is ones'-complement −0 (every bit set)."""
    return code.as_unsigned().all()


def past(m, value, *, name, init=0):
    """A register holding ``value`` of the previous clock (``init`` before the first)."""
    register = Signal(value.shape(), name=name, init=init)
    m.d.sync += register.eq(value)
    return register


def state_register(elaboratable, name):
    """Elaborate ``elaboratable`` once; return ``(fragment, register)``: the fragment (to be
    added as the submodule in its place, so the register found is the one built) and the
    signal named ``name`` that its ``sync`` statements drive.

    The element proofs use this for an element's one state register (a generator's phase, an
    extender's count, a delay line): it makes the contract 1-inductive where no port shows
    that state. Of the cores, only :class:`~kontur.hdl.linear.LinearCore`'s proof uses it
    (:func:`state_registers`), for its prepared segment's flags; the cores' elements are seen
    through their ports only."""
    fragment, (register,) = state_registers(elaboratable, name)
    return fragment, register


def state_registers(elaboratable, *names):
    """As :func:`state_register`, for several registers of one elaboratable: ``(fragment,
    registers)``, the registers in the order of ``names``."""
    from amaranth.hdl import Fragment
    from amaranth.hdl._ast import Assign, Switch

    fragment = Fragment.get(elaboratable, None)

    def driven(statements):
        for statement in statements:
            if isinstance(statement, Assign):
                yield from statement.lhs._lhs_signals()
            elif isinstance(statement, Switch):
                for _patterns, body, _src_loc in statement.cases:
                    yield from driven(body)

    found = {}
    for signal in driven(fragment.statements.get("sync", ())):
        if signal.name in names:
            found.setdefault(signal.name, signal)
    missing = [name for name in names if name not in found]
    if missing:
        raise KeyError(f"{elaboratable!r} drives no register {', '.join(map(repr, missing))}")
    return fragment, [found[name] for name in names]
