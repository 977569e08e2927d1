"""The new shapes from Python: core against oracle mass properties, bad input, Compound and Mesh
piece round trips, re-centring of dynamic hulls and compounds, static-only triangle meshes."""
import numpy as np
import pytest

import signorini as sg
from signorini import oracle
from signorini import meshes

RNG = np.random.default_rng(20240611)


def box_mesh(half_extents):
    return sg.Mesh(*meshes.box_mesh(half_extents))


def quat(axis, angle):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def cloud(n=60, scale=(1.0, 0.6, 0.4), shift=(0.0, 0.0, 0.0)):
    return RNG.normal(size=(n, 3)) * scale + shift


def assert_mass_close(core, ref, rel=1e-12):
    """mass and inertia within rel of their size, com within rel of the inertia's length scale."""
    (m, com, I), (m_ref, com_ref, I_ref) = core, ref
    assert m == pytest.approx(m_ref, rel=rel)
    length = np.sqrt(np.abs(I_ref).max() / m_ref)
    assert np.abs(com - com_ref).max() <= rel * max(length, np.abs(com_ref).max())
    assert np.abs(I - I_ref).max() <= rel * np.abs(I_ref).max()


def world_state(w):
    s = w.snapshot()
    return (w.num_bodies, w.time, s["position"].tobytes(), s["rotation"].tobytes(), w.masses.tobytes())


# core against the oracle -------------------------------------------------------------------------

def mixed_compound():
    return sg.Compound([
        (sg.Box((0.5, 0.2, 0.1)), ((0.3, 0.0, 0.0), quat((0, 0, 1), 0.3))),
        (sg.Capsule(0.1, 0.4), ((-0.2, 0.5, 0.1), quat((1, 1, 0), 1.1))),
        (sg.Cylinder(0.2, 0.05), ((0.0, -0.4, 0.3), (1.0, 0.0, 0.0, 0.0))),
        (sg.Sphere(0.15), ((0.6, 0.6, -0.2), (0.0, 0.0, 1.0, 0.0))),
        (sg.ConvexHull(cloud(30, shift=(2.0, 0.0, 0.0))), ((0.0, 0.0, -1.0), quat((0.2, -1, 0.5), 2.0))),
    ])


@pytest.mark.parametrize("shape", [
    sg.Capsule(0.3, 0.8), sg.Capsule(0.7, 0.0), sg.Cylinder(0.4, 0.9), sg.Cylinder(2.0, 0.01),
    sg.ConvexHull(cloud()), sg.ConvexHull(cloud(shift=(1.0, -2.0, 0.5))), mixed_compound(),
], ids=repr)
def test_core_mass_properties_match_the_oracle(shape):
    core = sg.mass_properties(shape, 850.0)
    ref = oracle.mass_properties(sg.shape_dict(shape), density=850.0)
    assert_mass_close(core, ref)


def test_closed_forms_in_the_oracle():
    r, h, rho = 0.3, 0.8, 1200.0
    m, _, I = oracle.mass_properties_cylinder(r, h, rho)
    assert m == pytest.approx(rho * np.pi * r**2 * 2 * h, rel=1e-15)
    assert I[0, 0] == pytest.approx(m * (3 * r**2 + (2 * h)**2) / 12, rel=1e-14)
    assert I[2, 2] == pytest.approx(m * r**2 / 2, rel=1e-15)
    # a capsule of zero length is the sphere
    assert_mass_close(oracle.mass_properties_capsule(0.7, 0.0, rho), oracle.mass_properties_sphere(0.7, rho))
    # two boxes side by side are one box of double length
    pair = {"type": "compound", "parts": [({"type": "box", "half_extents": np.array([0.5, 0.3, 0.2])}, (-0.5, 0, 0), np.eye(3)),
                                          ({"type": "box", "half_extents": np.array([0.5, 0.3, 0.2])}, (0.5, 0, 0), np.eye(3))]}
    assert_mass_close(oracle.mass_properties(pair, density=rho), oracle.mass_properties_box((1.0, 0.3, 0.2), rho))
    assert oracle.shape_volume(pair) == pytest.approx(8 * 1.0 * 0.3 * 0.2, rel=1e-15)


