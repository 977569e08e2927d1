"""Acceptance tests of the contact solver against closed-form answers (issue: friction, restitution,
warm start, position pass, gyroscopic term, contact forces, the Signorini certificate).

Tolerances come from the physics: Coulomb's law gives exact accelerations (a converged solve
reproduces them to rounding), Newton's law of restitution an exact rebound speed, the midpoint rule
keeps the free rotation's invariants to rounding.
"""
import math
import warnings

import numpy as np
import pytest

import signorini as sg
from signorini import scenes
from signorini.scenes import axis_angle_quaternion

from helpers import FULL, block_on_slope, first_rebound_apex, head_on_velocities, newtons_cradle

G = 9.81


@pytest.mark.parametrize("dt", [1 / 240, 1 / 60])
def test_block_slides_down_a_30_degree_slope_at_g_sin_minus_mu_cos(dt):
    w, b, downhill = block_on_slope(0.5, dt)
    w.step(dt, round(0.25 / dt))  # sliding from the first step; measure after contacts settle
    t0, v0 = w.time, w.velocities[b] @ downhill
    w.step(dt, round(2.0 / dt))
    a = (w.velocities[b] @ downhill - v0) / (w.time - t0)
    exact = G * (math.sin(math.radians(30)) - 0.5 * math.cos(math.radians(30)))  # 0.657 m/s^2
    assert a == pytest.approx(exact, rel=1e-6)  # the issue asks 1%; a converged solve gives rounding


@pytest.mark.parametrize("dt", [1 / 240, 1 / 60])
def test_block_holds_on_a_30_degree_slope_when_mu_exceeds_tan_30(dt):
    w, b, _ = block_on_slope(0.7, dt)  # tan 30 = 0.577 < 0.7
    p0 = w.positions[b].copy()
    w.step(dt, round(2.0 / dt))
    assert np.linalg.norm(w.positions[b] - p0) < 1e-5  # 0.01 mm
    # friction carries the downhill pull m g sin 30 exactly, inside the cone
    assert np.linalg.norm(w.contacts.friction.sum(axis=0)) == pytest.approx(G * 0.5, rel=1e-6)


@pytest.mark.parametrize("force", [0.4 * G, 0.9 * G])
def test_box_pushed_sideways_below_mu_m_g_stays_above_it_accelerates(force):
    dt, mu, m = 1 / 240, 0.5, 2.0
    w = sg.World()
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0), friction=mu)
    b = w.add_body(sg.Box((0.3, 0.3, 0.3)), mass=m, position=(0, 0, 0.3), friction=mu)
    w.set_external_wrench(b, force=(force * m, 0, 0))
    w.step(dt, 24)
    p0, v0, t0 = w.positions[b].copy(), w.velocities[b][0], w.time
    w.step(dt, round(2.0 / dt))
    if force * m < mu * m * G:
        assert np.linalg.norm(w.positions[b] - p0) < 1e-5
    else:
        a = (w.velocities[b][0] - v0) / (w.time - t0)
        assert a == pytest.approx((force * m - mu * m * G) / m, rel=1e-6)


@pytest.mark.parametrize("dt, substeps", [(1 / 1000, 1), (1 / 240, 4), (1 / 60, 8)])
def test_ball_with_e_half_rebounds_to_a_quarter_of_its_drop_height(dt, substeps):
    # Newton's law: rebound speed e v, apex e^2 h. What remains is the integrator's O(dt) lag of
    # the sampled apex (semi-implicit Euler rises v dt / 2 short), 0.6% here; plain dt 1/240
    # gives 0.2449 (docs/conventions.md)
    assert first_rebound_apex(dt, substeps=substeps) == pytest.approx(0.25, rel=0.02)


def test_newtons_cradle_passes_the_impact_speed_to_the_last_ball():
    # five equal frictionless spheres 2 cm apart, e = 1: each impact exchanges the velocities
    w = newtons_cradle()
    v = w.velocities[:, 0]
    assert v[-1] == pytest.approx(1.0, rel=0.01)
    assert np.all(np.abs(v[:-1]) < 0.01)
    assert w.kinetic_energy() == pytest.approx(0.5, rel=1e-9)


def test_head_on_collision_with_e_1_keeps_energy_and_e_0_sticks():
    for e, expected in ((1.0, (-1.0, 1.0)), (0.0, (0.0, 0.0))):
        va, vb = head_on_velocities(e)
        assert va == pytest.approx(expected[0], abs=1e-12)
        assert vb == pytest.approx(expected[1], abs=1e-12)


