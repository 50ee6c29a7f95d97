"""The command line's contract under random and adversarial arguments (hypothesis).

Whatever the arguments, ``kontur`` ends with status 0 and only ``dx dy`` lines (or ``cycle dx
dy`` lines with ``--cycles``) on standard output, or with status 2, nothing on standard
output and the reason as the last line of standard error; never with a traceback, never with
another status. The runs are in-process (``kontur.cli.main``) on the model, so that
thousands of argument lists take seconds; the RTL engines' part of the contract is in
``tests/test_cli.py``.
"""

import contextlib
import io
import re

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from kontur import cli
from kontur.sim.models.linear import steps

NUMBER = st.one_of(
    st.integers(-70_000, 70_000).map(str),
    st.integers(-(1 << 70), 1 << 70).map(str),
    st.sampled_from(["0", "-0", "1e3", "0x10", "3.5", "", " 7", "+4", "--", "-", "nan",
                     "٣", "9" * 40, "-" + "9" * 40]),
)
OPTION = st.one_of(
    st.tuples(st.just("--variant"), st.sampled_from(["device", "exact", "faithful", "fast",
                                                     "spice", ""])),
    st.tuples(st.just("--engine"), st.sampled_from(["model", "spice", "", "MODEL"])),
    st.tuples(st.just("--width"), NUMBER),
    st.tuples(st.just("--max-clocks"), NUMBER),
    st.tuples(st.sampled_from(["--vcd", "--vcd="]), st.sampled_from(["", "/", "x.vcd",
                                                                     "/no/such/x.vcd"])),
    st.tuples(st.sampled_from(["--cycles", "--cw", "--ccw", "--bogus", "-x", "--width="])),
)


@st.composite
def arguments(draw):
    kind = draw(st.sampled_from(["line", "arc", "spline", ""]))
    count = {"line": 2, "arc": 4}.get(kind, draw(st.integers(0, 3)))
    count = draw(st.sampled_from([count, count, count - 1, count + 1]))
    numbers = [draw(NUMBER) for _ in range(max(count, 0))]
    options = [token for option in draw(st.lists(OPTION, max_size=4)) for token in option]
    tokens = numbers + options
    order = draw(st.permutations(range(len(tokens))))
    head = draw(st.sampled_from([["trace"], ["trace"], ["trace"], [], ["trace", "trace"],
                                 ["tracer"], ["bench", "fast"], ["build", "--board", "x"]]))
    return [*head, kind, *(tokens[i] for i in order)]


STEP = re.compile(r"^-?[01] -?[01]$")
CYCLE_STEP = re.compile(r"^\d+ -?[01] -?[01]$")


def run(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = cli.main(argv)
    return status, out.getvalue(), err.getvalue()


@settings(max_examples=1500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(arguments())
def test_contract(argv):
    # Keep each case short: a long but valid command would only take time.
    for token in argv:
        if token.lstrip("-+").isdigit() and len(token) > 6 and "--max-clocks" not in argv:
            argv = argv + ["--max-clocks", "20000"]
            break
    status, out, err = run(argv)
    assert "Traceback" not in err and "Traceback" not in out, err
    assert status in (0, 2), (argv, status, err)
    if status == 0:
        pattern = CYCLE_STEP if "--cycles" in argv else STEP
        assert all(pattern.match(line) for line in out.splitlines()), (argv, out[:200])
    else:
        assert out == "", (argv, out[:200])
        last = err.rstrip("\n").splitlines()[-1]
        assert last.startswith("kontur: ") and len(last) > len("kontur: "), (argv, err)


def test_contract_examples():
    # A few of the cases above, made sure of: refused, bad usage, traced.
    assert run(["trace", "line", "65536", "0"])[0] == 2
    assert run(["trace", "arc", "4", "0", "2", "4"])[0] == 2
    assert run(["trace", "line", "3"])[0] == 2
    assert run(["trace", "line", "3", "4", "--width", "0"])[0] == 2
    status, out, _ = run(["trace", "line", "3", "-4"])
    assert status == 0 and out == "".join(f"{dx} {dy}\n" for dx, dy in steps(3, -4))
