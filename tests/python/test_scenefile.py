"""Scene files (TOML): the built-in scenes are shipped as files and round-trip exactly; a saved
scene steps bit for bit like the original; bad files name the file, the key and the problem."""
import math
import re

import numpy as np
import pytest

import signorini as sg
from signorini import meshes, scenefile, scenes

STATE = ("positions", "rotations", "velocities", "angular_velocities")
MODEL = ("masses", "inertias", "frictions", "restitutions", "spinning_frictions", "is_static")
# steps per scene: enough for contacts and warm starts to matter, few for the big ones
STEPS = {"torus": 120, "boxes": 120, "shapes": 120, "pile": 40, "pyramid": 20, "rain": 10, "hull_pile": 20}


def assert_same_world(a, b, keys=STATE + MODEL):
    assert a.num_bodies == b.num_bodies
    for key in keys:
        assert np.array_equal(getattr(a, key), getattr(b, key)), key


@pytest.mark.parametrize("name", sorted(scenes.SCENES))
def test_saved_builtin_scene_is_the_shipped_file_and_steps_bit_identically(tmp_path, name):
    original = scenes.build(name)
    path = sg.save_scene(original, tmp_path / f"{name}.toml")
    # the shipped file is a fixed point of load and save: same text, same mesh arrays
    assert path.read_text() == scenes.SCENES[name].read_text()
    for mesh in sorted((tmp_path / f"{name}.meshes").glob("*.npz")) if (tmp_path / f"{name}.meshes").exists() else []:
        shipped = scenes.SCENE_DIR / f"{name}.meshes" / mesh.name
        with np.load(mesh) as a, np.load(shipped) as b:
            assert a.files == b.files and all(np.array_equal(a[k], b[k]) for k in a.files)
    loaded = sg.read_scene(path)
    assert (loaded.name, loaded.dt, loaded.steps, loaded.description, loaded.names, loaded.snapshot_times) == (
        original.name, original.dt, original.steps, original.description, original.names, original.snapshot_times)
    assert_same_world(original.world, loaded.world)
    original.world.step(original.dt, STEPS[name])
    loaded.world.step(loaded.dt, STEPS[name])
    assert_same_world(original.world, loaded.world, STATE)
    assert np.array_equal(original.world.contacts.alpha, loaded.world.contacts.alpha)


@pytest.mark.parametrize("name", sorted(scenes.SCENES))
def test_shipped_scene_files_are_what_their_generators_build(name):
    # the files were generated once; this keeps them and the generators from drifting apart
    generated, shipped = scenes.GENERATORS[name](), scenes.build(name)
    assert_same_world(generated.world, shipped.world)
    assert generated.names == shipped.names and generated.description == shipped.description
    assert [type(generated.world.shape(i)) for i in range(generated.world.num_bodies)] == \
        [type(shipped.world.shape(i)) for i in range(shipped.world.num_bodies)]


def test_the_generators_write_the_shipped_files_again(tmp_path):
    # python -m signorini.scenes writes the shipped files from the generators: they come out the
    # same, sleeping off as shipped (the generators' worlds sleep by default)
    for path in scenes.write_scene_files(tmp_path, names=["boxes", "pile", "shapes"]):
        assert path.read_text() == scenes.SCENES[path.stem].read_text(), path.stem


def test_schema_file_is_generated_from_the_model():
    assert scenefile.SCHEMA_PATH.read_text() == scenefile.schema_text(), \
        "run python -m signorini.scenes to write signorini/data/scene.schema.json again"
    schema = scenefile.scene_schema()
    assert schema["additionalProperties"] is False and "bodies" in schema["properties"]


