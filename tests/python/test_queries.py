"""World queries (issue 24): ray casts, overlaps, distances.

Tolerances come from the geometry:
  REL = 1e-12 (relative): the analytic shapes' entry distances (sphere, box, capsule, cylinder,
    plane) are a few dozen double operations on coordinates below 10 m, so rounding is ~1e-15 of
    the distance; the reference here is computed by a different formula (the textbook quadratic,
    or the slabs in another order), so 1e-12 leaves room for both roundings and nothing more.
  EXACT = 1e-9 (m): polytopes (clipped by their face planes, whose normals are themselves rounded
    from Qhull's hull) and triangles (Moller-Trumbore): the issue's figure.
FCL 0.7 has no ray query, so the references are written here from the shapes' definitions.
"""
import math

import numpy as np
import pytest

import signorini as sg
from signorini.oracle.rigid import quat_to_matrix

REL = 1e-12
EXACT = 1e-9


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def random_quat(rng):
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def rays_towards(rng, centre, n, spread, dist=6.0):
    """n rays starting about dist from centre, aimed at points within spread of it."""
    o = centre + dist * np.array([unit(rng.normal(size=3)) for _ in range(n)])
    target = centre + rng.uniform(-spread, spread, size=(n, 3))
    return o, target - o


def world(**kw):
    return sg.World(gravity=(0, 0, 0), sleeping=False, **kw)


# ---- closed forms per shape ----

def sphere_entry(o, u, c, r):
    """Textbook quadratic t^2 + 2 b t + c0 = 0, smaller root."""
    b = np.dot(o - c, u)
    c0 = np.dot(o - c, o - c) - r * r
    disc = b * b - c0
    if disc < 0 or b > 0:
        return None
    return -b - math.sqrt(disc)


def test_sphere_closed_form_at_random_rays():
    rng = np.random.default_rng(1)
    w = world()
    c, r = np.array([0.3, -0.2, 1.1]), 0.7
    w.add_body(sg.Sphere(r), density=1000, position=c, orientation=random_quat(rng))
    O, D = rays_towards(rng, c, 300, 1.0)
    hits = 0
    for o, d in zip(O, D):
        u = unit(d)
        ref = sphere_entry(o, u, c, r)
        h = w.cast_ray(o, d)
        if ref is None:
            assert h is None
            continue
        hits += 1
        assert h.body == 0
        assert abs(h.distance - ref) <= REL * ref
        assert np.allclose(h.point, o + ref * u, rtol=0, atol=1e-12 * 10)
        assert np.allclose(h.normal, (h.point - c) / r, atol=1e-12)
        assert sg.feature(h.feature) == sg.Feature(0, "face", 0)
    assert 100 < hits < 300  # both hits and misses were tried


def box_entry(o, u, h):
    """Slabs in the box frame: (t, axis, sign) of the face entered last, or None."""
    t_in, t_out, face = -math.inf, math.inf, None
    for i in range(3):
        if u[i] == 0:
            if abs(o[i]) > h[i]:
                return None
            continue
        ts = sorted([((s * h[i] - o[i]) / u[i], s) for s in (-1, 1)])
        if ts[0][0] > t_in:
            t_in, face = ts[0][0], (i, ts[0][1])
        t_out = min(t_out, ts[1][0])
    if t_in < 0 or t_in > t_out:
        return None
    return t_in, face


def test_rotated_box_closed_form_normals_and_faces():
    rng = np.random.default_rng(2)
    w = world()
    p, h = np.array([1.0, 2.0, 0.5]), np.array([0.4, 0.7, 0.25])
    q = random_quat(rng)
    R = quat_to_matrix(q)
    w.add_static(sg.Box(h), position=p, orientation=q)
    O, D = rays_towards(rng, p, 300, 0.8)
    hits = 0
    for o, d in zip(O, D):
        u = unit(d)
        ref = box_entry(R.T @ (o - p), R.T @ u, h)
        got = w.cast_ray(o, d)
        if ref is None:
            assert got is None
            continue
        hits += 1
        t, (axis, sign) = ref
        assert abs(got.distance - t) <= REL * t
        n = np.zeros(3)
        n[axis] = sign
        assert np.allclose(got.normal, R @ n, atol=1e-12)
        assert sg.feature(got.feature) == sg.Feature(0, "face", 2 * axis + (sign > 0))
    assert 100 < hits < 300


