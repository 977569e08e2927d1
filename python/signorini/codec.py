"""The codec: shapes, bodies and rotations to and from plain data, written once for the whole package.

Shapes have two dict forms:

- arrays (``shape_to_dict``): the oracle's input and ``World.snapshot``'s. Vectors and meshes are
  float64 / int64 arrays; a compound's parts are (part dict, position (3,), compound-from-part
  rotation (3, 3)) exactly as the core holds them.
- data (``shape_to_data``, ``shape_from_data``): floats and lists, what TOML and JSON hold (scene
  files, trajectories, fuzzer scenes). A compound's parts are {"shape", "position" (3,),
  "orientation" (4,) w x y z}; a hull is its "points"; a mesh or triangle mesh is a "file" (scene
  files, through ``mesh_file``) or, without one, its sizes (trajectories keep the geometry as draw
  meshes).

Bodies: ``BodyArgs`` (what ``add_body`` was given), ``body_models`` (what a world holds per body),
``scene_bodies`` / ``add_scene_body`` (a body as a scene file's table and back; whatever a table
cannot hold is refused, naming the body and the property) and ``write_scene`` (a world as a TOML
scene file and its mesh files). Rotations: ``quat_to_matrix`` / ``matrix_to_quat``, the core's own
maths (bound from C++), so a matrix made here equals ``World.rotations`` to the bit.

No physics, and no import of ``World``: worlds are read through their public properties.
"""
from __future__ import annotations

import hashlib
import re
from pathlib import Path
from typing import Any, Callable, NamedTuple, Optional

import numpy as np

from . import _core, meshfile
from ._core import Box, Capsule, Compound, ConvexHull, Cylinder, Mesh, Plane, Sphere, TriangleMesh

__all__ = ["quat_to_matrix", "matrix_to_quat", "shape_kind", "shape_to_dict", "shape_to_data", "shape_from_data",
           "inline_mesh_arrays", "BodyArgs", "body_models", "MeshFiles", "scene_bodies", "add_scene_body",
           "scene_document", "write_scene", "SCENE_FORMAT"]

# rotations ------------------------------------------------------------------------------------
#: (3, 3) world-from-body matrix of a quaternion (4,) w x y z, normalised first as the World does
quat_to_matrix = _core.quat_to_matrix
#: unit quaternion (4,) w x y z, w >= 0, of a rotation matrix (3, 3)
matrix_to_quat = _core.matrix_to_quat


# shapes ---------------------------------------------------------------------------------------
_KINDS = {Sphere: "sphere", Box: "box", Plane: "plane", Mesh: "mesh", Capsule: "capsule", Cylinder: "cylinder",
          ConvexHull: "hull", TriangleMesh: "trimesh", Compound: "compound"}


def shape_kind(shape) -> str:
    """The "type" of a shape: sphere, box, plane, mesh, capsule, cylinder, hull, trimesh or compound.
    Objects that are not core shapes are told apart by their attributes (drawing code and tests
    pass look-alikes); TypeError when none fits."""
    kind = _KINDS.get(type(shape))
    if kind is not None:
        return kind
    if hasattr(shape, "parts"):
        return "compound"
    if hasattr(shape, "half_length"):
        return "capsule"
    if hasattr(shape, "half_height"):
        return "cylinder"
    if hasattr(shape, "vertices") and hasattr(shape, "faces"):
        return {"convexhull": "hull", "trianglemesh": "trimesh"}.get(type(shape).__name__.lower(), "mesh")
    if hasattr(shape, "half_extents"):
        return "box"
    if hasattr(shape, "radius"):
        return "sphere"
    if hasattr(shape, "normal") and hasattr(shape, "offset"):
        return "plane"
    raise TypeError(f"not a signorini shape: {shape!r}")


