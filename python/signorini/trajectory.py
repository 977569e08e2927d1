"""Trajectories that carry their scene: record a world as it steps, save it to one file, load it back.

A ``Record`` holds a run of T steps of a world with N bodies (static bodies included), sampled
every ``stride`` steps into F frames (frame 0 is the state before the first step; the last step is
always a frame, so F = ceil(T / stride) + 1):

- the scene, enough to redraw it without the simulator: ``names`` (N,) str; ``shapes``, one dict
  of shape parameters per body (``{"type": "box", "half_extents": [..]}``, m, body frame; see
  ``shape_params``); ``draw_meshes``, one (vertices (n_i, 3) float64 m body frame, faces (k_i, 3)
  int64) per body, static ones too (a plane is drawn as a square patch around where the bodies
  went); ``masses`` (N,) kg (inf for static bodies); ``is_static`` (N,) bool; ``gravity`` (3,) m/s^2;
- frame arrays, F rows: ``frame_step`` (F,) int64, the number of steps taken before the frame;
  ``time`` (F,) s; ``positions`` (F, N, 3) COM, world, m; ``orientations`` (F, N, 4) (w, x, y, z)
  world-from-body; ``velocities`` (F, N, 3) m/s; ``angular_velocities`` (F, N, 3) rad/s, world;
  ``kinetic_energy`` and ``potential_energy`` (F,) J (potential relative to the origin, as
  ``World.potential_energy``);
- step arrays, T rows (row k describes step k + 1, the step that ended at ``step_time[k]``):
  ``step_time`` (T,) s; ``num_contacts`` (T,) int64; ``min_gap`` (T,) m, the smallest contact gap
  of the step (NaN when it had none); ``solver``, a dict of (T,) arrays, one per field of
  ``World.solver_stats`` (sweeps, convergence and the Signorini certificate), so
  ``record.iterations``, ``record.residual`` and ``record.converged`` read from it;
- optional per-frame contacts (``contacts`` is None when not recorded): a dict of C rows over all
  frames, the contacts of the step that ended at each frame (frame 0 has none): ``offsets``
  (F + 1,) int64 (frame f owns rows offsets[f]:offsets[f + 1]), ``body_a``, ``body_b`` (C,) int64,
  ``point`` (C, 3) m world, ``normal`` (C, 3) unit A->B world, ``force`` (C, 3) N on B world (alpha
  n + friction), ``gap`` (C,) m;
- ``scene`` (str), ``dt`` (s), ``stride`` (int), ``wall_time`` (s spent in ``World.step``).

Memory: the frame arrays grow by N * 16 doubles per frame, plus the frame's contacts (13 numbers
each); the step arrays by 15 numbers (120 bytes) per step, kept in typed arrays. A stride of s
divides the first by s.

The file is one compressed ``.npz`` (no pickles): ``save_trajectory(path, record)`` (also
``record.save(path)``) and ``load_trajectory(path)``; the command line writes it.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time as _time
import warnings
import zipfile
from array import array
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import codec, filecheck, meshes
from .world import SolverWarning

__all__ = ["Record", "Recorder", "save_trajectory", "load_trajectory", "shape_params", "body_names",
           "TRAJECTORY_FORMAT"]

TRAJECTORY_FORMAT = "signorini-trajectory"
TRAJECTORY_VERSION = 1
CONTACT_KEYS = ("body_a", "body_b", "point", "normal", "force", "gap")


@dataclass
class Record:
    """A recorded run and its scene; shapes and units in the module docstring."""

    scene: str
    dt: float
    stride: int
    wall_time: float
    names: list
    shapes: list
    draw_meshes: list
    masses: np.ndarray
    is_static: np.ndarray
    gravity: np.ndarray
    frame_step: np.ndarray
    time: np.ndarray
    positions: np.ndarray
    orientations: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray
    kinetic_energy: np.ndarray
    potential_energy: np.ndarray
    step_time: np.ndarray
    num_contacts: np.ndarray
    min_gap: np.ndarray
    solver: dict
    contacts: dict | None = None

    @property
    def steps(self) -> int:
        """Number of recorded steps T."""
        return len(self.step_time)

    @property
    def frames(self) -> int:
        """Number of frames F."""
        return len(self.time)

    @property
    def num_bodies(self) -> int:
        """Number of bodies N, static ones included."""
        return self.positions.shape[1]

    @property
    def dynamic(self) -> list[int]:
        """Indices of the dynamic bodies."""
        return [i for i in range(self.num_bodies) if not self.is_static[i]]

    @property
    def total_energy(self) -> np.ndarray:
        """Kinetic plus potential energy (F,), J."""
        return self.kinetic_energy + self.potential_energy

    @property
    def iterations(self) -> np.ndarray:
        """PGS sweeps of each step (T,)."""
        return self.solver["iterations"]

    @property
    def residual(self) -> np.ndarray:
        """Natural residual at the end of each step's solve (T,), m/s."""
        return self.solver["residual"]

    @property
    def converged(self) -> np.ndarray:
        """Whether each step's iterate stage met its tolerance (T,) bool."""
        return self.solver["converged"]

    @property
    def penetration(self) -> np.ndarray:
        """Largest penetration of each step (T,), m: max(-min_gap, 0), 0 for steps without contacts."""
        return np.where(np.isnan(self.min_gap), 0.0, np.maximum(-np.nan_to_num(self.min_gap), 0.0))

    def frame_contacts(self, f: int) -> dict:
        """The contacts shown at frame f: a dict of ``CONTACT_KEYS`` arrays (K rows; empty if the
        record has none)."""
        if self.contacts is None:
            return {"body_a": np.zeros(0, np.int64), "body_b": np.zeros(0, np.int64),
                    "point": np.zeros((0, 3)), "normal": np.zeros((0, 3)), "force": np.zeros((0, 3)),
                    "gap": np.zeros(0)}
        lo, hi = self.contacts["offsets"][f], self.contacts["offsets"][f + 1]
        return {k: self.contacts[k][lo:hi] for k in CONTACT_KEYS}

    def frame_at(self, t: float) -> int:
        """The frame nearest to time t (s)."""
        return int(np.argmin(np.abs(self.time - t)))

    def world_vertices(self, i: int, f: int) -> np.ndarray:
        """Body i's draw mesh in world coordinates at frame f, (n_i, 3) m."""
        return meshes.posed(self.draw_meshes[i][0], self.positions[f, i], self.orientations[f, i])

    def save(self, path) -> Path:
        """``save_trajectory(path, self)``."""
        return save_trajectory(path, self)

    def select_frames(self, frames) -> "Record":
        """A record of only the given frames (increasing indices), with their contacts; the step
        arrays, the scene and the stride's meaning (frame_step) are kept as they are."""
        idx = np.asarray(frames, dtype=np.int64)
        if idx.ndim != 1 or idx.size == 0 or np.any(np.diff(idx) <= 0) or idx[0] < 0 or idx[-1] >= self.frames:
            raise ValueError(f"select_frames: need increasing frame indices in [0, {self.frames}), got {frames!r}")
        contacts = None
        if self.contacts is not None:
            o = self.contacts["offsets"]
            rows = np.concatenate([np.arange(o[f], o[f + 1]) for f in idx]).astype(np.int64)
            counts = o[idx + 1] - o[idx]
            contacts = {k: self.contacts[k][rows] for k in CONTACT_KEYS}
            contacts["offsets"] = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        frame_fields = ("frame_step", "time", "positions", "orientations", "velocities", "angular_velocities",
                        "kinetic_energy", "potential_energy")
        return dataclasses.replace(self, contacts=contacts, **{k: getattr(self, k)[idx] for k in frame_fields})


