"""One registry of what kontur is made of: kinds of command, their variants, and boards.

A *kind* is a kind of command with its engine (a front end of ``hdl/``) and the engine's
cycle model: ``line`` (:class:`kontur.hdl.line.LineEngine`), ``arc`` (:class:`kontur.hdl.arc.ArcEngine`) and
``profile`` (:class:`kontur.hdl.equidistant.EquidistantEngine`, whose commands are a *program*: the
frames of a contour, prepared by the host from G-code).
A *variant* of a kind is a core that plugs into that engine, with the core's cycle model, its
step-level model, the parameters it takes and what the generic tests hold it to. A *board*
has a platform (``constraints/``) and a demo top.

The registry is the composition root, on the top floor: it names the classes and functions
of ``hdl/``, ``sim/models/`` and ``constraints/`` directly, and the tables at the end of this
module (:data:`KIND_TABLE`, :data:`VARIANT_TABLE`, :data:`BOARD_TABLE`) are declarations, one
entry each. ``kontur trace``, ``bench``, ``demo``, ``build`` and the tests all read them, so a
new variant is added by the file that holds its core and model and one :class:`Variant` entry;
nothing else lists variants (the tests derive their lists from :func:`variants`).
"""

import math
from dataclasses import dataclass, field

from kontur.hdl.arc import ArcEngine
from kontur.hdl.circular import FaithfulArcCore, FastArcCore
from kontur.hdl.circular_timing import FaithfulTiming
from kontur.hdl.equidistant import SETTLE, EquidistantEngine
from kontur.hdl.line import LineEngine
from kontur.hdl.linear import LinearCore
from kontur.hdl.motion.controller import MotionController
from kontur.hdl.motion.homing import homing_row
from kontur.hdl.motion.tools import tool_row
from kontur.hdl.serial import SerialArcCore, SerialLineCore
from kontur.hdl.spatial import SpatialLineCore
from kontur.hdl.textbook import DdaCore, SeparateArcCore, SeparateLineCore
from kontur.hdl.top import DemoTop
from kontur.sim.models.arc import ArcEngineModel, arc_steps, check_arc, round_sqrt
from kontur.sim.models.circular import FaithfulArcCoreModel, FastArcCoreModel
from kontur.sim.models.equidistant import EquidistantEngineModel, Formats, frame_outcomes
from kontur.sim.models.errors import InputError
from kontur.sim.models.line import LineEngineModel
from kontur.sim.models.linear import LinearCoreModel, check_line
from kontur.sim.models.linear import steps as linear_steps
from kontur.sim.models.serial import SerialArcCoreModel, SerialLineCoreModel, word_length
from kontur.sim.models.spatial import SpatialLineCoreModel
from kontur.sim.models.spatial import line_steps as spatial_line_steps
from kontur.sim.models.textbook import (DdaCoreModel, SeparateArcCoreModel, SeparateLineCoreModel,
                                 dda_capacity, dda_steps, separate_arc_steps,
                                 separate_line_steps)

__all__ = ["Kind", "Variant", "Board", "KINDS", "VARIANTS", "BOARDS", "KIND_TABLE",
           "VARIANT_TABLE", "BOARD_TABLE", "InputError", "register", "kind", "variant",
           "variants", "make_core", "make_engine", "make_model", "board", "make_controller",
           "check", "steps", "outcomes"]


@dataclass(frozen=True)
class Kind:
    """A kind of command and the engine that runs it.

    ``engine`` and ``model`` are called as ``engine(core)`` and ``model(core_model)``;
    ``fields`` are the frame's integer fields in command-line order; ``check(*values, width)``
    raises :exc:`InputError` for a command the engine refuses, ``values`` being the payload's
    ``checked`` fields in that order (for a ``program`` kind, ``check(frames, width)``). For a
    ``program`` kind the payload is a list of frames, and a variant's ``steps(frames, width)``
    gives every frame's ``(outcome, steps)``.
    """
    name: str
    help: str
    engine: object
    model: object
    fields: tuple
    check: object
    default_variant: str
    default_width: int
    program: bool = False
    checked: tuple = ()