def shape_to_dict(shape) -> dict:
    """A shape in the arrays form, the oracle's ({"type": "sphere", "radius": r}, ...; module doc)."""
    kind = shape_kind(shape)
    if kind == "sphere":
        return {"type": "sphere", "radius": shape.radius}
    if kind == "box":
        return {"type": "box", "half_extents": np.array(shape.half_extents)}
    if kind == "plane":
        return {"type": "plane", "normal": np.array(shape.normal), "offset": shape.offset}
    if kind == "capsule":
        return {"type": "capsule", "radius": shape.radius, "half_length": shape.half_length}
    if kind == "cylinder":
        return {"type": "cylinder", "radius": shape.radius, "half_height": shape.half_height}
    if kind == "compound":
        return {"type": "compound", "parts": [(shape_to_dict(s), np.array(pos), R.copy())
                                              for (s, (pos, _)), R in zip(shape.parts, shape.rotations)]}
    d = {"type": kind, "vertices": np.array(shape.vertices), "faces": np.array(shape.faces)}
    if kind == "mesh" and getattr(shape, "pieces", None):
        d["pieces"] = [np.array(p) for p in shape.pieces]  # convex pieces' hull vertices (n_i, 3)
    return d


def floats(a) -> list:
    """An array-like as a flat list of Python floats."""
    return [float(x) for x in np.asarray(a, dtype=np.float64).ravel()]


def shape_to_data(shape, mesh_file: Optional[Callable] = None, exact: bool = False) -> dict:
    """A shape in the data form (module doc). ``mesh_file(vertices, faces, pieces) -> str`` names
    the file a mesh or triangle mesh is written to (hulls are then written as points); without it
    meshes, hulls and triangle meshes give their sizes (num_vertices, num_faces). ``exact``: a
    compound part whose quaternion would not give back its rotation matrix to the bit is written
    with its "rotation" (3, 3) instead (scene files)."""
    kind = shape_kind(shape)
    if kind == "sphere":
        return {"type": "sphere", "radius": float(shape.radius)}
    if kind == "box":
        return {"type": "box", "half_extents": floats(shape.half_extents)}
    if kind == "capsule":
        return {"type": "capsule", "radius": float(shape.radius), "half_length": float(shape.half_length)}
    if kind == "cylinder":
        return {"type": "cylinder", "radius": float(shape.radius), "half_height": float(shape.half_height)}
    if kind == "plane":
        return {"type": "plane", "normal": floats(shape.normal), "offset": float(shape.offset)}
    if kind == "compound":
        parts = []
        for k, (part, (pos, q)) in enumerate(shape.parts):
            d = {"shape": shape_to_data(part, mesh_file, exact), "position": floats(pos)}
            if exact and not np.array_equal(quat_to_matrix(q), shape.rotations[k]):
                d["rotation"] = [floats(row) for row in shape.rotations[k]]
            else:
                d["orientation"] = floats(q)
            parts.append(d)
        return {"type": "compound", "parts": parts}
    if mesh_file is None:
        return {"type": kind, "num_vertices": int(len(shape.vertices)), "num_faces": int(len(shape.faces))}
    if kind == "hull":
        return {"type": "hull", "points": [floats(p) for p in np.asarray(shape.vertices)]}
    pieces = list(shape.pieces) if kind == "mesh" else []
    return {"type": kind, "file": mesh_file(shape.vertices, shape.faces, pieces)}


def inline_mesh_arrays(d: dict, where: str = "shape"):
    """(vertices (n, 3), faces (k, 3), pieces []) of a data-form mesh given inline ("vertices",
    "faces", an optional "scale")."""
    if d.get("vertices") is None or d.get("faces") is None:
        raise ValueError("inline meshes need both vertices and faces")
    scale = d.get("scale", 1.0)
    vertices = np.array(d["vertices"], dtype=np.float64).reshape(-1, 3) * scale
    return vertices, np.array(d["faces"], dtype=np.int64).reshape(-1, 3), []


