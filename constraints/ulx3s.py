"""ULX3S with the ECP5-85F (LFE5U-85F-6BG381C): the board's platforms.

Two uses, one resource set each:

* :func:`platform`, the machine controller (:class:`~kontur.hdl.top.ControllerTop`): ``stepper`` on
  the GPIO header J1 (``gpio`` connector 0): step X on ``0+`` (GP0, B11), step Y on ``1+``
  (GP1, A10), step Z on ``6+`` (GP6, C6), dir X on ``0-`` (GN0, C11), dir Y on ``1-`` (GN1, A11),
  dir Z on ``6-`` (GN6, C7), enable (active low) on ``2+`` (GP2, A9); ``led_g`` (busy) and ``led_r`` (error) on the board's LEDs 0 and 1 (B2,
  C2); the serial line is the board's own ``uart`` (the FTDI's USB serial port: rx M1, tx L4);
  ``switches``, the seven inputs of :data:`kontur.hdl.motion.inputs.INPUTS3` on J1 with the
  ECP5's pull-ups: e-stop ``3+`` (GP3), limit X ``3-`` (GN3), limit Y ``4+`` (GP4), probe
  ``4-`` (GN4), cycle start ``5+`` (GP5), feed hold ``5-`` (GN5), limit Z ``7+`` (GP7, A6); a
  switch connects its pin to ground (the controller has three axes: issue 28); ``tool``, the
  tool outputs (:data:`kontur.hdl.motion.tools.TOOL_PINS`, active high): spindle/laser/torch
  enable ``8+`` (GP8), direction (M4) ``8-`` (GN8), PWM ``9+`` (GP9), mist ``9-`` (GN9), flood
  ``10+`` (GP10);
* :func:`bench_platform`, the place-and-route benchmarks: a ``shift_in`` resource for any
  :class:`~kontur.hdl.top.ShiftInTop` on the first pins of the GPIO header (``0+``, ``0-``, ``1+``,
  ...).

All LVCMOS33. The board's clock is 25 MHz. Amaranth's ULX3S platform asks for
``OPENFPGALOADER`` even when it only builds; nothing here ever programs.
"""

from amaranth.build import Attrs, Pins, PinsN, Resource, Subsignal
from amaranth_boards.ulx3s import ULX3S_85F_Platform

__all__ = ["ULX3S_85F_Platform", "STEPPER", "SWITCHES", "TOOL", "FREE_PINS", "platform",
           "bench_platform"]

_GPIO = ("gpio", 0)
_LVCMOS33 = Attrs(IO_TYPE="LVCMOS33")

STEPPER = [
    Resource("stepper", 0,
             Subsignal("step", Pins("0+ 1+ 6+", dir="o", conn=_GPIO)),  # X, Y, Z
             Subsignal("dir", Pins("0- 1- 6-", dir="o", conn=_GPIO)),   # X, Y, Z; 1 = negative
             Subsignal("enable", PinsN("2+", dir="o", conn=_GPIO)),     # low: drivers on
             _LVCMOS33),
    Resource("led_g", 0, Pins("B2", dir="o"), Attrs(IO_TYPE="LVCMOS33", DRIVE="4")),   # LED 0
    Resource("led_r", 0, Pins("C2", dir="o"), Attrs(IO_TYPE="LVCMOS33", DRIVE="4")),   # LED 1
]


#: The switch inputs, in the order of :data:`kontur.hdl.motion.inputs.INPUTS3`.
SWITCHES = [
    Resource("switches", 0, Pins("3+ 3- 4+ 4- 5+ 5- 7+", dir="i", conn=_GPIO),
             Attrs(IO_TYPE="LVCMOS33", PULLMODE="UP")),
]


#: The tool outputs, in the order of :data:`kontur.hdl.motion.tools.TOOL_PINS`: enable,
#: direction, PWM, mist, flood.
TOOL = [
    Resource("tool", 0, Pins("8+ 8- 9+ 9- 10+", dir="o", conn=_GPIO), _LVCMOS33),
]


def platform():
    """Return a new :class:`ULX3S_85F_Platform` with :data:`STEPPER`, :data:`SWITCHES` and
    :data:`TOOL`."""
    board = ULX3S_85F_Platform()
    board.add_resources(STEPPER + SWITCHES + TOOL)
    return board

#: The pins a ``shift_in`` resource takes, in order: the GPIO header's pairs 0 to 13.
FREE_PINS = [ULX3S_85F_Platform().connectors[_GPIO].mapping[f"{n}{side}"]
             for n in range(14) for side in "+-"]


def bench_platform(top):
    """Return a new :class:`ULX3S_85F_Platform` with a ``shift_in`` resource for ``top``."""
    from kontur.constraints.shift_in import resource
    board = ULX3S_85F_Platform()
    board.add_resources(resource(top, FREE_PINS, Attrs(IO_TYPE="LVCMOS33")))
    return board
