// Signed distance of two convex items from their support mappings alone: GJK (Gilbert, Johnson,
// Keerthi 1988) on the Minkowski difference for separated items, with the signed-volumes distance
// subalgorithm (Montanari, Petrinic, Barbieri 2017), and EPA (expanding polytope algorithm, van
// den Bergen 2001) for touching and overlapping ones.
//
// Why our own code and not libccd / FCL: measured here, libccd's EPA inside libfcl aborts the
// process (an assertion in ComputeVisiblePatch) on some touching cylinder pairs, reverses the
// normal of exactly touching ones and leaves up to ~1e-3 m of GJK tolerance in the gap; the
// narrow phase needs 1e-9 m and must never abort. Internal to cpp/src/collision/.
#pragma once

#include "collision/collision.hpp"

namespace signorini::collision {

/// The point of item `it` farthest along unit direction d (world frame, m): its support mapping
/// (defined in round_contacts.cpp).
Vec3 support_point(const Item& it, const Vec3& d);

/// What one gjk_epa() call did (for tests and benchmarks).
struct GjkEpaStats {
  int gjk_iterations = 0;  ///< GJK support calls on the shapes themselves
  int epa_iterations = 0;  ///< EPA expansions (0 when GJK alone decided the pair)
  bool used_epa = false;   ///< true when the items touch or overlap (within the inflation margin)
  bool converged = true;   ///< false when an iteration cap or a numerical guard stopped a loop
};

/// Signed distance of convex items A and B (world frame, m), from support_point() only.
///
/// Works on the Minkowski difference D = B - A, whose support along d is s_B(d) - s_A(-d).
/// - GJK on D: while the closest point v of the simplex to the origin is farther than the
///   inflation margin 2 mu (mu = 1e-6 L, L = a.radius() + b.radius()), it is the distance; it stops
///   when the duality gap |v| - v.w/|v| (w the support along -v) is below 1e-12 of the scale
///   (L + |p_b - p_a|), when a support point repeats or |v| stops shrinking, or after 128
///   iterations (then |v| is still the distance of two points on the shapes: an upper bound).
/// - Otherwise (touching, or overlapping): A and B are inflated by balls of radius mu, which puts
///   the origin at least mu inside D' = D + ball(2 mu) and away from the degenerate cases of EPA
///   (the origin on a face, an edge or a vertex); the signed distance of D' is exactly that of D
///   minus 2 mu. GJK continues on D' until its simplex encloses the origin (a degenerate simplex
///   is blown up to a tetrahedron by supports normal to it), then EPA expands that tetrahedron
///   towards the boundary of D' until the support along the closest face's normal lies within
///   1e-10 L of it, or after 128 expansions (then the best face so far; EPA never aborts).
///
/// Result (the collision::Distance of collision.hpp): gap = signed distance (m; negative = minus
/// the penetration depth), normal = unit vector A -> B (moving B by -gap along it separates, or
/// makes the shapes touch), w_a, w_b = witness points on A and B (world, m), barycentric in the
/// support points of the final simplex or face; w_b - w_a = gap * normal exactly for a GJK result,
/// to within the tolerances for an EPA one.
Distance gjk_epa(const Item& a, const Item& b, GjkEpaStats* stats = nullptr);

}  // namespace signorini::collision
