"""signorini's joints against MuJoCo and pybullet: the figures the acceptance tests check, as one table (no asserts).

    python3 benchmarks/compare_joints.py

The comparisons of tests/python/test_mjcf_joints.py and tests/python/test_urdf.py, repeated for
each signorini solver (``pgs``, the default, and ``soft`` with the settings the MJCF test gives it:
32 substeps, 4 soft and 4 relax iterations), each figure the largest over the model:

- MJCF (the test's files, tests/python/data/mjcf_joints: a pendulum, a double pendulum, a 7-link
  planar arm; no contacts), imported by ``signorini.mjcf.import_mjcf``, sleeping off: the joint
  angles after 1 s of a limp fall at dt 1/1000 against MuJoCo's (RK4, the reference), both wrapped
  into [-pi, pi) (rad; the test's bound 1e-2); and the joint-space mass matrix at the start, built
  from signorini's bodies and joints (``MJCFModel.mass_matrix``), against MuJoCo's ``mj_fullM``,
  relative to its largest entry (bound 1e-9).
- URDF kuka_iiwa of pybullet_data, ``sg.add_urdf`` with the base fixed: link masses (relative),
  inertias about the centre of mass in the link frame (relative to the link's largest entry),
  joint limits (lower, upper, effort, velocity; relative) against pybullet's getDynamicsInfo and
  getJointInfo (URDF_USE_INERTIA_FROM_FILE; bound 1e-9); and the joint angles after a 0.5 s limp
  fall (``dynamics=False``; pybullet: joint damping and link damping 0, motors off) with the base
  turned 90 degrees about x ("horizontal") or about (0.6, 0.8, 0) ("tilted"), dt 1/240 in both
  (bound 0.05 rad). The kuka tests use the PGS only; its soft row is this script's own.

"reference" is the largest |angle| the reference engine reached (the tests ask the models to move
far: > 1 rad for MJCF, > 0.4 rad for kuka). "above bound" names the solvers whose figure is above its
test's bound; each such figure is listed again under the table, on a line starting with "!".
"""
from __future__ import annotations

import importlib.metadata
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

import signorini as sg
from signorini.mjcf import import_mjcf


sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/_peers.py (not a package)
import _peers as peers  # noqa: E402

MJCF_DATA = Path(__file__).resolve().parents[1] / "tests" / "python" / "data" / "mjcf_joints"
MJCF_MODELS = ["pendulum", "double_pendulum", "arm7"]
MJCF_DT, MJCF_STEPS = 1e-3, 1000
URDF_DT, URDF_STEPS = 1.0 / 240.0, 120
POSES = {"horizontal": (1.0, 0.0, 0.0), "tilted": (0.6, 0.8, 0.0)}
# test_mjcf_joints.SOLVERS: the soft step's joints are springs (joint_hertz), the arm's light links need sweeps
SOLVERS = {
    "pgs": dict(solver="pgs"),
    "soft": dict(solver="soft", substeps=32, soft_iterations=4, relax_iterations=4),
}


def wrapped(angle):
    """Angles (rad) into [-pi, pi): signorini's hinge angle wraps, MuJoCo's does not."""
    return (np.asarray(angle) + math.pi) % (2 * math.pi) - math.pi


def mjcf_figures(mujoco, name, settings):
    """(max |q - q_mujoco| after 1 s (rad), mass matrix relative difference, max |q_mujoco|)."""
    path = MJCF_DATA / f"{name}.xml"
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    expected = np.zeros((m.nv, m.nv))
    if hasattr(d, "qM"):  # MuJoCo 3: from the sparse qM; MuJoCo 4 reads mjData itself
        mujoco.mj_fullM(m, expected, d.qM)
    else:
        mujoco.mj_fullM(m, d, expected)
    model = import_mjcf(path)
    model.world.set_solver(**settings)
    model.world.set_sleep(sleeping=False)
    relative = np.abs(model.mass_matrix() - expected).max() / np.abs(expected).max()
    m.opt.timestep = MJCF_DT
    d = mujoco.MjData(m)
    for _ in range(MJCF_STEPS):
        mujoco.mj_step(m, d)
        model.world.step(MJCF_DT)
    return np.abs(wrapped(model.qpos() - d.qpos)).max(), relative, np.abs(d.qpos).max()


