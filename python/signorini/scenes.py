"""Built-in scenes, written once and used by the command line, the tests and the benchmarks.

Each built-in scene is a scene file shipped in the package (``signorini/data/scenes/<name>.toml``,
meshes in ``<name>.meshes/``; format in ``signorini.scenefile``). ``SCENES`` maps a name to its
file and ``build(name)`` reads it into a fresh ``Scene`` (a new ``World`` each time, so scenes can
be run side by side). A scene file is the whole scene as data: every body with its pose, the
random clouds and piles as drawn, and the convex pieces of decomposed meshes, so a scene is the
same on every machine and with every numpy or CoACD version, loads without decomposing anything,
and a user can read or copy it. The generators below wrote the files once
(``python -m signorini.scenes`` writes them again); a test checks the shipped files against them.

Scenes:
- ``torus`` (the default): the CSC417 rigid-body assignment setting. A torus mesh tumbles onto a
  static plane tilted 45 degrees (normal normalize(0.7, 0.7, 0) through (0, -0.1, 0)) under
  gravity (0, -0.98, 0), lands, wobbles down flat and slides down the slope against friction 0.5
  (the default, on both bodies) at g (sin 45 - 0.5 cos 45) = 0.3465 m/s^2.
- ``boxes``: boxes and spheres dropped on the ground plane z = 0 under gravity (0, 0, -9.81);
  two spheres meet head on, one lands on a box, one on another sphere.
- ``shapes``: every collidable shape on a triangle-mesh floor.
- ``pile``: 100 mixed bodies of every dynamic shape type dropped into a walled pit (the solver's
  energy and rest acceptance scene), with spinning friction ``PILE_SPINNING_FRICTION``.
- ``pyramid``: 210 unit boxes of 1 kg stacked in a pyramid with a base row of 20, 1 mm apart in a
  row, on the ground z = 0 (the solver's stacking acceptance scene; 10 s).
- ``rain``: 1,000 spheres and 200 boxes rained from a grid into a walled bin (5 s).
- ``hull_pile``: 200 convex hulls of seeded random 16-point clouds dropped into a walled bin (5 s).

The last three are the scenes of ``benchmarks/bench_solver.py``; their builders (``pyramid``,
``rain``, ``hull_pile``) take sizes as keywords, so tests can build small versions, and every body
and the ground carry friction 0.5, restitution 0 and no spinning friction (pybullet's default,
so the two engines solve the same problem). The benchmark mirrors the built world (shapes,
poses, masses) into pybullet, so each scene is written only here.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Callable

import numpy as np

from . import meshes
from ._core import Box, Capsule, Compound, ConvexHull, Cylinder, Mesh, Plane, Sphere, TriangleMesh
from .scenefile import SCHEMA_PATH, Scene, read_scene, save_scene, schema_text
from .world import World

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python < 3.11
    import tomli as tomllib

__all__ = ["Scene", "SCENES", "GENERATORS", "SCENE_DIR", "build", "scene_info", "write_scene_files", "DEFAULT_SCENE",
           "axis_angle_quaternion", "pyramid", "rain", "hull_pile"]

DEFAULT_SCENE = "torus"


def axis_angle_quaternion(axis, angle: float) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of a rotation by angle (rad) about axis (3,) (any length > 0)."""
    a = np.asarray(axis, dtype=np.float64)
    # plain IEEE arithmetic, not np.linalg.norm: its BLAS kernel differs by CPU, and the shipped
    # scene files must be what this gives on any machine
    a = a / math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    s = math.sin(0.5 * angle)
    return (math.cos(0.5 * angle), s * a[0], s * a[1], s * a[2])


