"""The Python API: names, shapes and types of results, and bad input that leaves the world as it was."""
import math

import numpy as np
import pytest

import signorini as sg
from signorini.meshes import box_mesh, torus


def make_world():
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    w.add_body(sg.Box(half_extents=(0.5, 0.5, 0.5)), density=1000.0, position=(0, 0, 1.0),
               orientation=(1, 0, 0, 0), velocity=(0, 0, 0), angular_velocity=(0, 0, 0))
    w.add_body(sg.Sphere(radius=0.2), mass=1.0, position=(2, 0, 1))
    return w


def test_all_lists_every_name_the_docs_use_and_dir_shows_them():
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    texts = [root / "README.md", *sorted((root / "docs").glob("*.md"))]
    used = {name for path in texts for name in re.findall(r"\bsg\.([A-Za-z_]\w*)", path.read_text())}
    assert {"World", "load_mjcf", "load_scene", "meshfile"} <= used  # the scan finds what it should
    assert sorted(used - set(sg.__all__)) == []
    listed = dir(sg)
    for name in sg.__all__:
        assert hasattr(sg, name), name
        assert name in listed, name  # the lazily imported ones too
    assert len(set(sg.__all__)) == len(sg.__all__)
    # `from signorini import *` gives exactly the public API
    namespace: dict = {}
    exec("from signorini import *", namespace)
    assert set(namespace) - {"__builtins__"} == set(sg.__all__)


def test_mesh_constructors_have_docstrings():
    for cls in (sg.Mesh, sg.TriangleMesh):
        doc = cls.__init__.__doc__
        # pybind11 puts the signature first; a docstring follows it
        assert len(doc.strip().splitlines()) > 1, doc
        assert "(n, 3)" in doc and "(k, 3)" in doc and "load_mesh" in doc


def world_state(w):
    """Everything observable about a world, for before/after comparisons."""
    s = w.snapshot()
    return (w.num_bodies, w.time, s["position"].tobytes(), s["rotation"].tobytes(), s["velocity"].tobytes(),
            s["angular_velocity"].tobytes(), s["force"].tobytes(), w.masses.tobytes(), len(w.contacts))


def test_readme_example_shapes_and_types():
    w = make_world()
    w.step(dt=1 / 240, steps=10)
    assert w.positions.shape == (3, 3) and w.orientations.shape == (3, 4)
    assert w.velocities.shape == (3, 3) and w.angular_velocities.shape == (3, 3)
    assert w.positions.dtype == np.float64
    assert np.allclose(np.linalg.norm(w.orientations, axis=1), 1.0, atol=1e-15)
    c = w.contacts
    for name in ("body_a", "body_b", "gap", "impulse", "alpha"):
        assert getattr(c, name).shape == (len(c),)
    assert c.point.shape == (len(c), 3) and c.normal.shape == (len(c), 3)
    stats = w.solver_stats
    assert isinstance(stats.iterations, int) and isinstance(stats.converged, bool)
    assert math.isclose(w.time, 10 / 240, rel_tol=1e-15)
    mass, com, inertia = sg.mass_properties(sg.Box((0.5, 0.5, 0.5)), density=1000.0)
    assert mass == pytest.approx(1000.0, rel=1e-15) and com.shape == (3,) and inertia.shape == (3, 3)


def test_state_arrays_are_read_only_views():
    w = make_world()
    p = w.positions
    with pytest.raises(ValueError):
        p[1, 2] = 5.0  # writing would bypass the core's checks: refused (use the setters)
    w.step(1 / 240)
    assert p[1, 2] < 1.0  # a view taken before the step shows the step
    w.set_position(1, (0, 0, 2.0))
    assert w.positions[1, 2] == 2.0 and p[1, 2] == 2.0


def test_static_bodies_have_infinite_mass_and_never_move():
    w = make_world()
    assert np.isinf(w.masses[0]) and w.is_static.tolist() == [True, False, False]
    w.step(1 / 240, 240)
    assert np.array_equal(w.positions[0], np.zeros(3))


def test_non_unit_quaternion_is_normalised():
    w = sg.World()
    i = w.add_body(sg.Box((0.1, 0.2, 0.3)), density=1.0, orientation=(2.0, 0.0, 0.0, 2.0))
    q = w.orientations[i]
    assert np.allclose(q, [math.sqrt(0.5), 0, 0, math.sqrt(0.5)], atol=1e-15)


def test_mesh_body_frame_is_its_centre_of_mass():
    v, f = box_mesh((0.5, 0.25, 0.1))
    w = sg.World()
    i = w.add_body(sg.Mesh(v + [3.0, 2.0, 1.0], f), density=100.0, position=(0, 0, 1))
    centred = w.shape(i).vertices
    assert np.allclose(centred.mean(axis=0), 0.0, atol=1e-14)
    assert w.masses[i] == pytest.approx(100.0 * 0.1, rel=1e-12)


