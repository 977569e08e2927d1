"""Friction, and spring-damper motors of hinges and sliders (sg.Motor with stiffness and damping: joint damping,
servos, MuJoCo's velocity and position actuators), against closed forms: the damped rotor's decay
the servo's damped oscillation, a rotor braked by Coulomb friction. The oracle repeats them step by step in
test_joints.py::test_oracle_matches_pgs_steps_of_a_jointed_scene (its scene has a servo hinge, a
damped slider, and a hinge and a slider with friction)."""
import math

import numpy as np
import pytest

import signorini as sg

SOLVERS = ["pgs", "soft"]


def rotor(solver, motor, omega0=3.0, substeps=1, friction=0.0):
    """A 1 kg box (0.4 x 0.2 x 0.1 m half extents) spinning at omega0 about z on a hinge through its
    centre to a static body, no gravity: the hinge's coordinate is its angle about z."""
    w = sg.World(gravity=(0.0, 0.0, 0.0), solver=solver, sleeping=False)
    w.set_solver(substeps=substeps)
    ground = w.add_static(sg.Box((0.1, 0.1, 0.1)), position=(0.0, 0.0, -1.0))
    body = w.add_body(sg.Box((0.4, 0.2, 0.1)), mass=1.0, angular_velocity=(0.0, 0.0, omega0))
    j = w.add_joint(sg.Revolute(ground, body, anchor=(0, 0, 0), axis=(0, 0, 1), motor=motor, friction=friction))
    I_z = 1.0 / 3.0 * (0.4 ** 2 + 0.2 ** 2)  # m (a^2 + b^2) / 3 for half extents a, b
    return w, body, j, I_z


@pytest.mark.parametrize("solver", SOLVERS)
def test_joint_damping_decays_a_rotor_as_implicit_euler_and_the_exponential(solver):
    # I omega_dot = -c omega: each substep h of implicit Euler gives omega / (1 + c h / I), exactly;
    # the exponential exp(-c t / I) differs from it by n ((c h / I)^2 / 2) in the logarithm
    c, dt, steps = 0.05, 1 / 240, 240
    w, body, j, I = rotor(solver, sg.Motor(0.0, math.inf, damping=c))
    h = dt / w.solver["substeps"] if w.solver["substeps"] else dt
    n = round(dt / h) * steps
    w.step(dt, steps)
    omega = w.joint_velocities[j]
    assert omega == pytest.approx(3.0 / (1 + c * h / I) ** n, rel=1e-9)
    x = c * h / I
    assert abs(math.log(omega / 3.0) + c * (dt * steps) / I) <= n * x * x / 2 * 1.01
    # the torque the damper transmits is -c omega_new (about the axis, on B)
    assert w.joint_torques[j][2] == pytest.approx(-c * omega, rel=1e-9)


def substep_count(w, dt):
    s = w.solver["substeps"]
    return s if s else max(1, math.ceil(dt * (960 if w.solver["solver"] == "pgs" else 240) - 1e-9))


@pytest.mark.parametrize("solver", SOLVERS)
def test_a_servo_rings_down_to_its_position_at_the_damped_frequency(solver):
    # I theta'' = k (theta_t - theta) - c theta': omega_n = sqrt(k / I), zeta = c / (2 sqrt(k I)),
    # the error rings at omega_d = omega_n sqrt(1 - zeta^2) and decays as exp(-zeta omega_n t).
    # Implicit Euler at h stretches the period by O((omega_n h)^2) and adds the decay rate
    # omega_n^2 h / 2 (its amplification 1 / (1 + i omega h) has modulus exp(-omega^2 h / 2 + ...)):
    # with omega_n h < 0.01 the period stays well inside the 1 % asked
    dt = 1 / 240
    w, body, j, I = rotor(solver, None, omega0=0.0, substeps=4)
    k = I * (2 * math.pi) ** 2  # 1 Hz
    c = 2 * 0.05 * math.sqrt(k * I)  # zeta = 0.05
    target = 0.5
    w.set_joint_motor(j, sg.Motor(0.0, math.inf, position=target, stiffness=k, damping=c))
    theta = []
    for _ in range(240 * 6):
        w.step(dt)
        theta.append(w.joint_positions[j])
    e = np.array(theta) - target
    # upward zero crossings of the error, interpolated: their spacing is the damped period
    up = [i + e[i] / (e[i] - e[i + 1]) for i in range(len(e) - 1) if e[i] < 0.0 <= e[i + 1]]
    assert len(up) >= 4
    period = float(np.mean(np.diff(up))) * dt
    omega_n, zeta = math.sqrt(k / I), c / (2 * math.sqrt(k * I))
    assert period == pytest.approx(2 * math.pi / (omega_n * math.sqrt(1 - zeta ** 2)), rel=0.01)
    # the envelope: peaks fall at zeta omega_n plus implicit Euler's omega_n^2 h / 2 (h the substep)
    h = dt / 4
    peaks = [abs(e[int(round(u + 0.75 * period / dt))]) for u in up[:3]]
    rate = math.log(peaks[0] / peaks[2]) / (2 * period)
    assert rate == pytest.approx(zeta * omega_n + omega_n ** 2 * h / 2, rel=0.01)
    # and it closes on the target at least as fast as the exact envelope (1 + zeta-sized phase slack)
    T = len(theta) * dt
    assert abs(e[-1]) <= target * math.exp(-zeta * omega_n * T) / math.sqrt(1 - zeta ** 2)


