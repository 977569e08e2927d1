// What both contact solvers share (docs/conventions.md, "One step", step 3): the rows of a
// contact, their solve order and warm start, one contact's rows in a sweep, restitution, and the
// store stage that writes forces, the next warm-start cache and the certificate. The lecture's PGS
// (contact_solver.cpp) and the soft step (soft_step.cpp) are two schedules of these stages.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "parallel/pool.hpp"
#include "parallel/prefetch.hpp"
#include "solver/contact_solver.hpp"

namespace signorini::solver::rows {

using Velocities = std::vector<BodyVelocity>;

/// Contacts per task below which a colour is not split over threads (a task costs about as much
/// as this many contacts' rows).
constexpr std::size_t kContactsPerTask = 256;

/// Contacts ahead of the one in hand whose scattered outputs a loop asks the memory for.
constexpr std::size_t kAhead = 8;
/// The bytes of a Contact its key (bodies and features) spans, from its start.
constexpr std::size_t kContactKeyBytes = offsetof(Contact, feature_b) + sizeof(FeatureId);
/// The memory hints (parallel/prefetch.hpp), for loops that reach their items out of order (by
/// solve position, or the other way), which the processor cannot foresee, kAhead items early, and
/// for walks in order (kWalkAhead).
using parallel::kWalkAhead;
using parallel::prefetch_read;
using parallel::prefetch_write;

/// f(begin, end) over [0, n) on d.pool's threads (the calling thread alone without a pool), for
/// work whose items write only their own outputs.
template <class F>
void for_ranges(const SolverData& d, std::size_t n, std::size_t grain, F&& f) {
  parallel::for_ranges(d.pool, n, grain, f);
}

/// sweep(begin, end) over the solve positions [0, K), K = d.rows.size(), in solve order colour by
/// colour; each colour (whose units share no moving body) cut into the blocks of solve_order
/// (at least kContactsPerTask contacts, never splitting a unit or a WideGroup) that d.pool's threads
/// claim in order from one counter, and the shared last colour (whose contacts may share a body)
/// one block, so that every thread count gives the bits of one thread. A thread that claims a
/// block of colour c first waits until every block of the colours before c is done (each was
/// claimed, so a running thread is finishing it: a thread alone finishes the sweep). One job per
/// sweep, not one per colour: the threads stay in it from colour to colour, as in Box2D v3's
/// solver stages, instead of being woken up some 30 times a sweep. sweep returns the largest
/// change of its positions; returns the largest over all.
template <class Sweep>
double by_colour(const SolverData& d, Sweep&& sweep) {
  const std::size_t K = d.rows.size();
  if (d.pool == nullptr || d.pool->threads() <= 1 || K <= kContactsPerTask) return sweep(std::size_t(0), K);
  const std::size_t colours = d.colour_start.size() - 1;
  const std::size_t total = d.block_start.size() - 1;
  std::atomic<std::size_t> next{0}, done{0};
  double change = 0.0;
  std::mutex joined;  // only the participants' maxima meet here (a max: the order does not matter)
  d.pool->join([&](std::size_t) {
    double m = 0.0;
    std::size_t c = 0;
    for (std::size_t b = next.fetch_add(1, std::memory_order_relaxed); b < total;
         b = next.fetch_add(1, std::memory_order_relaxed)) {
      while (static_cast<std::size_t>(d.colour_block[c + 1]) <= b && c + 1 < colours) ++c;  // blocks are claimed in increasing order
      const std::size_t before = static_cast<std::size_t>(d.colour_block[c]);
      for (int spin = 0; done.load(std::memory_order_acquire) < before; ++spin) parallel::back_off(spin);
      m = std::max(m, sweep(static_cast<std::size_t>(d.block_start[b]), static_cast<std::size_t>(d.block_start[b + 1])));
      done.fetch_add(1, std::memory_order_release);
    }
    const std::lock_guard<std::mutex> lock(joined);
    change = std::max(change, m);
  });
  return change;
}

/// v.assign(n, x), growing the capacity geometrically: a contact count that creeps up one at a time
/// (a pile settling) then reallocates a handful of times, not at every new high.
template <class T>
void assign_n(std::vector<T>& v, std::size_t n, const T& x) {
  if (n > v.capacity()) v.reserve(std::max(n, 2 * v.capacity()));
  v.assign(n, x);
}

/// v_B + omega_B x r_b - (v_A + omega_A x r_a): the relative velocity at the contact (m/s, world);
/// row k's velocity J_k q_dot is its component along d_k.
inline Vec3 point_velocity(const ContactRows& c, const BodyVelocity& A, const BodyVelocity& B) {
  return (B.v + B.omega.cross(c.r_b)) - (A.v + A.omega.cross(c.r_a));
}

/// J_n q_dot (m/s), the normal row's velocity.
inline double normal_velocity(const ContactRows& c, const BodyVelocity& A, const BodyVelocity& B) {
  return c.n.dot(point_velocity(c, A, B));
}

inline double normal_velocity(const ContactRows& c, const Velocities& qd) { return normal_velocity(c, qd[c.a], qd[c.b]); }

/// q_dot_X += sum_k d_alpha_k dt M_X^-1 J_X,k for the force changes whose sum along the rows'
/// directions is P (N; on B, -P on A): B.omega += dt I_B^-1 (r_b x P), B.v += dt m_B^-1 P, A the
/// opposite way. dI holds dt I_X^-1 per body. A body that does not move is skipped rather than
/// given 0 * P, which an overflowing force would turn into NaN.
[[gnu::always_inline]] inline void push(const ContactRows& c, const Mat3* dI, const Vec3& P, BodyVelocity& A,
                                        BodyVelocity& B) {
  if (c.a_moves) {
    A.omega -= dI[c.a] * c.r_a.cross(P);
    A.v -= c.dinv_mass_a * P;
  }
  if (c.b_moves) {
    B.omega += dI[c.b] * c.r_b.cross(P);
    B.v += c.dinv_mass_b * P;
  }
}

/// A spin row's velocity n . (omega_B - omega_A) (rad/s).
inline double spin_velocity(const SpinRow& q, const BodyVelocity& A, const BodyVelocity& B) {
  return q.n.dot(B.omega) - q.n.dot(A.omega);
}

/// omega_X += d_tau dt I_X^-1 J_X_ang for a spin row's torque change d_tau (N m), on the bodies
/// of its contact c that move.
inline void apply_spin(const SpinRow& q, const ContactRows& c, double d_tau, BodyVelocity& A, BodyVelocity& B) {
  if (c.a_moves) A.omega += d_tau * q.dMJA_ang;
  if (c.b_moves) B.omega += d_tau * q.dMJB_ang;
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

/// One normal-row update alone: gamma = J_n q_dot - delta alpha + bias, alpha <- max(-gamma / delta, 0).
/// Returns delta |d_alpha| (m/s).
inline double update_normal(const ContactRows& c, const Mat3* dI, double bias, double& alpha, BodyVelocity& A,
                            BodyVelocity& B) {
  if (!(c.delta[0] > 0.0)) return 0.0;  // both bodies static: never produced by the narrow phase
  // the row's own terms first, so that only one addition waits for the velocities
  const double gamma = normal_velocity(c, A, B) + (bias - c.delta[0] * alpha);
  const double alpha_new = std::max(-gamma * c.inv_delta[0], 0.0);
  const double d_alpha = alpha_new - alpha;
  if (d_alpha == 0.0) return 0.0;
  alpha = alpha_new;
  push(c, dI, d_alpha * c.n, A, B);
  return c.delta[0] * std::abs(d_alpha);
}

inline double update_normal(const ContactRows& c, const Mat3* dI, double bias, double& alpha, Velocities& qd) {
  return update_normal(c, dI, bias, alpha, qd[c.a], qd[c.b]);
}

/// A friction bound of 0 projects any friction force to 0: the forces alpha[1], alpha[2] go to 0,
/// their changes into d1, d2.
inline void drop_friction(double* alpha, double& d1, double& d2) {
  d1 = -alpha[1];
  d2 = -alpha[2];
  alpha[1] = alpha[2] = 0.0;
}

/// One contact's three rows in a sweep (normal, then its two friction rows) on the velocities A, B
/// of its bodies; change = max(change, the rows' delta |d_alpha|).
/// This is the lecture's Gauss-Seidel order, row after row, written so that the three rows do not
/// wait on each other through the body velocities: the relative velocity at the point is read from
/// A and B once, each later row adds the changes of the rows before it through the Delassus entries
/// W_jk, and the three force changes reach A and B together at the end, as one impulse. Same sums,
/// other rounding. Always inlined, so that A and B stay in registers through the rows
/// (docs/conventions.md, "One step", 3c). dI holds dt I_X^-1 per body.
template <class Normal>
[[gnu::always_inline]] inline void contact_rows(const SolverSettings& s, const ContactRows& c, const Mat3* dI,
                                                double* alpha, BodyVelocity& A, BodyVelocity& B, double& change,
                                                const Normal& normal) {
  if (!(c.delta[0] > 0.0)) return;  // both bodies static: never produced by the narrow phase
  const Vec3 dv = point_velocity(c, A, B);
  // normal: the lecture's projection onto alpha >= 0
  // (alpha - (J q_dot + b) / delta is -gamma / delta of the lecture, with gamma = J q_dot + b - delta alpha)
  const double a0 = normal.next(c, c.n.dot(dv), alpha[0]);
  const double d0 = a0 - alpha[0];
  alpha[0] = a0;
  // friction: Coulomb, bounded by mu times the current normal force
  const double bound = c.mu * a0;
  double d1 = 0.0, d2 = 0.0;
  if (bound == 0.0) {
    // (a separating or speculative contact: the friction rows' velocities are not needed)
    drop_friction(alpha, d1, d2);
  } else if (c.delta[1] > 0.0) {
    // A and B are untouched so far: the rows read the velocity the normal row read
    const double u1 = c.t1.dot(dv) + c.W_1n * d0;
    if (s.friction_cone == FrictionCone::Cone) {
      // one scale for both rows, so that the projection onto the disk acts on the slip itself
      // (with each row's own delta the converged friction opposes a scaled slip, not the slip)
      const double u2 = c.t2.dot(dv) + c.W_2n * d0;
      const double delta_t = std::max(c.delta[1], c.delta[2]);
      double a1 = alpha[1] - u1 / delta_t;
      double a2 = alpha[2] - u2 / delta_t;
      clamp_to_disk(a1, a2, bound);
      d1 = a1 - alpha[1];
      d2 = a2 - alpha[2];
      alpha[1] = a1;
      alpha[2] = a2;
    } else {
      const double a1 = std::clamp(alpha[1] - u1 * c.inv_delta[1], -bound, bound);
      d1 = a1 - alpha[1];
      alpha[1] = a1;
      const double u2 = c.t2.dot(dv) + (c.W_2n * d0 + c.W_21 * d1);
      const double a2 = std::clamp(alpha[2] - u2 * c.inv_delta[2], -bound, bound);
      d2 = a2 - alpha[2];
      alpha[2] = a2;
    }
  }
  change = std::max({change, c.delta[0] * std::abs(d0), c.delta[1] * std::abs(d1), c.delta[2] * std::abs(d2)});
  if (d0 == 0.0 && d1 == 0.0 && d2 == 0.0) return;
  push(c, dI, d0 * c.n + d1 * c.t1 + d2 * c.t2, A, B);
}

/// A spin row in a sweep, after its contact's three rows have moved A and B (plain Gauss-Seidel:
/// it reads their velocities as those rows left them): torsional friction, bounded by mu_spin
/// times the contact's current normal force alpha_n,
///   tau <- clamp(tau - n . (omega_B - omega_A) / delta, -mu_spin alpha_n, mu_spin alpha_n).
/// change = max(change, delta |d_tau|) (rad/s).
[[gnu::always_inline]] inline void spin_row(const SpinRow& q, const ContactRows& c, double alpha_n, double& tau,
                                            BodyVelocity& A, BodyVelocity& B, double& change) {
  const double bound = q.mu_spin * alpha_n;
  // a zero bound (a separating or speculative contact) projects any torque to 0
  const double t = bound == 0.0 ? 0.0 : std::clamp(tau - spin_velocity(q, A, B) * q.inv_delta, -bound, bound);
  const double d_tau = t - tau;
  if (d_tau == 0.0) return;
  tau = t;
  apply_spin(q, c, d_tau, A, B);
  change = std::max(change, q.delta * std::abs(d_tau));
}

/// The end of contact k's turn in a sweep: its spin row (kSpin: some contacts have one), then A
/// and B stored back for the bodies that move.
template <bool kSpin>
[[gnu::always_inline]] inline void finish_contact(SolverData& d, std::size_t k, const ContactRows& c,
                                                  const double* alpha, BodyVelocity& A, BodyVelocity& B,
                                                  double& change) {
  if constexpr (kSpin) {
    const int j = d.spin_slot[k];
    if (j >= 0) spin_row(d.spin_rows[j], c, alpha[0], d.spin_alpha[j], A, B, change);
  }
  if (c.a_moves) d.qd[c.a] = A;
  if (c.b_moves) d.qd[c.b] = B;
}

/// The lecture's normal row: alpha <- max(alpha - (J q_dot + b) / delta, 0) with b the row's own
/// bias (alpha - (J q_dot + b) / delta is -gamma / delta of the lecture, with
/// gamma = J q_dot + b - delta alpha).
struct HardNormal {
  double next(const ContactRows& c, double vn, double alpha) const {
    return std::max(alpha - (vn + c.bias) * c.inv_delta[0], 0.0);
  }
};

/// A soft normal row (docs/conventions.md, "The soft step"): the spring-damper's bias b and its
/// mass and impulse scales, alpha <- max(alpha - (mass_scale J q_dot + b) / delta
/// - impulse_scale alpha, 0). mass_scale 1 and impulse_scale 0 give the hard row with bias b.
struct SoftNormal {
  double bias = 0.0, mass_scale = 1.0, impulse_scale = 0.0;
  double next(const ContactRows& c, double vn, double alpha) const {
    return std::max(alpha - (mass_scale * vn + bias) * c.inv_delta[0] - impulse_scale * alpha, 0.0);
  }
};

/// The coupling of the normal rows of two contacts c1, c2 of one body pair (s/kg):
/// K12 = dt J_n1 M^-1 J_n2^T = (dt / m_A + dt / m_B) n1 . n2 + (r_a1 x n1) . dt I_A^-1 (r_a2 x n2)
/// + (r_b1 x n1) . dt I_B^-1 (r_b2 x n2), a body that does not move adding nothing. dI holds dt I_X^-1.
inline double normal_coupling(const ContactRows& c1, const ContactRows& c2, const Mat3* dI) {
  double K12 = (c1.dinv_mass_a + c1.dinv_mass_b) * c1.n.dot(c2.n);
  if (c1.a_moves) K12 += c1.r_a.cross(c1.n).dot(dI[c1.a] * c2.r_a.cross(c2.n));
  if (c1.b_moves) K12 += c1.r_b.cross(c1.n).dot(dI[c1.b] * c2.r_b.cross(c2.n));
  return K12;
}

/// The two normal rows of a two-point pair as one block: the new forces y >= 0 with
/// w = K' y - c >= 0 and y_i w_i = 0 (K' = [[K11, K12], [K21, K22]], s/kg: the pair's Delassus
/// block with each row's coupling scaled by its soft rule's mass scale, pair_side; c m/s), by
/// Box2D v2's cases in turn: both rows push (y = K'^-1 c, when det K' >= kPairConditioning K11 K22),
/// only the first (y1 = c1 / K11, w2 = K21 y1 - c2 >= 0), only the second, neither (c <= 0). K' is
/// a P-matrix (a positive diagonal times a positive definite matrix), so one of them holds; at a
/// case's edge, where rounding may reject every one, the first row alone pushes. The lanes repeat
/// these operations (wide_kernel.hpp).
inline void solve_pair(double K11, double K22, double K12, double K21, double c1, double c2, double& y1, double& y2) {
  const double det = K11 * K22 - K12 * K21;
  if (det >= kPairConditioning * (K11 * K22)) {
    y1 = (K22 * c1 - K12 * c2) / det;
    y2 = (K11 * c2 - K21 * c1) / det;
    if (y1 >= 0.0 && y2 >= 0.0) return;
  }
  const double z1 = c1 / K11, z2 = c2 / K22;
  if (z1 >= 0.0 && K21 * z1 - c2 >= 0.0) {
    y1 = z1, y2 = 0.0;
  } else if (z2 >= 0.0 && K12 * z2 - c1 >= 0.0) {
    y1 = 0.0, y2 = z2;
  } else if (c1 <= 0.0 && c2 <= 0.0) {
    y1 = 0.0, y2 = 0.0;
  } else {
    y1 = std::max(z1, 0.0), y2 = 0.0;
  }
}

/// Row i of a two-point pair's block (solve_pair) by its soft rule (SoftNormal: bias b, mass_scale
/// ms, impulse_scale): the row's own rule, K_ii (y_i - alpha_i) = -(ms vn_i + b) - impulse_scale
/// K_ii alpha_i, with its velocity vn_i seeing the other row's change too, vn_i + K_ij (y_j -
/// alpha_j):
///   K_ii (y_i - alpha_i) + ms K_ij (y_j - alpha_j) = -(ms vn_i + b) - impulse_scale K_ii alpha_i
/// (alpha the forces before the sweep). Returns K'_ij = ms K_ij into *coupling and
/// c_i = (K_ii alpha_i + K'_ij alpha_j) - impulse_scale (K_ii alpha_i) - (ms vn_i + b).
inline double pair_side(double K_ii, double K_ij, double alpha_i, double alpha_j, double vn, const SoftNormal& rule,
                        double* coupling) {
  *coupling = rule.mass_scale * K_ij;
  const double own = K_ii * alpha_i;
  return ((own + *coupling * alpha_j) - rule.impulse_scale * own) - (rule.mass_scale * vn + rule.bias);
}

/// The solve order and the rows: d.order, d.slot, d.rows (a contact's normal, t1 and t2 rows,
/// in solve order, dt folded in), d.alpha zeroed, by solve position u_i = J_n q_dot (from d.qd;
/// 0 for a contact with e_i = 0, which never reads it) and e_i, and the spin rows. A normal row's
/// bias is max(gap, 0) / dt (a speculative contact closes its gap, no more). d.dI_inv must hold
/// dt I_X^-1 per body.
/// With `recall` (the soft step's warm start), d.alpha and d.spin_alpha also take the recalled
/// forces (recall_forces, the same bits) as each contact's rows are made, in the same pass. With
/// `springs` (the soft step: springs[0] between two moving bodies, springs[1] against one that does
/// not move), d.soft takes each contact's soft point there too: its spring, its gap and a round
/// side's core offset (SoftPoint).
void prepare(const Model& model, const State& state, double dt, const std::vector<Contact>& contacts,
             const std::vector<Vec3>* anchor_a, const std::vector<Vec3>* anchor_b, SolverData& d,
             Order order = Order::ByContact, const SolverSettings* recall = nullptr,
             const SoftPoint* springs = nullptr);

/// d.alpha (and d.spin_alpha) from the previous step's cache d.cache, matched by key and clamped
/// to the friction set. Returns whether any contact found its entry.
bool recall_forces(const SolverSettings& s, const std::vector<Contact>& contacts, SolverData& d);

/// Applies every row's force d.alpha (and spin torque) to d.qd, in solve order.
void apply_forces(SolverData& d);

/// apply_forces for the contact at solve position k: its three forces as one impulse, then its
/// spin torque, added to the velocities qd (d.qd, or d.kick: the next substep's warm start, summed
/// in the last relax sweep). dI holds dt I_X^-1 per body.
inline void apply_force(SolverData& d, const Mat3* dI, std::size_t k, Velocities& qd) {
  const ContactRows& c = d.rows[k];
  const double* alpha = &d.alpha[3 * k];
  if (alpha[0] != 0.0 || alpha[1] != 0.0 || alpha[2] != 0.0)
    push(c, dI, alpha[0] * c.n + alpha[1] * c.t1 + alpha[2] * c.t2, qd[c.a], qd[c.b]);
  if (!d.spin_rows.empty() && d.spin_slot[k] >= 0) {
    const std::size_t j = static_cast<std::size_t>(d.spin_slot[k]);
    if (d.spin_alpha[j] != 0.0) apply_spin(d.spin_rows[j], c, d.spin_alpha[j], qd[c.a], qd[c.b]);
  }
}
inline void apply_force(SolverData& d, const Mat3* dI, std::size_t k) { apply_force(d, dI, k, d.qd); }

/// Newton's law on the contacts flagged in d.restitutive (by solve position):
/// n^T (v_B - v_A) >= -e u, by sweeps over d.qd up to the tolerance. Returns the sweeps used.
int restitution(const SolverSettings& s, SolverData& d);

/// Forces and velocities per contact (from d.alpha and d.qd), summed forces per body, the next
/// cache (normal forces d.alpha_iter), the certificate (against each row's bias, or e u for a
/// restitutive contact; its violation maxima at least 0). c.impulse = dt alpha, or with soft (the
/// soft step's points, by solve position) the impulse summed over its substeps, and the bias
/// max(s, 0) / dt of each point's gap s at the step's end instead of the row's.
/// report = false (a run of the soft step's rows that another follows in the same step): only each
/// contact's alpha, friction, spin_torque and impulse, d.touches and the next cache; the rest (the
/// contacts' force, velocities and slip, the bodies' sums, stats) left as they were.
void store(double dt, const SolverSettings& s, std::vector<Contact>& contacts, SolverData& d, SolverStats& stats,
           const std::vector<SoftPoint>* soft = nullptr, bool report = true);

}  // namespace signorini::solver::rows
