"""Board tops: a few-pin measurement wrapper for any engine or core, the bare accumulator the
benchmarks hold every design against, pins for any component, the machine controller on a
board, and the iCEBreaker demo.

Only this module calls ``platform.request()``; the resources it asks for (``shift_in``,
``stepper``, ``uart``, ``led_r``, ``led_g``, ``button``) are defined in ``constraints/``.
"""

from amaranth import *
from amaranth.lib import data, io, stream, wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out

from . import spec
from .elements._checks import check_width
from .line import LineEngine
from .linear import LinearCore
from .motion import ProgramPlayer
from .motion.player import check_timing
from .motion.tools import TOOL_PINS, tool_engine

__all__ = ["BareAccumulator", "ShiftInTop", "PinnedTop", "ControllerTop", "DemoTop", "OCTAGON"]

#: The demo program: a closed octagon, one segment in each octant, relative moves: the frames
#: of :data:`kontur.hdl.spec.OCTAGON`, which ``kontur/demo.py`` plots.
OCTAGON = [{"x": x, "y": y} for x, y in spec.OCTAGON]


class BareAccumulator(wiring.Component):
    """The decision loop alone: a register that adds one of two operands chosen by its sign.

    An interpolator making one decision per clock can go no faster than this: the
    accumulator's sign bit selects the operand (:py:`a` while negative, :py:`b` otherwise),
    which is added in the same clock. The operands are registers loaded from :py:`cmd`, so
    that nothing is constant; the sign is the output. It is the benchmarks' reference
    (``kontur bench speed``), not a part of any engine.

    Parameters
    ----------
    width : :class:`int`
        Width of the accumulator and of the operands.

    Members
    -------
    cmd : :py:`In(stream.Signature(BareAccumulator.Operands(width)))`
        New operands, always taken (:py:`cmd.ready` is high).
    sign : :py:`Out(1)`
        The accumulator is negative.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2.
    """

    @staticmethod
    def Operands(width):
        return data.StructLayout({"a": signed(width), "b": signed(width)})

    def __init__(self, width=16):
        check_width("Accumulator width", width, minimum=2)
        self._width = width
        super().__init__({
            "cmd":  In(stream.Signature(self.Operands(width))),
            "sign": Out(1),
        })

    @property
    def width(self):
        return self._width

    def elaborate(self, platform):
        m = Module()
        a = Signal(signed(self._width))
        b = Signal(signed(self._width))
        acc = Signal(signed(self._width))
        m.d.comb += self.cmd.ready.eq(1)
        with m.If(self.cmd.valid):
            m.d.sync += [a.eq(self.cmd.payload.a), b.eq(self.cmd.payload.b)]
        m.d.sync += acc.eq(acc + Mux(acc[-1], a, b))
        m.d.comb += self.sign.eq(acc[-1])
        return m


def _pin_name(path):
    """The wrapper's member for a design's port: ``feed.tick`` is ``tick``, ``motion.step``
    ``step``, ``status.valid`` ``status_valid``; any other path is joined with ``_``."""
    if path[0] in ("feed", "motion"):
        path = path[1:]
    return "_".join(path)


