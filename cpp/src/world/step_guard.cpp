#include "world/step_guard.hpp"

#include <algorithm>
#include <array>
#include <sstream>
#include <stdexcept>
#include <string>

#include "signorini/world.hpp"
#include "parallel/pool.hpp"
#include "solver/contact_solver.hpp"
#include "world/checks.hpp"

namespace signorini {

double body_kinetic_energy(const Model& model, const State& s, std::size_t i) {
  if (model.is_static[i] || model.is_kinematic[i] || !model.enabled[i]) return 0.0;
  const Vec3& w = s.omega[i];
  return 0.5 * model.mass[i] * s.v[i].squaredNorm() + 0.5 * w.dot(s.R[i] * (model.I_body[i] * (s.R[i].transpose() * w)));
}

void StepGuard::begin(const State& state, const solver::SolverData& solver, const std::vector<BodyIndex>* bodies,
                      const parallel::Pool* pool) {
  const std::size_t n = state.p.size();
  if (whole_ || bodies == nullptr || before_.p.size() != n || before_.awake.size() != state.awake.size()) {
    before_ = state;
    whole_ = bodies == nullptr;
  } else {
    // the bodies a step can change (each its own entries); every other entry was copied when it
    // last changed
    parallel::for_bodies(pool, bodies, n, 1024, [&](std::size_t i) {
      before_.for_each_array_with(state, [i](auto& mine, const auto& now) { mine[i] = now[i]; });
      if (!state.awake.empty()) {
        before_.awake[i] = state.awake[i];
        before_.sleep_time[i] = state.sleep_time[i];
        before_.island[i] = state.island[i];
      }
    });
    before_.time = state.time;
  }
  held_ = false;  // the cache stays where it is (swap_cache, keep_cache)
  pool_ = pool;
  whole_forces_ = solver.bodies == nullptr || solver.is_forced.size() != solver.body_force.size();
  if (whole_forces_) {
    force_before_ = solver.body_force;
    torque_before_ = solver.body_torque;
    return;
  }
  const std::size_t m = solver.forced.size();
  if (forced_before_.capacity() < m) forced_before_.reserve(2 * m);
  if (force_before_.capacity() < m) force_before_.reserve(2 * m), torque_before_.reserve(2 * m);
  forced_before_.assign(solver.forced.begin(), solver.forced.end());
  force_before_.resize(m);
  torque_before_.resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    force_before_[k] = solver.body_force[forced_before_[k]];
    torque_before_[k] = solver.body_torque[forced_before_[k]];
  }
}

void StepGuard::swap_cache(solver::SolverData& solver) {
  solver.cache.swap(solver.cache_next);
  if (held_) return;
  // the cache the step started with is now cache_next, which the next run's store would write
  cache_before_.swap(solver.cache_next);
  held_ = true;
}

void StepGuard::keep_cache(const solver::SolverData& solver) {
  if (held_) return;
  // copied into kept storage, grown geometrically (a copy assignment allocates the exact size),
  // in ranges over the threads
  if (cache_before_.capacity() < solver.cache.size()) cache_before_.reserve(2 * solver.cache.size());
  cache_before_.resize(solver.cache.size());
  parallel::for_ranges(pool_, solver.cache.size(), 4096, [&](std::size_t first, std::size_t end) {
    std::copy(solver.cache.begin() + static_cast<std::ptrdiff_t>(first), solver.cache.begin() + static_cast<std::ptrdiff_t>(end),
              cache_before_.begin() + static_cast<std::ptrdiff_t>(first));
  });
  held_ = true;
}

void StepGuard::measure_start(const Model& model, const State& state, const std::vector<BodyIndex>* bodies,
                              const parallel::Pool* pool) {
  const std::size_t n = bodies ? bodies->size() : model.size();
  kinetic_.resize(n);
  parallel::for_ranges(pool, n, 1024, [&](std::size_t first, std::size_t end) {
    for (std::size_t k = first; k < end; ++k)
      kinetic_[k] = body_kinetic_energy(model, state, bodies ? static_cast<std::size_t>((*bodies)[k]) : k);
  });
  T0_ = 0.0;
  for (std::size_t k = 0; k < n; ++k) T0_ += kinetic_[k];
}

