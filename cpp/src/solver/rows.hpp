// What both contact solvers share (docs/conventions.md, "One step", step 3): the rows of a
// contact, their solve order and warm start, one contact's rows in a sweep, restitution, and the
// store stage that writes forces, the next warm-start cache and the certificate. The lecture's PGS
// (contact_solver.cpp) and the soft step (soft_step.cpp) are two schedules of these stages.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <vector>

#include "parallel/pool.hpp"
#include "solver/contact_solver.hpp"

namespace signorini::solver::rows {

using Velocities = std::vector<BodyVelocity>;

/// Contacts per task below which a colour is not split over threads (a task costs about as much
/// as this many contacts' rows).
constexpr std::size_t kContactsPerTask = 256;

/// f(begin, end) over [0, n) on d.pool's threads (the calling thread alone without a pool), for
/// work whose items write only their own outputs.
template <class F>
void for_ranges(const SolverData& d, std::size_t n, std::size_t grain, F&& f) {
  parallel::for_ranges(d.pool, n, grain, f);
}

/// sweep(begin, end) over the solve positions [0, K), K = d.rows.size() / 3, in solve order colour by
/// colour; each colour (whose contacts share no moving body) spread over d.pool's threads, but the
/// shared last one (whose contacts may) on the calling thread, so that every thread count gives the
/// bits of one thread. sweep returns the
/// largest change of its positions; returns the largest over all.
template <class Sweep>
double by_colour(const SolverData& d, Sweep&& sweep) {
  const std::size_t K = d.rows.size() / 3;
  if (d.pool == nullptr || d.pool->threads() <= 1 || K <= kContactsPerTask) return sweep(std::size_t(0), K);
  double change = 0.0;
  std::mutex joined;  // only the tasks' maxima meet here (a max: the order they arrive in does not matter)
  const std::size_t colours = d.colour_start.size() - 1;
  for (std::size_t c = 0; c < colours; ++c) {
    const std::size_t first = static_cast<std::size_t>(d.colour_start[c]);
    const std::size_t n = static_cast<std::size_t>(d.colour_start[c + 1]) - first;
    if (c + 1 == colours) {
      if (n > 0) change = std::max(change, sweep(first, first + n));
      break;
    }
    d.pool->for_ranges(n, kContactsPerTask, [&](std::size_t b, std::size_t e) {
      const double m = sweep(first + b, first + e);
      const std::lock_guard<std::mutex> lock(joined);
      change = std::max(change, m);
    });
  }
  return change;
}

/// v.assign(n, x), growing the capacity geometrically: a contact count that creeps up one at a time
/// (a pile settling) then reallocates a handful of times, not at every new high.
template <class T>
void assign_n(std::vector<T>& v, std::size_t n, const T& x) {
  if (n > v.capacity()) v.reserve(std::max(n, 2 * v.capacity()));
  v.assign(n, x);
}

/// J q_dot = J_B . q_dot_B + J_A . q_dot_A (m/s), from A's and B's velocities.
inline double row_velocity(const Row& r, const BodyVelocity& A, const BodyVelocity& B) {
  return r.JB_ang.dot(B.omega) + r.J_lin.dot(B.v - A.v) + r.JA_ang.dot(A.omega);
}

inline double row_velocity(const Row& r, const Velocities& qd) { return row_velocity(r, qd[r.a], qd[r.b]); }

/// q_dot_X += d_alpha dt M_X^-1 J_X for both sides, for a force change d_alpha (N). Static bodies
/// are skipped rather than given 0 * d_alpha, which an overflowing d_alpha would turn into NaN.
inline void apply(const Row& r, double d_alpha, BodyVelocity& A, BodyVelocity& B) {
  if (r.a_moves) {
    A.omega += d_alpha * r.dMJA_ang;
    A.v -= (d_alpha * r.dinv_mass_a) * r.J_lin;
  }
  if (r.b_moves) {
    B.omega += d_alpha * r.dMJB_ang;
    B.v += (d_alpha * r.dinv_mass_b) * r.J_lin;
  }
}

inline void apply(const Row& r, double d_alpha, Velocities& qd) { apply(r, d_alpha, qd[r.a], qd[r.b]); }

/// A spin row's velocity n . (omega_B - omega_A) (rad/s).
inline double spin_velocity(const SpinRow& q, const BodyVelocity& A, const BodyVelocity& B) {
  return q.n.dot(B.omega) - q.n.dot(A.omega);
}

/// omega_X += d_tau dt I_X^-1 J_X_ang for a spin row's torque change d_tau (N m), on the bodies
/// of its contact's normal row r that move.
inline void apply_spin(const SpinRow& q, const Row& r, double d_tau, BodyVelocity& A, BodyVelocity& B) {
  if (r.a_moves) A.omega += d_tau * q.dMJA_ang;
  if (r.b_moves) B.omega += d_tau * q.dMJB_ang;
}

/// Scales (a1, a2) onto the disk of radius bound when it lies outside.
inline void clamp_to_disk(double& a1, double& a2, double bound) {
  const double s = std::hypot(a1, a2);
  if (s > bound) {
    const double k = s > 0.0 ? bound / s : 0.0;
    a1 *= k;
    a2 *= k;
  }
}

/// One normal-row update: gamma = J q_dot - delta alpha + bias, alpha <- max(-gamma / delta, 0).
/// Returns delta |d_alpha| (m/s).
inline double update_normal(const Row& r, double bias, double& alpha, BodyVelocity& A, BodyVelocity& B) {
  if (!(r.delta > 0.0)) return 0.0;  // both bodies static: never produced by the narrow phase
  // the row's own terms first, so that only one addition waits for the velocities
  const double gamma = row_velocity(r, A, B) + (bias - r.delta * alpha);
  const double alpha_new = std::max(-gamma * r.inv_delta, 0.0);
  const double d_alpha = alpha_new - alpha;
  if (d_alpha == 0.0) return 0.0;
  alpha = alpha_new;
  apply(r, d_alpha, A, B);
  return r.delta * std::abs(d_alpha);
}

inline double update_normal(const Row& r, double bias, double& alpha, Velocities& qd) {
  return update_normal(r, bias, alpha, qd[r.a], qd[r.b]);
}

/// One contact's three rows in a sweep (normal, then its two friction rows) on the velocities A, B
/// of its bodies; change = max(change, the rows' delta |d_alpha|).
/// This is the lecture's Gauss-Seidel order, row after row, written so that the three rows do not
/// wait on each other through the body velocities: their velocities are read from A and B once,
/// each later row adds the changes of the rows before it through the Delassus entries W_jk, and
/// the three force changes reach A and B together at the end. Same sums, other rounding.
/// Always inlined, so that A and B stay in registers through the rows (docs/conventions.md, "One
/// step", 3c).
template <class Normal>
[[gnu::always_inline]] inline void contact_rows(const SolverSettings& s, const Row* r, double* alpha,
                                                BodyVelocity& A, BodyVelocity& B, double& change,
                                                const Normal& normal) {
  if (!(r[0].delta > 0.0)) return;  // both bodies static: never produced by the narrow phase
  // normal: the lecture's projection onto alpha >= 0
  // (alpha - (J q_dot + b) / delta is -gamma / delta of the lecture, with gamma = J q_dot + b - delta alpha)
  const double a0 = normal.next(r[0], row_velocity(r[0], A, B), alpha[0]);
  const double d0 = a0 - alpha[0];
  alpha[0] = a0;
  // friction: Coulomb, bounded by mu times the current normal force
  const double bound = r[1].mu * a0;
  double d1 = 0.0, d2 = 0.0;
  if (bound == 0.0) {
    // a zero bound projects any friction force to 0 (a separating or speculative contact): the
    // friction rows' velocities are not needed
    d1 = -alpha[1];
    d2 = -alpha[2];
    alpha[1] = alpha[2] = 0.0;
  } else if (r[1].delta > 0.0) {
    // A and B are untouched so far: the rows read the velocities the normal row read
    const double v1 = row_velocity(r[1], A, B), v2 = row_velocity(r[2], A, B);
    const double u1 = v1 + r[1].W_n * d0;
    if (s.friction_cone == FrictionCone::Cone) {
      // one scale for both rows, so that the projection onto the disk acts on the slip itself
      // (with each row's own delta the converged friction opposes a scaled slip, not the slip)
      const double u2 = v2 + r[2].W_n * d0;
      const double delta_t = std::max(r[1].delta, r[2].delta);
      double a1 = alpha[1] - u1 / delta_t;
      double a2 = alpha[2] - u2 / delta_t;
      clamp_to_disk(a1, a2, bound);
      d1 = a1 - alpha[1];
      d2 = a2 - alpha[2];
      alpha[1] = a1;
      alpha[2] = a2;
    } else {
      const double a1 = std::clamp(alpha[1] - u1 * r[1].inv_delta, -bound, bound);
      d1 = a1 - alpha[1];
      alpha[1] = a1;
      const double u2 = v2 + (r[2].W_n * d0 + r[2].W_t1 * d1);
      const double a2 = std::clamp(alpha[2] - u2 * r[2].inv_delta, -bound, bound);
      d2 = a2 - alpha[2];
      alpha[2] = a2;
    }
  }
  change = std::max({change, r[0].delta * std::abs(d0), r[1].delta * std::abs(d1), r[2].delta * std::abs(d2)});
  if (d0 == 0.0 && d1 == 0.0 && d2 == 0.0) return;
  // q_dot_X += sum_k d_alpha_k dt M_X^-1 J_X,k; a body that does not move is skipped (its factors
  // times an overflowing d_alpha would give NaN)
  // (the rows share the bodies' masses: the linear parts are m^-1 times the summed force change)
  const Vec3 dP = d0 * r[0].J_lin + d1 * r[1].J_lin + d2 * r[2].J_lin;
  if (r[0].a_moves) {
    A.omega += d0 * r[0].dMJA_ang + d1 * r[1].dMJA_ang + d2 * r[2].dMJA_ang;
    A.v -= r[0].dinv_mass_a * dP;
  }
  if (r[0].b_moves) {
    B.omega += d0 * r[0].dMJB_ang + d1 * r[1].dMJB_ang + d2 * r[2].dMJB_ang;
    B.v += r[0].dinv_mass_b * dP;
  }
}

/// A spin row in a sweep, after its contact's three rows have moved A and B (plain Gauss-Seidel:
/// it reads their velocities as those rows left them): torsional friction, bounded by mu_spin
/// times the contact's current normal force alpha_n,
///   tau <- clamp(tau - n . (omega_B - omega_A) / delta, -mu_spin alpha_n, mu_spin alpha_n).
/// change = max(change, delta |d_tau|) (rad/s).
[[gnu::always_inline]] inline void spin_row(const SpinRow& q, const Row& normal, double alpha_n, double& tau,
                                            BodyVelocity& A, BodyVelocity& B, double& change) {
  const double bound = q.mu_spin * alpha_n;
  // a zero bound (a separating or speculative contact) projects any torque to 0
  const double t = bound == 0.0 ? 0.0 : std::clamp(tau - spin_velocity(q, A, B) * q.inv_delta, -bound, bound);
  const double d_tau = t - tau;
  if (d_tau == 0.0) return;
  tau = t;
  apply_spin(q, normal, d_tau, A, B);
  change = std::max(change, q.delta * std::abs(d_tau));
}

/// The end of contact k's turn in a sweep: its spin row (kSpin: some contacts have one), then A
/// and B stored back for the bodies that move.
template <bool kSpin>
[[gnu::always_inline]] inline void finish_contact(SolverData& d, std::size_t k, const Row* r, const double* alpha,
                                                  BodyVelocity& A, BodyVelocity& B, double& change) {
  if constexpr (kSpin) {
    const int j = d.spin_slot[k];
    if (j >= 0) spin_row(d.spin_rows[j], r[0], alpha[0], d.spin_alpha[j], A, B, change);
  }
  if (r[0].a_moves) d.qd[r[0].a] = A;
  if (r[0].b_moves) d.qd[r[0].b] = B;
}

/// The lecture's normal row: alpha <- max(alpha - (J q_dot + b) / delta, 0) with b the row's own
/// bias (alpha - (J q_dot + b) / delta is -gamma / delta of the lecture, with
/// gamma = J q_dot + b - delta alpha).
struct HardNormal {
  double next(const Row& r, double vn, double alpha) const { return std::max(alpha - (vn + r.bias) * r.inv_delta, 0.0); }
};

/// A soft normal row (docs/conventions.md, "The soft step"): the spring-damper's bias b and its
/// mass and impulse scales, alpha <- max(alpha - (mass_scale J q_dot + b) / delta
/// - impulse_scale alpha, 0). mass_scale 1 and impulse_scale 0 give the hard row with bias b.
struct SoftNormal {
  double bias = 0.0, mass_scale = 1.0, impulse_scale = 0.0;
  double next(const Row& r, double vn, double alpha) const {
    return std::max(alpha - (mass_scale * vn + bias) * r.inv_delta - impulse_scale * alpha, 0.0);
  }
};

/// The solve order and the rows: d.order, d.slot, d.rows (normal, t1, t2 per contact, in solve
/// order, dt folded in), d.alpha zeroed, per contact u_i = J_n q_dot (from d.qd), e_i, and the
/// spin rows. A normal row's bias is max(gap, 0) / dt (a speculative contact closes its gap, no
/// more). d.dI_inv must hold dt I_X^-1 per body.
void prepare(const Model& model, const State& state, double dt, const std::vector<Contact>& contacts,
             const std::vector<Vec3>* anchor_a, const std::vector<Vec3>* anchor_b, SolverData& d);

/// d.alpha (and d.spin_alpha) from the previous step's cache d.cache, matched by key and clamped
/// to the friction set. Returns whether any contact found its entry.
bool recall_forces(const SolverSettings& s, const std::vector<Contact>& contacts, SolverData& d);

/// Applies every row's force d.alpha (and spin torque) to d.qd, in solve order.
void apply_forces(SolverData& d);

/// Newton's law on the contacts flagged in d.restitutive (contact order):
/// n^T (v_B - v_A) >= -e u, by sweeps over d.qd up to the tolerance. Returns the sweeps used.
int restitution(const SolverSettings& s, SolverData& d);

/// Forces and velocities per contact (from d.alpha and d.qd), summed forces per body, the next
/// cache (normal forces d.alpha_iter), the certificate (against each row's bias, or e u for a
/// restitutive contact; its violation maxima at least 0). c.impulse = dt alpha.
void store(double dt, const SolverSettings& s, std::vector<Contact>& contacts, SolverData& d, SolverStats& stats);

}  // namespace signorini::solver::rows
