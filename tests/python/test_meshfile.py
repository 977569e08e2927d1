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
    # the same open square as a dynamic body: load_mesh names the file, the problem and the ways out
    with pytest.raises(ValueError, match=r"floor\.obj.*open.*repair=True.*static=True"):
        sg.load_mesh(tmp_path / "floor.obj")
    # and add_body names the body
    with pytest.raises(ValueError, match="body 1"):
        w.add_body(sg.Mesh(v, f), density=1.0)
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


# seams, repair and files of several objects -----------------------------------------------------

def write_obj(path, objects, keyword="o", seams=False):
    """An OBJ of named objects [(name, vertices, faces)]; with seams, every face corner gets its own
    texture coordinate and normal (as exporters write textured meshes), so positions repeat."""
    lines, base, corner = [], 1, 1
    for name, v, f in objects:
        lines.append(f"{keyword} {name}")
        lines += [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in v]
        for face in f:
            if seams:
                lines += [f"vt {0.1 * (corner + i) % 1:.3f} 0.5" for i in range(3)] + ["vn 0 0 1"]
                lines.append("f " + " ".join(f"{base + i}/{corner + k}/{(corner + 2) // 3}" for k, i in enumerate(face)))
                corner += 3
            else:
                lines.append("f " + " ".join(str(base + i) for i in face))
        base += len(v)
    path.write_text("\n".join(lines) + "\n")
    return path


def volume(shape):
    return sg.mass_properties(shape, density=1.0)[0]


CUBE_V, CUBE_F = meshes.box_mesh((0.5, 0.5, 0.5))


def test_texture_and_normal_seams_are_merged_into_one_closed_mesh(tmp_path):
    # each corner with its own texture coordinate: trimesh alone keeps the corners apart (open)
    path = write_obj(tmp_path / "textured.obj", [("cube", CUBE_V, CUBE_F)], seams=True)
    loaded = trimesh.load(str(path), force="mesh")
    assert len(loaded.vertices) > 8 and not loaded.is_watertight
    mesh = sg.load_mesh(path)
    assert len(mesh.vertices) == 8 and mesh.closedness_problem() == ""
    assert volume(mesh) == pytest.approx(1.0, rel=1e-12)


def test_materials_and_textures_named_by_an_obj_are_not_read(tmp_path, monkeypatch):
    # an OBJ naming a material library (and through it, textures): no file but the OBJ is opened
    opened = []
    monkeypatch.setattr(trimesh.resolvers.FilePathResolver, "get", lambda self, name: opened.append(name))
    (tmp_path / "cube.mtl").write_text("newmtl skin\nmap_Kd skin.png\n")
    path = write_obj(tmp_path / "cube.obj", [("cube", CUBE_V, CUBE_F)])
    path.write_text("mtllib cube.mtl\nusemtl skin\n" + path.read_text())
    assert len(sg.load_mesh(path).faces) == 12
    assert opened == []


def broken_cubes():
    """(name, faces, report fields after repair) of a unit cube broken in one way each."""
    f = CUBE_F
    flipped = f.copy()
    flipped[3] = flipped[3, ::-1]
    return [
        ("degenerate", np.vstack([f, [[0, 0, 1]]]), dict(degenerate_faces=1)),
        ("duplicate", np.vstack([f, f[5:6]]), dict(duplicate_faces=1)),
        ("flipped", flipped, dict(flipped_faces=1)),
        ("inside_out", f[:, ::-1].copy(), dict(flipped_faces=12)),
        # inside out but one face, the walk starting from an inward face (trimesh's multibody.stl)
        ("inside_out_but_one", np.where(np.arange(12)[:, None] == 3, f, f[:, ::-1]), dict(flipped_faces=11)),
        ("triangle_hole", np.delete(f, 7, axis=0), dict(filled_holes=1, added_faces=1)),
        ("quad_hole", np.delete(f, [0, 6], axis=0), dict(filled_holes=1, added_faces=2)),   # the -z side
    ]


@pytest.mark.parametrize("name,faces,changed", broken_cubes(), ids=[c[0] for c in broken_cubes()])
def test_a_broken_mesh_is_refused_with_the_problem_and_repaired_on_request(tmp_path, name, faces, changed):
    path = write_obj(tmp_path / f"{name}.obj", [(name, CUBE_V, faces)])
    with pytest.raises(ValueError, match=rf"{name}\.obj.*repair=True"):
        sg.load_mesh(path)
    with pytest.warns(sg.MeshRepairWarning, match=rf"{name}\.obj.*repaired") as caught:
        mesh = sg.load_mesh(path, repair=True)
    report = caught[0].message.report
    assert {k: v for k, v in vars(report).items() if v and not k.startswith("first")} == changed
    assert mesh.closedness_problem() == "" and volume(mesh) == pytest.approx(1.0, rel=1e-12)
    # the warning points at the caller's line, not at signorini's
    assert caught[0].filename == __file__


