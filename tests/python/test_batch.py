"""sg.Batch (issue 22): many worlds stepped together give, world by world, the bits of separate
World objects at every thread count; per-world parameters give their closed-form answers; a
world that fails is frozen and the others go on; bad input changes nothing."""
import math
import pickle

import numpy as np
import pytest

import signorini as sg
from helpers import SLOPE_ANGLE, SLOPE_DOWN, slope_box

G = 9.81
ANGLE = SLOPE_ANGLE
DOWN = SLOPE_DOWN


def slope(friction: float = 0.3) -> sg.World:
    return slope_box(0, friction)


def pile(i: int = 0) -> sg.World:
    """Eight boxes and spheres dropped onto each other and a floor (world i: tilted by i mrad)."""
    w = sg.World(gravity=(0, 0, -G))
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    rng = np.random.default_rng(7)
    for k in range(8):
        shape = sg.Box((0.2, 0.15, 0.1)) if k % 2 else sg.Sphere(0.15)
        w.add_body(shape, density=500.0, position=(0.05 * rng.standard_normal() + 0.001 * i, 0.05 * rng.standard_normal(),
                                                   0.3 + 0.35 * k), friction=0.6, restitution=0.2)
    return w


def separate(source, n, steps, dt=1 / 240):
    out = []
    for i in range(n):
        w = source(i) if callable(source) else pickle.loads(pickle.dumps(source))
        w.step(dt, steps)
        out.append(w)
    return out