def shape_from_data(d: dict, mesh_arrays: Callable = inline_mesh_arrays, where: str = "shape"):
    """The shape of a data-form dict; ``mesh_arrays(d, where) -> (vertices, faces, pieces)`` reads
    a mesh or triangle mesh (inline by default; scene files resolve files). ValueError / TypeError
    prefixed by the key ``where`` (``shape.parts[2].shape: ...``)."""
    kind = d.get("type")
    try:
        if kind == "sphere":
            return Sphere(d["radius"])
        if kind == "box":
            return Box(d["half_extents"])
        if kind == "capsule":
            return Capsule(d["radius"], d["half_length"])
        if kind == "cylinder":
            return Cylinder(d["radius"], d["half_height"])
        if kind == "plane":
            return Plane(d["normal"], d.get("offset", 0.0))
        if kind == "hull":
            return ConvexHull(np.array(d["points"], dtype=np.float64).reshape(-1, 3))
        if kind == "mesh":
            vertices, faces, pieces = mesh_arrays(d, where)
            mesh = Mesh(vertices, faces)
            return mesh.with_pieces(pieces) if pieces else mesh
        if kind == "trimesh":
            vertices, faces, _ = mesh_arrays(d, where)
            return TriangleMesh(vertices, faces)
        if kind == "compound":
            # a part's "rotation" (3, 3), when given, is its exact matrix (instead of the quaternion)
            return Compound([(shape_from_data(p["shape"], mesh_arrays, f"{where}.parts[{k}].shape"),
                              (p.get("position", (0.0, 0.0, 0.0)),
                               p["rotation"] if p.get("rotation") is not None
                               else p.get("orientation", (1.0, 0.0, 0.0, 0.0))))
                             for k, p in enumerate(d["parts"])])
    except (TypeError, ValueError) as e:
        message = str(e)
        raise type(e)(message if message.startswith(where) else f"{where}: {message}") from None
    raise ValueError(f"{where}: unknown shape type {kind!r}")


# bodies ---------------------------------------------------------------------------------------
class BodyArgs(NamedTuple):
    """What ``World.add_body`` / ``add_static`` was given for a body, as converted (the shape after
    any decomposition): a scene file writes a body that has not moved with exactly these."""
    shape: object
    density: Optional[float]
    mass: Optional[float]
    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    inertia: Optional[np.ndarray] = None  # (3, 3), given with mass


class JointArgs(NamedTuple):
    """What a joint was made from (World.joint_args): world coordinates at creation, and the poses
    of its bodies then."""
    anchor: np.ndarray      # (3,) m, the shared point (a Distance joint's point on A)
    anchor_b: np.ndarray    # (3,) m, a Distance joint's point on B (unused by the others)
    axis: np.ndarray        # (3,) a hinge's or slider's axis as given (the core normalises it)
    positions: np.ndarray   # (2, 3) m, the centres of mass of body_a and body_b at creation
    rotations: np.ndarray   # (2, 3, 3) their world-from-body rotation matrices at creation


#: the body-frame values the core makes of a joint's description at its bodies' poses
JOINT_FRAMES = ("anchor_a", "anchor_b", "axis_a", "axis_b", "ref_a", "ref_b", "R_rel")


def joint_key(d: dict) -> bytes:
    """A joint (``World.joint``'s dict) as bytes: its two bodies (16 bytes) and its body-frame
    values, which never change while the joint lives (equal exactly when every bit is)."""
    bodies = np.array([d["body_a"], d["body_b"]], dtype=np.int64)
    return bodies.tobytes() + b"".join(np.ascontiguousarray(d[k], dtype=np.float64).tobytes() for k in JOINT_FRAMES)


def body_models(world) -> list[dict]:
    """Per body, what the world holds of its model: static, kinematic, enabled, can_sleep, sensor, bullet (bool),
    mass (kg), inertia (3, 3), friction, restitution, spinning_friction, name, group, mask. Linear in N."""
    masses, inertias, statics, kinematic = world.masses, world.inertias, world.is_static, world.is_kinematic
    can_sleep, sensor, bullet = world.can_sleep, world.is_sensor, world.is_bullet
    enabled, (groups, masks), names = world.enabled, world.collision_filters, world.names
    frictions, restitutions, spinning = world.frictions, world.restitutions, world.spinning_frictions
    return [{"static": bool(statics[i]), "kinematic": bool(kinematic[i]), "enabled": bool(enabled[i]),
             "can_sleep": bool(can_sleep[i]), "sensor": bool(sensor[i]), "bullet": bool(bullet[i]),
             "mass": float(masses[i]), "inertia": np.array(inertias[i]), "friction": float(frictions[i]),
             "restitution": float(restitutions[i]), "spinning_friction": float(spinning[i]), "name": names[i],
             "group": int(groups[i]), "mask": int(masks[i])} for i in range(world.num_bodies)]


