"""One registry of what kontur is made of: kinds of command, their variants, and boards.

A *kind* is a kind of command with its engine (a front end of ``hdl/``) and the engine's
cycle model: ``line`` (:class:`hdl.line.LineEngine`), ``arc`` (:class:`hdl.arc.ArcEngine`) and
``profile`` (:class:`hdl.equidistant.EquidistantEngine`, whose commands are a *program*: the
frames of a contour, prepared by the host from G-code).
A *variant* of a kind is a core that plugs into that engine, with the core's cycle model, its
step-level model and the parameters it takes. A *board* has a platform (``constraints/``) and a
demo top. ``kontur trace``, ``bench``, ``demo``, ``build`` and the tests all read this module,
so a new variant is added by one :func:`register` call here and the file that holds its core
and model; nothing else lists variants.
"""

from dataclasses import dataclass

from sim.models.errors import InputError

__all__ = ["Kind", "Variant", "Board", "KINDS", "VARIANTS", "BOARDS", "InputError", "register", "variant",
           "variants", "make_engine", "make_model", "board", "make_controller", "check", "steps",
           "outcomes"]


@dataclass(frozen=True)
class Kind:
    """A kind of command and the engine that runs it.

    ``engine`` and ``model`` are called as ``engine(core)`` and ``model(core_model)``;
    ``fields`` are the frame's integer fields in command-line order; ``check(payload, width)``
    raises :exc:`InputError` for a command the engine refuses. For a ``program`` kind the
    payload is a list of frames, and a variant's ``steps(frames, width)`` gives every frame's
    ``(outcome, steps)``.
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


@dataclass(frozen=True)
class Variant:
    """A core of a kind: ``core(width=, **params)`` builds the RTL core, ``model(width=,
    **params)`` its cycle model, ``steps(payload, width)`` returns the step-level trajectory;
    ``params`` names the parameters besides ``width`` that it takes. ``clocks(payload, width,
    **params)``, if given, is an upper bound on the clocks the core takes for a command at full
    feed (its own setup included, the front end's not); without it a core makes one step per
    clock (or per generator period) and no more steps than the longer projection of a line or
    ``8R + 8`` for an arc."""
    kind: str
    name: str
    help: str
    core: object
    model: object
    steps: object
    params: tuple = ()
    min_width: int = 2
    clocks: object = None


@dataclass(frozen=True)
class Board:
    """A board: ``platform()`` returns a new Amaranth platform, ``demo()`` its demo top (a
    program played in a loop); ``clock_hz`` is the machine controller's clock, the board's
    divided by ``divide`` (see :class:`hdl.top.ControllerTop`), ``line`` and ``arc`` the
    ``(variant, width)`` of its engines, ``profile`` that of its equidistant engine
    (cutter-radius compensation, G41/G42), or ``None`` where the board has no room for one
    (see :func:`make_controller`)."""
    name: str
    help: str
    platform: object
    demo: object
    clock_hz: float
    line: tuple = ("exact", 16)
    arc: tuple = ("fast", 24)
    divide: int = 1
    profile: tuple = None


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


def make_engine(kind_name, variant_name=None, *, width=None, **params):
    """The RTL engine of a kind around the core of a variant."""
    item = variant(kind_name, variant_name)
    return KINDS[kind_name].engine(item.core(**_arguments(item, width, params)))


def make_model(kind_name, variant_name=None, *, width=None, **params):
    """The cycle model of :func:`make_engine` with the same arguments."""
    item = variant(kind_name, variant_name)
    return KINDS[kind_name].model(item.model(**_arguments(item, width, params)))


def board(name):
    """The :class:`Board` ``name`` (a :class:`Board` itself is returned as it is: a board not
    registered, for tests); :exc:`ValueError` if there is none."""
    if isinstance(name, Board):
        return name
    if name not in BOARDS:
        raise ValueError(f"Board must be one of {', '.join(map(repr, BOARDS))}, not {name!r}")
    return BOARDS[name]


def make_controller(board_name, machine):
    """The machine controller of a board (:class:`hdl.motion.controller.MotionController`)
    with its engines (the equidistant engine too where the board has one), its clock, and the
    serial rate, queue length and step/dir timing of ``machine`` (a
    :class:`kontur.machine.Machine`, whose ``clock_hz`` must be the board's).
    """
    from hdl.motion.controller import MotionController
    item = board(board_name)
    if machine.clock_hz != item.clock_hz:
        raise ValueError(f"The machine's clock is {machine.clock_hz:g} Hz, the {item.name}'s "
                         f"{item.clock_hz:g} Hz")
    profile = None if item.profile is None else \
        make_engine("profile", item.profile[0], width=item.profile[1])
    return MotionController(line=make_engine("line", item.line[0], width=item.line[1]),
                            arc=make_engine("arc", item.arc[0], width=item.arc[1]),
                            profile=profile,
                            clock_hz=item.clock_hz, baud=machine.baud,
                            queue_frames=machine.queue_frames, dir_setup=machine.dir_setup,
                            step_width=machine.step_width)


def check(kind_name, payload, width):
    """Raise :exc:`InputError` if the engine of a kind refuses ``payload`` at ``width``."""
    kind(kind_name).check(payload, width)


def steps(kind_name, payload, variant_name=None, *, width=None, **params):
    """The step-level trajectory of ``payload`` (a program's frames for a program kind): a
    list of ``(dx, dy)``. ``params`` are those of the variant that change its trajectory (none
    for most)."""
    item = variant(kind_name, variant_name)
    arguments = _arguments(item, width, params)
    width = arguments.pop("width")
    if kind(kind_name).program:
        return [step for _, path in item.steps(payload, width, **arguments) for step in path]
    return item.steps(payload, width, **arguments)


def outcomes(kind_name, frames, variant_name=None, *, width=None):
    """What the engine makes of ``frames`` (no abort), frame by frame at the step level: a list
    of ``(outcome, steps)``, ``outcome`` 0 (done) or 1 (refused)."""
    item = variant(kind_name, variant_name)
    width = _arguments(item, width, {})["width"]
    if kind(kind_name).program:
        return item.steps(frames, width)
    result = []
    for frame in frames:
        try:
            result.append((0, item.steps(frame, width)))
        except InputError:
            result.append((1, []))
    return result


# ---- the kinds and variants of kontur ----------------------------------------------------

def _line_check(payload, width):
    from sim.models.linear import check_line
    check_line(payload["x"], payload["y"], width)


def _arc_check(payload, width):
    from sim.models.arc import check_arc
    check_arc(payload["x0"], payload["y0"], payload["x1"], payload["y1"], width)


def _line_engine(core):
    from hdl.line import LineEngine
    return LineEngine(core)


def _line_engine_model(core):
    from sim.models.line import LineEngineModel
    return LineEngineModel(core)


def _arc_engine(core):
    from hdl.arc import ArcEngine
    return ArcEngine(core)


def _arc_engine_model(core):
    from sim.models.arc import ArcEngineModel
    return ArcEngineModel(core)


def _linear(variant_name):
    def core(**params):
        from hdl.linear import LinearCore
        return LinearCore(variant=variant_name, **params)

    def model(**params):
        from sim.models.linear import LinearCoreModel
        return LinearCoreModel(variant=variant_name, **params)

    def trajectory(payload, width):
        from sim.models.linear import steps as linear_steps
        return linear_steps(payload["x"], payload["y"], variant=variant_name, width=width)

    return core, model, trajectory


def _arc_trajectory(payload, width):
    from sim.models.arc import arc_steps
    return arc_steps(payload["x0"], payload["y0"], payload["x1"], payload["y1"],
                     cw=payload["cw"], width=width)


def _faithful_core(**params):
    from hdl.circular import FaithfulArcCore
    return FaithfulArcCore(**params)


def _faithful_model(**params):
    from sim.models.circular import FaithfulArcCoreModel
    return FaithfulArcCoreModel(**params)


def _fast_core(**params):
    from hdl.circular import FastArcCore
    return FastArcCore(**params)


def _fast_model(**params):
    from sim.models.circular import FastArcCoreModel
    return FastArcCoreModel(**params)


def _profile_engine(core):
    from hdl.equidistant import EquidistantEngine
    return EquidistantEngine(core)


def _profile_engine_model(core):
    from sim.models.equidistant import EquidistantEngineModel
    return EquidistantEngineModel(core)


def _profile_check(frames, width):
    from sim.models.equidistant import Formats, frame_outcomes
    for number, (outcome, _) in enumerate(frame_outcomes(frames, Formats(width))):
        if outcome:
            raise InputError(f"frame {number} is refused")


def _profile_trajectory(frames, width):
    from sim.models.equidistant import Formats, frame_outcomes
    return frame_outcomes(frames, Formats(width))


def _profile_core(name):
    """An arc core for the equidistant engine: two bits wider than its coordinates."""
    def core(*, width, **params):
        if name == "fast":
            from hdl.circular import FastArcCore
            return FastArcCore(width=width + 2, **params)
        from hdl.circular import FaithfulArcCore
        return FaithfulArcCore(width=width + 2, **params)

    def model(*, width, **params):
        if name == "fast":
            from sim.models.circular import FastArcCoreModel
            return FastArcCoreModel(width=width + 2, **params)
        from sim.models.circular import FaithfulArcCoreModel
        return FaithfulArcCoreModel(width=width + 2, **params)

    return core, model


def _textbook(core_name, model_name, **fixed):
    """Factories of a core of ``hdl.textbook`` or ``hdl.serial`` (its name starts with
    ``Serial``) and of its cycle model, with ``fixed`` parameters."""
    module = "serial" if core_name.startswith("Serial") else "textbook"

    def core(**params):
        from importlib import import_module
        return getattr(import_module(f"hdl.{module}"), core_name)(**fixed, **params)

    def model(**params):
        from importlib import import_module
        return getattr(import_module(f"sim.models.{module}"), model_name)(**fixed, **params)

    return core, model


def _separate_line_steps(payload, width):
    from sim.models.textbook import separate_line_steps
    return separate_line_steps(payload["x"], payload["y"], width=width)


def _separate_arc_steps(payload, width):
    from sim.models.textbook import separate_arc_steps
    return separate_arc_steps(payload["x0"], payload["y0"], payload["x1"], payload["y1"],
                              cw=payload["cw"], width=width)


def _dda_steps(preset):
    def trajectory(payload, width, capacity="segment"):
        from sim.models.textbook import dda_steps
        return dda_steps(payload["x"], payload["y"], width=width, preset=preset,
                         capacity=capacity)
    return trajectory


def _arc_radius(payload):
    from sim.models.arc import round_sqrt
    return round_sqrt(payload["x0"] ** 2 + payload["y0"] ** 2)


def _separate_line_clocks(payload, width, **params):
    return abs(payload["x"]) + abs(payload["y"]) + 2


def _dda_clocks(payload, width, capacity="segment", **params):
    from sim.models.textbook import dda_capacity          # N iterations, a clock each
    return (1 << dda_capacity(payload["x"], payload["y"], width=width, capacity=capacity)) + 2


def _separate_arc_clocks(payload, width, **params):
    return 8 * _arc_radius(payload) + 16             # 2·Rn steps a quadrant, up to 4 of them


def _serial_line_clocks(payload, width, **params):
    from sim.models.serial import word_length
    return word_length(width) * (abs(payload["x"]) + abs(payload["y"]) + 2) + 2


def _serial_arc_clocks(payload, width, **params):
    from sim.models.serial import word_length           # up to 5 runs: 3 words more each
    return word_length(width) * (8 * _arc_radius(payload) + 16)


def _icebreaker_platform():
    from constraints import icebreaker
    return icebreaker.platform()


def _icebreaker_demo():
    from hdl.top import DemoTop
    return DemoTop()


def _ulx3s_platform():
    from constraints import ulx3s
    return ulx3s.platform()


register(Kind("line", "segment from the origin to (X, Y)", _line_engine, _line_engine_model,
              ("x", "y"), _line_check, "exact", 16))
register(Kind("arc", "arc around the origin from (X0, Y0) to (X1, Y1), a full circle when they "
                     "are equal", _arc_engine, _arc_engine_model,
              ("x0", "y0", "x1", "y1", "cw"), _arc_check, "faithful", 24))
register(Variant("line", "device", "SU 1571551 as its device is drawn: counter-fed increments",
                 *_linear("device"), params=("period",)))
register(Variant("line", "exact", "SU 1571551's equation (1): constant increments",
                 *_linear("exact"), params=("period",)))
register(Variant("arc", "faithful", "SU 1665343's structure and timing, 4 clocks a step",
                 _faithful_core, _faithful_model, _arc_trajectory, params=("timing",)))
register(Variant("arc", "fast", "SU 1665343's trajectory, one step per clock",
                 _fast_core, _fast_model, _arc_trajectory, params=("period",)))
register(Kind("profile", "a contour of a G-code program: the cutter's centre on its "
                         "equidistant (T. Siimut, 1963)", _profile_engine, _profile_engine_model,
              (), _profile_check, "fast", 8, program=True))
register(Variant("profile", "fast", "arcs on SU 1665343's one-step-per-clock core",
                 *_profile_core("fast"), _profile_trajectory, params=("period",), min_width=4))
register(Variant("profile", "faithful", "arcs on SU 1665343's faithful core, 4 clocks a step",
                 *_profile_core("faithful"), _profile_trajectory, params=("timing",),
                 min_width=4))
register(Variant("line", "separate", "textbook: estimating function, separate steps",
                 *_textbook("SeparateLineCore", "SeparateLineCoreModel"),
                 _separate_line_steps, clocks=_separate_line_clocks))
register(Variant("line", "dda", "textbook: DDA, registers preset to half their capacity",
                 *_textbook("DdaCore", "DdaCoreModel", preset="half"),
                 _dda_steps("half"), params=("capacity",), clocks=_dda_clocks))
register(Variant("line", "dda-zero", "textbook: DDA, registers starting at zero",
                 *_textbook("DdaCore", "DdaCoreModel", preset="zero"),
                 _dda_steps("zero"), params=("capacity",), clocks=_dda_clocks))
register(Variant("line", "serial", "textbook: the bit-serial linear-circular node",
                 *_textbook("SerialLineCore", "SerialLineCoreModel"),
                 _separate_line_steps, clocks=_serial_line_clocks))
register(Variant("arc", "separate", "textbook: estimating function, separate steps",
                 *_textbook("SeparateArcCore", "SeparateArcCoreModel"),
                 _separate_arc_steps, clocks=_separate_arc_clocks))
register(Variant("arc", "serial", "textbook: the bit-serial linear-circular node",
                 *_textbook("SerialArcCore", "SerialArcCoreModel"),
                 _separate_arc_steps, clocks=_serial_arc_clocks))
# The iCEBreaker's controller: the line engine at 16 bits (moves up to 65 535 steps, 819 mm at
# 80 steps/mm) and the arc engine at its default 24 bits (radii up to 2**23 steps) fill 90 % of
# the UP5K (4753 LC, since issue 8 made the arc engine smaller; before, only a 16-bit one
# fitted). Its longest path (the turn queue's read into the feed generator's rate) closes at
# 11.58 MHz, not at the board's 12 MHz: the controller runs at 6 MHz.
register(Board("icebreaker", "iCEBreaker (iCE40UP5K-SG48)", _icebreaker_platform,
               _icebreaker_demo, clock_hz=6e6, arc=("fast", 24), divide=2))
# The ULX3S-85F holds both engines at their default widths and the equidistant engine of
# cutter compensation (G41/G42) at 16 bits. That engine's corner search (its blocks 13 and 7-8
# through the core's increments) closes at 14.7 MHz, below the board's 25 MHz: the controller
# runs at half the board's clock, 12.5 MHz.
register(Board("ulx3s", "ULX3S (ECP5 LFE5U-85F)", _ulx3s_platform, None, clock_hz=12.5e6,
               line=("exact", 16), arc=("fast", 24), profile=("fast", 16), divide=2))
