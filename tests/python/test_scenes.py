"""Built-in scenes: they build, start clear of the ground, and end where physics says they should.

The end states are closed-form predictions (a body sliding down a slope against Coulomb friction
accelerates at g (sin(theta) - mu cos(theta)) and loses exactly the friction's work; two equal spheres meeting head on in a perfectly inelastic
contact stop), not numbers read off a run.
"""

import math

import numpy as np

import signorini as sg
import pytest

from signorini import meshes, output, scenes
from signorini.oracle import quat_to_matrix


def test_registry_and_unknown_name():
    assert scenes.DEFAULT_SCENE in scenes.SCENES
    for name in scenes.SCENES:
        scene = scenes.build(name)
        assert scene.name == name and scene.dt > 0 and scene.steps >= 1 and scene.description
    with pytest.raises(ValueError, match="'no-such-scene'"):
        scenes.build("no-such-scene")


def test_builders_give_fresh_worlds():
    a, b = scenes.build("boxes"), scenes.build("boxes")
    assert a.world is not b.world
    a.world.step(dt=a.dt, steps=5)
    assert b.world.time == 0.0


def lowest_gap(world, plane_index, body):
    """Smallest signed distance (m) of a dynamic body's surface from a static plane."""
    plane = world.shape(plane_index)
    n = np.asarray(plane.normal, dtype=float)
    n = n / np.linalg.norm(n)
    shape = world.shape(body)
    p, q = world.positions[body], world.orientations[body]
    if hasattr(shape, "radius") and not hasattr(shape, "vertices"):
        return float(n @ p - plane.offset - shape.radius)
    v, _ = meshes.render_mesh(shape)
    return float(np.min(meshes.posed(v, p, q) @ n - plane.offset))


# the registry's scenes, and the small versions the solver benchmark's smoke test builds
SMALL_SCENES = {
    "pyramid-base-5": lambda: scenes.pyramid(base=5),
    "rain-40-10": lambda: scenes.rain(spheres=40, boxes=10),
    "hull_pile-20": lambda: scenes.hull_pile(hulls=20),
}


@pytest.mark.parametrize("name", sorted(scenes.SCENES) + sorted(SMALL_SCENES))
def test_scenes_start_without_overlap(name):
    # resting on the ground (gap 0) is allowed, overlapping anything is not
    scene = SMALL_SCENES[name]() if name in SMALL_SCENES else scenes.build(name)
    world = scene.world
    if isinstance(world.shape(0), sg.Plane):
        for body in np.flatnonzero(~np.asarray(world.is_static)):
            assert lowest_gap(world, 0, body) >= -1e-12
    contacts = world.detect_contacts(scene.dt)
    assert len(contacts) == 0 or contacts.gap.min() >= -1e-12


def test_benchmark_scenes_have_the_bodies_of_issue_7():
    # pyramid: rows of 20, 19, ..., 1 unit boxes of 1 kg, 1 mm apart, each row on the one below
    world = scenes.build("pyramid").world
    assert world.num_bodies == 1 + 210 and isinstance(world.shape(0), sg.Plane)
    np.testing.assert_array_equal(world.masses[1:], 1.0)
    z = world.positions[1:, 2]
    np.testing.assert_array_equal(np.bincount(np.rint(z - 0.5).astype(int)), np.arange(20, 0, -1))
    base = np.sort(world.positions[1:21, 0])
    np.testing.assert_allclose(np.diff(base), 1.001, rtol=1e-12)
    # rain: 1,000 spheres and 200 boxes in the bin's footprint; hull pile: 200 hulls of <= 16 points
    world = scenes.build("rain").world
    kinds = [type(world.shape(i)).__name__ for i in range(world.num_bodies) if not world.is_static[i]]
    assert kinds.count("Sphere") == 1000 and kinds.count("Box") == 200
    assert np.abs(world.positions[~np.asarray(world.is_static), :2]).max() < 2.0 - 0.157
    world = scenes.build("hull_pile").world
    hulls = [world.shape(i) for i in range(world.num_bodies) if not world.is_static[i]]
    assert len(hulls) == 200 and all(isinstance(h, sg.ConvexHull) and len(h.vertices) <= 16 for h in hulls)
    # every body and the ground: friction 0.5, restitution 0, no spinning friction (as pybullet's default)
    for name in ("pyramid", "rain", "hull_pile"):
        world = scenes.build(name).world
        np.testing.assert_array_equal(world.frictions, 0.5)
        np.testing.assert_array_equal(world.restitutions, 0.0)
        np.testing.assert_array_equal(world.spinning_frictions, 0.0)
    # the mixed pile: spinning friction on every body, walls and ground too
    world = scenes.build("pile").world
    np.testing.assert_array_equal(world.spinning_frictions, scenes.PILE_SPINNING_FRICTION)
    assert scenes.PILE_SPINNING_FRICTION == pytest.approx(3 * math.pi / 16 * 0.5 * 1.7e-3, rel=0.02)