class ShiftInTop(wiring.Component):
    """Few-pin wrapper that keeps every gate of a design: frames shifted in, outcomes out.

    It exists to place and route any engine, core or the :class:`BareAccumulator` on a small
    package (a UP5K in a 48-pin package has 39 I/O) with all of its logic intact: every
    payload bit of the design's :py:`cmd` stream comes from a register loaded through one
    pin, and an engine's outcomes go out through another, so nothing can be constant-folded.

    A frame is sent least significant bit first: in each clock in which :py:`shift` is high,
    :py:`sdi` enters the top of the frame register and the register moves one place down, so
    after ``payload_width`` such clocks it holds the frame. A rising edge of :py:`valid` (high
    in this clock, low in the previous one) then offers the frame on the design's ``cmd``
    stream, which is held offered (:py:`full` high) until the design takes it. Do not shift
    while :py:`full` is high: the offered payload must not change. An outcome taken from an
    engine's status stream (:py:`status_ready` high) is loaded into a register that shifts out
    on :py:`sdo`, least significant bit first, one bit a clock. Every other port of the design
    is a member of the same name (``feed.tick`` is :py:`tick`, ``motion.step`` :py:`step`,
    ``status.valid`` :py:`status_valid`), registered once in the fabric (one clock each way,
    the same for all), so that a measured path runs from register to register inside the
    design, never from a pin across the device: a design's inputs come from registers beside
    it in any system.

    Parameters
    ----------
    engine : :class:`~amaranth.lib.wiring.Component`
        The design: any component with a command stream ``cmd`` (every engine, every core,
        :class:`BareAccumulator`). It becomes the submodule ``engine``.

    Members
    -------
    sdi, shift, valid : :py:`In(1)`
        Serial frame data, its shift enable, and the offer (see above).
    ready : :py:`Out(1)`
        The design's ``cmd.ready``.
    full : :py:`Out(1)`
        A frame is offered and not yet taken.
    sdo : :py:`Out(1)`
        Serial outcome data (an engine's status payload; only if the design has ``status``).
    the design's other ports
        For an engine: :py:`tick`, :py:`abort`, :py:`status_ready` in; :py:`step`,
        :py:`dir`, :py:`due`, :py:`diagonal`, :py:`busy`, :py:`status_valid` out.

    Raises
    ------
    :exc:`TypeError`
        If ``engine`` is not a component with a command stream ``cmd``.
    """

    def __init__(self, engine):
        members = getattr(getattr(engine, "signature", None), "members", {})
        cmd = (members["cmd"] if isinstance(engine, wiring.Component) and "cmd" in members
               else None)
        if (cmd is None or cmd.flow != In or not cmd.is_signature
                or not isinstance(cmd.signature, stream.Signature)):
            raise TypeError(f"Design must be a component with a command stream 'cmd', "
                            f"not {engine!r}")
        self._engine = engine
        self._ports = []                         # (member name, path) of the design's ports
        inputs, outputs = {"sdi": In(1), "shift": In(1), "valid": In(1)}, {}
        status = "status" in members
        for path, member, _ in engine.signature.flatten(engine):
            if path[0] == "cmd" or path == ("status", "payload"):
                continue
            name = _pin_name(path)
            self._ports.append((name, path))
            (inputs if member.flow == In else outputs)[name] = (
                In(member.shape) if member.flow == In else Out(member.shape))
        outputs.update({"ready": Out(1), "full": Out(1)})
        if status:
            outputs["sdo"] = Out(1)
        super().__init__({**inputs, **outputs})

    @property
    def engine(self):
        return self._engine

    @property
    def payload_width(self):
        """Number of bits in a frame (clocks of :py:`shift` per frame)."""
        return Shape.cast(self._engine.cmd.payload.shape()).width

    def elaborate(self, platform):
        m = Module()
        m.submodules.engine = engine = self._engine

        frame = Signal(self.payload_width)
        with m.If(self.shift):
            m.d.sync += frame.eq(Cat(frame[1:], self.sdi))

        valid_q = Signal()
        full = Signal()
        m.d.sync += valid_q.eq(self.valid)
        with m.If(self.valid & ~valid_q):
            m.d.sync += full.eq(1)
        with m.Elif(engine.cmd.ready):
            m.d.sync += full.eq(0)

        if "status" in engine.signature.members:
            outcome = Signal(len(engine.status.payload.as_value()))
            with m.If(engine.status.valid & engine.status.ready):
                m.d.sync += outcome.eq(engine.status.payload)
            with m.Else():
                m.d.sync += outcome.eq(outcome >> 1)
            m.d.sync += self.sdo.eq(outcome[0])     # registered as the ports below are

        m.d.comb += [
            engine.cmd.payload.eq(frame),
            engine.cmd.valid.eq(full),
            self.full.eq(full),
        ]
        m.d.sync += self.ready.eq(engine.cmd.ready)      # registered as the ports below are
        for name, path in self._ports:
            port = engine
            for part in path:
                port = getattr(port, part)
            # Registered in the fabric too: the design's own paths, not the pins', are measured.
            mine = getattr(self, name)
            staged = Signal.like(mine, name=f"{name}_q")
            if self.signature.members[name].flow == In:
                m.d.sync += staged.eq(mine)
                m.d.comb += port.eq(staged)
            else:
                m.d.sync += staged.eq(port)
                m.d.comb += mine.eq(staged)
        return m