def test_capsule_side_and_caps_closed_forms():
    w = world()
    r, hl = 0.3, 0.8
    w.add_static(sg.Capsule(r, hl), position=(0, 0, 0))
    # side, perpendicular to the axis, off-centre by y0: t = 5 - sqrt(r^2 - y0^2)
    for y0, z0 in [(0.0, 0.2), (0.1, -0.5), (0.29, 0.8)]:
        h = w.cast_ray((-5, y0, z0), (1, 0, 0))
        ref = 5 - math.sqrt(r * r - y0 * y0)
        assert abs(h.distance - ref) <= REL * ref
        assert sg.feature(h.feature) == sg.Feature(0, "edge", 0)
        assert np.allclose(h.normal, [-math.sqrt(r * r - y0 * y0) / r, y0 / r, 0], atol=1e-12)
    # along the axis into the top cap: t = 5 - hl - r; off the axis by x0: 5 - hl - sqrt(r^2 - x0^2)
    for x0 in [0.0, 0.2]:
        h = w.cast_ray((x0, 0, 5), (0, 0, -1))
        ref = 5 - hl - math.sqrt(r * r - x0 * x0)
        assert abs(h.distance - ref) <= REL * ref
        assert sg.feature(h.feature) == sg.Feature(0, "vertex", 1)
    h = w.cast_ray((0, 0, -5), (0, 0, 1))
    assert sg.feature(h.feature) == sg.Feature(0, "vertex", 0)
    assert w.cast_ray((0.31, 0, 5), (0, 0, -1)) is None


def segment_distance(x, a, b):
    ab = b - a
    s = np.clip(np.dot(x - a, ab) / np.dot(ab, ab), 0, 1)
    return np.linalg.norm(x - (a + s * ab))


def test_capsule_random_rays_enter_at_the_first_surface_point():
    rng = np.random.default_rng(3)
    w = world()
    r, hl = 0.35, 0.6
    p, q = np.array([0.2, 0.1, -0.3]), random_quat(rng)
    a = quat_to_matrix(q)[:, 2]
    w.add_body(sg.Capsule(r, hl), density=1000, position=p, orientation=q)
    O, D = rays_towards(rng, p, 200, 0.9)
    hits = 0
    for o, d in zip(O, D):
        h = w.cast_ray(o, d)
        u = unit(d)
        ts = np.linspace(0, 12, 4001)
        dist = np.array([segment_distance(o + t * u, p - hl * a, p + hl * a) for t in ts])
        if h is None:
            assert dist.min() > r - 1e-3  # no sample deep inside
            continue
        hits += 1
        assert abs(segment_distance(h.point, p - hl * a, p + hl * a) - r) <= EXACT
        assert (dist[ts < h.distance - 1e-9] > r).all()  # nothing earlier is inside
    assert hits > 50


def test_cylinder_caps_side_and_rotation():
    rng = np.random.default_rng(4)
    w = world()
    r, hh = 0.5, 0.3
    w.add_static(sg.Cylinder(r, hh), position=(0, 0, 0))
    h = w.cast_ray((0.2, 0.1, 4), (0, 0, -1))
    assert abs(h.distance - (4 - hh)) <= REL * (4 - hh)
    assert sg.feature(h.feature) == sg.Feature(0, "face", 1) and np.allclose(h.normal, [0, 0, 1])
    h = w.cast_ray((0.2, 0.1, -4), (0, 0, 1))
    assert sg.feature(h.feature) == sg.Feature(0, "face", 0) and np.allclose(h.normal, [0, 0, -1])
    y0 = 0.3
    h = w.cast_ray((-3, y0, 0.1), (1, 0, 0))
    ref = 3 - math.sqrt(r * r - y0 * y0)
    assert abs(h.distance - ref) <= REL * ref
    assert sg.feature(h.feature) == sg.Feature(0, "face", 2)
    # a slanted ray into the cap: the plane z = hh, t = (z0 - hh) / |u_z|, if it lands inside the disk
    o, d = np.array([0.1, 0.0, 2.0]), np.array([0.1, 0.05, -1.0])
    u = unit(d)
    ref = (2.0 - hh) / -u[2]
    h = w.cast_ray(o, d)
    assert abs(h.distance - ref) <= REL * ref
    # random rotated cylinder: hit point on the surface, nothing inside before it
    p, q = np.array([3.0, 0, 0]), random_quat(rng)
    R = quat_to_matrix(q)
    w2 = world()
    w2.add_body(sg.Cylinder(r, hh), density=1000, position=p, orientation=q)

    def inside(x):
        xl = R.T @ (x - p)
        return xl[0] ** 2 + xl[1] ** 2 < r * r and abs(xl[2]) < hh

    O, D = rays_towards(rng, p, 150, 0.6)
    hits = 0
    for o, d in zip(O, D):
        h = w2.cast_ray(o, d)
        if h is None:
            continue
        hits += 1
        xl = R.T @ (h.point - p)
        on_side = abs(math.hypot(xl[0], xl[1]) - r) <= EXACT and abs(xl[2]) <= hh + EXACT
        on_cap = abs(abs(xl[2]) - hh) <= EXACT and math.hypot(xl[0], xl[1]) <= r + EXACT
        assert on_side or on_cap
        u = unit(d)
        assert not any(inside(o + t * u) for t in np.linspace(0, h.distance - 1e-9, 500))
    assert hits > 50


