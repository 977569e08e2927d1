"""Torsional ("spinning") friction at single-point contacts (docs/conventions.md, "Materials" and step
3): closed forms, the zero value leaving everything as it was, the oracle, energy, saved states.

A ball resting on the ground and spun at omega0 about the vertical feels the torque mu_spin alpha_n
about the normal, alpha_n = m g, so it decelerates at a = mu_spin m g / I_zz, constant, and stops
at t* = I_zz omega0 / (mu_spin m g). In the discrete step the spin row takes exactly the torque
impulse dt mu_spin m g each step (its bound; a converged normal force is m g to rounding), so
omega drops by a dt per step to rounding, and the step in which it stops is the first whose end
passes t*: t* <= t_stop < t* + dt.
"""
import math
import pickle

import numpy as np
import pytest

import signorini as sg
from signorini import compare, oracle

G = 9.81


def spinning_body(shape, omega0, mu_spin_body, mu_spin_ground=0.0, mass=1.0, z=None):
    """A body of the given mass resting on the ground at rest but for omega0 (rad/s) about the
    vertical; returns (world, body)."""
    w = sg.World(gravity=(0, 0, -G))
    w.add_static(sg.Plane((0, 0, 1), 0.0), spinning_friction=mu_spin_ground)
    b = w.add_body(shape, mass=mass, position=(0, 0, z), angular_velocity=(0, 0, omega0),
                   spinning_friction=mu_spin_body)
    return w, b


SHAPES = {  # shape and the height of its centre when it rests on its lowest point
    "ball": (sg.Sphere(0.1), 0.1),
    "upright capsule": (sg.Capsule(0.05, 0.1), 0.15),
}


@pytest.mark.parametrize("dt", [1 / 240, 1 / 60])
@pytest.mark.parametrize("shape", sorted(SHAPES))
@pytest.mark.parametrize("mu_ground, mu_body", [(0.0, 0.002), (0.002, 0.0), (0.002, 0.0005)],
                         ids=["body's", "ground's", "larger of the two"])
def test_spinning_body_decelerates_at_mu_m_g_over_I_and_stops_at_the_closed_form_time(dt, shape, mu_ground,
                                                                                       mu_body):
    shp, z = SHAPES[shape]
    omega0, m, mu_spin = 5.0, 1.0, max(mu_ground, mu_body)  # the pair's value: the larger one
    w, b = spinning_body(shp, omega0, mu_body, mu_ground, mass=m, z=z)
    I_zz = w.inertias[b][2, 2]
    if shape == "ball":
        assert I_zz == pytest.approx(0.4 * m * 0.1**2, rel=1e-14)
    a = mu_spin * m * G / I_zz                      # rad/s^2
    t_star = I_zz * omega0 / (mu_spin * m * G)      # s
    omega, yaw, stopped = [omega0], 0.0, None
    for k in range(1, math.ceil(1.5 * t_star / dt) + 1):
        R0 = w.rotations[b].copy()
        w.step(dt)
        turn = w.rotations[b] @ R0.T
        yaw += math.atan2(turn[1, 0], turn[0, 0])
        omega.append(w.angular_velocities[b][2])
        c = w.contacts
        assert len(c) == 1 and c.alpha[0] == pytest.approx(m * G, rel=1e-9)
        if omega[-1] > a * dt:  # a full step of sliding spin: the torque sits on its bound, against the spin
            assert omega[-2] - omega[-1] == pytest.approx(a * dt, rel=1e-9)
            assert c.spin_torque[0] == pytest.approx(-mu_spin * c.alpha[0], rel=1e-12)
            assert w.contact_torques[b] == pytest.approx([0.0, 0.0, c.spin_torque[0]], abs=1e-12)
        if stopped is None and abs(omega[-1]) <= 1e-12:
            stopped = k * dt
    assert stopped is not None
    assert t_star - 1e-9 <= stopped < t_star + dt
    # stopped, it stays stopped (static torsional friction), the torque back to 0
    assert np.abs(omega[round(stopped / dt):]).max() <= 1e-12
    assert w.contacts.spin_torque[0] == pytest.approx(0.0, abs=1e-12)
    # the angle turned, omega0^2 / (2 a), to the first order in dt of the step's integration
    assert yaw == pytest.approx(omega0**2 / (2 * a), abs=omega0 * dt)
    # nothing else moved
    assert np.abs(w.angular_velocities[b][:2]).max() <= 1e-12 and np.abs(w.velocities[b]).max() <= 1e-12


def test_zero_spinning_friction_keeps_the_spin_bit_for_bit():
    # no row at all: nothing turns the ball's spin about the normal, to the last bit
    w, b = spinning_body(sg.Sphere(0.1), 5.0, 0.0, 0.0, z=0.1)
    w.step(1 / 240, 480)
    assert w.angular_velocities[b].tolist() == [0.0, 0.0, 5.0]
    assert w.contacts.spin_torque.tolist() == [0.0] and w.warm_start_cache["spin"].tolist() == [0.0]


def boxes_and_lying_capsule(mu_spin):
    """Bodies whose contacts with the ground come in manifolds of 2 or 4 points, all spinning."""
    w = sg.World()
    w.add_static(sg.Plane((0, 0, 1), 0.0), spinning_friction=mu_spin)
    for k in range(3):
        w.add_body(sg.Box((0.2, 0.15, 0.1)), density=500.0, position=(0.6 * k, 0, 0.1),
                   angular_velocity=(0, 0, 2.0 + k), spinning_friction=mu_spin)
    w.add_body(sg.Capsule(0.05, 0.2), density=800.0, position=(0, 1.0, 0.05),
               orientation=(math.sqrt(0.5), math.sqrt(0.5), 0, 0), angular_velocity=(0, 0, 3.0),
               spinning_friction=mu_spin)
    return w


