"""Joints (issue 23; docs/conventions.md, "Joints"): hinge, slider, ball, weld and distance joints
in both solvers, checked against closed forms of mechanics, plus their bookkeeping (saved states,
threads, islands, collisions between jointed bodies) and bad input.

Tolerances come from the physics and the integrator: a step of h makes an O(h^2) local error in
the phase, so a pendulum's period at dt = 1/240 is within about 1e-4 of the closed form; joint rows are
solved at the substep's midpoint poses, so that a swing neither loses nor gains energy at first
order (docs, "Joints").
"""
import math
import pickle

import numpy as np
import pytest
from helpers import every_kind
from scipy.special import ellipk

import signorini as sg

G = 9.81
DT = 1.0 / 240.0
SOLVERS = ["pgs", "soft"]
# the semi-implicit Euler step falls a t (t + h) / 2 in time t, not a t^2 / 2, h the substep
# (World.substep_count: 1/960 s for both solvers in a world with joints, at the defaults)
# the soft step's joints are springs of joint_hertz = 240 Hz: a point held by one is off by up to
# ~1e-5 m here (g / omega^2 = 4.3e-3 mm under its own weight, more while it swings; at 60 Hz, 16
# times as far: the bound was 2e-4 m then), the PGS's by ~1e-6 m
JOINT_ERROR = {"pgs": 1e-5, "soft": 1.25e-5}


def world(solver, **kw):
    kw.setdefault("sleeping", False)
    kw.setdefault("gravity", (0.0, 0.0, -G))
    return sg.World(solver=solver, **kw)


def pendulum(solver, theta0, length=1.0, **kw):
    """A point-like bob (1 kg sphere of radius 1 cm) on a hinge about y at the origin, hanging at
    theta0 from the vertical; returns (world, bob, joint). The hinge holds the bob to a static
    plane far below (the world)."""
    w = world(solver, **kw)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    bob = w.add_body(sg.Sphere(0.01), mass=1.0,
                     position=(length * math.sin(theta0), 0.0, -length * math.cos(theta0)))
    j = w.add_joint(sg.Revolute(ground, bob, anchor=(0, 0, 0), axis=(0, 1, 0)))
    return w, bob, j


def periods(w, bob, seconds):
    """Periods (s) between successive downward crossings of x = 0 by the bob (linear interpolation)."""
    t, x = [], []
    for _ in range(int(round(seconds / DT))):
        w.step(DT)
        t.append(w.time)
        x.append(w.positions[bob][0])
    t, x = np.array(t), np.array(x)
    i = np.where((x[:-1] > 0) & (x[1:] <= 0))[0]
    crossings = t[i] + (t[i + 1] - t[i]) * x[i] / (x[i] - x[i + 1])
    return np.diff(crossings)


def energy(w):
    return w.kinetic_energy() + w.potential_energy()


# --------------------------------------------------------------------------- pendulums

@pytest.mark.parametrize("solver", SOLVERS)
def test_small_angle_period(solver):
    # 0.05 rad: the finite-amplitude correction 1 + theta0^2 / 16 = 1.00016 is well inside 0.5 %;
    # the bob's own inertia (2/5 m r^2 = 4e-5 of m L^2) likewise
    w, bob, _ = pendulum(solver, 0.05)
    P = periods(w, bob, 5.0)
    expected = 2 * math.pi * math.sqrt(1.0 / G)
    assert len(P) >= 1
    np.testing.assert_allclose(P, expected, rtol=5e-3)


@pytest.mark.parametrize("solver", SOLVERS)
def test_large_amplitude_period(solver):
    # released at 90 degrees: T = 4 sqrt(L/g) K(sin^2(theta0 / 2)) (K the complete elliptic
    # integral of the first kind with parameter m = k^2, scipy's convention)
    w, bob, _ = pendulum(solver, math.pi / 2)
    P = periods(w, bob, 5.0)
    expected = 4 * math.sqrt(1.0 / G) * ellipk(math.sin(math.pi / 4) ** 2)
    assert len(P) >= 1
    np.testing.assert_allclose(P[0], expected, rtol=5e-3)


