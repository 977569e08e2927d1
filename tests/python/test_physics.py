"""Scenes with closed-form answers: resting, free rotation, momentum, sliding, speculative stops."""
import math

import numpy as np
import pytest

import signorini as sg

DT = 1 / 240


def test_box_dropped_on_plane_rests_at_half_height_and_does_not_sink():
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    b = w.add_body(sg.Box((0.5, 0.5, 0.5)), density=1000.0, position=(0, 0, 1.5),
                   orientation=(0.98, 0.1, 0.15, 0.05), angular_velocity=(0.5, -0.3, 0.2))
    w.step(DT, 3 * 240)
    # at rest: on a face, its centre at the half height (issue: within 1 mm)
    assert w.positions[b, 2] == pytest.approx(0.5, abs=1e-3)
    assert np.linalg.norm(w.velocities[b]) < 1e-3
    heights = []
    for _ in range(10 * 240):
        w.step(DT)
        heights.append(w.positions[b, 2])
    # 10 s later it has not sunk (nor crept) by more than the same 1 mm
    assert min(heights) > 0.5 - 1e-3 and max(heights) < 0.5 + 1e-3
    assert len(w.contacts) == 4 and w.solver_stats.converged
    # the four corner forces carry the weight exactly: sum alpha = m g
    assert w.contacts.alpha.sum() == pytest.approx(w.masses[b] * 9.81, rel=1e-9)


def test_torque_free_body_keeps_angular_momentum_with_the_explicit_term():
    # |L'| / |L| = sqrt(1 + dt^2 |omega x L|^2 / |L|^2) per step (see tests/cpp/test_dynamics.cpp);
    # at dt = 1/240 and |omega| ~ 1.3 rad/s that is below 1e-5, and with dt = 1e-3 below 1e-6
    w = sg.World(gravity=(0, 0, 0), gyroscopic="explicit")
    b = w.add_body(sg.Box((0.1, 0.3, 0.6)), density=500.0, orientation=(0.9, 0.3, 0.1, -0.2),
                   angular_velocity=(0.4, 1.0, -0.3))
    inertia = w.inertias[b]

    def L():
        R = w.rotations[b]
        return R @ inertia @ R.T @ w.angular_velocities[b]

    worst = 0.0
    for _ in range(2000):
        L0 = L()
        wxL = np.cross(w.angular_velocities[b], L0)
        predicted = math.sqrt(1 + 1e-3 ** 2 * (wxL @ wxL) / (L0 @ L0))
        w.step(1e-3)
        L1 = L()
        ratio = np.linalg.norm(L1) / np.linalg.norm(L0)
        assert ratio == pytest.approx(predicted, abs=1e-12)
        worst = max(worst, abs(ratio - 1))
    assert worst < 1e-6


def test_frictionless_head_on_sphere_collision_keeps_linear_momentum():
    w = sg.World(gravity=(0, 0, 0))
    a = w.add_body(sg.Sphere(0.2), mass=1.0, position=(-1, 0, 0), velocity=(3.0, 0, 0))
    b = w.add_body(sg.Sphere(0.3), mass=2.5, position=(1, 0, 0), velocity=(-1.0, 0, 0))
    p0 = w.masses[a] * w.velocities[a] + w.masses[b] * w.velocities[b]
    collided = False
    for _ in range(240):
        w.step(DT)
        collided |= len(w.contacts) > 0 and w.contacts.impulse.max() > 0
        p = w.masses[a] * w.velocities[a] + w.masses[b] * w.velocities[b]
        assert np.linalg.norm(p - p0) < 1e-9
    assert collided
    # without restitution the two leave the collision with a common normal velocity (perfectly
    # inelastic): v = p0 / (m_a + m_b)
    assert w.velocities[a] == pytest.approx(p0 / 3.5, abs=1e-9)
    assert w.velocities[b] == pytest.approx(p0 / 3.5, abs=1e-9)
    assert np.linalg.norm(w.angular_velocities) < 1e-12


def test_sphere_on_tilted_frictionless_plane_slides_with_g_sin_theta():
    # resting contact removes only the normal velocity: along the slope v(t) = g sin(theta) t
    theta = 0.3
    n = np.array([0.0, -math.sin(theta), math.cos(theta)])
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane(n, 0.0), friction=0.0)
    b = w.add_body(sg.Sphere(0.25), mass=3.0, position=0.25 * n, friction=0.0)
    w.step(DT, 240)
    downhill = -np.array([0.0, math.cos(theta), math.sin(theta)])  # g minus its normal part, unit
    expected = 9.81 * math.sin(theta) * 1.0 * downhill
    assert w.velocities[b] == pytest.approx(expected, abs=1e-9)
    assert np.dot(w.positions[b], n) == pytest.approx(0.25, abs=1e-12)


def test_fast_sphere_is_stopped_at_the_plane_by_a_speculative_contact():
    # 20 m/s at dt = 1/240 moves 8 cm a step: the speculative contact stops it exactly at gap 0
    # instead of letting it tunnel or sink (no restitution yet)
    w = sg.World(gravity=(0, 0, 0))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    b = w.add_body(sg.Sphere(0.1), mass=1.0, position=(0, 0, 1.0), velocity=(0, 0, -20.0))
    lowest = 1.0
    for _ in range(60):
        w.step(DT)
        lowest = min(lowest, w.positions[b, 2])
    assert lowest == pytest.approx(0.1, abs=1e-12)
    assert np.linalg.norm(w.velocities[b]) < 1e-12


def test_newtons_third_law_in_the_contact_impulses():
    # every contact applies +impulse n to B and -impulse n to A: in zero gravity, momentum is kept
    # through a box landing on a spinning box
    w = sg.World(gravity=(0, 0, 0))
    a = w.add_body(sg.Box((0.5, 0.5, 0.2)), density=200.0, angular_velocity=(0, 0, 1.0))
    b = w.add_body(sg.Box((0.2, 0.2, 0.2)), density=800.0, position=(0.1, 0.05, 0.6),
                   orientation=(0.95, 0.2, 0.1, 0), velocity=(0, 0, -2.0))
    p0 = w.masses[a] * w.velocities[a] + w.masses[b] * w.velocities[b]
    touched = 0
    for _ in range(120):
        w.step(DT)
        touched += len(w.contacts)
        p = w.masses[a] * w.velocities[a] + w.masses[b] * w.velocities[b]
        assert np.linalg.norm(p - p0) < 1e-9 * np.linalg.norm(p0)
    assert touched > 0


def test_sphere_rests_on_a_static_convex_mesh():
    # sphere against a convex mesh is exact (closest point over the triangles): it must stop on
    # the top face (z = 0.5) with its centre one radius above it, and stay, without creeping
    from signorini.meshes import box_mesh
    v, f = box_mesh((1.0, 1.0, 0.5))
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Mesh(v, f))
    b = w.add_body(sg.Sphere(0.2), mass=1.0, position=(0.3, -0.2, 1.5))
    w.step(DT, 3 * 240)
    assert w.positions[b] == pytest.approx([0.3, -0.2, 0.7], abs=1e-9)
    assert np.linalg.norm(w.velocities[b]) < 1e-12
    assert len(w.contacts) == 1 and w.contacts.normal[0] == pytest.approx([0, 0, 1], abs=1e-15)
