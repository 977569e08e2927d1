"""The core against the NumPy oracle (signorini.oracle), which never imports the core.

Tolerances: one step of the same formulas from the same state agrees to rounding (~1e-15); 1e-10
leaves room only for a few ulps of arithmetic-order differences times the condition of the step.
Over 500 free steps rounding differences can be amplified by the contact LCP (degenerate when many
coplanar vertices touch: the impulses are not unique), hence 1e-8 as the issue sets it.
"""
import numpy as np
import pytest

import signorini as sg
from signorini import compare, oracle
from signorini.meshes import box_mesh, icosphere, torus


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["tumbling_box", "mesh_drop", "spheres", "torus", "boxes", "stack", "spinners"])
def test_one_step_agrees_to_1e_10(scene):
    world, dt, steps = compare.build(scene)
    report = compare.lockstep(world, dt, min(steps, 400))
    assert report.largest < 1e-10, "\n".join(report.lines())
    # the scene did make contacts, or the comparison would test nothing about the solver
    assert world.solver_stats.contacts > 0


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["tumbling_box", "mesh_drop", "spheres", "stack", "spinners"])
def test_free_rollout_agrees_over_500_steps_to_1e_8(scene):
    # one substep a step: with the default 4 (carried contacts, checked step by step to 1e-10 by
    # the lockstep test above), mesh_drop's flat-lying mesh, whose coplanar vertex contacts make
    # the forces non-unique, amplifies rounding over the 2,000 solves to 4e-6 m/s. The PGS: these
    # figures are its free rollout's against the oracle's PGS
    world, dt, steps = compare.build(scene)
    world.set_solver(solver="pgs", substeps=1)
    assert steps == 500
    report = compare.free(world, dt, steps)
    assert report.largest < 1e-8, "\n".join(report.lines())
    assert report.contact_count_mismatches == 0


@pytest.mark.parametrize("scene", ["tumbling_box", "mesh_drop", "spheres", "torus", "stack"])
def test_contacts_match_the_oracle_feature_by_feature(scene):
    world, dt, _ = compare.build(scene)
    seen = 0
    for _ in range(60):
        world.step(dt, 5)
        core = world.detect_contacts(dt)
        expected = oracle.detect_contacts(world.snapshot(), dt)
        assert np.array_equal(core.body_a, expected["body_a"])
        assert np.array_equal(core.body_b, expected["body_b"])
        for key in ("point", "normal", "gap"):
            assert np.allclose(getattr(core, key), expected[key], rtol=0, atol=1e-12), key
        # the same features: box-box manifolds clipped and reduced the same way, ids and all
        for key in ("feature_a", "feature_b"):
            assert np.array_equal(getattr(core, key), np.asarray(expected[key], dtype=np.uint64)), key
        seen += len(core)
    assert seen > 0


def test_a_spinning_body_keeps_the_oracles_speculative_points():
    # a capsule spinning at 50 rad/s among balls resting 2 cm apart: the body-wide reach takes
    # every neighbour, the per-point rule (docs/conventions.md, "Which contacts exist") only those
    # its surface moves towards; the core keeps exactly the oracle's points
    world = sg.World()
    world.add_static(sg.Plane((0, 0, 1), 0.0))
    for i in range(-2, 3):
        for j in range(-2, 3):
            if (i, j) != (0, 0):
                world.add_body(sg.Sphere(0.05), mass=1.0, position=(0.12 * i, 0.12 * j, 0.05))
    cap = world.add_body(sg.Capsule(0.03, 0.06), mass=1.0, position=(0.0, 0.0, 0.1),
                         angular_velocity=(50.0, 0.0, 0.0))
    for dt in (1 / 240, 1 / 60):
        core = world.detect_contacts(dt)
        expected = oracle.detect_contacts(world.snapshot(), dt)
        assert np.array_equal(core.body_a, expected["body_a"]) and np.array_equal(core.body_b, expected["body_b"])
        assert np.allclose(core.gap, expected["gap"], rtol=0, atol=1e-12)
        mine = (core.body_a == cap) | (core.body_b == cap)
        touched = set(core.body_a[mine].tolist()) | set(core.body_b[mine].tolist())
        # measured with the body-wide reach alone: the floor at 1/240 s, the floor and 4 balls at
        # 1/60 s; with the per-point rule: none, and the floor and 1 ball
        assert len(touched - {cap}) <= {1 / 240: 0, 1 / 60: 2}[dt]


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_a_stack_falling_as_one_keeps_the_contacts_its_landing_closes(solver):
    # two 20 cm cubes falling at 20 m/s, 5 cm apart, the lower one 10 cm over the floor: they do
    # not approach each other, but the lower one lands within the step (dt |v| = 33 cm) and the
    # upper one then closes on it at 20 m/s (docs/conventions.md, "Which contacts exist": a body's
    # own closing speed counts when its partner can be stopped by a third). Without that rule the
    # pair had no contact in that step, and the upper cube went 18.5 cm (PGS) and 9.1 cm (soft step)
    # into the lower one. With it, the speculative contact stops the upper cube at the lower one's
    # face: no deeper than the slop (1 mm) after the landing step
    dt = 1 / 60
    world = sg.World(gravity=(0.0, 0.0, -9.81), solver=solver)
    world.add_static(sg.Plane((0, 0, 1), 0.0))
    lower = world.add_body(sg.Box((0.1, 0.1, 0.1)), mass=1.0, position=(0, 0, 0.2), velocity=(0, 0, -20.0))
    upper = world.add_body(sg.Box((0.1, 0.1, 0.1)), mass=1.0, position=(0, 0, 0.45), velocity=(0, 0, -20.0))
    core = world.detect_contacts(dt)
    expected = oracle.detect_contacts(world.snapshot(), dt)
    assert np.array_equal(core.body_a, expected["body_a"]) and np.array_equal(core.body_b, expected["body_b"])
    assert np.allclose(core.gap, expected["gap"], rtol=0, atol=1e-12)
    pair = (core.body_a == lower) & (core.body_b == upper)
    assert pair.sum() == 4 and np.allclose(core.gap[pair], 0.05, rtol=0, atol=1e-12)
    world.step(dt)
    assert np.all(world.velocities[:, 2] > -1.0)  # both landed within the step
    after = world.detect_contacts(dt)
    pair = (after.body_a == lower) & (after.body_b == upper)
    assert pair.any() and after.gap[pair].min() > -0.001


