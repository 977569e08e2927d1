"""The fuzzer (python -m signorini.fuzz): its scenes, its checks, and a seeded sample that meets
issue 8's targets."""
import json
import math
import subprocess
import sys

import numpy as np
import pytest

import signorini as sg
from signorini import fuzz

SAMPLE_SEED = 2026
SAMPLE_SCENES = 20


def test_scenes_are_reproducible_and_cover_what_the_issue_asks_for():
    scenes = [fuzz.generate(3, i) for i in range(150)]
    assert json.dumps(scenes[17]) == json.dumps(fuzz.generate(3, 17))  # the same seed, the same scene
    assert json.dumps(fuzz.generate(4, 17)) != json.dumps(scenes[17])
    kinds = {b["shape"]["type"] for s in scenes for b in s["bodies"]}
    assert kinds == set(fuzz.KINDS)
    assert {s["floor"] for s in scenes} == set(fuzz.FLOORS)
    assert {s["dt"] for s in scenes} == set(fuzz.DTS)
    for s in scenes:
        drawn = s["bodies"][:len(fuzz.generate(3, s["index"], projectiles=False)["bodies"])]  # not the projectiles
        assert 1 <= len(drawn) <= fuzz.MAX_BODIES
        masses = [b["mass"] for b in s["bodies"]]
        assert max(masses) / min(masses) <= 1000.0 * (1 + 1e-12)
        for b in drawn:
            assert np.linalg.norm(b["velocity"]) <= fuzz.MAX_SPEED * (1 + 1e-12)
            assert np.linalg.norm(b["angular_velocity"]) <= fuzz.MAX_SPIN * (1 + 1e-12)
    # largest dimensions from about 1 cm to 10 m
    radii = []
    for s in scenes[:60]:
        w, _ = fuzz.build(s)
        radii += [fuzz._bounding_radius(sg.shape_dict(w.shape(i))) for i in range(w.num_bodies) if not w.is_static[i]]
    assert min(radii) < 0.01 and max(radii) > 3.0


@pytest.mark.slots("sphere-sphere", "sphere-polytope", "sphere-capsule", "sphere-cylinder", role="random",
                   note="gap only")
@pytest.mark.parametrize("shape", [
    sg.Sphere(0.3), sg.Box((0.4, 0.2, 0.1)), sg.Capsule(0.1, 0.3), sg.Cylinder(0.2, 0.35),
    sg.ConvexHull(np.random.default_rng(5).normal(size=(14, 3)) * 0.3),
    sg.Compound([(sg.Box((0.2, 0.1, 0.1)), ((0.1, 0, 0), (1, 0, 0, 0))),
                 (sg.Sphere(0.15), ((-0.2, 0.05, 0), (0.9, 0.1, 0.3, 0)))]),
])
def test_point_distance_matches_the_cores_closest_points(shape):
    # a small ball at each point: the core's exact sphere tests give distance = gap + r
    rng = np.random.default_rng(7)
    p, q = np.array([0.3, -0.2, 1.0]), np.array([0.8, 0.3, -0.2, 0.4])
    q /= np.linalg.norm(q)
    w = sg.World()
    i = w.add_body(shape, density=1000.0, position=p, orientation=q)
    body = sg.shape_dict(w.shape(i))
    X = p + rng.normal(size=(80, 3)) * 0.5
    d = fuzz.point_distance(body, w.positions[i], w.rotations[i], X)
    r = 1e-4
    for x, dx in zip(X, d):
        c = sg.collide(w.shape(i), (w.positions[i], w.orientations[i]), sg.Sphere(r), (x, (1, 0, 0, 0)), margin=2.0)
        if dx > r:  # outside: the ball does not reach in
            assert dx == pytest.approx(c.gap.min() + r, abs=1e-12)
        elif dx == 0.0:
            assert c.gap.min() <= -r + 1e-12


def _sphere(position, **extra):
    return {"shape": {"type": "sphere", "radius": 0.1}, "mass": 1.0, "position": position,
            "orientation": [1, 0, 0, 0], "velocity": [0, 0, 0], "angular_velocity": [0, 0, 0],
            "friction": 0.5, "restitution": 0.0, **extra}


