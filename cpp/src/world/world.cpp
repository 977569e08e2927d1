// The World's settings and its step, as a pipeline of named stages (docs/conventions.md, "One
// step"); the stages live with their subsystems (dynamics, collision, solver) and the step's checks
// and undo in step_guard.cpp.
#include "signorini/world.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <stdexcept>

#include "collision/collision.hpp"
#include "dynamics/rigid_body.hpp"
#include "math/rotation.hpp"
#include "parallel/pool.hpp"
#include "solver/contact_solver.hpp"
#include "solver/joint_rows.hpp"
#include "solver/soft_step.hpp"
#include "world/checks.hpp"
#include "world/islands.hpp"
#include "world/step_guard.hpp"

namespace signorini {
namespace {

/// The step's stages timed one after the other (StepProfile): each call adds the wall time since
/// the last to a stage, and done() the whole step's to total.
class Laps {
 public:
  explicit Laps(StepProfile& into) : into_(into), start_(Clock::now()), last_(start_) {}
  void operator()(double& stage) {
    const Clock::time_point now = Clock::now();
    stage += ms(now - last_);
    last_ = now;
  }
  void done() { into_.total += ms(last_ - start_); }

 private:
  using Clock = std::chrono::steady_clock;
  static double ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }
  StepProfile& into_;
  Clock::time_point start_, last_;
};

}  // namespace

World::World(const WorldSettings& settings)
    : contacts_(std::make_shared<std::vector<Contact>>()),
      broad_phase_(std::make_unique<collision::BroadPhase>()),
      memory_(std::make_unique<collision::ContactMemory>()),
      scratch_(std::make_unique<collision::Scratch>()),
      solver_(std::make_unique<solver::SolverData>()),
      guard_(std::make_unique<StepGuard>()),
      islands_(std::make_unique<Islands>()),
      joints_(std::make_unique<solver::JointSet>()) {
  solver_->bodies = &moving_;
  solver_->joints = joints_.get();
  islands_->set_joints(&joints_->joints);
  set_settings(settings);
}

World::~World() = default;

void World::set_settings(const WorldSettings& s) {
  const Lock lock(mutex_);
  checks::require_finite("World", "gravity", s.gravity);
  checks::require(std::isfinite(s.contact_margin) && s.contact_margin >= 0.0,
          "contact_margin must be finite and >= 0, got " + std::to_string(s.contact_margin));
  const SolverSettings& q = s.solver;
  checks::require(std::isfinite(q.erp) && q.erp >= 0.0 && q.erp <= 1.0, "erp must be in [0, 1], got " + std::to_string(q.erp));
  checks::require(std::isfinite(q.tolerance) && q.tolerance >= 0.0,
          "tolerance must be finite and >= 0, got " + std::to_string(q.tolerance));
  checks::require(q.max_iterations >= 1, "max_iterations must be >= 1, got " + std::to_string(q.max_iterations));
  checks::require(std::isfinite(q.slop) && q.slop >= 0.0, "slop must be finite and >= 0, got " + std::to_string(q.slop));
  checks::require(std::isfinite(q.max_push_velocity) && q.max_push_velocity > 0.0,
          "max_push_velocity must be finite and > 0, got " + std::to_string(q.max_push_velocity));
  checks::require(std::isfinite(q.restitution_threshold) && q.restitution_threshold >= 0.0,
          "restitution_threshold must be finite and >= 0, got " + std::to_string(q.restitution_threshold));
  checks::require(q.substeps >= 0, "substeps must be >= 1, or 0 for automatic, got " + std::to_string(q.substeps));
  checks::require(std::isfinite(q.warn_velocity) && q.warn_velocity >= 0.0,
          "warn_velocity must be finite and >= 0, got " + std::to_string(q.warn_velocity));
  checks::require(std::isfinite(q.recycle_distance) && q.recycle_distance >= 0.0,
          "recycle_distance must be finite and >= 0, got " + std::to_string(q.recycle_distance));
  checks::require(q.method == SolverMethod::PGS || q.method == SolverMethod::Soft, "method must be PGS or Soft");
  checks::require(std::isfinite(q.contact_hertz) && q.contact_hertz > 0.0,
          "contact_hertz must be finite and > 0, got " + std::to_string(q.contact_hertz));
  checks::require(std::isfinite(q.damping_ratio) && q.damping_ratio >= 0.0,
          "damping_ratio must be finite and >= 0, got " + std::to_string(q.damping_ratio));
  checks::require(std::isfinite(q.joint_hertz) && q.joint_hertz > 0.0,
          "joint_hertz must be finite and > 0, got " + std::to_string(q.joint_hertz));
  checks::require(std::isfinite(q.joint_damping_ratio) && q.joint_damping_ratio >= 0.0,
          "joint_damping_ratio must be finite and >= 0, got " + std::to_string(q.joint_damping_ratio));
  checks::require(q.soft_iterations >= 1, "soft_iterations must be >= 1, got " + std::to_string(q.soft_iterations));
  checks::require(q.relax_iterations >= 0, "relax_iterations must be >= 0, got " + std::to_string(q.relax_iterations));
  checks::require(s.threads >= 0, "threads must be >= 1 (or 0 for the machine's cores), got " + std::to_string(s.threads));
  const SleepSettings& z = s.sleep;
  checks::require(std::isfinite(z.linear_velocity) && z.linear_velocity >= 0.0,
                  "sleep_linear_velocity must be finite and >= 0, got " + std::to_string(z.linear_velocity));
  checks::require(std::isfinite(z.angular_velocity) && z.angular_velocity >= 0.0,
                  "sleep_angular_velocity must be finite and >= 0, got " + std::to_string(z.angular_velocity));
  checks::require(std::isfinite(z.time_to_sleep) && z.time_to_sleep >= 0.0,
                  "time_to_sleep must be finite and >= 0, got " + std::to_string(z.time_to_sleep));
  // a new gravity, or sleeping switched off, wakes everything
  const bool wake_everything = s.gravity != settings_.gravity || !z.enabled;
  const int threads = s.threads == 0 ? parallel::Pool::machine_threads() : s.threads;
  if (!pool_ || pool_->threads() != threads) {
    pool_ = std::make_unique<parallel::Pool>(threads);  // the only step that may throw; nothing changed yet
    solver_->pool = pool_.get();
  }
  settings_ = s;
  settings_.threads = threads;
  if (wake_everything) wake_all();
}

