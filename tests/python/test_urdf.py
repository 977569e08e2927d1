"""URDF import (issue 23; signorini.urdf, docs/conventions.md "URDF"): robots of pybullet_data load
with the masses, inertias and limits pybullet reads from the same files, a limp KUKA arm falls as
pybullet's does (with the file's joint damping and without), joint <dynamics> become dampers and
friction, and bad files are refused by element before the World changes.

Tolerances: masses, inertias and limits are copied from the file (1e-12 relative: the sums of a
merged group, rounding); pybullet diagonalises a full inertia tensor by Jacobi iterations, whose
eigenvectors are good to about 1e-9 (the principal moments, second order in them, to 1e-12). The
fall: pybullet integrates reduced coordinates with one semi-implicit Euler step of 1/240 s, the
PGS maximal coordinates in substeps of 1/960 s with the rows at the substep's midpoint; both are
first-order in time, and over 0.5 s of a fall reaching 2 rad their angles differ by up to 0.03 rad
(measured 0.015 and 0.027 rad in the two poses below), inside the issue's 0.05 rad.

With the file's joint damping (0.5 N m s/rad on every KUKA joint) pybullet at 1/240 s is no
reference: it applies joint damping explicitly, omega <- omega (1 - c h / I) per step (measured on a
rotor: 0.875 per step for c h / I = 0.125), and KUKA's last link (I_zz = 0.001 kg m^2) has
c h / I = 2.08 > 2 there, so its joint's speed alternates in sign and grows to pybullet's 100 rad/s
clamp within 0.2 s. At 1/4800 s (c h / I = 0.10) pybullet's fall is converged (1/2400 differs by
5e-4 rad) and is the reference; signorini's damper is implicit (exact implicit Euler per substep),
stable at any step.
"""
import math
import os
import re
import sys

import numpy as np
import pytest

import signorini as sg

pytest.importorskip("yourdfpy")
pybullet = pytest.importorskip("pybullet")
import pybullet_data  # noqa: E402  (installed with pybullet)

DATA = os.path.join(os.path.dirname(__file__), "data", "urdf")
PYBULLET = pybullet_data.getDataPath()
KUKA = os.path.join(PYBULLET, "kuka_iiwa", "model.urdf")
DT = 1.0 / 240.0


@pytest.fixture
def client():
    c = pybullet.connect(pybullet.DIRECT)
    yield c
    pybullet.disconnect(c)


def pybullet_robot(client, path, **kw):
    return pybullet.loadURDF(path, flags=pybullet.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client, **kw)


def pybullet_link_inertia(client, robot, link):
    """(mass, inertia (3, 3) about the centre of mass in the link frame) from getDynamicsInfo: the
    principal moments and the inertial frame's orientation in the link frame."""
    info = pybullet.getDynamicsInfo(robot, link, physicsClientId=client)
    R = np.array(pybullet.getMatrixFromQuaternion(info[4])).reshape(3, 3)
    return info[0], R @ np.diag(info[2]) @ R.T, np.array(info[2])


# loading: what pybullet reads from the same file ---------------------------------------------
def test_kuka_has_7_revolute_joints_with_pybullets_limits_masses_and_inertias(client):
    w = sg.World()
    robot = sg.add_urdf(w, KUKA, fixed_base=True)
    pb = pybullet_robot(client, KUKA, useFixedBase=True)
    n = pybullet.getNumJoints(pb, physicsClientId=client)
    assert n == 7 and w.num_joints == 7 and w.num_bodies == 8
    assert w.is_static[robot.root] and not w.is_static[1:].any()
    for j in range(n):
        info = pybullet.getJointInfo(pb, j, physicsClientId=client)
        name, child = info[1].decode(), info[12].decode()
        ours = robot.joints[name]
        assert info[2] == pybullet.JOINT_REVOLUTE and w.joint(ours.index)["kind"] == "Revolute"
        assert ours.lower == pytest.approx(info[8], rel=1e-9) and ours.upper == pytest.approx(info[9], rel=1e-9)
        assert w.joint(ours.index)["lower"] == pytest.approx(info[8], rel=1e-9)
        assert w.joint(ours.index)["upper"] == pytest.approx(info[9], rel=1e-9)
        assert ours.effort == pytest.approx(info[10], rel=1e-9) and ours.velocity == pytest.approx(info[11], rel=1e-9)
        mass, inertia, _ = pybullet_link_inertia(client, pb, j)
        body = robot.bodies[child]
        assert w.masses[body] == pytest.approx(mass, rel=1e-9)
        np.testing.assert_allclose(w.inertias[body], inertia, rtol=0, atol=1e-9 * np.abs(inertia).max())
        # the centre of mass where pybullet puts it (world, at the zero configuration)
        com = pybullet.getLinkState(pb, j, computeForwardKinematics=True, physicsClientId=client)[0]
        np.testing.assert_allclose(w.positions[body], com, atol=1e-9)


