"""The soft step (World(solver="soft")): the oracle's twin (signorini.oracle.soft) against the core in
lockstep, and both against closed forms of its spring-damper contacts.

Tolerances. One lockstep step of the same formulas from the same state and the same contacts
agrees to rounding (~1e-15 in the state, ~1e-13 of the largest force, a few ulps times the
condition of the step); 1e-10 (as the PGS comparison, tests/python/test_crosscheck.py) leaves room
only for arithmetic-order differences. Forces are compared relative to the step's largest normal
force (at least 1 N), impulses to that times dt (``compare._SCALE``), so that a heavy box and a
light ball are held to the same relative rounding. One thing is not rounding: the soft rule is
discontinuous at a zero gap (rigid above, a spring at and below), and a contact that closed its gap
speculatively rests at a gap of rounding size, so the side it takes in the next biased sweep is
rounding's choice; the harness tries both sides for such a contact (``compare._closest_sides``,
with the band ``oracle.soft.gap_rounding``: 16 ulps of the lengths the gap is summed from) and
the core must match one of them to 1e-10.

The closed forms are derived in their tests; eps = 2.2e-16 is the unit roundoff. The worlds are
built with sleeping off whatever the default: the oracle does not sleep, and the closed forms of
resting follow a slow creep that sleeping would stop.
"""
import math

import numpy as np
import pytest

import signorini as sg
from signorini import compare, oracle
from signorini.oracle import soft

EPS = np.finfo(float).eps
G = 9.81
CONTACT_KEYS = ("body_a", "body_b", "point", "normal", "gap", "feature_a", "feature_b")


# --------------------------------------------------------------------------- scenes

def sphere_resting(**settings):
    """A 2 kg ball of radius 0.5 m resting on the ground."""
    w = sg.World(gravity=(0, 0, -G), sleeping=False, **settings)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Sphere(0.5), mass=2.0, position=(0, 0, 0.5))
    return w


def incline(**settings):
    """A box on a 30-degree slope, friction 0.3 < tan 30: it slides, its face on the slope."""
    t = np.radians(30.0)
    n = np.array([0.0, -np.sin(t), np.cos(t)])
    w = sg.World(gravity=(0, 0, -G), sleeping=False, **settings)
    w.add_static(sg.Plane(tuple(n), 0.0), friction=0.3)
    w.add_body(sg.Box((0.2, 0.15, 0.1)), density=500.0, position=tuple(0.1 * n),
               orientation=(np.cos(t / 2), np.sin(t / 2), 0, 0), friction=0.3)
    return w


def stack(**settings):
    """Three boxes dropped onto each other, each a little off the one below."""
    w = sg.World(gravity=(0, 0, -G), sleeping=False, **settings)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    for k in range(3):
        w.add_body(sg.Box((0.2, 0.2, 0.1)), density=500.0, position=(0.01 * k, 0, 0.1 + 0.201 * k))
    return w


def pyramid(**settings):
    """Six boxes in a pyramid of three rows, each on two below, the boxes of a row 2 mm apart
    (speculative contacts): every box in three to five pairs of four points, solved pair by pair."""
    w = sg.World(gravity=(0, 0, -G), sleeping=False, **settings)
    w.add_static(sg.Plane((0, 0, 1), 0.0), friction=0.6)
    for row in range(3):
        for j in range(3 - row):
            w.add_body(sg.Box((0.1, 0.1, 0.1)), density=500.0, friction=0.6,
                       position=(0.1 * row + 0.2 * j + 0.002 * j, 0.003 * row, 0.1 + 0.2 * row))
    return w


