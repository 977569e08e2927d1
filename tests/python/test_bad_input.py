"""Bad input gets a ValueError or TypeError saying what is wrong (never pybind11's signature dump,
an OverflowError or a misleading message), and the world is exactly as it was; a step whose energy
explodes is undone and reported like a non-finite one (issue 8)."""
import math

import numpy as np
import pytest

import signorini as sg


def make_world():
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Box((0.5, 0.5, 0.5)), density=1000.0, position=(0, 0, 0.5), velocity=(0.3, 0, 0))
    w.step(1 / 240, 5)
    return w


def world_state(w):
    """Everything observable about a world, for before/after comparisons."""
    s = w.snapshot()
    c = w.contacts
    return (w.num_bodies, w.time, s["position"].tobytes(), s["rotation"].tobytes(), s["velocity"].tobytes(),
            s["angular_velocity"].tobytes(), s["force"].tobytes(), w.masses.tobytes(), w.inertias.tobytes(),
            c.gap.tobytes(), c.alpha.tobytes(), w.contact_forces.tobytes(), w.contact_torques.tobytes(),
            tuple(v.tobytes() for v in w.warm_start_cache.values()), repr(w.solver))


def no_signature_dump(e):
    assert "incompatible" not in str(e) and "supported" not in str(e), str(e)


# ---- shapes: Python types are converted, never guessed --------------------------------------

@pytest.mark.parametrize("make, message", [
    (lambda: sg.Sphere(True), r"Sphere: radius must be a number, got True"),
    (lambda: sg.Sphere(np.bool_(True)), r"Sphere: radius must be a number, got (np\.)?(True|bool)"),
    (lambda: sg.Sphere("1"), r"Sphere: radius must be a number, got '1'"),
    (lambda: sg.Sphere(None), r"Sphere: radius must be a number, got None"),
    (lambda: sg.Capsule(True, 1.0), r"Capsule: radius must be a number"),
    (lambda: sg.Cylinder(0.5, "2"), r"Cylinder: half_height must be a number"),
    (lambda: sg.Plane((0, 0, 1), None), r"Plane: offset must be a number"),
    (lambda: sg.Compound(5), r"Compound: parts must be a list of \(shape, \(position, orientation\)\), got 5"),
])
def test_shape_constructors_reject_non_numbers_with_a_clear_type_error(make, message):
    w = make_world()
    before = world_state(w)
    with pytest.raises(TypeError, match=message) as e:
        make()
    no_signature_dump(e.value)
    assert world_state(w) == before


def test_shape_constructors_still_take_numpy_numbers():
    assert sg.Sphere(np.float32(0.5)).radius == 0.5
    assert sg.Sphere(np.int64(2)).radius == 2.0
    assert sg.Capsule(1, 0).half_length == 0.0


def test_a_huge_int_radius_is_a_value_error_not_an_overflow():
    with pytest.raises(ValueError, match=r"Sphere: radius is too large for a double"):
        sg.Sphere(10**400)


# ---- world calls ------------------------------------------------------------------------------

@pytest.mark.parametrize("call, error, message", [
    (lambda w: w.step(None), TypeError, r"step: dt must be a number, got None"),
    (lambda w: w.step(1 / 240, 2**31), ValueError, r"step: steps = 2147483648 is too large: at most 2147483647"),
    (lambda w: w.step(1 / 240, 1.0), TypeError, r"step: steps must be an integer"),
    (lambda w: w.detect_contacts(None), TypeError, r"detect_contacts: dt must be a number"),
    (lambda w: w.detect_contacts(0.0), ValueError, r"detect_contacts: dt must be positive and finite, got 0"),
    (lambda w: w.detect_contacts(-1 / 240), ValueError, r"detect_contacts: dt must be positive and finite, got -0\.004"),
    (lambda w: w.detect_contacts(math.nan), ValueError, r"detect_contacts: dt must be positive and finite, got nan"),
    (lambda w: w.detect_contacts(math.inf), ValueError, r"detect_contacts: dt must be positive and finite, got inf"),
    (lambda w: w.set_solver(max_iterations=2**40), ValueError,
     r"set_solver: max_iterations = 1099511627776 is too large: at most 2147483647"),
])
def test_world_calls_reject_bad_arguments_and_leave_the_world_unchanged(call, error, message):
    w = make_world()
    before = world_state(w)
    with pytest.raises(error, match=message) as e:
        call(w)
    no_signature_dump(e.value)
    assert world_state(w) == before


