"""Mesh generators: closed, outward oriented, right topology, right volume.

The volumes are checked against closed forms derived for the discrete meshes (see the docstrings
in signorini.meshes), not against tolerances tuned to the output.
"""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from signorini import meshes


def directed_edges(faces):
    """(3k, 2) directed edges (a, b) of the faces (k, 3), in face order."""
    f = np.asarray(faces)
    return np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])


def assert_closed_and_consistent(vertices, faces):
    """every directed edge once, its reverse once; no degenerate faces; every vertex used."""
    assert vertices.dtype == np.float64 and vertices.ndim == 2 and vertices.shape[1] == 3
    assert faces.dtype == np.int64 and faces.ndim == 2 and faces.shape[1] == 3
    edges = directed_edges(faces)
    as_set = {tuple(e) for e in edges.tolist()}
    assert len(as_set) == len(edges), "a directed edge appears twice (inconsistent winding)"
    missing = [e for e in as_set if (e[1], e[0]) not in as_set]
    assert not missing, f"edges without a reverse (holes): {missing[:5]}"
    assert np.all(faces[:, 0] != faces[:, 1]) and np.all(faces[:, 1] != faces[:, 2])
    assert np.all(faces[:, 2] != faces[:, 0])
    v0, v1, v2 = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    assert np.all(np.linalg.norm(np.cross(v1 - v0, v2 - v0), axis=1) > 0)
    assert set(np.unique(faces).tolist()) == set(range(len(vertices)))


def euler_characteristic(vertices, faces):
    """V - E + F, counting each undirected edge once."""
    undirected = {tuple(sorted(e)) for e in directed_edges(faces).tolist()}
    return len(vertices) - len(undirected) + len(faces)


def face_normals_and_centroids(vertices, faces):
    """(k, 3) unnormalised normals (v1 - v0) x (v2 - v0) and (k, 3) centroids."""
    v0, v1, v2 = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    return np.cross(v1 - v0, v2 - v0), (v0 + v1 + v2) / 3.0


# torus


@pytest.mark.parametrize("n_major,n_minor", [(3, 3), (8, 5), (32, 16), (64, 24)])
def test_torus_closed_genus_one(n_major, n_minor):
    v, f = meshes.torus(1.0, 0.3, n_major, n_minor)
    assert v.shape == (n_major * n_minor, 3) and f.shape == (2 * n_major * n_minor, 3)
    assert_closed_and_consistent(v, f)
    assert euler_characteristic(v, f) == 0


def test_torus_vertices_on_the_smooth_surface():
    R, r = 0.04, 0.015
    v, _ = meshes.torus(R, r, 20, 10)
    rho = np.hypot(v[:, 0], v[:, 1])
    np.testing.assert_allclose((rho - R) ** 2 + v[:, 2] ** 2, r**2, rtol=1e-12)


def test_torus_faces_point_out_of_the_tube():
    R, r = 1.0, 0.4
    v, f = meshes.torus(R, r, 24, 12)
    normal, centroid = face_normals_and_centroids(v, f)
    # nearest point of the tube's centre circle
    rho = np.hypot(centroid[:, 0], centroid[:, 1])
    core = np.column_stack([R * centroid[:, 0] / rho, R * centroid[:, 1] / rho, np.zeros(len(f))])
    assert np.all(np.einsum("ij,ij->i", normal, centroid - core) > 0)


@pytest.mark.parametrize("n_major,n_minor", [(3, 3), (7, 4), (32, 16), (100, 50)])
def test_torus_volume_is_the_exact_polyhedral_volume(n_major, n_minor):
    R, r = 0.04, 0.015
    v, f = meshes.torus(R, r, n_major, n_minor)
    exact = meshes.torus_mesh_volume(R, r, n_major, n_minor)
    assert meshes.signed_volume(v, f) == pytest.approx(exact, rel=1e-12)

    # below the smooth torus, by at most (2 pi^2 / 3)(1/n_major^2 + 1/n_minor^2) (sin x >= x - x^3/6)
    smooth = 2.0 * math.pi**2 * R * r**2
    bound = (2.0 * math.pi**2 / 3.0) * (1.0 / n_major**2 + 1.0 / n_minor**2)
    assert 0.0 < smooth - exact <= bound * smooth


