"""Scene files: a world, its bodies and how to run it, in TOML.

One pydantic model (``SceneFile``) defines the format; its JSON Schema (``scene_schema()``, shipped
as ``signorini/data/scene.schema.json``) is generated from it, so editors can check a file as it is
written. A file reads like this (every table and key optional unless marked)::

    format = 1

    [scene]                      # how to run it: python -m signorini run file.toml
    name = "drop"
    description = "a box dropped on the ground"
    dt = 0.004166666666666667    # s, the suggested time step
    steps = 480
    snapshot_times = [0.0, 0.5, 1.0]

    [world]                      # World(...) keywords: gravity, contact_margin, the solver's and sleep's
    gravity = [0.0, 0.0, -9.81]
    erp = 0.2

    [materials.rubber]           # named materials bodies refer to
    friction = 0.9
    restitution = 0.8
    spinning_friction = 0.002    # m (torsional friction; default 0)

    [[bodies]]
    name = "ground"
    static = true
    shape = { type = "plane", normal = [0.0, 0.0, 1.0], offset = 0.0 }

    [[bodies]]
    name = "box"
    shape = { type = "box", half_extents = [0.5, 0.5, 0.5] }
    density = 1000.0             # or mass (kg); exactly one, for dynamic bodies
    material = "rubber"          # or friction = ..., restitution = ..., spinning_friction = ... (they override it)
    position = [0.0, 0.0, 1.0]   # centre of mass, m
    orientation = [1.0, 0.0, 0.0, 0.0]   # quaternion w, x, y, z
    velocity = [0.0, 0.0, 0.0]
    angular_velocity = [0.0, 0.0, 0.0]
    kinematic = false            # moved by its velocity only (then density and mass are optional)
    inertia = [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]]   # kg m^2, with mass (explicit)
    force = [0.0, 0.0, 0.0]      # persistent external force (N) and torque (N m), world
    torque = [0.0, 0.0, 0.0]
    group = 1                    # collision filter bits (World.set_collision_filter)
    mask = 4294967295
    enabled = true               # false: neither moves nor collides (World.set_enabled)

    disabled_pairs = [[0, 1]]    # top level: body indices that never collide (World.disable_collision)

    [[joints]]                   # made after every body, in this order (joint indices); signorini.joints
    name = "hinge"
    type = "revolute"            # revolute, prismatic, spherical, fixed or distance
    body_a = "ground"            # a body's name (or its index); a static body attaches to the world
    body_b = "box"
    anchor = [0.0, 0.0, 1.5]     # world, m, at the bodies' poses above (prismatic, fixed: default body_b's centre)
    axis = [1.0, 0.0, 0.0]       # revolute, prismatic: world, at creation
    limits = [-1.0, 1.0]         # rad or m, 0 at creation
    motor = { speed = 2.0, max_torque = 5.0 }   # or max_force; position, stiffness, damping: a servo
    friction = 0.1               # N m or N
    effort = 0.0                 # N m or N, applied along the joint
    break_force = 1000.0         # N (and break_torque, N m; absent: never)
    collide_connected = false
    broken = false
    # distance: anchor_a, anchor_b (world points of body_a and body_b), min_length, max_length

Shapes (``type``): ``sphere`` (radius), ``box`` (half_extents), ``capsule`` (radius, half_length),
``cylinder`` (radius, half_height), ``plane`` (normal, offset; static only), ``hull`` (points),
``mesh`` and ``trimesh`` (``file`` relative to the scene file's folder, with an optional ``scale``,
or inline ``vertices`` and ``faces``; ``trimesh`` is static only), ``compound`` (``parts``, each a
``shape`` with a ``position`` and ``orientation`` in the compound frame, or instead of the
orientation its exact ``rotation`` matrix, which ``save_scene`` writes when the part's quaternion
would not give the matrix back to the bit).

``load_scene(path)`` gives the World; ``read_scene(path)`` gives a ``Scene`` (the world with
its name, time step, step count, description and body names). ``save_scene(world or scene, path)``
writes a file and the mesh files it refers to (``<stem>.meshes/mesh_<k>.npz`` next to it, exact
float64 arrays with the convex pieces of decomposed meshes, so loading needs no decomposition).

Exactness: a body is written with the values it was added with (shape, density or mass, pose and
velocities) as long as its state is still the one it was added with, so loading a saved scene and
stepping it is bit-identical to stepping the original. A body that has moved since is written with
its current position and velocities (exact) and the quaternion of its rotation matrix (to the last
bit or two). A compound part keeps its rotation matrix exactly (as ``rotation`` when its quaternion
would not give it back). Kinematic and enabled flags, explicit mass and
inertia, filter bits, disabled pairs, names, materials and persistent wrenches are kept, so a saved
world with kinematic or filtered bodies steps bit for bit like the original too. Joints are written
with the anchors and axis they were made from (``World.joint_args``) and their current limits,
motor, friction, effort, breaking limits, flags and name; each is made once in the world the file's
bodies load as, to check that the file makes it bit for bit. What a file cannot hold (a pending
impulse or a force for the next step only; a joint whose bodies have moved since it was made, whose
angle, offset or drift a file made at the written poses would lose) is refused at save time with a
ValueError naming the body or joint, never dropped. The warm-start cache and the time are state, not scene:
``World.save_state`` keeps those. The conversions themselves are ``signorini.codec``'s.

Limits (checked before the file is parsed, or as its values are read): the file is at most
``MAX_SCENE_BYTES`` (32 MiB); arrays, tables and dotted keys nest at most ``MAX_SCENE_DEPTH`` (32)
levels, found by a linear scan before the TOML parser runs; ``[scene] dt`` lies in [``MIN_DT``,
``MAX_DT``] = [1e-6, 1] s, ``steps`` in [0, ``MAX_STEPS``] = [0, 10^7], ``snapshot_times`` are finite
and >= 0; every other value is checked by the core as the World is built (finite poses and
velocities, positive sizes and masses...). A mesh ``file`` resolves (symlinks followed) inside the
scene file's folder, or inside a folder passed as ``read_scene(path, allow_paths=[...])``;
anything else (``..`` out of it, an absolute path elsewhere, a symlink leading out) is refused
with the same message whether or not that path exists.

Errors: a missing or malformed file, an unknown key (every table forbids extra keys), a wrong type,
an unknown material, a value the core rejects, a limit above or running out of memory or stack
each raise ``SceneFileError`` (a ValueError) naming the file, the key (``bodies[3].shape.radius``,
``joints[0].limits``), the body's or joint's name when it has one, and the problem. A joint's
types, shapes, NaN, limits lo > hi, an unknown joint type or body, the same body twice and two
static bodies are found before any world is built; the rest (a hinge's limits outside (-pi, pi),
a zero axis, a name taken) by the core as the joint is added.
No physics here: values are converted to the types the ``World`` facade takes; the core checks them.
"""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Dict, List, Literal, Optional, Tuple, Union


