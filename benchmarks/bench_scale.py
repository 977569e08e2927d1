"""Scale benchmark of issue 21: Box3D's benchmark scenes in signorini, pybullet and rapier3d (no asserts).

    python benchmarks/bench_scale.py [--scenes large_pyramid,many_pyramids,rain,convex_pile,large_world,sleep,box_bin]
        [--tiny] [--seconds S] [--dt DT] [--scale F] [--repeats 1] [--chunks 10]
        [--engines signorini,pybullet,rapier3d] [--sweeps 10 --substeps 1] [--box3d PATH]

Scenes, re-created from the definitions in Box3D's ``shared/benchmarks.c`` (erincatto/box3d).
Box3D is y-up; here z is up, a point (x, y, z) of Box3D's being (x, -z, y) here. Gravity 10 m/s^2,
friction 0.6 and restitution 0 everywhere, density 1000 kg/m^3 unless said, dt 1/60 (Box3D's
benchmark app steps 1/60 with 4 substeps), and Box3D's step counts:
- ``large_pyramid``: a 2D pyramid of unit cubes (density 100) with a base row of 100 (5,050 boxes),
  touching side by side, on a static 800 x 800 x 2 m box; sleeping off (200 steps).
- ``many_pyramids``: 14 x 14 pyramids of base 10 (10,780 unit cubes, density 100) on one static
  box, as Box3D spaces them; sleeping off (100 steps).
- ``rain``: bodies only. Box3D drops groups of 3 jointed ragdolls (14 capsules each) from 20 m
  onto a 10 x 10 grid of 15 m cells, each a static triangle-mesh grid with a torus, a column of
  cells at a time, then re-drops the oldest column. Here each ragdoll is 14 loose capsules
  (radius 6 cm, 32 cm long) in a 2 x 7 stack of the ragdoll's height, there are no joints, and
  each cell is a flat static box (no mesh, no torus); the drop schedule (the steps whose index has
  bits 0-3 and 5 clear) and the re-drops are Box3D's. 4,200 capsules (400 steps).
- ``convex_pile``: 8 x 8 x 80 = 5,120 copies of one convex hull of 32 points on a 2 m sphere
  (PEEL's generator with seed 42, as Box3D) stacked 4 m apart, collapsing into a pile on a static
  box (500 steps).
- ``large_world``: static 10 x 10 x 0.5 m boxes on an n x n grid and 100 spheres of radius 0.5 m,
  one released from 1.5 m every 5 steps over the inner 80% of the floor (500 steps). Box3D's n is
  1,000 (a million static bodies); here n = round(1000 x ``--scale``) (default 0.05: 50 x 50).
- ``sleep`` (not Box3D's): 2,000 boxes of 0.5 m (20 x 20 columns of 5, 1 cm apart, seeded
  jitter) dropped 1 cm onto each other; 150 steps settle it untimed, then 120 are timed with
  sleeping off (the row) and on (the "sleep on/off" column, the ratio of the two costs: the cost
  of the settled pile asleep against awake; the issue's target is at most 5 %), for signorini's
  PGS and soft rows and the peers.
- ``box_bin`` (not Box3D's: issue 21's "10,000 boxes settling in a bin", at its dt 1/240): 10,000
  boxes of 0.5 m, 20 x 20 columns of 25 in a lattice 0.75 m apart across and 0.6 m up, each box
  turned up to 0.1 rad about a seeded axis, falling onto each other inside four static walls;
  sleeping off; 180 steps land the layers untimed, then 240 are timed as the columns settle.

Engines, all in this process with the scene's dt; each scene is built by one function and
mirrored into the peers (``benchmarks/_peers.py``):
- signorini with its defaults (engine ``signorini``), a row "signorini soft" with
  ``set_solver(solver="soft")`` (engine ``soft``: the soft step at its defaults) and, with
  ``--sweeps N``, a row "signorini fast" set to
  ``set_solver(max_iterations=N, substeps=--substeps)``;
- pybullet (optional), DIRECT mode, 10 solver iterations, one solve per step;
- rapier3d (optional, the official Rapier wheel), its default integration parameters, 1 thread.
Sleeping follows Box3D's scene (off in the two pyramid scenes, on elsewhere) in every engine
that has it (signorini: ``World(sleeping=...)``). Column "2 threads" (signorini:
``World(threads=2)``; rapier3d: 2 worker threads) prints ``n/a (not implemented)`` while
signorini's World lacks the keyword, as "sleep on/off" does for a World without ``sleeping``.
It gives the 2-thread ms/step, the speed-up of the medians and, with two chunks or more, the
range of the speed-ups chunk by chunk.

Timing: the run is cut into ``--chunks`` chunks and the engines' chunks alternate, so a load
spike hits all; each step is timed alone (releases, certificate and state reads are not) and a
chunk's ms/step is its total over its length. ms/step is the median over the chunks of all
``--repeats`` runs, with the 25-75 % range. "sg/this" is signorini's first row (its defaults, else the soft step) over the row's.
``--box3d PATH`` also runs Box3D's own benchmark app on the matching scene (1 thread, its own
scene at its own size and sleeping, in child processes interleaved with our chunks: one run before
the first and one after each, so that a load change on the machine weighs on both sides) and
prints its ms/step, the median over its runs, and signorini's ratio to it chunk by chunk (each of
our chunks against the app's runs just before and just after it).
``--box3d-sag PATH`` runs ``benchmarks/box3d/pyramid_sag.c`` (built against a Box3D checkout, see
its header) for large_pyramid over the same simulated time and dt, 4 substeps, and prints Box3D's
largest box displacement in the box3d app row's "max disp m", judged by the same 1 cm rule.

Quality, at the end of the first repeat: the largest displacement of a dynamic body from its start
(m; a pyramid stands when every box stays within 1 cm), the deepest penetration now (m), the
kinetic energy (J), and signorini's certificate maxima over the run (``solver_stats``).
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import math
import os
import re
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import signorini as sg
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
NA = "n/a (not implemented)"

# the certificate fields reported as maxima over the run
CERTIFICATE = ("residual", "max_penetration_velocity", "max_complementarity", "max_cone_violation",
               "max_dissipation_violation")


@dataclasses.dataclass
class BenchScene:
    """A scene built for the benchmark.

    - world: the signorini World; bodies released later are in it, disabled, at their release pose;
    - dt (s), steps: Box3D's step and step count; settle: untimed steps before timing starts;
    - releases: step index -> body indices put (back) at their release pose, at rest, enabled;
    - stands: whether "every box within 1 cm of its start" is the scene's pass mark;
    - size: what was built, in words; box3d: the Box3D benchmark of the same name, or None.
    """
    name: str
    world: sg.World
    dt: float
    steps: int
    size: str
    settle: int = 0
    releases: dict = dataclasses.field(default_factory=dict)
    stands: bool = False
    box3d: str | None = None

    @property
    def sleeping(self) -> bool:
        """Whether Box3D's scene lets bodies sleep."""
        return BOX3D_SLEEPING[self.name]


