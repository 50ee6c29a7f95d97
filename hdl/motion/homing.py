"""Homing to the limit switches: one homing *pass* per HOME frame (issue 25).

:class:`HomingEngine` is a row of the controller's engine table (frame type :data:`HOME`, turn
:data:`HOMING_UNIT`). A pass moves one axis in one direction, one step per permission of the
feed generator (the rate of the FEED frame before it: the host sends the seek or the approach
feed with its exit rate equal to its cruise, so there is no ramp down), until its condition
holds: the axis's limit switch active (a seek, an approach) or inactive (a back-off). The
condition is looked at before every step: the pass ends in the clock it is seen, with no
further step (as Grbl stops a homing seek at the switch), ``DONE``; if ``steps`` steps are made
without it the pass ends ``REFUSED`` (the host reports "homing failed": the switch was not
found within that distance). A pass ending ``DONE`` with ``set`` loads ``value`` into the
controller's position counter of its axis (:py:`load`): the machine's zero plus the offset,
in steps.

Besides the engine signature the engine has plain members the controller wires up:
:py:`limits` (in: the filtered limit switches, bit 0 X, bit 1 Y), and out: :py:`homing`
(a pass is taken and not ended: the HOMING state), :py:`mask` (the limit of the pass's axis:
the ALARM unit does not trip on it while the pass runs; the e-stop always trips), and
:py:`load`, :py:`load_axis`, :py:`load_value`.

The switch's level counts only in the engine's turn (the turn queue's readiness for its
outcome, :py:`status.ready`): a pass taken while the move before runs does not end on a
switch that move passes.
"""

import struct

from amaranth import *
from amaranth.lib import data, wiring

from ..engine import EngineSignature, Outcome, StatusUnit
from .dispatch import EngineUnit, raw_bits
from .inputs import inputs_of
from .link import SYNC, profile_bytes
from .protocol import crc

__all__ = ["HOME", "HOMING_UNIT", "HomeFrame", "HomingEngine", "homing_row", "connect_homing",
           "home_frame"]

#: The HOME frame's type and the engine's turn number (the built-in rows use 1 to 4).
HOME, HOMING_UNIT = 0x17, 5


def HomeFrame():
    """A homing pass, as the HOME frame's payload carries it (9 bytes, little-endian, least
    significant bit first): the axis (0 X, 1 Y), the direction (1 negative), the condition
    (``until`` 1: the switch active; 0: inactive), whether to set the position, ``z`` (bit 4:
    the pass is Z's, on a 3-axis controller; ``axis`` is then 0), the most steps to make, the
    position to set (steps)."""
    return data.StructLayout({"axis": 1, "negative": 1, "until": 1, "set": 1, "z": 1,
                              "reserved": 3, "steps": unsigned(32), "value": signed(32)})


