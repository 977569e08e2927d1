"""Export a recorded run to the formats other tools read: glTF 2.0 binary (.glb) and USD (.usda).

Both take a ``trajectory.Record`` and need no simulator:

- ``write_gltf(path, record)`` (pygltflib): one node per body (nodes 0..N-1, in body order), named
  as the body, holding its draw mesh (body-frame vertices, m, as float32) and its frame-0 pose;
  one animation ("motion") with a translation and a rotation channel per dynamic body, linear
  samplers over the frame times (s, float32); rotations as glTF quaternions (x, y, z, w). Static
  bodies are plain nodes. The bodies are children of a root node "world" (node N) whose rotation
  turns the simulator's up (against gravity) onto glTF's +Y, so Blender and web viewers show the
  scene upright while the body nodes keep the simulator's world-frame poses: keyframes equal the
  trajectory within float32 rounding.
- ``write_usd(path, record)`` (usd-core): a stage with ``/World``, one ``Xform`` per body
  (``/World/<name>``) with ``xformOp:translate`` (double3, m) and ``xformOp:orient`` (quatd, w x y
  z) time-sampled at every frame, time code = the frame's step number, ``timeCodesPerSecond`` =
  1 / dt; a child ``Mesh`` prim ``geom`` with the body-frame draw mesh and a display colour. The
  stage's up axis is the world axis nearest to -gravity, metersPerUnit 1.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .output import up_direction
from .render import body_colours
from .trajectory import Record

__all__ = ["write_gltf", "write_usd"]


def write_gltf(path, record: Record) -> Path:
    """Write the run as a binary glTF 2.0 file (.glb); see the module docstring. Returns the path."""
    import pygltflib as g

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    blob = bytearray()
    views, accessors = [], []

    def add(array: np.ndarray, target=None, minmax=False) -> int:
        """Append an array to the binary buffer as a view and an accessor; returns the accessor index."""
        data = np.ascontiguousarray(array)
        while len(blob) % 4:
            blob.append(0)
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=data.nbytes, target=target))
        blob.extend(data.tobytes())
        kind = {1: g.SCALAR, 3: g.VEC3, 4: g.VEC4}[1 if data.ndim == 1 else data.shape[1]]
        component = g.FLOAT if data.dtype == np.float32 else g.UNSIGNED_INT
        accessor = g.Accessor(bufferView=len(views) - 1, componentType=component, count=len(data), type=kind)
        if minmax:
            accessor.min = data.min(axis=0).tolist() if data.ndim > 1 else [float(data.min())]
            accessor.max = data.max(axis=0).tolist() if data.ndim > 1 else [float(data.max())]
        accessors.append(accessor)
        return len(accessors) - 1

    colours = body_colours(record)
    nodes, meshes_, materials = [], [], []
    for i in range(record.num_bodies):
        vertices, faces = record.draw_meshes[i]
        node = g.Node(name=record.names[i],
                      translation=[float(x) for x in record.positions[0, i]],
                      rotation=[float(x) for x in record.orientations[0, i][[1, 2, 3, 0]]])
        if len(faces):
            position = add(vertices.astype(np.float32), g.ARRAY_BUFFER, minmax=True)
            indices = add(faces.astype(np.uint32).ravel(), g.ELEMENT_ARRAY_BUFFER)
            materials.append(g.Material(
                name=f"{record.names[i]}_material", doubleSided=bool(record.is_static[i]),
                pbrMetallicRoughness=g.PbrMetallicRoughness(
                    baseColorFactor=[c / 255.0 for c in colours[i]] + [1.0], metallicFactor=0.0, roughnessFactor=0.8)))
            meshes_.append(g.Mesh(name=record.names[i], primitives=[g.Primitive(
                attributes=g.Attributes(POSITION=position), indices=indices, material=len(materials) - 1)]))
            node.mesh = len(meshes_) - 1
        nodes.append(node)

    # a root turning the simulator's up onto glTF's +Y
    nodes.append(g.Node(name="world", children=list(range(record.num_bodies)),
                        rotation=[float(x) for x in _rotation_onto(up_direction(record), np.array([0.0, 1.0, 0.0]))]))

    # the motion: one translation and one rotation channel per dynamic body
    animation = g.Animation(name="motion", channels=[], samplers=[])
    if record.frames > 1:
        times = add(record.time.astype(np.float32), minmax=True)
        for i in record.dynamic:
            for path_name, values in (("translation", record.positions[:, i]),
                                      ("rotation", record.orientations[:, i][:, [1, 2, 3, 0]])):
                animation.samplers.append(g.AnimationSampler(
                    input=times, output=add(values.astype(np.float32)), interpolation="LINEAR"))
                animation.channels.append(g.AnimationChannel(
                    sampler=len(animation.samplers) - 1, target=g.AnimationChannelTarget(node=i, path=path_name)))

    gltf = g.GLTF2(
        asset=g.Asset(generator="signorini", version="2.0"),
        scene=0, scenes=[g.Scene(name=record.scene, nodes=[len(nodes) - 1])],
        nodes=nodes, meshes=meshes_, materials=materials, accessors=accessors, bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob))],
        animations=[animation] if animation.channels else [],
    )
    gltf.set_binary_blob(bytes(blob))
    gltf.save_binary(str(path))
    return path


def _rotation_onto(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The shortest rotation taking unit vector a onto unit vector b, as a quaternion (x, y, z, w)."""
    axis = np.cross(a, b)
    c = float(a @ b)
    if c < -1.0 + 1e-12:
        # opposite: half a turn about any axis perpendicular to a
        perpendicular = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return np.append(perpendicular / np.linalg.norm(perpendicular), 0.0)
    q = np.append(axis, 1.0 + c)
    return q / np.linalg.norm(q)