def from_y_up(x: float, y: float, z: float) -> tuple[float, float, float]:
    """A point of Box3D's y-up scenes in signorini's z-up frame (a quarter turn about x)."""
    return (x, -z, y)


def _ground(world, half_x: float, half_y: float) -> None:
    """Box3D's ground: a static box 2 m thick whose top face is z = 0."""
    world.add_static(sg.Box((half_x, half_y, 1.0)), position=(0.0, 0.0, -1.0), friction=FRICTION, restitution=0.0)


def _pyramid(world, base: int, extent: float, center_x: float, depth: float) -> None:
    """A 2D pyramid of cubes of half extent ``extent`` (density 100), rows of base, base-1, ... 1
    touching side by side, starting at Box3D's x = center_x + extent - 0.5, at Box3D's z = depth."""
    for row in range(base):
        for j in range(row, base):
            x = (row + 1.0) * extent + 2.0 * (j - row) * extent + center_x
            world.add_body(sg.Box((extent, extent, extent)), density=100.0,
                           position=from_y_up(x, (2.0 * row + 1.0) * extent, depth),
                           friction=FRICTION, restitution=0.0)


def large_pyramid(tiny: bool = False, **world_kwargs) -> BenchScene:
    """Box3D's large_pyramid: base row 100 (tiny: 5), 5,050 unit cubes, sleeping off, 200 steps."""
    base = 5 if tiny else 100
    world = sg.World(gravity=GRAVITY, **world_kwargs)
    _ground(world, 400.0, 400.0)
    _pyramid(world, base, 0.5, -0.5 * base, 0.0)
    return BenchScene("large_pyramid", world, DT, 200, f"base {base}, {base * (base + 1) // 2} cubes",
                      stands=True, box3d="large_pyramid")


def many_pyramids(tiny: bool = False, **world_kwargs) -> BenchScene:
    """Box3D's many_pyramids: 14 x 14 pyramids of base 10 (tiny: 2 x 2 of base 3), sleeping off."""
    base, count, extent = (3, 2, 0.5) if tiny else (10, 14, 0.5)
    world = sg.World(gravity=GRAVITY, **world_kwargs)
    ground = extent * count * (base + 1.0)
    _ground(world, ground, ground)
    width = 2.0 * extent * base
    depth = -ground + 2.0 * extent
    step = 2.0 * (ground - 2.0 * extent) / (count - 1.0)
    for _ in range(count):
        for column in range(count):
            center_x = -ground + column * (width + 2.0 * extent) + 2.0 * extent
            _pyramid(world, base, extent, center_x - 0.5, depth)
        depth += step
    n = count * count * base * (base + 1) // 2
    return BenchScene("many_pyramids", world, DT, 100, f"{count} x {count} pyramids of base {base}, {n} cubes",
                      stands=True, box3d="many_pyramids")


def rain_release_steps(steps: int) -> list[int]:
    """The steps at which Box3D's rain releases a column of groups: index bits 0-3 and 5 clear."""
    return [k for k in range(steps) if k & 0x2F == 0]


def rain(tiny: bool = False, **world_kwargs) -> BenchScene:
    """Box3D's rain, bodies only: 10 x 10 cells of 15 m (tiny: 2 x 2), groups of 3 (tiny: 1)
    ragdoll-sized stacks of 14 loose capsules dropped from 20 m a column at a time (400 steps)."""
    grid, group, cell = (2, 1, 15.0) if tiny else (10, 3, 15.0)
    world = sg.World(gravity=GRAVITY, **world_kwargs)
    span = cell * grid
    for i in range(grid):
        for j in range(grid):
            x, y, _ = from_y_up(-0.5 * span + cell * (i + 0.5), 0.0, -0.5 * span + cell * (j + 0.5))
            world.add_static(sg.Box((0.5 * cell, 0.5 * cell, 0.5)), position=(x, y, -0.5),
                             friction=FRICTION, restitution=0.0)
    radius, half_length = 0.06, 0.1
    lying = axis_angle_quaternion((0.0, 1.0, 0.0), 0.5 * math.pi)  # capsule axis along x
    columns: list[list[int]] = [[] for _ in range(grid)]
    for column in range(grid):
        for row in range(grid):
            x0, y0, _ = from_y_up(-0.5 * span + cell * (column + 0.5), 0.0, -0.5 * span + cell * (row + 0.5))
            for member in range(group):
                for level in range(7):
                    for side in (-1.0, 1.0):
                        i = world.add_body(sg.Capsule(radius, half_length), density=1000.0,
                                           position=(x0 + 0.75 * member, y0 + 0.07 * side, 20.1 + 0.26 * level),
                                           orientation=lying, friction=FRICTION, restitution=0.0)
                        world.set_enabled(i, False)
                        columns[column].append(i)
    releases = {}
    # Box3D's schedule over 10 simulated minutes, for runs longer than its 400 steps
    for event, k in enumerate(rain_release_steps(36000)):
        releases[k] = columns[event % grid]
    n = grid * grid * group * 14
    return BenchScene("rain", world, DT, 400,
                      f"{grid} x {grid} cells, {group} stack(s) of 14 capsules each, {n} capsules",
                      releases=releases, box3d="rain")