def test_turned_inertial_frames_off_diagonal_terms_and_merged_links_agree_with_pybullet(client):
    path = os.path.join(DATA, "inertia.urdf")
    w = sg.World()
    robot = sg.add_urdf(w, path)
    pb = pybullet_robot(client, path)
    # base (-1), bare (0, no <inertial>: 1 kg and unit inertia, as pybullet), turned (1) with tool (2)
    # welded to it: one body of both links, whose inertia pybullet's links sum to about the
    # group's centre of mass
    mass, inertia, principal = pybullet_link_inertia(client, pb, -1)
    assert w.masses[robot.bodies["base"]] == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(np.linalg.eigvalsh(w.inertias[robot.bodies["base"]]), np.sort(principal), rtol=1e-12)
    np.testing.assert_allclose(w.inertias[robot.bodies["base"]], inertia, atol=1e-9 * np.abs(inertia).max())
    assert w.masses[robot.bodies["bare"]] == 1.0
    np.testing.assert_array_equal(w.inertias[robot.bodies["bare"]], np.eye(3))
    body = robot.bodies["turned"]
    assert robot.bodies["tool"] == body
    states = [pybullet.getLinkState(pb, k, computeForwardKinematics=True, physicsClientId=client) for k in (1, 2)]
    parts = [pybullet_link_inertia(client, pb, k) for k in (1, 2)]
    M = sum(p[0] for p in parts)
    com = sum(p[0] * np.array(s[0]) for p, s in zip(parts, states)) / M
    # world inertia of the pair about its centre of mass (each link's frame from pybullet's link state)
    I_world = np.zeros((3, 3))
    for (m, I, _), s in zip(parts, states):
        R = np.array(pybullet.getMatrixFromQuaternion(s[5])).reshape(3, 3)  # the link frame, world
        d = np.array(s[0]) - com
        I_world += R @ I @ R.T + m * (d @ d * np.eye(3) - np.outer(d, d))
    R = w.rotations[body]
    assert w.masses[body] == pytest.approx(M, rel=1e-12)
    np.testing.assert_allclose(w.positions[body], com, atol=1e-12)
    np.testing.assert_allclose(R @ w.inertias[body] @ R.T, I_world, atol=1e-9 * np.abs(I_world).max())
    # limits: lower > upper is no limit (pybullet's rule); the other's as given
    assert math.isnan(robot.joints["j1"].lower) and not w.joint(robot.joints["j1"].index)["has_limits"]
    assert (robot.joints["j2"].lower, robot.joints["j2"].upper) == (-1.0, 1.5)
    assert robot.joints["weld"].index == -1


# the fall: limp joints, fixed base, no contacts ---------------------------------------------
def pybullet_fall(client, orientation_xyzw, steps, dt=DT, joint_damping=False):
    pb = pybullet_robot(client, KUKA, useFixedBase=True, baseOrientation=orientation_xyzw)
    pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
    pybullet.setTimeStep(dt, physicsClientId=client)
    n = pybullet.getNumJoints(pb, physicsClientId=client)
    for j in range(-1, n):
        # pybullet's links have damping 0.04 by default, and the file gives joint damping 0.5
        # (applied by pybullet as loaded; zeroed unless joint_damping)
        kw = {} if joint_damping else dict(jointDamping=0)
        pybullet.changeDynamics(pb, j, linearDamping=0, angularDamping=0, physicsClientId=client, **kw)
    if joint_damping:
        assert [pybullet.getJointInfo(pb, j, physicsClientId=client)[6] for j in range(n)] == [0.5] * n
    pybullet.setJointMotorControlArray(pb, list(range(n)), pybullet.VELOCITY_CONTROL, forces=[0.0] * n,
                                       physicsClientId=client)
    for _ in range(steps):
        pybullet.stepSimulation(physicsClientId=client)
    return np.array([pybullet.getJointState(pb, j, physicsClientId=client)[0] for j in range(n)])


