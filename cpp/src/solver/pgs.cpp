#include "solver/pgs.hpp"

#include <algorithm>
#include <cmath>

#include "dynamics/rigid_body.hpp"

namespace signorini::solver {
namespace {

/// One contact row, in the notes' symbols. Angular part first, as in q_dot = (omega, p_dot).
struct Row {
  std::size_t a, b;
  bool a_static, b_static;
  Vec3 gA_ang, gA_lin, gB_ang, gB_lin;      // g_i^A, g_i^B
  Vec3 MgA_ang, MgA_lin, MgB_ang, MgB_lin;  // M^-1 g for each side
  double delta;                            // dt (g_B^T M_B^-1 g_B + g_A^T M_A^-1 g_A)
  double bias;                             // b_i (m/s)
};

/// g_B^T q_dot_B + g_A^T q_dot_A: the relative normal velocity n^T (v_B(y) - v_A(y)).
double relative_velocity(const Row& r, const std::vector<Vec3>& v, const std::vector<Vec3>& omega) {
  return r.gB_ang.dot(omega[r.b]) + r.gB_lin.dot(v[r.b]) + r.gA_ang.dot(omega[r.a]) + r.gA_lin.dot(v[r.a]);
}

}  // namespace

SolverStats solve_pgs(const Model& model, const State& state, double dt, const SolverSettings& settings,
                      std::vector<Contact>& contacts, std::vector<Vec3>& v, std::vector<Vec3>& omega) {
  // prepare: rows from the contacts (J^T n = (r x n, n) with r = y - p)
  std::vector<Row> rows(contacts.size());
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const Contact& c = contacts[i];
    Row& r = rows[i];
    r.a = static_cast<std::size_t>(c.body_a);
    r.b = static_cast<std::size_t>(c.body_b);
    r.a_static = model.is_static[r.a];
    r.b_static = model.is_static[r.b];
    const Vec3& n = c.normal;
    r.gA_ang = -(c.point - state.p[r.a]).cross(n);
    r.gA_lin = -n;
    r.gB_ang = (c.point - state.p[r.b]).cross(n);
    r.gB_lin = n;
    const Mat3 IinvA = dynamics::inverse_inertia_world(model, state, r.a);
    const Mat3 IinvB = dynamics::inverse_inertia_world(model, state, r.b);
    r.MgA_ang = IinvA * r.gA_ang;
    r.MgA_lin = model.inv_mass[r.a] * r.gA_lin;
    r.MgB_ang = IinvB * r.gB_ang;
    r.MgB_lin = model.inv_mass[r.b] * r.gB_lin;
    r.delta = dt * (r.gB_ang.dot(r.MgB_ang) + r.gB_lin.dot(r.MgB_lin) + r.gA_ang.dot(r.MgA_ang) +
                    r.gA_lin.dot(r.MgA_lin));
    r.bias = (c.gap >= 0.0 ? 1.0 : settings.erp) * c.gap / dt;
  }

  // sweep: alpha_i = max(-gamma_i / delta_i, 0), in contact order, until nothing moves
  std::vector<double> alpha(contacts.size(), 0.0);
  SolverStats stats;
  stats.contacts = static_cast<int>(contacts.size());
  stats.converged = contacts.empty();
  while (!stats.converged && stats.iterations < settings.max_iterations) {
    ++stats.iterations;
    double largest_change = 0.0;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const Row& r = rows[i];
      if (!(r.delta > 0.0)) continue;  // both bodies static: never produced by the narrow phase
      const double gamma = relative_velocity(r, v, omega) - r.delta * alpha[i] + r.bias;
      const double alpha_new = std::max(-gamma / r.delta, 0.0);
      const double d_alpha = alpha_new - alpha[i];
      if (d_alpha == 0.0) continue;
      alpha[i] = alpha_new;
      // static bodies (M^-1 = 0) are skipped rather than given 0 * alpha, which an overflowing
      // alpha would turn into NaN
      const double s = dt * d_alpha;
      if (!r.a_static) {
        omega[r.a] += s * r.MgA_ang;
        v[r.a] += s * r.MgA_lin;
      }
      if (!r.b_static) {
        omega[r.b] += s * r.MgB_ang;
        v[r.b] += s * r.MgB_lin;
      }
      largest_change = std::max(largest_change, r.delta * std::abs(d_alpha));
    }
    stats.converged = largest_change <= settings.tolerance;
  }

  // report: alpha, impulses, and the Signorini residual max |min(delta alpha, w)|
  for (std::size_t i = 0; i < rows.size(); ++i) {
    contacts[i].alpha = alpha[i];
    contacts[i].impulse = dt * alpha[i];
    const double w = relative_velocity(rows[i], v, omega) + rows[i].bias;
    stats.residual = std::max(stats.residual, std::abs(std::min(rows[i].delta * alpha[i], w)));
  }
  return stats;
}

}  // namespace signorini::solver
