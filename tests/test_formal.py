# amaranth: UnusedElaboratable=no
"""The formal proofs (``sim/formal.py``, ``hdl/formal/``), run by SymbiYosys: each must pass;
a deliberately broken core must fail its proof from reset (a base-case counterexample)."""

import dataclasses

import pytest

from kontur.hdl.circular import CircularInterpolator, FaithfulTiming
from kontur.hdl.formal import circular, linear
from kontur.sim import formal

from .broken import OppositeTieInterpolator
from .utils import BUILD_DIR

pytestmark = pytest.mark.formal


@pytest.mark.parametrize("name", [n for n, p in formal.PROOFS.items() if not p.slow])
def test_proof(name):
    result = formal.prove(formal.PROOFS[name])
    assert result.passed, result.report()


def test_opposite_tie_fails_the_bound():
    # The opposite tie at F = 0 stays within 0.5 cos(alpha) (a tie is exactly on the bound),
    # but it is not eq. (1): the strict side of the bound, -a < E, catches it, from reset.
    harness = lambda: linear.LinearInterpolatorProperties(
        width=16, interpolator=OppositeTieInterpolator(width=16))
    proof = dataclasses.replace(formal.PROOFS["linear_exact_16"], name="broken_opposite_tie",
                                harness=harness, depth=4)
    result = formal.prove(proof, root=BUILD_DIR / "formal" / "broken")
    assert result.status == "FAIL", result.report()
    cases = {case for case, *_ in result.failures}
    assert "basecase" in cases, result.report()
    sources = " ".join(source for _case, _location, source, _step in result.failures)
    assert "frame.e > -a" in sources, result.report()          # the bound, -a < E <= a


def test_literal_transfer_fails_the_tie_of_f():
    # Delay 12 read before the X = Y switch-over has set trigger 16: the diagonal landing on
    # X = Y adds -2, not -1, and at the next settled pulse adder 1 is no longer F of the
    # point. A start two steps from the diagonal shows it within 16 clocks of reset.
    literal = FaithfulTiming(delay12=2, check=False)
    harness = lambda: circular.CircularInterpolatorProperties(
        width=4, interpolator=CircularInterpolator(width=4, timing=literal))
    proof = dataclasses.replace(formal.PROOFS["circular_faithful_4"],
                                name="broken_literal_transfer", harness=harness, depth=16)
    result = formal.prove(proof, root=BUILD_DIR / "formal" / "broken")
    assert result.status == "FAIL", result.report()
    basecase = [source for case, _location, source, _step in result.failures
                if case == "basecase"]
    assert basecase and "ip.adder1.q" in basecase[0], result.report()


def test_failed_log_is_read():
    # The runner's reading of a SymbiYosys log: status, failed assertion, its source line.
    log = ("SBY 1:00:00 [job] summary: counterexample trace [basecase]: job/engine_0/t.vcd\n"
           f"SBY 1:00:00 [job] summary:   failed assertion top._witness_.check_3 at "
           f"{formal.ROOT / 'sim' / 'formal.py'}:1 step 2\n"
           "SBY 1:00:00 [job] DONE (FAIL, rc=2)\n")
    status, failures = formal.parse_log(log)
    first_line = (formal.ROOT / "sim" / "formal.py").read_text().splitlines()[0].strip()
    assert status == "FAIL"
    assert failures == [("basecase", "sim/formal.py:1", first_line, 2)]