def test_plane_closed_form_and_a_ray_parallel_or_away_misses():
    w = world()
    n = unit([0.2, -0.1, 1.0])
    w.add_static(sg.Plane(n, 0.4))
    o, d = np.array([1.0, 2.0, 5.0]), np.array([0.3, 0.1, -1.0])
    h = w.cast_ray(o, d)
    u = unit(d)
    ref = (n @ o - 0.4) / -(n @ u)
    assert abs(h.distance - ref) <= REL * ref
    assert np.allclose(h.normal, n, atol=1e-15)
    assert w.cast_ray(o, -d) is None
    assert w.cast_ray(o, np.cross(n, [1, 0, 0])) is None
    assert w.cast_ray(o, d, max_distance=ref * (1 - 1e-9)) is None
    assert w.cast_ray(o, d, max_distance=ref * (1 + 1e-9)).body == 0


def test_hull_agrees_with_its_half_spaces_and_with_the_box_it_is():
    rng = np.random.default_rng(5)
    h = np.array([0.5, 0.3, 0.2])
    corners = np.array([[sx * h[0], sy * h[1], sz * h[2]] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    pts = np.vstack([rng.normal(size=(30, 3)) * 0.4])
    for shape_pts, box in [(corners, sg.Box(h)), (pts, None)]:
        p, q = np.array([0.5, -0.2, 0.3]), random_quat(rng)
        w = world()
        w.add_static(sg.ConvexHull(shape_pts), position=p, orientation=q)
        if box is not None:
            w.add_static(box, position=p + np.array([0, 0, 100.0]), orientation=q)
        R = quat_to_matrix(q)
        # the hull's half-spaces from scipy (independent of the core's polytope)
        from scipy.spatial import ConvexHull as SciHull
        eq = SciHull(shape_pts).equations  # n . x + c <= 0 inside
        O, D = rays_towards(rng, p, 150, 0.5)
        hits = 0
        for o, d in zip(O, D):
            got = w.cast_ray(o, d, max_distance=50)
            ol, ul = R.T @ (o - p), R.T @ unit(d)
            num, den = -(eq[:, :3] @ ol + eq[:, 3]), eq[:, :3] @ ul
            t_in = max([nu / de for nu, de in zip(num, den) if de < 0], default=-math.inf)
            t_out = min([nu / de for nu, de in zip(num, den) if de > 0], default=math.inf)
            if t_in > t_out or t_in < 0:
                assert got is None
                continue
            hits += 1
            assert abs(got.distance - t_in) <= EXACT
            if box is not None:  # the same ray 100 m higher hits the box at the same distance
                twin = w.cast_ray(o + [0, 0, 100], d, max_distance=50)
                assert twin.body == 1 and abs(twin.distance - got.distance) <= EXACT
                assert np.allclose(twin.normal, got.normal, atol=1e-9)
        assert hits > 40


def test_triangle_mesh_known_triangle_both_sides_and_a_terrain():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.5]], dtype=float)
    F = np.array([[0, 1, 2], [1, 3, 2]])
    w = world()
    w.add_static(sg.TriangleMesh(V, F), position=(0, 0, 1))
    h = w.cast_ray((0.2, 0.3, 5), (0, 0, -1))
    assert h.body == 0 and abs(h.distance - 4.0) <= EXACT
    assert np.allclose(h.normal, [0, 0, 1]) and sg.feature(h.feature) == sg.Feature(0, "face", 0)
    h = w.cast_ray((0.2, 0.3, -5), (0, 0, 1))  # from behind: the normal faces the ray
    assert abs(h.distance - 6.0) <= EXACT and np.allclose(h.normal, [0, 0, -1])
    # the second triangle (plane through (1,0,0), (1,1,.5), (0,1,0)): z = 0.5 (x + y - 1)
    x, y = 0.8, 0.7
    h = w.cast_ray((x, y, 5), (0, 0, -1))
    assert sg.feature(h.feature).part == 1 and abs(h.distance - (4 - 0.5 * (x + y - 1))) <= EXACT
    assert w.cast_ray((1.2, 0.3, 5), (0, 0, -1)) is None
    # a 40 x 40 terrain of 3200 triangles: height by its closed form under random rays
    n = 40
    xs = np.linspace(-2, 2, n + 1)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    Z = 0.3 * X + 0.1 * Y  # a tilted plane: every triangle lies in it
    V = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    idx = lambda i, j: i * (n + 1) + j  # noqa: E731
    F = [[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)] for i in range(n) for j in range(n)]
    F += [[idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)] for i in range(n) for j in range(n)]
    w = world()
    w.add_static(sg.TriangleMesh(V, np.array(F)))
    rng = np.random.default_rng(6)
    nrm = unit([-0.3, -0.1, 1])
    for _ in range(100):
        o = np.array([*rng.uniform(-1.8, 1.8, 2), 3.0])
        d = np.array([*rng.uniform(-0.2, 0.2, 2), -1.0])
        u = unit(d)
        ref = (nrm @ o) / -(nrm @ u)  # the plane z = 0.3 x + 0.1 y through the origin
        h = w.cast_ray(o, d)
        if np.abs(o + ref * u)[:2].max() > 2 - 1e-9:  # beyond the terrain's edge
            assert h is None
            continue
        assert abs(h.distance - ref) <= EXACT and np.allclose(h.normal, nrm, atol=1e-9)