@pytest.mark.parametrize("solver", SOLVERS)
def test_pendulum_joint_force_and_reading(solver):
    # hanging at rest: the joint carries the bob's weight; the hinge's coordinate is 0, its rate 0
    w, bob, j = pendulum(solver, 0.0)
    w.step(DT, 10)
    # the force on B (the bob) is m g up; no torque about the bob's anchor
    np.testing.assert_allclose(w.joint_forces[j], [0, 0, G], atol=1e-6)
    np.testing.assert_allclose(w.joint_torques[j], 0.0, atol=1e-6)
    assert abs(w.joint_positions[j]) < 1e-9 and abs(w.joint_velocities[j]) < 1e-9
    # the soft step's joint is a spring of joint_hertz (240 Hz): it sags by g / omega^2 = 4.3e-3 mm
    # under the weight
    sag = G / (2 * math.pi * w.solver["joint_hertz"]) ** 2 if solver == "soft" else 0.0
    np.testing.assert_allclose(w.positions[bob], [0, 0, -1 - sag], atol=1e-5)


@pytest.mark.parametrize("solver", SOLVERS)
def test_joint_coordinate_follows_the_bob(solver):
    # the hinge's angle is the bob's angle about +y from where it was made (here 0 at the bottom);
    # its rate is omega_y of the bob
    w, bob, j = pendulum(solver, 0.0)
    w.set_velocity(bob, (1.0, 0.0, 0.0))
    w.set_angular_velocity(bob, (0.0, -1.0, 0.0))
    for _ in range(30):
        w.step(DT)
        x, _, z = w.positions[bob]
        assert w.joint_positions[j] == pytest.approx(math.atan2(-x, -z), abs=JOINT_ERROR[solver])
        assert w.joint_velocities[j] == pytest.approx(w.angular_velocities[bob][1], abs=1e-9)


def double_pendulum(solver, **kw):
    """Two 1 kg point-like bobs on massless-like hinges of 1 m (about y), the first at the origin,
    the second at the first bob; released with both links horizontal-ish (a chaotic swing)."""
    w = world(solver, **kw)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    a = w.add_body(sg.Sphere(0.01), mass=1.0, position=(1.0, 0.0, 0.0))
    b = w.add_body(sg.Sphere(0.01), mass=1.0, position=(1.0 + math.sin(1.0), 0.0, -math.cos(1.0)))
    w.add_joint(sg.Revolute(ground, a, anchor=(0, 0, 0), axis=(0, 1, 0)))
    w.add_joint(sg.Revolute(a, b, anchor=(1, 0, 0), axis=(0, 1, 0)))
    return w, a, b


@pytest.mark.parametrize("solver, bound", [("pgs", 0.01), ("soft", 0.02)])
def test_double_pendulum_energy(solver, bound):
    # frictionless: the total energy stays within 1 % of the scale 2 m g L = 19.6 J over 20 s at
    # dt 1/240 with the PGS (measured: 0.16 %); the soft step's damped joint springs let it wander
    # further (measured: 1.04 %; docs/conventions.md, "Joints")
    w, a, b = double_pendulum(solver)
    E0 = energy(w)
    scale = 2 * G * 1.0
    worst = 0.0
    for _ in range(20 * 240):
        w.step(DT)
        worst = max(worst, abs(energy(w) - E0))
    assert worst < bound * scale, worst / scale


@pytest.mark.parametrize("solver, bound", [("pgs", 0.005), ("soft", 0.01)])
def test_double_pendulum_energy_short(solver, bound):
    # the quick version of the test above: 2 s (measured: PGS 0.15 %, soft step 0.5 % of 2 m g L)
    w, a, b = double_pendulum(solver)
    E0 = energy(w)
    for _ in range(2 * 240):
        w.step(DT)
        assert abs(energy(w) - E0) < bound * 2 * G


# --------------------------------------------------------------------------- each joint kind

@pytest.mark.parametrize("solver", SOLVERS)
def test_hinge_axis_holds(solver):
    # a box hinged at its centre about y, spun about all three axes: after the first step only the
    # spin about y is left (the hinge takes the rest), and it stays so; the centre stays put
    w = world(solver, gravity=(0, 0, 0))
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    box = w.add_body(sg.Box((0.3, 0.2, 0.1)), density=500.0, angular_velocity=(1.0, 2.0, 0.5))
    w.add_joint(sg.Revolute(ground, box, anchor=(0, 0, 0), axis=(0, 1, 0)))
    for _ in range(240):
        w.step(DT)
        omega = w.angular_velocities[box]
        assert math.hypot(omega[0], omega[2]) < 1e-6
        assert np.linalg.norm(w.positions[box]) < 1e-6
        # the box's y axis is still the world's y
        assert abs(w.rotations[box][1, 1] - 1.0) < 1e-6
    assert abs(w.angular_velocities[box][1]) > 0.1


