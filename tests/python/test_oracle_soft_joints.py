"""The NumPy oracle's soft step with joints (issue 23; docs/conventions.md, "Joints", "In the soft
step"): ``signorini.oracle.soft.soft_step`` repeats each step of the core's soft step
(World(solver="soft")) from the same state and contacts, its joints' rows included (springs in the
biased sweeps, rigid in the relax sweeps, the drift and its skips), and never calls the core.

Tolerance: 1e-10 on every compared quantity (``compare.lockstep``), as for the PGS: the oracle
evaluates the same formulas in another order, so the two differ by rounding only (a few ulps of
the largest velocity or force, measured 1e-14 here), and any real difference of a rule (a row, a
bias, a sweep out of order) shows at the size of the quantity it changes, far above 1e-10.
"""
import numpy as np
from helpers import every_kind, hanging_rod, load_benchmark

import signorini as sg
from signorini import compare, oracle
from signorini.oracle.joints import DRIFT_TURN

DT = 1.0 / 240.0
LOCKSTEP = 1e-10


def assert_lockstep(w, dt, steps):
    report = compare.lockstep(w, dt, steps)
    assert report.largest < LOCKSTEP, "\n".join(report.lines())
    assert report.stat_mismatches == 0, report.first_stat_mismatch
    return report


def one_step(w, dt):
    """Steps the world once and the oracle once from the same state and contacts; returns the
    oracle's (new_snapshot, info)."""
    before = w.snapshot()
    detected = w.detect_contacts(dt).as_dict()
    contacts = {key: detected[key] for key in ("body_a", "body_b", "point", "normal", "gap", "feature_a", "feature_b")}
    w.step(dt)
    return oracle.step(before, dt, contacts=contacts)


def test_oracle_matches_soft_steps_of_a_jointed_scene():
    # every joint kind (hinges with limits, motors rigid and spring-damper, friction and effort;
    # sliders; balls; welds; a rope; a rod) beside contacts with loose boxes on the floor
    w = every_kind("soft")
    w.step(DT, 30)  # the chains swing onto the floor, limits and contacts act
    w.set_joint_broken(4)  # a broken joint makes no rows in either
    assert_lockstep(w, DT, 20)
    assert w.solver_stats.contacts > 0
    assert np.count_nonzero(w.joint_limit_forces) > 0
    # and the joints' forces and torques on B, at the step's end poses
    new, info = one_step(w, DT)
    scale = max(1.0, float(np.abs(w.joint_forces).max()))
    np.testing.assert_allclose(info["joint_force"], w.joint_forces, rtol=0, atol=LOCKSTEP * scale)
    np.testing.assert_allclose(info["joint_torque"], w.joint_torques, rtol=0, atol=LOCKSTEP * scale)
    core_alpha = np.array([j["alpha"] for j in w.snapshot()["joints"]])
    np.testing.assert_allclose(np.array([j["alpha"] for j in new["joints"]]), core_alpha, rtol=0,
                               atol=LOCKSTEP * max(1.0, float(np.abs(core_alpha).max())))
    assert np.abs(w.joint_forces).max() > 0.1


def test_oracle_matches_soft_steps_with_more_sweeps_and_substeps_without_warm_start():
    # two biased and two relax sweeps (each followed by the joints'), 3 substeps, and no warm start
    # (every joint's forces start from 0 in each substep, an effort row's from its first sweep)
    w = every_kind("soft")
    w.set_solver(soft_iterations=2, relax_iterations=2, substeps=3, warm_start=False)
    w.step(DT, 30)
    assert_lockstep(w, DT, 10)
    assert w.solver_stats.contacts > 0