@pytest.mark.parametrize("solver", SOLVERS)
def test_a_servo_never_exceeds_its_max_torque_and_takes_the_short_way_round(solver):
    # saturated at first (k times the 2 rad error is 40 times max_torque), yet strong enough to
    # brake: the clamp holds |torque| <= max_torque throughout. Then a target of -3 rad from +2 rad:
    # 1.28 rad forwards through pi, not 5 rad back through 0
    dt, max_torque = 1 / 240, 0.5
    w, body, j, I = rotor(solver, None, omega0=0.0)
    w.set_joint_motor(j, sg.Motor(0.0, max_torque, position=2.0, stiffness=10.0, damping=1.0))
    torques = []
    for _ in range(240 * 4):
        w.step(dt)
        torques.append(w.joint_torques[j][2])
    assert max(abs(t) for t in torques) <= max_torque * (1 + 1e-12)
    assert w.joint_positions[j] == pytest.approx(2.0, abs=1e-3)
    w.set_joint_motor(j, sg.Motor(0.0, max_torque, position=-3.0, stiffness=10.0, damping=1.0))
    w.step(dt, 10)
    assert w.joint_velocities[j] > 0.0  # forwards through pi, not back through 0
    w.step(dt, 240 * 4)
    assert abs(math.remainder(w.joint_positions[j] + 3.0, 2 * math.pi)) < 1e-3
    assert max(abs(t) for t in torques) == pytest.approx(max_torque, rel=1e-12)  # it did saturate


def test_a_damped_slider_falls_at_the_terminal_speed():
    # a 2 kg block on a vertical slider with damping c falls at m g / c once the transient is gone
    m, c, dt = 2.0, 40.0, 1 / 240
    w = sg.World(gravity=(0.0, 0.0, -9.81), sleeping=False)
    ground = w.add_static(sg.Box((0.1, 0.1, 0.1)), position=(0.0, 0.0, 5.0))
    block = w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=m, position=(0.0, 0.0, 4.0))
    j = w.add_joint(sg.Prismatic(ground, block, anchor=(0, 0, 4.0), axis=(0, 0, 1),
                                 motor=sg.Motor(0.0, math.inf, damping=c)))
    w.step(dt, 240)  # tau = m / c = 0.05 s: 20 time constants
    assert w.joint_velocities[j] == pytest.approx(-m * 9.81 / c, rel=1e-6)


@pytest.mark.parametrize("field, value, message", [
    ("stiffness", -1.0, "stiffness must be finite and >= 0"),
    ("stiffness", math.nan, "stiffness must be finite and >= 0"),
    ("damping", -0.5, "damping must be finite and >= 0"),
    ("damping", math.inf, "damping must be finite and >= 0"),
    ("position", math.nan, "position must be finite"),
])
def test_bad_drive_settings_name_the_joint_and_change_nothing(field, value, message):
    w, body, j, I = rotor("pgs", sg.Motor(1.0, 2.0))
    before = w.joint(j)
    bad = sg.Motor(0.0, 1.0, **{field: value})
    with pytest.raises(ValueError, match=message) as info:
        w.set_joint_motor(j, bad)
    assert "joint 0" in str(info.value)
    assert w.joint(j)["motor_speed"] == before["motor_speed"] == 1.0
    assert w.joint(j)["motor_max_force"] == 2.0
    n = w.num_joints
    with pytest.raises(ValueError, match=message):
        w.add_joint(sg.Revolute(0, body, anchor=(0, 0, 0), axis=(0, 0, 1), motor=bad))
    assert w.num_joints == n
    with pytest.raises(TypeError, match="motor stiffness"):
        w.set_joint_motor(j, sg.Motor(0.0, 1.0, stiffness="stiff"))


