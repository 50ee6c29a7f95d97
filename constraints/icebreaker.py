"""iCEBreaker (iCE40UP5K-SG48): the board's platform with kontur's PMOD wiring.

Two sets of extra resources, one per top in ``hdl/top.py`` (a build requests only its own):

* ``stepper`` (:class:`~kontur.hdl.top.ControllerTop`, :class:`~kontur.hdl.top.DemoTop`): step/dir of two
  stepper drivers on PMOD1A, pin 1 step X, pin 2 step Y, pin 3 dir X, pin 4 dir Y, pin 7 the
  drivers' enable, active low (FPGA pins 4, 2, 47, 45, 3); the serial line is the board's
  ``uart`` (FTDI channel B: FPGA pins 6 rx, 9 tx), as ``amaranth_boards`` defines it;
* ``switches`` (:class:`~kontur.hdl.top.ControllerTop`): the six switch inputs of
  :data:`kontur.hdl.motion.inputs.INPUTS` on PMOD1B, pin 1 e-stop, 2 limit X, 3 limit Y, 4
  probe, 7 cycle start, 8 feed hold (FPGA pins 43, 38, 34, 31, 42, 36), each with the
  iCE40's pull-up: a switch connects its pin to ground (PMOD1B pin 5 or 11);
* ``tool`` (:class:`~kontur.hdl.top.ControllerTop`): the tool outputs of
  :data:`kontur.hdl.motion.tools.TOOL_PINS` (active high) on the free pins beside them:
  spindle/laser/torch enable PMOD1A pin 8, direction (M4) PMOD1A 9, PWM PMOD1A 10, mist
  PMOD1B 9, flood PMOD1B 10 (FPGA pins 48, 46, 44, 32, 28; issue 28);
* the three-axis controller (board ``icebreaker-z``, :func:`platform` with ``axes=3``) has
  Z on PMOD2: pin 1 step Z, pin 2 dir Z (FPGA pins 27, 25), pin 4 Z's limit switch (FPGA
  pin 19, pulled up, INPUTS3's bit 6), the rest as above. PMOD2 is the snap-off LED and
  button section's: left on, its LEDs on pins 1 and 2 show Z's steps and direction and its
  button 2 (pin 4) is in parallel with the Z limit (pressed: tripped); snapped off, PMOD2 is
  a plain PMOD;
* ``shift_in`` (:class:`~kontur.hdl.top.ShiftInTop` through :class:`~kontur.hdl.top.PinnedTop`, for the
  place-and-route benchmarks): inputs on PMOD1B's top row and PMOD2 pins 1-2, outputs on
  PMOD1A and PMOD1B's bottom row; the subsignals carry the names of
  :class:`~kontur.hdl.top.ShiftInTop`'s members.

PMOD pins are numbered as on the connector: 1-4 top row, 7-10 bottom row (5, 6, 11, 12 are
ground and 3.3 V). PMOD2 is the board's snap-off LED and button section; ``shift_in`` uses
two of its pins, which the benchmark builds never share with the LEDs or buttons.
"""

from amaranth.build import Attrs, Pins, PinsN, Resource, Subsignal
from amaranth_boards.icebreaker import ICEBreakerPlatform

__all__ = ["ICEBreakerPlatform", "STEPPER", "SWITCHES", "STEPPER3", "SWITCHES3", "TOOL",
           "SHIFT_IN", "FREE_PINS", "platform", "bench_platform"]

_PMOD1A = ("pmod", 0)
_PMOD1B = ("pmod", 1)
_PMOD2 = ("pmod", 2)
_LVCMOS = Attrs(IO_STANDARD="SB_LVCMOS")

STEPPER = [
    Resource("stepper", 0,
             Subsignal("step", Pins("1 2", dir="o", conn=_PMOD1A)),    # X, Y
             Subsignal("dir", Pins("3 4", dir="o", conn=_PMOD1A)),     # X, Y; 1 = negative
             Subsignal("enable", PinsN("7", dir="o", conn=_PMOD1A)),   # EN/ENA-: low = on
             _LVCMOS),
]

#: The three-axis controller's step/dir: Z's on PMOD2's pins 1 and 2.
STEPPER3 = [
    Resource("stepper", 0,
             Subsignal("step", Pins("pmod_0:1 pmod_0:2 pmod_2:1", dir="o")),   # X, Y, Z
             Subsignal("dir", Pins("pmod_0:3 pmod_0:4 pmod_2:2", dir="o")),    # 1 = negative
             Subsignal("enable", PinsN("7", dir="o", conn=_PMOD1A)),
             _LVCMOS),
]