def test_oracle_matches_soft_steps_of_a_ragdoll_on_the_ground():
    # benchmarks/bench_joints.py's ragdoll (ball joints with cones and twists, hinges with limits)
    # dropped onto the ground at its benchmark step (1/60 s: 4 substeps of the soft step)
    bench = load_benchmark("bench_joints")
    dt = 1.0 / 60.0
    w = sg.World(gravity=(0.0, 0.0, -10.0), solver="soft", sleeping=False)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0), friction=0.6)
    R, t = bench.ragdoll_layer_pose(0, per_layer=1, lift=0.3)
    bench.add_ragdoll(w, R, t)
    w.step(dt, 30)  # landed: the parts on the ground, their joints loaded
    assert w.solver_stats.contacts > 0
    assert_lockstep(w, dt, 10)
    assert np.abs(w.joint_forces).max() > 1.0


def test_oracle_matches_a_soft_twist_at_its_limit():
    # a rod spun about its axis at 3 rad/s and swinging against a 0.5 rad cone: at its twist limit
    # (held there by the speculative rule, C a few nm inside: measured 6e-9 rad)
    w, rod, _ = hanging_rod("soft", 3.0, swing=2.0, cone=0.5)
    w.step(DT, 40)  # at the twist limit by now (0.4 rad at 3 rad/s: 32 steps)
    assert w.joint_limit_forces[0] != 0.0
    assert_lockstep(w, DT, 20)
    assert w.joint_limit_forces[0] != 0.0


def test_oracle_matches_a_soft_joint_turning_too_fast_for_its_drift():
    # a free ball joint whose rod spins at 60 rad/s: it turns 60 h / 2 = 0.125 rad in half a substep,
    # more than DRIFT_TURN, so the soft step asks no drift of it (a hinge beside it at 10 rad/s does)
    w, rod, _ = hanging_rod("soft", 60.0, swing=1.0, twist=None)
    ground = 0  # hanging_rod's static plane, far below
    bob = w.add_body(sg.Sphere(0.05), mass=1.0, position=(2.0, 0.0, -1.0))
    w.add_joint(sg.Revolute(ground, bob, anchor=(2.0, 0.0, 0.0), axis=(0, 1, 0)))
    w.set_angular_velocity(bob, (0.0, 10.0, 0.0))
    w.set_velocity(bob, (-10.0, 0.0, 0.0))  # omega x (0, 0, -1): swinging about the hinge
    assert 0.5 * DT * np.linalg.norm(w.angular_velocities[rod]) > DRIFT_TURN
    assert 0.5 * DT * np.linalg.norm(w.angular_velocities[bob]) < DRIFT_TURN
    assert_lockstep(w, DT, 20)
    assert 0.5 * DT * np.linalg.norm(w.angular_velocities[rod]) > DRIFT_TURN


def test_a_joint_breaks_after_the_soft_step_in_the_oracle_as_in_the_core():
    # a 1 kg bob thrown at 4 m/s on a 0.5 m ball joint that bears 20 N: the soft joint's spring
    # takes a step to load (10.5 N in the first), then pulls towards m (g + v^2 / L) = 42 N and
    # breaks after the second step, in the oracle as in the core (each step from the core's state)
    w = sg.World(gravity=(0.0, 0.0, -9.81), solver="soft", sleeping=False)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-10.0))
    bob = w.add_body(sg.Sphere(0.05), mass=1.0, position=(0.0, 0.0, -0.5), velocity=(4.0, 0.0, 0.0))
    w.add_joint(sg.Spherical(ground, bob, anchor=(0.0, 0.0, 0.0), break_force=20.0))
    for _ in range(20):
        new, info = one_step(w, DT)
        broke = list(w.joint_breaks.joint)
        assert info["joint_breaks"] == broke
        assert new["joints"][0]["broken"] == w.snapshot()["joints"][0]["broken"]
        np.testing.assert_allclose(info["joint_force"], w.joint_forces, rtol=0, atol=LOCKSTEP * 50.0)
        if broke:
            break
    assert broke == [0]
    assert not np.any(new["joints"][0]["alpha"]) and not np.any(info["joint_force"])
    # the next steps: no rows in either, the bob flies free
    assert_lockstep(w, DT, 5)
    assert w.joint_forces[0].tolist() == [0.0, 0.0, 0.0]