class HomingEngine(wiring.Component):
    """Homing passes: steps on one axis until its limit switch reaches a level.

    A pass is taken only when the engine is idle (no pass in flight, no outcome waiting), so
    passes never overlap. :py:`abort` ends a running pass ``ABORTED`` where it is.

    ``axes`` (2 or 3): on three the frame's ``z`` bit picks Z (a 2-axis engine ignores it).

    Members (besides :class:`~kontur.hdl.engine.EngineSignature`'s)
    -------
    limits : :py:`Signal(axes)`, in
        The filtered limit switches (1 active).
    homing : :py:`Signal(1)`, out
        A pass is running.
    mask : :py:`Signal(axes)`, out
        The running pass's axis, one bit: its limit must not trip the ALARM.
    load : :py:`Signal(1)`, out
    load_axis : :py:`Signal(range(axes))`, out
        Set the position of axis :py:`load_axis` to :py:`load_value` in this clock.
    load_value : :py:`Signal(signed(32))`, out
    """

    def __init__(self, axes=2):
        if axes not in (2, 3):
            raise ValueError(f"Axes must be 2 or 3, not {axes!r}")
        self._axes = axes
        super().__init__(EngineSignature(HomeFrame(), axes=axes))
        self.limits = Signal(axes)
        self.homing = Signal()
        self.mask = Signal(axes)
        self.load = Signal()
        self.load_axis = Signal(range(axes))
        self.load_value = Signal(signed(32))

    def elaborate(self, platform):
        m = Module()
        axes = self._axes
        m.submodules.unit = unit = StatusUnit(axes=axes)
        cmd, feed = self.cmd, self.feed
        run = Signal()
        axis, negative, until, set_ = Signal(range(axes)), Signal(), Signal(), Signal()
        one = Signal(axes)                   # the pass's axis, one bit
        m.d.comb += one.eq(1 << axis)
        left = Signal(32)
        value = Signal(signed(32))

        met = Signal()                       # the pass's condition holds
        ending = Signal()
        stepping = Signal()
        m.d.comb += [
            met.eq(self.limits.bit_select(axis, 1) == until),
            ending.eq(run & self.status.ready & ~unit.hold & ~self.abort &
                      (met | (left == 0))),
            feed.due.eq(run & ~unit.hold & ~self.abort & ~met & (left != 0)),
            feed.diagonal.eq(0),
            stepping.eq(feed.due & feed.tick),
            self.motion.step.eq(Mux(stepping, one, 0)),
            self.motion.dir.eq(Mux(negative, (1 << axes) - 1, 0)),
            cmd.ready.eq(unit.idle & ~unit.flushing & ~self.abort),
            unit.accept.eq(cmd.valid & cmd.ready),
            unit.end.eq(ending),
            unit.outcome.eq(Mux(met, Outcome.DONE, Outcome.REFUSED)),
            unit.flush.eq(self.abort),
            unit.motion.step.eq(self.motion.step),
            unit.motion.dir.eq(self.motion.dir),
            self.busy.eq(unit.busy),
            self.homing.eq(run),
            self.mask.eq(Mux(run, one, 0)),
            self.load.eq(ending & met & set_),
            self.load_axis.eq(axis),
            self.load_value.eq(value),
        ]
        wiring.connect(m, unit.status, wiring.flipped(self.status))
        with m.If(unit.accept):
            taken = Mux(cmd.payload.z, 2, cmd.payload.axis) if axes == 3 else cmd.payload.axis
            m.d.sync += [run.eq(1), axis.eq(taken), negative.eq(cmd.payload.negative),
                         until.eq(cmd.payload.until), set_.eq(cmd.payload.set),
                         left.eq(cmd.payload.steps), value.eq(cmd.payload.value)]
        with m.Elif(ending | self.abort):
            m.d.sync += run.eq(0)
        with m.Elif(stepping):
            m.d.sync += left.eq(left - 1)
        return m


def home_frame(axis, negative, until, steps, value=None):
    """The HOME frame of a pass (the host's side): ``axis`` 0, 1 or 2 (Z: the ``z`` flag, bit
    4, for a 3-axis controller), ``negative`` the direction, ``until`` the switch level that
    ends it, at most ``steps`` steps, and the position to set (``None``: none)."""
    if axis not in (0, 1, 2):
        raise ValueError(f"A homing pass's axis must be 0 (X), 1 (Y) or 2 (Z), not {axis!r}")
    if not 0 <= steps < 1 << 32:
        raise ValueError(f"A homing pass's step count must fit 32 bits, not {steps!r}")
    flags = (axis & 1) | bool(negative) << 1 | bool(until) << 2 | (value is not None) << 3 \
        | (axis == 2) << 4
    payload = struct.pack("<BIi", flags, steps, 0 if value is None else value)
    body = bytes([HOME, len(payload)]) + payload
    return bytes([SYNC]) + body + crc(body).to_bytes(2, "big")


def homing_row(engine=None, axes=2):
    """The engine-table row of a homing engine (a new :class:`HomingEngine` on ``axes`` by
    default): ``MotionController(engines=[homing_row()])``."""
    engine = HomingEngine(axes) if engine is None else engine
    return EngineUnit("homing", HOMING_UNIT, HOME, engine, profile_bytes(HomeFrame()), raw_bits)


def connect_homing(m, controller):
    """Wire the homing engines of ``controller``'s table (none: nothing is built): the limit
    switches in, the HOMING state and the ALARM's mask, and the position loads (after the
    position's counting in ``m``, so that a load wins over a step counted in its clock)."""
    for row in controller.table:
        engine = row.engine
        if not isinstance(engine, HomingEngine):
            continue
        active, alarm = controller.input_stage.active, controller.alarm_unit
        names = inputs_of(controller.axes)
        m.d.comb += [
            engine.limits.eq(Cat(*(active[names.index(f"limit_{axis}")]
                                   for axis in "xyz"[:len(engine.limits)]))),
            alarm.homing.eq(engine.homing),
            alarm.mask.eq(engine.mask),
        ]
        with m.If(engine.load):
            m.d.sync += controller.position[engine.load_axis].eq(engine.load_value)