BAD_BODIES = [
    (dict(density=float("nan")), ValueError, "density"),
    (dict(density=float("inf")), ValueError, "density"),
    (dict(density=0.0), ValueError, "density"),
    (dict(density=-5.0), ValueError, "density"),
    (dict(mass=-1.0), ValueError, "mass"),
    (dict(mass=0.0), ValueError, "mass"),
    (dict(density=1.0, mass=1.0), ValueError, "exactly one"),
    (dict(), ValueError, "exactly one"),
    (dict(density=1.0, position=(0, 0, float("nan"))), ValueError, "position"),
    (dict(density=1.0, position=(0, 0)), ValueError, "shape (3,)"),
    (dict(density=1.0, position=[[0, 0, 0]]), ValueError, "shape (3,)"),
    (dict(density=1.0, position="up"), TypeError, "position"),
    (dict(density=1.0, velocity=(0, float("inf"), 0)), ValueError, "velocity"),
    (dict(density=1.0, angular_velocity=(0, 0, 0, 0)), ValueError, "angular_velocity"),
    (dict(density=1.0, orientation=(0, 0, 0, 0)), ValueError, "zero"),
    (dict(density=1.0, orientation=(1, 0, 0)), ValueError, "orientation"),
    (dict(density=1.0, orientation=(float("nan"), 0, 0, 1)), ValueError, "orientation"),
    (dict(density="heavy"), TypeError, "density"),
]


@pytest.mark.parametrize("kwargs, error, words", BAD_BODIES)
def test_bad_body_is_rejected_by_name_and_world_unchanged(kwargs, error, words):
    w = make_world()
    w.step(1 / 240, 5)
    before = world_state(w)
    with pytest.raises(error) as info:
        w.add_body(sg.Sphere(0.1), **kwargs)
    assert "body 3 (Sphere)" in str(info.value) and words in str(info.value)
    assert world_state(w) == before


def test_bad_shapes_are_rejected():
    with pytest.raises(ValueError, match="radius"):
        sg.Sphere(radius=-1.0)
    with pytest.raises(ValueError, match="radius"):
        sg.Sphere(radius=float("nan"))
    with pytest.raises(ValueError, match="half extents"):
        sg.Box(half_extents=(1.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="shape"):
        sg.Box(half_extents=(1.0, 1.0))
    with pytest.raises(ValueError, match="non-zero"):
        sg.Plane(normal=(0, 0, 0), offset=0.0)
    with pytest.raises(ValueError, match="vertices must have shape"):
        sg.Mesh(np.zeros((4, 2)), [[0, 1, 2]])
    with pytest.raises(ValueError, match="faces must have shape"):
        sg.Mesh(np.eye(3), [0, 1, 2])
    with pytest.raises(TypeError, match="integer"):
        sg.Mesh(np.eye(3), [[0.0, 1.0, 2.0]])
    with pytest.raises(ValueError, match="outside"):
        sg.Mesh(np.eye(3), [[0, 1, 3]])
    with pytest.raises(ValueError, match="not finite"):
        sg.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]]), [[0, 1, 2]])
    with pytest.raises(ValueError, match="degenerate"):
        sg.Mesh(np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]]), [[0, 1, 2]])


def test_open_or_inverted_mesh_is_rejected_for_a_dynamic_body_and_world_unchanged():
    v, f = box_mesh((0.5, 0.5, 0.5))
    w = make_world()
    before = world_state(w)
    with pytest.raises(ValueError, match=r"body 3 \(Mesh\).*open"):
        w.add_body(sg.Mesh(v, f[:-1]), density=1.0)
    with pytest.raises(ValueError, match=r"body 3 \(Mesh\).*volume"):
        w.add_body(sg.Mesh(v, f[:, ::-1]), density=1.0)
    flipped = f.copy()
    flipped[0] = flipped[0, ::-1]
    with pytest.raises(ValueError, match=r"body 3 \(Mesh\).*inconsistently oriented"):
        w.add_body(sg.Mesh(v, flipped), density=1.0)
    assert world_state(w) == before
    # an open mesh is fine as static scenery, as a TriangleMesh
    w.add_static(sg.TriangleMesh(v, f[:-1]), position=(10, 0, 0))


def test_plane_must_be_static_and_static_takes_no_mass():
    w = make_world()
    before = world_state(w)
    with pytest.raises(ValueError, match="static"):
        w.add_body(sg.Plane((0, 0, 1), 0.0), mass=1.0)
    with pytest.raises(TypeError, match="shape must be"):
        w.add_body("box", density=1.0)
    assert world_state(w) == before


def test_unsupported_pair_is_refused_when_the_body_is_added():
    # an open mesh without convex pieces collides with planes only: static scenery is a
    # TriangleMesh; refused at once against a dynamic body, the world unchanged
    w = make_world()
    before = world_state(w)
    v, f = box_mesh((0.5, 0.5, 0.5))
    with pytest.raises(ValueError, match=r"body 3 \(Mesh\): unsupported pair Box - Mesh \(non-convex or open\).*TriangleMesh"):
        w.add_static(sg.Mesh(v, f[:-1]), position=(10, 0, 0))
    assert world_state(w) == before
    # every other pair is supported: a cylinder on a triangle mesh, for one
    w.add_static(sg.TriangleMesh([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]]))
    w.add_body(sg.Cylinder(0.1, 0.2), density=100.0, position=(5, 0, 1))


