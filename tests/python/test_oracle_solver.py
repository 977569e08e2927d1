"""Tests of the oracle's staged contact solver (signorini.oracle.solver) and the gyroscopic
options of its unconstrained step, against closed forms of mechanics.

Only the oracle is imported: it is the reference the C++ core is checked against, so it is
checked here against physics.  Tolerances are derived in comments; eps = 2.2e-16 is the
double-precision unit roundoff.  A solve stops after a sweep whose largest velocity change
delta |d_alpha| is <= tolerance; where a closed form is compared to 1e-6 or better, the test sets
a tolerance far below it (1e-12 m/s) and says how the per-step error adds up.
"""

import numpy as np
import pytest

from signorini import oracle as o

EPS = np.finfo(float).eps
G = 9.81


# --------------------------------------------------------------------------- scene helpers

def make_body(shape, density=1000.0, static=False, friction=0.5, restitution=0.0):
    """A body dict as ``World.snapshot()`` gives it, with its material."""
    if static:
        body = {"shape": shape, "static": True, "mass": np.inf, "inv_mass": 0.0,
                "inertia": np.zeros((3, 3)), "inv_inertia": np.zeros((3, 3))}
    else:
        m, _, I = o.mass_properties(shape, density)
        body = {"shape": shape, "static": False, "mass": m, "inv_mass": 1.0 / m,
                "inertia": I, "inv_inertia": np.linalg.inv(I)}
    body.update(friction=friction, restitution=restitution)
    return body


def make_snapshot(bodies, position, rotation=None, velocity=None, angular_velocity=None,
                  gravity=(0.0, 0.0, -G), **settings):
    """A snapshot; settings not given take the documented defaults (the oracle fills them in),
    but for substeps: 1, so that a step of these tests is the single step their closed forms
    describe (the automatic choice would split dt = 0.01 s into 3)."""
    N = len(bodies)
    return {
        "gravity": np.array(gravity, dtype=float),
        "settings": {"substeps": 1, **settings},
        "bodies": bodies,
        "position": np.array(position, dtype=float).reshape(N, 3),
        "rotation": (np.tile(np.eye(3), (N, 1, 1)) if rotation is None
                     else np.array(rotation, dtype=float).reshape(N, 3, 3)),
        "velocity": np.zeros((N, 3)) if velocity is None else np.array(velocity, float).reshape(N, 3),
        "angular_velocity": (np.zeros((N, 3)) if angular_velocity is None
                             else np.array(angular_velocity, float).reshape(N, 3)),
        "force": np.zeros((N, 3)),
        "torque": np.zeros((N, 3)),
    }


def plane(normal=(0.0, 0.0, 1.0), offset=0.0, **material):
    return make_body({"type": "plane", "normal": np.array(normal, float), "offset": offset},
                     static=True, **material)


def sphere_on_plane(gap=0.0, velocity=(0.0, 0.0, 0.0), r=0.5, mu=0.5, e=0.0, **settings):
    """A sphere of radius r (1000 kg/m^3) at the given gap above the plane z = 0, both of
    material (mu, e)."""
    return make_snapshot([plane(friction=mu, restitution=e),
                          make_body({"type": "sphere", "radius": r}, friction=mu, restitution=e)],
                         [[0, 0, 0], [0, 0, r + gap]], velocity=[[0, 0, 0], velocity], **settings)


# --------------------------------------------------------------------------- rows and materials