@dataclass(frozen=True)
class Variant:
    """A core of a kind.

    1. ``core(width=, **fixed, **params)`` builds the RTL core, ``model(width=, **fixed,
       **params)`` its cycle model; ``steps(**payload, width=, **fixed, **params)`` returns the
       step-level trajectory, a list of ``(dx, dy)`` (for a ``program`` kind ``steps(frames,
       width)``, every frame's ``(outcome, steps)``). ``fixed`` are the parameters that make
       this variant of a class that serves several (``LinearCore(variant="exact")``).
    2. ``params`` names the parameters besides ``width`` that a user may give.
    3. ``margin``: the core is that many bits wider than the kind's coordinates (the
       equidistant engine's arc core: 2).
    4. ``clocks(payload, width, **params)``, if given, is an upper bound on the clocks the core
       takes for a command at full feed (its own setup included, the front end's not); without
       it a core makes one step per clock (or per generator period) and no more steps than the
       longer projection of a line or ``8R + 8`` for an arc.
    5. What the generic tests hold it to: ``widths``, the register widths the engine suites
       (cocotb, both simulators) run it at (empty: the kind's default width alone);
       ``accuracy``, the bound of its path's deviation in steps (``kontur bench accuracy``:
       the largest distance of a visited point from the segment, or the radial error of an
       arc), which the accuracy bench's test checks for every variant; ``None`` where the
       deviation has no bound independent of the command's length.
    6. ``step_clocks``: the clocks a step of the core at full feed apart from its generator's
       period, an :class:`int` or a function of the width (the shortest interval between two
       of its steps on a line or an arc: its rate; a quadrant's change may take longer).
       :func:`step_clocks` gives the longer of it and the generator's period; a board's
       slowest engine's bounds its step rate as the step/dir timing does
       (:meth:`Board.slowest`, :func:`check_machine`).
    """
    kind: str
    name: str
    help: str
    core: object
    model: object
    steps: object
    params: tuple = ()
    min_width: int = 2
    clocks: object = None
    fixed: dict = field(default_factory=dict)
    margin: int = 0
    widths: tuple = ()
    accuracy: float = None
    step_clocks: object = 1


@dataclass(frozen=True)
class Board:
    """A board: ``platform()`` returns a new Amaranth platform, ``demo()`` its demo top (a
    program played in a loop); ``clock_hz`` is the machine controller's clock, the board's
    divided by ``divide`` (see :class:`kontur.hdl.top.ControllerTop`), ``line`` and ``arc`` the
    ``(variant, width)`` of its engines, ``profile`` that of its equidistant engine
    (cutter-radius compensation, G41/G42), or ``None`` where the board has no room for one
    (see :func:`make_controller`); ``overrides`` whether its feed generator has the feed and
    rapid overrides (:class:`kontur.hdl.motion.feed.FeedGenerator`) and its tool outputs the
    spindle override; ``homing`` whether it has
    the homing engine (:class:`kontur.hdl.motion.homing.HomingEngine`: HOME frames, homing to
    the limit switches; a board without it reports HOME an unknown frame type); ``tools``
    whether it has the tool outputs (:class:`kontur.hdl.motion.tools.ToolEngine`: TOOL frames,
    the spindle/laser/torch and coolant pins; a board without them lists the program's tool
    words in the summary and drives no pin); ``laser_mode`` whether those outputs have Grbl's
    laser mode (the PWM following the feed generator's rate; without it, about 115 LC fewer on
    the UP5K, a machine file's ``laser = true`` is refused for the board); ``axes`` 2 or
    3: with 3 the controller has Z (its line engine the spatial core on three axes, its arc
    engine a :class:`kontur.hdl.helix.HelixEngine` around the ``arc`` engine: LINE3 and HELIX
    frames)."""
    name: str
    help: str
    platform: object
    demo: object
    clock_hz: float
    line: tuple = ("exact", 16)
    arc: tuple = ("fast", 24)
    divide: int = 1
    profile: tuple = None
    overrides: bool = True
    homing: bool = False
    tools: bool = False
    laser_mode: bool = True
    axes: int = 2

    @property
    def engines(self):
        """``(kind, variant, width)`` of each engine the controller has (on three axes the
        line engine is the spatial core, :func:`make_controller`; the helix engine makes its
        steps at its arc core's rate)."""
        line = ("spatial", self.line[1]) if self.axes == 3 else self.line
        return [(kind, *spec) for kind, spec in (("line", line), ("arc", self.arc),
                                                 ("profile", self.profile))
                if spec is not None]

    def slowest(self):
        """``(clocks, kind, variant, width)`` of the engine that takes the most clocks a step
        (:func:`step_clocks`; the first of those with it)."""
        return max(((step_clocks(*engine), *engine) for engine in self.engines),
                   key=lambda row: row[0])


