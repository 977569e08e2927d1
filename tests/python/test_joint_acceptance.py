"""Acceptance figures of issue 23 ("Joints and robots"; docs/conventions.md, "Joints"): a hanging
chain of 20 links on distance rods settles to its catenary, and a hinge at its limit holds a 10 kg
load with under 1 degree of overshoot, in both solvers.

The chain's reference is the exact equilibrium of the discrete chain (point masses on massless
rods), not the continuous catenary: every rod carries the same horizontal tension H, and the
vertical tension drops by each link's weight m g from one rod to the next, so rod k of the 21
slopes at tan(phi_k) = (10 - k) m g / H, H found from the span sum_k l cos(phi_k) = S. The
continuous catenary of the same length L = 21 l through the same anchors, a cosh(x / a) with
2 a sinh(S / (2 a)) = L, spreads the mass along the chain instead of lumping it at the joints; for
this chain its sag is 0.24 % deeper (0.6568 m against 0.6553 m), so it would do as a reference at
the issue's 1 %, but the discrete one is what the simulated chain must reach exactly.
"""
import math

import numpy as np
import pytest
from scipy.optimize import brentq

import signorini as sg

G = 9.81
DT = 1.0 / 240.0

# the chain: N spheres of mass M on N + 1 rods of length L_ROD, anchors SPAN apart at z = 0
N, L_ROD, SPAN, M, RADIUS = 20, 0.1, 1.5, 0.1, 0.02


