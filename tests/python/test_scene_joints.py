"""Joints in scene files (issue 23): [[joints]] tables name their bodies, hold every option of the
Python API, build the same world bit for bit, round-trip through save_scene, take a sweep's dotted
overrides, and refuse bad input naming the joint and the key before any world is built."""
import math
import pickle
import re

import numpy as np
import pytest

import signorini as sg

G = 9.81
DT = 1.0 / 240.0
THETA0 = 0.3

PENDULUM = f"""
[world]
gravity = [0.0, 0.0, -9.81]
sleeping = false

[[bodies]]
name = "ground"
static = true
shape = {{ type = "plane", normal = [0.0, 0.0, 1.0], offset = -100.0 }}

[[bodies]]
name = "bob"
shape = {{ type = "sphere", radius = 0.01 }}
mass = 1.0
position = [{math.sin(THETA0)!r}, 0.0, {-math.cos(THETA0)!r}]

[[joints]]
name = "elbow"
type = "revolute"
body_a = "ground"
body_b = "bob"
anchor = [0.0, 0.0, 0.0]
axis = [0.0, 1.0, 0.0]
"""


def python_pendulum():
    """The file above through the Python API."""
    w = sg.World(gravity=(0.0, 0.0, -G), sleeping=False)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0), name="ground")
    bob = w.add_body(sg.Sphere(0.01), mass=1.0, position=(math.sin(THETA0), 0.0, -math.cos(THETA0)), name="bob")
    w.add_joint(sg.Revolute(ground, bob, anchor=(0, 0, 0), axis=(0, 1, 0), name="elbow"))
    return w


def test_a_hinge_pendulum_from_a_file_is_the_python_one_bit_for_bit(tmp_path):
    path = tmp_path / "pendulum.toml"
    path.write_text(PENDULUM)
    a, b = sg.load_scene(path), python_pendulum()
    assert a.num_joints == 1 and a.find_joint("elbow") == 0 and a.joint(0)["body_a"] == 0
    for _ in range(480):
        a.step(DT)
        b.step(DT)
        assert np.array_equal(a.positions, b.positions) and np.array_equal(a.velocities, b.velocities)
    assert np.array_equal(a.joint_positions, b.joint_positions)
    # and it is a pendulum: the bob stays 1 m from the hinge (the PGS holds a joint to ~1e-6 m)
    assert np.linalg.norm(a.positions[1]) == pytest.approx(1.0, abs=1e-5)


def every_kind():
    """Every joint type with every option: limits, a velocity motor, a servo, a damper with an
    infinite max force, friction, effort, breaking limits, collide_connected, names, a broken joint,
    a rope and a rod, a static and an unnamed body, bodies turned off the axes."""
    w = sg.World(gravity=(0.0, 0.0, -G), sleeping=False)
    g = w.add_static(sg.Plane((0, 0, 1), 0.0), name="ground")
    a = w.add_body(sg.Capsule(0.05, 0.3), mass=1.3, position=(0.1, 0.2, 1.1), orientation=(0.9, 0.1, 0.2, 0.3),
                   name="upper")
    b = w.add_body(sg.Box((0.1, 0.07, 0.3)), mass=0.7, position=(0.3, -0.1, 0.7), orientation=(0.7, -0.1, 0.3, 0.2),
                   name="lower")
    c = w.add_body(sg.Sphere(0.1), mass=0.5, position=(0.7, 0.1, 0.9))
    d = w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=0.4, position=(-0.6, 0.0, 0.8), name="wheel")
    w.add_joint(sg.Revolute(g, a, anchor=(0.1, 0.2, 1.43), axis=(0.3, 1, 0.1), limits=(-1, 1.2),
                            motor=sg.Motor(0.3, max_torque=2.0), friction=0.01, name="shoulder", break_torque=500.0))
    w.add_joint(sg.Prismatic(a, b, axis=(0.1, 0.2, 1.0), limits=(-0.1, 0.2),
                             motor=sg.Motor(0.0, 5.0, position=0.05, stiffness=50.0, damping=2.0), effort=0.1))
    w.add_joint(sg.Spherical(b, c, anchor=(0.5, 0.0, 0.8), break_force=1e4, name="ball"))
    w.add_joint(sg.Fixed(a, c, break_torque=30.0, collide_connected=True))
    w.add_joint(sg.Distance(g, c, (0.7, 0.1, 1.9), (0.7, 0.1, 1.0), 0.0, 1.0, name="rope"))
    w.add_joint(sg.Distance(d, c, (-0.6, 0.0, 0.8), (0.7, 0.1, 0.9), name="rod"))
    w.add_joint(sg.Revolute(g, d, anchor=(-0.6, 0.0, 0.8), axis=(0.0, 0.0, 2.0),
                            motor=sg.Motor(0.0, math.inf, damping=0.5), effort=-0.2, name="wheel_axle"))
    j = w.add_joint(sg.Fixed(g, d, name="clamp"))
    w.set_joint_broken(j, True)
    return w


