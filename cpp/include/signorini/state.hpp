// State: the dynamic part of a world (mjData's role), one entry per body. Written by the
// integrate stage and by the user's setters; read by collision, dynamics and the solver.
#pragma once

#include <cstdint>
#include <vector>

#include "signorini/types.hpp"

namespace signorini {

/// Python sees p, q, R, v, omega, f_ext and tau_ext without copies: each vector is N contiguous
/// entries of 3, 4 or 9 doubles (Mat3 column-major), and the World keeps their storage in place
/// while the body count does not change (steps, setters and restore_state write into it).
struct State {
  std::vector<Vec3> p;       ///< com position, world (m)                      (N)
  std::vector<Mat3> R;       ///< rotation world-from-body                      (N)
  std::vector<Quat4> q;      ///< R as a unit quaternion (w, x, y, z), w >= 0; written with R by the
                             ///< World after each step and by the setters       (N)
  std::vector<Vec3> v;       ///< p_dot, world (m/s)                            (N)
  std::vector<Vec3> omega;   ///< angular velocity, world (rad/s)               (N)
  std::vector<Vec3> f_ext;   ///< external force at the com, world (N), every step        (N)
  std::vector<Vec3> tau_ext; ///< external torque about the com, world (N m), every step  (N)
  std::vector<Vec3> f_step;  ///< force at the com, world (N), the next step only (then zeroed)  (N)
  std::vector<Vec3> tau_step;///< torque about the com, world (N m), the next step only          (N)
  std::vector<Vec3> impulse;         ///< impulse at the com, world (N s), added to m v at the start
                                     ///< of the next step (then zeroed)          (N)
  std::vector<Vec3> angular_impulse; ///< angular impulse about the com, world (N m s), likewise (N)
  double time = 0.0;         ///< s

  // Sleeping (docs/conventions.md, "Sleeping"): written by the World's islands stage (the end of a
  // step) and by its wake-ups (setters, touches); not in for_each_array (they are not vectors of
  // 3-vectors). Empty in a State built by hand, which reads as every body awake.
  std::vector<std::uint8_t> awake;  ///< 1: moves; 0: asleep (poses frozen, skipped by every stage)
                                    ///< or static (which never moves)                  (N)
  std::vector<double> sleep_time;   ///< s a dynamic body has stayed below the sleep thresholds (N)
  /// asleep: the smallest body index of the island it fell asleep with (its label); -1 otherwise (N)
  std::vector<std::int32_t> island;

  /// true when body i is asleep or static (awake is 0): nothing moves it this step.
  bool asleep(std::size_t i) const { return !awake.empty() && awake[i] == 0; }

  /// Calls f on each per-body array in the order above (p, R, q, v, omega, f_ext, tau_ext, f_step,
  /// tau_step, impulse, angular_impulse): the one list of the fields, used to add, remove, copy,
  /// save and restore bodies, so that a new field is added here only.
  template <class F>
  void for_each_array(F&& f) {
    f(p), f(R), f(q), f(v), f(omega), f(f_ext), f(tau_ext), f(f_step), f(tau_step), f(impulse), f(angular_impulse);
  }
  template <class F>
  void for_each_array(F&& f) const {
    f(p), f(R), f(q), f(v), f(omega), f(f_ext), f(tau_ext), f(f_step), f(tau_step), f(impulse), f(angular_impulse);
  }
  /// Calls f on each sleeping array (awake, sleep_time, island): added, removed, saved and restored
  /// beside the arrays above.
  template <class F>
  void for_each_sleep_array(F&& f) {
    f(awake), f(sleep_time), f(island);
  }
  /// f(mine, theirs) on each pair of matching arrays of this state and another.
  template <class F>
  void for_each_array_with(const State& other, F&& f) {
    f(p, other.p), f(R, other.R), f(q, other.q), f(v, other.v), f(omega, other.omega), f(f_ext, other.f_ext),
        f(tau_ext, other.tau_ext), f(f_step, other.f_step), f(tau_step, other.tau_step), f(impulse, other.impulse),
        f(angular_impulse, other.angular_impulse);
  }
};

}  // namespace signorini