@pytest.mark.parametrize("axis", [(1.0, 0.0, 0.0), (0.6, 0.8, 0.0)], ids=["horizontal", "tilted"])
def test_limp_kuka_with_a_fixed_base_falls_as_pybullets(client, axis):
    # the base turned 90 degrees about axis: the straight arm starts across gravity and falls far
    s, c = math.sin(math.pi / 4), math.cos(math.pi / 4)
    steps = round(0.5 / DT)
    expected = pybullet_fall(client, (s * axis[0], s * axis[1], s * axis[2], c), steps)
    w = sg.World(solver="pgs", sleeping=False)
    robot = sg.add_urdf(w, KUKA, fixed_base=True, orientation=(c, s * axis[0], s * axis[1], s * axis[2]),
                        dynamics=False)
    for _ in range(steps):
        w.step(DT)
        assert len(w.contacts) == 0  # the robot's links never collide with each other
    angles = w.joint_positions[robot.joint_indices]
    assert np.abs(expected).max() > 0.4  # it did fall
    assert np.abs(angles - expected).max() < 0.05, (angles, expected)


@pytest.mark.parametrize("axis", [(1.0, 0.0, 0.0), (0.6, 0.8, 0.0)], ids=["horizontal", "tilted"])
def test_kuka_with_the_files_joint_damping_falls_as_pybullets(client, axis):
    # the same fall with the file's damping on in both: pybullet at 1/4800 s (module doc: at 1/240
    # its explicit damping of the last joint is unstable), signorini at 1/240 s. The damped arm
    # moves slowly and smoothly, so both first-order integrators' time errors are small: measured
    # 8e-4 and 1.5e-3 rad (joints travelling up to 0.06 and 1.54 rad); 16 substeps give 4e-4 and
    # 3e-4. Asserted within 0.01 rad, a fifth of the limp test's bound
    s, c = math.sin(math.pi / 4), math.cos(math.pi / 4)
    expected = pybullet_fall(client, (s * axis[0], s * axis[1], s * axis[2], c), 2400, dt=0.5 / 2400,
                             joint_damping=True)
    w = sg.World(solver="pgs", sleeping=False)
    robot = sg.add_urdf(w, KUKA, fixed_base=True, orientation=(c, s * axis[0], s * axis[1], s * axis[2]))
    for j in robot.joint_indices:
        assert w.joint(j)["motor"] and w.joint(j)["motor_damping"] == 0.5
        assert w.joint(j)["motor_max_force"] == math.inf and w.joint(j)["motor_speed"] == 0.0
    w.step(DT, round(0.5 / DT))
    angles = w.joint_positions[robot.joint_indices]
    assert np.abs(expected).max() > 0.05  # it did move
    assert np.abs(angles - expected).max() < 0.01, (angles, expected)
    # the damping matters at this scale: the limp arm (dynamics=False) is far from the damped one
    limp = sg.World(solver="pgs", sleeping=False)
    limp_robot = sg.add_urdf(limp, KUKA, fixed_base=True, orientation=(c, s * axis[0], s * axis[1], s * axis[2]),
                             dynamics=False)
    limp.step(DT, round(0.5 / DT))
    assert np.abs(limp.joint_positions[limp_robot.joint_indices] - expected).max() > 0.3


# joint <dynamics>: dampers and friction --------------------------------------------------
DYNAMICS = os.path.join(DATA, "dynamics.urdf")
G = 9.81
# the arms of dynamics.urdf: 1 kg, centre of mass 0.25 m from the hinge, I about the hinge
ARM_TORQUE = 1.0 * G * 0.25
ARM_INERTIA = 0.0210416667 + 1.0 * 0.25 ** 2


def dynamics_world(**kw):
    w = sg.World(solver="pgs", sleeping=False, substeps=4)
    robot = sg.add_urdf(w, DYNAMICS, fixed_base=True, **kw)
    return w, robot


