"""A ball joint's twist limits (issue 23; docs/conventions.md, "Joints"): B's turn about the joint's
axis relative to A, once the swing is taken out, stays within [lo, hi], alone or with a cone, in
both solvers and in the oracle. The twist is measured here independently of the core: the twist
part of the relative rotation q = swing * twist, 2 atan2(q_v . a, q_w)."""
import math

import numpy as np
import pytest
from helpers import AXIS, HI, LO, assert_pickle_and_saved_state_continue, hanging_rod
from scipy.spatial.transform import Rotation

import signorini as sg

DT = 1.0 / 240.0


def twist_of(R):
    """The twist (rad, in (-pi, pi]) about AXIS of a rod whose rotation is R (A is the static ground,
    at the identity; the rod starts at the identity)."""
    x, y, z, w = Rotation.from_matrix(R).as_quat()
    psi = 2.0 * math.atan2(np.dot((x, y, z), AXIS), w)
    return (psi + math.pi) % (2.0 * math.pi) - math.pi


def twists(w, rod, steps=480, forces=None):
    """The rod's twist after each step (and, into `forces`, its joint's limit force)."""
    out = []
    for _ in range(steps):
        w.step(DT)
        out.append(twist_of(w.rotations[rod]))
        if forces is not None:
            forces.append(w.joint_limit_forces[0])
    return np.array(out)


@pytest.mark.parametrize("solver, overshoot", [("pgs", 1e-6), ("soft", math.radians(1.0))])
@pytest.mark.parametrize("spin", [2.0, -2.0])
def test_a_spun_rod_twists_freely_to_its_limit_and_stops_there(solver, overshoot, spin):
    # hanging straight, the rod spins about a principal axis with no torque on it: psi = spin t
    # exactly until the limit (0.2 s or 0.15 s away); restitution 0, so it stays there (the PGS's
    # rigid row: within rounding and a substep's drift; the soft step's spring of joint_hertz: within 1 degree)
    w, rod, j = hanging_rod(solver, spin)
    forces = []
    psi = twists(w, rod, forces=forces)
    limit = HI if spin > 0 else LO
    free = np.arange(1, len(psi) + 1) * DT * spin
    before = np.abs(free) < abs(limit) - abs(spin) * DT  # a whole step before the limit
    np.testing.assert_allclose(psi[before], free[before], rtol=0, atol=1e-9)
    if spin > 0:
        assert psi.max() < HI + overshoot and psi[-120:].min() > HI - overshoot
    else:
        assert psi.min() > LO - overshoot and psi[-120:].max() < LO + overshoot
    # the rod has stopped turning about its axis; the limit pushed to stop it (> 0 at the lower
    # one), never the other way, and nothing pushes it once it rests there
    assert abs(np.dot(w.angular_velocities[rod], AXIS)) < 1e-3
    forces = np.array(forces) * math.copysign(1.0, -spin)
    assert forces.max() > 0.0 and forces.min() >= 0.0
    assert abs(forces[-1]) < 1e-6


@pytest.mark.parametrize("solver, overshoot", [("pgs", 1e-3), ("soft", math.radians(1.0))])
def test_twist_limits_hold_while_the_rod_swings_against_a_cone(solver, overshoot):
    # spun and kicked at once: the rod swings past 90 degrees without a cone; with a 0.5 rad cone
    # and the twist limits, both hold together, the twist measured with the swing taken out
    w, rod, _ = hanging_rod(solver, spin=3.0, swing=6.0, cone=0.5)
    psi, swing = [], []
    for _ in range(480):
        w.step(DT)
        R = w.rotations[rod]
        psi.append(twist_of(R))
        swing.append(math.acos(np.clip(np.dot(R @ AXIS, AXIS), -1.0, 1.0)))
    assert max(psi) > HI - 0.02 and max(psi) < HI + overshoot and min(psi) > LO - overshoot
    assert max(swing) > 0.48 and max(swing) < 0.5 + overshoot


def test_inside_its_range_the_joint_is_a_plain_ball_joint():
    # a small twist (amplitude 0.05 rad) never reaches the limits: bit for bit the free ball joint
    def run(twist):
        w, rod, _ = hanging_rod("pgs", 0.0, twist=twist)
        w.set_angular_velocity(rod, (0.4, 0.2, 0.3))
        w.step(DT, 240)
        return np.concatenate([w.positions.ravel(), w.velocities.ravel(), w.angular_velocities.ravel()])
    np.testing.assert_array_equal(run((LO, HI)), run(None))


def test_the_oracle_matches_a_twist_at_its_limit_step_by_step():
    from signorini import compare
    w, rod, _ = hanging_rod("pgs", 3.0, swing=2.0, cone=0.5)
    w.step(DT, 40)  # at the twist limit by now (0.4 rad at 3 rad/s: 32 steps)
    assert w.joint_limit_forces[0] != 0.0
    report = compare.lockstep(w, DT, 20)
    assert report.largest < 1e-10, "\n".join(report.lines())
    assert report.stat_mismatches == 0, report.first_stat_mismatch