KINDS = {}
VARIANTS = {}
BOARDS = {}


def register(item):
    """Add a :class:`Kind`, :class:`Variant` or :class:`Board`; return it."""
    if isinstance(item, Kind):
        table, key = KINDS, item.name
    elif isinstance(item, Variant):
        if item.kind not in KINDS:
            raise ValueError(f"Variant {item.name!r} is of an unknown kind {item.kind!r}")
        table, key = VARIANTS, (item.kind, item.name)
    elif isinstance(item, Board):
        table, key = BOARDS, item.name
    else:
        raise TypeError(f"Only a Kind, Variant or Board can be registered, not {item!r}")
    if key in table:
        raise ValueError(f"{type(item).__name__} {key!r} is registered already")
    table[key] = item
    return item


def kind(name):
    """The :class:`Kind` ``name``; :exc:`ValueError` if there is none."""
    if name not in KINDS:
        raise ValueError(f"Kind must be one of {', '.join(map(repr, KINDS))}, not {name!r}")
    return KINDS[name]


def variants(kind_name):
    """Names of the variants of a kind, in the order they were registered."""
    kind(kind_name)
    return tuple(name for k, name in VARIANTS if k == kind_name)


def variant(kind_name, name=None):
    """The :class:`Variant` ``name`` of a kind (its default without a name)."""
    name = kind(kind_name).default_variant if name is None else name
    if (kind_name, name) not in VARIANTS:
        raise ValueError(f"{kind_name} variant must be one of "
                         f"{', '.join(map(repr, variants(kind_name)))}, not {name!r}")
    return VARIANTS[kind_name, name]


def step_clocks(kind_name, name=None, width=None, **params):
    """The clocks a step of a variant's core at ``width`` (its default width without one) at
    full feed, built with ``params`` (its defaults without them): the longer of its
    generator's period (a ``period`` parameter, or a faithful ``timing``'s period) and
    :attr:`Variant.step_clocks`."""
    item = variant(kind_name, name)
    width = KINDS[kind_name].default_width if width is None else width
    clocks = item.step_clocks
    floor = clocks(width) if callable(clocks) else clocks
    if "timing" in item.params:
        period = (params.get("timing") or FaithfulTiming()).period
    else:
        period = params.get("period") or 1
    return max(floor, period)


def check_machine(board_name, machine):
    """Return ``machine`` if ``board_name``'s engines make its highest feed, else raise
    :exc:`kontur.machine.RateError` (naming ``max_feed``): ``max_feed`` in steps a second
    at most the controller's clock over its slowest engine's clocks a step
    (:meth:`Board.slowest`; the bit-serial node's is its word length). The step/dir timing's
    bound is :class:`~kontur.machine.Machine`'s own."""
    from kontur.machine import RateError
    item = board(board_name)
    clocks, kind_name, name, width = item.slowest()
    rate = item.clock_hz / clocks
    need = machine.max_feed / 60 * machine.steps_per_mm
    if need > rate:
        raise RateError(
            f"max_feed {machine.max_feed:g} mm/min is {need:.0f} steps/s, more than the "
            f"{rate:.0f} the {item.name}'s {kind_name} engine makes ({name} at {width} bits: "
            f"a step every {clocks} clocks)")
    return machine


