// Translational sweeps (shape casts and the step's continuous collision): the first time a convex
// item moved along a straight line comes within a target distance of another. Written here rather
// than taken from FCL: FCL 0.7's continuous collision (conservative advancement over its own GJK)
// neither reaches the 1e-9 the casts promise nor knows our one-sided triangles and rounded cores
// (docs/conventions.md, "Shape casts and continuous collision").
#include <algorithm>
#include <cmath>

#include "collision/collision.hpp"
#include "collision/gjk_epa.hpp"

namespace signorini::collision {
namespace {

constexpr int kMaxAdvances = 64;

/// Item b moved by s (world, m).
Item moved(const Item& b, const Vec3& s) {
  Item m = b;
  m.pose.p += s;
  m.ball_centre += s;
  return m;
}

/// The earlier of two hits (ties: the first).
void keep_first(CastHit& best, const CastHit& h) {
  if (h.hit && (!best.hit || h.t < best.t)) best = h;
}

/// A plane (world normal n, offset: n . x = offset) against item b moving by t delta: the item's
/// deepest point along -n, whose height over the plane falls linearly in t.
CastHit cast_plane(const Vec3& n, double offset, const Item& b, const Vec3& delta, double target) {
  CastHit h;
  const Vec3 low = support_point(b, -n);
  const double gap = n.dot(low) - offset;
  const double closing = -n.dot(delta);  // how fast the gap shrinks per unit t
  if (gap <= target) {
    h = {true, 0.0, n, low - 0.5 * gap * n};
  } else if (closing > 0.0 && gap - target <= closing) {
    const double t = (gap - target) / closing;
    h = {true, t, n, Vec3(low + t * delta - 0.5 * target * n)};
  }
  return h;
}

}  // namespace

CastHit cast_item(const Item& a, const Item& b, const Vec3& delta, double target, EpaScratch& epa) {
  // d(t) = dist(a, b + t delta) is convex in t (the distance of two convex sets along a line of
  // translations), and d'(t) = delta . n(t) (n from a to b). A Newton step from a t where
  // d(t) > target lands on the tangent's root, which convexity puts at or before the first t where
  // d = target: the advance never passes it, and converges to it (quadratically on a face, linearly
  // at worst) until the gap is within tol of the target
  const double L = a.radius() + b.radius() + delta.norm();
  const double tol = 1e-12 * L;
  double t = 0.0;
  for (int k = 0; k < kMaxAdvances; ++k) {
    const Distance d = gjk_epa(a, moved(b, t * delta), epa);
    if (d.gap - target <= tol) return {true, t, d.normal, Vec3(0.5 * (d.w_a + d.w_b))};
    const double closing = -delta.dot(d.normal);
    if (!(closing > 0.0)) return {};  // moving apart along the closest direction: never closer
    t += (d.gap - target) / closing;
    if (t > 1.0) return {};
  }
  // the cap: t is still before the first touch (every advance stays before it)
  const Distance d = gjk_epa(a, moved(b, t * delta), epa);
  return {true, t, d.normal, Vec3(0.5 * (d.w_a + d.w_b))};
}

CastHit cast_shape(const Shape& fixed, const Pose& pose_a, const Shape& moving, const Pose& pose_b, const Vec3& delta,
                   double target, const TriangleQuery* triangles, Scratch& s) {
  std::vector<Item>& items_b = s.items_b;
  std::vector<std::shared_ptr<const Polytope>> keep;
  items_b.clear();
  items_of(moving, pose_b, items_b, keep);
  CastHit best;
  if (const auto* plane = std::get_if<Plane>(&fixed)) {
    const Vec3 n = pose_a.R * plane->normal;
    const double offset = plane->offset + n.dot(pose_a.p);
    for (const Item& b : items_b) keep_first(best, cast_plane(n, offset, b, delta, target));
    return best;
  }
  if (const auto* mesh = std::get_if<TriangleMesh>(&fixed)) {
    std::unique_ptr<TriangleQuery> own;
    if (!triangles) {
      own = std::make_unique<TriangleQuery>(*mesh);
      triangles = own.get();
    }
    // one-sided: a triangle counts for an item whose centre starts in front of it and that moves
    // towards its front
    const Vec3 delta_l = pose_a.R.transpose() * delta;
    for (const Item& b : items_b) {
      const Vec3 c0 = pose_a.R.transpose() * (b.pose.p - pose_a.p);
      const Vec3 c1 = c0 + delta_l;
      const double r = b.radius() + std::max(target, 0.0);
      s.triangles.clear();
      triangles->overlapping(c0.cwiseMin(c1) - Vec3::Constant(r), c0.cwiseMax(c1) + Vec3::Constant(r), s.triangles,
                             s.bvh_stack);
      for (const int t : s.triangles) {
        const Vec3& n = mesh->normals[static_cast<std::size_t>(t)];
        if (!(n.dot(delta_l) < 0.0) || !(n.dot(c0 - mesh->vertex(mesh->faces(t, 0))) > 0.0)) continue;
        triangle_polytope_of(*mesh, t, s.triangle);
        Item face;
        face.kind = ItemKind::Polytope;
        face.polytope = &s.triangle;
        face.pose = pose_a;
        face.part = static_cast<std::uint32_t>(t);
        keep_first(best, cast_item(face, b, delta, target, *s.epa));
      }
    }
    return best;
  }
  std::vector<Item>& items_a = s.items_a;
  items_a.clear();
  items_of(fixed, pose_a, items_a, keep);
  for (const Item& a : items_a)
    for (const Item& b : items_b) {
      // items whose balls stay farther apart than the target along the whole path cannot touch
      const Vec3 c = b.ball_centre - a.ball_centre;
      const double reach = a.ball_radius + b.ball_radius + std::max(target, 0.0);
      const double u = delta.squaredNorm() > 0.0 ? std::clamp(-c.dot(delta) / delta.squaredNorm(), 0.0, 1.0) : 0.0;
      if ((c + u * delta).norm() > reach) continue;
      keep_first(best, cast_item(a, b, delta, target, *s.epa));
    }
  return best;
}

}  // namespace signorini::collision
