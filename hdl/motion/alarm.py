"""The controller's state and its ALARM: the e-stop and the limit switches stop the machine.

:class:`Alarm` watches the filtered inputs (:class:`~.inputs.Inputs`). The e-stop trips while
it is active, a limit switch when it becomes active: the controller enters ALARM in that
clock. :py:`enter` (one clock) is the controller's ABORT (every queued frame ends
``ABORTED``, the engines stop), :py:`halt` (from that clock on) drops every step of the
step/dir stage still in its direction set-up; a pulse already on its pin is finished. In
ALARM the dispatcher refuses every queued frame (``REFUSED``, without running it). UNLOCK leaves ALARM unless
the e-stop is still active; a limit still pressed does not keep it (the axis may then be moved
off the switch, as Grbl allows).
"""

from amaranth import *
from amaranth.lib import enum, wiring
from amaranth.lib.wiring import In, Out

from .inputs import INPUTS, inputs_of

__all__ = ["State", "CAUSES", "Alarm"]


class State(enum.Enum, shape=3):
    """The controller's state, as STATUS reports it."""
    IDLE = 0
    RUN = 1
    HOLD = 2
    HOMING = 3
    ALARM = 4


#: The bits of STATUS's alarm cause: the inputs that tripped since the ALARM was entered.
CAUSES = ("estop", "limit_x", "limit_y")


class Alarm(wiring.Component):
    """ALARM on a tripped input; the controller's state.

    Members
    -------
    active : :py:`In(6)`
        The filtered inputs (:data:`~.inputs.INPUTS`).
    unlock : :py:`In(1)`
        A checked UNLOCK frame ended in this clock.
    busy, hold, homing : :py:`In(1)`
        Frames are queued or running; the feed is held; the machine is homing (the states
        below ALARM, in this order of precedence: HOMING, HOLD, RUN, IDLE).
    mask : :py:`In(axes)`
        The limits that do not trip (bit 0 X, bit 1 Y, bit 2 Z): the axis a homing pass runs on
        (:class:`~.homing.HomingEngine`); the e-stop always trips.
    enter : :py:`Out(1)`
        ALARM begins in this clock (an input tripped, and the controller was not in ALARM).
    halt : :py:`Out(1)`
        In ALARM, or entering it: no new step on the pins.
    alarm : :py:`Out(1)`
        In ALARM (registered: from the clock after :py:`enter`).
    cause : :py:`Out(3)` (:py:`Out(7)` on three axes)
        The inputs of :data:`CAUSES` that tripped since the ALARM began (0 out of ALARM); on
        three axes bit 6 is Z's limit (the inputs' bit).
    state : :py:`Out(State)`

    Parameters
    ----------
    axes : :class:`int`
        2 (default) or 3: the limits watched (Z's is input bit 6).
    """

    def __init__(self, axes=2):
        self._axes = axes
        super().__init__({
            "active": In(len(inputs_of(axes))),
            "unlock": In(1),
            "busy":   In(1),
            "hold":   In(1),
            "homing": In(1),
            "mask":   In(axes),
            "enter":  Out(1),
            "halt":   Out(1),
            "alarm":  Out(1),
            "cause":  Out(len(CAUSES) if axes == 2 else 7),
            "state":  Out(State),
        })

    def elaborate(self, platform):
        m = Module()
        names = inputs_of(self._axes)
        estop = self.active[names.index("estop")]
        limits = Cat(*(self.active[names.index(f"limit_{axis}")]
                       for axis in "xyz"[:self._axes]))
        pressed = Signal(self._axes)              # the limits' levels a clock before
        m.d.sync += pressed.eq(limits)
        fresh = limits & ~pressed & ~self.mask
        tripped = Cat(estop, fresh) if self._axes == 2 else \
            Cat(estop, fresh[:2], C(0, 3), fresh[2])
        trip = tripped.any()
        m.d.comb += [self.enter.eq(trip & ~self.alarm), self.halt.eq(trip | self.alarm)]
        with m.If(trip):
            m.d.sync += [self.alarm.eq(1), self.cause.eq(self.cause | tripped)]
        with m.Elif(self.unlock):
            m.d.sync += [self.alarm.eq(0), self.cause.eq(0)]
        with m.If(self.alarm):
            m.d.comb += self.state.eq(State.ALARM)
        with m.Elif(self.homing):
            m.d.comb += self.state.eq(State.HOMING)
        with m.Elif(self.hold):
            m.d.comb += self.state.eq(State.HOLD)
        with m.Elif(self.busy):
            m.d.comb += self.state.eq(State.RUN)
        with m.Else():
            m.d.comb += self.state.eq(State.IDLE)
        return m