def python_world():
    """Every shape type, materials, spins, a mesh given off-centre and a rotated compound part."""
    w = sg.World(gravity=(0.1, -0.2, -9.8), contact_margin=0.003, erp=0.3, friction_cone="cone", substeps=2)
    w.add_static(sg.Plane((0, 0, 1), 0.0), friction=0.7, restitution=0.1)
    v, f = meshes.box_mesh((0.1, 0.2, 0.15))
    w.add_static(sg.TriangleMesh(v + (2.0, 0.0, 0.0), f))
    w.add_body(sg.Sphere(0.1), mass=2.0, position=(0, 0, 0.5), velocity=(0.3, -0.0, 0.0), restitution=0.4,
               spinning_friction=0.002)
    w.add_body(sg.Box((0.1, 0.2, 0.3)), density=700.0, position=(0.5, 0, 0.6),
               orientation=(0.9, 0.1, 0.2, 0.3), angular_velocity=(1.0, 2.0, 3.0))
    w.add_body(sg.Capsule(0.05, 0.1), density=300.0, position=(-0.5, 0, 0.4), orientation=(0, 1, 0, 0))
    w.add_body(sg.Cylinder(0.07, 0.1), density=300.0, position=(0, 0.5, 0.4))
    w.add_body(sg.ConvexHull(np.random.default_rng(3).normal(size=(12, 3)) * 0.1), density=400.0,
               position=(0, -0.5, 0.5))
    w.add_body(sg.Mesh(v + (0.01, 0.02, 0.03), f), density=900.0, position=(0.5, 0.5, 0.5))
    w.add_body(sg.Compound([(sg.Box((0.1, 0.05, 0.02)), ((0.0, 0.0, 0.0), (1, 0, 0, 0))),
                            (sg.Sphere(0.04), ((0.1, 0.0, 0.05), sg.scenes.axis_angle_quaternion((0, 0, 1), 0.3)))]),
               density=500.0, position=(-0.5, 0.5, 0.5))
    return w


def test_a_world_built_in_python_round_trips_bit_for_bit(tmp_path):
    a = python_world()
    path = a.save_scene(tmp_path / "mine.toml")
    b = sg.load_scene(path)
    assert_same_world(a, b)
    assert a.solver == b.solver and np.array_equal(a.gravity, b.gravity)
    a.step(1 / 240, 60)
    b.step(1 / 240, 60)
    assert_same_world(a, b, STATE)
    # the meshes went to files next to the scene, referenced relatively
    text = path.read_text()
    assert 'file = "mine.meshes/mesh_0.npz"' in text and 'file = "mine.meshes/mesh_1.npz"' in text


def test_a_moved_world_is_saved_in_its_current_state(tmp_path):
    a = python_world()
    a.step(1 / 240, 30)
    a.set_velocity(2, (0.0, 0.0, 1.0))
    b = sg.load_scene(a.save_scene(tmp_path / "later.toml"))
    # positions and velocities exactly; the orientation as the quaternion of the rotation matrix
    for key in ("positions", "velocities", "angular_velocities", "masses", "frictions"):
        assert np.array_equal(getattr(a, key), getattr(b, key)), key
    np.testing.assert_allclose(b.rotations, a.rotations, rtol=0, atol=4e-16)
    np.testing.assert_allclose(b.inertias, a.inertias, rtol=1e-15)


def flagged_world():
    """Kinematic bodies (added with and without a mass, and made kinematic later), explicit
    inertia, filter bits, a disabled pair, a disabled body, a persistent wrench and names."""
    w = sg.World()
    w.add_static(sg.Plane((0, 0, 1), 0.0), name="ground", friction=0.8)
    # a paddle sweeping along the ground, kinematic without a mass
    w.add_body(sg.Box((0.5, 0.1, 0.05)), kinematic=True, position=(-1.0, -0.5, 0.06), velocity=(1.0, 0.0, 0.0),
               name="paddle")
    w.add_body(sg.Sphere(0.1), mass=2.0, kinematic=True, position=(0.5, 0.8, 0.3), angular_velocity=(0, 0, 3.0))
    w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=1.5, inertia=np.diag([0.01, 0.02, 0.03]), position=(0, 0, 0.12),
               orientation=(0.9, 0.1, 0.2, 0.3), spinning_friction=0.001, restitution=0.3, group=8, name="block")
    # falls through the block (group 8 is not in its mask) onto the ground
    w.add_body(sg.Sphere(0.05), density=800.0, position=(0.05, 0.0, 0.5), group=2, mask=0xFFFFFFF7, name="ghost")
    w.add_body(sg.Capsule(0.05, 0.1), density=600.0, position=(0.3, 0.0, 0.4))
    w.add_body(sg.Cylinder(0.05, 0.1), density=600.0, position=(0.3, 0.0, 0.7), enabled=False, name="off")
    w.add_body(sg.Box((0.05, 0.05, 0.05)), density=500.0, position=(-0.3, 0.2, 0.3))
    w.set_kinematic(7, True)
    w.set_velocity(7, (0.0, 0.0, -0.1))
    w.add_body(sg.Sphere(0.08), density=300.0, position=(0.3, 0.0, 0.2), name="free")
    w.disable_collision(5, 8)  # the capsule falls through the ball below it
    w.set_collision_filter(5, 4, 0xFF)
    w.set_material(6, friction=0.2)
    w.set_external_wrench(8, (0.0, 0.2, 0.0), (0.0, 0.0, 0.01))
    return w