def test_twist_limits_survive_pickling_saved_states_and_scene_files(tmp_path):
    w, rod, _ = hanging_rod("pgs", 3.0, swing=1.0, cone=0.5)
    w.step(DT, 30)
    assert w.save_state().data[:8] == b"SGSTATE8"
    assert_pickle_and_saved_state_continue(w, DT)
    assert w.joint(0)["has_twist"] and (w.joint(0)["twist_lower"], w.joint(0)["twist_upper"]) == (LO, HI)
    fresh, rod, _ = hanging_rod("pgs", 3.0)
    path = tmp_path / "twist.toml"
    fresh.save_scene(path)
    assert "twist = [" in path.read_text()
    again = sg.load_scene(path)
    np.testing.assert_array_equal(twists(fresh, rod, 120), twists(again, rod, 120))


@pytest.mark.parametrize("kw, words", [
    (dict(twist=(LO, HI)), ["axis"]),
    (dict(axis=(0, 0, 0), twist=(LO, HI)), ["axis", "non-zero"]),
    (dict(axis=(0, 0, 1), twist=(0.5, 0.4)), ["twist", "lower <= upper"]),
    (dict(axis=(0, 0, 1), twist=(-4.0, 0.4)), ["twist", "(-pi, pi)"]),
    (dict(axis=(0, 0, 1), twist=(-0.3, math.pi)), ["twist", "(-pi, pi)"]),
    (dict(axis=(0, 0, 1), twist=(math.nan, 0.4)), ["twist"]),
    (dict(axis=(0, 0, 1), twist=0.4), ["twist", "(lower, upper)"]),
])
def test_bad_twist_limits_are_refused_naming_the_joint(kw, words):
    w = sg.World()
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    rod = w.add_body(sg.Box((0.02, 0.02, 0.5)), mass=1.0, position=(0, 0, 1.0))
    before = w.save_state().data
    with pytest.raises((TypeError, ValueError)) as e:
        w.add_joint(sg.Spherical(ground, rod, anchor=(0, 0, 1.5), **kw))
    assert "joint 0" in str(e.value)
    for word in words:
        assert word in str(e.value)
    assert w.num_joints == 0 and w.save_state().data == before


def test_the_twist_rows_direction_is_the_twists_exact_rate():
    # dpsi/dt = t . (omega_B - omega_A), t = (a_A + a_B) / (1 + a_A . a_B), at random poses with up to
    # a 2 rad swing: against a central difference of psi over +-1e-6 s (error ~ 1e-10, rounding
    # 1e-16 / 1e-6); the unit bisector, the usual approximation, is off by up to tens of percent
    from signorini.oracle.joints import twist_angle
    joint = {"axis_a": AXIS, "axis_b": AXIS, "ref_a": np.array([1.0, 0, 0]), "ref_b": np.array([1.0, 0, 0])}
    rng = np.random.default_rng(7)
    worst_bisector = 0.0
    for k in range(50):
        RA = Rotation.random(random_state=k).as_matrix()
        RB = RA @ Rotation.from_rotvec(rng.normal(size=3) * 0.7).as_matrix()
        w_a, w_b = rng.normal(size=3), rng.normal(size=3)
        turn = lambda R, w, h: Rotation.from_rotvec(w * h).as_matrix() @ R
        h = 1e-6
        rate = (twist_angle(joint, turn(RA, w_a, h), turn(RB, w_b, h))[0]
                - twist_angle(joint, turn(RA, w_a, -h), turn(RB, w_b, -h))[0]) / (2 * h)
        _, t = twist_angle(joint, RA, RB)
        assert abs(rate - t @ (w_b - w_a)) < 1e-7 * (1 + abs(rate))
        bisector = t / np.linalg.norm(t)
        worst_bisector = max(worst_bisector, abs(rate - bisector @ (w_b - w_a)) / max(abs(rate), 1e-3))
    assert worst_bisector > 0.05


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_at_a_swing_of_pi_the_twist_rows_stay_open_and_the_oracle_agrees(solver):
    # with twist limits and no cone the rod may swing over the top: at a swing of exactly pi the
    # twist is not defined, and its two rows stay with C = 2 pi (far open: they cannot push), so the
    # joint has the same rows at every pose; the oracle builds the same, and both step through it
    from signorini import compare
    from signorini.oracle.joints import build_blocks
    w, rod, j = hanging_rod(solver, 0.0)
    flip = Rotation.from_rotvec((math.pi, 0.0, 0.0))
    w.set_orientation(rod, flip.as_quat()[[3, 0, 1, 2]])
    w.set_position(rod, (0.0, 0.0, 0.5))
    joint = w.joint(j)
    blocks = build_blocks(joint, np.zeros(3), np.eye(3), np.array(w.positions[rod]), w.rotations[rod], DT)
    twist_rows = [b for b in blocks if b["slot"] in (6, 7)]
    assert len(twist_rows) == 2 and all(b["C"][0] == 2.0 * math.pi for b in twist_rows)
    # balanced upside down (gravity along the rod), it stays at the swing of pi: the rows never push
    report = compare.lockstep(w, DT, 5)
    assert report.largest < 1e-10, "\n".join(report.lines())
    assert w.joint_row_forces[j, 6] == 0.0 and w.joint_row_forces[j, 7] == 0.0
    # tipped, it swings away through poses where the twist is barely defined: the same in both
    w.set_angular_velocity(rod, (0.0, 0.5, 0.0))
    report = compare.lockstep(w, DT, 5)
    assert report.largest < 1e-10, "\n".join(report.lines())