def test_a_saved_state_and_a_pickle_keep_the_drive():
    import pickle
    w, body, j, I = rotor("pgs", sg.Motor(0.3, 5.0, position=1.0, stiffness=2.0, damping=0.4))
    w.step(1 / 240, 30)
    saved = w.save_state()
    copy = pickle.loads(pickle.dumps(w))
    w.step(1 / 240, 60)
    ahead = w.joint_positions.copy()
    w.restore_state(saved)
    w.step(1 / 240, 60)
    assert np.array_equal(w.joint_positions, ahead)
    copy.step(1 / 240, 60)
    assert np.array_equal(copy.joint_positions, ahead)
    assert copy.joint(j)["motor_stiffness"] == 2.0 and copy.joint(j)["motor_damping"] == 0.4
    assert copy.joint(j)["motor_position"] == 1.0


@pytest.mark.parametrize("solver", SOLVERS)
def test_joint_friction_brakes_a_rotor_at_f_over_i_and_holds_it(solver):
    # Coulomb friction f on a free rotor: omega falls at f / I and stops at t = I omega0 / f, then
    # stays at rest (the row holds it, |torque| <= f); before it stops the torque is -f exactly
    f, dt = 0.02, 1 / 240
    w, body, j, I = rotor(solver, None, omega0=3.0, friction=f)
    stop = I * 3.0 / f
    steps = int(0.5 * stop / dt)
    w.step(dt, steps)
    assert w.joint_velocities[j] == pytest.approx(3.0 - f / I * steps * dt, rel=1e-9)
    assert w.joint_torques[j][2] == pytest.approx(-f, rel=1e-12)
    w.step(dt, 2 * steps)
    assert abs(w.joint_velocities[j]) < 1e-12
    assert abs(w.joint_torques[j][2]) <= f


def test_joint_friction_holds_a_slider_below_it_and_lets_it_slide_above():
    # a 1 kg block on a vertical slider: friction above m g holds it; below, it falls at g - f / m
    dt = 1 / 240
    for f, expected in ((12.0, 0.0), (4.0, -(9.81 - 4.0) * 1.0)):
        w = sg.World(gravity=(0.0, 0.0, -9.81), sleeping=False)
        ground = w.add_static(sg.Box((0.1, 0.1, 0.1)), position=(0.0, 0.0, 5.0))
        block = w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=1.0, position=(0.0, 0.0, 4.0))
        j = w.add_joint(sg.Prismatic(ground, block, anchor=(0, 0, 4.0), axis=(0, 0, 1), friction=f))
        w.step(dt, 240)
        assert w.joint_velocities[j] == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize("bad, error, message", [
    (lambda g, b: sg.Revolute(g, b, anchor=(0, 0, 0), friction=-1.0), ValueError, "friction must be finite and >= 0"),
    (lambda g, b: sg.Prismatic(g, b, friction=math.nan), ValueError, "friction must be finite and >= 0"),
    (lambda g, b: sg.Revolute(g, b, anchor=(0, 0, 0), friction="some"), TypeError, "friction"),
])
def test_bad_friction_names_the_joint_and_adds_nothing(bad, error, message):
    w, body, j, I = rotor("pgs", None)
    with pytest.raises(error, match=message):
        w.add_joint(bad(0, body))
    assert w.num_joints == 1


def hanging(break_force, solver="pgs"):
    """A 2 kg ball hanging 1 m under a static anchor on a rod (a Distance joint), at rest: the rod
    carries m g = 19.62 N."""
    w = sg.World(gravity=(0.0, 0.0, -9.81), solver=solver, sleeping=False)
    top = w.add_static(sg.Box((0.05, 0.05, 0.05)), position=(0.0, 0.0, 2.0))
    ball = w.add_body(sg.Sphere(0.1), mass=2.0, position=(0.0, 0.0, 1.0))
    j = w.add_joint(sg.Distance(top, ball, (0, 0, 2.0), (0, 0, 1.0), break_force=break_force))
    return w, ball, j