def test_kinematic_inertia_filters_disabled_pairs_and_enabled_flags_round_trip_bit_for_bit(tmp_path):
    a = flagged_world()
    path = a.save_scene(tmp_path / "flags.toml")
    b = sg.load_scene(path)
    assert_same_world(a, b)
    for key in ("is_kinematic", "enabled", "names", "disabled_pairs", "forces", "torques"):
        assert np.array_equal(getattr(a, key), getattr(b, key)), key
    assert all(np.array_equal(x, y) for x, y in zip(a.collision_filters, b.collision_filters))
    assert np.array_equal(b.is_kinematic, [False, True, True, False, False, False, False, True, False])
    assert list(b.enabled).count(False) == 1 and b.disabled_pairs == [(5, 8)]
    assert np.array_equal(b.inertias[3], np.diag([0.01, 0.02, 0.03])) and b.masses[1] == np.inf
    for _ in range(200):
        a.step(1 / 240)
        b.step(1 / 240)
    assert_same_world(a, b, STATE + ("orientations",))
    assert np.array_equal(a.contacts.alpha, b.contacts.alpha)
    # the flags acted: the paddle slid 200/240 m without falling, the disabled body stayed put,
    # the ghost fell through the block to the ground, the capsule through the ball, which the
    # wrench rolled along +y
    assert b.positions[1, 2] == 0.06 and b.positions[1, 0] == pytest.approx(-1.0 + 200 / 240, abs=1e-12)
    assert np.array_equal(b.positions[6], (0.3, 0.0, 0.7))
    assert b.positions[4, 2] == pytest.approx(0.05, abs=0.002)
    assert b.positions[5, 2] < 0.2 and b.positions[8, 1] > 0.03


def test_a_compound_with_turned_parts_round_trips_bit_for_bit(tmp_path):
    # quaternions that are not unit: a Compound keeps the matrices, which the file keeps exactly
    rng = np.random.default_rng(4)
    parts = [(sg.Box((0.1, 0.05, 0.02)), ((0.0, 0.0, 0.0), tuple(rng.normal(size=4)))),
             (sg.Sphere(0.04), ((0.1, 0.0, 0.05), tuple(rng.normal(size=4)))),
             (sg.Capsule(0.02, 0.05), ((-0.1, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0)))]
    a = sg.World()
    a.add_static(sg.Plane((0, 0, 1), 0.0))
    a.add_body(sg.Compound(parts), density=500.0, position=(0, 0, 0.3), angular_velocity=(1.0, 2.0, 3.0))
    path = a.save_scene(tmp_path / "compound.toml")
    assert path.read_text().count("rotation = [") == 2 and path.read_text().count("orientation = [1.0, 0.0") == 1
    b = sg.load_scene(path)
    assert np.array_equal(a.shape(1).rotations, b.shape(1).rotations)
    assert_same_world(a, b)
    a.step(1 / 240, 200)
    b.step(1 / 240, 200)
    assert_same_world(a, b, STATE)


@pytest.mark.parametrize("pending, what", [
    (lambda w, i: w.apply_force(i, (1.0, 0.0, 0.0), point=w.positions[i] + (0.0, 0.0, 0.1)),
     "a force for the next step only (apply_force)"),
    (lambda w, i: w.apply_impulse(i, (0.0, 0.0, 1.0)), "a pending impulse (apply_impulse)"),
])
def test_what_a_scene_file_cannot_hold_is_refused_naming_the_body(tmp_path, pending, what):
    w = flagged_world()
    pending(w, 8)
    before = w.save_state()
    with pytest.raises(ValueError, match=re.escape(f"body 8 'free' (Sphere): {what}")):
        w.save_scene(tmp_path / "pending.toml")
    with pytest.raises(ValueError, match=re.escape(f"body 8 'free' (Sphere): {what}")):
        sg.save_scene(w, tmp_path / "pending.toml")
    assert not (tmp_path / "pending.toml").exists() and w.save_state().data == before.data