void World::step(double dt, int steps) {
  const Lock lock(mutex_);
  if (!(std::isfinite(dt) && dt > 0.0))
    throw std::invalid_argument("step: dt must be positive and finite, got " + std::to_string(dt));
  if (steps < 0) throw std::invalid_argument("step: steps must be >= 0, got " + std::to_string(steps));
  report_ = StepReport();
  events_.begin.clear();
  events_.end.clear();
  events_.hits.clear();
  events_.sensor_begin.clear();
  events_.sensor_end.clear();
  event_step_ = 0;
  breaks_.clear();
  std::vector<solver::JointSet::Kept>& kept = joints_->kept;
  for (int s = 0; s < steps; ++s) {
    if (joints_->empty()) {
      step_once(dt);
      continue;
    }
    // the joints' forces as they were, for a step the guard undoes (it puts back the rest)
    kept.resize(joints_->joints.size());
    for (std::size_t j = 0; j < kept.size(); ++j) {
      const Joint& x = joints_->joints[j];
      kept[j] = {x.alpha, x.force, x.torque};
    }
    try {
      step_once(dt);
    } catch (...) {
      for (std::size_t j = 0; j < kept.size(); ++j) {
        Joint& x = joints_->joints[j];
        x.alpha = kept[j].alpha, x.force = kept[j].force, x.torque = kept[j].torque;
      }
      throw;
    }
    break_joints(s);
  }
}

void World::wake(BodyIndex i) {
  // every setter comes here: a static body's state changed outside a step, which the guard's
  // checkpoint copies only when told
  if (model_.is_static[i]) guard_->invalidate();
  islands_->mark(state_, i);
  // a static or kinematic body changed by a call: the islands resting on it wake
  if (model_.is_static[i] || model_.is_kinematic[i]) islands_->mark_touching(state_, i);
  islands_->wake_marked(model_, state_, solver_->cache, true, &moving_);
}

void World::wake_all() {
  islands_->mark_all(model_, state_);
  islands_->wake_marked(model_, state_, solver_->cache, true, &moving_);
}

void World::wake_touched(double dt) {
  // a sleeping island touched by a moving body wakes before this step's solve, and the contacts are
  // detected again with it awake (its own contacts were not detected while it slept); with
  // sleeping off nothing sleeps (switching it off, or restoring into such a world, wakes all)
  if (!settings_.sleep.enabled) return;
  while (islands_->mark_touched(model_, state_, contacts_base_)) {
    guard_->keep_cache(*solver_);  // (the woken islands' stashed entries join the cache)
    if (!islands_->wake_marked(model_, state_, solver_->cache, false, &moving_)) break;
    detect_contacts(dt, contacts_base_);
  }
}

void World::end_islands(double dt) {
  islands_->purge(model_, state_);  // what the step woke leaves the sleeping lists
  islands_->end_step(model_, state_, settings_.sleep, dt, *contacts_, solver_->cache, solver_->body_force,
                     solver_->body_torque, &moving_);
}

void World::bodies_changed(bool relist) {
  if (relist) {
    moving_.clear();
    for (std::size_t i = 0; i < model_.size(); ++i)
      if (!model_.is_static[i]) moving_.push_back(static_cast<BodyIndex>(i));
  }
  // the per-body scratch of the stages is sized and zeroed again by the next step
  guard_->invalidate();
  touching_known_ = false;  // the reported contacts were renumbered or replaced
  solver::forget_bodies(*solver_);
  v_.clear();
  omega_.clear();
  turned_.clear();
  escaped_.clear();
  scratch_->reach.clear();
  least_inner_ = -1.0;
}

