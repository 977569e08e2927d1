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

    [world]                      # World(...) keywords: gravity, contact_margin and the solver's
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

Shapes (``type``): ``sphere`` (radius), ``box`` (half_extents), ``capsule`` (radius, half_length),
``cylinder`` (radius, half_height), ``plane`` (normal, offset; static only), ``hull`` (points),
``mesh`` and ``trimesh`` (``file`` relative to the scene file's folder, with an optional ``scale``,
or inline ``vertices`` and ``faces``; ``trimesh`` is static only), ``compound`` (``parts``, each a
``shape`` with a ``position`` and ``orientation`` in the compound frame).

``load_scene(path)`` gives the World; ``read_scene(path)`` gives a ``scenes.Scene`` (the world with
its name, time step, step count, description and body names). ``save_scene(world or scene, path)``
writes a file and the mesh files it refers to (``<stem>.meshes/mesh_<k>.npz`` next to it, exact
float64 arrays with the convex pieces of decomposed meshes, so loading needs no decomposition).

Exactness: a body is written with the values it was added with (shape, density or mass, pose and
velocities) as long as its state is still the one it was added with, so loading a saved scene and
stepping it is bit-identical to stepping the original. A body that has moved since is written with
its current position and velocities (exact) and the quaternion of its rotation matrix (to the last
bit or two); so is a compound part with a turned pose (a Compound keeps its parts' rotation
matrices, not the quaternions they were given). The warm-start cache and the time are state, not scene: ``World.save_state`` keeps those.

Errors: a missing or malformed file, an unknown key (every table forbids extra keys), a wrong type,
an unknown material or a value the core rejects each raise ``SceneFileError`` (a ValueError) naming
the file, the key (``bodies[3].shape.radius``), the body's name when it has one, and the problem.
No physics here: values are converted to the types the ``World`` facade takes; the core checks them.
"""
from __future__ import annotations

import hashlib
import json
import re
import sys
from pathlib import Path
from typing import Annotated, Any, Dict, List, Literal, Optional, Tuple, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, Strict, ValidationError, model_validator

from . import meshfile
from ._core import Box, Capsule, Compound, ConvexHull, Cylinder, Mesh, Plane, Sphere, TriangleMesh

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python < 3.11
    import tomli as tomllib

__all__ = ["SceneFile", "SceneFileError", "load_scene", "read_scene", "save_scene", "scene_schema",
           "FORMAT", "SCHEMA_PATH", "schema_text"]

#: the format version this module writes (``format = 1`` at the top of a file)
FORMAT: Literal[1] = 1

# strict scalars: a number given as a string ("0.5") or a boolean given as 1 is an error, not a
# silent conversion (an int is still a float)
Float = Annotated[float, Strict()]
Int = Annotated[int, Strict()]
Bool = Annotated[bool, Strict()]
Str = Annotated[str, Strict()]
Vec3 = Tuple[Float, Float, Float]
Quat = Tuple[Float, Float, Float, Float]
Face = Tuple[Int, Int, Int]


class SceneFileError(ValueError):
    """A scene file that cannot be read: the message names the file, the key and the problem."""


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
    """One body: a static one never moves; a dynamic one takes exactly one of density and mass."""
    name: Optional[Str] = None
    shape: AnyShape
    static: Bool = False
    density: Optional[Float] = Field(None, description="kg/m^3 (dynamic bodies)")
    mass: Optional[Float] = Field(None, description="kg (dynamic bodies)")
    material: Optional[Str] = Field(None, description="a name in [materials]")
    friction: Optional[Float] = Field(None, description="overrides the material's (default 0.5)")
    restitution: Optional[Float] = Field(None, description="overrides the material's (default 0)")
    spinning_friction: Optional[Float] = Field(None, description="overrides the material's (default 0, m)")
    position: Vec3 = Field((0.0, 0.0, 0.0), description="centre of mass, world, m")
    orientation: Quat = Field((1.0, 0.0, 0.0, 0.0), description="quaternion (w, x, y, z), world-from-body")
    velocity: Vec3 = Field((0.0, 0.0, 0.0), description="m/s, world")
    angular_velocity: Vec3 = Field((0.0, 0.0, 0.0), description="rad/s, world")


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
    warn_velocity: Float = 0.01


class SceneInfo(_Table):
    """How to run the scene: its name, a one-line description, the time step (s) and step count."""
    name: Optional[Str] = None
    description: Str = ""
    dt: Float = 1.0 / 240.0
    steps: Int = 240
    snapshot_times: Optional[List[Float]] = None


class SceneFile(_Table):
    """A signorini scene file (TOML)."""
    model_config = ConfigDict(extra="forbid", title="signorini scene file")
    format: Literal[1] = FORMAT
    scene: SceneInfo = SceneInfo()
    world: WorldSettings = WorldSettings()
    materials: Dict[Str, Material] = {}
    bodies: List[Body] = []


def scene_schema() -> dict:
    """The JSON Schema of scene files, generated from ``SceneFile``."""
    schema = SceneFile.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    return schema


# reading ---------------------------------------------------------------------------------------
def _key(loc) -> str:
    """('bodies', 3, 'shape', 'sphere', 'radius') -> 'bodies[3].shape.radius' (pydantic's union
    tags dropped)."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif part in ("sphere", "box", "capsule", "cylinder", "plane", "hull", "mesh", "trimesh", "compound") \
                and out.endswith("shape"):
            continue
        else:
            out += ("." if out else "") + str(part)
    return out or "(top level)"


