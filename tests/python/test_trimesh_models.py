"""Meshes as people have them, part two: model files of trimesh's own repository (copied into
tests/data/trimesh_models; its README gives the source commit, path and licence of each), loaded
by ``sg.load_mesh`` as they come: seam-split OBJ and PLY, binary and ASCII STL (one solid or
several), OFF, a GLB scene of nested nodes, and files that are open, flat, non-manifold or wound
inconsistently. The pybullet_data meshes are in test_mesh_files.py (skipped without pybullet);
these run everywhere.

Expected figures come from geometry (closed forms for cubes and tetrahedra, Euler's formula for
closed meshes, the distinct positions a file stores) or from trimesh itself, which reads the same
files: the same triangles summed in another order agree to rounding (1e-9); files that store
float32 coordinates (binary STL and PLY) agree with a closed form to float32's 7 digits."""
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import signorini as sg
from signorini import decomposition

trimesh = pytest.importorskip("trimesh")
DATA = Path(__file__).resolve().parents[1] / "data" / "trimesh_models"
ROUNDING = 1e-9      # relative: the same triangles summed in another order
FLOAT32 = 1e-6       # relative: float32 coordinates (eps 6e-8) against a closed form, three of them in a volume


@pytest.fixture
def no_coacd(monkeypatch):
    """Fails the test if anything starts a CoACD decomposition."""
    monkeypatch.setattr(decomposition, "_run_worker", lambda *a, **k: pytest.fail("CoACD was run"))


def volume(shape):
    return sg.mass_properties(shape, density=1.0)[0]


def trimesh_objects(name):
    """trimesh's reading of a file: its objects placed by their nodes, corners merged (seams too),
    each wound consistently outwards by trimesh's own repair."""
    # an OBJ's o objects and g groups as separate geometries, as load_mesh reads them
    options = dict(split_objects=True, split_groups=True) if name.endswith(".obj") else {}
    objects = [g for g in trimesh.load_scene(DATA / name, **options).dump() if isinstance(g, trimesh.Trimesh)]
    for g in objects:
        g.merge_vertices(merge_tex=True, merge_norm=True)
        trimesh.repair.fix_normals(g)
    return objects


def stored_positions(name):
    """The distinct vertex positions the file stores (trimesh reading it without merging anything)."""
    raw = trimesh.load_scene(DATA / name, process=False).dump()
    return np.unique(np.concatenate([g.vertices for g in raw]), axis=0), sum(len(g.vertices) for g in raw)


def load_quietly(name, **options):
    """load_mesh with every warning an error (a file that loads cleanly warns of nothing)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return sg.load_mesh(DATA / name, **options)


def test_every_file_the_readme_lists_is_here_and_nothing_else():
    readme = (DATA / "README.md").read_text()
    listed = set(re.findall(r"^\| `([^`]+)` \|", readme, flags=re.M))
    assert listed == {p.name for p in DATA.iterdir() if p.name != "README.md"}
    assert sum(p.stat().st_size for p in DATA.iterdir()) < 2 * 2**20


# ---------------------------------------------------------------- seams: corners stored per texture or normal

@pytest.mark.parametrize("name", ["textured_tetrahedron.obj", "cubevt.obj", "ico4uv.obj", "cube_blender_uv.ply"])
def test_seam_split_files_load_closed_with_one_vertex_per_position(name):
    positions, stored = stored_positions(name)
    assert stored > len(positions)   # the file splits corners at seams (v/vt/vn triples, per-face UVs)
    mesh = load_quietly(name)
    assert len(mesh.vertices) == len(positions)
    assert mesh.closedness_problem() == ""
    # a closed mesh of one piece without handles: V - E + F = 2 with E = 3 F / 2
    assert len(mesh.vertices) == len(mesh.faces) // 2 + 2
    (theirs,) = trimesh_objects(name)
    assert volume(mesh) == pytest.approx(theirs.volume, rel=ROUNDING)


def test_the_textured_tetrahedron_has_the_volume_of_its_four_corners():
    v = np.array([[float(x) for x in line.split()[1:]] for line in (DATA / "textured_tetrahedron.obj").read_text().splitlines()
                  if line.startswith("v ")])
    mesh = load_quietly("textured_tetrahedron.obj")
    assert (len(mesh.vertices), len(mesh.faces)) == (4, 4)
    assert volume(mesh) == pytest.approx(abs(np.linalg.det(v[1:] - v[0])) / 6.0, rel=ROUNDING)


@pytest.mark.parametrize("name", ["cubevt.obj", "cube_blender_uv.ply"])
def test_the_textured_unit_cubes_are_unit_cubes(name):
    mesh = load_quietly(name)
    np.testing.assert_allclose(np.ptp(np.asarray(mesh.vertices), axis=0), 1.0, rtol=ROUNDING)
    assert volume(mesh) == pytest.approx(1.0, rel=ROUNDING)
    assert mesh.is_convex()


# ---------------------------------------------------------------- one closed solid: STL, PLY, OFF

def lowest_point(w, b):
    """The height (m) of body b's lowest vertex in the world."""
    return float((np.asarray(w.shape(b).vertices) @ w.rotations[b].T + w.positions[b])[:, 2].min())