@pytest.mark.parametrize("solver", SOLVERS)
def test_prismatic_slides_along_tilted_axis(solver):
    # a box on a slider along an axis tilted theta below the horizontal: it accelerates at
    # g sin(theta) along the axis, does not turn and never leaves the axis
    theta = math.radians(30.0)
    axis = np.array([math.cos(theta), 0.0, -math.sin(theta)])
    w = world(solver)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    box = w.add_body(sg.Box((0.2, 0.1, 0.1)), density=500.0, position=(0, 0, 0))
    j = w.add_joint(sg.Prismatic(ground, box, anchor=(0, 0, 0), axis=axis))
    w.step(DT, 240)
    t, h, a = w.time, DT / w.substep_count(DT), G * math.sin(theta)
    assert w.joint_positions[j] == pytest.approx(0.5 * a * t * (t + h), rel=1e-6)
    assert w.joint_velocities[j] == pytest.approx(a * t, rel=1e-6)
    p = w.positions[box]
    off_axis = p - p.dot(axis) * axis
    assert np.linalg.norm(off_axis) < JOINT_ERROR[solver]
    np.testing.assert_allclose(w.rotations[box], np.eye(3), atol=1e-6)


@pytest.mark.parametrize("solver", SOLVERS)
def test_fixed_joint_keeps_two_boxes_rigid(solver):
    # two boxes welded side by side, thrown spinning under gravity: their relative pose stays what
    # it was (to the joint's tolerance: 1e-4 m and 1e-4 rad), and the pair's centre of mass falls
    # freely (the weld is internal)
    w = world(solver)
    a = w.add_body(sg.Box((0.2, 0.1, 0.1)), density=500.0, position=(0.0, 0.0, 10.0),
                   velocity=(1.0, 0.0, 2.0), angular_velocity=(0.5, 1.0, 2.0))
    b = w.add_body(sg.Box((0.1, 0.1, 0.3)), density=800.0, position=(0.3, 0.0, 10.2))
    # b moves with a's spin from the start (a rigid pair)
    omega = np.array([0.5, 1.0, 2.0])
    w.set_velocity(b, np.array([1.0, 0.0, 2.0]) + np.cross(omega, [0.3, 0.0, 0.2]))
    w.set_angular_velocity(b, omega)
    w.add_joint(sg.Fixed(a, b, anchor=(0.2, 0.0, 10.1)))
    m = w.masses
    com0 = (m[a] * w.positions[a] + m[b] * w.positions[b]) / (m[a] + m[b])
    v_com = (m[a] * w.velocities[a] + m[b] * w.velocities[b]) / (m[a] + m[b])
    rel0 = w.rotations[a].T @ (w.positions[b] - w.positions[a])
    Rrel0 = w.rotations[a].T @ w.rotations[b]
    for _ in range(240):
        w.step(DT)
        rel = w.rotations[a].T @ (w.positions[b] - w.positions[a])
        assert np.linalg.norm(rel - rel0) < 1e-4
        assert np.linalg.norm(w.rotations[a].T @ w.rotations[b] - Rrel0) < 1e-4
    com = (m[a] * w.positions[a] + m[b] * w.positions[b]) / (m[a] + m[b])
    t, h = w.time, DT / w.substep_count(DT)
    expected = com0 + v_com * t + 0.5 * np.array([0, 0, -G]) * t * (t + h)
    # the joint's forces are equal and opposite, so the centre of mass falls freely to rounding
    # (the position pass moves the pair by pseudo-velocities of zero sum as well)
    np.testing.assert_allclose(com, expected, atol=1e-9)


@pytest.mark.parametrize("solver", SOLVERS)
def test_spherical_joint_keeps_the_point(solver):
    # a rod-like box on a ball joint at its end, swinging and twisting: the end stays at the anchor
    w = world(solver)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    rod = w.add_body(sg.Box((0.5, 0.05, 0.05)), density=500.0, position=(0.5, 0.0, 0.0),
                     angular_velocity=(3.0, 0.0, 1.0))
    w.add_joint(sg.Spherical(ground, rod, anchor=(0, 0, 0)))
    for _ in range(480):
        w.step(DT)
        end = w.positions[rod] + w.rotations[rod] @ np.array([-0.5, 0.0, 0.0])
        assert np.linalg.norm(end) < 1e-3


