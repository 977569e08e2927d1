"""Thin and light bodies do not sink deep (issue 21, "Deep overlaps go"): no overlap deeper than
half the smaller body's inner radius, with mass ratios up to 1:1000.

The position pass leaves an overlap up to the slop alone (docs/conventions.md, "One step"). A fixed
1 mm slop is more than half of a plate 1.8 mm thick, so a contact's slop is at most
``SolverSettings.slop_inner_fraction`` (0.2) of the smaller inner radius of its bodies
(``World.inner_radii``). A body resting under a heavier one then sinks at most that slop plus what
the unconverged solve leaves; the target bound, half the inner radius, is the tolerance."""
import numpy as np
import pytest

import signorini as sg
from signorini import fuzz, oracle

SLOP_INNER_FRACTION = 0.2   # the core's SolverSettings::slop_inner_fraction, the oracle's constant
TARGET = 0.5                # of the smaller body's inner radius: issue 21's bound


def test_inner_radii_are_the_radii_of_balls_the_shapes_contain():
    w = sg.World()
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    shapes = [sg.Sphere(0.03), sg.Box((0.04, 0.01, 0.02)), sg.Capsule(0.015, 0.05), sg.Cylinder(0.02, 0.005),
              sg.Cylinder(0.005, 0.02)]
    expected = [0.03, 0.01, 0.015, 0.005, 0.005]
    for k, s in enumerate(shapes):
        w.add_body(s, mass=1.0, position=(k, 0, 1))
    # a hull: the distance from its vertex mean to its nearest face, as the fuzzer measures it
    points = np.array([[x, y, z] for x in (-0.02, 0.02) for y in (-0.03, 0.03) for z in (-0.004, 0.004)])
    h = w.add_body(sg.ConvexHull(points), mass=1.0, position=(9, 0, 1))
    inner = w.inner_radii
    assert inner[0] == np.inf
    np.testing.assert_allclose(inner[1:h], expected, rtol=1e-15)
    assert inner[h] == pytest.approx(fuzz._inner_size(sg.shape_dict(w.shape(h))), rel=1e-12)
    assert inner[h] == pytest.approx(0.004, rel=1e-12)
    # the snapshot carries them to the oracle
    assert [b["inner_radius"] for b in w.snapshot()["bodies"]] == inner.tolist()


def test_a_contact_s_slop_is_at_most_a_fifth_of_the_thinner_body_s_inner_radius():
    w = sg.World()
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    thin = w.add_body(sg.Box((0.01, 0.01, 0.0009)), mass=1.0, position=(0, 0, 0.0009))
    thick = w.add_body(sg.Box((0.01, 0.01, 0.01)), mass=1.0, position=(1, 0, 0.01))
    snap = w.snapshot()
    contacts = {"body_a": np.array([0, 0, thin]), "body_b": np.array([thin, thick, thick])}
    slops = oracle.contact_slops(snap, contacts, w.solver["slop"])
    np.testing.assert_allclose(slops, [SLOP_INNER_FRACTION * 0.0009, 0.001, SLOP_INNER_FRACTION * 0.0009],
                               rtol=1e-15)


def deepest_overlap(w, dt, steps, thin):
    """The deepest overlap (m) of any contact of body `thin` over `steps` steps of dt."""
    deepest = 0.0
    for _ in range(steps):
        c = w.detect_contacts(dt)
        mine = (c.body_a == thin) | (c.body_b == thin)
        if mine.any():
            deepest = max(deepest, float(-c.gap[mine].min()))
        w.step(dt)
    return deepest


def plate_under_block(solver, ratio, t=0.0009, m=0.01, sunk=0.0):
    """A plate 2 t thick (inner radius t) on the ground, sunk `sunk` m into it, under a block of
    `ratio` times its mass set down 1 mm above it (none for ratio 0): (world, plate)."""
    w = sg.World(gravity=(0, 0, -9.81), solver=solver)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    plate = w.add_body(sg.Box((0.02, 0.02, t)), mass=m, position=(0, 0, t - sunk))
    if ratio:
        w.add_body(sg.Box((0.015, 0.015, 0.015)), mass=ratio * m, position=(0, 0, 2 * t - sunk + 0.015 + 0.001))
    return w, plate


