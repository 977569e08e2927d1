// Shape casts and continuous collision (issue 24; docs/conventions.md, "Shape casts and
// continuous collision"): a bounded shape swept along a straight line against the bodies the broad
// phase finds along it, by collision::cast_shape (conservative advancement on exact distances).
// The step uses the same sweep for its fast bodies, against the static ones, after its substeps:
// speculative contacts stop most fast bodies, but a small body crossing a bumpy triangle mesh in
// one step can find no contact in time and end behind it.
#include <algorithm>
#include <cmath>
#include <string>

#include "collision/collision.hpp"
#include "collision/ray.hpp"
#include "signorini/rotation.hpp"
#include "signorini/world.hpp"
#include "world/checks.hpp"
#include "solver/joint_rows.hpp"
#include "world/step_guard.hpp"

namespace signorini {
namespace {

using collision::CastHit;
using collision::Pose;

/// A dynamic body is swept when it moved more than this fraction of its inner radius in the step
/// (or is a bullet): slower, its speculative contacts have it covered.
constexpr double kFastFraction = 0.5;
/// A sweep counts only where the body's path goes deeper than this fraction of its inner radius
/// into a static body: a path that ends on a surface (the solver stopped it there) or slides along
/// one (a flat mesh's neighbouring triangles) is left alone.
constexpr double kAllowFraction = 0.25;
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

std::optional<ShapeHit> World::cast_shape(const Shape& shape, const Vec3& position, const Quat4& orientation,
                                          const Vec3& translation, const QueryFilter& filter) const {
  const Lock lock(mutex_);
  const std::string who = "cast_shape";
  if (static_only(shape))
    throw std::invalid_argument(who + ": shape must be bounded (not a Plane or TriangleMesh), got a " +
                                shape_name(shape));
  checks::require_finite(who, "position", position);
  checks::require_finite(who, "translation", translation);
  const Quat4 q = checks::unit_quaternion(who + ": orientation", orientation);
  for (const BodyIndex i : filter.exclude)
    if (i < 0 || static_cast<std::size_t>(i) >= model_.size())
      throw BodyIndexError(who + ": exclude: body index " + std::to_string(i) + " is out of range: the world has " +
                           std::to_string(model_.size()) + " bodies");
  broad_phase_->refresh(model_, state_);
  const Pose pose{position, rotation_matrix(q)};
  std::optional<ShapeHit> best;
  query_stats_ = QueryStats{1, 0, 0};
  for (const BodyIndex i : along(*broad_phase_, shape, pose, translation, *scratch_)) {
    if (!model_.enabled[i] || !(model_.filter[i].group & filter.mask) || !(model_.filter[i].mask & filter.group) ||
        std::find(filter.exclude.begin(), filter.exclude.end(), i) != filter.exclude.end())
      continue;
    ++query_stats_.body_tests;
    const CastHit h = collision::cast_shape(model_.shape[i], Pose{state_.p[i], state_.R[i]}, shape, pose, translation,
                                            0.0, broad_phase_->triangles(i), *scratch_);
    if (h.hit && (!best || h.t < best->fraction)) best = ShapeHit{i, h.t, h.point, h.normal};
  }
  return best;
}

void World::continuous() {
  if (!settings_.solver.continuous) return;
  const State& start = guard_->start();
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
    // swept with its end orientation (a translation: the turn within one step is left to the
    // speculative contacts), from where it started, as deep as the allowance
    const Shape& shape = model_.shape[i];
    const Pose from{start.p[i], state_.R[i]};
    const double allow = kAllowFraction * inner;
    CastHit first;
    for (const BodyIndex j : along(*broad_phase_, shape, from, delta, *scratch_)) {
      if (!model_.is_static[j] || model_.is_sensor[j] || !model_.can_collide(i, j)) continue;
      const CastHit h = collision::cast_shape(model_.shape[j], Pose{state_.p[j], state_.R[j]}, shape, from, delta,
                                              -allow, broad_phase_->triangles(j), *scratch_);
      if (h.hit && h.t > 0.0 && (!first.hit || h.t < first.t)) first = h;
    }
    if (!first.hit) continue;
    // back along the path to kBackFraction of the inner radius before the touch, as the normal at
    // the allowance's depth measures it (the gap closes at -delta . n per unit of the path)
    const double closing = -delta.dot(first.normal);
    if (!(closing > 0.0)) continue;
    const double back = std::max(0.0, first.t - (allow + kBackFraction * inner) / closing);
    state_.p[i] = start.p[i] + back * delta;
    ++report_.continuous;
  }
}

}  // namespace signorini