def kuka_load_figures(p, client, kuka, settings):
    """Largest relative differences (masses, inertias, limits) and absolute ones (centre of mass, m)
    of the kuka loaded in signorini and in pybullet."""
    w = sg.World(sleeping=False, **settings)
    robot = sg.add_urdf(w, kuka, fixed_base=True)
    pb = p.loadURDF(kuka, flags=p.URDF_USE_INERTIA_FROM_FILE, useFixedBase=True, physicsClientId=client)
    masses, inertias, limits, coms = [], [], [], []
    for j in range(p.getNumJoints(pb, physicsClientId=client)):
        info = p.getJointInfo(pb, j, physicsClientId=client)
        ours, joint = robot.joints[info[1].decode()], w.joint(robot.joints[info[1].decode()].index)
        for mine, theirs in ((ours.lower, info[8]), (ours.upper, info[9]), (joint["lower"], info[8]),
                             (joint["upper"], info[9]), (ours.effort, info[10]), (ours.velocity, info[11])):
            limits.append(abs(mine - theirs) / abs(theirs))
        dyn = p.getDynamicsInfo(pb, j, physicsClientId=client)
        R = np.array(p.getMatrixFromQuaternion(dyn[4])).reshape(3, 3)
        inertia = R @ np.diag(dyn[2]) @ R.T
        body = robot.bodies[info[12].decode()]
        masses.append(abs(w.masses[body] - dyn[0]) / dyn[0])
        inertias.append(np.abs(w.inertias[body] - inertia).max() / np.abs(inertia).max())
        com = p.getLinkState(pb, j, computeForwardKinematics=True, physicsClientId=client)[0]
        coms.append(np.abs(w.positions[body] - np.array(com)).max())
    p.removeBody(pb, physicsClientId=client)
    return max(masses), max(inertias), max(limits), max(coms)


def pybullet_fall(p, client, kuka, orientation_xyzw, steps):
    """test_urdf.pybullet_fall without joint damping: the limp kuka's joint angles after ``steps``."""
    pb = p.loadURDF(kuka, flags=p.URDF_USE_INERTIA_FROM_FILE, useFixedBase=True, baseOrientation=orientation_xyzw,
                    physicsClientId=client)
    p.setGravity(0, 0, -9.81, physicsClientId=client)
    p.setTimeStep(URDF_DT, physicsClientId=client)
    n = p.getNumJoints(pb, physicsClientId=client)
    for j in range(-1, n):
        p.changeDynamics(pb, j, linearDamping=0, angularDamping=0, jointDamping=0, physicsClientId=client)
    p.setJointMotorControlArray(pb, list(range(n)), p.VELOCITY_CONTROL, forces=[0.0] * n, physicsClientId=client)
    for _ in range(steps):
        p.stepSimulation(physicsClientId=client)
    angles = np.array([p.getJointState(pb, j, physicsClientId=client)[0] for j in range(n)])
    p.removeBody(pb, physicsClientId=client)
    return angles


def kuka_fall(kuka, axis, settings, expected):
    """(max |q - q_pybullet| after 0.5 s (rad), the most contacts seen at a step) of the limp kuka."""
    s, c = math.sin(math.pi / 4), math.cos(math.pi / 4)
    w = sg.World(sleeping=False, **settings)
    robot = sg.add_urdf(w, kuka, fixed_base=True, orientation=(c, s * axis[0], s * axis[1], s * axis[2]),
                        dynamics=False)
    contacts = 0
    for _ in range(URDF_STEPS):
        w.step(URDF_DT)
        contacts = max(contacts, len(w.contacts))
    return np.abs(w.joint_positions[robot.joint_indices] - expected).max(), contacts