def _arguments(item, width, params):
    width = KINDS[item.kind].default_width if width is None else width
    if isinstance(width, bool) or not isinstance(width, int) or width < item.min_width:
        raise TypeError(f"Register width must be an integer of at least {item.min_width}, "
                        f"not {width!r}")
    for name in params:
        if name not in item.params:
            takes = ", ".join(map(repr, item.params)) or "nothing but 'width'"
            raise TypeError(f"{item.kind} variant {item.name!r} takes no parameter {name!r} "
                            f"(it takes {takes})")
    return {"width": width, **params}


def _built(item, factory, width, params):
    arguments = _arguments(item, width, params)
    arguments["width"] += item.margin
    return factory(**item.fixed, **arguments)


def make_core(kind_name, variant_name=None, *, width=None, **params):
    """The RTL core of a variant alone (``margin`` bits wider than ``width``)."""
    item = variant(kind_name, variant_name)
    return _built(item, item.core, width, params)


def make_engine(kind_name, variant_name=None, *, width=None, **params):
    """The RTL engine of a kind around the core of a variant."""
    item = variant(kind_name, variant_name)
    return KINDS[kind_name].engine(_built(item, item.core, width, params))


def make_model(kind_name, variant_name=None, *, width=None, **params):
    """The cycle model of :func:`make_engine` with the same arguments."""
    item = variant(kind_name, variant_name)
    return KINDS[kind_name].model(_built(item, item.model, width, params))


def board(name):
    """The :class:`Board` ``name`` (a :class:`Board` itself is returned as it is: a board not
    registered, for tests); :exc:`ValueError` if there is none."""
    if isinstance(name, Board):
        return name
    if name not in BOARDS:
        raise ValueError(f"Board must be one of {', '.join(map(repr, BOARDS))}, not {name!r}")
    return BOARDS[name]


def make_controller(board_name, machine):
    """The machine controller of a board (:class:`kontur.hdl.motion.controller.MotionController`)
    with its engines (the equidistant engine too where the board has one), its clock, and the
    serial rate, queue length and step/dir timing of ``machine`` (a
    :class:`kontur.machine.Machine`, whose ``clock_hz`` must be the board's).
    """
    item = board(board_name)
    if machine.clock_hz != item.clock_hz:
        raise ValueError(f"The machine's clock is {machine.clock_hz:g} Hz, the {item.name}'s "
                         f"{item.clock_hz:g} Hz")
    profile = None if item.profile is None else \
        make_engine("profile", item.profile[0], width=item.profile[1])
    if item.axes == 3:
        from kontur.hdl.helix import HelixEngine
        line = LineEngine(SpatialLineCore(width=item.line[1], axes=3))
        arc = HelixEngine(make_engine("arc", item.arc[0], width=item.arc[1]))
    else:
        line = make_engine("line", item.line[0], width=item.line[1])
        arc = make_engine("arc", item.arc[0], width=item.arc[1])
    engines = [homing_row(axes=item.axes)] if item.homing else []
    if item.tools:
        engines.append(tool_row(s_max=machine.s_max, period=machine.pwm_period,
                                laser_mode=item.laser_mode, spindle_override=item.overrides,
                                axes=item.axes))
    return MotionController(line=line, arc=arc, profile=profile, engines=engines,
                            clock_hz=item.clock_hz, baud=machine.baud,
                            queue_frames=machine.queue_frames, dir_setup=machine.dir_setup,
                            step_width=machine.step_width, input_filter=machine.input_filter,
                            polarity=machine.polarity, overrides=item.overrides)


def check(kind_name, payload, width):
    """Raise :exc:`InputError` if the engine of a kind refuses ``payload`` at ``width``."""
    item = kind(kind_name)
    if item.program:
        item.check(payload, width)
    else:
        item.check(*(payload[name] for name in item.checked), width)


def _trajectory(item, payload, width, params):
    if KINDS[item.kind].program:
        return item.steps(payload, width, **params)
    return item.steps(**payload, width=width, **item.fixed, **params)


