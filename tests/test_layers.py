"""The floors of the house, stated once and held against every import in the code.

Each module belongs to the room of its longest prefix in :data:`ROOMS`; a room may import
itself and the rooms :data:`ALLOWED` names, all on floors below it, and nothing else of the
project. Every import counts: at the top of a module, inside a function (where a reader does
not look for it) and through ``importlib.import_module`` (whose argument must then be a
literal, so that the arrow can be read). The floors, bottom up:

    spec        hdl/spec.py, hdl/circular_timing.py: what gateware and models share, pure
                Python (no Amaranth)
    gateware    hdl/: the elements, cores, engines and the controller
    models      sim/models/: the golden models, pure Python (of hdl, the spec alone)
    simulation  sim/: the stimulus, runners, cocotb parts, child processes, proofs' runner
    boards      constraints/: pin maps, platforms, the synthesis and place-and-route flows
    program     kontur/: the registry (the composition root) and the commands on it
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

ROOMS = {
    "kontur.hdl.spec": "spec",
    "kontur.hdl.circular_timing": "spec",
    "kontur.hdl": "gateware",
    "kontur.sim.models": "models",
    "kontur.sim": "simulation",
    "kontur.constraints": "boards",
    "kontur": "program",
}

#: The folders at the project's top that are packages of ``kontur`` (``pyproject.toml``,
#: ``kontur/__init__.py``): imported by their bare names, they would be modules the installed
#: project does not have, and a second copy of each in a checkout.
FOLDERS = ("hdl", "sim", "constraints")

ALLOWED = {
    "spec": set(),
    "gateware": {"spec"},
    "models": {"spec"},
    "simulation": {"spec", "gateware", "models"},
    "boards": {"spec", "gateware", "simulation"},
    "program": {"spec", "gateware", "models", "simulation", "boards"},
}

#: Rooms that are pure Python: no Amaranth, so that the models run without it.
PURE = {"spec", "models"}

FLOORS = ["spec", "gateware", "models", "simulation", "boards", "program"]


def room(module):
    """The room of a dotted module name (``None``: not the project's)."""
    parts = module.split(".")
    for length in range(len(parts), 0, -1):
        name = ".".join(parts[:length])
        if name in ROOMS:
            return ROOMS[name]
    return None


def modules(tops=(*FOLDERS, "kontur")):
    """Every module of the project: its dotted name (as installed) and its path."""
    for top in tops:
        for path in sorted((ROOT / top).rglob("*.py")):
            name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
            if top in FOLDERS:
                name = f"kontur.{name}"
            yield name.removesuffix(".__init__"), path


def imports(name, path):
    """``(line, module, names)`` for every import in a module, wherever it stands: ``names``
    are those a ``from`` import takes (each may be a module itself: ``from sim import
    processes``)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name, ()
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module
            yield node.lineno, module, tuple(alias.name for alias in node.names)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(
                node.func, "id", None)) in ("import_module", "__import__"):
            argument = node.args[0] if node.args else None
            if isinstance(argument, ast.Constant) and isinstance(argument.value, str):
                yield node.lineno, argument.value, ()
            else:
                yield node.lineno, None, ()


def breaches(name, path):
    """What in a module breaks the floors, one line each."""
    own = room(name)
    found = []
    for line, module, names in imports(name, path):
        where = f"{path.relative_to(ROOT)}:{line}"
        if module is None:
            found.append(f"{where}: import_module of a computed name (the arrow cannot be read)")
            continue
        if module.split(".")[0] in FOLDERS:
            found.append(f"{where}: imports {module}, a name the installed project does not "
                         f"have (kontur.{module})")
            continue
        if own in PURE and module.split(".")[0] == "amaranth":
            found.append(f"{where}: {own} is pure Python, but imports {module}")
        for target in (module, *(f"{module}.{item}" for item in names)):
            other = room(target)
            if other is None or other == own or other in ALLOWED[own]:
                continue
            higher = FLOORS.index(other) > FLOORS.index(own)
            found.append(f"{where}: {own} imports {target} ({other}, "
                         f"{'above it' if higher else 'not its'})")
    return found


def test_floors_are_a_total_order_bottom_up():
    for number, name in enumerate(FLOORS):
        assert ALLOWED[name] <= set(FLOORS[:number]), name
    assert set(ROOMS.values()) == set(FLOORS) == set(ALLOWED)


@pytest.mark.parametrize("top", [*FOLDERS, "kontur"])
def test_no_import_climbs_or_crosses(top):
    found = [breach for name, path in modules((top,)) for breach in breaches(name, path)]
    assert not found, "\n".join(found)


def test_tests_import_the_installed_names():
    # The tests stand above every floor, but take the project by the names it is installed
    # under, as everything else does (conftest's import_module of $KONTUR_EXTRA_VARIANTS is
    # computed on purpose).
    found = [f"{path.relative_to(ROOT)}:{line}: {module}"
             for path in sorted((ROOT / "tests").rglob("*.py"))
             for line, module, _ in imports(f"tests.{path.stem}", path)
             if module is not None and module.split(".")[0] in FOLDERS]
    assert not found, "\n".join(found)


def test_the_rule_catches_what_it_states(tmp_path):
    """The test itself: imports that break the floors, at the top, in a function and through
    import_module, are each caught."""
    (tmp_path / "sim").mkdir()
    bad = tmp_path / "sim" / "bad.py"
    bad.write_text("from kontur import registry\n"
                   "def f():\n    from kontur.constraints.flow import place_and_route\n"
                   "def g():\n    import importlib\n    importlib.import_module('kontur.cli')\n"
                   "def h(m):\n    import importlib\n    importlib.import_module(f'hdl.{m}')\n"
                   "from sim.models import linear\n")
    models = tmp_path / "sim" / "models"
    models.mkdir()
    (models / "m.py").write_text("from amaranth import Signal\n"
                                 "from kontur.hdl.top import DemoTop\n"
                                 "from kontur.hdl.spec import Formats\n")
    global ROOT
    saved, ROOT = ROOT, tmp_path
    try:
        found = (breaches("kontur.sim.bad", bad)
                 + breaches("kontur.sim.models.m", models / "m.py"))
    finally:
        ROOT = saved
    assert [f.split(": ", 1)[1] for f in found] == [
        "simulation imports kontur (program, above it)",
        "simulation imports kontur.registry (program, above it)",
        "imports sim.models, a name the installed project does not have (kontur.sim.models)",
        "simulation imports kontur.constraints.flow (boards, above it)",
        "simulation imports kontur.constraints.flow.place_and_route (boards, above it)",
        "simulation imports kontur.cli (program, above it)",
        "import_module of a computed name (the arrow cannot be read)",
        "models is pure Python, but imports amaranth",
        "models imports kontur.hdl.top (gateware, not its)",
        "models imports kontur.hdl.top.DemoTop (gateware, not its)",
    ], found


#: The longest an ``elaborate`` in hdl/ or a function in sim/models/ may be (issue 24): a
#: design too large for one screenful or two is split along its own parts.
LONGEST = 150


def too_long(path, names=None):
    """The functions of a file (those named in ``names`` only, if given) over :data:`LONGEST`
    lines, from the ``def`` to the last line of the body, as ``path:line name (n lines)``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if (isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
                and (names is None or node.name in names)):
            length = node.end_lineno - node.lineno + 1
            if length > LONGEST:
                found.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} "
                             f"({length} lines)")
    return found