int SolverSettings::substep_count(double dt, bool joints) const {
  if (substeps >= 1) return substeps;
  // 1e-9: dt = k / 960 gives k substeps despite its rounding; capped so that a huge dt stays an int
  double longest = method == SolverMethod::Soft ? soft_auto_substep : auto_substep;
  // the soft step's joint springs hold only at most a quarter of the substep rate (joint_hertz)
  if (method == SolverMethod::Soft && joints) longest = std::min(longest, solver::kMaxHertzPerRate / joint_hertz);
  return static_cast<int>(std::clamp(std::ceil(dt / longest - 1e-9), 1.0, 1e6));
}

std::vector<Contact>& World::own_contacts() {
  if (contacts_.use_count() > 1) contacts_ = std::make_shared<std::vector<Contact>>();
  return *contacts_;
}

void World::step_once(double dt) {
  if (settings_.solver.method == SolverMethod::Soft) return soft_step_once(dt);
  StepProfile& t = report_.time;
  Laps lap(t);
  guard_->begin(state_, *solver_, &moving_, pool_.get());  // checkpoint: what an undo puts back
  dynamics::apply_impulses(model_, state_, &moving_);  // pending impulses change v and omega
  guard_->measure_start(model_, state_, &moving_, pool_.get());  // the kinetic energy the step answers to
  lap(t.guard);
  detect_contacts(dt, contacts_base_);                 // once, as far as the whole step reaches
  lap(t.detect);
  wake_touched(dt);                                    // sleeping islands touched by moving bodies wake
  lap(t.wake);
  // (after the wake: a joint that woke asks for its substeps; automatic substeps are also short
  // enough for the fast-turning bodies in contact, at most turn_budget of them, half up front)
  const auto [first_n, most, automatic] = plan_substeps(dt);
  int n = first_n;
  double h = dt / n, elapsed = 0.0;
  SolverStats stats;
  for (int k = 0; k < n; ++k) {
    carry_contacts(k, dt - elapsed);                   // the step's contacts moved to this substep
    dynamics::unconstrained_velocity(model_, state_, settings_.gravity, h, settings_.solver.gyroscopic, v_, omega_,
                                     pool_.get(), &moving_);
    stats = solver::solve_contacts(model_, state_, h, settings_.solver, contacts_next_, v_, omega_, *solver_,
                                   k == 0 ? nullptr : &anchor_a_, k == 0 ? nullptr : &anchor_b_);
    sum_impulses(k);                                   // Contacts.impulse: the whole step's
    lap(t.solve);
    dynamics::advance(model_, state_, solver_->v_move, solver_->omega_move, v_, omega_, h, pool_.get(), &moving_);
    guard_->check_finite(model_, state_, *solver_, &moving_);  // checkpoint: nothing non-finite is kept
    end_substep(stats, h);
    elapsed += h;
    // a body set turning fast by this substep's contacts: the rest of the step in shorter substeps
    if (automatic && k + 1 < n && n < most) {
      const double rest = (n - k - 1) * h;
      const int more = std::min(most - k - 1, turn_substeps(contacts_next_, rest));
      if (more > n - k - 1) {
        h = rest / more;
        n = k + 1 + more;
      }
    }
    lap(t.integrate);
  }
  continuous();                                        // fast bodies put back before the static ones they passed
  lap(t.continuous);
  guard_->check_energy(model_, settings_.gravity, dt, state_, *solver_, &moving_, pool_.get());  // checkpoint: no explosion
  lap(t.guard);
  commit_step(stats);
  end_islands(dt);                                     // sleep timers; islands at rest fall asleep
  lap(t.commit);
  lap.done();
}

int World::substep_count(double dt) const {
  if (!(std::isfinite(dt) && dt > 0.0))
    throw std::invalid_argument("substep_count: dt must be positive and finite, got " + std::to_string(dt));
  // a joint's spring asks for substeps short enough for its joint_hertz, while it holds and one
  // of its bodies moves (a joint links its bodies' island: asleep, they sleep together, and a
  // settled jointed pile no longer pays the joints' substeps; one body waking wakes the island)
  const auto& joints = joints_->joints;
  const auto moves = [&](BodyIndex i) {
    const std::size_t k = static_cast<std::size_t>(i);
    return !model_.is_static[k] && !state_.asleep(k);
  };
  return settings_.solver.substep_count(
      dt, std::any_of(joints.begin(), joints.end(), [&](const Joint& j) { return !j.broken && (moves(j.a) || moves(j.b)); }));
}