@pytest.mark.parametrize("solver", SOLVERS)
def test_distance_rope_is_slack_then_taut(solver):
    # a rope of 1 m from the origin to a bob 0.5 m below: the bob falls freely until the rope is
    # taut (0.5 m of free fall), then hangs at 1 m (to 1 mm)
    w = world(solver)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    bob = w.add_body(sg.Sphere(0.01), mass=1.0, position=(0.0, 0.0, -0.5))
    j = w.add_joint(sg.Distance(ground, bob, (0, 0, 0), (0, 0, -0.5), min_length=0.0, max_length=1.0))
    t_free = math.sqrt(2 * 0.5 / G)
    w.step(DT, int(t_free / DT) - 2)  # still slack: free fall
    t, h = w.time, DT / w.substep_count(DT)
    assert w.positions[bob][2] == pytest.approx(-0.5 - 0.5 * G * t * (t + h), abs=1e-9)
    np.testing.assert_allclose(w.joint_forces[j], 0.0, atol=1e-12)
    longest = 0.0
    for _ in range(480):
        w.step(DT)
        longest = max(longest, np.linalg.norm(w.positions[bob]))
    assert longest < 1.0 + 1e-3
    assert np.linalg.norm(w.positions[bob]) == pytest.approx(1.0, abs=1e-3)


@pytest.mark.parametrize("solver", SOLVERS)
def test_distance_rod_holds_its_length(solver):
    # a rod (min = max = the length at creation) swinging a bob thrown sideways at 2 m/s: the length
    # stays within 1 mm; thrown inwards at 1 m/s, the rod pushes it back out (it does not come
    # closer than the rod's length by more than the soft spring's give, v / (2 zeta omega) = 0.7 mm)
    for velocity, tol in (((1.2, 0.0, 1.6), 1e-3), ((-0.8, 0.0, 0.6), 1e-3)):
        w = world(solver)
        ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
        bob = w.add_body(sg.Sphere(0.01), mass=1.0, position=(0.8, 0.0, -0.6), velocity=velocity)
        w.add_joint(sg.Distance(ground, bob, (0, 0, 0), (0.8, 0.0, -0.6)))
        for _ in range(480):
            w.step(DT)
            assert abs(np.linalg.norm(w.positions[bob]) - 1.0) < tol


@pytest.mark.parametrize("solver", SOLVERS)
def test_hinge_limit_stops_the_swing(solver):
    # a 10 kg arm (a 1 m box hinged at its end) released horizontal swings down (its angle about +y
    # grows) until the upper limit of 0.5 rad stops it: it never passes it by more than 1 degree
    # and comes to rest there
    w = world(solver)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    bob = w.add_body(sg.Box((0.5, 0.05, 0.05)), mass=10.0, position=(0.5, 0.0, 0.0))
    j = w.add_joint(sg.Revolute(ground, bob, anchor=(0, 0, 0), axis=(0, 1, 0), limits=(-0.3, 0.5)))
    highest = -1.0
    for _ in range(3 * 240):
        w.step(DT)
        highest = max(highest, w.joint_positions[j])
    assert 0.5 - 1e-3 < highest < 0.5 + math.radians(1.0)
    assert w.joint_positions[j] == pytest.approx(0.5, abs=math.radians(1.0))
    assert abs(w.joint_velocities[j]) < 1e-2


@pytest.mark.parametrize("solver", SOLVERS)
def test_hinge_limit_stops_a_point_like_bob(solver):
    # the PGS solves the hinge's limit with its point and tilt rows as one group (docs, "Joints"):
    # measured, it passes the limit by 3e-8 degrees. Row by row it took the turn back as spin and
    # overshot to 0.60 rad. The soft step's group takes mass_scale times the rigid group's answer
    # (docs, "The soft step's group"): 0.002 degrees (0.03 with 60 Hz joints). Each block softened
    # on its own, the point rows gave back a tenth of their answer to the limit, which spun the bob
    # at thousands of rad/s: the guard stopped an energy explosion at the impact
    w = world(solver)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    bob = w.add_body(sg.Sphere(0.01), mass=10.0, position=(1.0, 0.0, 0.0))
    j = w.add_joint(sg.Revolute(ground, bob, anchor=(0, 0, 0), axis=(0, 1, 0), limits=(-0.3, 0.5)))
    highest = -1.0
    for _ in range(3 * 240):
        w.step(DT)
        highest = max(highest, w.joint_positions[j])
    assert highest < 0.5 + math.radians(1.0)
    assert w.joint_positions[j] == pytest.approx(0.5, abs=math.radians(1.0))