def test_the_checks_catch_a_tunnelled_body_and_an_energy_gain():
    # a ball starting 0.5 m below a flat one-sided height field (behind it: no contact) falls on
    flat = {"half_width": 4.0, "cells": 4, "amplitude": 0.0, "waves": [], "noise_seed": 0}
    scene = {"seed": 0, "index": 0, "floor": "heightfield", "dt": 1 / 60, "duration": 0.5, "heightfield": flat,
             "bodies": [_sphere([0.3, 0.2, -0.5]), _sphere([1.3, 0.2, 0.1])]}
    result = fuzz.run(scene)
    assert list(result["failures"]) == ["tunnel"] and "body 1 (sphere" in result["failures"]["tunnel"]
    # the lecture's explicit gyroscopic term gains energy on a fast asymmetric spinner
    box = {"shape": {"type": "box", "half_extents": [0.5, 0.25, 0.1]}, "mass": 1.0, "position": [0, 0, 5.0],
           "orientation": [1, 0, 0, 0], "velocity": [0, 0, 0], "angular_velocity": [20.0, 20.0, 20.0],
           "friction": 0.5, "restitution": 0.0}
    scene = {"seed": 0, "index": 1, "floor": "plane", "dt": 1 / 60, "duration": 0.5,
             "world": {"gyroscopic": "explicit", "substeps": 1}, "bodies": [box]}
    result = fuzz.run(scene)
    assert list(result["failures"]) == ["energy"]
    # and with the default (midpoint) term the same spinner keeps its energy
    del scene["world"]
    result = fuzz.run(scene)
    assert result["failures"] == {} and result["max_energy_gain"] < 1e-6


@pytest.mark.slow
def test_a_scene_runs_alone_and_prints_its_reproducer_line():
    out = subprocess.run([sys.executable, "-m", "signorini.fuzz", "--scene", "5:3", "--json"],
                         capture_output=True, text=True, timeout=300, check=True).stdout
    result = json.loads(out.splitlines()[-1])
    assert result["scene"] == "5:3" and result["steps"] == round(fuzz.DURATION / fuzz.generate(5, 3)["dt"])
    assert fuzz.reproducer("5:3") == "python -m signorini.fuzz --scene 5:3"


@pytest.fixture(scope="module")
def sample():
    lines = []
    report = fuzz.run_many(SAMPLE_SCENES, SAMPLE_SEED, jobs=2, timeout=240.0, out=lines.append)
    print("\n".join(lines))
    return report, lines


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["crash", "timeout", "exception", "nonfinite", "explosion", "tunnel", "off_shape",
                                  "energy"])
def test_a_seeded_sample_meets_the_targets(sample, kind):
    report, lines = sample
    assert report["counts"][kind] == 0, "\n".join(line for line in lines if f"FAIL {kind} " in line)
    assert lines[-1].startswith(f"fuzz {SAMPLE_SCENES} scenes, seed {SAMPLE_SEED}: ")


@pytest.mark.parametrize("name", ["1:723", "1:578", "1:43"])
def test_scenes_that_had_contact_points_off_their_shapes_are_clean(name):
    # seed 1 of the 1,000-scene run, each with a different cause, now fixed:
    # 1:723, a cylinder on a height-field triangle: EPA's witnesses were the origin's projection
    #   clamped into a face of the cylinder's flat cap that did not hold it (0.19 m off);
    # 1:578, a box pressed into a ridge: a triangle edge axis whose edge lines meet off the edges;
    # 1:43, a capsule whose core crosses a triangle's edge: the point was the core's end
    seed, index = map(int, name.split(":"))
    result = fuzz.run(fuzz.generate(seed, index, joints=False))  # the scenes as drawn then
    assert "off_shape" not in result["failures"], result["failures"]
    assert result["max_point_error"] < 1e-6


def test_a_taut_rope_between_fast_spinners_gains_no_energy_in_the_soft_step():
    # fuzz 1:1 with the soft step: a rope (a distance joint's limit row) ties two capsules that spin
    # up to 190 rad/s, 0.099 rad in half a substep of 1/960 s (the substeps of a world with joints),
    # under the drift rule's 0.1 rad: the limit's midpoint drift asked for separating velocities that
    # the rope, letting go, kept, and the scene's energy doubled. The soft step asks no drift of
    # limit rows (docs/conventions.md, "Joints"): measured, no gain
    result = fuzz.run(fuzz.with_solver(fuzz.generate(1, 1), "soft"))
    assert not result["failures"], result["failures"]
    assert result["max_energy_gain"] < fuzz.ENERGY_GAIN


def test_a_kept_contact_lies_within_its_pairs_recycling_drift_of_both_bodies(monkeypatch):
    # A kept contact has its witness points carried with their bodies; as a pair slides they part
    # along its features (fuzz 1:478 once: a box pair's edge-edge point left both boxes by 3.5e-5 m
    # more than |gap|). The pair's drift since it was found is at most min(recycle_distance, 0.1
    # r_inner): within that bound fuzz 1:23 with the soft step (contact recycling on) is clean;
    # without the drift's allowance the check catches it, and with recycling off it is clean
    # without the allowance too. (1:478's steps changed when the soft step began to make its rows
    # again for turning pairs, and it no longer drifts past |gap|)
    scene = fuzz.with_solver(fuzz.generate(1, 23), "soft")
    result = fuzz.run(scene)
    assert "off_shape" not in result["failures"], result["failures"]
    monkeypatch.setattr(fuzz, "RECYCLE_INNER_FRACTION", 0.0)
    assert "off_shape" in fuzz.run(scene)["failures"]
    fresh = {**scene, "world": {**scene["world"], "recycle_distance": 0.0}}
    assert "off_shape" not in fuzz.run(fresh)["failures"]


