"""Peer engines for the benchmarks: a signorini world mirrored body for body into pybullet or rapier3d.

Neither peer is a dependency of signorini; ``load_pybullet()`` and ``load_rapier()`` return None
when one is not installed. A twin reads the built signorini World back (shapes, poses,
velocities, masses, frictions, enabled flags), so a scene is written once, in signorini.

Shapes mirrored: Plane, Box, Sphere, Capsule (on the body z axis in all three engines) and
ConvexHull; any other shape raises ValueError. A body that is disabled in the signorini world is
not in the peer's simulation until ``drop()`` brings it in (pybullet: created then; rapier3d:
created disabled and enabled then).

Friction: signorini combines sqrt(mu_A mu_B), Bullet mu_A mu_B (each pybullet body gets sqrt(mu)),
Rapier the average (each collider gets mu); the three agree when every body has the same friction,
as in every benchmark scene. Restitution is the body's in all three.
"""
from __future__ import annotations

import contextlib
import math
import os
import sys
import time

import numpy as np

import signorini as sg
from signorini.oracle import matrix_to_quat, quat_to_matrix


@contextlib.contextmanager
def quiet_stdout():
    """Silences file descriptor 1 (pybullet's C code prints "argv[0]=" on connect straight to it)."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def load_pybullet():
    """(pybullet, BulletClient class), or None if pybullet is not installed."""
    try:
        import pybullet
        from pybullet_utils import bullet_client
    except ImportError:
        return None
    return pybullet, bullet_client.BulletClient


def timed_steps(step, steps: int) -> float:
    """Calls step() ``steps`` times; returns the summed wall time of the calls alone (s)."""
    total = 0.0
    for _ in range(steps):
        t0 = time.perf_counter()
        step()
        total += time.perf_counter() - t0
    return total


def load_rapier():
    """The rapier3d module, or None if it is not installed."""
    try:
        import rapier3d
    except ImportError:
        return None
    return rapier3d


def table(rows, columns, left) -> str:
    r"""One aligned table of rows (dicts), columns (header, width, key, format) and the keys
    written flush left: '-' where a figure does not apply (None), "range" the row's q1-q3, a
    format of None the value as it is. Cells are two spaces apart and hold no two spaces, so
    ``re.split(r"\s{2,}")`` reads a line back."""
    lines = ["  ".join(f"{h:<{w}s}" if k in left else f"{h:>{w}s}" for h, w, k, _ in columns)]
    for row in rows:
        cells = []
        for _, width, key, fmt in columns:
            if key == "range":
                text = "-" if row.get("q1") is None else f"{row['q1']:.3f}-{row['q3']:.3f}"
            elif row.get(key) is None:
                text = "-"
            elif fmt is None:
                text = str(row[key])
            else:
                text = format(row[key], fmt)
            cells.append(f"{text:<{width}s}" if key in left else f"{text:>{width}s}")
        lines.append("  ".join(cells))
    return "\n".join(lines)


def chunk_lengths(steps: int, chunks: int) -> list[int]:
    """``steps`` cut into ``chunks`` nearly equal positive parts (fewer if steps < chunks)."""
    chunks = max(1, min(chunks, steps))
    return [steps // chunks + (1 if k < steps % chunks else 0) for k in range(chunks)]


def _principal(world, i):
    """Body i's principal frame E (3, 3) in body axes (det +1) and principal moments (3,)."""
    moments, E = np.linalg.eigh(np.asarray(world.inertias[i], dtype=float))
    if np.linalg.det(E) < 0:
        E[:, 2] = -E[:, 2]
    return E, moments