def test_compound_and_decomposed_mesh():
    w = world()
    parts = [(sg.Sphere(0.2), ((0, 0, 0.5), (1, 0, 0, 0))), (sg.Box((0.1, 0.1, 0.1)), ((0, 0, -0.5), (1, 0, 0, 0)))]
    w.add_static(sg.Compound(parts), position=(0, 0, 1))
    h = w.cast_ray((0, 0, 5), (0, 0, -1))
    assert abs(h.distance - (5 - 1.7)) <= REL * 3.3 and sg.feature(h.feature) == sg.Feature(0, "face", 0)
    h = w.cast_ray((0, 0, -5), (0, 0, 1))
    assert abs(h.distance - (5 + 0.4)) <= REL * 5.4 and sg.feature(h.feature) == sg.Feature(1, "face", 4)
    h = w.cast_ray((0.15, 0, 5), (0, 0, -1))  # off the sphere part's centre: 5 - (1.5 + sqrt(r^2 - x^2))
    ref = 5 - (1.5 + math.sqrt(0.2**2 - 0.15**2))
    assert abs(h.distance - ref) <= REL * ref
    assert w.cast_ray((0.21, 0, 5), (0, 0, -1)) is None  # beside the sphere, above nothing else
    # a mesh body collides (and is hit) through its convex pieces: a cube mesh is one piece
    V = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    F = sg.ConvexHull(V).faces
    w2 = world()
    i = w2.add_body(sg.Mesh(V, F), density=100, position=(3, 0, 0))
    h = w2.cast_ray((0, 0.1, 0.2), (1, 0, 0))
    assert h.body == i and abs(h.distance - 2.5) <= EXACT and np.allclose(h.normal, [-1, 0, 0], atol=1e-9)


def test_a_ray_from_inside_hits_at_distance_zero():
    w = world()
    w.add_body(sg.Sphere(1.0), density=1, position=(0, 0, 0))
    h = w.cast_ray((0.1, 0.2, 0.3), (0, 1, 0))
    assert h.distance == 0 and np.array_equal(h.point, [0.1, 0.2, 0.3]) and np.array_equal(h.normal, [0, -1, 0])
    assert sg.feature(h.feature).kind == "shape"
    # on the surface, going out: no hit; going in: at 0 with the surface normal
    assert w.cast_ray((0, 0, 1), (0, 0, 1)) is None
    h = w.cast_ray((0, 0, 1), (0, 0, -1))
    assert h.distance == 0 and np.allclose(h.normal, [0, 0, 1])


# ---- modes, batches, threads ----

def mixed_scene(threads=None, n=6, seed=7):
    rng = np.random.default_rng(seed)
    w = sg.World(gravity=(0, 0, 0), sleeping=False, threads=threads)
    w.add_static(sg.Plane((0, 0, 1), -1.0))
    V = np.array([[-3, -3, -0.5], [3, -3, -0.5], [0, 3, -0.5]], dtype=float)
    w.add_static(sg.TriangleMesh(V, np.array([[0, 1, 2]])))
    hull = sg.ConvexHull(rng.normal(size=(20, 3)) * 0.3)
    shapes = [sg.Sphere(0.3), sg.Box((0.3, 0.2, 0.1)), sg.Capsule(0.1, 0.3), sg.Cylinder(0.2, 0.2), hull,
              sg.Compound([(sg.Sphere(0.1), ((0.2, 0, 0), (1, 0, 0, 0))),
                           (sg.Capsule(0.05, 0.2), ((-0.2, 0, 0), (1, 0, 0, 0)))])]
    for k in range(n * len(shapes)):
        w.add_body(shapes[k % len(shapes)], density=500, position=rng.uniform(-2, 2, 3) + [0, 0, 1],
                   orientation=random_quat(rng))
    return w


def test_batch_equals_single_rays_bit_for_bit_at_1_and_2_threads():
    rng = np.random.default_rng(8)
    O = rng.uniform(-4, 4, (400, 3)) + [0, 0, 2]
    D = rng.normal(size=(400, 3))
    M = rng.uniform(1, 10, 400)
    results = []
    for threads in (1, 2):
        w = mixed_scene(threads=threads)
        b = w.cast_rays(O, D, M)
        results.append(b)
        for k in range(len(O)):
            h = w.cast_ray(O[k], D[k], M[k])
            if h is None:
                assert b.body[k] == -1 and b.distance[k] == math.inf
                continue
            assert b.body[k] == h.body and b.distance[k] == h.distance and b.feature[k] == h.feature
            assert np.array_equal(b.point[k], h.point) and np.array_equal(b.normal[k], h.normal)
    assert 100 < (results[0].body >= 0).sum() < 400
    for name in ("body", "point", "normal", "distance", "feature"):
        assert np.array_equal(getattr(results[0], name), getattr(results[1], name)), name