def test_the_manifold_is_chosen_among_the_points_the_step_can_close():
    # a flat box (half 6 x 6 x 1 cm) turned 45 degrees about z and tilted 4 degrees about x, its
    # lowest point 1 mm over a static box's top face, sliding at 5 m/s along x: the body-wide
    # reach (dt |v| = 2.1 cm at 1/240 s) takes the whole clipped octagon as candidates, but the
    # pair closes only gravity's dt^2 g = 0.17 mm beyond the 5 mm margin in this step. Reduced
    # among every candidate (as sg.collide, which knows no motion, does) the octagon's far corners
    # take two of the four slots and the reachability rule then leaves a line of two points; chosen
    # among the reachable ones (docs/conventions.md, "Manifolds"), the pair keeps 4 points, all
    # within the margin, spanning an area; the core keeps exactly the oracle's points
    theta, margin, dt = np.radians(4.0), 0.005, 1 / 240
    tilt = (np.cos(theta / 2), np.sin(theta / 2), 0.0, 0.0)
    turn = (np.cos(np.pi / 8), 0.0, 0.0, np.sin(np.pi / 8))
    q = tuple(oracle.matrix_to_quat(oracle.quat_to_matrix(tilt) @ oracle.quat_to_matrix(turn)))
    z = 0.05 + 0.01 / np.cos(theta) + 0.05 * np.sin(theta) + 0.001
    world = sg.World(gravity=(0.0, 0.0, -9.81), contact_margin=margin)
    world.add_static(sg.Box((0.05, 0.05, 0.05)))
    world.add_body(sg.Box((0.06, 0.06, 0.01)), density=500.0, position=(0.0, 0.0, z), orientation=q,
                   velocity=(5.0, 0.0, 0.0))
    core = world.detect_contacts(dt)
    expected = oracle.detect_contacts(world.snapshot(), dt)
    assert np.allclose(core.gap, expected["gap"], rtol=0, atol=1e-12)
    for key in ("feature_a", "feature_b"):
        assert np.array_equal(getattr(core, key), np.asarray(expected[key], dtype=np.uint64)), key
    assert len(core) == 4 and np.all(core.gap < margin)
    y = core.point - core.point.mean(axis=0)
    assert np.linalg.svd(y, compute_uv=False)[1] > 0.01  # not on a line: two spans over 1 cm
    threshold = margin + dt * (5.0 + dt * 9.81)  # the broad reach s_B of the pair
    everything = sg.collide(sg.Box((0.05, 0.05, 0.05)), ((0, 0, 0), (1, 0, 0, 0)), sg.Box((0.06, 0.06, 0.01)),
                            ((0.0, 0.0, z), q), margin=threshold)
    assert len(everything) == 4 and np.sum(everything.gap >= margin + dt * dt * 9.81) == 2