@pytest.mark.parametrize("dt", [1 / 240, 1 / 60])
def test_stack_of_10_boxes_stands_10_s_within_1_mm_with_the_defaults(dt):
    # unit 1 kg boxes resting exactly on each other: after 10 s every box within 1 mm of its start,
    # the stack at rest (a single cold solve of one full step leaves the top sinking 5 mm into the
    # slop and shifting 1.7 mm sideways; the default substeps of 1/960 s keep it within 0.3 mm)
    w = sg.World()
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    for k in range(10):
        w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(0, 0, 0.5 + k))
    p0 = w.positions.copy()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sg.SolverWarning)  # the first, cold steps
        w.step(dt, round(10 / dt))
    assert np.linalg.norm(w.positions - p0, axis=1).max() < 1e-3
    assert w.kinetic_energy() < 1e-8


def test_two_box_stack_with_mass_ratio_100_stands():
    # a 100 kg box on a 1 kg box: it stands (within 1 cm of its start after 10 s) and comes to rest
    w = sg.World()
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(0, 0, 0.5))
    w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=100.0, position=(0, 0, 1.5))
    p0 = w.positions.copy()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sg.SolverWarning)  # the first steps, before warm start helps
        w.step(1 / 240, 2400)
    assert np.abs(w.positions - p0).max() < 1e-2
    assert w.kinetic_energy() < 1e-6


def test_contact_forces_of_a_resting_stack_carry_the_weight_above():
    # a converged solve of the PGS (tight tolerance, enough sweeps): the contacts under box k carry
    # the boxes k..n-1, and the net contact force on each box is its weight
    n, m = 10, 1.0
    w = sg.World(solver="pgs", tolerance=1e-12, max_iterations=3000, substeps=1)  # one converged solve a step
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    boxes = [w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=m, position=(0, 0, 0.5 + k)) for k in range(n)]
    w.step(1 / 240, 240)
    assert w.solver_stats.converged
    c = w.contacts
    for k, body in enumerate(boxes):
        below = c.body_b == body
        assert c.force[below, 2].sum() == pytest.approx((n - k) * m * G, rel=1e-6)
        assert w.contact_forces[body] == pytest.approx([0, 0, m * G], rel=1e-6, abs=1e-6 * m * G)
    assert w.contact_forces[0][2] == pytest.approx(-n * m * G, rel=1e-6)  # the ground's reaction


def test_box_at_rest_on_a_plane_settles_below_1e_8_joule():
    w = sg.World()
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    w.add_body(sg.Box((0.4, 0.3, 0.2)), density=800.0, position=(0, 0, 0.25))
    w.step(1 / 240, 480)
    assert w.kinetic_energy() < 1e-8
    s = w.solver_stats
    assert s.converged and s.max_penetration_velocity < 1e-6
    # the four corners' friction may hold each other (the forces of a redundant manifold are not
    # unique); the pyramid allows each at most sqrt(2) mu alpha
    assert s.max_cone_violation <= (math.sqrt(2) - 1) * 0.5 * w.contacts.alpha.max() + 1e-9


def spinner(rate, dt, gyroscopic, substeps=0):
    """A free plate with inertia 1 : 2 : 3 (to 0.25%) spun about its middle axis, no gravity."""
    w = sg.World(gravity=(0, 0, 0), gyroscopic=gyroscopic, substeps=substeps)
    b = w.add_body(sg.Box((math.sqrt(2) * 0.2, 0.2, 0.01)), mass=1.0,
                   angular_velocity=(1e-3 * rate, rate, 1e-3 * rate))
    return w, b


def angular_momentum(w, b):
    R = w.rotations[b]
    return R @ w.inertias[b] @ R.T @ w.angular_velocities[b]


def test_free_spinner_keeps_energy_and_angular_momentum_with_the_midpoint_rule():
    w, b = spinner(20.0, 1 / 240, "midpoint")
    E0, L0 = w.kinetic_energy(), np.linalg.norm(angular_momentum(w, b))
    flips, last = 0, 1.0
    for _ in range(2400):
        w.step(1 / 240)
        assert w.kinetic_energy() == pytest.approx(E0, rel=1e-9)  # the issue asks 0.5%
        assert np.linalg.norm(angular_momentum(w, b)) == pytest.approx(L0, rel=1e-9)
        y_axis = w.rotations[b][:, 1] @ angular_momentum(w, b) / L0
        flips += (y_axis * last) < 0
        last = y_axis
    assert flips >= 2  # the middle axis is unstable: the plate tumbles (Dzhanibekov)


