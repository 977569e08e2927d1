#include "solver/contact_solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dynamics/rigid_body.hpp"

namespace signorini::solver {
namespace {

/// Below this slip speed (m/s) a contact counts as sticking for the maximum-dissipation check.
constexpr double kSlidingSpeed = 1e-3;

bool key_less(const CachedContact& x, const CachedContact& y) {
  if (x.body_a != y.body_a) return x.body_a < y.body_a;
  if (x.body_b != y.body_b) return x.body_b < y.body_b;
  if (x.feature_a != y.feature_a) return x.feature_a < y.feature_a;
  return x.feature_b < y.feature_b;
}

bool same_key(const CachedContact& x, const CachedContact& y) { return !key_less(x, y) && !key_less(y, x); }

/// J q_dot = J_B . q_dot_B + J_A . q_dot_A (m/s).
double row_velocity(const Row& r, const std::vector<Vec3>& v, const std::vector<Vec3>& omega) {
  return r.JB_ang.dot(omega[r.b]) + r.JB_lin.dot(v[r.b]) + r.JA_ang.dot(omega[r.a]) + r.JA_lin.dot(v[r.a]);
}

/// q_dot_X += s M_X^-1 J_X for both sides, s = dt d_alpha (N s). Static bodies are skipped rather
/// than given 0 * s, which an overflowing s would turn into NaN.
void apply(const Row& r, double s, std::vector<Vec3>& v, std::vector<Vec3>& omega) {
  if (r.a_moves) {
    omega[r.a] += s * r.MJA_ang;
    v[r.a] += s * r.MJA_lin;
  }
  if (r.b_moves) {
    omega[r.b] += s * r.MJB_ang;
    v[r.b] += s * r.MJB_lin;
  }
}

/// The row of direction d (unit, world) between bodies a and b, acting at y_a on A and y_b on B:
/// J_A = -(r_A x d, d), J_B = (r_B x d, d), r_X = y_X - p_X, delta = dt (J_A M_A^-1 J_A + J_B M_B^-1 J_B).
void make_row(const Model& model, const State& state, const Mat3& IinvA, const Mat3& IinvB, int a, int b,
              const Vec3& y_a, const Vec3& y_b, const Vec3& d, double dt, Row& r) {
  r.a = a;
  r.b = b;
  r.a_moves = !model.is_static[a];
  r.b_moves = !model.is_static[b];
  r.JA_ang = -(y_a - state.p[a]).cross(d);
  r.JA_lin = -d;
  r.JB_ang = (y_b - state.p[b]).cross(d);
  r.JB_lin = d;
  r.MJA_ang = IinvA * r.JA_ang;
  r.MJA_lin = model.inv_mass[a] * r.JA_lin;
  r.MJB_ang = IinvB * r.JB_ang;
  r.MJB_lin = model.inv_mass[b] * r.JB_lin;
  r.delta = dt * (r.JB_ang.dot(r.MJB_ang) + r.JB_lin.dot(r.MJB_lin) + r.JA_ang.dot(r.MJA_ang) +
                  r.JA_lin.dot(r.MJA_lin));
  r.bias = 0.0;
  r.normal = -1;
  r.mu = 0.0;
}

/// Scales (a1, a2) onto the disk of radius bound when it lies outside.
void clamp_to_disk(double& a1, double& a2, double bound) {
  const double s = std::hypot(a1, a2);
  if (s > bound) {
    const double k = s > 0.0 ? bound / s : 0.0;
    a1 *= k;
    a2 *= k;
  }
}

// ---- a. prepare ---------------------------------------------------------------------------------
/// Rows (normal, t1, t2 per contact), pair materials, and u_i = J_n q_dot* (before the solve).
void prepare(const Model& model, const State& state, double dt, const std::vector<Contact>& contacts,
             const std::vector<Vec3>* anchor_a, const std::vector<Vec3>* anchor_b, const std::vector<Vec3>& v,
             const std::vector<Vec3>& omega, SolverData& d) {
  const std::size_t K = contacts.size();
  d.rows.resize(3 * K);
  d.alpha.assign(3 * K, 0.0);
  d.u.resize(K);
  d.e.resize(K);
  for (std::size_t i = 0; i < K; ++i) {
    const Contact& c = contacts[i];
    const int a = c.body_a, b = c.body_b;
    const Mat3 IinvA = dynamics::inverse_inertia_world(model, state, a);
    const Mat3 IinvB = dynamics::inverse_inertia_world(model, state, b);
    const Material& ma = model.material[a];
    const Material& mb = model.material[b];
    const double mu = std::sqrt(ma.friction * mb.friction);
    Vec3 t1, t2;
    tangent_basis(c.normal, t1, t2);
    Row* r = &d.rows[3 * i];
    const Vec3& y_a = anchor_a ? (*anchor_a)[i] : c.point;
    const Vec3& y_b = anchor_b ? (*anchor_b)[i] : c.point;
    make_row(model, state, IinvA, IinvB, a, b, y_a, y_b, c.normal, dt, r[0]);
    make_row(model, state, IinvA, IinvB, a, b, y_a, y_b, t1, dt, r[1]);
    make_row(model, state, IinvA, IinvB, a, b, y_a, y_b, t2, dt, r[2]);
    // a speculative contact may close its gap, no more; an overlap is left to the position pass
    r[0].bias = std::max(c.gap, 0.0) / dt;
    for (int k = 1; k <= 2; ++k) {
      r[k].normal = static_cast<int>(3 * i);
      r[k].mu = mu;
    }
    d.u[i] = row_velocity(r[0], v, omega);
    d.e[i] = std::max(ma.restitution, mb.restitution);
  }
}

// ---- b. warm start ------------------------------------------------------------------------------
/// Forces of the previous step for contacts with the same key, clamped to the friction set, applied.
void warm_start(double dt, const SolverSettings& s, const std::vector<Contact>& contacts, SolverData& d,
                std::vector<Vec3>& v, std::vector<Vec3>& omega) {
  if (d.cache.empty()) return;
  d.cache_used.assign(d.cache.size(), 0);
  CachedContact key;
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const Contact& c = contacts[i];
    key.body_a = c.body_a;
    key.body_b = c.body_b;
    key.feature_a = c.feature_a;
    key.feature_b = c.feature_b;
    const auto it = std::lower_bound(d.cache.begin(), d.cache.end(), key, key_less);
    if (it == d.cache.end() || !same_key(*it, key)) continue;
    const std::size_t j = static_cast<std::size_t>(it - d.cache.begin());
    if (d.cache_used[j]) continue;  // an equal key earlier in contact order took it
    d.cache_used[j] = 1;
    const Row* r = &d.rows[3 * i];
    const double alpha_n = it->alpha;
    double a1 = it->friction.dot(r[1].JB_lin), a2 = it->friction.dot(r[2].JB_lin);
    const double bound = r[1].mu * alpha_n;
    if (s.friction_cone == FrictionCone::Cone) {
      clamp_to_disk(a1, a2, bound);
    } else {
      a1 = std::clamp(a1, -bound, bound);
      a2 = std::clamp(a2, -bound, bound);
    }
    d.alpha[3 * i] = alpha_n;
    d.alpha[3 * i + 1] = a1;
    d.alpha[3 * i + 2] = a2;
  }
  for (std::size_t k = 0; k < d.rows.size(); ++k)
    if (d.alpha[k] != 0.0) apply(d.rows[k], dt * d.alpha[k], v, omega);
}

// ---- c. iterate ---------------------------------------------------------------------------------
/// One normal-row update: gamma = J q_dot - delta alpha + bias, alpha <- max(-gamma / delta, 0).
/// Returns delta |d_alpha| (m/s).
double update_normal(const Row& r, double bias, double dt, double& alpha, std::vector<Vec3>& v,
                     std::vector<Vec3>& omega) {
  if (!(r.delta > 0.0)) return 0.0;  // both bodies static: never produced by the narrow phase
  const double gamma = row_velocity(r, v, omega) - r.delta * alpha + bias;
  const double alpha_new = std::max(-gamma / r.delta, 0.0);
  const double d_alpha = alpha_new - alpha;
  if (d_alpha == 0.0) return 0.0;
  alpha = alpha_new;
  apply(r, dt * d_alpha, v, omega);
  return r.delta * std::abs(d_alpha);
}

/// PGS sweeps over all rows (normal, then its two friction rows, contact by contact).
/// Returns the sweeps used; converged tells whether the last one met the tolerance.
int iterate(double dt, const SolverSettings& s, SolverData& d, std::vector<Vec3>& v, std::vector<Vec3>& omega,
            bool& converged) {
  const std::size_t K = d.rows.size() / 3;
  converged = K == 0;
  int sweeps = 0;
  while (!converged && sweeps < s.max_iterations) {
    ++sweeps;
    double change = 0.0;
    for (std::size_t i = 0; i < K; ++i) {
      const Row* r = &d.rows[3 * i];
      double* alpha = &d.alpha[3 * i];
      // normal: the lecture's projection onto alpha >= 0
      change = std::max(change, update_normal(r[0], r[0].bias, dt, alpha[0], v, omega));
      // friction: Coulomb, bounded by mu times the current normal force
      const double bound = r[1].mu * alpha[0];
      if (!(r[1].delta > 0.0)) continue;
      if (s.friction_cone == FrictionCone::Cone) {
        // one scale for both rows, so that the projection onto the disk acts on the slip itself
        // (with each row's own delta the converged friction opposes a scaled slip, not the slip)
        const double delta_t = std::max(r[1].delta, r[2].delta);
        double a1 = alpha[1] - row_velocity(r[1], v, omega) / delta_t;
        double a2 = alpha[2] - row_velocity(r[2], v, omega) / delta_t;
        clamp_to_disk(a1, a2, bound);
        const double d1 = a1 - alpha[1], d2 = a2 - alpha[2];
        alpha[1] = a1;
        alpha[2] = a2;
        if (d1 != 0.0) apply(r[1], dt * d1, v, omega);
        if (d2 != 0.0) apply(r[2], dt * d2, v, omega);
        change = std::max({change, r[1].delta * std::abs(d1), r[2].delta * std::abs(d2)});
      } else {
        for (int k = 1; k <= 2; ++k) {
          const double gamma = row_velocity(r[k], v, omega) - r[k].delta * alpha[k];
          const double a = std::clamp(-gamma / r[k].delta, -bound, bound);
          const double da = a - alpha[k];
          if (da == 0.0) continue;
          alpha[k] = a;
          apply(r[k], dt * da, v, omega);
          change = std::max(change, r[k].delta * std::abs(da));
        }
      }
    }
    converged = change <= s.tolerance;
  }
  return sweeps;
}

// ---- d. restitution -----------------------------------------------------------------------------
/// Newton's law on the contacts that approached faster than the threshold and pushed:
/// n^T (v_B - v_A) >= -e u. Returns the sweeps used.
int restitution(double dt, const SolverSettings& s, SolverData& d, std::vector<Vec3>& v, std::vector<Vec3>& omega) {
  const std::size_t K = d.u.size();
  d.restitutive.assign(K, 0);
  bool any = false;
  for (std::size_t i = 0; i < K; ++i) {
    d.restitutive[i] = d.e[i] > 0.0 && d.u[i] < -s.restitution_threshold && d.alpha[3 * i] > 0.0;
    any = any || d.restitutive[i];
  }
  if (!any) return 0;
  int sweeps = 0;
  bool converged = false;
  while (!converged && sweeps < s.max_iterations) {
    ++sweeps;
    double change = 0.0;
    for (std::size_t i = 0; i < K; ++i)
      if (d.restitutive[i])
        change = std::max(change, update_normal(d.rows[3 * i], d.e[i] * d.u[i], dt, d.alpha[3 * i], v, omega));
    converged = change <= s.tolerance;
  }
  return sweeps;
}

// ---- e. position pass ---------------------------------------------------------------------------
/// Split impulse: pseudo-velocities (v_p, omega_p) that remove overlaps beyond the slop (erp of the
/// excess per step, at most max_push_velocity) and carry a bounce on for the part of the step after its impact.
/// They move the poses and are then dropped, so they never add kinetic energy.
int position_pass(double dt, const SolverSettings& s, const std::vector<Contact>& contacts, SolverData& d) {
  const std::size_t K = contacts.size();
  d.b_pos.resize(K);
  bool any = false;
  for (std::size_t i = 0; i < K; ++i) {
    const double gap = contacts[i].gap;
    const double push = std::min(s.erp * std::max(-gap - s.slop, 0.0) / dt, s.max_push_velocity);
    const double bounce = d.restitutive[i] ? d.e[i] * std::max(-d.u[i] - std::max(gap, 0.0) / dt, 0.0) : 0.0;
    d.b_pos[i] = std::max(push, bounce);
    any = any || d.b_pos[i] > 0.0;
  }
  if (!any) return 0;
  d.beta.assign(K, 0.0);
  int sweeps = 0;
  bool converged = false;
  while (!converged && sweeps < s.max_iterations) {
    ++sweeps;
    double change = 0.0;
    for (std::size_t i = 0; i < K; ++i)
      change = std::max(change, update_normal(d.rows[3 * i], -d.b_pos[i], dt, d.beta[i], d.v_p, d.omega_p));
    converged = change <= s.tolerance;
  }
  return sweeps;
}

// ---- f. store -----------------------------------------------------------------------------------
/// Forces and velocities per contact, summed forces per body, the next cache, the certificate.
void store(double dt, const SolverSettings& s, std::vector<Contact>& contacts, SolverData& d,
           const std::vector<Vec3>& v, const std::vector<Vec3>& omega, SolverStats& stats) {
  const std::size_t K = contacts.size();
  d.cache_next.resize(K);
  for (std::size_t i = 0; i < K; ++i) {
    Contact& c = contacts[i];
    const Row* r = &d.rows[3 * i];
    const double* alpha = &d.alpha[3 * i];
    // forces: normal alpha n, friction alpha_t1 t1 + alpha_t2 t2 (on B; A gets the opposite)
    c.alpha = alpha[0];
    c.impulse = dt * alpha[0];
    c.friction = alpha[1] * r[1].JB_lin + alpha[2] * r[2].JB_lin;
    c.force = alpha[0] * c.normal + c.friction;
    for (int k = 0; k < 3; ++k) {
      d.body_force[r[k].a] += alpha[k] * r[k].JA_lin;
      d.body_torque[r[k].a] += alpha[k] * r[k].JA_ang;
      d.body_force[r[k].b] += alpha[k] * r[k].JB_lin;
      d.body_torque[r[k].b] += alpha[k] * r[k].JB_ang;
    }
    // velocities after the solve: normal and slip
    const double vn = row_velocity(r[0], v, omega);
    const double vt1 = row_velocity(r[1], v, omega), vt2 = row_velocity(r[2], v, omega);
    c.normal_velocity = vn;
    c.slip = vt1 * r[1].JB_lin + vt2 * r[2].JB_lin;

    // the certificate: w_i against the row's own target
    const double b = d.restitutive[i] ? d.e[i] * d.u[i] : r[0].bias;
    const double w = vn + b;
    const double mu = r[1].mu;
    stats.max_alpha_negative = std::max(stats.max_alpha_negative, -alpha[0]);
    stats.max_penetration_velocity = std::max(stats.max_penetration_velocity, -w);
    stats.max_complementarity = std::max(stats.max_complementarity, std::abs(alpha[0] * w));
    stats.max_cone_violation = std::max(stats.max_cone_violation, c.friction.norm() - mu * alpha[0]);
    const double slip_speed = c.slip.norm();
    if (slip_speed > kSlidingSpeed)
      stats.max_dissipation_violation = std::max(stats.max_dissipation_violation,
                                                 (c.friction + (mu * alpha[0] / slip_speed) * c.slip).norm());
    stats.max_overlap = std::max(stats.max_overlap, -c.gap);
    // natural residual delta |alpha - P(alpha - w / delta)| per row
    if (r[0].delta > 0.0) {
      stats.residual = std::max(stats.residual, r[0].delta * std::abs(alpha[0] - std::max(alpha[0] - w / r[0].delta, 0.0)));
      const double bound = mu * alpha[0];
      if (s.friction_cone == FrictionCone::Cone) {
        const double delta_t = std::max(r[1].delta, r[2].delta);
        double p1 = alpha[1] - vt1 / delta_t, p2 = alpha[2] - vt2 / delta_t;
        clamp_to_disk(p1, p2, bound);
        stats.residual = std::max({stats.residual, delta_t * std::abs(alpha[1] - p1), delta_t * std::abs(alpha[2] - p2)});
      } else {
        const double p1 = std::clamp(alpha[1] - vt1 / r[1].delta, -bound, bound);
        const double p2 = std::clamp(alpha[2] - vt2 / r[2].delta, -bound, bound);
        stats.residual = std::max({stats.residual, r[1].delta * std::abs(alpha[1] - p1), r[2].delta * std::abs(alpha[2] - p2)});
      }
    }

    // the cache for the next step's warm start: the force before restitution
    CachedContact& e = d.cache_next[i];
    e.body_a = c.body_a;
    e.body_b = c.body_b;
    e.feature_a = c.feature_a;
    e.feature_b = c.feature_b;
    e.alpha = d.alpha_iter[i];
    e.friction = c.friction;
    e.order = static_cast<int>(i);
  }
  // sorted by key (first in contact order on equal keys), one entry per key
  std::sort(d.cache_next.begin(), d.cache_next.end(), [](const CachedContact& x, const CachedContact& y) {
    return key_less(x, y) || (same_key(x, y) && x.order < y.order);
  });
  d.cache_next.erase(std::unique(d.cache_next.begin(), d.cache_next.end(), same_key), d.cache_next.end());
}

}  // namespace

