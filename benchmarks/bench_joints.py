"""Joints benchmark of issue 23: Box3D's joint_grid and a pile of ragdolls, in signorini, pybullet and MuJoCo (no asserts).

    python benchmarks/bench_joints.py [--scenes joint_grid,ragdolls] [--tiny] [--steps N] [--dt DT]
        [--chunks 10] [--engines signorini,soft,pybullet,mujoco] [--grid 100] [--ragdolls 50]

Scenes (z up, gravity 10 m/s^2, dt 1/60 as Box3D's benchmark app):
- ``joint_grid``: Box3D's scene of that name (``shared/benchmarks.c``, erincatto/box3d), rebuilt:
  an n x n grid (Box3D: n = 100, 10,000 bodies) of spheres of radius 0.4 m (density 1) 1 m apart in
  a vertical plane, the top row static, each sphere joined to the one above it and to the one on
  its left by ball joints at the midpoints; the spheres never collide with each other (a filter
  bit); sleeping off; 100 steps. Box3D also joins the static top row sideways; signorini refuses a
  joint between two static bodies (it would do nothing), so those n - 1 joints are left out.
- ``ragdolls``: ``--ragdolls`` (50) ragdolls of this module's own design (``add_ragdoll``: 11
  capsules, ball joints at the neck, shoulders and hips, hinges with limits at the waist, elbows
  and knees; density 1000, about 58 kg), lying in crossed layers of 5 and dropped onto a static
  ground box into a pile; a ragdoll's own parts never collide with each other (as in Box3D's and
  pybullet's ragdolls); sleeping off; 300 steps (5 s).

Engines, in this process, with the same dt, their chunks interleaved:
- ``signorini``: its defaults (the PGS); ``soft``: ``set_solver(solver="soft")`` (joints of 240 Hz
  in substeps of 1/960 s); ``soft60``: the same with ``joint_hertz=60`` (Box2D v3's joints, in
  the contacts' substeps of 1/240 s);
- ``pybullet``: DIRECT, 10 solver iterations, one solve per step (as bench_scale). The grid is
  mirrored body for body (``_peers.PybulletTwin``, maximal coordinates) with a ``createConstraint``
  JOINT_POINT2POINT per ball joint, its maxForce raised from pybullet's 500 N to 1e30 (comparable).
  A ragdoll is one ``createMultiBody`` in reduced coordinates (pybullet's ``createConstraint`` has
  no hinge, and a hinge limit exists only on a multibody joint: ``changeDynamics(jointLowerLimit,
  jointUpperLimit)``), its motors switched off and its damping 0: the same bodies, masses,
  inertias, frictions and joints, but a different method: its joints cannot separate, so its
  separation column is rounding, and the ms/step compares a reduced-coordinate solve with ours.
- ``mujoco`` (joint_grid only): the grid as MJCF, built in memory from the signorini World
  (``mujoco_grid_mjcf``). MuJoCo's bodies form a tree and a grid has loops, so the grid is a tree
  plus loop closures: the static top row's spheres are geoms of the world body; the tree is found
  breadth first from them over the joints (``mujoco_tree``), which makes each column a chain of
  n - 1 nested bodies hanging from its static sphere, each attached to the one above by a ``ball``
  joint at that joint's anchor (reduced coordinates: these n (n - 1) joints hold exactly); each of
  the (n - 1)^2 sideways joints, the links that close the loops, is an ``<equality><connect>`` of
  its two spheres at its anchor: 3 rows of MuJoCo's soft constraint with its default solref and
  solimp (at dt 1/60 MuJoCo raises the 0.02 s time constant to 2 dt). Masses and diagonal inertias
  are signorini's (``<inertial>``), the spheres are geoms that collide with nothing (contype =
  conaffinity = 0; they never touch in signorini either), gravity and dt are the same, the
  integrator MuJoCo's default (Euler), its default solver (Newton) with 10 iterations (pybullet's
  count; MuJoCo's default is 100, each a Newton step with an early stop). Its ms/step is
  ``mj_step`` alone and compares a reduced-coordinate tree, whose connect rows are dense over the
  chains above both spheres, with our maximal coordinates. Compiling it (untimed) takes MuJoCo
  minutes and about 1 GB at n = 100. Box3D's ragdolls are not modelled in MuJoCo here.

Timing: the run is cut into ``--chunks`` chunks, every engine runs a chunk in turn; a chunk's
ms/step is its stepping time alone over its length; the table gives the median over chunks and the
25-75 % range, and "sg/this" is signorini's first row over this row.

Quality, at the end: the largest joint separation |x_B - x_A| between the two bodies' anchor
points (m), the kinetic energy (J); for signorini and MuJoCo rows also the largest separation over
the run and how far the total energy E = KE + sum m g z of the dynamic bodies ever rose above its
start (J; <= 0: it never rose), each measured after every step, untimed.
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import signorini as sg
from signorini.fuzz import PARTS, RAGDOLL_JOINTS
from signorini.oracle import matrix_to_quat, quat_to_matrix
from signorini.scenes import axis_angle_quaternion


def _load_peers():
    """benchmarks/_peers.py, loaded by path (the benchmarks folder is not a package)."""
    spec = importlib.util.spec_from_file_location("_peers", Path(__file__).resolve().parent / "_peers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


peers = _load_peers()

GRAVITY = (0.0, 0.0, -10.0)
FRICTION = 0.6
DT = 1.0 / 60.0
PYBULLET_ITERATIONS = 10
MUJOCO_ITERATIONS = 10
ENGINES = ("signorini", "soft", "soft60", "pybullet", "mujoco")
ALL_BITS = 0xFFFFFFFF

# --------------------------------------------------------------------------- the ragdoll

# the ragdoll's parts and joints (PARTS, RAGDOLL_JOINTS) are the fuzzer's, which builds them too
SIDEWAYS = quat_to_matrix(axis_angle_quaternion((1.0, 0.0, 0.0), -0.5 * math.pi))  # body z -> world y


@dataclasses.dataclass
class Ragdoll:
    """One ragdoll in a World: ``bodies`` (11,) body indices in PARTS order, ``joints`` (10,) joint
    indices in RAGDOLL_JOINTS order, ``pose`` the (R (3, 3), t (3,)) it was placed with (a
    standing ragdoll's point x went to R x + t)."""
    bodies: list
    joints: list
    pose: tuple


def add_ragdoll(world, rotation=np.eye(3), position=(0.0, 0.0, 0.0), *, density: float = 1000.0,
                friction: float = FRICTION, self_collision: bool = False, name: str = "") -> Ragdoll:
    """Adds a ragdoll (PARTS, RAGDOLL_JOINTS) to ``world``, its standing pose turned by ``rotation``
    (3, 3) and moved by ``position`` (3,) m, at rest. Its parts do not collide with each other
    unless ``self_collision`` (jointed pairs never do). ``name``: a prefix for body and joint
    names (unique names in a World); empty: no names."""
    R, t = np.asarray(rotation, dtype=float), np.asarray(position, dtype=float)
    index = {}
    bodies = []
    for part, radius, half_length, centre, direction in PARTS:
        turn = R @ SIDEWAYS if direction == "y" else R
        i = world.add_body(sg.Capsule(radius, half_length), density=density, position=R @ np.asarray(centre) + t,
                           orientation=matrix_to_quat(turn), friction=friction, restitution=0.0,
                           name=f"{name}{part}" if name else None)
        index[part] = i
        bodies.append(i)
    joints = []
    for joint, parent, child, kind, anchor, axis, limits in RAGDOLL_JOINTS:
        a, b = index[parent], index[child]
        y = R @ np.asarray(anchor) + t
        label = f"{name}{joint}" if name else None
        if kind == "ball":
            cone, twist = limits
            desc = sg.Spherical(a, b, anchor=y, axis=R @ np.asarray(axis), cone=cone, twist=twist, name=label)
        else:
            desc = sg.Revolute(a, b, anchor=y, axis=R @ np.asarray(axis), limits=limits, name=label)
        joints.append(world.add_joint(desc))
    if not self_collision:
        for k, i in enumerate(bodies):
            for j in bodies[k + 1:]:
                world.disable_collision(i, j)
    return Ragdoll(bodies, joints, (R, t))


# --------------------------------------------------------------------------- scenes

@dataclasses.dataclass
class JointScene:
    """A scene built for the benchmark.

    - world: the signorini World; dt (s), steps: its step and Box3D's (or our) step count;
    - size: what was built, in words;
    - joint_bodies (J, 2): each joint's bodies A, B; anchors (J, 2, 3): its anchor point in A's and
      in B's body frame (m), from the poses at creation, for the separation measure;
    - ball_joints: (A, B, world anchor) of the grid's joints (for pybullet's point-to-point twins);
    - ragdolls: the ragdolls, for pybullet's multibody twins; ground: the static ground body or None.
    """
    name: str
    world: sg.World
    dt: float
    steps: int
    size: str
    joint_bodies: np.ndarray
    anchors: np.ndarray
    ball_joints: list = dataclasses.field(default_factory=list)
    ragdolls: list = dataclasses.field(default_factory=list)
    ground: int | None = None


def joint_anchors(world) -> tuple[np.ndarray, np.ndarray]:
    """(J, 2) bodies and (J, 2, 3) anchor points in each body's frame of every joint of ``world``
    as the core keeps them (``World.joint``)."""
    bodies = np.zeros((world.num_joints, 2), dtype=np.int64)
    anchors = np.zeros((world.num_joints, 2, 3))
    for j in range(world.num_joints):
        d = world.joint(j)
        bodies[j] = d["body_a"], d["body_b"]
        anchors[j] = d["anchor_a"], d["anchor_b"]
    return bodies, anchors


def separations(positions, rotations, joint_bodies, anchors) -> np.ndarray:
    """(J,) |x_B - x_A| (m) of every joint: x_X = p_X + R_X anchor_X, from positions (N, 3) and
    rotations (N, 3, 3) of the bodies."""
    a, b = joint_bodies[:, 0], joint_bodies[:, 1]
    x_a = positions[a] + np.einsum("jik,jk->ji", rotations[a], anchors[:, 0])
    x_b = positions[b] + np.einsum("jik,jk->ji", rotations[b], anchors[:, 1])
    return np.linalg.norm(x_b - x_a, axis=1)


def joint_grid(tiny: bool = False, n: int | None = None) -> JointScene:
    """Box3D's joint_grid: n x n (default 100, tiny 4) spheres of 0.4 m, 1 m apart in the x-z
    plane, row 0 (z = 0) static, ball joints to the sphere above and the one on the left."""
    n = n or (4 if tiny else 100)
    world = sg.World(gravity=GRAVITY, sleeping=False)
    sphere = sg.Sphere(0.4)
    ids = np.zeros((n, n), dtype=np.int64)  # [column k, row i]
    balls = []
    for k in range(n):
        for i in range(n):
            position = (float(k), 0.0, -float(i))
            # Box3D: category bit 2, mask all but 2, so the spheres never touch each other
            if i == 0:
                ids[k, i] = world.add_static(sphere, position=position, friction=FRICTION, group=2, mask=ALL_BITS & ~2)
            else:
                ids[k, i] = world.add_body(sphere, density=1.0, position=position, friction=FRICTION,
                                           restitution=0.0, group=2, mask=ALL_BITS & ~2)
            if i > 0:
                balls.append((int(ids[k, i - 1]), int(ids[k, i]), np.array([k, 0.0, -(i - 0.5)])))
            if k > 0 and i > 0:  # two static bodies are not joined (see the module's doc)
                balls.append((int(ids[k - 1, i]), int(ids[k, i]), np.array([k - 0.5, 0.0, -float(i)])))
    for a, b, y in balls:
        world.add_joint(sg.Spherical(a, b, anchor=y))
    bodies, anchors = joint_anchors(world)
    return JointScene("joint_grid", world, DT, 100,
                      f"{n} x {n} spheres ({n * (n - 1)} moving), {len(balls)} ball joints",
                      bodies, anchors, ball_joints=balls)


def ragdoll_layer_pose(k: int, per_layer: int = 5, spacing: float = 1.7, layer_height: float = 0.45,
                       lift: float = 0.4, rng=None) -> tuple[np.ndarray, np.ndarray]:
    """The pose (R, t) of the k-th ragdoll of a pile: lying face down (head along +x), ``per_layer``
    side by side ``spacing`` m apart, every other layer turned a quarter about z, layers
    ``layer_height`` m apart from ``lift`` m; ``rng`` adds a seeded turn about z of up to 0.1 rad."""
    layer, slot = divmod(k, per_layer)
    lying = quat_to_matrix(axis_angle_quaternion((0.0, 1.0, 0.0), 0.5 * math.pi))  # up -> +x
    yaw = 0.5 * math.pi * (layer % 2) + (float(rng.uniform(-0.1, 0.1)) if rng is not None else 0.0)
    R = quat_to_matrix(axis_angle_quaternion((0.0, 0.0, 1.0), yaw)) @ lying
    across = (slot - 0.5 * (per_layer - 1)) * spacing
    # the standing ragdoll's mid-height (z = 0.87) goes to the layer's centre
    centre = np.array([0.0, across, lift + layer * layer_height])
    if layer % 2:
        centre[:2] = -across, 0.0
    return R, centre - R @ np.array([0.0, 0.0, 0.87])


def ragdolls(tiny: bool = False, count: int | None = None) -> JointScene:
    """A pile of ``count`` ragdolls (default 50, tiny 2) dropped onto a static ground, 300 steps."""
    count = count or (2 if tiny else 50)
    world = sg.World(gravity=GRAVITY, sleeping=False)
    ground = world.add_static(sg.Box((20.0, 20.0, 1.0)), position=(0.0, 0.0, -1.0), friction=FRICTION)
    rng = np.random.default_rng(23)
    dolls = [add_ragdoll(world, *ragdoll_layer_pose(k, rng=rng)) for k in range(count)]
    bodies, anchors = joint_anchors(world)
    return JointScene("ragdolls", world, DT, 300,
                      f"{count} ragdolls, {count * len(PARTS)} capsules, {count * len(RAGDOLL_JOINTS)} joints",
                      bodies, anchors, ragdolls=dolls, ground=ground)


SCENES = {"joint_grid": joint_grid, "ragdolls": ragdolls}


# --------------------------------------------------------------------------- runs

class SignoriniRun:
    """A signorini scene being stepped; after each step (untimed) it records the total energy and
    the joints' separation. ``solver``: set_solver keywords (empty: the defaults)."""

    def __init__(self, scene: JointScene, solver: dict):
        self.scene, self.world = scene, scene.world
        if solver:
            self.world.set_solver(**solver)
        self.energy0 = self.energy()
        self.rise = -math.inf  # max over steps of E - E0 (J)
        self.max_separation = self.separation()
        self.steps = 0
        self.failed = None  # the error that stopped the run (the core's energy guard), if one did

    def energy(self) -> float:
        return float(self.world.kinetic_energy() + self.world.potential_energy())

    def separation(self) -> float:
        s = separations(self.world.positions, self.world.rotations, self.scene.joint_bodies, self.scene.anchors)
        return float(s.max()) if s.size else 0.0

    def step(self) -> float | None:
        """One timed step (s); None once a step failed (the run stops there and says so)."""
        if self.failed is not None:
            return None
        t0 = time.perf_counter()
        try:
            self.world.step(self.scene.dt)
        except RuntimeError as error:
            self.failed = f"step {self.steps + 1} refused: {str(error).split(';')[0]}"
            return None
        elapsed = time.perf_counter() - t0
        self.steps += 1
        self.rise = max(self.rise, self.energy() - self.energy0)
        self.max_separation = max(self.max_separation, self.separation())
        return elapsed

    def quality(self) -> dict:
        return {"separation": self.separation(), "max_separation": self.max_separation,
                "kinetic_energy": float(self.world.kinetic_energy()), "energy0": self.energy0,
                "rise": self.rise, "failed": self.failed, "stepped": self.steps}

    def close(self) -> None:
        pass


class PybulletGrid:
    """The joint grid in pybullet: every body mirrored (``_peers.PybulletTwin``, with the spheres'
    filter bits) and a point-to-point constraint per ball joint at its world anchor."""

    def __init__(self, scene: JointScene, mods):
        self.scene = scene
        world = scene.world
        self.twin = peers.PybulletTwin(world, scene.dt, PYBULLET_ITERATIONS, False, mods)
        pb, p = self.twin.pb, self.twin.p
        groups, masks = (np.asarray(x) for x in world.collision_filters)
        def signed(bits) -> int:  # pybullet takes the 32 filter bits as a C int
            bits = int(bits)
            return bits - (1 << 32) if bits >= 1 << 31 else bits

        for i, body in self.twin.ids.items():
            pb.setCollisionFilterGroupMask(body, -1, signed(groups[i]), signed(masks[i]))
        for a, b, y in scene.ball_joints:
            local_a = quat_to_matrix(world.orientations[a]).T @ (y - world.positions[a])
            local_b = quat_to_matrix(world.orientations[b]).T @ (y - world.positions[b])
            c = pb.createConstraint(self.twin.ids[a], -1, self.twin.ids[b], -1, p.JOINT_POINT2POINT, [0, 0, 0],
                                    local_a.tolist(), local_b.tolist())
            pb.changeConstraint(c, maxForce=1e30)

    def step(self) -> float:
        return self.twin.run_chunk(1)

    def poses(self):
        """(N, 3) positions and (N, 3, 3) rotations of every body, in signorini's order and frames."""
        n = self.scene.world.num_bodies
        positions, rotations = np.zeros((n, 3)), np.zeros((n, 3, 3))
        for i, body in self.twin.ids.items():
            position, (x, y, z, w) = self.twin.pb.getBasePositionAndOrientation(body)
            positions[i], rotations[i] = position, quat_to_matrix((w, x, y, z))
        return positions, rotations

    def quality(self) -> dict:
        s = separations(*self.poses(), self.scene.joint_bodies, self.scene.anchors)
        return {"separation": float(s.max()) if s.size else 0.0, "kinetic_energy": self.twin.state()[1]}

    def close(self) -> None:
        self.twin.close()


class PybulletRagdolls:
    """The ragdoll pile in pybullet: the ground a static box, each ragdoll one multibody in reduced
    coordinates whose base is the pelvis and whose links are the other parts, each link's frame at
    its joint's anchor with the part's axes, its inertial and collision frames at the part's centre
    (so a link's inertial frame is the signorini body's frame); masses, diagonal inertias and
    frictions (sqrt(mu), Bullet multiplies) are signorini's; revolute joints get the hinge limits;
    motors off, damping 0; links of one ragdoll do not collide (no self-collision flag)."""

    def __init__(self, scene: JointScene, mods):
        self.scene = scene
        self.p, client_class = mods
        p = self.p
        with peers.quiet_stdout():
            self.pb = pb = client_class(connection_mode=p.DIRECT)
        world = scene.world
        pb.setGravity(*GRAVITY)
        pb.setPhysicsEngineParameter(numSolverIterations=PYBULLET_ITERATIONS, fixedTimeStep=scene.dt, numSubSteps=0)
        g = world.shape(scene.ground)
        col = pb.createCollisionShape(p.GEOM_BOX, halfExtents=list(g.half_extents))
        ground = pb.createMultiBody(0.0, col, basePosition=list(world.positions[scene.ground]))
        pb.changeDynamics(ground, -1, lateralFriction=math.sqrt(float(world.frictions[scene.ground])),
                          restitution=0.0)
        self.links = []  # per body of the scene: (pybullet body, link index; -1 the base)
        self.doll_ids = [self._ragdoll(doll) for doll in scene.ragdolls]

    def _ragdoll(self, doll: Ragdoll) -> int:
        p, pb, world = self.p, self.pb, self.scene.world
        parts = [row[0] for row in PARTS]
        joint_of = {row[2]: row for row in RAGDOLL_JOINTS}  # child -> its joint
        R = {i: quat_to_matrix(world.orientations[i]) for i in doll.bodies}
        P = {i: np.asarray(world.positions[i], dtype=float) for i in doll.bodies}
        frame = {}  # body -> (origin, rotation) of its pybullet link frame, world
        shapes, masses, link_pos, link_orn, inertial_pos, parents, kinds, axes = [], [], [], [], [], [], [], []
        base = doll.bodies[0]
        frame[base] = (P[base], R[base])
        R_doll, t_doll = doll.pose
        for k, part in enumerate(parts[1:], start=1):
            body = doll.bodies[k]
            _, parent, _, kind, anchor, axis, _ = joint_of[part]
            parent_body = doll.bodies[parts.index(parent)]
            y = R_doll @ np.asarray(anchor) + t_doll
            frame[body] = (y, R[body])
            origin, rotation = frame[parent_body]
            link_pos.append((rotation.T @ (y - origin)).tolist())
            w, x, yq, z = matrix_to_quat(rotation.T @ R[body])
            link_orn.append([x, yq, z, w])
            offset = R[body].T @ (P[body] - y)
            inertial_pos.append(offset.tolist())
            shapes.append(self._capsule(body, offset))
            masses.append(float(world.masses[body]))
            parents.append(parts.index(parent))  # 0: the base, j: link j - 1
            kinds.append(p.JOINT_SPHERICAL if kind == "ball" else p.JOINT_REVOLUTE)
            axes.append((R[body].T @ (R_doll @ np.asarray(axis))).tolist() if kind == "hinge" else [0.0, 0.0, 1.0])
        w, x, yq, z = matrix_to_quat(R[base])
        n = len(parts) - 1
        doll_id = pb.createMultiBody(
            baseMass=float(world.masses[base]), baseCollisionShapeIndex=self._capsule(base, np.zeros(3)),
            basePosition=P[base].tolist(), baseOrientation=[x, yq, z, w],
            linkMasses=masses, linkCollisionShapeIndices=shapes, linkVisualShapeIndices=[-1] * n,
            linkPositions=link_pos, linkOrientations=link_orn, linkInertialFramePositions=inertial_pos,
            linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]] * n, linkParentIndices=parents,
            linkJointTypes=kinds, linkJointAxis=axes)
        for k, body in enumerate(doll.bodies):
            link = k - 1
            self.links.append((body, doll_id, link))
            pb.changeDynamics(doll_id, link, mass=float(world.masses[body]),
                              localInertiaDiagonal=np.diag(np.asarray(world.inertias[body])).tolist(),
                              lateralFriction=math.sqrt(float(world.frictions[body])), restitution=0.0,
                              linearDamping=0.0, angularDamping=0.0, jointDamping=0.0,
                              activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING)
            if link < 0:
                continue
            _, _, _, kind, _, _, limits = joint_of[parts[k]]
            if kind == "ball":
                pb.setJointMotorControlMultiDof(doll_id, link, p.POSITION_CONTROL, targetPosition=[0, 0, 0, 1],
                                                positionGain=0.0, velocityGain=0.0, force=[0.0, 0.0, 0.0])
            else:
                pb.setJointMotorControl2(doll_id, link, p.VELOCITY_CONTROL, force=0.0)
                pb.changeDynamics(doll_id, link, jointLowerLimit=limits[0], jointUpperLimit=limits[1])
        return doll_id

    def _capsule(self, body: int, offset) -> int:
        shape = self.scene.world.shape(body)
        return self.pb.createCollisionShape(self.p.GEOM_CAPSULE, radius=float(shape.radius),
                                            height=2.0 * float(shape.half_length),
                                            collisionFramePosition=list(offset))

    def step(self) -> float:
        return peers.timed_steps(self.pb.stepSimulation, 1)

    def poses(self):
        """(N, 3) positions, (N, 3, 3) rotations of the parts (signorini's body frames) and the
        kinetic energy (J) of the ragdolls."""
        world = self.scene.world
        n = world.num_bodies
        positions, rotations = np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1))
        energy = 0.0
        for body, doll, link in self.links:
            if link < 0:
                position, (x, y, z, w) = self.pb.getBasePositionAndOrientation(doll)
                v, omega = self.pb.getBaseVelocity(doll)
            else:
                state = self.pb.getLinkState(doll, link, computeLinkVelocity=1, computeForwardKinematics=1)
                position, (x, y, z, w), v, omega = state[0], state[1], state[6], state[7]
            positions[body], rotations[body] = position, quat_to_matrix((w, x, y, z))
            local = rotations[body].T @ np.asarray(omega)
            energy += 0.5 * float(world.masses[body]) * float(np.dot(v, v)) + \
                0.5 * float(local @ np.asarray(world.inertias[body]) @ local)
        return positions, rotations, energy

    def quality(self) -> dict:
        positions, rotations, energy = self.poses()
        s = separations(positions, rotations, self.scene.joint_bodies, self.scene.anchors)
        return {"separation": float(s.max()) if s.size else 0.0, "kinetic_energy": energy}

    def close(self) -> None:
        self.pb.disconnect()