def test_fast_spinner_at_dt_1_60_stays_finite_and_gains_no_energy():
    for gyroscopic in ("midpoint", "implicit"):
        w, b = spinner(50.0, 1 / 60, gyroscopic)
        E0 = w.kinetic_energy()
        for _ in range(600):
            w.step(1 / 60)
            assert w.kinetic_energy() <= E0 * (1 + 1e-12)
        assert np.all(np.isfinite(w.angular_velocities))
    # Catto's implicit step dissipates; the lecture's explicit term gains (both by an amount that
    # grows with the step: one substep of 1/240 s each)
    w, b = spinner(20.0, 1 / 240, "implicit", substeps=1)
    w.step(1 / 240, 2400)
    assert w.kinetic_energy() < 0.9 * spinner(20.0, 1 / 240, "implicit")[0].kinetic_energy()
    w, b = spinner(20.0, 1 / 240, "explicit", substeps=1)
    E0 = w.kinetic_energy()
    w.step(1 / 240, 480)
    assert w.kinetic_energy() > 1.05 * E0


def test_cone_keeps_friction_inside_the_circle_the_pyramid_may_not():
    # a box sliding diagonally to the pyramid's tangent axes on a plane; the PGS, whose certificate
    # (cone and dissipation violations) is that of a converged solve
    for cone, bound in (("cone", 1e-9), ("pyramid", math.sqrt(2) - 1 + 1e-9)):
        w = sg.World(solver="pgs", friction_cone=cone)
        w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
        b = w.add_body(sg.Box((0.3, 0.3, 0.3)), mass=1.0, position=(0, 0, 0.3), velocity=(2.0, 2.0, 0.0))
        w.step(1 / 240, 12)
        c, s = w.contacts, w.solver_stats
        f = np.linalg.norm(c.friction, axis=1)
        assert np.all(f <= 0.5 * c.alpha * (1 + bound) + 1e-9)
        if cone == "cone":
            assert s.max_cone_violation < 1e-9
            # sliding: friction opposite the slip, on the cone's edge (maximum dissipation)
            assert s.max_dissipation_violation < 1e-6 * 0.5 * G
        else:
            assert s.max_cone_violation > 0.1 * 0.5 * c.alpha.max()


def test_warm_start_reaches_the_converged_forces_in_one_sweep():
    # awake throughout: a sleeping body's warm-start entries are set aside, not in warm_start_cache
    w = sg.World(max_iterations=1, sleeping=False)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    b = w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(0, 0, 0.5))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sg.SolverWarning)
        w.step(1 / 240, 240)
    assert w.contacts.alpha.sum() == pytest.approx(G, rel=1e-6)
    assert len(w.warm_start_cache["alpha"]) == 4
    cold = sg.World(max_iterations=1, warm_start=False, sleeping=False)
    cold.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    cold.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(0, 0, 0.5))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sg.SolverWarning)
        cold.step(1 / 240, 240)
    assert abs(cold.contacts.alpha.sum() - G) > abs(w.contacts.alpha.sum() - G)


def test_overlap_is_removed_without_adding_kinetic_energy():
    # a box placed 5 cm into the ground: pushed out at most max_push_velocity, velocity untouched.
    # The PGS: its split-impulse position pass moves the pose without velocity (the soft step's
    # springs push with velocity, which its relax sweeps take back only in part)
    w = sg.World(gravity=(0, 0, 0), max_push_velocity=0.5, solver="pgs")
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    b = w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(0, 0, 0.45))
    dt = 1 / 240
    for _ in range(240):
        z = w.positions[b][2]
        w.step(dt)
        assert w.positions[b][2] - z <= (0.5 + w.solver["tolerance"]) * dt
        assert w.kinetic_energy() < 1e-20
    assert 0.5 - w.positions[b][2] <= w.solver.get("slop") + 1e-9


def test_unconverged_substeps_warn():
    # a stack at rest with one cold sweep a substep approaches at about 0.1 m/s: under the 1 m/s
    # default (a pile's harmless leftover), flagged at 0.01 m/s. The PGS: only it raises the warning
    w = sg.World(solver="pgs", max_iterations=1, warm_start=False, warn_velocity=0.01)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    for k in range(5):
        w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(0, 0, 0.5 + k))
    with pytest.warns(sg.SolverWarning, match="unconverged"):
        w.step(1 / 240, 10)


def test_a_loop_of_unconverged_substeps_warns_once_and_counts_them_all():
    # one sweep a step leaves a stack unconverged every step: stepped one step per call, the world
    # warns on the first call only and counts every flagged step; new settings re-arm the warning.
    # The PGS: only it raises the warning
    w = sg.World(solver="pgs", max_iterations=1, tolerance=1e-12, warn_velocity=1e-9, warm_start=False, substeps=1)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    for k in range(4):
        w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=1.0, position=(0.01 * k, 0, 0.1 + 0.2 * k))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(20):
            w.step(1 / 240)
        assert w.unconverged_substeps == 20
        assert len(caught) == 1 and issubclass(caught[0].category, sg.SolverWarning)
        assert "warns once" in str(caught[0].message)
        w.set_solver(max_iterations=2)
        w.step(1 / 240, 5)
        assert len(caught) == 2 and "5 of 5 solver substeps" in str(caught[1].message)
        assert w.unconverged_substeps == 25


