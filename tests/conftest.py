"""Shared test configuration: simulator selection and build directories."""

import os

import pytest

from sim.runners import SIMULATORS

from .utils import BUILD_DIR


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "cocotb: runs the generated Verilog under cocotb (Icarus or Verilator)")
    config.addinivalue_line(
        "markers", "formal: runs a SymbiYosys proof (make formal)")


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
    see :class:`sim.runners.CocotbBuild`)."""
    return BUILD_DIR / "cocotb"