def load_mujoco():
    """The mujoco module, or None if it is not installed."""
    try:
        import mujoco
    except ImportError:
        return None
    return mujoco


def _numbers(values) -> str:
    return " ".join(f"{float(x):.17g}" for x in values)


def mujoco_tree(scene: JointScene) -> tuple[list, list]:
    """The scene's joints split into MuJoCo's body tree and its loop closures, breadth first from
    the static bodies: parent (N,) the joint index each dynamic body was first reached through (-1
    for static bodies), and the indices of the other joints (the loop-closing links). ValueError if a
    dynamic body hangs from no static body."""
    world = scene.world
    static = np.asarray(world.is_static)
    parent = [-1] * world.num_bodies
    reached = static.copy()
    links = {}  # body -> the joints at it, in index order
    for j, (a, b) in enumerate(scene.joint_bodies):
        links.setdefault(int(a), []).append(j)
        links.setdefault(int(b), []).append(j)
    queue = [i for i in range(world.num_bodies) if static[i]]
    tree = set()
    for body in queue:  # the queue grows as bodies are reached
        for j in links.get(body, []):
            a, b = (int(x) for x in scene.joint_bodies[j])
            other = b if a == body else a
            if not reached[other]:
                reached[other], parent[other] = True, j
                tree.add(j)
                queue.append(other)
    if not reached.all():
        raise ValueError(f"body {int(np.argmin(reached))} hangs from no static body: no MuJoCo tree for it")
    return parent, [j for j in range(len(scene.joint_bodies)) if j not in tree]