@pytest.mark.parametrize("key", ["max_iterations", "substeps"])
def test_world_constructor_rejects_counts_beyond_a_c_int(key):
    with pytest.raises(ValueError, match=rf"World: {key} = 1099511627776 is too large: at most 2147483647") as e:
        sg.World(**{key: 2**40})
    no_signature_dump(e.value)


# ---- bodies: values the core checks, named by body --------------------------------------------

@pytest.mark.parametrize("shape, kwargs, error, message", [
    (sg.Sphere(0.5), {"mass": 10**400}, ValueError,
     r"body 2 \(Sphere\): mass is too large for a double: an integer of 401 digits"),
    (sg.Sphere(0.5), {"mass": 1.0, "position": (10**400, 0, 0)}, ValueError,
     r"body 2 \(Sphere\): position has a number too large for a double"),
    (sg.Sphere(0.5), {"mass": 1.0, "velocity": (0, 10**400, 0)}, ValueError,
     r"body 2 \(Sphere\): velocity has a number too large for a double"),
    (sg.Sphere(1e308), {"mass": 1.0}, ValueError,
     r"body 2 \(Sphere\): the shape is too large \(bounding radius 1e\+308 m\): its volume or inertia overflows"),
    (sg.Cylinder(1e200, 1e200), {"density": 1.0}, ValueError, r"body 2 \(Cylinder\): the shape is too large"),
    (sg.Sphere(1e-300), {"mass": 1.0}, ValueError,
     r"body 2 \(Sphere\): the shape is too small \(bounding radius 1e-300 m\): its volume or inertia underflows"),
    (sg.Capsule(1e-300, 0.0), {"mass": 1.0}, ValueError, r"body 2 \(Capsule\): the shape is too small"),
    (sg.Sphere(0.5), {"mass": 1e-320}, ValueError,
     r"body 2 \(Sphere\): mass \S+e-32\d is too small for a shape \(bounding radius 0\.5 m\): its inverse mass"),
    (sg.Sphere(0.5), {"density": 1e-320}, ValueError, r"body 2 \(Sphere\): density \S+e-32\d is too small"),
    (sg.Sphere(1e-10), {"mass": 1e308}, ValueError,
     r"body 2 \(Sphere\): mass 1e\+308 is too large for a shape \(bounding radius 1e-10 m\)"),
    (sg.Sphere(0.5), {"mass": True}, TypeError, r"body 2 \(Sphere\): mass must be a number, got True"),
])
def test_add_body_names_the_body_and_the_problem_and_changes_nothing(shape, kwargs, error, message):
    w = make_world()
    before = world_state(w)
    with pytest.raises(error, match=message) as e:
        w.add_body(shape, **kwargs)
    no_signature_dump(e.value)
    assert "singular" not in str(e.value)
    assert world_state(w) == before


def test_a_large_but_representable_mass_is_accepted_with_its_exact_inertia():
    # 1e300 kg on a 1 m sphere: I = 2/5 m r^2 is finite, though its determinant is not
    w = sg.World()
    i = w.add_body(sg.Sphere(1.0), mass=1e300)
    assert w.masses[i] == pytest.approx(1e300, rel=1e-12)
    assert np.allclose(w.inertias[i], 0.4e300 * np.eye(3), rtol=1e-12, atol=0)


# ---- orientations: scaled before the norm ------------------------------------------------------

def quarter_turn_about_x():
    return np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=float)


def test_a_huge_quaternion_is_normalised_without_overflow():
    # (1e300, 1e300, 0, 0) is (1, 1, 0, 0) / sqrt 2: a quarter turn about x, not the identity
    w = make_world()
    i = w.add_body(sg.Sphere(0.2), mass=1.0, position=(3, 0, 1), orientation=(1e300, 1e300, 0, 0))
    assert np.allclose(w.rotations[i], quarter_turn_about_x(), atol=1e-15)
    w.set_orientation(i, (0, 0, 0, 1e300))
    assert np.allclose(w.rotations[i], np.diag([-1.0, -1.0, 1.0]), atol=1e-15)
    c = sg.Compound([(sg.Box((1, 0.1, 0.1)), ((0, 0, 0), (1e300, 1e300, 0, 0)))])
    assert np.allclose(c.rotations[0], quarter_turn_about_x(), atol=1e-15)