def test_the_refusal_counts_what_repair_would_drop_and_the_report_lists_it(tmp_path):
    faces = np.vstack([CUBE_F, [[0, 0, 1], [2, 2, 3]], CUBE_F[:3]])
    path = write_obj(tmp_path / "messy.obj", [("messy", CUBE_V, faces)])
    with pytest.raises(ValueError, match=r"messy\.obj.*degenerate.*2 degenerate faces and 3 duplicate faces"):
        sg.load_mesh(path)
    v, f, report = sg.meshfile.repair_arrays(CUBE_V, faces)
    assert (report.degenerate_faces, report.duplicate_faces, report.first_degenerate) == (2, 3, (12, 13))
    assert report.first_duplicate == (14, 15, 16)
    assert str(report) == "dropped 2 degenerate faces (faces 12, 13); dropped 3 duplicate faces (faces 14, 15, 16)"
    np.testing.assert_array_equal(f, CUBE_F)


def test_repair_drops_unused_vertices_and_leaves_a_good_mesh_alone(tmp_path):
    v = np.vstack([CUBE_V, [[5.0, 5.0, 5.0]]])
    _, _, report = sg.meshfile.repair_arrays(v, CUBE_F)
    assert report.unused_vertices == 1 and str(report) == "dropped 1 unused vertex"
    path = write_obj(tmp_path / "good.obj", [("good", CUBE_V, CUBE_F)])
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mesh = sg.load_mesh(path, repair=True)
    np.testing.assert_array_equal(mesh.faces, sg.load_mesh(path).faces)


def test_holes_of_more_than_four_edges_stay_and_the_error_says_so(tmp_path):
    v, f = meshes.icosphere(0.5, 1)
    # the five faces around vertex 0 removed: a pentagonal hole
    path = write_obj(tmp_path / "pierced.obj", [("ball", v, f[~np.any(f == 0, axis=1)])])
    # (nothing repaired: no warning)
    with pytest.raises(ValueError, match=r"pierced\.obj.*open.*after repair.*more than 4 edges.*static=True"):
        sg.load_mesh(path, repair=True)


def test_static_repair_keeps_holes_and_the_winding_of_most_of_the_area(tmp_path):
    # a 3 x 1 strip of squares facing +z, one triangle flipped, and a degenerate one
    v = np.array([(x, y, 0.0) for y in (0, 1) for x in range(4)], dtype=float)
    f = np.array([(0, 1, 5), (0, 5, 4), (1, 2, 6), (1, 6, 5), (2, 3, 7), (2, 7, 6)])
    f[2] = f[2, ::-1]
    path = write_obj(tmp_path / "strip.obj", [("strip", v, np.vstack([f, [[4, 5, 6]]]))])
    with pytest.raises(ValueError, match=r"strip\.obj.*degenerate.*repair=True"):
        sg.load_mesh(path, static=True)
    with pytest.warns(sg.MeshRepairWarning) as caught:
        floor = sg.load_mesh(path, static=True, repair=True)
    report = caught[0].message.report
    assert (report.degenerate_faces, report.flipped_faces, report.added_faces) == (1, 1, 0)
    assert isinstance(floor, sg.TriangleMesh) and len(floor.faces) == 6
    a, b, c = (np.asarray(floor.vertices)[np.asarray(floor.faces)[:, i]] for i in range(3))
    assert np.all(np.cross(b - a, c - a)[:, 2] > 0)


def boxes(centres, half=0.1):
    return [(f"piece_{k}", meshes.box_mesh((half, half, half))[0] + c, meshes.box_mesh((half, half, half))[1])
            for k, c in enumerate(np.asarray(centres, dtype=float))]