def test_dynamics_damping_and_friction_become_the_joints_damper_and_friction():
    w, robot = dynamics_world()
    expected = {"spin": (0.3, 0.0), "slide": (4.0, 0.0), "held": (0.0, 4.0), "slipping": (0.0, 1.0)}
    for name, (damping, friction) in expected.items():
        j = robot.joints[name]
        assert (j.damping, j.friction) == (damping, friction)
        info = w.joint(j.index)
        assert info["friction"] == friction
        assert info["motor"] == (damping > 0)  # a damper is the joint's drive; none without damping
        if damping > 0:
            assert (info["motor_speed"], info["motor_max_force"], info["motor_damping"]) == (0.0, math.inf, damping)
            assert info["motor_stiffness"] == 0.0
    # dynamics=False: limp and frictionless, the file's values not applied
    w, robot = dynamics_world(dynamics=False)
    for name in expected:
        j = robot.joints[name]
        assert (j.damping, j.friction) == (0.0, 0.0)
        assert not w.joint(j.index)["motor"] and w.joint(j.index)["friction"] == 0.0


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_the_files_damping_slows_a_rotor_and_a_slider_as_implicit_euler(solver):
    # gravity off; the rotor (I_zz = 0.01 kg m^2, c = 0.3 N m s/rad) and the slider (2 kg, c = 4 N
    # s/m) set moving: the damper is exactly implicit Euler per substep h, omega / (1 + c h / I)
    # (docs, "Motors, servos and damping"), close to the exponential exp(-c t / I): c h / I = 0.031,
    # the two factors differ by about (c h / I)^2 / 2 per substep, 2.3 % after 48
    w = sg.World(solver=solver, sleeping=False, gravity=(0, 0, 0), substeps=4)
    robot = sg.add_urdf(w, DYNAMICS, fixed_base=True)
    rotor, slider = robot.bodies["rotor"], robot.bodies["slider"]
    w.set_angular_velocity(rotor, (0.0, 0.0, 10.0))
    w.set_velocity(slider, (1.0, 0.0, 0.0))
    steps, h = 12, DT / 4
    w.step(DT, steps)
    spin, slide = robot.joints["spin"].index, robot.joints["slide"].index
    assert w.joint_velocities[spin] == pytest.approx(10.0 / (1 + 0.3 * h / 0.01) ** (4 * steps), rel=1e-6)
    assert w.joint_velocities[slide] == pytest.approx(1.0 / (1 + 4.0 * h / 2.0) ** (4 * steps), rel=1e-6)
    assert w.joint_velocities[spin] == pytest.approx(10.0 * math.exp(-0.3 * w.time / 0.01), rel=0.05)


def test_a_velocity_motor_replaces_the_damper_while_on_and_gives_it_back():
    w, robot = dynamics_world()
    spin = robot.joints["spin"].index
    robot.set_motor("spin", 2.0)
    info = w.joint(spin)
    assert (info["motor_speed"], info["motor_damping"], info["motor_stiffness"]) == (2.0, 0.0, 0.0)
    w.step(DT, 24)
    assert w.joint_velocities[spin] == pytest.approx(2.0, rel=1e-6)  # rigid: the command is met
    # the slider's motor: speed clamped to <limit velocity> 1 m/s, max force <limit effort> 50 N
    motor = robot.motor("slide", 3.0)
    assert (motor.speed, motor.max_force, motor.damping) == (1.0, 50.0, 0.0)
    # off again: the file's damper, not a limp joint
    robot.set_motor("spin", None)
    info = w.joint(spin)
    assert info["motor"] and (info["motor_speed"], info["motor_damping"]) == (0.0, 0.3)
    w.step(DT, 24)
    assert w.joint_velocities[spin] == pytest.approx(2.0 / (1 + 0.3 * (DT / 4) / 0.01) ** 96, rel=1e-6)
    # a joint without damping goes limp
    robot.set_motor("held", 1.0)
    robot.set_motor("held", None)
    assert not w.joint(robot.joints["held"].index)["motor"]


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_the_files_friction_holds_an_arm_against_its_weight_and_lets_a_heavier_one_turn(solver):
    # both arms start horizontal under gravity: 'held' has friction 4 N m > its weight's 2.4525 N m
    # and stays (the friction row carries the weight's torque); 'slipping' has 1 N m and turns at
    # (m g d - f) / I_hinge = 17.4 rad/s^2 (cos(theta) stays above 0.9997 in the 0.05 s measured)
    w = sg.World(solver=solver, sleeping=False, substeps=4)
    robot = sg.add_urdf(w, DYNAMICS, fixed_base=True)
    held, slipping = robot.joints["held"].index, robot.joints["slipping"].index
    w.step(DT, 12)
    alpha = (ARM_TORQUE - 1.0) / ARM_INERTIA
    assert w.joint_velocities[slipping] == pytest.approx(alpha * w.time, rel=0.02)
    assert abs(w.joint_row_forces[slipping][9]) == pytest.approx(1.0, rel=1e-9)  # at its bound
    w.step(DT, 228)
    assert abs(w.joint_positions[held]) < 1e-3 and abs(w.joint_velocities[held]) < 1e-3
    assert abs(w.joint_row_forces[held][9]) == pytest.approx(ARM_TORQUE, rel=1e-2)
    assert w.joint_positions[slipping] > 1.0  # fell to its limit region
    # without the file's dynamics the held arm falls as well
    w, robot = dynamics_world(dynamics=False)
    w.step(DT, 12)
    assert w.joint_velocities[robot.joints["held"].index] == pytest.approx(ARM_TORQUE / ARM_INERTIA * w.time, rel=0.02)