def spinning_pile(**settings):
    """Six balls spinning about the vertical dropped into a pile (ball-ball and ball-ground points,
    each its pair's only one: spin rows), and a capsule spinning upright on its end; the ground's
    spinning friction and the bodies' differ."""
    w = sg.World(gravity=(0, 0, -G), sleeping=False, **settings)
    w.add_static(sg.Plane((0, 0, 1), 0.0), spinning_friction=0.001)
    rng = np.random.default_rng(3)
    for k in range(6):
        w.add_body(sg.Sphere(0.1), mass=1.0,
                   position=(0.15 * (k % 3) - 0.15 + 0.02 * rng.normal(), 0.1 * (k // 3) + 0.02 * rng.normal(),
                             0.1 + 0.15 * k),
                   angular_velocity=(0, 0, 5.0 * (-1) ** k), spinning_friction=0.002)
    w.add_body(sg.Capsule(0.05, 0.1), density=800.0, position=(0.5, 0, 0.15), angular_velocity=(0, 0, 10.0),
               spinning_friction=0.001)
    return w


def bounce(**settings):
    """A ball of restitution 0.8 dropped from 0.5 m onto a ground of 0.8, frictionless."""
    w = sg.World(gravity=(0, 0, -G), sleeping=False, **settings)
    w.add_static(sg.Plane((0, 0, 1), 0.0), restitution=0.8, friction=0.0)
    w.add_body(sg.Sphere(0.1), mass=0.5, position=(0, 0, 0.6), restitution=0.8, friction=0.0)
    return w


def kinematic_paddle(**settings):
    """A kinematic paddle, moving and turning, pushes a box across the ground; a ball rests nearby."""
    w = sg.World(gravity=(0, 0, -G), sleeping=False, **settings)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Box((0.2, 0.2, 0.2)), density=500.0, position=(0.0, 0, 0.2), friction=0.3)
    w.add_body(sg.Box((0.05, 0.5, 0.3)), kinematic=True, position=(-0.3, 0, 0.31), velocity=(0.8, 0, 0),
               angular_velocity=(0, 0, 0.3))
    w.add_body(sg.Sphere(0.1), mass=1.0, position=(0.3, 0.6, 0.1))
    return w


def two_points(**settings):
    """Two-point pairs, whose normal rows the soft step solves as one block: a capsule landing flat,
    one landing tilted on one end and then falling flat and sliding, a box landing on an edge, and
    a box tilted onto another box's face (an edge on a face); frictions differ."""
    w = sg.World(gravity=(0, 0, -G), sleeping=False, **settings)
    w.add_static(sg.Plane((0, 0, 1), 0.0), friction=0.7)
    lying = (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0)  # the capsule's axis along x
    w.add_body(sg.Capsule(0.05, 0.15), density=800.0, position=(0, 0, 0.1), orientation=lying,
               velocity=(0, 0, -3.0), friction=0.5)
    tilt = 0.3  # about y, from lying
    w.add_body(sg.Capsule(0.05, 0.15), density=800.0, position=(0, 0.6, 0.3),
               orientation=(math.cos(math.pi / 4 + tilt / 2), 0.0, math.sin(math.pi / 4 + tilt / 2), 0.0),
               velocity=(0.4, 0, -1.0), friction=0.5)
    edge = (math.cos(0.3), math.sin(0.3), 0.0, 0.0)  # 0.6 rad about x: it lands on an edge
    w.add_body(sg.Box((0.1, 0.1, 0.1)), density=500.0, position=(1.0, 0, 0.25), orientation=edge, friction=0.4)
    w.add_body(sg.Box((0.25, 0.25, 0.1)), density=500.0, position=(1.0, 1.0, 0.1), friction=0.4)
    w.add_body(sg.Box((0.08, 0.08, 0.08)), density=900.0, position=(1.0, 1.0, 0.35), orientation=edge, friction=0.6)
    return w


def run_lockstep(world, dt, steps):
    """``compare.lockstep`` one step at a time, keeping what the core did in each (for the checks
    that a scene exercised what it is for). Returns (largest difference, the report of the step
    that had it, summed counters, history: a list of (Contacts, SolverStats, positions) per step)."""
    largest, worst, counts, history = -1.0, None, dict.fromkeys(
        ("stat_mismatches", "tied_steps", "retied_steps", "untried_steps"), 0), []
    for _ in range(steps):
        report = compare.lockstep(world, dt, 1)
        for key in counts:
            counts[key] += getattr(report, key)
        if report.largest > largest:
            largest, worst = report.largest, report
        history.append((world.contacts, world.solver_stats, world.positions.copy()))
    return largest, worst, counts, history


