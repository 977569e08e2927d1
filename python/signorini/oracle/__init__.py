"""signorini.oracle: a plain-NumPy reference for one step of the simulator.

Written straight from the CSC417 contact notes and docs/conventions.md, to check the C++
core number for number.  It imports nothing from the rest of ``signorini`` (in particular
never ``signorini._core``), so it also loads as a standalone package.

Modules, in the order of a step:
    mass      mass properties of spheres, boxes, capsules, cylinders, closed meshes, hulls, compounds
    rigid     skew, Rodrigues, quaternions, the Jacobian J(y), unconstrained velocity, integrate
    contacts  exact contacts (plane-sphere, plane-box, plane-mesh, sphere-sphere)
    pgs       projected Gauss-Seidel on the Signorini conditions, and its residual
    lcp       the same problem as an LCP, solved exactly by enumeration (small K)
    step      one step and a rollout
"""

from .contacts import (
    bounding_radius,
    box_corners,
    contact_box_sphere,
    contact_plane_points,
    contact_plane_sphere,
    contact_sphere_sphere,
    detect_contacts,
    plane_reach,
    speculative_reach,
)
from .lcp import (
    contact_jacobian,
    contact_lcp,
    inverse_mass_matrix,
    lcp_solve,
    velocities_from_alpha,
)
from .mass import (
    mass_properties,
    mass_properties_box,
    mass_properties_capsule,
    mass_properties_compound,
    mass_properties_cylinder,
    mass_properties_hull,
    mass_properties_mesh,
    mass_properties_sphere,
    mesh_volume_integrals,
    shape_volume,
)
from .pgs import bias, contact_rows, pgs
from .rigid import (
    integrate,
    inverse_mass_blocks,
    jacobian,
    matrix_to_quat,
    quat_to_matrix,
    rodrigues,
    skew,
    unconstrained_velocity,
    world_inertia,
)
from .step import copy_snapshot, rollout, step

__all__ = [
    "bias", "bounding_radius", "box_corners", "contact_box_sphere", "plane_reach", "contact_jacobian", "contact_lcp",
    "contact_plane_points", "contact_plane_sphere", "contact_rows", "contact_sphere_sphere",
    "copy_snapshot", "detect_contacts", "integrate", "inverse_mass_blocks",
    "inverse_mass_matrix", "jacobian", "lcp_solve", "mass_properties", "mass_properties_box",
    "mass_properties_capsule", "mass_properties_compound", "mass_properties_cylinder", "mass_properties_hull",
    "mass_properties_mesh", "mass_properties_sphere", "matrix_to_quat", "mesh_volume_integrals",
    "pgs", "quat_to_matrix", "rodrigues", "rollout", "shape_volume", "skew", "speculative_reach",
    "step", "unconstrained_velocity", "velocities_from_alpha", "world_inertia",
]