def test_all_and_any_modes_agree_with_the_closest():
    rng = np.random.default_rng(9)
    w = mixed_scene()
    for _ in range(100):
        o, d = rng.uniform(-3, 3, 3) + [0, 0, 3], rng.normal(size=3)
        closest = w.cast_ray(o, d)
        every = w.cast_ray_all(o, d)
        some = w.cast_ray_any(o, d)
        assert (closest is None) == (len(every) == 0) == (some is None)
        if closest is None:
            continue
        first = every[0]
        assert (first.body, first.distance, first.feature) == (closest.body, closest.distance, closest.feature)
        assert np.array_equal(first.point, closest.point) and np.array_equal(first.normal, closest.normal)
        assert [h.distance for h in every] == sorted(h.distance for h in every)
        assert len({h.body for h in every}) == len(every)
        assert any(h.body == some.body and h.distance == some.distance for h in every)


def test_masks_and_exclusions():
    w = world()
    a = w.add_static(sg.Box((1, 1, 0.1)), position=(0, 0, 0))
    b = w.add_static(sg.Box((1, 1, 0.1)), position=(0, 0, 1))
    w.set_collision_filter(b, group=2)
    hit = lambda **kw: w.cast_ray((0, 0, 5), (0, 0, -1), **kw)  # noqa: E731
    assert hit().body == b
    assert hit(mask=1).body == a  # b's group 2 is not in the mask
    assert hit(exclude=[b]).body == a
    assert hit(exclude=[a, b]) is None
    w.set_collision_filter(a, group=1, mask=2)  # a sees only group 2: a query of group 1 misses it
    assert hit(mask=1, group=1) is None
    assert hit(mask=1, group=2).body == a
    w.set_enabled(b, False)
    assert hit().body == a  # a disabled body is never hit
    assert (w.cast_rays([[0, 0, 5]], [[0, 0, -1]], exclude=[a]).body == -1).all()


def test_misses_give_none_and_minus_one():
    w = world()
    w.add_static(sg.Sphere(0.5), position=(0, 0, 0))
    assert w.cast_ray((0, 0, 5), (0, 0, 1)) is None
    assert w.cast_ray((0, 0, 5), (0, 0, -1), max_distance=4.4) is None
    assert w.cast_ray((0, 0, 5), (0, 0, -1), max_distance=4.5).distance == 4.5
    assert w.cast_ray_all((3, 0, 0), (0, 1, 0)) == []
    r = w.cast_rays([[0, 0, 5], [0, 0, 5]], [[0, 0, 1], [0, 0, -1]])
    assert r.body.tolist() == [-1, 0] and r.distance[0] == math.inf and (r.point[0] == 0).all()
    assert r.body.dtype == np.int32 and r.point.shape == (2, 3) and not r.body.flags.writeable


def test_sleeping_and_moved_bodies_are_seen_where_they_are():
    w = sg.World()
    w.add_static(sg.Plane((0, 0, 1), 0))
    i = w.add_body(sg.Box((0.2, 0.2, 0.2)), density=100, position=(0, 0, 0.2))
    w.step(1 / 60, 120)
    assert not w.awake[i]
    z = w.positions[i, 2]
    h = w.cast_ray((0, 0, 3), (0, 0, -1))
    assert h.body == i and abs(h.distance - (3 - z - 0.2)) <= 1e-9
    j = w.add_body(sg.Sphere(0.1), density=100, position=(5, 0, 1))
    w.step(1 / 60)
    w.set_position(j, (0, 0, 2))  # moved between steps: the query sees it there
    assert w.cast_ray((0, 0, 3), (0, 0, -1)).body == j


