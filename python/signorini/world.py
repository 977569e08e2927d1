"""The World facade: argument checking and NumPy-friendly results around ``signorini._core``.

No physics lives here: every number is computed by the C++ core. This layer turns Python
arguments into the exact shapes the core takes, with errors that name the body and the problem,
and wraps the core's arrays into small result objects.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from . import _core
from ._core import Box, Capsule, Compound, ConvexHull, Cylinder, Mesh, Plane, Sphere, TriangleMesh

Shape = (Sphere, Box, Plane, Mesh, Capsule, Cylinder, ConvexHull, TriangleMesh, Compound)


class BodyIndexError(IndexError, ValueError):
    """A body index that is not in the world (both an IndexError and a ValueError)."""


class SolverWarning(RuntimeWarning):
    """A step ended with the contact solver unconverged and a contact still approaching faster
    than ``warn_velocity`` allows (see ``World.solver_stats``)."""


@dataclass(frozen=True)
class Contacts:
    """Contacts of the last step, one row per contact (K rows).

    body_a, body_b: (K,) int64 body indices; the normal points from A to B (a plane is always A).
    point: (K, 3) world contact points y_i (m), midway between the witness points on A and B.
    normal: (K, 3) world unit normals n_i.
    gap: (K,) signed distances along n_i (m), negative when overlapping.
    alpha: (K,) normal forces alpha_i >= 0 (N), as in the lecture notes.
    impulse: (K,) impulses dt * alpha_i (N s) applied as +impulse n on B and -impulse n on A.
    friction: (K, 3) friction forces on B (N, world, tangent to n); A gets the opposite.
    force: (K, 3) total contact forces on B, alpha n + friction (N, world).
    normal_velocity: (K,) n . (v_B(y) - v_A(y)) after the solve (m/s; > 0 separating).
    slip: (K, 3) tangential velocity of B's point against A's after the solve (m/s, world).
    feature_a, feature_b: (K,) uint64 feature ids of the point on A and on B, the same from one
        step to the next for the same contact: part * 2**32 + kind * 2**28 + index, kind 0 whole
        shape, 1 vertex, 2 edge, 3 face (see ``signorini.feature``).
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
    normal_velocity: np.ndarray
    slip: np.ndarray
    feature_a: np.ndarray
    feature_b: np.ndarray

    def __len__(self) -> int:
        return len(self.gap)

    def as_dict(self) -> dict:
        """The arrays as a dict (the oracle's contact format)."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class SolverStats:
    """What the last step's contact solver did, and its Signorini certificate
    (docs/conventions.md, "The Signorini certificate"; w_i = normal velocity + the row's target).

    iterations, restitution_iterations, position_iterations: sweeps of each stage.
    converged: the iterate stage met ``tolerance``. contacts: number of contacts.
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
    residual: float
    max_alpha_negative: float
    max_penetration_velocity: float
    max_complementarity: float
    max_cone_violation: float
    max_dissipation_violation: float
    max_overlap: float


SOLVER_DEFAULTS = {
    "erp": 0.2, "tolerance": 1e-6, "max_iterations": 30, "slop": 0.001, "max_push_velocity": 1.0,
    "restitution_threshold": 0.5, "friction_cone": "pyramid", "gyroscopic": "midpoint",
    "warm_start": True, "substeps": 0, "warn_velocity": 0.01,
}


def _solver_settings(who: str, current=None, **given):
    """A _core.SolverSettings from keyword values (None = keep current or the default), checked
    for type here and for range by the core."""
    s = _core.SolverSettings()
    for key, default in SOLVER_DEFAULTS.items():
        value = given.get(key)
        if value is None:
            value = getattr(current, key) if current is not None else default
            if key in ("friction_cone", "gyroscopic") and not isinstance(value, str):
                value = value.name
        if key in ("max_iterations", "substeps"):
            value = _count(value, who, key)
        elif key == "warm_start":
            if not isinstance(value, (bool, np.bool_)):
                raise TypeError(f"{who}: warm_start must be True or False, got {value!r}")
            value = bool(value)
        elif key == "friction_cone":
            if value not in ("pyramid", "cone"):
                raise ValueError(f"{who}: friction_cone must be 'pyramid' or 'cone', got {value!r}")
            value = getattr(_core.FrictionCone, value)
        elif key == "gyroscopic":
            if value not in ("midpoint", "implicit", "explicit"):
                raise ValueError(f"{who}: gyroscopic must be 'midpoint', 'implicit' or 'explicit', got {value!r}")
            value = getattr(_core.Gyroscopic, value)
        else:
            value = _scalar(value, who, key)
        setattr(s, key, value)
    return s


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def _vector(x, n: int, who: str, what: str) -> np.ndarray:
    """x as a float64 array of shape (n,), or a TypeError / ValueError naming who and what."""
    if isinstance(x, (str, bytes)):
        raise TypeError(f"{who}: {what} must be {n} numbers, got {x!r}")
    try:
        a = np.asarray(x, dtype=np.float64)
    except OverflowError:
        raise ValueError(f"{who}: {what} has a number too large for a double (at most about 1.8e308)") from None
    except (TypeError, ValueError):
        raise TypeError(f"{who}: {what} must be {n} numbers, got {x!r}") from None
    if a.shape != (n,):
        raise ValueError(f"{who}: {what} must have shape ({n},), got shape {a.shape}")
    return a


def _scalar(x, who: str, what: str):
    """x as a float (None stays None), or a TypeError / ValueError naming who and what."""
    if x is None:
        return None
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{who}: {what} must be a number, got {x!r}")
    try:
        return float(x)
    except OverflowError:
        raise ValueError(f"{who}: {what} is too large for a double: an integer of {len(str(abs(int(x))))} digits "
                         "(at most about 1.8e308)") from None


def _required(x, who: str, what: str) -> float:
    """Like _scalar, but None is a TypeError too."""
    if x is None:
        raise TypeError(f"{who}: {what} must be a number, got None")
    return _scalar(x, who, what)


INT_MAX = 2**31 - 1  # the core's counts are C ints


def _count(x, who: str, what: str) -> int:
    """x as an int the core can hold, or a TypeError / ValueError naming who and what."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)):
        raise TypeError(f"{who}: {what} must be an integer, got {x!r}")
    if not -INT_MAX - 1 <= x <= INT_MAX:
        raise ValueError(f"{who}: {what} = {x} is too large: at most {INT_MAX}")
    return int(x)


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
    tolerance : a solver stage stops when no row's velocity changes by more than this (m/s).
    max_iterations : at most this many sweeps per solver stage and substep.
    slop : overlap (m) the position pass leaves alone, so resting contacts are never stirred.
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
        (m/s) raises a ``SolverWarning`` (once per ``step()`` call).

    The defaults (``SOLVER_DEFAULTS``) stand a 10-box stack and a 210-box pyramid.
    """

    def __init__(self, gravity=(0.0, 0.0, -9.81), contact_margin: float = 0.005, erp: float = 0.2,
                 tolerance: float = 1e-6, max_iterations: int = 30, *, slop: float = 0.001,
                 max_push_velocity: float = 1.0,
                 restitution_threshold: float = 0.5, friction_cone: str = "pyramid",
                 gyroscopic: str = "midpoint", warm_start: bool = True, substeps: int = 0,
                 warn_velocity: float = 0.01):
        g = _vector(gravity, 3, "World", "gravity")
        solver = _solver_settings(
            "World", erp=erp, tolerance=tolerance, max_iterations=max_iterations, slop=slop,
            max_push_velocity=max_push_velocity, restitution_threshold=restitution_threshold,
            friction_cone=friction_cone, gyroscopic=gyroscopic, warm_start=warm_start, substeps=substeps,
            warn_velocity=warn_velocity)
        self._core = _core.World(g, _scalar(contact_margin, "World", "contact_margin"), solver)

    def set_solver(self, **settings) -> None:
        """Changes solver settings by keyword (the names of the constructor's); the others stay."""
        unknown = set(settings) - set(SOLVER_DEFAULTS)
        if unknown:
            raise TypeError(f"set_solver: unknown setting(s) {sorted(unknown)}; known: {sorted(SOLVER_DEFAULTS)}")
        self._core.set_solver(_solver_settings("set_solver", self._core.solver, **settings))

    @property
    def solver(self) -> dict:
        """The solver settings as a dict (the constructor's keywords)."""
        s = self._core.solver
        return {k: (getattr(s, k).name if k in ("friction_cone", "gyroscopic") else getattr(s, k))
                for k in SOLVER_DEFAULTS}

    # bodies -----------------------------------------------------------------------------------
    def add_body(self, shape, *, density=None, mass=None, position=(0.0, 0.0, 0.0),
                 orientation=(1.0, 0.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0),
                 angular_velocity=(0.0, 0.0, 0.0), friction: float = 0.5, restitution: float = 0.0) -> int:
        """Adds a dynamic body and returns its index.

        Exactly one of ``density`` (kg/m^3) or ``mass`` (kg). ``position`` (3,) is where the
        centre of mass goes (a mesh is re-centred on its centre of mass, axes unchanged);
        ``orientation`` is a quaternion (w, x, y, z), normalised if it is not unit length (a zero
        one is an error); velocities are world-frame (m/s, rad/s). ``friction`` mu >= 0 and
        ``restitution`` e in [0, 1] are the body's material; a contact uses sqrt(mu_A mu_B) and
        max(e_A, e_B). On any bad argument raises ValueError or TypeError naming the body, and the
        world is unchanged.
        """
        return self._add(shape, False, density, mass, position, orientation, velocity, angular_velocity,
                         friction, restitution)

    def add_static(self, shape, *, position=(0.0, 0.0, 0.0), orientation=(1.0, 0.0, 0.0, 0.0),
                   friction: float = 0.5, restitution: float = 0.0) -> int:
        """Adds a static body (inverse mass and inertia zero: it never moves) and returns its index.
        ``friction`` and ``restitution`` as for ``add_body``."""
        return self._add(shape, True, None, None, position, orientation, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                         friction, restitution)

    def _add(self, shape, is_static, density, mass, position, orientation, velocity, angular_velocity,
             friction, restitution) -> int:
        who = f"body {self.num_bodies} ({type(shape).__name__})"
        if not isinstance(shape, Shape):
            raise TypeError(f"{who}: shape must be a Sphere, Box, Plane, Mesh, Capsule, Cylinder, ConvexHull, "
                            f"TriangleMesh or Compound, got {type(shape).__name__}")
        if (not is_static and isinstance(shape, Mesh) and not shape.pieces and not shape.is_convex()
                and _solid(shape)):
            # a dynamic non-convex mesh collides with other bodies through convex pieces
            from .decompose import decompose
            try:
                shape = decompose(shape)
            except ValueError as e:
                raise ValueError(f"{who}: {e}") from None
        return self._core.add_body(
            shape, is_static, _scalar(density, who, "density"), _scalar(mass, who, "mass"),
            _vector(position, 3, who, "position"), _vector(orientation, 4, who, "orientation"),
            _vector(velocity, 3, who, "velocity"), _vector(angular_velocity, 3, who, "angular_velocity"),
            _scalar(friction, who, "friction"), _scalar(restitution, who, "restitution"))

    def _index(self, i) -> int:
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)):
            raise TypeError(f"body index must be an integer, got {i!r}")
        if not 0 <= i < self.num_bodies:
            raise BodyIndexError(f"body index {i} is out of range: the world has {self.num_bodies} bodies")
        return int(i)

    def _label(self, i: int) -> str:
        return f"body {i} ({type(self._core.shape(i)).__name__})"

    def shape(self, i: int):
        """The shape of body i (a mesh body's vertices are centred on its centre of mass)."""
        return self._core.shape(self._index(i))

    def set_position(self, i: int, position) -> None:
        i = self._index(i)
        self._core.set_position(i, _vector(position, 3, self._label(i), "position"))

    def set_orientation(self, i: int, orientation) -> None:
        i = self._index(i)
        self._core.set_orientation(i, _vector(orientation, 4, self._label(i), "orientation"))

    def set_velocity(self, i: int, velocity) -> None:
        i = self._index(i)
        self._core.set_velocity(i, _vector(velocity, 3, self._label(i), "velocity"))

    def set_angular_velocity(self, i: int, angular_velocity) -> None:
        i = self._index(i)
        self._core.set_angular_velocity(i, _vector(angular_velocity, 3, self._label(i), "angular_velocity"))

    def set_external_wrench(self, i: int, force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0)) -> None:
        """Sets a world-frame force (N, at the centre of mass) and torque (N m) applied every step."""
        i = self._index(i)
        self._core.set_external_wrench(i, _vector(force, 3, self._label(i), "force"),
                                       _vector(torque, 3, self._label(i), "torque"))

    def set_material(self, i: int, friction=None, restitution=None) -> None:
        """Sets body i's friction (mu >= 0) and/or restitution (e in [0, 1]); None keeps it."""
        i = self._index(i)
        who = self._label(i)
        mu = _scalar(friction, who, "friction")
        e = _scalar(restitution, who, "restitution")
        self._core.set_material(i, float(self._core.frictions[i]) if mu is None else mu,
                                float(self._core.restitutions[i]) if e is None else e)

    # stepping ---------------------------------------------------------------------------------
    def step(self, dt: float, steps: int = 1) -> None:
        """Advances ``steps`` steps of ``dt`` seconds (dt > 0 and finite)."""
        dt = _required(dt, "step", "dt")
        if isinstance(steps, (int, np.integer)) and not isinstance(steps, (bool, np.bool_)) and steps > INT_MAX:
            raise ValueError(f"step: steps = {steps} is too large: at most {INT_MAX} per call (call step again)")
        steps = _count(steps, "step", "steps")
        if steps < 0:
            raise ValueError(f"step: steps must be >= 0, got {steps}")
        self._core.step(dt, int(steps))
        report = self._core.step_report
        if report["flagged"]:
            warnings.warn(
                f"{report['flagged']} of {report['steps']} steps ended with the contact solver unconverged "
                f"and a contact approaching faster than warn_velocity = {self._core.solver.warn_velocity:g} m/s "
                f"(worst {report['worst_penetration_velocity']:.3g} m/s at t = {report['worst_time']:.6g} s); "
                "raise max_iterations or substeps, or lower dt", SolverWarning, stacklevel=2)

    # state: read-only copies, (N, 3) / (N, 4) ---------------------------------------------------
    @property
    def num_bodies(self) -> int:
        return self._core.num_bodies

    @property
    def time(self) -> float:
        """Simulated time (s)."""
        return self._core.time

    @property
    def positions(self) -> np.ndarray:
        """(N, 3) centre-of-mass positions, world (m)."""
        return _readonly(self._core.positions)

    @property
    def orientations(self) -> np.ndarray:
        """(N, 4) unit quaternions (w, x, y, z) with w >= 0, world-from-body."""
        return _readonly(self._core.orientations)

    @property
    def rotations(self) -> np.ndarray:
        """(N, 3, 3) rotation matrices R, world-from-body."""
        return _readonly(self._core.rotations)

    @property
    def velocities(self) -> np.ndarray:
        """(N, 3) linear velocities of the centres of mass, world (m/s)."""
        return _readonly(self._core.velocities)

    @property
    def angular_velocities(self) -> np.ndarray:
        """(N, 3) angular velocities, world (rad/s)."""
        return _readonly(self._core.angular_velocities)

    @property
    def masses(self) -> np.ndarray:
        """(N,) masses (kg); infinity for static bodies."""
        return _readonly(self._core.masses)

    @property
    def inertias(self) -> np.ndarray:
        """(N, 3, 3) inertia tensors about the centre of mass, body axes (kg m^2); zero for static."""
        return _readonly(self._core.inertias)

    @property
    def frictions(self) -> np.ndarray:
        """(N,) friction coefficients mu."""
        return _readonly(self._core.frictions)

    @property
    def restitutions(self) -> np.ndarray:
        """(N,) restitution coefficients e."""
        return _readonly(self._core.restitutions)

    @property
    def contact_forces(self) -> np.ndarray:
        """(N, 3) summed contact force on each body in the last step (N, world), static ones too."""
        return _readonly(self._core.contact_forces)

    @property
    def contact_torques(self) -> np.ndarray:
        """(N, 3) summed contact torque about each body's com in the last step (N m, world)."""
        return _readonly(self._core.contact_torques)

    @property
    def warm_start_cache(self) -> dict:
        """The forces the next step starts from: body_a, body_b (K,), feature_a, feature_b (K,)
        uint64, alpha (K,) N, friction (K, 3) N world, sorted by key."""
        return {k: _readonly(v) for k, v in self._core.warm_start_cache.items()}

    @property
    def is_static(self) -> np.ndarray:
        """(N,) bool."""
        return _readonly(self._core.is_static)

    @property
    def gravity(self) -> np.ndarray:
        return _readonly(np.array(self._core.gravity))

    @property
    def contacts(self) -> Contacts:
        """Contacts of the last step (found at its start) with their solved forces and impulses."""
        return Contacts(**{k: _readonly(v) for k, v in self._core.contacts.items()})

    @property
    def solver_stats(self) -> SolverStats:
        return SolverStats(**self._core.solver_stats)

    def detect_contacts(self, dt: float) -> Contacts:
        """Contacts the current state would give for a step of dt, without stepping (alpha = 0)."""
        return Contacts(**self._core.detect_contacts(_required(dt, "detect_contacts", "dt")))

    def kinetic_energy(self) -> float:
        """1/2 sum (m |v|^2 + omega . I_w omega) (J)."""
        return self._core.kinetic_energy()

    def potential_energy(self) -> float:
        """-sum m g . p over dynamic bodies (J), relative to the origin."""
        return self._core.potential_energy()

    # the oracle's view --------------------------------------------------------------------------
    def snapshot(self) -> dict:
        """The whole world as plain NumPy data, the input format of ``signorini.oracle``."""
        c = self._core
        inv_inertias = c.inv_inertias
        bodies = []
        for i in range(c.num_bodies):
            bodies.append({
                "shape": shape_dict(c.shape(i)),
                "static": bool(c.is_static[i]),
                "mass": float(c.masses[i]),
                "inv_mass": float(c.inv_masses[i]),
                "inertia": c.inertias[i],
                "inv_inertia": inv_inertias[i],
                "friction": float(c.frictions[i]),
                "restitution": float(c.restitutions[i]),
            })
        return {
            "gravity": np.array(c.gravity),
            "settings": {"contact_margin": c.contact_margin, **self.solver},
            "cache": self.warm_start_cache,
            "bodies": bodies,
            "position": c.positions, "rotation": c.rotations, "velocity": c.velocities,
            "angular_velocity": c.angular_velocities, "force": c.forces, "torque": c.torques,
        }

    def __repr__(self) -> str:
        return f"World({self.num_bodies} bodies, t={self.time:g} s)"


