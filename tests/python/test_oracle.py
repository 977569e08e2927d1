"""Tests of the NumPy oracle alone (signorini.oracle) against closed forms.

The oracle is the reference the C++ core is checked against, so it is checked here against
mathematics only: matrix exponentials, exact mass properties, single contacts solved by hand,
exact LCP solutions and the conservation law of the explicit gyroscopic term.

Tolerances are derived in comments.  eps = 2.2e-16 is the double-precision unit roundoff.
"""

import numpy as np
import pytest
import scipy.linalg

from signorini import oracle as o

EPS = np.finfo(float).eps
G = 9.81


# --------------------------------------------------------------------------- scene helpers

def make_body(shape, density=1000.0, static=False):
    """A body dict as the facade produces it."""
    if static:
        return {"shape": shape, "static": True, "mass": np.inf, "inv_mass": 0.0,
                "inertia": np.zeros((3, 3)), "inv_inertia": np.zeros((3, 3))}
    m, _, I = o.mass_properties(shape, density)
    return {"shape": shape, "static": False, "mass": m, "inv_mass": 1.0 / m,
            "inertia": I, "inv_inertia": np.linalg.inv(I)}


def make_snapshot(bodies, position, rotation=None, velocity=None, angular_velocity=None,
                  gravity=(0.0, 0.0, -G), **settings):
    N = len(bodies)
    # substeps 1: a step of these tests is the single step of their closed forms, whatever dt
    s = {"contact_margin": 0.005, "erp": 0.2, "tolerance": 1e-10, "max_iterations": 100, "substeps": 1}
    s.update(settings)
    return {
        "gravity": np.array(gravity, dtype=float),
        "settings": s,
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


def ground(normal=(0.0, 0.0, 1.0), offset=0.0):
    return make_body({"type": "plane", "normal": np.array(normal, float), "offset": offset},
                     static=True)


def random_rotation(rng):
    q = rng.normal(size=4)
    return o.quat_to_matrix(q)


def box_mesh(half_extents, center=(0.0, 0.0, 0.0)):
    """12-triangle outward box: vertices in the conventions' corner order."""
    V = o.box_corners(half_extents) + np.asarray(center, float)
    F = np.array([[0, 2, 3], [0, 3, 1],    # -z
                  [4, 5, 7], [4, 7, 6],    # +z
                  [0, 1, 5], [0, 5, 4],    # -y
                  [2, 6, 7], [2, 7, 3],    # +y
                  [0, 4, 6], [0, 6, 2],    # -x
                  [1, 3, 7], [1, 7, 5]])   # +x
    return V, F


def icosphere(radius, levels):
    """Unit icosahedron refined `levels` times by edge midpoints pushed onto the sphere.
    Every step is symmetric, so the mesh keeps the icosahedron's full symmetry group."""
    phi = (1.0 + 5.0**0.5) / 2.0
    V = [(-1, phi, 0), (1, phi, 0), (-1, -phi, 0), (1, -phi, 0), (0, -1, phi), (0, 1, phi),
         (0, -1, -phi), (0, 1, -phi), (phi, 0, -1), (phi, 0, 1), (-phi, 0, -1), (-phi, 0, 1)]
    V = [np.array(v, float) / np.linalg.norm(v) for v in V]
    F = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        cache, new_F = {}, []

        def mid(i, j):
            key = (min(i, j), max(i, j))
            if key not in cache:
                m = V[i] + V[j]
                V.append(m / np.linalg.norm(m))
                cache[key] = len(V) - 1
            return cache[key]

        for a, b, c in F:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new_F += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        F = new_F
    V = radius * np.array(V)
    F = np.array(F)
    # orient every face outward (the solid is convex and contains the origin)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    flip = np.einsum("ki,ki->k", n, V[F[:, 0]]) < 0
    F[flip] = F[flip][:, ::-1]
    return V, F


# --------------------------------------------------------------------------- rotations

def test_skew_is_cross_product():
    rng = np.random.default_rng(0)
    x, y = rng.normal(size=3), rng.normal(size=3)
    # one product and one sum per entry: a few ulp
    np.testing.assert_allclose(o.skew(x) @ y, np.cross(x, y), rtol=0, atol=8 * EPS * 4)
    np.testing.assert_array_equal(o.skew(x), -o.skew(x).T)


@pytest.mark.parametrize("theta", [0.0, 1e-9, 3e-5, 9.9e-5, 1.01e-4, 1e-2, 0.5, 2.0, 3.1])
def test_rodrigues_matches_expm(theta):
    # Rodrigues is the closed form of exp([omega dt]x).  Entries are O(1); sin, cos and the
    # products each round to ~1 ulp, and the series branch (theta < 1e-4) truncates at
    # theta^4/120 < 1e-18, so 1e-14 leaves ample room and would catch any wrong coefficient.
    rng = np.random.default_rng(1)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    dt = 0.01
    omega = axis * theta / dt
    R = o.rodrigues(omega, dt)
    np.testing.assert_allclose(R, scipy.linalg.expm(o.skew(omega * dt)), rtol=0, atol=1e-14)
    # a rotation: orthonormal with determinant +1, to rounding
    np.testing.assert_allclose(R.T @ R, np.eye(3), rtol=0, atol=1e-14)
    assert abs(np.linalg.det(R) - 1.0) < 1e-14
    # the axis is fixed
    np.testing.assert_allclose(R @ axis, axis, rtol=0, atol=1e-14)


def test_quaternion_round_trip():
    rng = np.random.default_rng(2)
    for _ in range(200):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        R = o.quat_to_matrix(q)
        np.testing.assert_allclose(R.T @ R, np.eye(3), rtol=0, atol=1e-14)
        assert abs(np.linalg.det(R) - 1.0) < 1e-14
        q_back = o.matrix_to_quat(R)
        assert q_back[0] >= 0
        # q and -q are the same rotation; Shepperd's method divides by >= 1/2, so ~ulp errors
        np.testing.assert_allclose(q_back, q * np.sign(q[0]), rtol=0, atol=1e-14)
        np.testing.assert_allclose(o.quat_to_matrix(q_back), R, rtol=0, atol=1e-14)
    # the near-180-degree rotations use the other branches of Shepperd's method
    for axis in np.eye(3):
        R = o.rodrigues(axis * np.pi, 1.0)
        np.testing.assert_allclose(o.quat_to_matrix(o.matrix_to_quat(R)), R, rtol=0, atol=1e-14)


def test_quaternion_conventions():
    # (w, x, y, z): (cos(t/2), sin(t/2) axis) is the rotation by t about axis
    t = 0.7
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    q = np.concatenate([[np.cos(t / 2)], np.sin(t / 2) * axis])
    np.testing.assert_allclose(o.quat_to_matrix(q), o.rodrigues(axis, t), rtol=0, atol=1e-14)
    # a non-unit quaternion is normalised; a zero one rejected
    np.testing.assert_allclose(o.quat_to_matrix(3.0 * q), o.quat_to_matrix(q), rtol=0, atol=1e-15)
    with pytest.raises(ValueError):
        o.quat_to_matrix(np.zeros(4))


# --------------------------------------------------------------------------- jacobian

def test_jacobian_matches_finite_differences():
    # x(t) = R(t) X + p(t), R(t) = exp([omega]x t) R0, p(t) = p0 + v t: dx/dt(0) = J(y) q_dot.
    # Central differences with h = 1e-5: truncation h^2/6 |x'''| ~ 1e-10 |omega|^3 |r|, rounding
    # eps |x| / h ~ 1e-11; with |omega|, |r|, |x| ~ 1-3 a 1e-8 bound is safe and still tight.
    rng = np.random.default_rng(3)
    R0 = random_rotation(rng)
    p0, v, omega, X = rng.normal(size=(4, 3))

    def x(t):
        return o.rodrigues(omega, t) @ R0 @ X + p0 + v * t

    h = 1e-5
    x_dot = (x(h) - x(-h)) / (2 * h)
    y = x(0.0)
    q_dot = np.concatenate([omega, v])
    J = o.jacobian(p0, y)
    assert J.shape == (3, 6)
    np.testing.assert_allclose(J @ q_dot, x_dot, rtol=0, atol=1e-8)
    # J^T f = (r x f, f): torque and force of a force f at y
    f = rng.normal(size=3)
    np.testing.assert_allclose(J.T @ f, np.concatenate([np.cross(y - p0, f), f]),
                               rtol=0, atol=1e-14)


def test_contact_rows_are_jacobian_transposes():
    # g_A = -J_A(y)^T n, g_B = J_B(y)^T n, checked against the (3, 6) jacobian directly
    rng = np.random.default_rng(4)
    snap = make_snapshot([make_body({"type": "sphere", "radius": 1.0})] * 3,
                         rng.normal(size=(3, 3)))
    n = rng.normal(size=(2, 3))
    contacts = {"body_a": np.array([0, 1]), "body_b": np.array([2, 0]),
                "point": rng.normal(size=(2, 3)), "normal": n / np.linalg.norm(n, axis=1)[:, None],
                "gap": np.zeros(2)}
    g_A, g_B = o.contact_rows(snap, contacts)
    for i in range(2):
        y, ni = contacts["point"][i], contacts["normal"][i]
        np.testing.assert_allclose(g_A[i], -o.jacobian(snap["position"][contacts["body_a"][i]], y).T @ ni,
                                   rtol=0, atol=1e-14)
        np.testing.assert_allclose(g_B[i], o.jacobian(snap["position"][contacts["body_b"][i]], y).T @ ni,
                                   rtol=0, atol=1e-14)


# --------------------------------------------------------------------------- mass properties

def test_box_mesh_matches_box_closed_form():
    # the 12-triangle mesh is the box exactly, so only rounding separates them: the integrals
    # sum 12 terms of size ~ rho V h^2, hence ~1e-15 relative; 1e-13 relative is generous.
    h = np.array([0.5, 0.3, 0.2])
    V, F = box_mesh(h)
    m, com, I = o.mass_properties_mesh(V, F, 700.0)
    m_ref, com_ref, I_ref = o.mass_properties_box(h, 700.0)
    assert m == pytest.approx(700.0 * 8 * 0.5 * 0.3 * 0.2, rel=1e-14)
    assert m == pytest.approx(m_ref, rel=1e-14)
    np.testing.assert_allclose(com, com_ref, rtol=0, atol=1e-15)
    np.testing.assert_allclose(I, I_ref, rtol=0, atol=1e-13 * np.abs(I_ref).max())


def test_sphere_closed_form():
    m, com, I = o.mass_properties_sphere(0.3, 2.0)
    assert m == pytest.approx(2.0 * 4 / 3 * np.pi * 0.027, rel=1e-15)
    np.testing.assert_allclose(I, 0.4 * m * 0.09 * np.eye(3), rtol=1e-15)
    np.testing.assert_array_equal(com, 0.0)


@pytest.mark.parametrize("levels", [2, 3, 4])
def test_icosphere_mesh_is_bounded_by_inscribed_and_circumscribed_balls(levels):
    # The icosphere is convex with vertices on the sphere of radius r: it lies inside that
    # ball and contains the ball of radius r_in = min distance from the centre to a face plane.
    # Volume and each I_ii = rho int (x_j^2 + x_k^2) have non-negative integrands, so they are
    # bracketed by the ball closed forms at r_in and r (a rigorous discretisation bound).
    # The mesh has the icosahedral symmetry group, which acts irreducibly on R^3, so its
    # inertia is exactly a multiple of I3 and its COM is the centre (up to rounding).
    r, rho = 0.7, 1100.0
    V, F = icosphere(r, levels)
    m, com, I = o.mass_properties_mesh(V, F, rho)

    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    r_in = np.min(np.einsum("ki,ki->k", n, V[F[:, 0]]) / np.linalg.norm(n, axis=1))
    m_in, _, I_in = o.mass_properties_sphere(r_in, rho)
    m_out, _, I_out = o.mass_properties_sphere(r, rho)
    assert m_in < m < m_out
    assert np.all((I_in.diagonal() < I.diagonal()) & (I.diagonal() < I_out.diagonal()))
    np.testing.assert_allclose(com, 0.0, rtol=0, atol=1e-14 * r)
    np.testing.assert_allclose(I, I.trace() / 3 * np.eye(3), rtol=0, atol=1e-12 * I.trace())


def test_icosphere_converges_at_second_order():
    # each refinement halves the edge length h; the volume error of an inscribed polyhedron is
    # O(h^2) (the sagitta), so the error ratio between levels tends to 4.
    r = 1.0
    errors = []
    for levels in (3, 4, 5):
        V, F = icosphere(r, levels)
        errors.append(o.mass_properties_sphere(r, 1.0)[0] - o.mass_properties_mesh(V, F, 1.0)[0])
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 3.8) & (ratios < 4.2)), ratios