def test_multi_point_manifolds_get_no_spin_row_and_their_results_do_not_change():
    # boxes flat on the ground (4 points) and a capsule lying on it (2 points) resist spin through
    # the friction at their separate points; spinning friction makes no row for them, so the
    # results are the bits of spinning friction 0
    runs = []
    for mu_spin in (0.0, 0.01):
        w = boxes_and_lying_capsule(mu_spin)
        out = []
        for _ in range(120):
            w.step(1 / 240)
            assert len(w.contacts) == 3 * 4 + 2
            assert not w.contacts.spin_torque.any()
            out.append(np.concatenate([w.positions.ravel(), w.rotations.ravel(), w.velocities.ravel(),
                                       w.angular_velocities.ravel(), w.contacts.alpha]))
        runs.append(np.array(out))
    assert np.array_equal(runs[0], runs[1])
    # and the friction at the separate points did slow the spins
    assert np.all(np.abs(w.angular_velocities[1:, 2]) < [2.0, 3.0, 4.0, 3.0])


@pytest.mark.slow
def test_spin_rows_agree_with_the_oracle_contact_by_contact():
    # the compare scene "spinners" (spheres on the ground and on a sphere, an upright capsule), one
    # step at a time from the core's state and contacts: torques, forces and the next cache as the
    # oracle derives them
    w, dt, _ = compare.build("spinners")
    seen = 0
    for k in range(240):
        before = w.snapshot()
        contacts = {key: v for key, v in w.detect_contacts(dt).as_dict().items()
                    if key in ("body_a", "body_b", "point", "normal", "gap", "feature_a", "feature_b")}
        w.step(dt)
        expected, info = oracle.step(before, dt, contacts=contacts)
        c = w.contacts
        scale = np.abs(info["spin_torque"]).max(initial=1e-3)
        np.testing.assert_allclose(c.spin_torque, info["spin_torque"], rtol=0, atol=1e-10 * scale)
        np.testing.assert_allclose(c.alpha, info["alpha"], rtol=0, atol=1e-9 * info["alpha"].max(initial=1.0))
        np.testing.assert_allclose(w.warm_start_cache["spin"], expected["cache"]["spin"], rtol=0, atol=1e-10 * scale)
        np.testing.assert_allclose(w.contact_torques, info["body_torque"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(w.angular_velocities, expected["angular_velocity"], rtol=0, atol=1e-10)
        # a spin row exactly where the oracle makes one: a pair's only point with mu_spin > 0
        has_row = info["mu_spin"] > 0
        has_row &= oracle.alone_in_pair(contacts)
        assert np.all(c.spin_torque[~has_row] == 0.0)
        seen += int(np.count_nonzero(c.spin_torque))
    assert seen > 240 * 3  # several contacts turn against their spin every step


def test_energy_never_rises_while_spin_friction_works():
    # the spin rows only take energy away (a torque against the relative spin, within its bound):
    # the total energy of the spinners scene falls every step, and spinning stops
    w, dt, _ = compare.build("spinners")
    w.set_solver(tolerance=1e-6)
    E = [w.kinetic_energy() + w.potential_energy()]
    for _ in range(600):
        w.step(dt)
        E.append(w.kinetic_energy() + w.potential_energy())
    assert np.all(np.diff(E) <= 1e-12 * E[0])
    # after 2.5 s only ball 3 (mu_spin 0.0005 from the ground, 1.5 kg, r = 0.2 m: about 16 s from
    # 5 rad/s; the ball that landed on it and rolled off took some more) still turns about the vertical
    spinning = np.flatnonzero(np.abs(w.angular_velocities[:, 2]) > 1e-9)
    assert spinning.tolist() == [3]
    assert 0.0 < w.angular_velocities[3, 2] < 5.0 - 0.0005 * 1.5 * G / (0.4 * 1.5 * 0.2**2) * w.time


def trajectory(w, steps, dt=1 / 240):
    out = []
    for _ in range(steps):
        w.step(dt)
        c = w.contacts
        out.append(np.concatenate([w.positions.ravel(), w.rotations.ravel(), w.velocities.ravel(),
                                   w.angular_velocities.ravel(), c.alpha, c.spin_torque,
                                   w.warm_start_cache["spin"]]))
    return out


def test_saved_states_and_pickles_continue_bit_identically_with_spin_rows():
    w, dt, _ = compare.build("spinners")
    w.step(dt, 40)
    assert np.count_nonzero(w.warm_start_cache["spin"]) >= 3
    saved = w.save_state()
    twin = pickle.loads(pickle.dumps(w))
    assert np.array_equal(twin.spinning_frictions, w.spinning_frictions)
    first = trajectory(w, 60, dt)
    w.restore_state(saved)
    for a, b in zip(trajectory(w, 60, dt), first):
        assert np.array_equal(a, b)
    for a, b in zip(trajectory(twin, 60, dt), first):
        assert np.array_equal(a, b)


def test_set_material_changes_the_spinning_friction_and_keeps_the_rest():
    w, b = spinning_body(sg.Sphere(0.1), 5.0, 0.0, 0.0, z=0.1)
    w.set_material(b, spinning_friction=0.002)
    assert (w.frictions[b], w.restitutions[b], w.spinning_frictions[b]) == (0.5, 0.0, 0.002)
    w.set_material(b, friction=0.3)
    assert (w.frictions[b], w.spinning_frictions[b]) == (0.3, 0.002)
    w.step(1 / 240)
    assert w.angular_velocities[b][2] == pytest.approx(5.0 - 0.002 * G / (0.4 * 0.01) / 240, rel=1e-9)
    assert w.snapshot()["bodies"][b]["spinning_friction"] == 0.002
