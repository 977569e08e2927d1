"""Contact recycling (docs/conventions.md, "Contact recycling"): a pair at rest keeps the manifold it
was found with, its points carried with the bodies and its rows' lever arms as found, while its
bodies have moved (relative to each other and about their centres) by at most ``recycle_distance``
(counting the coming step at the current velocities).

The bounds below come from that rule: a kept point is a material point of each body, so after a
motion of at most d (m) of every point, the kept point, its gap, its lever arms and its normal
differ from the narrow phase's by at most d (point, gap, arms) and d / rho (normal, rad)."""
import numpy as np
import pytest

import signorini as sg

DT = 1.0 / 60.0
TOL = 0.00001  # recycle_distance in these tests (m): the largest that keeps soft stacks still


def stack(n=4, solver="pgs", **kw):
    """n unit boxes stacked on a static slab (box pairs: they recycle), sleeping off so that the
    pile stays awake and its pairs are detected every step."""
    kw.setdefault("recycle_distance", TOL)
    w = sg.World(gravity=(0, 0, -9.81), solver=solver, sleeping=False, **kw)
    w.add_static(sg.Box((5.0, 5.0, 0.5)), position=(0, 0, -0.5))
    for k in range(n):
        w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(0.01 * k, 0, 0.5 + k))
    return w


def settled(w, steps=240):
    for _ in range(steps):
        w.step(DT)
    return w


def exact_twin(w):
    """A copy of w that finds every pair anew (recycle_distance 0), in the same state."""
    twin = stack(len(w.positions) - 1, solver=w.solver["solver"], recycle_distance=0.0)
    twin.restore_state(w.save_state())
    return twin


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_a_settled_stack_keeps_its_manifolds(solver):
    w = settled(stack(solver=solver))
    s = w.solver_stats
    assert s.pairs == 4 and s.recycled_pairs == s.pairs
    # and the stack still stands: every box within 1 mm of its column
    assert np.abs(w.positions[1:, 0] - 0.01 * np.arange(4)).max() < 1e-3


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_recycled_contacts_are_the_narrow_phase_s_within_the_drift_bound(solver):
    w = settled(stack(solver=solver))
    for _ in range(30):  # let the kept manifolds age
        w.step(DT)
    assert w.solver_stats.recycled_pairs == 4
    kept = w.detect_contacts(DT)
    exact = exact_twin(w).detect_contacts(DT)
    assert len(kept.gap) == len(exact.gap)
    assert np.array_equal(kept.body_a, exact.body_a) and np.array_equal(kept.body_b, exact.body_b)
    # the points pair up one to one, each within the bound (feature ids may differ: face on face,
    # a clip point is an edge crossing or a corner by a rounding-sized turn either way)
    rho = np.sqrt(3.0) * 0.5  # a unit box's bounding radius
    for pair in set(zip(kept.body_a, kept.body_b)):
        mine = np.flatnonzero((kept.body_a == pair[0]) & (kept.body_b == pair[1]))
        theirs = np.flatnonzero((exact.body_a == pair[0]) & (exact.body_b == pair[1]))
        assert len(mine) == len(theirs) == 4
        distance = np.linalg.norm(kept.point[mine][:, None] - exact.point[theirs][None], axis=2)
        match = theirs[distance.argmin(axis=1)]
        assert len(set(match)) == len(match) and distance.min(axis=1).max() <= TOL
        assert np.abs(kept.gap[mine] - exact.gap[match]).max() <= TOL
        turn = np.arccos(np.clip(np.sum(kept.normal[mine] * exact.normal[match], axis=1), -1, 1))
        assert turn.max() <= TOL / rho + 1e-7  # arccos near 1: 1e-7 rad of rounding
        # the rows' lever arms as found: within d of those of the points found now
        assert kept.kept[mine].all() and not exact.kept.any()
        for arm in ("arm_a", "arm_b"):
            assert np.linalg.norm(getattr(kept, arm)[mine] - getattr(exact, arm)[match], axis=1).max() <= TOL


