"""Run a scene while recording it; save the record; summarise and plot it.

A ``Record`` holds, for a run of T steps of a world with N bodies (static bodies included):

- state arrays, T + 1 rows (row 0 is the state before the first step, row k the state after step k):
  ``time`` (T+1,) s; ``positions`` (T+1, N, 3) COM, world, m; ``orientations`` (T+1, N, 4)
  (w, x, y, z) world-from-body; ``velocities`` (T+1, N, 3) m/s; ``angular_velocities``
  (T+1, N, 3) rad/s, world; ``kinetic_energy`` and ``potential_energy`` (T+1,) J (potential
  relative to the origin, -sum m g . p, as ``World.potential_energy``);
- step arrays, T rows (row k describes step k + 1, the step that ended at ``time[k + 1]``):
  ``num_contacts`` (T,) int64; ``min_gap`` (T,) m, the smallest contact gap of the step (its
  contacts are found from the state at the start of the step; NaN when it had none), so the
  largest penetration is ``-min_gap`` where that is positive; ``iterations`` (T,) int64 PGS sweeps;
  ``residual`` (T,) m/s, the complementarity residual; ``converged`` (T,) bool;
- per body: ``masses`` (N,) kg (inf for static bodies), ``is_static`` (N,) bool;
- ``scene`` (str), ``dt`` (s) and ``wall_time`` (s, the time spent stepping).

The plot is drawn with matplotlib's Agg backend, so no display is needed.
"""

from __future__ import annotations

import math
import sys
import time as _time
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from tqdm import tqdm

from . import meshes

__all__ = ["Record", "run", "save_npz", "load_npz", "summary", "format_summary", "plot"]


@dataclass
class Record:
    """What ``run`` recorded; shapes and units in the module docstring."""

    scene: str
    dt: float
    wall_time: float
    time: np.ndarray
    positions: np.ndarray
    orientations: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray
    kinetic_energy: np.ndarray
    potential_energy: np.ndarray
    num_contacts: np.ndarray
    min_gap: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    converged: np.ndarray
    masses: np.ndarray
    is_static: np.ndarray

    @property
    def steps(self) -> int:
        """Number of recorded steps T."""
        return len(self.time) - 1

    @property
    def num_bodies(self) -> int:
        """Number of bodies N, static ones included."""
        return self.positions.shape[1]

    @property
    def total_energy(self) -> np.ndarray:
        """Kinetic plus potential energy (T+1,), J."""
        return self.kinetic_energy + self.potential_energy

    @property
    def step_time(self) -> np.ndarray:
        """Time at the end of each step (T,), s: the time axis of the step arrays."""
        return self.time[1:]

    @property
    def penetration(self) -> np.ndarray:
        """Largest penetration of each step (T,), m: max(-min_gap, 0), 0 for steps without contacts."""
        return np.where(np.isnan(self.min_gap), 0.0, np.maximum(-np.nan_to_num(self.min_gap), 0.0))