from pydantic import BaseModel, ConfigDict, Field, Strict, ValidationError, model_validator

from . import codec, filecheck, meshfile
from .joints import Distance, Fixed, Motor, Prismatic, Revolute, Spherical
from .world import World

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python < 3.11
    import tomli as tomllib

__all__ = ["Scene", "SceneFile", "SceneFileError", "ScenePathError", "load_scene", "read_scene", "save_scene",
           "scene_schema", "FORMAT", "SCHEMA_PATH", "schema_text"]

#: the format version this module writes (``format = 1`` at the top of a file)
FORMAT: Literal[1] = codec.SCENE_FORMAT

# limits (module doc): the largest shipped scene (1,200 bodies) is 0.23 MB, so 32 MiB holds over
# 100,000 bodies while bounding what the parser and the model may build
MAX_SCENE_BYTES = 32 * 2**20
# a compound part's vector is 6 levels deep (bodies, shape, parts, shape, key, array); 32 leaves room
# for hand-written layouts and stops the 50,000-deep keys and arrays that cost gigabytes or the stack
MAX_SCENE_DEPTH = 32
# time step bounds (s): below 1 us a run of MAX_STEPS covers 10 s; above 1 s contacts are not resolved
MIN_DT, MAX_DT = 1e-6, 1.0
# at most 10^7 steps in a run (11.6 h of simulated time at 1/240 s), so a run's length is bounded
MAX_STEPS = 10_000_000

# strict scalars: a number given as a string ("0.5") or a boolean given as 1 is an error, not a
# silent conversion (an int is still a float)
Float = Annotated[float, Strict()]
Int = Annotated[int, Strict()]
Bool = Annotated[bool, Strict()]
Str = Annotated[str, Strict()]
Vec3 = Tuple[Float, Float, Float]
Quat = Tuple[Float, Float, Float, Float]
Face = Tuple[Int, Int, Int]
Bits = Annotated[int, Strict(), Field(ge=0, le=0xFFFFFFFF)]


@dataclass
class Scene:
    """A world ready to run, with how to run it (what ``read_scene`` and ``read_mjcf`` give, and the
    built-in scenes of ``signorini.scenes``).

    Fields:
    - name: the registry name (str);
    - world: the ``signorini.World``, in its initial state (running the scene advances it);
    - dt: time step (s);
    - steps: number of steps of a full run (the simulated time is dt * steps);
    - description: one line for ``python -m signorini list`` and the plot title;
    - snapshot_times: times (s) of the 3-D snapshots in the plot, or None for evenly spaced ones;
    - names: one name per body (recorded trajectories, the player and the exports use them), or
      None for "<kind>_<index>".
    """

    name: str
    world: World
    dt: float
    steps: int
    description: str
    snapshot_times: Optional[Tuple[float, ...]] = None
    names: Optional[Tuple[str, ...]] = None

    @property
    def duration(self) -> float:
        """Simulated time of a full run (s)."""
        return self.dt * self.steps


