// Ray casts and point tests against one shape (no world, no FCL): the exact part of the World's
// queries (world/queries.cpp), after the broad phase has picked the bodies. FCL 0.7 has no ray
// query at all, so every shape's test is written here: closed forms for the analytic shapes
// (slabs, quadratics), half-space clipping for polytopes, Moller-Trumbore per triangle.
#pragma once

#include <cstdint>
#include <vector>

#include "collision/collision.hpp"
#include "signorini/contact.hpp"
#include "signorini/shapes.hpp"

namespace signorini::collision {

/// A ray o + t u, t in [0, t_max]: origin o (m), unit direction u, in the frame the caller says.
struct Ray {
  Vec3 o = Vec3::Zero();
  Vec3 u = Vec3::UnitX();
  double t_max = 0.0;
};

/// The first point where a ray enters a shape: t (m along u), the unit outward normal there and
/// the feature (signorini/query.hpp, RayHit::feature). inside: the origin is strictly inside a
/// solid (then t = 0, normal = -u, feature of kind Shape).
struct RayResult {
  double t = 0.0;
  Vec3 normal = Vec3::Zero();
  FeatureId feature = 0;
  bool inside = false;
};

/// The roots t0 <= t1 of a t^2 + 2 b t + c = 0 (a > 0) given D = b^2 - a c >= 0, computed without
/// cancellation (the larger-magnitude root from -(b + sign(b) sqrt D), the other as c over it).
void quadratic_roots(double a, double b, double c, double D, double& t0, double& t1);

/// Ray (world) against shape at pose: true and result set when it meets the shape at some t in
/// [0, ray.t_max] (or starts inside a solid). A TriangleMesh needs its TriangleQuery (the BVH);
/// stack is the traversal's scratch. Throws std::logic_error for a shape kind without a test.
bool ray_shape(const Shape& shape, const Pose& pose, const Ray& ray, const TriangleQuery* triangles,
               std::vector<int>& stack, RayResult& result);

/// Moller-Trumbore: the ray (o, u) meets triangle (a, b, c) at t in [0, t_max], barycentric
/// coordinates inclusive (a ray through a shared edge hits both triangles). front: u points
/// against the triangle's normal (b - a) x (c - a).
bool ray_triangle(const Vec3& o, const Vec3& u, const Vec3& a, const Vec3& b, const Vec3& c, double t_max,
                  double& t, bool& front);

/// Whether the world point x lies in the closed solid of shape at pose (its surface included; a
/// plane's half-space n . x <= offset). A TriangleMesh is a surface and contains no point.
bool shape_contains(const Shape& shape, const Pose& pose, const Vec3& x);

/// The tight world box [lo, hi] of a bounded shape at pose (what the broad phase puts in its
/// trees before growing it). Throws std::logic_error for a plane.
void shape_aabb(const Shape& shape, const Pose& pose, Vec3& lo, Vec3& hi);

}  // namespace signorini::collision
