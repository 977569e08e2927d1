"""The World facade: argument checking and NumPy-friendly results around ``signorini._core``.

No physics lives here: every number is computed by the C++ core. This layer turns Python
arguments into the exact shapes the core takes, with errors that name the body and the problem,
and wraps the core's arrays into small result objects.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from ._core import Box, Capsule, Compound, ConvexHull, Cylinder, Mesh, Plane, Sphere, TriangleMesh

Shape = (Sphere, Box, Plane, Mesh, Capsule, Cylinder, ConvexHull, TriangleMesh, Compound)


class BodyIndexError(IndexError, ValueError):
    """A body index that is not in the world (both an IndexError and a ValueError)."""


@dataclass(frozen=True)
class Contacts:
    """Contacts of the last step, one row per contact (K rows).

    body_a, body_b: (K,) int64 body indices; the normal points from A to B (a plane is always A).
    point: (K, 3) world contact points y_i (m), midway between the witness points on A and B.
    normal: (K, 3) world unit normals n_i.
    gap: (K,) signed distances along n_i (m), negative when overlapping.
    alpha: (K,) contact force magnitudes alpha_i (N), as in the lecture notes.
    impulse: (K,) impulses dt * alpha_i (N s) applied as +impulse n on B and -impulse n on A.
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
    feature_a: np.ndarray
    feature_b: np.ndarray

    def __len__(self) -> int:
        return len(self.gap)

    def as_dict(self) -> dict:
        """The arrays as a dict (the oracle's contact format)."""
        return {k: getattr(self, k) for k in ("body_a", "body_b", "point", "normal", "gap", "alpha", "impulse",
                                              "feature_a", "feature_b")}


@dataclass(frozen=True)
class SolverStats:
    """What the last step's PGS did: sweeps used, whether it met the tolerance, the Signorini
    residual max_i |min(delta_i alpha_i, w_i)| (m/s), and the number of contacts."""

    iterations: int
    residual: float
    converged: bool
    contacts: int


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def _vector(x, n: int, who: str, what: str) -> np.ndarray:
    """x as a float64 array of shape (n,), or a TypeError / ValueError naming who and what."""
    if isinstance(x, (str, bytes)):
        raise TypeError(f"{who}: {what} must be {n} numbers, got {x!r}")
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{who}: {what} must be {n} numbers, got {x!r}") from None
    if a.shape != (n,):
        raise ValueError(f"{who}: {what} must have shape ({n},), got shape {a.shape}")
    return a


def _scalar(x, who: str, what: str):
    if x is None:
        return None
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{who}: {what} must be a number, got {x!r}")
    return float(x)


def _solid(mesh) -> bool:
    """True when the mesh is a closed solid of positive volume (else add_body reports why)."""
    try:
        _core.mass_properties(mesh, 1.0)
    except ValueError:
        return False
    return True


class World:
    """A rigid-body world stepped by the lecture's PGS contact solver.

    Parameters
    ----------
    gravity : (3,) m/s^2, world frame.
    contact_margin : m. Pairs closer than this (plus each body's speculative reach for the step)
        get contacts; those with a positive gap only stop an approach that would close it.
    erp : Baumgarte factor in [0, 1]: the fraction of an overlap removed per step.
    tolerance : PGS stops when no contact's velocity changes by more than this (m/s) in a sweep.
    max_iterations : at most this many PGS sweeps per step.
    """

    def __init__(self, gravity=(0.0, 0.0, -9.81), contact_margin: float = 0.005, erp: float = 0.2,
                 tolerance: float = 1e-10, max_iterations: int = 100):
        g = _vector(gravity, 3, "World", "gravity")
        if isinstance(max_iterations, bool) or not isinstance(max_iterations, (int, np.integer)):
            raise TypeError(f"World: max_iterations must be an integer, got {max_iterations!r}")
        self._core = _core.World(g, _scalar(contact_margin, "World", "contact_margin"),
                                 _scalar(erp, "World", "erp"), _scalar(tolerance, "World", "tolerance"),
                                 int(max_iterations))

    # bodies -----------------------------------------------------------------------------------
    def add_body(self, shape, *, density=None, mass=None, position=(0.0, 0.0, 0.0),
                 orientation=(1.0, 0.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0),
                 angular_velocity=(0.0, 0.0, 0.0)) -> int:
        """Adds a dynamic body and returns its index.

        Exactly one of ``density`` (kg/m^3) or ``mass`` (kg). ``position`` (3,) is where the
        centre of mass goes (a mesh is re-centred on its centre of mass, axes unchanged);
        ``orientation`` is a quaternion (w, x, y, z), normalised if it is not unit length (a zero
        one is an error); velocities are world-frame (m/s, rad/s). On any bad argument raises
        ValueError or TypeError naming the body, and the world is unchanged.
        """
        return self._add(shape, False, density, mass, position, orientation, velocity, angular_velocity)

    def add_static(self, shape, *, position=(0.0, 0.0, 0.0), orientation=(1.0, 0.0, 0.0, 0.0)) -> int:
        """Adds a static body (inverse mass and inertia zero: it never moves) and returns its index."""
        return self._add(shape, True, None, None, position, orientation, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    def _add(self, shape, is_static, density, mass, position, orientation, velocity, angular_velocity) -> int:
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
            _vector(velocity, 3, who, "velocity"), _vector(angular_velocity, 3, who, "angular_velocity"))

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

    # stepping ---------------------------------------------------------------------------------
    def step(self, dt: float, steps: int = 1) -> None:
        """Advances ``steps`` steps of ``dt`` seconds (dt > 0 and finite)."""
        dt = _scalar(dt, "step", "dt")
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)):
            raise TypeError(f"step: steps must be an integer, got {steps!r}")
        if steps < 0:
            raise ValueError(f"step: steps must be >= 0, got {steps}")
        self._core.step(dt, int(steps))

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
        return Contacts(**self._core.detect_contacts(_scalar(dt, "detect_contacts", "dt")))

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
            })
        return {
            "gravity": np.array(c.gravity),
            "settings": {"contact_margin": c.contact_margin, "erp": c.erp, "tolerance": c.tolerance,
                         "max_iterations": c.max_iterations},
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