def test_the_broad_phase_prunes_a_world_of_10000_static_boxes():
    w = sg.World()
    n = 100
    for i in range(n):
        for j in range(n):
            w.add_static(sg.Box((0.2, 0.2, 0.2)), position=(i, j, 0))
    h = w.cast_ray((10.0, 20.0, 5.0), (0, 0, -1))
    assert h.body == 10 * n + 20 and abs(h.distance - 4.8) <= REL * 4.8
    stats = w.query_stats
    assert stats["queries"] == 1
    assert stats["body_tests"] <= 4  # one box under the ray (a few boxes' grown AABBs at most)
    assert stats["nodes"] < 400  # a tree of 10,000 leaves has 19,999 nodes: a scan would test all
    # a long ray along a row tests only that row's boxes (and stops at the first)
    w.cast_ray((-5.0, 3.0, 0.0), (1, 0, 0))
    assert w.query_stats["body_tests"] <= 3
    assert len(w.cast_ray_all((-5.0, 3.0, 0.0), (1, 0, 0))) == n
    assert n <= w.query_stats["body_tests"] <= 3 * n
    # overlaps too: a box around one body tests the few bodies whose tree boxes reach it
    assert w.overlap_aabb((9.9, 19.9, -0.1), (10.1, 20.1, 0.1)).tolist() == [10 * n + 20]
    assert w.query_stats["body_tests"] <= 4 and w.query_stats["nodes"] < 400
    assert w.overlap_point((10.0, 20.0, 0.0)).tolist() == [10 * n + 20] and w.query_stats["body_tests"] <= 4


# ---- overlaps and distances ----

def sphere_field(seed=10, n=60):
    rng = np.random.default_rng(seed)
    w = world()
    C = rng.uniform(-3, 3, (n, 3))
    R = rng.uniform(0.1, 0.4, n)
    for c, r in zip(C, R):
        w.add_static(sg.Sphere(r), position=c)
    return w, C, R


def test_overlap_of_a_sphere_a_box_and_a_point_against_closed_forms():
    w, C, R = sphere_field()
    rng = np.random.default_rng(11)
    for _ in range(30):
        p, r = rng.uniform(-3, 3, 3), rng.uniform(0.2, 1.5)
        d = np.linalg.norm(C - p, axis=1)
        got = w.overlap(sg.Sphere(r), p)
        ref = np.flatnonzero(d < R + r)
        assert got.tolist() == ref.tolist()
        lo, hi = p - rng.uniform(0.1, 1, 3), p + rng.uniform(0.1, 1, 3)
        q = np.clip(C, lo, hi)
        ref = np.flatnonzero(np.linalg.norm(C - q, axis=1) < R)
        assert w.overlap_aabb(lo, hi).tolist() == ref.tolist()
        ref = np.flatnonzero(d <= R)
        assert w.overlap_point(p).tolist() == ref.tolist()
    # a rotated box against the spheres, by the box's closest point
    q = random_quat(rng)
    Rm, h = quat_to_matrix(q), np.array([1.0, 0.3, 0.5])
    got = w.overlap(sg.Box(h), (0.5, 0, 0), q)
    local = (C - [0.5, 0, 0]) @ Rm
    ref = np.flatnonzero(np.linalg.norm(local - np.clip(local, -h, h), axis=1) < R)
    assert got.tolist() == ref.tolist() and len(ref) > 0


def test_overlap_sees_planes_triangle_meshes_and_respects_filters():
    w = world()
    plane = w.add_static(sg.Plane((0, 0, 1), 0))
    V = np.array([[-1, -1, 1], [1, -1, 1], [0, 1, 1]], dtype=float)
    mesh = w.add_static(sg.TriangleMesh(V, np.array([[0, 1, 2]])))
    assert w.overlap(sg.Sphere(0.5), (0, 0, 0.4)).tolist() == [plane]
    assert w.overlap(sg.Sphere(0.3), (0, 0, 0.6)).tolist() == []  # 0.3 above the plane, 0.4 below the triangle
    assert w.overlap(sg.Sphere(0.5), (0, 0, 1.2)).tolist() == [mesh]
    assert w.overlap(sg.Sphere(0.5), (0, 0, 0.4), exclude=[plane]).tolist() == []
    assert w.overlap_point((3, 3, -0.1)).tolist() == [plane]
    assert w.overlap_point((0, 0, 1)).tolist() == []  # a triangle mesh contains no point


def test_distance_between_bodies_against_closed_forms():
    w = world()
    a = w.add_body(sg.Sphere(0.5), density=1, position=(0, 0, 0))
    b = w.add_body(sg.Sphere(0.25), density=1, position=(1, 2, 2))
    c = w.add_static(sg.Box((1, 1, 1)), position=(5, 0, 0))
    p = w.add_static(sg.Plane((0, 0, 1), -2))
    d = w.distance(a, b)
    assert abs(d.distance - (3 - 0.75)) <= EXACT
    assert np.allclose(d.normal, [1 / 3, 2 / 3, 2 / 3], atol=1e-12)
    assert np.allclose(d.point_a, 0.5 * d.normal) and np.allclose(d.point_b, [1, 2, 2] - 0.25 * d.normal)
    d = w.distance(c, a)  # from the box to the sphere: normal -x
    assert abs(d.distance - 3.5) <= EXACT and np.allclose(d.normal, [-1, 0, 0])
    d = w.distance(a, p)
    assert abs(d.distance - 1.5) <= EXACT and np.allclose(d.normal, [0, 0, -1], atol=1e-12)
    w.set_position(b, (0.5, 0, 0))  # overlapping by 0.25
    d = w.distance(a, b)
    assert abs(d.distance + 0.25) <= EXACT and np.allclose(d.point_b - d.point_a, d.distance * d.normal)
    V = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0.0]])
    m = w.add_static(sg.TriangleMesh(V, np.array([[0, 1, 2]])), position=(0, 0, -3))
    assert abs(w.distance(m, a).distance - 2.5) <= EXACT
    w.set_position(a, (0, 0, -4))
    with pytest.raises(RuntimeError, match="one-sided"):
        w.distance(m, a)