def discrete_catenary():
    """(sag of the middle rod m, H / (m g) m) of the chain's exact equilibrium (module doc)."""
    def span(a):
        return sum(L_ROD / math.hypot(1.0, (N / 2 - k) / a) for k in range(N + 1)) - SPAN
    a = brentq(span, 1e-6, 1e6, xtol=1e-15)
    sag = sum(L_ROD * (N / 2 - k) / a / math.hypot(1.0, (N / 2 - k) / a) for k in range(N // 2))
    return sag, a


def continuous_catenary():
    """Sag (m) of the uniform catenary of length (N + 1) L_ROD through the anchors."""
    length = (N + 1) * L_ROD
    a = brentq(lambda a: 2 * a * math.sinh(SPAN / (2 * a)) - length, 0.05, 100.0, xtol=1e-15)
    return a * (math.cosh(SPAN / (2 * a)) - 1.0)


def hanging_chain(solver, seconds=8.0, gamma=2.0, **settings):
    """The chain released as a V with a flat bottom rod (every rod at its length), settled for
    ``seconds`` under a viscous force -gamma m v on each link applied by the test (the World has
    no linear damping; it changes nothing at rest). Returns the world, the link bodies and the
    chain's points (anchor, links, anchor) (N + 2, 3)."""
    w = sg.World(solver=solver, sleeping=False, **settings)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))  # the anchors' body
    c = (SPAN - L_ROD) / (N * L_ROD)
    s = math.sqrt(1 - c * c)
    down, flat, up = np.array([c, 0, -s]), np.array([1.0, 0, 0]), np.array([c, 0, s])
    points = [np.array([-SPAN / 2, 0.0, 0.0])]
    for k in range(N + 1):
        points.append(points[-1] + L_ROD * (down if k < N // 2 else flat if k == N // 2 else up))
    assert np.allclose(points[-1], (SPAN / 2, 0, 0), atol=1e-12)
    links = [w.add_body(sg.Sphere(RADIUS), mass=M, position=p) for p in points[1:-1]]
    ends = [ground] + links + [ground]
    for k in range(N + 1):
        w.add_joint(sg.Distance(ends[k], ends[k + 1], points[k], points[k + 1]))
    for _ in range(round(seconds / DT)):
        for b, v in zip(links, w.velocities[links]):
            w.apply_force(b, -gamma * M * v)
        w.step(DT)
    anchors = np.array([[-SPAN / 2, 0, 0], [SPAN / 2, 0, 0]])
    return w, links, np.vstack([anchors[:1], w.positions[links], anchors[1:]])


def middle_sag(points):
    return -0.5 * (points[N // 2, 2] + points[N // 2 + 1, 2])


def test_the_two_catenaries_differ_by_a_quarter_percent():
    sag, _ = discrete_catenary()
    assert sag == pytest.approx(0.65526, abs=1e-5)
    assert continuous_catenary() / sag - 1 == pytest.approx(0.0024, abs=1e-4)


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_hanging_chain_settles_to_its_catenary_within_1_percent_of_the_sag(solver):
    # measured: the PGS 4.5e-5 off the discrete sag (rods at their length to 4e-9 m), the soft
    # step (240 Hz joint springs) 0.13 % deep; with Box2D v3's 60 Hz, 2.1 % (below)
    w, links, points = hanging_chain(solver)
    assert np.abs(w.velocities[links]).max() < 1e-2  # settled
    sag, _ = discrete_catenary()
    assert middle_sag(points) == pytest.approx(sag, rel=1e-2)


@pytest.mark.parametrize("joint_hertz", [240.0, 60.0])
def test_soft_chain_rods_stretch_as_springs_of_joint_hertz(joint_hertz):
    # why the soft chain sags deeper: at rest each rod is a spring of stiffness m_eff omega^2
    # (m_eff = m / 2 between two links, m for the rods to the anchors), so rod k stretches by its
    # tension T_k = m g sqrt(a^2 + (10 - k)^2) over that: 0.04 to 0.09 mm at 240 Hz (the default:
    # substeps of 1/960 s), 0.7 to 1.4 mm at 60 Hz (Box2D v3's, substeps of 1/240 s), and the sag
    # comes out 2.1 % deep at 60 Hz. T_k is the rigid chain's; the stretched chain's tensions differ
    # by about its change of shape (2 % at 60 Hz)
    w, links, points = hanging_chain("soft", joint_hertz=joint_hertz)
    assert w.substep_count(DT) == round(4 * joint_hertz * DT)  # substeps of 0.25 / joint_hertz
    if joint_hertz == 60.0:
        sag, _ = discrete_catenary()
        assert middle_sag(points) / sag - 1 == pytest.approx(0.021, abs=0.002)
    _, a = discrete_catenary()
    omega = 2 * math.pi * joint_hertz
    stretch = np.linalg.norm(np.diff(points, axis=0), axis=1) - L_ROD
    expected = [M * G * math.hypot(a, N / 2 - k) / ((M if k in (0, N) else M / 2) * omega ** 2) for k in range(N + 1)]
    np.testing.assert_allclose(stretch, expected, rtol=0.03)


# --------------------------------------------------------------------------- hinge limits

def swing_into_limit(solver, load_body, seconds=3.0):
    """A hinge about y at the origin with limits (-0.3, 0.5) rad holding the body ``load_body(w)``
    makes (returns (B, extra bodies)), released horizontal: gravity swings it into the upper limit.
    Returns (the largest angle reached, the angle at the end) rad."""
    w = sg.World(solver=solver, sleeping=False)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    b = load_body(w)
    j = w.add_joint(sg.Revolute(ground, b, anchor=(0, 0, 0), axis=(0, 1, 0), limits=(-0.3, 0.5)))
    highest = -math.inf
    for _ in range(round(seconds / DT)):
        w.step(DT)
        highest = max(highest, w.joint_positions[j])
    return highest, w.joint_positions[j]


def arm_with_welded_load(w):
    # a 1 kg arm of 1 m (a thin box) carrying a 10 kg cube of 0.2 m welded at its end
    arm = w.add_body(sg.Box((0.5, 0.02, 0.02)), mass=1.0, position=(0.5, 0.0, 0.0))
    load = w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=10.0, position=(1.1, 0.0, 0.0))
    w.add_joint(sg.Fixed(arm, load))
    return arm


def compact_load(w):
    # the 10 kg cube of 0.2 m alone, its centre 1 m from the hinge (m L^2 / I = 150)
    return w.add_body(sg.Box((0.1, 0.1, 0.1)), mass=10.0, position=(1.0, 0.0, 0.0))


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_hinge_limit_holds_a_10_kg_load_with_under_1_degree_of_overshoot(solver):
    # measured: the PGS passes the limit by 5e-5 degrees and rests on it; the soft step (its limit
    # and equality rows springs of 240 Hz, substeps of 1/960 s) by 0.68 degrees; with 60 Hz joints
    # (Box2D v3's; substeps of 1/240 s) by 2.9: the weld to the load gives
    highest, end = swing_into_limit(solver, arm_with_welded_load)
    assert highest < 0.5 + math.radians(1.0)
    assert end == pytest.approx(0.5, abs=math.radians(1.0))


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_hinge_limit_holds_a_compact_10_kg_load(solver):
    # m L^2 / I = 150: solved row by row, the limit saw only the cube's spin about its own centre and
    # the PGS's unconverged forces exploded at the impact (kinetic energy 0.0195 J -> 11.2 J). Solved
    # with the point and tilt rows as one group (docs, "Joints"), measured: the PGS passes the limit by
    # 4e-8 degrees, the soft step not at all (0.05 degrees with 60 Hz joints) and rests on it
    highest, end = swing_into_limit(solver, compact_load)
    assert highest < 0.5 + math.radians(1.0)
    assert end == pytest.approx(0.5, abs=math.radians(1.0))
