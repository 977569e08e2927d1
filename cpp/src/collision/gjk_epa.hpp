// Signed distance of two convex items from their support mappings alone: GJK (Gilbert, Johnson,
// Keerthi 1988) on the Minkowski difference for separated items, with the signed-volumes distance
// subalgorithm (Montanari, Petrinic, Barbieri 2017), and EPA (expanding polytope algorithm, van
// den Bergen 2001) for touching and overlapping ones. Our own rather than libccd's inside FCL, which
// can abort and is far from the 1e-9 m the narrow phase needs (docs/conventions.md, "Contacts").
// Internal to cpp/src/collision/.
#pragma once

#include "collision/collision.hpp"

namespace signorini::collision {

/// The point of item `it` farthest along unit direction d (world frame, m): its support mapping
/// (defined in round_contacts.cpp).
Vec3 support_point(const Item& it, const Vec3& d);

/// What one gjk_epa() call did (for tests and benchmarks).
struct GjkEpaStats {
  int gjk_iterations = 0;  ///< GJK iterations on D (one support call each)
  int epa_iterations = 0;  ///< EPA expansions (0 when GJK alone decided the pair)
  bool used_epa = false;   ///< true when the items touch or overlap (or GJK stalled near contact)
  bool converged = true;   ///< false when an iteration cap or a numerical guard stopped a loop
  int simplex = 0;         ///< vertices of GJK's final simplex
  double shift = 0.0;      ///< |c|, the shift of D for EPA (m; 0 without EPA)
  const char* stop = "";   ///< how GJK stopped, or why a loop stopped early
};

/// Signed distance of convex items A and B (world frame, m), from support_point() only.
///
/// Spheres and capsules enter as their cores (a point, a segment) and their radii are added at the
/// end; everything below works on the Minkowski difference D = B_core - A_core, whose support along
/// d is s_B(d) - s_A(-d). L = a.radius() + b.radius() is the pair's size.
/// - GJK on D: v, the point of the simplex closest to the origin (a triangle's v is the origin
///   projected onto its plane, whose direction stays exact near contact), is the distance while
///   |v| > mu = 1e-10 L. It stops when the duality gap |v| - v.w/|v| (w the support along -v) is
///   below 1e-12 of (L + |p_b - p_a|), when a support point repeats or |v| stops shrinking (one
///   step that keeps its new vertex and leaves |v| within 1e-14 scale of rounding is let through:
///   near a ridge of D, every other step does that), or after 128 iterations (then |v| is still
///   the distance of two points of the shapes). A stop short of the duality gap within 1e-6 L of
///   contact (rounding then turns v by ~1e-16 scale / |v|) is handed to EPA as a touching pair.
/// - Touching or overlapping: EPA on D' = D - c, c = v + 2 mu e, e the unit vector from v (GJK's
///   closest point, 0 once a tetrahedron enclosed the origin) towards the difference of the
///   items' interior points, so c lies inside D (convexity) however flat D is about the origin;
///   else c = 2 max(mu, 0.75 |v|) n0 (n0 GJK's last direction). The origin of D' is then inside,
///   away from the cases where EPA breaks (the origin on a face, an edge or a vertex). GJK
///   continues on D' until a tetrahedron encloses the origin (a flat simplex is blown up by
///   supports normal to it); EPA expands it until the support along the closest face's normal lies
///   within 1e-10 L of the face, or after 256 expansions, or when rounding damages the polytope
///   (then the best face so far; it never aborts). Among the faces that the shift could have put
///   behind the closest one, the normal n with the best g(n) = n . s_D(-n) for the unshifted D wins.
///
/// Result (the collision::Distance of collision.hpp): gap = signed distance (m; negative = minus
/// the penetration depth), normal = unit vector A -> B (moving B by -gap along it separates the
/// shapes or makes them touch), w_a, w_b = witness points on A and B (world, m), barycentric in the
/// support points of the final simplex or face; w_b - w_a = gap * normal to rounding for a GJK
/// result. For an EPA one they come from the face of the final polytope that the ray from the
/// shifted origin through gap * normal leaves by (found by walking from the closest face), so
/// w_b - w_a = gap * normal to within EPA's tolerance, or to within about |c| when that face is a
/// neighbour of the closest one that EPA did not refine (|c| <= |v| + 2 mu; a GJK stall near
/// contact leaves |v| <= 1e-6 L).
Distance gjk_epa(const Item& a, const Item& b, EpaScratch& epa, GjkEpaStats* stats = nullptr);
/// The same with buffers of its own (allocates: for tests and one-off queries).
Distance gjk_epa(const Item& a, const Item& b, GjkEpaStats* stats = nullptr);

}  // namespace signorini::collision