def convex_pile_points(count: int = 32, radius: float = 2.0, seed: int = 42) -> np.ndarray:
    """``count`` points (count, 3) on a sphere of ``radius`` from PEEL's linear congruential
    generator, as Box3D's convex_pile draws them: coordinates uniform in [-1/2, 1/2] from the low
    16 bits of each draw, rejected outside the ball of radius 1/2, then pushed to the sphere."""
    state = seed
    points = []

    def draw() -> float:
        nonlocal state
        state = (state * 2147001325 + 715136305) & 0xFFFFFFFF
        return (state & 0xFFFF) / 65535.0 - 0.5

    while len(points) < count:
        p = np.array([draw(), draw(), draw()])
        if p @ p <= 0.25:
            points.append(radius * p / np.linalg.norm(p))
    return np.array(points)


def convex_pile(tiny: bool = False, **world_kwargs) -> BenchScene:
    """Box3D's convex_pile: 8 x 8 x 80 copies (tiny: 2 x 2 x 2) of one 32-point hull, 500 steps."""
    across, layers = (2, 2) if tiny else (8, 80)
    world = sg.World(gravity=GRAVITY, **world_kwargs)
    _ground(world, 250.0, 250.0)
    amplitude = 2.0
    hull = sg.ConvexHull(np.array([from_y_up(*p) for p in convex_pile_points(32, amplitude)]))
    for layer in range(layers):
        for k in range(across):
            for m in range(across):
                position = from_y_up((m - 0.5 * across) * 2.0 * amplitude, amplitude + 2.0 * amplitude * layer,
                                     (k - 0.5 * across) * 2.0 * amplitude)
                world.add_body(hull, density=1000.0, position=position, friction=FRICTION, restitution=0.0)
    n = across * across * layers
    return BenchScene("convex_pile", world, DT, 500, f"{across} x {across} x {layers} = {n} hulls", box3d="convex_pile")