@pytest.mark.parametrize("solver", SOLVERS)
def test_motor_reaches_its_speed_within_its_torque(solver):
    # a wheel (box spun about z at its centre, no gravity torque) driven at 3 rad/s with at most
    # 0.5 N m: it accelerates at tau / I_zz until it reaches 3 rad/s (within 1 %) and the motor's
    # torque never exceeds 0.5 N m
    w = world(solver)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    wheel = w.add_body(sg.Box((0.3, 0.3, 0.05)), mass=2.0)
    j = w.add_joint(sg.Revolute(ground, wheel, anchor=(0, 0, 0), axis=(0, 0, 1),
                                motor=sg.Motor(3.0, max_torque=0.5)))
    Izz = 2.0 / 3.0 * (0.3 ** 2 + 0.3 ** 2)
    w.step(DT, 24)  # 0.1 s: still accelerating at the torque bound
    assert w.joint_velocities[j] == pytest.approx(0.5 / Izz * w.time, rel=1e-6)
    for _ in range(2 * 240):
        w.step(DT)
        assert abs(w.joint_torques[j][2]) <= 0.5 * (1 + 1e-12)
    assert w.joint_velocities[j] == pytest.approx(3.0, rel=1e-2)


@pytest.mark.parametrize("solver", SOLVERS)
def test_slider_motor_and_limit(solver):
    # a slider along x driven at 0.5 m/s by at most 100 N (far more than needed) stops at its upper
    # limit of 0.2 m
    w = world(solver)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    box = w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=1.0)
    j = w.add_joint(sg.Prismatic(ground, box, anchor=(0, 0, 0), axis=(1, 0, 0), limits=(-0.1, 0.2),
                                 motor=sg.Motor(0.5, 100.0)))
    w.step(DT, 24)
    assert w.joint_velocities[j] == pytest.approx(0.5, rel=1e-6)
    w.step(DT, 240)
    assert w.joint_positions[j] == pytest.approx(0.2, abs=1e-3)
    assert abs(w.joint_velocities[j]) < 1e-6


# --------------------------------------------------------------------------- contacts and joints

def chain(solver, threads=None, links=4):
    """A chain of boxes on hinges from a static anchor, swinging onto a floor (contacts and joints)."""
    w = world(solver, threads=threads)
    floor = w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    prev = floor
    for k in range(links):
        b = w.add_body(sg.Box((0.2, 0.05, 0.05)), density=500.0, position=(0.2 + 0.4 * k, 0.0, 1.0))
        w.add_joint(sg.Revolute(prev, b, anchor=(0.4 * k, 0.0, 1.0), axis=(0, 1, 0)))
        prev = b
    for k in range(6):
        w.add_body(sg.Box((0.1, 0.1, 0.1)), density=500.0, position=(0.9 + 0.25 * k, 0.1, 0.1 + 0.01 * k))
    return w


@pytest.mark.parametrize("solver", SOLVERS)
def test_threads_bit_identical(solver):
    one, two = chain(solver, threads=1), chain(solver, threads=2)
    one.step(DT, 120)
    two.step(DT, 120)
    assert len(one.contacts) > 0
    assert np.array_equal(one.positions, two.positions)
    assert np.array_equal(one.velocities, two.velocities)
    assert np.array_equal(one.joint_forces, two.joint_forces)


@pytest.mark.parametrize("solver", SOLVERS)
def test_saved_state_continues_bit_identical(solver):
    w = chain(solver)
    w.step(DT, 60)
    saved = w.save_state()
    w.step(DT, 60)
    p, v, f = w.positions.copy(), w.velocities.copy(), w.joint_forces.copy()
    w.restore_state(saved)
    w.step(DT, 60)
    assert np.array_equal(w.positions, p) and np.array_equal(w.velocities, v)
    assert np.array_equal(w.joint_forces, f)
    # a pickled copy goes on the same way (its joints come with the saved state)
    w.restore_state(saved)
    copy = pickle.loads(pickle.dumps(w))
    assert copy.num_joints == w.num_joints == 4
    copy.step(DT, 60)
    assert np.array_equal(copy.positions, p)


def test_restoring_a_state_puts_back_its_joints():
    w, bob, j = pendulum("pgs", 0.3)
    saved = w.save_state()
    w.remove_joint(j)
    assert w.num_joints == 0
    w.restore_state(saved)
    assert w.num_joints == 1
    w.step(DT, 240)
    assert np.linalg.norm(w.positions[bob]) == pytest.approx(1.0, abs=1e-3)