# --------------------------------------------------------------------------- settings and formulas

def test_the_soft_settings_reach_the_oracle_and_choose_its_substeps():
    w = sg.World(solver="soft", contact_hertz=45.0, damping_ratio=2.0, soft_iterations=2, relax_iterations=3)
    s = oracle.solver_settings(w.snapshot())
    assert (s["solver"], s["contact_hertz"], s["damping_ratio"], s["soft_iterations"], s["relax_iterations"]) == \
        ("soft", 45.0, 2.0, 2, 3)
    assert oracle.solver_settings({})["solver"] == "pgs"
    for bad in ({"solver": "tgs"}, {"contact_hertz": 0.0}, {"damping_ratio": -1.0}, {"soft_iterations": 0},
                {"relax_iterations": -1}, {"joint_hertz": 0.0}, {"joint_hertz": np.inf}, {"joint_damping_ratio": -1.0}):
        with pytest.raises(ValueError):
            oracle.solver_settings({"settings": bad})
    # automatic substeps: at most 1/240 s for the soft step, 1/960 s for the PGS
    from signorini.oracle.solver import substep_count
    soft_s, pgs_s = oracle.solver_settings(w.snapshot()), oracle.solver_settings({})
    assert [substep_count(soft_s, dt) for dt in (1 / 240, 1 / 60, 1 / 30)] == [1, 4, 8]
    assert [substep_count(pgs_s, dt) for dt in (1 / 240, 1 / 60)] == [4, 16]
    # with joints, the soft step's substeps are at most 0.25 / joint_hertz (1/960 s at 240 Hz), and
    # the core counts them the same (World.substep_count)
    assert [substep_count(soft_s, dt, joints=True) for dt in (1 / 1000, 1 / 240, 1 / 60)] == [1, 4, 16]
    assert [substep_count(dict(soft_s, joint_hertz=60.0), dt, joints=True) for dt in (1 / 240, 1 / 60)] == [1, 4]
    assert [substep_count(pgs_s, dt, joints=True) for dt in (1 / 240, 1 / 60)] == [4, 16]
    for hertz in (240.0, 60.0, 1000.0, 7.5):
        w.set_solver(joint_hertz=hertz)
        a, b = w.add_body(sg.Sphere(0.1), mass=1.0), w.add_body(sg.Sphere(0.1), mass=1.0, position=(0, 0, 1))
        assert w.substep_count(1 / 60) == 4  # no joint yet
        j = w.add_joint(sg.Spherical(a, b, anchor=(0, 0, 0.5)))
        s = oracle.solver_settings(w.snapshot())
        for dt in (1 / 1000, 1 / 240, 1 / 60, 1 / 30):
            assert w.substep_count(dt) == substep_count(s, dt, joints=True) == max(1, math.ceil(dt * max(240.0, 4 * hertz) - 1e-9))
        w.set_joint_broken(j, True)  # a broken joint makes no rows: the contacts' substeps again
        assert w.substep_count(1 / 60) == 4
        w.remove_body(b), w.remove_body(a)


