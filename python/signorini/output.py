"""Run a scene while recording it; summarise and plot the record.

``run(scene)`` steps a built-in scene (``signorini.scenes``) through a ``trajectory.Recorder`` and
returns its ``Record`` (shapes and units in ``signorini.trajectory``: frames of poses,
velocities and energy, per-step contact counts and the solver's certificate, optional contacts,
and the scene's shapes and names), which ``save_trajectory`` writes to one .npz.
``summary`` and ``format_summary`` give the headline numbers; ``plot`` draws energy, contacts,
solver effort and 3-D snapshots into a PNG with matplotlib's Agg backend (no display needed),
from the record alone.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from . import meshes, progress as progress_bars
from .trajectory import TRAJECTORY_BUDGET, Record, Recorder, load_trajectory, save_trajectory

__all__ = ["Record", "run", "save_trajectory", "load_trajectory", "summary", "format_summary", "energy_change_text",
           "plot", "megabytes"]


def run(scene, steps: int | None = None, dt: float | None = None, progress: bool | None = None,
        stride: int | None = None, contacts: bool = True, budget: float = TRAJECTORY_BUDGET) -> Record:
    """Step a scene's world one step at a time, recording it.

    Inputs: scene (``scenes.Scene``; its world is advanced in place; its optional ``names`` name
    the bodies), steps (default ``scene.steps``), dt (s, default ``scene.dt``), progress (on
    stderr once the run has taken a second: a tqdm bar on a terminal, a few plain lines anywhere
    else, ``signorini.progress``; None, the default: yes), stride (a frame every ``stride`` steps; None, the default: chosen so that the
    frames fit ``budget`` bytes, ``trajectory.TRAJECTORY_BUDGET``), contacts (record each frame's
    contacts). Output: a ``Record`` of ``steps`` steps.
    """
    world = scene.world
    steps = scene.steps if steps is None else int(steps)
    dt = scene.dt if dt is None else float(dt)
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a finite number > 0, got {dt}")

    recorder = Recorder(world, stride=stride, steps=steps, budget=budget, contacts=contacts,
                        names=getattr(scene, "names", None), scene=scene.name)
    # only for runs longer than a second; a bar on a terminal, a few lines in a log
    if progress is None or progress:
        with progress_bars.bar(steps, scene.name, "step", delay=1.0, leave=False) as bar:
            recorder.step(dt, steps, progress=bar.update)
    else:
        recorder.step(dt, steps)
    return recorder.record()


def summary(record: Record, window: float = 1.0) -> dict:
    """Headline numbers of a run.

    Inputs: record; window (s), the final stretch over which the penetration is reported.
    Output dict: bodies, dynamic, steps, simulated_time (s), wall_time (s), kinetic_initial,
    kinetic_final, potential_initial, potential_final (J; the potential's zero is arbitrary, so only
    its change means something), initial_energy, final_energy (kinetic + potential, J),
    energy_change (final - initial, J: negative when contacts and friction dissipated energy,
    positive when the world gained some), energy_available (J: the initial kinetic energy plus the
    potential energy released between the first and the last frame, what the run had to spend;
    a loss is a share of it), energy_scale (J, the largest of the peak kinetic energy and the
    potential energies' sizes: below 1e-9 of it a change is rounding), max_penetration_last (m, over the last ``window``
    seconds; 0 if no overlap), contact_steps (steps with contacts), iterations_median and
    iterations_max (over steps with contacts; 0 when there were none), max_residual (m/s),
    not_converged (steps whose PGS stopped at max_iterations), certificate_run and
    certificate_last: the largest of each Signorini certificate figure (``CERTIFICATE``) over the
    run and over the last ``window`` seconds (those the record holds).
    """
    energy = record.total_energy
    kinetic, potential = record.kinetic_energy, record.potential_energy
    scale = max(float(np.max(kinetic)), abs(float(potential[0])), abs(float(potential[-1])))
    late = record.step_time > record.time[-1] - window - 1e-12
    with_contacts = record.num_contacts > 0
    iterations = record.iterations[with_contacts]
    return {
        "bodies": record.num_bodies,
        "dynamic": int(np.count_nonzero(~record.is_static)),
        "steps": record.steps,
        "simulated_time": float(record.time[-1] - record.time[0]),
        "wall_time": record.wall_time,
        "kinetic_initial": float(kinetic[0]),
        "kinetic_final": float(kinetic[-1]),
        "potential_initial": float(potential[0]),
        "potential_final": float(potential[-1]),
        "initial_energy": float(energy[0]),
        "final_energy": float(energy[-1]),
        "energy_change": float(energy[-1] - energy[0]),
        "energy_available": float(kinetic[0] + potential[0] - potential[-1]),
        "energy_scale": scale,
        "max_penetration_last": float(record.penetration[late].max()) if late.any() else 0.0,
        "window": window,
        "contact_steps": int(np.count_nonzero(with_contacts)),
        "iterations_median": float(np.median(iterations)) if iterations.size else 0.0,
        "iterations_max": int(iterations.max()) if iterations.size else 0,
        "max_residual": float(record.residual.max()) if record.steps else 0.0,
        "not_converged": int(np.count_nonzero(with_contacts & ~record.converged)),
        "certificate_run": {k: float(record.solver[k].max()) if record.steps else 0.0
                            for k, _, _ in CERTIFICATE if k in record.solver},
        "certificate_last": {k: float(record.solver[k][late].max()) if late.any() else 0.0
                             for k, _, _ in CERTIFICATE if k in record.solver},
    }


# the Signorini certificate figures of World.solver_stats: key, label, unit
CERTIFICATE = (
    ("residual", "residual", "m/s"),
    ("max_penetration_velocity", "penetration velocity", "m/s"),
    ("max_complementarity", "complementarity", "W"),
    ("max_cone_violation", "cone", "N"),
    ("max_dissipation_violation", "dissipation", "N"),
)


def energy_change_text(kinetic: tuple[float, float], potential: tuple[float, float], scale: float) -> str:
    """The energy line of a summary: what happened to the mechanical energy of a run, named as
    what it is.

    Inputs: kinetic (initial, final) and potential (initial, final), J; scale (J, ``summary``'s
    energy_scale): a change of the total within 1e-9 of it is rounding. The potential energy's zero
    is arbitrary (``World.potential_energy`` measures heights from the origin), so the line gives its
    change, never its level. A loss is energy dissipated by contacts and friction (inelastic impacts,
    sliding, the solver's position pass adds none), given in joules and as a share of what the run
    had to spend: the initial kinetic energy plus the potential energy released (lost height), which
    the dissipated energy and the final kinetic energy add up to, so the share is at most 100 %. A
    gain is named a gain, with where it can come from (contacts and friction never add energy).
    """
    k0, k1 = (float(x) for x in kinetic)
    p0, p1 = (float(x) for x in potential)
    change = (k1 + p1) - (k0 + p0)
    fall = p0 - p1

    def joules(x: float) -> str:  # rounding-sized values as 0
        return f"{0.0 if abs(x) <= 1e-12 * scale else x:.3g} J"

    if change == 0.0 or abs(change) <= 1e-9 * scale:
        return (f"kept: kinetic {joules(k0)} -> {joules(k1)}, potential released {joules(fall)} "
                f"(total changed by {change:+.2g} J, rounding)")
    if change < 0:
        available = k0 + fall  # = dissipated + k1 >= dissipated
        source = f"+ {joules(fall)} of potential energy released" if fall >= 0 else \
            f"- {joules(-fall)} gone into potential energy"
        return (f"dissipated {joules(-change)} by contacts and friction: {100.0 * -change / available:.3g} % of the "
                f"{joules(available)} available (kinetic {joules(k0)} at the start {source}), "
                f"{joules(k1)} still kinetic at the end")
    return (f"gained {joules(change)}: kinetic {joules(k0)} -> {joules(k1)}, potential released {joules(fall)}; "
            "contacts and friction only dissipate, so it came from external forces, kinematic bodies or the integration")


def megabytes(size: int) -> str:
    """A file size as the summary prints it: '12.3 MB' (10^6 bytes), '4.1 kB' below a megabyte."""
    return f"{size / 1e6:.3g} MB" if size >= 1e6 else f"{size / 1e3:.3g} kB"


def format_summary(record: Record, files=(), budget: float | None = None) -> str:
    """The few lines the command line prints after a run; ``files`` are the paths written (each
    with its size, and their total). ``budget``: the frame budget (bytes) when the stride was
    chosen automatically, None when it was given."""
    s = summary(record)
    speed = s["steps"] / s["wall_time"] if s["wall_time"] > 0 else float("inf")
    chosen = (f"chosen for the {megabytes(int(budget))} frame budget; --stride sets it" if budget is not None
              else "as given")
    lines = [
        f"scene        {record.scene}",
        f"bodies       {s['bodies']} ({s['dynamic']} dynamic)",
        f"steps        {s['steps']} x dt {record.dt:.6g} s = {s['simulated_time']:.4g} s simulated",
        f"frames       {record.frames}, every {record.stride} step{'s' if record.stride > 1 else ''} "
        f"(stride {record.stride}, {chosen})",
        f"wall time    {s['wall_time']:.3f} s in World.step ({speed:.0f} steps/s)",
        "energy       " + energy_change_text((s["kinetic_initial"], s["kinetic_final"]),
                                         (s["potential_initial"], s["potential_final"]), s["energy_scale"]),
        f"penetration  largest in the last {s['window']:g} s: {1e3 * s['max_penetration_last']:.3g} mm",
        f"solver       iterations median {s['iterations_median']:g}, max {s['iterations_max']} "
        f"over {s['contact_steps']} steps with contacts; max residual {s['max_residual']:.2e} m/s, "
        f"{s['not_converged']} not converged",
    ]
    if s["certificate_run"]:
        lines.append("certificate  largest over the run / the last {:g} s: ".format(s["window"]) + ", ".join(
            f"{label} {s['certificate_run'][k]:.2e} / {s['certificate_last'][k]:.2e} {unit}"
            for k, label, unit in CERTIFICATE if k in s["certificate_run"]))
    sizes = [Path(path).stat().st_size if Path(path).is_file() else 0 for path in files]
    for i, (path, size) in enumerate(zip(files, sizes)):
        lines.append(f"{'written' if i == 0 else '':<12} {path} ({megabytes(size)})")
    if len(files) > 1:
        lines.append(f"{'':<12} {megabytes(sum(sizes))} in all")
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


def up_direction(record: Record) -> np.ndarray:
    """Unit 'up' (3,) for a camera: against gravity if there is any, else the first plane's normal,
    else z."""
    g = np.asarray(record.gravity, dtype=np.float64)
    if np.linalg.norm(g) > 0:
        return -g / np.linalg.norm(g)
    for params in record.shapes:
        if params["type"] == "plane":
            n = np.asarray(params["normal"], dtype=np.float64)
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


def plot(path_png, record: Record, scene=None) -> Path:
    """Draw a run: energy, contacts and solver effort over time, and 3-D snapshots of the bodies.

    Inputs: path_png (file to write), record (from ``run`` or ``load_trajectory``: the bodies are
    drawn from its shapes), scene (optional: the ``Scene`` that was run, for its ``description``
    and ``snapshot_times``). Output: the path written.
    Snapshots are drawn at ``scene.snapshot_times`` (s; four evenly spaced when None), each centred
    on the dynamic bodies, all with the same scale and view size (the largest extent of the dynamic
    bodies per axis over the snapshots), planes clipped to the view as patches, and each dynamic
    body's COM path so far as a thin line.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    n = record.num_bodies
    # planes are drawn as patches clipped to each view, everything else as its draw mesh
    render = [None if p["type"] == "plane" else record.draw_meshes[i] for i, p in enumerate(record.shapes)]
    planes = [
        (np.asarray(p["normal"], dtype=np.float64) / np.linalg.norm(p["normal"]), float(p["offset"]))
        for p in record.shapes
        if p["type"] == "plane"
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
    ax.set_title("energy (the total falls by what contacts and friction dissipate)", fontsize=9)
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

    up = up_direction(record)
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