# the scene: shape parameters, names, meshes for drawing


def shape_params(shape) -> dict:
    """A shape's parameters as plain JSON-able data (m, body frame): ``{"type": kind, ...}``.

    Kinds and keys: sphere (radius), box (half_extents), capsule (radius, half_length), cylinder
    (radius, half_height), plane (normal, offset), mesh / hull / trimesh (num_vertices,
    num_faces; the geometry itself is the body's draw mesh), compound (parts: a list of
    {"shape": params, "position": (3,), "orientation": (4,) w x y z}). Attributes are tested
    rather than classes for look-alike objects (the codec's data form, ``codec.shape_to_data``).
    """
    return codec.shape_to_data(shape)


def body_names(world, names=None) -> list[str]:
    """One name per body: ``names`` when given (N strings, unique), else "<kind>_<index>"
    (``plane_0``, ``box_1``), which are valid node names in glTF and USD."""
    n = world.num_bodies
    if names is not None:
        names = [str(x) for x in names]
        if len(names) != n:
            raise ValueError(f"names: {len(names)} names for {n} bodies")
        if len(set(names)) != n:
            raise ValueError(f"names: not unique: {names}")
        return names
    return [f"{shape_params(world.shape(i))['type']}_{i}" for i in range(n)]


def plane_patch(normal, offset: float, centre, half: float, cells: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """A square (2 half) x (2 half) m on the plane n . x = offset, centred on the projection of
    centre (3,), as a grid of cells x cells squares (so a near camera clips it cell by cell):
    (vertices ((cells + 1)^2, 3), faces (2 cells^2, 3)) facing along n."""
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    c = np.asarray(centre, dtype=np.float64)
    c = c - (n @ c - offset) * n
    e1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    u = np.linspace(-half, half, cells + 1)
    a, b = np.meshgrid(u, u, indexing="ij")
    v = c + a.reshape(-1, 1) * e1 + b.reshape(-1, 1) * e2
    i, j = np.meshgrid(np.arange(cells), np.arange(cells), indexing="ij")
    p0 = (i * (cells + 1) + j).ravel()
    p1, p2, p3 = p0 + cells + 1, p0 + cells + 2, p0 + 1
    faces = np.concatenate([np.stack([p0, p1, p2], 1), np.stack([p0, p2, p3], 1)]).astype(np.int64)
    return v, faces


# recording


class Recorder:
    """Records a world as it steps: every step's contact count, smallest gap and solver report, every
    ``stride``-th step's state (and contacts, with ``contacts=True``), and the scene.

        rec = sg.Recorder(world, stride=4)       # frame 0 is the state now
        rec.step(dt=1/240, steps=480)             # steps the world, recording
        record = rec.record()                     # a Record; record.save("run.npz")

    A world stepped by other code is recorded by calling ``rec.observe()`` after each single step.
    Inputs: world (a ``signorini.World``), stride (int >= 1), contacts (bool), names (N strings or
    None, see ``body_names``), scene (the run's name).
    """

    def __init__(self, world, *, stride: int = 1, contacts: bool = True, names=None, scene: str = "world"):
        if isinstance(stride, bool) or not isinstance(stride, (int, np.integer)) or stride < 1:
            raise ValueError(f"Recorder: stride must be an integer >= 1, got {stride!r}")
        self.world = world
        self.stride = int(stride)
        self.with_contacts = bool(contacts)
        self.scene = str(scene)
        self.names = body_names(world, names)
        n = world.num_bodies
        self._shapes = [world.shape(i) for i in range(n)]
        self.wall_time = 0.0
        self.dt = None
        self._steps = 0
        self._frames = {k: [] for k in ("frame_step", "time", "positions", "orientations", "velocities",
                                        "angular_velocities", "kinetic_energy", "potential_energy")}
        # per-step numbers in typed arrays: 8 bytes a number, not a Python object each
        self._step = {"step_time": array("d"), "num_contacts": array("q"), "min_gap": array("d")}
        self._solver: dict[str, array] = {}
        self._contacts = {k: [] for k in CONTACT_KEYS}
        self._contact_counts = [0]
        self._pending = None  # contacts of the last step, kept until we know it is a frame
        self._frame()

    @property
    def steps(self) -> int:
        """Steps observed so far."""
        return self._steps

    @property
    def frames(self) -> int:
        """Frames recorded so far."""
        return len(self._frames["time"])

    def frame(self, f: int) -> dict:
        """Frame f as recorded so far, without building a Record: time (s), positions (N, 3),
        orientations (N, 4), velocities (N, 3), angular_velocities (N, 3) and contacts (a dict of
        ``CONTACT_KEYS`` arrays, or None when contacts are not recorded)."""
        out = {k: self._frames[k][f] for k in ("time", "positions", "orientations", "velocities",
                                               "angular_velocities")}
        out["contacts"] = None
        if self.with_contacts and f > 0:
            out["contacts"] = {k: self._contacts[k][f - 1] for k in CONTACT_KEYS}
        return out

    def _frame(self) -> None:
        """Append the world's current state as a frame."""
        w = self.world
        f = self._frames
        f["frame_step"].append(self._steps)
        f["time"].append(float(w.time))
        f["positions"].append(np.array(w.positions, dtype=np.float64))
        f["orientations"].append(np.array(w.orientations, dtype=np.float64))
        f["velocities"].append(np.array(w.velocities, dtype=np.float64))
        f["angular_velocities"].append(np.array(w.angular_velocities, dtype=np.float64))
        f["kinetic_energy"].append(float(w.kinetic_energy()))
        f["potential_energy"].append(float(w.potential_energy()))
        if self._steps > 0 and self.with_contacts:
            c = self._pending
            for k in CONTACT_KEYS:
                self._contacts[k].append(c[k])
            self._contact_counts.append(len(c["gap"]))

    def observe(self) -> None:
        """Record the step the world just took (call once after every single step)."""
        w = self.world
        t = float(w.time)
        if self.dt is None:
            self.dt = t - self._frames["time"][0]
        self._steps += 1

        # the step's numbers: contacts found at its start and the solver's report
        contacts = w.contacts
        gap = np.asarray(contacts.gap, dtype=np.float64)
        self._step["step_time"].append(t)
        self._step["num_contacts"].append(gap.size)
        self._step["min_gap"].append(float(gap.min()) if gap.size else math.nan)
        stats = w.solver_stats
        values = dataclasses.asdict(stats) if dataclasses.is_dataclass(stats) else dict(vars(stats))
        if not self._solver:
            kinds = {k: ("b" if isinstance(v, (bool, np.bool_)) else "q" if isinstance(v, (int, np.integer)) else "d")
                     for k, v in values.items() if isinstance(v, (bool, int, float, np.number, np.bool_))}
            self._solver = {k: array(code) for k, code in kinds.items()}
        for k, column in self._solver.items():
            column.append(values[k])

        # a frame every stride steps; the contacts are read only when they will be kept
        if self._steps % self.stride == 0:
            self._pending = self._read_contacts(contacts) if self.with_contacts else None
            self._frame()
        elif self.with_contacts:
            self._pending = contacts  # converted if this step turns out to be the last

    def _read_contacts(self, c) -> dict:
        n = len(np.asarray(c.gap))
        return {
            "body_a": np.asarray(c.body_a, dtype=np.int64).reshape(n),
            "body_b": np.asarray(c.body_b, dtype=np.int64).reshape(n),
            "point": np.asarray(c.point, dtype=np.float64).reshape(n, 3),
            "normal": np.asarray(c.normal, dtype=np.float64).reshape(n, 3),
            "force": np.asarray(c.force, dtype=np.float64).reshape(n, 3),
            "gap": np.asarray(c.gap, dtype=np.float64).reshape(n),
        }

    def step(self, dt: float, steps: int = 1, progress=None) -> None:
        """Advance the world ``steps`` single steps of dt (s), observing each; ``progress`` is an
        optional callable called with 1 after each step (a tqdm bar's ``update``).

        Warnings of one category are gathered and given once, the first one's text with how many
        recorded steps raised it (a world's ``SolverWarning`` comes once, with how many recorded
        solver substeps were unconverged: ``World.unconverged_substeps``).
        """
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 0:
            raise ValueError(f"Recorder.step: steps must be an integer >= 0, got {steps!r}")
        if not (isinstance(dt, (int, float, np.number)) and math.isfinite(dt) and dt > 0):
            raise ValueError(f"Recorder.step: dt must be a finite number > 0, got {dt!r}")
        flagged = getattr(self.world, "unconverged_substeps", 0)  # a duck-typed world may have none
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for _ in range(int(steps)):
                start = _time.perf_counter()
                self.world.step(dt=dt, steps=1)
                self.wall_time += _time.perf_counter() - start
                self.observe()
                if progress is not None:
                    progress(1)
        first: dict = {}
        for w in caught:
            first.setdefault(w.category, [w.message, 0])[1] += 1
        flagged = getattr(self.world, "unconverged_substeps", 0) - flagged
        for category, (message, count) in first.items():
            more = f" [{count} of {steps} recorded steps warned; this is the first]" if count > 1 else ""
            if issubclass(category, SolverWarning) and flagged > 1:
                more = f" [{flagged} unconverged solver substeps in {steps} recorded steps]"
            warnings.warn(f"{message}{more}", category, stacklevel=2)
        if steps:
            self.dt = float(dt)

    def record(self) -> Record:
        """The recording so far as a ``Record`` (the last step becomes a frame if it is not one)."""
        if self._frames["frame_step"][-1] != self._steps:
            if self.with_contacts:
                self._pending = self._read_contacts(self._pending)
            self._frame()
        f = {k: np.array(v) for k, v in self._frames.items()}
        f["frame_step"] = f["frame_step"].astype(np.int64)
        steps = self._steps
        solver = {k: np.array(v, dtype=bool if v.typecode == "b" else None) for k, v in self._solver.items()}
        contacts = None
        if self.with_contacts:
            contacts = {"offsets": np.concatenate([[0], np.cumsum(self._contact_counts)]).astype(np.int64)}
            for k in CONTACT_KEYS:
                empty = np.zeros((0, 3)) if k in ("point", "normal", "force") else np.zeros(0)
                parts = self._contacts[k]
                contacts[k] = np.concatenate(parts) if parts else empty
                if k in ("body_a", "body_b"):
                    contacts[k] = contacts[k].astype(np.int64)
        is_static = np.array(self.world.is_static, dtype=bool)
        return Record(
            scene=self.scene,
            dt=float(self.dt) if self.dt is not None else 0.0,
            stride=self.stride,
            wall_time=float(self.wall_time),
            names=list(self.names),
            shapes=[shape_params(s) for s in self._shapes],
            draw_meshes=_draw_meshes(self._shapes, f["positions"], is_static),
            masses=np.array(self.world.masses, dtype=np.float64),
            is_static=is_static,
            gravity=np.array(getattr(self.world, "gravity", np.zeros(3)), dtype=np.float64).reshape(3),
            step_time=np.array(self._step["step_time"], dtype=np.float64).reshape(steps),
            num_contacts=np.array(self._step["num_contacts"], dtype=np.int64).reshape(steps),
            min_gap=np.array(self._step["min_gap"], dtype=np.float64).reshape(steps),
            solver=solver,
            contacts=contacts,
            **f,
        )


def _draw_meshes(shapes, positions, is_static) -> list:
    """Body-frame triangle meshes for drawing; planes become patches around the dynamic bodies'
    whole path (every body's if none is dynamic). Round shapes get 320 triangles, or 80 in scenes
    of more than 200 bodies (a thousand spheres stay quick to draw and to store)."""
    subdivisions = 2 if len(shapes) <= 200 else 1
    out = [meshes.render_mesh(s, sphere_subdivisions=subdivisions) for s in shapes]
    moving = positions[:, ~is_static].reshape(-1, 3) if (~is_static).any() else positions.reshape(-1, 3)
    lo, hi = moving.min(axis=0), moving.max(axis=0)
    centre = 0.5 * (lo + hi)
    # the largest body's reach, so a patch is never smaller than what lies on it
    reach = max([float(np.linalg.norm(m[0], axis=1).max()) for m, st in zip(out, is_static)
                 if m is not None and len(m[0]) and not st] or [0.5])
    half = 0.75 * float(np.max(hi - lo)) + 3.0 * reach
    for i, s in enumerate(shapes):
        if out[i] is None:
            out[i] = plane_patch(s.normal, float(s.offset), centre, half)
        v, f = out[i]
        out[i] = (np.array(v, dtype=np.float64).reshape(-1, 3), np.array(f, dtype=np.int64).reshape(-1, 3))
    return out


# the file


def save_trajectory(path, record: Record) -> Path:
    """Write a record to one compressed .npz (no pickles); returns the path.

    Keys: the Record's array fields by name; ``solver_<field>`` for the solver report;
    ``contact_<key>`` and ``contact_offsets`` when contacts were recorded; ``names`` (N,) str;
    ``shapes`` a JSON string; the draw meshes concatenated as ``mesh_vertices`` (V, 3),
    ``mesh_faces`` (K, 3) (indices local to each body) with ``mesh_vertex_offsets`` and
    ``mesh_face_offsets`` (N + 1,); ``format`` and ``version``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {
        "format": np.array(TRAJECTORY_FORMAT), "version": np.array(TRAJECTORY_VERSION),
        "scene": np.array(record.scene), "dt": np.array(record.dt), "stride": np.array(record.stride),
        "wall_time": np.array(record.wall_time), "names": np.array(record.names, dtype=str),
        "shapes": np.array(json.dumps(record.shapes)),
        "mesh_vertices": np.concatenate([v for v, _ in record.draw_meshes]).reshape(-1, 3),
        "mesh_faces": np.concatenate([f for _, f in record.draw_meshes]).reshape(-1, 3).astype(np.int64),
        "mesh_vertex_offsets": np.cumsum([0] + [len(v) for v, _ in record.draw_meshes]).astype(np.int64),
        "mesh_face_offsets": np.cumsum([0] + [len(f) for _, f in record.draw_meshes]).astype(np.int64),
        "has_contacts": np.array(record.contacts is not None),
    }
    for name in _ARRAYS:
        data[name] = np.asarray(getattr(record, name))
    for k, v in record.solver.items():
        data[f"solver_{k}"] = np.asarray(v)
    if record.contacts is not None:
        for k, v in record.contacts.items():
            data[f"contact_{k}"] = np.asarray(v)
    np.savez_compressed(path, **data)
    return path


_ARRAYS = ("masses", "is_static", "gravity", "frame_step", "time", "positions", "orientations", "velocities",
           "angular_velocities", "kinetic_energy", "potential_energy", "step_time", "num_contacts", "min_gap")


#: the most bytes a trajectory's arrays may hold once decompressed, all together (a 1,000-body run
#: of 5,000 frames with its contacts is about 0.8 GB); checked from the arrays' headers before any is
#: read, so a small file claiming gigabytes is refused at once; ``load_trajectory(max_bytes=)`` raises it
MAX_TRAJECTORY_BYTES = 1 << 30
#: the most bytes a trajectory's arrays may hold per byte of the file once they hold more than
#: ``TRAJECTORY_RATIO_FLOOR``, checked from the headers too, so that what a file makes the loader
#: take in memory stays within this multiple of its size. The built-in scenes' recordings hold 1.4
#: to 6.1 bytes per byte of file (contacts included; their most compressible member, the contacts'
#: body indices, 106 to 191); a world of almost only static or resting bodies records mostly
#: repeated poses and zero velocities, about 220 (so over the floor, 256 MiB of arrays, it needs
#: ``load_trajectory(max_ratio=None)``); deflated zeros reach 1,032. README "Files" has the figures
MAX_TRAJECTORY_RATIO = 64
#: arrays of at most this many bytes (256 MiB) load whatever their ratio (a small file's floor)
TRAJECTORY_RATIO_FLOOR = 256 << 20
#: deepest nesting of the ``shapes`` JSON (a compound part's box is 6 deep; the format is otherwise flat)
MAX_SHAPES_DEPTH = 16
# arrays of numbers that must be finite (min_gap is NaN for steps without contacts; masses are inf
# for static bodies, checked apart)
_FINITE = ("gravity", "time", "positions", "orientations", "velocities", "angular_velocities", "kinetic_energy",
           "potential_energy", "step_time", "mesh_vertices")
_SCALARS = ("format", "version", "scene", "dt", "stride", "wall_time", "shapes", "has_contacts")


def load_trajectory(path, *, max_bytes: int = MAX_TRAJECTORY_BYTES,
                    max_ratio: float | None = MAX_TRAJECTORY_RATIO) -> Record:
    """Read a trajectory written by ``save_trajectory`` (or the command line).

    Limits, checked before the arrays are read: the arrays hold at most ``max_bytes`` once
    decompressed (``MAX_TRAJECTORY_BYTES``, 1 GiB, by default) and, above
    ``TRAJECTORY_RATIO_FLOOR`` (256 MiB), at most ``max_ratio`` times the file's size
    (``MAX_TRAJECTORY_RATIO``, 64; None: no bound, for a file you trust), each array's .npy header
    agrees with its zip entry's size and that size with what deflate can hold in the compressed
    bytes, no array holds Python objects; the ``shapes`` JSON is nested at most
    ``MAX_SHAPES_DEPTH`` deep.
    Values, checked after: poses, velocities, times, energies, gravity and draw meshes are finite,
    masses > 0 (inf for static bodies), the mesh and contact offsets start at 0, never decrease and
    end at their array's length, faces index their own body's vertices, contacts name bodies that
    exist, ``dt`` >= 0 and ``stride`` >= 1.

    Raises FileNotFoundError for a missing file and ValueError naming the file and the array for
    anything that is not a readable signorini trajectory (not an .npz, truncated, over a limit,
    missing, inconsistent or non-finite arrays; running out of memory is reported the same way).
    """
    if max_ratio is not None:
        if isinstance(max_ratio, (bool, np.bool_)) or not isinstance(max_ratio, (int, float, np.integer, np.floating)):
            raise TypeError(f"load_trajectory: max_ratio must be a number or None, got {max_ratio!r}")
        if not max_ratio > 0:
            raise ValueError(f"load_trajectory: max_ratio must be > 0 (or None: no bound), got {max_ratio!r}")
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such trajectory file")
    if not zipfile.is_zipfile(path):
        raise ValueError(f"{path}: not a signorini trajectory (not an .npz file: no zip archive inside)")
    try:
        data = filecheck.read_npz(path, max_bytes, max_ratio=max_ratio, ratio_floor=TRAJECTORY_RATIO_FLOOR)
        if "format" not in data or data["format"].shape != () or str(data["format"]) != TRAJECTORY_FORMAT:
            raise ValueError(f"{path}: not a signorini trajectory (no format marker {TRAJECTORY_FORMAT!r}; "
                             "written by an older version or another program?)")
        missing = [k for k in _ARRAYS + ("scene", "dt", "stride", "names", "shapes", "mesh_vertices", "mesh_faces",
                                         "mesh_vertex_offsets", "mesh_face_offsets") if k not in data]
        if missing:
            raise ValueError(f"{path}: trajectory is missing {', '.join(missing)}")
        _check_values(data, path)
        vo, fo = data["mesh_vertex_offsets"], data["mesh_face_offsets"]
        draw = [(data["mesh_vertices"][vo[i]:vo[i + 1]], data["mesh_faces"][fo[i]:fo[i + 1]])
                for i in range(len(vo) - 1)]
        contacts = None
        if bool(data.get("has_contacts", False)):
            contacts = {k: data[f"contact_{k}"] for k in ("offsets",) + CONTACT_KEYS}
        record = Record(
            scene=str(data["scene"]), dt=float(data["dt"]), stride=int(data["stride"]),
            wall_time=float(data.get("wall_time", 0.0)), names=[str(x) for x in data["names"]],
            shapes=_shapes(str(data["shapes"]), path), draw_meshes=draw,
            solver={k[len("solver_"):]: v for k, v in data.items() if k.startswith("solver_")},
            contacts=contacts, **{k: data[k] for k in _ARRAYS},
        )
        _check(record, path)
    except filecheck.FileLimitError as e:
        lift = "; load_trajectory(path, max_ratio=None) reads a file you trust" \
            if isinstance(e, filecheck.RatioLimitError) else ""
        raise ValueError(f"{path}: not a readable signorini trajectory (.npz): {e}{lift}") from None
    except (KeyError, IndexError, TypeError, OverflowError) as e:
        raise ValueError(f"{path}: corrupt trajectory: {type(e).__name__}: {e}") from None
    except (MemoryError, RecursionError) as e:
        raise ValueError(f"{path}: corrupt trajectory: out of memory or nested too deep reading it "
                         f"({type(e).__name__})") from None
    except ValueError as e:
        message = str(e)
        raise ValueError(message if message.startswith(str(path)) else f"{path}: corrupt trajectory: {message}") \
            from None
    return record


def _shapes(text: str, path) -> list:
    """The ``shapes`` JSON: a list of dicts each with a string "type", nested at most MAX_SHAPES_DEPTH."""
    filecheck.json_depth(text, MAX_SHAPES_DEPTH)
    shapes = json.loads(text)
    if not isinstance(shapes, list) or not all(isinstance(d, dict) and isinstance(d.get("type"), str)
                                               for d in shapes):
        raise ValueError(f"{path}: corrupt trajectory: shapes must be a list of {{\"type\": ...}} objects")
    return shapes


def _offsets(data: dict, key: str, rows: int, parts: int, path) -> np.ndarray:
    """An offsets array (parts + 1,) int: 0 first, never decreasing, rows last; else ValueError."""
    o = data[key]
    if o.dtype.kind not in "iu" or o.shape != (parts + 1,) or o[0] != 0 or o[-1] != rows or np.any(np.diff(o) < 0):
        shown = o[:6].tolist() if o.ndim == 1 else o.shape
        raise ValueError(f"{path}: corrupt trajectory: {key} must be {parts + 1} integers from 0 up to {rows}, "
                         f"never decreasing; got {shown}{' ...' if o.size > 6 else ''}")
    return o.astype(np.int64)


def _check_values(data: dict, path) -> None:
    """ValueError naming the file and the array for a value a trajectory cannot hold (see
    ``load_trajectory``); runs on the file's arrays before a Record is built from them."""
    def bad(key: str, problem: str):
        return ValueError(f"{path}: corrupt trajectory: {key} {problem}")

    for key in _SCALARS:
        if key in data and data[key].shape != ():
            raise bad(key, f"must be a single value, got shape {data[key].shape}")
    for key in _ARRAYS + ("mesh_vertices", "mesh_faces"):
        if data[key].dtype.kind not in "biuf":
            raise bad(key, f"must hold numbers, got dtype {data[key].dtype}")
    for key in _FINITE:
        if not np.all(np.isfinite(data[key])):
            raise bad(key, "holds a value that is not finite (NaN or infinity)")
    masses = data["masses"]
    if np.any(np.isnan(masses)) or np.any(masses <= 0):
        raise bad("masses", "must be > 0 (inf for static bodies)")
    dt, stride = data["dt"], data["stride"]
    if dt.dtype.kind not in "iuf" or not (math.isfinite(float(dt)) and float(dt) >= 0):
        raise bad("dt", f"must be a finite number >= 0, got {dt}")
    if stride.dtype.kind not in "iu" or int(stride) < 1:
        raise bad("stride", f"must be an integer >= 1, got {stride}")
    n = len(data["names"]) if data["names"].ndim == 1 else -1
    vertices, faces = data["mesh_vertices"], data["mesh_faces"]
    if vertices.ndim != 2 or vertices.shape[1:] != (3,) or faces.ndim != 2 or faces.shape[1:] != (3,):
        raise bad("mesh_vertices", f"and mesh_faces must be (V, 3) and (K, 3), got {vertices.shape} and {faces.shape}")
    vo = _offsets(data, "mesh_vertex_offsets", len(vertices), max(n, 0), path)
    fo = _offsets(data, "mesh_face_offsets", len(faces), max(n, 0), path)
    # each body's faces index its own vertices: 0 <= face < its vertex count
    counts = np.repeat(np.diff(vo), np.diff(fo))
    if faces.size and (faces.dtype.kind not in "iu" or np.any(faces < 0) or np.any(faces >= counts[:, None])):
        raise bad("mesh_faces", "index vertices outside their body's draw mesh")
    if "has_contacts" in data and bool(data["has_contacts"]):
        missing = [f"contact_{k}" for k in ("offsets",) + CONTACT_KEYS if f"contact_{k}" not in data]
        if missing:
            raise bad("contacts", f"are missing {', '.join(missing)}")
        c = len(data["contact_gap"]) if data["contact_gap"].ndim == 1 else -1
        frames = len(data["time"]) if data["time"].ndim == 1 else 0
        _offsets(data, "contact_offsets", c, frames, path)
        for k in CONTACT_KEYS:
            a = data[f"contact_{k}"]
            if a.shape != ((c, 3) if k in ("point", "normal", "force") else (c,)) or a.dtype.kind not in "iuf":
                raise bad(f"contact_{k}", f"must be {c} rows of numbers, got {a.shape} {a.dtype}")
            if k in ("body_a", "body_b"):
                if np.any(a < 0) or np.any(a >= n):
                    raise bad(f"contact_{k}", f"names a body outside 0..{n - 1}")
            elif not np.all(np.isfinite(a)):
                raise bad(f"contact_{k}", "holds a value that is not finite (NaN or infinity)")


def _check(r: Record, path) -> None:
    """ValueError naming the file and the array when the record's shapes disagree."""
    f, n, t = len(r.time), len(r.names), len(r.step_time)
    expect = {"positions": (f, n, 3), "orientations": (f, n, 4), "velocities": (f, n, 3),
              "angular_velocities": (f, n, 3), "kinetic_energy": (f,), "potential_energy": (f,),
              "frame_step": (f,), "masses": (n,), "is_static": (n,), "gravity": (3,), "num_contacts": (t,),
              "min_gap": (t,)}
    for k, shape in expect.items():
        if getattr(r, k).shape != shape:
            raise ValueError(f"{path}: corrupt trajectory: {k} has shape {getattr(r, k).shape}, expected {shape}")
    if len(r.draw_meshes) != n or len(r.shapes) != n:
        raise ValueError(f"{path}: corrupt trajectory: {len(r.draw_meshes)} meshes for {n} bodies")
    if f < 1:
        raise ValueError(f"{path}: trajectory has no frames")
    if r.contacts is not None and len(r.contacts["offsets"]) != f + 1:
        raise ValueError(f"{path}: corrupt trajectory: contact offsets do not match {f} frames")
    for k, v in r.solver.items():
        if v.shape != (t,) or v.dtype.kind not in "biuf":
            raise ValueError(f"{path}: corrupt trajectory: solver_{k} has shape {v.shape} {v.dtype}, expected ({t},) "
                             "numbers")
