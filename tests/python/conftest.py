"""pytest configuration of tests/python: the `slots` mark, which test_slot_coverage.py reads, and the
`slow` mark of the tests that take seconds each (``pytest -m "not slow"`` is the quick subset).

Seeded random samples of hundreds of pairs or scenes run a smaller sample by default and their full
one with SIGNORINI_FULL=1 in the environment (helpers.sample)."""
import math

import pytest

from signorini import fuzz


def pytest_configure(config):
    config.addinivalue_line(
        "markers",
        "slots(*slots, role, note=''): the dispatch-table slots ('capsule-cylinder', 'plane-sphere', "
        "'trimesh-polytope', ...) this test covers, as a 'golden' (closed-form configuration) or "
        "'random' (seeded random pairs against a reference) test; test_slot_coverage.py checks that "
        "every slot has both")
    config.addinivalue_line(
        "markers",
        "slow: takes seconds (a long simulation, an oracle rollout, a large random sample, a browser or a "
        "server); part of the default suite, left out of the quick subset (pytest -m 'not slow')")


@pytest.fixture(autouse=True)
def _no_wall_time_in_fuzz_results(monkeypatch):
    """Tests never assert on wall time: the fuzzer's `slow` failure (a step past fuzz.SLOW_STEP of
    wall time, a finding for fuzzing runs) is off in the tests that run scenes in this process, so a
    stall of a shared machine (a 145 ms step of 35 bodies, once, in CI) fails none of them."""
    monkeypatch.setattr(fuzz, "SLOW_STEP", math.inf)