def test_no_elaborate_or_model_function_over_150_lines(tmp_path):
    # The rule itself: a method of 151 lines is caught, one of 150 is not, nested or not.
    body = "".join(f"        x = {i}\n" for i in range(LONGEST - 1))     # 149 lines
    probe = tmp_path / "probe.py"
    probe.write_text(f"class A:\n    def elaborate(self):\n{body}        y = 0\n"
                     f"    def short(self):\n{body}"
                     f"def f():\n    def g():\n{body}        y = 0\n")
    saved = globals()["ROOT"]
    globals()["ROOT"] = tmp_path
    try:
        assert sorted(too_long(probe)) == ["probe.py:2 elaborate (151 lines)",
                                           "probe.py:303 f (152 lines)",
                                           "probe.py:304 g (151 lines)"]
        assert too_long(probe, {"elaborate", "short"}) == ["probe.py:2 elaborate (151 lines)"]
        assert too_long(probe, {"short"}) == []
    finally:
        globals()["ROOT"] = saved

    hdl = sorted((ROOT / "hdl").rglob("*.py"))
    models = sorted((ROOT / "sim" / "models").rglob("*.py"))
    assert len(hdl) > 10 and len(models) > 5
    found = [f for path in hdl for f in too_long(path, {"elaborate"})]
    found += [f for path in models for f in too_long(path)]
    assert not found, "\n".join(found)