def test_jointed_bodies_do_not_collide_unless_asked():
    # two overlapping boxes: jointed, no contacts between them; with collide_connected=True, contacts;
    # without the joint, contacts again
    for connected in (False, True):
        w = world("pgs", gravity=(0, 0, 0))
        a = w.add_body(sg.Box((0.2, 0.2, 0.2)), density=500.0)
        b = w.add_body(sg.Box((0.2, 0.2, 0.2)), density=500.0, position=(0.3, 0, 0))
        j = w.add_joint(sg.Fixed(a, b, collide_connected=connected))
        assert (len(w.detect_contacts(DT)) > 0) == connected
        w.remove_joint(j)
        assert len(w.detect_contacts(DT)) > 0


def test_world_without_joints_is_unchanged_by_an_added_and_removed_joint():
    # adding and removing a joint leaves the world stepping as one that never had it
    def scene():
        w = world("pgs")
        w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
        for k in range(3):
            w.add_body(sg.Box((0.1, 0.1, 0.1)), density=500.0, position=(0.0, 0.0, 0.1 + 0.21 * k))
        return w
    plain, touched = scene(), scene()
    j = touched.add_joint(sg.Spherical(1, 2, anchor=(0, 0, 0.2)))
    touched.remove_joint(j)
    plain.step(DT, 60)
    touched.step(DT, 60)
    assert np.array_equal(plain.positions, touched.positions)


def test_joint_links_islands_for_sleeping():
    # a pendulum hanging at rest from a second, resting body sleeps as one island; a push on the
    # anchor body wakes the bob too
    w = sg.World(gravity=(0, 0, -G))
    floor = w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    base = w.add_body(sg.Box((0.5, 0.5, 0.1)), density=500.0, position=(0, 0, 0.1))
    bob = w.add_body(sg.Box((0.05, 0.05, 0.05)), density=500.0, position=(1.0, 0.0, 0.1))
    w.add_joint(sg.Distance(base, bob, (0.4, 0, 0.1), (1.0, 0, 0.1), 0.0, 0.7))
    w.step(DT, 480)
    assert not w.awake[base] and not w.awake[bob]
    w.apply_impulse(base, (0.0, 0.0, 1.0))
    w.step(DT)
    assert w.awake[base] and w.awake[bob]
    del floor


def test_removing_a_body_drops_its_joints():
    w = world("pgs")
    a = w.add_body(sg.Sphere(0.1), mass=1.0)
    b = w.add_body(sg.Sphere(0.1), mass=1.0, position=(1, 0, 0))
    c = w.add_body(sg.Sphere(0.1), mass=1.0, position=(2, 0, 0))
    w.add_joint(sg.Spherical(a, b, anchor=(0.5, 0, 0), name="ab"))
    w.add_joint(sg.Spherical(b, c, anchor=(1.5, 0, 0), name="bc"))
    w.remove_body(a)
    assert w.num_joints == 1 and w.find_joint("bc") == 0 and w.find_joint("ab") == -1
    info = w.joint(0)
    assert (info["body_a"], info["body_b"], info["kind"]) == (0, 1, "Spherical")


def test_readings_shapes_and_nan_for_multi_dof():
    w = world("pgs")
    a = w.add_body(sg.Sphere(0.1), mass=1.0)
    b = w.add_body(sg.Sphere(0.1), mass=1.0, position=(1, 0, 0))
    w.add_joint(sg.Revolute(a, b, anchor=(0.5, 0, 0), axis=(0, 0, 1)))
    w.add_joint(sg.Spherical(a, b, anchor=(0.5, 0, 0)))
    w.step(DT)
    assert w.joint_forces.shape == (2, 3) and w.joint_torques.shape == (2, 3)
    assert w.joint_positions.shape == (2,) and w.joint_velocities.shape == (2,)
    assert np.isfinite(w.joint_positions[0]) and np.isnan(w.joint_positions[1])
    assert np.isnan(w.joint_velocities[1])


# --------------------------------------------------------------------------- bad input

def two_bodies():
    w = world("pgs")
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    ground2 = w.add_static(sg.Sphere(0.1), position=(5, 0, 0))
    a = w.add_body(sg.Sphere(0.1), mass=1.0, position=(0, 0, 1))
    b = w.add_body(sg.Sphere(0.1), mass=1.0, position=(1, 0, 1))
    return w, ground, ground2, a, b