def test_hull_of_a_box_mesh_has_the_box_properties():
    mesh = box_mesh((0.5, 1.0, 1.5))
    inside = RNG.uniform(-0.4, 0.4, size=(20, 3))
    hull = sg.ConvexHull(np.vstack([inside, np.array(mesh.vertices)]))
    assert hull.vertices.shape == (8, 3) and hull.faces.shape == (12, 3)
    assert_mass_close(sg.mass_properties(hull, 3.0), sg.mass_properties(sg.Box((0.5, 1.0, 1.5)), 3.0))


def test_given_mass_uses_the_volume_of_the_parts():
    c = mixed_compound()
    w = sg.World()
    i = w.add_body(c, mass=2.5)
    assert w.masses[i] == pytest.approx(2.5, rel=1e-14)
    m, _, I = oracle.mass_properties(sg.shape_dict(c), mass=2.5)
    assert m == pytest.approx(2.5, rel=1e-14)
    assert np.abs(w.inertias[i] - I).max() <= 1e-12 * np.abs(I).max()


def test_static_only_shapes_have_no_mass_anywhere():
    floor = sg.TriangleMesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    with pytest.raises(ValueError, match="TriangleMesh: a triangle mesh has no volume; it can only be static"):
        sg.mass_properties(floor, 1.0)
    with pytest.raises(ValueError, match="it can only be static"):
        oracle.mass_properties(sg.shape_dict(floor), density=1.0)


# bad input ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("make, error, message", [
    (lambda: sg.Capsule(-1.0, 1.0), ValueError, r"Capsule: radius must be positive and finite, got -1"),
    (lambda: sg.Capsule(1.0, float("nan")), ValueError, r"Capsule: half_length must be finite and >= 0, got nan"),
    (lambda: sg.Cylinder(1.0, 0.0), ValueError, r"Cylinder: half_height must be positive and finite, got 0"),
    (lambda: sg.ConvexHull(np.eye(3)), ValueError, r"ConvexHull: needs at least 4 points, got 3"),
    (lambda: sg.ConvexHull(np.zeros(6)), ValueError, r"ConvexHull: points must have shape \(n, 3\), got \(6,\)"),
    (lambda: sg.ConvexHull(np.zeros((5, 2))), ValueError, r"ConvexHull: points must have shape \(n, 3\), got \(5, 2\)"),
    (lambda: sg.ConvexHull([[0, 0, 0], [1, 0, 0], [0, np.nan, 0], [0, 0, 1]]), ValueError,
     r"ConvexHull: point 2 is not finite"),
    (lambda: sg.ConvexHull([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.5, 0]]), ValueError,
     r"ConvexHull: the points are coplanar \(the hull has no volume\)"),
    (lambda: sg.TriangleMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2], [2, 0, 1]]), ValueError,
     r"TriangleMesh: face 1 repeats face 0"),
    (lambda: sg.TriangleMesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]]), ValueError,
     r"TriangleMesh: face 0 is degenerate"),
    (lambda: sg.TriangleMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]]), ValueError,
     r"TriangleMesh: face 0 has vertex index 3 outside \[0, 3\)"),
    (lambda: sg.TriangleMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [0, 1, 2]), ValueError,
     r"TriangleMesh: faces must have shape \(k, 3\), got \(3,\)"),
    (lambda: sg.Compound([]), ValueError, r"Compound: needs at least one part"),
    (lambda: sg.Compound([(sg.Sphere(1.0), ((0, 0, 0), (1, 0, 0, 0))), (sg.Plane((0, 0, 1), 0.0), ((0, 0, 0), (1, 0, 0, 0)))]),
     TypeError, r"Compound: part 1: shape must be a Sphere, Box, Capsule, Cylinder, ConvexHull or convex Mesh, got Plane"),
    (lambda: sg.Compound([(sg.Sphere(1.0), ((0, 0, 0), (0, 0, 0, 0)))]), ValueError,
     r"Compound: part 0: orientation quaternion \(0, 0, 0, 0\) is zero"),
    (lambda: sg.Compound([(sg.Sphere(1.0), ((0, 0, 0), (1, 0, np.inf, 0)))]), ValueError,
     r"Compound: part 0: orientation quaternion must be finite"),
    (lambda: sg.Compound([(sg.Sphere(1.0), ((0, np.nan, 0), (1, 0, 0, 0)))]), ValueError,
     r"Compound: part 0: position must be finite"),
    (lambda: sg.Compound([(sg.Sphere(1.0), ((0, 0), (1, 0, 0, 0)))]), ValueError,
     r"Compound: part 0: position must have shape \(3,\), got \(2,\)"),
    (lambda: sg.Compound([(sg.Sphere(1.0), ((0, 0, 0), (1, 0, 0)))]), ValueError,
     r"Compound: part 0: orientation must have shape \(4,\), got \(3,\)"),
    (lambda: sg.Compound([(sg.Sphere(1.0), (0, 0, 0))]), TypeError, r"Compound: part 0: pose must be \(position, orientation\)"),
    (lambda: sg.Compound([sg.Sphere(1.0)]), TypeError, r"Compound: part 0 must be \(shape, \(position, orientation\)\)"),
])
def test_bad_input_names_the_problem(make, error, message):
    with pytest.raises(error, match=message):
        make()


