"""Board tops: a few-pin measurement wrapper for any engine, and the iCEBreaker demo.

Everything here works on any engine with the common interface (``cmd`` stream of a
:mod:`~amaranth.lib.data` layout, ``tick``, ``step``, ``dir``, ``busy``, ``done``, ``error``).
Only this module calls ``platform.request()``; the resources it asks for (``shift_in``,
``stepper``, ``led_r``, ``led_g``, ``button``) are defined in ``constraints/``.
"""

from amaranth import *
from amaranth.hdl import ShapeCastable
from amaranth.lib import data, io, wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .linear import LineEngine

__all__ = ["ShiftInTop", "PinnedTop", "ProgramPlayer", "DemoTop", "OCTAGON", "ENGINE_MEMBERS"]

#: Members every engine has (see ``docs/architecture.md``).
ENGINE_MEMBERS = ("cmd", "tick", "step", "dir", "busy", "done", "error")

#: The demo program: a closed octagon, one segment in each octant, relative moves. The same
#: frames as ``OCTAGON`` in ``sim/demo.py`` (copied: ``hdl/`` never imports ``sim/``; a test
#: checks that the two agree).
OCTAGON = [
    {"x": 14, "y": 4}, {"x": 9, "y": 11}, {"x": -9, "y": 11}, {"x": -14, "y": 4},
    {"x": -14, "y": -4}, {"x": -9, "y": -11}, {"x": 9, "y": -11}, {"x": 14, "y": -4},
]


def _check_engine(engine):
    """Raise :exc:`TypeError` unless ``engine`` has the common engine interface; return its
    payload layout."""
    members = getattr(getattr(engine, "signature", None), "members", None)
    if (not isinstance(engine, wiring.Component) or members is None
            or any(name not in members for name in ENGINE_MEMBERS)):
        raise TypeError(f"Engine must be a wiring.Component with members "
                        f"{', '.join(ENGINE_MEMBERS)}, not {engine!r}")
    shape = engine.cmd.payload.shape()
    try:
        return data.Layout.cast(shape)
    except TypeError:
        raise TypeError(f"Engine command payload must have a data layout, not {shape!r}")


def _check_int(name, value, minimum):
    if not isinstance(value, int) or isinstance(value, bool) or value < minimum:
        if minimum == 1:
            raise TypeError(f"{name} must be a positive integer, not {value!r}")
        raise TypeError(f"{name} must be an integer of at least {minimum}, not {value!r}")


def _check_timing(divider, dir_setup, step_width):
    _check_int("Tick divider", divider, 1)
    _check_int("Direction setup", dir_setup, 0)
    _check_int("Step pulse width", step_width, 1)
    if dir_setup + step_width >= divider:
        raise ValueError(f"Direction setup plus step pulse width must be less than the tick "
                         f"divider {divider}, not {dir_setup + step_width!r}")


def _check_frame(layout, frame):
    """Raise unless ``frame`` (a dict) is a payload of ``layout`` with every value in range."""
    if not isinstance(frame, dict):
        raise TypeError(f"A frame must be a dict of payload fields, not {frame!r}")
    fields = dict(layout)
    for name, value in frame.items():
        if name not in fields:
            raise ValueError(f"Frame {frame!r} has a field {name!r} that the payload "
                             f"({', '.join(fields)}) does not have")
        if not isinstance(value, int):
            raise TypeError(f"Frame field {name!r} must be an integer, not {value!r}")
        shape = fields[name].shape
        if not isinstance(shape, ShapeCastable):        # a plain shape: check the range here
            shape = Shape.cast(shape)
            low = -(1 << (shape.width - 1)) if shape.signed else 0
            high = (1 << (shape.width - shape.signed)) - 1
            if not low <= value <= high:
                raise ValueError(f"Frame field {name!r} = {value!r} does not fit {shape!r}")