def steps(kind_name, payload, variant_name=None, *, width=None, **params):
    """The step-level trajectory of ``payload`` (a program's frames for a program kind): a
    list of ``(dx, dy)``. ``params`` are those of the variant that change its trajectory (none
    for most)."""
    item = variant(kind_name, variant_name)
    arguments = _arguments(item, width, params)
    width = arguments.pop("width")
    if kind(kind_name).program:
        return [step for _, path in _trajectory(item, payload, width, arguments)
                for step in path]
    return _trajectory(item, payload, width, arguments)


def outcomes(kind_name, frames, variant_name=None, *, width=None):
    """What the engine makes of ``frames`` (no abort), frame by frame at the step level: a list
    of ``(outcome, steps)``, ``outcome`` 0 (done) or 1 (refused)."""
    item = variant(kind_name, variant_name)
    width = _arguments(item, width, {})["width"]
    if kind(kind_name).program:
        return _trajectory(item, frames, width, {})
    result = []
    for frame in frames:
        try:
            result.append((0, _trajectory(item, frame, width, {})))
        except InputError:
            result.append((1, []))
    return result


# ---- what the tables need besides the classes and functions they name --------------------

def _profile_outcomes(frames, width):
    """Every frame's ``(outcome, steps)`` on the equidistant engine at ``width``."""
    return frame_outcomes(frames, Formats(width))


def _profile_check(frames, width):
    for number, (outcome, _) in enumerate(_profile_outcomes(frames, width)):
        if outcome:
            raise InputError(f"frame {number} is refused")


def _arc_radius(payload):
    return round_sqrt(payload["x0"] ** 2 + payload["y0"] ** 2)


def _separate_line_clocks(payload, width, **params):
    return abs(payload["x"]) + abs(payload["y"]) + 2


def _dda_clocks(payload, width, capacity="segment", **params):
    # N iterations, a clock each
    return (1 << dda_capacity(payload["x"], payload["y"], width=width, capacity=capacity)) + 2


def _separate_arc_clocks(payload, width, **params):
    return 8 * _arc_radius(payload) + 16             # 2·Rn steps a quadrant, up to 4 of them


def _serial_line_clocks(payload, width, **params):
    return word_length(width) * (abs(payload["x"]) + abs(payload["y"]) + 2) + 2


def _serial_arc_clocks(payload, width, **params):
    return word_length(width) * (8 * _arc_radius(payload) + 16)   # up to 5 runs: 3 words more


def _icebreaker_platform():
    from kontur.constraints import icebreaker          # amaranth_boards: only when a board is built
    return icebreaker.platform()


def _icebreaker_z_platform():
    from kontur.constraints import icebreaker
    return icebreaker.platform(axes=3)


def _ulx3s_platform():
    from kontur.constraints import ulx3s
    return ulx3s.platform()


# ---- the kinds, variants and boards of kontur --------------------------------------------

#: Half a step: the patents' bound (SU 1571551's equation (1), 0.5 cos α for a line; SU
#: 1665343's radial error). The estimating function's separate steps: half the diagonal of a
#: step's square. The device as drawn and the DDA: less than one step.
HALF, HALF_DIAGONAL, ONE = 0.5, 1 / math.sqrt(2), 1.0

KIND_TABLE = (
    Kind("line", "segment from the origin to (X, Y)", LineEngine, LineEngineModel,
         ("x", "y"), check_line, "exact", 16, checked=("x", "y")),
    Kind("arc", "arc around the origin from (X0, Y0) to (X1, Y1), a full circle when they "
                "are equal", ArcEngine, ArcEngineModel,
         ("x0", "y0", "x1", "y1", "cw"), check_arc, "faithful", 24,
         checked=("x0", "y0", "x1", "y1")),
    Kind("profile", "a contour of a G-code program: the cutter's centre on its equidistant "
                    "(T. Siimut, 1963)", EquidistantEngine, EquidistantEngineModel,
         (), _profile_check, "fast", 8, program=True),
)