# ---- bad input ----

def test_bad_input_names_the_argument_and_changes_nothing():
    w = mixed_scene(n=1)
    before = w.save_state()
    cases = [
        (lambda: w.cast_ray((math.nan, 0, 0), (0, 0, 1)), ValueError, "origin"),
        (lambda: w.cast_ray((0, 0, 0), (0, 0, 0)), ValueError, "direction"),
        (lambda: w.cast_ray((0, 0, 0), (0, math.inf, 0)), ValueError, "direction"),
        (lambda: w.cast_ray((0, 0, 0), (0, 0, 1), -1.0), ValueError, "max_distance"),
        (lambda: w.cast_ray((0, 0, 0), (0, 0, 1), math.nan), ValueError, "max_distance"),
        (lambda: w.cast_ray((0, 0), (0, 0, 1)), ValueError, "origin"),
        (lambda: w.cast_ray((0, 0, 0), (0, 0, 1), exclude=[99]), sg.BodyIndexError, "exclude"),
        (lambda: w.cast_ray((0, 0, 0), (0, 0, 1), mask=-1), TypeError, "mask"),
        (lambda: w.cast_ray_all((0, 0, 0), (0, 0, 0)), ValueError, "direction"),
        (lambda: w.cast_ray_any((0, 0, 0), (0, 0, 1), exclude=[-1]), sg.BodyIndexError, "exclude"),
        (lambda: w.cast_rays(np.zeros((3, 2)), np.ones((3, 3))), ValueError, "origins"),
        (lambda: w.cast_rays(np.zeros((3, 3)), np.ones((2, 3))), ValueError, "directions"),
        (lambda: w.cast_rays(np.zeros((3, 3)), np.ones((3, 3)), [1.0, 2.0]), ValueError, "max_distance"),
        (lambda: w.cast_rays(np.zeros((3, 3)), [[0, 0, 1], [0, 0, 0], [1, 0, 0]]), ValueError, "direction row 1"),
        (lambda: w.cast_rays([[0, 0, math.nan]], [[0, 0, 1]]), ValueError, "origin row 0"),
        (lambda: w.cast_rays(np.zeros((2, 3)), np.ones((2, 3)), [1.0, -2.0]), ValueError, "max_distance row 1"),
        (lambda: w.overlap(sg.Plane((0, 0, 1), 0)), ValueError, "shape"),
        (lambda: w.overlap(sg.Sphere(1), (0, math.nan, 0)), ValueError, "position"),
        (lambda: w.overlap(sg.Sphere(1), (0, 0, 0), (0, 0, 0, 0)), ValueError, "orientation"),
        (lambda: w.overlap("sphere"), TypeError, "shape"),
        (lambda: w.overlap_aabb((0, 0, 0), (1, -1, 1)), ValueError, "lo"),
        (lambda: w.overlap_aabb((0, 0, math.inf), (1, 1, 1)), ValueError, "lo"),
        (lambda: w.overlap_point((0, 0)), ValueError, "point"),
        (lambda: w.distance(0, 999), sg.BodyIndexError, "999"),
        (lambda: w.distance(2, 2), ValueError, "same body"),
        (lambda: w.distance(0, 1), ValueError, "planes or triangle meshes"),
    ]
    for call, error, word in cases:
        with pytest.raises(error, match=word):
            call()
    assert w.save_state().data == before.data
    assert w.num_bodies == 2 + 6


@pytest.mark.slow
def test_a_batch_of_100000_rays_gives_exactly_the_single_ray_results():
    """The issue's acceptance figure (100,000 rays on 2 threads; about 20 s of single casts)."""
    rng = np.random.default_rng(12)
    w = mixed_scene(threads=2, n=20)
    n = 100_000
    O = rng.uniform(-4, 4, (n, 3)) + [0, 0, 2]
    D = rng.normal(size=(n, 3))
    b = w.cast_rays(O, D, 12.0)
    assert 20_000 < (b.body >= 0).sum() < n
    for k in range(n):
        h = w.cast_ray(O[k], D[k], 12.0)
        if h is None:
            assert b.body[k] == -1
        else:
            assert (b.body[k], b.distance[k], b.feature[k]) == (h.body, h.distance, h.feature)
            assert np.array_equal(b.point[k], h.point) and np.array_equal(b.normal[k], h.normal)


# ---- every shape kind at random poses against the oracle's brute force ----