def unit_tetrahedron():
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return V, F


def test_tetrahedron_closed_form():
    # corner tetrahedron: V = 1/6, COM = (1/4, 1/4, 1/4), int x^2 = 1/60, int x y = 1/120, so about
    # the COM I_xx = rho (2/60 - (1/6)(2/16)) = rho/80 and I_xy = -rho (1/120 - (1/6)/16) = rho/480.
    rho = 3.0
    V, F = unit_tetrahedron()
    m, com, I = o.mass_properties_mesh(V, F, rho)
    I_ref = rho * (np.full((3, 3), 1 / 480) + np.eye(3) * (1 / 80 - 1 / 480))
    assert m == pytest.approx(rho / 6, rel=1e-15)
    np.testing.assert_allclose(com, 0.25, rtol=1e-15)
    np.testing.assert_allclose(I, I_ref, rtol=1e-13)


def test_moved_mesh_rotates_inertia_and_moves_com():
    # rigid motion x -> Q x + t of the solid: com -> Q com + t, I_com -> Q I_com Q^T
    rng = np.random.default_rng(5)
    Q, t = random_rotation(rng), rng.normal(size=3) * 5
    V, F = unit_tetrahedron()
    m0, com0, I0 = o.mass_properties_mesh(V, F, 2.0)
    m1, com1, I1 = o.mass_properties_mesh(V @ Q.T + t, F, 2.0)
    # moving by |t| ~ 10 costs ~ eps |t|^2 / |x|^2 in the parallel-axis subtraction: 1e-12
    assert m1 == pytest.approx(m0, rel=1e-13)
    np.testing.assert_allclose(com1, Q @ com0 + t, rtol=0, atol=1e-13)
    np.testing.assert_allclose(I1, Q @ I0 @ Q.T, rtol=0, atol=1e-12 * np.abs(I0).max() * 100)