VARIANT_TABLE = (
    Variant("line", "device", "SU 1571551 as its device is drawn: counter-fed increments",
            LinearCore, LinearCoreModel, linear_steps, fixed={"variant": "device"},
            params=("period",), widths=(16, 32), accuracy=ONE),
    Variant("line", "exact", "SU 1571551's equation (1): constant increments",
            LinearCore, LinearCoreModel, linear_steps, fixed={"variant": "exact"},
            params=("period",), widths=(16, 32), accuracy=HALF),
    # The third axis's core on two axes (its steps are exact's; axes=3 in docs/architecture.md,
    # "The third axis"), so the generic suites hold it to the engine contract.
    Variant("line", "spatial", "SU 1571551's function per axis against the dominant one",
            SpatialLineCore, SpatialLineCoreModel, spatial_line_steps, fixed={"axes": 2},
            accuracy=HALF),
    Variant("arc", "faithful", "SU 1665343's structure and timing, 4 clocks a step",
            FaithfulArcCore, FaithfulArcCoreModel, arc_steps, params=("timing",),
            widths=(24, 32), accuracy=HALF),
    Variant("arc", "fast", "SU 1665343's trajectory, one step per clock",
            FastArcCore, FastArcCoreModel, arc_steps, params=("period",),
            widths=(24, 32), accuracy=HALF),
    Variant("profile", "fast", "arcs on SU 1665343's one-step-per-clock core",
            FastArcCore, FastArcCoreModel, _profile_outcomes, params=("period",), min_width=4,
            margin=2, step_clocks=SETTLE + 1),
    Variant("profile", "faithful", "arcs on SU 1665343's faithful core, 4 clocks a step",
            FaithfulArcCore, FaithfulArcCoreModel, _profile_outcomes, params=("timing",),
            min_width=4, margin=2, step_clocks=SETTLE + 1),
    Variant("line", "separate", "textbook: estimating function, separate steps",
            SeparateLineCore, SeparateLineCoreModel, separate_line_steps,
            clocks=_separate_line_clocks, accuracy=HALF_DIAGONAL),
    Variant("line", "dda", "textbook: DDA, registers preset to half their capacity",
            DdaCore, DdaCoreModel, dda_steps, fixed={"preset": "half"},
            params=("capacity",), clocks=_dda_clocks, accuracy=ONE),
    Variant("line", "dda-zero", "textbook: DDA, registers starting at zero",
            DdaCore, DdaCoreModel, dda_steps, fixed={"preset": "zero"},
            params=("capacity",), clocks=_dda_clocks, accuracy=ONE),
    Variant("line", "serial", "textbook: the bit-serial linear-circular node",
            SerialLineCore, SerialLineCoreModel, separate_line_steps,
            clocks=_serial_line_clocks, accuracy=HALF_DIAGONAL, step_clocks=word_length),
    Variant("arc", "separate", "textbook: estimating function, separate steps",
            SeparateArcCore, SeparateArcCoreModel, separate_arc_steps,
            clocks=_separate_arc_clocks, accuracy=HALF_DIAGONAL),
    Variant("arc", "serial", "textbook: the bit-serial linear-circular node",
            SerialArcCore, SerialArcCoreModel, separate_arc_steps,
            clocks=_serial_arc_clocks, accuracy=HALF_DIAGONAL, step_clocks=word_length),
)

