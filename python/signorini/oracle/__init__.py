"""signorini.oracle: a plain-NumPy reference for one step of the simulator.

Written straight from the CSC417 contact notes and docs/conventions.md, to check the C++
core number for number.  It imports nothing from the rest of ``signorini`` (in particular
never ``signorini._core``), so it also loads as a standalone package.

Modules, in the order of a step:
    mass      mass properties of spheres, boxes, capsules, cylinders, closed meshes, hulls, compounds
    rigid     skew, Rodrigues, quaternions, the Jacobian J(y), the unconstrained velocity with
              the gyroscopic options (midpoint, implicit, explicit), integrate
    contacts  exact contacts per shape pair (dispatch table ``PAIRS``), with feature ids
    manifold  feature ids, the box polytope, box-box SAT + face clipping, the 4-point reduction
    support   support mappings and the brute-force signed separation of two convex shapes
    solver    the staged contact solve of a step: prepare rows, warm start, iterate (PGS with
              Coulomb friction, pyramid or cone, and torsional friction at single-point contacts),
              restitution, position pass (split impulse), store, and the Signorini certificate;
              materials and the warm-start cache
    soft      the soft step (settings["solver"] = "soft"): Catto's soft-constraint substepping on
              the same rows: softness, the gap carried with the bodies, biased and relax sweeps
              (each followed by the joints': springs, then rigid), restitution and store at the end
    pgs       the lecture's frictionless projected Gauss-Seidel (cold start, erp bias)
    lcp       the frictionless problem as an LCP, solved exactly by enumeration (small K)
    rays      ray casts by brute force (containment tests, sampling and bisection; triangles by
              edge functions), to check the World's queries
    step      one step (contacts, then substeps of velocity, solve, integrate on the contacts
              carried along: carry_contacts, a fast-turning pair's found again: redetect_turned,
              in substeps short enough for its turn: turn_substeps; or the soft step) and a rollout

A snapshot (``World.snapshot()``, or built by hand) holds gravity, settings (defaults in
``solver.DEFAULT_SETTINGS`` for missing keys), bodies (shape, static, mass, inv_mass, inertia,
inv_inertia, friction, restitution; optional spinning_friction, kinematic, enabled, group,
mask), the state arrays, the optional warm-start cache, the optional excluded_pairs [(i, j)]
and the optional one-step step_force, step_torque and pending impulse, angular_impulse arrays
(N, 3).
"""

from .contacts import (
    PAIRS,
    bounding_radius,
    box_corners,
    contact_box_sphere,
    contact_plane_capsule,
    contact_plane_cylinder,
    contact_plane_points,
    contact_plane_sphere,
    contact_sphere_capsule,
    contact_sphere_sphere,
    detect_contacts,
    pair_filter,
    plane_reach,
    reachable,
    speculative_reach,
)
from .lcp import (
    contact_jacobian,
    contact_lcp,
    inverse_mass_matrix,
    lcp_solve,
    velocities_from_alpha,
)
from .manifold import (
    EDGE,
    FACE,
    FACE_PREFERENCE,
    SHAPE,
    VERTEX,
    box_box_separation,
    box_edge,
    box_polytope,
    clip_incident_face,
    closest_features,
    contact_box_box,
    feature_id,
    feature_parts,
    polytope_to_world,
    reduce_manifold,
    select_manifold,
    signed_area,
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
    apply_impulses,
    free_rotation,
    motion_flags,
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
from .solver import (
    DEFAULT_SETTINGS,
    alone_in_pair,
    apply_forces,
    certificate,
    contact_materials,
    contact_slops,
    empty_cache,
    friction_rows,
    iterate,
    position_pass,
    position_targets,
    prepare_rows,
    project_friction,
    read_cache,
    recall_forces,
    restitution,
    restitutive_contacts,
    solve_contacts,
    solver_settings,
    sort_cache,
    speculative_bias,
    spinning_friction,
    store,
    tangent_basis,
    warm_start,
)
from .soft import carried_gaps, contact_softness, core_offsets, gap_rounding, rounding_radius, soft_step, soft_sweep, softness
from .step import (carry_contacts, copy_snapshot, redetect_turned, rollout, soft_runs, step, step_once, turn_budget,
                   turn_substeps)
from .support import (
    fibonacci_sphere,
    support_box,
    support_capsule,
    support_cylinder,
    support_hull,
    support_of,
    support_separation,
    support_sphere,
)

__all__ = [
    "DEFAULT_SETTINGS", "alone_in_pair", "apply_impulses", "EDGE", "FACE", "FACE_PREFERENCE", "PAIRS", "SHAPE", "VERTEX", "bias",
    "bounding_radius", "box_box_separation", "box_corners", "box_edge", "box_polytope",
    "certificate", "motion_flags", "pair_filter", "clip_incident_face", "closest_features", "contact_box_box", "contact_box_sphere",
    "contact_jacobian", "contact_lcp", "contact_materials", "contact_plane_capsule",
    "contact_plane_cylinder", "contact_plane_points", "contact_plane_sphere", "contact_rows",
    "contact_sphere_capsule", "contact_sphere_sphere", "copy_snapshot", "detect_contacts",
    "empty_cache", "feature_id", "feature_parts", "fibonacci_sphere", "free_rotation", "integrate",
    "inverse_mass_blocks", "inverse_mass_matrix", "iterate", "jacobian", "lcp_solve",
    "mass_properties", "mass_properties_box", "mass_properties_capsule", "mass_properties_compound",
    "mass_properties_cylinder", "mass_properties_hull", "mass_properties_mesh",
    "mass_properties_sphere", "matrix_to_quat", "mesh_volume_integrals", "pgs", "plane_reach",
    "polytope_to_world", "position_pass", "position_targets", "contact_slops", "prepare_rows", "project_friction",
    "quat_to_matrix", "reachable", "read_cache", "reduce_manifold", "restitution", "restitutive_contacts",
    "rodrigues", "rollout", "select_manifold", "shape_volume", "signed_area", "skew",
    "solve_contacts", "solver_settings", "sort_cache", "speculative_bias", "speculative_reach", "spinning_friction",
    "carry_contacts", "redetect_turned", "step", "step_once", "store", "turn_substeps", "turn_budget", "soft_runs", "support_box", "support_capsule", "support_cylinder",
    "support_hull", "support_of", "support_separation", "support_sphere", "tangent_basis",
    "unconstrained_velocity", "velocities_from_alpha", "warm_start", "world_inertia",
    "apply_forces", "carried_gaps", "contact_softness", "core_offsets", "friction_rows", "gap_rounding",
    "recall_forces", "rounding_radius",
    "soft_step", "soft_sweep", "softness",
]