@pytest.mark.parametrize("make, error, words", [
    (lambda g, g2, a, b: sg.Revolute(a, 99, anchor=(0, 0, 1)), sg.BodyIndexError, "joint 0 (Revolute)"),
    (lambda g, g2, a, b: sg.Revolute(a, a, anchor=(0, 0, 1)), ValueError, "same body"),
    (lambda g, g2, a, b: sg.Spherical(g, g2, anchor=(0, 0, 1)), ValueError, "both bodies are static"),
    (lambda g, g2, a, b: sg.Revolute(a, b, anchor=(0, 0, 1), axis=(0, 0, 0)), ValueError, "non-zero"),
    (lambda g, g2, a, b: sg.Revolute(a, b, anchor=(0, 0, 1), axis=(0, math.nan, 1)), ValueError, "axis must be finite"),
    (lambda g, g2, a, b: sg.Spherical(a, b, anchor=(0, math.nan, 1)), ValueError, "anchor must be finite"),
    (lambda g, g2, a, b: sg.Revolute(a, b, anchor=(0, 0, 1), limits=(0.5, -0.5)), ValueError, "lower <= upper"),
    (lambda g, g2, a, b: sg.Revolute(a, b, anchor=(0, 0, 1), limits=(0.0, math.nan)), ValueError, "finite"),
    (lambda g, g2, a, b: sg.Prismatic(a, b, axis=(1, 0, 0), motor=sg.Motor(1.0, -2.0)), ValueError, ">= 0"),
    (lambda g, g2, a, b: sg.Distance(a, b, (0, 0, 1), (1, 0, 1), 2.0, 1.0), ValueError, "max_length"),
    (lambda g, g2, a, b: sg.Distance(a, b, (0, 0, 1), (1, 0, 1), -1.0, 1.0), ValueError, "min_length"),
    (lambda g, g2, a, b: sg.Revolute(a, b, anchor="here"), TypeError, "anchor"),
    (lambda g, g2, a, b: sg.Revolute(1.5, b, anchor=(0, 0, 1)), TypeError, "body_a"),
    (lambda g, g2, a, b: sg.Revolute(a, b, anchor=(0, 0, 1), motor=(1, 2)), TypeError, "motor"),
    (lambda g, g2, a, b: sg.Revolute(a, b, anchor=(0, 0, 1), limits=5), TypeError, "limits"),
])
def test_bad_input_names_the_joint_and_changes_nothing(make, error, words):
    w, g, g2, a, b = two_bodies()
    before = w.save_state()
    with pytest.raises(error, match=None) as e:
        w.add_joint(make(g, g2, a, b))
    assert words in str(e.value)
    assert "joint 0" in str(e.value)
    assert w.num_joints == 0
    assert w.save_state().data == before.data


def test_bad_input_more():
    w, g, g2, a, b = two_bodies()
    w.add_joint(sg.Spherical(a, b, anchor=(0.5, 0, 1), name="ball"))
    with pytest.raises(ValueError, match="joint 1 'ball' \\(Spherical\\).*taken"):
        w.add_joint(sg.Spherical(a, g, anchor=(0, 0, 1), name="ball"))
    with pytest.raises(TypeError, match="add_joint"):
        w.add_joint("hinge")
    with pytest.raises(IndexError, match="joint index 3"):
        w.remove_joint(3)
    with pytest.raises(TypeError, match="Motor"):
        sg.Motor(1.0)
    assert w.num_joints == 1


# --------------------------------------------------------------------------- the oracle