def test_softness_is_cattos_spring_damper():
    h = 1 / 240
    # zeta = 0: a1 = h omega, a2 = (h omega)^2, bias_rate = 1 / h (the whole overlap each substep)
    omega = 2 * np.pi * 30.0
    bias_rate, mass_scale, impulse_scale = soft.softness(30.0, 0.0, h)
    assert bias_rate == pytest.approx(1 / h, rel=4 * EPS)
    assert mass_scale == pytest.approx((h * omega) ** 2 / (1 + (h * omega) ** 2), rel=4 * EPS)
    assert mass_scale + impulse_scale == pytest.approx(1.0, rel=4 * EPS)
    # zeta = 10: a1 = 20 + h omega, a2 = h omega a1
    a1 = 20 + h * omega
    a2 = h * omega * a1
    np.testing.assert_allclose(soft.softness(30.0, 10.0, h), [omega / a1, a2 / (1 + a2), 1 / (1 + a2)],
                               rtol=4 * EPS)
    # per contact: twice the hertz and half the damping against a static or a kinematic body, the
    # hertz capped at a quarter of the substep rate (60 Hz at h = 1/240 s)
    snap = kinematic_paddle(solver="soft", contact_hertz=30.0, damping_ratio=10.0).snapshot()
    contacts = {"body_a": [0, 1, 1], "body_b": [1, 2, 3]}  # ground-box, box-paddle, box-ball
    settings = oracle.solver_settings(snap)
    c = soft.contact_softness(snap, contacts, settings, h)
    assert c["hertz"].tolist() == [60.0, 60.0, 30.0] and c["zeta"].tolist() == [5.0, 5.0, 10.0]
    capped = soft.contact_softness(snap, contacts, {**settings, "contact_hertz": 500.0}, h)
    assert capped["hertz"].tolist() == [120.0, 120.0, 60.0]
    np.testing.assert_array_equal(capped["mass_scale"], soft.softness([120.0, 120.0, 60.0], [5.0, 5.0, 10.0], h)[1])


def test_the_gap_is_carried_with_the_bodies_as_a_rigid_point():
    # a box's corner touching the ground, then the box moved and turned: the corner's carried gap is
    # its new height, (p + R l)_z, for a corner l in the box's frame (the plane, body A, stays)
    box = {"shape": {"type": "box", "half_extents": np.array([0.2, 0.15, 0.1])}, "static": False}
    ground = {"shape": {"type": "plane", "normal": np.array([0, 0, 1.0]), "offset": 0.0}, "static": True}
    R0 = oracle.rodrigues(np.array([0.3, -0.5, 0.2]), 1.0)
    l = np.array([-0.2, 0.15, -0.1])
    p0 = np.array([0.4, -0.1, 0.0]) - R0 @ l + np.array([0, 0, 0.003])  # the corner 3 mm up
    corner0 = p0 + R0 @ l
    contacts = {"body_a": [0], "body_b": [1], "point": [corner0], "normal": [[0, 0, 1.0]], "gap": [corner0[2]]}
    start = {"bodies": [ground, box], "position": np.array([np.zeros(3), p0]), "rotation": np.array([np.eye(3), R0])}
    R = oracle.rodrigues(np.array([-0.1, 0.7, 0.4]), 1.0) @ R0  # a turn of about 0.8 rad and a move
    p = p0 + np.array([0.05, 0.02, -0.004])
    now = {"bodies": [ground, box], "position": np.array([np.zeros(3), p]), "rotation": np.array([np.eye(3), R])}
    s = soft.carried_gaps(contacts, start, now)
    # rounding: a few ulps of the lengths summed (|l|, |p|, |dp| < 1 m)
    assert s[0] == pytest.approx((p + R @ l)[2], abs=16 * EPS)
    assert abs(s[0] - (p + R @ l)[2]) <= soft.gap_rounding(contacts, start, now)[0]
    # not moved: the detected gap; the gap's sign is rounding's within gap_rounding
    assert soft.carried_gaps(contacts, start, start)[0] == pytest.approx(corner0[2], abs=16 * EPS)