def large_world(tiny: bool = False, scale: float = 0.05, **world_kwargs) -> BenchScene:
    """Box3D's large_world at ``scale``: round(1000 scale)^2 static 10 m floor tiles (tiny: 4 x 4)
    and 100 spheres (tiny: 4) released one every 5 steps (500 steps)."""
    n, spheres = (4, 4) if tiny else (max(2, round(1000 * scale)), 100)
    world = sg.World(gravity=GRAVITY, **world_kwargs)
    cell = 10.0
    half_span = 0.5 * cell * n
    for i in range(n):
        for j in range(n):
            world.add_static(sg.Box((0.5 * cell, 0.5 * cell, 0.25)),
                             position=from_y_up(-half_span + (i + 0.5) * cell, 0.0, -half_span + (j + 0.5) * cell),
                             friction=FRICTION, restitution=0.0)
    side = math.ceil(math.sqrt(spheres))
    inset = 0.2 * half_span
    usable = 2.0 * half_span - 2.0 * inset
    releases = {}
    for k in range(spheres):
        x = -half_span + inset + (k % side + 0.5) * usable / side
        z = -half_span + inset + (k // side + 0.5) * usable / side
        i = world.add_body(sg.Sphere(0.5), density=1000.0, position=from_y_up(x, 1.5, z),
                           friction=FRICTION, restitution=0.0)
        world.set_enabled(i, False)
        releases[5 * (k + 1)] = [i]
    return BenchScene("large_world", world, DT, 500,
                      f"{n} x {n} static tiles ({n * n}; Box3D: 1000 x 1000), {spheres} spheres",
                      releases=releases, box3d="large_world")


def sleep_pile(tiny: bool = False, across: int | None = None, layers: int | None = None, **world_kwargs) -> BenchScene:
    """2,000 boxes of 0.5 m (tiny: 3 x 3 x 2), 20 x 20 columns of 5, settled 150 steps (2.5 s: Bullet
    and Rapier put a body to sleep after 2 s at rest, Box3D after 0.5 s), then 120 timed.
    across, layers: another number of columns a side and of boxes a column (bench_slope.py's piles)."""
    across, layers = (across or (3 if tiny else 20)), (layers or (2 if tiny else 5))
    world = sg.World(gravity=GRAVITY, **world_kwargs)
    half = max(50.0, 0.52 * across)
    _ground(world, half, half)
    rng = np.random.default_rng(2000)
    h, pitch = 0.25, 0.52
    for layer in range(layers):
        for i in range(across):
            for j in range(across):
                dx, dy = rng.uniform(-0.005, 0.005, size=2)
                world.add_body(sg.Box((h, h, h)), density=1000.0,
                               position=((i - 0.5 * (across - 1)) * pitch + dx, (j - 0.5 * (across - 1)) * pitch + dy,
                                         h + 0.01 + layer * (2.0 * h + 0.01)),
                               orientation=axis_angle_quaternion((0.0, 0.0, 1.0), rng.uniform(-0.05, 0.05)),
                               friction=FRICTION, restitution=0.0)
    n = across * across * layers
    return BenchScene("sleep", world, DT, 120, f"{n} boxes, {across} x {across} columns of {layers}",
                      settle=10 if tiny else 150, stands=True)


def box_bin(tiny: bool = False, **world_kwargs) -> BenchScene:
    """10,000 boxes of 0.5 m (tiny: 3 x 3 x 2) settling in a walled bin at dt 1/240, sleeping off
    (not Box3D's: issue 21's "10,000 boxes settling in a bin"): 20 x 20 columns of 25, 0.75 m
    apart across and 0.6 m up, each box turned up to 0.1 rad about a seeded axis (it reaches 0.57
    m at most), inside four static walls 0.25 m beyond the outer columns, the lowest layer's
    centres 0.3 m over the floor. The lattice falls onto itself layer by layer: 180 untimed steps
    (0.75 s) land the layers, then 240 steps (1 s) are timed while the columns (40,000 contacts,
    four a box) settle on each other."""
    across, layers = (3, 2) if tiny else (20, 25)
    world = sg.World(gravity=GRAVITY, **world_kwargs)
    h, pitch, rise = 0.25, 0.75, 0.6
    inner = 0.5 * pitch * across + 0.25  # the walls' inner faces, from the middle
    height = rise * layers + 1.0
    _ground(world, inner + 1.0, inner + 1.0)
    for axis in (0, 1):
        for side in (-1.0, 1.0):
            centre = [0.0, 0.0, 0.5 * height]
            centre[axis] = side * (inner + 0.25)
            half = [inner + 0.5, inner + 0.5, 0.5 * height]
            half[axis] = 0.25
            world.add_static(sg.Box(tuple(half)), position=tuple(centre), friction=FRICTION, restitution=0.0)
    rng = np.random.default_rng(10000)
    for layer in range(layers):
        for i in range(across):
            for j in range(across):
                axis = rng.normal(size=3)
                world.add_body(sg.Box((h, h, h)), density=1000.0,
                               position=((i - 0.5 * (across - 1)) * pitch, (j - 0.5 * (across - 1)) * pitch,
                                         (layer + 0.5) * rise),
                               orientation=axis_angle_quaternion(tuple(axis / np.linalg.norm(axis)),
                                                                 rng.uniform(0.0, 0.1)),
                               friction=FRICTION, restitution=0.0)
    n = across * across * layers
    return BenchScene("box_bin", world, 1.0 / 240.0, 240,
                      f"{n} boxes, {across} x {across} columns of {layers}, in a bin", settle=10 if tiny else 180)


SCENES = {"large_pyramid": large_pyramid, "many_pyramids": many_pyramids, "rain": rain,
          "convex_pile": convex_pile, "large_world": large_world, "sleep": sleep_pile, "box_bin": box_bin}
ENGINES = ("signorini", "soft", "pybullet", "rapier3d")
# whether Box3D's scene lets bodies sleep (its two pyramid scenes switch sleeping off); for our
# own scenes, whether they do (the sleep scene's main rows switch it off, its sleep column on)
BOX3D_SLEEPING = {"large_pyramid": False, "many_pyramids": False, "rain": True, "convex_pile": True,
                  "large_world": True, "sleep": True, "box_bin": False}


def world_supports(keyword: str, value) -> bool:
    """Whether signorini's World takes ``keyword`` (``threads``, ``sleeping``): a try on the keyword."""
    try:
        sg.World(**{keyword: value})
    except TypeError:
        return False
    return True


class SignoriniRun:
    """A signorini scene being stepped, with per-step certificate maxima.

    - solver: ``set_solver`` keywords (empty: the defaults);
    - start (N_dyn, 3): dynamic bodies' positions at ``mark_start()``; cert: maxima of CERTIFICATE
      and sweeps over the timed steps; converged, counted: converged and timed step counts.
    """

    def __init__(self, scene: BenchScene, solver: dict):
        self.scene, self.world = scene, scene.world
        if solver:
            self.world.set_solver(**solver)
        self.release_pose = (self.world.positions.copy(), self.world.orientations.copy())
        self.dynamic = np.flatnonzero(~np.asarray(self.world.is_static))
        self.cert = dict.fromkeys(CERTIFICATE + ("iterations",), 0.0)
        self.converged = self.counted = 0

    def drop(self, indices) -> None:
        w = self.world
        for i in indices:
            w.set_enabled(i, True)
            w.set_position(i, self.release_pose[0][i])
            w.set_orientation(i, self.release_pose[1][i])
            w.set_velocity(i, (0.0, 0.0, 0.0))
            w.set_angular_velocity(i, (0.0, 0.0, 0.0))

    def step(self) -> float:
        t0 = time.perf_counter()
        self.world.step(self.scene.dt)
        elapsed = time.perf_counter() - t0
        s = self.world.solver_stats
        for key in self.cert:
            self.cert[key] = max(self.cert[key], float(getattr(s, key)))
        self.converged += bool(s.converged)
        self.counted += 1
        return elapsed

    def state(self):
        positions = self.world.positions[self.dynamic].astype(float)
        positions[~np.asarray(self.world.enabled)[self.dynamic]] = np.nan
        return positions, float(self.world.kinetic_energy())

    def mark_start(self) -> None:
        self.start = self.state()[0]
        self.cert = dict.fromkeys(self.cert, 0.0)
        self.converged = self.counted = 0

    def penetration(self) -> float:
        return float(self.world.solver_stats.max_overlap)

    def certificate(self) -> dict:
        return {**self.cert, "converged_pct": 100.0 * self.converged / max(self.counted, 1)}

    def close(self) -> None:
        pass


class PeerRun:
    """A peer twin (``_peers.PybulletTwin`` or ``RapierTwin``) of a freshly built scene; the
    built world is only read, never stepped, so releases read their pose from it."""

    def __init__(self, scene: BenchScene, twin):
        self.scene, self.twin = scene, twin

    def drop(self, indices) -> None:
        self.twin.drop(indices)

    def step(self) -> float:
        return self.twin.run_chunk(1)

    def state(self):
        return self.twin.state()

    def mark_start(self) -> None:
        self.twin.mark_start()
        self.start = self.twin.start

    def penetration(self) -> float:
        return self.twin.penetration()

    def certificate(self) -> dict:
        return {}

    def close(self) -> None:
        self.twin.close()


@dataclasses.dataclass
class Variant:
    """One run of a scene: the table row it belongs to (row) and which figure it gives (kind:
    "main" for the row's own, "threads" for its 2-thread column, "sleep_on" for its sleep column)."""
    row: str
    kind: str
    make: object  # () -> run object
    times: list = dataclasses.field(default_factory=list)


def make_variants(name: str, args, available: dict) -> list[Variant]:
    """The runs of scene ``name``: every engine's main run, its 2-thread and sleeping-on runs
    where the engine has them."""
    build = SCENES[name]
    extra = {"scale": args.scale} if name == "large_world" else {}

    def scene(**world_kwargs) -> BenchScene:
        s = build(tiny=args.tiny, **extra, **world_kwargs)
        if args.dt is not None:
            s.dt = args.dt
        return s

    sleep_scene = name == "sleep"
    variants = []
    if "signorini" in args.engines or "soft" in args.engines:
        def signorini(solver, threads=1, sleeping=None):
            def make():
                kw = {}
                if available["threads"]:
                    kw["threads"] = threads
                if available["sleeping"]:
                    kw["sleeping"] = BOX3D_SLEEPING[name] if sleeping is None else sleeping
                return SignoriniRun(scene(**kw), solver)
            return make

        main_sleep = False if sleep_scene else None
        if "signorini" in args.engines:
            variants.append(Variant("signorini", "main", signorini({}, sleeping=main_sleep)))
            if available["threads"]:
                variants.append(Variant("signorini", "threads", signorini({}, threads=2, sleeping=main_sleep)))
            if sleep_scene and available["sleeping"]:
                variants.append(Variant("signorini", "sleep_on", signorini({}, sleeping=True)))
        if "soft" in args.engines:
            variants.append(Variant("signorini soft", "main", signorini({"solver": "soft"}, sleeping=main_sleep)))
            if available["threads"]:
                variants.append(Variant("signorini soft", "threads",
                                        signorini({"solver": "soft"}, threads=2, sleeping=main_sleep)))
            if sleep_scene and available["sleeping"]:
                variants.append(Variant("signorini soft", "sleep_on", signorini({"solver": "soft"}, sleeping=True)))
        if args.sweeps is not None:
            fast = {"max_iterations": args.sweeps, "substeps": args.substeps}
            variants.append(Variant("signorini fast", "main", signorini(fast, sleeping=main_sleep)))
    if "pybullet" in args.engines and available["pybullet"] is not None:
        def pybullet(sleeping=None):
            def make():
                s = scene()
                on = s.sleeping if sleeping is None else sleeping
                return PeerRun(s, peers.PybulletTwin(s.world, s.dt, PYBULLET_ITERATIONS, on, available["pybullet"]))
            return make

        variants.append(Variant("pybullet", "main", pybullet(False if sleep_scene else None)))
        if sleep_scene:
            variants.append(Variant("pybullet", "sleep_on", pybullet(True)))
    if "rapier3d" in args.engines and available["rapier3d"] is not None:
        def rapier(threads=1, sleeping=None):
            def make():
                s = scene()
                on = s.sleeping if sleeping is None else sleeping
                return PeerRun(s, peers.RapierTwin(s.world, s.dt, threads, on, available["rapier3d"]))
            return make

        variants.append(Variant("rapier3d", "main", rapier(1, False if sleep_scene else None)))
        variants.append(Variant("rapier3d", "threads", rapier(2, False if sleep_scene else None)))
        if sleep_scene:
            variants.append(Variant("rapier3d", "sleep_on", rapier(1, True)))
    return variants


def run_steps(run, first: int, count: int, releases: dict) -> float:
    """Steps ``run`` ``count`` times from step index ``first``, releasing bodies where the scene
    says (untimed); returns the summed time of the steps alone (s)."""
    total = 0.0
    for k in range(first, first + count):
        if k in releases:
            run.drop(releases[k])
        total += run.step()
    return total


def bench_scene(name: str, args, available: dict, between=None) -> list[dict]:
    """Runs every variant of one scene, chunks interleaved; returns a row dict per table row.
    ``between()``, when given, runs after each chunk of every repeat: Box3D's app interleaved with
    ours (``--box3d``).

    Row fields: scene, engine, bodies (dynamic), steps (timed), ms, q1, q3 (median and quartiles
    of the chunks' ms/step), ratio (signorini's ms over this row's), threads2_ms, sleep_ratio
    (None when not measured; the text for them is in threads2, sleep), displacement (m),
    penetration (m), kinetic_energy (J), and signorini's certificate maxima and converged_pct.
    """
    variants = make_variants(name, args, available)
    info: dict = {}
    quality: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sg.SolverWarning)
        for repeat in range(args.repeats):
            runs = []
            try:
                for v in variants:
                    run = v.make()
                    runs.append((v, run))
                scene = runs[0][1].scene
                dt = scene.dt
                steps = scene.steps if args.seconds is None else max(1, round(args.seconds / dt))
                releases = {k: v for k, v in scene.releases.items() if k < steps}
                info = {"size": scene.size, "steps": steps, "dt": dt, "settle": scene.settle,
                        "bodies": int(np.count_nonzero(~np.asarray(scene.world.is_static))),
                        "stands": scene.stands, "sleeping": scene.sleeping, "box3d": scene.box3d}
                for v, run in runs:
                    run_steps(run, 0, scene.settle, {})
                    run.mark_start()
                first = 0
                lengths = peers.chunk_lengths(steps, args.chunks)
                for chunk, length in enumerate(lengths):
                    for v, run in runs:
                        v.times.append(1e3 * run_steps(run, first, length, releases) / length)
                    first += length
                    if between is not None:
                        between()
                    # progress on stderr, so stdout keeps the figures alone
                    print(f"    {name}: repeat {repeat + 1}/{args.repeats}, chunk {chunk + 1}/{len(lengths)}",
                          file=sys.stderr, flush=True)
                if repeat == 0:
                    for v, run in runs:
                        if v.kind != "main":
                            continue
                        positions, energy = run.state()
                        moved = np.linalg.norm(positions - run.start, axis=1)
                        moved = moved[np.isfinite(moved)]
                        # bodies released during the run have no start to be measured from
                        displacement = None if releases else (float(moved.max()) if moved.size else 0.0)
                        quality[v.row] = {"displacement": displacement,
                                          "penetration": run.penetration(), "kinetic_energy": energy,
                                          **run.certificate()}
            finally:
                for _, run in runs:
                    run.close()
    return make_rows(name, variants, info, quality, available)


