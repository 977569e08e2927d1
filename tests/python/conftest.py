"""pytest configuration of tests/python: the `slots` mark, which test_slot_coverage.py reads, and the
`slow` mark of the tests that take seconds each (``pytest -m "not slow"`` is the quick subset).

Seeded random samples of hundreds of pairs or scenes run a smaller sample by default and their full
one with SIGNORINI_FULL=1 in the environment (helpers.sample)."""


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