@pytest.mark.parametrize("ratio", [0, 1, 10])
def test_a_thin_plate_set_into_the_ground_is_pushed_out_to_its_own_slop(ratio):
    # a plate 1.8 mm thick set 0.8 mm (89 % of its inner radius) into the ground, alone or under a
    # block: a fixed 1 mm slop left it there; its slop is now 0.2 x 0.9 mm, and after 1 s it rests
    # within that plus what gravity presses in over one substep (h^2 g, h = 1/960 s at dt = 1/240)
    t, dt, h = 0.0009, 1 / 240, 1 / 960
    w, plate = plate_under_block("pgs", ratio, t=t, sunk=0.0008)
    deepest_overlap(w, dt, 240, plate)
    late = deepest_overlap(w, dt, 240, plate)
    assert late <= SLOP_INNER_FRACTION * t + h**2 * 9.81
    assert late < TARGET * t


@pytest.mark.parametrize("solver", ["pgs", "soft"])
@pytest.mark.xfail(strict=True, reason="issue 21, not met yet: at 1:1000 the PGS's 30 sweeps a substep leave the heavy "
                   "block sinking (300 sweeps: 41 %, 3,000: 0 %), at dt 1/60 the plate's manifold takes a far-side corner, "
                   "and the soft step's springs give way; docs/conventions.md, \"Deep overlaps\"")
def test_a_thin_light_plate_under_a_block_1000_times_heavier_keeps_its_overlap_under_half_its_inner_radius(solver):
    # the target: a plate 1.8 mm thick (inner radius 0.9 mm) under a block 1000 times heavier at dt 1/60, 2 s
    w, plate = plate_under_block(solver, 1000)
    assert deepest_overlap(w, 1 / 60, 120, plate) < TARGET * 0.0009


def test_the_oracle_and_the_core_push_a_small_sphere_out_to_a_fifth_of_its_radius_alike():
    # a sphere of radius r = 3 mm set d = 2 mm into the ground, no gravity: the position pass
    # moves it up by erp (overlap - slop_i) a step, slop_i = 0.2 r = 0.6 mm < 1 mm, so the overlap
    # after k steps is slop_i + (d - slop_i) (1 - erp)^k; the core steps it as the oracle does.
    # The PGS: the position pass of erp and slop is its own
    r, d, dt, erp = 0.003, 0.002, 1 / 240, 0.2
    w = sg.World(gravity=(0, 0, 0), solver="pgs", substeps=1)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    b = w.add_body(sg.Sphere(r), density=1000.0, position=(0, 0, r - d))
    slop = SLOP_INNER_FRACTION * r
    overlaps, snap = [], w.snapshot()
    for k in range(10):
        new, _ = oracle.step(snap, dt)
        w.step(dt)
        # (positions ~3 mm round to ~1e-19 m a step: 1e-12 m is ample)
        np.testing.assert_allclose(w.positions[b], new["position"][b], rtol=0, atol=1e-12)
        overlaps.append(r - new["position"][b][2])
        snap = new
    np.testing.assert_allclose(overlaps, slop + (d - slop) * (1 - erp) ** np.arange(1, 11), rtol=1e-9)


def flat_floor():
    """A flat TriangleMesh floor z = 0 of 2 x 2 squares 2 m wide, faces up."""
    return sg.TriangleMesh(*fuzz.heightfield_mesh({"half_width": 2.0, "cells": 2, "amplitude": 0.0, "waves": [],
                                                   "noise_seed": 0}))


def points_against(floor, shape, pose, margin):
    """{(kind, index) of B's feature: gap} of the contacts of shape at pose against floor."""
    c = sg.collide(floor, ((0, 0, 0), (1, 0, 0, 0)), shape, pose, margin=margin)
    return {(sg.feature(f).kind, sg.feature(f).index): g for f, g in zip(c.feature_b, c.gap)}


