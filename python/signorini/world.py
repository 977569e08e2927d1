"""The World facade: type conversion and NumPy-friendly results around ``signorini._core``.

No physics lives here: every number is computed by the C++ core. This layer turns Python
arguments into the exact types and shapes the core takes; the core checks the values (finite,
in range, a valid body index...) and its errors name the body and the problem. The state and
contact arrays are read-only views of the core's storage, not copies.

Threads: a World is safe to share between threads. Each method and property holds the world's
re-entrant lock (``World.lock``) for its whole call, core call and Python-side records (what each
body was added with, the warning counters) together, so calls on one World run one at a time and
none sees another half done. ``step`` keeps the lock while the core steps with the GIL released:
other worlds step in parallel in other threads, and other threads' calls on this world wait for
the lock without holding the GIL. README "Threads" says what is and is not safe.
"""
from __future__ import annotations

import functools
import math
import os
import sys
import threading
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from . import _core, codec, queries
from .arguments import (ALL_BITS, INT_MAX, as_bits, as_count, as_flag, as_indices, as_name, as_number, as_rows,
                        as_scalar, as_vector, readonly)
from .joints import KINDS as _JOINT_KINDS, SPHERICAL, Joint, Motor
from ._core import Box, Capsule, Compound, ConvexHull, Cylinder, Mesh, Plane, Sphere, TriangleMesh

Shape = (Sphere, Box, Plane, Mesh, Capsule, Cylinder, ConvexHull, TriangleMesh, Compound)


BodyIndexError = _core.BodyIndexError
BodyIndexError.__doc__ = "A body index that is not in the world (both an IndexError and a ValueError)."


class SolverWarning(RuntimeWarning):
    """A step ended with the contact solver unconverged and a contact still approaching faster
    than ``warn_velocity`` allows (see ``World.solver_stats``). A world gives it once (again after
    ``set_solver``); ``warnings.filterwarnings("ignore", category=signorini.SolverWarning)``
    silences it, and ``World.unconverged_substeps`` still counts."""


_PACKAGE = os.path.realpath(os.path.dirname(__file__)) + os.sep


def user_stacklevel() -> int:
    """The ``stacklevel`` for ``warnings.warn`` called by the caller of this function that makes the
    warning name the first frame outside the signorini package: the user's line that called into
    it (through the lock decorator, the Recorder or ``output.run``), as pandas'
    ``find_stack_level`` does (Python 3.12's ``skip_file_prefixes`` is not in 3.11)."""
    frame, level = sys._getframe(1), 1
    while frame is not None and os.path.realpath(frame.f_code.co_filename).startswith(_PACKAGE):
        frame, level = frame.f_back, level + 1
    return level