void StepGuard::undo(State& state, solver::SolverData& solver) {
  state.for_each_array_with(before_, [](auto& mine, const auto& saved) { checks::copy_into(mine, saved); });
  state.time = before_.time;
  // islands woken by the step sleep again (their stashed forces are still stashed)
  checks::copy_into(state.awake, before_.awake);
  checks::copy_into(state.sleep_time, before_.sleep_time);
  checks::copy_into(state.island, before_.island);
  if (held_) solver.cache.swap(cache_before_);  // (else the step has not moved or changed it)
  held_ = false;
  if (whole_forces_) {
    solver.body_force.swap(force_before_);
    solver.body_torque.swap(torque_before_);
    solver.is_forced.clear();  // any entry may be non-zero: the next step zeroes all
    solver.forced.clear();
    return;
  }
  solver::clear_body_forces(solver, solver.body_force.size());
  for (std::size_t k = 0; k < forced_before_.size(); ++k) {
    const int i = forced_before_[k];
    solver.body_force[i] = force_before_[k];
    solver.body_torque[i] = torque_before_[k];
    solver::mark_forced(solver, i);
  }
}

void StepGuard::check_finite(const Model& model, State& state, solver::SolverData& solver,
                             const std::vector<BodyIndex>* bodies) {
  const std::size_t n = bodies ? bodies->size() : model.size();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = bodies ? static_cast<std::size_t>((*bodies)[k]) : k;
    if (state.p[i].allFinite() && state.v[i].allFinite() && state.omega[i].allFinite() && state.R[i].allFinite())
      continue;
    undo(state, solver);
    throw std::runtime_error(checks::body_label(model, static_cast<BodyIndex>(i)) +
                             ": state became non-finite at t = " + std::to_string(before_.time) +
                             "; the step was undone (check forces, masses and dt)");
  }
}

void StepGuard::check_energy(const Model& model, const Vec3& gravity, double dt, State& state,
                             solver::SolverData& solver, const std::vector<BodyIndex>* bodies,
                             const parallel::Pool* pool) {
  const std::size_t n = bodies ? bodies->size() : model.size();
  const auto body = [&](std::size_t k) { return bodies ? static_cast<std::size_t>((*bodies)[k]) : k; };
  // a moving kinematic body is a source of energy the balance cannot bound
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = body(k);
    if (model.is_kinematic[i] && model.enabled[i] && (state.v[i].squaredNorm() > 0.0 || state.omega[i].squaredNorm() > 0.0))
      return;
  }
  // W counted only where positive: the position pass lifts bodies without giving them kinetic
  // energy, and a heavy body lifted out of an overlap must not hide another's fall
  // each body's terms over the threads (a body the sums skip gives 0, which adds nothing), summed
  // in body order
  kinetic_.resize(n);
  work_.resize(n);
  parallel::for_ranges(pool, n, 1024, [&](std::size_t first, std::size_t end) {
    for (std::size_t k = first; k < end; ++k) {
      const std::size_t i = body(k);
      kinetic_[k] = work_[k] = 0.0;
      if (model.is_static[i] || model.is_kinematic[i] || !model.enabled[i]) continue;
      kinetic_[k] = body_kinetic_energy(model, state, i);
      const Vec3 f = model.mass[i] * gravity + before_.f_ext[i] + before_.f_step[i];
      const Vec3 tau = before_.tau_ext[i] + before_.tau_step[i];
      work_[k] = std::max(0.0, f.dot(state.p[i] - before_.p[i]) + tau.dot(before_.omega[i] + state.omega[i]) * 0.5 * dt);
    }
  });
  double T1 = 0.0, W = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    T1 += kinetic_[k];
    W += work_[k];
  }
  const double budget = T0_ + W;
  if (!(T1 > World::kExplosionFactor * budget && T1 - budget > World::kExplosionFloor)) return;
  // name the bodies that gained the most, largest first (at most 3)
  std::array<std::pair<double, std::size_t>, 3> worst{};
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = body(k);
    if (model.is_static[i]) continue;
    const double gained = kinetic_[k] - body_kinetic_energy(model, before_, i);  // kinetic_: the sums' T_1 terms
    for (std::size_t k = 0; k < worst.size(); ++k)
      if (gained > worst[k].first) {
        for (std::size_t m = worst.size() - 1; m > k; --m) worst[m] = worst[m - 1];
        worst[k] = {gained, i};
        break;
      }
  }
  std::ostringstream s;
  s.precision(3);
  bool first = true;
  for (const auto& [gained, i] : worst) {
    if (!(gained > 0.0)) continue;
    s << (first ? "" : ", ") << checks::body_label(model, static_cast<BodyIndex>(i)) << " +" << gained << " J";
    first = false;
  }
  std::ostringstream total;
  total.precision(3);
  total << "kinetic energy rose from " << T0_ << " J to " << T1 << " J in one step at t = " << before_.time
        << " s (gravity and external forces supplied " << W << " J)";
  undo(state, solver);
  throw std::runtime_error("energy explosion: " + total.str() + "; gained most: " + s.str() +
                           "; the step was undone (check dt, masses, speeds and overlaps)");
}

}  // namespace signorini