@pytest.mark.parametrize("solver", SOLVERS)
def test_a_rod_breaks_under_a_load_past_its_break_force_and_holds_below(solver):
    dt = 1 / 240
    w, ball, j = hanging(25.0, solver)  # above m g: it holds
    w.step(dt, 120)
    assert len(w.joint_breaks) == 0 and not w.joint(j)["broken"]
    assert w.positions[ball][2] == pytest.approx(1.0, abs=1e-3)
    assert np.linalg.norm(w.joint_forces[j]) == pytest.approx(2.0 * 9.81, rel=1e-3)
    w, ball, j = hanging(15.0, solver)  # below m g: it breaks after the first step, then falls free
    w.step(dt, 121)
    breaks = w.joint_breaks
    assert breaks.step.tolist() == [0] and breaks.joint.tolist() == [j]
    assert np.linalg.norm(breaks.force[0]) > 15.0
    assert w.joint(j)["broken"] and np.all(w.joint_forces[j] == 0.0)
    # 120 steps of free fall after the breaking step: v = -g t (the first step held it)
    assert w.velocities[ball][2] == pytest.approx(-9.81 * 120 * dt, rel=1e-9)
    w.step(dt, 10)
    assert len(w.joint_breaks) == 0  # each call lists its own


def test_a_broken_joint_can_be_mended_and_its_bodies_collide_while_broken():
    dt = 1 / 240
    w = sg.World(gravity=(0.0, 0.0, -9.81), sleeping=False)
    floor = w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    box = w.add_body(sg.Box((0.2, 0.2, 0.2)), mass=1.0, position=(0.0, 0.0, 0.5))
    # welded to the floor through the floor: while welded they do not collide
    j = w.add_joint(sg.Fixed(floor, box, anchor=(0.0, 0.0, 0.5)))
    w.step(dt, 10)
    assert len(w.contacts) == 0 and w.positions[box][2] == pytest.approx(0.5, abs=1e-6)
    w.set_joint_broken(j)
    w.step(dt, 240)
    assert w.positions[box][2] == pytest.approx(0.2, abs=2e-3)  # fell onto the floor, resting
    assert len(w.contacts) > 0 and len(w.joint_breaks) == 0  # broken by a call, not by a force
    w.set_joint_broken(j, False)
    w.step(dt)
    assert len(w.contacts) == 0 and not w.joint(j)["broken"]


def test_a_saved_state_keeps_a_broken_joint_broken():
    import pickle
    w, ball, j = hanging(15.0)
    saved = w.save_state()
    w.step(1 / 240, 5)
    assert w.joint(j)["broken"]
    copy = pickle.loads(pickle.dumps(w))
    assert copy.joint(j)["broken"]
    copy.step(1 / 240, 5)
    w.step(1 / 240, 5)
    assert np.array_equal(copy.positions, w.positions)
    w.restore_state(saved)
    assert not w.joint(j)["broken"]
    w.step(1 / 240)
    assert w.joint_breaks.joint.tolist() == [j]


@pytest.mark.parametrize("value, error", [(0.0, ValueError), (-1.0, ValueError), (math.nan, ValueError),
                                          ("big", TypeError)])
def test_bad_break_limits_name_the_joint_and_add_nothing(value, error):
    w = sg.World()
    top = w.add_static(sg.Box((0.05, 0.05, 0.05)))
    ball = w.add_body(sg.Sphere(0.1), mass=1.0, position=(0.0, 0.0, -1.0))
    for kw in ("break_force", "break_torque"):
        with pytest.raises(error, match=kw):
            w.add_joint(sg.Spherical(top, ball, (0, 0, 0), **{kw: value}))
        assert w.num_joints == 0