def test_a_binary_stl_unit_cube_rests_on_the_ground():
    mesh = load_quietly("unit_cube.STL", scale=0.1)
    assert (len(mesh.vertices), len(mesh.faces)) == (8, 12)
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    b = w.add_body(mesh, density=1000.0, position=(0, 0, 0.2))
    assert w.masses[b] == pytest.approx(1.0, rel=FLOAT32)
    w.step(1 / 240, 240)
    # resting: the centre half the side above the floor, sunk at most the solver's 1 mm slop
    assert w.positions[b][2] == pytest.approx(0.05, abs=1e-3)
    assert lowest_point(w, b) > -1e-3


def test_seven_eighths_of_a_cube_is_closed_and_not_convex(no_coacd):
    # a binary STL: a cube of side a with one octant (a/2)^3 cut out
    mesh = load_quietly("7_8ths_cube.stl")
    a = float(np.ptp(np.asarray(mesh.vertices)[:, 0]))
    assert np.ptp(np.asarray(mesh.vertices), axis=0) == pytest.approx([a, a, a], rel=FLOAT32)
    assert volume(mesh) == pytest.approx(7 / 8 * a**3, rel=FLOAT32)
    assert not mesh.is_convex() and not mesh.pieces
    # the hull is the cube less the corner tetrahedron (legs a/2) beyond the cut octant's three outer
    # corners: 47/48 a^3, which exceeds the solid by 5/47 of itself
    assert volume(sg.ConvexHull(np.asarray(mesh.vertices))) == pytest.approx(47 / 48 * a**3, rel=FLOAT32)
    assert sg.meshfile.convex_problem(np.asarray(mesh.vertices), np.asarray(mesh.faces)) == \
        f"it is not convex (its convex hull is {100 * 5 / 47:.2g} % larger)"


@pytest.mark.parametrize("name", ["angle_block.STL", "tet.ply", "whitespace.off"])
def test_closed_solids_have_trimesh_s_counts_and_volume(name):
    # angle_block.STL: a binary STL whose header starts with "solid" (as an ASCII one does), a CAD
    # part with a hole through it; tet.ply: binary PLY; whitespace.off: an OFF header on one line
    mesh = load_quietly(name)
    (theirs,) = trimesh_objects(name)
    assert (len(mesh.vertices), len(mesh.faces)) == (len(theirs.vertices), len(theirs.faces))
    assert mesh.closedness_problem() == ""
    assert volume(mesh) == pytest.approx(theirs.volume, rel=ROUNDING)


def test_the_angle_block_has_one_handle():
    # V - E + F = 2 - 2 g with E = 3 F / 2: the bolt hole makes its genus 1
    mesh = load_quietly("angle_block.STL")
    assert len(mesh.vertices) - len(mesh.faces) // 2 == 2 - 2 * 1


def test_the_off_cube_has_the_volume_of_its_corners():
    # corners (+-d, 0, +-h), (0, +-d, +-h): a square of diagonal 2 d (area 2 d^2) times the height 2 h
    # (a cube to the file's 7 digits: d sqrt(2) = 2 h)
    d, h = 1.632993, 1.154701
    mesh = load_quietly("whitespace.off")
    assert volume(mesh) == pytest.approx(2 * d**2 * 2 * h, rel=ROUNDING)
    assert mesh.is_convex()


# ---------------------------------------------------------------- several objects: convex pieces or a compound

@pytest.mark.parametrize("name,volumes", [
    ("two_objects.obj", [1.0, 1.0 / 6.0]),                    # OBJ o objects: a unit cube and a corner tetrahedron
    ("two_objects_mixed_case_names.stl", [1.0, 1.0]),         # two ASCII STL solids: two unit cubes
    ("nested.glb", None),                                     # three boxes, each placed by a chain of GLB nodes
])
def test_files_of_convex_objects_are_their_convex_pieces(name, volumes, no_coacd):
    mesh = load_quietly(name)
    theirs = trimesh_objects(name)
    assert len(mesh.pieces) == len(theirs)
    if volumes is None:
        volumes = [g.volume for g in theirs]
    pieces = [sg.ConvexHull(p) for p in mesh.pieces]
    assert sorted(volume(p) for p in pieces) == pytest.approx(sorted(volumes), rel=ROUNDING)
    assert volume(mesh) == pytest.approx(sum(volumes), rel=ROUNDING)
    # each piece where trimesh places its object (the GLB's node transforms applied)
    ours = sorted(np.round(np.mean(p, axis=0), 9).tolist() for p in mesh.pieces)
    expected = sorted(np.round(np.mean(np.unique(g.vertices, axis=0), axis=0), 9).tolist() for g in theirs)
    np.testing.assert_allclose(ours, expected, atol=1e-9)
    compound = load_quietly(name, compound=True)
    assert len(compound.parts) == len(theirs)
    assert volume(compound) == pytest.approx(sum(volumes), rel=ROUNDING)