void World::soft_step_once(double dt) {
  const SolverSettings& q = settings_.solver;
  StepProfile& t = report_.time;
  Laps lap(t);
  guard_->begin(state_, *solver_, &moving_, pool_.get());  // checkpoint: what an undo puts back
  dynamics::apply_impulses(model_, state_, &moving_);  // pending impulses change v and omega
  guard_->measure_start(model_, state_, &moving_, pool_.get());  // the kinetic energy the step answers to
  lap(t.guard);
  detect_contacts(dt, contacts_base_);                 // once, as far as the whole step reaches
  lap(t.detect);
  wake_touched(dt);                                    // sleeping islands touched by moving bodies wake
  lap(t.wake);
  // (after the wake: a joint that woke asks for its substeps; automatic substeps are also short
  // enough for the fast-turning bodies in contact, as in step_once)
  const auto [first_n, most, automatic] = plan_substeps(dt);
  int n = first_n;
  double h = dt / n;
  // the step's contacts, to be written by the solver: moved, not copied (the soft step never
  // reads them as detected again; the next step detects into the other list)
  contacts_next_.swap(contacts_base_);
  solver::soft_begin(model_, state_, h, n, q, contacts_next_, *solver_);
  lap(t.prepare);
  soft_runs_ = 0;
  for (int k = 0; k < n; ++k) {
    dynamics::unconstrained_velocity(model_, state_, settings_.gravity, h, q.gyroscopic, v_, omega_, pool_.get(),
                                     &moving_);
    solver::soft_solve(model_, state_, q, v_, omega_, *solver_);
    lap(t.solve);
    dynamics::advance(model_, state_, v_, omega_, v_, omega_, h, pool_.get(), &moving_);  // the poses move with the solved velocities
    lap(t.integrate);
    solver::soft_relax(model_, state_, q, state_.v, state_.omega, *solver_, k + 1 < n);
    lap(t.relax);
    guard_->check_finite(model_, state_, *solver_, &moving_);  // checkpoint: nothing non-finite is kept
    ++report_.steps;
    // a pair turned far since the rows were made, or a body set turning fast: the rest of the step
    // on rows made again (at most `most` substeps in all)
    if (automatic && k + 1 < n) soft_cut(k, n, h, most);
    lap(t.integrate);
  }
  SolverStats stats = solver::soft_end(model_, state_, q, contacts_next_, state_.v, state_.omega, *solver_);
  if (soft_runs_ > 0) add_impulse_sums();  // the step's impulses: the runs before summed by key
  end_substep_flags(stats, state_.time);
  guard_->swap_cache(*solver_);  // (the cache the step started with kept for an undo)
  lap(t.store);
  continuous();                                        // fast bodies put back before the static ones they passed
  lap(t.continuous);
  guard_->check_energy(model_, settings_.gravity, dt, state_, *solver_, &moving_, pool_.get());  // checkpoint: no explosion
  lap(t.guard);
  commit_step(stats);
  end_islands(dt);                                     // sleep timers; islands at rest fall asleep
  lap(t.commit);
  lap.done();
}

namespace {

/// The step's impulse sums for the contacts `now` (K), from the last substep's contacts `last`,
/// whose impulse fields hold their sums so far: a contact's sum is that of the contact of `last`
/// with its key (bodies, features), else 0 (a point found anew). Both lists are in the order of the
/// step's candidate pairs, sorted by (lower body, higher body); a pair's points are matched among
/// themselves (at most a few).
/// A contact's body pair as the candidate pairs list it: (lower, higher).
std::pair<BodyIndex, BodyIndex> pair_of(const Contact& c) {
  return std::make_pair(std::min(c.body_a, c.body_b), std::max(c.body_a, c.body_b));
}

void match_impulses(const std::vector<Contact>& last, const std::vector<Contact>& now, std::vector<double>& sums) {
  sums.assign(now.size(), 0.0);
  std::size_t i = 0;
  for (std::size_t j = 0; j < now.size();) {
    const auto pair = pair_of(now[j]);
    std::size_t end = j;  // now's run of the pair
    while (end < now.size() && now[end].body_a == now[j].body_a && now[end].body_b == now[j].body_b) ++end;
    while (i < last.size() && pair_of(last[i]) < pair) ++i;
    std::size_t last_end = i;  // last's run of the pair
    while (last_end < last.size() && last[last_end].body_a == now[j].body_a && last[last_end].body_b == now[j].body_b)
      ++last_end;
    for (std::size_t k = j; k < end; ++k)
      for (std::size_t m = i; m < last_end; ++m)
        if (last[m].feature_a == now[k].feature_a && last[m].feature_b == now[k].feature_b) {
          sums[k] = last[m].impulse;
          break;
        }
    i = last_end;
    j = end;
  }
}

}  // namespace

void World::carry_contacts(int k, double rest) {
  if (k == 0) {
    // copied into kept storage, grown geometrically (a copy assignment allocates the exact size)
    if (contacts_next_.capacity() < contacts_base_.size()) contacts_next_.reserve(2 * contacts_base_.size());
    contacts_next_ = contacts_base_;
    redetected_ = false;
    return;
  }
  find_turned(guard_->start());
  const bool turned = collision::any_turned(model_, scratch_->pairs, turned_);
  // a body set moving past its reach within the step (docs/conventions.md, "Deep overlaps":
  // escaped bodies): its pairs that the detection did not reach are found now
  const bool escaped = find_escaped(guard_->start(), rest);
  // the step's impulse sums follow the contacts by key when the list is not the carried one
  const bool rekey = turned || escaped || redetected_;
  if (rekey) contacts_prev_.swap(contacts_next_);  // (their impulses are the sums so far: sum_impulses)
  collision::carry_contacts(model_, contacts_base_, guard_->start(), state_, contacts_next_, anchor_a_, anchor_b_,
                            nullptr, nullptr, pool_.get());
  if (turned || escaped) redetect_turned(rest, escaped);
  redetected_ = turned || escaped;
  if (rekey) match_impulses(contacts_prev_, contacts_next_, impulse_sum_);
}