def test_non_convex_mesh_part_and_bad_pieces_are_refused():
    torus = sg.Mesh(*meshes.torus(1.0, 0.3))
    with pytest.raises(ValueError, match="Compound: part 0: a Mesh part must be convex"):
        sg.Compound([(torus, ((0, 0, 0), (1, 0, 0, 0)))])
    mesh = box_mesh((1, 1, 1))
    with pytest.raises(ValueError, match=r"Mesh.with_pieces: piece 1: vertices must have shape \(n, 3\), got \(4, 2\)"):
        mesh.with_pieces([np.array(mesh.vertices), np.zeros((4, 2))])
    with pytest.raises(ValueError, match=r"Mesh.with_pieces: piece 0: ConvexHull: the points are coplanar"):
        mesh.with_pieces([np.array(mesh.vertices)[:4]])


# round trips -------------------------------------------------------------------------------------

def test_compound_round_trip():
    hull = sg.ConvexHull(cloud(20))
    given = [
        (sg.Box((0.5, 0.2, 0.1)), (np.array([0.3, 0.0, 0.0]), quat((0, 0, 1), 0.3))),
        (hull, (np.array([0.0, 1.0, 2.0]), 3.0 * quat((1, 2, 3), 0.7))),  # not unit: normalised
        (sg.Capsule(0.1, 0.4), (np.array([-1.0, 0.0, 0.0]), -quat((1, 0, 0), 1.0))),  # w < 0: same rotation
    ]
    c = sg.Compound(given)
    parts = c.parts
    assert len(parts) == 3
    assert [type(s) for s, _ in parts] == [sg.Box, sg.ConvexHull, sg.Capsule]
    for (s0, (p0, q0)), (s1, (p1, q1)), R in zip(given, parts, c.rotations):
        assert np.array_equal(p1, p0)
        q0 = q0 / np.linalg.norm(q0)
        q0 = q0 if q0[0] >= 0 else -q0
        assert np.allclose(q1, q0, rtol=0, atol=1e-15) and q1[0] >= 0
        assert np.allclose(R, oracle.quat_to_matrix(q0), rtol=0, atol=1e-15)
    assert np.array_equal(parts[1][0].vertices, hull.vertices)
    assert parts[2][0].radius == 0.1 and parts[2][0].half_length == 0.4
    # the parts as given back build the same compound (up to rounding of R -> q -> R)
    again = sg.Compound(parts)
    assert np.allclose(again.rotations, c.rotations, rtol=0, atol=1e-15)
    assert "Compound(3 parts: Box, ConvexHull, Capsule)" == repr(c)
    # a convex Mesh part becomes the hull of its vertices
    m = sg.Compound([(box_mesh((1, 2, 3)), ((0, 0, 0), (1, 0, 0, 0)))])
    (shape, _), = m.parts
    assert isinstance(shape, sg.ConvexHull) and shape.vertices.shape == (8, 3)
    d = sg.shape_dict(c)
    assert d["type"] == "compound" and len(d["parts"]) == 3
    assert d["parts"][1][0]["type"] == "hull" and d["parts"][2][0] == {"type": "capsule", "radius": 0.1, "half_length": 0.4}