class SceneFileError(ValueError):
    """A scene file that cannot be read: the message names the file, the key and the problem."""


class ScenePathError(SceneFileError):
    """A scene file naming a mesh file outside the folders it may be read from (its own and those
    in ``allow_paths``); a SceneFileError, told apart so that callers can say how to allow one."""


class _Table(BaseModel):
    # every table of the format rejects keys it does not know (typos do not pass silently)
    model_config = ConfigDict(extra="forbid")


# shapes ----------------------------------------------------------------------------------------
class SphereShape(_Table):
    """A ball of ``radius`` (m) centred on the body's origin."""
    type: Literal["sphere"]
    radius: Float


class BoxShape(_Table):
    """A box with ``half_extents`` (a, b, c) (m) along the body axes."""
    type: Literal["box"]
    half_extents: Vec3


class CapsuleShape(_Table):
    """A segment on the z axis from -half_length to +half_length, swept by a ball of ``radius`` (m)."""
    type: Literal["capsule"]
    radius: Float
    half_length: Float


class CylinderShape(_Table):
    """A cylinder of ``radius`` (m) on the z axis from -half_height to +half_height (m)."""
    type: Literal["cylinder"]
    radius: Float
    half_height: Float


class PlaneShape(_Table):
    """The half space n . x <= offset (static only); bodies live on the side n . x > offset."""
    type: Literal["plane"]
    normal: Vec3
    offset: Float = 0.0


class HullShape(_Table):
    """The convex hull (Qhull) of at least 4 points (n, 3) (m) that are not coplanar."""
    type: Literal["hull"]
    points: List[Vec3]


class _MeshData(_Table):
    file: Optional[Str] = Field(None, description="mesh file (.obj .stl .ply .off .glb .npz), relative to "
                                                   "the scene file's folder")
    scale: Float = Field(1.0, description="multiplies every coordinate of the file (e.g. 0.001 for mm)")
    vertices: Optional[List[Vec3]] = Field(None, description="inline vertices (n, 3), m (instead of file)")
    faces: Optional[List[Face]] = Field(None, description="inline triangles (k, 3), counter-clockwise seen from "
                                                          "outside (instead of file)")

    @model_validator(mode="after")
    def _file_or_inline(self):
        if (self.file is None) == (self.vertices is None and self.faces is None):
            raise ValueError("give either file or vertices and faces")
        if self.file is None and (self.vertices is None or self.faces is None):
            raise ValueError("inline meshes need both vertices and faces")
        return self


class MeshShape(_MeshData):
    """A closed triangle mesh (dynamic bodies; a non-convex one is decomposed into convex pieces)."""
    type: Literal["mesh"]


class TriangleMeshShape(_MeshData):
    """A triangle mesh for static bodies only (terrain, bowls, ramps); need not be closed."""
    type: Literal["trimesh"]


PartShape = Annotated[Union[SphereShape, BoxShape, CapsuleShape, CylinderShape, HullShape, MeshShape],
                      Field(discriminator="type")]


class CompoundPart(_Table):
    """One convex part of a compound: its shape and its pose in the compound frame."""
    shape: PartShape
    position: Vec3 = (0.0, 0.0, 0.0)
    orientation: Quat = (1.0, 0.0, 0.0, 0.0)
    rotation: Optional[Tuple[Vec3, Vec3, Vec3]] = Field(None, description="compound-from-part rotation matrix, "
                                                        "kept exactly (instead of orientation)")

    @model_validator(mode="after")
    def _orientation_or_rotation(self):
        if self.rotation is not None and "orientation" in self.model_fields_set:
            raise ValueError("give either orientation or rotation")
        return self


class CompoundShape(_Table):
    """Convex parts on one body; a dynamic compound is re-centred on its centre of mass."""
    type: Literal["compound"]
    parts: List[CompoundPart]


AnyShape = Annotated[Union[SphereShape, BoxShape, CapsuleShape, CylinderShape, PlaneShape, HullShape, MeshShape,
                           TriangleMeshShape, CompoundShape], Field(discriminator="type")]


# bodies, materials, world, scene ---------------------------------------------------------------
class Material(_Table):
    """Friction coefficient mu >= 0, restitution e in [0, 1] and spinning (torsional) friction mu_spin >= 0 \
(m); a contact uses sqrt(mu_A mu_B), max(e_A, e_B) and max(mu_spin_A, mu_spin_B)."""
    friction: Float = 0.5
    restitution: Float = 0.0
    spinning_friction: Float = Field(0.0, description="m: the torque about the normal at a contact that is its "
                                                      "body pair's only point is at most this times the normal force")


