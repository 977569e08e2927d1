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
- ``events``, the world's contact events of every step (``World.events``), a dict of kind
  (``EVENT_KINDS``: begin, end, hits, sensor_begin, sensor_end) -> dict of arrays, E rows each:
  ``step`` (E,) int64, the step k (0-based: it ended at ``step_time[k]``), ``body_a``, ``body_b``
  (E,) int64, ``point``, ``normal`` (E, 3), ``speed`` (E,) m/s, ``impulse`` (E,) N s; empty for a
  world without events (and a file written before them);
- ``scene`` (str), ``dt`` (s), ``stride`` (int), ``wall_time`` (s spent in ``World.step``).

Size. A ``Recorder`` left to choose its stride (the default) keeps a frame every s steps so that the
file's frame arrays hold at most ``TRAJECTORY_BUDGET`` (20 MB) before compression: s is chosen from
the moving bodies and the steps (``auto_stride``, allowing ``CONTACTS_PER_BODY`` contacts a body)
and the frames are thinned further at ``record()`` if the contacts passed that allowance
(``fit_budget``). A stride given (``Recorder(stride=...)``, ``run --stride``) is kept as given.

Memory. The recorder appends frames to temporary files a chunk at a time (``CHUNK_BYTES``) and
holds at most one chunk; ``Recorder.record()`` gives the frame arrays and contacts as read-only
memory maps of those files (float64, the run's exact values). The step arrays grow by 15 numbers
(120 bytes) a step, kept in typed arrays.

The file is one compressed ``.npz`` (no pickles): ``save_trajectory(path, record)`` (also
``record.save(path)``) and ``load_trajectory(path)``; the command line writes it. Version 2 (this
one) stores the poses and velocities of the bodies that move as **float32** and those of bodies
that never move (static bodies) once; contacts as float32 and int32. ``load_trajectory`` gives
float64 and int64 arrays back, as a recording holds them: a coordinate x comes back within
2^-24 |x| of the recorded value (float32 rounding), a still body's exactly. Version 1 files
(float64, every body every frame) still load.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import tempfile
import time as _time
import warnings
import weakref
import zipfile
from array import array
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import codec, filecheck, meshes
from .world import SolverWarning, user_stacklevel

__all__ = ["Record", "Recorder", "save_trajectory", "load_trajectory", "shape_params", "body_names",
           "TRAJECTORY_FORMAT", "TRAJECTORY_BUDGET", "auto_stride", "fit_budget", "record_bytes", "moving_bodies"]

TRAJECTORY_FORMAT = "signorini-trajectory"
TRAJECTORY_VERSION = 2  # 1: every frame of every body in float64 (still read)
CONTACT_KEYS = ("body_a", "body_b", "point", "normal", "force", "gap")


#: the kinds of contact events a record keeps (``World.events``) and their fields
EVENT_KINDS = ("begin", "end", "hits", "sensor_begin", "sensor_end")
EVENT_FIELDS = ("step", "body_a", "body_b", "point", "normal", "speed", "impulse")


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
    events: dict = dataclasses.field(default_factory=lambda: _no_events())

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

#: the default size of a recording's frame arrays as the file holds them, before compression
#: (bytes): the poses and velocities of the moving bodies (float32, ``BODY_FRAME_BYTES`` a body)
#: and the frames' contacts (``CONTACT_BYTES`` each). A ``Recorder`` whose stride is left to it
#: keeps every s-th step so that a run fits (``auto_stride``), and thins the frames further when
#: it records more contacts than it allowed for. 20 MB keeps a run's trajectory and its player
#: (which stores about as much again, base64) under 50 MB together.
TRAJECTORY_BUDGET = 20_000_000
#: file bytes of one moving body in one frame: position 3, orientation 4, velocity 3, angular
#: velocity 3, as float32
BODY_FRAME_BYTES = 13 * 4
#: file bytes of one contact: point, normal, force (3 float32 each), gap (float32), body_a, body_b (int32)
CONTACT_BYTES = 10 * 4 + 2 * 4
#: contacts a moving body is expected to have in a frame, when the stride is chosen before the run
#: (a box resting on a box has 4; a sphere in a pile about 3)
CONTACTS_PER_BODY = 4
#: the bytes of frames a ``Recorder`` holds in memory before it appends them to its spool on disk
CHUNK_BYTES = 4 << 20

_FRAME_ARRAYS = {"positions": 3, "orientations": 4, "velocities": 3, "angular_velocities": 3}
_FRAME_SCALARS = ("frame_step", "time", "kinetic_energy", "potential_energy")


def frame_bytes(moving_bodies: int, contacts: int = 0) -> int:
    """File bytes of frames holding ``moving_bodies`` body poses in all and ``contacts`` contacts in all."""
    return int(moving_bodies) * BODY_FRAME_BYTES + int(contacts) * CONTACT_BYTES


def auto_stride(moving_bodies: int, steps: int, budget: float = TRAJECTORY_BUDGET, contacts: bool = True) -> int:
    """The smallest stride s >= 1 whose frames (ceil(steps / s) + 1 of them, ``moving_bodies``
    each, with ``CONTACTS_PER_BODY`` contacts a body when ``contacts``) fit in ``budget`` bytes."""
    per_frame = frame_bytes(max(int(moving_bodies), 1), CONTACTS_PER_BODY * max(int(moving_bodies), 1) if contacts else 0)
    frames = max(int(budget // per_frame), 2)
    return max(1, math.ceil(int(steps) / (frames - 1)))


class _Spool:
    """Rows of one dtype and row shape appended to an anonymous temporary file (deleted when
    closed or collected), read back as a read-only memory map."""

    def __init__(self, dtype, row_shape: tuple):
        self.dtype, self.row_shape = np.dtype(dtype), tuple(row_shape)
        self.row_bytes = self.dtype.itemsize * int(np.prod(self.row_shape, dtype=np.int64))
        self.rows = 0
        self._file = None

    def append(self, rows: np.ndarray) -> None:
        if len(rows) == 0:
            return
        if self._file is None:
            self._file = tempfile.TemporaryFile(prefix="signorini-frames-")
            # closed with the spool; a memory map made of it keeps the data until it goes too
            weakref.finalize(self, self._file.close)
        self._file.seek(0, 2)
        self._file.write(np.ascontiguousarray(rows, dtype=self.dtype).tobytes())
        self.rows += len(rows)

    def read(self, lo: int, hi: int) -> np.ndarray:
        """Rows lo:hi as a new array."""
        self._file.flush()
        data = os.pread(self._file.fileno(), (hi - lo) * self.row_bytes, lo * self.row_bytes)
        return np.frombuffer(data, dtype=self.dtype).reshape((hi - lo,) + self.row_shape).copy()

    def map(self) -> np.ndarray:
        """Every row so far, (rows, *row_shape), a read-only memory map of the file."""
        if self.rows == 0:
            return np.zeros((0,) + self.row_shape, dtype=self.dtype)
        self._file.flush()
        return np.memmap(self._file, dtype=self.dtype, mode="r", shape=(self.rows,) + self.row_shape)


class Recorder:
    """Records a world as it steps: every step's contact count, smallest gap and solver report, every
    ``stride``-th step's state (and contacts, with ``contacts=True``), and the scene.

        rec = sg.Recorder(world)                  # frame 0 is the state now
        rec.step(dt=1/240, steps=480)             # steps the world, recording
        record = rec.record()                     # a Record; record.save("run.npz")

    A world stepped by other code is recorded by calling ``rec.observe()`` after each single step.
    Inputs: world (a ``signorini.World``), stride (int >= 1, or None: chosen to fit ``budget``),
    steps (the run's length, when known before ``step`` is called: for the automatic stride),
    budget (bytes, ``TRAJECTORY_BUDGET`` by default), contacts (bool), names (N strings or None,
    see ``body_names``), scene (the run's name), chunk_bytes (``CHUNK_BYTES``).

    The stride. Given, it is kept. Left to the recorder (None), it is ``auto_stride`` of the moving
    bodies and the steps (``steps=``, or those of the first ``step`` call; 1 when neither comes
    before the first ``observe``), and ``record`` keeps every k-th frame (and the last) if the
    frames then hold more than ``budget`` bytes in the file (more contacts than allowed for), so the
    file's frame arrays hold at most ``budget`` bytes before compression. ``stride_auto`` says which.

    Memory. The frames go to temporary files on disk (``_Spool``) a chunk at a time, about
    ``chunk_bytes`` of them (``chunk_frames``); the recorder holds at most one chunk
    (``frames_in_memory``), plus the per-step numbers (120 bytes a step) and four numbers a frame.
    ``record()`` gives memory maps of those files (float64, exact), so a long run costs disk, not
    memory; the files go when the last array of them goes.
    """

    def __init__(self, world, *, stride: int | None = None, steps: int | None = None,
                 budget: float = TRAJECTORY_BUDGET, contacts: bool = True, names=None, scene: str = "world",
                 chunk_bytes: int = CHUNK_BYTES):
        if stride is not None and (isinstance(stride, bool) or not isinstance(stride, (int, np.integer)) or stride < 1):
            raise ValueError(f"Recorder: stride must be an integer >= 1 or None (chosen to fit the budget), got {stride!r}")
        if steps is not None and (isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 0):
            raise ValueError(f"Recorder: steps must be an integer >= 0 or None, got {steps!r}")
        if isinstance(budget, bool) or not isinstance(budget, (int, float, np.number)) or not budget > 0:
            raise ValueError(f"Recorder: budget must be a number of bytes > 0, got {budget!r}")
        if isinstance(chunk_bytes, bool) or not isinstance(chunk_bytes, (int, np.integer)) or chunk_bytes < 1:
            raise ValueError(f"Recorder: chunk_bytes must be an integer >= 1, got {chunk_bytes!r}")
        self.world = world
        self.stride_auto = stride is None
        self.budget = float(budget)
        self.with_contacts = bool(contacts)
        self.scene = str(scene)
        self.names = body_names(world, names)
        n = world.num_bodies
        self._shapes = [world.shape(i) for i in range(n)]
        self._is_static = np.array(world.is_static, dtype=bool).reshape(n)
        self.stride = int(stride) if stride is not None else 1
        if self.stride_auto and steps is not None:
            self.stride = self._auto(int(steps))
        self.wall_time = 0.0
        self.dt = None
        self._steps = 0
        # frames: four numbers each in memory, the arrays in chunks spooled to disk
        self._scalars = {"frame_step": array("q"), "time": array("d"), "kinetic_energy": array("d"),
                         "potential_energy": array("d")}
        self._spool = {k: _Spool(np.float64, (n, m)) for k, m in _FRAME_ARRAYS.items()}
        self._chunk = {k: [] for k in _FRAME_ARRAYS}
        self.chunk_frames = max(1, int(chunk_bytes) // max(1, n * 13 * 8))
        # per-step numbers in typed arrays: 8 bytes a number, not a Python object each
        self._step = {"step_time": array("d"), "num_contacts": array("q"), "min_gap": array("d")}
        self._solver: dict[str, array] = {}
        self._contact_spool = {k: _Spool(np.int64 if k in ("body_a", "body_b") else np.float64,
                                         (3,) if k in ("point", "normal", "force") else ())
                               for k in CONTACT_KEYS}
        self._contact_chunk = {k: [] for k in CONTACT_KEYS}
        self._contact_counts = array("q", [0])
        # the contact events of every step (World.events), as lists of arrays per kind and field
        self._events = {kind: {k: [] for k in EVENT_FIELDS} for kind in EVENT_KINDS}
        self._pending = None  # contacts of the last step, kept until we know it is a frame
        self._frame()

    def _auto(self, steps: int) -> int:
        return auto_stride(int(np.count_nonzero(~self._is_static)), steps, self.budget, self.with_contacts)

    @property
    def steps(self) -> int:
        """Steps observed so far."""
        return self._steps

    @property
    def frames(self) -> int:
        """Frames recorded so far."""
        return len(self._scalars["time"])

    @property
    def frames_in_memory(self) -> int:
        """Frames held in memory, not yet appended to the spool on disk (at most ``chunk_frames``)."""
        return len(self._chunk["positions"])

    def frame(self, f: int) -> dict:
        """Frame f as recorded so far, without building a Record: time (s), positions (N, 3),
        orientations (N, 4), velocities (N, 3), angular_velocities (N, 3) and contacts (a dict of
        ``CONTACT_KEYS`` arrays, or None when contacts are not recorded)."""
        if not 0 <= f < self.frames:
            raise IndexError(f"Recorder.frame: frame {f} of {self.frames}")
        spooled = self._spool["positions"].rows
        out = {"time": self._scalars["time"][f]}
        for k in _FRAME_ARRAYS:
            out[k] = self._spool[k].read(f, f + 1)[0] if f < spooled else self._chunk[k][f - spooled]
        out["contacts"] = None
        if self.with_contacts and f > 0:
            lo, hi = int(np.sum(self._contact_counts[:f])), int(np.sum(self._contact_counts[:f + 1]))
            stored = self._contact_spool["gap"].rows
            if hi <= stored:
                out["contacts"] = {k: self._contact_spool[k].read(lo, hi) for k in CONTACT_KEYS}
            else:
                rows = {k: np.concatenate(v) if v else self._contact_spool[k].read(0, 0)
                        for k, v in self._contact_chunk.items()}
                out["contacts"] = {k: rows[k][lo - stored:hi - stored] for k in CONTACT_KEYS}
        return out

    def _frame(self) -> None:
        """Append the world's current state as a frame (to the chunk in memory; a full chunk goes to disk)."""
        w = self.world
        s = self._scalars
        s["frame_step"].append(self._steps)
        s["time"].append(float(w.time))
        s["kinetic_energy"].append(float(w.kinetic_energy()))
        s["potential_energy"].append(float(w.potential_energy()))
        for k in _FRAME_ARRAYS:
            self._chunk[k].append(np.array(getattr(w, k), dtype=np.float64))
        if self._steps > 0 and self.with_contacts:
            c = self._pending
            for k in CONTACT_KEYS:
                self._contact_chunk[k].append(c[k])
            self._contact_counts.append(len(c["gap"]))
        if self.frames_in_memory >= self.chunk_frames:
            self._flush()

    def _flush(self) -> None:
        """Append the chunk in memory to the spool files and empty it."""
        for k, rows in self._chunk.items():
            if rows:
                self._spool[k].append(np.stack(rows))
            rows.clear()
        for k, parts in self._contact_chunk.items():
            if parts:
                self._contact_spool[k].append(np.concatenate(parts))
            parts.clear()

    def observe(self) -> None:
        """Record the step the world just took (call once after every single step)."""
        w = self.world
        t = float(w.time)
        if self.dt is None:
            self.dt = t - self._scalars["time"][0]
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
        # the step's contact events (a world without them, duck-typed, has none)
        events = getattr(w, "events", None)
        for kind in EVENT_KINDS if events is not None else ():
            lst = getattr(events, kind)
            if len(lst):
                for k in EVENT_FIELDS:
                    v = np.asarray(getattr(lst, k))
                    self._events[kind][k].append(np.full(len(v), self._steps - 1, np.int64) if k == "step" else v)

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
        optional callable called with 1 after each step (a tqdm bar's ``update``). With an
        automatic stride and no steps recorded yet, the stride is chosen for these ``steps``.

        Warnings of one category are gathered and given once, the first one's text with how many
        recorded steps raised it (a world's ``SolverWarning`` comes once, with how many recorded
        solver substeps were unconverged: ``World.unconverged_substeps``).
        """
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 0:
            raise ValueError(f"Recorder.step: steps must be an integer >= 0, got {steps!r}")
        if not (isinstance(dt, (int, float, np.number)) and math.isfinite(dt) and dt > 0):
            raise ValueError(f"Recorder.step: dt must be a finite number > 0, got {dt!r}")
        if self.stride_auto and self._steps == 0:
            self.stride = self._auto(int(steps))
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
            warnings.warn(f"{message}{more}", category, stacklevel=user_stacklevel())
        if steps:
            self.dt = float(dt)

    def record(self) -> Record:
        """The recording so far as a ``Record`` (the last step becomes a frame if it is not one).
        Its frame arrays are read-only memory maps of the spool; with an automatic stride, frames
        are thinned to fit the budget (see the class docstring)."""
        if self._scalars["frame_step"][-1] != self._steps:
            if self.with_contacts:
                self._pending = self._read_contacts(self._pending)
            self._frame()
        self._flush()
        f = {k: self._spool[k].map() for k in _FRAME_ARRAYS}
        f.update({k: np.array(v, dtype=np.int64 if k == "frame_step" else np.float64) for k, v in self._scalars.items()})
        steps = self._steps
        solver = {k: np.array(v, dtype=bool if v.typecode == "b" else None) for k, v in self._solver.items()}
        contacts = None
        if self.with_contacts:
            counts = np.array(self._contact_counts, dtype=np.int64)
            contacts = {"offsets": np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)}
            contacts.update({k: self._contact_spool[k].map() for k in CONTACT_KEYS})
        record = Record(
            scene=self.scene,
            dt=float(self.dt) if self.dt is not None else 0.0,
            stride=self.stride,
            wall_time=float(self.wall_time),
            names=list(self.names),
            shapes=[shape_params(s) for s in self._shapes],
            draw_meshes=_draw_meshes(self._shapes, f["positions"], self._is_static),
            masses=np.array(self.world.masses, dtype=np.float64),
            is_static=self._is_static.copy(),
            gravity=np.array(getattr(self.world, "gravity", np.zeros(3)), dtype=np.float64).reshape(3),
            step_time=np.array(self._step["step_time"], dtype=np.float64).reshape(steps),
            num_contacts=np.array(self._step["num_contacts"], dtype=np.int64).reshape(steps),
            min_gap=np.array(self._step["min_gap"], dtype=np.float64).reshape(steps),
            solver=solver,
            contacts=contacts,
            events={kind: {k: (np.concatenate(parts) if parts else _no_events()[kind][k])
                           for k, parts in fields.items()} for kind, fields in self._events.items()},
            **f,
        )
        if self.stride_auto:
            record = fit_budget(record, self.budget)
        return record


def record_bytes(record: Record) -> int:
    """Bytes of a record's frame arrays as ``save_trajectory`` writes them, before compression:
    the moving bodies' poses and velocities (``BODY_FRAME_BYTES``) and the contacts
    (``CONTACT_BYTES``); bodies that never move are stored once and not counted."""
    contacts = len(record.contacts["gap"]) if record.contacts is not None else 0
    return frame_bytes(record.frames * int(np.count_nonzero(moving_bodies(record))), contacts)


def fit_budget(record: Record, budget: float = TRAJECTORY_BUDGET) -> Record:
    """The record itself when its frames fit ``budget`` bytes (``record_bytes``), else every k-th
    frame and the last, k the smallest that fits (the stride becomes stride k; the step arrays stay)."""
    if record_bytes(record) <= budget or record.frames <= 2:
        return record
    k = max(2, math.floor(record_bytes(record) / budget))
    while True:
        keep = list(range(0, record.frames, k))
        if keep[-1] != record.frames - 1:
            keep.append(record.frames - 1)
        thin = record.select_frames(keep)
        if record_bytes(thin) <= budget or len(keep) <= 2:
            return dataclasses.replace(thin, stride=record.stride * k)
        k += 1


def moving_bodies(record: Record, chunk: int = 256) -> np.ndarray:
    """(N,) bool: the bodies whose pose or velocity differs from frame 0's in some frame (read a
    chunk of frames at a time). The others are stored once in a file."""
    moving = np.zeros(record.num_bodies, dtype=bool)
    for k in _FRAME_ARRAYS:
        a = getattr(record, k)
        first = np.asarray(a[0])
        for lo in range(1, record.frames, chunk):
            moving |= np.any(np.asarray(a[lo:lo + chunk]) != first, axis=(0, 2))
    return moving


def _draw_meshes(shapes, positions, is_static) -> list:
    """Body-frame triangle meshes for drawing; planes become patches around the dynamic bodies'
    whole path (every body's if none is dynamic). Round shapes get 320 triangles, or 80 in scenes
    of more than 200 bodies (a thousand spheres stay quick to draw and to store)."""
    subdivisions = 2 if len(shapes) <= 200 else 1
    out = [meshes.render_mesh(s, sphere_subdivisions=subdivisions) for s in shapes]
    # the box of the moving bodies' path, a chunk of frames at a time (positions may be a memory map)
    columns = ~is_static if (~is_static).any() else np.ones(len(is_static), dtype=bool)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for start in range(0, len(positions), 256):
        chunk = np.asarray(positions[start:start + 256])[:, columns].reshape(-1, 3)
        lo, hi = np.minimum(lo, chunk.min(axis=0)), np.maximum(hi, chunk.max(axis=0))
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
    """Write a record to one compressed .npz (no pickles), format version 2; returns the path.

    Keys: ``format``, ``version`` (2), ``scene``, ``dt``, ``stride``, ``wall_time``, ``names`` (N,)
    str, ``shapes`` a JSON string; ``masses``, ``is_static``, ``gravity``; the frames' ``frame_step``,
    ``time``, ``kinetic_energy``, ``potential_energy`` (float64); ``moving`` (N,) bool, the bodies
    whose pose or velocity changes in some frame (``moving_bodies``): their poses and velocities
    every frame as **float32** ``frame_positions`` (F, M, 3), ``frame_orientations`` (F, M, 4),
    ``frame_velocities`` and ``frame_angular_velocities`` (F, M, 3), and the others' once, exact,
    as float64 ``still_positions`` (S, 3), ``still_orientations`` (S, 4), ``still_velocities`` and
    ``still_angular_velocities`` (S, 3) (static bodies always among them); the step arrays
    ``step_time``, ``num_contacts``, ``min_gap`` and ``solver_<field>``; with contacts,
    ``contact_offsets`` (F + 1,) int64, ``contact_body_a``, ``contact_body_b`` (C,) int32 and
    ``contact_point``, ``contact_normal``, ``contact_force`` (C, 3), ``contact_gap`` (C,) float32;
    the draw meshes concatenated as ``mesh_vertices`` (V, 3), ``mesh_faces`` (K, 3) (indices local
    to each body) with ``mesh_vertex_offsets`` and ``mesh_face_offsets`` (N + 1,).

    float32 keeps 24 bits: a stored coordinate x comes back within 2^-24 |x| (6e-8 relative; 0.6 um
    at 10 m), far below what a picture or a plot shows; the exact run is the simulator's to repeat.
    Arrays are written a chunk of frames at a time, so a memory-mapped record (``Recorder.record``)
    is never read into memory whole.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    moving = moving_bodies(record)
    still = ~moving
    small = {
        "format": np.array(TRAJECTORY_FORMAT), "version": np.array(TRAJECTORY_VERSION),
        "scene": np.array(record.scene), "dt": np.array(record.dt), "stride": np.array(record.stride),
        "wall_time": np.array(record.wall_time), "names": np.array(record.names, dtype=str),
        "shapes": np.array(json.dumps(record.shapes)),
        "mesh_vertices": np.concatenate([v for v, _ in record.draw_meshes]).reshape(-1, 3),
        "mesh_faces": np.concatenate([f for _, f in record.draw_meshes]).reshape(-1, 3).astype(np.int64),
        "mesh_vertex_offsets": np.cumsum([0] + [len(v) for v, _ in record.draw_meshes]).astype(np.int64),
        "mesh_face_offsets": np.cumsum([0] + [len(f) for _, f in record.draw_meshes]).astype(np.int64),
        "has_contacts": np.array(record.contacts is not None),
        "moving": moving,
    }
    for name in _ARRAYS_V2:
        small[name] = np.asarray(getattr(record, name))
    for k in _FRAME_ARRAYS:
        small[f"still_{k}"] = np.asarray(getattr(record, k)[0])[still].astype(np.float64)
    for k, v in record.solver.items():
        small[f"solver_{k}"] = np.asarray(v)
    for kind, fields in record.events.items():
        for k, v in fields.items():
            small[f"event_{kind}_{k}"] = np.asarray(v)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, allowZip64=True) as z:
        for name, value in small.items():
            _write_member(z, name, value, value.dtype)
        for k, m in _FRAME_ARRAYS.items():
            _write_member(z, f"frame_{k}", getattr(record, k), np.float32, columns=moving)
        if record.contacts is not None:
            c = record.contacts
            _write_member(z, "contact_offsets", np.asarray(c["offsets"]), np.int64)
            for k in CONTACT_KEYS:
                _write_member(z, f"contact_{k}", c[k], np.int32 if k in ("body_a", "body_b") else np.float32)
    return path


def _write_member(z: zipfile.ZipFile, name: str, a, dtype, columns=None, rows: int = 256) -> None:
    """Write a (or a[:, columns]) as ``name.npy`` of ``dtype`` into the open zip, ``rows`` of its
    first axis at a time (a may be a memory map: only a chunk is in memory at once)."""
    shape = tuple(a.shape) if columns is None else (a.shape[0], int(np.count_nonzero(columns))) + tuple(a.shape[2:])
    dtype = np.dtype(dtype)
    nbytes = dtype.itemsize * int(np.prod(shape, dtype=np.int64))
    header = {"descr": np.lib.format.dtype_to_descr(dtype), "fortran_order": False, "shape": shape}
    with z.open(name + ".npy", "w", force_zip64=nbytes > (1 << 30)) as out:
        np.lib.format.write_array_header_1_0(out, header)
        if len(shape) == 0:
            out.write(np.asarray(a, dtype=dtype).tobytes())
            return
        for lo in range(0, shape[0], rows):
            chunk = np.asarray(a[lo:lo + rows])
            if columns is not None:
                chunk = chunk[:, columns]
            out.write(np.ascontiguousarray(chunk, dtype=dtype).tobytes())


# the arrays a version 2 file holds as they are (the frame arrays are split into moving and still)
_ARRAYS_V2 = ("masses", "is_static", "gravity", "frame_step", "time", "kinetic_energy", "potential_energy",
              "step_time", "num_contacts", "min_gap")
_ARRAYS = ("masses", "is_static", "gravity", "frame_step", "time", "positions", "orientations", "velocities",
           "angular_velocities", "kinetic_energy", "potential_energy", "step_time", "num_contacts", "min_gap")


#: the most bytes a trajectory's arrays may hold once decompressed, all together (a 1,000-body run
#: of 5,000 frames with its contacts is about 0.8 GB); checked from the arrays' headers before any is
#: read, so a small file claiming gigabytes is refused at once; ``load_trajectory(max_bytes=)`` raises it
MAX_TRAJECTORY_BYTES = 1 << 30
#: the most bytes a trajectory's arrays may hold per byte of the file once they hold more than
#: ``TRAJECTORY_RATIO_FLOOR``, checked from the headers too, so that what a file makes the loader
#: take in memory stays within this multiple of its size. ``run pyramid``, ``rain`` and ``shapes``
#: write 2.2, 1.8 and 8.2 bytes of arrays per byte of file (format 2; most compressible member 163 and 121;
#: format 1 files of the built-in scenes 1.4 to 6.1, members up to 191); a format 1 file of almost
#: only static or resting bodies records mostly repeated poses and zero velocities, about 220 (so
#: over the floor, 256 MiB of arrays, it needs ``load_trajectory(max_ratio=None)``); deflated zeros
#: reach 1,032. README "Files" has the figures
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
    """Read a trajectory written by ``save_trajectory`` (or the command line), version 1 or 2.

    The record holds float64 and int64 arrays whatever the file stores: a version 2 file's float32
    poses, velocities and contacts come back within float32 rounding of the recorded values (2^-24
    relative), its still bodies' exactly; a version 1 file's exactly.

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
        version = data.get("version")
        if version is None or version.shape != () or version.dtype.kind not in "iu" or int(version) not in (1, 2):
            raise ValueError(f"{path}: a signorini trajectory of version {version if version is None else version.tolist()!r}"
                             f"; this signorini reads versions 1 and 2 (written by a newer one?)")
        if int(version) == 2:
            data = _expand_v2(data, path, max_bytes)
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
            events=_events(data, path),
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


def _expand_v2(data: dict, path, max_bytes: int) -> dict:
    """A version 2 file's arrays in version 1's form: ``positions``, ``orientations``,
    ``velocities``, ``angular_velocities`` (F, N, .) float64, the moving bodies' from the float32
    frame arrays and the still ones' repeated; contacts as float64 and int64. ValueError naming the
    array for shapes that disagree, FileLimitError when the frames would pass ``max_bytes``."""
    need = ["moving", "time", "names"] + [f"{p}_{k}" for p in ("frame", "still") for k in _FRAME_ARRAYS]
    missing = [k for k in need if k not in data]
    if missing:
        raise ValueError(f"{path}: trajectory is missing {', '.join(missing)}")
    moving, time, names = data["moving"], data["time"], data["names"]
    if moving.dtype != np.bool_ or moving.ndim != 1 or names.ndim != 1 or moving.shape != names.shape:
        raise ValueError(f"{path}: corrupt trajectory: moving must be one bool per body ({names.shape}), "
                         f"got {moving.shape} {moving.dtype}")
    if time.ndim != 1:
        raise ValueError(f"{path}: corrupt trajectory: time must be (F,), got {time.shape}")
    n, f, m = len(moving), len(time), int(np.count_nonzero(moving))
    if f * n * sum(_FRAME_ARRAYS.values()) * 8 > max_bytes:
        raise filecheck.FileLimitError(f"its {f} frames of {n} bodies hold more than {max_bytes:,} bytes once "
                                       "expanded (limit)")
    split = {f"{p}_{k}" for p in ("frame", "still") for k in _FRAME_ARRAYS}
    out = {k: v for k, v in data.items() if k not in split}
    for k, width in _FRAME_ARRAYS.items():
        frames, still = data[f"frame_{k}"], data[f"still_{k}"]
        if frames.shape != (f, m, width) or frames.dtype.kind != "f":
            raise ValueError(f"{path}: corrupt trajectory: frame_{k} must be ({f}, {m}, {width}) floats, "
                             f"got {frames.shape} {frames.dtype}")
        if still.shape != (n - m, width) or still.dtype.kind != "f":
            raise ValueError(f"{path}: corrupt trajectory: still_{k} must be ({n - m}, {width}) floats, "
                             f"got {still.shape} {still.dtype}")
        full = np.empty((f, n, width), dtype=np.float64)
        full[:, moving] = frames
        full[:, ~moving] = still
        out[k] = full
    for k in CONTACT_KEYS:
        key = f"contact_{k}"
        integer = k in ("body_a", "body_b")
        if key in out and out[key].dtype.kind in ("iu" if integer else "f"):
            out[key] = out[key].astype(np.int64 if integer else np.float64)
    return out


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


def _no_events() -> dict:
    """No events of any kind: empty arrays of the fields' shapes."""
    return {kind: {k: np.zeros((0, 3) if k in ("point", "normal") else 0,
                               dtype=np.int64 if k in ("step", "body_a", "body_b") else np.float64)
                   for k in EVENT_FIELDS} for kind in EVENT_KINDS}


def _events(data: dict, path) -> dict:
    """The file's events (``event_<kind>_<field>``; none in a file written before them), checked:
    each kind's fields of one length, steps within the run, bodies that exist, finite numbers."""
    out = _no_events()
    steps = len(data["step_time"]) if data["step_time"].ndim == 1 else 0
    n = len(data["names"]) if data["names"].ndim == 1 else 0
    for kind in EVENT_KINDS:
        keys = [f"event_{kind}_{k}" for k in EVENT_FIELDS]
        present = [k in data for k in keys]
        if not any(present):
            continue
        if not all(present):
            raise ValueError(f"{path}: corrupt trajectory: event_{kind} is missing "
                             f"{', '.join(k for k, p in zip(keys, present) if not p)}")
        e = len(data[keys[0]]) if data[keys[0]].ndim == 1 else -1
        for k, key in zip(EVENT_FIELDS, keys):
            a = data[key]
            if a.shape != ((e, 3) if k in ("point", "normal") else (e,)) or a.dtype.kind not in "iuf":
                raise ValueError(f"{path}: corrupt trajectory: {key} must be {e} rows of numbers, got {a.shape} {a.dtype}")
            if k == "step" and (np.any(a < 0) or np.any(a >= steps)):
                raise ValueError(f"{path}: corrupt trajectory: {key} names a step outside 0..{steps - 1}")
            if k in ("body_a", "body_b") and (np.any(a < 0) or np.any(a >= n)):
                raise ValueError(f"{path}: corrupt trajectory: {key} names a body outside 0..{n - 1}")
            if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
                raise ValueError(f"{path}: corrupt trajectory: {key} holds a value that is not finite")
            out[kind][k] = a.astype(np.int64 if k in ("step", "body_a", "body_b") else np.float64)
    return out


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