def test_hull_and_pieces_are_read_only_and_canonical():
    points = cloud(40)
    hull = sg.ConvexHull(points)
    assert not hull.vertices.flags.writeable and not hull.faces.flags.writeable
    # hull vertices are input points in input order; the triangulation closes the hull
    rows = [int(np.flatnonzero((points == v).all(axis=1))[0]) for v in hull.vertices]
    assert rows == sorted(rows)
    assert hull.faces.shape == (2 * len(hull.vertices) - 4, 3)
    again = sg.ConvexHull(points)
    assert np.array_equal(again.vertices, hull.vertices) and np.array_equal(again.faces, hull.faces)
    # the volume agrees with SciPy's Qhull wrapper, an independent route to the same hull
    spatial = pytest.importorskip("scipy.spatial")
    assert oracle.shape_volume(sg.shape_dict(hull)) == pytest.approx(spatial.ConvexHull(points).volume, rel=1e-12)

    mesh = box_mesh((1, 1, 1))
    assert mesh.pieces == []
    a, b = cloud(10, shift=(-0.5, 0, 0)), cloud(12, shift=(0.5, 0, 0))
    split = mesh.with_pieces([a, b])
    assert len(split.pieces) == 2 and mesh.pieces == []
    assert np.array_equal(split.pieces[0], sg.ConvexHull(a).vertices)
    assert np.array_equal(split.pieces[1], sg.ConvexHull(b).vertices)
    assert not split.pieces[0].flags.writeable
    assert repr(split) == "Mesh(8 vertices, 12 faces, 2 convex pieces)"
    assert len(sg.shape_dict(split)["pieces"]) == 2


def test_triangle_mesh_edges_from_python():
    floor = sg.TriangleMesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    assert floor.active_edge.tolist() == [[True, True, False], [False, True, True]]
    assert np.array_equal(floor.normals, [[0, 0, 1], [0, 0, 1]])
    assert sg.shape_dict(floor)["type"] == "trimesh"


# the world ---------------------------------------------------------------------------------------

def test_dynamic_hull_is_recentred_on_its_com():
    points = cloud(30, shift=(2.0, -1.0, 0.5))
    hull = sg.ConvexHull(points)
    _, com, I = sg.mass_properties(hull, 500.0)
    w = sg.World()
    i = w.add_body(hull, density=500.0, position=(0.0, 0.0, 3.0))
    stored = w.shape(i)
    assert np.allclose(stored.vertices, hull.vertices - com, rtol=0, atol=1e-14)
    assert np.array_equal(stored.faces, hull.faces)
    _, com_after, I_after = sg.mass_properties(stored, 500.0)
    assert np.abs(com_after).max() <= 1e-14
    assert np.abs(I_after - I).max() <= 1e-12 * np.abs(I).max()
    assert np.array_equal(w.positions[i], [0.0, 0.0, 3.0])
    # a static hull stays where it was given
    j = w.add_static(hull)
    assert np.array_equal(w.shape(j).vertices, hull.vertices)


def test_dynamic_compound_and_mesh_pieces_are_recentred_on_the_com():
    c = mixed_compound()
    _, com, _ = sg.mass_properties(c, 1.0)
    w = sg.World()
    i = w.add_body(c, density=1.0, position=(1.0, 2.0, 3.0))
    for (_, (p0, q0)), (_, (p1, q1)) in zip(c.parts, w.shape(i).parts):
        assert np.allclose(p1, p0 - com, rtol=0, atol=1e-14)
        assert np.array_equal(q1, q0)
    assert np.abs(sg.mass_properties(w.shape(i), 1.0)[1]).max() <= 1e-14

    mesh = box_mesh((1.0, 0.5, 0.25))
    shifted = sg.Mesh(np.array(mesh.vertices) + (3.0, 0.0, 0.0), mesh.faces)
    pieces = [np.array(shifted.vertices)[[0, 1, 2, 3, 4, 5, 6, 7]]]
    j = w.add_body(shifted.with_pieces(pieces), density=1.0)
    stored = w.shape(j)
    assert np.allclose(stored.pieces[0], sg.ConvexHull(pieces[0]).vertices - (3.0, 0.0, 0.0), rtol=0, atol=1e-14)


def test_triangle_mesh_is_static_only_and_the_world_is_unchanged():
    w = sg.World()
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Sphere(0.5), density=1.0, position=(0, 0, 1))
    before = world_state(w)
    bowl = sg.TriangleMesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    with pytest.raises(ValueError, match=r"body 2 \(TriangleMesh\): a triangle mesh can only be static; use add_static"):
        w.add_body(bowl, density=1.0)
    assert world_state(w) == before
    assert w.add_static(bowl) == 2