def is_zero(a) -> bool:
    """True when every component is +0.0 (a file's default; -0.0 is written out)."""
    a = np.asarray(a, dtype=np.float64)
    return not np.any(a != 0.0) and not np.any(np.signbit(a))


DEFAULT_GROUP, DEFAULT_MASK = 1, 0xFFFFFFFF


def scene_bodies(world, mesh_file: Callable, names=None) -> list[dict]:
    """One scene-file table per body (keys as ``scenefile.Body``; defaults left out). A body whose
    state is still the one it was added with is written with the values it was given (bit-identical
    stepping after loading); one that has moved with its current state (module doc of scenefile).
    Kinematic and enabled flags, explicit inertia, filter bits and the persistent wrench are
    written; a pending impulse or one-step force is refused (ValueError naming the body)."""
    n = world.num_bodies
    p, R, v, w = world.positions, world.rotations, world.velocities, world.angular_velocities
    q_now = world.orientations
    forces, torques = world.forces, world.torques
    # a torque comes only with its force, an angular impulse with its impulse (at a point)
    pending = ((("step_forces", "step_torques"), "a force for the next step only (apply_force)"),
               (("impulses", "angular_impulses"), "a pending impulse (apply_impulse)"))
    for attributes, what in pending:
        held = np.zeros(n, dtype=bool)
        for attribute in attributes:
            held |= np.any(getattr(world, attribute) != 0.0, axis=1)
        if held.any():
            raise ValueError(f"{world.label(int(np.argmax(held)))}: {what} cannot be written to a scene file; "
                             "step the world first, or keep it with save_state")
    models = body_models(world)
    bodies = []
    for i, model in enumerate(models):
        given = world.body_args(i)
        table: dict[str, Any] = {}
        if names is not None and names[i]:
            table["name"] = str(names[i])
        # no record of what was given (an old pickle): the core's shape (re-centred), mass and inertia
        table["shape"] = shape_to_data(given.shape if given is not None else world.shape(i), mesh_file, exact=True)
        if model["static"]:
            table["static"] = True
        if model["kinematic"]:
            table["kinematic"] = True
        if given is not None:
            if given.density is not None:
                table["density"] = float(given.density)
            if given.mass is not None:
                table["mass"] = float(given.mass)
            if given.inertia is not None:
                table["inertia"] = [floats(row) for row in given.inertia]
        elif not model["static"] and np.isfinite(model["mass"]):
            table["mass"] = model["mass"]
            table["inertia"] = [floats(row) for row in model["inertia"]]
        # the defaults (friction 0.5, restitution 0, spinning friction 0, identity orientation, zero
        # velocities and wrench, group 1, every mask bit, enabled) are left out
        if model["friction"] != 0.5:
            table["friction"] = model["friction"]
        if not is_zero(model["restitution"]):
            table["restitution"] = model["restitution"]
        if not is_zero(model["spinning_friction"]):
            table["spinning_friction"] = model["spinning_friction"]
        unchanged = given is not None and (
            np.array_equal(p[i], given.position) and np.array_equal(v[i], given.velocity)
            and np.array_equal(w[i], given.angular_velocity)
            and np.array_equal(R[i], quat_to_matrix(given.orientation)))
        if unchanged:
            position, orientation = given.position, given.orientation
            velocity, angular_velocity = given.velocity, given.angular_velocity
        else:
            position, orientation, velocity, angular_velocity = p[i], q_now[i], v[i], w[i]
        table["position"] = floats(position)
        if not (orientation[0] == 1.0 and not np.signbit(orientation[0]) and is_zero(orientation[1:])):
            table["orientation"] = floats(orientation)
        for key, value in (("velocity", velocity), ("angular_velocity", angular_velocity), ("force", forces[i]),
                           ("torque", torques[i])):
            if not is_zero(value):
                table[key] = floats(value)
        if model["group"] != DEFAULT_GROUP:
            table["group"] = model["group"]
        if model["mask"] != DEFAULT_MASK:
            table["mask"] = model["mask"]
        if not model["enabled"]:
            table["enabled"] = False
        if not model["can_sleep"]:
            table["can_sleep"] = False
        if model.get("sensor"):
            table["sensor"] = True
        if model.get("bullet"):
            table["bullet"] = True
        bodies.append(table)
    return bodies