def test_tangent_basis_rule_and_orthonormality():
    # n = e_z: |n_x| = |n_y| = 0 tie, the first (x) wins: t1 = unit(e_z x e_x) = e_y, t2 = e_z x e_y = -e_x
    t1, t2 = o.tangent_basis([[0.0, 0.0, 1.0]])
    np.testing.assert_array_equal(t1, [[0.0, 1.0, 0.0]])
    np.testing.assert_array_equal(t2, [[-1.0, 0.0, 0.0]])
    # random normals: (n, t1, t2) orthonormal and right-handed to rounding (a few ulp)
    rng = np.random.default_rng(0)
    n = rng.normal(size=(50, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    t1, t2 = o.tangent_basis(n)
    frames = np.stack([n, t1, t2], axis=2)
    np.testing.assert_allclose(np.einsum("kij,kil->kjl", frames, frames), np.tile(np.eye(3), (50, 1, 1)),
                               rtol=0, atol=8 * EPS)
    np.testing.assert_allclose(np.linalg.det(frames), 1.0, rtol=0, atol=8 * EPS)
    # t1 is orthogonal to the axis of the smallest |n_k|
    k = np.argmin(np.abs(n), axis=1)
    np.testing.assert_allclose(t1[np.arange(50), k], 0.0, rtol=0, atol=0)


def test_materials_combine_and_default():
    # mu = sqrt(mu_A mu_B), e = max(e_A, e_B); a body without the keys has mu 0.5 and e 0
    bodies = [plane(friction=0.8, restitution=0.1),
              make_body({"type": "sphere", "radius": 0.5}, friction=0.2, restitution=0.6),
              make_body({"type": "sphere", "radius": 0.5})]
    del bodies[2]["friction"], bodies[2]["restitution"]
    contacts = {"body_a": np.array([0, 0, 1]), "body_b": np.array([1, 2, 2])}
    snap = make_snapshot(bodies, np.zeros((3, 3)))
    mu, e = o.contact_materials(snap, contacts)
    np.testing.assert_allclose(mu, [0.4, np.sqrt(0.4), np.sqrt(0.1)], rtol=4 * EPS)
    np.testing.assert_array_equal(e, [0.6, 0.1, 0.6])


def test_settings_defaults_and_checks():
    s = o.solver_settings({"settings": {"erp": 0.3}})
    assert s["erp"] == 0.3 and s == {**o.DEFAULT_SETTINGS, "erp": 0.3}
    assert o.solver_settings({}) == o.DEFAULT_SETTINGS
    for bad in ({"friction_cone": "square"}, {"gyroscopic": "rk4"}, {"substeps": -1}, {"solver": "tgs"},
                {"contact_hertz": 0.0}, {"contact_hertz": np.inf}, {"damping_ratio": -1.0},
                {"soft_iterations": 0}, {"relax_iterations": -1}):
        with pytest.raises(ValueError):
            o.solver_settings({"settings": bad})
    # automatic substeps: the fewest of at most 1/960 s (PGS) or 1/240 s (the soft step)
    from signorini.oracle.solver import substep_count
    soft = o.solver_settings({"settings": {"solver": "soft"}})
    assert [substep_count(o.DEFAULT_SETTINGS, dt) for dt in (1 / 960, 1 / 240, 1 / 60)] == [1, 4, 16]
    assert [substep_count(soft, dt) for dt in (1 / 960, 1 / 240, 1 / 60, 1 / 30)] == [1, 1, 4, 8]
    assert substep_count({**soft, "substeps": 3}, 1 / 60) == 3


def test_rows_are_the_jacobian_transposes_and_delta_is_their_mass():
    # J_A = -J_A(y)^T d, J_B = J_B(y)^T d for d = n, t1, t2; delta = dt (J M^-1 J) both sides
    rng = np.random.default_rng(1)
    bodies = [make_body({"type": "box", "half_extents": [0.3, 0.2, 0.1]}) for _ in range(2)]
    snap = make_snapshot(bodies, rng.normal(size=(2, 3)),
                         rotation=[o.quat_to_matrix(rng.normal(size=4)) for _ in range(2)])
    n = rng.normal(size=3)
    contacts = {"body_a": np.array([0]), "body_b": np.array([1]), "point": rng.normal(size=(1, 3)),
                "normal": [n / np.linalg.norm(n)], "gap": np.array([0.01])}
    dt = 0.01
    rows = o.prepare_rows(snap, contacts, np.zeros((2, 6)), dt)
    M_inv = o.inverse_mass_blocks(snap)
    t1, t2 = o.tangent_basis(contacts["normal"])
    y = contacts["point"][0]
    for k, d in enumerate([contacts["normal"][0], t1[0], t2[0]]):
        J_A = -o.jacobian(snap["position"][0], y).T @ d
        J_B = o.jacobian(snap["position"][1], y).T @ d
        np.testing.assert_allclose(rows["J_A"][k], J_A, rtol=0, atol=1e-14)
        np.testing.assert_allclose(rows["J_B"][k], J_B, rtol=0, atol=1e-14)
        assert rows["delta"][k] == pytest.approx(dt * (J_A @ M_inv[0] @ J_A + J_B @ M_inv[1] @ J_B), rel=1e-13)
    assert rows["bias"][0] == pytest.approx(0.01 / dt, rel=1e-15)


# --------------------------------------------------------------------------- friction on a slope

def slope_scene(mu, axis, friction_cone, theta=np.radians(30.0), h=(0.2, 0.15, 0.1)):
    """A box (half extents h) resting on the plane through the origin tilted by theta about the
    horizontal axis, box and plane of friction mu; gravity -z.  Returns the snapshot, the plane
    normal n and the unit downhill direction s."""
    axis = np.asarray(axis, dtype=float)
    R = o.rodrigues(axis / np.linalg.norm(axis), theta)
    n = R @ [0.0, 0.0, 1.0]
    snap = make_snapshot([plane(n, friction=mu), make_body({"type": "box", "half_extents": list(h)}, friction=mu)],
                         [[0, 0, 0], h[2] * n], rotation=[np.eye(3), R],
                         friction_cone=friction_cone, tolerance=1e-12, max_iterations=1000)
    g_t = np.array([0.0, 0.0, -G]) + G * n[2] * n
    return snap, n, g_t / np.linalg.norm(g_t)


# tilt about -e_y: n = (-sin 30, 0, cos 30) and t1 (the axis of the smallest |n_k| is y) is the
# slope direction, so the pyramid's rows are along and across the slope; the other axis makes the
# slope run between t1 and t2
ALIGNED, OBLIQUE = (0.0, -1.0, 0.0), (np.cos(0.7), np.sin(0.7), 0.0)


@pytest.mark.parametrize("friction_cone, axis", [("pyramid", ALIGNED), ("cone", ALIGNED), ("cone", OBLIQUE)])
def test_box_slides_down_a_30_degree_slope_at_g_sin_minus_mu_cos(friction_cone, axis):
    # mu = 0.5 < tan 30: the box slides with a = g (sin 30 - mu cos 30) = 0.657 m/s^2, all four
    # corners pushing and the friction mu alpha_i against the slip at each (no torque about n:
    # the centre of pressure lies on the slope line through the com).  Each step's velocity
    # errs by about the solver tolerance (1e-12 m/s); over 230 steps that is < 1e-9 m/s against a
    # velocity gain of a * 0.96 s = 0.63 m/s: 1e-6 relative leaves a wide margin.
    mu, dt, steps = 0.5, 1 / 240, 240
    snap, n, s = slope_scene(mu, axis, friction_cone)
    out = o.rollout(snap, dt, steps)
    v = out["velocity"][:, 1] @ s
    a = (v[steps] - v[10]) / ((steps - 10) * dt)
    a_ref = G * (np.sin(np.radians(30)) - mu * np.cos(np.radians(30)))
    assert a == pytest.approx(a_ref, rel=1e-6)
    # it slides straight down: no velocity across the slope or off it, no spin
    np.testing.assert_allclose(out["velocity"][:, 1] - np.outer(v, s), 0.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["angular_velocity"][:, 1], 0.0, rtol=0, atol=1e-9)
    # the forces: N = m g cos 30 over four pushing corners, each with mu alpha_i against the slip
    # (N-scale figures: the weight is m g ~ 235 N, so 1e-9 N is rounding of the sums)
    info = out["infos"][-1]
    m = snap["bodies"][1]["mass"]
    assert len(info["alpha"]) == 4 and np.all(info["alpha"] > 0)
    assert info["alpha"].sum() == pytest.approx(m * G * np.cos(np.radians(30)), rel=1e-9)
    np.testing.assert_allclose(info["friction"] @ s, -info["mu"] * info["alpha"], rtol=1e-9)
    np.testing.assert_allclose(info["friction"].sum(axis=0), -mu * info["alpha"].sum() * s, rtol=0, atol=1e-9)
    assert info["max_penetration_velocity"] < 1e-12 and info["residual"] < 1e-12
    if friction_cone == "cone":
        # the certificate: every friction force on the cone's edge, against its slip
        assert info["max_dissipation_violation"] < 1e-9 and info["max_cone_violation"] < 1e-9
    else:
        # the pyramid's cross-slope rows stick (no slip across) and may hold self-balancing forces
        # pulling the corners together, which the certificate reports as off the cone; they cancel
        assert np.abs(info["slip"] - np.outer(info["slip"] @ s, s)).max() < 1e-12
        np.testing.assert_allclose(info["friction"].sum(axis=0) @ np.cross(n, s), 0.0, rtol=0, atol=1e-9)


@pytest.mark.parametrize("friction_cone, axis", [("pyramid", ALIGNED), ("cone", ALIGNED), ("cone", OBLIQUE)])
def test_box_sticks_on_a_30_degree_slope_with_mu_above_tan_30(friction_cone, axis):
    # mu = 0.7 > tan 30 = 0.577: static friction m g sin 30 holds the box.  Each step leaves at
    # most ~ the tolerance (1e-12 m/s) of velocity, so 1 s moves it < 1e-11 m: 1e-8 m is safe.
    mu, dt, steps = 0.7, 1 / 240, 240
    snap, n, s = slope_scene(mu, axis, friction_cone)
    out = o.rollout(snap, dt, steps)
    assert np.linalg.norm(out["position"][-1, 1] - out["position"][0, 1]) < 1e-8
    # the total contact force on the box is its weight, upwards; on the plane the opposite
    m = snap["bodies"][1]["mass"]
    info = out["infos"][-1]
    np.testing.assert_allclose(info["body_force"][1], [0, 0, m * G], rtol=0, atol=1e-9 * m * G)
    np.testing.assert_allclose(info["body_force"][0], -info["body_force"][1], rtol=0, atol=1e-12 * m * G)
    np.testing.assert_allclose(info["body_torque"][1], 0.0, rtol=0, atol=1e-9 * m * G)
    np.testing.assert_allclose(info["force"].sum(axis=0), [0, 0, m * G], rtol=0, atol=1e-9 * m * G)


def test_pyramid_grips_an_oblique_slope_up_to_sqrt2_mu():
    # On the oblique slope the downhill direction s has components (s1, s2) on (t1, t2).  The
    # pyramid bounds each component by mu alpha, so it can hold up to mu N / max(|s1|, |s2|)
    # along s (between mu N and sqrt(2) mu N): with mu = 0.5 that exceeds m g sin 30 here, and the
    # box that slides under the cone stays put.  Its friction then exceeds mu alpha, and the
    # certificate says by how much.
    mu = 0.5
    snap, n, s = slope_scene(mu, OBLIQUE, "pyramid")
    t1, t2 = o.tangent_basis([n])
    grip = mu / max(abs(s @ t1[0]), abs(s @ t2[0]))
    assert np.tan(np.radians(30)) < grip < np.sqrt(2) * mu
    out = o.rollout(snap, 1 / 240, 48)
    assert np.linalg.norm(out["position"][-1, 1] - out["position"][0, 1]) < 1e-9
    info = out["infos"][-1]
    m = snap["bodies"][1]["mass"]
    f_t = info["friction"].sum(axis=0)
    N = info["alpha"].sum()
    assert np.linalg.norm(f_t) == pytest.approx(m * G * np.sin(np.radians(30)), rel=1e-9)
    assert mu * N < np.linalg.norm(f_t) <= np.sqrt(2) * mu * N
    assert info["max_cone_violation"] > 0.0


@pytest.mark.parametrize("degrees", [0.0, 20.0, 45.0, 70.0, 90.0, 135.0, 200.0])
def test_cone_keeps_friction_on_the_disk_and_the_pyramid_within_sqrt2(degrees):
    # A sphere sliding at 3 m/s on the plane z = 0 (n = e_z, t1 = e_y, t2 = -e_x) in the direction
    # phi.  Friction can change the slip by at most mu g dt (1 + m r^2 / I) = 0.17 m/s in a step,
    # so it slides all step and Coulomb's law puts the force on the edge: the cone gives exactly
    # |f| = mu alpha against the slip; the pyramid clamps each row at mu alpha, so |f| <= sqrt(2)
    # mu alpha, equal on the diagonals (both rows saturate whenever both slip components exceed
    # 0.17 m/s), and mu alpha on the axes.  Rounding: a few ulp of the force, 1e-12 relative.
    phi = np.radians(degrees)
    v = 3.0 * np.array([np.cos(phi), np.sin(phi), 0.0])
    forces = {}
    for cone in ("cone", "pyramid"):
        _, info = o.step(sphere_on_plane(velocity=v, friction_cone=cone, tolerance=1e-12,
                                         max_iterations=1000), 0.01)
        f, alpha, mu = info["friction"][0], info["alpha"][0], info["mu"][0]
        forces[cone] = np.linalg.norm(f) / (mu * alpha)
        if cone == "cone":
            assert forces[cone] == pytest.approx(1.0, rel=1e-12)
            # opposite the slip (which stays along v: the friction acts along -v)
            slip = info["slip"][0]
            np.testing.assert_allclose(f / np.linalg.norm(f), -slip / np.linalg.norm(slip), rtol=0, atol=1e-12)
            assert info["max_cone_violation"] <= 1e-12 * alpha
            assert info["max_dissipation_violation"] <= 1e-12 * alpha
        else:
            assert forces[cone] <= np.sqrt(2) * (1 + 1e-12)
            assert info["max_cone_violation"] == pytest.approx(max(forces[cone] - 1, 0) * mu * alpha,
                                                               rel=1e-9, abs=1e-12 * alpha)
    on_axis = np.isclose(np.sin(2 * phi), 0.0, atol=1e-12)
    expected = 1.0 if on_axis else np.sqrt(2)
    assert forces["pyramid"] == pytest.approx(expected, rel=1e-12)


# --------------------------------------------------------------------------- restitution

@pytest.mark.parametrize("gap", [0.0, 0.01])
def test_sphere_bounces_off_the_plane_with_half_its_approach_speed(gap):
    # e = max(0.5, 0) = 0.5.  The approach speed after gravity is |u| = 2 + g dt (> 0.5 m/s
    # threshold).  Stage c stops it at the gap (v_z = -gap / dt), stage d lifts it to e |u|:
    # it leaves with half the approach speed.  The cache keeps the force of c,
    # m (|u| - gap / dt) / dt; the reported force is the total m (1 + e) |u| / dt.  The position
    # pass moves it on from the impact at t_c = gap / |u| at e |u|, so the new gap is
    # e (|u| dt - gap).  Rounding: ~eps of the O(1) numbers.
    dt, e, v0 = 0.01, 0.5, 2.0
    snap = sphere_on_plane(gap=gap, velocity=(0, 0, -v0))
    snap["bodies"][1]["restitution"] = e
    m = snap["bodies"][1]["mass"]
    u = v0 + G * dt
    new, info = o.step(snap, dt)
    assert info["restitution"][0] == e and info["restitution_iterations"] >= 1
    assert new["velocity"][1, 2] == pytest.approx(e * u, rel=1e-14)
    np.testing.assert_allclose(new["velocity"][1, :2], 0.0, rtol=0, atol=1e-15)
    assert info["alpha"][0] == pytest.approx(m * (1 + e) * u / dt, rel=1e-13)
    assert new["cache"]["alpha"][0] == pytest.approx(m * (u - gap / dt) / dt, rel=1e-13)
    assert new["position"][1, 2] - 0.5 == pytest.approx(e * (u * dt - gap), rel=1e-12)
    assert info["max_penetration_velocity"] < 1e-14 and info["max_complementarity"] < 1e-9


def test_slow_approach_gets_no_restitution():
    # |u| = 0.3 + g dt < 0.5 m/s threshold: stage d is skipped and the sphere comes to rest
    snap = sphere_on_plane(velocity=(0, 0, -0.3), e=0.9)
    new, info = o.step(snap, 0.01)
    assert info["restitution_iterations"] == 0
    assert abs(new["velocity"][1, 2]) < 1e-15
    # a threshold below |u| brings the bounce back: v = e |u|
    snap["settings"]["restitution_threshold"] = 0.2
    new, info = o.step(snap, 0.01)
    assert new["velocity"][1, 2] == pytest.approx(0.9 * (0.3 + G * 0.01), rel=1e-13)


def test_equal_spheres_head_on_with_e1_exchange_velocities_and_keep_energy():
    # Equal masses, e = 1, mu = 0, touching (gap exactly 0: r = 0.5, centres 1 apart), no gravity.
    # Along the line of centres x they swap velocities (3, -1) -> (-1, 3); the components across
    # it are untouched without friction; kinetic energy is kept.  Rounding ~ a few ulp of 3 m/s.
    bodies = [make_body({"type": "sphere", "radius": 0.5}, friction=0.0, restitution=1.0) for _ in range(2)]
    v = np.array([[3.0, 0.5, 0.0], [-1.0, 0.0, -0.25]])
    snap = make_snapshot(bodies, [[0, 0, 0], [1.0, 0, 0]], velocity=v, gravity=(0, 0, 0))
    new, info = o.step(snap, 0.01)
    assert len(info["alpha"]) == 1 and info["restitution_iterations"] >= 1
    np.testing.assert_allclose(new["velocity"], [[-1.0, 0.5, 0.0], [3.0, 0.0, -0.25]], rtol=0, atol=1e-14)
    np.testing.assert_array_equal(new["angular_velocity"], 0.0)
    m = bodies[0]["mass"]
    energy = lambda vel: 0.5 * m * np.sum(vel**2)
    assert energy(new["velocity"]) == pytest.approx(energy(v), rel=1e-14)
    # action and reaction: the forces on the two bodies cancel
    np.testing.assert_allclose(info["body_force"].sum(axis=0), 0.0, rtol=0, atol=1e-9)


# --------------------------------------------------------------------------- warm start

def resting_box(**settings):
    """A 1 x 0.5 x 0.25 m box (1000 kg/m^3, 125 kg) resting flat on the plane z = 0 (gaps exactly 0)."""
    return make_snapshot([plane(), make_body({"type": "box", "half_extents": [0.5, 0.25, 0.125]})],
                         [[0, 0, 0], [0, 0, 0.125]], **settings)


def test_warm_start_reaches_the_cold_forces_in_one_sweep():
    # Cold, many sweeps: the four corners carry m g between them with no net torque, the box stays
    # at rest.  (Four coplanar corners leave one force pattern free, so PGS picks one solution.)
    # Warm-started from those forces (the cache of that step), one sweep reproduces them: each row
    # sees zero velocity error and changes by rounding only.  Cold with one sweep does not.
    dt = 1 / 240
    cold, info_cold = o.step(resting_box(warm_start=False, tolerance=1e-13, max_iterations=1000), dt)
    m = cold["bodies"][1]["mass"]
    assert info_cold["converged"] and info_cold["iterations"] > 5
    assert info_cold["alpha"].sum() == pytest.approx(m * G, rel=1e-10)
    np.testing.assert_allclose(info_cold["body_torque"][1], 0.0, rtol=0, atol=1e-10 * m * G)

    warm = resting_box(max_iterations=1)
    warm["cache"] = cold["cache"]
    new, info = o.step(warm, dt)
    assert info["iterations"] == 1 and info["converged"]
    np.testing.assert_allclose(info["alpha"], info_cold["alpha"], rtol=0, atol=1e-10 * m * G)
    np.testing.assert_allclose(new["velocity"][1], 0.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(new["angular_velocity"][1], 0.0, rtol=0, atol=1e-12)

    # the same step cold with one sweep: not converged, the box moves
    _, info = o.step(resting_box(max_iterations=1, warm_start=False), dt)
    assert not info["converged"]
    assert np.abs(info["alpha"] - info_cold["alpha"]).max() > 1e-3 * m * G

    # and a rollout at one sweep a step stays at rest on the forces it carries over
    out = o.rollout(new, dt, 24)
    assert np.all(out["iterations"] == 1) and np.all(out["converged"])
    np.testing.assert_allclose(out["position"][:, 1], [[0, 0, 0.125]] * 25, rtol=0, atol=1e-12)


def test_warm_start_matches_keys_and_projects_onto_the_friction_set():
    # sphere on the plane: key (0, 1, plane face 0, sphere shape 0); a cached friction beyond
    # mu alpha_n is clamped per row (pyramid) or scaled onto the disk (cone); a cache entry of
    # another key is ignored
    snap = sphere_on_plane()
    dt = 0.01
    contacts = o.detect_contacts(snap, dt)
    key = [contacts[k][0] for k in ("body_a", "body_b", "feature_a", "feature_b")]
    cache = {"body_a": np.array([0, key[0]]), "body_b": np.array([2, key[1]]),
             "feature_a": np.array([7, key[2]], dtype=np.uint64),
             "feature_b": np.array([7, key[3]], dtype=np.uint64),
             "alpha": np.array([99.0, 100.0]), "friction": np.array([[1.0, 2.0, 3.0], [-80.0, 30.0, 0.0]])}
    q_dot = np.zeros((2, 6))
    rows = o.prepare_rows(snap, contacts, q_dot, dt)
    # t1 = e_y, t2 = -e_x: f . t1 = 30, f . t2 = 80, bound 0.5 * 100 = 50
    alpha = o.warm_start(rows, contacts, o.read_cache({"cache": cache}), q_dot.copy(), dt, "pyramid")
    np.testing.assert_allclose(alpha, [100.0, 30.0, 50.0], rtol=1e-15)
    alpha = o.warm_start(rows, contacts, o.read_cache({"cache": cache}), q_dot.copy(), dt, "cone")
    np.testing.assert_allclose(alpha, np.array([100.0, 30.0 * 50 / np.hypot(30, 80), 80.0 * 50 / np.hypot(30, 80)]),
                               rtol=1e-15)
    # the forces are applied: the sphere gets dt (alpha_n n + f) / m
    m = snap["bodies"][1]["mass"]
    q = q_dot.copy()
    o.warm_start(rows, contacts, o.read_cache({"cache": cache}), q, dt, "pyramid")
    np.testing.assert_allclose(q[1, 3:], dt * np.array([-50.0, 30.0, 100.0]) / m, rtol=1e-14)
    np.testing.assert_array_equal(q[0], 0.0)
    # a missing or None cache is empty
    assert len(o.read_cache({})["alpha"]) == 0 and len(o.read_cache({"cache": None})["alpha"]) == 0


# --------------------------------------------------------------------------- torsional friction

def spinning_sphere(omega0, mu_spin_ball, mu_spin_ground=0.0, r=0.1, **settings):
    """A sphere of radius r (1000 kg/m^3) resting on the plane z = 0, spinning at omega0 about z."""
    ground = plane()
    ground["spinning_friction"] = mu_spin_ground
    ball = make_body({"type": "sphere", "radius": r})
    ball["spinning_friction"] = mu_spin_ball
    return make_snapshot([ground, ball], [[0, 0, 0], [0, 0, r]], angular_velocity=[[0, 0, 0], [0, 0, omega0]],
                         **settings)


def test_spin_materials_take_the_larger_value_and_only_lone_contacts_get_a_row():
    # mu_spin = max(mu_spin_A, mu_spin_B), 0 for a body without the key; the rows go to contacts
    # whose neighbours in the list belong to other body pairs
    bodies = [plane(), make_body({"type": "sphere", "radius": 0.5}), make_body({"type": "sphere", "radius": 0.5})]
    bodies[0]["spinning_friction"], bodies[1]["spinning_friction"] = 0.001, 0.004
    snap = make_snapshot(bodies, np.zeros((3, 3)))
    contacts = {"body_a": np.array([0, 0, 0, 1]), "body_b": np.array([1, 2, 2, 2])}
    np.testing.assert_array_equal(o.spinning_friction(snap, contacts), [0.004, 0.001, 0.001, 0.004])
    np.testing.assert_array_equal(o.alone_in_pair(contacts), [True, False, False, True])
    np.testing.assert_array_equal(o.alone_in_pair({"body_a": np.array([3]), "body_b": np.array([4])}), [True])
    assert len(o.alone_in_pair({"body_a": np.zeros(0, int), "body_b": np.zeros(0, int)})) == 0


def test_spin_row_is_the_angular_jacobian_about_the_normal():
    # J_A = (-n, 0), J_B = (n, 0), delta = dt (n I_A^-1 n + n I_B^-1 n); sphere: I = 2/5 m r^2
    snap = spinning_sphere(5.0, 0.002)
    dt = 0.01
    contacts = o.detect_contacts(snap, dt)
    rows = o.prepare_rows(snap, contacts, np.zeros((2, 6)), dt)
    assert rows["spin"].tolist() == [True] and rows["mu_spin"].tolist() == [0.002]
    np.testing.assert_array_equal(rows["spin_J_A"][0], [0, 0, -1, 0, 0, 0])
    np.testing.assert_array_equal(rows["spin_J_B"][0], [0, 0, 1, 0, 0, 0])
    m = snap["bodies"][1]["mass"]
    assert rows["spin_delta"][0] == pytest.approx(dt / (0.4 * m * 0.1**2), rel=1e-14)


@pytest.mark.parametrize("friction_cone", ["pyramid", "cone"])
def test_spinning_sphere_loses_dt_mu_spin_m_g_over_I_per_step_until_it_stops(friction_cone):
    # each step the spin row takes the torque impulse dt mu_spin alpha_n with alpha_n = m g (the
    # normal row converges to 1e-12 m/s, so alpha_n = m g to about 1e-12 delta^-1 ~ 1e-9 relative),
    # against the spin; the step in which the remaining spin is less than that stops it exactly
    mu_spin, omega0, dt = 0.002, 0.3, 0.01
    snap = spinning_sphere(omega0, mu_spin, friction_cone=friction_cone, tolerance=1e-12, max_iterations=100)
    m = snap["bodies"][1]["mass"]
    step = dt * mu_spin * m * G / (0.4 * m * 0.1**2)   # rad/s per step
    omega = [omega0]
    for _ in range(int(omega0 / step) + 3):
        snap, info = o.step(snap, dt)
        omega.append(snap["angular_velocity"][1, 2])
    omega = np.array(omega)
    full = int(omega0 / step)                           # full steps before the spin is gone
    np.testing.assert_allclose(np.diff(omega[:full + 1]), -step, rtol=1e-8)
    np.testing.assert_allclose(omega[full + 1:], 0.0, rtol=0, atol=1e-15)
    assert info["spin_torque"][0] == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(snap["angular_velocity"][1, :2], 0.0, atol=1e-15)


def test_zero_spinning_friction_leaves_the_spin_untouched():
    snap = spinning_sphere(5.0, 0.0)
    for _ in range(20):
        snap, info = o.step(snap, 0.01)
    assert snap["angular_velocity"][1].tolist() == [0.0, 0.0, 5.0]
    assert info["spin_torque"].tolist() == [0.0] and snap["cache"]["spin"].tolist() == [0.0]


def test_warm_start_clamps_the_cached_spin_torque_to_its_bound():
    # cached torque beyond mu_spin alpha_n is clamped; within, taken as is; applied to omega
    snap = spinning_sphere(5.0, 0.002)
    dt = 0.01
    contacts = o.detect_contacts(snap, dt)
    key = [contacts[k][0] for k in ("body_a", "body_b", "feature_a", "feature_b")]
    q_dot = np.zeros((2, 6))
    rows = o.prepare_rows(snap, contacts, q_dot, dt)
    m = snap["bodies"][1]["mass"]
    for cached, expected in ((-1.0, -0.002 * 100.0), (0.05, 0.05)):
        cache = {"body_a": np.array([key[0]]), "body_b": np.array([key[1]]),
                 "feature_a": np.array([key[2]], dtype=np.uint64), "feature_b": np.array([key[3]], dtype=np.uint64),
                 "alpha": np.array([100.0]), "friction": np.zeros((1, 3)), "spin": np.array([cached])}
        spin, q = np.zeros(1), q_dot.copy()
        o.warm_start(rows, contacts, o.read_cache({"cache": cache}), q, dt, "pyramid", spin)
        assert spin[0] == pytest.approx(expected, rel=1e-15)
        assert q[1, 2] == pytest.approx(dt * expected / (0.4 * m * 0.01), rel=1e-14)
    # a cache without spin torques (an older snapshot) reads as zeros
    del cache["spin"]
    assert o.read_cache({"cache": cache})["spin"].tolist() == [0.0]


# --------------------------------------------------------------------------- position pass

@pytest.mark.parametrize("slop", [0.0, 0.001])
def test_position_pass_removes_erp_of_the_overlap_per_step_and_keeps_velocity(slop):
    # A sphere at rest overlapping the plane by d: the velocity rows ignore the overlap, so it
    # keeps v = 0 (to the rounding of g dt, ~eps g dt); the position pass moves it up by
    # erp (overlap - slop) each step, so the overlap after k steps is slop + (d - slop) (1 - erp)^k.
    # (Positions ~0.5 m round to ~1e-16 m per step: 1e-10 relative of the mm overlap is ample.)
    dt, d, erp = 0.01, 0.004, 0.2
    out = o.rollout(sphere_on_plane(gap=-d, erp=erp, slop=slop), dt, 10)
    overlap = 0.5 - out["position"][:, 1, 2]
    np.testing.assert_allclose(overlap, slop + (d - slop) * (1 - erp) ** np.arange(11), rtol=1e-10)
    np.testing.assert_allclose(out["velocity"][:, 1], 0.0, rtol=0, atol=4 * EPS * G * dt)
    assert all(info["position_iterations"] >= 1 for info in out["infos"])


def test_overlap_within_the_slop_is_left_alone():
    # 0.5 mm < slop = 1 mm (the default): no pass, the resting sphere does not move at all
    new, info = o.step(sphere_on_plane(gap=-0.0005), 0.01)
    assert info["position_iterations"] == 0
    assert new["position"][1, 2] == 0.5 - 0.0005
    assert info["max_overlap"] == pytest.approx(0.0005, rel=1e-12)


def test_position_pass_is_capped_at_max_push_velocity():
    # overlap 0.2 m: erp (d - slop) / dt = 3.98 m/s > max_push_velocity = 1 m/s, so it moves 1 m/s * dt
    dt, d = 0.01, 0.2
    new, info = o.step(sphere_on_plane(gap=-d), dt)
    assert new["position"][1, 2] - (0.5 - d) == pytest.approx(1.0 * dt, rel=1e-12)
    new, info = o.step(sphere_on_plane(gap=-d, max_push_velocity=0.25), dt)
    assert new["position"][1, 2] - (0.5 - d) == pytest.approx(0.25 * dt, rel=1e-12)


def test_position_pass_never_changes_the_kept_velocity():
    # A sphere overlapping by 3 mm while sliding and spinning, and a box tipped into the plane on
    # one edge, each stepped with erp = 0.2 and with erp = 0 (no position pass): the kept
    # velocities are the same to the last bit (the pass only writes q_p); only the poses differ.
    sphere = sphere_on_plane(gap=-0.003, velocity=(1.5, -0.5, -0.2), slop=0.0)
    sphere["angular_velocity"][1] = (2.0, 1.0, -3.0)
    R = o.rodrigues(np.array([1.0, 0.3, 0.0]) / np.hypot(1.0, 0.3), 0.2)
    h = np.array([0.4, 0.3, 0.2])
    z = -(o.box_corners(h) @ R.T)[:, 2].min() - 0.004
    box = make_snapshot([plane(), make_body({"type": "box", "half_extents": h})], [[0, 0, 0], [0, 0, z]],
                        rotation=[np.eye(3), R], velocity=[[0, 0, 0], [0.3, 0.0, -0.5]],
                        angular_velocity=[[0, 0, 0], [1.0, -2.0, 0.5]])
    for snap in (sphere, box):
        pushed, info = o.step(snap, 0.01)
        plain, info_plain = o.step({**snap, "settings": {**snap["settings"], "erp": 0.0}}, 0.01)
        assert info["position_iterations"] >= 1 and info_plain["position_iterations"] == 0
        np.testing.assert_array_equal(pushed["velocity"], plain["velocity"])
        np.testing.assert_array_equal(pushed["angular_velocity"], plain["angular_velocity"])
        assert pushed["position"][1, 2] > plain["position"][1, 2]
    # the sphere's overlap is pushed out along n by erp * 3 mm on top of the same motion
    pushed, _ = o.step(sphere, 0.01)
    plain, _ = o.step({**sphere, "settings": {**sphere["settings"], "erp": 0.0}}, 0.01)
    np.testing.assert_allclose(pushed["position"][1] - plain["position"][1], [0, 0, 0.2 * 0.003],
                               rtol=0, atol=1e-15)


# --------------------------------------------------------------------------- gyroscopic options

def spinner(speed, gyroscopic):
    """A free body of principal inertias 1 : 2 : 3 kg m^2, spun at `speed` about its middle axis
    with a 1e-3 relative perturbation on the others; no gravity."""
    I = np.diag([1.0, 2.0, 3.0])
    body = {"shape": {"type": "sphere", "radius": 0.1}, "static": False, "mass": 1.0, "inv_mass": 1.0,
            "inertia": I, "inv_inertia": np.linalg.inv(I)}
    return make_snapshot([body], [[0, 0, 0]], angular_velocity=[[1e-3 * speed, speed, 1e-3 * speed]],
                         gravity=(0, 0, 0), gyroscopic=gyroscopic)


def energy_and_momentum(out):
    """Kinetic energy 1/2 w.I w and |I w| (w = R^T omega, body frame) after every step."""
    I = np.diag([1.0, 2.0, 3.0])
    w = np.einsum("kji,kj->ki", out["rotation"][:, 0], out["angular_velocity"][:, 0])
    return 0.5 * np.einsum("ki,ij,kj->k", w, I, w), np.linalg.norm(w @ I, axis=1)


def test_midpoint_rule_solves_its_equation():
    # Newton converged: F(w') = I (w' - w) + dt m x (I m) vanishes to rounding of |I w| ~ 40,
    # and the energy and |I w| of one step are kept (the midpoint rule keeps quadratic invariants)
    rng = np.random.default_rng(3)
    I = np.diag([1.0, 2.0, 3.0])
    for _ in range(20):
        w, dt = rng.normal(size=3) * 20, rng.uniform(1e-3, 0.05)
        w1 = o.free_rotation(I, w, dt, "midpoint")
        m = (w + w1) / 2
        np.testing.assert_allclose(I @ (w1 - w) + dt * np.cross(m, I @ m), 0.0, rtol=0, atol=1e-12)
        assert w1 @ I @ w1 == pytest.approx(w @ I @ w, rel=1e-14)
        assert np.linalg.norm(I @ w1) == pytest.approx(np.linalg.norm(I @ w), rel=1e-14)
    # Catto's one Newton step of backward Euler, by its formula
    w, dt = np.array([0.02, 20.0, 0.02]), 1 / 240
    expected = w - np.linalg.solve(I + dt * (o.skew(w) @ I - o.skew(I @ w)), dt * np.cross(w, I @ w))
    np.testing.assert_allclose(o.free_rotation(I, w, dt, "implicit"), expected, rtol=1e-15)


@pytest.mark.slow
def test_midpoint_keeps_energy_and_momentum_of_the_tennis_racket():
    # 20 rad/s about the unstable middle axis flips over and over in 10 s; the midpoint rule keeps
    # 1/2 w.I w and |I w| exactly but for rounding, ~eps per step: 2400 steps random-walk to ~1e-13,
    # so 1e-9 relative is a bound on any real drift, not on rounding.
    out = o.rollout(spinner(20.0, "midpoint"), 1 / 240, 2400)
    E, L = energy_and_momentum(out)
    np.testing.assert_allclose(E, E[0], rtol=1e-9)
    np.testing.assert_allclose(L, L[0], rtol=1e-9)
    # it did tumble: the middle-axis component reversed at some point
    assert np.min(np.einsum("kji,kj->ki", out["rotation"][:, 0], out["angular_velocity"][:, 0])[:, 1]) < -10


@pytest.mark.slow
def test_implicit_loses_energy_and_explicit_gains():
    # Catto's backward-Euler step dissipates every step (44% in these 10 s), the explicit term
    # adds dt^2/2 |I^-1 (w x I w)|_I^2 every step (+127%).  Per step allowance: rounding, 4 eps E.
    E_imp, _ = energy_and_momentum(o.rollout(spinner(20.0, "implicit"), 1 / 240, 2400))
    E_exp, _ = energy_and_momentum(o.rollout(spinner(20.0, "explicit"), 1 / 240, 2400))
    assert np.all(np.diff(E_imp) <= 4 * EPS * E_imp[0])
    assert np.all(np.diff(E_exp) >= -4 * EPS * E_exp[0])
    assert 0.3 < 1 - E_imp[-1] / E_imp[0] < 0.6
    assert E_exp[-1] / E_exp[0] - 1 > 1.0


def test_midpoint_at_50_rad_s_and_dt_1_60_stays_finite_and_never_gains():
    # omega dt = 0.83 rad per step.  The guard scales w' back whenever E' > E, so the energy can
    # only grow by the rounding of the next step's R^T omega (~eps per step): 600 steps < 1e-12.
    out = o.rollout(spinner(50.0, "midpoint"), 1 / 60, 600)
    assert np.all(np.isfinite(out["angular_velocity"])) and np.all(np.isfinite(out["rotation"]))
    E, _ = energy_and_momentum(out)
    assert np.all(E <= E[0] * (1 + 1e-12))
    assert E[-1] > 0.99 * E[0]


# --------------------------------------------------------------------------- steps and substeps

def test_substeps_solve_the_step_contacts_carried_along():
    # n substeps: contacts detected once for the whole step, then n solves of dt / n, the second
    # on the contacts carried along by the motion: the same numbers as the two substeps by hand
    snap = sphere_on_plane(gap=0.002, velocity=(0.5, 0.0, -1.0))
    two_settings = {**snap, "settings": {**snap["settings"], "substeps": 2}}
    two, info = o.step(two_settings, 0.02)
    contacts = o.detect_contacts(snap, 0.02)
    half, info_half = o.step_once(two_settings, 0.01, contacts)
    by_hand, info_hand = o.step_once(half, 0.01, o.carry_contacts(contacts, snap, half))
    for key in ("position", "rotation", "velocity", "angular_velocity"):
        np.testing.assert_array_equal(two[key], by_hand[key])
    np.testing.assert_array_equal(info["alpha"], info_hand["alpha"])
    # the step's impulse is the sum of its substeps' h alpha (the last substep's alpha is reported)
    np.testing.assert_array_equal(info["impulse"], 0.01 * info_half["alpha"] + 0.01 * info_hand["alpha"])
    assert info["impulse"][0] > 0.01 * info["alpha"][0]
    # the same contacts given explicitly give the same step
    given, _ = o.step(two_settings, 0.02, contacts=contacts)
    np.testing.assert_array_equal(given["position"], two["position"])


def test_carried_contacts_follow_their_bodies():
    # a sphere rolled by 0.2 rad about y while moving 0.1 m along x and 1 mm down: to first order
    # its bottom point moves along x only, so the gap closes by exactly the 1 mm (a rotated material
    # point would have lifted r (1 - cos 0.2) = 5 mm, a false gap); the anchor on the sphere moves
    # with its centre and stays half the gap over its witness (the gap closed by 1 mm: it rises
    # 0.5 mm against its centre, so that its core, gap / 2 + r under it, is the centre), the
    # plane's (a flat side, its lever arm) stays
    snap = sphere_on_plane(gap=0.002)
    contacts = o.detect_contacts(snap, 0.01)
    roll = np.array([np.cos(0.1), 0, np.sin(0.1), 0])  # 0.2 rad about y
    moved = {**snap, "position": snap["position"] + np.array([[0, 0, 0], [0.1, 0, -0.001]]),
             "rotation": np.stack([np.eye(3), o.quat_to_matrix(roll)])}
    carried = o.carry_contacts(contacts, snap, moved)
    assert carried["gap"][0] == pytest.approx(contacts["gap"][0] - 0.001, abs=1e-15)
    np.testing.assert_allclose(carried["anchor_a"][0], contacts["point"][0], atol=1e-15)
    np.testing.assert_allclose(carried["anchor_b"][0], contacts["point"][0] + [0.1, 0, -0.0005], atol=1e-15)
    core = carried["anchor_b"][0] + (0.5 * carried["gap"][0] + 0.5) * carried["normal"][0]  # r = 0.5
    np.testing.assert_allclose(core, moved["position"][1], atol=1e-15)
    np.testing.assert_array_equal(carried["normal"], contacts["normal"])
    # a box corner turning towards the plane closes its gap by the turn times its lever arm
    box = make_snapshot([plane(), make_body({"type": "box", "half_extents": np.array([0.5, 0.5, 0.5])})],
                        [[0, 0, 0], [0, 0, 0.502]])
    corners = o.detect_contacts(box, 0.01)
    tilt = {**box, "rotation": np.stack([np.eye(3), o.quat_to_matrix(np.array([np.cos(0.005), np.sin(0.005), 0, 0]))])}
    tilted = o.carry_contacts(corners, box, tilt)
    # about x by 0.01 rad: a corner at y = +0.5 goes down by 0.5 sin(0.01), one at y = -0.5 up
    y = corners["point"][:, 1]
    np.testing.assert_allclose(tilted["gap"] - corners["gap"], y * np.sin(0.01), rtol=0, atol=1e-15)


def test_a_capsule_s_end_cap_carried_through_a_large_turn_keeps_the_gap_of_its_core():
    # a capsule standing on its end cap (radius 0.1, segment half 0.3), turned by 0.8 rad about x
    # through its centre: the cap's witness stays under the segment's lower end (its core), which
    # the turn lifts to height z_c = 0.4 - 0.3 cos 0.8, so the carried gap is exactly z_c - 0.1
    # (the narrow phase's at the new pose). Carried to first order, the witness point 0.4 below the
    # centre moves by dtheta x r, along y: the gap stayed 0 while the cap rose 91 mm (and a turn
    # that lowers a tilted top's core went unseen the same way)
    capsule = make_snapshot([plane(), make_body({"type": "capsule", "radius": 0.1, "half_length": 0.3})],
                            [[0, 0, 0], [0, 0, 0.4]])
    contacts = o.detect_contacts(capsule, 0.01)
    assert len(contacts["gap"]) == 1 and contacts["gap"][0] == pytest.approx(0.0, abs=1e-15)
    turn = {**capsule, "rotation": np.stack([np.eye(3), o.quat_to_matrix(np.array([np.cos(0.4), np.sin(0.4), 0, 0]))])}
    carried = o.carry_contacts(contacts, capsule, turn)
    assert carried["gap"][0] == pytest.approx(0.4 - 0.3 * np.cos(0.8) - 0.1, abs=1e-15)


def test_contacts_without_feature_ids():
    # hand-made contacts without ids solve, but leave no cache (they cannot be recognised next
    # step); with a cache to match, the warm start needs the ids and says so
    snap = sphere_on_plane()
    contacts = {k: v for k, v in o.detect_contacts(snap, 0.01).items() if not k.startswith("feature")}
    new, info = o.step(snap, 0.01, contacts=contacts)
    assert len(info["alpha"]) == 1 and len(new["cache"]["alpha"]) == 0
    warm, _ = o.step(snap, 0.01)
    with pytest.raises(ValueError, match="feature"):
        o.step(warm, 0.01, contacts=contacts)
    # warm start off: the cache is not read
    warm["settings"]["warm_start"] = False
    o.step(warm, 0.01, contacts=contacts)


def test_unconverged_fast_approach_is_flagged():
    # a box dropped flat at 5 m/s with one sweep: the four corners are not all stopped
    snap = resting_box(max_iterations=1, warm_start=False)
    snap["velocity"][1] = [0.0, 0.0, -5.0]
    _, info = o.step(snap, 1 / 240)
    assert not info["converged"] and info["max_penetration_velocity"] > 0.01 and info["flagged"] == 1
    _, info = o.step(resting_box(), 1 / 240)
    assert info["flagged"] == 0


def test_info_and_cache_format():
    new, info = o.step(resting_box(), 1 / 240)
    K, N = 4, 2
    for key, shape in (("alpha", (K,)), ("impulse", (K,)), ("friction", (K, 3)), ("force", (K, 3)),
                       ("normal_velocity", (K,)), ("slip", (K, 3)), ("mu", (K,)), ("restitution", (K,)),
                       ("spin_torque", (K,)), ("mu_spin", (K,)), ("body_force", (N, 3)), ("body_torque", (N, 3))):
        assert np.shape(info[key]) == shape, key
    for key in ("iterations", "restitution_iterations", "position_iterations", "converged", "residual",
                "max_alpha_negative", "max_penetration_velocity", "max_complementarity",
                "max_cone_violation", "max_dissipation_violation", "max_overlap"):
        assert np.isscalar(info[key]), key
    np.testing.assert_allclose(info["force"], info["alpha"][:, None] * info["contacts"]["normal"]
                               + info["friction"], rtol=0, atol=0)
    cache = new["cache"]
    assert cache["feature_a"].dtype == np.uint64 and cache["body_a"].dtype == np.int64
    keys = list(zip(cache["body_a"], cache["body_b"], cache["feature_a"], cache["feature_b"]))
    assert keys == sorted(keys) and len(set(keys)) == K
    assert cache["spin"].shape == (K,) and not cache["spin"].any()  # a 4-point manifold: no spin rows


# --------------------------------------------------------------------------- exact LCP

def random_frictionless_problem(rng):
    """A few bodies (one static, 2-3 dynamic with random mass, inertia and pose) and 2-6 contacts
    with random pairs, points, normals, gaps in [-1, 1] cm and velocities; friction and restitution
    0, warm start off.  Drawn again until the Delassus matrix has condition number < 1e3, so that
    PGS contracts at a known rate and its stopping rule bounds its error."""
    dt = 0.01
    while True:
        n_dynamic = int(rng.integers(2, 4))
        bodies = [plane(friction=0.0)]
        for _ in range(n_dynamic):
            m = rng.uniform(0.5, 5.0)
            Q = o.quat_to_matrix(rng.normal(size=4))
            I = Q @ np.diag(rng.uniform(0.05, 1.0, 3) * m) @ Q.T
            bodies.append({"shape": {"type": "sphere", "radius": 0.5}, "static": False, "mass": m,
                           "inv_mass": 1 / m, "inertia": I, "inv_inertia": np.linalg.inv(I),
                           "friction": 0.0, "restitution": 0.0})
        N = len(bodies)
        p = rng.normal(size=(N, 3))
        snap = make_snapshot(bodies, p, rotation=[o.quat_to_matrix(rng.normal(size=4)) for _ in range(N)],
                             velocity=rng.normal(size=(N, 3)), angular_velocity=rng.normal(size=(N, 3)),
                             warm_start=False, tolerance=1e-13, max_iterations=20000)
        snap["velocity"][0] = snap["angular_velocity"][0] = 0.0
        K = int(rng.integers(2, 7))
        pairs = np.array([np.sort(rng.choice(N, 2, replace=False)) for _ in range(K)])
        n = rng.normal(size=(K, 3))
        contacts = {"body_a": pairs[:, 0], "body_b": pairs[:, 1],
                    "point": p[pairs].mean(axis=1) + 0.3 * rng.normal(size=(K, 3)),
                    "normal": n / np.linalg.norm(n, axis=1)[:, None], "gap": rng.uniform(-0.01, 0.01, K),
                    "feature_a": np.arange(K, dtype=np.uint64), "feature_b": np.arange(K, dtype=np.uint64)}
        v_star, omega_star = o.unconstrained_velocity(snap, dt)
        A, b = o.contact_lcp(snap, contacts, v_star, omega_star, dt, b_bias="speculative")
        eig = np.linalg.eigvalsh(A)
        if eig.min() > 1e-3 * eig.max():
            return snap, contacts, dt, v_star, omega_star, A, b


def test_frictionless_solver_reaches_the_exact_lcp_solution():
    # With mu = 0 the friction rows stay at 0 and with e = 0 there is no restitution, so the
    # normal rows are Gauss-Seidel on  w = A alpha + b >= 0, alpha >= 0, alpha . w = 0  with
    # b = G q_dot* + max(gap, 0) / dt.  For a definite A (cond < 1e3) PGS contracts linearly; it
    # stops when no row moves by more than 1e-13 m/s, which leaves the velocities within
    # ~cond * 1e-13 ~ 1e-10 of the fixed point.  The enumeration solves the same LCP exactly (its
    # own error ~cond eps).  1e-8 of the problem's velocity scale max |b| bounds both.
    active = 0
    for seed in range(100):
        rng = np.random.default_rng(seed)
        snap, contacts, dt, v_star, omega_star, A, b = random_frictionless_problem(rng)
        result = o.solve_contacts(snap, contacts, v_star, omega_star, dt)
        alpha, w = o.lcp_solve(A, b)
        assert result["converged"], seed
        scale = np.abs(b).max()
        # the velocities: w of the rows, and every body's q_dot
        G_rows = o.contact_jacobian(snap, contacts)
        q_dot = np.hstack([result["angular_velocity"], result["velocity"]]).reshape(-1)
        w_pgs = G_rows @ q_dot + o.speculative_bias(contacts, dt)
        np.testing.assert_allclose(w_pgs, w, rtol=0, atol=1e-8 * scale, err_msg=f"seed {seed}")
        v, omega = o.velocities_from_alpha(snap, contacts, v_star, omega_star, alpha, dt)
        np.testing.assert_allclose(result["velocity"], v, rtol=0, atol=1e-8 * scale, err_msg=f"seed {seed}")
        np.testing.assert_allclose(result["angular_velocity"], omega, rtol=0, atol=1e-8 * scale,
                                   err_msg=f"seed {seed}")
        # and the forces, unique for a definite A (~cond times the velocity error, over delta)
        np.testing.assert_allclose(result["alpha"], alpha, rtol=0, atol=1e-8 * scale / np.diag(A).min(),
                                   err_msg=f"seed {seed}")
        np.testing.assert_array_equal(result["friction"], 0.0)
        assert result["restitution_iterations"] == 0
        active += np.sum(alpha > 0) >= 2
    # most problems couple several pushing contacts, not one at a time
    assert active >= 30
