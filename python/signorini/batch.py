"""Many worlds in one object, stepped together by the core on threads (issue 22, "Many worlds").

    import signorini as sg
    b = sg.Batch(world, 64, threads=2)            # 64 copies of a World
    b.set_frictions(np.linspace(0.1, 0.9, 64))    # one friction per world, for every body
    b.step(1 / 240, 240)                          # the GIL released; worlds spread over the threads
    b.positions                                   # (64, N, 3), a read-only view, no copy

Sources: a World (copied n times), a scene file (.toml; read once, copied n times) or a function
``make(i) -> World`` (world i's own parameters, shapes or bodies; every world must have the same
number of bodies, so that the state arrays are (n, N, ...)).

A batch step is ``World.step`` of each world, each on one of the batch's threads (the worlds'
own step runs on one thread): world by world, the bits of separate World objects, for every
thread count. A world whose step fails (non-finite state, energy explosion) keeps the state
before the failing step, is frozen (``frozen[i]``) with its message (``errors[i]``), and the
others go on; ``reset`` unfreezes it.

State arrays (``positions`` (n, N, 3) m, ``orientations`` (n, N, 4) quaternions (w, x, y, z),
``velocities`` (n, N, 3) m/s, ``angular_velocities`` (n, N, 3) rad/s, world frame) are
read-only views of arrays the core writes after every step and setter: reading them copies
nothing. Per-world parameters are set from arrays whose first axis is the world: every array is
checked whole before any world changes (a wrong shape or value raises naming the parameter and,
for a value, the world and body, and nothing changes).

Joints: ``set_joint_motor_speeds``, ``set_joint_max_forces``, ``set_joint_servo_positions`` and
``set_joint_efforts`` set drive targets per world ((n,) or (n, K) for K chosen joints; default every
joint with a motor, or every hinge and slider, for efforts), checked the same way and naming the
joint; ``joint_positions`` and ``joint_velocities`` are (n, J) copies.
"""
from __future__ import annotations

import math
import os
import pickle
from pathlib import Path
from typing import Callable, Optional, Sequence, Union

import numpy as np

from . import _core
from .joints import Motor
from .world import Contacts, SolverStats, World