class ShiftInTop(wiring.Component):
    """Few-pin wrapper that keeps every gate of an engine: the frame is shifted in serially.

    It exists to place and route any engine on a small package (a UP5K in a 48-pin package has
    39 I/O) with all of its logic intact: every payload bit comes from a register loaded through
    one pin, so nothing can be constant-folded, and every engine output goes to a member.

    A frame is sent least significant bit first: in each clock in which :py:`shift` is high,
    :py:`sdi` enters the top of the frame register and the register moves one place down, so
    after ``payload_width`` such clocks it holds the frame. A rising edge of :py:`valid` (high
    in this clock, low in the previous one) then offers the frame on the engine's ``cmd``
    stream, which is held offered (:py:`full` high) until the engine takes it. Do not shift
    while :py:`full` is high: the offered payload must not change. Everything else is the
    engine's own port: :py:`tick` in, :py:`step`, :py:`dir`, :py:`busy`, :py:`done`,
    :py:`error` and the stream's :py:`ready` out, so the wrapper adds no clock to them.

    Parameters
    ----------
    engine : :class:`~amaranth.lib.wiring.Component`
        Any engine with the common interface. It becomes the submodule ``engine``.

    Members
    -------
    sdi : :py:`In(1)`
        Serial frame data.
    shift : :py:`In(1)`
        Shift :py:`sdi` into the frame register in this clock.
    valid : :py:`In(1)`
        A rising edge offers the frame register to the engine.
    tick : :py:`In(1)`
        The engine's feed-rate strobe.
    step, dir : :py:`Out(2)`
        The engine's step pulses and directions.
    busy, done, error : :py:`Out(1)`
        The engine's status.
    ready : :py:`Out(1)`
        The engine's ``cmd.ready``.
    full : :py:`Out(1)`
        A frame is offered and not yet taken.

    Raises
    ------
    :exc:`TypeError`
        If ``engine`` lacks the common interface or its payload has no data layout.
    """

    def __init__(self, engine):
        self._layout = _check_engine(engine)
        self._engine = engine
        super().__init__({
            "sdi":   In(1),
            "shift": In(1),
            "valid": In(1),
            "tick":  In(1),
            "step":  Out(2),
            "dir":   Out(2),
            "busy":  Out(1),
            "done":  Out(1),
            "error": Out(1),
            "ready": Out(1),
            "full":  Out(1),
        })

    @property
    def engine(self):
        return self._engine

    @property
    def payload_width(self):
        """Number of bits in a frame (clocks of :py:`shift` per frame)."""
        return self._layout.size

    def elaborate(self, platform):
        m = Module()
        m.submodules.engine = engine = self._engine

        frame = Signal(self._layout.size)
        with m.If(self.shift):
            m.d.sync += frame.eq(Cat(frame[1:], self.sdi))

        valid_q = Signal()
        full = Signal()
        m.d.sync += valid_q.eq(self.valid)
        with m.If(self.valid & ~valid_q):
            m.d.sync += full.eq(1)
        with m.Elif(engine.cmd.ready):
            m.d.sync += full.eq(0)

        m.d.comb += [
            engine.cmd.payload.eq(frame),
            engine.cmd.valid.eq(full),
            engine.tick.eq(self.tick),
            self.step.eq(engine.step),
            self.dir.eq(engine.dir),
            self.busy.eq(engine.busy),
            self.done.eq(engine.done),
            self.error.eq(engine.error),
            self.ready.eq(engine.cmd.ready),
            self.full.eq(full),
        ]
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