def _torus() -> Scene:
    """The CSC417 assignment setting: a torus dropped onto a tilted plane, gravity -0.98 y."""
    # the tilted ground: normal normalize(0.7, 0.7, 0) through the point (0, -0.1, 0)
    normal = np.array([0.7, 0.7, 0.0]) / np.linalg.norm([0.7, 0.7, 0.0])
    offset = float(normal @ np.array([0.0, -0.1, 0.0]))  # -0.0707 m: the origin is 0.0707 m above
    # a 1 mm contact margin: the default 5 mm is a third of this small torus's tube radius, and
    # would keep five rings of hovering vertices as speculative contacts once it lies flat
    # substeps=1: the assignment's stepping, one solve per step of 1/240 s. The landing of a tumbling
    # torus is chaotic: with the default substeps of 1/960 s it comes down on its rim and rolls
    # down the slope instead of lying flat (energy falls either way)
    world = World(gravity=(0.0, -0.98, 0.0), contact_margin=0.001, substeps=1)
    world.add_static(Plane(normal=tuple(normal), offset=offset))

    # a torus of outer radius R + r = 0.055 m < 0.0707 m clears the plane in any orientation
    R, r = 0.04, 0.015
    vertices, faces = meshes.torus(R, r, n_major=32, n_minor=16)

    # tilt its axis 50 degrees about the downhill direction (1, -1, 0) and make it tumble
    world.add_body(
        Mesh(vertices, faces),
        density=1000.0,
        position=(0.0, 0.0, 0.0),
        orientation=axis_angle_quaternion((1.0, -1.0, 0.0), math.radians(50.0)),
        velocity=(0.0, 0.0, 0.0),
        angular_velocity=(1.5, -0.5, 3.0),
    )
    return Scene(
        name="torus",
        world=world,
        dt=1.0 / 240.0,
        steps=1200,
        description="torus mesh tumbles onto a 45-degree plane (CSC417 setting), g = 0.98 m/s^2, "
        "friction 0.5: it lands, wobbles down flat and slides down at g (sin 45 - 0.5 cos 45) = 0.3465 m/s^2",
        snapshot_times=(0.0, 0.3, 0.9, 2.0, 5.0),
        names=("ground", "torus"),
    )


def _boxes() -> Scene:
    """Boxes and spheres dropped on the ground z = 0; two spheres meet head on."""
    world = World(gravity=(0.0, 0.0, -9.81))
    world.add_static(Plane(normal=(0.0, 0.0, 1.0), offset=0.0))

    # a cube tilted onto its edge, and a long flat box spinning as it falls
    world.add_body(
        Box(half_extents=(0.2, 0.2, 0.2)),
        density=500.0,
        position=(0.0, 0.0, 0.5),
        orientation=axis_angle_quaternion((1.0, 1.0, 0.0), math.radians(30.0)),
    )
    world.add_body(
        Box(half_extents=(0.4, 0.2, 0.1)),
        density=500.0,
        position=(1.2, -0.2, 0.4),
        orientation=axis_angle_quaternion((0.0, 0.0, 1.0), math.radians(20.0)),
        angular_velocity=(2.0, 0.0, 1.0),
    )

    # two equal spheres sliding towards each other: they meet near x = 0, y = 1
    world.add_body(Sphere(radius=0.15), mass=1.0, position=(-1.0, 1.0, 0.6), velocity=(1.5, 0.0, 0.0))
    world.add_body(Sphere(radius=0.15), mass=1.0, position=(1.0, 1.0, 0.6), velocity=(-1.5, 0.0, 0.0))

    # a small sphere dropped on the cube, and one dropped off-centre on a resting sphere
    world.add_body(Sphere(radius=0.1), mass=0.5, position=(0.05, 0.0, 1.4))
    world.add_body(Sphere(radius=0.2), mass=2.0, position=(-1.0, -1.0, 0.2))
    world.add_body(Sphere(radius=0.12), mass=0.5, position=(-0.93, -1.0, 1.2))

    return Scene(
        name="boxes",
        world=world,
        dt=1.0 / 240.0,
        steps=480,
        description="two boxes and five spheres dropped on the ground, g = 9.81 m/s^2; "
        "spheres meet head on and land on a box and on a sphere",
        snapshot_times=(0.0, 0.3, 0.6, 1.0, 2.0),
        names=("ground", "tilted_cube", "flat_box", "sphere_left", "sphere_right", "small_sphere",
               "resting_sphere", "falling_sphere"),
    )


