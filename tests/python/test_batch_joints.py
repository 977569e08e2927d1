"""sg.Batch joint drives (issue 23): per-world motor speeds, max torques, servo targets and efforts
give the bits of separate Worlds given the same targets at every thread count, and their
closed-form motions; joint positions and velocities read per world; bad input changes nothing."""
import pickle

import numpy as np
import pytest

import signorini as sg

DT = 1.0 / 240.0
MASS, A, C = 2.0, 0.3, 0.05
# the wheel (a box of half extents A, A, C) turns about z through its centre: I = m (2a)^2 * 2 / 12
I_Z = MASS * (2 * A) ** 2 * 2 / 12


def wheel(motor=None) -> sg.World:
    """A wheel on a hinge about z, nothing else acting (no gravity, no contacts, never asleep), and
    a ball on a spherical joint beside it (a joint without a coordinate)."""
    w = sg.World(gravity=(0, 0, 0), sleeping=False)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    wh = w.add_body(sg.Box((A, A, C)), mass=MASS)
    w.add_joint(sg.Revolute(ground, wh, anchor=(0, 0, 0), axis=(0, 0, 1),
                            motor=motor if motor is not None else sg.Motor(0.0, max_torque=10.0)))
    ball = w.add_body(sg.Sphere(0.1), mass=1.0, position=(2.0, 0, 0))
    w.add_joint(sg.Spherical(ground, ball, anchor=(2.0, 0, 0)))
    return w


def separate(world, n, each, steps):
    """n copies of world, ``each(i, w)`` applied to copy i, stepped ``steps``."""
    out = []
    for i in range(n):
        w = pickle.loads(pickle.dumps(world))
        each(i, w)
        w.step(DT, steps)
        out.append(w)
    return out


def assert_bits(b, worlds):
    for i, w in enumerate(worlds):
        for key in ("positions", "orientations", "velocities", "angular_velocities"):
            assert np.array_equal(getattr(b, key)[i], getattr(w, key)), (i, key)
        assert np.array_equal(b.joint_positions[i], w.joint_positions, equal_nan=True)
        assert np.array_equal(b.joint_velocities[i], w.joint_velocities, equal_nan=True)


@pytest.mark.parametrize("threads", [1, 2])
def test_per_world_motor_speeds_are_separate_worlds_bits_and_each_reaches_its_speed(threads):
    speeds = np.array([-2.0, 0.5, 1.0, 3.0, 6.0])
    b = sg.Batch(wheel(), len(speeds), threads=threads)
    b.set_joint_motor_speeds(speeds)
    b.step(DT, 120)
    assert_bits(b, separate(wheel(), len(speeds), lambda i, w: w.set_joint_motor(0, sg.Motor(speeds[i], 10.0)), 120))
    # the motor holds each speed (rigid up to 10 N m: 6 rad/s is reached within 0.1 s) to 1 %
    np.testing.assert_allclose(b.joint_velocities[:, 0], speeds, rtol=1e-2)
    assert b.joint_positions.shape == (5, 2) and np.isnan(b.joint_positions[:, 1]).all()
    assert b.world(4).joint(0)["motor_max_force"] == 10.0   # the rest of the motor kept


@pytest.mark.parametrize("threads", [1, 2])
def test_per_world_max_torques_spin_each_wheel_up_at_tau_over_i(threads):
    # a target the motor cannot reach in 0.1 s: it pushes with its max torque all along, so the
    # wheel spins up at exactly tau / I (about a principal axis: no gyroscopic term)
    tau = np.array([0.5, 1.0, 2.0, 4.0])
    b = sg.Batch(wheel(sg.Motor(100.0, max_torque=1.0)), len(tau), threads=threads)
    b.set_joint_max_forces(tau, joints=[0])
    b.step(DT, 24)
    np.testing.assert_allclose(b.joint_velocities[:, 0], tau / I_Z * 24 * DT, rtol=1e-9)
    assert_bits(b, separate(wheel(sg.Motor(100.0, max_torque=1.0)), len(tau),
                            lambda i, w: w.set_joint_motor(0, sg.Motor(100.0, tau[i])), 24))