def assert_same_joints(a, b):
    assert a.num_joints == b.num_joints
    for j in range(a.num_joints):
        x, y = a.joint(j), b.joint(j)
        assert x.keys() == y.keys()
        for key in x:
            assert np.array_equal(x[key], y[key]) if not isinstance(x[key], str) else x[key] == y[key], (j, key)


def test_every_joint_type_round_trips_bit_for_bit(tmp_path):
    a = every_kind()
    path = a.save_scene(tmp_path / "joints.toml")
    b = sg.load_scene(path)
    assert_same_joints(a, b)
    text = path.read_text()
    for kind in ("revolute", "prismatic", "spherical", "fixed", "distance"):
        assert f'type = "{kind}"' in text
    # bodies by name, the unnamed one by index; the damper's infinite max force kept
    assert 'body_b = "upper"' in text and "body_b = 3" in text and "max_force = inf" in text
    assert b.joint(7)["broken"] and b.joint(6)["motor_max_force"] == math.inf
    # read -> world -> write -> read: the same file, and the same steps
    again = sg.save_scene(b, tmp_path / "again.toml")
    assert again.read_text() == text
    c = sg.load_scene(again)
    for w in (a, b, c):
        w.step(DT, 240)
    for w in (b, c):
        for key in ("positions", "rotations", "velocities", "angular_velocities"):
            assert np.array_equal(getattr(a, key), getattr(w, key)), key
        assert np.array_equal(a.joint_positions, w.joint_positions, equal_nan=True)
        assert np.array_equal(a.joint_row_forces, w.joint_row_forces)


def test_joint_args_are_what_the_joints_were_made_from_and_survive_pickling(tmp_path):
    w = every_kind()
    given = w.joint_args(0)
    np.testing.assert_array_equal(given.anchor, (0.1, 0.2, 1.43))
    np.testing.assert_array_equal(given.axis, (0.3, 1.0, 0.1))  # as given, not normalised
    copy = pickle.loads(pickle.dumps(w))
    for j in range(w.num_joints):
        assert all(np.array_equal(x, y) for x, y in zip(w.joint_args(j), copy.joint_args(j)))
    assert_same_joints(w, sg.load_scene(copy.save_scene(tmp_path / "copy.toml")))
    # a removed body takes its joints; the others keep their records under new indices
    w.remove_body(w.find("wheel"))
    assert w.num_joints == 5 and w.joint_args(4).anchor_b.tolist() == [0.7, 0.1, 1.0]


def test_a_sweep_override_sets_a_joint_value_by_the_joints_name(tmp_path):
    # zero gravity, a motorised wheel: each override's speed is reached within 1 % (the motor is
    # rigid up to its torque: 10 N m on I = 2/3 m a^2 = 0.027 kg m^2 spins up in a few steps)
    path = tmp_path / "wheel.toml"
    path.write_text(PENDULUM.replace("[0.0, 0.0, -9.81]", "[0.0, 0.0, 0.0]").replace(
        'shape = { type = "sphere", radius = 0.01 }', 'shape = { type = "box", half_extents = [0.2, 0.2, 0.05] }')
        + "motor = { speed = 1.0, max_torque = 10.0 }\n")
    for speed in (-2.0, 3.0):
        w = sg.read_scene(path, overrides={"joints.elbow.motor.speed": speed}).world
        assert w.joint(0)["motor_speed"] == speed
        w.step(DT, 120)
        assert w.joint_velocities[0] == pytest.approx(speed, rel=1e-2)
    assert sg.read_scene(path, overrides={"joints.0.friction": 0.5}).world.joint(0)["friction"] == 0.5
    with pytest.raises(sg.SceneFileError, match=re.escape("'joints.knee' is not there (known: 'elbow')")):
        sg.read_scene(path, overrides={"joints.knee.motor.speed": 1.0})
    with pytest.raises(sg.SceneFileError, match=re.escape("joints[0].motor.speed (joint 'elbow'): Input should be")):
        sg.read_scene(path, overrides={"joints.elbow.motor.speed": "fast"})