class Body(_Table):
    """One body: a static one never moves; a dynamic one takes exactly one of density and mass (a
    kinematic one may take neither)."""
    name: Optional[Str] = None
    shape: AnyShape
    static: Bool = False
    kinematic: Bool = Field(False, description="moved by its velocity only, pushing others as an infinite mass")
    density: Optional[Float] = Field(None, description="kg/m^3 (dynamic bodies)")
    mass: Optional[Float] = Field(None, description="kg (dynamic bodies)")
    inertia: Optional[Tuple[Vec3, Vec3, Vec3]] = Field(None, description="kg m^2 about the centre of mass, body "
                                                       "axes (with mass; the shape's origin is then the centre of mass)")
    material: Optional[Str] = Field(None, description="a name in [materials]")
    friction: Optional[Float] = Field(None, description="overrides the material's (default 0.5)")
    restitution: Optional[Float] = Field(None, description="overrides the material's (default 0)")
    spinning_friction: Optional[Float] = Field(None, description="overrides the material's (default 0, m)")
    position: Vec3 = Field((0.0, 0.0, 0.0), description="centre of mass, world, m")
    orientation: Quat = Field((1.0, 0.0, 0.0, 0.0), description="quaternion (w, x, y, z), world-from-body")
    velocity: Vec3 = Field((0.0, 0.0, 0.0), description="m/s, world")
    angular_velocity: Vec3 = Field((0.0, 0.0, 0.0), description="rad/s, world")
    force: Vec3 = Field((0.0, 0.0, 0.0), description="persistent external force at the centre of mass, N, world")
    torque: Vec3 = Field((0.0, 0.0, 0.0), description="persistent external torque, N m, world")
    group: Bits = Field(1, description="collision filter: the categories the body belongs to (32 bits)")
    mask: Bits = Field(0xFFFFFFFF, description="collision filter: the categories it collides with (32 bits)")
    enabled: Bool = Field(True, description="false: the body neither moves nor collides")
    can_sleep: Bool = Field(True, description="false: the body never sleeps, nor does any island it is in")
    sensor: Bool = Field(False, description="true: the body collides with nothing and reports its overlaps as "
                                            "sensor events")
    bullet: Bool = Field(False, description="true: continuous collision against the static bodies after every "
                                            "step, not only when the body moves fast")


# joints (docs/conventions.md, "Joints"; signorini.joints): what the Python API takes, in world
# coordinates at creation; values the format can check (finite, ordered, non-negative) are checked
# here, before any world is built, the rest by the core as the joint is added
Finite = Annotated[float, Strict(), Field(allow_inf_nan=False)]
FiniteVec3 = Tuple[Finite, Finite, Finite]
NonNegative = Annotated[float, Strict(), Field(ge=0.0, allow_inf_nan=False)]
# a bound that may be infinite (TOML's inf), never NaN
Bound = Annotated[float, Strict(), Field(ge=0.0)]
Positive = Annotated[float, Strict(), Field(gt=0.0)]
BodyRef = Union[Str, Annotated[int, Strict(), Field(ge=0)]]
JOINT_TYPES = ("revolute", "prismatic", "spherical", "fixed", "distance")


class JointMotor(_Table):
    """A hinge's or slider's drive (``signorini.Motor``): a velocity motor driving the joint
    velocity to ``speed`` with at most ``max_force`` (or ``max_torque``, the same; exactly one), or
    with ``stiffness`` or ``damping`` a spring-damper servo holding ``position``."""
    speed: Finite = Field(0.0, description="rad/s (hinge) or m/s (slider), the target velocity")
    max_force: Optional[Bound] = Field(None, description="N m (hinge) or N (slider), >= 0, may be inf")
    max_torque: Optional[Bound] = Field(None, description="the same as max_force, by another name")
    position: Finite = Field(0.0, description="rad or m, the servo's target (0 at creation)")
    stiffness: NonNegative = Field(0.0, description="N m / rad or N / m")
    damping: NonNegative = Field(0.0, description="N m s / rad or N s / m")

    @model_validator(mode="after")
    def _one_max(self):
        if (self.max_force is None) == (self.max_torque is None):
            raise ValueError("give max_force (or max_torque), once")
        return self


class _JointTable(_Table):
    name: Optional[Str] = None
    body_a: BodyRef = Field(description="a body's name in [[bodies]] (or its index); may be a static body")
    body_b: BodyRef = Field(description="a body's name in [[bodies]] (or its index); may be a static body")
    collide_connected: Bool = Field(False, description="true: the two bodies still collide with each other")
    break_force: Optional[Positive] = Field(None, description="N: the joint breaks after a step that loads it more "
                                                              "(absent: never)")
    break_torque: Optional[Positive] = Field(None, description="N m: the same for its torque (absent: never)")
    broken: Bool = Field(False, description="true: already broken (World.set_joint_broken)")


class _AxialJointTable(_JointTable):
    axis: FiniteVec3 = Field((0.0, 0.0, 1.0), description="world, at creation (normalised)")
    limits: Optional[Tuple[Finite, Finite]] = Field(None, description="(lower, upper): rad (hinge, in (-pi, pi)) "
                                                    "or m (slider), 0 at creation")
    motor: Optional[JointMotor] = None
    friction: NonNegative = Field(0.0, description="N m or N: Coulomb friction of the joint")
    effort: Finite = Field(0.0, description="N m or N applied along the joint's coordinate, on body_b")

    @model_validator(mode="after")
    def _ordered(self):
        if self.limits is not None and self.limits[0] > self.limits[1]:
            raise ValueError(f"limits need lower <= upper, got {list(self.limits)}")
        return self


