"""Trace one command on any engine: the golden model, Amaranth's simulator, Icarus, Verilator.

Each kind of command (``line``, ``arc``) names its RTL engine, its cycle model and its input
check; :func:`trace` runs a single frame on the chosen engine and returns the record. Bad input
is refused the same way everywhere: the model raises :exc:`InputError` before running; the RTL
raises its ``error`` strobe, which is turned into the same :exc:`InputError` here.
"""

from dataclasses import dataclass

from .models.errors import InputError
from .runners import ENGINES, ROOT, CocotbBuild, run_amaranth
from .stimulus import Job, run_model

__all__ = ["Kind", "KINDS", "trace", "build_dir"]


@dataclass(frozen=True)
class Kind:
    """How to build, model and check one kind of command."""
    name: str
    variants: tuple
    default_variant: str
    default_width: int
    make_rtl: object          # (variant, width) -> wiring.Component
    make_model: object        # (variant, width) -> cycle model
    check: object             # (payload, width) -> None, or raise InputError
    coord_width: object       # width -> width of a coordinate field in a frame


def _line_kind():
    from .models import linear

    def make_rtl(variant, width):
        from hdl.linear import LineEngine
        return LineEngine(variant=variant, width=width)

    def make_model(variant, width):
        return linear.LineEngineModel(variant=variant, width=width)

    def check(payload, width):
        linear.check_line(payload["x"], payload["y"], width)

    return Kind("line", linear.VARIANTS, "exact", 16, make_rtl, make_model, check,
                lambda width: max(32, width + 1))


def _arc_kind():
    from .models import arc, circular

    def make_rtl(variant, width):
        from hdl.arc import ArcEngine
        return ArcEngine(variant=variant, width=width)

    def make_model(variant, width):
        return arc.ArcEngineModel(variant=variant, width=width)

    def check(payload, width):
        arc.check_arc(payload["x0"], payload["y0"], payload["x1"], payload["y1"], width)

    return Kind("arc", circular.CORE_VARIANTS, "faithful", 24, make_rtl, make_model, check,
                lambda width: max(32, width + 1))


KINDS = {"line": _line_kind(), "arc": _arc_kind()}


def build_dir(kind, variant, width, simulator, waves=False):
    """Where the command line keeps its cocotb builds (reused between calls)."""
    suffix = "_waves" if waves else ""
    return ROOT / "build" / "cli" / simulator / f"{kind}_{variant}_w{width}{suffix}"


def trace(kind, payload, *, variant=None, engine="model", width=None, vcd=None):
    """Run one frame ``payload`` of ``kind`` on ``engine``; return the record.

    Raises
    ------
    InputError
        If the command is refused (by the model's check, or by the RTL's ``error`` strobe).
    ValueError
        If the engine, variant or width is unknown, or ``vcd`` is asked of the model.
    """
    spec = KINDS[kind]
    variant = variant or spec.default_variant
    width = spec.default_width if width is None else width
    if variant not in spec.variants:
        raise ValueError(f"{kind} variant must be one of {', '.join(spec.variants)}, "
                         f"not {variant!r}")
    if engine not in ENGINES:
        raise ValueError(f"Engine must be one of {', '.join(ENGINES)}, not {engine!r}")
    if vcd is not None and engine == "model":
        raise ValueError("--vcd needs an RTL engine (amaranth, icarus or verilator)")
    if isinstance(width, bool) or not isinstance(width, int) or width < 2:
        raise ValueError(f"Width must be an integer of at least 2, not {width!r}")

    job = Job(frames=[payload])
    if engine == "model":
        spec.check(payload, width)
        return run_model(spec.make_model(variant, width), job)

    limit = 1 << (spec.coord_width(width) - 1)
    for name, value in payload.items():
        if not -limit <= value < limit:
            raise InputError(f"{name.upper()} = {value} does not fit the frame's "
                             f"{spec.coord_width(width)}-bit signed coordinates")
    rtl = spec.make_rtl(variant, width)
    if engine == "amaranth":
        record = run_amaranth(rtl, job, vcd=vcd)
    else:
        build = CocotbBuild(rtl, engine, build_dir(kind, variant, width, engine, vcd is not None),
                            waves=vcd is not None, quiet=True)
        record = build.run(job, vcd=vcd)

    refused = any(entry.get("error") for entry in record)
    try:
        spec.check(payload, width)
    except InputError as reason:
        if refused:
            raise InputError(f"{reason} (refused by the RTL: error strobe)") from None
        raise RuntimeError(f"the RTL accepted a command the model refuses: {reason}")
    if refused:
        raise RuntimeError("the RTL refused a command the model accepts")
    return record
