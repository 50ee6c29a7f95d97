"""Shared test configuration: simulator selection, build directories, and extra variants.

``KONTUR_EXTRA_VARIANTS`` (``module:NAME`` entries, comma-separated, e.g.
``tests.standin_core:VARIANT``) registers more variants before the tests are collected, so
that every generic suite (those that read :func:`kontur.registry.variants`) runs them too,
with no list edited: ``tests/test_registry.py`` runs the suites so over its stand-in.
"""

import importlib
import os

import pytest

from kontur.sim.runners import SIMULATORS


def extra_variants():
    """The variants named by ``$KONTUR_EXTRA_VARIANTS``."""
    found = []
    for entry in filter(None, os.environ.get("KONTUR_EXTRA_VARIANTS", "").split(",")):
        module, _, name = entry.strip().partition(":")
        if not name:
            raise pytest.UsageError(f"KONTUR_EXTRA_VARIANTS entries are module:NAME, "
                                    f"not {entry!r}")
        found.append(getattr(importlib.import_module(module), name))
    return found


def register_extra_variants():
    """Register the variants of ``$KONTUR_EXTRA_VARIANTS`` not registered yet (here, and in a
    cocotb suite's simulator process, which reads the registry on its own)."""
    from kontur import registry
    for item in extra_variants():
        if (item.kind, item.name) not in registry.VARIANTS:
            registry.register(item)


def pytest_configure(config):
    register_extra_variants()
    config.addinivalue_line(
        "markers", "cocotb: runs the generated Verilog under cocotb (Icarus or Verilator)")
    config.addinivalue_line(
        "markers", "formal: runs a SymbiYosys proof (make formal)")
    config.addinivalue_line(
        "markers", "long: runs for minutes (a bitstream build): collected first")


def pytest_collection_modifyitems(items):
    # The long tests first: with two pytest-xdist workers, a bitstream build collected last
    # would run alone at the end while the other worker waits.
    items.sort(key=lambda item: item.get_closest_marker("long") is None)


def selected_simulators():
    """The cocotb simulators of this run: ``$SIM`` if set, else both."""
    sim = os.environ.get("SIM", "")
    if not sim:
        return list(SIMULATORS)
    if sim not in SIMULATORS:
        raise pytest.UsageError(f"SIM must be one of {', '.join(map(repr, SIMULATORS))}, "
                                f"not {sim!r}")
    return [sim]


def cocotb_build_root():
    """Where the tests keep their simulator builds (one directory per design and simulator,
    see :class:`kontur.sim.runners.CocotbBuild`): where ``kontur`` keeps its own
    (:func:`kontur.trace.build_root`), so that a design a test builds and one a ``kontur``
    command of another test builds are one build."""
    from kontur.trace import build_root
    return build_root()