@pytest.mark.slots("trimesh-capsule", "trimesh-cylinder", role="golden",
                   note="segment ends and rim points over a face, as against a plane")
@pytest.mark.parametrize("shape,z,margin", [(sg.Capsule(0.01, 0.05), 0.035, 0.1), (sg.Cylinder(0.03, 0.01), 0.02, 0.01),
                                            (sg.Cylinder(0.03, 0.01), 0.012, 0.05)])
def test_a_tilted_capsule_or_cylinder_over_a_face_gets_the_points_a_plane_gives(shape, z, margin):
    # tilted by 0.6 rad over the middle of a triangle: a capsule's two segment ends and a
    # cylinder's rim points in the floor get the contacts (features and gaps) they get against the
    # plane z = 0. One point at the lower end let a capsule that landed tilted swing its upper end
    # through the floor, and a disc tilted into the floor pivot about one rim point and sink (issue 21)
    a = 0.6
    pose = ((0.5, 0.6, z), (np.cos(a / 2), np.sin(a / 2), 0.0, 0.0))
    plane = points_against(sg.Plane((0, 0, 1), 0.0), shape, pose, margin)
    if isinstance(shape, sg.Cylinder):
        # speculative rim points are the support clip's (docs/conventions.md, "Contacts")
        plane = {f: g for f, g in plane.items() if f[0] == "vertex" and g <= 0.0}
    mesh = points_against(flat_floor(), shape, pose, margin)
    assert len(plane) >= 2
    for feature, gap in plane.items():
        assert mesh[feature] == pytest.approx(gap, rel=0, abs=1e-15)


def top_overlap(solver, dt, spin):
    """The deepest overlap (m) in 1 s of a capsule (radius 5 mm, segment 40 mm, 50 g) set on the
    floor tilted 0.5 rad and spun at `spin` rad/s about its own axis, like a top."""
    w = sg.World(solver=solver, sleeping=False)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    tilt, r, half = 0.5, 0.005, 0.02
    axis = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
    w.add_body(sg.Capsule(r, half), mass=0.05, position=half * axis + (0, 0, r),
               orientation=(np.cos(tilt / 2), 0.0, np.sin(tilt / 2), 0.0), angular_velocity=spin * axis)
    deepest = 0.0
    for _ in range(round(1.0 / dt)):
        w.step(dt)
        if len(w.contacts.gap):
            deepest = max(deepest, -w.contacts.gap.min())
    return deepest


@pytest.mark.parametrize("solver", ["pgs", "soft"])
@pytest.mark.parametrize("dt", [1 / 240, 1 / 60])
@pytest.mark.parametrize("spin", [100.0, 200.0])
def test_a_capsule_spinning_like_a_top_sinks_no_further_than_its_contact_force_presses_it(solver, dt, spin):
    # A spun capsule's end cap touches the floor below its core, a point on its axis 20 mm from its
    # centre, which circles the axis of omega (tilted from the capsule's) at the full spin: 0.1 to
    # 0.8 rad in a substep here (the PGS's 1/960 s, the soft step's 1/240 s). With the rows' lever
    # arms kept as detected the velocity constraint aims at where the core was, and it sinks: 22 to
    # 46 % of its radius in the PGS, 18 to 62 % in the soft step. The PGS now finds the pair's
    # contacts again once the turn has moved the capsule's points a quarter of its radius, in
    # substeps that turn it by at most as much (up to 64 at dt 1/60): 5 to 12 %. The precessing top presses on the floor with up to 6 times its weight (the PGS's
    # largest normal force, measured with arms that followed the core), so
    # - the soft step's spring (2 pi * 60 Hz against the floor) should give way by at most 10 g / omega^2;
    # - the PGS's rigid contact by at most its slop, 0.2 of the inner radius (1 mm).
    deepest = top_overlap(solver, dt, spin)
    if solver == "soft":
        assert deepest < 10 * 9.81 / (2 * np.pi * 60.0) ** 2
    else:
        assert deepest < SLOP_INNER_FRACTION * 0.005
