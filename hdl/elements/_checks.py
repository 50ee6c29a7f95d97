"""Parameter checks shared by the elements and cores (messages quote the bad value)."""

__all__ = ["check_width", "check_positive", "check_choice"]


def _is_int(value):
    return isinstance(value, int) and not isinstance(value, bool)


def check_width(name, value, *, minimum=1):
    """Raise :exc:`TypeError` unless ``value`` is an integer of at least ``minimum``."""
    if not _is_int(value) or value < minimum:
        if minimum == 1:
            raise TypeError(f"{name} must be a positive integer, not {value!r}")
        raise TypeError(f"{name} must be an integer of at least {minimum}, not {value!r}")


def check_positive(name, value):
    """Raise :exc:`TypeError` unless ``value`` is a positive integer."""
    check_width(name, value, minimum=1)


def check_choice(name, value, choices):
    """Raise :exc:`ValueError` unless ``value`` is one of ``choices``."""
    if value not in choices:
        options = ", ".join(repr(c) for c in choices)
        raise ValueError(f"{name} must be one of {options}, not {value!r}")