def _parse(path: Path) -> tuple[SceneFile, dict]:
    """The validated model and the raw TOML dict of a file; SceneFileError naming file and key."""
    if not path.is_file():
        raise FileNotFoundError(f"scene file {str(path)!r} does not exist" if not path.exists()
                                else f"scene file {str(path)!r} is not a file")
    try:
        with open(path, "rb") as f:
            raw = tomllib.load(f)
    except tomllib.TOMLDecodeError as e:
        raise SceneFileError(f"scene file {str(path)!r}: not valid TOML: {e}") from None
    except (OSError, UnicodeDecodeError) as e:
        raise SceneFileError(f"scene file {str(path)!r}: unreadable: {e}") from None
    try:
        model = SceneFile.model_validate(raw)
    except ValidationError as e:
        problems = []
        for err in e.errors():
            key = _key(err["loc"])
            name = _body_name(raw, err["loc"])
            problems.append(f"{key}{name}: {err['msg']}")
        more = f" (and {len(problems) - 1} more: {'; '.join(problems[1:4])})" if len(problems) > 1 else ""
        raise SceneFileError(f"scene file {str(path)!r}: {problems[0]}{more}") from None
    return model, raw


def _body_name(raw: dict, loc) -> str:
    """' (body "name")' for an error inside a named body, else ''."""
    if len(loc) >= 2 and loc[0] == "bodies" and isinstance(loc[1], int):
        try:
            name = raw["bodies"][loc[1]].get("name")
        except (KeyError, IndexError, AttributeError, TypeError):
            return ""
        if isinstance(name, str):
            return f" (body {name!r})"
    return ""


def _mesh_arrays(spec: _MeshData, base: Path, where: str):
    """(vertices, faces, pieces) of a mesh or trimesh spec (file relative to base, or inline)."""
    if spec.file is not None:
        file = Path(spec.file)
        file = file if file.is_absolute() else base / file
        try:
            return meshfile.read_mesh_arrays(file, spec.scale)
        except (FileNotFoundError, ValueError) as e:
            raise ValueError(f"{where}.file: {e}") from None
    vertices = np.array(spec.vertices, dtype=np.float64).reshape(-1, 3) * spec.scale
    return vertices, np.array(spec.faces, dtype=np.int64).reshape(-1, 3), []