def _median(times):
    q1, median, q3 = np.percentile(times, [25, 50, 75])
    return float(median), float(q1), float(q3)


def make_rows(name, variants, info, quality, available) -> list[dict]:
    """The table rows of one scene from its variants' chunk times (see ``bench_scene``)."""
    rows, by_row = [], {}
    for v in variants:
        by_row.setdefault(v.row, {})[v.kind] = v
    for row_name, kinds in by_row.items():
        ms, q1, q3 = _median(kinds["main"].times)
        row = {"scene": name, "engine": row_name, "size": info["size"], "bodies": info["bodies"],
               "steps": info["steps"], "dt": info["dt"], "settle": info["settle"] or 0,
               "ms": ms, "q1": q1, "q3": q3, "times": list(kinds["main"].times), "ratio": None,
               "threads2_ms": None, "sleep_ratio": None,
               **quality.get(row_name, {})}
        if "threads" in kinds:
            t2 = _median(kinds["threads"].times)[0]
            row["threads2_ms"] = t2
            row["threads2"] = f"{t2:.3f} ({ms / t2:.2f}x)"
            main_times, thread_times = kinds["main"].times, kinds["threads"].times
            if len(main_times) == len(thread_times) > 1:
                # chunk by chunk (the two run side by side): on a shared machine a thread speed-up
                # moves by tens of percent between chunks, and the median alone hides it
                per_chunk = [a / b for a, b in zip(main_times, thread_times)]
                row["threads2"] = f"{t2:.3f} ({ms / t2:.2f}x, {min(per_chunk):.2f}-{max(per_chunk):.2f})"
        elif row_name.startswith("signorini") and not available["threads"]:
            row["threads2"] = NA
        else:
            row["threads2"] = "-"
        if "sleep_on" in kinds:
            on = _median(kinds["sleep_on"].times)[0]
            row["sleep_ratio"] = on / ms
            row["sleep"] = f"{on:.3f} / {ms:.3f} = {on / ms:.3f}"
        elif name == "sleep" and row_name.startswith("signorini") and not available["sleeping"]:
            row["sleep"] = NA
        else:
            row["sleep"] = "-"
        rows.append(row)
    # the ratios are signorini's first row (its defaults, else the soft step) over each row
    base = next((r["ms"] for r in rows if r["engine"].startswith("signorini")), None)
    for row in rows:
        row["ratio"] = base / row["ms"] if base is not None and row["ms"] > 0 else None
    return rows