def test_pgs_reaches_the_exact_lcp_solution():
    # a ball on the plane with a second ball landing on it off-centre: a coupled 2-contact LCP with
    # a positive definite Delassus matrix, so its solution is unique and PGS must converge to it
    # (frictionless, so that the LCP is the lecture's normal-only one)
    w = sg.World(gravity=(0, 0, -9.81), solver="pgs", tolerance=1e-13, max_iterations=10000, substeps=1)  # one LCP
    w.add_static(sg.Plane((0, 0, 1), 0.0), friction=0.0)
    w.add_body(sg.Sphere(0.3), mass=2.0, position=(0, 0, 0.3), velocity=(0, 0, -0.5), friction=0.0)
    d = np.array([0.2, 0.1, 1.0]) / np.linalg.norm([0.2, 0.1, 1.0])
    w.add_body(sg.Sphere(0.2), mass=1.0, position=np.array([0, 0, 0.3]) + (0.5 - 1e-4) * d, velocity=(0, 0, -1.0),
               friction=0.0)
    dt = 1 / 240
    snap = w.snapshot()
    w.step(dt)
    assert w.solver_stats.converged and len(w.contacts) == 2
    contacts = {k: getattr(w.contacts, k) for k in ("body_a", "body_b", "point", "normal", "gap")}
    v_star, omega_star = oracle.unconstrained_velocity(snap, dt)
    A, b = oracle.contact_lcp(snap, contacts, v_star, omega_star, dt, b_bias="speculative")
    x, _ = oracle.lcp_solve(A, b)
    assert np.allclose(w.contacts.alpha, x, rtol=1e-9, atol=1e-9 * np.abs(x).max())


def test_mesh_mass_properties_agree_with_closed_forms_and_the_oracle():
    # box mesh: the divergence theorem is exact for a polyhedron (rounding only)
    h = np.array([0.3, 0.5, 0.7])
    v, f = box_mesh(h)
    m, com, inertia = sg.mass_properties(sg.Mesh(v, f), density=900.0)
    m_box, _, i_box = sg.mass_properties(sg.Box(h), density=900.0)
    assert m == pytest.approx(m_box, rel=1e-14)
    assert np.allclose(com, 0.0, atol=1e-15) and np.allclose(inertia, i_box, rtol=1e-13, atol=1e-13)
    # fine icosphere: an inscribed polyhedron; its mass and inertia lie below the ball's, within the
    # second-order discretisation error 1 - (mesh volume / ball volume) ~ a few 1e-3 at 5 levels
    r = 0.5
    v, f = icosphere(r, 5)
    m, com, inertia = sg.mass_properties(sg.Mesh(v, f), density=1000.0)
    m_ball, _, i_ball = sg.mass_properties(sg.Sphere(r), density=1000.0)
    assert 0.0 < 1.0 - m / m_ball < 2e-3
    assert np.allclose(com, 0.0, atol=1e-12)
    # inertia scales as r^5 against volume's r^3: its relative deficit is about 5/3 the volume's
    deficit = 1.0 - m / m_ball
    assert np.all(np.diag(inertia) < np.diag(i_ball))
    assert np.allclose(np.diag(inertia), np.diag(i_ball), rtol=2.0 * deficit, atol=0)
    assert np.max(np.abs(inertia - np.diag(np.diag(inertia)))) < 1e-12 * i_ball[0, 0]
    # the core and the oracle agree on an arbitrary closed mesh (a torus) to rounding
    v, f = torus(0.4, 0.15, 24, 12)
    v = v @ oracle.quat_to_matrix(np.array([0.8, 0.4, -0.2, 0.4]) / np.linalg.norm([0.8, 0.4, -0.2, 0.4])).T + [1, 2, 3]
    core = sg.mass_properties(sg.Mesh(v, f), density=700.0)
    expected = oracle.mass_properties_mesh(v, f, 700.0)
    for a, b in zip(core, expected):
        assert np.allclose(a, b, rtol=1e-12, atol=1e-12)


def test_small_bodies_at_dt_1_60_keep_the_oracles_touching_points():
    # the manifold's touching rule against a plane counts gravity's kick (2.7 mm at dt 1/60) up to a
    # fifth of the smaller inner radius (docs/conventions.md, "Manifolds"): small cylinders, plates
    # and capsules of 1 to 5 mm, landing, tumbling and resting, get exactly the oracle's points
    rng = np.random.default_rng(7)
    world = sg.World(sleeping=False)
    world.add_static(sg.Plane((0, 0, 1), 0.0))
    for k in range(12):
        size = rng.uniform(0.001, 0.005)
        shape = [sg.Cylinder(size, 0.9 * size), sg.Box((2 * size, size, 0.5 * size)),
                 sg.Capsule(0.6 * size, size)][k % 3]
        q = rng.normal(size=4)
        world.add_body(shape, density=1000.0, position=(0.2 * k, 0.0, 0.004), orientation=tuple(q / np.linalg.norm(q)),
                       angular_velocity=tuple(rng.normal(size=3) * 5.0))
    seen = 0
    for _ in range(40):
        world.step(1 / 60)
        core = world.detect_contacts(1 / 60)
        expected = oracle.detect_contacts(world.snapshot(), 1 / 60)
        assert np.array_equal(core.body_a, expected["body_a"]) and np.array_equal(core.body_b, expected["body_b"])
        assert np.allclose(core.gap, expected["gap"], rtol=0, atol=1e-12)
        for key in ("feature_a", "feature_b"):
            assert np.array_equal(getattr(core, key), np.asarray(expected[key], dtype=np.uint64)), key
        seen += len(core)
    assert seen > 12 * 40