void World::redetect_turned(double rest, bool escapes) {
  collision::redetect_turned(model_, state_, rest, settings_.gravity, settings_.contact_margin, *broad_phase_, *memory_,
                             *scratch_, turned_, contacts_next_, anchor_a_, anchor_b_, redetected_list_, redetected_a_,
                             redetected_b_, escapes ? &escape_pairs_ : nullptr);
  contacts_next_.swap(redetected_list_);
  anchor_a_.swap(redetected_a_);
  anchor_b_.swap(redetected_b_);
}

int World::turn_budget(double dt, int n) const {
  // (1e-9 absorbs rounding: dt = 1/240 is one span)
  const int spans = static_cast<int>(std::clamp(std::ceil(dt * collision::kTurnRate - 1e-9), 1.0, 1e6));
  return std::max(collision::kTurnSubsteps * spans, collision::kTurnSubstepFactor * n);
}

World::SubstepPlan World::plan_substeps(double dt) const {
  SubstepPlan plan;
  plan.automatic = settings_.solver.substeps < 1;
  plan.n = substep_count(dt);
  plan.most = turn_budget(dt, plan.n);
  // (the bound first: a pile at rest asks for nothing, and its contacts are not read)
  if (plan.automatic && std::ceil(dt * turn_rate_bound() / collision::kTurnReach - 1e-9) > plan.n)
    plan.n = std::max(plan.n, std::min(plan.most / 2, turn_substeps(contacts_base_, dt)));
  return plan;
}

double World::turn_rate_bound(double* turned) const {
  if (least_inner_ < 0.0) {
    least_inner_ = std::numeric_limits<double>::infinity();
    for (const double r : model_.inner) least_inner_ = std::min(least_inner_, r);
  }
  // (maxima over the threads' ranges: the same bits in any order)
  double T = 0.0, S = 0.0;
  std::mutex joined;
  parallel::for_ranges(pool_.get(), moving_.size(), 1024, [&](std::size_t first, std::size_t end) {
    double T_part = 0.0, S_part = 0.0;
    for (std::size_t k = first; k < end; ++k) {
      const BodyIndex i = moving_[k];
      if (turned) T_part = std::max(T_part, turned_[i]);
      const double sweep = std::holds_alternative<Sphere>(model_.shape[i]) ? 0.0 : state_.omega[i].norm() * model_.rho[i];
      S_part = std::max(S_part, sweep + state_.v[i].norm());
    }
    const std::lock_guard<std::mutex> lock(joined);
    T = std::max(T, T_part);
    S = std::max(S, S_part);
  });
  if (turned) *turned = T;
  return 2.0 * S / least_inner_ * (1.0 + 1e-9);
}

bool World::soft_cut(int k, int& n, double& h, int most) {
  // the rows were made at segment_start_'s poses (the step's start for the first run of rows)
  const State& from = soft_runs_ ? segment_start_ : guard_->start();
  find_turned(from);
  // bounds from the moving bodies alone, so that a step where nothing turns or moves fast reads no
  // contact: no pair has turned far while 2 max(turned) <= kTurnReach min(inner) over every body,
  // and turn_substeps asks for no more than turn_rate_bound gives
  double T = 0.0;
  const double rate = turn_rate_bound(&T);
  const double rest = (n - k - 1) * h;
  const bool may_turn = 2.0 * T > collision::kTurnReach * least_inner_;
  const bool may_split = n < most && rest * rate / collision::kTurnReach - 1e-9 > n - k - 1;
  if (!may_turn && !may_split) return false;
  const bool turned = may_turn && std::any_of(contacts_next_.begin(), contacts_next_.end(), [&](const Contact& c) {
    return collision::turned_far(model_, c.body_a, c.body_b, turned_);
  });
  const int more = may_split ? std::min(most - k - 1, turn_substeps(contacts_next_, rest)) : 0;
  if (!turned && more <= n - k - 1) return false;
  // this run of rows ends here: its forces stored (the next run's warm start, by key) and its
  // impulses added to the step's sums so far (the report, the certificate and the bodies' sums,
  // is the last run's: not made here)
  solver::soft_end(model_, state_, settings_.solver, contacts_next_, state_.v, state_.omega, *solver_, false);
  guard_->swap_cache(*solver_);  // (the cache the step started with kept for an undo)
  if (soft_runs_ == 0) impulse_sum_.assign(contacts_next_.size(), 0.0);
  add_impulse_sums();
  // the run's contacts carried to now, the turned pairs collided again for the rest of the step
  // (a run after the first was made on carried contacts: their anchors, not their points, move on)
  contacts_prev_.swap(contacts_next_);
  if (soft_runs_ > 0) {
    redetected_a_.swap(anchor_a_);
    redetected_b_.swap(anchor_b_);
  }
  collision::carry_contacts(model_, contacts_prev_, from, state_, contacts_next_, anchor_a_, anchor_b_,
                            soft_runs_ > 0 ? &redetected_a_ : nullptr, soft_runs_ > 0 ? &redetected_b_ : nullptr,
                            pool_.get());
  if (turned) redetect_turned(rest);
  match_impulses(contacts_prev_, contacts_next_, impulse_sum_);
  if (more > n - k - 1) {
    h = rest / more;
    n = k + 1 + more;
  }
  segment_start_.p = state_.p;  // (copies into kept storage)
  segment_start_.R = state_.R;
  ++soft_runs_;
  solver::soft_begin(model_, state_, h, n - k - 1, settings_.solver, contacts_next_, *solver_, &anchor_a_,
                     &anchor_b_);
  return true;
}