@pytest.mark.slow
def test_the_summary_counts_every_scene(sample):
    report, lines = sample
    assert len(report["results"]) == SAMPLE_SCENES
    clean = sum(not r["failures"] for r in report["results"])
    assert f": {clean} clean; " in lines[-1]
    deep = [r for r in report["results"] if r["max_overlap"] > fuzz.DEEP_OVERLAP]
    in_range = [r["scene"] for r in deep if r["mass_ratio"] <= fuzz.MASS_RATIO_TARGET]
    assert f"({len(deep)} scenes past 50%, {len(in_range)} of them with masses within 1:1000" in lines[-1]
    assert all(name in lines[-1] for name in in_range)
    for r in report["results"]:
        for key in ("max_overlap", "max_energy_gain", "max_point_error"):
            assert math.isfinite(r[key])
        assert r["mass_ratio"] >= 1.0


def test_a_scenes_mass_ratio_counts_its_structures_links():
    # scene 1:1's free bodies span 1:22 in mass; its chains' links make the scene's span 1:73
    scene = fuzz.generate(1, 1)
    world, _ = fuzz.build(scene)
    m = world.masses[~world.is_static]  # the floor is not counted
    free = [b["mass"] for b in scene["bodies"]]
    result = fuzz.run({**scene, "duration": 2 * scene["dt"]})
    assert result["mass_ratio"] == m.max() / m.min()
    assert result["mass_ratio"] > 3 * max(free) / min(free)
    assert fuzz.mass_ratio(np.array([2.0])) == 1.0


def test_the_solver_option_runs_every_scene_with_that_solver():
    scene = fuzz.generate(1, 4)
    soft = fuzz.with_solver(scene, "soft")
    assert soft["world"]["solver"] == "soft" and fuzz.with_solver(scene, None) is scene
    assert "solver" not in scene.get("world", {})  # the scene itself is not changed
    world, _ = fuzz.build(soft)
    assert world.solver["solver"] == "soft"
    assert fuzz.reproducer("1:4", "soft").endswith("--scene 1:4 --solver soft")


def test_jointed_structures_start_held_and_in_one_rigid_motion():
    # every scene gets 1 or 2 structures from its own stream; the free bodies stay as drawn before
    kinds = set()
    for i in range(12):
        scene = fuzz.generate(11, i)
        before = fuzz.generate(11, i, joints=False)
        drawn = scene["bodies"][:len(before["bodies"])]  # the projectiles come after (their own stream)
        assert json.dumps(drawn) == json.dumps(before["bodies"]) and "structures" not in before
        assert 1 <= len(scene["structures"]) <= fuzz.MAX_STRUCTURES
        kinds |= {t["kind"] for t in scene["structures"]}
        world, _ = fuzz.build(scene)
        frames = fuzz.joint_frames(world)
        assert world.num_joints == sum(len(t["joints"]) for t in scene["structures"]) > 0
        assert fuzz.joint_errors(world, frames).max() < 1e-12 * (1 + np.abs(world.positions).max())
        # one rigid motion: the anchor points of each joint move alike (the joints allow it)
        a, b = frames["bodies"][:, 0], frames["bodies"][:, 1]
        V, W, R = world.velocities, world.angular_velocities, world.rotations
        arm_a = np.einsum("jik,jk->ji", R[a], frames["anchors"][:, 0])
        arm_b = np.einsum("jik,jk->ji", R[b], frames["anchors"][:, 1])
        slip = (V[b] + np.cross(W[b], arm_b)) - (V[a] + np.cross(W[a], arm_a))
        hinge = [world.joint(j)["kind"] == "Revolute" for j in range(world.num_joints)]
        scale = 1e-9 * (1 + np.abs(V).max() + np.abs(W).max()) * (1 + np.abs(world.positions).max())
        d = world.positions[b] + arm_b - world.positions[a] - arm_a
        point = ~frames["distance"]
        assert np.abs(slip[point]).max(initial=0.0) < scale  # the anchors of a hinge or ball joint move together
        assert np.abs(np.einsum("ji,ji->j", d, slip)[~point]).max(initial=0.0) < scale  # a rod keeps its length
        for j in np.nonzero(hinge)[0]:  # and no turn about a hinge's other axes
            axis = R[a[j]] @ world.joint(int(j))["axis_a"]
            turn = W[b[j]] - W[a[j]]
            assert np.linalg.norm(turn - (turn @ axis) * axis) < 1e-9 * (1 + np.abs(W).max())
    assert kinds == set(fuzz.STRUCTURES)


