"""Seeded random convex pairs: the core's manifold against independent references.

For every pair the deepest contact's gap must equal the reference separation within 1e-6 m when
the shapes overlap shallowly: the oracle's separating axes for boxes (``box_box_separation``), a
brute-force search over support functions for hulls (``support_separation``), neither of which
shares code with the core. Never a NaN, never a zero normal, exactly touching shapes included.

How a pair with a chosen depth is made: a random overlapping placement, then B moved along the
reference's separating direction n by (target - sep). Moving B along the direction of minimal
translation changes the separation by exactly that amount (the ball of radius |sep| about the
origin lies inside the Minkowski difference), so the new separation is the target without
another reference call.
"""
import zlib

import numpy as np
import pytest

import signorini as sg
from signorini.oracle import manifold as om
from signorini.oracle import support as osup
from signorini.oracle.rigid import quat_to_matrix

TOL = 1e-6          # m: the figure for shallow overlaps
N_BOX_PAIRS = 9000
N_HULL_PAIRS = 1000
CURVED_TOL = 5e-3   # m: cylinders against non-spheres are approximate: the distance comes from a
                    # pattern search over support directions, and points clipped on a face within
                    # 5.7 degrees of the normal measure their gap along that face's normal


def random_quaternion(rng):
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def check_contacts(c, who):
    assert len(c) >= 1, f"{who}: no contact"
    assert np.all(np.isfinite(c.point)) and np.all(np.isfinite(c.normal)) and np.all(np.isfinite(c.gap)), who
    assert np.allclose(np.linalg.norm(c.normal, axis=1), 1.0, atol=1e-12), f"{who}: normal not unit"
    assert len(c) <= 4, f"{who}: {len(c)} points"


def box_reference(p_a, R_a, h_a, p_b, R_b, h_b):
    """(sep, n): separating-axis separation of two boxes and its axis (A -> B), oracle."""
    s = om.box_box_separation(p_a, R_a, h_a, p_b, R_b, h_b)
    sep, n = s["sep_A"], None
    best = max(s["sep_A"], s["sep_B"], s["sep_E"])
    return best, s


def test_box_pairs_match_the_oracle_separating_axes():
    rng = np.random.default_rng(20261121)
    worst, done = 0.0, 0
    while done < N_BOX_PAIRS:
        h_a, h_b = rng.uniform(0.1, 1.0, 3), rng.uniform(0.1, 1.0, 3)
        q_a, q_b = random_quaternion(rng), random_quaternion(rng)
        R_a, R_b = quat_to_matrix(q_a), quat_to_matrix(q_b)
        p_a = rng.uniform(-1, 1, 3)
        p_b = p_a + rng.uniform(-0.5, 0.5) * (h_a.min() + h_b.min()) * random_quaternion(rng)[:3]
        # the support-function search gives the direction of least translation; then B is moved
        sep, n = osup.support_separation(osup.support_box(h_a, p_a, R_a), osup.support_box(h_b, p_b, R_b),
                                         n_directions=512, max_seeds=4) if done % 50 == 0 else (None, None)
        ref, s = box_reference(p_a, R_a, h_a, p_b, R_b, h_b)
        if ref >= 0.0:
            continue
        if sep is not None:
            # the two independent references agree with each other first
            assert abs(sep - ref) < 1e-9, (sep, ref)
        target = -rng.uniform(0.0, 0.02) if done % 10 else 0.0  # every tenth exactly touching
        axis = _axis_of(s, p_a, R_a, p_b, R_b)
        p_b = p_b + (target - ref) * axis
        ref2, _ = box_reference(p_a, R_a, h_a, p_b, R_b, h_b)
        assert abs(ref2 - target) < 1e-12
        c = sg.collide(sg.Box(h_a), (p_a, q_a), sg.Box(h_b), (p_b, q_b), margin=1e-9)
        check_contacts(c, f"box pair {done}")
        err = abs(c.gap.min() - ref2)
        worst = max(worst, err)
        assert err < TOL, f"box pair {done}: core {c.gap.min()} reference {ref2}"
        done += 1
    print(f"{done} box pairs: largest |gap - reference| = {worst:.2e} m")