void World::add_impulse_sums() {
  // Contacts.impulse: the step's whole normal impulse, this run's added to the sums before it
  // (and the touching flags, which store set from this run's alone, from the sum: what the events read)
  const bool flags = solver_->touches.size() == contacts_next_.size();
  for (std::size_t i = 0; i < contacts_next_.size(); ++i) {
    contacts_next_[i].impulse += impulse_sum_[i];
    impulse_sum_[i] = contacts_next_[i].impulse;
    if (flags) solver_->touches[i] = contacts_next_[i].impulse > 0.0 || contacts_next_[i].gap < 0.0;
  }
}

int World::turn_substeps(const std::vector<Contact>& contacts, double span) const {
  // the substeps that keep each pair's turn within kTurnReach of its smaller inner radius:
  // span (|omega_A| rho_A + |omega_B| rho_B + f u) / (kTurnReach min(inner_A, inner_B))
  const auto sweep = [&](BodyIndex i) {
    return model_.is_static[i] || std::holds_alternative<Sphere>(model_.shape[i]) ? 0.0 : state_.omega[i].norm() * model_.rho[i];
  };
  // A pair whose bodies' centres close within the span at speed u can be set turning by the
  // impact within a substep, too late for the substeps after it: at about f u / rho, f = lever /
  // rho of the impact, the larger of the bodies' (a body that turns: not static, kinematic or a
  // sphere), the impact at the centroid of the pair's points that close within the span. With the
  // soft step an impact through the centres (a capsule landing flat on its two ends, a ball on a
  // face) asks for nothing, and one at a corner of a small body up to u / rho. The PGS counts the
  // whole u (f = 1): its hard landings sink less in the substeps their closing asks for (rain's
  // columns: 108 steps past half a radius against 151 with the lever), the soft step's do not (280
  // either way). (The centres' closing: a turn's share of the closing is the sweep's already, and
  // a point carried through substeps, the anchors' midpoint, lags a fast body, so that omega x (y -
  // p) would read a spinning ball's travel as closing.)
  // A pair counts only when it can touch within the span: gap < span (sweeps + u) (a speculative
  // pair half a metre apart asks nothing for its turn)
  const auto closing = [&](const Contact& c) {
    return std::max(0.0, -c.normal.dot(state_.v[c.body_b] - state_.v[c.body_a]));
  };
  const auto lever = [&](BodyIndex i, const Vec3& y, const Vec3& n) {
    if (model_.is_static[i] || model_.is_kinematic[i] || std::holds_alternative<Sphere>(model_.shape[i])) return 0.0;
    return std::min(1.0, (y - state_.p[i]).cross(n).norm() / model_.rho[i]);
  };
  const bool levered = settings_.solver.method == SolverMethod::Soft;
  const auto same_pair = [&](std::size_t j, std::size_t k) {
    return contacts[j].body_a == contacts[k].body_a && contacts[j].body_b == contacts[k].body_b;
  };
  // the pairs over the pool's threads, a range taking the pairs that begin in it (a maximum: the
  // same bits in any order)
  double fastest = 0.0;
  std::mutex joined;
  parallel::for_ranges(pool_.get(), contacts.size(), 1024, [&](std::size_t first, std::size_t last) {
    std::size_t j = first;
    while (j > 0 && j < last && same_pair(j, j - 1)) ++j;  // the range before takes its last pair whole
    double part = 0.0;
    while (j < last) {
      // the pair's run of contacts (the list is in pair order) and, for the lever, the centroid of
      // its closing points
      const BodyIndex a = contacts[j].body_a, b = contacts[j].body_b;
      std::size_t end = j;
      Vec3 centroid = Vec3::Zero();
      int closes = 0;
      for (; end < contacts.size() && same_pair(end, j); ++end)
        if (levered && contacts[end].gap < span * closing(contacts[end])) {
          centroid += contacts[end].point;
          ++closes;
        }
      if (closes > 0) centroid /= closes;
      const double s = sweep(a) + sweep(b), inner = std::min(model_.inner[a], model_.inner[b]);
      for (; j < end; ++j) {
        const Contact& c = contacts[j];
        const double u = closing(c);
        if (!(c.gap < span * (s + u))) continue;
        const double f = !(c.gap < span * u) ? 0.0
                         : levered             ? std::max(lever(a, centroid, c.normal), lever(b, centroid, c.normal))
                                               : 1.0;
        part = std::max(part, (s + f * u) / inner);
      }
    }
    const std::lock_guard<std::mutex> lock(joined);
    fastest = std::max(fastest, part);
  });
  // (a huge count is capped by the caller; 1e-9 absorbs rounding)
  return static_cast<int>(std::clamp(std::ceil(span * fastest / collision::kTurnReach - 1e-9), 1.0, 1e6));
}