def test_a_gap_zero_to_rounding_takes_the_side_it_is_given():
    # a 1 kg ball approaching the ground at 1 m/s, gap exactly 0: the biased sweep as a spring (the
    # sign of 0) stops part of the approach, as rigid (ties: True) all of it
    snap = sphere_resting(solver="soft").snapshot()
    snap["velocity"][1] = [0, 0, -1.0]
    h = 1 / 240
    contacts = {"body_a": np.array([0]), "body_b": np.array([1]), "point": np.array([[0, 0, 0.0]]),
                "normal": np.array([[0, 0, 1.0]]), "gap": np.array([0.0])}
    settings = oracle.solver_settings(snap)
    results = {}
    for ties in (None, {0: True}, {0: False}):
        q_dot = np.hstack([snap["angular_velocity"], snap["velocity"]])
        rows = oracle.prepare_rows(snap, contacts, q_dot, h)
        c = soft.contact_softness(snap, contacts, settings, h)
        x, tau, tied = [0.0, 0.0, 0.0], [0.0], set()
        soft.soft_sweep(soft.RowSweep(rows, h), rows, c, [0.0], x, tau, q_dot, h, True, 1.0, "pyramid",
                        [1e-16], ties, tied)
        assert tied == {0}
        results[None if ties is None else ties[0]] = q_dot[1, 5]
    assert results[None] == results[False] and results[True] == pytest.approx(0.0, abs=4 * EPS)
    # vn' = (1 - mass_scale) vn: the spring with no overlap still damps (mass_scale < 1)
    assert results[False] == pytest.approx(-(1 - c["mass_scale"][0]), rel=1e-14)


# --------------------------------------------------------------------------- lockstep

LOCKSTEP = {
    # name: (scene, dt, steps, settings)
    "sphere_resting": (sphere_resting, 1 / 240, 300, {}),
    "incline": (incline, 1 / 240, 300, {}),
    "incline_cone_substeps": (incline, 1 / 60, 120, {"friction_cone": "cone"}),
    "stack_substeps": (stack, 1 / 60, 200, {}),
    "pyramid_substeps": (pyramid, 1 / 60, 120, {}),
    "stack_more_sweeps_cold": (stack, 1 / 120, 200, {"soft_iterations": 2, "relax_iterations": 3,
                                                      "warm_start": False, "damping_ratio": 0.5}),
    "spinning_pile": (spinning_pile, 1 / 240, 300, {}),
    "bounce": (bounce, 1 / 240, 300, {}),
    "bounce_substeps": (bounce, 1 / 60, 100, {}),
    "kinematic_paddle": (kinematic_paddle, 1 / 240, 300, {}),
    "two_points": (two_points, 1 / 240, 240, {}),
    "two_points_substeps": (two_points, 1 / 60, 90, {}),
}


@pytest.mark.filterwarnings("ignore::signorini.SolverWarning")
@pytest.mark.parametrize("name", sorted(LOCKSTEP))
def test_soft_step_agrees_with_the_oracle_step_by_step_to_1e_10(name):
    scene, dt, steps, settings = LOCKSTEP[name]
    # every stage to its sweep limit (tolerance 0): restitution's stopping test would otherwise sit
    # on rounding
    world = scene(solver="soft", tolerance=0.0, **settings)
    largest, worst, counts, history = run_lockstep(world, dt, steps)
    assert largest < 1e-10, "\n".join(worst.lines())
    # (a step with more than compare.MAX_TIED such gaps is compared as the oracle's signs have it,
    # and held to the same 1e-10: a box set down flat has four corners at gap 0 at once)
    assert counts["stat_mismatches"] == 0, counts
    # the scene did what it is for, or the comparison would test less than it says
    contacts = [c for c, _, _ in history]
    assert any(len(c) > 0 for c in contacts)
    if "bounce" in name:
        first = next(k for k, (_, stats, _) in enumerate(history) if stats.restitution_iterations > 0)
        assert max(p[1][2] for _, _, p in history[first:]) > 0.3  # it went back up (to ~0.4 m)
    if name == "spinning_pile":
        assert any(np.any(c.spin_torque != 0.0) for c in contacts)
    if name.startswith("incline"):
        assert np.linalg.norm(history[-1][2][1] - history[0][2][1]) > 0.1  # slid
        assert any(np.any(c.friction != 0.0) for c in contacts)
    if name == "kinematic_paddle":
        assert any(np.any((c.body_a == 2) | (c.body_b == 2)) for c in contacts)
    if name.startswith("two_points"):
        # pairs of exactly two points, pushing (blocks), and such a pair with one point alone pushing
        def pairs(c):
            keys, counts = np.unique(np.stack([c.body_a, c.body_b], axis=1), axis=0, return_counts=True)
            return {tuple(k): n for k, n in zip(keys, counts)}
        blocks = [(c, pairs(c)) for c in contacts if len(c)]
        assert any(n == 2 for _, p in blocks for n in p.values())
        assert any(n == 2 and np.count_nonzero(c.alpha[(c.body_a == a) & (c.body_b == b)] > 0) == 1
                   for c, p in blocks for (a, b), n in p.items())