def add_scene_body(world, table: dict, shape, material: dict) -> int:
    """Adds the body of a scene-file table (keys as ``scenefile.Body``, defaults filled) with its
    built ``shape`` and ``material`` ({"friction", "restitution", "spinning_friction"}, the table's
    own values win); returns its index. ValueError / TypeError naming the key; on an error the
    world is unchanged."""
    friction, restitution, spinning = (material[k] if table.get(k) is None else table[k]
                                       for k in ("friction", "restitution", "spinning_friction"))
    common = dict(position=table["position"], orientation=table["orientation"], friction=friction,
                  restitution=restitution, spinning_friction=spinning, group=table["group"], mask=table["mask"],
                  enabled=table["enabled"])
    if table.get("name"):
        common["name"] = table["name"]
    force, torque = table["force"], table["torque"]
    if table["static"]:
        # checked here because add_static takes none of these (the world stays unchanged)
        for key in ("density", "mass", "inertia"):
            if table.get(key) is not None:
                raise ValueError(f"{key}: a static body takes neither mass, density nor inertia")
        if table["kinematic"]:
            raise ValueError("kinematic: a static body cannot be kinematic")
        for key in ("velocity", "angular_velocity", "force", "torque"):
            if any(table[key]):
                raise ValueError(f"{key}: a static body cannot have a {key.replace('_', ' ')}")
        return world.add_static(shape, sensor=table.get("sensor", False), **common)
    i = world.add_body(shape, density=table.get("density"), mass=table.get("mass"), inertia=table.get("inertia"),
                       velocity=table["velocity"], angular_velocity=table["angular_velocity"],
                       kinematic=table["kinematic"], can_sleep=table.get("can_sleep", True),
                       sensor=table.get("sensor", False), bullet=table.get("bullet", False), **common)
    if any(force) or any(torque):
        try:
            world.set_external_wrench(i, force, torque)
        except (TypeError, ValueError):
            world.remove_body(i)
            raise
    return i


# scene files ----------------------------------------------------------------------------------
#: the scene-file format version written (``format = 1``)
SCENE_FORMAT = 1


class MeshFiles:
    """A ``mesh_file`` for ``shape_to_data``: writes each distinct mesh once, as
    ``<stem>.meshes/mesh_<k>.npz`` next to the scene file, and returns its relative name."""

    def __init__(self, path: Path):
        self.folder = Path(path).parent / f"{Path(path).stem}.meshes"
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


def scene_document(world, path, info: Optional[dict] = None, names=None) -> dict:
    """A world as a scene file's document (format, [scene] info when given, [world], bodies,
    disabled pairs, joints); writes the mesh files next to ``path``."""
    settings = {"gravity": floats(world.gravity), "contact_margin": float(world.contact_margin), **world.solver,
                **world.sleep}
    if settings["continuous"]:  # the default, as files written before continuous collision read
        del settings["continuous"]
    document: dict[str, Any] = {"format": SCENE_FORMAT}
    if info:
        document["scene"] = info
    document["world"] = settings
    document["bodies"] = scene_bodies(world, MeshFiles(Path(path)), names)
    pairs = [[int(i), int(j)] for i, j in world.disabled_pairs]
    if pairs:
        document["disabled_pairs"] = pairs
    joints = scene_joints(world, document["bodies"])
    if joints:
        document["joints"] = joints
    return document