class RevoluteJoint(_AxialJointTable):
    """A hinge: the bodies share ``anchor`` and body_b turns about ``axis`` only (world, at creation)."""
    type: Literal["revolute"]
    anchor: FiniteVec3 = Field(description="world, m, at creation")


class PrismaticJoint(_AxialJointTable):
    """A slider along ``axis`` (world, at creation); ``anchor`` defaults to body_b's centre of mass."""
    type: Literal["prismatic"]
    anchor: Optional[FiniteVec3] = Field(None, description="world, m, at creation")


class SphericalJoint(_JointTable):
    """A ball joint: the bodies share ``anchor`` (world, at creation); with ``axis`` (world, at
    creation), ``cone`` (rad, in (0, pi)): B's axis stays within that angle of A's, and ``twist``
    (rad, [lo, hi] in (-pi, pi)): B's turn about the axis relative to A, swing taken out."""
    type: Literal["spherical"]
    anchor: FiniteVec3 = Field(description="world, m, at creation")
    axis: Optional[FiniteVec3] = Field(None, description="the cone's and twist's axis, world, at creation")
    cone: Optional[Finite] = Field(None, description="swing limit, rad, in (0, pi) (with axis)")
    twist: Optional[Tuple[Finite, Finite]] = Field(None, description="twist limits [lo, hi], rad, in (-pi, pi) (with axis)")


class FixedJoint(_JointTable):
    """A weld; ``anchor`` (where its force is reported) defaults to body_b's centre of mass."""
    type: Literal["fixed"]
    anchor: Optional[FiniteVec3] = Field(None, description="world, m, at creation")


class DistanceJoint(_JointTable):
    """min_length <= |anchor_b - anchor_a| <= max_length for points on body_a and body_b (world, at
    creation); both absent: a rod of the current length, only max_length: a rope."""
    type: Literal["distance"]
    anchor_a: FiniteVec3 = Field(description="world, m, a point of body_a at creation")
    anchor_b: FiniteVec3 = Field(description="world, m, a point of body_b at creation")
    min_length: Optional[NonNegative] = Field(None, description="m (absent: 0, or the current length)")
    max_length: Optional[Bound] = Field(None, description="m, may be inf (absent: inf, or the current length)")

    @model_validator(mode="after")
    def _ordered(self):
        if self.min_length is not None and self.max_length is not None and self.min_length > self.max_length:
            raise ValueError(f"min_length must be <= max_length, got {self.min_length} > {self.max_length}")
        return self


AnyJoint = Annotated[Union[RevoluteJoint, PrismaticJoint, SphericalJoint, FixedJoint, DistanceJoint],
                     Field(discriminator="type")]


class WorldSettings(_Table):
    """The ``World`` constructor's keywords (see ``signorini.World``)."""
    gravity: Vec3 = (0.0, 0.0, -9.81)
    contact_margin: Float = 0.005
    erp: Float = 0.2
    tolerance: Float = 1e-6
    max_iterations: Int = 30
    slop: Float = 0.001
    max_push_velocity: Float = 1.0
    restitution_threshold: Float = 0.5
    friction_cone: Literal["pyramid", "cone"] = "pyramid"
    gyroscopic: Literal["midpoint", "implicit", "explicit"] = "midpoint"
    warm_start: Bool = True
    substeps: Int = 0
    warn_velocity: Float = 1.0
    solver: Literal["pgs", "soft"] = "pgs"
    contact_hertz: Float = 30.0
    damping_ratio: Float = 10.0
    soft_iterations: Int = 1
    relax_iterations: Int = 1
    # off when a file does not say (as sleeping): a scene file written before contact recycling
    # steps as it did; save_scene writes the world's value
    recycle_distance: Float = 0.0
    continuous: Bool = True
    joint_hertz: Float = 240.0
    joint_damping_ratio: Float = 2.0
    sleeping: Bool = False
    sleep_linear_velocity: Float = 0.05
    sleep_angular_velocity: Float = 0.05
    time_to_sleep: Float = 0.5


class SceneInfo(_Table):
    """How to run the scene: its name, a one-line description, the time step (s) and step count."""
    name: Optional[Str] = None
    description: Str = ""
    dt: Float = Field(1.0 / 240.0, ge=MIN_DT, le=MAX_DT, description="s, the suggested time step")
    steps: Int = Field(240, ge=0, le=MAX_STEPS, description="steps of a full run")
    snapshot_times: Optional[List[Annotated[float, Strict(), Field(ge=0.0, allow_inf_nan=False)]]] = None