def test_per_world_servo_targets_are_held():
    # a critically damped servo (k = 50 N m/rad, c = 2 sqrt(k I)): after 3 s, 60 time constants
    # sqrt(I / k) = 0.05 s, each wheel sits at its own target
    servo = sg.Motor(0.0, np.inf, position=0.0, stiffness=50.0, damping=2 * np.sqrt(50.0 * I_Z))
    targets = np.array([-1.0, 0.2, 2.5])
    b = sg.Batch(wheel(servo), 3, threads=2)
    b.set_joint_servo_positions(targets)
    b.step(DT, 720)
    np.testing.assert_allclose(b.joint_positions[:, 0], targets, atol=1e-6)
    assert b.world(2).joint(0)["motor_stiffness"] == 50.0


def test_per_world_efforts_spin_each_wheel_up_at_tau_over_i():
    w = wheel()
    w.set_joint_motor(0, None)
    tau = np.array([[-1.0], [0.0], [3.0]])
    b = sg.Batch(w, 3, threads=2)
    b.set_joint_efforts(tau)       # (n, K) with K = 1: the default joints are the hinges
    b.step(DT, 48)
    np.testing.assert_allclose(b.joint_velocities[:, 0], tau[:, 0] / I_Z * 48 * DT, rtol=1e-9, atol=1e-15)
    assert_bits(b, separate(w, 3, lambda i, x: x.set_joint_effort(0, tau[i, 0]), 48))


@pytest.mark.parametrize("call, error, message", [
    (lambda b: b.set_joint_motor_speeds(np.zeros(3)), ValueError, "set_joint_motor_speeds: speeds must have shape (4,)"),
    (lambda b: b.set_joint_motor_speeds(np.zeros((4, 2))), ValueError, "speeds must have shape (4,) or (4, 1)"),
    (lambda b: b.set_joint_motor_speeds([1.0, 2.0, np.nan, 3.0]), ValueError,
     "set_joint_motor_speeds: speeds of world 2, joint 0 is not finite"),
    (lambda b: b.set_joint_motor_speeds("fast"), TypeError, "set_joint_motor_speeds: speeds must be numbers"),
    (lambda b: b.set_joint_max_forces([1.0, -1.0, 1.0, 1.0]), ValueError,
     "set_joint_max_forces: max_forces of world 1, joint 0 must be >= 0.0, got -1.0"),
    (lambda b: b.set_joint_max_forces([1.0, 1.0, np.nan, 1.0]), ValueError,
     "set_joint_max_forces: max_forces of world 2, joint 0 is not a number"),
    (lambda b: b.set_joint_motor_speeds(np.ones(4), joints=[5]), IndexError,
     "set_joint_motor_speeds: joint index 5 is out of range: the worlds have 2 joints"),
    (lambda b: b.set_joint_servo_positions(np.ones(4), joints=[1]), ValueError,
     "set_joint_servo_positions: joint 1 of world 0 is a Spherical joint"),
    (lambda b: b.set_joint_efforts(np.ones(4), joints=[0.5]), ValueError, "set_joint_efforts: joints must be"),
    (lambda b: b.set_joint_efforts(np.full(4, np.inf)), ValueError,
     "set_joint_efforts: efforts of world 0, joint 0 is not finite"),
])
def test_bad_joint_input_names_the_parameter_and_changes_no_world(call, error, message):
    b = sg.Batch(wheel(), 4, threads=1)
    b.set_joint_motor_speeds([1.0, 2.0, 3.0, 4.0])
    b.step(DT, 5)
    before = [(pickle.dumps(b.world(i)), [b.world(i).joint(j) for j in range(2)]) for i in range(4)]
    with pytest.raises(error, match=message.replace("(", r"\(").replace(")", r"\)")):
        call(b)
    for i in range(4):
        assert pickle.dumps(b.world(i)) == before[i][0]


def test_a_joint_without_a_motor_is_named():
    w = wheel()
    w.set_joint_motor(0, None)
    b = sg.Batch(w, 2, threads=1)
    assert b.set_joint_motor_speeds(np.ones(2)) is None   # the default: no joint has a motor, none set
    with pytest.raises(ValueError, match=r"set_joint_motor_speeds: joint 0 of world 0 has no motor"):
        b.set_joint_motor_speeds(np.ones(2), joints=[0])