def scene_joints(world, bodies: list[dict]) -> list[dict]:
    """One scene-file table per joint (keys as ``scenefile``'s joint tables; defaults left out),
    with the anchors and axis it was made from (``World.joint_args``), its bodies by the names in
    ``bodies`` (their scene-file tables, ``scene_bodies``) when unique, else by index. A file makes
    a joint after its bodies, at their poses in the file: a joint is written only when those are,
    bit for bit, its bodies' poses when it was made, so that it loads bit for bit; otherwise (its
    bodies have moved since, and its angle, offset or drift would be lost; or what it was made from
    is unknown) ValueError naming it."""
    names = [table.get("name", "") for table in bodies]
    unique = {n for n in names if n and names.count(n) == 1}
    tables = []
    for j in range(world.num_joints):
        d, given = world.joint(j), world.joint_args(j)
        kind, a, b = d["kind"], d["body_a"], d["body_b"]
        axial = kind in ("Revolute", "Prismatic")
        # where the file puts its bodies: the position and the orientation's matrix the core makes
        at = [(np.asarray(bodies[i]["position"]), quat_to_matrix(np.asarray(bodies[i].get("orientation",
                                                                                        (1.0, 0.0, 0.0, 0.0)))))
              for i in (a, b)]
        if given is None or not all(np.array_equal(x, given.positions[k]) and np.array_equal(R, given.rotations[k])
                                    for k, (x, R) in enumerate(at)):
            why = "what it was made from is unknown (an old pickle)" if given is None else \
                "its bodies have moved since it was made (its angle, offset or drift would be lost)"
            raise ValueError(f"{world._core.joint_label(j)}: a scene file makes a joint from world coordinates at "
                             f"its bodies' poses in the file, and {why}; write the world before stepping it, or "
                             "keep it with save_state() or pickle")
        ref = {i: (names[i] if names[i] in unique else int(i)) for i in (a, b)}
        table: dict[str, Any] = {}
        if d["name"]:
            table["name"] = d["name"]
        table.update(type=kind.lower(), body_a=ref[a], body_b=ref[b])
        if kind == "Distance":
            table.update(anchor_a=floats(given.anchor), anchor_b=floats(given.anchor_b),
                         min_length=float(d["min_length"]))
            if d["max_length"] != np.inf:
                table["max_length"] = float(d["max_length"])
        else:
            table["anchor"] = floats(given.anchor)
        if axial:
            table["axis"] = floats(given.axis)
            if d["has_limits"]:
                table["limits"] = [float(d["lower"]), float(d["upper"])]
            if d["motor"]:
                table["motor"] = {k: float(d[f"motor_{k}"]) for k in ("speed", "max_force", "position", "stiffness",
                                                                      "damping")
                                  if k in ("speed", "max_force") or not is_zero(d[f"motor_{k}"])}
            for key in ("friction", "effort"):
                if not is_zero(d[key]):
                    table[key] = float(d[key])
        elif kind == "Spherical" and (d["has_limits"] or d["has_twist"]):
            table["axis"] = floats(given.axis)
            if d["has_limits"]:
                table["cone"] = float(d["upper"])
            if d["has_twist"]:
                table["twist"] = [float(d["twist_lower"]), float(d["twist_upper"])]
        for key in ("break_force", "break_torque"):
            if d[key] != np.inf:
                table[key] = float(d[key])
        if d["collide_connected"]:
            table["collide_connected"] = True
        if d["broken"]:
            table["broken"] = True
        tables.append(table)
    return tables


# an array of scalars that tomli-w spread over lines: "[\n    1.0,\n    2.0,\n]" (no brackets inside)
_SPREAD_ARRAY = re.compile(r"\[\n((?:[ \t]*[^\[\]\n]*,\n)+)[ \t]*\]")


def _compact_arrays(text: str) -> str:
    """tomli-w's output with every array of scalars on one line ([1.0, 2.0, 3.0]); an array of
    arrays keeps one inner array per line. Strings never hold a raw newline in tomli-w's output,
    so the pattern only meets arrays."""
    return _SPREAD_ARRAY.sub(lambda m: "[" + ", ".join(x.strip().rstrip(",") for x in m.group(1).splitlines()) + "]",
                             text)


def write_scene(world, path, info: Optional[dict] = None, names=None,
                check: Optional[Callable[[dict], Any]] = None) -> Path:
    """Writes a world to a TOML scene file (and its meshes to ``<stem>.meshes/``); returns the
    path. ``check(document)`` runs before the file is written (scenefile validates against its
    model). ValueError for a name not ending in .toml or a body or joint the format cannot hold."""
    import tomli_w

    path = Path(path)
    if path.suffix.lower() != ".toml":
        raise ValueError(f"scene file {str(path)!r}: a scene file's name must end in .toml")
    if names is None:
        names = world.names
    document = scene_document(world, path, info, names)
    if check is not None:
        check(document)
    header = "# signorini scene file: python -m signorini run <this file>; format in signorini.scenefile\n"
    text = header + _compact_arrays(tomli_w.dumps(document))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path