# --------------------------------------------------------------------------- closed forms

@pytest.mark.parametrize("hertz", [30.0, 1000.0])
@pytest.mark.parametrize("dt", [1 / 240, 1 / 60])
def test_a_resting_ball_sinks_by_g_over_omega_squared(hertz, dt):
    # with alpha = m g the sweep keeps its force where b / delta = -impulse_scale alpha, i.e.
    # s = -g / omega^2 (oracle/soft.py), with omega = 2 pi (2 min(hertz, 0.25 / h)) against the
    # ground. After the first step alpha = m g exactly (the relax sweep takes back all of the
    # substep's velocity), and the overlap obeys e' = lambda e, lambda = 1 - h mass_scale bias_rate.
    # It stops when a substep's move h v = (1 - lambda) e rounds away on z: |e| < ulp(z) / (2 (1 -
    # lambda)); the test allows ulp(z) / (1 - lambda) (~1e-11 relative), and runs until lambda^n
    # takes the first overlap (0 -> g / omega^2) below that.
    m, r = 2.0, 0.5
    world = sphere_resting(solver="soft", contact_hertz=hertz)
    n = oracle.solver.substep_count(oracle.solver_settings(world.snapshot()), dt)
    h = dt / n
    omega = 2 * np.pi * 2 * min(hertz, 0.25 / h)
    bias_rate, mass_scale, _ = soft.softness(omega / (2 * np.pi), 5.0, h)
    rate = h * mass_scale * bias_rate  # 1 - lambda per substep
    band = np.spacing(r) / rate
    s_star = G / omega ** 2
    steps = int(np.ceil(np.log(band / s_star) / np.log(1 - rate) / n)) + 20
    out = oracle.rollout(world.snapshot(), dt, steps)
    world.step(dt, steps)
    for z, alpha, impulse in ((out["position"][-1, 1, 2], out["infos"][-1]["alpha"], out["infos"][-1]["impulse"]),
                              (world.positions[1, 2], world.contacts.alpha, world.contacts.impulse)):
        assert abs((r - z) - s_star) <= band, (r - z, s_star, band)
        # the force and the step's impulse: m g and m g dt, to a few roundings of the velocity sums
        assert alpha.tolist() == pytest.approx([m * G], rel=16 * EPS)
        assert impulse.tolist() == pytest.approx([m * G * dt], rel=16 * EPS * n)