@dataclass(frozen=True)
class Contacts:
    """Contacts of the last step, one row per contact (K rows). From ``World.contacts`` the arrays
    are read-only views of the core's list for that step (with sleeping on, the sleeping islands'
    contacts are among them as they were solved when the island fell asleep); from
    ``detect_contacts`` and ``collide`` they are copies.

    body_a, body_b: (K,) integer body indices (int32 views, int64 copies); the normal points from A
    to B (a plane is always A).
    point: (K, 3) world contact points y_i (m), midway between the witness points on A and B.
    normal: (K, 3) world unit normals n_i.
    gap: (K,) signed distances along n_i (m), negative when overlapping.
    alpha: (K,) normal forces alpha_i >= 0 (N), as in the lecture notes, of the step's last substep.
    impulse: (K,) the step's whole normal impulses (N s), summed over its substeps, applied as
        +impulse n on B and -impulse n on A: impulse / dt is the mean normal force over the step
        (as users of other engines compute a force); alpha * dt / substeps is the last substep's.
    friction: (K, 3) friction forces on B (N, world, tangent to n); A gets the opposite.
    force: (K, 3) total contact forces on B, alpha n + friction (N, world).
    spin_torque: (K,) torsional friction torques on B about n_i (N m; B gets spin_torque n, A the
        opposite); 0 for a contact without a spin row (one of several points of its body pair, or
        spinning friction 0).
    normal_velocity: (K,) n . (v_B(y) - v_A(y)) after the solve (m/s; > 0 separating).
    slip: (K, 3) tangential velocity of B's point against A's after the solve (m/s, world).
    feature_a, feature_b: (K,) uint64 feature ids of the point on A and on B, the same from one
        step to the next for the same contact: part * 2**32 + kind * 2**28 + index, kind 0 whole
        shape, 1 vertex, 2 edge, 3 face (see ``signorini.feature``).
    arm_a, arm_b: (K, 3) the lever arms of the contact's rows (m, world): y - p_A and y - p_B when
        the point was found; a kept contact's are those of the detection that found its manifold.
    kept: (K,) bool, True for a contact whose pair kept its manifold from an earlier detection
        (contact recycling, ``recycle_distance``): its gap, point and normal follow the bodies, its
        rows keep their lever arms (docs/conventions.md, "Contact recycling").
    """

    body_a: np.ndarray
    body_b: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    gap: np.ndarray
    alpha: np.ndarray
    impulse: np.ndarray
    friction: np.ndarray
    force: np.ndarray
    spin_torque: np.ndarray
    normal_velocity: np.ndarray
    slip: np.ndarray
    feature_a: np.ndarray
    feature_b: np.ndarray
    arm_a: np.ndarray
    arm_b: np.ndarray
    kept: np.ndarray

    def __len__(self) -> int:
        return len(self.gap)

    def as_dict(self) -> dict:
        """The arrays as a dict (the oracle's contact format)."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class JointBreaks:
    """The joints that broke in the last ``step`` call, one row each (n rows), by step then index.

    step: (n,) int64, the step of the call after which it broke (0 .. steps - 1).
    joint: (n,) int64 joint indices.
    force, torque: (n, 3) what the joint transmitted to its body B in that step's last substep (N;
        N m about B's anchor, world), past ``break_force`` or ``break_torque``.
    """

    step: np.ndarray
    joint: np.ndarray
    force: np.ndarray
    torque: np.ndarray

    def __len__(self) -> int:
        return len(self.step)


@dataclass(frozen=True)
class ContactPairs:
    """The body pairs with contacts in the last step, one row per pair (P rows), in the contact
    list's order (``World.contacts`` keeps a pair's contacts together).

    body_a, body_b: (P,) int64 body indices (the normal points from A to B).
    count: (P,) int64 the pair's contacts; first: (P,) int64 the row of its first one in ``contacts``.
    force: (P, 3) the pair's summed contact force on B (N, world; A gets the opposite), of the
        step's last substep, as ``Contacts.force``.
    impulse: (P,) its summed normal impulse over the step (N s).
    touching: (P,) bool, whether it touches (a contact pushed in the step or overlaps), as
        ``World.events`` decides beginnings and ends.
    """

    body_a: np.ndarray
    body_b: np.ndarray
    count: np.ndarray
    first: np.ndarray
    force: np.ndarray
    impulse: np.ndarray
    touching: np.ndarray

    def __len__(self) -> int:
        return len(self.body_a)


@dataclass(frozen=True)
class ContactEventList:
    """One kind of contact event of the last ``step`` call, one row per event (n rows), in the
    order of the steps and, within a step, of the body pairs (body_a, then body_b): the same for
    every thread count (docs/conventions.md, "Contact events").

    step: (n,) int64, the step of the call it happened in (0 .. steps - 1).
    body_a, body_b: (n,) int64 body indices of the pair, as in its contacts (the normal points from
        A to B).
    point: (n, 3) the pair's first contact point (m, world); zero for an end.
    normal: (n, 3) that contact's unit normal (world); zero for an end.
    speed: (n,) the fastest approach of the pair's contacts at the step's start,
        -n . (v_B(y) - v_A(y)) from the velocities the step started with (m/s, 0 when none
        approached); 0 for an end.
    impulse: (n,) the pair's summed normal impulse in the step (N s); 0 for an end.
    """

    step: np.ndarray
    body_a: np.ndarray
    body_b: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    speed: np.ndarray
    impulse: np.ndarray

    def __len__(self) -> int:
        return len(self.step)


@dataclass(frozen=True)
class ContactEvents:
    """The contact events of the last ``step`` call. A body pair touches after a step when one of
    its contacts pushed in it (impulse > 0) or overlaps (gap < 0).

    begin: pairs that touch after a step and did not before it.
    end: pairs that touched before a step and do not after it (or whose body was disabled).
    hits: the beginnings whose approach ``speed`` was above ``World.hit_speed``.
    sensor_begin, sensor_end: a sensor body (body_a) and a body that is not one (body_b) began or
        ended overlapping (docs/conventions.md, "Sensors"); point and normal (from the sensor) of
        their deepest contact at the beginning, zero at the end; speed and impulse 0.
    """

    begin: ContactEventList
    end: ContactEventList
    hits: ContactEventList
    sensor_begin: ContactEventList
    sensor_end: ContactEventList


@dataclass(frozen=True)
class SolverStats:
    """What the last step's contact solver did, and its Signorini certificate
    (docs/conventions.md, "The Signorini certificate"; w_i = normal velocity + the row's target).

    iterations, restitution_iterations, position_iterations: sweeps of each stage.
    converged: the iterate stage met ``tolerance``. contacts: number of contacts.
    pairs: body pairs the step's contact detection collided; recycled_pairs: of them, those that
    kept their manifold (``recycle_distance``; docs/conventions.md, "Contact recycling").
    residual: natural residual over all rows (m/s).
    max_alpha_negative (N): push only. max_penetration_velocity (m/s): no approach beyond the gap.
    max_complementarity (W): max |alpha_i w_i|. max_cone_violation (N): |f| <= mu alpha.
    max_dissipation_violation (N): sliding friction opposite the slip, on the cone's edge.
    max_overlap (m): the deepest overlap at the start of the step.
    """

    iterations: int
    restitution_iterations: int
    position_iterations: int
    converged: bool
    contacts: int
    pairs: int
    recycled_pairs: int
    residual: float
    max_alpha_negative: float
    max_penetration_velocity: float
    max_complementarity: float
    max_cone_violation: float
    max_dissipation_violation: float
    max_overlap: float


@dataclass(frozen=True)
class SavedState:
    """A world's dynamic state from ``World.save_state()``, for ``World.restore_state()``: time,
    poses, velocities, persistent and one-step forces, pending impulses, kinematic and enabled
    flags, the warm-start cache, the last step's contacts, the triangle meshes' memory of
    which side a body belongs on, and the islands (awake flags, sleep timers, the sleeping islands'
    contacts and warm-start forces) (opaque bytes written and checked by the core). Picklable. ``num_bodies`` and ``time`` are for reading only."""

    data: bytes
    num_bodies: int
    time: float

    def __repr__(self) -> str:
        return f"SavedState({self.num_bodies} bodies, t={self.time:g} s, {len(self.data)} bytes)"


SOLVER_DEFAULTS = {
    "erp": 0.2, "tolerance": 1e-6, "max_iterations": 30, "slop": 0.001, "max_push_velocity": 1.0,
    "restitution_threshold": 0.5, "friction_cone": "pyramid", "gyroscopic": "midpoint",
    "warm_start": True, "substeps": 0, "warn_velocity": 1.0,
    "solver": "pgs", "contact_hertz": 30.0, "damping_ratio": 10.0, "soft_iterations": 1, "relax_iterations": 1,
    "recycle_distance": None, "continuous": True, "joint_hertz": 240.0, "joint_damping_ratio": 2.0,
}

# recycle_distance when not given, by solver (m): the soft step keeps resting manifolds (Box3D's 5 cm:
# its tall stacks stand only with them, docs/conventions.md "Contact recycling"); the PGS finds
# every pair anew
RECYCLE_DEFAULTS = {"pgs": 0.0, "soft": 0.05}


SLEEP_DEFAULTS = {"sleeping": True, "sleep_linear_velocity": 0.05, "sleep_angular_velocity": 0.05,
                  "time_to_sleep": 0.5}
# the keywords' names in _core.SleepSettings
_SLEEP_FIELDS = {"sleeping": "enabled", "sleep_linear_velocity": "linear_velocity",
                 "sleep_angular_velocity": "angular_velocity", "time_to_sleep": "time_to_sleep"}


def _sleep_settings(who: str, current=None, **given):
    """A _core.SleepSettings from keyword values (None = keep current or the default), checked for
    type here and for range by the core."""
    s = _core.SleepSettings()
    for key, default in SLEEP_DEFAULTS.items():
        value = given.get(key)
        if value is None:
            value = getattr(current, _SLEEP_FIELDS[key]) if current is not None else default
        value = as_flag(value, who, key) if key == "sleeping" else as_scalar(value, who, key)
        setattr(s, _SLEEP_FIELDS[key], value)
    return s


def _default_recycle(current, solver) -> float:
    """recycle_distance when not given: the solver's default (RECYCLE_DEFAULTS) for a new world;
    for a change of settings the current value, unless the solver changes from one whose default
    it still is (then the new solver's default)."""
    solver = solver if isinstance(solver, str) else None  # a bad value is refused by name below
    if current is None:
        return RECYCLE_DEFAULTS.get(solver if solver is not None else SOLVER_DEFAULTS["solver"], 0.0)
    old = current.method.name
    if solver is not None and solver != old and current.recycle_distance == RECYCLE_DEFAULTS[old]:
        return RECYCLE_DEFAULTS.get(solver, current.recycle_distance)
    return current.recycle_distance


def _setting(s, key: str):
    """Setting `key` of a _core.SolverSettings as the constructor takes it (enums by name; the
    keyword ``solver`` is the core's ``method``)."""
    if key == "solver":
        return s.method.name
    value = getattr(s, key)
    return value.name if key in ("friction_cone", "gyroscopic") else value


def _solver_settings(who: str, current=None, **given):
    """A _core.SolverSettings from keyword values (None = keep current or the default), checked
    for type here and for range by the core."""
    s = _core.SolverSettings()
    for key, default in SOLVER_DEFAULTS.items():
        value = given.get(key)
        if key == "recycle_distance" and value is None:
            value = _default_recycle(current, given.get("solver"))
        elif value is None:
            value = _setting(current, key) if current is not None else default
        if key in ("max_iterations", "substeps", "soft_iterations", "relax_iterations"):
            value = as_count(value, who, key)
        elif key in ("warm_start", "continuous"):
            if not isinstance(value, (bool, np.bool_)):
                raise TypeError(f"{who}: {key} must be True or False, got {value!r}")
            value = bool(value)
        elif key == "friction_cone":
            if value not in ("pyramid", "cone"):
                raise ValueError(f"{who}: friction_cone must be 'pyramid' or 'cone', got {value!r}")
            value = getattr(_core.FrictionCone, value)
        elif key == "gyroscopic":
            if value not in ("midpoint", "implicit", "explicit"):
                raise ValueError(f"{who}: gyroscopic must be 'midpoint', 'implicit' or 'explicit', got {value!r}")
            value = getattr(_core.Gyroscopic, value)
        elif key == "solver":
            if not isinstance(value, str):
                raise TypeError(f"{who}: solver must be 'pgs' or 'soft', got {value!r}")
            if value not in ("pgs", "soft"):
                raise ValueError(f"{who}: solver must be 'pgs' or 'soft', got {value!r}")
            s.method = getattr(_core.SolverMethod, value)
            continue
        else:
            value = as_scalar(value, who, key)
        setattr(s, key, value)
    return s


def _threads(who: str, threads) -> Optional[int]:
    """threads as given: None (the machine's cores) or an int >= 1, else a TypeError / ValueError."""
    if threads is None:
        return None
    threads = as_count(threads, who, "threads")
    if threads < 1:
        raise ValueError(f"{who}: threads must be >= 1 (or None for the machine's cores), got {threads}")
    return threads


def _locked(method):
    """The method, run holding its world's lock (``World.lock``)."""
    @functools.wraps(method)
    def locked(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)
    return locked


def _solid(mesh) -> bool:
    """True when the mesh is a closed solid of positive volume (else add_body reports why)."""
    try:
        _core.mass_properties(mesh, 1.0)
    except ValueError:
        return False
    return True


class World:
    """A rigid-body world stepped by the lecture's contact solver, with Coulomb friction,
    restitution, warm starting and energy-safe position correction (docs/conventions.md).

    Parameters
    ----------
    gravity : (3,) m/s^2, world frame.
    contact_margin : m. Pairs closer than this (plus each body's speculative reach for the step)
        get contacts; those with a positive gap only stop an approach that would close it.
    erp : in [0, 1], the fraction of an overlap the position pass removes per step.
    tolerance : a solver stage stops when no row's velocity changes by more than this (m/s);
        0 runs every sweep up to ``max_iterations``.
    max_iterations : at most this many sweeps per solver stage and substep.
    slop : overlap (m) the position pass leaves alone, so resting contacts are never stirred; a
        contact of a thin body gets at most 0.2 of its inner radius (``inner_radii``).
    max_push_velocity : cap on the speed (m/s) at which overlapping bodies are pushed apart.
    restitution_threshold : approach speeds (m/s) below this get no bounce.
    friction_cone : "pyramid" (each tangent force within mu alpha) or "cone" (|f_t| <= mu alpha).
    gyroscopic : "midpoint" (keeps energy and |L|), "implicit" (Catto 2015, dissipative) or
        "explicit" (the lecture's; gains energy on fast spinners).
    warm_start : start each step from the previous step's contact forces.
    substeps : a step detects contacts once and solves them in this many substeps of dt / substeps,
        the contacts carried along with the bodies; 0 (the default) runs the fewest substeps of at
        most 1/960 s (dt = 1/240: 4; dt = 1/60: 16). Substeps cost solver sweeps, not contact
        detection.
    warn_velocity : a step that ends unconverged with a contact still approaching faster than this
        (m/s) is flagged: the world's first flagged step raises a ``SolverWarning``, and
        ``unconverged_substeps`` counts every flagged substep (a loop of ``step(dt)`` warns once, not once a
        step; ``set_solver`` re-arms the warning). Default 1 m/s: so fast a contact sinks through the
        1 mm slop within one default substep (1/960 s). An unconverged solve leaves slower approaches
        in piles at impact (the built-in scenes: at most 0.2 m/s), which the position pass removes;
        ``solver_stats`` reports them, and a smaller value flags them too.
    solver : "pgs" (the lecture's hard PGS, swept to ``tolerance`` in every substep, with a
        split-impulse position pass) or "soft" (the soft step of docs/conventions.md: per substep
        one warm start, ``soft_iterations`` sweeps on soft contacts, the poses, ``relax_iterations``
        rigid sweeps; restitution last; ``substeps`` 0 then runs substeps of at most 1/240 s, and
        with a joint whose bodies are awake at most 0.25 / ``joint_hertz``).
    contact_hertz : soft step: a contact's stiffness as its spring's frequency (Hz, > 0), at most a
        quarter of the substep rate; twice this against a static or kinematic body.
    damping_ratio : soft step: the spring's damping ratio (>= 0; half this against a static or
        kinematic body).
    soft_iterations, relax_iterations : soft step: sweeps per substep with the soft bias (>= 1) and
        rigid sweeps after the poses move (>= 0).
    joint_hertz : soft step: a joint's stiffness as its rows' spring frequency (Hz, > 0), at most a
        quarter of the substep rate. A world with joints runs its automatic substeps at most
        0.25 / joint_hertz long (1/960 s at the default 240 Hz: 4 at dt = 1/240, 16 at dt = 1/60);
        60 Hz (Box2D v3's) keeps the contacts' 1/240 s and lets a joint stretch 16 times as far
        under a load (by load / (m_eff (2 pi f)^2)).
    joint_damping_ratio : soft step: the joint spring's damping ratio (>= 0).
    recycle_distance : contact recycling (m, >= 0; docs/conventions.md, "Contact recycling"): a
        pair of bodies other than spheres, planes and triangle meshes keeps the manifold it was last
        found with while it has drifted by at most this (and by 10% of the smaller body's inner
        radius) since, counting the coming step at the current velocities: its gaps follow the
        bodies, its rows keep the lever arms they were found with, and a resting pile is not
        collided again step after step. ``solver_stats.recycled_pairs`` counts them. Not given:
        0.05 with ``solver="soft"`` (Box3D's choice; its tall stacks stand only with it), 0 with
        ``"pgs"`` (``RECYCLE_DEFAULTS``); 0 finds every pair anew every step (the narrow phase's
        exact contacts, as the oracle finds them).
    continuous : continuous collision (docs/conventions.md, "Shape casts and continuous
        collision"; default on): after each step, a dynamic body that moved more than half its
        inner radius in it (or a ``bullet`` body) has its centre's path from its start to its end
        cast against the static bodies; if the centre crossed a surface, the body is put back along
        its path just before its shape's first touch (its velocity kept: the next step's contact
        stops it). Bodies with joints are left to their joints.
        ``step_report["continuous"]`` counts the bodies put back.

    sleeping : bodies at rest fall asleep with their island (docs/conventions.md, "Sleeping"): a
        sleeping body keeps its pose bit for bit and costs no solver or broad-phase work until a
        moving body touches it or a call wakes it. On by default (``World.awake``); ``False`` keeps
        every body awake (what a test of a slow approach to rest, or a comparison with the oracle,
        wants).
    sleep_linear_velocity : m/s (>= 0): a body slower than this counts as at rest.
    sleep_angular_velocity : rad/s (>= 0): a body turning slower than this counts as at rest.
    time_to_sleep : s (>= 0): an island whose bodies have all been at rest this long falls asleep.

    The defaults (``SOLVER_DEFAULTS``, ``SLEEP_DEFAULTS``) stand a 10-box stack and a 210-box pyramid.
    """

    def __init__(self, gravity=(0.0, 0.0, -9.81), contact_margin: float = 0.005, erp: float = 0.2,
                 tolerance: float = 1e-6, max_iterations: int = 30, *, slop: float = 0.001,
                 max_push_velocity: float = 1.0,
                 restitution_threshold: float = 0.5, friction_cone: str = "pyramid",
                 gyroscopic: str = "midpoint", warm_start: bool = True, substeps: int = 0,
                 warn_velocity: float = 1.0, solver: str = "pgs", contact_hertz: float = 30.0,
                 damping_ratio: float = 10.0, soft_iterations: int = 1, relax_iterations: int = 1,
                 recycle_distance: Optional[float] = None, continuous: bool = True, joint_hertz: float = 240.0,
                 joint_damping_ratio: float = 2.0, sleeping: bool = True, sleep_linear_velocity: float = 0.05,
                 sleep_angular_velocity: float = 0.05, time_to_sleep: float = 0.5, threads: Optional[int] = None):
        g = as_vector(gravity, 3, "World", "gravity")
        given_threads = _threads("World", threads)
        settings = _solver_settings(
            "World", erp=erp, tolerance=tolerance, max_iterations=max_iterations, slop=slop,
            max_push_velocity=max_push_velocity, restitution_threshold=restitution_threshold,
            friction_cone=friction_cone, gyroscopic=gyroscopic, warm_start=warm_start, substeps=substeps,
            warn_velocity=warn_velocity, solver=solver, contact_hertz=contact_hertz, damping_ratio=damping_ratio,
            soft_iterations=soft_iterations, relax_iterations=relax_iterations, recycle_distance=recycle_distance,
            continuous=continuous, joint_hertz=joint_hertz, joint_damping_ratio=joint_damping_ratio)
        sleep = _sleep_settings("World", sleeping=sleeping, sleep_linear_velocity=sleep_linear_velocity,
                                sleep_angular_velocity=sleep_angular_velocity, time_to_sleep=time_to_sleep)
        self._core = _core.World(g, as_scalar(contact_margin, "World", "contact_margin"), settings, sleep,
                                 given_threads or 0)
        self._threads = given_threads  # as given (None: the machine's cores), for pickles
        # held by every method and property (see World.lock); kept by __setstate__
        self._lock = self.__dict__.get("_lock") or threading.RLock()
        # what each body was added with, in index order (save_scene writes a body that has not
        # moved with these values, so a saved scene steps bit for bit like the original)
        self._args: list[Optional[codec.BodyArgs]] = []
        # what each joint was made from (joint_args; save_scene writes it), by its bodies and the
        # body-frame values the core made of it, which never change (renumbered with the bodies)
        self._joint_args: dict[bytes, codec.JointArgs] = {}
        self._unconverged_substeps = 0  # flagged substeps so far (see warn_velocity)
        self._warned = False

    @property
    def lock(self) -> threading.RLock:
        """The world's re-entrant lock. Every method and property holds it for its whole call, so
        calls from several threads run one at a time; hold it yourself (``with world.lock:``) to
        make several calls one unit, such as ``remove_body(find(name))`` or a ``save_state`` and
        the ``restore_state`` that undoes another thread's steps (README "Threads")."""
        return self._lock

    @property
    @_locked
    def threads(self) -> int:
        """The step's worker threads (README "Threads"): results are bit-identical for every count."""
        return self._core.threads

    @_locked
    def set_threads(self, threads: Optional[int]) -> None:
        """Sets the step's worker threads (an integer >= 1; None: the machine's cores)."""
        given = _threads("set_threads", threads)
        self._core.set_threads(given or 0)
        self._threads = given

    @_locked
    def set_solver(self, **settings) -> None:
        """Changes solver settings by keyword (the names of the constructor's); the others stay,
        but for ``recycle_distance``, which follows a change of ``solver`` while it is the old
        solver's default (``RECYCLE_DEFAULTS``)."""
        unknown = set(settings) - set(SOLVER_DEFAULTS)
        if unknown:
            raise TypeError(f"set_solver: unknown setting(s) {sorted(unknown)}; known: {sorted(SOLVER_DEFAULTS)}")
        self._core.set_solver(_solver_settings("set_solver", self._core.solver, **settings))
        self._warned = False  # new settings: their first unconverged step warns again

    @_locked
    def set_sleep(self, **settings) -> None:
        """Changes sleep settings by keyword (``sleeping``, ``sleep_linear_velocity``,
        ``sleep_angular_velocity``, ``time_to_sleep``); the others stay. ``sleeping=False`` wakes
        every body. A bad value raises naming the setting, and nothing changes."""
        unknown = set(settings) - set(SLEEP_DEFAULTS)
        if unknown:
            raise TypeError(f"set_sleep: unknown setting(s) {sorted(unknown)}; known: {sorted(SLEEP_DEFAULTS)}")
        self._core.set_sleep(_sleep_settings("set_sleep", self._core.sleep, **settings))

    @property
    @_locked
    def sleep(self) -> dict:
        """The sleep settings as a dict (the constructor's keywords)."""
        s = self._core.sleep
        return {k: getattr(s, f) for k, f in _SLEEP_FIELDS.items()}

    @property
    @_locked
    def awake(self) -> np.ndarray:
        """(N,) bool, a read-only view: False for a sleeping body (its pose frozen bit for bit, its
        velocities zero) and for a static one (which never moves); True for the others."""
        return self._core.awake

    @property
    @_locked
    def sleep_times(self) -> np.ndarray:
        """(N,) s: how long each awake dynamic body has stayed below the sleep thresholds (a copy)."""
        return readonly(self._core.sleep_times)

    @property
    @_locked
    def can_sleep(self) -> np.ndarray:
        """(N,) bool: False for bodies that never sleep (``set_can_sleep``)."""
        return readonly(self._core.can_sleep)

    @_locked
    def set_awake(self, i: int, awake: bool = True) -> None:
        """Wakes body i's island (``awake=True``), or puts the island body i is in (by the last
        step's contacts) to sleep now with its velocities zeroed (``awake=False``). ValueError naming
        the body for a static body, a kinematic or disabled one put to sleep, an island with a body
        that cannot sleep, or a world with sleeping off; nothing changes then."""
        i = self._index(i)
        self._core.set_awake(i, as_flag(awake, self.label(i), "awake"))

    @property
    @_locked
    def is_sensor(self) -> np.ndarray:
        """(N,) bool: True for sensor bodies (``add_body(..., sensor=True)``, ``set_sensor``)."""
        return readonly(self._core.is_sensor)

    @_locked
    def set_sensor(self, i: int, sensor: bool) -> None:
        """Makes body i a sensor (its overlaps with bodies that are not sensors are reported as
        ``events.sensor_begin`` and ``sensor_end``; it never collides) or a body that collides
        again. It wakes."""
        i = self._index(i)
        self._core.set_sensor(i, as_flag(sensor, self.label(i), "sensor"))

    @property
    def is_bullet(self) -> np.ndarray:
        """(N,) bool: True for bodies swept against the static ones after every step
        (``add_body(..., bullet=True)``, ``set_bullet``)."""
        return readonly(self._core.is_bullet)

    @_locked
    def set_bullet(self, i: int, bullet: bool) -> None:
        """Makes dynamic body i a bullet (continuous collision against the static bodies after every
        step, however slowly it moves; docs/conventions.md, "Shape casts and continuous collision")
        or a body swept only when it moves fast. A static body is refused."""
        i = self._index(i)
        self._core.set_bullet(i, as_flag(bullet, self.label(i), "bullet"))

    @_locked
    def set_can_sleep(self, i: int, can_sleep: bool) -> None:
        """Whether body i may sleep; False wakes its island and keeps any island it is in awake."""
        i = self._index(i)
        self._core.set_can_sleep(i, as_flag(can_sleep, self.label(i), "can_sleep"))

    @property
    @_locked
    def unconverged_substeps(self) -> int:
        """Solver substeps so far (``substeps`` per step) that ended with the contact solver unconverged and a contact approaching
        faster than ``warn_velocity`` (only the first of them raised a ``SolverWarning``)."""
        return self._unconverged_substeps

    @property
    @_locked
    def step_report(self) -> dict:
        """What the last ``step`` call did: ``steps`` (substeps counted), ``flagged`` (of them, ended
        unconverged with a contact approaching faster than ``warn_velocity``), the worst such
        ``worst_penetration_velocity`` (m/s) and its ``worst_time`` (s), and ``continuous``: the bodies
        continuous collision put back (``set_solver(continuous=...)``)."""
        return dict(self._core.step_report)

    @property
    @_locked
    def solver(self) -> dict:
        """The solver settings as a dict (the constructor's keywords)."""
        s = self._core.solver
        return {k: _setting(s, k) for k in SOLVER_DEFAULTS}

    # bodies -----------------------------------------------------------------------------------
    def add_body(self, shape, *, density=None, mass=None, inertia=None, position=(0.0, 0.0, 0.0),
                 orientation=(1.0, 0.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0),
                 angular_velocity=(0.0, 0.0, 0.0), friction: float = 0.5, restitution: float = 0.0,
                 spinning_friction: float = 0.0, kinematic: bool = False, name: str | None = None,
                 group: int = 1, mask: int = ALL_BITS, enabled: bool = True, can_sleep: bool = True,
                 sensor: bool = False, bullet: bool = False) -> int:
        """Adds a dynamic (or kinematic) body and returns its index.

        Exactly one of ``density`` (kg/m^3) or ``mass`` (kg). ``position`` (3,) is where the
        centre of mass goes (a mesh is re-centred on its centre of mass, axes unchanged);
        ``orientation`` is a quaternion (w, x, y, z), normalised if it is not unit length (a zero
        one is an error); velocities are world-frame (m/s, rad/s). ``friction`` mu >= 0,
        ``restitution`` e in [0, 1] and ``spinning_friction`` mu_spin >= 0 (a length, m) are the
        body's material; a contact uses sqrt(mu_A mu_B), max(e_A, e_B) and max(mu_spin_A,
        mu_spin_B). Spinning friction is torsional friction: at a contact that is its body pair's
        only point (a sphere on the ground, a capsule on its end, a corner) the torque about the
        normal is bounded by mu_spin alpha_n; 0 (the default) gives none (docs/conventions.md).

        ``inertia`` (3, 3) kg m^2 about the centre of mass, body axes, with ``mass``: replaces the
        shape's mass properties; the shape's origin is then the centre of mass (nothing re-centred).
        ``kinematic=True``: the body moves with the velocity you give it (``set_velocity``), feels
        no gravity or forces, and pushes dynamic bodies as an infinite mass would; a mass is
        optional (needed only to make it dynamic later). ``name``: unique in the world
        (``find``). ``group`` / ``mask``: collision filter bits (see ``set_collision_filter``).
        ``enabled=False`` adds it disabled (``set_enabled``). ``can_sleep=False``: it never sleeps,
        nor does any island it is in (``set_can_sleep``). ``sensor=True``: it collides with nothing;
        its overlaps with other bodies are ``events.sensor_begin`` / ``sensor_end`` (``set_sensor``).
        ``bullet=True``: continuous collision against the static bodies after every step, however
        slowly it moves (other bodies get it when they move more than half their inner radius in a
        step; ``set_solver(continuous=False)`` turns it off; ``set_bullet``).

        A non-convex ``Mesh`` without convex pieces is decomposed first (``sg.decompose`` with
        its defaults: cached, but the first time it can take minutes, with an estimate and a
        progress bar on stderr; Ctrl-C stops it and adds nothing).

        On any bad argument raises ValueError or TypeError naming the body (RuntimeError when
        CoACD fails), and the world is unchanged.
        """
        return self._add(shape, False, kinematic, density, mass, inertia, position, orientation, velocity,
                         angular_velocity, friction, restitution, spinning_friction, name, group, mask, enabled,
                         can_sleep, sensor, bullet)

    def add_static(self, shape, *, position=(0.0, 0.0, 0.0), orientation=(1.0, 0.0, 0.0, 0.0),
                   friction: float = 0.5, restitution: float = 0.0, spinning_friction: float = 0.0,
                   name: str | None = None, group: int = 1, mask: int = ALL_BITS, enabled: bool = True,
                   sensor: bool = False) -> int:
        """Adds a static body (inverse mass and inertia zero: it never moves) and returns its index.
        ``friction``, ``restitution``, ``spinning_friction``, ``name``, ``group``, ``mask``,
        ``enabled`` and ``sensor`` as for ``add_body``."""
        return self._add(shape, True, False, None, None, None, position, orientation, (0.0, 0.0, 0.0),
                         (0.0, 0.0, 0.0), friction, restitution, spinning_friction, name, group, mask, enabled,
                         True, sensor)

    def _add(self, shape, is_static, kinematic, density, mass, inertia, position, orientation, velocity,
             angular_velocity, friction, restitution, spinning_friction, name, group, mask, enabled,
             can_sleep=True, sensor=False, bullet=False) -> int:
        who = f"body {self.num_bodies} ({type(shape).__name__})"
        if not isinstance(shape, Shape):
            raise TypeError(f"{who}: shape must be a Sphere, Box, Plane, Mesh, Capsule, Cylinder, ConvexHull, "
                            f"TriangleMesh or Compound, got {type(shape).__name__}")
        kinematic = as_flag(kinematic, who, "kinematic")
        if inertia is not None:
            try:
                inertia = np.asarray(inertia, dtype=np.float64)
            except (TypeError, ValueError):
                raise TypeError(f"{who}: inertia must be a (3, 3) array of numbers, got {inertia!r}") from None
            if inertia.shape != (3, 3):
                raise ValueError(f"{who}: inertia must have shape (3, 3), got shape {inertia.shape}")
        args = (is_static, kinematic, as_scalar(density, who, "density"), as_scalar(mass, who, "mass"), inertia,
                as_vector(position, 3, who, "position"), as_vector(orientation, 4, who, "orientation"),
                as_vector(velocity, 3, who, "velocity"), as_vector(angular_velocity, 3, who, "angular_velocity"),
                as_number(friction, who, "friction"), as_number(restitution, who, "restitution"),
                as_number(spinning_friction, who, "spinning_friction"), as_name(name, who),
                as_bits(group, who, "group"), as_bits(mask, who, "mask"), as_flag(enabled, who, "enabled"),
                as_flag(can_sleep, who, "can_sleep"), as_flag(sensor, who, "sensor"), as_flag(bullet, who, "bullet"))
        if (not is_static and isinstance(shape, Mesh) and not shape.pieces and not shape.is_convex()
                and _solid(shape)):
            # a dynamic non-convex mesh collides with other bodies through convex pieces
            from .decomposition import decompose
            try:
                shape = decompose(shape)
            except (ValueError, RuntimeError) as e:
                raise type(e)(f"{who}: {e}") from None
        # what it was added with (save_scene writes a body that has not moved with these values)
        # (copies: a caller's array changed later must not change the record)
        record = codec.BodyArgs(shape, *args[2:4], *(readonly(np.array(a)) for a in args[5:9]),
                                inertia=None if args[4] is None else readonly(np.array(args[4])))
        with self._lock:  # the checks and a mesh's decomposition above run without it
            index = self._core.add_body(shape, *args)
            self._args.append(record)
        return index

    @_locked
    def remove_body(self, i: int) -> None:
        """Removes body i. Indices behave like a Python list's: every body after i moves down one
        index (body i + 1 becomes body i, ...), names follow their bodies, and the warm-start cache,
        the last step's contacts and disabled pairs are renumbered (those of body i dropped), so
        the next step goes on as if body i had never been there.

        State arrays read before (``positions``...) still point at valid memory but no longer
        match the bodies: read them again. Costs O(N) (the broad phase is rebuilt); to remove many
        bodies, ``remove_bodies`` does it in one pass."""
        i = self._index(i)
        joints = self._joints_before_removal()
        self._core.remove_body(i)
        del self._args[i]
        self._renumber_joint_args(joints, [i])

    @_locked
    def remove_bodies(self, indices) -> None:
        """Removes the bodies at ``indices`` ((K,) integers, any order, each once) in one O(N + K)
        pass with one broad-phase rebuild; the result is that of ``remove_body`` on each, from the
        highest index down: the bodies that stay keep their order and close up. An index out of
        range (BodyIndexError) or given twice (ValueError) changes nothing."""
        ii = as_indices(indices, "remove_bodies")
        beyond = ii[(ii < -2**31) | (ii >= 2**31)]  # not even a C int: the core could not name it
        if beyond.size:
            raise BodyIndexError(f"body index {beyond[0]} is out of range: the world has {self.num_bodies} bodies")
        joints = self._joints_before_removal()
        self._core.remove_bodies(ii)
        for i in sorted(set(int(k) for k in ii), reverse=True):
            del self._args[i]
        self._renumber_joint_args(joints, ii)

    def _joints_before_removal(self) -> list:
        """(joint dict, record) of each joint with a record, for _renumber_joint_args."""
        joints = (self._core.joint(j) for j in range(self._core.num_joints))
        return [(d, self._joint_args[codec.joint_key(d)]) for d in joints if codec.joint_key(d) in self._joint_args]

    def _renumber_joint_args(self, joints: list, removed) -> None:
        """The joint records after bodies ``removed`` went: theirs dropped, the others' bodies
        renumbered as the core renumbers them (later bodies move down)."""
        gone = np.unique(np.asarray(removed, dtype=np.int64))
        kept = {}
        for d, record in joints:
            if d["body_a"] in gone or d["body_b"] in gone:
                continue
            moved = {k: int(d[k] - np.searchsorted(gone, d[k])) for k in ("body_a", "body_b")}
            kept[codec.joint_key({**d, **moved})] = record
        self._joint_args = kept

    def _index(self, i) -> int:
        """i as an int (the core checks the range and raises BodyIndexError naming the index and
        the body count): a Python or NumPy integer, not a bool; negative indices are out of range."""
        if isinstance(i, (bool, np.bool_)) or not isinstance(i, (int, np.integer)):
            raise TypeError(f"body index must be an integer, got {i!r}")
        i = int(i)
        if not -2**31 <= i < 2**31:
            raise BodyIndexError(f"body index {i} is out of range: the world has {self.num_bodies} bodies")
        return i

    @_locked
    def label(self, i: int) -> str:
        """How errors name body i, "body 3 'ball' (Sphere)" (BodyIndexError when there is no body i)."""
        return self._core.label(self._index(i))

    @_locked
    def body_args(self, i: int) -> Optional[codec.BodyArgs]:
        """What body i was added with (shape after any decomposition, density or mass, inertia, pose
        and velocities, as converted), or None when unknown (a world unpickled from an old pickle)."""
        i = self._index(i)
        self.label(i)
        return self._args[i]

    @_locked
    def shape(self, i: int):
        """The shape of body i (a mesh body's vertices are centred on its centre of mass)."""
        i = self._index(i)
        self.label(i)
        return self._core.shape(i)

    @_locked
    def name(self, i: int) -> str:
        """Body i's name ("" when it has none)."""
        i = self._index(i)
        self.label(i)
        return self._core.names[i]

    @property
    @_locked
    def names(self) -> list:
        """Every body's name ("" for unnamed ones), in index order."""
        return self._core.names

    @_locked
    def find(self, name: str) -> int:
        """The index of the body called ``name``; KeyError when there is none."""
        if not isinstance(name, str):
            raise TypeError(f"find: name must be a string, got {name!r}")
        i = self._core.find(name) if name else -1
        if i < 0:
            raise KeyError(f"no body is named {name!r}")
        return i

    @_locked
    def set_position(self, i: int, position) -> None:
        i = self._index(i)
        self._core.set_position(i, as_vector(position, 3, self.label(i), "position"))

    @_locked
    def set_orientation(self, i: int, orientation) -> None:
        i = self._index(i)
        self._core.set_orientation(i, as_vector(orientation, 4, self.label(i), "orientation"))

    @_locked
    def set_velocity(self, i: int, velocity) -> None:
        i = self._index(i)
        self._core.set_velocity(i, as_vector(velocity, 3, self.label(i), "velocity"))

    @_locked
    def set_angular_velocity(self, i: int, angular_velocity) -> None:
        i = self._index(i)
        self._core.set_angular_velocity(i, as_vector(angular_velocity, 3, self.label(i), "angular_velocity"))

    @_locked
    def set_positions(self, indices, positions) -> None:
        """Sets the positions (n, 3) of bodies ``indices`` (n,) in one call; every row is checked
        before any is written (on an error the world is unchanged)."""
        self._core.set_positions(as_indices(indices, "set_positions"), as_rows(positions, 3, "set_positions", "positions"))

    @_locked
    def set_orientations(self, indices, orientations) -> None:
        """Sets the orientations (n, 4), quaternions (w, x, y, z), of bodies ``indices`` in one call."""
        self._core.set_orientations(as_indices(indices, "set_orientations"),
                                    as_rows(orientations, 4, "set_orientations", "orientations"))

    @_locked
    def set_velocities(self, indices, velocities) -> None:
        """Sets the linear velocities (n, 3) of bodies ``indices`` in one call (m/s, world)."""
        self._core.set_velocities(as_indices(indices, "set_velocities"),
                                  as_rows(velocities, 3, "set_velocities", "velocities"))

    @_locked
    def set_angular_velocities(self, indices, angular_velocities) -> None:
        """Sets the angular velocities (n, 3) of bodies ``indices`` in one call (rad/s, world)."""
        self._core.set_angular_velocities(as_indices(indices, "set_angular_velocities"),
                                          as_rows(angular_velocities, 3, "set_angular_velocities",
                                                "angular_velocities"))

    @_locked
    def set_external_wrench(self, i: int, force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0)) -> None:
        """Sets a world-frame force (N, at the centre of mass) and torque (N m) applied every step
        until changed (persistent; ``apply_force`` adds a force for one step only)."""
        i = self._index(i)
        self._core.set_external_wrench(i, as_vector(force, 3, self.label(i), "force"),
                                       as_vector(torque, 3, self.label(i), "torque"))

    @_locked
    def apply_impulse(self, i: int, impulse, point=None) -> None:
        """Applies an impulse J (3,) N s, world, at world ``point`` (m; None: the centre of mass)
        at the start of the next step: v += J / m and omega += I_w^-1 ((point - x) x J). Calls before
        a step add up. Dynamic bodies only (a disabled one ignores it)."""
        i = self._index(i)
        who = self.label(i)
        self._core.apply_impulse(i, as_vector(impulse, 3, who, "impulse"),
                                 None if point is None else as_vector(point, 3, who, "point"))

    @_locked
    def apply_force(self, i: int, force, point=None) -> None:
        """Applies a force F (3,) N, world, at world ``point`` (m; None: the centre of mass) during
        the next step only (the first step of the next ``step()`` call), with the torque
        (point - x) x F, on top of the persistent ``set_external_wrench``. Dynamic bodies only."""
        i = self._index(i)
        who = self.label(i)
        self._core.apply_force(i, as_vector(force, 3, who, "force"),
                               None if point is None else as_vector(point, 3, who, "point"))

    @_locked
    def set_kinematic(self, i: int, kinematic: bool = True) -> None:
        """Makes body i kinematic (moved by its velocity only, an infinite mass for the bodies it
        pushes, no gravity) or dynamic again (it needs a mass). Its velocity is kept."""
        i = self._index(i)
        self._core.set_kinematic(i, as_flag(kinematic, self.label(i), "kinematic"))

    @_locked
    def set_enabled(self, i: int, enabled: bool) -> None:
        """Disables (False) or enables body i. A disabled body keeps its pose and velocity, feels
        no gravity or forces and collides with nothing; enabled again, it carries on from there."""
        i = self._index(i)
        self._core.set_enabled(i, as_flag(enabled, self.label(i), "enabled"))

    @_locked
    def set_collision_filter(self, i: int, group: int = 1, mask: int = ALL_BITS) -> None:
        """Collision filter bits of body i (32 each): bodies a and b collide only when
        ``group_a & mask_b`` and ``group_b & mask_a`` are both non-zero (Box2D's category and
        mask bits). The defaults (1, all bits) collide with everything."""
        i = self._index(i)
        who = self.label(i)
        self._core.set_collision_filter(i, as_bits(group, who, "group"), as_bits(mask, who, "mask"))

    @_locked
    def disable_collision(self, i: int, j: int) -> None:
        """Bodies i and j never collide with each other (whatever their filter bits say)."""
        self._core.set_pair_collision(self._index(i), self._index(j), False)

    @_locked
    def enable_collision(self, i: int, j: int) -> None:
        """Undoes ``disable_collision(i, j)``: the pair collides again if their filter bits allow."""
        self._core.set_pair_collision(self._index(i), self._index(j), True)

    @_locked
    def set_material(self, i: int, friction=None, restitution=None, spinning_friction=None) -> None:
        """Sets body i's friction (mu >= 0), restitution (e in [0, 1]) and/or spinning friction
        (mu_spin >= 0, m); None keeps it."""
        i = self._index(i)
        who = self.label(i)
        mu = as_scalar(friction, who, "friction")
        e = as_scalar(restitution, who, "restitution")
        mu_spin = as_scalar(spinning_friction, who, "spinning_friction")
        self._core.set_material(i, float(self._core.frictions[i]) if mu is None else mu,
                                float(self._core.restitutions[i]) if e is None else e,
                                float(self._core.spinning_frictions[i]) if mu_spin is None else mu_spin)

    @_locked
    def set_mass(self, i: int, mass: float) -> None:
        """Sets dynamic (or kinematic) body i's mass (kg, finite, > 0); its inertia scales by
        mass / old mass (the same shape, uniformly denser or lighter)."""
        i = self._index(i)
        self._core.set_mass(i, as_number(mass, self.label(i), "mass"))

    @_locked
    def set_gravity(self, gravity) -> None:
        """Sets gravity (3,) m/s^2, world frame, finite; every sleeping body wakes."""
        self._core.set_gravity(as_vector(gravity, 3, "set_gravity", "gravity"))

    # saved states and pickling ----------------------------------------------------------------------
    @_locked
    def save_state(self) -> SavedState:
        """The dynamic state (see ``SavedState``): after ``restore_state`` of it, the following
        steps are bit-identical to those that followed the save."""
        return SavedState(self._core.save_state(), self.num_bodies, self.time)

    @_locked
    def restore_state(self, state: SavedState) -> None:
        """Puts back a ``save_state()`` of this world (or of one built the same way, such as its
        unpickled copy). A state of a different world (body count, shape kinds, static flags or
        masses) raises ValueError and changes nothing. State views stay valid and show the
        restored values."""
        if not isinstance(state, SavedState):
            raise TypeError(f"restore_state: expected a SavedState from World.save_state(), got {type(state).__name__}")
        self._core.restore_state(state.data)

    @_locked
    def __getstate__(self) -> dict:
        """The model (settings; per body its shape as stored, static and kinematic flags, mass and
        inertia, material, name, filter bits; disabled pairs) and the saved state."""
        c = self._core
        bodies = [{"shape": c.shape(i), **model} for i, model in enumerate(codec.body_models(self))]
        return {"version": 1, "gravity": np.array(c.gravity), "contact_margin": c.contact_margin,
                "solver": self.solver, "sleep": self.sleep, "bodies": bodies, "excluded_pairs": list(c.excluded_pairs),
                "state": self.save_state(), "given": [None if g is None else tuple(g) for g in self._args],
                "threads": self._threads, "hit_speed": c.hit_speed,
                "joints_given": [None if g is None else tuple(g) for g in map(self.joint_args, range(c.num_joints))]}

    def __setstate__(self, d: dict) -> None:
        """Builds the pickled world in a new core, then (holding the lock) puts it in place of this
        world's: a thread using this World sees the old world or the new one, never half of each."""
        if d.get("version") != 1:
            raise ValueError(f"World: cannot unpickle version {d.get('version')!r} (this is version 1)")
        new = World(gravity=d["gravity"], contact_margin=d["contact_margin"], threads=d.get("threads"), **d["solver"],
                    **d.get("sleep", {}))
        new._fill(d)
        new._core.hit_speed = d.get("hit_speed", 1.0)
        lock = self.__dict__.setdefault("_lock", threading.RLock())
        with lock:
            self.__dict__.update({k: v for k, v in new.__dict__.items() if k != "_lock"})

    def _fill(self, d: dict) -> None:
        """Adds __getstate__'s bodies, disabled pairs, saved state and records to this new world."""
        c = self._core
        zero, unit = np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])
        for b in d["bodies"]:
            # the shape as the world stored it (already centred), with its exact mass and inertia;
            # poses, velocities and flags come with the saved state
            has_mass = not b["static"] and bool(np.isfinite(b["mass"]))
            c.add_body(b["shape"], b["static"], b["kinematic"], None, b["mass"] if has_mass else None,
                       b["inertia"] if has_mass else None, zero, unit, zero, zero, b["friction"],
                       b["restitution"], b.get("spinning_friction", 0.0), b["name"], b["group"], b["mask"], True,
                       b.get("can_sleep", True), b.get("sensor", False), b.get("bullet", False))
        for i, j in d["excluded_pairs"]:
            c.set_pair_collision(i, j, False)
        self.restore_state(d["state"])
        # for save_scene; a record of an older version (no inertia) is unknown, not guessed
        given = d.get("given") or [None] * c.num_bodies
        self._args = [codec.BodyArgs(*g) if g is not None and len(g) == len(codec.BodyArgs._fields) else None
                      for g in given]
        for j, g in enumerate(d.get("joints_given") or []):
            if g is not None:
                self._joint_args[codec.joint_key(c.joint(j))] = codec.JointArgs(*g)

    # joints (docs/conventions.md, "Joints") -----------------------------------------------------
    @_locked
    def add_joint(self, joint: Joint) -> int:
        """Adds a joint (``sg.Revolute``, ``sg.Prismatic``, ``sg.Spherical``, ``sg.Fixed``,
        ``sg.Distance``; anchors and axes in world coordinates now) and returns its index. The two
        bodies wake and, unless ``collide_connected``, no longer collide with each other. Bad input
        (a body that does not exist, the same body twice, two static bodies, a zero or non-finite
        axis or anchor, limits lo > hi, a negative motor torque, a name already taken...) raises
        TypeError, ValueError or BodyIndexError naming the joint and the problem, and changes
        nothing."""
        if not isinstance(joint, Joint) or joint.kind not in _JOINT_KINDS:
            raise TypeError("add_joint: expected a signorini.Revolute, Prismatic, Spherical, Fixed or Distance, "
                            f"got {joint!r}")
        who = (f"joint {self._core.num_joints}" + (f" '{joint.name}'" if isinstance(joint.name, str) and joint.name
                                                   else "") + f" ({_JOINT_KINDS[joint.kind]})")
        args = joint._core_args(who, self.positions)
        j = self._core.add_joint(joint.kind, **args)
        ab = [args["body_a"], args["body_b"]]
        self._joint_args[codec.joint_key(self._core.joint(j))] = codec.JointArgs(
            *(readonly(np.array(args[k])) for k in ("anchor", "anchor_b", "axis")),
            readonly(np.array(self.positions[ab])), readonly(np.array(self.rotations[ab])))
        return j

    @_locked
    def joint_args(self, joint: int) -> Optional[codec.JointArgs]:
        """What joint ``joint`` was made from (``codec.JointArgs``): its anchor, anchor_b and axis as
        given (world, at creation; anchor_b is a Distance joint's) and its bodies' poses then, or
        None when unknown (a world unpickled from an old pickle)."""
        return self._joint_args.get(codec.joint_key(self._core.joint(self._joint_index(joint))))

    @_locked
    def remove_joint(self, joint: int) -> None:
        """Removes joint ``joint`` (an index from ``add_joint``); later joints move down one index
        (like a list). Its bodies wake and collide again (unless another joint or
        ``disable_collision`` keeps them apart)."""
        self._core.remove_joint(self._joint_index(joint))

    def _joint_index(self, joint) -> int:
        if isinstance(joint, (bool, np.bool_)) or not isinstance(joint, (int, np.integer)):
            raise TypeError(f"joint index must be an integer, got {joint!r}")
        if not 0 <= int(joint) < self._core.num_joints:
            raise IndexError(f"joint index {int(joint)} is out of range: the world has {self._core.num_joints} joints")
        return int(joint)

    @_locked
    def set_joint_motor(self, joint: int, motor: Optional[Motor]) -> None:
        """Gives hinge or slider ``joint`` a new motor from the next step on (``sg.Motor(speed,
        max_force)``; None switches it off): a target set per step. Its bodies wake. Bad values
        raise naming the joint, and nothing changes."""
        j = self._joint_index(joint)
        who = self._core.joint_label(j)
        if motor is None:
            self._core.set_joint_motor(j, False, 0.0, 0.0)
            return
        if not isinstance(motor, Motor):
            raise TypeError(f"{who}: motor must be a signorini.Motor or None, got {motor!r}")
        self._core.set_joint_motor(j, True, **motor._core_args(who))

    @_locked
    def set_joint_effort(self, joint: int, effort: float) -> None:
        """The torque (N m, a hinge) or force (N, a slider) ``joint`` applies along its coordinate
        from the next step on, on its body B (the opposite on A), every substep: a control set per
        step (MuJoCo's motor actuator, a ROS effort command). Its bodies wake. A joint without one
        degree of freedom, or a value that is not finite, raises naming the joint."""
        j = self._joint_index(joint)
        self._core.set_joint_effort(j, as_number(effort, self._core.joint_label(j), "effort"))

    @_locked
    def set_joint_broken(self, joint: int, broken: bool = True) -> None:
        """Breaks ``joint`` (it makes no rows, transmits nothing, and its bodies collide unless
        something else keeps them apart) or mends it (``broken=False``: its rows return at the
        next step, at the bodies' poses then, from zero forces). Its bodies wake."""
        j = self._joint_index(joint)
        self._core.set_joint_broken(j, as_flag(broken, self._core.joint_label(j), "broken"))

    @property
    @_locked
    def joint_breaks(self) -> JointBreaks:
        """The joints that broke in the last ``step`` call (their ``break_force`` or
        ``break_torque`` passed), in the order they broke; ``joint(j)["broken"]`` stays True."""
        return JointBreaks(**self._core.joint_breaks)

    @property
    @_locked
    def num_joints(self) -> int:
        return self._core.num_joints

    @_locked
    def find_joint(self, name: str) -> int:
        """Index of the joint named ``name``, or -1."""
        return self._core.find_joint(as_name(name, "find_joint"))

    @_locked
    def joint(self, joint: int) -> dict:
        """Joint ``joint`` as the world keeps it: kind, bodies, anchors, axes and reference vectors
        in each body's frame, R_rel, limits, motor, lengths, name, its rows' warm-start forces
        (``alpha``, 11 slots) and its last force and torque on B (signorini.oracle.joints)."""
        d = self._core.joint(self._joint_index(joint))
        d["kind"] = _JOINT_KINDS[d["kind"]]
        return d

    @property
    @_locked
    def joint_positions(self) -> np.ndarray:
        """(J,) each one-dof joint's coordinate: a hinge's angle (rad, in (-pi, pi], 0 at creation),
        a slider's offset (m); NaN for the other joints. A copy."""
        return self._core.joint_positions

    @property
    @_locked
    def joint_velocities(self) -> np.ndarray:
        """(J,) the rates of joint_positions (rad/s, m/s); NaN for joints that are not one-dof."""
        return self._core.joint_velocities

    @property
    @_locked
    def joint_limit_forces(self) -> np.ndarray:
        """(J,) what each joint's limit pushes with in the last substep (N m for a hinge, N for a
        slider or a Distance joint's length): > 0 at the lower limit (a Distance joint at its
        min_length), < 0 at the upper one (a rope taut at its max_length), 0 when no limit acts, so a
        limit is active exactly when this is non-zero; for a rod (min_length = max_length) the rod's
        push along its length (< 0: pulling). A ball joint's is its twist limits' (> 0 at the lower
        one) less its cone's push. NaN-free; 0 for joints without limits."""
        rows = self._core.joint_row_forces
        if not len(rows):
            return np.zeros(0)
        ball = np.array([self._core.joint(j)["kind"] == SPHERICAL for j in range(len(rows))], dtype=bool)
        return np.where(ball, rows[:, 6] - rows[:, 7], rows[:, 1]) - rows[:, 2]

    @property
    @_locked
    def joint_motor_forces(self) -> np.ndarray:
        """(J,) the torque (N m) or force (N) each joint's motor applied in the last substep, NaN
        for a joint without a motor; at +-max_force the motor is saturated. Its friction and effort
        rows are apart: ``joint_row_forces`` has every row."""
        rows = self._core.joint_row_forces
        has = np.array([bool(self._core.joint(j)["motor"]) for j in range(len(rows))], dtype=bool)
        return np.where(has, rows[:, 0] if len(rows) else np.zeros(0), np.nan)

    @property
    @_locked
    def joint_row_forces(self) -> np.ndarray:
        """(J, 11) each joint's rows' forces of the last substep by slot (docs/conventions.md,
        "Joints", warm start): motor, lower limit, upper limit (a ball joint's cone), three linear,
        three angular (a ball joint's twist lower and upper limits in the first two), friction,
        effort (N or N m; 0 for a row the joint does not have). A copy."""
        return self._core.joint_row_forces

    @property
    @_locked
    def joint_forces(self) -> np.ndarray:
        """(J, 3) the force (N, world) each joint transmitted to its body B in the last substep (A
        got the opposite). A copy."""
        return self._core.joint_forces

    @property
    @_locked
    def joint_torques(self) -> np.ndarray:
        """(J, 3) the torque (N m, world) each joint transmitted to its body B in the last substep,
        about B's anchor point (a hinge's is perpendicular to its axis unless a motor or limit acts)."""
        return self._core.joint_torques

    # stepping ---------------------------------------------------------------------------------
    @_locked
    def step(self, dt: float, steps: int = 1) -> None:
        """Advances ``steps`` steps of ``dt`` seconds (dt > 0 and finite)."""
        dt = as_number(dt, "step", "dt")
        if isinstance(steps, (int, np.integer)) and not isinstance(steps, (bool, np.bool_)) and steps > INT_MAX:
            raise ValueError(f"step: steps = {steps} is too large: at most {INT_MAX} per call (call step again)")
        steps = as_count(steps, "step", "steps")
        if steps < 0:
            raise ValueError(f"step: steps must be >= 0, got {steps}")
        self._core.step(dt, int(steps))
        report = self._core.step_report
        self._unconverged_substeps += report["flagged"]
        if report["flagged"] and not self._warned:
            self._warned = True
            warnings.warn(
                f"{report['flagged']} of {report['steps']} solver substeps ended with the contact solver unconverged "
                f"and a contact approaching faster than warn_velocity = {self._core.solver.warn_velocity:g} m/s "
                f"(worst {report['worst_penetration_velocity']:.3g} m/s at t = {report['worst_time']:.6g} s); "
                "to solve it: raise max_iterations or substeps (World.set_solver), or lower dt. This world warns once "
                "(until set_solver); World.unconverged_substeps counts every such substep; "
                "warnings.filterwarnings('ignore', category=signorini.SolverWarning) silences it",
                SolverWarning, stacklevel=user_stacklevel())

    @_locked
    def substep_count(self, dt: float) -> int:
        """The substeps a step of ``dt`` s (> 0, finite) runs with the current settings and joints:
        ``substeps`` when set, else the fewest of at most 1/960 s (the PGS) or 1/240 s (the soft
        step; with a joint that is not broken and has a body awake, at most 0.25 / ``joint_hertz``:
        1/960 s at the default)."""
        return int(self._core.substep_count(as_number(dt, "substep_count", "dt")))  # the core checks its range

    # state: read-only views of the core's arrays, (N, 3) / (N, 4) / (N, 3, 3) ------------------
    # They share memory with the world (np.shares_memory holds across reads), show every later
    # step, setter and restore_state, and keep the world alive. Adding or removing a body changes
    # the body count: views taken before stay valid memory but no longer match; read them again.
    @property
    @_locked
    def num_bodies(self) -> int:
        return self._core.num_bodies

    @property
    @_locked
    def time(self) -> float:
        """Simulated time (s)."""
        return self._core.time

    @property
    @_locked
    def positions(self) -> np.ndarray:
        """(N, 3) centre-of-mass positions, world (m); a read-only view."""
        return self._core.positions

    @property
    @_locked
    def orientations(self) -> np.ndarray:
        """(N, 4) unit quaternions (w, x, y, z) with w >= 0, world-from-body; a read-only view."""
        return self._core.orientations

    @property
    @_locked
    def rotations(self) -> np.ndarray:
        """(N, 3, 3) rotation matrices R, world-from-body; a read-only view."""
        return self._core.rotations

    @property
    @_locked
    def velocities(self) -> np.ndarray:
        """(N, 3) linear velocities of the centres of mass, world (m/s); a read-only view."""
        return self._core.velocities

    @property
    @_locked
    def angular_velocities(self) -> np.ndarray:
        """(N, 3) angular velocities, world (rad/s); a read-only view."""
        return self._core.angular_velocities

    @property
    @_locked
    def forces(self) -> np.ndarray:
        """(N, 3) persistent external forces (``set_external_wrench``), world (N); a read-only view."""
        return self._core.forces

    @property
    @_locked
    def torques(self) -> np.ndarray:
        """(N, 3) persistent external torques about the centres of mass, world (N m); a read-only view."""
        return self._core.torques

    @property
    @_locked
    def step_forces(self) -> np.ndarray:
        """(N, 3) forces for the next step only (``apply_force``), world (N); a read-only view."""
        return self._core.step_forces

    @property
    @_locked
    def step_torques(self) -> np.ndarray:
        """(N, 3) torques for the next step only (``apply_force`` at a point), world (N m); a read-only view."""
        return self._core.step_torques

    @property
    @_locked
    def impulses(self) -> np.ndarray:
        """(N, 3) pending impulses (``apply_impulse``), applied at the start of the next step (N s); a read-only view."""
        return self._core.impulses

    @property
    @_locked
    def angular_impulses(self) -> np.ndarray:
        """(N, 3) pending angular impulses about the centres of mass (N m s); a read-only view."""
        return self._core.angular_impulses

    @property
    @_locked
    def masses(self) -> np.ndarray:
        """(N,) masses (kg); infinity for static bodies."""
        return readonly(self._core.masses)

    @property
    @_locked
    def inner_radii(self) -> np.ndarray:
        """(N,) radius (m) of a ball each body's shape contains (sphere and capsule r, box its
        smallest half extent, cylinder min(r, h), a hull the distance from its vertex mean to its
        nearest face, a decomposed mesh or compound the largest over its pieces; infinity for
        planes and triangle meshes). A contact's slop is at most 0.2 of its bodies' smaller one
        (docs/conventions.md, "One step")."""
        return readonly(self._core.inner_radii)

    @property
    @_locked
    def inertias(self) -> np.ndarray:
        """(N, 3, 3) inertia tensors about the centre of mass, body axes (kg m^2); zero for static."""
        return readonly(self._core.inertias)

    @property
    @_locked
    def frictions(self) -> np.ndarray:
        """(N,) friction coefficients mu."""
        return readonly(self._core.frictions)

    @property
    @_locked
    def restitutions(self) -> np.ndarray:
        """(N,) restitution coefficients e."""
        return readonly(self._core.restitutions)

    @property
    @_locked
    def spinning_frictions(self) -> np.ndarray:
        """(N,) spinning (torsional) friction coefficients mu_spin (m)."""
        return readonly(self._core.spinning_frictions)

    @property
    @_locked
    def contact_forces(self) -> np.ndarray:
        """(N, 3) summed contact force on each body in the last step (N, world), static ones too."""
        return readonly(self._core.contact_forces)

    @property
    @_locked
    def contact_torques(self) -> np.ndarray:
        """(N, 3) summed contact torque about each body's com in the last step (N m, world)."""
        return readonly(self._core.contact_torques)

    @property
    @_locked
    def warm_start_cache(self) -> dict:
        """The forces the next step starts from: body_a, body_b (K,), feature_a, feature_b (K,)
        uint64, alpha (K,) N, friction (K, 3) N world, spin (K,) N m (the torsional friction
        torque about the normal), sorted by key."""
        return {k: readonly(v) for k, v in self._core.warm_start_cache.items()}

    @property
    @_locked
    def is_static(self) -> np.ndarray:
        """(N,) bool."""
        return readonly(self._core.is_static)

    @property
    @_locked
    def is_kinematic(self) -> np.ndarray:
        """(N,) bool: bodies moved by their velocity only."""
        return readonly(self._core.is_kinematic)

    @property
    @_locked
    def enabled(self) -> np.ndarray:
        """(N,) bool: False for disabled bodies (``set_enabled``)."""
        return readonly(self._core.enabled)

    @property
    @_locked
    def collision_filters(self) -> tuple:
        """(groups, masks): two (N,) uint32 arrays of collision filter bits."""
        return readonly(self._core.groups), readonly(self._core.masks)

    @property
    @_locked
    def contact_margin(self) -> float:
        """The contact margin (m) the world was made with."""
        return self._core.contact_margin

    @property
    @_locked
    def disabled_pairs(self) -> list:
        """Pairs (i, j), i < j, sorted, that never collide (``disable_collision``)."""
        return [tuple(p) for p in self._core.excluded_pairs]

    @property
    @_locked
    def gravity(self) -> np.ndarray:
        return readonly(np.array(self._core.gravity))

    @property
    @_locked
    def contacts(self) -> Contacts:
        """Contacts of the last step (found at its start) with their solved forces and impulses:
        read-only views of the core's contact list (body_a, body_b int32). Unlike the state views,
        they belong to the step they came from: later steps never change them."""
        return Contacts(**self._core.contacts)

    @property
    @_locked
    def solver_stats(self) -> SolverStats:
        return SolverStats(**self._core.solver_stats)

    @property
    @_locked
    def events(self) -> ContactEvents:
        """The contact events (begin, end, hits) of the last ``step`` call, as arrays (copies); a
        call of several steps gives those of every step, each with its ``step``. Whether a pair
        touched before a step follows from the contacts reported then, so a restored state or an
        unpickled world goes on giving the events the original would have."""
        e = self._core.events
        return ContactEvents(**{k: ContactEventList(**v) for k, v in e.items()})

    @property
    @_locked
    def contact_pairs(self) -> ContactPairs:
        """The last step's contacts summed by body pair (force, normal impulse, count, whether it
        touches): what a user asks of a pair ("how hard do these two press on each other")."""
        c = self._core.contacts
        a, b = np.asarray(c["body_a"], dtype=np.int64), np.asarray(c["body_b"], dtype=np.int64)
        if len(a) == 0:
            empty = np.zeros(0, dtype=np.int64)
            return ContactPairs(empty, empty.copy(), empty.copy(), empty.copy(), np.zeros((0, 3)), np.zeros(0),
                                np.zeros(0, dtype=bool))
        first = np.flatnonzero(np.r_[True, (a[1:] != a[:-1]) | (b[1:] != b[:-1])])
        impulse = np.asarray(c["impulse"], dtype=float)
        touches = (impulse > 0.0) | (np.asarray(c["gap"], dtype=float) < 0.0)
        return ContactPairs(body_a=a[first], body_b=b[first], count=np.diff(np.r_[first, len(a)]), first=first,
                            force=np.add.reduceat(np.asarray(c["force"], dtype=float), first, axis=0),
                            impulse=np.add.reduceat(impulse, first),
                            touching=np.logical_or.reduceat(touches, first))

    @property
    @_locked
    def hit_speed(self) -> float:
        """The approach speed above which a beginning is also a hit (m/s; default 1, as Box2D's)."""
        return self._core.hit_speed

    @hit_speed.setter
    @_locked
    def hit_speed(self, speed: float) -> None:
        self._core.hit_speed = as_number(speed, "World", "hit_speed")

    @property
    @_locked
    def step_profile(self) -> dict[str, float]:
        """Where the wall time of the last ``step`` call went, in ms summed over its steps, stage by
        stage in the step's order: ``guard`` (the checkpoint an undo puts back, pending impulses,
        the energy check), ``detect`` (broad and narrow phase), ``wake`` (sleeping islands touched),
        ``prepare`` (soft step: rows, colours, warm-start lookup), ``solve`` (per substep: gravity,
        warm start, sweeps; the PGS's whole solve), ``integrate`` (poses, finite check), ``relax``
        (soft step: relax sweeps, restitution), ``store`` (soft step: forces, cache, certificate),
        ``continuous`` (fast bodies swept against the static ones), ``commit`` (reported contacts,
        sleep timers, islands), and ``total``, which the stages add
        up to. For finding what a scene costs (docs/conventions.md, "Where a step's time goes");
        never part of a result, and as noisy as the machine."""
        return dict(self._core.step_profile)

    @_locked
    def detect_contacts(self, dt: float) -> Contacts:
        """Contacts the current state would give for a step of dt, without stepping (alpha = 0):
        kept manifolds included, as the step would find them (``recycle_distance``); it changes
        nothing the next step reads."""
        return Contacts(**self._core.detect_contacts(as_number(dt, "detect_contacts", "dt")))

    @_locked
    def kinetic_energy(self) -> float:
        """1/2 sum (m |v|^2 + omega . I_w omega) (J)."""
        return self._core.kinetic_energy()

    @_locked
    def potential_energy(self) -> float:
        """-sum m g . p over dynamic bodies (J), relative to the origin."""
        return self._core.potential_energy()

    # the oracle's view --------------------------------------------------------------------------
    @_locked
    def snapshot(self) -> dict:
        """The whole world as plain NumPy data (copies), the input format of ``signorini.oracle``.
        Linear in the body count. ``joints``: one dict per joint (``joint``; signorini.oracle.joints
        says what each key holds). ``step_force``, ``step_torque`` (N, 3): the next step's one-step
        force and torque (``apply_force``); ``impulse``, ``angular_impulse`` (N, 3): pending
        impulses about the centres of mass (``apply_impulse``)."""
        c = self._core
        inv_masses, inv_inertias, inner = c.inv_masses, c.inv_inertias, c.inner_radii
        bodies = [{"shape": codec.shape_to_dict(c.shape(i)), **model, "inv_mass": float(inv_masses[i]),
                   "inv_inertia": inv_inertias[i], "inner_radius": float(inner[i])}
                  for i, model in enumerate(codec.body_models(self))]
        return {
            "gravity": np.array(c.gravity),
            "settings": {"contact_margin": c.contact_margin, **self.solver},
            "cache": self.warm_start_cache,
            "bodies": bodies,
            "excluded_pairs": list(c.excluded_pairs),
            "position": np.array(c.positions), "rotation": np.array(c.rotations),
            "velocity": np.array(c.velocities), "angular_velocity": np.array(c.angular_velocities),
            "force": np.array(c.forces), "torque": np.array(c.torques),
            "step_force": np.array(c.step_forces), "step_torque": np.array(c.step_torques),
            "impulse": np.array(c.impulses), "angular_impulse": np.array(c.angular_impulses),
            "joints": [self.joint(j) for j in range(c.num_joints)],
        }

    @_locked
    def save_scene(self, path) -> Path:
        """Writes this world to a TOML scene file (``signorini.save_scene``); returns the path.
        ValueError naming the body for what a scene file cannot hold (a pending impulse or
        one-step force)."""
        return codec.write_scene(self, path)

    # ---- queries (issue 24; signorini.queries and docs/conventions.md, "Queries") ----
    @_locked
    def cast_ray(self, origin, direction, max_distance=math.inf, *, group=ALL_BITS, mask=ALL_BITS,
                 exclude=()) -> Optional[queries.Hit]:
        """The closest body the ray ``origin + t direction/|direction|``, ``0 <= t <= max_distance``
        meets, as a ``Hit`` (ties: the lower body index), or None. Bodies are seen when enabled,
        ``body_group & mask`` and ``body_mask & group`` are non-zero, and not in ``exclude``."""
        args = queries.ray_args("cast_ray", origin, direction, max_distance)
        return queries.hit(self._core.cast_ray(*args, **queries.filter_args("cast_ray", group, mask, exclude)))

    @_locked
    def cast_ray_any(self, origin, direction, max_distance=math.inf, *, group=ALL_BITS, mask=ALL_BITS,
                     exclude=()) -> Optional[queries.Hit]:
        """Some hit of the ray (the first the broad phase's walk meets, not necessarily the
        closest: "is anything in the way"), or None. Arguments as ``cast_ray``."""
        args = queries.ray_args("cast_ray_any", origin, direction, max_distance)
        return queries.hit(self._core.cast_ray_any(*args, **queries.filter_args("cast_ray_any", group, mask, exclude)))

    @_locked
    def cast_ray_all(self, origin, direction, max_distance=math.inf, *, group=ALL_BITS, mask=ALL_BITS,
                     exclude=()) -> list:
        """Every body the ray meets, one ``Hit`` each (where it enters it first), sorted by
        distance then body. Arguments as ``cast_ray``."""
        args = queries.ray_args("cast_ray_all", origin, direction, max_distance)
        hits = self._core.cast_ray_all(*args, **queries.filter_args("cast_ray_all", group, mask, exclude))
        return [queries.hit(h) for h in hits]

    @_locked
    def cast_rays(self, origins, directions, max_distance=math.inf, *, group=ALL_BITS, mask=ALL_BITS,
                  exclude=()) -> queries.RayHits:
        """n rays at once: origins, directions (n, 3), max_distance a number or (n,). Row k of the
        result (``RayHits``) is ``cast_ray`` of ray k bit for bit; the rays run on the world's
        threads with the GIL released, with the same bits for any thread count."""
        o, d, m = queries.rays_args(origins, directions, max_distance)
        return queries.ray_hits(self._core.cast_rays(o, d, m, **queries.filter_args("cast_rays", group, mask, exclude)))

    @_locked
    def cast_shape(self, shape, position=(0.0, 0.0, 0.0), orientation=(1.0, 0.0, 0.0, 0.0),
                   translation=(0.0, 0.0, 0.0), *, group=ALL_BITS, mask=ALL_BITS,
                   exclude=()) -> Optional[queries.ShapeHit]:
        """Sweeps a bounded ``shape`` from ``position`` (3,), unit quaternion ``orientation`` (w, x,
        y, z), along ``translation`` (3,) m: the first body it touches as a ``ShapeHit`` (its
        ``fraction`` of the translation, where and along which normal they touch), or None.
        Conservative advancement on exact distances (docs/conventions.md, "Shape casts and
        continuous collision"): the fraction is never past the touch and within 1e-12 of the
        sweep's size before it; a triangle mesh is hit from its front only; a shape that overlaps a
        body where it starts hits it at fraction 0. Bodies seen as for ``cast_ray``."""
        who = "cast_shape"
        return queries.shape_hit(self._core.cast_shape(
            shape, as_vector(position, 3, who, "position"), as_vector(orientation, 4, who, "orientation"),
            as_vector(translation, 3, who, "translation"), **queries.filter_args(who, group, mask, exclude)))

    @_locked
    def overlap(self, shape, position=(0.0, 0.0, 0.0), orientation=(1.0, 0.0, 0.0, 0.0), *, group=ALL_BITS,
                mask=ALL_BITS, exclude=()) -> np.ndarray:
        """Bodies (ascending int32) whose shape overlaps (signed distance < 0) a bounded ``shape``
        placed at ``position`` (3,) and unit quaternion ``orientation`` (w, x, y, z)."""
        who = "overlap"
        return queries.indices(self._core.overlap(shape, as_vector(position, 3, who, "position"),
                                                  as_vector(orientation, 4, who, "orientation"),
                                                  **queries.filter_args(who, group, mask, exclude)))

    @_locked
    def overlap_aabb(self, lo, hi, *, group=ALL_BITS, mask=ALL_BITS, exclude=()) -> np.ndarray:
        """Bodies (ascending int32) whose shape overlaps the world-axis box [lo, hi] (m, lo < hi)."""
        who = "overlap_aabb"
        return queries.indices(self._core.overlap_aabb(as_vector(lo, 3, who, "lo"), as_vector(hi, 3, who, "hi"),
                                                       **queries.filter_args(who, group, mask, exclude)))

    @_locked
    def overlap_point(self, point, *, group=ALL_BITS, mask=ALL_BITS, exclude=()) -> np.ndarray:
        """Bodies (ascending int32) whose closed solid contains ``point`` (3,) (planes: the half-space
        behind them; triangle meshes contain nothing)."""
        who = "overlap_point"
        return queries.indices(self._core.overlap_point(as_vector(point, 3, who, "point"),
                                                        **queries.filter_args(who, group, mask, exclude)))

    @_locked
    def distance(self, i: int, j: int) -> queries.BodyDistance:
        """Signed distance and closest points of bodies i and j (``BodyDistance``; normal i -> j)."""
        return queries.distance(self._core.distance(self._index(i), self._index(j)))

    @property
    @_locked
    def query_stats(self) -> dict:
        """Counts of the last query: ``queries`` asked, broad-phase tree ``nodes`` tested and exact
        ``body_tests`` (never timings)."""
        return self._core.query_stats

    @_locked
    def __repr__(self) -> str:
        return f"World({self.num_bodies} bodies, t={self.time:g} s)"


def mass_properties(shape, density: float):
    """(mass kg, com (3,) m in the shape's frame, inertia (3, 3) kg m^2 about the com) for a
    uniform density (kg/m^3). A mesh must be closed and outward-oriented."""
    return _core.mass_properties(shape, as_scalar(density, type(shape).__name__, "density"))
