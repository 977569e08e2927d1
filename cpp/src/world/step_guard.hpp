// The step's guard: what a step may not keep, checked at fixed checkpoints (after Rapier's
// quarantine). At the start of a step it keeps what an undo puts back (the state, the warm-start
// cache, the contact forces and torques); after each substep it refuses a non-finite pose or
// velocity; at the end it refuses an energy explosion (World::kExplosionFactor, kExplosionFloor).
// A refused step is undone and reported as std::runtime_error naming the body or bodies.
#pragma once

#include <vector>

#include "signorini/contact.hpp"
#include "signorini/model.hpp"
#include "signorini/state.hpp"
#include "signorini/types.hpp"

namespace signorini {

namespace solver { struct SolverData; }

class StepGuard {
 public:
  /// Checkpoint at the start of a step (before the pending impulses): keeps state, cache and
  /// contact forces in storage reused from step to step.
  void begin(const State& state, const solver::SolverData& solver);
  /// The kinetic energy T_0 the step answers to, measured after the pending impulses.
  void measure_start(const Model& model, const State& state);
  /// Checkpoint after each substep: a non-finite position, rotation or velocity undoes the step and
  /// throws, naming the first such body.
  void check_finite(const Model& model, State& state, solver::SolverData& solver);
  /// Checkpoint at the end of the step: the kinetic energy T_1 against T_0 + W, W the work gravity
  /// and the external wrenches did over the step's motion, body by body where positive
  /// (docs/conventions.md, "One step"). T_1 above both kExplosionFactor (T_0 + W) and
  /// kExplosionFloor + T_0 + W undoes the step and throws, naming the bodies that gained most.
  /// Steps with a moving kinematic body are not checked: it can give any energy.
  void check_energy(const Model& model, const Vec3& gravity, double dt, State& state, solver::SolverData& solver);
  /// The state at the start of the step (before its impulses).
  const State& start() const { return before_; }

 private:
  /// Puts back what the step changed: state (in place, sleeping flags included), warm-start cache,
  /// contact forces.
  void undo(State& state, solver::SolverData& solver);

  State before_;
  std::vector<CachedContact> cache_before_;
  std::vector<Vec3> force_before_, torque_before_;
  double T0_ = 0.0;
};

/// Kinetic energy of body i in state s, 1/2 (m v.v + omega . I_w omega) (J); 0 for a static,
/// kinematic or disabled body.
double body_kinetic_energy(const Model& model, const State& s, std::size_t i);

}  // namespace signorini