def test_a_ball_on_a_ball_sinks_by_the_effective_mass_deflections():
    # ground -> ball 1 (m1) -> ball 2 (m2), stacked vertically, at rest with alpha_1 = (m1 + m2) g and
    # alpha_2 = m2 g: each biased sweep keeps its force where mass_scale bias_rate s = -impulse_scale
    # delta alpha, s = -delta alpha / (h omega^2):
    #   ground: delta = h / m1, omega_s = 2 pi 60 Hz (twice 30):  s_1 = -(m1 + m2) g / (m1 omega_s^2)
    #   balls:  delta = h (1/m1 + 1/m2), omega = 2 pi 30 Hz:      s_2 = -(1 + m2 / m1) g / omega^2
    # Rounding stops the approach as for one ball (previous test), with 1 - lambda of the slowest
    # mode, measured here from the run itself (steps 200 to 400, far above the rounding floor).
    m1, m2, r1, r2, dt = 2.0, 0.5, 0.3, 0.2, 1 / 240
    w = sg.World(gravity=(0, 0, -G), solver="soft", sleeping=False)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Sphere(r1), mass=m1, position=(0, 0, r1))
    w.add_body(sg.Sphere(r2), mass=m2, position=(0, 0, 2 * r1 + r2))
    s1 = (m1 + m2) * G / (m1 * (2 * np.pi * 60) ** 2)
    s2 = (1 + m2 / m1) * G / (2 * np.pi * 30) ** 2
    out = oracle.rollout(w.snapshot(), dt, 900)
    z = out["position"][:, 1:, 2]
    e1, e2 = (r1 - z[:, 0]) - s1, (z[:, 0] + r1 + r2 - z[:, 1]) - s2
    rate = 1 - (abs(e1[400]) / abs(e1[200])) ** (1 / 200)
    assert abs(e1[400]) > 1e4 * np.spacing(1.0) and 0 < rate < 1  # far above rounding, and decaying
    band = 2 * np.spacing(1.0) / rate  # two positions' ulps (z < 1 m) over the slowest rate
    assert abs(e1[-1]) <= band and abs(e2[-1]) <= band, (e1[-1], e2[-1], band)
    assert out["infos"][-1]["alpha"].tolist() == pytest.approx([(m1 + m2) * G, m2 * G], rel=64 * EPS)


@pytest.mark.parametrize("dt", [1 / 240, 1 / 60])
def test_a_bounce_leaves_at_e_u_and_the_impulse_is_the_whole_steps(dt):
    # restitution ends the substep k in which the falling ball first pushes: n^T v >= -e u with u its
    # approach before that substep's biased sweep, u = v - (k + 1) g h after k + 1 kicks of free
    # flight (no force before: it had not pushed). The rebound e |u| is then above what the relax
    # sweep left, so v = -e u; in the substeps after it the contact is speculative and separating
    # (the warm start's push is taken back whole), so the step ends at
    #     v' = -e (v - (k + 1) g h) - (n - 1 - k) g h   for one k in 0..n-1,
    # and its momentum balance m (v' - v) = -m g dt + impulse holds with Contacts.impulse the
    # step's whole normal impulse, sum_k h alpha_k (restitution's included). Rounding: a few ulps
    # of |v| ~ 3 m/s (the warm start's push, ~(1 + e) |u|, applied and taken back), of m |v| N s.
    e, m = 0.8, 0.5
    n = 1 if dt == 1 / 240 else 4
    h = dt / n
    for run in ("oracle", "core"):
        world = bounce(solver="soft")
        snap = world.snapshot()
        seen = 0
        for _ in range(int(0.45 / dt)):
            if run == "oracle":
                v = snap["velocity"][1, 2]
                snap, info = oracle.step(snap, dt)
                v_new, impulse, sweeps = snap["velocity"][1, 2], info["impulse"], info["restitution_iterations"]
            else:
                v = world.velocities[1, 2]
                world.step(dt)
                v_new, impulse, sweeps = world.velocities[1, 2], world.contacts.impulse, world.solver_stats.restitution_iterations
            if sweeps == 0:
                continue
            seen += 1
            tol = 16 * EPS * abs(v)
            k = [k for k in range(n) if abs(v_new - (-e * (v - (k + 1) * G * h) - (n - 1 - k) * G * h)) <= tol]
            assert len(k) == 1 and v < -0.5, (v, v_new)
            if run == "oracle":
                assert info["bounced"].tolist() == [True]
                assert info["u"].tolist() == pytest.approx([v - (k[0] + 1) * G * h], abs=tol)
            assert m * (v_new - v) + m * G * dt == pytest.approx(impulse.sum(), abs=m * tol)
        assert seen == 1, run
