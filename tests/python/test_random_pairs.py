"""Seeded random convex pairs: the core's manifold against independent references.

For every pair the deepest contact's gap must equal the reference separation within 1e-6 m when
the shapes overlap shallowly: the oracle's separating axes for boxes (``box_box_separation``), a
brute-force search over support functions for hulls (``support_separation``), neither of which
shares code with the core. Never a NaN, never a zero normal, exactly touching shapes included.

How a pair with a chosen depth is made: a random overlapping placement, then B moved along the
reference's separating direction n by (target - sep). Moving B along the direction of minimal
translation changes the separation by exactly that amount (the ball of radius |sep| about the
origin lies inside the Minkowski difference), so the new separation is the target without
another reference call.
"""
import zlib

import numpy as np
import pytest

import signorini as sg
from signorini.oracle import manifold as om
from signorini.oracle import support as osup
from signorini.oracle.rigid import quat_to_matrix

from helpers import random_hull_points, sample, signed_distance, tessellated_floor

TOL = 1e-6          # m: the figure for shallow overlaps
# seeded samples: the default suite's, and the full ones with SIGNORINI_FULL=1 (the first pairs of the
# full sample: the same seeds, so every pair the default suite checks is one the full run checks)
N_BOX_PAIRS = sample(3000, 9000)
N_HULL_PAIRS = sample(300, 1000)
N_OFF_EDGE_PAIRS = sample(300, 600)  # half off-edge, half corner to corner
N_CONVEX_PAIRS = sample(8, 20)  # of each ordered pair of kinds, half touching, half 1 mm in
CURVED_TOL = 5e-3   # m: cylinders against non-spheres are approximate: the distance comes from a
                    # pattern search over support directions, and points clipped on a face within
                    # 5.7 degrees of the normal measure their gap along that face's normal


def random_quaternion(rng):
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def check_contacts(c, who):
    assert len(c) >= 1, f"{who}: no contact"
    assert np.all(np.isfinite(c.point)) and np.all(np.isfinite(c.normal)) and np.all(np.isfinite(c.gap)), who
    assert np.allclose(np.linalg.norm(c.normal, axis=1), 1.0, atol=1e-12), f"{who}: normal not unit"
    assert len(c) <= 4, f"{who}: {len(c)} points"


def box_reference(p_a, R_a, h_a, p_b, R_b, h_b):
    """(sep, n): separating-axis separation of two boxes and its axis (A -> B), oracle."""
    s = om.box_box_separation(p_a, R_a, h_a, p_b, R_b, h_b)
    sep, n = s["sep_A"], None
    best = max(s["sep_A"], s["sep_B"], s["sep_E"])
    return best, s


@pytest.mark.slow
@pytest.mark.slots("polytope-polytope", role="random", note="boxes, shallow")
def test_box_pairs_match_the_oracle_separating_axes():
    rng = np.random.default_rng(20261121)
    worst, done = 0.0, 0
    while done < N_BOX_PAIRS:
        h_a, h_b = rng.uniform(0.1, 1.0, 3), rng.uniform(0.1, 1.0, 3)
        q_a, q_b = random_quaternion(rng), random_quaternion(rng)
        R_a, R_b = quat_to_matrix(q_a), quat_to_matrix(q_b)
        p_a = rng.uniform(-1, 1, 3)
        p_b = p_a + rng.uniform(-0.5, 0.5) * (h_a.min() + h_b.min()) * random_quaternion(rng)[:3]
        # the support-function search gives the direction of least translation; then B is moved
        sep, n = osup.support_separation(osup.support_box(h_a, p_a, R_a), osup.support_box(h_b, p_b, R_b),
                                         n_directions=512, max_seeds=4) if done % 50 == 0 else (None, None)
        ref, s = box_reference(p_a, R_a, h_a, p_b, R_b, h_b)
        if ref >= 0.0:
            continue
        if sep is not None:
            # the two independent references agree with each other first
            assert abs(sep - ref) < 1e-9, (sep, ref)
        target = -rng.uniform(0.0, 0.02) if done % 10 else 0.0  # every tenth exactly touching
        axis = _axis_of(s, p_a, R_a, p_b, R_b)
        p_b = p_b + (target - ref) * axis
        ref2, _ = box_reference(p_a, R_a, h_a, p_b, R_b, h_b)
        assert abs(ref2 - target) < 1e-12
        c = sg.collide(sg.Box(h_a), (p_a, q_a), sg.Box(h_b), (p_b, q_b), margin=1e-9)
        check_contacts(c, f"box pair {done}")
        err = abs(c.gap.min() - ref2)
        worst = max(worst, err)
        assert err < TOL, f"box pair {done}: core {c.gap.min()} reference {ref2}"
        done += 1
    print(f"{done} box pairs: largest |gap - reference| = {worst:.2e} m")


