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
  rows::SoftNormal normal;
  if (p.s > 0.0) {
    normal.bias = p.s * x.inv_h;
  } else if (x.biased) {
    // the spring on the whole overlap (no slop: the relax sweeps keep a resting contact still)
    normal.bias = std::max(p.mass_scale * p.bias_rate * p.s, -x.max_push_velocity);
    normal.mass_scale = p.mass_scale;
    normal.impulse_scale = p.impulse_scale;
  }
  BodyVelocity A = d.qd[r.a], B = d.qd[r.b];
  double change = 0.0;  // not used: the soft step runs a fixed number of sweeps
  rows::contact_rows(s, r, d.dI_inv.data(), alpha, A, B, change, normal);
  rows::finish_contact<kSpin>(d, k, r, alpha, A, B, change);
  // the next substep's warm start of this contact, as its forces leave the sweep (SoftSweep::kick)
  if (x.kick) rows::apply_force(d, d.dI_inv.data(), k, d.kick);
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