class Batch:
    """n worlds stepped together (module doc).

    Inputs: source (a World, a scene file path, or make(i) -> World), n (>= 1 worlds), threads
    (>= 1, or None for the machine's cores)."""

    def __init__(self, source: Union[World, str, os.PathLike, Callable[[int], World]], n: int,
                 threads: Optional[int] = None):
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"Batch: n must be an integer >= 1, got {n!r}")
        if threads is None:
            threads = os.cpu_count() or 1
        if isinstance(threads, (bool, np.bool_)) or not isinstance(threads, (int, np.integer)) or threads < 1:
            raise ValueError(f"Batch: threads must be an integer >= 1 or None, got {threads!r}")
        n = int(n)
        if isinstance(source, World):
            blob = pickle.dumps(source)
            worlds = [pickle.loads(blob) for _ in range(n)]
        elif isinstance(source, (str, os.PathLike)):
            from .scenefile import read_scene

            blob = pickle.dumps(read_scene(Path(source)).world)
            worlds = [pickle.loads(blob) for _ in range(n)]
        elif callable(source):
            worlds = []
            for i in range(n):
                w = source(i)
                if not isinstance(w, World):
                    raise TypeError(f"Batch: make({i}) returned {type(w).__name__}, not a signorini.World")
                worlds.append(w)
        else:
            raise TypeError(f"Batch: source must be a World, a scene file path or a function make(i) -> World, "
                            f"got {type(source).__name__}")
        N = worlds[0].num_bodies
        for i, w in enumerate(worlds):
            if w.num_bodies != N:
                raise ValueError(f"Batch: world {i} has {w.num_bodies} bodies, world 0 has {N}: the worlds of a "
                                 "batch have the same body count")
            w.set_threads(1)   # the batch spreads worlds over its threads; each world steps on one
        self._worlds = worlds
        self._stepper = _core.BatchStepper(int(threads))
        self._p = np.zeros((n, N, 3))
        self._q = np.zeros((n, N, 4))
        self._v = np.zeros((n, N, 3))
        self._w = np.zeros((n, N, 3))
        self._frozen = np.zeros(n, dtype=np.uint8)
        self._errors = [""] * n
        self._initial = [w.save_state() for w in worlds]
        self._static = np.array(worlds[0].is_static)
        for i in range(n):
            self._copy(i)

    # ---- shape --------------------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self._worlds)

    @property
    def n(self) -> int:
        """Number of worlds."""
        return len(self._worlds)

    @property
    def num_bodies(self) -> int:
        """Bodies per world (N)."""
        return self._p.shape[1]

    @property
    def threads(self) -> int:
        """Threads the worlds are spread over."""
        return self._stepper.threads

    def __repr__(self) -> str:
        return f"Batch({self.n} worlds of {self.num_bodies} bodies, {self.threads} threads, {int(self._frozen.sum())} frozen)"

    # ---- pickling: the worlds (each a pickled World, in its current state), their start states,
    # flags and messages, and the thread count; a batch sent to another process or machine
    # continues bit for bit
    def __getstate__(self) -> dict:
        return {"version": 1, "worlds": [pickle.dumps(w) for w in self._worlds], "initial": self._initial,
                "frozen": self._frozen.copy(), "errors": list(self._errors), "threads": self.threads}

    def __setstate__(self, d: dict) -> None:
        if d.get("version") != 1:
            raise ValueError(f"Batch: cannot read a pickled batch of version {d.get('version')!r}")
        worlds = [pickle.loads(b) for b in d["worlds"]]
        self.__init__(lambda i: worlds[i], len(worlds), threads=d["threads"])
        self._initial = list(d["initial"])
        self._frozen[:] = d["frozen"]
        self._errors = list(d["errors"])
        for i in range(self.n):
            self._copy(i)

    # ---- stepping -----------------------------------------------------------------------------
    def step(self, dt: float, steps: int = 1) -> None:
        """Advances every world that is not frozen by ``steps`` steps of ``dt`` s (module doc)."""
        if isinstance(dt, (bool, np.bool_)) or not isinstance(dt, (int, float, np.floating, np.integer)) \
                or not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"Batch.step: dt must be a finite number > 0, got {dt!r}")
        if isinstance(steps, (bool, np.bool_)) or not isinstance(steps, (int, np.integer)) or not 0 <= steps < 2 ** 31:
            raise ValueError(f"Batch.step: steps must be an integer in [0, 2^31), got {steps!r}")
        errors = self._stepper.step([w._core for w in self._worlds], float(dt), int(steps), self._frozen,
                                    self._p, self._q, self._v, self._w)
        for i, e in enumerate(errors):
            if e:
                self._errors[i] = e

    # ---- state: read-only views -----------------------------------------------------------------
    @staticmethod
    def _view(a: np.ndarray) -> np.ndarray:
        v = a.view()
        v.flags.writeable = False
        return v

    @property
    def positions(self) -> np.ndarray:
        """(n, N, 3) centre of mass positions, world (m); a read-only view."""
        return self._view(self._p)

    @property
    def orientations(self) -> np.ndarray:
        """(n, N, 4) orientations as quaternions (w, x, y, z); a read-only view."""
        return self._view(self._q)

    @property
    def velocities(self) -> np.ndarray:
        """(n, N, 3) linear velocities, world (m/s); a read-only view."""
        return self._view(self._v)

    @property
    def angular_velocities(self) -> np.ndarray:
        """(n, N, 3) angular velocities, world (rad/s); a read-only view."""
        return self._view(self._w)

    @property
    def frozen(self) -> np.ndarray:
        """(n,) bool: worlds stopped by a failed step (``errors`` says why)."""
        return self._frozen.astype(bool)

    @property
    def errors(self) -> list[str]:
        """Per world: the message of the step that froze it, "" for the others."""
        return list(self._errors)

    @property
    def times(self) -> np.ndarray:
        """(n,) simulated time of each world (s)."""
        return np.array([w.time for w in self._worlds])

    def world(self, i: int) -> World:
        """World i as a World of its own (a copy: changing it does not change the batch)."""
        return pickle.loads(pickle.dumps(self._worlds[self._index(i)]))

    def contacts(self, i: int) -> Contacts:
        """The contacts of world i's last step."""
        return self._worlds[self._index(i)].contacts

    def solver_stats(self, i: int) -> SolverStats:
        """What world i's last step's solver did and its certificate."""
        return self._worlds[self._index(i)].solver_stats

    def certificate(self) -> dict:
        """The last step's certificate per world: {SolverStats field: (n,) array}."""
        stats = [w.solver_stats for w in self._worlds]
        return {k: np.array([getattr(s, k) for s in stats]) for k in SolverStats.__dataclass_fields__}

    def kinetic_energy(self) -> np.ndarray:
        """(n,) kinetic energy of each world (J)."""
        return np.array([w.kinetic_energy() for w in self._worlds])

    # ---- per-world parameters ------------------------------------------------------------------
    def _index(self, i) -> int:
        if isinstance(i, (bool, np.bool_)) or not isinstance(i, (int, np.integer)):
            raise TypeError(f"Batch: world index must be an integer, got {i!r}")
        if not -self.n <= i < self.n:
            raise IndexError(f"Batch: world index {i} is out of range: the batch has {self.n} worlds")
        return int(i) % self.n

    def _indices(self, indices, who: str) -> list[int]:
        if indices is None:
            return list(range(self.n))
        got = np.asarray(indices)
        if got.ndim != 1 or (got.size and not np.issubdtype(got.dtype, np.integer)):
            raise ValueError(f"{who}: indices must be a 1-D list of world indices, got {indices!r}")
        out = [self._index(int(i)) for i in got]
        if len(set(out)) != len(out):
            raise ValueError(f"{who}: a world index is given twice in {list(map(int, got))}")
        return out

    def _bodies(self, bodies, who: str, default) -> np.ndarray:
        if bodies is None:
            return np.asarray(default, dtype=np.int64)
        got = np.asarray(bodies)
        if got.ndim != 1 or (got.size and not np.issubdtype(got.dtype, np.integer)):
            raise ValueError(f"{who}: bodies must be a 1-D list of body indices, got {bodies!r}")
        if got.size and (got.min() < 0 or got.max() >= self.num_bodies):
            raise IndexError(f"{who}: body index out of range: the worlds have {self.num_bodies} bodies")
        return got.astype(np.int64)

    def _per_body(self, values, bodies, who: str, name: str, item: str = "body", finite: bool = True) -> np.ndarray:
        """values (n,) (one per world, every listed body, or joint: ``item``) or (n, B) as (n, B)
        floats; not NaN, and finite unless ``finite`` is False."""
        try:
            a = np.asarray(values, dtype=np.float64)
        except (TypeError, ValueError):
            raise TypeError(f"{who}: {name} must be numbers of shape ({self.n},) or ({self.n}, {len(bodies)}), "
                            f"got {values!r}") from None
        if a.shape == (self.n,):
            a = np.repeat(a[:, None], len(bodies), axis=1)
        if a.shape != (self.n, len(bodies)):
            raise ValueError(f"{who}: {name} must have shape ({self.n},) or ({self.n}, {len(bodies)}), got {a.shape}")
        bad = np.isnan(a) | (np.isinf(a) if finite else False)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            raise ValueError(f"{who}: {name} of world {i}, {item} {bodies[j]} is not {'finite' if finite else 'a number'}")
        return a

    def _refresh(self, indices) -> None:
        for i in indices:
            self._copy(i)

    def _copy(self, i: int) -> None:
        _core.BatchStepper.copy_state(self._worlds[i]._core, i, self._p, self._q, self._v, self._w)

    def set_frictions(self, values, bodies=None) -> None:
        """Friction coefficients (>= 0): (n,) one per world for every body in ``bodies`` (default
        all), or (n, B) per body. A contact uses sqrt(mu_A mu_B)."""
        b = self._bodies(bodies, "set_frictions", range(self.num_bodies))
        a = self._per_body(values, b, "set_frictions", "frictions")
        if (a < 0).any():
            i, j = np.argwhere(a < 0)[0]
            raise ValueError(f"set_frictions: friction of world {i}, body {b[j]} must be >= 0, got {a[i, j]}")
        for i, w in enumerate(self._worlds):
            for j, body in enumerate(b):
                w.set_material(int(body), friction=float(a[i, j]))

    def set_restitutions(self, values, bodies=None) -> None:
        """Restitution coefficients in [0, 1]: (n,) or (n, B) as ``set_frictions``."""
        b = self._bodies(bodies, "set_restitutions", range(self.num_bodies))
        a = self._per_body(values, b, "set_restitutions", "restitutions")
        if ((a < 0) | (a > 1)).any():
            i, j = np.argwhere((a < 0) | (a > 1))[0]
            raise ValueError(f"set_restitutions: restitution of world {i}, body {b[j]} must be in [0, 1], got {a[i, j]}")
        for i, w in enumerate(self._worlds):
            for j, body in enumerate(b):
                w.set_material(int(body), restitution=float(a[i, j]))

    def set_masses(self, values, bodies=None) -> None:
        """Masses (kg, > 0) of dynamic bodies (default: every non-static body): (n,) or (n, B);
        each body's inertia scales with its mass (``World.set_mass``)."""
        b = self._bodies(bodies, "set_masses", np.nonzero(~self._static)[0])
        if self._static[b].any():
            raise ValueError(f"set_masses: body {int(b[self._static[b]][0])} is static: it has no mass to set")
        a = self._per_body(values, b, "set_masses", "masses")
        if (a <= 0).any():
            i, j = np.argwhere(a <= 0)[0]
            raise ValueError(f"set_masses: mass of world {i}, body {b[j]} must be > 0, got {a[i, j]}")
        for i, w in enumerate(self._worlds):
            for j, body in enumerate(b):
                w.set_mass(int(body), float(a[i, j]))

    def set_gravity(self, values) -> None:
        """Gravity (m/s^2, world): (3,) for every world or (n, 3)."""
        a = np.asarray(values, dtype=np.float64)
        if a.shape == (3,):
            a = np.broadcast_to(a, (self.n, 3))
        if a.shape != (self.n, 3):
            raise ValueError(f"set_gravity: gravity must have shape (3,) or ({self.n}, 3), got {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"set_gravity: gravity of world {int(np.argwhere(~np.isfinite(a))[0][0])} is not finite")
        for i, w in enumerate(self._worlds):
            w.set_gravity(a[i])

    def set_external_forces(self, forces, torques=None) -> None:
        """Persistent external forces (n, N, 3) at the centres of mass (N, world) and optionally
        torques (n, N, 3) (N m); static bodies take zeros."""
        f = self._rows(forces, 3, "set_external_forces", "forces")
        t = np.zeros_like(f) if torques is None else self._rows(torques, 3, "set_external_forces", "torques")
        moving = np.nonzero(~self._static)[0]
        for name, a in (("forces", f), ("torques", t)):
            bad = np.argwhere(np.abs(a[:, self._static]).sum(axis=-1) > 0)
            if len(bad):
                raise ValueError(f"set_external_forces: {name} of world {bad[0][0]} on static body "
                                 f"{int(np.nonzero(self._static)[0][bad[0][1]])} must be zero")
        for i, w in enumerate(self._worlds):
            for j in moving:
                w.set_external_wrench(int(j), force=f[i, j], torque=t[i, j])

    # ---- joints: per-world drive targets (World.set_joint_motor, set_joint_effort) --------------
    @property
    def num_joints(self) -> int:
        """Joints per world (J); ValueError when the worlds have different counts."""
        counts = {w.num_joints for w in self._worlds}
        if len(counts) != 1:
            raise ValueError(f"Batch: the worlds have different joint counts {sorted(counts)}: per-world joint "
                             "arrays need the same count")
        return counts.pop()

    @property
    def joint_positions(self) -> np.ndarray:
        """(n, J) each world's ``World.joint_positions``: a hinge's angle (rad), a slider's offset
        (m), NaN for joints that are not one-dof. A copy."""
        return np.array([w.joint_positions for w in self._worlds]).reshape(self.n, self.num_joints)

    @property
    def joint_velocities(self) -> np.ndarray:
        """(n, J) each world's ``World.joint_velocities`` (rad/s, m/s; NaN as joint_positions). A copy."""
        return np.array([w.joint_velocities for w in self._worlds]).reshape(self.n, self.num_joints)

    def _joints(self, joints, who: str, motor: bool) -> np.ndarray:
        """The joint indices ``joints`` (1-D) or, for None, every joint with a motor (``motor``) or
        every hinge and slider, each checked in every world: IndexError or ValueError naming the
        parameter, the world and the joint."""
        J = self.num_joints
        rows = [[w.joint(j) for j in range(J)] for w in self._worlds]
        if joints is None:
            return np.array([j for j in range(J) if all(r[j]["motor"] if motor else
                                                        r[j]["kind"] in ("Revolute", "Prismatic") for r in rows)],
                            dtype=np.int64)
        got = np.asarray(joints)
        if got.ndim != 1 or (got.size and not np.issubdtype(got.dtype, np.integer)) or got.dtype == np.bool_:
            raise ValueError(f"{who}: joints must be a 1-D list of joint indices, got {joints!r}")
        if got.size and (got.min() < 0 or got.max() >= J):
            raise IndexError(f"{who}: joint index {int(got[(got < 0) | (got >= J)][0])} is out of range: the worlds "
                             f"have {J} joints")
        for i, r in enumerate(rows):
            for j in got:
                if r[j]["kind"] not in ("Revolute", "Prismatic"):
                    raise ValueError(f"{who}: joint {int(j)} of world {i} is a {r[j]['kind']} joint: only hinges and "
                                     "sliders take one")
                if motor and not r[j]["motor"]:
                    raise ValueError(f"{who}: joint {int(j)} of world {i} has no motor (World.set_joint_motor gives one)")
        return got.astype(np.int64)

    def _set_motors(self, values, joints, who: str, name: str, field: str, at_least: Optional[float] = None,
                    finite: bool = True) -> None:
        """Sets the motor ``field`` (speed, max_force, position) of the ``joints`` of every world,
        the motor's other values kept; checked whole first."""
        js = self._joints(joints, who, motor=True)
        a = self._per_body(values, js, who, name, item="joint", finite=finite)
        if at_least is not None and (a < at_least).any():
            i, j = np.argwhere(a < at_least)[0]
            raise ValueError(f"{who}: {name} of world {i}, joint {js[j]} must be >= {at_least}, got {a[i, j]}")
        for i, w in enumerate(self._worlds):
            for k, j in enumerate(js):
                d = w.joint(int(j))
                motor = {key: d[f"motor_{key}"] for key in ("speed", "max_force", "position", "stiffness", "damping")}
                motor[field] = float(a[i, k])
                w.set_joint_motor(int(j), Motor(motor.pop("speed"), motor.pop("max_force"), **motor))

    def set_joint_motor_speeds(self, values, joints=None) -> None:
        """Motor target speeds (rad/s for a hinge, m/s for a slider): (n,) one per world for every
        joint in ``joints`` (default: every joint with a motor), or (n, K) per joint; each motor's
        other values are kept (``World.set_joint_motor``)."""
        self._set_motors(values, joints, "set_joint_motor_speeds", "speeds", "speed")

    def set_joint_max_forces(self, values, joints=None) -> None:
        """Motors' largest torque (N m, a hinge) or force (N, a slider), >= 0 (may be inf): (n,) or
        (n, K) as ``set_joint_motor_speeds``."""
        self._set_motors(values, joints, "set_joint_max_forces", "max_forces", "max_force", at_least=0.0,
                         finite=False)

    def set_joint_servo_positions(self, values, joints=None) -> None:
        """Servo targets (rad, m; as ``joint_positions``) of motors with a stiffness: (n,) or (n, K)
        as ``set_joint_motor_speeds``."""
        self._set_motors(values, joints, "set_joint_servo_positions", "positions", "position")

    def set_joint_efforts(self, values, joints=None) -> None:
        """Efforts (N m, a hinge; N, a slider) applied along each joint's coordinate every substep
        (``World.set_joint_effort``): (n,) one per world for every joint in ``joints`` (default:
        every hinge and slider), or (n, K)."""
        js = self._joints(joints, "set_joint_efforts", motor=False)
        a = self._per_body(values, js, "set_joint_efforts", "efforts", item="joint")
        for i, w in enumerate(self._worlds):
            for k, j in enumerate(js):
                w.set_joint_effort(int(j), float(a[i, k]))

    def _rows(self, values, width: int, who: str, name: str, indices=None) -> np.ndarray:
        n = self.n if indices is None else len(indices)
        a = np.asarray(values, dtype=np.float64)
        if a.shape != (n, self.num_bodies, width):
            raise ValueError(f"{who}: {name} must have shape ({n}, {self.num_bodies}, {width}), got {a.shape}")
        if not np.isfinite(a).all():
            i, j, _ = np.argwhere(~np.isfinite(a))[0]
            raise ValueError(f"{who}: {name} of world {i}, body {j} is not finite")
        return a

    def _set_state(self, setter: str, values, width: int, indices) -> None:
        idx = self._indices(indices, setter)
        a = self._rows(values, width, setter, setter[4:], idx)
        all_bodies = np.arange(self.num_bodies)
        # each world checks its own rows before writing them, but a bad row in world k would leave the
        # worlds before k set: their states are saved first and put back on an error
        saved = [self._worlds[i].save_state() for i in idx]
        try:
            for k, i in enumerate(idx):
                getattr(self._worlds[i], setter)(all_bodies, a[k])
        except Exception:
            for k, i in enumerate(idx):
                self._worlds[i].restore_state(saved[k])
            raise
        finally:
            self._refresh(idx)

    def set_positions(self, values, indices=None) -> None:
        """Positions (len(indices) or n, N, 3) of the worlds ``indices`` (default all), m."""
        self._set_state("set_positions", values, 3, indices)

    def set_orientations(self, values, indices=None) -> None:
        """Orientations (…, N, 4), quaternions (w, x, y, z), of the worlds ``indices``."""
        self._set_state("set_orientations", values, 4, indices)

    def set_velocities(self, values, indices=None) -> None:
        """Velocities (…, N, 3), m/s, of the worlds ``indices``."""
        self._set_state("set_velocities", values, 3, indices)

    def set_angular_velocities(self, values, indices=None) -> None:
        """Angular velocities (…, N, 3), rad/s, of the worlds ``indices``."""
        self._set_state("set_angular_velocities", values, 3, indices)

    def reset(self, indices=None, seed=None, position_jitter: float = 0.0, velocity_jitter: float = 0.0) -> None:
        """Puts the worlds ``indices`` (default all) back in their initial state (as built) and
        unfreezes them. Randomisation: with ``seed`` (an int, or one int per index), world i's
        dynamic bodies get start positions moved by a uniform offset in [-position_jitter,
        position_jitter] (m) per axis and velocities uniform in [-velocity_jitter,
        velocity_jitter] (m/s) per axis, drawn from ``numpy.random.default_rng([seed, i])`` (an
        int seed) or ``default_rng(seed_k)`` (a list): the same seed gives the same world."""
        idx = self._indices(indices, "reset")
        for name, x in (("position_jitter", position_jitter), ("velocity_jitter", velocity_jitter)):
            if not (isinstance(x, (int, float, np.floating)) and math.isfinite(x) and x >= 0):
                raise ValueError(f"reset: {name} must be a finite number >= 0, got {x!r}")
        if seed is None:
            seeds = [None] * len(idx)
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, (bool, np.bool_)):
            seeds = [[int(seed), i] for i in idx]
        else:
            seeds = list(seed) if isinstance(seed, Sequence) or isinstance(seed, np.ndarray) else None
            if seeds is None or len(seeds) != len(idx) or not all(
                    isinstance(s, (int, np.integer)) and not isinstance(s, (bool, np.bool_)) for s in seeds):
                raise ValueError(f"reset: seed must be an int or one int per world index ({len(idx)}), got {seed!r}")
            seeds = [int(s) for s in seeds]
        moving = np.nonzero(~self._static)[0]
        for k, i in enumerate(idx):
            w = self._worlds[i]
            w.restore_state(self._initial[i])
            self._frozen[i] = 0
            self._errors[i] = ""
            if seeds[k] is not None and len(moving):
                rng = np.random.default_rng(seeds[k])
                dp = rng.uniform(-position_jitter, position_jitter, size=(len(moving), 3))
                dv = rng.uniform(-velocity_jitter, velocity_jitter, size=(len(moving), 3))
                w.set_positions(moving, np.asarray(w.positions)[moving] + dp)
                w.set_velocities(moving, np.asarray(w.velocities)[moving] + dv)
            self._copy(i)