def test_a_glb_scene_falls_as_one_body_of_its_pieces_and_rests(no_coacd):
    mesh = load_quietly("nested.glb", scale=0.1)
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    b = w.add_body(mesh, density=500.0, position=(0, 0, 1.0))
    w.step(1 / 240, 480)
    # after 2 s: at rest on the floor, sunk at most the solver's 1 mm slop
    assert np.linalg.norm(w.velocities[b]) < 1e-3
    assert -1e-3 < lowest_point(w, b) < 1e-6


# ---------------------------------------------------------------- broken files: a clear error, repair where it can

def test_a_multi_solid_stl_wound_inconsistently_is_refused_then_repaired_into_convex_pieces(no_coacd):
    # both solids closed, but with faces wound against their neighbours (CAD export, edited to break it)
    name = "multibody.stl"
    with pytest.raises(ValueError, match=r"multibody\.stl.*same direction.*inconsistently oriented.*repair=True"):
        sg.load_mesh(DATA / name)
    with pytest.warns(sg.MeshRepairWarning, match=r"multibody\.stl.*repaired.*reversed the winding") as caught:
        mesh = sg.load_mesh(DATA / name, repair=True)
    report = caught[0].message.report
    assert report.flipped_faces > 0
    assert (report.degenerate_faces, report.duplicate_faces, report.added_faces) == (0, 0, 0)
    theirs = trimesh_objects(name)
    assert mesh.closedness_problem() == ""
    assert volume(mesh) == pytest.approx(sum(g.volume for g in theirs), rel=ROUNDING)
    # once wound outwards, each solid is convex within CONVEX_TOLERANCE: the pieces, not a decomposition
    assert len(mesh.pieces) == 2
    with pytest.warns(sg.MeshRepairWarning):
        assert len(sg.load_mesh(DATA / name, repair=True, compound=True).parts) == 2


def test_two_cubes_sharing_an_edge_are_named_non_manifold():
    # shared.STL: one binary STL solid that is two cubes touching along an edge, four faces on it
    for options in ({}, {"repair": True}):
        with pytest.raises(ValueError, match=r"shared\.STL.*edge \(\d+, \d+\) is shared by 4 faces.*non-manifold"
                                             r".*its own object.*static=True"):
            sg.load_mesh(DATA / "shared.STL", **options)
    scene = load_quietly("shared.STL", static=True)
    assert len(scene.faces) == 24


def test_a_triangle_soup_is_open_and_repair_does_not_close_its_triangles_flat():
    # soup.stl: 100 separate triangles. Filling each one's three-edge hole would give 100 flat
    # two-sided triangles enclosing nothing: repair leaves them open and the error says why
    with pytest.raises(ValueError, match=r"soup\.stl.*open.*repair=True.*static=True accepts open meshes"):
        sg.load_mesh(DATA / "soup.stl")
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # nothing repaired: no warning
        with pytest.raises(ValueError, match=r"soup\.stl.*open.*after repair.*enclose nothing.*static=True"):
            sg.load_mesh(DATA / "soup.stl", repair=True)
    _, _, report = sg.meshfile.repair_arrays(*sg.meshfile.read_mesh_arrays(DATA / "soup.stl")[:2])
    assert not report
    scene = load_quietly("soup.stl", static=True)
    assert isinstance(scene, sg.TriangleMesh) and len(scene.faces) == 100


def test_a_wall_with_sliver_faces_is_refused_and_repaired_as_a_static_mesh():
    # wallhole.obj (Rhino): a wall with a hole, 11 zero-area slivers and a repeated face
    name = "wallhole.obj"
    for options in ({}, {"static": True}):
        with pytest.raises(ValueError, match=r"wallhole\.obj.*face 8 is degenerate.*11 degenerate faces and "
                                             r"1 duplicate face in all.*repair=True"):
            sg.load_mesh(DATA / name, **options)
    with pytest.warns(sg.MeshRepairWarning, match=r"wallhole\.obj.*dropped 11 degenerate faces") as caught:
        scene = sg.load_mesh(DATA / name, static=True, repair=True)
    report = caught[0].message.report
    # (the repeated face is one of the slivers: dropped as degenerate, before duplicates are looked for)
    assert (report.degenerate_faces, report.duplicate_faces, report.added_faces) == (11, 0, 0)
    assert report.first_degenerate[0] == 8
    assert isinstance(scene, sg.TriangleMesh) and len(scene.faces) == 66 - 11
    # as a dynamic body it stays open after repair (its holes are larger than 4 edges), and says so
    with pytest.warns(sg.MeshRepairWarning), pytest.raises(ValueError, match=r"wallhole\.obj.*open.*after repair"):
        sg.load_mesh(DATA / name, repair=True)