class PybulletTwin:
    """The world in a fresh pybullet DIRECT client: ``iterations`` solver iterations, one solve per
    step (``numSubSteps=0``), step ``dt``; classic rigid bodies (``useMaximalCoordinates``).
    ``sleeping`` False disables Bullet's deactivation on every body.

    - start (N_dyn, 3): the dynamic bodies' positions when ``mark_start()`` was last called;
    - dynamic: signorini indices of the dynamic bodies, in the order of ``start``.
    """

    def __init__(self, world, dt: float, iterations: int = 10, sleeping: bool = False, mods=None):
        self.p, client_class = mods if mods is not None else load_pybullet()
        with quiet_stdout():
            self.pb = client_class(connection_mode=self.p.DIRECT)
        self.pb.setGravity(*np.asarray(world.gravity, dtype=float))
        self.pb.setPhysicsEngineParameter(numSolverIterations=iterations, fixedTimeStep=dt, numSubSteps=0)
        self.world, self.sleeping = world, sleeping
        self.ids: dict[int, int] = {}  # signorini index -> pybullet body id
        self.inertia: dict[int, tuple] = {}  # index -> (mass, principal moments (3,), frame E (3, 3))
        static = np.asarray(world.is_static)
        enabled = np.asarray(world.enabled)
        self.dynamic = [i for i in range(world.num_bodies) if not static[i]]
        for i in range(world.num_bodies):
            if enabled[i]:
                self._create(i)
        self.mark_start()

    def _create(self, i: int) -> None:
        """Creates body i at its current signorini pose and velocity."""
        p, pb, world = self.p, self.pb, self.world
        shape, static = world.shape(i), bool(world.is_static[i])
        R = quat_to_matrix(world.orientations[i])
        position = np.asarray(world.positions[i], dtype=float)
        E, moments = (np.eye(3), None) if static else _principal(world, i)
        if isinstance(shape, sg.Plane):
            n = np.asarray(shape.normal, dtype=float)
            n = n / np.linalg.norm(n)
            col = pb.createCollisionShape(p.GEOM_PLANE, planeNormal=n.tolist())
            position, R, E = n * shape.offset, np.eye(3), np.eye(3)
        elif isinstance(shape, sg.ConvexHull):
            col = pb.createCollisionShape(p.GEOM_MESH, vertices=(np.asarray(shape.vertices, dtype=float) @ E).tolist())
        else:
            # boxes, spheres and capsules are symmetric about their body axes: no principal turn
            E = np.eye(3)
            if isinstance(shape, sg.Box):
                col = pb.createCollisionShape(p.GEOM_BOX, halfExtents=list(shape.half_extents))
            elif isinstance(shape, sg.Sphere):
                col = pb.createCollisionShape(p.GEOM_SPHERE, radius=float(shape.radius))
            elif isinstance(shape, sg.Capsule):
                col = pb.createCollisionShape(p.GEOM_CAPSULE, radius=float(shape.radius),
                                              height=2.0 * float(shape.half_length))
            else:
                raise ValueError(f"body {i}: no pybullet twin for a {type(shape).__name__}")
            if not static:
                moments = np.diag(np.asarray(world.inertias[i], dtype=float)).copy()
        w, x, y, z = matrix_to_quat(R @ E)
        mass = 0.0 if static else float(world.masses[i])
        body = pb.createMultiBody(baseMass=mass, baseCollisionShapeIndex=col, basePosition=position.tolist(),
                                  baseOrientation=[x, y, z, w], useMaximalCoordinates=True)
        dynamics = {"lateralFriction": math.sqrt(float(world.frictions[i])),
                    "restitution": float(world.restitutions[i])}
        if not self.sleeping:
            dynamics["activationState"] = p.ACTIVATION_STATE_DISABLE_SLEEPING
        if not static:
            # pybullet zeroes the mass given an inertia alone and recomputes the inertia given a
            # mass alone: pass both
            dynamics["mass"] = mass
            dynamics["localInertiaDiagonal"] = moments.tolist()
            self.inertia[i] = (mass, moments, E)
            pb.resetBaseVelocity(body, linearVelocity=list(world.velocities[i]),
                                 angularVelocity=list(world.angular_velocities[i]))
        pb.changeDynamics(body, -1, **dynamics)
        self.ids[i] = body

    def drop(self, indices) -> None:
        """Puts bodies ``indices`` at their current signorini pose and velocity (creating them the
        first time): a scene's release of new bodies or re-release of old ones."""
        world = self.world
        for i in indices:
            if i not in self.ids:
                self._create(i)
                continue
            mass, moments, E = self.inertia[i]
            w, x, y, z = matrix_to_quat(quat_to_matrix(world.orientations[i]) @ E)
            self.pb.resetBasePositionAndOrientation(self.ids[i], list(world.positions[i]), [x, y, z, w])
            self.pb.resetBaseVelocity(self.ids[i], linearVelocity=list(world.velocities[i]),
                                      angularVelocity=list(world.angular_velocities[i]))

    def run_chunk(self, steps: int) -> float:
        """Steps ``steps`` times; returns the summed wall time of the steps alone (s)."""
        return timed_steps(self.pb.stepSimulation, steps)

    def state(self):
        """Positions (N_dyn, 3) of the dynamic bodies (NaN where not created) and their kinetic energy (J)."""
        positions = np.full((len(self.dynamic), 3), np.nan)
        energy = 0.0
        for k, i in enumerate(self.dynamic):
            if i not in self.ids:
                continue
            body = self.ids[i]
            position, orientation = self.pb.getBasePositionAndOrientation(body)
            v, omega = self.pb.getBaseVelocity(body)
            positions[k] = position
            mass, moments, _ = self.inertia[i]
            x, y, z, w = orientation
            omega_principal = quat_to_matrix((w, x, y, z)).T @ np.asarray(omega)
            energy += 0.5 * mass * float(np.dot(v, v)) + 0.5 * float(moments @ omega_principal**2)
        return positions, energy

    def mark_start(self) -> None:
        self.start = self.state()[0]

    def penetration(self) -> float:
        """The deepest penetration of any contact now (m): minus the most negative contact distance."""
        distances = [c[8] for c in self.pb.getContactPoints()]
        return max(0.0, -min(distances)) if distances else 0.0

    def close(self) -> None:
        self.pb.disconnect()