@pytest.mark.parametrize("table, message", [
    ("kinematic = true", "bodies[0] ('wall'): kinematic: a static body cannot be kinematic"),
    ("inertia = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]", "bodies[0] ('wall'): inertia: a static body"),
    ("force = [0.0, 0.0, 1.0]", "bodies[0] ('wall'): force: a static body cannot have a force"),
    ("mask = 4294967296", "bodies[0].mask (body 'wall'): Input should be less than or equal to 4294967295"),
])
def test_flags_a_static_body_cannot_take_are_errors(tmp_path, table, message):
    path = tmp_path / "bad.toml"
    path.write_text(f'[[bodies]]\nname = "wall"\nstatic = true\n{table}\nshape = {{ type = "sphere", radius = 1.0 }}\n')
    with pytest.raises(sg.SceneFileError, match=re.escape(message)):
        sg.load_scene(path)


def test_a_disabled_pair_out_of_range_names_its_key(tmp_path):
    path = tmp_path / "pairs.toml"
    path.write_text('disabled_pairs = [[0, 3]]\n[[bodies]]\nshape = { type = "sphere", radius = 1.0 }\nmass = 1.0\n')
    with pytest.raises(sg.SceneFileError, match=re.escape("disabled_pairs[0]: ")):
        sg.load_scene(path)


def test_a_hand_written_file_with_materials_and_inline_mesh(tmp_path):
    (tmp_path / "drop.toml").write_text("""
[scene]
description = "a cube and a tetrahedron dropped on rubber"
dt = 0.01
steps = 50

[world]
gravity = [0, 0, -9.81]

[materials.rubber]
friction = 0.9
restitution = 0.8
spinning_friction = 0.004

[[bodies]]
name = "ground"
static = true
material = "rubber"
shape = { type = "plane", normal = [0, 0, 1] }

[[bodies]]
name = "cube"
shape = { type = "box", half_extents = [0.5, 0.5, 0.5] }
mass = 2
material = "rubber"
restitution = 0.5
spinning_friction = 0.001
position = [0, 0, 1]

[[bodies]]
name = "tetra"
density = 1000
position = [2, 0, 1]
shape = { type = "mesh", vertices = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]] }
""")
    scene = sg.read_scene(tmp_path / "drop.toml")
    w = scene.world
    assert scene.name == "drop" and scene.dt == 0.01 and scene.steps == 50 and scene.names == ("ground", "cube", "tetra")
    np.testing.assert_array_equal(w.frictions, [0.9, 0.9, 0.5])
    np.testing.assert_array_equal(w.restitutions, [0.8, 0.5, 0.0])
    np.testing.assert_array_equal(w.spinning_frictions, [0.004, 0.001, 0.0])
    assert w.masses[1] == 2.0 and w.masses[2] == pytest.approx(1000.0 / 6.0, rel=1e-12)


