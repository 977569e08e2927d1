"""Meshes as people have them: the OBJ files of pybullet_data (textured, seam-split, V-HACD pieces,
a big scene with bad faces), loaded by ``sg.load_mesh`` as they come. Skipped only when pybullet
(which ships pybullet_data; ``scripts/install.sh --test`` installs it) is absent."""
import warnings
from pathlib import Path

import numpy as np
import pytest

import signorini as sg
from signorini import decomposition

pybullet_data = pytest.importorskip("pybullet_data")
DATA = Path(pybullet_data.getDataPath())


@pytest.fixture
def no_coacd(monkeypatch):
    """Fails the test if anything starts a CoACD decomposition."""
    monkeypatch.setattr(decomposition, "_run_worker", lambda *a, **k: pytest.fail("CoACD was run"))


def volume(shape):
    return sg.mass_properties(shape, density=1.0)[0]


@pytest.mark.parametrize("name,vertices,faces", [("cube.obj", 8, 12), ("sphere_smooth.obj", 898, 1792),
                                                 ("soccerball.obj", 4526, 9048), ("duck.obj", 2108, 4212)])
def test_textured_meshes_load_closed_with_their_seams_merged(name, vertices, faces):
    # each stores its corners once per texture coordinate and normal: refused as open before
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mesh = sg.load_mesh(DATA / name)
    assert (len(mesh.vertices), len(mesh.faces)) == (vertices, faces)
    assert mesh.closedness_problem() == ""
    assert volume(mesh) > 0.0


def test_the_cube_is_a_unit_cube_and_rests_on_the_ground():
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    b = w.add_body(sg.load_mesh(DATA / "cube.obj", scale=0.1), density=1000.0, position=(0, 0, 0.2))
    assert w.masses[b] == pytest.approx(1.0, rel=1e-9)
    w.step(1 / 240, 240)
    assert w.positions[b][2] == pytest.approx(0.05, abs=1e-3)


def test_the_bunny_loads_closed_as_one_non_convex_mesh_without_coacd(no_coacd):
    # CoACD cuts it when it is added to a world or decomposed (README's table), not when it is read
    mesh = sg.load_mesh(DATA / "bunny.obj")
    assert (len(mesh.vertices), len(mesh.faces)) == (453, 902)
    assert mesh.closedness_problem() == "" and volume(mesh) > 0.0
    assert not mesh.pieces and not mesh.is_convex()


@pytest.mark.parametrize("name", ["sphere_smooth.obj", "soccerball.obj"])
def test_nearly_convex_balls_are_their_own_hull_without_coacd(name, no_coacd):
    # their faces bend by rounding (not convex to the core's 1e-9), well within CONVEX_TOLERANCE
    mesh = sg.load_mesh(DATA / name)
    assert not mesh.is_convex()
    pieces = sg.decompose(mesh).pieces
    assert len(pieces) == 1 and len(pieces[0]) <= len(mesh.vertices)


@pytest.mark.parametrize("name,pieces", [("duck_vhacd.obj", 5), ("teddy2_VHACD_CHs.obj", 15)])
def test_vhacd_files_are_their_convex_pieces_without_decomposition(name, pieces, no_coacd):
    mesh = sg.load_mesh(DATA / name)
    assert len(mesh.pieces) == pieces
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    b = w.add_body(mesh, density=500.0, position=(0, 0, 1.0))
    w.step(1 / 240, 120)
    assert w.positions[b][2] < 1.0
    compound = sg.load_mesh(DATA / name, compound=True)
    assert len(compound.parts) == pieces
    # the parts are the pieces' hulls, within CONVEX_TOLERANCE of the pieces
    assert volume(compound) == pytest.approx(volume(mesh), rel=sg.meshfile.CONVEX_TOLERANCE)


def test_the_samurai_monastery_loads_as_a_static_mesh_with_repair():
    path = DATA / "samurai_monastry.obj"
    with pytest.warns(sg.MeshRepairWarning, match=r"samurai_monastry\.obj.*repaired.*degenerate") as caught:
        scene = sg.load_mesh(path, static=True, repair=True)
    report = caught[0].message.report
    assert report.degenerate_faces >= 1 and report.filled_holes == 0
    assert isinstance(scene, sg.TriangleMesh) and len(scene.faces) > 100_000
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(scene)