def test_off_finds_every_pair_anew_and_matches_the_narrow_phase_exactly():
    w = settled(stack(recycle_distance=0.0))
    assert w.solver_stats.recycled_pairs == 0 and w.solver_stats.pairs == 4
    a, b = w.detect_contacts(DT), exact_twin(w).detect_contacts(DT)
    assert np.array_equal(a.gap, b.gap) and np.array_equal(a.point, b.point)


def test_a_struck_pair_is_found_anew():
    w = settled(stack())
    assert w.solver_stats.recycled_pairs == 4
    w.apply_impulse(4, (2.0, 0.0, 0.0))  # the top box, 2 m/s sideways: 33 mm in the coming step
    w.step(DT)
    assert w.solver_stats.recycled_pairs == 3  # the top pair only is collided again


def test_a_moved_body_is_found_anew():
    w = settled(stack())
    p = w.positions[4].copy()
    w.set_position(4, p + (0.002, 0.0, 0.0))  # 2 mm: more than recycle_distance
    w.step(DT)
    assert w.solver_stats.recycled_pairs == 3


def test_spheres_are_always_found_anew():
    w = sg.World(sleeping=False, recycle_distance=TOL)
    w.add_static(sg.Box((5.0, 5.0, 0.5)), position=(0, 0, -0.5))
    w.add_body(sg.Sphere(0.5), mass=1.0, position=(0, 0, 0.5))
    w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(2, 0, 0.5))
    settled(w, 120)
    assert w.solver_stats.pairs == 2 and w.solver_stats.recycled_pairs == 1  # the box's pair only


def test_continuing_from_a_saved_state_is_bit_identical_with_kept_manifolds():
    w = settled(stack(solver="soft"), 120)
    assert w.solver_stats.recycled_pairs > 0
    saved = w.save_state()
    for _ in range(60):
        w.step(DT)
    first = (w.positions.copy(), w.orientations.copy(), w.velocities.copy())
    w.restore_state(saved)
    for _ in range(60):
        w.step(DT)
    assert np.array_equal(first[0], w.positions) and np.array_equal(first[1], w.orientations)
    assert np.array_equal(first[2], w.velocities)


def test_a_step_undone_by_a_failed_step_does_not_advance_the_kept_manifolds():
    # detection without a step (detect_contacts) writes nothing the next step reads
    a, b = settled(stack(), 120), settled(stack(), 120)
    for _ in range(5):
        a.detect_contacts(DT)
    for w in (a, b):
        for _ in range(30):
            w.step(DT)
    assert np.array_equal(a.positions, b.positions)


def test_threads_give_the_same_bits_with_recycling():
    def pyramid(threads):
        w = sg.World(sleeping=False, solver="soft", threads=threads, recycle_distance=TOL)
        w.add_static(sg.Box((20.0, 20.0, 0.5)), position=(0, 0, -0.5))
        for row in range(14):  # 105 boxes, about 200 pairs: the detection splits over threads
            for k in range(14 - row):
                w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(k - 0.5 * (13 - row), 0, 0.5 + row))
        return settled(w, 90)
    one, two = pyramid(1), pyramid(2)
    assert one.solver_stats.recycled_pairs > 0
    assert one.solver_stats.recycled_pairs == two.solver_stats.recycled_pairs
    assert np.array_equal(one.positions, two.positions) and np.array_equal(one.velocities, two.velocities)


@pytest.mark.parametrize("bad", [-1e-3, float("nan"), float("inf")])
def test_bad_recycle_distance_names_the_setting_and_changes_nothing(bad):
    with pytest.raises(ValueError, match="recycle_distance"):
        sg.World(recycle_distance=bad)
    w = stack()
    before = w.solver
    with pytest.raises(ValueError, match="recycle_distance"):
        w.set_solver(recycle_distance=bad)
    assert w.solver == before


def test_a_pickled_world_keeps_its_manifolds():
    import pickle
    w = settled(stack(), 120)
    copy = pickle.loads(pickle.dumps(w))
    for x in (w, copy):
        for _ in range(30):
            x.step(DT)
    assert copy.solver_stats.recycled_pairs == w.solver_stats.recycled_pairs == 4
    assert np.array_equal(w.positions, copy.positions)