def test_a_static_open_mesh_refuses_the_moving_bodies_added_after_it_until_it_is_removed():
    # two static bodies never collide, so the open mesh is taken while nothing moves; a moving body
    # added later would touch it and is refused, naming both; once the mesh is gone it is taken
    w = sg.World()
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    v, f = box_mesh((0.5, 0.5, 0.5))
    mesh = w.add_static(sg.Mesh(v, f[:-1]), position=(10, 0, 0))
    w.add_static(sg.Box((1.0, 1.0, 1.0)), position=(-5, 0, 0))
    before = world_state(w)
    with pytest.raises(ValueError, match=r"body 3 \(Sphere\): unsupported pair Mesh \(non-convex or open\) - Sphere"
                       r".*\(with body 1\)"):
        w.add_body(sg.Sphere(0.1), density=100.0, position=(0, 0, 1))
    assert world_state(w) == before
    w.remove_body(mesh)
    ball = w.add_body(sg.Sphere(0.1), density=100.0, position=(0, 0, 1))
    w.step(1 / 240, 240)
    assert w.positions[ball][2] == pytest.approx(0.1, abs=2e-3)


def test_a_dynamic_torus_is_decomposed_and_carries_a_ball_on_its_tube():
    v, f = torus(0.3, 0.1, 24, 12)
    w = make_world()
    w.add_body(sg.Mesh(v, f), density=100.0, position=(5, 0, 0.1))
    # a ball dropped onto the tube (top at z = 0.2) rests on it instead of falling through
    j = w.add_body(sg.Sphere(0.05), density=100.0, position=(5.3, 0, 0.3))
    w.step(1 / 240, 90)
    # the convex pieces are hulls of the tessellated tube: within its sagitta of the true surface
    # (frictionless, the ball then slowly slides off the top of the tube)
    assert abs(w.positions[j][2] - 0.25) < 0.01
    assert np.linalg.norm(w.velocities[j]) < 0.05


def test_bad_steps_and_indices():
    w = make_world()
    w.step(1 / 240, 3)
    before = world_state(w)
    for dt in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="dt"):
            w.step(dt)
    with pytest.raises(TypeError, match="dt"):
        w.step("fast")
    with pytest.raises(ValueError, match="steps"):
        w.step(0.01, -1)
    with pytest.raises(TypeError, match="steps"):
        w.step(0.01, 2.5)
    for i in (3, -1, 100):
        with pytest.raises(ValueError, match="out of range"):
            w.set_velocity(i, (0, 0, 0))
        with pytest.raises(IndexError):
            w.shape(i)
    with pytest.raises(TypeError, match="integer"):
        w.set_position(1.0, (0, 0, 0))
    with pytest.raises(ValueError, match=r"body 1 \(Box\): velocity must be finite"):
        w.set_velocity(1, (0, float("nan"), 0))
    with pytest.raises(ValueError, match="static body cannot have a velocity"):
        w.set_velocity(0, (1, 0, 0))
    with pytest.raises(ValueError, match=r"body 1 \(Box\): force must have shape \(3,\)"):
        w.set_external_wrench(1, force=(1, 2))
    assert world_state(w) == before


def test_bad_world_settings():
    with pytest.raises(ValueError, match="gravity"):
        sg.World(gravity=(0, 0, float("nan")))
    with pytest.raises(ValueError, match="gravity"):
        sg.World(gravity=(0, -9.81))
    with pytest.raises(ValueError, match="erp"):
        sg.World(erp=1.5)
    with pytest.raises(ValueError, match="contact_margin"):
        sg.World(contact_margin=-0.1)
    with pytest.raises(ValueError, match="max_iterations"):
        sg.World(max_iterations=0)


def test_external_wrench_accelerates_in_free_flight():
    w = sg.World(gravity=(0, 0, 0))
    i = w.add_body(sg.Sphere(0.5), mass=2.0)
    w.set_external_wrench(i, force=(4.0, 0, 0))
    w.step(0.01, 100)  # a = 2 m/s^2 for 1 s; symplectic Euler is exact for the velocity
    assert w.velocities[i] == pytest.approx([2.0, 0, 0], abs=1e-12)


def test_determinism_bit_identical():
    def run():
        w = make_world()
        w.set_angular_velocity(1, (1.0, 2.0, -0.5))
        w.step(1 / 240, 480)
        return w.positions.tobytes() + w.orientations.tobytes() + w.velocities.tobytes()
    assert run() == run()


def test_a_step_that_overflows_is_undone_and_reported():
    w = sg.World(gravity=(0, 0, 0))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Sphere(0.5), mass=1.0, position=(0, 0, 2.0), velocity=(1.0, 0, 0))
    w.step(0.01, 2)
    w.set_external_wrench(1, force=(1e308, 0, 0))
    before = world_state(w)
    with pytest.raises(RuntimeError, match=r"body 1 \(Sphere\): state became non-finite"):
        w.step(1e10)  # v + dt f / m overflows to infinity
    assert world_state(w) == before