class PinnedTop(Elaboratable):
    """Put a component on a board: each member goes to the same-named pin of a resource.

    Every member of ``component`` must be a port (no nested interfaces). The resource must have
    a subsignal of the same name and width for each, and every member is registered in the I/O
    cell (:class:`~amaranth.lib.io.FFBuffer`), so the timing analysis of the placed design sees
    only paths from register to register.

    Parameters
    ----------
    component : :class:`~amaranth.lib.wiring.Component`
        The design; it becomes the submodule ``top``.
    resource : :class:`str`
        Name of the platform resource (number 0) carrying its pins.

    Raises
    ------
    :exc:`TypeError`
        If ``component`` is not a component whose members are all ports, or ``resource`` is
        not a string.
    """

    def __init__(self, component, resource):
        if (not isinstance(component, wiring.Component)
                or not all(member.is_port for member in component.signature.members.values())):
            raise TypeError(f"Component must be a wiring.Component whose members are all ports, "
                            f"not {component!r}")
        if not isinstance(resource, str):
            raise TypeError(f"Resource name must be a string, not {resource!r}")
        self._component = component
        self._resource = resource

    def elaborate(self, platform):
        if platform is None:
            raise TypeError("PinnedTop needs a platform to request its pins from")
        m = Module()
        m.submodules.top = top = self._component
        pins = platform.request(self._resource, 0, dir="-")
        for name, member in top.signature.members.items():
            port = getattr(pins, name)
            value = getattr(top, name)
            if len(port) != len(value):
                raise ValueError(f"Resource {self._resource!r} has {len(port)} pins for "
                                 f"{name!r}, the component {len(value)} bits")
            if member.flow == In:
                m.submodules[f"pin_{name}"] = buffer = io.FFBuffer("i", port)
                m.d.comb += value.eq(buffer.i)
            else:
                m.submodules[f"pin_{name}"] = buffer = io.FFBuffer("o", port)
                m.d.comb += buffer.o.eq(value)
        return m


class ControllerTop(Elaboratable):
    """A :class:`~kontur.hdl.motion.controller.MotionController` on a board's pins.

    The serial line on the board's ``uart`` resource (the USB serial port of its FTDI chip);
    step, dir and enable on the ``stepper`` resource, each registered in its I/O cell (one clock
    later than the controller's members, all alike, so the direction set-up and the pulse width
    are kept); the green LED (``led_g``) lights while frames are queued or running, the red one
    (``led_r``) once a frame has been dropped. The receiver synchronises ``rx`` itself; ``tx``
    comes straight from the transmitter's flip-flop. The switch inputs on the ``switches``
    resource (six pins, :data:`~kontur.hdl.motion.inputs.INPUTS`' order, pulled up) go to the
    controller's :py:`inputs`, which synchronises them itself. With a tool engine in its table
    (:class:`~kontur.hdl.motion.tools.ToolEngine`) its pins go to the ``tool`` resource
    (:data:`~kontur.hdl.motion.tools.TOOL_PINS`' order), registered like step and dir.

    With ``divide`` 2 the controller runs on half the board's clock (a flip-flop toggled by
    the board's clock, constrained as such for nextpnr; the I/O registers on it too), for a
    controller whose longest path does not close at the board's own clock.

    Parameters
    ----------
    controller : :class:`~kontur.hdl.motion.controller.MotionController`
        Built for its clock: the board's, divided by ``divide``.
    divide : :class:`int`
        1 or 2. Default 1.
    """

    def __init__(self, controller, *, divide=1):
        from .motion.controller import MotionController
        if not isinstance(controller, MotionController):
            raise TypeError(f"Controller must be a MotionController, not {controller!r}")
        if divide not in (1, 2):
            raise ValueError(f"Clock division must be 1 or 2, not {divide!r}")
        self._controller = controller
        self._divide = divide

    @property
    def controller(self):
        return self._controller

    @property
    def divide(self):
        return self._divide

    def elaborate(self, platform):
        if platform is None:
            raise TypeError("ControllerTop needs a platform; simulate MotionController instead")
        m = Module()
        domain = "sync"
        controller = self._controller
        if self._divide == 2:
            domain = "motion"
            m.domains.motion = ClockDomain("motion")
            half = Signal()                         # the motion clock: the board's, halved
            m.d.sync += half.eq(~half)
            m.d.comb += [
                ClockSignal("motion").eq(half),
                # The board's reset where it has one (the ULX3S's sync domain has none).
                ResetSignal("motion").eq(ResetSignal(allow_reset_less=True)),
            ]
            platform.add_clock_constraint(half, platform.default_clk_frequency / 2)
            controller = DomainRenamer("motion")(controller)
        m.submodules.controller = controller
        controller = self._controller
        uart = platform.request("uart", 0, dir="-")
        stepper = platform.request("stepper", 0, dir="-")
        m.submodules.rx_buffer = rx = io.Buffer("i", uart.rx)
        # tx straight from the transmitter's flip-flop: an I/O-cell register would start at 0,
        # a false start bit on the host's line at configuration.
        m.submodules.tx_buffer = tx = io.Buffer("o", uart.tx)
        m.submodules.step_buffer = step = io.FFBuffer("o", stepper.step, o_domain=domain)
        m.submodules.dir_buffer = dir_ = io.FFBuffer("o", stepper.dir, o_domain=domain)
        m.submodules.enable_buffer = enable = io.FFBuffer("o", stepper.enable, o_domain=domain)
        m.submodules.switch_buffer = switches = io.Buffer(
            "i", platform.request("switches", 0, dir="-"))
        m.submodules.led_busy = led_busy = io.Buffer("o", platform.request("led_g", 0, dir="-"))
        m.submodules.led_error = led_error = io.Buffer("o", platform.request("led_r", 0, dir="-"))
        tools = tool_engine(controller)
        if tools is not None:                   # the tool outputs, registered as step/dir
            m.submodules.tool_buffer = tool = io.FFBuffer(
                "o", platform.request("tool", 0, dir="-"), o_domain=domain)
            m.d.comb += tool.o.eq(Cat(getattr(tools, name) for name in TOOL_PINS))
        m.d.comb += [
            controller.rx.eq(rx.i),
            controller.inputs.eq(switches.i),
            tx.o.eq(controller.tx),
            step.o.eq(controller.motion.step),
            dir_.o.eq(controller.motion.dir),
            enable.o.eq(controller.enable),
            led_busy.o.eq(controller.busy),
            led_error.o.eq(controller.error),
        ]
        return m


