# amaranth: UnusedElaboratable=no
"""``kontur trace`` with the textbook's variants, on every engine: the same steps and clocks."""

import pytest

from kontur.sim.models.serial import word_length
from kontur.sim.models.textbook import dda_iterations, separate_arc_steps, separate_line_steps

from .conftest import selected_simulators
from .test_cli import expected_lines, kontur

LINE = ("line", -7, 3)
ARC = ("arc", 5, 0, -3, 4)                   # from (5, 0) to (-3, 4), counter-clockwise


def test_line_variants_model():
    for variant, path in (("separate", separate_line_steps(-7, 3)),
                          ("serial", separate_line_steps(-7, 3)),
                          ("dda", [s for s in dda_iterations(-7, 3) if s != (0, 0)]),
                          ("dda-zero", [s for s in dda_iterations(-7, 3, preset="zero")
                                        if s != (0, 0)])):
        run = kontur("trace", *LINE, "--variant", variant)
        assert run.returncode == 0, run.stderr
        assert run.stdout == expected_lines(path), variant


def test_arc_variants_model():
    for variant in ("separate", "serial"):
        run = kontur("trace", *ARC, "--variant", variant)
        assert run.returncode == 0, run.stderr
        assert run.stdout == expected_lines(separate_arc_steps(5, 0, -3, 4)), variant


def test_cycles_show_each_method_timing():
    # Separate steps one a clock; the serial node a word of width + 2 clocks a step; the DDA
    # one clock an iteration, idle iterations between its steps.
    separate = kontur("trace", *LINE, "--variant", "separate", "--cycles").stdout.splitlines()
    clocks = [int(line.split()[0]) for line in separate]
    assert clocks == list(range(clocks[0], clocks[0] + 10))
    serial = kontur("trace", *LINE, "--variant", "serial", "--cycles", "--width", "8")
    clocks = [int(line.split()[0]) for line in serial.stdout.splitlines()]
    assert [b - a for a, b in zip(clocks, clocks[1:])] == [word_length(8)] * 9
    dda = kontur("trace", *LINE, "--variant", "dda", "--cycles").stdout.splitlines()
    iterations = dda_iterations(-7, 3)
    start = int(dda[0].split()[0]) - next(k for k, s in enumerate(iterations) if s != (0, 0))
    assert [int(line.split()[0]) - start for line in dda] == \
        [k for k, s in enumerate(iterations) if s != (0, 0)]


def check_rtl(engine, variants):
    """Each ``(kind, variant)`` traced on ``engine`` with ``--cycles`` gives the model's lines;
    a refused line gives the RTL's refusal."""
    for kind, variant in variants:
        command = LINE if kind == "line" else ARC
        run = kontur("trace", *command, "--variant", variant, "--engine", engine, "--cycles",
                     "--width", "8")
        assert run.returncode == 0, run.stderr
        assert run.stdout == kontur("trace", *command, "--variant", variant, "--cycles",
                                    "--width", "8").stdout, (variant, engine)
    refused = kontur("trace", "line", 256, 0, "--variant", "serial", "--engine", engine,
                     "--width", "8")
    assert refused.returncode == 2 and "refused by the RTL" in refused.stderr


def test_amaranth():
    check_rtl("amaranth", [("line", v) for v in ("separate", "dda", "dda-zero", "serial")]
              + [("arc", v) for v in ("separate", "serial")])


@pytest.mark.cocotb
@pytest.mark.parametrize("simulator", selected_simulators())
def test_cocotb(simulator):
    check_rtl(simulator, [("line", "serial"), ("arc", "serial")])


def test_long_serial_runs_are_refused_up_front():
    # The serial node's own clock bound sizes the run: 18 clocks a step at width 16.
    run = kontur("trace", "line", 60000, 60000, "--variant", "serial", "--engine", "amaranth")
    assert run.returncode == 2 and run.stdout == ""
    assert "this line needs up to" in run.stderr and "raise --max-clocks" in run.stderr