class RapierTwin:
    """The world in a rapier3d PhysicsWorld with Rapier's default integration parameters except
    ``dt``, on ``threads`` worker threads; ``sleeping`` False makes every body unable to sleep.
    Masses are signorini's (a collider's inertia follows from its shape and that mass)."""

    def __init__(self, world, dt: float, threads: int = 1, sleeping: bool = True, rapier=None):
        r = self.r = rapier if rapier is not None else load_rapier()
        self.rw = r.PhysicsWorld(gravity=tuple(float(g) for g in world.gravity))
        self.rw.set_num_threads(threads)
        self.rw.integration_parameters.dt = dt
        self.world, self.sleeping = world, sleeping
        self.handles: dict[int, object] = {}
        static = np.asarray(world.is_static)
        enabled = np.asarray(world.enabled)
        self.dynamic = [i for i in range(world.num_bodies) if not static[i]]
        for i in range(world.num_bodies):
            self._create(i, bool(enabled[i]))
        self.mark_start()

    def _create(self, i: int, enabled: bool) -> None:
        r, world = self.r, self.world
        shape, static = world.shape(i), bool(world.is_static[i])
        position = tuple(float(c) for c in world.positions[i])
        w, x, y, z = (float(c) for c in world.orientations[i])
        if isinstance(shape, sg.Plane):
            n = np.asarray(shape.normal, dtype=float)
            n = n / np.linalg.norm(n)
            collider = r.Collider.halfspace(tuple(n))
            position, (w, x, y, z) = tuple(n * shape.offset), (1.0, 0.0, 0.0, 0.0)
        elif isinstance(shape, sg.Box):
            collider = r.Collider.cuboid(*(float(h) for h in shape.half_extents))
        elif isinstance(shape, sg.Sphere):
            collider = r.Collider.ball(float(shape.radius))
        elif isinstance(shape, sg.Capsule):
            collider = r.Collider.capsule_z(float(shape.half_length), float(shape.radius))
        elif isinstance(shape, sg.ConvexHull):
            collider = r.Collider.convex_hull(np.asarray(shape.vertices, dtype=float))
        else:
            raise ValueError(f"body {i}: no rapier3d twin for a {type(shape).__name__}")
        collider = collider.friction(float(world.frictions[i])).restitution(float(world.restitutions[i]))
        builder = r.RigidBody.fixed() if static else r.RigidBody.dynamic()
        builder = builder.position((position, (x, y, z, w)))
        if not static:
            collider = collider.mass(float(world.masses[i]))
            builder = (builder.linvel(tuple(float(c) for c in world.velocities[i]))
                       .angvel(tuple(float(c) for c in world.angular_velocities[i])).can_sleep(self.sleeping))
        self.handles[i] = self.rw.add_body(builder.enabled(enabled), [collider])

    def drop(self, indices) -> None:
        """Puts bodies ``indices`` at their current signorini pose and velocity and enables them."""
        world, bodies = self.world, self.rw.rigid_bodies
        for i in indices:
            body = bodies[self.handles[i]]
            w, x, y, z = (float(c) for c in world.orientations[i])
            body.position = (tuple(float(c) for c in world.positions[i]), (x, y, z, w))
            body.linvel = tuple(float(c) for c in world.velocities[i])
            body.angvel = tuple(float(c) for c in world.angular_velocities[i])
            body.is_enabled = True
            body.wake_up(True)

    def run_chunk(self, steps: int) -> float:
        """Steps ``steps`` times; returns the summed wall time of the steps alone (s)."""
        return timed_steps(self.rw.step, steps)

    def state(self):
        """Positions (N_dyn, 3) of the dynamic bodies (NaN where disabled) and their kinetic energy (J)."""
        bodies = self.rw.rigid_bodies
        positions = np.full((len(self.dynamic), 3), np.nan)
        energy = 0.0
        for k, i in enumerate(self.dynamic):
            body = bodies[self.handles[i]]
            if body.is_enabled:
                positions[k] = body.translation.to_tuple()
                energy += float(body.kinetic_energy())
        return positions, energy

    def mark_start(self) -> None:
        self.start = self.state()[0]

    def penetration(self) -> float:
        """The deepest penetration of any contact point now (m): minus the most negative distance."""
        deepest = 0.0
        for pair in self.rw.narrow_phase.contact_pairs():
            for manifold in pair.manifolds:
                for point in manifold.points:
                    deepest = max(deepest, -float(point.dist))
        return deepest

    def close(self) -> None:
        pass