def mujoco_grid_mjcf(scene: JointScene) -> str:
    """The MJCF text of a scene of spheres joined by ball joints (joint_grid), as described in the
    module's doc: static spheres are geoms of the world body; dynamic body i is ``<body name="b{i}">``
    with signorini's mass and diagonal inertia (``<inertial>``) and its sphere as a geom that
    collides with nothing, nested in the body (or the world) it was reached from (``mujoco_tree``)
    and attached to it by a ``ball`` joint at that joint's anchor; every other joint is an
    ``<equality><connect>`` of B (body1) and A (body2) at B's anchor. dt, gravity, MuJoCo's default
    (Newton) solver with MUJOCO_ITERATIONS iterations, its default soft-constraint parameters; the
    arena (``<size memory>``) from the connect rows' Jacobian, dense over the ancestors' degrees of
    freedom of both bodies."""
    world = scene.world
    static = np.asarray(world.is_static)
    parent, loops = mujoco_tree(scene)
    P = np.asarray(world.positions, dtype=float)
    R = [quat_to_matrix(q) for q in world.orientations]
    up = [-1] * world.num_bodies  # the parent body of each dynamic body (-1: the world)
    children = {-1: []}
    for i in range(world.num_bodies):
        if static[i]:
            continue
        a, b = (int(x) for x in scene.joint_bodies[parent[i]])
        up[i] = a if b == i else b
        up[i] = -1 if static[up[i]] else up[i]
        children.setdefault(up[i], []).append(i)
    depth = [0] * world.num_bodies
    for i in [i for i in children[-1]]:
        stack = [(i, 1)]
        while stack:
            k, d = stack.pop()
            depth[k] = d
            stack += [(c, d + 1) for c in children.get(k, [])]

    def sphere(i: int) -> str:
        shape = world.shape(i)
        if not isinstance(shape, sg.Sphere):
            raise ValueError(f"body {i}: a {type(shape).__name__}; this MJCF twin has spheres only")
        return f'size="{float(shape.radius):.17g}"'

    lines = []
    for i in np.nonzero(static)[0]:
        lines.append(f'<geom type="sphere" {sphere(i)} pos="{_numbers(P[i])}" quat="{_numbers(world.orientations[i])}"/>')
    stack = [("open", i) for i in reversed(children[-1])]
    while stack:
        what, i = stack.pop()
        if what == "close":
            lines.append("</body>")
            continue
        j = parent[i]
        origin, turn = (np.zeros(3), np.eye(3)) if up[i] < 0 else (P[up[i]], R[up[i]])
        side = 1 if int(scene.joint_bodies[j][1]) == i else 0
        inertia = np.diag(np.asarray(world.inertias[i], dtype=float))
        lines.append(f'<body name="b{i}" pos="{_numbers(turn.T @ (P[i] - origin))}" '
                     f'quat="{_numbers(matrix_to_quat(turn.T @ R[i]))}">'
                     f'<inertial pos="0 0 0" mass="{float(world.masses[i]):.17g}" diaginertia="{_numbers(inertia)}"/>'
                     f'<joint type="ball" pos="{_numbers(scene.anchors[j][side])}"/><geom type="sphere" {sphere(i)}/>')
        stack.append(("close", i))
        stack += [("open", c) for c in reversed(children.get(i, []))]
    connects = []
    rows = 0
    for j in loops:
        a, b = (int(x) for x in scene.joint_bodies[j])
        connects.append(f'<connect body1="b{b}" body2="{"world" if static[a] else f"b{a}"}" '
                        f'anchor="{_numbers(scene.anchors[j][1])}"/>')
        rows += 3 * 3 * (depth[a] + depth[b])
    memory = (64 << 20) + 100 * rows  # about twice what MuJoCo 3 and 4 used for the grid
    return (f'<mujoco model="{scene.name}"><size memory="{memory}"/>'
            f'<option timestep="{scene.dt:.17g}" gravity="{_numbers(world.gravity)}" solver="Newton" '
            f'iterations="{MUJOCO_ITERATIONS}"/><default><geom contype="0" conaffinity="0"/></default>'
            f'<worldbody>{"".join(lines)}</worldbody><equality>{"".join(connects)}</equality></mujoco>')