def test_torus_scene_is_the_assignment_setting():
    world = scenes.build("torus").world
    plane = world.shape(0)
    n = np.array([0.7, 0.7, 0.0]) / math.hypot(0.7, 0.7)
    np.testing.assert_allclose(plane.normal, n, rtol=1e-12)
    assert plane.offset == pytest.approx(n @ [0.0, -0.1, 0.0], rel=1e-12)
    assert world.num_bodies == 2 and not world.is_static[1]


def test_torus_lands_flat_then_slides_at_g_sin_45_minus_mu_cos_45():
    scene = scenes.build("torus")
    record = output.run(scene, progress=False)
    n = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    offset = -0.1 / math.sqrt(2.0)
    minor_radius = 0.015
    mu, g = 0.5, 0.98  # default friction on both bodies: sqrt(0.5 * 0.5)

    # at the end the torus lies flat: axis along the normal, COM one tube radius above the plane
    axis = quat_to_matrix(record.orientations[-1, 1])[:, 2]
    assert abs(axis @ n) > 0.999
    assert record.positions[-1, 1] @ n - offset == pytest.approx(minor_radius, abs=5e-4)

    # in the last second it slides downhill, (1, -1, 0) / sqrt(2), at g (sin 45 - mu cos 45)
    last = record.time >= record.time[-1] - 1.0
    downhill = np.array([1.0, -1.0, 0.0]) / math.sqrt(2.0)
    s = record.positions[last, 1] @ downhill
    acceleration = 2.0 * np.polyfit(record.time[last], s, 2)[0]
    assert acceleration == pytest.approx(g * (1.0 - mu) / math.sqrt(2.0), rel=1e-3)

    # sliding friction takes exactly its work mu m g cos 45 per metre slid; energy never rises
    energy = record.total_energy[last]
    m = record.masses[1]
    assert energy[0] - energy[-1] == pytest.approx(mu * m * g / math.sqrt(2.0) * (s[-1] - s[0]), rel=1e-3)
    assert np.all(np.diff(energy) <= 1e-12 * abs(energy).max())


def test_torus_description_states_its_friction_and_acceleration():
    # the description is what `run` and the player show: it must name the friction the bodies
    # have and the acceleration the test above measures, computed here from the built world
    scene = scenes.build("torus")
    world = scene.world
    mu = math.sqrt(world.frictions[0] * world.frictions[1])
    g = float(np.linalg.norm(world.gravity))
    acceleration = g * (1.0 - mu) / math.sqrt(2.0)
    assert mu > 0 and "no friction" not in scene.description
    assert f"friction {mu:g}" in scene.description
    assert f"{acceleration:.4f} m/s^2" in scene.description
    assert scenes.__doc__.count(f"{acceleration:.4f} m/s^2") == 1 and "no friction" not in scenes.__doc__


def test_boxes_spheres_meeting_head_on_stop():
    scene = scenes.build("boxes")
    record = output.run(scene, progress=False)
    # bodies 3 and 4 are the equal spheres sliding towards each other along x
    v = record.velocities[-1]
    np.testing.assert_allclose(v[3], 0.0, atol=1e-3)
    np.testing.assert_allclose(v[4], 0.0, atol=1e-3)
    assert record.positions[-1, 4, 0] - record.positions[-1, 3, 0] == pytest.approx(0.3, abs=1e-3)
    # nothing sinks into the ground deeper than the 1 mm slop (where resting contacts settle)
    for body in range(1, record.num_bodies):
        assert lowest_gap(scene.world, 0, body) >= -1e-3 - 1e-12
