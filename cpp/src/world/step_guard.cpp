#include "world/step_guard.hpp"

#include <algorithm>
#include <array>
#include <sstream>
#include <stdexcept>
#include <string>

#include "signorini/world.hpp"
#include "solver/contact_solver.hpp"
#include "world/checks.hpp"

namespace signorini {

double body_kinetic_energy(const Model& model, const State& s, std::size_t i) {
  if (model.is_static[i] || model.is_kinematic[i] || !model.enabled[i]) return 0.0;
  const Vec3& w = s.omega[i];
  return 0.5 * model.mass[i] * s.v[i].squaredNorm() + 0.5 * w.dot(s.R[i] * (model.I_body[i] * (s.R[i].transpose() * w)));
}

void StepGuard::begin(const State& state, const solver::SolverData& solver) {
  before_ = state;
  // copied into kept storage, grown geometrically (a copy assignment allocates the exact size)
  if (cache_before_.capacity() < solver.cache.size()) cache_before_.reserve(2 * solver.cache.size());
  cache_before_ = solver.cache;
  force_before_ = solver.body_force;
  torque_before_ = solver.body_torque;
}

void StepGuard::measure_start(const Model& model, const State& state) {
  T0_ = 0.0;
  for (std::size_t i = 0; i < model.size(); ++i) T0_ += body_kinetic_energy(model, state, i);
}

void StepGuard::undo(State& state, solver::SolverData& solver) {
  state.for_each_array_with(before_, [](auto& mine, const auto& saved) { checks::copy_into(mine, saved); });
  state.time = before_.time;
  // islands woken by the step sleep again (their stashed forces are still stashed)
  checks::copy_into(state.awake, before_.awake);
  checks::copy_into(state.sleep_time, before_.sleep_time);
  checks::copy_into(state.island, before_.island);
  solver.cache.swap(cache_before_);
  solver.body_force.swap(force_before_);
  solver.body_torque.swap(torque_before_);
}

void StepGuard::check_finite(const Model& model, State& state, solver::SolverData& solver) {
  for (std::size_t i = 0; i < model.size(); ++i) {
    if (state.p[i].allFinite() && state.v[i].allFinite() && state.omega[i].allFinite() && state.R[i].allFinite())
      continue;
    undo(state, solver);
    throw std::runtime_error(checks::body_label(model, static_cast<BodyIndex>(i)) +
                             ": state became non-finite at t = " + std::to_string(before_.time) +
                             "; the step was undone (check forces, masses and dt)");
  }
}

void StepGuard::check_energy(const Model& model, const Vec3& gravity, double dt, State& state,
                             solver::SolverData& solver) {
  // a moving kinematic body is a source of energy the balance cannot bound
  for (std::size_t i = 0; i < model.size(); ++i)
    if (model.is_kinematic[i] && model.enabled[i] && (state.v[i].squaredNorm() > 0.0 || state.omega[i].squaredNorm() > 0.0))
      return;
  // W counted only where positive: the position pass lifts bodies without giving them kinetic
  // energy, and a heavy body lifted out of an overlap must not hide another's fall
  double T1 = 0.0, W = 0.0;
  for (std::size_t i = 0; i < model.size(); ++i) {
    if (model.is_static[i] || model.is_kinematic[i] || !model.enabled[i]) continue;
    T1 += body_kinetic_energy(model, state, i);
    const Vec3 f = model.mass[i] * gravity + before_.f_ext[i] + before_.f_step[i];
    const Vec3 tau = before_.tau_ext[i] + before_.tau_step[i];
    W += std::max(0.0, f.dot(state.p[i] - before_.p[i]) + tau.dot(before_.omega[i] + state.omega[i]) * 0.5 * dt);
  }
  const double budget = T0_ + W;
  if (!(T1 > World::kExplosionFactor * budget && T1 - budget > World::kExplosionFloor)) return;
  // name the bodies that gained the most, largest first (at most 3)
  std::array<std::pair<double, std::size_t>, 3> worst{};
  for (std::size_t i = 0; i < model.size(); ++i) {
    if (model.is_static[i]) continue;
    const double gained = body_kinetic_energy(model, state, i) - body_kinetic_energy(model, before_, i);
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