def test_removing_a_far_body_keeps_the_others_manifolds():
    a, b = settled(stack(), 120), settled(stack(), 120)
    far = b.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=(50.0, 0, 0.5))
    b.step(DT)
    a.step(DT)
    b.remove_body(far)
    for w in (a, b):
        w.step(DT, 30)
    assert a.solver_stats.recycled_pairs == b.solver_stats.recycled_pairs == 4
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.velocities, b.velocities)


def test_a_contact_s_lever_arms_are_its_point_from_each_centre_as_found():
    w = stack(recycle_distance=0.0)
    w.step(DT, 10)
    c, p = w.detect_contacts(DT), w.positions
    assert not c.kept.any()
    assert np.array_equal(c.arm_a, c.point - p[c.body_a]) and np.array_equal(c.arm_b, c.point - p[c.body_b])
    # and a recycled contact keeps those it was found with, step after step
    w = settled(stack(recycle_distance=0.05), 60)
    first = w.contacts
    arms = {(a, b, fa, fb): (x.copy(), y.copy()) for a, b, fa, fb, x, y in
            zip(first.body_a, first.body_b, first.feature_a, first.feature_b, first.arm_a, first.arm_b)}
    w.step(DT, 30)
    later = w.contacts
    assert later.kept.all()
    for a, b, fa, fb, x, y in zip(later.body_a, later.body_b, later.feature_a, later.feature_b, later.arm_a, later.arm_b):
        assert np.array_equal(arms[(a, b, fa, fb)][0], x) and np.array_equal(arms[(a, b, fa, fb)][1], y)


def test_the_default_follows_the_solver():
    assert sg.World().solver["recycle_distance"] == 0.0
    from signorini.world import RECYCLE_DEFAULTS
    assert sg.World(solver="soft").solver["recycle_distance"] == RECYCLE_DEFAULTS["soft"] == 0.05
    w = sg.World()
    w.set_solver(solver="soft")  # still the PGS's default: it follows the solver
    assert w.solver["recycle_distance"] == 0.05
    w.set_solver(recycle_distance=0.01)
    w.set_solver(solver="pgs")  # a value the user chose stays
    assert w.solver["recycle_distance"] == 0.01
    with pytest.raises(ValueError, match="solver must be"):
        sg.World(solver="stiff")


def column(n, **kw):
    """n unit cubes of 100 kg stacked on a static slab (Box3D's density and friction), soft step."""
    w = sg.World(gravity=(0, 0, -10.0), solver="soft", sleeping=False, **kw)
    w.add_static(sg.Box((20.0, 20.0, 1.0)), position=(0, 0, -1.0), friction=0.6)
    for k in range(n):
        w.add_body(sg.Box((0.5, 0.5, 0.5)), density=100.0, position=(0, 0, 0.5 + k), friction=0.6)
    return w


def tilts(w):
    """Each body's tilt from the vertical (rad): the angle between its z axis and the world's."""
    q = w.orientations[1:]  # (w, x, y, z)
    return np.arccos(np.clip(1.0 - 2.0 * (q[:, 1] ** 2 + q[:, 2] ** 2), -1.0, 1.0))


def test_a_soft_box_on_a_box_turns_by_its_springs_closed_form():
    # a torque T on the top box of two: each soft contact is a spring k = m_eff omega^2 at its point,
    # so an interface of four corners turns by T / K, K = 4 k (a / 2)^2. A corner r = (+-a/2, +-a/2,
    # -a/2) of a cube of mass m (I = m a^2 / 6) against another: 1 / m_eff = 2 / m + 2 |r x n|^2 / I;
    # against the static slab (twice the frequency): 1 / m_eff = 1 / m + |r x n|^2 / I.
    m, a, T = 100.0, 1.0, 200.0
    I, rn2 = m * a * a / 6.0, 0.5 * a * a
    omega = 2.0 * np.pi * 30.0
    K = 4.0 * (omega ** 2 / (2.0 / m + 2.0 * rn2 / I)) * (a / 2) ** 2
    K_ground = 4.0 * ((2.0 * omega) ** 2 / (1.0 / m + rn2 / I)) * (a / 2) ** 2
    w = column(2)
    w.set_external_wrench(2, torque=(T, 0.0, 0.0))
    w.step(1 / 60, 300)
    q = w.orientations[1:]
    angle = 2.0 * np.arcsin(q[:, 1])  # about x
    # the weight's own moment about the turned interface is m g (a / 2) angle (0.1% of T here)
    np.testing.assert_allclose(angle[0], T / K_ground, rtol=0.01)
    np.testing.assert_allclose(angle[1] - angle[0], T / K, rtol=0.01)


