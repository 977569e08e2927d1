"""World.step_profile: where the last step call's wall time went, stage by stage. Never a timing
assertion: only what the profile is (its stages, in order, non-negative, adding up to the total,
summed over the call's steps, zero for the stages a solver does not run)."""
import math

import pytest

import signorini as sg

STAGES = ["guard", "detect", "wake", "prepare", "solve", "integrate", "relax", "store", "continuous", "commit", "total"]


def pile(solver):
    w = sg.World(solver=solver, sleeping=False)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    for k in range(4):
        w.add_body(sg.Box((0.5, 0.5, 0.5)), density=100.0, position=(0.0, 0.0, 0.5 + 1.0 * k))
    return w


def adds_up(profile):
    parts = math.fsum(v for k, v in profile.items() if k != "total")
    return parts == pytest.approx(profile["total"], rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_the_stages_come_in_the_steps_order_and_add_up_to_the_whole_step(solver):
    w = pile(solver)
    w.step(1 / 60, 3)
    profile = w.step_profile
    assert list(profile) == STAGES
    assert all(v >= 0.0 for v in profile.values())
    assert profile["total"] > 0.0 and profile["solve"] > 0.0 and profile["detect"] > 0.0
    assert adds_up(profile)
    # the PGS's rows, sweeps and store run inside its solve stage, every substep
    if solver == "pgs":
        assert profile["prepare"] == profile["relax"] == profile["store"] == 0.0
    else:
        assert profile["prepare"] > 0.0 and profile["relax"] > 0.0 and profile["store"] > 0.0


def test_a_call_of_no_steps_has_a_profile_of_zeros_and_each_call_starts_again():
    w = pile("soft")
    w.step(1 / 60, 2)
    assert w.step_profile["total"] > 0.0
    w.step(1 / 60, 0)
    assert w.step_profile == dict.fromkeys(STAGES, 0.0)


def test_the_profile_is_no_part_of_the_result():
    a, b = pile("soft"), pile("soft")
    for _ in range(20):
        a.step(1 / 60)
        a.step_profile  # reading it changes nothing
        b.step(1 / 60)
    assert (a.positions == b.positions).all() and (a.velocities == b.velocities).all()