def test_two_box_mesh_obeys_parallel_axis_theorem():
    # one mesh with two disjoint boxes: I_com = sum_i I_i + m_i (|r_i|^2 I3 - r_i r_i^T),
    # r_i = c_i - com, com = sum m_i c_i / sum m_i.
    h1, c1 = np.array([0.5, 0.2, 0.1]), np.array([1.0, 0.5, -0.3])
    h2, c2 = np.array([0.1, 0.3, 0.4]), np.array([-0.7, 0.2, 0.9])
    V1, F1 = box_mesh(h1, c1)
    V2, F2 = box_mesh(h2, c2)
    m, com, I = o.mass_properties_mesh(np.vstack([V1, V2]), np.vstack([F1, F2 + 8]), 500.0)
    (m1, _, I1), (m2, _, I2) = o.mass_properties_box(h1, 500.0), o.mass_properties_box(h2, 500.0)
    com_ref = (m1 * c1 + m2 * c2) / (m1 + m2)
    I_ref = np.zeros((3, 3))
    for mi, Ii, ci in ((m1, I1, c1), (m2, I2, c2)):
        r = ci - com_ref
        I_ref += Ii + mi * (r @ r * np.eye(3) - np.outer(r, r))
    assert m == pytest.approx(m1 + m2, rel=1e-14)
    np.testing.assert_allclose(com, com_ref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(I, I_ref, rtol=0, atol=1e-13 * np.abs(I_ref).max())


def test_mass_properties_dispatch_and_given_mass():
    V, F = box_mesh([0.5, 0.3, 0.2])
    shapes = [{"type": "sphere", "radius": 0.4}, {"type": "box", "half_extents": [0.5, 0.3, 0.2]},
              {"type": "mesh", "vertices": V, "faces": F}]
    for shape in shapes:
        m, _, I = o.mass_properties(shape, mass=2.5)  # density = mass / volume
        assert m == pytest.approx(2.5, rel=1e-14)
        m_d, _, I_d = o.mass_properties(shape, density=2.5 / o.shape_volume(shape))
        np.testing.assert_allclose(I, I_d, rtol=1e-14)
    with pytest.raises(ValueError):
        o.mass_properties({"type": "plane", "normal": [0, 0, 1], "offset": 0.0}, 1.0)
    with pytest.raises(ValueError):
        o.mass_properties(shapes[0])


def test_inward_mesh_is_rejected():
    V, F = box_mesh([1.0, 1.0, 1.0])
    with pytest.raises(ValueError):
        o.mass_properties_mesh(V, F[:, ::-1], 1.0)


# --------------------------------------------------------------------------- contacts

def test_box_face_on_plane_gives_four_bottom_corners_with_zero_gap():
    # half extents and the position are dyadic, so corners land exactly on z = 0 and the gaps
    # are exactly 0; the top corners are 2c = 0.5 m away, far beyond margin + reach.
    h = [0.5, 0.25, 0.25]
    snap = make_snapshot([ground(), make_body({"type": "box", "half_extents": h})],
                         [[0, 0, 0], [1.0, 2.0, 0.25]])
    c = o.detect_contacts(snap, 1 / 240)
    np.testing.assert_array_equal(c["body_a"], [0, 0, 0, 0])
    np.testing.assert_array_equal(c["body_b"], [1, 1, 1, 1])
    np.testing.assert_array_equal(c["gap"], 0.0)
    np.testing.assert_array_equal(c["normal"], np.tile([0.0, 0.0, 1.0], (4, 1)))
    # corners 0..3 (sz = -1) in corner order: x = 1 -+ 0.5, y = 2 -+ 0.25
    np.testing.assert_array_equal(c["point"], [[0.5, 1.75, 0], [1.5, 1.75, 0],
                                               [0.5, 2.25, 0], [1.5, 2.25, 0]])


def test_plane_contact_point_is_the_witness_midpoint():
    # plane against a point x of B: w_B = x, w_A = x - gap n, y = x - gap n / 2.
    # A sphere at gap 0.0625 (dyadic, so exact) above a tilted plane, and a raised box.
    n = np.array([0.0, 0.6, 0.8])
    r, gap = 0.5, 0.0625
    c = 2.0 * n + (r + gap) * n + np.array([1.0, 0.0, 0.0])
    snap = make_snapshot([make_body({"type": "sphere", "radius": r}), ground(n, 2.0)], [c, [0, 0, 0]],
                         velocity=[-n, [0, 0, 0]])
    con = o.detect_contacts(snap, 0.1)
    assert con["body_a"][0] == 1 and con["body_b"][0] == 0
    assert con["gap"][0] == pytest.approx(gap, abs=8 * EPS)
    np.testing.assert_allclose(con["point"][0], c - (r + gap / 2) * n, rtol=0, atol=8 * EPS)
    # box lifted by 0.0625 with every corner's gap known: bottom corners at gap 0.0625
    h = [0.5, 0.25, 0.25]
    snap = make_snapshot([ground(), make_body({"type": "box", "half_extents": h})],
                         [[0, 0, 0], [0, 0, 0.3125]], velocity=[[0, 0, 0], [0, 0, -10.0]])
    con = o.detect_contacts(snap, 0.01)
    np.testing.assert_array_equal(con["gap"], [0.0625] * 4)
    np.testing.assert_array_equal(con["point"][:, 2], [0.03125] * 4)


def test_plane_is_always_body_a_and_pairs_are_lexicographic():
    # bodies: sphere 0, sphere 1 touching it, plane 2 under both, mesh box 3 on the plane
    V, F = box_mesh([0.25, 0.25, 0.25])
    bodies = [make_body({"type": "sphere", "radius": 0.5}), make_body({"type": "sphere", "radius": 0.5}),
              ground(), make_body({"type": "mesh", "vertices": V, "faces": F})]
    snap = make_snapshot(bodies, [[0, 0, 0.5], [1.0, 0, 0.5], [0, 0, 0], [5.0, 0, 0.25]])
    c = o.detect_contacts(snap, 1 / 240)
    # (0, 1) sphere-sphere, (0, 2) plane-sphere, (1, 2) plane-sphere, (2, 3) plane-mesh (4 vertices)
    np.testing.assert_array_equal(c["body_a"], [0, 2, 2, 2, 2, 2, 2])
    np.testing.assert_array_equal(c["body_b"], [1, 0, 1, 3, 3, 3, 3])
    np.testing.assert_array_equal(c["gap"], 0.0)
    np.testing.assert_array_equal(c["point"][0], [0.5, 0, 0.5])
    np.testing.assert_array_equal(c["normal"][0], [1.0, 0, 0])


def test_sphere_sphere_geometry():
    # d = c_B - c_A = (3, 4, 0): |d| = 5, n = (0.6, 0.8, 0), gap = 5 - 2 - 2.5 = 0.5 (dyadic radii)
    snap = make_snapshot([make_body({"type": "sphere", "radius": 2.0}),
                          make_body({"type": "sphere", "radius": 2.5})],
                         [[0, 0, 0], [3.0, 4.0, 0]], velocity=[[0, 0, 0], [-60.0, -80.0, 0]],
                         gravity=(0, 0, 0))
    c = o.detect_contacts(snap, 0.01)  # reach of B: 0.01 * 100 = 1 m > gap
    assert c["gap"][0] == pytest.approx(0.5, abs=4 * EPS)
    np.testing.assert_allclose(c["normal"][0], [0.6, 0.8, 0], rtol=0, atol=4 * EPS)
    w_A, w_B = 2.0 * c["normal"][0], np.array([3.0, 4.0, 0]) - 2.5 * c["normal"][0]
    np.testing.assert_allclose(c["point"][0], (w_A + w_B) / 2, rtol=0, atol=8 * EPS)
    # without the approach velocity the 0.5 m gap is beyond the margin: no contact
    snap["velocity"][:] = 0.0
    assert len(o.detect_contacts(snap, 0.01)["gap"]) == 0


def test_speculative_reach_rule():
    # body pairs: s_b = dt (|v| + dt |g| + |omega| rho); against a plane only the approach counts,
    # dt (max(0, -n.v) + dt max(0, -n.g) + |omega| rho); a contact exists iff gap < margin + reach
    dt, r = 0.01, 0.5
    v, w = np.array([0, 3.0, -4.0]), np.array([0, 0, 2.0])
    snap = make_snapshot([ground(), make_body({"type": "sphere", "radius": r})],
                         [[0, 0, 0], [0, 0, r]], velocity=[[0, 0, 0], v],
                         angular_velocity=[[0, 0, 0], w])
    s = o.speculative_reach(snap, dt)
    expected = dt * (5.0 + dt * G + 2.0 * r)
    np.testing.assert_allclose(s, [0.0, expected], rtol=1e-15)
    toward_plane = dt * (4.0 + dt * G + 2.0 * r)
    assert o.plane_reach(snap, 1, np.array([0, 0, 1.0]), dt) == pytest.approx(toward_plane, rel=1e-15)
    # each point then needs its own approach: the lowest point y = p - r z moves at v + w x (-r z)
    # = v (w is along z), so u = 4 m/s, g_n = G, and the spin's turn |w|^2 r / 2 = 1 m/s^2
    # replaces the body-wide |w| r = 1 m/s, which is the smaller reach here
    point_reach = dt * (4.0 + dt * (G + 0.5 * 4.0 * r))
    assert point_reach < toward_plane
    threshold = 0.005 + point_reach
    for gap, present in ((threshold * (1 - 1e-9), True), (threshold * (1 + 1e-9), False)):
        snap["position"][1, 2] = r + gap
        assert (len(o.detect_contacts(snap, dt)["gap"]) == 1) == present


def test_a_spinning_body_keeps_only_the_speculative_points_it_moves_towards():
    # two unit spheres 0.3 m apart (gap 0.3 m, far beyond the 5 mm margin), no gravity. B spins
    # about the line of centres at 50 rad/s: its body-wide reach dt |w| rho = 0.5 m takes the pair,
    # but the surface at the contact point moves sideways (w x (y - p) is normal to n) and the
    # spin's turn dt^2 |w|^2 rho / 2 = 0.125 m falls short, so no point is kept. Moving B towards A
    # at 40 m/s makes it one: dt u = 0.4 m
    dt = 0.01
    snap = make_snapshot([make_body({"type": "sphere", "radius": 1.0}), make_body({"type": "sphere", "radius": 1.0})],
                         [[0, 0, 0], [2.3, 0, 0]], angular_velocity=[[0, 0, 0], [50.0, 0, 0]],
                         gravity=(0, 0, 0))
    assert o.speculative_reach(snap, dt)[1] == pytest.approx(0.5)
    assert len(o.detect_contacts(snap, dt)["gap"]) == 0
    snap["velocity"][1] = [-40.0, 0, 0]
    c = o.detect_contacts(snap, dt)
    assert len(c["gap"]) == 1 and c["gap"][0] == pytest.approx(0.3)


def test_unsupported_pair_raises_only_when_within_reach():
    # the oracle has no exact test for a box against a capsule (the core clips one; the oracle
    # checks the pairs the issue lists: planes, box-box, sphere pairs, sphere-capsule)
    bodies = [make_body({"type": "box", "half_extents": [0.5, 0.5, 0.5]}),
              make_body({"type": "capsule", "radius": 0.25, "half_length": 0.0})]
    near = make_snapshot(bodies, [[0, 0, 0], [1.0, 0, 0]], gravity=(0, 0, 0))
    with pytest.raises(NotImplementedError, match="box.*capsule"):
        o.detect_contacts(near, 0.01)
    # bounding spheres |(0.5, 0.5, 0.5)| + 0.25 = 1.12 m; 10 m apart they cannot touch
    far = make_snapshot(bodies, [[0, 0, 0], [10.0, 0, 0]], gravity=(0, 0, 0))
    assert len(o.detect_contacts(far, 0.01)["gap"]) == 0
    # static-static pairs are skipped whatever their shapes
    static = make_snapshot([make_body({"type": "box", "half_extents": [1, 1, 1]}, static=True),
                            make_body({"type": "box", "half_extents": [1, 1, 1]}, static=True)],
                           [[0, 0, 0], [0.5, 0, 0]])
    assert len(o.detect_contacts(static, 0.01)["gap"]) == 0


# --------------------------------------------------------------------------- single contacts

def sphere_on_plane(gap=0.0, vz=0.0, r=0.5, density=1000.0):
    return make_snapshot([ground(), make_body({"type": "sphere", "radius": r}, density)],
                         [[0, 0, 0], [0, 0, r + gap]], velocity=[[0, 0, 0], [0, 0, vz]])


def test_resting_sphere_gets_its_weight_in_one_sweep():
    # n = e_z through the centre, so only the linear part counts: delta = dt / m,
    # gamma = v*_z = -g dt and alpha = -gamma / delta = m g, up to a few roundings (4 ulp).
    dt = 1 / 240
    snap = sphere_on_plane()
    m = snap["bodies"][1]["mass"]
    new, info = o.step(snap, dt)
    assert info["alpha"].shape == (1,)
    assert info["alpha"][0] == pytest.approx(m * G, rel=4 * EPS)
    np.testing.assert_allclose(info["impulse"], dt * info["alpha"])
    # sweep 1 sets alpha, sweep 2 changes nothing and stops
    assert info["iterations"] == 2 and info["converged"]
    assert info["residual"] <= 1e-15
    # the sphere stays put: |v| is the rounding of g dt (~ eps * 0.04)
    np.testing.assert_allclose(new["velocity"][1], 0.0, rtol=0, atol=1e-17)
    np.testing.assert_allclose(new["position"][1], [0, 0, 0.5], rtol=0, atol=1e-19)
    # the plane never moves
    np.testing.assert_array_equal(new["position"][0], 0.0)
    np.testing.assert_array_equal(new["velocity"][0], 0.0)


def test_speculative_contact_stops_the_sphere_exactly_at_the_plane():
    # gap g0 > 0 and approach speed u with u dt > g0: the bias b = g0 / dt makes w = 0 mean
    # v_z' = -g0 / dt, so the sphere moves exactly onto the plane: new gap = g0 + dt v_z' = 0,
    # and the impulse is m (v_z' - v*_z) = m (u + g dt - g0 / dt).
    dt, g0, u = 0.01, 0.02, 5.0
    snap = sphere_on_plane(gap=g0, vz=-u)
    m = snap["bodies"][1]["mass"]
    new, info = o.step(snap, dt)
    assert len(info["alpha"]) == 1
    assert info["impulse"][0] == pytest.approx(m * (u + G * dt - g0 / dt), rel=1e-14)
    assert new["velocity"][1, 2] == pytest.approx(-g0 / dt, rel=1e-14)
    # positions ~0.5 m: the new gap is a difference of O(1) numbers, so ~ eps
    assert abs(new["position"][1, 2] - 0.5) < 4 * EPS


def test_speculative_contact_does_not_stop_a_slow_approach():
    # same gap, but the sphere would not close it within the step: alpha = 0, free fall
    dt, g0, u = 0.01, 0.004, 0.1
    snap = sphere_on_plane(gap=g0, vz=-u)
    new, info = o.step(snap, dt)
    assert len(info["alpha"]) == 1 and info["alpha"][0] == 0.0
    assert new["velocity"][1, 2] == -u - G * dt


def test_overlap_is_pushed_out_by_the_position_pass_not_the_velocity():
    # overlap d: the velocity rows use b = max(gap, 0) / dt = 0, so the sphere at rest keeps
    # v_z' = 0 (up to the rounding of g dt - dt alpha / m, ~ eps g dt); the position pass asks
    # for b_pos = erp (d - slop) / dt and moves it up by dt b_pos = erp (d - slop) (positions
    # ~0.5 m: ~eps).
    dt, d, slop = 0.01, 0.003, 0.001
    snap = sphere_on_plane(gap=-d)
    snap["settings"]["slop"] = slop
    new, info = o.step(snap, dt)
    assert abs(new["velocity"][1, 2]) < 4 * EPS * G * dt
    assert new["position"][1, 2] - (0.5 - d) == pytest.approx(0.2 * (d - slop), rel=1e-12)
    assert info["position_iterations"] >= 1 and info["max_overlap"] == pytest.approx(d, rel=1e-12)


def test_step_reports_non_convergence():
    # a box resting on 4 corners needs several sweeps from a cold start; with 1 allowed the step
    # must say so
    snap = make_snapshot([ground(), make_body({"type": "box", "half_extents": [0.5, 0.25, 0.125]})],
                         [[0, 0, 0], [0, 0, 0.125]], max_iterations=1)
    _, info = o.step(snap, 1 / 240)
    assert info["iterations"] == 1 and not info["converged"]


# --------------------------------------------------------------------------- PGS vs exact LCP

def pgs_and_lcp(snap, dt):
    contacts = o.detect_contacts(snap, dt)
    v_star, w_star = o.unconstrained_velocity(snap, dt)
    result = o.pgs(snap, contacts, v_star, w_star, dt)
    A, b = o.contact_lcp(snap, contacts, v_star, w_star, dt)
    alpha, w = o.lcp_solve(A, b)
    return contacts, v_star, w_star, result, A, b, alpha, w


def test_lcp_diagonal_is_pgs_delta():
    snap = make_snapshot([ground(), make_body({"type": "box", "half_extents": [0.5, 0.25, 0.125]})],
                         [[0, 0, 0], [0, 0, 0.125]])
    contacts, v_star, w_star, result, A, b, _, _ = pgs_and_lcp(snap, 1 / 240)
    np.testing.assert_allclose(np.diag(A), result["delta"], rtol=1e-14)
    np.testing.assert_allclose(A, A.T, rtol=0, atol=1e-16 * np.abs(A).max())


def test_pgs_converges_to_lcp_on_resting_box():
    # four coplanar corners: A (4 x 4) has rank 3, so alpha is not unique, but for a PSD LCP
    # the velocities are.  Both must give zero velocity, total force m g and no net torque.
    # PGS stops when delta_i |change| <= 1e-12 m/s; it converges linearly, so the velocities
    # are within a small multiple of that: 1e-10 m/s.
    dt = 1 / 240
    snap = make_snapshot([ground(), make_body({"type": "box", "half_extents": [0.5, 0.25, 0.125]})],
                         [[0, 0, 0], [0, 0, 0.125]], tolerance=1e-12, max_iterations=10000)
    contacts, v_star, w_star, result, A, b, alpha, w = pgs_and_lcp(snap, dt)
    assert len(contacts["gap"]) == 4 and result["converged"]
    m = snap["bodies"][1]["mass"]
    for a in (result["alpha"], alpha):
        v, omega = o.velocities_from_alpha(snap, contacts, v_star, w_star, a, dt)
        np.testing.assert_allclose(v, 0.0, rtol=0, atol=1e-10)
        np.testing.assert_allclose(omega, 0.0, rtol=0, atol=1e-10)
        assert a.sum() == pytest.approx(m * G, rel=1e-9)
    np.testing.assert_allclose(result["velocity"], 0.0, rtol=0, atol=1e-10)
    np.testing.assert_allclose(A @ result["alpha"] + b, w, rtol=0, atol=1e-10)
    assert result["residual"] <= 1e-10


@pytest.mark.parametrize("seed", range(8))
def test_pgs_converges_to_lcp_on_random_scene(seed):
    # A box tipped onto one bottom edge (2 or 3 corner contacts), and three spheres on the plane, each
    # touching the next, all driven into each other and into the plane with random velocities.
    # No body has two contacts with the same normal, so the Delassus matrix is definite, the
    # LCP solution alpha is unique and PGS must reach it.  PGS stops at
    # delta_i |change| <= 1e-13 m/s, so each force is left within ~1e-13 / delta_i ~ 1e-13 m / dt
    # (~1e-9 N here) times a contraction factor of order one, and the enumeration's own solve
    # errs by ~cond(A) eps <= 1e6 * 2e-16 relative (cond is asserted below): 1e-8 of the force
    # scale bounds both with room.
    rng = np.random.default_rng(seed)
    dt = 0.01
    axis = np.array([1.0, 0.0, 0.0]) + rng.normal(size=3) * 0.05
    R_box = o.rodrigues(axis / np.linalg.norm(axis), 0.05)
    h = np.array([0.4, 0.3, 0.2])
    z_box = -(o.box_corners(h) @ R_box.T)[:, 2].min() - rng.uniform(0.0, 0.002)
    r = rng.uniform(0.3, 0.5, size=3)
    x = [np.array([3.0, 0.0, r[0]])]
    for k, direction in ((1, [1.0, 0.0]), (2, [0.0, 1.0])):
        # sphere k on the plane, touching sphere k - 1 (horizontal distance from the radii)
        d = np.sqrt((r[k] + r[k - 1])**2 - (r[k] - r[k - 1])**2)
        x.append(x[k - 1] + np.array([d * direction[0], d * direction[1], r[k] - r[k - 1]]))
    x = np.array(x) + np.array([0, 0, -1e-3]) + rng.uniform(-1e-3, 1e-3, (3, 3))
    v_spheres = (x.mean(axis=0) - x) * 2.0 + rng.normal(size=(3, 3)) * 0.2 - [0, 0, 0.5]
    bodies = [ground(), make_body({"type": "box", "half_extents": h}, rng.uniform(500, 2000))]
    bodies += [make_body({"type": "sphere", "radius": ri}, rng.uniform(500, 2000)) for ri in r]
    snap = make_snapshot(bodies, np.vstack([[0, 0, 0], [0, 0, z_box], x]),
                         rotation=[np.eye(3), R_box, np.eye(3), np.eye(3), np.eye(3)],
                         velocity=np.vstack([[0, 0, 0], rng.normal(size=3) * 0.3 - [0, 0, 0.5],
                                             v_spheres]),
                         angular_velocity=np.vstack([[0, 0, 0], rng.normal(size=(4, 3))]),
                         tolerance=1e-13, max_iterations=100000)
    contacts, _, _, result, A, b, alpha, w = pgs_and_lcp(snap, dt)
    # 2-3 box corners (a fast spin reaches the third), 3 sphere-plane, 2 sphere-sphere
    assert np.sum(contacts["body_b"] == 1) in (2, 3)
    np.testing.assert_array_equal(contacts["body_b"][-5:], [2, 3, 4, 3, 4])
    assert np.linalg.eigvalsh(A).min() > 1e-6 * np.linalg.eigvalsh(A).max()
    assert np.sum(alpha > 0) >= 4          # a coupled problem, not a set of single contacts
    assert result["converged"]
    scale = np.abs(alpha).max()
    np.testing.assert_allclose(result["alpha"], alpha, rtol=0, atol=1e-8 * scale)
    np.testing.assert_allclose(A @ result["alpha"] + b, w, rtol=0, atol=1e-10)
    assert result["residual"] <= 1e-10


def test_lcp_solve_recovers_a_planted_solution():
    # plant a complementary pair (x, w), set b = w - A x, and solve
    rng = np.random.default_rng(7)
    for K in (1, 3, 6, 9):
        L = rng.normal(size=(K, K + 2))
        A = L @ L.T
        active = rng.random(K) < 0.5
        x = np.where(active, rng.uniform(0.1, 1.0, K), 0.0)
        w = np.where(active, 0.0, rng.uniform(0.1, 1.0, K))
        x_got, w_got = o.lcp_solve(A, w - A @ x)
        # A is well conditioned at these sizes: 1e-9 is far above the lstsq rounding
        np.testing.assert_allclose(x_got, x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(w_got, w, rtol=0, atol=1e-9)
    with pytest.raises(ValueError):
        o.lcp_solve(np.eye(13), np.ones(13))


# --------------------------------------------------------------------------- free motion

def free_box(omega, R=None, h=(0.5, 0.3, 0.1), gyroscopic="explicit"):
    return make_snapshot([make_body({"type": "box", "half_extents": list(h)})], [[0, 0, 0]],
                         rotation=None if R is None else [R], angular_velocity=[omega],
                         gravity=(0, 0, 0), gyroscopic=gyroscopic)


def angular_momentum(snap):
    b = snap["bodies"][0]
    R = snap["rotation"][0]
    return R @ b["inertia"] @ R.T @ snap["angular_velocity"][0]


def test_gyroscopic_term_keeps_angular_momentum_to_second_order():
    # The lecture's explicit term (gyroscopic="explicit"; the midpoint default and "implicit" are
    # checked in test_oracle_solver.py).  Torque-free, one step: I_w omega' = L - dt omega x L
    # and L' = Q I_w Q^T omega' with Q = exp([omega']x dt); Q^T omega' = omega', so
    # L' = Q (L - dt omega x L) and, as
    # omega x L is orthogonal to L,
    #   |L'| / |L| - 1 = sqrt(1 + dt^2 |omega x L|^2 / |L|^2) - 1.
    # The rotation after the polar step differs from Q R by ~eps, so the measured relative
    # change matches to ~1e-15 absolute (the change itself is ~1e-4).
    rng = np.random.default_rng(8)
    snap = free_box(np.array([1.0, 2.0, 3.0]), random_rotation(rng))
    for dt in (1e-2, 3e-3):
        state = snap
        for _ in range(50):
            L = angular_momentum(state)
            omega = state["angular_velocity"][0]
            new, info = o.step(state, dt)
            assert len(info["alpha"]) == 0
            L_new = angular_momentum(new)
            predicted = np.sqrt(1 + dt**2 * np.sum(np.cross(omega, L)**2) / (L @ L)) - 1
            measured = np.linalg.norm(L_new) / np.linalg.norm(L) - 1
            assert abs(measured - predicted) < 1e-13
            state = new


def test_gyroscopic_sign_makes_the_change_of_L_second_order():
    # (the explicit term, as above)
    # L' - L = Q (L - dt omega x L) - L = dt (omega' - omega) x L + O(dt^2) = O(dt^2), while the
    # flipped sign (+ dt omega x L) gives L' - L = 2 dt omega x L + O(dt^2).  Halving dt must
    # divide the change by ~4 for the oracle, and by ~2 for the flipped sign.
    rng = np.random.default_rng(9)
    R = random_rotation(rng)
    omega = np.array([1.0, 2.0, 3.0])
    snap = free_box(omega, R)
    L = angular_momentum(snap)
    I_w = R @ snap["bodies"][0]["inertia"] @ R.T

    def change(dt):
        new, _ = o.step(snap, dt)
        return np.linalg.norm(angular_momentum(new) - L)

    def change_flipped(dt):
        omega_new = np.linalg.solve(I_w, L + dt * np.cross(omega, L))
        Q = o.rodrigues(omega_new, dt)
        return np.linalg.norm(Q @ I_w @ Q.T @ omega_new - L)

    dt = 1e-3
    assert 3.8 < change(dt) / change(dt / 2) < 4.2
    assert 1.9 < change_flipped(dt) / change_flipped(dt / 2) < 2.1
    assert change_flipped(dt) == pytest.approx(2 * dt * np.linalg.norm(np.cross(omega, L)), rel=0.05)
    assert change(dt) < 0.01 * change_flipped(dt)


def test_unconstrained_velocity_closed_form():
    # v* = v + dt (g + f/m); for a sphere (I_w = I isotropic, omega x I omega = 0)
    # omega* = omega + dt tau / I
    dt = 0.01
    snap = make_snapshot([ground(), make_body({"type": "sphere", "radius": 0.5})],
                         [[0, 0, 0], [0, 0, 2.0]], velocity=[[0, 0, 0], [1.0, 2.0, 3.0]],
                         angular_velocity=[[0, 0, 0], [0.5, -0.5, 1.0]])
    snap["force"][1] = [4.0, 0.0, -2.0]
    snap["torque"][1] = [0.0, 3.0, 1.0]
    b = snap["bodies"][1]
    v, w = o.unconstrained_velocity(snap, dt)
    np.testing.assert_allclose(v[1], [1.0, 2.0, 3.0] + dt * (np.array([0, 0, -G]) + snap["force"][1] / b["mass"]),
                               rtol=1e-15)
    np.testing.assert_allclose(w[1], [0.5, -0.5, 1.0] + dt * snap["torque"][1] / b["inertia"][0, 0],
                               rtol=1e-15)
    np.testing.assert_array_equal(v[0], 0.0)
    np.testing.assert_array_equal(w[0], 0.0)


def test_ballistic_rollout_matches_symplectic_euler_closed_form():
    # no contacts: v_k = v0 + k dt g and p_k = p0 + k dt v0 + dt^2 g k (k + 1) / 2 exactly
    # (up to the rounding of ~k additions: 1e-12 m after 100 steps)
    dt, steps = 0.01, 100
    p0, v0 = np.array([0.0, 0.0, 100.0]), np.array([1.0, -2.0, 10.0])
    g = np.array([0.0, 0.0, -G])
    snap = make_snapshot([make_body({"type": "sphere", "radius": 0.1})], [p0], velocity=[v0])
    out = o.rollout(snap, dt, steps)
    k = np.arange(steps + 1)[:, None]
    assert out["position"].shape == (steps + 1, 1, 3)
    np.testing.assert_allclose(out["velocity"][:, 0], v0 + k * dt * g, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out["position"][:, 0], p0 + k * dt * v0 + dt**2 * g * k * (k + 1) / 2,
                               rtol=0, atol=1e-11)
    assert np.all(out["num_contacts"] == 0) and np.all(out["converged"])


def test_integrate_keeps_rotations_orthonormal_and_statics_fixed():
    # over 1000 steps of fast spin, the polar step holds R^T R = I to rounding
    rng = np.random.default_rng(10)
    snap = make_snapshot([make_body({"type": "box", "half_extents": [0.3, 0.2, 0.1]}, static=True),
                          make_body({"type": "box", "half_extents": [0.3, 0.2, 0.1]})],
                         [[0, 0, 0], [0, 0, 0]], rotation=[random_rotation(rng), random_rotation(rng)])
    R0_static = snap["rotation"][0].copy()
    p, R = snap["position"], snap["rotation"]
    for _ in range(1000):
        snap["position"], snap["rotation"] = o.integrate(snap, [[1, 1, 1], [1, 2, 3]],
                                                         [[5, 5, 5], [10.0, -20.0, 30.0]], 0.01)
    np.testing.assert_allclose(snap["rotation"][1].T @ snap["rotation"][1], np.eye(3), rtol=0, atol=1e-14)
    np.testing.assert_array_equal(snap["rotation"][0], R0_static)
    np.testing.assert_array_equal(snap["position"][0], 0.0)
    np.testing.assert_allclose(snap["position"][1], [10.0, 20.0, 30.0], rtol=1e-12)


def test_step_does_not_modify_its_input():
    snap = sphere_on_plane(gap=0.01, vz=-1.0)
    before = o.copy_snapshot(snap)
    new, _ = o.step(snap, 0.01)
    for key in ("position", "rotation", "velocity", "angular_velocity"):
        np.testing.assert_array_equal(snap[key], before[key])
    assert not np.array_equal(new["position"], snap["position"])


def test_oracle_imports_only_numpy_and_itself():
    # the oracle must never lean on the core it checks: scan its imports
    import ast
    import pathlib
    allowed = {"numpy", "copy", "itertools"}
    for path in pathlib.Path(o.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                assert {a.name.split(".")[0] for a in node.names} <= allowed, path
            elif isinstance(node, ast.ImportFrom):
                # relative imports stay inside the oracle package (level 1 only)
                assert node.level == 1 if node.level else node.module.split(".")[0] in allowed, path