def _axis_of(s, p_a, R_a, p_b, R_b):
    """The unit axis (A -> B) of the separating-axis maximum in the oracle's result."""
    if s["sep_E"] > max(s["sep_A"], s["sep_B"]):
        i, j = s["axes"]
        L = np.cross(R_a[:, i], R_b[:, j])
        L /= np.linalg.norm(L)
        return L if L @ (p_b - p_a) >= 0 else -L
    if s["sep_B"] > s["sep_A"]:
        f = s["face_b"]
        return (1.0 if f % 2 else -1.0) * -R_b[:, f // 2]
    f = s["face_a"]
    return (1.0 if f % 2 else -1.0) * R_a[:, f // 2]


def off_edge_pair(rng):
    """Boxes apart by delta in (0, 0.02] m along L = u_i x w_j whose supporting edges (A's along +L,
    B's along -L) would cross delta apart, but with the crossing beyond the end of A's edge, of B's
    or of both (the lines' closest points off the segments): the edge axis is the separating-axis
    maximum more often than not, and it only bounds the distance from below. Returns the pair
    (p_A, q_A, h_A, p_B, q_B, h_B) and None: their distance is not known in closed form."""
    h_A, h_B = rng.uniform(0.1, 1.0, 3), rng.uniform(0.1, 1.0, 3)
    q_A, q_B = random_quaternion(rng), random_quaternion(rng)
    R_A, R_B = quat_to_matrix(q_A), quat_to_matrix(q_B)
    p_A = rng.uniform(-1, 1, 3)
    i, j = rng.integers(3), rng.integers(3)
    L = np.cross(R_A[:, i], R_B[:, j])
    L /= np.linalg.norm(L)
    s_A = np.where(R_A.T @ L >= 0, 1.0, -1.0)
    s_B = np.where(-(R_B.T @ L) >= 0, 1.0, -1.0)
    beyond = rng.integers(1, 4)  # 1: A's edge, 2: B's, 3: both
    s_A[i] = rng.choice([-1, 1]) * (rng.uniform(1.0005, 1.05) if beyond & 1 else rng.uniform(0, 0.9))
    s_B[j] = rng.choice([-1, 1]) * (rng.uniform(1.0005, 1.05) if beyond & 2 else rng.uniform(0, 0.9))
    p_B = p_A + R_A @ (s_A * h_A) + rng.uniform(1e-4, 0.02) * L - R_B @ (s_B * h_B)
    return (p_A, q_A, h_A, p_B, q_B, h_B), None


def corner_pair(rng):
    """Boxes whose closest points are a corner of each, delta in (0, 0.02] m apart along a random
    unit d: A's corner of largest d . x and B's of least, B placed so that the second is the first
    plus delta d (both boxes then lie on their sides of the planes normal to d through them, so
    their distance is delta exactly). Returns the pair (p_A, q_A, h_A, p_B, q_B, h_B) and delta."""
    h_A, h_B = rng.uniform(0.1, 1.0, 3), rng.uniform(0.1, 1.0, 3)
    q_A, q_B = random_quaternion(rng), random_quaternion(rng)
    R_A, R_B = quat_to_matrix(q_A), quat_to_matrix(q_B)
    p_A = rng.uniform(-1, 1, 3)
    d = random_quaternion(rng)[:3]
    d /= np.linalg.norm(d)
    corner_A = p_A + R_A @ (np.where(R_A.T @ d >= 0, 1.0, -1.0) * h_A)
    corner_B = R_B @ (np.where(-(R_B.T @ d) >= 0, 1.0, -1.0) * h_B)
    delta = rng.uniform(1e-4, 0.02)
    return (p_A, q_A, h_A, corner_A + delta * d - corner_B, q_B, h_B), delta


def box_distance(h, p, R, X):
    """Distances (K,) of world points X (K, 3) from the box (half extents h, COM p, rotation R)."""
    local = (np.asarray(X, dtype=float).reshape(-1, 3) - p) @ R
    return np.linalg.norm(np.maximum(np.abs(local) - h, 0.0), axis=1)


CLOSEST_KINDS = {(om.VERTEX, om.VERTEX), (om.VERTEX, om.EDGE), (om.EDGE, om.VERTEX)}  # face clipping never makes these


def check_vertex_pair(c, i, j, x_a, delta, d, k):
    """The contacts of c made by the closest-pair rule (kinds in CLOSEST_KINDS) must be vertex i of
    A against vertex j of B, x_a (world) on A and delta apart along d: gap delta, normal d, point
    x_a + delta d / 2. Returns how many there were; k names the case in a failure."""
    found = 0
    for m in range(len(c)):
        kinds = (int(om.feature_parts(c.feature_a[m])[1]), int(om.feature_parts(c.feature_b[m])[1]))
        if kinds not in CLOSEST_KINDS:
            continue
        found += 1
        assert (c.feature_a[m], c.feature_b[m]) == (om.feature_id(om.VERTEX, i), om.feature_id(om.VERTEX, j)), k
        assert abs(c.gap[m] - delta) < 1e-12, k
        assert np.linalg.norm(c.point[m] - (x_a + 0.5 * delta * d)) < 1e-12, k
        assert np.linalg.norm(c.normal[m] - d) < 1e-10, k
    return found


@pytest.mark.slow
@pytest.mark.slots("polytope-polytope", role="random", note="boxes apart, off the edges")
def test_separated_box_pairs_off_the_edges_match_the_oracle_and_the_distance():
    # Boxes apart whose edge lines would meet off the edges: when the edge axis wins, its
    # separation only bounds the distance, so the contact is the boxes' closest pair (a corner
    # against a corner or an edge). Every pair's manifold (whatever its rule) matches the oracle,
    # ids and all; those closest-pair contacts (the only ones with vertex-vertex or vertex-edge
    # ids) also have the boxes' distance as their gap (a corner pair's delta, exact by
    # construction; an off-edge pair's from a brute-force support search, once a pair) and lie within
    # gap / 2 of both boxes (the midpoint of a point of each). Some face contacts whose clip keeps
    # points but misses the closest pair get it added beside those points (docs, "Manifolds", face
    # contact): those mixed manifolds match the oracle too.
    rng = np.random.default_rng(20260808)
    threshold = 0.03
    closest = mixed = 0
    for k in range(N_OFF_EDGE_PAIRS):
        (p_A, q_A, h_A, p_B, q_B, h_B), distance = (off_edge_pair, corner_pair)[k % 2](rng)
        R_A, R_B = quat_to_matrix(q_A), quat_to_matrix(q_B)
        c = sg.collide(sg.Box(h_A), (p_A, q_A), sg.Box(h_B), (p_B, q_B), margin=threshold)
        L = np.linalg.norm(h_A) + np.linalg.norm(h_B)
        y, n, gap, fa, fb = om.select_manifold(*om.contact_box_box(p_A, R_A, h_A, p_B, R_B, h_B, threshold),
                                               threshold, L)
        assert len(c) == len(gap), k
        np.testing.assert_array_equal(c.feature_a, fa, err_msg=str(k))
        np.testing.assert_array_equal(c.feature_b, fb, err_msg=str(k))
        for name, ours, theirs in (("point", c.point, y), ("gap", c.gap, gap)):
            np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-12, err_msg=f"{k} {name}")
        # a closest pair's normal (q - p) / |q - p| carries the rounding of q - p (~1e-16 m here,
        # core in A's frame, oracle in the world's) divided by the gap (down to 1e-4 m)
        assert np.all(np.linalg.norm(c.normal - n, axis=1) <= 1e-12 + 1e-14 / np.abs(gap)), k
        for m in range(len(c)):
            kinds = (int(om.feature_parts(c.feature_a[m])[1]), int(om.feature_parts(c.feature_b[m])[1]))
            if kinds not in CLOSEST_KINDS:
                continue
            closest += 1
            mixed += len(c) > 1
            if distance is None:
                distance, _ = osup.support_separation(osup.support_box(h_A, p_A, R_A),
                                                      osup.support_box(h_B, p_B, R_B))
            assert abs(c.gap[m] - distance) < 1e-9, (k, c.gap[m], distance)
            for h, p, R in ((h_A, p_A, R_A), (h_B, p_B, R_B)):
                assert box_distance(h, p, R, c.point[m])[0] <= 0.5 * c.gap[m] + 1e-12, k
    # the sample holds enough of each case: of the 600 pairs, 446 closest-pair contacts (219 in the
    # first 300), 55 of them in mixed manifolds (26)
    assert closest >= 250 * N_OFF_EDGE_PAIRS // 600, closest
    assert mixed >= 40 * N_OFF_EDGE_PAIRS // 600, mixed


@pytest.mark.slow
@pytest.mark.slots("polytope-polytope", role="random", note="hulls, shallow")
def test_hull_pairs_match_a_brute_force_support_search():
    rng = np.random.default_rng(417)
    worst, done = 0.0, 0
    while done < N_HULL_PAIRS:
        a, b = sg.ConvexHull(random_hull_points(rng)), sg.ConvexHull(random_hull_points(rng))
        q_a, q_b = random_quaternion(rng), random_quaternion(rng)
        R_a, R_b = quat_to_matrix(q_a), quat_to_matrix(q_b)
        p_a = np.zeros(3)
        p_b = rng.uniform(-0.2, 0.2, 3)
        sep, n = osup.support_separation(osup.support_hull(np.asarray(a.vertices), p_a, R_a),
                                         osup.support_hull(np.asarray(b.vertices), p_b, R_b), n_directions=1024)
        if sep >= 0.0:
            continue
        target = -rng.uniform(0.0, 0.02) if done % 10 else 0.0
        p_b = p_b + (target - sep) * n
        c = sg.collide(a, (p_a, q_a), b, (p_b, q_b), margin=1e-9)
        check_contacts(c, f"hull pair {done}")
        err = abs(c.gap.min() - target)
        worst = max(worst, err)
        assert err < TOL, f"hull pair {done}: core {c.gap.min()} reference {target}"
        done += 1
    print(f"{done} hull pairs: largest |gap - reference| = {worst:.2e} m")


@pytest.mark.slow
@pytest.mark.slots("polytope-polytope", role="random", note="hull corners apart")
def test_separated_hull_corners_get_their_closest_pair():
    # Hulls apart whose closest points are a vertex of each, delta apart along a random unit d
    # (A's vertex of largest d . x, B's of least, B placed so that the second is the first plus
    # delta d): the distance is delta exactly. When the separating-axis test picks an edge pair
    # there, its separation is only a lower bound and the contact is that closest pair: ids
    # (vertex a, vertex b), gap delta, normal d, point midway between the two vertices. Every 10th
    # pair's delta is checked against a brute-force support search first.
    rng = np.random.default_rng(4170)
    closest = 0
    for k in range(400):
        a, b = sg.ConvexHull(random_hull_points(rng)), sg.ConvexHull(random_hull_points(rng))
        q_a, q_b = random_quaternion(rng), random_quaternion(rng)
        R_a, R_b = quat_to_matrix(q_a), quat_to_matrix(q_b)
        V_a = np.asarray(a.vertices) @ R_a.T
        V_b = np.asarray(b.vertices) @ R_b.T
        d = random_quaternion(rng)[:3]
        d /= np.linalg.norm(d)
        i, j = int(np.argmax(V_a @ d)), int(np.argmin(V_b @ d))
        delta = rng.uniform(1e-3, 0.02)
        p_b = V_a[i] + delta * d - V_b[j]
        if k % 10 == 0:
            sep, _ = osup.support_separation(osup.support_hull(np.asarray(a.vertices), np.zeros(3), R_a),
                                             osup.support_hull(np.asarray(b.vertices), p_b, R_b), n_directions=1024)
            assert abs(sep - delta) < 1e-9, (k, sep, delta)
        c = sg.collide(a, (np.zeros(3), q_a), b, (p_b, q_b), margin=0.03)
        closest += check_vertex_pair(c, i, j, V_a[i], delta, d, k)
    assert closest >= 100, closest  # 142 of the 400 pairs


@pytest.mark.slots("trimesh-polytope", role="random", note="box corners apart")
def test_separated_box_corners_over_a_triangle_get_their_closest_pair():
    # The same for a box in front of a one-triangle mesh (its edges all active): a triangle vertex
    # and a box corner delta apart along d, d . n_t >= 0.2 (the box in front of the face, which
    # is one-sided). When the triangle's separating axes pick an edge pair there, the contact is
    # that pair of vertices: gap delta, normal d, point midway, ids (vertex i of the triangle,
    # part 0; corner j of the box).
    rng = np.random.default_rng(5)
    closest = 0
    for k in range(400):
        V = rng.normal(size=(3, 3)) * 0.5
        n_t = np.cross(V[1] - V[0], V[2] - V[0])
        n_t /= np.linalg.norm(n_t)
        mesh = sg.TriangleMesh(V, np.array([[0, 1, 2]]))
        h, q = rng.uniform(0.1, 0.5, 3), random_quaternion(rng)
        R = quat_to_matrix(q)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        if d @ n_t < 0.2:
            d = d - (d @ n_t - 0.2 - rng.uniform(0.0, 0.8)) * n_t
            d /= np.linalg.norm(d)
        i = int(np.argmax(V @ d))
        signs = np.where(-(R.T @ d) >= 0, 1.0, -1.0)
        j = int(sum(bit for bit, sign in zip((1, 2, 4), signs) if sign > 0))  # corner numbering
        delta = rng.uniform(1e-3, 0.02)
        p = V[i] + delta * d - R @ (signs * h)
        c = sg.collide(mesh, (np.zeros(3), [1.0, 0.0, 0.0, 0.0]), sg.Box(h), (p, q), margin=0.03)
        closest += check_vertex_pair(c, i, j, V[i], delta, d, k)
    assert closest >= 80, closest  # 105 of the 400 pairs


SHAPES = {
    "sphere": lambda rng: sg.Sphere(rng.uniform(0.1, 0.5)),
    "box": lambda rng: sg.Box(rng.uniform(0.1, 0.5, 3)),
    "capsule": lambda rng: sg.Capsule(rng.uniform(0.05, 0.3), rng.uniform(0.0, 0.5)),
    "cylinder": lambda rng: sg.Cylinder(rng.uniform(0.1, 0.4), rng.uniform(0.05, 0.4)),
    "hull": lambda rng: sg.ConvexHull(random_hull_points(rng)),
}
ITEM_KIND = {"sphere": "sphere", "box": "polytope", "capsule": "capsule", "cylinder": "cylinder", "hull": "polytope"}


@pytest.mark.slow
@pytest.mark.slots(*sorted({f"{ITEM_KIND[a]}-{ITEM_KIND[b]}" for a in SHAPES for b in SHAPES}), role="random",
                   note=f"{N_CONVEX_PAIRS} pairs, deepest gap only, 5 mm for cylinders")
@pytest.mark.parametrize("kind_a", sorted(SHAPES))
@pytest.mark.parametrize("kind_b", sorted(SHAPES))
def test_every_convex_pair_touching_or_shallow_has_finite_unit_normals(kind_a, kind_b):
    rng = np.random.default_rng(zlib.crc32(f"{kind_a}-{kind_b}".encode()))  # the same seed every run
    worst = 0.0
    for k in range(N_CONVEX_PAIRS):
        a, b = SHAPES[kind_a](rng), SHAPES[kind_b](rng)
        q_a, q_b = random_quaternion(rng), random_quaternion(rng)
        p_a, p_b = np.zeros(3), rng.uniform(-0.1, 0.1, 3)
        da, db = sg.shape_dict(a), sg.shape_dict(b)
        sep, n = osup.support_separation(osup.support_of(da, p_a, quat_to_matrix(q_a)),
                                         osup.support_of(db, p_b, quat_to_matrix(q_b)), n_directions=1024)
        target = 0.0 if k % 2 else -0.001
        # closed forms (spheres, capsules, polytopes) to 1e-6; cylinders against anything but a
        # sphere go through a search over support directions and rim-sampled caps (CURVED_TOL)
        exact = "cylinder" not in (kind_a, kind_b) or "sphere" in (kind_a, kind_b)
        p_b = p_b + (target - sep) * n
        c = sg.collide(a, (p_a, q_a), b, (p_b, q_b), margin=1e-6 if exact else CURVED_TOL)
        check_contacts(c, f"{kind_a}-{kind_b} {k}")
        worst = max(worst, abs(c.gap.min() - target))
    print(f"{kind_a}-{kind_b}: largest |gap - reference| = {worst:.2e} m")
    assert worst < (TOL if exact else CURVED_TOL), f"{kind_a}-{kind_b}: largest gap error {worst:.2e} m"


def _assert_on_body(kind, r, h, on_body, gap):
    """Body witnesses (K, 3, body frame) on the body or inside it (a capsule's segment clipped at a
    triangle's side ends r below a point of its axis, which other axis points may be nearer), the
    deepest one on its surface."""
    d = signed_distance(kind, r, h, on_body)
    assert d.max() < 1e-9 and abs(d[np.argmin(gap)]) < 1e-9, d


@pytest.mark.parametrize("kind", [pytest.param(k, marks=pytest.mark.slots("trimesh-" + k, role="random",
                                                                          note="a tessellated floor"))
                                  for k in ["capsule", "cylinder"]])
def test_capsules_and_cylinders_get_no_ghost_normals_from_a_tessellated_floor(kind):
    # any orientation, anywhere over a flat floor of 128 triangles, its lowest point within 4 mm of
    # the floor in or out: the floor is one plane, so every contact normal is its normal, the
    # deepest gap is the closed form of the lowest point (capsule: z - h |a_z| - r; cylinder:
    # z - h |a_z| - r sqrt(1 - a_z^2)), and every point is on both (its floor witness y - gap/2 n
    # in z = 0, its body witness y + gap/2 n on the body's surface): the inactive-edge rule
    # (docs/conventions.md, "Contacts", static triangle mesh)
    floor = tessellated_floor()
    r, h = 0.05, 0.1
    shape = sg.Capsule(r, h) if kind == "capsule" else sg.Cylinder(r, h)
    rng = np.random.default_rng(11)
    for _ in range(600):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        R = quat_to_matrix(q)
        a_z = R[2, 2]
        drop = h * abs(a_z) + (r if kind == "capsule" else r * np.sqrt(max(0.0, 1 - a_z ** 2)))
        lowest = rng.uniform(-0.004, 0.004)
        p = np.array([rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), lowest + drop])
        c = sg.collide(floor, ((0, 0, 0), (1, 0, 0, 0)), shape, (p, q), margin=0.01)
        assert len(c) > 0
        np.testing.assert_allclose(c.normal, np.tile([0.0, 0.0, 1.0], (len(c), 1)), rtol=0, atol=1e-12)
        assert abs(c.gap.min() - lowest) < 1e-12
        on_floor = c.point - 0.5 * c.gap[:, None] * c.normal
        on_body = (c.point + 0.5 * c.gap[:, None] * c.normal - p) @ R
        np.testing.assert_allclose(on_floor[:, 2], 0.0, atol=1e-12)
        assert np.all(np.abs(on_floor[:, :2]) <= 1.0)
        _assert_on_body(kind, r, h, on_body, c.gap)