class MujocoGrid:
    """The joint grid in MuJoCo (``mujoco_grid_mjcf``), stepped by ``mj_step``. After each step,
    untimed: the poses (``mj_kinematics``: mj_step leaves them at the step's start), the total
    energy (``mj_comPos``, ``mj_crb``, then ``mj_energyPos`` + ``mj_energyVel``: MuJoCo's potential
    -sum m g . x is signorini's sum m g z) and the joints' separation, as SignoriniRun records them.
    None of these calls changes the next step, which recomputes all from qpos and qvel. A step after
    which MuJoCo reset its state (its bad-acceleration warning) stops the run."""

    def __init__(self, scene: JointScene, mujoco):
        self.scene, self.mj = scene, mujoco
        self.model = mujoco.MjModel.from_xml_string(mujoco_grid_mjcf(scene))
        self.data = mujoco.MjData(self.model)
        world = scene.world
        self.dynamic = np.nonzero(~np.asarray(world.is_static))[0]
        self.ids = np.array([self.model.body(f"b{i}").id for i in self.dynamic], dtype=np.int64)
        self.positions = np.array(world.positions, dtype=float)
        self.rotations = np.array(world.rotations, dtype=float)
        self._refresh()
        self.energy0 = self.energy()
        self.rise = -math.inf
        self.max_separation = self.separation()
        self.steps = 0
        self.failed = None

    def _refresh(self) -> None:
        m, d = self.model, self.data
        for stage in (self.mj.mj_kinematics, self.mj.mj_comPos, self.mj.mj_crb, self.mj.mj_energyPos,
                      self.mj.mj_energyVel):
            stage(m, d)
        self.positions[self.dynamic] = d.xpos[self.ids]
        self.rotations[self.dynamic] = d.xmat[self.ids].reshape(-1, 3, 3)

    def energy(self) -> float:
        return float(self.data.energy[0] + self.data.energy[1])

    def separation(self) -> float:
        s = separations(self.positions, self.rotations, self.scene.joint_bodies, self.scene.anchors)
        return float(s.max()) if s.size else 0.0

    def step(self) -> float | None:
        if self.failed is not None:
            return None
        warning = self.data.warning[self.mj.mjtWarning.mjWARN_BADQACC]
        resets = int(warning.number)
        t0 = time.perf_counter()
        self.mj.mj_step(self.model, self.data)
        elapsed = time.perf_counter() - t0
        if int(warning.number) > resets:
            self.failed = f"step {self.steps + 1}: MuJoCo reset its state (bad acceleration)"
            return None
        self.steps += 1
        self._refresh()
        self.rise = max(self.rise, self.energy() - self.energy0)
        self.max_separation = max(self.max_separation, self.separation())
        return elapsed

    def quality(self) -> dict:
        return {"separation": self.separation(), "max_separation": self.max_separation,
                "kinetic_energy": float(self.data.energy[1]), "energy0": self.energy0, "rise": self.rise,
                "failed": self.failed, "stepped": self.steps}

    def close(self) -> None:
        pass