def main() -> list[dict]:
    """Runs the comparisons, prints the versions, the table and the figures above their bounds."""
    try:
        import mujoco
    except ImportError:
        mujoco = None
    mods = peers.load_pybullet()
    try:
        import pybullet_data
        import yourdfpy  # noqa: F401  (sg.add_urdf's parser)
    except ImportError:
        mods = None
    print(f"signorini {sg.__file__}")
    print(f"mujoco {mujoco.__version__}" if mujoco else "mujoco: not installed (pip install mujoco)")
    print(f"pybullet {importlib.metadata.version('pybullet')}" if mods else
          "pybullet: not installed, or pybullet_data or yourdfpy missing (pip install pybullet yourdfpy)")
    print("solvers: " + "; ".join(f"{k}: {', '.join(f'{a}={v}' for a, v in s.items())}" for k, s in SOLVERS.items()))
    rows = []

    def add(model, figure, bound, reference=None, **values):
        rows.append(dict(model=model, figure=figure, bound=bound, reference=reference, **values,
                         over=" ".join(k for k, v in values.items() if v is not None and v > bound) or None))

    if mujoco is not None:
        for name in MJCF_MODELS:
            t0 = time.perf_counter()
            figures = {k: mjcf_figures(mujoco, name, s) for k, s in SOLVERS.items()}
            add(name, "angle after 1 s (rad)", 1e-2, next(iter(figures.values()))[2],
                **{k: f[0] for k, f in figures.items()})
            add(name, "mass matrix at start (rel)", 1e-9, **{k: f[1] for k, f in figures.items()})
            print(f"  {name}: {time.perf_counter() - t0:.1f} s wall", file=sys.stderr, flush=True)
    if mods is not None:
        p = mods[0]
        kuka = os.path.join(pybullet_data.getDataPath(), "kuka_iiwa", "model.urdf")
        with peers.quiet_stdout():
            client = p.connect(p.DIRECT)
        try:
            t0 = time.perf_counter()
            loads = {k: kuka_load_figures(p, client, kuka, s) for k, s in SOLVERS.items()}
            for i, figure in enumerate(["link masses (rel)", "link inertias (rel)", "joint limits (rel)"]):
                add("kuka_iiwa", figure, 1e-9, **{k: f[i] for k, f in loads.items()})
            add("kuka_iiwa", "centre of mass at start (m)", 1e-9, **{k: f[3] for k, f in loads.items()})
            for pose, axis in POSES.items():
                s, c = math.sin(math.pi / 4), math.cos(math.pi / 4)
                expected = pybullet_fall(p, client, kuka, (s * axis[0], s * axis[1], s * axis[2], c), URDF_STEPS)
                falls = {k: kuka_fall(kuka, axis, st, expected) for k, st in SOLVERS.items()}
                add(f"kuka_iiwa {pose}", "angle after 0.5 s (rad)", 0.05, np.abs(expected).max(),
                    **{k: f[0] for k, f in falls.items()})
                if any(f[1] for f in falls.values()):
                    print(f"  kuka_iiwa {pose}: contacts during the fall {({k: f[1] for k, f in falls.items()})}")
            print(f"  kuka_iiwa: {time.perf_counter() - t0:.1f} s wall", file=sys.stderr, flush=True)
        finally:
            p.disconnect(client)
    columns = [("model", 20, "model", None), ("figure", 27, "figure", None), ("test bound", 10, "bound", ".0e")]
    columns += [(k, 9, k, ".2e") for k in SOLVERS]
    columns += [("reference", 9, "reference", ".3f"), ("above bound", 11, "over", None)]
    print()
    print(peers.table(rows, columns, left={"model", "figure", "over"}))
    print()
    over = [r for r in rows if r["over"]]
    if not over:
        print("every figure is within its test's bound")
    for r in over:
        print(f"! {r['model']}, {r['figure']}: {r['over']} above the test's bound {r['bound']:g} "
              f"({', '.join(f'{k} {r[k]:.2e}' for k in SOLVERS)})")
    sys.stdout.flush()
    return rows


if __name__ == "__main__":
    main()
