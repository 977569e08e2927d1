// Continuous collision (issue 24; docs/conventions.md, "Shape casts and continuous collision"):
// after its substeps the step checks its fast bodies: one whose centre's path crossed a static
// body's surface is put back before its shape's first touch along the path (collision::cast_shape,
// the sweep World::cast_shape in queries.cpp makes too). Speculative contacts
// stop most fast bodies, but a small body crossing a bumpy triangle mesh in one step can find no
// contact in time and end behind it. A body fast by its turn (issue 21: a thin hull spun to
// hundreds of rad/s by its landing turns a vertex its contacts did not have into the floor) that
// ends deep in a static body is put back along its path (travel and turn) to where it was not, and
// so is any other body that started the step against a static body. A
// jointed body takes its mechanism with it: the bodies welded to it move with it rigidly, and every
// other body its joints link it to is wound back by the same fraction of its own path, so that the
// joints stay as they were along the way.
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>

#include "collision/collision.hpp"
#include "collision/ray.hpp"
#include "math/rotation.hpp"
#include "parallel/pool.hpp"
#include "parallel/prefetch.hpp"
#include "signorini/world.hpp"
#include "solver/contact_solver.hpp"
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
/// A body fast by its turn is put back when it ends deeper in a static body than it started by more
/// than this fraction of its inner radius (speculative contacts keep shallower overlaps in hand);
/// where along its path: by this many halvings of the step.
constexpr double kDeepFraction = 0.25;
constexpr int kBisections = 20;
/// It is put back too when it ends deeper than it started by any more than kBackFraction and past
/// this fraction of its inner radius deep (issue 21's overlap target): a small body tumbling on a
/// bumpy mesh went 0.25 of its inner radius deeper step after step, each step's contacts carried
/// from its start to first order in the turn, until it was 64 % deep (fuzz 1:286)
constexpr double kOverlapFraction = 0.5;

/// How much deeper shape (bounded, at pose) is in the static bodies `walls` than `start_depth` says
/// it was in each (m, the largest; 0 when it is in none deeper): each depth is -(the least gap of
/// the narrow phase's manifold with gap < 0). depth: each wall's depth.
double deeper(const Model& model, const State& state, const collision::BroadPhase& bp, const Shape& shape,
              const Pose& pose, const std::vector<BodyIndex>& walls, const std::vector<double>& start_depth,
              collision::Scratch& s, std::vector<Contact>& contacts, std::vector<double>* depth = nullptr) {
  double most = 0.0;
  for (std::size_t k = 0; k < walls.size(); ++k) {
    const BodyIndex j = walls[k];
    contacts.clear();
    collision::collide(model.shape[j], Pose{state.p[j], state.R[j]}, shape, pose, 0.0, {bp.triangles(j), nullptr, &s},
                       contacts);
    double d = 0.0;
    for (const Contact& c : contacts) d = std::max(d, -c.gap);
    if (depth) (*depth)[k] = d;
    if (!start_depth.empty()) most = std::max(most, d - start_depth[k]);
  }
  return most;
}

/// The static bodies whose broad-phase boxes meet the box [lo, hi] (world, m), and every plane,
/// ascending, each once: written into s.swept (allocates nothing once it has grown). Only the
/// static tree is walked: continuous collision puts bodies back before static ones alone (rain's
/// 4,200 falling capsules made the walk of the moving bodies' tree a tenth of the step).
const std::vector<BodyIndex>& in_box(const collision::BroadPhase& bp, const Vec3& lo, const Vec3& hi,
                                     collision::Scratch& s) {
  std::vector<BodyIndex>& out = s.swept;
  out.assign(bp.planes().begin(), bp.planes().end());
  std::int64_t nodes = 0;
  bp.overlap_box(lo, hi, out, s.tree_stack, nodes, /*statics_only=*/true);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

/// A body's path over the step, as continuous collision takes it: its centre's straight travel
/// from p0 and a steady turn phi (angle-axis of R R0^T) from R0; at(t), its pose at fraction t.
struct Path {
  Vec3 p0, moved, phi;
  Mat3 R0;
  Path(const Vec3& p0_, const Mat3& R0_, const Vec3& p, const Mat3& R) : p0(p0_), moved(p - p0_), R0(R0_) {
    const Eigen::AngleAxisd turn(Mat3(R * R0_.transpose()));
    phi = turn.angle() * turn.axis();
  }
  Pose at(double t) const { return Pose{Vec3(p0 + t * moved), Mat3(math::orthonormalize(math::rodrigues(phi, t) * R0))}; }
};

/// in_box of the box that shape covers from pose to pose + delta.
const std::vector<BodyIndex>& along(const collision::BroadPhase& bp, const Shape& shape, const Pose& pose,
                                    const Vec3& delta, collision::Scratch& s) {
  Vec3 lo, hi;
  collision::shape_aabb(shape, pose, lo, hi);
  return in_box(bp, lo.cwiseMin(lo + delta), hi.cwiseMax(hi + delta), s);
}

}  // namespace