BAD = [
    # (file text, what the error must say)
    ("[[bodies]]\nshape = { type = 'sphere', radius = 1.0 }\ndensity = 1\ncolour = 'red'\n",
     r"bodies\[0\]\.colour: Extra inputs are not permitted"),
    ("[world]\ngravty = [0, 0, -9.81]\n", r"world\.gravty: Extra inputs are not permitted"),
    ("[[bodies]]\nname = 'ball'\nshape = { type = 'sphere', radius = 'big' }\nmass = 1\n",
     r"bodies\[0\]\.shape\.radius \(body 'ball'\): Input should be a valid number"),
    ("[[bodies]]\nshape = { type = 'cone', radius = 1.0 }\nmass = 1\n", r"bodies\[0\]\.shape: Input tag 'cone'"),
    ("[[bodies]]\nshape = { type = 'box', half_extents = [1, 2] }\nmass = 1\n", r"bodies\[0\]\.shape\.half_extents"),
    ("[[bodies]]\nname = 'ball'\nshape = { type = 'sphere', radius = -1.0 }\nmass = 1\n",
     r"bodies\[0\] \('ball'\): shape: .*radius"),
    ("[[bodies]]\nname = 'ball'\nshape = { type = 'sphere', radius = 1.0 }\n", r"bodies\[0\] \('ball'\): .*density"),
    ("[[bodies]]\nshape = { type = 'sphere', radius = 1.0 }\nmass = 1\nmaterial = 'ice'\n",
     r"bodies\[0\]: material: unknown material 'ice'"),
    ("[[bodies]]\nshape = { type = 'mesh', file = 'nowhere.obj' }\nmass = 1\n",
     r"bodies\[0\]: shape\.file: mesh file .*nowhere\.obj.* does not exist"),
    ("[[bodies]]\nshape = { type = 'mesh' }\nmass = 1\n", r"bodies\[0\]\.shape: Value error, give either file or"),
    ("[[bodies]]\nstatic = true\nshape = { type = 'plane', normal = [0, 0, 1] }\nvelocity = [1, 0, 0]\n",
     r"bodies\[0\]: velocity: a static body cannot have a velocity"),
    ("[[bodies]]\nshape = { type = 'plane', normal = [0, 0, 1] }\nmass = 1\n", r"bodies\[0\]: .*plane"),
    ("[world]\nerp = 2.0\n", r"world: .*erp"),
    ("format = 2\n", r"format: Input should be 1"),
    ("[[bodies]]\nshape = { type = 'sphere', radius = '0.5' }\nmass = 1\n", r"bodies\[0\]\.shape\.radius: Input should be a valid number"),
    ("[[bodies]]\nstatic = 1\nshape = { type = 'plane', normal = [0, 0, 1] }\n", r"bodies\[0\]\.static: Input should be a valid boolean"),
    ("[world]\nmax_iterations = 30.0\n", r"world\.max_iterations: Input should be a valid integer"),
    ("[materials.ice]\nspinning_friction = 'small'\n", r"materials\.ice\.spinning_friction: Input should be a valid number"),
    ("[[bodies]]\nname = 'top'\nshape = { type = 'sphere', radius = 0.1 }\nmass = 1\nspinning_friction = -0.001\n",
     r"bodies\[0\] \('top'\): body 0 'top' \(Sphere\): spinning_friction must be finite and >= 0"),
    ("[scene\nname = 'x'\n", r"not valid TOML"),
]


@pytest.mark.parametrize("text, message", BAD)
def test_bad_files_name_the_file_the_key_and_the_problem(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(sg.SceneFileError, match=r"bad\.toml.*" + message):
        sg.load_scene(path)


def test_missing_file_and_a_failure_after_some_bodies_build_nothing(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.toml"):
        sg.load_scene(tmp_path / "nothing.toml")
    # the third body fails: load_scene returns no half-built world, it raises
    path = tmp_path / "third.toml"
    path.write_text("[[bodies]]\nstatic = true\nshape = { type = 'plane', normal = [0, 0, 1] }\n"
                    "[[bodies]]\nshape = { type = 'sphere', radius = 0.1 }\nmass = 1\nposition = [0, 0, 1]\n"
                    "[[bodies]]\nshape = { type = 'sphere', radius = 0.1 }\nmass = 1\nposition = [0, 0, nan]\n")
    with pytest.raises(sg.SceneFileError, match=r"third\.toml': bodies\[2\]: .*position"):
        sg.load_scene(path)


def test_save_scene_refuses_other_suffixes_and_objects(tmp_path):
    with pytest.raises(ValueError, match=r"must end in \.toml"):
        sg.save_scene(sg.World(), tmp_path / "scene.json")
    with pytest.raises(TypeError, match="World or a Scene"):
        sg.save_scene(42, tmp_path / "scene.toml")


def test_mesh_file_paths_are_relative_to_the_scene_file(tmp_path):
    v, f = meshes.icosphere(0.2, 1)
    import trimesh

    (tmp_path / "assets").mkdir()
    trimesh.Trimesh(v, f).export(str(tmp_path / "assets" / "ball.stl"))
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "s.toml").write_text(
        "[[bodies]]\nshape = { type = 'mesh', file = '../assets/ball.stl', scale = 2.0 }\ndensity = 1000\n")
    # a folder outside the scene file's own is read only when passed (test_file_limits: refused otherwise)
    w = sg.load_scene(tmp_path / "scenes" / "s.toml", allow_paths=[tmp_path / "assets"])
    radius = np.linalg.norm(w.shape(0).vertices, axis=1)
    np.testing.assert_allclose(radius, 0.4, rtol=1e-6)
    assert w.masses[0] < 1000 * 4 / 3 * math.pi * 0.4**3