def _axis_of(s, p_a, R_a, p_b, R_b):
    """The unit axis (A -> B) of the separating-axis maximum in the oracle's result."""
    if s["sep_E"] > max(s["sep_A"], s["sep_B"]):
        i, j = s["axes"]
        L = np.cross(R_a[:, i], R_b[:, j])
        L /= np.linalg.norm(L)
        return L if L @ (p_b - p_a) >= 0 else -L
    if s["sep_B"] > s["sep_A"]:
        f = s["face_b"]
        return (1.0 if f % 2 else -1.0) * -R_b[:, f // 2]
    f = s["face_a"]
    return (1.0 if f % 2 else -1.0) * R_a[:, f // 2]


def random_hull_points(rng):
    k = rng.integers(6, 20)
    return rng.normal(size=(k, 3)) * rng.uniform(0.1, 0.6, 3)


def test_hull_pairs_match_a_brute_force_support_search():
    rng = np.random.default_rng(417)
    worst, done = 0.0, 0
    while done < N_HULL_PAIRS:
        a, b = sg.ConvexHull(random_hull_points(rng)), sg.ConvexHull(random_hull_points(rng))
        q_a, q_b = random_quaternion(rng), random_quaternion(rng)
        R_a, R_b = quat_to_matrix(q_a), quat_to_matrix(q_b)
        p_a = np.zeros(3)
        p_b = rng.uniform(-0.2, 0.2, 3)
        sep, n = osup.support_separation(osup.support_hull(np.asarray(a.vertices), p_a, R_a),
                                         osup.support_hull(np.asarray(b.vertices), p_b, R_b), n_directions=1024)
        if sep >= 0.0:
            continue
        target = -rng.uniform(0.0, 0.02) if done % 10 else 0.0
        p_b = p_b + (target - sep) * n
        c = sg.collide(a, (p_a, q_a), b, (p_b, q_b), margin=1e-9)
        check_contacts(c, f"hull pair {done}")
        err = abs(c.gap.min() - target)
        worst = max(worst, err)
        assert err < TOL, f"hull pair {done}: core {c.gap.min()} reference {target}"
        done += 1
    print(f"{done} hull pairs: largest |gap - reference| = {worst:.2e} m")


SHAPES = {
    "sphere": lambda rng: sg.Sphere(rng.uniform(0.1, 0.5)),
    "box": lambda rng: sg.Box(rng.uniform(0.1, 0.5, 3)),
    "capsule": lambda rng: sg.Capsule(rng.uniform(0.05, 0.3), rng.uniform(0.0, 0.5)),
    "cylinder": lambda rng: sg.Cylinder(rng.uniform(0.1, 0.4), rng.uniform(0.05, 0.4)),
    "hull": lambda rng: sg.ConvexHull(random_hull_points(rng)),
}


@pytest.mark.parametrize("kind_a", sorted(SHAPES))
@pytest.mark.parametrize("kind_b", sorted(SHAPES))
def test_every_convex_pair_touching_or_shallow_has_finite_unit_normals(kind_a, kind_b):
    rng = np.random.default_rng(zlib.crc32(f"{kind_a}-{kind_b}".encode()))  # the same seed every run
    worst = 0.0
    for k in range(20):
        a, b = SHAPES[kind_a](rng), SHAPES[kind_b](rng)
        q_a, q_b = random_quaternion(rng), random_quaternion(rng)
        p_a, p_b = np.zeros(3), rng.uniform(-0.1, 0.1, 3)
        da, db = sg.shape_dict(a), sg.shape_dict(b)
        sep, n = osup.support_separation(osup.support_of(da, p_a, quat_to_matrix(q_a)),
                                         osup.support_of(db, p_b, quat_to_matrix(q_b)), n_directions=1024)
        target = 0.0 if k % 2 else -0.001
        # closed forms (spheres, capsules, polytopes) to 1e-6; cylinders against anything but a
        # sphere go through a search over support directions and rim-sampled caps (CURVED_TOL)
        exact = "cylinder" not in (kind_a, kind_b) or "sphere" in (kind_a, kind_b)
        p_b = p_b + (target - sep) * n
        c = sg.collide(a, (p_a, q_a), b, (p_b, q_b), margin=1e-6 if exact else CURVED_TOL)
        check_contacts(c, f"{kind_a}-{kind_b} {k}")
        worst = max(worst, abs(c.gap.min() - target))
    print(f"{kind_a}-{kind_b}: largest |gap - reference| = {worst:.2e} m")
    assert worst < (TOL if exact else CURVED_TOL), f"{kind_a}-{kind_b}: largest gap error {worst:.2e} m"