def _shapes() -> Scene:
    """Every collidable of the lecture on a tessellated floor: a stack of boxes, a capsule, a
    cylinder, a convex hull, a compound (a table) and a torus decomposed into convex pieces."""

    world = World(gravity=(0.0, 0.0, -9.81), contact_margin=0.002)
    # the floor: a 2 m x 2 m static triangle mesh of 8 x 8 cells (128 triangles)
    n, s = 8, 1.0
    grid = np.linspace(-s, s, n + 1)
    vertices = np.array([(x, y, 0.0) for x in grid for y in grid])
    faces = []
    for i in range(n):
        for j in range(n):
            a, b = i * (n + 1) + j, (i + 1) * (n + 1) + j
            faces += [(a, b, b + 1), (a, b + 1, a + 1)]
    world.add_static(TriangleMesh(vertices, np.array(faces)))

    # a stack of three boxes, each turned a little about the vertical
    for k in range(3):
        world.add_body(Box((0.1, 0.1, 0.1)), density=500.0, position=(-0.5, -0.5, 0.1 + 0.2 * k + 0.001 * k),
                       orientation=axis_angle_quaternion((0.0, 0.0, 1.0), math.radians(15.0 * k)))
    # a capsule dropped lying, a cylinder dropped standing, a hull tumbling
    world.add_body(Capsule(0.05, 0.15), density=500.0, position=(0.4, -0.5, 0.3),
                   orientation=axis_angle_quaternion((0.0, 1.0, 0.0), math.radians(90.0)))
    world.add_body(Cylinder(0.08, 0.1), density=500.0, position=(0.0, -0.5, 0.3))
    rng = np.random.default_rng(7)
    world.add_body(ConvexHull(rng.normal(size=(20, 3)) * 0.08), density=500.0, position=(0.5, 0.4, 0.4),
                   angular_velocity=(1.0, 2.0, 0.0))
    # a compound table: a top and four legs
    legs = [(Box((0.02, 0.02, 0.1)), ((sx * 0.12, sy * 0.12, -0.1), (1, 0, 0, 0))) for sx in (-1, 1) for sy in (-1, 1)]
    world.add_body(Compound([(Box((0.15, 0.15, 0.02)), ((0.0, 0.0, 0.02), (1, 0, 0, 0)))] + legs),
                   density=500.0, position=(-0.4, 0.4, 0.3))
    # a torus (non-convex: decomposed by CoACD, cached) falling onto a ball
    world.add_body(Sphere(0.06), density=500.0, position=(0.0, 0.3, 0.06))
    v, f = meshes.torus(0.12, 0.035, 32, 16)
    world.add_body(Mesh(v, f), density=500.0, position=(0.0, 0.3, 0.4),
                   orientation=axis_angle_quaternion((1.0, 0.0, 0.0), math.radians(20.0)))
    return Scene(
        name="shapes",
        world=world,
        dt=1.0 / 240.0,
        steps=720,
        description="boxes stacked three high, a capsule, a cylinder, a convex hull, a compound table and a "
        "decomposed torus on a triangle-mesh floor, g = 9.81 m/s^2",
        snapshot_times=(0.0, 0.3, 1.0, 3.0),
        names=("floor", "box_bottom", "box_middle", "box_top", "capsule", "cylinder", "hull", "table", "ball",
               "torus"),
    )


#: the pile's spinning (torsional) friction, m: the largest torque about the normal, (3 pi / 16) mu a
#: alpha_n, that friction mu = 0.5 gives over a Hertzian contact patch of radius a = 1.7 mm. The
#: pile's 1 kg ball (radius 8 cm) makes a patch of about 0.5 mm under its own weight in wood, 0.8 mm
#: in hard plastic, 6 mm in rubber: this is a soft plastic. Without it a ball of the pile can be
#: left spinning about the vertical for good (its one contact point has no lever arm about n).
PILE_SPINNING_FRICTION = 0.0005