def test_torus_volume_increases_towards_the_smooth_volume():
    R, r = 2.0, 0.5
    smooth = 2.0 * math.pi**2 * R * r**2
    volumes = [meshes.signed_volume(*meshes.torus(R, r, n, n // 2)) for n in (16, 32, 64, 128, 256)]
    assert all(a < b < smooth for a, b in zip(volumes, volumes[1:]))
    # second order: halving the spacing divides the error by about four
    errors = smooth - np.array(volumes)
    ratios = errors[:-1] / errors[1:]
    assert np.all((ratios > 3.5) & (ratios < 4.5)), ratios


def test_torus_rejects_bad_arguments():
    with pytest.raises(ValueError, match="minor_radius"):
        meshes.torus(0.1, 0.2)
    with pytest.raises(ValueError, match="major_radius"):
        meshes.torus(-1.0, 0.2)
    with pytest.raises(ValueError, match="n_minor"):
        meshes.torus(1.0, 0.2, 8, 2)


# icosphere


@pytest.mark.parametrize("subdivisions", [0, 1, 2, 3])
def test_icosphere_closed_genus_zero(subdivisions):
    v, f = meshes.icosphere(0.7, subdivisions)
    assert v.shape == (10 * 4**subdivisions + 2, 3) and f.shape == (20 * 4**subdivisions, 3)
    assert_closed_and_consistent(v, f)
    assert euler_characteristic(v, f) == 2
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 0.7, rtol=1e-13)


@pytest.mark.parametrize("subdivisions", [0, 1, 2, 3])
def test_icosphere_volume_between_inscribed_and_circumscribing_balls(subdivisions):
    r = 0.7
    v, f = meshes.icosphere(r, subdivisions)
    normal, centroid = face_normals_and_centroids(v, f)
    unit = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    # each face faces away from the centre (convex, outward)
    distance = np.einsum("ij,ij->i", unit, centroid)
    assert np.all(distance > 0)
    # convex and inscribed: contains the ball of radius min distance, inside the sphere
    volume = meshes.signed_volume(v, f)
    assert 4.0 / 3.0 * math.pi * distance.min() ** 3 < volume < 4.0 / 3.0 * math.pi * r**3


def test_icosphere_volume_converges_at_second_order():
    smooth = 4.0 / 3.0 * math.pi
    errors = np.array([smooth - meshes.signed_volume(*meshes.icosphere(1.0, s)) for s in range(1, 5)])
    assert np.all(errors > 0)
    ratios = errors[:-1] / errors[1:]
    assert np.all((ratios > 3.5) & (ratios < 4.5)), ratios


# box and cylinder


def test_box_mesh_corner_order_volume_and_topology():
    a, b, c = 0.5, 0.25, 2.0
    v, f = meshes.box_mesh((a, b, c))
    assert v.shape == (8, 3) and f.shape == (12, 3)
    assert_closed_and_consistent(v, f)
    assert euler_characteristic(v, f) == 2
    # conventions: corner k = (sx a, sy b, sz c), sx = + if k & 1, sy = + if k & 2, sz = + if k & 4
    for k in range(8):
        expected = [a if k & 1 else -a, b if k & 2 else -b, c if k & 4 else -c]
        np.testing.assert_array_equal(v[k], expected)
    assert meshes.signed_volume(v, f) == pytest.approx(8 * a * b * c, rel=1e-14)
    normal, centroid = face_normals_and_centroids(v, f)
    assert np.all(np.einsum("ij,ij->i", normal, centroid) > 0)


def test_box_mesh_rejects_flat_box():
    with pytest.raises(ValueError, match="c must be"):
        meshes.box_mesh((1.0, 1.0, 0.0))


@pytest.mark.parametrize("n", [3, 4, 17, 64])
def test_cylinder_mesh_is_a_closed_prism(n):
    r, h = 0.3, 0.8
    v, f = meshes.cylinder_mesh(r, h, n)
    assert v.shape == (2 * n + 2, 3) and f.shape == (4 * n, 3)
    assert_closed_and_consistent(v, f)
    assert euler_characteristic(v, f) == 2
    exact = meshes.cylinder_mesh_volume(r, h, n)
    assert meshes.signed_volume(v, f) == pytest.approx(exact, rel=1e-12)
    assert exact < math.pi * r**2 * 2 * h
    normal, centroid = face_normals_and_centroids(v, f)
    assert np.all(np.einsum("ij,ij->i", normal, centroid) > 0)


def test_signed_volume_flips_with_the_winding():
    v, f = meshes.icosphere(1.0, 1)
    assert meshes.signed_volume(v, f[:, ::-1]) == pytest.approx(-meshes.signed_volume(v, f))


# drawing helpers


def test_posed_applies_rotation_then_translation():
    q = (math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))
    out = meshes.posed([[1.0, 0.0, 0.0], [0.0, 0.0, 2.0]], (10.0, 0.0, 0.0), q)
    np.testing.assert_allclose(out, [[10.0, 1.0, 0.0], [10.0, 0.0, 2.0]], atol=1e-15)


def test_render_mesh_by_shape_attributes():
    v, f = meshes.render_mesh(SimpleNamespace(radius=0.2))
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 0.2)
    v, f = meshes.render_mesh(SimpleNamespace(half_extents=(1.0, 2.0, 3.0)))
    assert np.abs(v).max(axis=0).tolist() == [1.0, 2.0, 3.0]
    tv, tf = meshes.torus(1.0, 0.2, 6, 4)
    v, f = meshes.render_mesh(SimpleNamespace(vertices=tv, faces=tf))
    np.testing.assert_array_equal(f, tf)
    assert meshes.render_mesh(SimpleNamespace(normal=(0, 0, 1), offset=0.0)) is None
    with pytest.raises(TypeError, match="str"):
        meshes.render_mesh("not a shape")


def test_meshes_module_does_not_import_the_oracle():
    # the oracle checks the core independently; drawing and test meshes must not lean on it
    import subprocess
    import sys

    code = "import sys, signorini.meshes; print('signorini.oracle' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