def write_usd(path, record: Record) -> Path:
    """Write the run as a USD stage (.usda text, or .usd / .usdc); see the module docstring."""
    from pxr import Gf, Sdf, Usd, UsdGeom, Vt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists():
        path.unlink()  # CreateNew refuses to overwrite
    stage = Usd.Stage.CreateNew(str(path))
    up = up_direction(record)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z if abs(up[2]) >= abs(up[1]) else UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    codes = record.frame_step.astype(float)
    stage.SetStartTimeCode(float(codes[0]))
    stage.SetEndTimeCode(float(codes[-1]))
    stage.SetTimeCodesPerSecond(1.0 / record.dt if record.dt > 0 else 1.0)
    root = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(root.GetPrim())

    colours = body_colours(record)
    for i in range(record.num_bodies):
        name = Sdf.Path.IsValidIdentifier(record.names[i]) and record.names[i] or f"body_{i}"
        xform = UsdGeom.Xform.Define(stage, f"/World/{name}")
        translate = xform.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble)
        orient = xform.AddOrientOp(UsdGeom.XformOp.PrecisionDouble)
        frames = range(record.frames) if not record.is_static[i] else [0]
        for f in frames:
            code = Usd.TimeCode(float(codes[f])) if not record.is_static[i] else Usd.TimeCode.Default()
            p, q = record.positions[f, i], record.orientations[f, i]
            translate.Set(Gf.Vec3d(*map(float, p)), code)
            orient.Set(Gf.Quatd(float(q[0]), Gf.Vec3d(*map(float, q[1:]))), code)

        vertices, faces = record.draw_meshes[i]
        mesh = UsdGeom.Mesh.Define(stage, f"/World/{name}/geom")
        mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, v)) for v in vertices]))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(faces)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray([int(x) for x in faces.ravel()]))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateDoubleSidedAttr(bool(record.is_static[i]))
        mesh.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*[c / 255.0 for c in colours[i]])]))
    stage.GetRootLayer().Save()
    return path
