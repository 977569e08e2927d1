// Queries a World answers between steps (issue 24): ray casts (closest, any, all, and batches of
// rays), overlap of a shape, a box or a point with the bodies, and the signed distance of two
// bodies. Plain result structs; the World's query functions (world.hpp) fill them. Units SI,
// vectors world-frame. docs/conventions.md, "Queries", gives the rules in full.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "signorini/contact.hpp"
#include "signorini/types.hpp"

namespace signorini {

/// Which bodies a query sees. Body i is seen when it is enabled, (group_i & mask) != 0 and
/// (mask_i & group) != 0 (its CollisionFilter against this one, as two bodies' filters meet),
/// and i is not in `exclude`. The defaults see every enabled body whose mask is not 0.
struct QueryFilter {
  std::uint32_t group = 0xFFFFFFFFu;  ///< the categories the query belongs to (bits)
  std::uint32_t mask = 0xFFFFFFFFu;   ///< the categories it sees (bits)
  std::vector<BodyIndex> exclude;     ///< bodies never reported (each must exist)
};

/// Where a ray o + t u (u = direction / |direction|, t in [0, max_distance]) meets a body.
/// A ray that starts inside a solid (strictly: sphere, box, capsule, cylinder, hull, mesh piece,
/// compound part, or behind a plane) hits it at distance 0, point = origin, normal = -u, feature
/// of kind Shape (index 0, part the piece or part). Triangle meshes are surfaces, hit from
/// either side.
struct RayHit {
  BodyIndex body = -1;
  Vec3 point = Vec3::Zero();   ///< o + distance u (m, world)
  /// unit, world: out of the hit body at point (a triangle: its front normal when hit from the
  /// front, the reverse when hit from behind, so always against u)
  Vec3 normal = Vec3::Zero();
  double distance = 0.0;       ///< t (m) along the unit direction, in [0, max_distance]
  /// the surface hit (contact.hpp's packing): a box face 2i (-e_i) or 2i + 1 (+e_i); a hull or
  /// mesh piece face (its Polytope's face index); a capsule's side Edge 0 or end cap Vertex 0
  /// (z = -h) / 1 (z = +h); a cylinder's cap Face 0 (z = -h) / 1 (z = +h) or side Face 2; a
  /// sphere or a plane Face 0; a triangle mesh Face 0 with the triangle as part. part is the
  /// compound part or mesh piece otherwise.
  FeatureId feature = 0;
};

/// A shape cast's first touch (World::cast_shape).
struct ShapeHit {
  BodyIndex body = -1;
  double fraction = 1.0;       ///< of the translation, in [0, 1]
  Vec3 point = Vec3::Zero();   ///< where they touch (m, world)
  Vec3 normal = Vec3::Zero();  ///< unit, world: out of the hit body, against the sweep
};

/// Many rays' closest hits (World::cast_rays): row k is ray k. body[k] = -1 where ray k hits
/// nothing, and then point, normal are 0, distance is +inf and feature 0.
struct RayHits {
  std::vector<BodyIndex> body;     ///< (n,)
  Points point;                    ///< (n, 3) m, world
  Points normal;                   ///< (n, 3) unit, world
  std::vector<double> distance;    ///< (n,) m
  std::vector<FeatureId> feature;  ///< (n,)
};

/// Signed distance between two bodies (World::distance): normal points from A to B, point_b -
/// point_a = distance * normal; distance < 0 when they overlap (the penetration depth).
struct BodyDistance {
  double distance = 0.0;       ///< m
  Vec3 point_a = Vec3::Zero(); ///< witness on A (m, world)
  Vec3 point_b = Vec3::Zero(); ///< witness on B (m, world)
  Vec3 normal = Vec3::Zero();  ///< unit, world, A -> B
};

/// What the last query call did: counts, never timings (a test checks that the broad phase
/// prunes with them).
struct QueryStats {
  std::int64_t queries = 0;      ///< rays (or shapes, boxes, points) asked
  std::int64_t nodes = 0;        ///< broad-phase tree nodes whose boxes were tested
  std::int64_t body_tests = 0;   ///< exact tests of one body's shape (planes included)
};

}  // namespace signorini