void World::continuous() {
  if (!settings_.solver.continuous) return;
  const State& start = guard_->start();
  // A body i put back from its end pose `from` to fraction t of its path takes its mechanism with
  // it: the bodies its unbroken joints link it to, through any number of joints (found only now,
  // in storage kept from step to step; a kinematic or sleeping body does not move). Those welded
  // to it (through Fixed joints only) are part of its rigid body: they move by i's rigid motion
  // from `from` to where i is now, so the welds stay as the solve left them (each wound back
  // along its own path, its centre on the chord of its arc, a pair welded side by side and spun
  // at 170 rad/s opened 2.6 cm: tests/python/test_continuous.py). The others are each wound back
  // to fraction t of their own path over the step, their centre along their travel and (turning)
  // their rotation by t of their turn, as i's: every linked body moved rigidly with i put bodies
  // of the seeded fuzz scenes 1:253, 1:286 and 2026:11 deep into the floor
  std::vector<BodyIndex>& mechanism = scratch_->mechanism;
  const auto wind_back_with = [&](BodyIndex i, const Pose& from, double t, bool turning) {
    if (joints_->joints.empty()) return;
    mechanism.assign(1, i);
    const auto link = [&](bool welds_only) {  // every body linked to those listed, appended
      for (std::size_t k = 0; k < mechanism.size(); ++k) {
        const BodyIndex x = mechanism[k];
        for (const Joint& j : joints_->joints) {
          if (j.broken || (j.a != x && j.b != x) || (welds_only && j.kind != JointKind::Fixed)) continue;
          const BodyIndex y = j.a == x ? j.b : j.a;
          if (model_.is_static[y] || std::find(mechanism.begin(), mechanism.end(), y) != mechanism.end()) continue;
          mechanism.push_back(y);
        }
      }
    };
    link(true);
    const std::size_t welded = mechanism.size();  // i and the bodies welded to it, first
    link(false);
    const Mat3 turn = state_.R[i] * from.R.transpose();  // i's rigid motion: x -> p_i + turn (x - from.p)
    for (std::size_t n = 1; n < mechanism.size(); ++n) {
      const BodyIndex k = mechanism[n];
      if (model_.is_kinematic[k] || !model_.enabled[k] || state_.asleep(k)) continue;
      if (n < welded) {
        state_.p[k] = state_.p[i] + turn * (state_.p[k] - from.p);
        state_.R[k] = math::orthonormalize(turn * state_.R[k]);
      } else if (!turning) {
        state_.p[k] = start.p[k] + t * (state_.p[k] - start.p[k]);
      } else {
        const Pose back = Path(start.p[k], start.R[k], state_.p[k], state_.R[k]).at(t);
        state_.p[k] = back.p;
        state_.R[k] = back.R;
      }
    }
  };
  // the bodies the step's contacts hold against a static body: the ones that can have ended deep in
  // one without a fast travel or turn (an impact at one end spins a body within the step, and its
  // far end, beyond its reach at the step's start, swings into the mesh: fuzz 1:65), or with a
  // travel whose centre crossed no surface (the others had none within their reach at the start).
  // (contacts_next_: the contacts the step solved, in both steps; the soft step moved the detected
  // list there, and contacts_base_ then holds an older step's)
  // Over the threads: two contacts may flag the same body, so the flags are stored atomically (the
  // same value whoever stores it; relaxed: the pool's join orders them before the checks read them)
  std::vector<char>& on_static = scratch_->on_static;
  on_static.assign(model_.size(), char(0));
  const auto flag = [&](BodyIndex x) {
    __atomic_store_n(&on_static[static_cast<std::size_t>(x)], char(1), __ATOMIC_RELAXED);
  };
  // The bodies of each contact as the solver's store listed them (contact_body: A at 2k, B at
  // 2k + 1, 8 bytes a contact, in contact order), when it listed this step's: a contact is a few
  // cache lines, read for its bodies alone (asked for ahead, 90 % of this stage on the 5,050-cube
  // pyramid: the walk of 14 MB), so only without that list are the contacts walked
  const std::vector<BodyIndex>& listed = solver_->contact_body;
  const bool by_list = listed.size() == 2 * contacts_next_.size();
  parallel::for_ranges(pool_.get(), contacts_next_.size(), 4096, [&](std::size_t first, std::size_t end) {
    for (std::size_t k = first; k < end; ++k) {
      BodyIndex a, b;
      if (by_list) {
        a = listed[2 * k];
        b = listed[2 * k + 1];
      } else {
        if (k + parallel::kWalkAhead < end)
          parallel::prefetch_read(&contacts_next_[k + parallel::kWalkAhead], 2 * sizeof(BodyIndex));
        a = contacts_next_[k].body_a;
        b = contacts_next_[k].body_b;
      }
      if (model_.is_static[a]) flag(b);
      if (model_.is_static[b]) flag(a);
    }
  });
  // body i checked, with buffers s (kept from step to step: a step allocates nothing once they have
  // grown); true when it was put back. It reads the static bodies and its own state and writes its
  // own pose (and, through wind_back_with, its mechanism's)
  const auto check = [&](BodyIndex i, collision::Scratch& s) -> bool {
    if (model_.is_kinematic[i] || !model_.enabled[i] || model_.is_sensor[i] || state_.asleep(i)) return false;
    const Vec3 delta = state_.p[i] - start.p[i];
    const double travel = delta.norm();
    const double inner = model_.inner[i];
    const bool travelled = travel > 0.0 && (model_.bullet[i] || travel > kFastFraction * inner);
    // the turn's angle from the trace of R R0^T (the elementwise sum of R .* R0), no more per body;
    // its axis only for a body that turned fast
    const double cos_turn = std::clamp(0.5 * (state_.R[i].cwiseProduct(start.R[i]).sum() - 1.0), -1.0, 1.0);
    const bool turned = std::acos(cos_turn) * model_.rho[i] > kFastFraction * inner;
    const bool held = on_static[static_cast<std::size_t>(i)] != 0;
    if (!travelled && !turned && !held) return false;  // nothing to check
    // a jointed body is not moved alone: putting it back without its partners would open its
    // joints, so its mechanism goes with it (wind_back_with)
    const Shape& shape = model_.shape[i];
    const Pose from{start.p[i], state_.R[i]};
    // went through: its centre's path from the step's start crosses a static body's surface (a body
    // that slid over a bump or stopped on a surface keeps its centre in front; only a centre that
    // starts outside counts)
    double crossed = 2.0;
    BodyIndex wall = -1;
    if (travelled) {
      collision::Ray ray{start.p[i], delta / travel, travel};
      for (const BodyIndex j : along(*broad_phase_, shape, from, delta, s)) {
        if (!model_.is_static[j] || model_.is_sensor[j] || !model_.can_collide(i, j)) continue;
        collision::RayResult r;
        const Pose at{state_.p[j], state_.R[j]};
        if (!collision::ray_shape(model_.shape[j], at, ray, broad_phase_->triangles(j), s.bvh_stack, r) || r.inside)
          continue;
        if (r.t / travel < crossed) crossed = r.t / travel, wall = j;
      }
    }
    if (wall >= 0) {
      // put back before the first touch of its shape along the path (the sweep against that body),
      // by kBackFraction of its inner radius as the touch's normal measures the gap; where the shape
      // touched it at the start already, or the sweep finds no touch, its inner radius before the
      // centre's crossing
      const CastHit h = collision::cast_shape(model_.shape[wall], Pose{state_.p[wall], state_.R[wall]}, shape, from,
                                              delta, 0.0, broad_phase_->triangles(wall), s);
      const double closing = h.hit ? -delta.dot(h.normal) : 0.0;
      const double back = h.hit && h.t > 0.0 && closing > 0.0 ? h.t - kBackFraction * inner / closing
                                                             : crossed - inner / travel;
      const double t = std::max(0.0, std::min(back, crossed));
      const Pose end{state_.p[i], state_.R[i]};
      state_.p[i] = start.p[i] + t * delta;
      wind_back_with(i, end, t, false);
    }
    // each body put back counts once (the crossing, the path or both). A body that is not fast by
    // its turn is checked along its path too when it started the step against a static body: one
    // skidding along the floor at speed crosses no surface with its centre, and can end deep on
    // its contacts from the step's start (fuzz 1:29, 1:113)
    if (!turned && !held) return wall >= 0;
    // along its path: the path's poses (straight travel to where it is now, put back or not, and a
    // steady turn about the step's turn axis), the static bodies its ball sweeps; when it ends
    // deeper in one than it started by more than kDeepFraction of its inner radius (or by more than
    // kBackFraction of it, past kOverlapFraction of it deep), put back to the last pose found (by
    // halving) that is no deeper than the start by more than kBackFraction of it
    std::vector<BodyIndex>& walls = s.walls;
    const Vec3 reach = Vec3::Constant(model_.rho[i]);
    walls = in_box(*broad_phase_, start.p[i].cwiseMin(state_.p[i]) - reach, start.p[i].cwiseMax(state_.p[i]) + reach,
                   s);
    walls.erase(std::remove_if(walls.begin(), walls.end(),
                               [&](BodyIndex j) {
                                 return !model_.is_static[j] || model_.is_sensor[j] || !model_.can_collide(i, j);
                               }),
                walls.end());
    if (walls.empty()) return wall >= 0;
    // the end first: each rule needs it deeper than the start by more than kBackFraction of the
    // inner radius, so deeper than that (most bodies are not, and their start is never looked at)
    const std::vector<double> none;
    const Pose end{state_.p[i], state_.R[i]};
    s.end_depth.assign(walls.size(), 0.0);
    deeper(model_, state_, *broad_phase_, shape, end, walls, none, s, s.wall_contacts, &s.end_depth);
    const double deepest = *std::max_element(s.end_depth.begin(), s.end_depth.end());
    if (deepest <= kBackFraction * inner) return wall >= 0;
    const Path path(start.p[i], start.R[i], state_.p[i], state_.R[i]);
    s.start_depth.assign(walls.size(), 0.0);
    deeper(model_, state_, *broad_phase_, shape, path.at(0.0), walls, none, s, s.wall_contacts, &s.start_depth);
    double rise = 0.0;
    for (std::size_t k = 0; k < walls.size(); ++k) rise = std::max(rise, s.end_depth[k] - s.start_depth[k]);
    if (rise <= kDeepFraction * inner && (deepest <= kOverlapFraction * inner || rise <= kBackFraction * inner))
      return wall >= 0;
    double lo = 0.0, hi = 1.0;
    for (int k = 0; k < kBisections; ++k) {
      const double mid = 0.5 * (lo + hi);
      const bool clear = deeper(model_, state_, *broad_phase_, shape, path.at(mid), walls, s.start_depth, s,
                                s.wall_contacts) <= kBackFraction * inner;
      (clear ? lo : hi) = mid;
    }
    const Pose back = path.at(lo);
    state_.p[i] = back.p;
    state_.R[i] = back.R;
    wind_back_with(i, end, lo, true);
    return true;
  };
  // Without joints each check touches only its own body (the static ones are only read), so the
  // bodies are checked over the threads, each with its thread's buffers, and every thread count
  // gives the same poses. A joint's mechanism is wound back with its body, which a later check
  // reads: with joints, the bodies go one after the other, in order, on the calling thread
  if (!joints_->joints.empty() || !pool_ || pool_->threads() == 1) {
    for (const BodyIndex i : moving_) report_.continuous += check(i, *scratch_) ? 1 : 0;
    return;
  }
  const std::size_t threads = static_cast<std::size_t>(pool_->threads());
  collision::grow_workers(*scratch_, threads);
  std::atomic<int> put_back{0};
  pool_->for_ranges(moving_.size(), 32, [&](std::size_t first, std::size_t end) {
    collision::Scratch& s = collision::worker_scratch(*scratch_, threads);
    int n = 0;
    for (std::size_t k = first; k < end; ++k) n += check(moving_[k], s) ? 1 : 0;
    if (n > 0) put_back.fetch_add(n, std::memory_order_relaxed);
  });
  report_.continuous += put_back.load();
}

}  // namespace signorini