class SceneFile(_Table):
    """A signorini scene file (TOML)."""
    model_config = ConfigDict(extra="forbid", title="signorini scene file")
    format: Literal[1] = FORMAT
    scene: SceneInfo = SceneInfo()
    world: WorldSettings = WorldSettings()
    materials: Dict[Str, Material] = {}
    bodies: List[Body] = []
    disabled_pairs: List[Tuple[Int, Int]] = Field([], description="pairs of body indices (in the order of "
                                                                  "[[bodies]]) that never collide")
    joints: List[AnyJoint] = Field([], description="joints in the order of their indices, made after every body "
                                                   "at the bodies' initial poses")


def scene_schema() -> dict:
    """The JSON Schema of scene files, generated from ``SceneFile``."""
    schema = SceneFile.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    return schema


# reading ---------------------------------------------------------------------------------------
def _key(loc) -> str:
    """('bodies', 3, 'shape', 'sphere', 'radius') -> 'bodies[3].shape.radius', ('joints', 0, 'revolute',
    'limits') -> 'joints[0].limits' (pydantic's union tags dropped)."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif part in ("sphere", "box", "capsule", "cylinder", "plane", "hull", "mesh", "trimesh", "compound") \
                and out.endswith("shape"):
            continue
        elif part in JOINT_TYPES and out.startswith("joints[") and out.endswith("]") and "." not in out:
            continue
        else:
            out += ("." if out else "") + str(part)
    return out or "(top level)"


def _parse(path: Path, overrides: Optional[dict] = None) -> tuple[SceneFile, dict]:
    """The validated model and the raw TOML dict of a file, with ``overrides`` (dotted paths,
    ``apply_overrides``) applied before validation; SceneFileError naming file and key. Size and
    depth are checked before the TOML parser runs (module doc, limits)."""
    if not path.is_file():
        raise FileNotFoundError(f"scene file {str(path)!r} does not exist" if not path.exists()
                                else f"scene file {str(path)!r} is not a file")
    try:
        filecheck.check_size(path, MAX_SCENE_BYTES)
        text = path.read_bytes().decode("utf-8")
        filecheck.toml_depth(text, MAX_SCENE_DEPTH)
        raw = tomllib.loads(text)
    except filecheck.FileLimitError as e:
        raise SceneFileError(f"scene file {str(path)!r}: {e}") from None
    except tomllib.TOMLDecodeError as e:
        raise SceneFileError(f"scene file {str(path)!r}: not valid TOML: {e}") from None
    except (OSError, UnicodeDecodeError) as e:
        raise SceneFileError(f"scene file {str(path)!r}: unreadable: {e}") from None
    except (RecursionError, MemoryError) as e:
        raise SceneFileError(f"scene file {str(path)!r}: out of memory or stack parsing it ({type(e).__name__})") \
            from None
    for dotted, value in (overrides or {}).items():
        apply_override(raw, dotted, value, f"scene file {str(path)!r}")
    try:
        model = SceneFile.model_validate(raw)
    except (RecursionError, MemoryError) as e:
        raise SceneFileError(f"scene file {str(path)!r}: out of memory or stack checking it ({type(e).__name__})") \
            from None
    except ValidationError as e:
        problems = []
        for err in e.errors():
            key = _key(err["loc"])
            name = _body_name(raw, err["loc"])
            problems.append(f"{key}{name}: {err['msg']}")
        more = f" (and {len(problems) - 1} more: {'; '.join(problems[1:4])})" if len(problems) > 1 else ""
        raise SceneFileError(f"scene file {str(path)!r}: {problems[0]}{more}") from None
    return model, raw


def apply_override(raw: dict, dotted: str, value, where: str) -> None:
    """Sets ``dotted`` (e.g. 'bodies.box.friction', 'world.gravity.2', 'materials.wood.friction',
    'joints.elbow.motor.speed', 'scene.dt') in a scene file's raw TOML dict to value. In ``bodies``
    and ``joints`` an entry is named by its ``name`` or its index; in other lists an index. The last key may be new (a body's friction the
    file left to its material); validation then checks it. SceneFileError naming the path and what
    is not there."""
    keys = dotted.split(".") if isinstance(dotted, str) else []
    if not keys or any(not k for k in keys):
        raise SceneFileError(f"{where}: parameter {dotted!r}: give a dotted path such as 'bodies.box.friction'")
    node = raw
    for depth, key in enumerate(keys):
        last = depth == len(keys) - 1
        here = ".".join(keys[:depth + 1])
        if isinstance(node, list):
            index = None
            if keys[0] in ("bodies", "joints") and depth == 1:
                named = [i for i, b in enumerate(node) if isinstance(b, dict) and b.get("name") == key]
                if named:
                    index = named[0]
            if index is None and key.lstrip("-").isdigit():
                index = int(key)
            if index is None or not -len(node) <= index < len(node):
                known = ", ".join(repr(b.get("name")) for b in node if isinstance(b, dict) and b.get("name")) \
                    if depth == 1 and keys[0] in ("bodies", "joints") else f"indices 0 to {len(node) - 1}"
                raise SceneFileError(f"{where}: parameter {dotted!r}: {here!r} is not there (known: {known or 'none'})")
            if last:
                node[index] = value
            else:
                node = node[index]
        elif isinstance(node, dict):
            if last:
                node[key] = value
            elif key not in node:
                known = ", ".join(sorted(map(str, node))) or "none"
                raise SceneFileError(f"{where}: parameter {dotted!r}: {here!r} is not there (known: {known})")
            else:
                node = node[key]
        else:
            raise SceneFileError(f"{where}: parameter {dotted!r}: {'.'.join(keys[:depth])!r} is a value, not a table")


def _body_name(raw: dict, loc) -> str:
    """' (body "name")' for an error inside a named body (' (joint "name")' in a joint), else ''."""
    if len(loc) >= 2 and loc[0] in ("bodies", "joints") and isinstance(loc[1], int):
        try:
            name = raw[loc[0]][loc[1]].get("name")
        except (KeyError, IndexError, AttributeError, TypeError):
            return ""
        if isinstance(name, str):
            return f" ({'body' if loc[0] == 'bodies' else 'joint'} {name!r})"
    return ""


def _mesh_reader(base: Path, allow_paths=()):
    """codec.shape_from_data's mesh reader: a ``file`` relative to base, inside base or one of
    allow_paths (module doc), or inline arrays."""
    def read(d: dict, where: str):
        if d.get("file") is not None:
            try:
                file = filecheck.inside(d["file"], base, [base, *allow_paths], "mesh file")
                return meshfile.read_mesh_arrays(file, d.get("scale", 1.0))
            except (FileNotFoundError, ValueError) as e:
                # the path rule's refusal keeps its type up to _read_scene (codec keeps it too)
                kind = filecheck.OutsideError if isinstance(e, filecheck.OutsideError) else ValueError
                raise kind(f"{where}.file: {e}") from None
        return codec.inline_mesh_arrays(d, where)
    return read


def read_scene(path, *, allow_paths=(), overrides: Optional[dict] = None):
    """The ``Scene`` of a scene file: its World (in the file's initial state), name (the
    [scene] name or the file's stem), dt, steps, description, snapshot times and body names
    (None when no body has one). Mesh files are read from inside the scene file's folder and the
    folders in ``allow_paths`` (paths) only. Limits in the module doc (file size, nesting depth,
    dt and steps bounds). ``overrides`` ({dotted path: value}, ``apply_override``) change the
    file's values before it is checked (what a sweep varies). Raises FileNotFoundError or
    SceneFileError naming the file, the key and the problem; nothing is half built."""
    path = Path(path)
    where_file = f"scene file {str(path)!r}"
    try:
        return _read_scene(path, [Path(a) for a in allow_paths], where_file, overrides)
    except (RecursionError, MemoryError) as e:
        raise SceneFileError(f"{where_file}: out of memory or stack building it ({type(e).__name__})") from None


def _joint_key(k: int, table) -> str:
    return f"joints[{k}]" + (f" ({table.name!r})" if table.name else "")


def _scene_joints(model: SceneFile, where_file: str) -> list:
    """The file's joints as ``signorini.joints`` descriptions with their ``broken`` flags, their
    bodies resolved from names (or indices) in [[bodies]]; SceneFileError naming the joint and the
    key for an unknown body, the same body twice or two static bodies (before any world is built)."""
    index = {}
    for i, body in enumerate(model.bodies):
        if body.name:
            index.setdefault(body.name, i)
    out = []
    for k, t in enumerate(model.joints):
        key = f"{where_file}: {_joint_key(k, t)}"
        ends = []
        for side in ("body_a", "body_b"):
            ref = getattr(t, side)
            i = index.get(ref) if isinstance(ref, str) else ref
            if i is None or i >= len(model.bodies):
                known = ", ".join(repr(n) for n in index) or "none"
                what = f"unknown body {ref!r} (known: {known})" if isinstance(ref, str) else \
                    f"body index {ref} is out of range: the file has {len(model.bodies)} bodies"
                raise SceneFileError(f"{key}: {side}: {what}")
            ends.append(i)
        a, b = ends
        if a == b:
            raise SceneFileError(f"{key}: body_b: body_a and body_b are the same body ({t.body_a!r}); give two bodies")
        if model.bodies[a].static and model.bodies[b].static:
            raise SceneFileError(f"{key}: body_b: both bodies are static ({t.body_a!r}, {t.body_b!r}): a joint needs "
                                 "one that moves")
        common = dict(name=t.name, break_force=t.break_force, break_torque=t.break_torque,
                      collide_connected=t.collide_connected)
        if isinstance(t, (RevoluteJoint, PrismaticJoint)):
            motor = None
            if t.motor is not None:
                m = t.motor
                motor = Motor(m.speed, m.max_force if m.max_force is not None else m.max_torque, position=m.position,
                              stiffness=m.stiffness, damping=m.damping)
            kind = Revolute if isinstance(t, RevoluteJoint) else Prismatic
            joint = kind(a, b, t.anchor, t.axis, limits=t.limits, motor=motor, friction=t.friction, effort=t.effort,
                         **common)
        elif isinstance(t, SphericalJoint):
            joint = Spherical(a, b, t.anchor, axis=t.axis, cone=t.cone, twist=t.twist, **common)
        elif isinstance(t, FixedJoint):
            joint = Fixed(a, b, t.anchor, **common)
        else:
            joint = Distance(a, b, t.anchor_a, t.anchor_b, t.min_length, t.max_length, **common)
        out.append((_joint_key(k, t), joint, t.broken))
    return out


def _read_scene(path: Path, allow_paths: list, where_file: str, overrides: Optional[dict] = None):
    model, _ = _parse(path, overrides)
    world, names = _build_world(model, path.parent, allow_paths, where_file)
    info = model.scene
    return Scene(
        name=info.name or path.stem, world=world, dt=info.dt, steps=info.steps, description=info.description,
        snapshot_times=tuple(info.snapshot_times) if info.snapshot_times is not None else None,
        names=tuple(n or f"body_{i}" for i, n in enumerate(names)) if any(names) else None)


def _build_world(model: SceneFile, base: Path, allow_paths: list, where_file: str) -> tuple:
    """The World of a checked file (its bodies, disabled pairs and joints, in that order) and its
    body names ("" for unnamed ones); SceneFileError naming the file, the key and the problem."""
    joints = _scene_joints(model, where_file)
    try:
        world = World(**model.world.model_dump())
    except (TypeError, ValueError) as e:
        raise SceneFileError(f"{where_file}: world: {e}") from None
    names: list[str] = []
    for i, body in enumerate(model.bodies):
        key = f"bodies[{i}]" + (f" ({body.name!r})" if body.name else "")
        try:
            shape = codec.shape_from_data(body.shape.model_dump(), _mesh_reader(base, allow_paths), "shape")
            if body.material is not None and body.material not in model.materials:
                known = ", ".join(sorted(model.materials)) or "none"
                raise ValueError(f"material: unknown material {body.material!r} (known: {known})")
            material = model.materials[body.material] if body.material is not None else Material()
            codec.add_scene_body(world, body.model_dump(exclude={"shape"}), shape, material.model_dump())
        except (TypeError, ValueError) as e:
            kind = ScenePathError if isinstance(e, filecheck.OutsideError) else SceneFileError
            raise kind(f"{where_file}: {key}: {e}") from None
        names.append(body.name if body.name else "")
    for k, (i, j) in enumerate(model.disabled_pairs):
        try:
            world.disable_collision(i, j)
        except (TypeError, ValueError) as e:
            raise SceneFileError(f"{where_file}: disabled_pairs[{k}]: {e}") from None
    for key, joint, broken in joints:
        try:
            j = world.add_joint(joint)
        except (TypeError, ValueError, IndexError) as e:
            raise SceneFileError(f"{where_file}: {key}: {e}") from None
        if broken:
            world.set_joint_broken(j, True)
    return world, names


def load_scene(path, *, allow_paths=()):
    """The World described by a scene file (see ``read_scene`` for the name, dt and steps too, the
    limits and ``allow_paths``, the folders besides the file's own that mesh files may be read from)."""
    return read_scene(path, allow_paths=allow_paths).world


# writing ---------------------------------------------------------------------------------------
def save_scene(world_or_scene, path) -> Path:
    """Writes a World (or a ``Scene``: its world with its name, dt, steps, description and
    body names) to a TOML scene file, and its meshes to ``<stem>.meshes/`` next to it; returns the
    path. ``load_scene(path)`` rebuilds it (bit-identical stepping; see the module doc)."""
    path = Path(path)
    if path.suffix.lower() != ".toml":
        raise ValueError(f"scene file {str(path)!r}: a scene file's name must end in .toml")
    if not isinstance(world_or_scene, World):
        if not isinstance(getattr(world_or_scene, "world", None), World):
            raise TypeError(f"save_scene: expected a World or a Scene, got {type(world_or_scene).__name__}")
        scene, world = world_or_scene, world_or_scene.world
        names = scene.names
        info: dict[str, Any] = {"name": scene.name, "description": scene.description, "dt": float(scene.dt),
                                "steps": int(scene.steps)}
        if scene.snapshot_times is not None:
            info["snapshot_times"] = [float(t) for t in scene.snapshot_times]
    else:
        world, info, names = world_or_scene, {}, None  # None: the world's own body names
    # what is written reads back (checked before the file is written)
    return codec.write_scene(world, path, info, names,
                             check=lambda document: SceneFile.model_validate(json.loads(json.dumps(document))))


#: the shipped JSON Schema (``python -m signorini.scenes`` writes it again; a test compares)
SCHEMA_PATH = Path(__file__).resolve().parent / "data" / "scene.schema.json"


def schema_text() -> str:
    """The JSON Schema as the shipped file holds it (sorted keys, 2-space indent, final newline)."""
    return json.dumps(scene_schema(), indent=2, sort_keys=True) + "\n"