def test_oracle_matches_pgs_steps_of_a_jointed_scene():
    # the NumPy oracle (signorini.oracle.joints, never the core) repeats each step of the core from
    # the same state and contacts: every state to 1e-10 (the crosscheck's tolerance: the same
    # formulas in another order of rounding), the same sweep counts, and the joints' forces
    from signorini import compare, oracle
    w = every_kind()
    w.step(DT, 30)  # the chains swing, the joints carry forces, contacts are made
    w.set_joint_broken(4)  # a broken joint makes no rows in either
    report = compare.lockstep(w, DT, 20)
    assert report.largest < 1e-10, "\n".join(report.lines())
    assert report.stat_mismatches == 0, report.first_stat_mismatch
    assert w.solver_stats.contacts > 0
    before = w.snapshot()
    assert len(before["joints"]) == 36
    detected = w.detect_contacts(DT).as_dict()
    contacts = {key: detected[key] for key in ("body_a", "body_b", "point", "normal", "gap", "feature_a", "feature_b")}
    w.step(DT)
    _, info = oracle.step(before, DT, contacts=contacts)
    scale = max(1.0, float(np.abs(w.joint_forces).max()))
    np.testing.assert_allclose(info["joint_force"], w.joint_forces, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(info["joint_torque"], w.joint_torques, rtol=0, atol=1e-10 * scale)
    assert np.abs(w.joint_forces).max() > 0.1


def test_every_kind_runs_in_both_solvers_and_holds():
    # the scene above for 2 s: no joint separates by more than 2 mm at its anchor (the soft step's
    # springs under the impacts), nothing explodes
    for solver in SOLVERS:
        w = every_kind(solver)
        w.step(DT, 480)
        snap = w.snapshot()
        R, P = snap["rotation"], snap["position"]
        for j in snap["joints"]:
            if j["kind"] in ("Revolute", "Spherical", "Fixed"):
                a, b = j["body_a"], j["body_b"]
                gap = (P[b] + R[b] @ j["anchor_b"]) - (P[a] + R[a] @ j["anchor_a"])
                assert np.linalg.norm(gap) < 2e-3, (solver, j["kind"], np.linalg.norm(gap))


def test_a_scene_file_refuses_a_jointed_world_that_has_moved(tmp_path):
    # scene files make joints at the written poses (test_scene_joints): a swung pendulum written
    # so would lose its hinge angle, so it is refused; unswung it is written
    w, bob, j = pendulum("pgs", 0.3)
    w.step(DT, 10)
    with pytest.raises(ValueError, match="joint 0 \\(Revolute\\): .*moved since it was made"):
        w.save_scene(tmp_path / "pendulum.toml")
    assert not (tmp_path / "pendulum.toml").exists()
    assert pendulum("pgs", 0.3)[0].save_scene(tmp_path / "pendulum.toml").exists()


@pytest.mark.parametrize("solver", SOLVERS)
def test_motor_target_set_per_step(solver):
    # a wheel's motor target changed between steps (up, down, off): it follows each within 1 %, and
    # switched off it keeps turning (nothing else acts on it)
    w = world(solver, gravity=(0, 0, 0))
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    wheel = w.add_body(sg.Box((0.3, 0.3, 0.05)), mass=2.0)
    j = w.add_joint(sg.Revolute(ground, wheel, anchor=(0, 0, 0), axis=(0, 0, 1), motor=sg.Motor(1.0, 10.0)))
    for speed in (1.0, 4.0, -2.0):
        w.set_joint_motor(j, sg.Motor(speed, max_torque=10.0))
        w.step(DT, 120)
        assert w.joint_velocities[j] == pytest.approx(speed, rel=1e-2)
    w.set_joint_motor(j, None)
    w.step(DT, 60)
    assert w.joint_velocities[j] == pytest.approx(-2.0, rel=1e-2)
    with pytest.raises(ValueError, match="joint 0 \\(Revolute\\): motor max force"):
        w.set_joint_motor(j, sg.Motor(1.0, -1.0))
    ball = w.add_joint(sg.Spherical(ground, wheel, anchor=(0, 0, 0)))
    with pytest.raises(ValueError, match="only Revolute and Prismatic"):
        w.set_joint_motor(ball, sg.Motor(1.0, 1.0))
    with pytest.raises(IndexError):
        w.set_joint_motor(5, None)


def test_a_bob_hung_from_a_moving_kinematic_carriage_follows_it():
    # sleeping on: a bob on a rod under a kinematic carriage that moves at a steady 0.2 m/s is
    # carried along (the carriage's velocity enters the joint's rows; it is in no island, and the
    # bob stays awake), the rod at its length
    w = sg.World(gravity=(0, 0, -G))
    cart = w.add_body(sg.Box((0.1, 0.1, 0.1)), kinematic=True, position=(0, 0, 1.0), velocity=(0.2, 0, 0))
    bob = w.add_body(sg.Sphere(0.05), mass=1.0, position=(0, 0, 0.5))
    w.add_joint(sg.Distance(cart, bob, (0, 0, 1.0), (0, 0, 0.5)))
    w.step(DT, 3 * 240)
    assert w.awake[bob]
    assert np.linalg.norm(w.positions[bob] - w.positions[cart]) == pytest.approx(0.5, abs=1e-3)
    # it trails the carriage within its swing: started at rest under a carriage at 0.2 m/s, it swings
    # with a velocity amplitude of 0.2 m/s about the carriage, so at most 0.2 / sqrt(g / L) = 0.045 m
    # to either side (the carriage has gone 0.6 m)
    assert abs(w.positions[bob][0] - w.positions[cart][0]) < 0.05