def _pile() -> Scene:
    """100 bodies of every dynamic shape type (spheres, boxes, capsules, cylinders, convex hulls,
    convex meshes, compounds, decomposed tori) dropped from a 5 x 5 x 4 grid into a 1.6 m square pit
    walled by static boxes, friction 0.5, spinning friction ``PILE_SPINNING_FRICTION``, no
    restitution."""
    world = World(gravity=(0.0, 0.0, -9.81))
    spin = PILE_SPINNING_FRICTION
    _walled_bin(world, half_width=0.8, height=1.0, thickness=0.1, friction=0.5, spinning_friction=spin)
    rng = np.random.default_rng(2026)
    ico_v, ico_f = meshes.icosphere(0.09, 1)
    torus_v, torus_f = meshes.torus(0.09, 0.03, 24, 12)
    legs = [(Box((0.015, 0.015, 0.05)), ((sx * 0.07, sy * 0.07, -0.05), (1, 0, 0, 0)))
            for sx in (-1, 1) for sy in (-1, 1)]

    def shape(k: int) -> object:
        kind = k % 8
        if kind == 0:
            return Sphere(0.08)
        if kind == 1:
            return Box((0.09, 0.07, 0.05))
        if kind == 2:
            return Capsule(0.05, 0.07)
        if kind == 3:
            return Cylinder(0.07, 0.05)
        if kind == 4:
            return ConvexHull(rng.normal(size=(16, 3)) * 0.06)
        if kind == 5:
            return Mesh(ico_v, ico_f)
        if kind == 6:
            return Compound([(Box((0.09, 0.09, 0.015)), ((0.0, 0.0, 0.015), (1, 0, 0, 0)))] + legs)
        return Mesh(torus_v, torus_f)

    k = 0
    for layer in range(4):
        for i in range(5):
            for j in range(5):
                world.add_body(
                    shape(k), density=500.0,
                    position=(-0.56 + 0.28 * i, -0.56 + 0.28 * j, 0.25 + 0.3 * layer),
                    orientation=axis_angle_quaternion(rng.normal(size=3), rng.uniform(0.0, math.pi)),
                    velocity=tuple(rng.uniform(-0.5, 0.5, size=3)),
                    angular_velocity=tuple(rng.uniform(-2.0, 2.0, size=3)),
                    spinning_friction=spin,
                )
                k += 1
    return Scene(
        name="pile",
        world=world,
        dt=1.0 / 240.0,
        steps=2400,
        description="100 spheres, boxes, capsules, cylinders, hulls, convex meshes, compound tables and "
        f"decomposed tori dropped into a walled pit, g = 9.81 m/s^2, friction 0.5, spinning friction "
        f"{spin * 1000:g} mm",
        snapshot_times=(0.0, 0.4, 1.0, 3.0, 10.0),
    )


def _walled_bin(world, half_width: float, height: float, thickness: float, friction: float,
                spinning_friction: float = 0.0) -> None:
    """The ground plane z = 0 and four static box walls around the square |x|, |y| < half_width,
    ``thickness`` (m) thick and ``height`` (m) high; friction and spinning friction as given,
    restitution 0."""
    world.add_static(Plane(normal=(0.0, 0.0, 1.0), offset=0.0), friction=friction, restitution=0.0,
                     spinning_friction=spinning_friction)
    for axis in (0, 1):
        for side in (-1.0, 1.0):
            half = [half_width + thickness, half_width + thickness, 0.5 * height]
            half[axis] = 0.5 * thickness
            centre = [0.0, 0.0, 0.5 * height]
            centre[axis] = side * (half_width + 0.5 * thickness)
            world.add_static(Box(tuple(half)), position=tuple(centre), friction=friction, restitution=0.0,
                             spinning_friction=spinning_friction)


