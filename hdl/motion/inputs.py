"""The machine's switch inputs: synchronised, glitch-filtered, their polarity applied.

Six inputs, in this order (bit ``n`` of :py:`Inputs.pins` and :py:`Inputs.active` is
``INPUTS[n]``): the e-stop, a limit switch per axis (min and max wired together), the probe,
and the cycle-start and feed-hold buttons. A normally-closed switch (``"nc"``, the safe
default of the e-stop, the limits and feed hold: a broken wire reads as pressed) pulls its pin
low while closed, so its pin is high when it is *active* (pressed, tripped, or the wire
broken); a normally-open one (``"no"``: the probe, cycle start) pulls its pin low when active.
The pins have pull-ups (the board files).

Each input is synchronised to the clock (:class:`amaranth.lib.cdc.FFSynchronizer`, two
flip-flops) and filtered: a new level counts only once it has held for ``filter`` clocks in a
row. A level set on a pin in clock ``c`` is therefore seen on :py:`active` from clock ``c +
filter + 2`` (:data:`LATENCY` ``+ filter``).
"""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out

from ..elements._checks import check_width

__all__ = ["INPUTS", "INPUTS3", "inputs_of", "POLARITIES", "DEFAULT_POLARITY", "LATENCY", "check_polarity", "idle_pins", "pin_levels",
           "InputFilter", "Inputs"]

#: The inputs, bit by bit.
INPUTS = ("estop", "limit_x", "limit_y", "probe", "cycle_start", "feed_hold")

#: A 3-axis controller's inputs: Z's limit switch is bit 6 (normally closed: its polarity is
#: not in the machine file yet).
INPUTS3 = INPUTS + ("limit_z",)


def inputs_of(axes):
    """The inputs of a controller on ``axes`` axes (2 or 3), bit by bit."""
    return INPUTS3 if axes == 3 else INPUTS

#: The two kinds of switch.
POLARITIES = ("nc", "no")

#: Each input's kind unless the machine file says otherwise.
DEFAULT_POLARITY = {"estop": "nc", "limit_x": "nc", "limit_y": "nc", "probe": "no",
                    "cycle_start": "no", "feed_hold": "nc", "limit_z": "nc"}

#: Clocks from a pin to :py:`Inputs.active` besides the filter's: the synchroniser's two.
LATENCY = 2


def check_polarity(polarity):
    """The full polarity table: ``polarity`` (a dict, missing inputs at their default)
    checked (:exc:`ValueError` for an unknown input or kind)."""
    table = dict(DEFAULT_POLARITY)
    for name, kind in dict(polarity or {}).items():
        if name not in INPUTS3:
            raise ValueError(f"Input must be one of {', '.join(INPUTS3)}, not {name!r}")
        if kind not in POLARITIES:
            raise ValueError(f"Input {name} must be 'nc' or 'no', not {kind!r}")
        table[name] = kind
    return table


def pin_levels(active, polarity=None, axes=2):
    """The pin word (bit ``n`` for ``INPUTS[n]``) with the inputs named in ``active`` active
    and the others idle, for switches of ``polarity`` (a dict; defaults
    :data:`DEFAULT_POLARITY`)."""
    table = check_polarity(polarity)
    word = 0
    for bit, name in enumerate(inputs_of(axes)):
        high = (name in active) == (table[name] == "nc")
        word |= int(high) << bit
    return word


def idle_pins(polarity=None, axes=2):
    """The pin word with every input idle."""
    return pin_levels((), polarity, axes)


class InputFilter(wiring.Component):
    """One input: two synchronising flip-flops, then a level that must hold ``filter`` clocks.

    Parameters
    ----------
    filter : :class:`int`
        Clocks a new level must hold (1: none but the synchroniser's).
    init : :class:`int`
        The level before the first clock (the idle one).

    Members
    -------
    i : :py:`In(1)`
        The pin.
    o : :py:`Out(1)`
        The filtered level.
    """

    def __init__(self, filter, *, init=0):
        check_width("Input filter", filter)
        self._filter = filter
        self._init = init
        super().__init__({"i": In(1, init=init), "o": Out(1, init=init)})

    def elaborate(self, platform):
        m = Module()
        synced = Signal(init=self._init)
        m.submodules.sync = FFSynchronizer(self.i, synced, init=self._init)
        if self._filter == 1:
            m.d.sync += self.o.eq(synced)
            return m
        count = Signal(range(self._filter))
        with m.If(synced == self.o):
            m.d.sync += count.eq(0)
        with m.Elif(count == self._filter - 1):
            m.d.sync += [self.o.eq(synced), count.eq(0)]
        with m.Else():
            m.d.sync += count.eq(count + 1)
        return m


class Inputs(wiring.Component):
    """The six inputs (:data:`INPUTS`; seven on three axes, :data:`INPUTS3`): pins in, active
    levels out.

    Parameters
    ----------
    filter : :class:`int`
        The glitch filter, clocks (see :class:`InputFilter`).
    polarity : :class:`dict`
        ``"nc"`` or ``"no"`` for any input (the others at :data:`DEFAULT_POLARITY`).
    axes : :class:`int`
        2 (default) or 3: with 3, Z's limit (bit 6, ``polarity``'s ``limit_z``).

    Members
    -------
    pins : :py:`In(6, init=idle_pins(polarity))`
        The pins, bit ``n`` for ``INPUTS[n]``.
    active : :py:`Out(6)`
        The inputs active (pressed, tripped), filtered.
    """

    def __init__(self, *, filter=1, polarity=None, axes=2):
        check_width("Input filter", filter)
        self._filter = filter
        self._polarity = check_polarity(polarity)
        self._axes = axes
        self._idle = idle_pins(self._polarity, axes)
        names = inputs_of(axes)
        super().__init__({"pins": In(len(names), init=self._idle),
                          "active": Out(len(names))})

    @property
    def filter(self):
        return self._filter

    @property
    def polarity(self):
        return dict(self._polarity)

    @property
    def idle(self):
        """The pin word with every input idle."""
        return self._idle

    def elaborate(self, platform):
        m = Module()
        for bit, name in enumerate(inputs_of(self._axes)):
            idle = (self._idle >> bit) & 1
            m.submodules[name] = stage = InputFilter(self._filter, init=idle)
            m.d.comb += [stage.i.eq(self.pins[bit]),
                         self.active[bit].eq(stage.o ^ idle)]
        return m