def shape_dict(shape) -> dict:
    """A shape as the oracle's plain dict ({"type": "sphere", "radius": r}, ...)."""
    if isinstance(shape, Sphere):
        return {"type": "sphere", "radius": shape.radius}
    if isinstance(shape, Box):
        return {"type": "box", "half_extents": np.array(shape.half_extents)}
    if isinstance(shape, Plane):
        return {"type": "plane", "normal": np.array(shape.normal), "offset": shape.offset}
    if isinstance(shape, Mesh):
        d = {"type": "mesh", "vertices": np.array(shape.vertices), "faces": np.array(shape.faces)}
        if shape.pieces:
            d["pieces"] = [np.array(p) for p in shape.pieces]  # convex pieces' hull vertices (n_i, 3)
        return d
    if isinstance(shape, Capsule):
        return {"type": "capsule", "radius": shape.radius, "half_length": shape.half_length}
    if isinstance(shape, Cylinder):
        return {"type": "cylinder", "radius": shape.radius, "half_height": shape.half_height}
    if isinstance(shape, ConvexHull):
        return {"type": "hull", "vertices": np.array(shape.vertices), "faces": np.array(shape.faces)}
    if isinstance(shape, TriangleMesh):
        return {"type": "trimesh", "vertices": np.array(shape.vertices), "faces": np.array(shape.faces)}
    if isinstance(shape, Compound):
        # (part dict, position (3,), compound-from-part rotation (3, 3)) exactly as the core holds them
        return {"type": "compound", "parts": [(shape_dict(s), np.array(pos), R.copy())
                                              for (s, (pos, _)), R in zip(shape.parts, shape.rotations)]}
    raise TypeError(f"not a signorini shape: {shape!r}")


def mass_properties(shape, density: float):
    """(mass kg, com (3,) m in the shape's frame, inertia (3, 3) kg m^2 about the com) for a
    uniform density (kg/m^3). A mesh must be closed and outward-oriented."""
    return _core.mass_properties(shape, _scalar(density, type(shape).__name__, "density"))