def _grid(count: int, half_width: float, spacing: float, z0: float) -> list[tuple[float, float, float]]:
    """``count`` grid points (x, y, z) filling layers of the square |x|, |y| <= half_width - spacing/2
    at ``spacing`` (m), from height z0 up: the layer, then the row, then the column varies slowest."""
    per_row = max(1, int((2.0 * half_width) // spacing))
    start = -0.5 * spacing * (per_row - 1)
    points = []
    for k in range(count):
        layer, rest = divmod(k, per_row * per_row)
        i, j = divmod(rest, per_row)
        points.append((start + spacing * i, start + spacing * j, z0 + spacing * layer))
    return points


def pyramid(base: int = 20, gap: float = 0.001, friction: float = 0.5) -> Scene:
    """A pyramid of unit boxes (half extents 0.5 m, 1 kg) on the ground z = 0: rows of base,
    base - 1, ..., 1 boxes, each row centred on x = 0 with ``gap`` (m) between neighbours and
    resting exactly on the row below (210 boxes for base 20), friction ``friction``, restitution 0.
    Nothing moves if the solver holds the stack: every box should stay where it starts (10 s)."""
    world = World(gravity=(0.0, 0.0, -9.81))
    world.add_static(Plane(normal=(0.0, 0.0, 1.0), offset=0.0), friction=friction, restitution=0.0)
    for row in range(base):
        m = base - row
        for j in range(m):
            world.add_body(Box((0.5, 0.5, 0.5)), mass=1.0,
                           position=((j - 0.5 * (m - 1)) * (1.0 + gap), 0.0, 0.5 + row),
                           friction=friction, restitution=0.0)
    return Scene(
        name="pyramid",
        world=world,
        dt=1.0 / 240.0,
        steps=2400,
        description=f"{base * (base + 1) // 2} unit boxes of 1 kg in a pyramid with a base row of {base}, "
        f"{gap * 1000:g} mm apart, on the ground, friction {friction:g}; it should stand still",
        snapshot_times=(0.0, 1.0, 5.0, 10.0),
    )


def rain(spheres: int = 1000, boxes: int = 200, seed: int = 240, friction: float = 0.5) -> Scene:
    """``spheres`` spheres (radius 0.1 m) and ``boxes`` boxes (half extents 0.12 x 0.08 x 0.06 m,
    random orientations), density 500, rained from rest off a jittered grid (0.36 m spacing,
    bodies at most 0.157 m from their centre, so none overlap) into a 4 m square bin walled 1 m
    high; the boxes are spread evenly through the grid. Friction ``friction``, restitution 0 (5 s)."""
    world = World(gravity=(0.0, 0.0, -9.81))
    _walled_bin(world, half_width=2.0, height=1.0, thickness=0.2, friction=friction)
    rng = np.random.default_rng(seed)
    total = spheres + boxes
    # every (total / boxes)-th grid slot is a box
    is_box = np.zeros(total, dtype=bool)
    if boxes:
        is_box[np.floor(np.arange(boxes) * total / boxes).astype(int)] = True
    for k, (x, y, z) in enumerate(_grid(total, half_width=2.0, spacing=0.36, z0=0.4)):
        dx, dy = rng.uniform(-0.02, 0.02, size=2)
        shape: object
        if is_box[k]:
            shape = Box((0.12, 0.08, 0.06))
            orientation = axis_angle_quaternion(rng.normal(size=3), rng.uniform(0.0, math.pi))
        else:
            shape = Sphere(0.1)
            orientation = (1.0, 0.0, 0.0, 0.0)
        world.add_body(shape, density=500.0, position=(x + dx, y + dy, z), orientation=orientation,
                       friction=friction, restitution=0.0)
    return Scene(
        name="rain",
        world=world,
        dt=1.0 / 240.0,
        steps=1200,
        description=f"{spheres} spheres and {boxes} boxes rained into a 4 m walled bin, g = 9.81 m/s^2, "
        f"friction {friction:g}",
        snapshot_times=(0.0, 0.5, 1.0, 2.0, 5.0),
    )


def hull_pile(hulls: int = 200, points: int = 16, seed: int = 417, friction: float = 0.5) -> Scene:
    """``hulls`` convex hulls, each of ``points`` seeded random points in a ball of radius 0.12 m
    (uniform directions, radii uniform in [0.06, 0.12] m), density 500, dropped from rest with
    random orientations off a 0.5 m grid (a hull lies within 0.24 m of its centre of mass, so
    none overlap) into a 3 m square bin walled 1 m high. Friction ``friction``, restitution 0 (5 s)."""
    world = World(gravity=(0.0, 0.0, -9.81))
    _walled_bin(world, half_width=1.5, height=1.0, thickness=0.2, friction=friction)
    rng = np.random.default_rng(seed)
    for x, y, z in _grid(hulls, half_width=1.5, spacing=0.5, z0=0.4):
        d = rng.normal(size=(points, 3))
        cloud = d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(0.06, 0.12, size=(points, 1))
        world.add_body(ConvexHull(cloud), density=500.0, position=(x, y, z),
                       orientation=axis_angle_quaternion(rng.normal(size=3), rng.uniform(0.0, math.pi)),
                       friction=friction, restitution=0.0)
    return Scene(
        name="hull_pile",
        world=world,
        dt=1.0 / 240.0,
        steps=1200,
        description=f"{hulls} convex hulls of {points} random points dropped into a 3 m walled bin, "
        f"g = 9.81 m/s^2, friction {friction:g}",
        snapshot_times=(0.0, 0.5, 1.0, 2.0, 5.0),
    )


#: name -> the generator of its shipped scene file (``python -m signorini.scenes`` writes them again)
GENERATORS: dict[str, Callable[[], Scene]] = {
    "torus": _torus,
    "boxes": _boxes,
    "shapes": _shapes,
    "pile": _pile,
    "pyramid": pyramid,
    "rain": rain,
    "hull_pile": hull_pile,
}

#: the folder of the shipped scene files (package data)
SCENE_DIR = Path(__file__).resolve().parent / "data" / "scenes"

#: name -> shipped scene file; ``build(name)`` reads it
SCENES: dict[str, Path] = {name: SCENE_DIR / f"{name}.toml" for name in GENERATORS}


def build(name: str = DEFAULT_SCENE) -> Scene:
    """A fresh ``Scene`` (a new World each call) read from the shipped scene file of a built-in
    scene; ValueError naming the scene and the known ones."""
    try:
        path = SCENES[name]
    except KeyError:
        known = ", ".join(sorted(SCENES))
        raise ValueError(f"unknown scene {name!r} (known scenes: {known})") from None
    return read_scene(path)


def scene_info(name: str) -> dict:
    """A built-in scene's [scene] table and body count, read from its file without building it
    (for ``python -m signorini list``): {"name", "description", "dt", "steps", "bodies"}."""
    if name not in SCENES:
        raise ValueError(f"unknown scene {name!r} (known scenes: {', '.join(sorted(SCENES))})")
    with open(SCENES[name], "rb") as f:
        raw = tomllib.load(f)
    info = raw.get("scene", {})
    return {"name": info.get("name", name), "description": info.get("description", ""),
            "dt": float(info.get("dt", 1.0 / 240.0)), "steps": int(info.get("steps", 240)),
            "bodies": len(raw.get("bodies", []))}


def write_scene_files(folder: Path = SCENE_DIR, names=None) -> list[Path]:
    """Runs the generators and writes their scene files (and mesh files) into ``folder``; returns
    the paths. The shipped files are written by this once and checked against it by the tests.
    Their worlds keep every body awake (``sleeping = false``), as the files were first written
    before sleeping was on by default: the pinned runs of the built-in scenes step them so."""
    paths = []
    for name in names or GENERATORS:
        scene = GENERATORS[name]()
        scene.world.set_sleep(sleeping=False)
        paths.append(save_scene(scene, Path(folder) / f"{name}.toml"))
    return paths


if __name__ == "__main__":
    # python -m signorini.scenes: the shipped scene files and the scene file JSON Schema, again
    for written in write_scene_files():
        print(f"written      {written}")
    SCHEMA_PATH.write_text(schema_text())
    print(f"written      {SCHEMA_PATH}")