def make_runs(name: str, args, mods, mujoco=None) -> list[tuple[str, object]]:
    """(row name, run) of every engine asked for, each on a freshly built scene (MuJoCo: the grid
    only)."""
    def scene() -> JointScene:
        size = {"joint_grid": args.grid, "ragdolls": args.ragdolls}[name]
        s = SCENES[name](tiny=args.tiny, **({"n": size} if name == "joint_grid" else {"count": size}))
        if args.dt is not None:
            s.dt = args.dt
        return s

    runs = []
    if "signorini" in args.engines:
        runs.append(("signorini", SignoriniRun(scene(), {})))
    if "soft" in args.engines:
        runs.append(("signorini soft", SignoriniRun(scene(), {"solver": "soft"})))
    if "soft60" in args.engines:
        runs.append(("signorini soft60", SignoriniRun(scene(), {"solver": "soft", "joint_hertz": 60.0})))
    if "pybullet" in args.engines and mods is not None:
        twin = PybulletGrid if name == "joint_grid" else PybulletRagdolls
        runs.append(("pybullet", twin(scene(), mods)))
    if "mujoco" in args.engines and mujoco is not None and name == "joint_grid":
        runs.append(("mujoco", MujocoGrid(scene(), mujoco)))
    return runs


def _median(times):
    q1, median, q3 = np.percentile(times, [25, 50, 75])
    return float(median), float(q1), float(q3)


