#include "solver/contact_solver.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "dynamics/rigid_body.hpp"

namespace signorini::solver {
namespace {

/// tangent_basis treats components of a unit normal that differ by less than this as tied.
constexpr double kTangentTie = 1e-9;

/// Below this slip speed (m/s) a contact counts as sticking for the maximum-dissipation check.
constexpr double kSlidingSpeed = 1e-3;

bool key_less(const CachedContact& x, const CachedContact& y) {
  if (x.body_a != y.body_a) return x.body_a < y.body_a;
  if (x.body_b != y.body_b) return x.body_b < y.body_b;
  if (x.feature_a != y.feature_a) return x.feature_a < y.feature_a;
  return x.feature_b < y.feature_b;
}

bool same_key(const CachedContact& x, const CachedContact& y) { return !key_less(x, y) && !key_less(y, x); }

using Velocities = std::vector<BodyVelocity>;

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

/// true when contact i is the only one of its body pair: the contact list holds each pair's
/// contacts next to each other (docs/conventions.md, "Order"), so its neighbours tell.
bool alone_in_pair(const std::vector<Contact>& contacts, std::size_t i) {
  const auto same_pair = [&](std::size_t j) {
    return contacts[j].body_a == contacts[i].body_a && contacts[j].body_b == contacts[i].body_b;
  };
  return (i == 0 || !same_pair(i - 1)) && (i + 1 == contacts.size() || !same_pair(i + 1));
}

/// The rows of one contact between bodies a and b, acting at lever arms r_a = y_a - p_a on A and
/// r_b = y_b - p_b on B, along the directions d[0..2] (unit, world; normal, t1, t2):
/// J_A = -(r_a x d, d), J_B = (r_b x d, d), delta = dt (J_A M_A^-1 J_A + J_B M_B^-1 J_B).
/// dI_inv holds dt I_X^-1 per body (world). What the rows share (bodies, masses) is read once.
void make_rows(const Model& model, const std::vector<Mat3>& dI_inv, int a, int b, const Vec3& r_a, const Vec3& r_b,
               const Vec3* d, double dt, Row* r) {
  // static and kinematic bodies have infinite mass here: contacts never change their velocities
  const bool a_moves = !model.is_static[a] && !model.is_kinematic[a];
  const bool b_moves = !model.is_static[b] && !model.is_kinematic[b];
  const double dinv_mass_a = a_moves ? dt * model.inv_mass[a] : 0.0;
  const double dinv_mass_b = b_moves ? dt * model.inv_mass[b] : 0.0;
  for (int k = 0; k < 3; ++k) {
    Row& x = r[k];
    x.a = a;
    x.b = b;
    x.a_moves = a_moves;
    x.b_moves = b_moves;
    x.J_lin = d[k];
    x.JA_ang = -r_a.cross(d[k]);
    x.JB_ang = r_b.cross(d[k]);
    x.dMJA_ang = a_moves ? Vec3(dI_inv[a] * x.JA_ang) : Vec3::Zero();
    x.dMJB_ang = b_moves ? Vec3(dI_inv[b] * x.JB_ang) : Vec3::Zero();
    x.dinv_mass_a = dinv_mass_a;
    x.dinv_mass_b = dinv_mass_b;
    x.delta = x.JB_ang.dot(x.dMJB_ang) + x.JA_ang.dot(x.dMJA_ang) + (dinv_mass_a + dinv_mass_b) * d[k].squaredNorm();
    x.inv_delta = x.delta > 0.0 ? 1.0 / x.delta : 0.0;
    x.bias = 0.0;
    x.mu = 0.0;
    x.W_n = x.W_t1 = 0.0;
  }
}

/// W_jk = dt J_j M^-1 J_k^T (s/kg) of two rows on the same bodies: how much a force change of row k
/// moves row j's velocity.
double coupling(const Row& j, const Row& k) {
  return j.JB_ang.dot(k.dMJB_ang) + j.JA_ang.dot(k.dMJA_ang) + (k.dinv_mass_a + k.dinv_mass_b) * j.J_lin.dot(k.J_lin);
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
/// The solve order (docs/conventions.md, "Solve order"): contacts coloured greedily in contact
/// order, each taking the lowest of 64 colours that none of its moving bodies has yet (the rest
/// share a 65th), then listed colour by colour, in contact order within a colour. Consecutive
/// contacts then rarely share a body, so a sweep does not wait for one contact's velocity update
/// before starting the next (the idea of Box2D v3's graph colouring, here for one thread).
/// Out: d.order (K: solve position -> contact), d.slot (K: contact -> solve position).
void solve_order(const Model& model, const std::vector<Contact>& contacts, SolverData& d) {
  const std::size_t K = contacts.size();
  constexpr int kColours = 65;
  assign_n(d.colours_used, model.size(), std::uint64_t(0));
  d.slot.resize(K);  // the colour of each contact first
  std::array<int, kColours + 1> start{};
  for (std::size_t i = 0; i < K; ++i) {
    const int a = contacts[i].body_a, b = contacts[i].body_b;
    const bool a_moves = !model.is_static[a] && !model.is_kinematic[a];
    const bool b_moves = !model.is_static[b] && !model.is_kinematic[b];
    const std::uint64_t taken = (a_moves ? d.colours_used[a] : 0) | (b_moves ? d.colours_used[b] : 0);
    int colour = kColours - 1;
    if (~taken != 0) {
      colour = 0;
      while (taken >> colour & 1) ++colour;
      if (a_moves) d.colours_used[a] |= std::uint64_t(1) << colour;
      if (b_moves) d.colours_used[b] |= std::uint64_t(1) << colour;
    }
    d.slot[i] = colour;
    ++start[colour + 1];
  }
  for (int c = 0; c < kColours; ++c) start[c + 1] += start[c];
  d.order.resize(K);
  for (std::size_t i = 0; i < K; ++i) {
    const int k = start[d.slot[i]]++;
    d.order[k] = static_cast<int>(i);
    d.slot[i] = k;
  }
}

/// Rows (normal, t1, t2 per contact, stored in solve order), pair materials, u_i = J_n q_dot*
/// (before the solve), and the spin rows (a contact alone in its body pair, with
/// mu_spin = max(mu_spin_A, mu_spin_B) > 0, in solve order).
void prepare(const Model& model, const State& state, double dt, const std::vector<Contact>& contacts,
             const std::vector<Vec3>* anchor_a, const std::vector<Vec3>* anchor_b, SolverData& d) {
  const std::size_t K = contacts.size();
  solve_order(model, contacts, d);
  d.rows.resize(3 * K);
  assign_n(d.alpha, 3 * K, 0.0);
  d.u.resize(K);
  d.e.resize(K);
  bool spinning = false;  // some contact's pair has spinning friction
  for (std::size_t i = 0; i < K; ++i) {
    const Contact& c = contacts[i];
    const int a = c.body_a, b = c.body_b;
    const Material& ma = model.material[a];
    const Material& mb = model.material[b];
    const double mu = std::sqrt(ma.friction * mb.friction);
    Vec3 dir[3];
    dir[0] = c.normal;
    tangent_basis(c.normal, dir[1], dir[2]);
    Row* r = &d.rows[3 * d.slot[i]];
    const Vec3 r_a = (anchor_a ? (*anchor_a)[i] : c.point) - state.p[a];
    const Vec3 r_b = (anchor_b ? (*anchor_b)[i] : c.point) - state.p[b];
    make_rows(model, d.dI_inv, a, b, r_a, r_b, dir, dt, r);
    // a speculative contact may close its gap, no more; an overlap is left to the position pass
    r[0].bias = std::max(c.gap, 0.0) / dt;
    for (int k = 1; k <= 2; ++k) {
      r[k].mu = mu;
      r[k].W_n = coupling(r[k], r[0]);
    }
    r[2].W_t1 = coupling(r[2], r[1]);
    d.u[i] = row_velocity(r[0], d.qd);
    d.e[i] = std::max(ma.restitution, mb.restitution);
    spinning = spinning || ma.spinning_friction > 0.0 || mb.spinning_friction > 0.0;
  }
  // spin rows: J_A = (-n, 0), J_B = (n, 0), delta = dt (n . I_A^-1 n + n . I_B^-1 n); none, and
  // nothing more to do, when no pair has spinning friction
  d.spin_rows.clear();
  if (spinning) assign_n(d.spin_slot, K, -1);
  for (std::size_t k = 0; spinning && k < K; ++k) {
    const int i = d.order[k];
    const Contact& c = contacts[i];
    const double mu_spin =
        std::max(model.material[c.body_a].spinning_friction, model.material[c.body_b].spinning_friction);
    if (!(mu_spin > 0.0) || !alone_in_pair(contacts, static_cast<std::size_t>(i))) continue;
    const Row& r = d.rows[3 * k];
    SpinRow q;
    q.n = c.normal;
    q.dMJA_ang = r.a_moves ? Vec3(d.dI_inv[r.a] * -c.normal) : Vec3::Zero();
    q.dMJB_ang = r.b_moves ? Vec3(d.dI_inv[r.b] * c.normal) : Vec3::Zero();
    q.delta = q.n.dot(q.dMJB_ang) - q.n.dot(q.dMJA_ang);
    if (!(q.delta > 0.0)) continue;
    q.inv_delta = 1.0 / q.delta;
    q.mu_spin = mu_spin;
    d.spin_slot[k] = static_cast<int>(d.spin_rows.size());
    d.spin_rows.push_back(q);
  }
  assign_n(d.spin_alpha, d.spin_rows.size(), 0.0);
}

// ---- b. warm start ------------------------------------------------------------------------------
/// Forces of the previous step for contacts with the same key, clamped to the friction set (a spin
/// row's torque to [-mu_spin alpha_n, mu_spin alpha_n]), applied in solve order.
void warm_start(const SolverSettings& s, const std::vector<Contact>& contacts, SolverData& d) {
  if (d.cache.empty()) return;
  assign_n(d.cache_used, d.cache.size(), char(0));
  CachedContact key, previous;
  auto cursor = d.cache.begin();  // the first entry not below the previous contact's key
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const Contact& c = contacts[i];
    key.body_a = c.body_a;
    key.body_b = c.body_b;
    key.feature_a = c.feature_a;
    key.feature_b = c.feature_b;
    // the first entry not below the key: the narrow phase lists contacts in key order, so it is
    // found by walking on from the previous one (everything before the cursor is below the key);
    // a key that goes back is searched for from the start
    auto it = cursor;
    if (i > 0 && !key_less(key, previous)) {
      while (it != d.cache.end() && key_less(*it, key)) ++it;
    } else {
      it = std::lower_bound(d.cache.begin(), d.cache.end(), key, key_less);
    }
    cursor = it;
    previous = key;
    if (it == d.cache.end() || !same_key(*it, key)) continue;
    const std::size_t j = static_cast<std::size_t>(it - d.cache.begin());
    if (d.cache_used[j]) continue;  // an equal key earlier in contact order took it
    d.cache_used[j] = 1;
    const std::size_t k = 3 * static_cast<std::size_t>(d.slot[i]);
    const Row* r = &d.rows[k];
    const double alpha_n = it->alpha;
    double a1 = it->friction.dot(r[1].J_lin), a2 = it->friction.dot(r[2].J_lin);
    const double bound = r[1].mu * alpha_n;
    if (s.friction_cone == FrictionCone::Cone) {
      clamp_to_disk(a1, a2, bound);
    } else {
      a1 = std::clamp(a1, -bound, bound);
      a2 = std::clamp(a2, -bound, bound);
    }
    d.alpha[k] = alpha_n;
    d.alpha[k + 1] = a1;
    d.alpha[k + 2] = a2;
    if (!d.spin_rows.empty() && d.spin_slot[d.slot[i]] >= 0) {
      const std::size_t j = static_cast<std::size_t>(d.spin_slot[d.slot[i]]);
      const double spin_bound = d.spin_rows[j].mu_spin * alpha_n;
      d.spin_alpha[j] = std::clamp(it->spin, -spin_bound, spin_bound);
    }
  }
  // each contact's normal, t1 and t2 rows, then its spin row
  const bool spin = !d.spin_rows.empty();
  for (std::size_t k = 0; k < d.rows.size(); ++k) {
    if (d.alpha[k] != 0.0) apply(d.rows[k], d.alpha[k], d.qd);
    if (spin && k % 3 == 2 && d.spin_slot[k / 3] >= 0) {
      const std::size_t j = static_cast<std::size_t>(d.spin_slot[k / 3]);
      const Row& r = d.rows[k - 2];
      if (d.spin_alpha[j] != 0.0) apply_spin(d.spin_rows[j], r, d.spin_alpha[j], d.qd[r.a], d.qd[r.b]);
    }
  }
}

// ---- c. iterate ---------------------------------------------------------------------------------
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
[[gnu::always_inline]] inline void contact_rows(const SolverSettings& s, const Row* r, double* alpha,
                                                BodyVelocity& A, BodyVelocity& B, double& change) {
  if (!(r[0].delta > 0.0)) return;  // both bodies static: never produced by the narrow phase
  // normal: the lecture's projection onto alpha >= 0
  // (alpha - (J q_dot + b) / delta is -gamma / delta of the lecture, with gamma = J q_dot + b - delta alpha)
  const double a0 = std::max(alpha[0] - (row_velocity(r[0], A, B) + r[0].bias) * r[0].inv_delta, 0.0);
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

/// The sweeps of iterate; kSpin: some contacts have a spin row (without any, the loop is the one
/// of a scene without spinning friction, untouched).
template <bool kSpin>
int sweeps(const SolverSettings& s, SolverData& d, bool& converged) {
  Velocities& qd = d.qd;
  const std::size_t K = d.rows.size() / 3;
  converged = K == 0;
  int sweeps = 0;
  while (!converged && sweeps < s.max_iterations) {
    ++sweeps;
    double change = 0.0;
    for (std::size_t k = 0; k < K; ++k) {  // in solve order, as the rows are stored
      const Row* r = &d.rows[3 * k];
      double* alpha = &d.alpha[3 * k];
      // the contact's two bodies, held locally through its three rows (the same arithmetic; the
      // velocities need not go through memory between rows) and stored back after
      BodyVelocity A = qd[r[0].a], B = qd[r[0].b];
      contact_rows(s, r, alpha, A, B, change);
      if constexpr (kSpin) {
        const int j = d.spin_slot[k];
        if (j >= 0) spin_row(d.spin_rows[j], r[0], alpha[0], d.spin_alpha[j], A, B, change);
      }
      if (r[0].a_moves) qd[r[0].a] = A;
      if (r[0].b_moves) qd[r[0].b] = B;
    }
    converged = s.tolerance > 0.0 && change <= s.tolerance;
  }
  return sweeps;
}

/// PGS sweeps over all rows (normal, then its two friction rows, then its spin row if it has one,
/// contact by contact in solve order). Returns the sweeps used; converged tells whether the last
/// one met the tolerance.
int iterate(const SolverSettings& s, SolverData& d, bool& converged) {
  return d.spin_rows.empty() ? sweeps<false>(s, d, converged) : sweeps<true>(s, d, converged);
}

// ---- d. restitution -----------------------------------------------------------------------------
/// Newton's law on the contacts that approached faster than the threshold and pushed:
/// n^T (v_B - v_A) >= -e u. Returns the sweeps used.
int restitution(const SolverSettings& s, SolverData& d) {
  const std::size_t K = d.u.size();
  assign_n(d.restitutive, K, char(0));
  bool any = false;
  for (std::size_t i = 0; i < K; ++i) {
    d.restitutive[i] = d.e[i] > 0.0 && d.u[i] < -s.restitution_threshold && d.alpha[3 * d.slot[i]] > 0.0;
    any = any || d.restitutive[i];
  }
  if (!any) return 0;
  int sweeps = 0;
  bool converged = false;
  while (!converged && sweeps < s.max_iterations) {
    ++sweeps;
    double change = 0.0;
    for (std::size_t k = 0; k < K; ++k) {  // in solve order
      const int i = d.order[k];
      if (d.restitutive[i])
        change = std::max(change, update_normal(d.rows[3 * k], d.e[i] * d.u[i], d.alpha[3 * k], d.qd));
    }
    converged = s.tolerance > 0.0 && change <= s.tolerance;
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
  assign_n(d.beta, K, 0.0);
  int sweeps = 0;
  bool converged = false;
  while (!converged && sweeps < s.max_iterations) {
    ++sweeps;
    double change = 0.0;
    for (std::size_t k = 0; k < K; ++k) {  // in solve order
      const int i = d.order[k];
      change = std::max(change, update_normal(d.rows[3 * k], -d.b_pos[i], d.beta[i], d.qd_p));
    }
    converged = s.tolerance > 0.0 && change <= s.tolerance;
  }
  return sweeps;
}

// ---- f. store -----------------------------------------------------------------------------------
/// Forces and velocities per contact, summed forces per body, the next cache, the certificate.
void store(double dt, const SolverSettings& s, std::vector<Contact>& contacts, SolverData& d, SolverStats& stats) {
  const std::size_t K = contacts.size();
  d.cache_next.resize(K);
  for (std::size_t i = 0; i < K; ++i) {
    Contact& c = contacts[i];
    const Row* r = &d.rows[3 * d.slot[i]];
    const double* alpha = &d.alpha[3 * d.slot[i]];
    // forces: normal alpha n, friction alpha_t1 t1 + alpha_t2 t2 (on B; A gets the opposite)
    c.alpha = alpha[0];
    c.impulse = dt * alpha[0];
    c.friction = alpha[1] * r[1].J_lin + alpha[2] * r[2].J_lin;
    c.force = alpha[0] * c.normal + c.friction;
    for (int k = 0; k < 3; ++k) {
      d.body_force[r[k].a] -= alpha[k] * r[k].J_lin;
      d.body_torque[r[k].a] += alpha[k] * r[k].JA_ang;
      d.body_force[r[k].b] += alpha[k] * r[k].J_lin;
      d.body_torque[r[k].b] += alpha[k] * r[k].JB_ang;
    }
    // torsional friction: spin_torque n on B, the opposite on A
    const int spin = d.spin_rows.empty() ? -1 : d.spin_slot[d.slot[i]];
    c.spin_torque = spin >= 0 ? d.spin_alpha[spin] : 0.0;
    if (spin >= 0) {
      d.body_torque[c.body_a] -= c.spin_torque * c.normal;
      d.body_torque[c.body_b] += c.spin_torque * c.normal;
    }
    // velocities after the solve: normal and slip
    const double vn = row_velocity(r[0], d.qd);
    const double vt1 = row_velocity(r[1], d.qd), vt2 = row_velocity(r[2], d.qd);
    c.normal_velocity = vn;
    c.slip = vt1 * r[1].J_lin + vt2 * r[2].J_lin;

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
      if (spin >= 0) {  // the spin row: P onto [-mu_spin alpha_n, mu_spin alpha_n] (rad/s)
        const SpinRow& q = d.spin_rows[spin];
        const double spin_bound = q.mu_spin * alpha[0];
        const double p = std::clamp(c.spin_torque - spin_velocity(q, d.qd[c.body_a], d.qd[c.body_b]) / q.delta,
                                    -spin_bound, spin_bound);
        stats.residual = std::max(stats.residual, q.delta * std::abs(c.spin_torque - p));
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
    e.spin = c.spin_torque;
    e.order = static_cast<int>(i);
  }
  // sorted by key (first in contact order on equal keys), one entry per key; the narrow phase
  // lists contacts by body pair and feature ids, so this is usually sorted already
  const auto before = [](const CachedContact& x, const CachedContact& y) {
    return key_less(x, y) || (same_key(x, y) && x.order < y.order);
  };
  if (!std::is_sorted(d.cache_next.begin(), d.cache_next.end(), before))
    std::sort(d.cache_next.begin(), d.cache_next.end(), before);
  d.cache_next.erase(std::unique(d.cache_next.begin(), d.cache_next.end(), same_key), d.cache_next.end());
}

}  // namespace

void tangent_basis(const Vec3& n, Vec3& t1, Vec3& t2) {
  // the first axis within kTangentTie of the smallest |n_k|: a normal of a stack or a wall has two
  // components that are zero up to rounding, and choosing between them by their rounding noise
  // would turn the friction pyramid by 90 degrees from one computation of the normal to the next
  const Vec3 m = n.cwiseAbs();
  const double least = m.minCoeff() + kTangentTie;
  const int k = m[0] <= least ? 0 : m[1] <= least ? 1 : 2;
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
  data.qd_p.assign(N, BodyVelocity());
  data.qd.resize(N);
  data.dI_inv.resize(N);
  for (std::size_t i = 0; i < N; ++i) {
    data.dI_inv[i] = dt * dynamics::inverse_inertia_world(model, state, i);
    data.qd[i].omega = omega[i];
    data.qd[i].v = v[i];
  }

  // a. prepare rows; b. warm start; c. iterate
  prepare(model, state, dt, contacts, anchor_a, anchor_b, data);
  if (settings.warm_start) warm_start(settings, contacts, data);
  stats.iterations = iterate(settings, data, stats.converged);
  data.alpha_iter.resize(K);
  for (std::size_t i = 0; i < K; ++i) data.alpha_iter[i] = data.alpha[3 * data.slot[i]];
  // the poses move with the velocities of c; d changes only the kept ones
  data.v_pos.resize(N);
  data.omega_pos.resize(N);
  for (std::size_t i = 0; i < N; ++i) {
    data.v_pos[i] = data.qd[i].v;
    data.omega_pos[i] = data.qd[i].omega;
  }
  // d. restitution; e. position pass
  stats.restitution_iterations = restitution(settings, data);
  stats.position_iterations = position_pass(dt, settings, contacts, data);
  // f. store
  store(dt, settings, contacts, data, stats);
  data.v_move.resize(N);
  data.omega_move.resize(N);
  for (std::size_t i = 0; i < N; ++i) {
    v[i] = data.qd[i].v;
    omega[i] = data.qd[i].omega;
    data.v_move[i] = data.v_pos[i] + data.qd_p[i].v;
    data.omega_move[i] = data.omega_pos[i] + data.qd_p[i].omega;
  }
  stats.max_alpha_negative = std::max(stats.max_alpha_negative, 0.0);
  stats.max_penetration_velocity = std::max(stats.max_penetration_velocity, 0.0);
  stats.max_cone_violation = std::max(stats.max_cone_violation, 0.0);
  stats.max_overlap = std::max(stats.max_overlap, 0.0);
  return stats;
}

}  // namespace signorini::solver