def _build_shape(spec, base: Path, where: str):
    """A signorini shape object from a shape spec; ValueError prefixed by the key (``where``)."""
    try:
        if isinstance(spec, SphereShape):
            return Sphere(spec.radius)
        if isinstance(spec, BoxShape):
            return Box(spec.half_extents)
        if isinstance(spec, CapsuleShape):
            return Capsule(spec.radius, spec.half_length)
        if isinstance(spec, CylinderShape):
            return Cylinder(spec.radius, spec.half_height)
        if isinstance(spec, PlaneShape):
            return Plane(spec.normal, spec.offset)
        if isinstance(spec, HullShape):
            return ConvexHull(np.array(spec.points, dtype=np.float64).reshape(-1, 3))
        if isinstance(spec, MeshShape):
            vertices, faces, pieces = _mesh_arrays(spec, base, where)
            mesh = Mesh(vertices, faces)
            return mesh.with_pieces(pieces) if pieces else mesh
        if isinstance(spec, TriangleMeshShape):
            vertices, faces, _ = _mesh_arrays(spec, base, where)
            return TriangleMesh(vertices, faces)
        if isinstance(spec, CompoundShape):
            parts = [(_build_shape(p.shape, base, f"{where}.parts[{k}].shape"), (p.position, p.orientation))
                     for k, p in enumerate(spec.parts)]
            return Compound(parts)
    except (TypeError, ValueError) as e:
        message = str(e)
        raise ValueError(message if message.startswith(where) else f"{where}: {message}") from None
    raise TypeError(f"{where}: unknown shape spec {type(spec).__name__}")  # the model admits no other


def _world(model: SceneFile):
    from .world import World

    return World(**model.world.model_dump())


def read_scene(path):
    """The ``scenes.Scene`` of a scene file: its World (in the file's initial state), name (the
    [scene] name or the file's stem), dt, steps, description, snapshot times and body names
    (None when no body has one). Raises FileNotFoundError or SceneFileError naming the file, the
    key and the problem; nothing is half built."""
    from .scenes import Scene

    path = Path(path)
    model, _ = _parse(path)
    base = path.parent
    where_file = f"scene file {str(path)!r}"
    try:
        world = _world(model)
    except (TypeError, ValueError) as e:
        raise SceneFileError(f"{where_file}: world: {e}") from None
    names: list[str] = []
    for i, body in enumerate(model.bodies):
        key = f"bodies[{i}]" + (f" ({body.name!r})" if body.name else "")
        try:
            shape = _build_shape(body.shape, base, "shape")
            if body.material is not None and body.material not in model.materials:
                known = ", ".join(sorted(model.materials)) or "none"
                raise ValueError(f"material: unknown material {body.material!r} (known: {known})")
            material = model.materials[body.material] if body.material is not None else Material()
            friction = material.friction if body.friction is None else body.friction
            restitution = material.restitution if body.restitution is None else body.restitution
            spinning = material.spinning_friction if body.spinning_friction is None else body.spinning_friction
            # the body's name, into the world (find, errors naming the body)
            kwargs: dict[str, Any] = {"name": body.name} if body.name else {}
            if body.static:
                # checked here because add_static takes none of these (the world stays unchanged)
                for field in ("density", "mass"):
                    if getattr(body, field) is not None:
                        raise ValueError(f"{field}: a static body takes neither mass nor density")
                for field in ("velocity", "angular_velocity"):
                    if any(getattr(body, field)):
                        raise ValueError(f"{field}: a static body cannot have a velocity")
                world.add_static(shape, position=body.position, orientation=body.orientation, friction=friction,
                                 restitution=restitution, spinning_friction=spinning, **kwargs)
            else:
                world.add_body(shape, density=body.density, mass=body.mass, position=body.position,
                               orientation=body.orientation, velocity=body.velocity,
                               angular_velocity=body.angular_velocity, friction=friction, restitution=restitution,
                               spinning_friction=spinning, **kwargs)
        except (TypeError, ValueError) as e:
            raise SceneFileError(f"{where_file}: {key}: {e}") from None
        names.append(body.name if body.name else "")
    info = model.scene
    return Scene(
        name=info.name or path.stem, world=world, dt=info.dt, steps=info.steps, description=info.description,
        snapshot_times=tuple(info.snapshot_times) if info.snapshot_times is not None else None,
        names=tuple(n or f"body_{i}" for i, n in enumerate(names)) if any(names) else None)