def run(scene, steps: int | None = None, dt: float | None = None, progress: bool | None = None) -> Record:
    """Step a scene's world one step at a time, recording state, energy, contacts and solver stats.

    Inputs: scene (``scenes.Scene``; its world is advanced in place), steps (default
    ``scene.steps``), dt (s, default ``scene.dt``), progress (show a tqdm bar; default: only
    when stdout is a terminal). Output: a ``Record`` of ``steps`` steps.
    """
    world = scene.world
    steps = scene.steps if steps is None else int(steps)
    dt = scene.dt if dt is None else float(dt)
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a finite number > 0, got {dt}")

    # preallocate: state rows 0..T, step rows 0..T-1
    n = world.num_bodies
    time = np.empty(steps + 1)
    positions = np.empty((steps + 1, n, 3))
    orientations = np.empty((steps + 1, n, 4))
    velocities = np.empty((steps + 1, n, 3))
    angular_velocities = np.empty((steps + 1, n, 3))
    kinetic = np.empty(steps + 1)
    potential = np.empty(steps + 1)
    num_contacts = np.zeros(steps, dtype=np.int64)
    min_gap = np.full(steps, np.nan)
    iterations = np.zeros(steps, dtype=np.int64)
    residual = np.zeros(steps)
    converged = np.zeros(steps, dtype=bool)

    def record_state(k: int) -> None:
        time[k] = world.time
        positions[k] = world.positions
        orientations[k] = world.orientations
        velocities[k] = world.velocities
        angular_velocities[k] = world.angular_velocities
        kinetic[k] = world.kinetic_energy()
        potential[k] = world.potential_energy()

    # a progress bar only for a person watching a terminal
    if progress is None:
        progress = sys.stdout.isatty()
    bar = tqdm(total=steps, unit="step", desc=scene.name, leave=False) if progress else None

    # step, then read back the state, the contacts of that step and its solver report
    record_state(0)
    wall = 0.0
    for k in range(steps):
        start = _time.perf_counter()
        world.step(dt=dt, steps=1)
        wall += _time.perf_counter() - start
        record_state(k + 1)
        gap = np.asarray(world.contacts.gap)
        num_contacts[k] = gap.size
        if gap.size:
            min_gap[k] = gap.min()
        stats = world.solver_stats
        iterations[k] = stats.iterations
        residual[k] = stats.residual
        converged[k] = stats.converged
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()

    return Record(
        scene=scene.name,
        dt=dt,
        wall_time=wall,
        time=time,
        positions=positions,
        orientations=orientations,
        velocities=velocities,
        angular_velocities=angular_velocities,
        kinetic_energy=kinetic,
        potential_energy=potential,
        num_contacts=num_contacts,
        min_gap=min_gap,
        iterations=iterations,
        residual=residual,
        converged=converged,
        masses=np.asarray(world.masses, dtype=np.float64).copy(),
        is_static=np.asarray(world.is_static, dtype=bool).copy(),
    )