@pytest.mark.parametrize("kwargs, match", [
    ({"friction": -0.1}, "friction"), ({"friction": float("nan")}, "friction"),
    ({"restitution": 1.5}, "restitution"), ({"restitution": -0.1}, "restitution"),
    ({"spinning_friction": -0.001}, "spinning_friction must be finite and >= 0"),
    ({"spinning_friction": float("nan")}, "spinning_friction must be finite and >= 0"),
    ({"spinning_friction": float("inf")}, "spinning_friction must be finite and >= 0"),
])
def test_bad_materials_name_the_body_and_leave_the_world_unchanged(kwargs, match):
    w = sg.World()
    w.add_body(sg.Sphere(0.1), mass=1.0)
    with pytest.raises(ValueError, match=f"body 1 \\(Sphere\\).*{match}"):
        w.add_body(sg.Sphere(0.1), mass=1.0, **kwargs)
    assert w.num_bodies == 1
    with pytest.raises(ValueError, match=f"body 0 \\(Sphere\\).*{match}"):
        w.set_material(0, **kwargs)
    assert w.frictions[0] == 0.5 and w.restitutions[0] == 0.0 and w.spinning_frictions[0] == 0.0


@pytest.mark.parametrize("kwargs", [{"slop": -1.0}, {"max_push_velocity": 0.0}, {"substeps": -1},
                                    {"restitution_threshold": -1.0}, {"friction_cone": "square"},
                                    {"gyroscopic": "rk4"}])
def test_bad_solver_settings_are_refused(kwargs):
    with pytest.raises(ValueError, match=next(iter(kwargs))):
        sg.World(**kwargs)


@pytest.mark.slow
@pytest.mark.parametrize("dt, settings", [(1 / 240, {"max_iterations": 10, "substeps": 1}), (1 / 60, {})],
                         ids=["dt 1/240, one solve of 10 sweeps", "dt 1/60, defaults"])
def test_pyramid_of_210_boxes_stands_10_s(dt, settings):
    # base row 20, unit 1 kg boxes 1 mm apart in a row: every box within 1 cm of its start after 10 s
    # (the defaults at dt 1/60 run 16 substeps of 1/960 s)
    w = scenes.pyramid().world
    w.set_solver(**settings)
    p0 = w.positions.copy()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sg.SolverWarning)
        w.step(dt, round(10 / dt))
    assert w.num_bodies == 211
    assert np.linalg.norm(w.positions - p0, axis=1).max() < 0.01
    assert w.kinetic_energy() < 1e-3


# The pile is at rest (kinetic energy ~1e-10 J) after 5 s at dt 1/60 and 8 s at dt 1/240 (its last
# motion, a ball spinning about the vertical, ~1e-3 J until 4-6 s) and stays so: the default suite
# runs 20 s; SIGNORINI_FULL=1 runs on to 60 s, checking the energy all along and the rest again then
PILE_SECONDS = 60.0 if FULL else 20.0


@pytest.mark.slow
@pytest.mark.parametrize("dt", [1 / 240, 1 / 60])
def test_mixed_pile_never_gains_energy_and_is_at_rest_after_20_s(dt):
    # 100 spheres, boxes, capsules, cylinders, hulls, convex meshes, compounds and decomposed tori
    # dropped into a walled pit: finite throughout (a non-finite step raises), the total energy
    # never more than 1% of its start above it (the contacts only remove energy; the 1% leaves room
    # for the position pass, which moves bodies without adding velocity but can lift one a little),
    # at rest after 20 s (its spinning friction stops a ball left spinning about the vertical on its
    # one contact point, which friction alone never stops), and with SIGNORINI_FULL=1 still at
    # rest after 60 s
    w = scenes.build("pile").world
    E0 = w.kinetic_energy() + w.potential_energy()
    highest = E0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sg.SolverWarning)
        for k in range(1, round(PILE_SECONDS / dt) + 1):
            w.step(dt)
            highest = max(highest, w.kinetic_energy() + w.potential_energy())
            if k == round(20 / dt):
                assert w.kinetic_energy() < 1e-3
    assert E0 > 0
    assert highest <= E0 + 0.01 * E0
    assert w.kinetic_energy() < 1e-3
