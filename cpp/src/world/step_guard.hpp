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
namespace parallel { class Pool; }

class StepGuard {
 public:
  /// Checkpoint at the start of a step (before the pending impulses): keeps state and contact
  /// forces in storage reused from step to step, and the cache as it is (swap_cache, keep_cache).
  /// bodies: the bodies a step can change (the World's non-static bodies, ascending; null: all),
  /// the only ones copied once a whole copy has been taken: a step never changes a static body, and
  /// whatever else changes one (a setter, a restore, bodies added or removed) calls invalidate()
  /// first. Contact forces: only the entries listed as forced (solver::SolverData::forced) when the
  /// solver has a body list. The bodies' entries (and keep_cache's copy) are copied on pool's
  /// threads (null: the calling thread alone).
  void begin(const State& state, const solver::SolverData& solver, const std::vector<BodyIndex>* bodies = nullptr,
             const parallel::Pool* pool = nullptr);
  /// The next begin() copies the whole state (a static body's state changed, or the body count).
  void invalidate() { whole_ = true; }
  /// The warm-start cache between begin() and the end of the step. begin() copies none of it: the
  /// cache the step started with stays where it is, which is never written in place while it is
  /// there (prepare reads it; store writes cache_next), until one of these two moves or changes it:
  /// swap_cache, where a run of rows ends (the solver's next cache becomes the cache: the cache the
  /// step started with goes to the guard, and the guard's spare becomes cache_next), and
  /// keep_cache, before the step changes the cache in place (a sleeping island woken merges its
  /// stashed entries into it: a copy, as rare as the wake). So a step swaps three buffers instead
  /// of copying the cache (3 MB on the 5,050-cube pyramid), and an undo puts the cache back either way.
  void swap_cache(solver::SolverData& solver);
  void keep_cache(const solver::SolverData& solver);
  /// The kinetic energy T_0 the step answers to, measured after the pending impulses. Each body's
  /// term on pool's threads (null: the calling thread alone), summed in body order on the calling
  /// thread: the same bits for every thread count.
  void measure_start(const Model& model, const State& state, const std::vector<BodyIndex>* bodies = nullptr,
                     const parallel::Pool* pool = nullptr);
  /// Checkpoint after each substep: a non-finite position, rotation or velocity undoes the step and
  /// throws, naming the first such body (of `bodies`: those the step moves; null: all).
  void check_finite(const Model& model, State& state, solver::SolverData& solver,
                    const std::vector<BodyIndex>* bodies = nullptr);
  /// Checkpoint at the end of the step: the kinetic energy T_1 against T_0 + W, W the work gravity
  /// and the external wrenches did over the step's motion, body by body where positive
  /// (docs/conventions.md, "One step"). T_1 above both kExplosionFactor (T_0 + W) and
  /// kExplosionFloor + T_0 + W undoes the step and throws, naming the bodies that gained most.
  /// Steps with a moving kinematic body are not checked: it can give any energy. Sums over
  /// `bodies` (null: all; a static body adds nothing); the terms on pool's threads, summed in body
  /// order as measure_start's.
  void check_energy(const Model& model, const Vec3& gravity, double dt, State& state, solver::SolverData& solver,
                    const std::vector<BodyIndex>* bodies = nullptr, const parallel::Pool* pool = nullptr);
  /// The state at the start of the step (before its impulses).
  const State& start() const { return before_; }

 private:
  /// Puts back what the step changed: state (in place, sleeping flags included), warm-start cache,
  /// contact forces.
  void undo(State& state, solver::SolverData& solver);

  State before_;
  bool whole_ = true;  ///< the next begin copies every body
  /// the cache the step started with, once held_ (swap_cache, keep_cache); else the spare buffer
  std::vector<CachedContact> cache_before_;
  bool held_ = false;
  const parallel::Pool* pool_ = nullptr;  ///< begin()'s, for keep_cache's copy
  /// contact forces and torques: all N (whole_forces_), or those of the bodies listed in forced_before_
  std::vector<Vec3> force_before_, torque_before_;
  std::vector<int> forced_before_;
  bool whole_forces_ = true;
  double T0_ = 0.0;
  /// per entry of the body list: its kinetic energy and its positive work (scratch of the sums)
  std::vector<double> kinetic_, work_;
};

/// Kinetic energy of body i in state s, 1/2 (m v.v + omega . I_w omega) (J); 0 for a static,
/// kinematic or disabled body.
double body_kinetic_energy(const Model& model, const State& s, std::size_t i);

}  // namespace signorini