def oracle_shapes(rng):
    hull_pts = rng.normal(size=(12, 3)) * 0.4
    V = np.array([[x, y, z] for x in (-0.4, 0.4) for y in (-0.3, 0.3) for z in (-0.2, 0.2)])
    return [
        sg.Sphere(0.45), sg.Box((0.5, 0.3, 0.2)), sg.Capsule(0.2, 0.4), sg.Cylinder(0.35, 0.25),
        sg.ConvexHull(hull_pts), sg.Mesh(V, sg.ConvexHull(V).faces),
        sg.Compound([(sg.Box((0.3, 0.1, 0.1)), ((0.2, 0, 0), random_quat(rng))),
                     (sg.Cylinder(0.1, 0.3), ((-0.2, 0.1, 0), random_quat(rng))),
                     (sg.Capsule(0.1, 0.2), ((0, -0.2, 0.1), random_quat(rng)))]),
        ("L", None),  # a non-convex mesh with two convex pieces (as a decomposition gives them)
    ]


@pytest.mark.parametrize("k", range(8))
def test_every_solid_kind_at_random_poses_agrees_with_the_oracle(k):
    from signorini.oracle import rays as orays
    rng = np.random.default_rng(20 + k)
    shape = oracle_shapes(rng)[k]
    w = world()
    q, p = random_quat(rng), rng.uniform(-1, 1, 3)
    if isinstance(shape, tuple):  # an L-shaped static mesh hit through its two convex pieces
        A = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.2, 0.2) for z in (-0.2, 0.2)])
        B = A[:, [1, 0, 2]] + [0.3, 0.5, 0]
        FA = sg.ConvexHull(A).faces
        FB = sg.ConvexHull(B).faces
        surface = sg.Mesh(np.vstack([sg.ConvexHull(A).vertices, sg.ConvexHull(B).vertices]),
                          np.vstack([FA, FB + len(sg.ConvexHull(A).vertices)]))
        i = w.add_static(surface.with_pieces([A, B]), position=p, orientation=q)
    else:
        i = w.add_static(shape, position=p, orientation=q)
    d = sg.shape_dict(w.shape(i))
    R, P = quat_to_matrix(w.orientations[i]), np.asarray(w.positions[i])
    hits = 0
    for _ in range(40):
        o = P + 3.0 * unit(rng.normal(size=3))
        for target in (P + rng.uniform(-0.1, 0.1, 3), P + rng.uniform(-0.8, 0.8, 3)):
            u = unit(target - o)
            h = w.cast_ray(o, u, 8.0)
            ref = orays.first_entry(d, R, P, o, u, 8.0)
            if ref is None:
                continue  # the oracle may miss a grazing chord shorter than its sampling
            hits += 1
            assert h is not None and h.body == i
            assert abs(h.distance - ref) <= EXACT, (h.distance, ref)
            # the normal is out of the body: a step along it leaves, a step against it enters
            assert not orays.contains(d, R, P, h.point + 1e-6 * h.normal)
            assert orays.contains(d, R, P, h.point - 1e-6 * h.normal)
    assert hits >= 25


def test_triangle_meshes_at_random_poses_agree_with_the_oracle():
    from signorini.oracle import rays as orays
    rng = np.random.default_rng(30)
    n = 12
    xs = np.linspace(-1, 1, n + 1)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    Z = 0.2 * np.sin(3 * X) * np.cos(2 * Y)  # a bumpy terrain
    V = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    idx = lambda i, j: i * (n + 1) + j  # noqa: E731
    F = np.array([[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)] for i in range(n) for j in range(n)]
                 + [[idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)] for i in range(n) for j in range(n)])
    q, p = random_quat(rng), rng.uniform(-1, 1, 3)
    w = world()
    w.add_static(sg.TriangleMesh(V, F), position=p, orientation=q)
    R = quat_to_matrix(w.orientations[0])
    hits = 0
    for _ in range(150):
        o = p + 3.0 * unit(rng.normal(size=3))
        u = unit(p + rng.uniform(-0.7, 0.7, 3) - o)
        h = w.cast_ray(o, u, 8.0)
        ref = orays.triangle_entry(V, F, R, p, o, u, 8.0)
        assert (h is None) == (ref is None)
        if ref is None:
            continue
        hits += 1
        assert abs(h.distance - ref[0]) <= EXACT
        # the triangle named by the feature is met at that distance (through a shared edge, either)
        mine = orays.triangle_entry(V, F[[sg.feature(h.feature).part]], R, p, o, u, 8.0)
        assert mine is not None and abs(mine[0] - h.distance) <= EXACT
        a, b, c = (V[F[sg.feature(h.feature).part]] @ R.T) + p
        n_tri = unit(np.cross(b - a, c - a))
        assert np.allclose(h.normal, n_tri if n_tri @ u < 0 else -n_tri, atol=1e-12)
    assert hits > 50