def bench_scene(name: str, args, mods, mujoco=None) -> list[dict]:
    """Runs every engine on one scene, chunks interleaved; returns a row dict per engine: scene,
    engine, size, bodies (moving), joints, steps, dt, ms, q1, q3 (median and quartiles of the
    chunks' ms/step), ratio (signorini's first row's ms over this row's), separation (m, at the
    end), kinetic_energy (J, at the end), and for signorini and MuJoCo rows max_separation (m, over the run),
    energy0 (J) and rise (J: the most E ever exceeded E0 by)."""
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sg.SolverWarning)
        runs = make_runs(name, args, mods, mujoco)
        try:
            if not runs:
                return rows
            scene = runs[0][1].scene
            steps = args.steps if args.steps is not None else (10 if args.tiny else scene.steps)
            times = {row: [] for row, _ in runs}
            for chunk, length in enumerate(peers.chunk_lengths(steps, args.chunks)):
                for row, run in runs:
                    elapsed = [run.step() for _ in range(length)]
                    if None not in elapsed:  # a run stopped by an error times no more chunks
                        times[row].append(1e3 * sum(elapsed) / length)
                print(f"    {name}: chunk {chunk + 1}/{min(args.chunks, steps)}", file=sys.stderr, flush=True)
            for row, run in runs:
                ms, q1, q3 = _median(times[row]) if times[row] else (math.nan, math.nan, math.nan)
                rows.append({"scene": name, "engine": row, "size": scene.size,
                             "bodies": int(np.count_nonzero(~np.asarray(scene.world.is_static))),
                             "joints": int(scene.world.num_joints), "steps": steps, "dt": scene.dt,
                             "ms": ms, "q1": q1, "q3": q3, **run.quality()})
        finally:
            for _, run in runs:
                run.close()
    base = next((r["ms"] for r in rows if r["engine"].startswith("signorini")), None)
    for row in rows:
        row["ratio"] = base / row["ms"] if base is not None and row["ms"] > 0 else None
    return rows


