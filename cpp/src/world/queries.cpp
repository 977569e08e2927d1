// World queries (issue 24): ray casts, overlaps, distances. Each one validates its input, refits
// the broad phase's boxes to the current poses (BroadPhase::refresh), walks the trees (planes are
// tested directly: they have no box) and runs the exact per-shape test (collision/ray.hpp, or the
// narrow phase's collide() for shapes). Results never depend on the walk's order: hits are
// ordered by (distance, body), overlaps by body.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <string>

#include "collision/collision.hpp"
#include "collision/ray.hpp"
#include "parallel/pool.hpp"
#include "signorini/rotation.hpp"
#include "signorini/world.hpp"
#include "world/checks.hpp"

namespace signorini {
namespace {

using collision::BroadPhase;
using collision::Pose;
using collision::Ray;
using collision::RayResult;

/// Which bodies a query sees (QueryFilter's rule); exclude sorted.
struct Seen {
  const Model& model;
  const QueryFilter& filter;
  std::vector<BodyIndex> excluded;
  bool operator()(BodyIndex i) const {
    return model.enabled[i] && (model.filter[i].group & filter.mask) && (model.filter[i].mask & filter.group) &&
           !std::binary_search(excluded.begin(), excluded.end(), i);
  }
};

Seen seen_by(const Model& model, const QueryFilter& filter, const std::string& who) {
  Seen seen{model, filter, filter.exclude};
  for (const BodyIndex i : seen.excluded)
    if (i < 0 || static_cast<std::size_t>(i) >= model.size())
      throw BodyIndexError(who + ": exclude: body index " + std::to_string(i) + " is out of range: the world has " +
                           std::to_string(model.size()) + " bodies");
  std::sort(seen.excluded.begin(), seen.excluded.end());
  return seen;
}

/// A checked ray: origin finite, direction finite and non-zero (made unit), max_distance >= 0 or
/// +inf. what_row: "" or " row k" for a batch.
Ray checked_ray(const std::string& who, const Vec3& origin, const Vec3& direction, double max_distance,
                const std::string& row = "") {
  if (!origin.allFinite())
    throw std::invalid_argument(who + ": origin" + row + " must be finite, got (" + std::to_string(origin.x()) + ", " +
                                std::to_string(origin.y()) + ", " + std::to_string(origin.z()) + ")");
  const double norm = direction.norm();
  if (!direction.allFinite() || !std::isfinite(norm) || norm == 0.0)
    throw std::invalid_argument(who + ": direction" + row + " must be finite and non-zero, got (" +
                                std::to_string(direction.x()) + ", " + std::to_string(direction.y()) + ", " +
                                std::to_string(direction.z()) + ")");
  if (std::isnan(max_distance) || max_distance < 0.0)
    throw std::invalid_argument(who + ": max_distance" + row + " must be >= 0 (or inf), got " +
                                std::to_string(max_distance));
  return Ray{origin, direction / norm, max_distance};
}

/// What one ray needs: the world (read only), the filter, and per-thread scratch and counts.
struct RayContext {
  const Model& model;
  const State& state;
  const BroadPhase& broad_phase;
  const Seen& seen;
  std::vector<const void*> stack;
  std::vector<int> triangle_stack;
  std::int64_t nodes = 0, tests = 0;
  RayContext(const Model& m, const State& s, const BroadPhase& b, const Seen& f)
      : model(m), state(s), broad_phase(b), seen(f) {}

  /// The exact test of body i with the ray cut at bound.
  bool test(BodyIndex i, const Ray& ray, double bound, RayResult& r) {
    ++tests;
    Ray cut = ray;
    cut.t_max = bound;
    return collision::ray_shape(model.shape[i], Pose{state.p[i], state.R[i]}, cut, broad_phase.triangles(i),
                                triangle_stack, r);
  }
};

RayHit as_hit(BodyIndex i, const Ray& ray, const RayResult& r) {
  RayHit h;
  h.body = i;
  h.distance = r.t;
  h.point = r.inside ? ray.o : Vec3(ray.o + r.t * ray.u);
  h.normal = r.normal;
  h.feature = r.feature;
  return h;
}

/// mode: the closest hit, any hit (the walk stops at the first), or all (one per body).
enum class Mode { Closest, Any, All };

struct Walker : BroadPhase::RayVisitor {
  RayContext& ctx;
  const Ray& ray;
  Mode mode;
  std::vector<RayHit>* all = nullptr;
  bool hit = false;
  BodyIndex best_body = -1;
  RayResult best;
  Walker(RayContext& c, const Ray& r, Mode m) : ctx(c), ray(r), mode(m) {}

