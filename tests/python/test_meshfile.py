"""Mesh files: OBJ, STL, PLY, OFF and GLB written by trimesh's exporters and read back by
``sg.load_mesh``; volumes against closed forms; bad files give errors naming the file."""
import math

import numpy as np
import pytest

import signorini as sg
from signorini import meshes

trimesh = pytest.importorskip("trimesh")

FORMATS = ["obj", "stl", "ply", "off", "glb"]


def write(tmp_path, name, vertices, faces):
    path = tmp_path / name
    trimesh.Trimesh(vertices, faces, process=False).export(str(path))
    return path


@pytest.mark.parametrize("fmt", FORMATS)
def test_unit_cube_reads_back_with_8_vertices_and_volume_1(tmp_path, fmt):
    v, f = meshes.box_mesh((0.5, 0.5, 0.5))
    mesh = sg.load_mesh(write(tmp_path, f"cube.{fmt}", v, f))
    assert isinstance(mesh, sg.Mesh)
    assert len(mesh.vertices) == 8 and len(mesh.faces) == 12
    mass, com, inertia = sg.mass_properties(mesh, density=1.0)
    assert mass == pytest.approx(1.0, rel=1e-12)          # volume of the unit cube
    np.testing.assert_allclose(com, 0.0, atol=1e-12)
    np.testing.assert_allclose(inertia, np.eye(3) / 6.0, atol=1e-12)   # m (a^2 + a^2) / 12, a = 1


@pytest.mark.parametrize("fmt", FORMATS)
def test_icosphere_volume_and_scale(tmp_path, fmt):
    r, s = 0.3, 2
    v, f = meshes.icosphere(r, s)
    path = write(tmp_path, f"ball.{fmt}", v, f)
    mesh = sg.load_mesh(path, scale=2.0)
    assert len(mesh.vertices) == 10 * 4**s + 2 and len(mesh.faces) == 20 * 4**s
    # the scaled mesh's volume is 8 times the polyhedron's, which lies below the sphere's 4/3 pi r^3
    volume = sg.mass_properties(mesh, density=1.0)[0]
    assert volume == pytest.approx(8.0 * meshes.signed_volume(v, f), rel=1e-6)   # STL stores float32
    assert 8.0 * 4.0 / 3.0 * math.pi * (0.9 * r) ** 3 < volume < 8.0 * 4.0 / 3.0 * math.pi * r**3
    np.testing.assert_allclose(np.linalg.norm(mesh.vertices, axis=1), 2.0 * r, rtol=1e-6)


def test_static_gives_a_triangle_mesh_and_open_meshes_are_fine_there(tmp_path):
    # a 2 x 2 open square floor: a TriangleMesh need not be closed
    v = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], dtype=float)
    f = np.array([(0, 1, 2), (0, 2, 3)])
    floor = sg.load_mesh(write(tmp_path, "floor.obj", v, f), static=True)
    assert isinstance(floor, sg.TriangleMesh) and len(floor.faces) == 2
    w = sg.World()
    w.add_static(floor)
    # the same open square as a dynamic body: add_body names the body and the problem
    with pytest.raises(ValueError, match="body 1"):
        w.add_body(sg.load_mesh(tmp_path / "floor.obj"), density=1.0)
    assert w.num_bodies == 1


def test_npz_mesh_files_are_exact_and_keep_convex_pieces(tmp_path):
    v, f = meshes.torus(0.1, 0.03, 16, 8)
    pieces = [v[v[:, 0] > 0.0], v[v[:, 0] <= 0.0]]
    path = sg.meshfile.write_npz_mesh(tmp_path / "torus.npz", v, f, pieces)
    mesh = sg.load_mesh(path)
    np.testing.assert_array_equal(mesh.vertices, v)
    np.testing.assert_array_equal(mesh.faces, f)
    assert len(mesh.pieces) == 2


def test_missing_empty_unknown_and_broken_files_name_the_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.obj"):
        sg.load_mesh(tmp_path / "nothing.obj")
    (tmp_path / "empty.stl").write_bytes(b"")
    with pytest.raises(ValueError, match=r"empty\.stl.*empty"):
        sg.load_mesh(tmp_path / "empty.stl")
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(ValueError, match=r"notes\.txt.*unknown mesh format"):
        sg.load_mesh(tmp_path / "notes.txt")
    (tmp_path / "broken.glb").write_bytes(b"glTF\x02\x00\x00\x00garbage")
    with pytest.raises(ValueError, match=r"broken\.glb"):
        sg.load_mesh(tmp_path / "broken.glb")
    # an OBJ with vertices but no faces
    (tmp_path / "points.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(ValueError, match=r"points\.obj"):
        sg.load_mesh(tmp_path / "points.obj")
    with pytest.raises(ValueError, match=r"scale must be a finite number > 0"):
        sg.load_mesh(tmp_path / "points.obj", scale=0.0)
    (tmp_path / "bad.npz").write_bytes(b"PK\x03\x04 not a zip")
    with pytest.raises(ValueError, match=r"bad\.npz"):
        sg.load_mesh(tmp_path / "bad.npz")