@pytest.mark.parametrize("kind", [pytest.param(k, marks=pytest.mark.slots("trimesh-" + k, role="random",
                                                                          note="a valley"))
                                  for k in ["capsule", "cylinder"]])
def test_capsules_and_cylinders_in_a_valley_touch_its_faces(kind):
    # a V valley (faces z = -s x for x < 0 and z = s x for x > 0, s = 0.4, fold along y, cut into
    # triangles; the fold is concave, so inactive), the body anywhere near the fold in any
    # orientation, its deepest point within 4 mm of the nearer face's plane in or out: every contact
    # normal is one of the two face normals and every point's valley witness lies on the valley
    # (z = s |x|), its body witness on the body
    s, half, n = 0.4, 1.0, 6
    xs, ys = np.linspace(-half, half, 2 * n + 1), np.linspace(-half, half, n + 1)
    V = np.array([(x, y, s * abs(x)) for y in ys for x in xs])
    F = []
    for j in range(n):
        for i in range(2 * n):
            a = j * (2 * n + 1) + i
            F += [(a, a + 1, a + 2 * n + 2), (a, a + 2 * n + 2, a + 2 * n + 1)]
    valley = sg.TriangleMesh(V, np.array(F))
    faces = np.array([[s, 0.0, 1.0], [-s, 0.0, 1.0]]) / np.hypot(s, 1.0)
    r, h = 0.05, 0.1
    shape = sg.Capsule(r, h) if kind == "capsule" else sg.Cylinder(r, h)
    rng = np.random.default_rng(12)
    touched = 0
    for _ in range(600):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        a_n = faces @ quat_to_matrix(q)[:, 2]
        extent = h * np.abs(a_n) + (r if kind == "capsule" else r * np.sqrt(np.maximum(0.0, 1 - a_n ** 2)))
        p = np.array([rng.uniform(-0.2, 0.2), rng.uniform(-0.6, 0.6), 0.0])
        # the height at which min over the faces of n_i . p - extent_i is `lowest`
        p[2] = np.max((rng.uniform(-0.004, 0.004) + extent - faces[:, 0] * p[0]) / faces[:, 2])
        c = sg.collide(valley, ((0, 0, 0), (1, 0, 0, 0)), shape, (p, q), margin=0.01)
        touched += len(c) > 0
        assert np.all(np.abs(c.normal @ faces.T).max(axis=1) > 1.0 - 1e-12), c.normal
        on_valley = c.point - 0.5 * c.gap[:, None] * c.normal
        np.testing.assert_allclose(on_valley[:, 2], s * np.abs(on_valley[:, 0]), atol=1e-9)
        on_body = (c.point + 0.5 * c.gap[:, None] * c.normal - p) @ quat_to_matrix(q)
        _assert_on_body(kind, r, h, on_body, c.gap)
    assert touched == 600