BOX3D_RUN = re.compile(r"^run \d+ : ([0-9.eE+-]+) \(ms\)")
BOX3D_STEPS = re.compile(r"^benchmark: (\S+), steps = (\d+)")


def run_box3d(path: str, name: str, repeats: int, timeout: float = 1800.0) -> dict:
    """Box3D's benchmark app on its scene ``name``, 1 thread, ``repeats`` runs, in a scratch folder
    (it writes a csv there). Its step count is its own; its first step is untimed, so ms/step is a
    run's time over steps - 1. Returns {"ms", "q1", "q3", "steps", "runs"} or {"error": text}."""
    with tempfile.TemporaryDirectory() as folder:
        try:
            done = subprocess.run([os.path.abspath(path), "-t=1", "-w=1", f"-b={name}", f"-r={repeats}"],
                                  cwd=folder, capture_output=True, text=True, timeout=timeout)
        except (OSError, subprocess.TimeoutExpired) as error:
            return {"error": str(error)}
    steps, totals = None, []
    for line in done.stdout.splitlines():
        if m := BOX3D_STEPS.match(line):
            steps = int(m.group(2))
        elif m := BOX3D_RUN.match(line):
            totals.append(float(m.group(1)))
    if done.returncode != 0 or not totals or not steps:
        return {"error": f"exit {done.returncode}: {(done.stdout + done.stderr)[-300:]}"}
    per_step = [t / max(steps - 1, 1) for t in totals]
    ms, q1, q3 = _median(per_step)
    return {"ms": ms, "q1": q1, "q3": q3, "steps": steps, "runs": len(totals), "per_step": per_step}