def test_kept_lever_arms_stand_a_soft_column_that_arms_found_anew_let_fall():
    # a column of 30 cubes on 30 Hz springs: found anew, the contact points move under the tilted
    # boxes and the weight above turns them further (statically unstable past about 20 cubes);
    # with the arms kept, the load passes straight down (docs/conventions.md, "Contact recycling")
    kept, anew = column(30), column(30, recycle_distance=0.0)
    for w in (kept, anew):
        w.step(1 / 60, 300)
    assert kept.solver_stats.recycled_pairs == kept.solver_stats.pairs == 30
    assert tilts(kept).max() < 5e-3 and np.abs(kept.positions[1:, :2]).max() < 0.05
    assert tilts(anew).max() > 0.05


def test_a_light_box_under_a_heavy_one_does_not_rock():
    # the ground's contacts are solved after those of the bodies they carry (docs/conventions.md,
    # "Solve order"): solved first, one sweep a substep left a 100 kg box under 1,400 kg tilting to
    # 2.5e-3 rad and wandering 1.4 cm in 10 s
    for recycle in (0.0, 0.05):
        w = sg.World(gravity=(0, 0, -10.0), solver="soft", sleeping=False, recycle_distance=recycle)
        w.add_static(sg.Box((20.0, 20.0, 1.0)), position=(0, 0, -1.0), friction=0.6)
        w.add_body(sg.Box((0.5, 0.5, 0.5)), density=100.0, position=(0, 0, 0.5), friction=0.6)
        w.add_body(sg.Box((0.5, 0.5, 0.5)), density=1400.0, position=(0, 0, 1.5), friction=0.6)
        w.step(1 / 60, 600)
        assert tilts(w).max() < 1e-4 and np.abs(w.positions[1:, :2]).max() < 1e-3, recycle


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_a_sliding_box_s_kept_points_stay_on_both_surfaces(solver):
    # a 0.2 m box sliding at 2 cm/s on a static slab keeps its manifold for tens of steps (0.1 of its
    # inner radius is 1 cm, a third of a millimetre a step). Its corners are points of the box and
    # their gaps to the slab's face are exact however far it slides, while the face's material
    # witnesses slide away with it: the reported point is half the gap from the corner along the
    # normal, so it lies within |gap| / 2 of each body (the contract of a found contact), where the
    # midpoint of the two witnesses left both surfaces by half the slide
    from signorini import fuzz
    w = sg.World(solver=solver, recycle_distance=0.05, sleeping=False)
    slab = w.add_static(sg.Box((1.0, 1.0, 0.1)), position=(0, 0, -0.1))
    box = w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=1.0, position=(0, 0, 0.1), velocity=(0.02, 0, 0))
    w.set_material(box, friction=0.0)
    shapes = {slab: {"type": "box", "half_extents": [1.0, 1.0, 0.1]}, box: {"type": "box", "half_extents": [0.1] * 3}}
    kept_seen, worst = 0, 0.0
    for _ in range(60):
        w.step(1 / 60)
        c = w.detect_contacts(1 / 60)
        kept_seen += int(c.kept.sum())
        for i in (slab, box):
            d = fuzz.point_distance(shapes[i], w.positions[i], w.rotations[i], c.point)
            worst = max(worst, float((d - np.abs(c.gap) / 2).max()))
    assert kept_seen > 100  # most steps recycle the box's four corners
    assert worst <= 1e-12
