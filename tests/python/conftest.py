"""pytest configuration of tests/python: the `slots` mark, which test_slot_coverage.py reads."""


def pytest_configure(config):
    config.addinivalue_line(
        "markers",
        "slots(*slots, role, note=''): the dispatch-table slots ('capsule-cylinder', 'plane-sphere', "
        "'trimesh-polytope', ...) this test covers, as a 'golden' (closed-form configuration) or "
        "'random' (seeded random pairs against a reference) test; test_slot_coverage.py checks that "
        "every slot has both")