class Box3dBeside:
    """Box3D's app interleaved with our chunks: one run of it (``run_box3d``, 1 repeat) before the
    scene and one after each chunk (``bench_scene``'s ``between``), so that its figure and ours
    see the same minutes of a shared machine's load. ``result()``: the median and quartiles over
    all its runs, ``per_step`` the runs in order ([0] before the first chunk, [i + 1] after chunk
    i), or {"error": text} when every run failed."""

    def __init__(self, path: str, name: str):
        self.path, self.name, self.runs, self.errors = path, name, [], []
        self()

    def __call__(self) -> None:
        got = run_box3d(self.path, self.name, 1)
        if "error" in got:
            self.errors.append(got["error"])
            self.runs.append(None)
        else:
            self.steps = got["steps"]
            self.runs.append(got["per_step"][0])

    def result(self) -> dict:
        per_step = [r for r in self.runs if r is not None]
        if not per_step:
            return {"error": self.errors[-1] if self.errors else "never ran"}
        ms, q1, q3 = _median(per_step)
        return {"ms": ms, "q1": q1, "q3": q3, "steps": self.steps, "runs": len(per_step), "per_step": self.runs}


def chunk_ratios(times: list[float], beside: list) -> list[float]:
    """Our chunk i's ms/step over the mean of the Box3D runs just before and just after it
    (``Box3dBeside.per_step``: [i] and [i + 1]; one alone when the other failed)."""
    ratios = []
    for i, ms in enumerate(times):
        near = [r for r in beside[i:i + 2] if r is not None]
        if near:
            ratios.append(ms / (sum(near) / len(near)))
    return ratios


BOX3D_SAG = re.compile(r"^result steps=(\d+) max_disp=([0-9.eE+-]+) top_dz=([0-9.eE+-]+) boxes_over_1cm=(\d+)")


def run_box3d_sag(path: str, steps: int, dt: float, timeout: float = 3600.0) -> dict:
    """``pyramid_sag`` (benchmarks/box3d/pyramid_sag.c) for ``steps`` steps of ``dt`` with 4
    substeps. Returns {"displacement", "top_dz", "over"} (m, m, boxes beyond 1 cm) or {"error"}."""
    try:
        done = subprocess.run([os.path.abspath(path), str(steps), "4", repr(1.0 / dt)], capture_output=True,
                              text=True, timeout=timeout)
    except (OSError, subprocess.TimeoutExpired) as error:
        return {"error": str(error)}
    for line in done.stdout.splitlines():
        if m := BOX3D_SAG.match(line):
            return {"displacement": float(m.group(2)), "top_dz": float(m.group(3)), "over": int(m.group(4))}
    return {"error": f"exit {done.returncode}: {(done.stdout + done.stderr)[-300:]}"}


COLUMNS = [  # header, width, row key, format (None: the row's own text)
    ("scene", 13, "scene", "s"), ("engine", 14, "engine", "s"), ("bodies", 6, "bodies", "d"),
    ("steps", 5, "steps", "d"), ("ms/step", 9, "ms", ".3f"), ("25-75 %", 17, "range", None),
    ("sg/this", 7, "ratio", ".2f"), ("2 threads ms", 30, "threads2", None),
    ("sleep on/off", 21, "sleep", None), ("max disp m", 10, "displacement", ".3e"),
    ("pen end m", 9, "penetration", ".2e"), ("KE end J", 9, "kinetic_energy", ".2e"),
    ("residual", 8, "residual", ".2e"), ("pen vel", 8, "max_penetration_velocity", ".2e"),
    ("compl", 8, "max_complementarity", ".2e"), ("cone", 8, "max_cone_violation", ".2e"),
    ("dissip", 8, "max_dissipation_violation", ".2e"), ("sweeps", 6, "iterations", ".0f"),
    ("conv %", 6, "converged_pct", ".1f"),
]
LEFT = ("scene", "engine", "threads2", "sleep")


def format_table(rows) -> str:
    """One aligned table, a line per scene and engine; '-' where a figure does not apply. Cells are
    separated by two spaces and no cell holds two spaces, so ``re.split(r"\\s{2,}")`` reads it back."""
    return peers.table(rows, COLUMNS, LEFT)