  double visit(BodyIndex i, double bound) override {
    if (!ctx.seen(i)) return bound;
    RayResult r;
    if (!ctx.test(i, ray, bound, r)) return bound;
    if (mode == Mode::All) {
      all->push_back(as_hit(i, ray, r));
      return bound;
    }
    if (!hit || r.t < best.t || (r.t == best.t && i < best_body)) best = r, best_body = i, hit = true;
    return mode == Mode::Any ? -1.0 : best.t;
  }
};

/// One ray through the planes and the trees, as mode says.
void walk(RayContext& ctx, const Ray& ray, Walker& w) {
  double bound = ray.t_max;
  for (const BodyIndex i : ctx.broad_phase.planes()) {
    bound = w.visit(i, bound);
    if (bound < 0.0) return;
  }
  ctx.broad_phase.cast_ray(ray.o, ray.u, bound, w, ctx.stack, ctx.nodes);
}

std::optional<RayHit> closest(RayContext& ctx, const Ray& ray, Mode mode) {
  Walker w(ctx, ray, mode);
  walk(ctx, ray, w);
  if (!w.hit) return std::nullopt;
  return as_hit(w.best_body, ray, w.best);
}

/// One ray of World::cast_ray (mode Closest) or cast_ray_any (Any), checked and named by `who`,
/// through the bodies as they are now; stats: the query's counts.
std::optional<RayHit> one_ray(const char* who, Mode mode, const Model& model, const State& state,
                              collision::BroadPhase& broad_phase, const Vec3& origin, const Vec3& direction,
                              double max_distance, const QueryFilter& filter, QueryStats& stats) {
  const Ray ray = checked_ray(who, origin, direction, max_distance);
  const Seen seen = seen_by(model, filter, who);
  broad_phase.refresh(model, state);
  RayContext ctx(model, state, broad_phase, seen);
  std::optional<RayHit> hit = closest(ctx, ray, mode);
  stats = QueryStats{1, ctx.nodes, ctx.tests};
  return hit;
}

}  // namespace

std::optional<RayHit> World::cast_ray(const Vec3& origin, const Vec3& direction, double max_distance,
                                      const QueryFilter& filter) const {
  const Lock lock(mutex_);
  return one_ray("cast_ray", Mode::Closest, model_, state_, *broad_phase_, origin, direction, max_distance, filter,
                 query_stats_);
}

std::optional<RayHit> World::cast_ray_any(const Vec3& origin, const Vec3& direction, double max_distance,
                                          const QueryFilter& filter) const {
  const Lock lock(mutex_);
  return one_ray("cast_ray_any", Mode::Any, model_, state_, *broad_phase_, origin, direction, max_distance, filter,
                 query_stats_);
}

std::vector<RayHit> World::cast_ray_all(const Vec3& origin, const Vec3& direction, double max_distance,
                                        const QueryFilter& filter) const {
  const Lock lock(mutex_);
  const Ray ray = checked_ray("cast_ray_all", origin, direction, max_distance);
  const Seen seen = seen_by(model_, filter, "cast_ray_all");
  broad_phase_->refresh(model_, state_);
  RayContext ctx(model_, state_, *broad_phase_, seen);
  std::vector<RayHit> hits;
  Walker w(ctx, ray, Mode::All);
  w.all = &hits;
  walk(ctx, ray, w);
  std::sort(hits.begin(), hits.end(), [](const RayHit& a, const RayHit& b) {
    return a.distance != b.distance ? a.distance < b.distance : a.body < b.body;
  });
  query_stats_ = QueryStats{1, ctx.nodes, ctx.tests};
  return hits;
}

RayHits World::cast_rays(const Points& origins, const Points& directions, const Eigen::VectorXd& max_distance,
                         const QueryFilter& filter) const {
  const Lock lock(mutex_);
  const std::string who = "cast_rays";
  const Eigen::Index n = origins.rows();
  if (directions.rows() != n)
    throw std::invalid_argument(who + ": directions has " + std::to_string(directions.rows()) +
                                " rows but origins has " + std::to_string(n));
  if (max_distance.size() != n)
    throw std::invalid_argument(who + ": max_distance has " + std::to_string(max_distance.size()) +
                                " entries but origins has " + std::to_string(n) + " rows");
  std::vector<Ray> rays(static_cast<std::size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k)
    rays[k] = checked_ray(who, origins.row(k).transpose(), directions.row(k).transpose(), max_distance[k],
                          " row " + std::to_string(k));
  const Seen seen = seen_by(model_, filter, who);
  broad_phase_->refresh(model_, state_);
  RayHits out;
  out.body.assign(n, -1);
  out.point = Points::Zero(n, 3);
  out.normal = Points::Zero(n, 3);
  out.distance.assign(n, std::numeric_limits<double>::infinity());
  out.feature.assign(n, 0);
  std::atomic<std::int64_t> nodes{0}, tests{0};  // integer sums: the same for any split
  parallel::for_ranges(pool_.get(), static_cast<std::size_t>(n), 64, [&](std::size_t first, std::size_t end) {
    RayContext ctx(model_, state_, *broad_phase_, seen);
    for (std::size_t k = first; k < end; ++k) {
      const std::optional<RayHit> hit = closest(ctx, rays[k], Mode::Closest);
      if (!hit) continue;
      out.body[k] = hit->body;
      out.point.row(k) = hit->point.transpose();
      out.normal.row(k) = hit->normal.transpose();
      out.distance[k] = hit->distance;
      out.feature[k] = hit->feature;
    }
    nodes += ctx.nodes;
    tests += ctx.tests;
  });
  query_stats_ = QueryStats{n, nodes.load(), tests.load()};
  return out;
}

namespace {

/// The planes and the bodies whose broad-phase boxes meet [lo, hi] (world, m), ascending, each
/// once: a query's candidates; stats restarts as one query with the tree nodes it visited.
std::vector<BodyIndex> candidates_in(const BroadPhase& broad_phase, const Vec3& lo, const Vec3& hi, QueryStats& stats) {
  std::vector<BodyIndex> candidates(broad_phase.planes());
  std::vector<const void*> stack;
  stats = QueryStats{1, 0, 0};
  broad_phase.overlap_box(lo, hi, candidates, stack, stats.nodes);
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  return candidates;
}

/// The bodies overlapping a bounded shape at pose (sorted), by the narrow phase with threshold 0.
std::vector<BodyIndex> overlapping(const Model& model, const State& state, BroadPhase& broad_phase,
                                   collision::Scratch& scratch, const Seen& seen, const Shape& shape, const Pose& pose,
                                   QueryStats& stats) {
  Vec3 lo, hi;
  collision::shape_aabb(shape, pose, lo, hi);
  const std::vector<BodyIndex> candidates = candidates_in(broad_phase, lo, hi, stats);
  std::vector<BodyIndex> out;
  std::vector<Contact> contacts;
  for (const BodyIndex i : candidates) {
    if (!seen(i)) continue;
    ++stats.body_tests;
    contacts.clear();
    collision::collide(model.shape[i], Pose{state.p[i], state.R[i]}, shape, pose, 0.0,
                       {broad_phase.triangles(i), nullptr, &scratch}, contacts);
    if (!contacts.empty()) out.push_back(i);
  }
  return out;
}

/// A query shape and its position (overlap, cast_shape): bounded, and finite; else invalid_argument
/// naming the query.
void check_swept(const std::string& who, const Shape& shape, const Vec3& position) {
  if (static_only(shape))
    throw std::invalid_argument(who + ": shape must be bounded (not a Plane or TriangleMesh), got a " +
                                shape_name(shape));
  checks::require_finite(who, "position", position);
}

}  // namespace

std::vector<BodyIndex> World::overlap(const Shape& shape, const Vec3& position, const Quat4& orientation,
                                      const QueryFilter& filter) const {
  const Lock lock(mutex_);
  const std::string who = "overlap";
  check_swept(who, shape, position);
  const Quat4 q = checks::unit_quaternion(who + ": orientation", orientation);
  const Seen seen = seen_by(model_, filter, who);
  broad_phase_->refresh(model_, state_);
  return overlapping(model_, state_, *broad_phase_, *scratch_, seen, shape, Pose{position, rotation_matrix(q)},
                     query_stats_);
}

std::optional<ShapeHit> World::cast_shape(const Shape& shape, const Vec3& position, const Quat4& orientation,
                                          const Vec3& translation, const QueryFilter& filter) const {
  const Lock lock(mutex_);
  const std::string who = "cast_shape";
  check_swept(who, shape, position);
  checks::require_finite(who, "translation", translation);
  const Quat4 q = checks::unit_quaternion(who + ": orientation", orientation);
  const Seen seen = seen_by(model_, filter, who);
  broad_phase_->refresh(model_, state_);
  // the bodies whose boxes meet the box the shape sweeps, and the planes (collision::cast_shape on
  // each: conservative advancement on exact distances)
  const Pose pose{position, rotation_matrix(q)};
  Vec3 lo, hi;
  collision::shape_aabb(shape, pose, lo, hi);
  const std::vector<BodyIndex> candidates =
      candidates_in(*broad_phase_, lo.cwiseMin(lo + translation), hi.cwiseMax(hi + translation), query_stats_);
  std::optional<ShapeHit> best;
  for (const BodyIndex i : candidates) {
    if (!seen(i)) continue;
    ++query_stats_.body_tests;
    const collision::CastHit h = collision::cast_shape(model_.shape[i], Pose{state_.p[i], state_.R[i]}, shape, pose,
                                                       translation, 0.0, broad_phase_->triangles(i), *scratch_);
    if (h.hit && (!best || h.t < best->fraction)) best = ShapeHit{i, h.t, h.point, h.normal};
  }
  return best;
}

std::vector<BodyIndex> World::overlap_aabb(const Vec3& lo, const Vec3& hi, const QueryFilter& filter) const {
  const Lock lock(mutex_);
  const std::string who = "overlap_aabb";
  checks::require_finite(who, "lo", lo);
  checks::require_finite(who, "hi", hi);
  if (!(lo.array() < hi.array()).all())
    throw std::invalid_argument(who + ": lo must be below hi in every axis, got lo (" + std::to_string(lo.x()) + ", " +
                                std::to_string(lo.y()) + ", " + std::to_string(lo.z()) + "), hi (" +
                                std::to_string(hi.x()) + ", " + std::to_string(hi.y()) + ", " +
                                std::to_string(hi.z()) + ")");
  const Seen seen = seen_by(model_, filter, who);
  broad_phase_->refresh(model_, state_);
  const Shape box = Box(0.5 * (hi - lo));
  return overlapping(model_, state_, *broad_phase_, *scratch_, seen, box, Pose{0.5 * (lo + hi), Mat3::Identity()},
                     query_stats_);
}

std::vector<BodyIndex> World::overlap_point(const Vec3& point, const QueryFilter& filter) const {
  const Lock lock(mutex_);
  const std::string who = "overlap_point";
  checks::require_finite(who, "point", point);
  const Seen seen = seen_by(model_, filter, who);
  broad_phase_->refresh(model_, state_);
  const std::vector<BodyIndex> candidates = candidates_in(*broad_phase_, point, point, query_stats_);
  std::vector<BodyIndex> out;
  for (const BodyIndex i : candidates) {
    if (!seen(i)) continue;
    ++query_stats_.body_tests;
    if (collision::shape_contains(model_.shape[i], Pose{state_.p[i], state_.R[i]}, point)) out.push_back(i);
  }
  return out;
}

BodyDistance World::distance(BodyIndex i, BodyIndex j) const {
  const Lock lock(mutex_);
  check_index(i);
  check_index(j);
  if (i == j) throw std::invalid_argument("distance: i and j are the same body (" + label(i) + ")");
  const Shape& a = model_.shape[i];
  const Shape& b = model_.shape[j];
  if (static_only(a) && static_only(b))
    throw std::invalid_argument("distance: " + label(i) + " and " + label(j) +
                                " are both planes or triangle meshes (no distance between them is computed)");
  // a threshold above any gap the pair can have: every point of a bounded shape lies within its
  // bounding radius rho of the body origin; a plane's gap to a shape is at most that shape's
  // origin height plus its rho
  double bound;
  const Vec3& p_i = state_.p[i];
  const Vec3& p_j = state_.p[j];
  if (const auto* plane = std::get_if<Plane>(&a)) {
    const Vec3 n = state_.R[i] * plane->normal;
    bound = std::abs(n.dot(p_j - p_i) - plane->offset) + model_.rho[j];
  } else if (const auto* plane = std::get_if<Plane>(&b)) {
    const Vec3 n = state_.R[j] * plane->normal;
    bound = std::abs(n.dot(p_i - p_j) - plane->offset) + model_.rho[i];
  } else {
    bound = (p_i - p_j).norm() + model_.rho[i] + model_.rho[j];
  }
  const double threshold = 1.001 * bound + 1e-6;
  std::vector<Contact> contacts;
  collision::collide(a, Pose{p_i, state_.R[i]}, b, Pose{p_j, state_.R[j]}, threshold,
                     {broad_phase_->triangles(i), broad_phase_->triangles(j), scratch_.get()}, contacts);
  if (contacts.empty())
    throw std::runtime_error("distance: the narrow phase found no closest pair for " + label(i) + " and " + label(j) +
                             " (a triangle mesh is one-sided: a body wholly behind it has no distance to it)");
  const Contact* c = &contacts[0];
  for (const Contact& k : contacts)
    if (k.gap < c->gap) c = &k;
  BodyDistance d;
  d.distance = c->gap;
  d.normal = c->normal;
  d.point_a = c->point - 0.5 * c->gap * c->normal;
  d.point_b = c->point + 0.5 * c->gap * c->normal;
  query_stats_ = QueryStats{1, 0, 1};
  return d;
}

QueryStats World::query_stats() const {
  const Lock lock(mutex_);
  return query_stats_;
}

}  // namespace signorini