def test_collide_normalises_a_huge_quaternion_without_overflow():
    # a 2 x 0.2 x 0.2 box turned a quarter about z by (1e300, 0, 0, 1e300) reaches y = 1: a sphere
    # of radius 0.5 at y = 1.4 is 0.1 m away along y (the unturned box would be 1.2 m away)
    with np.errstate(over="ignore"):
        c = sg.collide(sg.Box((1.0, 0.1, 0.1)), ((0, 0, 0), (1e300, 0, 0, 1e300)),
                       sg.Sphere(0.5), ((0, 1.4, 0), (1, 0, 0, 0)), margin=0.2)
    assert len(c) == 1
    assert c.gap[0] == pytest.approx(-0.1, abs=1e-12)
    assert np.allclose(c.normal[0], (0, 1, 0), atol=1e-12)


def test_a_tiny_quaternion_is_still_zero():
    w = make_world()
    before = world_state(w)
    with pytest.raises(ValueError, match=r"body 1 \(Box\): orientation quaternion .* is zero"):
        w.set_orientation(1, (1e-300, 0, 0, 0))
    assert world_state(w) == before


# ---- the energy-explosion guard ------------------------------------------------------------------

def explicit_spin_step(I, omega, dt):
    """One explicit (forward Euler) gyroscopic step of a free body, body axes = world axes:
    omega_1 = omega_0 - dt I^-1 (omega_0 x I omega_0), and the kinetic energies before and after."""
    I = np.diag(I)
    omega1 = omega - dt * np.linalg.solve(I, np.cross(omega, I @ omega))
    return 0.5 * omega @ I @ omega, 0.5 * omega1 @ I @ omega1


def box_inertia(m, h):
    a, b, c = 2 * np.asarray(h)
    return m / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def test_a_step_whose_energy_explodes_is_undone_and_names_the_body():
    # the lecture's explicit gyroscopic term on a fast asymmetric spinner with a long step: forward
    # Euler multiplies its kinetic energy by the closed form's factor (well over 100, over 1 J)
    h, m, omega, dt = (0.5, 0.25, 0.1), 1.0, np.array([20.0, 20.0, 20.0]), 1.0
    T0, T1 = explicit_spin_step(box_inertia(m, h), omega, dt)
    assert T1 > 100 * T0 and T1 - T0 > 1.0
    w = sg.World(gravity=(0, 0, 0), gyroscopic="explicit", substeps=1)
    w.add_static(sg.Plane((0, 0, 1), -100.0))  # beyond the spinner's reach in the step
    w.add_body(sg.Sphere(0.1), mass=1.0, position=(50, 0, 0), velocity=(1, 0, 0))
    w.add_body(sg.Box(h), mass=m)
    w.step(1e-3)
    w.set_angular_velocity(2, omega)  # body axes are still world axes
    before = world_state(w)
    with pytest.raises(RuntimeError, match=r"energy explosion: kinetic energy rose from .* in one step at t = 0\.001 s"
                                           r".*gained most: body 2 \(Box\) \+.*the step was undone") as e:
        w.step(dt)
    assert world_state(w) == before
    # the message gives the closed form's energies (the world's include the sphere's 1/2 J)
    text = str(e.value)
    assert f"{T0 + 0.5:.3g} J to {T1 + 0.5:.3g} J" in text
    assert f"body 2 (Box) +{T1 - T0:.3g} J" in text and "body 1" not in text
    # the same world steps on with a sensible dt
    w.step(1e-3)
    assert w.time == pytest.approx(0.002)


def test_the_energy_guard_lets_a_heavy_body_fall_from_rest_and_land():
    # free fall from rest (T_0 = 0) of a 10 m box of 1e6 kg: gravity's work pays for every joule,
    # and landing with an overlap only lifts it (no kinetic energy): no explosion is reported
    w = sg.World()
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Box((5.0, 5.0, 5.0)), mass=1e6, position=(0, 0, 4.95))
    w.step(1 / 60, 120)
    assert w.positions[1][2] == pytest.approx(5.0, abs=0.01)


def test_a_heavy_body_lifted_out_of_an_overlap_does_not_hide_another_bodys_fall():
    # first step: a 1e6 kg box starting 2 cm into the floor is lifted by the position pass (gravity
    # does negative work on it) while a 1e4 kg box falls from rest and gains 134 J: the budget
    # counts each body's positive work, so this is no explosion
    w = sg.World()
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1e6, position=(0, 0, 0.48))
    w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1e4, position=(5, 0, 10.0))
    w.step(1 / 60)
    assert w.positions[1][2] > 0.48
    assert w.kinetic_energy() == pytest.approx(0.5 * 1e4 * (9.81 / 60) ** 2, rel=1e-9)