def save_npz(path, record: Record) -> Path:
    """Write every field of the record to a compressed .npz (names as in ``Record``); returns the path.

    ``scene`` is stored as a 0-d unicode array, so ``np.load`` needs no pickling.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **{f.name: np.asarray(getattr(record, f.name)) for f in fields(Record)})
    return path


def load_npz(path) -> Record:
    """Read a record written by ``save_npz``."""
    with np.load(path, allow_pickle=False) as data:
        values = {f.name: data[f.name] for f in fields(Record)}
    values["scene"] = str(values["scene"])
    values["dt"] = float(values["dt"])
    values["wall_time"] = float(values["wall_time"])
    return Record(**values)


def summary(record: Record, window: float = 1.0) -> dict:
    """Headline numbers of a run.

    Inputs: record; window (s), the final stretch over which the penetration is reported.
    Output dict: bodies, dynamic, steps, simulated_time (s), wall_time (s), initial_energy,
    final_energy, energy_drift (final - initial, J), energy_scale (J, max(|E0|, max kinetic
    energy), what the drift is compared with), max_penetration_last (m, over the last ``window``
    seconds; 0 if no overlap), contact_steps (steps with contacts), iterations_median and
    iterations_max (over steps with contacts; 0 when there were none), max_residual (m/s),
    not_converged (steps whose PGS stopped at max_iterations).
    """
    energy = record.total_energy
    scale = max(abs(float(energy[0])), float(np.max(record.kinetic_energy)))
    late = record.step_time > record.time[-1] - window - 1e-12
    with_contacts = record.num_contacts > 0
    iterations = record.iterations[with_contacts]
    return {
        "bodies": record.num_bodies,
        "dynamic": int(np.count_nonzero(~record.is_static)),
        "steps": record.steps,
        "simulated_time": float(record.time[-1] - record.time[0]),
        "wall_time": record.wall_time,
        "initial_energy": float(energy[0]),
        "final_energy": float(energy[-1]),
        "energy_drift": float(energy[-1] - energy[0]),
        "energy_scale": scale,
        "max_penetration_last": float(record.penetration[late].max()) if late.any() else 0.0,
        "window": window,
        "contact_steps": int(np.count_nonzero(with_contacts)),
        "iterations_median": float(np.median(iterations)) if iterations.size else 0.0,
        "iterations_max": int(iterations.max()) if iterations.size else 0,
        "max_residual": float(record.residual.max()) if record.steps else 0.0,
        "not_converged": int(np.count_nonzero(with_contacts & ~record.converged)),
    }


def format_summary(record: Record, files=()) -> str:
    """The few lines the command line prints after a run; ``files`` are the paths written."""
    s = summary(record)
    drift_pct = 100.0 * s["energy_drift"] / s["energy_scale"] if s["energy_scale"] > 0 else 0.0
    speed = s["steps"] / s["wall_time"] if s["wall_time"] > 0 else float("inf")
    lines = [
        f"scene        {record.scene}",
        f"bodies       {s['bodies']} ({s['dynamic']} dynamic)",
        f"steps        {s['steps']} x dt {record.dt:.6g} s = {s['simulated_time']:.4g} s simulated",
        f"wall time    {s['wall_time']:.3f} s in World.step ({speed:.0f} steps/s)",
        f"energy       initial {s['initial_energy']:.6g} J, final {s['final_energy']:.6g} J, "
        f"drift {s['energy_drift']:+.3g} J ({drift_pct:+.2f} % of {s['energy_scale']:.3g} J)",
        f"penetration  largest in the last {s['window']:g} s: {1e3 * s['max_penetration_last']:.3g} mm",
        f"solver       iterations median {s['iterations_median']:g}, max {s['iterations_max']} "
        f"over {s['contact_steps']} steps with contacts; max residual {s['max_residual']:.2e} m/s, "
        f"{s['not_converged']} not converged",
    ]
    for i, path in enumerate(files):
        lines.append(f"{'written' if i == 0 else '':<12} {path}")
    return "\n".join(lines)


# plotting


def _snapshot_indices(record: Record, times) -> list[int]:
    """Rows of the record nearest to the requested times (s), as many as requested; four evenly
    spaced when None, and evenly spaced as well when a shorter run would merge requested times."""
    t = record.time
    count = 4 if times is None else max(len(times), 1)
    if times is not None:
        wanted = [min(max(float(x), t[0]), t[-1]) for x in times]
        rows = sorted({int(np.argmin(np.abs(t - x))) for x in wanted})
        if len(rows) == min(count, len(t)):
            return rows
    return sorted({int(np.argmin(np.abs(t - x))) for x in np.linspace(t[0], t[-1], count)})


def _up_direction(world) -> np.ndarray:
    """Unit 'up' for the camera: against gravity if the world tells it, else the first plane normal, else z."""
    gravity = getattr(world, "gravity", None)
    if gravity is not None and np.linalg.norm(gravity) > 0:
        g = np.asarray(gravity, dtype=np.float64)
        return -g / np.linalg.norm(g)
    for i in range(world.num_bodies):
        shape = world.shape(i)
        if meshes.render_mesh(shape) is None:
            n = np.asarray(shape.normal, dtype=np.float64)
            return n / np.linalg.norm(n)
    return np.array([0.0, 0.0, 1.0])


def _camera(up: np.ndarray, planes) -> tuple[float, float, str]:
    """(elev, azim, vertical_axis) for Axes3D.view_init: vertical axis nearest to up, camera 25
    degrees above the horizon, on the side a tilted plane faces, turned 60 degrees around up."""
    k = int(np.argmax(np.abs(up)))
    vertical = np.zeros(3)
    vertical[k] = 1.0

    # horizontal direction towards the camera
    h = np.zeros(3)
    for normal, _ in planes:
        h = normal - (normal @ vertical) * vertical
        if np.linalg.norm(h) > 0.1:
            break
    if np.linalg.norm(h) <= 0.1:
        h = np.zeros(3)
        h[(k + 1) % 3] = 1.0
    h /= np.linalg.norm(h)
    turn = math.radians(-60.0)
    h = math.cos(turn) * h + math.sin(turn) * np.cross(vertical, h)

    # matplotlib rolls the eye direction so that the vertical axis plays the part of z
    elev = math.radians(25.0)
    d = math.cos(elev) * h + math.sin(elev) * vertical
    p = np.roll(d, 2 - k)
    return math.degrees(math.asin(p[2])), math.degrees(math.atan2(p[1], p[0])), "xyz"[k]


def _plane_in_box(normal: np.ndarray, offset: float, lo: np.ndarray, hi: np.ndarray) -> np.ndarray | None:
    """Polygon (m, 3) where the plane n . x = offset cuts the box [lo, hi], ordered around its
    centre; None if the plane misses the box."""
    corners = np.array([[(hi if k & (1 << a) else lo)[a] for a in range(3)] for k in range(8)])
    side = corners @ normal - offset
    points = []
    for a in range(8):
        for b in range(a + 1, 8):
            # box edges join corners that differ in one coordinate
            if bin(a ^ b).count("1") == 1 and side[a] * side[b] < 0:
                s = side[a] / (side[a] - side[b])
                points.append(corners[a] + s * (corners[b] - corners[a]))
            elif bin(a ^ b).count("1") == 1 and side[a] == 0:
                points.append(corners[a])
    if len(points) < 3:
        return None
    points = np.unique(np.round(np.array(points), 15), axis=0)
    centre = points.mean(axis=0)
    e1 = points[0] - centre
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    angle = np.arctan2((points - centre) @ e2, (points - centre) @ e1)
    return points[np.argsort(angle)]


def plot(path_png, record: Record, scene) -> Path:
    """Draw a run: energy, contacts and solver effort over time, and 3-D snapshots of the bodies.

    Inputs: path_png (file to write), record (from ``run``), scene (the ``Scene`` that was run;
    only ``name``, ``description``, ``snapshot_times`` and ``world.shape(i)`` / ``world.num_bodies``
    are used, so a scene rebuilt with ``scenes.build`` works as well). Output: the path written.
    Snapshots are drawn at ``scene.snapshot_times`` (s; four evenly spaced when None), each centred
    on the dynamic bodies, all with the same scale and view size (the largest extent of the dynamic
    bodies per axis over the snapshots), planes clipped to the view as patches, and each dynamic
    body's COM path so far as a thin line.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    world = scene.world
    n = record.num_bodies
    shapes = [world.shape(i) for i in range(n)]
    render = [meshes.render_mesh(s) for s in shapes]
    planes = [
        (np.asarray(s.normal, dtype=np.float64) / np.linalg.norm(s.normal), float(s.offset))
        for s, r in zip(shapes, render)
        if r is None
    ]
    dynamic = [i for i in range(n) if not record.is_static[i]]
    rows = _snapshot_indices(record, getattr(scene, "snapshot_times", None))

    # the figure: three time plots on top, one 3-D snapshot per chosen time below
    ncols = max(len(rows), 3)
    fig = plt.figure(figsize=(max(3.6 * ncols, 13.0), 8.4), layout="constrained")
    grid = fig.add_gridspec(2, ncols * 2, height_ratios=[1.0, 1.5])
    top = [fig.add_subplot(grid[0, 2 * ncols * j // 3 : 2 * ncols * (j + 1) // 3]) for j in range(3)]
    fig.suptitle(f"{record.scene}: {getattr(scene, 'description', '')}", fontsize=11)

    # energy: kinetic, potential (relative to the origin) and their sum
    ax = top[0]
    ax.plot(record.time, record.kinetic_energy, label="kinetic")
    ax.plot(record.time, record.potential_energy, label="potential")
    ax.plot(record.time, record.total_energy, "k", lw=1.5, label="total")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("energy (J)")
    ax.set_title("energy")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)

    # contacts: largest penetration of each step, and how many contacts there were
    ax = top[1]
    ax.plot(record.step_time, 1e3 * record.penetration, color="tab:red", lw=1)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("largest penetration (mm)", color="tab:red")
    ax.set_title("contacts")
    ax.grid(alpha=0.3)
    twin = ax.twinx()
    twin.step(record.step_time, record.num_contacts, color="tab:gray", lw=0.8, where="post")
    twin.set_ylabel("contacts", color="tab:gray")

    # solver: PGS sweeps per step and the residual at the end of each step
    ax = top[2]
    ax.plot(record.step_time, record.iterations, color="tab:blue", lw=1)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("PGS iterations", color="tab:blue")
    ax.set_title("solver")
    ax.grid(alpha=0.3)
    positive = record.residual > 0
    if positive.any():
        twin = ax.twinx()
        twin.semilogy(record.step_time[positive], record.residual[positive], ".", ms=2, color="tab:green")
        twin.set_ylabel("residual (m/s)", color="tab:green")

    # one view size for all snapshots: the largest extent of the dynamic bodies per axis, padded
    def world_vertices(i: int, k: int) -> np.ndarray:
        return meshes.posed(render[i][0], record.positions[k, i], record.orientations[k, i])

    drawn = dynamic or [i for i in range(n) if render[i] is not None]
    centres, extent = {}, np.zeros(3)
    for k in rows:
        if drawn:
            points = np.concatenate([world_vertices(i, k) for i in drawn])
            lo_k, hi_k = points.min(axis=0), points.max(axis=0)
        else:
            lo_k, hi_k = -np.ones(3), np.ones(3)
        centres[k] = 0.5 * (lo_k + hi_k)
        extent = np.maximum(extent, hi_k - lo_k)
    half = 0.5 * extent * 1.15 + 0.05 * max(float(extent.max()), 1e-3)
    half = np.maximum(half, 0.3 * half.max())

    up = _up_direction(world)
    elev, azim, vertical = _camera(up, planes)
    colours = plt.get_cmap("tab10")

    for j, k in enumerate(rows):
        ax = fig.add_subplot(grid[1, 2 * j : 2 * j + 2], projection="3d")
        lo, hi = centres[k] - half, centres[k] + half

        # static planes as patches clipped to the view
        for normal, offset in planes:
            polygon = _plane_in_box(normal, offset, lo, hi)
            if polygon is not None:
                patch = Poly3DCollection([polygon], facecolor="0.75", edgecolor="0.5", alpha=0.45)
                ax.add_collection3d(patch)

        # bodies as shaded triangle meshes, static non-plane bodies in grey
        for i in range(n):
            if render[i] is None:
                continue
            v = world_vertices(i, k)
            colour = "0.6" if record.is_static[i] else colours(dynamic.index(i) % 10)
            ax.plot_trisurf(
                v[:, 0], v[:, 1], v[:, 2], triangles=render[i][1], color=colour,
                edgecolor=(0, 0, 0, 0.15), linewidth=0.2, shade=True,
                alpha=0.35 if record.is_static[i] else 1.0,  # see-through scenery hides nothing
            )

        # the path of each dynamic body's COM up to now, inside the view only
        for i in dynamic:
            path = record.positions[: k + 1, i].copy()
            outside = np.any((path < lo) | (path > hi), axis=1)
            path[outside] = np.nan
            ax.plot(path[:, 0], path[:, 1], path[:, 2], lw=0.8, color=colours(dynamic.index(i) % 10))

        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        ax.set_box_aspect(tuple(half), zoom=1.1)
        ax.view_init(elev=elev, azim=azim, vertical_axis=vertical)
        ax.set_xlabel("x (m)", fontsize=8)
        ax.set_ylabel("y (m)", fontsize=8)
        ax.set_zlabel("z (m)", fontsize=8)
        ax.tick_params(labelsize=6)
        ax.set_title(f"t = {record.time[k]:.2f} s", fontsize=10)

    path_png = Path(path_png)
    path_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path_png, dpi=110)
    plt.close(fig)
    return path_png