def main(argv: list[str] | None = None) -> list[dict]:
    """Parses the options, runs the scenes, prints progress and the table; returns the rows."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default=",".join(SCENES), help="comma-separated, from: " + ", ".join(SCENES))
    parser.add_argument("--tiny", action="store_true", help="small versions of the scenes (smoke test)")
    parser.add_argument("--seconds", type=float, default=None, help="simulated seconds timed per scene "
                        "(default: Box3D's step count)")
    parser.add_argument("--dt", type=float, default=None, help="time step (default: the scene's, "
                        "Box3D's 1/60; box_bin 1/240)")
    parser.add_argument("--scale", type=float, default=0.05, help="large_world's grid as a share of "
                        "Box3D's 1000 x 1000 (default 0.05)")
    parser.add_argument("--repeats", type=int, default=1, help="fresh runs per scene (default 1)")
    parser.add_argument("--chunks", type=int, default=10, help="timed chunks per run (default 10)")
    parser.add_argument("--engines", default=",".join(ENGINES), help="comma-separated, from: " + ", ".join(ENGINES))
    parser.add_argument("--sweeps", type=int, default=None, help="also run signorini with this many sweeps")
    parser.add_argument("--substeps", type=int, default=1, help="substeps of the --sweeps row (default 1)")
    parser.add_argument("--box3d", default=None, metavar="PATH", help="Box3D's benchmark app, run on the "
                        "matching scenes for a same-machine calibration")
    parser.add_argument("--box3d-sag", default=None, metavar="PATH", help="benchmarks/box3d/pyramid_sag.c built "
                        "against Box3D: its large_pyramid's largest box displacement, same time and dt")
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.scenes.split(",") if n.strip()]
    if unknown := [n for n in names if n not in SCENES]:
        parser.error(f"unknown scene(s) {unknown}; known: {', '.join(SCENES)}")
    args.engines = [e.strip() for e in args.engines.split(",") if e.strip()]
    if unknown := [e for e in args.engines if e not in ENGINES]:
        parser.error(f"unknown engine(s) {unknown}; known: {', '.join(ENGINES)}")
    if args.repeats < 1 or args.chunks < 1:
        parser.error("--repeats and --chunks must be at least 1")
    if args.seconds is not None and not args.seconds > 0:
        parser.error("--seconds must be positive")
    if args.dt is not None and not args.dt > 0:
        parser.error("--dt must be positive")
    if not args.scale > 0:
        parser.error("--scale must be positive")

    available = {"threads": world_supports("threads", 1), "sleeping": world_supports("sleeping", False),
                 "pybullet": peers.load_pybullet() if "pybullet" in args.engines else None,
                 "rapier3d": peers.load_rapier() if "rapier3d" in args.engines else None}
    for engine, hint in (("pybullet", "pip install pybullet"), ("rapier3d", "pip install rapier3d")):
        if engine not in args.engines:
            print(f"{engine}: skipped (--engines)")
        elif available[engine] is None:
            print(f"{engine}: not installed ({hint})")
    print(f"signorini World(threads=...): {'yes' if available['threads'] else NA}; "
          f"World(sleeping=...): {'yes' if available['sleeping'] else NA}")
    print(f"gravity 10 m/s^2, friction {FRICTION:g}, restitution 0; pybullet {PYBULLET_ITERATIONS} iterations, "
          f"rapier3d defaults (1 thread); {args.repeats} repeat(s) x {args.chunks} chunk(s); "
          f"ms/step = median over chunks")
    rows, box3d = [], {}
    for name in names:
        target = {"sleep": None, "box_bin": None}.get(name, name)
        beside = Box3dBeside(args.box3d, target) if args.box3d and target and not args.tiny else None
        t0 = time.perf_counter()
        scene_rows = bench_scene(name, args, available, between=beside)
        rows += scene_rows
        size = scene_rows[0]["size"] if scene_rows else "no engine ran"
        print(f"  {name}: {size}, done in {time.perf_counter() - t0:.0f} s wall", flush=True)
        if beside is not None:
            result = beside.result()
            box3d[name] = result
            if "error" in result:
                print(f"  {name}: Box3D app failed: {result['error']}")
            else:
                # signorini's first row (its defaults, else the soft step), as in sg/this
                first = next((r for r in scene_rows if r["engine"].startswith("signorini")), None)
                base = first["ms"] if first else None
                rows.append({"scene": name, "engine": "box3d app", "bodies": None, "steps": result["steps"],
                             "ms": result["ms"], "q1": result["q1"], "q3": result["q3"],
                             "ratio": base / result["ms"] if base else None, "threads2": "-", "sleep": "-"})
                if first is not None:
                    ratios = chunk_ratios(first["times"], result["per_step"])
                    if ratios:
                        print(f"  {name}: {first['engine']} / Box3D app, chunk by chunk (each against the app's "
                              f"runs just before and after it): median {float(np.median(ratios)):.2f}, "
                              f"range {min(ratios):.2f}-{max(ratios):.2f} over {len(ratios)} chunks")
        if args.box3d_sag and name == "large_pyramid" and not args.tiny and scene_rows:
            ours = scene_rows[0]
            sag_steps = ours["settle"] + ours["steps"]  # the simulated time our quality columns saw
            sag = run_box3d_sag(args.box3d_sag, sag_steps, ours["dt"])
            if "error" in sag:
                print(f"  {name}: Box3D pyramid_sag failed: {sag['error']}")
            else:
                row = next((r for r in rows if r["scene"] == name and r["engine"] == "box3d app"), None)
                if row is None:
                    row = {"scene": name, "engine": "box3d app", "bodies": None, "steps": sag_steps,
                           "ms": None, "q1": None, "q3": None, "ratio": None, "threads2": "-", "sleep": "-"}
                    rows.append(row)
                row["displacement"] = sag["displacement"]
                print(f"  {name}: Box3D's own solver (pyramid_sag, {sag_steps} steps, 4 substeps): "
                      f"largest box displacement {sag['displacement']:.3f} m, top box {sag['top_dz']:+.3f} m, "
                      f"{sag['over']} boxes beyond 1 cm")

    print()
    print(format_table(rows))
    print()
    for row in rows:
        if row.get("displacement") is not None and _stands_scene(row["scene"]):
            held = row["displacement"] < 0.01
            if row["scene"] == "sleep":
                verdict = "stays settled" if held else "moves"
            else:
                verdict = "stands" if held else "falls"
            print(f"{row['scene']}, {row['engine']}: {verdict} (largest box displacement "
                  f"{row['displacement'] * 1000:.2f} mm; 1 cm allowed)")
    if box3d:
        print("box3d app: its own scene (its size, sleeping and 4 substeps), 1 thread, child processes between our chunks; "
              "large_world at Box3D's 1000 x 1000; rain with its ragdolls and meshes")
    sys.stdout.flush()
    return rows


def _stands_scene(name: str) -> bool:
    return name in ("large_pyramid", "many_pyramids", "sleep")


if __name__ == "__main__":
    main()