@pytest.mark.parametrize("keyword", ["o", "g"])
def test_objects_that_are_all_convex_are_the_pieces_without_decomposition(tmp_path, monkeypatch, keyword):
    from signorini import decomposition
    monkeypatch.setattr(decomposition, "convex_pieces", lambda *a, **k: pytest.fail("decomposed again"))
    centres = [(0, 0, 0), (0.3, 0, 0), (0, 0.3, 0.1)]
    path = write_obj(tmp_path / "vhacd.obj", boxes(centres), keyword=keyword, seams=True)
    mesh = sg.load_mesh(path)
    assert len(mesh.pieces) == 3 and len(mesh.vertices) == 24
    np.testing.assert_allclose(sorted(np.mean(p, axis=0).tolist() for p in mesh.pieces), sorted(np.array(centres).tolist()),
                               atol=1e-12)
    assert volume(mesh) == pytest.approx(3 * 0.2**3, rel=1e-12)
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    b = w.add_body(mesh, density=100.0, position=(0, 0, 0.5))
    w.step(1 / 240, 240)
    # the body comes to rest with its lowest piece on the ground
    assert w.positions[b][2] < 0.5 and np.linalg.norm(w.velocities[b]) < 0.05
    # as a compound: one part per object, the same mass
    parts = sg.load_mesh(path, compound=True)
    assert isinstance(parts, sg.Compound) and len(parts.parts) == 3
    assert volume(parts) == pytest.approx(volume(mesh), rel=1e-12)


def test_a_non_convex_object_makes_the_file_one_mesh_and_compound_names_it(tmp_path):
    lv = np.array([(0, 0, 0), (2, 0, 0), (2, 1, 0), (1, 1, 0), (1, 2, 0), (0, 2, 0)], dtype=float)
    lv = np.vstack([lv, lv + (0, 0, 1)]) * 0.1
    n = 6
    caps = [(0, 2, 1), (0, 3, 2), (0, 4, 3), (0, 5, 4)]
    lf = caps + [(a + n, c + n, b + n) for a, b, c in caps]
    lf += [t for i in range(n) for t in ((i, (i + 1) % n, (i + 1) % n + n), (i, (i + 1) % n + n, i + n))]
    objects = boxes([(1, 0, 0)]) + [("ell", lv, np.array(lf))]
    path = write_obj(tmp_path / "mixed.obj", objects)
    mesh = sg.load_mesh(path)
    assert mesh.pieces == [] and mesh.closedness_problem() == ""
    with pytest.raises(ValueError, match=r"mixed\.obj.*compound=True.*'ell' is not.*not convex"):
        sg.load_mesh(path, compound=True)
    with pytest.raises(ValueError, match=r"compound=True.*static=True"):
        sg.load_mesh(path, compound=True, static=True)
    # static: the union of the objects' triangles
    assert len(sg.load_mesh(path, static=True).faces) == 12 + len(lf)


def test_a_closed_mesh_split_into_groups_is_merged_back(tmp_path):
    # each side of the cube its own group: no group is closed, their union is
    sides = [(f"side_{k}", CUBE_V, CUBE_F[2 * k:2 * k + 2]) for k in range(6)]
    lines, path = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in CUBE_V], tmp_path / "sides.obj"
    for name, _, f in sides:
        lines += [f"g {name}"] + ["f " + " ".join(str(i + 1) for i in face) for face in f]
    path.write_text("\n".join(lines) + "\n")
    mesh = sg.load_mesh(path)
    assert len(mesh.vertices) == 8 and mesh.is_convex() and mesh.pieces == []


def test_a_glb_scene_of_convex_nodes_gives_pieces_placed_by_their_nodes(tmp_path):
    scene = trimesh.Scene()
    v, f = meshes.box_mesh((0.1, 0.1, 0.1))
    for k, offset in enumerate([(0.0, 0.0, 0.0), (0.5, 0.0, 0.0)]):
        scene.add_geometry(trimesh.Trimesh(v, f), node_name=f"box_{k}",
                           transform=trimesh.transformations.translation_matrix(offset))
    path = tmp_path / "scene.glb"
    scene.export(str(path))
    mesh = sg.load_mesh(path)
    assert len(mesh.pieces) == 2
    np.testing.assert_allclose(sorted(np.mean(p, axis=0)[0] for p in mesh.pieces), [0.0, 0.5], atol=1e-6)


def test_save_mesh_writes_what_load_mesh_reads_back(tmp_path):
    path = write_obj(tmp_path / "two.obj", boxes([(0, 0, 0), (0.5, 0, 0)]))
    mesh = sg.load_mesh(path)
    again = sg.load_mesh(sg.save_mesh(mesh, tmp_path / "two.npz"))
    np.testing.assert_array_equal(again.vertices, mesh.vertices)
    np.testing.assert_array_equal(again.faces, mesh.faces)
    assert all(np.array_equal(a, b) for a, b in zip(again.pieces, mesh.pieces)) and len(again.pieces) == 2
    with pytest.raises(ValueError, match=r"two\.obj.*must end in \.npz"):
        sg.save_mesh(mesh, tmp_path / "two.obj")
    with pytest.raises(TypeError, match="Mesh"):
        sg.save_mesh(sg.Sphere(1.0), tmp_path / "ball.npz")
