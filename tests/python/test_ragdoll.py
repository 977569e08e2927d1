"""Issue 23's ragdoll acceptance: a ragdoll (11 capsules; ball joints with cone and twist limits at
the neck, shoulders and hips, hinges with limits at the waist, elbows and knees: benchmarks/bench_joints.py's
``add_ragdoll``) dropped onto a pile of boxes (4 x 4 and 3 x 3). Over the run the total energy
E = KE + sum m g z of the dynamic bodies (boxes included) never rises above its start, and at rest
no joint's two anchor points are more than 1 mm apart.

Tolerances from the physics:
- energy: a rigid contact with restitution 0 and joint rows that do no work can only take energy
  out, and semi-implicit Euler loses m g^2 h^2 / 2 per step in free fall, so E_k <= E_0 holds up to
  the rounding of E itself: its sum of terms m g |z| (and 1/2 m v^2) is rounded to a few ulps of
  their total, 1e-12 of it is a wide margin for that and far below any real gain (a 1 g body
  rising 1 um already gains 1e-8 J);
- rest: every body's centre of mass slower than 1 cm/s over the last of the 4 s (at every step of
  it, not at one instant: the soft step's ragdoll keeps rocking, between 0.4 and 4 cm/s, and passed
  the one-instant check at 4 s by the phase of its rocking);
- joints: 1 mm at the anchors, the issue's figure.
"""
import math
import warnings

import numpy as np
import pytest
from helpers import load_benchmark

import signorini as sg

bench = load_benchmark("bench_joints")

G = 10.0
DT = 1.0 / 60.0
SECONDS = 4.0
REST_SPEED = 0.01    # m/s
SEPARATION = 1e-3    # m
ROUNDING = 1e-12     # of the energy's scale (module doc)


def ragdoll_on_boxes(solver: str):
    """A world with a pile of 25 boxes (4 x 4 then 3 x 3, 0.5 m, seeded jitter) on a static
    ground and a ragdoll lying face down 0.3 m above the pile, everything at rest, sleeping off.
    The ragdoll (1.74 m) is longer than the pile's top (1.54 m): its head and feet land on the
    layer below. (Over an edge a limb on a frictionless ball joint swings as a pendulum for ever.)"""
    w = sg.World(gravity=(0.0, 0.0, -G), solver=solver, sleeping=False)
    w.add_static(sg.Box((10.0, 10.0, 1.0)), position=(0.0, 0.0, -1.0), friction=0.6)
    rng = np.random.default_rng(23)
    h = 0.25
    for layer, across in enumerate((4, 3)):
        for i in range(across):
            for j in range(across):
                x = (i - 0.5 * (across - 1)) * 2.05 * h + rng.uniform(-0.01, 0.01)
                y = (j - 0.5 * (across - 1)) * 2.05 * h + rng.uniform(-0.01, 0.01)
                w.add_body(sg.Box((h, h, h)), density=500.0, position=(x, y, h + 0.005 + layer * (2 * h + 0.005)),
                           friction=0.6, restitution=0.0)
    top = 4 * h + 0.01
    R, t = bench.ragdoll_layer_pose(0, per_layer=1, lift=top + 0.3)
    doll = bench.add_ragdoll(w, R, t)
    return w, doll


def run(solver: str) -> dict:
    w, doll = ragdoll_on_boxes(solver)
    bodies, anchors = bench.joint_anchors(w)
    dynamic = ~np.asarray(w.is_static)
    masses = np.asarray(w.masses)[dynamic]

    def energy() -> float:
        return float(w.kinetic_energy() + w.potential_energy())

    e0 = energy()
    scale = float(np.sum(masses * G * np.abs(np.asarray(w.positions)[dynamic, 2])))
    energies, speeds = [], []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sg.SolverWarning)
        for _ in range(round(SECONDS / DT)):
            w.step(DT)
            energies.append(energy())
            speeds.append(float(np.linalg.norm(np.asarray(w.velocities)[dynamic], axis=1).max()))
    separation = bench.separations(w.positions, w.rotations, bodies, anchors)
    # each ball joint's swing (the angle between its axes in the two bodies) and twist, at the end
    from signorini.oracle.joints import twist_angle
    swings, twists = [], []
    for j in doll.joints:
        joint = w.joint(j)
        if joint["kind"] != "Spherical":
            swings.append(math.nan)
            twists.append(math.nan)
            continue
        RA, RB = w.rotations[joint["body_a"]], w.rotations[joint["body_b"]]
        a_A, a_B = RA @ joint["axis_a"], RB @ joint["axis_b"]
        swings.append(math.atan2(np.linalg.norm(np.cross(a_A, a_B)), a_A @ a_B))
        twists.append(twist_angle(joint, RA, RB)[0])
    # the fastest body's speed at any step of the last second
    speed = max(speeds[-round(1.0 / DT):])
    return {"e0": e0, "scale": scale, "energies": np.array(energies), "speed": speed,
            "doll_mass": float(np.asarray(w.masses)[doll.bodies].sum()), "separation": float(separation.max()),
            "joint_positions": w.joint_positions[doll.joints], "swings": swings, "twists": twists,
            "doll_z": float(np.asarray(w.positions)[doll.bodies, 2].min())}


SOLVERS = ["pgs", "soft"]


@pytest.fixture(scope="module")
def runs():
    return {solver: run(solver) for solver in SOLVERS}


@pytest.mark.parametrize("solver", SOLVERS)
def test_energy_never_rises_above_its_start(runs, solver):
    r = runs[solver]
    rise = float(r["energies"].max() - r["e0"])
    assert rise <= ROUNDING * r["scale"], (solver, r["e0"], r["energies"].max())
    # it did fall: the landing took out at least half the ragdoll's m g h over its 0.3 m drop (a check of the scene)
    assert r["energies"][-1] < r["e0"] - 0.5 * r["doll_mass"] * G * 0.3


@pytest.mark.parametrize("solver", [
    "pgs",
    pytest.param("soft", marks=pytest.mark.xfail(
        strict=True, reason="the soft step's ragdoll keeps rocking on the pile (0.4 to 4 cm/s from 2 s to 10 s, "
                            "its centre of mass swaying by about a centimetre): not yet at rest")),
])
def test_the_ragdoll_comes_to_rest(runs, solver):
    r = runs[solver]
    assert r["speed"] < REST_SPEED, (solver, r["speed"])


@pytest.mark.parametrize("solver", ["pgs", "soft"])
def test_joints_hold_within_a_millimetre_at_rest(runs, solver):
    r = runs[solver]
    assert r["doll_z"] > 0.0  # on the pile or the ground, not through it
    assert r["separation"] < SEPARATION, (solver, r["separation"])
    # the hinges rest inside their limits, the ball joints inside their cones and twist ranges (limit
    # rows are speculative and may close them, no more)
    for (name, _, _, kind, _, _, limits), q, swing, twist in zip(bench.RAGDOLL_JOINTS, r["joint_positions"],
                                                                r["swings"], r["twists"]):
        if kind == "hinge":
            assert limits[0] - 0.02 <= q <= limits[1] + 0.02, (solver, name, q)
        else:
            cone, (lo, hi) = limits
            assert swing <= cone + 0.02 and lo - 0.02 <= twist <= hi + 0.02, (solver, name, swing, twist)