void World::find_turned(const State& from) {
  // how far a turn from R_0 to R moves a point at distance rho from the centre, at most:
  // 2 sin(angle / 2) rho = sqrt(3 - tr(R R_0^T)) rho (tr = 1 + 2 cos(angle))
  // (a sphere's turn moves none of its surface; a capsule's or cylinder's spin about its own axis
  // does not either, yet counts: the tops of tests/python/test_deep_overlaps.py, spun about their
  // axes, sink past their slop when only the axis's turn counts. Only the moving bodies' entries
  // are written: a static body's stays 0 from the sizing, which bodies_changed redoes, so that the
  // cost follows the moving bodies)
  parallel::fit(turned_, model_.size(), 0.0);
  parallel::for_bodies(pool_.get(), &moving_, model_.size(), 1024, [&](std::size_t i) {
    const bool still = state_.asleep(i) || std::holds_alternative<Sphere>(model_.shape[i]);
    turned_[i] = still ? 0.0 : std::sqrt(std::max(0.0, 3.0 - state_.R[i].cwiseProduct(from.R[i]).sum())) * model_.rho[i];
  });
}

bool World::find_escaped(const State& from, double rest) {
  // (in body order on the calling thread: a few operations per moving body, beside a substep's
  // sweeps; only the moving bodies' entries are written, as for turned_)
  escaped_.clear();
  // out of the box the step's broad phase grew for it (its reach then and half the margin): a
  // body still inside it can meet no body the detection left out, whose own box it did not meet
  const std::vector<double>& reach = scratch_->reach;  // the step's detection's
  const double half_margin = 0.5 * settings_.contact_margin;
  for (const BodyIndex i : moving_) {
    if (model_.is_kinematic[i] || state_.asleep(i)) continue;
    if ((state_.p[i] - from.p[i]).norm() + turned_[i] > reach[i] + half_margin) escaped_.push_back(i);
  }
  if (escaped_.empty()) return false;
  collision::speculative_reach(model_, state_, rest, settings_.gravity, escape_reach_, &moving_);
  double bound = 0.0;
  for (const BodyIndex i : moving_) bound = std::max(bound, escape_reach_[i]);
  broad_phase_->escaped_pairs(model_, state_, escaped_, escape_reach_, bound, settings_.contact_margin, escape_pairs_,
                              escape_met_, escape_stack_);
  // and every plane (unbounded: in no tree), as the detection pairs it with every dynamic body
  if (!broad_phase_->planes().empty()) {
    for (const BodyIndex k : broad_phase_->planes())
      for (const BodyIndex i : escaped_) escape_pairs_.emplace_back(std::min(k, i), std::max(k, i));
    std::sort(escape_pairs_.begin(), escape_pairs_.end());
    escape_pairs_.erase(std::unique(escape_pairs_.begin(), escape_pairs_.end()), escape_pairs_.end());
  }
  const auto sleeps = [&](BodyIndex x) { return !model_.is_static[x] && state_.asleep(x); };
  const auto refused = [&](const std::pair<BodyIndex, BodyIndex>& p) {
    return !model_.can_collide(p.first, p.second) || model_.is_sensor[p.first] || model_.is_sensor[p.second] ||
           sleeps(p.first) || sleeps(p.second);
  };
  // and those that carry contacts (the step's detected list, which carry_contacts carries: in pair
  // order, sorted by lower then higher body): an escaped body's pair whose boxes do not meet now
  // gets no contact for the rest of the step either, so the pairs left are all that is found anew
  const auto carries = [&](const std::pair<BodyIndex, BodyIndex>& p) {
    const auto it = std::lower_bound(contacts_base_.begin(), contacts_base_.end(), p,
                                     [&](const Contact& c, const std::pair<BodyIndex, BodyIndex>& x) { return pair_of(c) < x; });
    return it != contacts_base_.end() && pair_of(*it) == p;
  };
  escape_pairs_.erase(std::remove_if(escape_pairs_.begin(), escape_pairs_.end(),
                                     [&](const auto& p) { return refused(p) || carries(p); }),
                      escape_pairs_.end());
  return !escape_pairs_.empty();
}

