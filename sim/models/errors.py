"""The one exception type the golden models raise for input a core refuses."""

__all__ = ["InputError"]


class InputError(ValueError):
    """A command the interpolator refuses (the RTL raises its ``error`` strobe for the same)."""
