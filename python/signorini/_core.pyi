"""
signorini C++ core (private; use the signorini package)
"""
from __future__ import annotations
import collections.abc
import numpy
import numpy.typing
import typing
__all__: list[str] = ['Box', 'Capsule', 'Compound', 'ConvexHull', 'Cylinder', 'FrictionCone', 'Gyroscopic', 'Mesh', 'Plane', 'SolverSettings', 'Sphere', 'TriangleMesh', 'World', 'collide', 'mass_properties']
class Sphere:
    """
    Ball of the given radius (m), centred at the body origin.
    """
    def __init__(self, radius: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    def __repr__(self) -> str:
        ...
    @property
    def radius(self) -> float:
        ...
class Box:
    """
    Box with half extents (a, b, c) (m) along the body axes.
    """
    def __init__(self, half_extents: typing.Any) -> None:
        ...
    def __repr__(self) -> str:
        ...
    @property
    def half_extents(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
        ...
class Plane:
    """
    Static plane n . x = offset (n normalised); bodies live on the side n . x > offset.
    """
    def __init__(self, normal: typing.Any, offset: typing.SupportsFloat | typing.SupportsIndex = 0.0) -> None:
        ...
    def __repr__(self) -> str:
        ...
    @property
    def normal(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
        ...
    @property
    def offset(self) -> float:
        ...
class Mesh:
    """
    Triangle mesh: vertices (n, 3) in m, faces (k, 3) vertex indices, counter-clockwise seen from outside. A dynamic mesh must be closed; its body frame is its centre of mass. A non-convex one collides through convex pieces (see with_pieces).
    """
    def __init__(self, vertices: typing.Any, faces: typing.Any) -> None:
        ...
    def __repr__(self) -> str:
        ...
    def closedness_problem(self) -> str:
        """
        Empty when closed and consistently oriented; otherwise what is wrong.
        """
    def is_convex(self) -> bool:
        ...
    def with_pieces(self, pieces: collections.abc.Iterable) -> Mesh:
        """
        A copy of this mesh whose convex pieces (for collisions) are the convex hulls of the given (n_i, 3) vertex arrays (m, mesh frame). Mass properties stay those of the mesh itself.
        """
    @property
    def faces(self) -> typing.Annotated[numpy.typing.NDArray[numpy.int64], "[m, 3]"]:
        ...
    @property
    def pieces(self) -> list:
        """
        The convex pieces' hull vertices, a list of read-only (n_i, 3) arrays (empty when none).
        """
    @property
    def vertices(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
class Capsule:
    """
    Points within `radius` (m) of the segment from (0, 0, -half_length) to (0, 0, +half_length) (m) on the body z axis; half_length 0 is a sphere.
    """
    def __init__(self, radius: typing.SupportsFloat | typing.SupportsIndex, half_length: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    def __repr__(self) -> str:
        ...
    @property
    def half_length(self) -> float:
        ...
    @property
    def radius(self) -> float:
        ...
class Cylinder:
    """
    Solid cylinder of `radius` (m) around the body z axis, from z = -half_height to +half_height (m).
    """
    def __init__(self, radius: typing.SupportsFloat | typing.SupportsIndex, half_height: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    def __repr__(self) -> str:
        ...
    @property
    def half_height(self) -> float:
        ...
    @property
    def radius(self) -> float:
        ...
class ConvexHull:
    """
    Convex hull (Qhull) of (n, 3) points (m, body frame), n >= 4, not all coplanar. vertices: the hull's points in input order; faces: (k, 3) outward triangles.
    """
    def __init__(self, points: typing.Any) -> None:
        ...
    def __repr__(self) -> str:
        ...
    @property
    def faces(self) -> typing.Annotated[numpy.typing.NDArray[numpy.int64], "[m, 3]"]:
        ...
    @property
    def vertices(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
class TriangleMesh:
    """
    Static triangle mesh of any shape (terrain, bowls, ramps): vertices (n, 3) in m, faces (k, 3) counter-clockwise seen from the side bodies touch. Static bodies only.
    """
    def __init__(self, vertices: typing.Any, faces: typing.Any) -> None:
        ...
    def __repr__(self) -> str:
        ...
    @property
    def active_edge(self) -> numpy.typing.NDArray[numpy.bool]:
        """
        (k, 3) bool: side c of face k (v_c -> v_c+1) can make edge contacts (boundary, non-manifold, or convex by more than 1e-6 rad).
        """
    @property
    def faces(self) -> typing.Annotated[numpy.typing.NDArray[numpy.int64], "[m, 3]"]:
        ...
    @property
    def normals(self) -> numpy.typing.NDArray[numpy.float64]:
        """
        (k, 3) unit face normals.
        """
    @property
    def vertices(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[m, 3]"]:
        ...
class Compound:
    """
    Convex parts on one body: a list of (shape, (position, orientation)), shape a Sphere, Box, Capsule, Cylinder, ConvexHull or convex Mesh (which becomes the ConvexHull of its vertices), position (3,) m and orientation (w, x, y, z) (normalised) in the compound frame. A dynamic compound is re-centred on its centre of mass.
    """
    def __init__(self, parts: collections.abc.Iterable) -> None:
        ...
    def __repr__(self) -> str:
        ...
    @property
    def parts(self) -> list:
        """
        [(shape, (position (3,), orientation (w, x, y, z) with w >= 0))], in the compound frame.
        """
    @property
    def rotations(self) -> numpy.typing.NDArray[numpy.float64]:
        """
        (parts, 3, 3) compound-from-part rotation matrices, as the core stores them.
        """
class FrictionCone:
    """
    Members:
    
      pyramid
    
      cone
    """
    __members__: typing.ClassVar[dict[str, FrictionCone]]
    cone: typing.ClassVar[FrictionCone]
    pyramid: typing.ClassVar[FrictionCone]
    @typing.overload
    def __eq__(self, other: FrictionCone) -> bool:
        ...
    @typing.overload
    def __eq__(self, other: typing.Any) -> bool:
        ...
    def __getstate__(self) -> int:
        ...
    def __hash__(self) -> int:
        ...
    def __index__(self) -> int:
        ...
    def __init__(self, value: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    def __int__(self) -> int:
        ...
    @typing.overload
    def __ne__(self, other: FrictionCone) -> bool:
        ...
    @typing.overload
    def __ne__(self, other: typing.Any) -> bool:
        ...
    def __repr__(self) -> str:
        ...
    def __setstate__(self, state: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    def __str__(self) -> str:
        ...
    @property
    def name(self) -> str:
        ...
    @property
    def value(self) -> int:
        ...
class Gyroscopic:
    """
    Members:
    
      midpoint
    
      implicit
    
      explicit
    """
    __members__: typing.ClassVar[dict[str, Gyroscopic]]
    explicit: typing.ClassVar[Gyroscopic]
    implicit: typing.ClassVar[Gyroscopic]
    midpoint: typing.ClassVar[Gyroscopic]
    @typing.overload
    def __eq__(self, other: Gyroscopic) -> bool:
        ...
    @typing.overload
    def __eq__(self, other: typing.Any) -> bool:
        ...
    def __getstate__(self) -> int:
        ...
    def __hash__(self) -> int:
        ...
    def __index__(self) -> int:
        ...
    def __init__(self, value: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    def __int__(self) -> int:
        ...
    @typing.overload
    def __ne__(self, other: Gyroscopic) -> bool:
        ...
    @typing.overload
    def __ne__(self, other: typing.Any) -> bool:
        ...
    def __repr__(self) -> str:
        ...
    def __setstate__(self, state: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    def __str__(self) -> str:
        ...
    @property
    def name(self) -> str:
        ...
    @property
    def value(self) -> int:
        ...
class SolverSettings:
    friction_cone: FrictionCone
    gyroscopic: Gyroscopic
    warm_start: bool
    def __init__(self) -> None:
        ...
    @property
    def erp(self) -> float:
        ...
    @erp.setter
    def erp(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def max_iterations(self) -> int:
        ...
    @max_iterations.setter
    def max_iterations(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def max_push_velocity(self) -> float:
        ...
    @max_push_velocity.setter
    def max_push_velocity(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def restitution_threshold(self) -> float:
        ...
    @restitution_threshold.setter
    def restitution_threshold(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def slop(self) -> float:
        ...
    @slop.setter
    def slop(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def substeps(self) -> int:
        ...
    @substeps.setter
    def substeps(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def tolerance(self) -> float:
        ...
    @tolerance.setter
    def tolerance(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def warn_velocity(self) -> float:
        ...
    @warn_velocity.setter
    def warn_velocity(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class World:
    def __init__(self, gravity: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], contact_margin: typing.SupportsFloat | typing.SupportsIndex, solver: SolverSettings) -> None:
        ...
    def add_body(self, shape: typing.Any, is_static: bool, density: typing.SupportsFloat | typing.SupportsIndex | None, mass: typing.SupportsFloat | typing.SupportsIndex | None, position: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], orientation: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[4, 1]"], velocity: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], angular_velocity: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], friction: typing.SupportsFloat | typing.SupportsIndex, restitution: typing.SupportsFloat | typing.SupportsIndex) -> int:
        ...
    def detect_contacts(self, dt: typing.SupportsFloat | typing.SupportsIndex) -> dict:
        ...
    def kinetic_energy(self) -> float:
        ...
    def potential_energy(self) -> float:
        ...
    def set_angular_velocity(self, arg0: typing.SupportsInt | typing.SupportsIndex, arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"]) -> None:
        ...
    def set_external_wrench(self, arg0: typing.SupportsInt | typing.SupportsIndex, arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], arg2: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"]) -> None:
        ...
    def set_material(self, arg0: typing.SupportsInt | typing.SupportsIndex, arg1: typing.SupportsFloat | typing.SupportsIndex, arg2: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    def set_orientation(self, arg0: typing.SupportsInt | typing.SupportsIndex, arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[4, 1]"]) -> None:
        ...
    def set_position(self, arg0: typing.SupportsInt | typing.SupportsIndex, arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"]) -> None:
        ...
    def set_solver(self, arg0: SolverSettings) -> None:
        ...
    def set_velocity(self, arg0: typing.SupportsInt | typing.SupportsIndex, arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"]) -> None:
        ...
    def shape(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> typing.Any:
        ...
    def step(self, dt: typing.SupportsFloat | typing.SupportsIndex, steps: typing.SupportsInt | typing.SupportsIndex = 1) -> None:
        ...
    @property
    def angular_velocities(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def contact_forces(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def contact_margin(self) -> float:
        ...
    @property
    def contact_torques(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def contacts(self) -> dict:
        ...
    @property
    def forces(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def frictions(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def gravity(self) -> typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"]:
        ...
    @property
    def inertias(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def inv_inertias(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def inv_masses(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def is_static(self) -> numpy.typing.NDArray[numpy.bool]:
        ...
    @property
    def masses(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def num_bodies(self) -> int:
        ...
    @property
    def orientations(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def positions(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def restitutions(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def rotations(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def solver(self) -> SolverSettings:
        ...
    @property
    def solver_stats(self) -> dict:
        ...
    @property
    def step_report(self) -> dict:
        ...
    @property
    def time(self) -> float:
        ...
    @property
    def torques(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def velocities(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
    @property
    def warm_start_cache(self) -> dict:
        ...
def collide(shape_a: typing.Any, position_a: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], orientation_a: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[4, 1]"], shape_b: typing.Any, position_b: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[3, 1]"], orientation_b: typing.Annotated[numpy.typing.ArrayLike, numpy.float64, "[4, 1]"], margin: typing.SupportsFloat | typing.SupportsIndex = 0.0) -> dict:
    """
    Contact arrays (as World.contacts) of shape_a and shape_b at the given poses; normals from A to B.
    """
def mass_properties(shape: typing.Any, density: typing.SupportsFloat | typing.SupportsIndex) -> tuple[float, typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 1]"], typing.Annotated[numpy.typing.NDArray[numpy.float64], "[3, 3]"]]:
    """
    (mass kg, com (3,) m in the shape frame, inertia (3, 3) kg m^2 about the com) for a uniform density.
    """