def test_joint_errors_measure_an_opened_joint():
    # a ball joint's two bodies moved 3 mm apart, a rod 2 mm too long, a slack rope: exactly those
    w = sg.World()
    a = w.add_body(sg.Sphere(0.1), mass=1.0, position=(0, 0, 1))
    b = w.add_body(sg.Sphere(0.1), mass=1.0, position=(0.5, 0, 1))
    w.add_joint(sg.Spherical(a, b, anchor=(0.25, 0, 1)))
    w.add_joint(sg.Distance(a, b, (0, 0, 1), (0.5, 0, 1)))
    w.add_joint(sg.Distance(a, b, (0, 0, 1), (0.5, 0, 1), 0.0, 0.6))
    frames = fuzz.joint_frames(w)
    w.set_position(b, (0.503, 0, 1))
    np.testing.assert_allclose(fuzz.joint_errors(w, frames), [0.003, 0.003, 0.0], atol=1e-15)
    w.set_position(b, (0.5, 0.002, 1))  # sideways: the rod is sqrt(0.25 + 4e-6) long
    np.testing.assert_allclose(fuzz.joint_errors(w, frames), [0.002, math.hypot(0.5, 0.002) - 0.5, 0.0],
                               rtol=1e-9, atol=1e-15)


def test_half_the_scenes_shoot_fast_small_bodies_at_the_floor():
    # issue 24: 1 to 3 bodies of 1 to 2 cm at 20 to 200 m/s, down at the floor, after the others
    shot = 0
    for i in range(20):
        scene, before = fuzz.generate(13, i), fuzz.generate(13, i, projectiles=False)
        extra = scene["bodies"][len(before["bodies"]):]
        assert json.dumps(scene["bodies"][:len(before["bodies"])]) == json.dumps(before["bodies"])
        shot += bool(extra)
        for b in extra:
            v = np.array(b["velocity"])
            assert 20.0 <= np.linalg.norm(v) <= 200.0 and v[2] <= -0.5 * np.linalg.norm(v)  # within 60 degrees
            assert fuzz._bounding_radius(b["shape"]) <= 0.02
    assert 5 <= shot <= 15


@pytest.mark.slow
def test_a_body_back_under_the_field_from_past_its_edge_is_not_measured_against_it():
    # fuzz 1:229: a ragdoll's thigh falls past the height field's edge (its square is 2.33 m wide),
    # and its joints pull it back in under the field, 25 mm below its surface (200 % of its inner
    # size) where it comes up through it; as the tunnel rule does, the overlap measure leaves a
    # body's contacts with the floor alone once its centre has left the square
    result = fuzz.run(fuzz.generate(1, 229))
    assert not result["failures"]
    assert result["max_overlap"] < fuzz.DEEP_OVERLAP, result["overlap_at"]


def test_structures_start_clear_of_the_fast_small_bodies():
    # the projectiles join the placed bodies, so a chain or ragdoll drawn after them starts clear:
    # fuzz 1:770's chain began with a link 39 mm inside a 1 cm projectile box (926 % of its inner
    # size before any step); now nothing in it overlaps at the start
    scene = fuzz.generate(1, 770)
    assert scene["structures"] and len(scene["bodies"]) > len(fuzz.generate(1, 770, projectiles=False)["bodies"])
    world, _ = fuzz.build(scene)
    gaps = world.detect_contacts(scene["dt"]).gap
    assert not (gaps < 0.0).any()


@pytest.mark.parametrize("solver", [None, "soft"])
def test_scenes_with_fast_small_bodies_meet_the_targets(solver):
    # the tunnel target among them: no centre ends below the floor surface
    for index in (1, 4):
        scene = fuzz.with_solver(fuzz.generate(13, index), solver)
        assert len(scene["bodies"]) > len(fuzz.generate(13, index, projectiles=False)["bodies"])
        scene["duration"] = 0.5
        result = fuzz.run(scene)
        assert result["failures"] == {}, (index, result["failures"])


@pytest.mark.parametrize("solver", [None, "soft"])
def test_jointed_scenes_meet_the_targets(solver):
    # a few jointed scenes (chains and ragdolls) through the same checks, with both solvers
    for index in (0, 2, 5):
        scene = fuzz.with_solver(fuzz.generate(7, index), solver)
        scene["duration"] = 0.5
        result = fuzz.run(scene)
        assert result["joints"] > 0
        assert result["failures"] == {}, (index, result["failures"])
        assert math.isfinite(result["max_joint"])