COLUMNS = [  # header, width, row key, format (None: the row's own text)
    ("scene", 10, "scene", "s"), ("engine", 14, "engine", "s"), ("bodies", 6, "bodies", "d"),
    ("joints", 6, "joints", "d"), ("steps", 5, "steps", "d"), ("ms/step", 9, "ms", ".3f"),
    ("25-75 %", 17, "range", None), ("sg/this", 7, "ratio", ".2f"), ("sep end m", 9, "separation", ".2e"),
    ("sep max m", 9, "max_separation", ".2e"), ("KE end J", 9, "kinetic_energy", ".2e"),
    ("E0 J", 10, "energy0", ".4e"), ("E rise J", 9, "rise", ".2e"),
]
LEFT = ("scene", "engine")


def format_table(rows) -> str:
    """One aligned table, a line per scene and engine, '-' where a figure does not apply; cells are
    two spaces apart and hold no two spaces, so ``re.split(r"\\s{2,}")`` reads a line back."""
    return peers.table(rows, COLUMNS, LEFT)


def main(argv: list[str] | None = None) -> list[dict]:
    """Parses the options, runs the scenes, prints the table and a verdict per signorini row."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default=",".join(SCENES), help="comma-separated, from: " + ", ".join(SCENES))
    parser.add_argument("--tiny", action="store_true", help="small versions (a 4 x 4 grid, 2 ragdolls, 10 steps)")
    parser.add_argument("--steps", type=int, default=None, help="timed steps (default: 100 for the grid as "
                        "Box3D, 300 for the ragdolls; --tiny: 10)")
    parser.add_argument("--dt", type=float, default=None, help="time step (default 1/60)")
    parser.add_argument("--chunks", type=int, default=10, help="timed chunks per run (default 10)")
    parser.add_argument("--engines", default=",".join(ENGINES), help="comma-separated, from: " + ", ".join(ENGINES))
    parser.add_argument("--grid", type=int, default=None, help="joint_grid's n (default Box3D's 100; --tiny: 4)")
    parser.add_argument("--ragdolls", type=int, default=None, help="ragdolls in the pile (default 50; --tiny: 2)")
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.scenes.split(",") if n.strip()]
    if unknown := [n for n in names if n not in SCENES]:
        parser.error(f"unknown scene(s) {unknown}; known: {', '.join(SCENES)}")
    args.engines = [e.strip() for e in args.engines.split(",") if e.strip()]
    if unknown := [e for e in args.engines if e not in ENGINES]:
        parser.error(f"unknown engine(s) {unknown}; known: {', '.join(ENGINES)}")
    if args.chunks < 1 or (args.steps is not None and args.steps < 1):
        parser.error("--chunks and --steps must be at least 1")
    if args.dt is not None and not args.dt > 0:
        parser.error("--dt must be positive")
    if (args.grid is not None and args.grid < 2) or (args.ragdolls is not None and args.ragdolls < 1):
        parser.error("--grid must be at least 2 and --ragdolls at least 1")

    mods = peers.load_pybullet() if "pybullet" in args.engines else None
    if "pybullet" not in args.engines:
        print("pybullet: skipped (--engines)")
    elif mods is None:
        print("pybullet: not installed (pip install pybullet)")
    mujoco = load_mujoco() if "mujoco" in args.engines else None
    if "mujoco" not in args.engines:
        print("mujoco: skipped (--engines)")
    elif mujoco is None:
        print("mujoco: not installed (pip install mujoco)")
    else:
        print(f"mujoco {mujoco.__version__}: joint_grid only, Newton, {MUJOCO_ITERATIONS} iterations")
    print(f"gravity 10 m/s^2, friction {FRICTION:g}, restitution 0, sleeping off; pybullet {PYBULLET_ITERATIONS} "
          f"iterations; {args.chunks} chunk(s); ms/step = median over chunks")
    rows = []
    for name in names:
        t0 = time.perf_counter()
        scene_rows = bench_scene(name, args, mods, mujoco)
        rows += scene_rows
        size = scene_rows[0]["size"] if scene_rows else "no engine ran"
        print(f"  {name}: {size}, dt {scene_rows[0]['dt'] if scene_rows else DT:.6g} s, "
              f"done in {time.perf_counter() - t0:.0f} s wall", flush=True)
    print()
    print(format_table(rows))
    print()
    for row in rows:
        if row.get("failed"):
            print(f"{row['scene']}, {row['engine']}: stopped after {row['stepped']} steps, {row['failed']} "
                  "(ms/step from the chunks before it; quality at the last kept step)")
        if row.get("rise") is None:
            continue
        verdict = "never rose above its start" if row["rise"] <= 0.0 else "ROSE above its start"
        print(f"{row['scene']}, {row['engine']}: energy {verdict} (max E - E0 = {row['rise']:.3e} J of "
              f"E0 = {row['energy0']:.6e} J); joints apart by at most {row['max_separation'] * 1e3:.3f} mm "
              f"over the run, {row['separation'] * 1e3:.3f} mm at the end")
    sys.stdout.flush()
    return rows


if __name__ == "__main__":
    main()