BOARD_TABLE = (
    # The iCEBreaker's controller: the line engine at 16 bits (moves up to 65 535 steps, 819 mm
    # at 80 steps/mm) and the arc engine at its default 24 bits (radii up to 2**23 steps) fill
    # 90 % of the UP5K (4753 LC, since issue 8 made the arc engine smaller; before, only a
    # 16-bit one fitted). It runs at the board's 12 MHz, undivided: its longest path, the turn
    # queue's read into the feed generator's rate, closed at 11.58 MHz until the generator's
    # target became a register (issue 27); before, the controller ran at 6 MHz.
    # With the safety inputs and feed hold it is 97 % full; the feed and rapid overrides (their
    # multiplier and look-ahead, about 315 LUT4) do not fit beside them (5452 of 5280 LC).
    # The tool outputs (issues 27/28) fit with the arc engine on the faithful core (the fast
    # core's steps at 4 clocks a step: 5144 -> 4850 LC) and without their laser mode (with it
    # 5252 LC, which did not place): 5117 LC, 12.92 MHz. A smaller line core (the serial node,
    # separate steps) would leave the laser mode room (4971 LC) but is 0.654 steps off
    # bracket.ngc's contour (the exact core 0.499; tests/test_run.py holds it to 0.5). Since
    # OVERRIDE's values are not kept without the overrides: 5017 LC, seeds 1-3 placed at
    # 14.97-15.55 MHz (with the laser mode 5181, 98 %: not adopted; icebreaker-z has it).
    # With the arc engine on the textbook's bit-serial node at 20 bits (radii up to 1 048 575
    # steps, 13.1 m at 80 steps/mm; separate steps, within half a diagonal of the arc where
    # the faithful core is within half a step; 22 clocks a step, under the step/dir timing's
    # 37) there is room for the feed, rapid and spindle overrides and the laser mode: 5177
    # LC, seeds 1-3 placed at 17.07-17.96 MHz with Yosys's UltraPlus timing model (-device u;
    # 5156 LC, 15.67-16.69 MHz without it; issue 27; the node at 24 bits was 5314 LC and did
    # not place, at 16 bits 5039 LC). With the spindle override's product on a multiplier
    # block (synth_ice40 -dsp): 4950 LC, 19.04 / 18.84 MHz at seeds 1 and 2, seed 3 unplaced,
    # seeds 4-7 placed at 17.69-18.58 MHz (with the homing engine besides 5170 LC: seed 1 does
    # not place).
    Board("icebreaker", "iCEBreaker (iCE40UP5K-SG48)", _icebreaker_platform, DemoTop,
          clock_hz=12e6, arc=("serial", 20), tools=True),
    # The iCEBreaker on three axes (issues 27/28: Z for routers and mills; the two-axis one
    # above for lasers, plasma and plotters): Z's step, dir and limit on PMOD2; lines in XYZ
    # by the spatial core, helices by the helix engine around the arc engine on the
    # textbook's bit-serial node at 16 bits (radii up to 65 535 steps, 819 mm at 80
    # steps/mm; separate steps, within half a diagonal of the arc where the faithful core is
    # within half a step; 18 clocks a step, faster than the step/dir timing's 37): the
    # faithful core at 24 bits made 5963 LC (of 5280), at 16 bits 5455, the serial node at 24
    # bits with the laser mode 5518; at 16 bits 4877 LC without the laser mode, 5026 with it
    # (seed 1). Tool outputs with Grbl's laser mode; no overrides.
    Board("icebreaker-z", "iCEBreaker (iCE40UP5K-SG48), three axes (Z on PMOD2)",
          _icebreaker_z_platform, None, clock_hz=12e6, arc=("serial", 16), overrides=False,
          tools=True, axes=3),
    # The ULX3S-85F holds both engines at their default widths and the equidistant engine of
    # cutter compensation (G41/G42) at 16 bits. It runs at the board's 25 MHz, undivided,
    # since that engine's block 11 test is registered (issue 27: 34.68-36.52 MHz routed,
    # seeds 1-3);
    # before, its element end (block 11's test, the feed's permission, the memory's shift and
    # the frame taken) in one clock closed at 22.71-23.17 MHz and the controller ran at half
    # the board's clock, 12.5 MHz.
    # It has the homing engine too (issue 25), which neither iCEBreaker has room for, the tool
    # outputs (issue 28) and the third axis, Z (issue 28: lines in XYZ by the spatial core,
    # helices by the helix engine around the arc engine), all three of its engines at their
    # one-step-a-clock cores.
    Board("ulx3s", "ULX3S (ECP5 LFE5U-85F)", _ulx3s_platform, None, clock_hz=25e6,
          line=("exact", 16), arc=("fast", 24), profile=("fast", 16), homing=True,
          tools=True, axes=3),
)

for _item in KIND_TABLE + VARIANT_TABLE + BOARD_TABLE:
    register(_item)
del _item