# robots of pybullet_data that load and run ---------------------------------------------------
@pytest.mark.parametrize("name, position", [("r2d2.urdf", (0, 0, 0.5)), ("table/table.urdf", (0, 0, 0)),
                                            ("racecar/racecar.urdf", (0, 0, 0.2))])
def test_pybullet_data_robots_load_and_run_60_steps(name, position):
    w = sg.World()
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    robot = sg.add_urdf(w, os.path.join(PYBULLET, name), position=position)
    assert w.num_bodies == 1 + len(set(robot.bodies.values()))
    w.step(DT, 60)
    assert np.isfinite(w.positions).all() and np.isfinite(w.orientations).all()
    assert np.isfinite(w.velocities).all() and np.isfinite(w.angular_velocities).all()
    assert w.positions[robot.root][2] > -0.05  # on the ground, not through it


def test_r2d2_maps_its_joints_and_merges_fixed_links():
    w = sg.load_urdf(os.path.join(PYBULLET, "r2d2.urdf"), fixed_base=True)
    robot = sg.add_urdf(w, os.path.join(PYBULLET, "r2d2.urdf"), prefix="second/")
    kinds = {name: j.type for name, j in robot.joints.items()}
    assert kinds["gripper_extension"] == "prismatic" and kinds["head_swivel"] == "continuous"
    assert robot.bodies["right_leg"] == robot.bodies["base_link"]  # welded by a fixed joint
    assert w.joint(robot.joints["gripper_extension"].index)["kind"] == "Prismatic"
    assert w.is_static[w.find("base_link")] and not w.is_static[w.find("second/base_link")]
    assert w.find_joint("second/head_swivel") == robot.joints["head_swivel"].index
    # effort and velocity: the motor's bounds
    motor = robot.motor("gripper_extension", 3.0)
    assert (motor.speed, motor.max_force) == (0.5, 1000.0)


# bad input: the element named, nothing added ------------------------------------------------
BAD = [
    ("loop.urdf", "joint name='back'", "loop"),
    ("missing_mesh.urdf", "link name='arm'", "no_such_arm.stl"),
    ("unknown_joint.urdf", "joint name='shoulder'", "unknown or missing joint type 'screw'"),
    ("missing_link.urdf", "joint name='shoulder'", "link 'forearm' does not exist"),
    ("massless_link.urdf", "link name='arm'", "non-positive mass"),
    ("negative_mass.urdf", "link name='arm'", "mass -2 kg is negative"),
    ("nan.urdf", "joint name='shoulder'", "<origin xyz='0 nan 0.1'>: not a list of finite numbers"),
    ("negative_damping.urdf", "joint name='elbow'", "<dynamics> damping -0.5 and friction 0 must be >= 0"),
]


@pytest.mark.parametrize("name, element, problem", BAD, ids=[b[0] for b in BAD])
def test_bad_files_are_refused_naming_the_element_before_anything_is_added(name, element, problem):
    w = sg.World()
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    w.add_body(sg.Sphere(0.1), density=1000.0, position=(0, 0, 1), name="base")
    before = w.save_state()
    with pytest.raises(sg.URDFError) as e:
        sg.add_urdf(w, os.path.join(DATA, name), prefix="robot/")
    message = str(e.value)
    assert name in message and element in message and problem in message, message
    assert re.search(r"line \d+ <", message)
    assert w.num_bodies == 2 and w.num_joints == 0 and w.names == ["", "base"]
    assert w.save_state() == before


def test_names_already_in_the_world_are_refused_before_anything_is_added():
    w = sg.World()
    w.add_body(sg.Sphere(0.1), density=1000.0, name="lbr_iiwa_link_3")
    with pytest.raises(sg.URDFError, match="lbr_iiwa_link_3.*already has a body named"):
        sg.add_urdf(w, KUKA)
    assert w.num_bodies == 1 and w.num_joints == 0


def test_a_missing_file_and_a_missing_parser_say_what_is_wrong(monkeypatch, tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        sg.load_urdf(tmp_path / "nothing.urdf")
    monkeypatch.setitem(sys.modules, "yourdfpy", None)  # as if it were not installed
    with pytest.raises(ImportError, match="pip install yourdfpy"):
        sg.load_urdf(KUKA)