void tangent_basis(const Vec3& n, Vec3& t1, Vec3& t2) {
  int k = 0;
  if (std::abs(n[1]) < std::abs(n[k])) k = 1;
  if (std::abs(n[2]) < std::abs(n[k])) k = 2;
  t1 = n.cross(Vec3::Unit(k)).normalized();
  t2 = n.cross(t1);
}

SolverStats solve_contacts(const Model& model, const State& state, double dt, const SolverSettings& settings,
                           std::vector<Contact>& contacts, std::vector<Vec3>& v, std::vector<Vec3>& omega,
                           SolverData& data, const std::vector<Vec3>* anchor_a, const std::vector<Vec3>* anchor_b) {
  const std::size_t N = model.size(), K = contacts.size();
  SolverStats stats;
  stats.contacts = static_cast<int>(K);
  data.body_force.assign(N, Vec3::Zero());
  data.body_torque.assign(N, Vec3::Zero());
  data.v_p.assign(N, Vec3::Zero());
  data.omega_p.assign(N, Vec3::Zero());

  // a. prepare rows; b. warm start; c. iterate
  prepare(model, state, dt, contacts, anchor_a, anchor_b, v, omega, data);
  if (settings.warm_start) warm_start(dt, settings, contacts, data, v, omega);
  stats.iterations = iterate(dt, settings, data, v, omega, stats.converged);
  data.alpha_iter.resize(K);
  for (std::size_t i = 0; i < K; ++i) data.alpha_iter[i] = data.alpha[3 * i];
  // the poses move with the velocities of c; d changes only the kept ones
  data.v_pos = v;
  data.omega_pos = omega;
  // d. restitution; e. position pass
  stats.restitution_iterations = restitution(dt, settings, data, v, omega);
  stats.position_iterations = position_pass(dt, settings, contacts, data);
  // f. store
  store(dt, settings, contacts, data, v, omega, stats);
  stats.max_alpha_negative = std::max(stats.max_alpha_negative, 0.0);
  stats.max_penetration_velocity = std::max(stats.max_penetration_velocity, 0.0);
  stats.max_cone_violation = std::max(stats.max_cone_violation, 0.0);
  stats.max_overlap = std::max(stats.max_overlap, 0.0);
  return stats;
}

}  // namespace signorini::solver