#: The three-axis controller's switch inputs (:data:`kontur.hdl.motion.inputs.INPUTS3`): Z's
#: limit on PMOD2's pin 4.
SWITCHES3 = [
    Resource("switches", 0,
             Pins("pmod_1:1 pmod_1:2 pmod_1:3 pmod_1:4 pmod_1:7 pmod_1:8 pmod_2:4", dir="i"),
             Attrs(IO_STANDARD="SB_LVCMOS", PULLUP=1)),
]

#: The switch inputs, in the order of :data:`kontur.hdl.motion.inputs.INPUTS`.
SWITCHES = [
    Resource("switches", 0,
             Pins("1 2 3 4 7 8", dir="i", conn=_PMOD1B),
             Attrs(IO_STANDARD="SB_LVCMOS", PULLUP=1)),
]

#: The tool outputs, in the order of :data:`kontur.hdl.motion.tools.TOOL_PINS`: enable,
#: direction, PWM (PMOD1A's bottom row after the enable of the drivers), mist, flood (PMOD1B's
#: bottom row after the switches).
TOOL = [
    Resource("tool", 0, Pins("pmod_0:8 pmod_0:9 pmod_0:10 pmod_1:9 pmod_1:10", dir="o"),
             _LVCMOS),
]

SHIFT_IN = [
    Resource("shift_in", 0,
             Subsignal("sdi", Pins("1", dir="i", conn=_PMOD1B)),
             Subsignal("shift", Pins("2", dir="i", conn=_PMOD1B)),
             Subsignal("valid", Pins("3", dir="i", conn=_PMOD1B)),
             Subsignal("tick", Pins("4", dir="i", conn=_PMOD1B)),
             Subsignal("abort", Pins("1", dir="i", conn=_PMOD2)),
             Subsignal("status_ready", Pins("2", dir="i", conn=_PMOD2)),
             Subsignal("step", Pins("1 2", dir="o", conn=_PMOD1A)),
             Subsignal("dir", Pins("3 4", dir="o", conn=_PMOD1A)),
             Subsignal("busy", Pins("7", dir="o", conn=_PMOD1A)),
             Subsignal("ready", Pins("8", dir="o", conn=_PMOD1A)),
             Subsignal("full", Pins("9", dir="o", conn=_PMOD1A)),
             Subsignal("status_valid", Pins("10", dir="o", conn=_PMOD1A)),
             Subsignal("due", Pins("7", dir="o", conn=_PMOD1B)),
             Subsignal("diagonal", Pins("8", dir="o", conn=_PMOD1B)),
             Subsignal("sdo", Pins("9", dir="o", conn=_PMOD1B)),
             _LVCMOS),
]


def platform(axes=2):
    """Return a new :class:`ICEBreakerPlatform` with :data:`STEPPER`, :data:`SWITCHES`,
    :data:`TOOL` and :data:`SHIFT_IN` (with ``axes=3`` :data:`STEPPER3` and :data:`SWITCHES3`,
    and no ``shift_in``, which shares PMOD2)."""
    board = ICEBreakerPlatform()
    if axes == 3:
        board.add_resources(STEPPER3 + SWITCHES3 + TOOL)
    else:
        board.add_resources(STEPPER + SWITCHES + TOOL + SHIFT_IN)
    return board


#: The pins a generated ``shift_in`` resource takes, in order: PMOD1B, PMOD1A, PMOD2 (top row,
#: then bottom row of each).
FREE_PINS = [ICEBreakerPlatform().connectors[conn].mapping[pin]
             for conn in (_PMOD1B, _PMOD1A, _PMOD2) for pin in "1 2 3 4 7 8 9 10".split()]


def bench_platform(top):
    """Return a new :class:`ICEBreakerPlatform` with a ``shift_in`` resource for ``top`` (any
    :class:`~kontur.hdl.top.ShiftInTop`, see :func:`kontur.constraints.shift_in.resource`)."""
    from kontur.constraints.shift_in import resource
    board = ICEBreakerPlatform()
    board.add_resources(resource(top, FREE_PINS, _LVCMOS))
    return board