BAD = [
    # (what replaces 'body_b = "bob"' in the pendulum file, what the error must say)
    ('body_b = "bobb"', "joints[0] ('elbow'): body_b: unknown body 'bobb' (known: 'ground', 'bob')"),
    ('body_b = 7', "joints[0] ('elbow'): body_b: body index 7 is out of range: the file has 2 bodies"),
    ('body_b = "ground"', "joints[0] ('elbow'): body_b: body_a and body_b are the same body"),
    ('body_b = "bob"\ncolour = "red"', "joints[0].colour (joint 'elbow'): Extra inputs are not permitted"),
    ('body_b = "bob"\nmin_length = 1.0', "joints[0].min_length (joint 'elbow'): Extra inputs are not permitted"),
    ('body_b = 1.5', "joints[0].body_b"),
    ('body_b = "bob"\nlimits = [1.0, -1.0]', "joints[0] (joint 'elbow'): Value error, limits need lower <= upper"),
    ('body_b = "bob"\nlimits = [0.0]', "joints[0].limits[1] (joint 'elbow'): Field required"),
    ('body_b = "bob"\nlimits = [-1.0, nan]', "joints[0].limits[1] (joint 'elbow'): Input should be a finite number"),
    ('body_b = "bob"\nfriction = "some"', "joints[0].friction (joint 'elbow'): Input should be a valid number"),
    ('body_b = "bob"\nmotor = { speed = 1.0 }', "joints[0].motor (joint 'elbow'): Value error, give max_force"),
    ('body_b = "bob"\nmotor = { speed = nan, max_torque = 1.0 }',
     "joints[0].motor.speed (joint 'elbow'): Input should be a finite number"),
    ('body_b = "bob"\nmotor = { speed = 1.0, max_torque = -1.0 }',
     "joints[0].motor.max_torque (joint 'elbow'): Input should be greater than or equal to 0"),
    ('body_b = "bob"\nbreak_force = 0.0', "joints[0].break_force (joint 'elbow'): Input should be greater than 0"),
    ('body_b = "bob"\nlimits = [-4.0, 4.0]',
     "joints[0] ('elbow'): joint 0 'elbow' (Revolute): a hinge's limits must lie in (-pi, pi) rad"),
]


@pytest.mark.parametrize("replace, message", BAD)
def test_bad_joints_name_the_joint_and_the_key(tmp_path, replace, message):
    path = tmp_path / "bad.toml"
    path.write_text(PENDULUM.replace('body_b = "bob"', replace))
    with pytest.raises(sg.SceneFileError, match=r"bad\.toml'?: " + re.escape(message)):
        sg.load_scene(path)


@pytest.mark.parametrize("table, message", [
    ('type = "hinge"\nbody_a = "ground"\nbody_b = "bob"\nanchor = [0.0, 0.0, 0.0]',
     "joints[1] (joint 'knee'): Input tag 'hinge' found using 'type' does not match any of the expected tags: "
     "'revolute', 'prismatic', 'spherical', 'fixed', 'distance'"),
    ('type = "spherical"\nbody_a = "ground"\nbody_b = "bob"\nanchor = [0.0, 0.0]',
     "joints[1].anchor[2] (joint 'knee'): Field required"),
    ('type = "distance"\nbody_a = "ground"\nbody_b = "bob"\nanchor_a = [0.0, 0.0, 0.0]\nanchor_b = [0.0, 0.0, -1.0]\n'
     'min_length = 2.0\nmax_length = 1.0', "joints[1] (joint 'knee'): Value error, min_length must be <= max_length"),
    ('type = "fixed"\nbody_a = "ground"\nbody_b = "wall"', "joints[1] ('knee'): body_b: both bodies are static "
                                                          "('ground', 'wall'): a joint needs one that moves"),
])
def test_bad_second_joints_name_it_before_any_world_is_built(tmp_path, table, message):
    # a static wall with a bad shape comes after the bodies: the core would refuse it while
    # building the world, so reading the joint's error shows the joints were checked before
    path = tmp_path / "bad.toml"
    wall = '\n[[bodies]]\nname = "wall"\nstatic = true\nshape = { type = "sphere", radius = -1.0 }\n'
    path.write_text(PENDULUM.replace("\n[[joints]]", wall + "\n[[joints]]", 1) + f'\n[[joints]]\nname = "knee"\n{table}\n')
    with pytest.raises(sg.SceneFileError, match=r"bad\.toml'?: " + re.escape(message)):
        sg.load_scene(path)
    # and without the joint, it is the wall that is refused
    path.write_text(PENDULUM.replace("\n[[joints]]", wall + "\n[[joints]]", 1))
    with pytest.raises(sg.SceneFileError, match=re.escape("bodies[2] ('wall'): shape")):
        sg.load_scene(path)


def test_a_joint_whose_description_is_unknown_is_refused_naming_it(tmp_path):
    # a pickle of a version that did not keep joint_args: the file could not make the joint again
    w = python_pendulum()
    w._joint_args.clear()
    assert w.joint_args(0) is None
    with pytest.raises(ValueError, match=re.escape("joint 0 'elbow' (Revolute): ") + ".*unknown"):
        w.save_scene(tmp_path / "p.toml")
    assert not (tmp_path / "p.toml").exists()
