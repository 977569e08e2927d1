// Continuous collision (issue 24; docs/conventions.md, "Shape casts and continuous collision"):
// after its substeps the step checks its fast bodies: one whose centre's path crossed a static
// body's surface is put back before its shape's first touch along the path (collision::cast_shape,
// the sweep World::cast_shape in queries.cpp makes too). Speculative contacts
// stop most fast bodies, but a small body crossing a bumpy triangle mesh in one step can find no
// contact in time and end behind it.
#include <algorithm>
#include <cmath>
#include <string>

#include "collision/collision.hpp"
#include "collision/ray.hpp"
#include "signorini/world.hpp"
#include "solver/joint_rows.hpp"
#include "world/step_guard.hpp"

namespace signorini {
namespace {

using collision::CastHit;
using collision::Pose;

/// A dynamic body is swept when it moved more than this fraction of its inner radius in the step
/// (or is a bullet): slower, its speculative contacts have it covered.
constexpr double kFastFraction = 0.5;
/// Where a swept body is put back: this fraction of its inner radius before the touch.
constexpr double kBackFraction = 0.01;

/// The bodies whose broad-phase boxes meet the box that shape covers from pose to pose + delta,
/// and every plane, ascending, each once: written into s.swept (allocates nothing once it has grown).
const std::vector<BodyIndex>& along(const collision::BroadPhase& bp, const Shape& shape, const Pose& pose,
                                    const Vec3& delta, collision::Scratch& s) {
  Vec3 lo, hi;
  collision::shape_aabb(shape, pose, lo, hi);
  std::vector<BodyIndex>& out = s.swept;
  out.assign(bp.planes().begin(), bp.planes().end());
  std::int64_t nodes = 0;
  bp.overlap_box(lo.cwiseMin(lo + delta), hi.cwiseMax(hi + delta), out, s.tree_stack, nodes);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace

void World::continuous() {
  if (!settings_.solver.continuous) return;
  const State& start = guard_->start();
  std::vector<int>& stack = scratch_->bvh_stack;
  for (const BodyIndex i : moving_) {
    if (model_.is_kinematic[i] || !model_.enabled[i] || model_.is_sensor[i] || state_.asleep(i)) continue;
    const Vec3 delta = state_.p[i] - start.p[i];
    const double travel = delta.norm();
    const double inner = model_.inner[i];
    if (!(travel > 0.0) || (!model_.bullet[i] && travel <= kFastFraction * inner)) continue;
    // a jointed body is not moved alone: putting it back without its partners would open its joints
    // (its joints' rows and speculative contacts hold it instead)
    const bool jointed = std::any_of(joints_->joints.begin(), joints_->joints.end(),
                                     [&](const Joint& j) { return !j.broken && (j.a == i || j.b == i); });
    if (jointed) continue;
    // went through: its centre's path from the step's start crosses a static body's surface (a body
    // that slid over a bump or stopped on a surface keeps its centre in front; only a centre that
    // starts outside counts)
    const Shape& shape = model_.shape[i];
    const Pose from{start.p[i], state_.R[i]};
    collision::Ray ray{start.p[i], delta / travel, travel};
    double crossed = 2.0;
    BodyIndex wall = -1;
    for (const BodyIndex j : along(*broad_phase_, shape, from, delta, *scratch_)) {
      if (!model_.is_static[j] || model_.is_sensor[j] || !model_.can_collide(i, j)) continue;
      collision::RayResult r;
      const Pose at{state_.p[j], state_.R[j]};
      if (!collision::ray_shape(model_.shape[j], at, ray, broad_phase_->triangles(j), stack, r) || r.inside) continue;
      if (r.t / travel < crossed) crossed = r.t / travel, wall = j;
    }
    if (wall < 0) continue;
    // put back before the first touch of its shape along the path (the sweep against that body), by
    // kBackFraction of its inner radius as the touch's normal measures the gap; where the shape
    // touched it at the start already, or the sweep finds no touch, its inner radius before the
    // centre's crossing
    const CastHit h = collision::cast_shape(model_.shape[wall], Pose{state_.p[wall], state_.R[wall]}, shape, from,
                                            delta, 0.0, broad_phase_->triangles(wall), *scratch_);
    const double closing = h.hit ? -delta.dot(h.normal) : 0.0;
    const double back = h.hit && h.t > 0.0 && closing > 0.0 ? h.t - kBackFraction * inner / closing
                                                           : crossed - inner / travel;
    state_.p[i] = start.p[i] + std::max(0.0, std::min(back, crossed)) * delta;
    ++report_.continuous;
  }
}

}  // namespace signorini