class ProgramPlayer(wiring.Component):
    """Play a program of frames through an engine in a loop, with step/dir timed for drivers.

    The frames sit in a ROM and are offered to the engine one after the other, back to back,
    from the first clock after reset; after the last comes the first again. The engine's
    ``tick`` is high in one clock of every ``divider`` (the feed rate: at most one step per
    axis per ``divider`` clocks), except while :py:`pause` is high.

    The engine's ``step`` pulses last one clock and its ``dir`` changes with the first step of
    a frame, which is too fast for a stepper driver. Here, for each axis, a step in clock ``k``
    latches the engine's direction onto :py:`dir` in clock ``k + 1`` and drives :py:`step` high
    in clocks ``k + 1 + dir_setup`` to ``k + dir_setup + step_width``: the direction is set up
    ``dir_setup`` clocks before the rising edge of the step and held at least
    ``divider - dir_setup`` clocks after it.

    Parameters
    ----------
    engine : :class:`~amaranth.lib.wiring.Component`
        Any engine with the common interface. It becomes the submodule ``engine``.
    program : :class:`list` of :class:`dict`
        The frames, as payload dicts (field name to integer; a missing field is zero).
    divider : :class:`int`
        Clocks per ``tick``.
    dir_setup : :class:`int`
        Clocks from a direction change to the rising edge of the step pulse (0 or more).
    step_width : :class:`int`
        Length of a step pulse in clocks.

    Members
    -------
    pause : :py:`In(1)`
        Hold the feed: no ``tick`` reaches the engine while it is high.
    step : :py:`Out(2)`
        Step pulses, ``step_width`` clocks long; bit 0 X, bit 1 Y.
    dir : :py:`Out(2)`
        Directions (1 negative), valid from ``dir_setup`` clocks before each step pulse.
    busy : :py:`Out(1)`
        The engine's ``busy``.
    error : :py:`Out(1)`
        The engine has refused a frame since reset (sticky).

    Raises
    ------
    :exc:`TypeError`
        If ``engine`` lacks the common interface, ``program`` is not a non-empty list of dicts,
        a frame value is not an integer, ``divider`` or ``step_width`` is not a positive integer
        or ``dir_setup`` not a non-negative one.
    :exc:`ValueError`
        If a frame has a field the payload lacks or a value out of its field's range, or the
        step pulse does not end before the next step can come
        (``dir_setup + step_width >= divider``).
    """

    def __init__(self, engine, program, divider, *, dir_setup=0, step_width=1):
        _check_timing(divider, dir_setup, step_width)
        layout = _check_engine(engine)
        if not isinstance(program, (list, tuple)) or not program:
            raise TypeError(f"Program must be a non-empty list of frames, not {program!r}")
        for frame in program:
            _check_frame(layout, frame)
        self._engine = engine
        self._layout = layout
        self._program = [dict(frame) for frame in program]
        self._divider = divider
        self._dir_setup = dir_setup
        self._step_width = step_width
        super().__init__({
            "pause": In(1),
            "step":  Out(2),
            "dir":   Out(2),
            "busy":  Out(1),
            "error": Out(1),
        })

    @property
    def engine(self):
        return self._engine

    @property
    def program(self):
        return [dict(frame) for frame in self._program]

    @property
    def divider(self):
        return self._divider

    @property
    def dir_setup(self):
        return self._dir_setup

    @property
    def step_width(self):
        return self._step_width

    def elaborate(self, platform):
        m = Module()
        m.submodules.engine = engine = self._engine
        depth = len(self._program)

        # ---- the program ROM, played in a loop -------------------------------------------------
        m.submodules.rom = rom = Memory(shape=self._layout, depth=depth, init=self._program)
        read = rom.read_port()
        index = Signal(range(depth))
        primed = Signal()                    # the read port holds frame 0 (one clock after reset)
        accept = Signal()
        following = Mux(index == depth - 1, 0, index + 1)
        m.d.sync += primed.eq(1)
        m.d.comb += [
            accept.eq(engine.cmd.valid & engine.cmd.ready),
            read.addr.eq(Mux(accept, following, index)),
            engine.cmd.valid.eq(primed),
            engine.cmd.payload.eq(read.data),
        ]
        with m.If(accept):
            m.d.sync += index.eq(following)

        # ---- feed rate -------------------------------------------------------------------------
        phase = Signal(range(self._divider))
        last = phase == self._divider - 1
        m.d.sync += phase.eq(Mux(last, 0, phase + 1))
        m.d.comb += engine.tick.eq(last & ~self.pause)

        # ---- step/dir timing for drivers -------------------------------------------------------
        setup, width = self._dir_setup, self._step_width
        for axis in range(2):
            left = Signal(range(setup + width + 1), name=f"left_{'xy'[axis]}")
            with m.If(engine.step[axis]):
                m.d.sync += [
                    left.eq(setup + width),
                    self.dir[axis].eq(engine.dir[axis]),
                ]
            with m.Elif(left != 0):
                m.d.sync += left.eq(left - 1)
            m.d.comb += self.step[axis].eq((left != 0) & (left <= width))

        with m.If(engine.error):
            m.d.sync += self.error.eq(1)
        m.d.comb += self.busy.eq(engine.busy)
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
        The engine, or a callable returning it (such as the class :class:`LineEngine`).
        Default: ``LineEngine(width=16, variant="exact")``.
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
        _check_timing(divider, dir_setup, step_width)
        if engine is None:
            engine = LineEngine(width=16, variant="exact")
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
        m.submodules.led_busy = led_busy = io.Buffer("o", platform.request("led_g", 0, dir="-"))
        m.submodules.led_error = led_error = io.Buffer("o", platform.request("led_r", 0, dir="-"))
        m.submodules.button = button = io.Buffer("i", platform.request("button", 0, dir="-"))
        m.submodules.pause_sync = FFSynchronizer(button.i, player.pause)
        m.d.comb += [
            step_buffer.o.eq(player.step),
            dir_buffer.o.eq(player.dir),
            led_busy.o.eq(player.busy),
            led_error.o.eq(player.error),
        ]
        return m
