// One contact of the soft step in a sweep, by the scalar code (docs/conventions.md, "The soft
// step"): what the soft step's sweeps run for a contact that is in no WideGroup, and for every
// contact when the rows have spin rows or the cone friction rule (wide_rows.hpp).
#pragma once

#include <algorithm>
#include <cstddef>

#include "solver/rows.hpp"
#include "solver/wide_rows.hpp"

namespace signorini::solver {

/// Contact k's gap now, s = gap0 + n . ((dp_B + dR_B r_B) - (dp_A + dR_A r_A)): its point carried
/// with each body from the step's start (r_X the lever arm then, world; dR_X r_X = (R R0^T - I) r_X
/// how far the body's turn has moved the point), exactly gap0 until a body moves; on a round side
/// the point carried is its core (SoftPoint::sigma_a, sigma_b), whose witness stays where the
/// normal says however the body turns. Needs d.dp, d.dR.
inline double gap_now(const SolverData& d, const ContactRows& r, const SoftPoint& p) {
  const Vec3 moved_b = d.dp[r.b] + d.dR[r.b] * r.r_b;
  const Vec3 moved_a = d.dp[r.a] + d.dR[r.a] * r.r_a;
  const double s = p.gap0 + r.n.dot(moved_b - moved_a);
  if (p.sigma_a == 0.0 && p.sigma_b == 0.0) return s;
  // a round side's point is its core, sigma along n from the contact point: y_B = r_B + sigma_B n,
  // y_A = r_A - sigma_A n (the lanes add the same terms in the same order)
  const Vec3 dR_b_n = d.dR[r.b] * r.n, dR_a_n = d.dR[r.a] * r.n;
  return s + (p.sigma_b * r.n.dot(dR_b_n) + p.sigma_a * r.n.dot(dR_a_n));
}

/// The soft rule of a contact's normal row in sweep x, from its gap p.s: speculative (s > 0) the
/// rigid row closing the gap, else the spring in a biased sweep and the rigid row in a relax sweep.
inline rows::SoftNormal soft_rule(const SoftSweep& x, const SoftPoint& p) {
  rows::SoftNormal normal;
  if (p.s > 0.0) {
    normal.bias = p.s * x.inv_h;
  } else if (x.biased) {
    // the spring on the whole overlap (no slop: the relax sweeps keep a resting contact still)
    normal.bias = std::max(p.mass_scale * p.bias_rate * p.s, -x.max_push_velocity);
    normal.mass_scale = p.mass_scale;
    normal.impulse_scale = p.impulse_scale;
  }
  return normal;
}

/// The contact at solve position k in a sweep: the normal row by the soft rule (biased: the spring
/// while the contact overlaps; not biased: rigid), then its friction rows and its spin row. A
/// contact with a positive gap is rigid with the speculative bias gap / h either way. kGap: its
/// gap is brought up to date first (gap_now: the poses have moved since the last sweep), in the
/// same pass, so the rows are read once. With x.kick, its forces as they leave the sweep are also
/// added to its bodies' d.kick.
template <bool kSpin, bool kGap>
[[gnu::always_inline]] inline void soft_contact(const SolverSettings& s, const SoftSweep& x, SolverData& d,
                                                std::size_t k) {
  const ContactRows& r = d.rows[k];
  double* alpha = &d.alpha[3 * k];
  SoftPoint& p = d.soft[k];
  if constexpr (kGap) p.s = gap_now(d, r, p);
  const rows::SoftNormal normal = soft_rule(x, p);
  BodyVelocity A = d.qd[r.a], B = d.qd[r.b];
  double change = 0.0;  // not used: the soft step runs a fixed number of sweeps
  rows::contact_rows(s, r, d.dI_inv.data(), alpha, A, B, change, normal);
  rows::finish_contact<kSpin>(d, k, r, alpha, A, B, change);
  // the next substep's warm start of this contact, as its forces leave the sweep (SoftSweep::kick)
  if (x.kick) rows::apply_force(d, d.dI_inv.data(), k, d.kick);
}

/// The friction rows of the contact at solve position k after its pair's normal rows
/// (soft_pair): from the velocity at its point now, bounded by mu times its new normal force; the
/// pyramid's t2 row sees t1's change through W_21, as in contact_rows. Pushes A and B.
inline void pair_friction(const SolverSettings& s, SolverData& d, std::size_t k, BodyVelocity& A, BodyVelocity& B) {
  const ContactRows& c = d.rows[k];
  double* alpha = &d.alpha[3 * k];
  const double bound = c.mu * alpha[0];
  double d1 = 0.0, d2 = 0.0;
  if (bound == 0.0) {
    rows::drop_friction(alpha, d1, d2);
  } else if (c.delta[1] > 0.0) {
    const Vec3 dv = rows::point_velocity(c, A, B);
    if (s.friction_cone == FrictionCone::Cone) {
      const double delta_t = std::max(c.delta[1], c.delta[2]);
      double a1 = alpha[1] - c.t1.dot(dv) / delta_t;
      double a2 = alpha[2] - c.t2.dot(dv) / delta_t;
      rows::clamp_to_disk(a1, a2, bound);
      d1 = a1 - alpha[1];
      d2 = a2 - alpha[2];
      alpha[1] = a1;
      alpha[2] = a2;
    } else {
      const double a1 = std::clamp(alpha[1] - c.t1.dot(dv) * c.inv_delta[1], -bound, bound);
      d1 = a1 - alpha[1];
      alpha[1] = a1;
      const double u2 = c.t2.dot(dv) + c.W_21 * d1;
      const double a2 = std::clamp(alpha[2] - u2 * c.inv_delta[2], -bound, bound);
      d2 = a2 - alpha[2];
      alpha[2] = a2;
    }
  }
  if (d1 != 0.0 || d2 != 0.0) rows::push(c, d.dI_inv.data(), d1 * c.t1 + d2 * c.t2, A, B);
}

/// The two-point pair at solve positions k, k + 1 in a sweep (docs/conventions.md, "The soft
/// step"): both normal rows as one block (rows::solve_pair, each row's soft rule from its own gap,
/// brought up to date first with kGap), their changes applied point after point, then each
/// point's friction rows (pair_friction). Solving the normal rows one after the other, the first
/// point to stop a landing body turned it: a capsule landing flat at 20 m/s spun at 2.2 rad/s, a
/// column of two sank 2.1 cm into each other. With x.kick, the points' forces as they leave the
/// sweep are added to d.kick, point after point. Two-point pairs have no spin rows (a spin row is
/// a single point's).
template <bool kGap>
inline void soft_pair(const SolverSettings& s, const SoftSweep& x, SolverData& d, std::size_t k) {
  const ContactRows& r1 = d.rows[k];
  const ContactRows& r2 = d.rows[k + 1];
  SoftPoint& p1 = d.soft[k];
  SoftPoint& p2 = d.soft[k + 1];
  if (!(r1.delta[0] > 0.0) || !(r2.delta[0] > 0.0)) {  // both bodies static: never made by the narrow phase
    soft_contact<false, kGap>(s, x, d, k);
    soft_contact<false, kGap>(s, x, d, k + 1);
    return;
  }
  if constexpr (kGap) {
    p1.s = gap_now(d, r1, p1);
    p2.s = gap_now(d, r2, p2);
  }
  const rows::SoftNormal rule1 = soft_rule(x, p1), rule2 = soft_rule(x, p2);
  const Mat3* dI = d.dI_inv.data();
  BodyVelocity A = d.qd[r1.a], B = d.qd[r1.b];
  double* alpha1 = &d.alpha[3 * k];
  double* alpha2 = &d.alpha[3 * k + 3];
  const double vn1 = r1.n.dot(rows::point_velocity(r1, A, B)), vn2 = r2.n.dot(rows::point_velocity(r2, A, B));
  const double K11 = r1.delta[0], K22 = r2.delta[0], K12 = rows::normal_coupling(r1, r2, dI);
  double K12_soft, K21_soft;
  const double c1 = rows::pair_side(K11, K12, alpha1[0], alpha2[0], vn1, rule1, &K12_soft);
  const double c2 = rows::pair_side(K22, K12, alpha2[0], alpha1[0], vn2, rule2, &K21_soft);
  double y1, y2;
  rows::solve_pair(K11, K22, K12_soft, K21_soft, c1, c2, y1, y2);
  const double d1 = y1 - alpha1[0], d2 = y2 - alpha2[0];
  alpha1[0] = y1;
  alpha2[0] = y2;
  if (d1 != 0.0) rows::push(r1, dI, d1 * r1.n, A, B);
  if (d2 != 0.0) rows::push(r2, dI, d2 * r2.n, A, B);
  pair_friction(s, d, k, A, B);
  pair_friction(s, d, k + 1, A, B);
  if (r1.a_moves) d.qd[r1.a] = A;
  if (r1.b_moves) d.qd[r1.b] = B;
  if (x.kick) {
    rows::apply_force(d, dI, k, d.kick);
    rows::apply_force(d, dI, k + 1, d.kick);
  }
}

/// The contacts at solve positions [first, end) (whole units of the solve order by pair) in a
/// sweep, one unit after the other: a two-point pair by soft_pair, any other contact by
/// soft_contact.
template <bool kSpin, bool kGap>
inline void soft_units(const SolverSettings& s, const SoftSweep& x, SolverData& d, std::size_t first, std::size_t end) {
  for (std::size_t k = first; k < end;) {
    if (k + 1 < end && d.unit_first[k] && !d.unit_first[k + 1] && (k + 2 >= end || d.unit_first[k + 2])) {
      soft_pair<kGap>(s, x, d, k);
      k += 2;
    } else {
      soft_contact<kSpin, kGap>(s, x, d, k);
      ++k;
    }
  }
}

/// The impulse and largest normal force so far of the contact at solve position k, with this
/// substep's force.
inline void add_impulse(SolverData& d, std::size_t k) {
  SoftPoint& p = d.soft[k];
  p.impulse += d.h * d.alpha[3 * k];
  p.alpha_max = std::max(p.alpha_max, d.alpha[3 * k]);
}
/// The contact at solve position k after a substep's relax sweeps (soft_relax), with its normal
/// force alpha_n: that force kept for the warm-start cache (alpha_iter); whether it bounces now
/// (restitution: in the substep where the contact first pushes, on its approach before that push,
/// so that the rebound starts within h of the impact, not at the step's end; u becomes that
/// approach); and, unless it bounces, add_impulse (after restitution for one that does). Returns
/// whether it bounces.
inline bool settle(const SolverSettings& s, SolverData& d, std::size_t k) {
  const SoftPoint& p = d.soft[k];
  const double alpha_n = d.alpha[3 * k];
  d.alpha_iter[k] = alpha_n;
  const bool bounces = p.alpha_max == 0.0 && alpha_n > 0.0 && d.e[k] > 0.0 && p.u_before < -s.restitution_threshold;
  d.restitutive[k] = bounces;
  if (bounces) d.u[k] = p.u_before;
  else add_impulse(d, k);
  return bounces;
}

}  // namespace signorini::solver