def load_scene(path):
    """The World described by a scene file (see ``read_scene`` for the name, dt and steps too)."""
    return read_scene(path).world


# writing ---------------------------------------------------------------------------------------
class _MeshWriter:
    """Writes each distinct mesh once, as <stem>.meshes/mesh_<k>.npz next to the scene file."""

    def __init__(self, path: Path):
        self.folder = path.parent / f"{path.stem}.meshes"
        self.written: dict[str, str] = {}

    def __call__(self, vertices, faces, pieces=()) -> str:
        h = hashlib.sha256()
        for a in (np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(faces, dtype=np.int64),
                  *[np.ascontiguousarray(p, dtype=np.float64) for p in pieces]):
            h.update(str(a.shape).encode())
            h.update(a.tobytes())
        digest = h.hexdigest()
        if digest not in self.written:
            if not self.written:
                self.folder.mkdir(parents=True, exist_ok=True)
            name = f"mesh_{len(self.written)}.npz"
            meshfile.write_npz_mesh(self.folder / name, vertices, faces, pieces)
            self.written[digest] = f"{self.folder.name}/{name}"
        return self.written[digest]


def _floats(a) -> list:
    return [float(x) for x in np.asarray(a, dtype=np.float64).ravel()]


def _shape_table(shape, meshes: _MeshWriter) -> dict:
    """A shape object as its TOML table (meshes written to files)."""
    if isinstance(shape, Sphere):
        return {"type": "sphere", "radius": float(shape.radius)}
    if isinstance(shape, Box):
        return {"type": "box", "half_extents": _floats(shape.half_extents)}
    if isinstance(shape, Capsule):
        return {"type": "capsule", "radius": float(shape.radius), "half_length": float(shape.half_length)}
    if isinstance(shape, Cylinder):
        return {"type": "cylinder", "radius": float(shape.radius), "half_height": float(shape.half_height)}
    if isinstance(shape, Plane):
        return {"type": "plane", "normal": _floats(shape.normal), "offset": float(shape.offset)}
    if isinstance(shape, ConvexHull):
        return {"type": "hull", "points": [_floats(p) for p in np.asarray(shape.vertices)]}
    if isinstance(shape, Mesh):
        return {"type": "mesh", "file": meshes(shape.vertices, shape.faces, list(shape.pieces))}
    if isinstance(shape, TriangleMesh):
        return {"type": "trimesh", "file": meshes(shape.vertices, shape.faces)}
    if isinstance(shape, Compound):
        return {"type": "compound", "parts": [
            {"shape": _shape_table(part, meshes), "position": _floats(pos), "orientation": _floats(q)}
            for part, (pos, q) in shape.parts]}
    raise TypeError(f"not a signorini shape: {shape!r}")