void World::sum_impulses(int k) {
  const std::size_t K = contacts_next_.size();
  if (k == 0) {
    if (impulse_sum_.capacity() < K) impulse_sum_.reserve(2 * K);
    impulse_sum_.assign(K, 0.0);
  }
  // (and the solver's touching flags, which store set from this substep's impulse alone, from the
  // sum: what the events read)
  const bool flags = solver_->touches.size() == K;
  for (std::size_t i = 0; i < K; ++i) {
    impulse_sum_[i] += contacts_next_[i].impulse;
    contacts_next_[i].impulse = impulse_sum_[i];
    if (flags) solver_->touches[i] = contacts_next_[i].impulse > 0.0 || contacts_next_[i].gap < 0.0;
  }
}

void World::end_substep(const SolverStats& stats, double h) {
  guard_->swap_cache(*solver_);  // (the cache the step started with kept for an undo)
  ++report_.steps;
  end_substep_flags(stats, state_.time - h);
}

void World::end_substep_flags(const SolverStats& stats, double time) {
  if (!stats.converged && stats.max_penetration_velocity > settings_.solver.warn_velocity) {
    ++report_.flagged;
    if (stats.max_penetration_velocity > report_.worst_penetration_velocity) {
      report_.worst_penetration_velocity = stats.max_penetration_velocity;
      report_.worst_time = time;
    }
  }
}

void World::commit_step(const SolverStats& solved) {
  SolverStats stats = solved;
  stats.pairs = memory_->manifolds.pairs;
  stats.recycled_pairs = memory_->manifolds.recycled;
  memory_->commit(guard_->start().p, &moving_);
  // the pairs touching before the step, for its events: from the contacts reported then, when a
  // restore or a change of bodies made them new
  if (!touching_known_) touching_pairs(*contacts_, touching_);
  // the reported contacts and forces: the step's, and the sleeping islands' as they fell asleep
  std::vector<Contact>& contacts = own_contacts();
  if (islands_->contacts().empty()) {
    contacts.swap(contacts_next_);
  } else {
    islands_->purge(model_, state_);  // islands woken in this step are solved in it
    islands_->merge_contacts(contacts_next_, contacts);
    islands_->add_forces(*solver_);
  }
  record_events(contacts);
  record_sensor_events();
  ++event_step_;
  stats_ = stats;
  // (a static body has no one-step force: apply_force refuses it)
  parallel::for_bodies(pool_.get(), &moving_, model_.size(), 1024, [&](std::size_t i) {
    if (model_.enabled[i] && !state_.asleep(i)) state_.q[i] = math::matrix_to_quat(state_.R[i]);
    state_.f_step[i].setZero();
    state_.tau_step[i].setZero();
  });
}

std::vector<Contact> World::detect_contacts(double dt) const {
  const Lock lock(mutex_);
  std::vector<Contact> out;
  detect_contacts(dt, out);
  return out;
}

void World::detect_contacts(double dt, std::vector<Contact>& out) const {
  const Lock lock(mutex_);
  if (!(std::isfinite(dt) && dt > 0.0))
    throw std::invalid_argument("detect_contacts: dt must be positive and finite, got " + std::to_string(dt));
  collision::generate_contacts(model_, state_, dt, settings_.gravity, settings_.contact_margin, *broad_phase_, *memory_,
                               *scratch_, out, pool_.get(), &moving_, settings_.solver.recycle_distance);
  split_sensors(out);  // sensors' contacts are never solved or reported
}

std::size_t World::num_bodies() const {
  const Lock lock(mutex_);
  return model_.size();
}

WorldSettings World::settings() const {
  const Lock lock(mutex_);
  return settings_;
}

std::vector<Contact> World::contacts() const {
  const Lock lock(mutex_);
  return *contacts_;
}

std::shared_ptr<const std::vector<Contact>> World::shared_contacts() const {
  const Lock lock(mutex_);
  return contacts_;
}

SolverStats World::solver_stats() const {
  const Lock lock(mutex_);
  return stats_;
}

StepReport World::step_report() const {
  const Lock lock(mutex_);
  return report_;
}

std::vector<Vec3> World::contact_forces() const {
  const Lock lock(mutex_);
  return solver_->body_force;
}

std::vector<Vec3> World::contact_torques() const {
  const Lock lock(mutex_);
  return solver_->body_torque;
}

std::vector<CachedContact> World::warm_start_cache() const {
  const Lock lock(mutex_);
  return solver_->cache;
}

double World::kinetic_energy() const {
  const Lock lock(mutex_);
  double T = 0.0;
  for (std::size_t i = 0; i < model_.size(); ++i) {
    if (model_.is_static[i] || model_.is_kinematic[i]) continue;
    const Mat3& R = state_.R[i];
    const Vec3& w = state_.omega[i];
    T += 0.5 * model_.mass[i] * state_.v[i].squaredNorm() + 0.5 * w.dot(R * (model_.I_body[i] * (R.transpose() * w)));
  }
  return T;
}

double World::potential_energy() const {
  const Lock lock(mutex_);
  double V = 0.0;
  for (std::size_t i = 0; i < model_.size(); ++i)
    if (!model_.is_static[i] && !model_.is_kinematic[i]) V -= model_.mass[i] * settings_.gravity.dot(state_.p[i]);
  return V;
}

}  // namespace signorini