@pytest.mark.parametrize("threads", [1, 2])
def test_a_batch_gives_the_bits_of_separate_worlds(threads):
    steps = 240
    for source in (pile(), pile):   # a World copied n times, and make(i)
        b = sg.Batch(source, 5, threads=threads)
        b.step(1 / 240, steps // 2)
        b.step(1 / 240, steps // 2)
        for i, w in enumerate(separate(source, 5, steps)):
            for got, want in ((b.positions[i], w.positions), (b.orientations[i], w.orientations),
                              (b.velocities[i], w.velocities), (b.angular_velocities[i], w.angular_velocities)):
                assert np.array_equal(got, want)
            assert b.contacts(i).gap.tolist() == w.contacts.gap.tolist()
            assert b.solver_stats(i) == w.solver_stats
        assert b.certificate()["contacts"].tolist() == [w.solver_stats.contacts for w in separate(source, 5, steps)]


def test_per_world_friction_on_a_slope_gives_each_world_its_acceleration():
    b = sg.Batch(slope(), 6, threads=2)
    mu = np.array([0.0, 0.01, 0.04, 0.09, 0.16, 0.2])      # sqrt(mu 1) < tan 25: every box slides
    b.set_frictions(mu, bodies=[1])
    steps, dt = 120, 1 / 240
    b.step(dt, steps)
    speed = b.velocities[:, 1] @ DOWN
    expected = G * (math.sin(ANGLE) - np.sqrt(mu) * math.cos(ANGLE)) * steps * dt
    np.testing.assert_allclose(speed, expected, rtol=0.01)
    assert b.world(3).frictions[1] == 0.09


def test_per_world_gravity_gives_each_world_its_fall():
    w = sg.World(gravity=(0, 0, -G), substeps=1)
    w.add_body(sg.Sphere(0.1), density=1000.0, position=(0, 0, 10.0))
    b = sg.Batch(w, 3, threads=2)
    g = np.array([[0, 0, -9.81], [0, 0, -1.62], [0.5, 0, -3.71]])
    b.set_gravity(g)
    k, dt = 60, 1 / 240
    b.step(dt, k)
    # symplectic Euler from rest: p_k = p_0 + g dt^2 k (k + 1) / 2, exactly up to rounding
    np.testing.assert_allclose(b.positions[:, 0], np.array([0, 0, 10.0]) + g * dt * dt * k * (k + 1) / 2,
                               rtol=1e-12, atol=1e-12)


def test_per_world_masses_scale_inertia_and_set_the_momentum_a_push_gives():
    w = sg.World(gravity=(0, 0, 0))
    w.add_body(sg.Box((0.1, 0.2, 0.3)), mass=2.0, position=(0, 0, 0))
    b = sg.Batch(w, 2, threads=1)
    b.set_masses([2.0, 8.0])
    w1 = b.world(1)
    assert w1.masses[0] == 8.0
    np.testing.assert_allclose(w1.inertias[0], 4.0 * w.inertias[0], rtol=1e-15)
    # the same force for 1 s: v = F t / m in each world
    b.set_external_forces(np.array([[[4.0, 0, 0]], [[4.0, 0, 0]]]))
    b.step(1 / 100, 100)
    np.testing.assert_allclose(b.velocities[:, 0, 0], [2.0, 0.5], rtol=1e-12)


def test_a_world_that_goes_nonfinite_is_frozen_and_the_others_go_on():
    b = sg.Batch(slope(), 3, threads=2)
    forces = np.zeros((3, 2, 3))
    forces[1, 1, 0] = 1.7e308           # overflows world 1's velocity: the core undoes its step
    b.set_external_forces(forces)
    b.step(1 / 240, 10)
    assert b.frozen.tolist() == [False, True, False]
    assert "non-finite" in b.errors[1] and b.errors[0] == b.errors[2] == ""
    assert b.times.tolist() == pytest.approx([10 / 240, 0.0, 10 / 240])
    frozen_at = b.positions[1].copy()
    b.step(1 / 240, 10)
    assert np.array_equal(b.positions[1], frozen_at) and b.times[0] == pytest.approx(20 / 240)
    b.reset([1])
    assert not b.frozen.any() and b.errors[1] == "" and b.times[1] == 0.0


def test_reset_puts_back_the_start_and_seeds_randomise_it_reproducibly():
    b = sg.Batch(pile(), 4, threads=2)
    start = b.positions.copy()
    b.step(1 / 240, 30)
    b.reset()
    assert np.array_equal(b.positions, start) and (b.times == 0).all()
    b.reset(seed=5, position_jitter=0.01, velocity_jitter=0.1)
    first = b.positions.copy()
    moved = np.abs(first[:, 1:] - start[:, 1:])
    assert (moved <= 0.01).all() and (moved > 0).any() and np.array_equal(first[:, 0], start[:, 0])
    assert (np.abs(b.velocities[:, 1:]) <= 0.1).all()
    assert len({first[i].tobytes() for i in range(4)}) == 4   # each world its own draw
    b.reset(seed=5, position_jitter=0.01, velocity_jitter=0.1)
    assert np.array_equal(b.positions, first)
    b.reset([2, 0], seed=[11, 12], position_jitter=0.01)
    assert not np.array_equal(b.positions[2], first[2])
    with pytest.raises(ValueError, match=r"seed must be an int or one int per world index \(2\)"):
        b.reset([0, 1], seed=[1, 2, 3])


def test_views_are_read_only_and_copy_nothing():
    b = sg.Batch(pile(), 2, threads=1)
    p = b.positions
    assert p.shape == (2, 9, 3) and b.orientations.shape == (2, 9, 4)
    assert np.shares_memory(p, b.positions)
    b.step(1 / 240, 5)
    assert np.array_equal(p, b.positions)      # the view shows the step
    with pytest.raises(ValueError):
        p[0, 0, 0] = 1.0


def test_bad_input_names_the_parameter_and_changes_nothing():
    b = sg.Batch(slope(), 3, threads=1)
    b.step(1 / 240, 5)
    before = (b.positions.copy(), b.velocities.copy(), [b.world(i).frictions.tolist() for i in range(3)])
    cases = [
        (lambda: b.set_frictions(np.ones(4)), ValueError, r"frictions must have shape \(3,\) or \(3, 2\)"),
        (lambda: b.set_frictions([0.1, -0.2, 0.3]), ValueError, "friction of world 1, body 0 must be >= 0"),
        (lambda: b.set_frictions([0.1, float("nan"), 0.3]), ValueError, "frictions of world 1, body 0 is not finite"),
        (lambda: b.set_restitutions([0.1, 1.5, 0.3]), ValueError, r"restitution of world 1, body 0 must be in \[0, 1\]"),
        (lambda: b.set_masses([1.0, 0.0, 1.0]), ValueError, "mass of world 1, body 1 must be > 0"),
        (lambda: b.set_masses([1.0, 1.0, 1.0], bodies=[0]), ValueError, "body 0 is static"),
        (lambda: b.set_gravity(np.zeros((2, 3))), ValueError, r"gravity must have shape \(3,\) or \(3, 3\)"),
        (lambda: b.set_positions(np.zeros((3, 2, 2))), ValueError, r"positions must have shape \(3, 2, 3\)"),
        (lambda: b.set_velocities(np.full((3, 2, 3), np.inf)), ValueError, "velocities of world 0, body 0 is not finite"),
        (lambda: b.set_external_forces(np.ones((3, 2, 3))), ValueError, "forces of world 0 on static body 0 must be zero"),
        (lambda: b.world(3), IndexError, "world index 3 is out of range: the batch has 3 worlds"),
        (lambda: b.step(0.0), ValueError, "dt must be a finite number > 0"),
        (lambda: b.step(1 / 240, -1), ValueError, "steps must be an integer"),
        (lambda: b.reset([0, 0]), ValueError, "a world index is given twice"),
        (lambda: b.reset(position_jitter=-1.0), ValueError, "position_jitter must be a finite number >= 0"),
    ]
    for call, kind, message in cases:
        with pytest.raises(kind, match=message):
            call()
    after = (b.positions, b.velocities, [b.world(i).frictions.tolist() for i in range(3)])
    assert np.array_equal(before[0], after[0]) and np.array_equal(before[1], after[1]) and before[2] == after[2]
    with pytest.raises(ValueError, match="n must be an integer >= 1"):
        sg.Batch(slope(), 0)
    with pytest.raises(ValueError, match="threads must be an integer >= 1"):
        sg.Batch(slope(), 2, threads=0)
    with pytest.raises(ValueError, match="world 1 has 9 bodies, world 0 has 2"):
        sg.Batch(lambda i: slope() if i == 0 else pile(), 2)
    with pytest.raises(TypeError, match="source must be a World, a scene file path or a function"):
        sg.Batch(3.0, 2)


def test_a_batch_from_a_scene_file(tmp_path):
    path = tmp_path / "s.toml"
    pile().save_scene(path)
    b = sg.Batch(path, 2, threads=2)
    b.step(1 / 240, 20)
    (w,) = separate(sg.load_scene(path), 1, 20)
    assert np.array_equal(b.positions[1], w.positions)


def test_world_set_mass_and_set_gravity_refuse_bad_values_and_change_nothing():
    w = slope()
    with pytest.raises(ValueError, match="a static body has no mass to set"):
        w.set_mass(0, 1.0)
    with pytest.raises(ValueError, match="mass must be finite and > 0"):
        w.set_mass(1, -1.0)
    with pytest.raises(ValueError, match="gravity"):
        w.set_gravity((0, 0, float("nan")))
    assert w.masses[1] == pytest.approx(8.0, rel=1e-15) and w.gravity.tolist() == [0, 0, -G]
    masses = w.masses.copy()
    with pytest.raises(ValueError):
        w.set_mass(1, float("inf"))
    assert np.array_equal(w.masses, masses)
    w.set_gravity((0, 0, -1.0))
    assert w.gravity.tolist() == [0, 0, -1.0]


def test_a_pickled_batch_continues_bit_for_bit():
    b = sg.Batch(pile, 3, threads=2)
    b.step(1 / 240, 30)
    copy = pickle.loads(pickle.dumps(b))
    assert copy.threads == 2 and np.array_equal(copy.positions, b.positions)
    b.step(1 / 240, 30)
    copy.step(1 / 240, 30)
    assert np.array_equal(copy.positions, b.positions) and np.array_equal(copy.velocities, b.velocities)
    copy.reset()
    assert np.array_equal(copy.positions, sg.Batch(pile, 3).positions)