def _rotation_of(quaternions: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotation matrices the core makes of (N, 4) quaternions, read back from a scratch world."""
    from .world import World

    scratch = World()
    scratch.add_static(Sphere(1.0))
    out = np.empty((len(quaternions), 3, 3))
    for k, q in enumerate(quaternions):
        scratch.set_orientation(0, q)
        out[k] = scratch.rotations[0]
    return out


def _body_tables(world, meshes: _MeshWriter, names) -> list[dict]:
    """One TOML table per body: the values it was added with while its state is unchanged, its
    current state otherwise (see the module doc)."""
    n = world.num_bodies
    given = getattr(world, "_given", None)
    if given is not None and len(given) != n:
        given = None
    p, R, v, w = world.positions, world.rotations, world.velocities, world.angular_velocities
    q_now, static, masses = world.orientations, world.is_static, world.masses
    frictions, restitutions, spinning = world.frictions, world.restitutions, world.spinning_frictions
    unchanged = np.zeros(n, dtype=bool)
    if given is not None and n:
        R_given = _rotation_of(np.array([g.orientation for g in given]))
        for i, g in enumerate(given):
            unchanged[i] = (np.array_equal(p[i], g.position) and np.array_equal(v[i], g.velocity)
                            and np.array_equal(w[i], g.angular_velocity) and np.array_equal(R[i], R_given[i]))
    bodies = []
    for i in range(n):
        table: dict[str, Any] = {}
        if names is not None and names[i]:
            table["name"] = str(names[i])
        if given is not None:
            g = given[i]
            shape = g.shape
        else:
            # no record of what was given: the core's shape (re-centred) and mass
            shape = world.shape(i)
        table["shape"] = _shape_table(shape, meshes)
        if static[i]:
            table["static"] = True
        elif given is not None:
            table.update({"density": float(g.density)} if g.density is not None else {"mass": float(g.mass)})
        else:
            table["mass"] = float(masses[i])
        # the defaults (friction 0.5, restitution 0, spinning friction 0, identity orientation, zero
        # velocities) are left out
        if float(frictions[i]) != 0.5:
            table["friction"] = float(frictions[i])
        if not _is_zero(restitutions[i]):
            table["restitution"] = float(restitutions[i])
        if not _is_zero(spinning[i]):
            table["spinning_friction"] = float(spinning[i])
        if unchanged[i]:
            position, orientation = g.position, g.orientation
            velocity, angular_velocity = g.velocity, g.angular_velocity
        else:
            position, orientation, velocity, angular_velocity = p[i], q_now[i], v[i], w[i]
        table["position"] = _floats(position)
        if not (orientation[0] == 1.0 and not np.signbit(orientation[0]) and _is_zero(orientation[1:])):
            table["orientation"] = _floats(orientation)
        for key, value in (("velocity", velocity), ("angular_velocity", angular_velocity)):
            if not _is_zero(value):
                table[key] = _floats(value)
        bodies.append(table)
    return bodies


# an array of scalars that tomli-w spread over lines: "[\n    1.0,\n    2.0,\n]" (no brackets inside)
_SPREAD_ARRAY = re.compile(r"\[\n((?:[ \t]*[^\[\]\n]*,\n)+)[ \t]*\]")


def _compact_arrays(text: str) -> str:
    """tomli-w's output with every array of scalars on one line ([1.0, 2.0, 3.0]); an array of
    arrays keeps one inner array per line. Strings never hold a raw newline in tomli-w's output,
    so the pattern only meets arrays."""
    return _SPREAD_ARRAY.sub(lambda m: "[" + ", ".join(x.strip().rstrip(",") for x in m.group(1).splitlines()) + "]",
                             text)


def _is_zero(a) -> bool:
    """True when every component is +0.0 (the file's default; -0.0 is written out)."""
    a = np.asarray(a, dtype=np.float64)
    return not np.any(a != 0.0) and not np.any(np.signbit(a))


def save_scene(world_or_scene, path) -> Path:
    """Writes a World (or a ``scenes.Scene``: its world with its name, dt, steps, description and
    body names) to a TOML scene file, and its meshes to ``<stem>.meshes/`` next to it; returns the
    path. ``load_scene(path)`` rebuilds it (bit-identical stepping; see the module doc)."""
    import tomli_w

    from .world import World

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
        world, info = world_or_scene, {}
        # the world's body names
        names = [world.name(i) for i in range(world.num_bodies)] if hasattr(world, "name") else None
    settings = {"gravity": _floats(world.gravity), "contact_margin": float(world._core.contact_margin),
                **world.solver}
    meshes = _MeshWriter(path)
    document = {"format": FORMAT, "scene": info, "world": settings, "bodies": _body_tables(world, meshes, names)}
    if not info:
        del document["scene"]
    header = "# signorini scene file: python -m signorini run <this file>; format in signorini.scenefile\n"
    text = header + _compact_arrays(tomli_w.dumps(document))
    SceneFile.model_validate(json.loads(json.dumps(document)))  # what is written reads back
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


#: the shipped JSON Schema (``python -m signorini.scenes`` writes it again; a test compares)
SCHEMA_PATH = Path(__file__).resolve().parent / "data" / "scene.schema.json"


def schema_text() -> str:
    """The JSON Schema as the shipped file holds it (sorted keys, 2-space indent, final newline)."""
    return json.dumps(scene_schema(), indent=2, sort_keys=True) + "\n"