@pytest.mark.parametrize("solver", SOLVERS)
def test_an_effort_spins_a_rotor_up_at_tau_over_i_and_is_set_per_step(solver):
    # a constant torque tau about the hinge: omega = tau t / I, exactly (tau h / I per substep)
    dt, tau = 1 / 240, 0.3
    w, body, j, I = rotor(solver, None, omega0=0.0)
    w.set_joint_effort(j, tau)
    w.step(dt, 120)
    assert w.joint_velocities[j] == pytest.approx(tau / I * 120 * dt, rel=1e-12)
    assert w.joint_torques[j][2] == pytest.approx(tau, rel=1e-12)  # what the joint transmits to B
    w.set_joint_effort(j, -tau)  # a control changed between steps: back down to rest
    w.step(dt, 120)
    assert abs(w.joint_velocities[j]) < 1e-12
    w.set_joint_effort(j, 0.0)
    w.step(dt, 10)
    assert abs(w.joint_velocities[j]) < 1e-12 and w.joint(j)["effort"] == 0.0


def test_an_effort_pushes_a_slider_at_f_over_m_and_bad_efforts_are_refused():
    dt, force = 1 / 240, 3.0
    w = sg.World(gravity=(0.0, 0.0, 0.0), sleeping=False)
    ground = w.add_static(sg.Box((0.1, 0.1, 0.1)))
    block = w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=2.0, position=(1.0, 0.0, 0.0))
    j = w.add_joint(sg.Prismatic(ground, block, axis=(1, 0, 0), effort=force))
    w.step(dt, 60)
    assert w.joint_velocities[j] == pytest.approx(force / 2.0 * 60 * dt, rel=1e-12)
    with pytest.raises(ValueError, match="joint 0.*effort must be finite"):
        w.set_joint_effort(j, math.nan)
    assert w.joint(j)["effort"] == force
    ball = w.add_joint(sg.Spherical(ground, block, (0.5, 0, 0)))
    with pytest.raises(ValueError, match="only Revolute and Prismatic joints take an effort"):
        w.set_joint_effort(ball, 1.0)
    with pytest.raises(TypeError, match="effort"):
        w.set_joint_effort(j, None)


@pytest.mark.parametrize("solver", SOLVERS)
def test_limit_and_motor_activity_read_as_arrays(solver):
    # a 1 kg rod on a hinge resting on its lower limit under gravity (the limit carries m g L / 2
    # about the hinge), a saturated motor on a free wheel, and a joint without either
    dt = 1 / 240
    w = sg.World(gravity=(0.0, 0.0, -9.81), solver=solver, sleeping=False)
    ground = w.add_static(sg.Box((0.05, 0.05, 0.05)), position=(0.0, 0.0, 5.0))
    rod = w.add_body(sg.Box((0.5, 0.02, 0.02)), mass=1.0, position=(0.5, 0.0, 5.0))
    hinge = w.add_joint(sg.Revolute(ground, rod, anchor=(0, 0, 5.0), axis=(0, 1, 0), limits=(0.0, 0.5)))
    wheel = w.add_body(sg.Sphere(0.1), mass=1.0, position=(3.0, 0.0, 5.0))
    motor = w.add_joint(sg.Revolute(ground, wheel, anchor=(3.0, 0, 5.0), axis=(0, 0, 1),
                                    motor=sg.Motor(100.0, max_torque=0.01)))
    free = w.add_body(sg.Sphere(0.1), mass=1.0, position=(-3.0, 0.0, 5.0))
    ball = w.add_joint(sg.Spherical(ground, free, (-3.0, 0.0, 5.0)))
    w.step(dt, 480)
    # the rod along +x turns about +y as it falls (x towards -z: a positive angle), swings down to
    # its upper limit, 0.5 rad, and rests there: the limit pushes back (negative) with the weight's
    # moment about the hinge, m g (L / 2) cos(0.5)
    assert w.joint_positions[hinge] == pytest.approx(0.5, abs=1e-3)
    limits = w.joint_limit_forces
    # (at the angle it rests at: the soft step's limit is a stiff spring, a fraction of a mrad past)
    assert limits[hinge] == pytest.approx(-9.81 * 0.5 * math.cos(w.joint_positions[hinge]), rel=1e-9)
    assert limits[motor] == 0.0 and limits[ball] == 0.0
    motors = w.joint_motor_forces
    assert motors[motor] == pytest.approx(0.01, rel=1e-12)  # saturated at its max torque
    assert math.isnan(motors[hinge]) and math.isnan(motors[ball])
    assert w.joint_row_forces.shape == (3, 11)
