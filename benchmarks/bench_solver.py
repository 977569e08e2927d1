"""Solver benchmark of issue 7: signorini and pybullet side by side on three scenes (no asserts).

    python benchmarks/bench_solver.py [--quick] [--tiny] [--scenes pyramid,rain,hull_pile]
                                      [--repeats 3] [--chunks 20] [--no-pybullet]

Scenes (built by ``signorini.scenes``; the pybullet twin is read back from the built signorini
world, so each scene is written once):
- ``pyramid``: 210 unit boxes of 1 kg, base row 20, 1 mm apart in a row, on the ground (10 s);
- ``rain``: 1,000 spheres and 200 boxes rained into a walled bin (5 s);
- ``hull_pile``: 200 convex hulls of seeded 16-point clouds dropped into a walled bin (5 s).

Both engines run in this process with dt 1/240 and 10 solver sweeps: signorini with
``set_solver(max_iterations=10, substeps=1)`` (one solve per step, as pybullet's
``numSubSteps=0``; its other settings at their defaults), pybullet (optional:
``pip install pybullet``; it is not a dependency of signorini) in DIRECT mode with
``setPhysicsEngineParameter(numSolverIterations=10, fixedTimeStep=1/240, numSubSteps=0)``.
pybullet's bodies are classic rigid bodies (``useMaximalCoordinates=True``) with sleeping
disabled, as signorini has no sleeping; masses and inertias are signorini's (a hull is handed
to pybullet in its principal axes with ``localInertiaDiagonal``). Friction 0.5 on every contact
in both engines: signorini combines sqrt(mu_A mu_B) and Bullet mu_A mu_B, so pybullet's bodies
get lateralFriction sqrt(0.5) each; restitution 0 everywhere; a scene's spinning friction s
becomes pybullet's spinningFriction s / (2 sqrt(mu)) (the three scenes have none).

Timing: each run is cut into ``--chunks`` chunks; every step is timed alone (the certificate and
state reads in between are not timed) and a chunk's ms per step is its steps' total over its
length. The two engines' chunks alternate, so a load spike on this shared machine hits both.
The printed ms/step is the median over all chunks of all ``--repeats`` runs, with the 25th-75th
percentile range; the ratio is signorini's median over pybullet's. Never a lone absolute time.

Quality, from the first repeat: the largest displacement of any dynamic body from its start (m;
the pyramid should keep every box within 1 cm), the largest penetration at the end (signorini:
``solver_stats.max_overlap`` of the last step; pybullet: minus the most negative
``contactDistance`` of ``getContactPoints()``), the kinetic energy at the end (J), and for
signorini the Signorini certificate maxima over every step of the run (``solver_stats``: natural
residual, penetration velocity, complementarity, cone and dissipation violations, sweeps) and
the share of steps that converged.

``--quick`` runs 0.5 s of each scene in 4 chunks once (a smoke test); ``--tiny`` builds small
versions of the scenes (a 5-box-base pyramid, 40 spheres and 10 boxes, 20 hulls).
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import signorini as sg
from signorini import scenes
from signorini.oracle import matrix_to_quat, quat_to_matrix

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/ is not a package
import _peers as peers  # noqa: E402  (pybullet's quiet connect and loader)

DT = 1.0 / 240.0
SWEEPS = 10
FRICTION = 0.5

# name -> (builder, keyword arguments of the full scene, of the tiny one)
SCENES = {
    "pyramid": (scenes.pyramid, {}, {"base": 5}),
    "rain": (scenes.rain, {}, {"spheres": 40, "boxes": 10}),
    "hull_pile": (scenes.hull_pile, {}, {"hulls": 20}),
}

# the certificate fields reported as maxima over the run
CERTIFICATE = ("residual", "max_penetration_velocity", "max_complementarity", "max_cone_violation",
               "max_dissipation_violation")


def load_pybullet():
    """The pybullet module and its BulletClient class, or (None, None) if it is not installed."""
    return peers.load_pybullet() or (None, None)


class SignoriniRun:
    """A signorini scene being stepped: per-step times and per-step certificate maxima.

    - world: the scene's world, set to SWEEPS sweeps per solver stage;
    - start (N, 3): initial positions; dynamic (N,) bool: which bodies move;
    - cert: maxima over the steps taken so far of the CERTIFICATE fields and of the sweeps;
    - converged_steps, steps: counts of steps that converged and of all steps.
    """

    engine = "signorini"

    def __init__(self, world):
        self.world = world
        world.set_solver(max_iterations=SWEEPS, substeps=1)
        self.start = world.positions.copy()
        self.dynamic = ~np.asarray(world.is_static)
        self.cert = dict.fromkeys(CERTIFICATE + ("iterations",), 0.0)
        self.converged_steps = 0
        self.steps = 0

    def run_chunk(self, steps: int) -> float:
        """Steps ``steps`` times; returns the summed wall time of the steps alone (s)."""
        total = 0.0
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sg.SolverWarning)
            for _ in range(steps):
                t0 = time.perf_counter()
                self.world.step(DT)
                total += time.perf_counter() - t0
                # the certificate of this step, read outside the timed window
                s = self.world.solver_stats
                for key in self.cert:
                    self.cert[key] = max(self.cert[key], float(getattr(s, key)))
                self.converged_steps += bool(s.converged)
                self.steps += 1
        return total

    def quality(self) -> dict:
        """The end-of-run figures: displacement (m), penetration (m), kinetic energy (J), and the
        certificate maxima with the converged share (%)."""
        d = np.linalg.norm(self.world.positions - self.start, axis=1)[self.dynamic]
        q = {"displacement": float(d.max()), "penetration": float(self.world.solver_stats.max_overlap),
             "kinetic_energy": float(self.world.kinetic_energy())}
        q.update(self.cert)
        q["converged_pct"] = 100.0 * self.converged_steps / max(self.steps, 1)
        return q

    def close(self) -> None:
        pass


class PybulletRun:
    """The same scene mirrored into a fresh pybullet DIRECT client, body for body.

    Reads the signorini world back (shapes, poses, velocities, masses, inertias, frictions) so the
    geometry comes from the one builder in ``signorini.scenes``. Planes, boxes, spheres and convex
    hulls are mirrored; any other shape raises ValueError.
    """

    engine = "pybullet"

    def __init__(self, world, pybullet, client_class):
        self.p = pybullet
        with peers.quiet_stdout():
            self.pb = client_class(connection_mode=pybullet.DIRECT)
        pb = self.pb
        pb.setGravity(*np.asarray(world.gravity, dtype=float))
        pb.setPhysicsEngineParameter(numSolverIterations=SWEEPS, fixedTimeStep=DT, numSubSteps=0)
        self.ids, self.dynamic_ids, start = [], [], []
        # per dynamic body: mass (kg), principal inertia (3,) and the principal frame E (3, 3)
        # in body axes, so that omega_principal = (R_pb)^T omega_world with R_pb = R E
        self.inertia = []
        positions, orientations = world.positions, world.orientations
        velocities, angular = world.velocities, world.angular_velocities
        for i in range(world.num_bodies):
            shape, static = world.shape(i), bool(world.is_static[i])
            R = quat_to_matrix(orientations[i])
            E = np.eye(3)
            position = np.asarray(positions[i], dtype=float)
            if isinstance(shape, sg.Plane):
                n = np.asarray(shape.normal, dtype=float)
                n = n / np.linalg.norm(n)
                col = pb.createCollisionShape(pybullet.GEOM_PLANE, planeNormal=n.tolist())
                position, R = n * shape.offset, np.eye(3)
            elif isinstance(shape, sg.Box):
                col = pb.createCollisionShape(pybullet.GEOM_BOX, halfExtents=list(shape.half_extents))
            elif isinstance(shape, sg.Sphere):
                col = pb.createCollisionShape(pybullet.GEOM_SPHERE, radius=float(shape.radius))
            elif isinstance(shape, sg.ConvexHull):
                # vertices about the centre of mass in body axes; hand them over in principal axes
                if not static:
                    _, E = np.linalg.eigh(world.inertias[i])
                    if np.linalg.det(E) < 0:
                        E[:, 2] = -E[:, 2]
                vertices = np.asarray(shape.vertices, dtype=float) @ E
                col = pb.createCollisionShape(pybullet.GEOM_MESH, vertices=vertices.tolist())
            else:
                raise ValueError(f"body {i}: no pybullet twin for a {type(shape).__name__}")
            R_pb = R @ E
            w, x, y, z = matrix_to_quat(R_pb)
            mass = 0.0 if static else float(world.masses[i])
            body = pb.createMultiBody(baseMass=mass, baseCollisionShapeIndex=col,
                                      basePosition=position.tolist(), baseOrientation=[x, y, z, w],
                                      useMaximalCoordinates=True)
            # Bullet multiplies the two frictions of a contact; signorini takes sqrt(mu_A mu_B)
            f = math.sqrt(float(world.frictions[i]))
            dynamics = {"lateralFriction": f,
                        "restitution": float(world.restitutions[i]),
                        "activationState": pybullet.ACTIVATION_STATE_DISABLE_SLEEPING}
            # spinning (torsional) friction, m: Bullet combines s_A f_B + s_B f_A, signorini takes
            # max(s_A, s_B); s / (2 f) each makes them agree for two bodies of the same material.
            # (Bullet applies it at every point of a manifold, signorini at a pair's only point.)
            if world.spinning_frictions[i] > 0.0 and f > 0.0:
                dynamics["spinningFriction"] = float(world.spinning_frictions[i]) / (2.0 * f)
            if not static:
                principal = np.diag(E.T @ world.inertias[i] @ E).copy()
                # pybullet zeroes the mass when given an inertia alone, and recomputes the inertia
                # from the shape when given a mass alone: pass both
                dynamics["mass"] = mass
                dynamics["localInertiaDiagonal"] = principal.tolist()
                self.dynamic_ids.append(body)
                self.inertia.append((mass, principal))
                start.append(position)
                pb.resetBaseVelocity(body, linearVelocity=list(velocities[i]),
                                     angularVelocity=list(angular[i]))
            pb.changeDynamics(body, -1, **dynamics)
            self.ids.append(body)
        self.start = np.array(start).reshape(-1, 3)

    def run_chunk(self, steps: int) -> float:
        """Steps ``steps`` times; returns the summed wall time of the steps alone (s)."""
        total = 0.0
        step = self.pb.stepSimulation
        for _ in range(steps):
            t0 = time.perf_counter()
            step()
            total += time.perf_counter() - t0
        return total

    def quality(self) -> dict:
        """Displacement (m), penetration (m) and kinetic energy (J) at the end."""
        pb = self.pb
        displacement, energy = 0.0, 0.0
        for body, start, (mass, principal) in zip(self.dynamic_ids, self.start, self.inertia):
            position, orientation = pb.getBasePositionAndOrientation(body)
            v, omega = pb.getBaseVelocity(body)
            displacement = max(displacement, float(np.linalg.norm(np.asarray(position) - start)))
            x, y, z, w = orientation
            omega_principal = quat_to_matrix((w, x, y, z)).T @ np.asarray(omega)
            energy += 0.5 * mass * float(np.dot(v, v)) + 0.5 * float(principal @ omega_principal**2)
        distances = [c[8] for c in pb.getContactPoints()]
        penetration = max(0.0, -min(distances)) if distances else 0.0
        return {"displacement": displacement, "penetration": penetration, "kinetic_energy": energy}

    def close(self) -> None:
        self.pb.disconnect()


def chunk_lengths(steps: int, chunks: int) -> list[int]:
    """``steps`` cut into ``chunks`` nearly equal positive parts (fewer if steps < chunks)."""
    chunks = max(1, min(chunks, steps))
    return [steps // chunks + (1 if k < steps % chunks else 0) for k in range(chunks)]


def bench_scene(name: str, tiny: bool, seconds: float | None, repeats: int, chunks: int, pybullet_mods):
    """Runs one scene in both engines, chunks interleaved; returns a row dict per engine.

    Row fields: scene, engine, bodies (dynamic), steps, ms (median ms/step over all chunks of
    all repeats), q1, q3 (quartiles of the same), ratio (signorini / pybullet, on the signorini
    row), and the quality figures of the first repeat (``SignoriniRun.quality``).
    """
    builder, full, small = SCENES[name]
    times: dict[str, list[float]] = {}
    quality: dict[str, dict] = {}
    info = {}
    for repeat in range(repeats):
        scene = builder(**(small if tiny else full))
        steps = scene.steps if seconds is None else max(1, round(seconds / DT))
        runs = [SignoriniRun(scene.world)]
        if pybullet_mods[0] is not None:
            # mirror before stepping: the twin starts from the same initial state
            runs.append(PybulletRun(scene.world, *pybullet_mods))
        info = {"bodies": int(np.count_nonzero(runs[0].dynamic)), "steps": steps}
        try:
            for length in chunk_lengths(steps, chunks):
                for run in runs:
                    times.setdefault(run.engine, []).append(1e3 * run.run_chunk(length) / length)
            if repeat == 0:
                for run in runs:
                    quality[run.engine] = run.quality()
        finally:
            for run in runs:
                run.close()
    rows = []
    for engine, ms in times.items():
        q1, median, q3 = np.percentile(ms, [25, 50, 75])
        rows.append({"scene": name, "engine": engine, **info, "ms": float(median), "q1": float(q1),
                     "q3": float(q3), "ratio": None, **quality[engine]})
    if len(rows) == 2:
        rows[0]["ratio"] = rows[0]["ms"] / rows[1]["ms"]
    return rows


COLUMNS = [  # header, width, row key, format
    ("scene", 9, "scene", "s"), ("engine", 9, "engine", "s"), ("bodies", 6, "bodies", "d"),
    ("steps", 5, "steps", "d"), ("ms/step", 8, "ms", ".3f"), ("q1-q3", 13, None, None),
    ("ratio", 5, "ratio", ".2f"), ("max disp m", 10, "displacement", ".3e"),
    ("pen end m", 9, "penetration", ".2e"), ("KE end J", 9, "kinetic_energy", ".2e"),
    ("residual", 8, "residual", ".2e"), ("pen vel", 8, "max_penetration_velocity", ".2e"),
    ("compl", 8, "max_complementarity", ".2e"), ("cone", 8, "max_cone_violation", ".2e"),
    ("dissip", 8, "max_dissipation_violation", ".2e"), ("sweeps", 6, "iterations", ".0f"),
    ("conv %", 6, "converged_pct", ".1f"),
]


def format_table(rows) -> str:
    """One aligned table, a line per scene and engine; '-' where a figure does not apply."""
    lines = ["  ".join(f"{h:>{w}s}" if k not in ("scene", "engine") else f"{h:<{w}s}" for h, w, k, _ in COLUMNS)]
    for row in rows:
        cells = []
        for header, width, key, fmt in COLUMNS:
            if key is None:
                text = f"{row['q1']:.3f}-{row['q3']:.3f}"
            elif row.get(key) is None:
                text = "-"
            else:
                text = format(row[key], fmt)
            cells.append(f"{text:<{width}s}" if key in ("scene", "engine") else f"{text:>{width}s}")
        lines.append("  ".join(cells))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> list[dict]:
    """Parses the options, runs the scenes, prints progress and the table; returns the rows."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="0.5 s per scene, 4 chunks, 1 repeat")
    parser.add_argument("--tiny", action="store_true", help="small versions of the scenes")
    parser.add_argument("--scenes", default=",".join(SCENES), help="comma-separated, from: " + ", ".join(SCENES))
    parser.add_argument("--repeats", type=int, default=None, help="fresh runs per scene (default 3, quick 1)")
    parser.add_argument("--chunks", type=int, default=None, help="timed chunks per run (default 20, quick 4)")
    parser.add_argument("--no-pybullet", action="store_true", help="run signorini only")
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.scenes.split(",") if n.strip()]
    unknown = [n for n in names if n not in SCENES]
    if unknown:
        parser.error(f"unknown scene(s) {unknown}; known: {', '.join(SCENES)}")
    repeats = args.repeats if args.repeats is not None else (1 if args.quick else 3)
    chunks = args.chunks if args.chunks is not None else (4 if args.quick else 20)
    if repeats < 1 or chunks < 1:
        parser.error("--repeats and --chunks must be at least 1")
    seconds = 0.5 if args.quick else None

    pybullet_mods = (None, None) if args.no_pybullet else load_pybullet()
    if args.no_pybullet:
        print("pybullet: skipped (--no-pybullet)")
    elif pybullet_mods[0] is None:
        print("pybullet: not installed, signorini only (pip install pybullet)")
    print(f"dt 1/{round(1 / DT)}, {SWEEPS} sweeps, friction {FRICTION:g}, restitution 0; "
          f"{repeats} repeat(s) x {chunks} chunk(s); ms/step = median over chunks")
    rows = []
    for name in names:
        t0 = time.perf_counter()
        scene_rows = bench_scene(name, args.tiny, seconds, repeats, chunks, pybullet_mods)
        rows += scene_rows
        print(f"  {name}: done in {time.perf_counter() - t0:.0f} s wall", flush=True)

    print()
    print(format_table(rows))
    print()
    for row in rows:
        if row["scene"] == "pyramid":
            verdict = "stands" if row["displacement"] < 0.01 else "falls"
            print(f"pyramid, {row['engine']}: {verdict} (largest box displacement "
                  f"{row['displacement'] * 1000:.2f} mm; 1 cm allowed)")
    if pybullet_mods[0] is None and not args.no_pybullet:
        print("pybullet is missing: pip install pybullet for the side-by-side figures")
    sys.stdout.flush()
    return rows


if __name__ == "__main__":
    main()