class DemoTop(Elaboratable):
    """iCEBreaker demo: a program played in a loop through an engine, on PMOD pins and LEDs.

    A :class:`ProgramPlayer` on the board: step X, step Y, dir X, dir Y on the ``stepper``
    resource (PMOD1A pins 1-4 in ``constraints/icebreaker.py``), each registered in its I/O
    cell (one clock later than :class:`ProgramPlayer`'s members, all alike); the green LED shows
    ``busy``, the red LED lights at the first refused frame; holding the user button pauses the
    feed. With the defaults on the 12 MHz clock: 1000 steps per second, 2 µs step pulses with
    the direction set up 1 µs before them, and the octagon (100 steps) every 0.1 s.

    Parameters
    ----------
    engine : :class:`~amaranth.lib.wiring.Component` or callable
        The engine, or a callable returning it. Default:
        ``LineEngine(LinearCore(width=16, variant="exact"))``.
    program : :class:`list` of :class:`dict`
        The frames (payload dicts). Default: :data:`OCTAGON`.
    divider : :class:`int`
        Clocks per ``tick``. Default 12000: 1 kHz from the iCEBreaker's 12 MHz.
    dir_setup, step_width : :class:`int`
        See :class:`ProgramPlayer`. Defaults 12 and 24 clocks (1 µs and 2 µs at 12 MHz).

    Raises
    ------
    :exc:`TypeError`, :exc:`ValueError`
        As :class:`ProgramPlayer`; :exc:`TypeError` also if ``engine`` is neither a component
        nor callable.
    """

    def __init__(self, engine=None, program=None, divider=12000, *, dir_setup=12, step_width=24):
        # The numbers first: a refused top then leaves no unused engine behind.
        check_timing(divider, dir_setup, step_width)
        if engine is None:
            engine = LineEngine(LinearCore(width=16, variant="exact"))
        elif not isinstance(engine, wiring.Component):
            if not callable(engine):
                raise TypeError(f"Engine must be a wiring.Component or a callable returning one, "
                                f"not {engine!r}")
            engine = engine()
        self._player = ProgramPlayer(engine, OCTAGON if program is None else program, divider,
                                     dir_setup=dir_setup, step_width=step_width)

    @property
    def player(self):
        return self._player

    def elaborate(self, platform):
        if platform is None:
            raise TypeError("DemoTop needs a platform; simulate ProgramPlayer instead")
        m = Module()
        m.submodules.player = player = self._player

        stepper = platform.request("stepper", 0, dir="-")
        m.submodules.step_buffer = step_buffer = io.FFBuffer("o", stepper.step)
        m.submodules.dir_buffer = dir_buffer = io.FFBuffer("o", stepper.dir)
        m.submodules.enable_buffer = enable_buffer = io.FFBuffer("o", stepper.enable)
        m.submodules.switch_buffer = switches = io.Buffer(
            "i", platform.request("switches", 0, dir="-"))
        m.submodules.led_busy = led_busy = io.Buffer("o", platform.request("led_g", 0, dir="-"))
        m.submodules.led_error = led_error = io.Buffer("o", platform.request("led_r", 0, dir="-"))
        m.submodules.button = button = io.Buffer("i", platform.request("button", 0, dir="-"))
        m.submodules.pause_sync = FFSynchronizer(button.i, player.pause)
        m.d.comb += [
            step_buffer.o.eq(player.motion.step),
            dir_buffer.o.eq(player.motion.dir),
            enable_buffer.o.eq(1),
            led_busy.o.eq(player.busy),
            led_error.o.eq(player.error),
        ]
        return m
