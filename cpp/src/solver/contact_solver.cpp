#include "solver/contact_solver.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "dynamics/rigid_body.hpp"
#include "parallel/pool.hpp"
#include "solver/joint_rows.hpp"
#include "solver/rows.hpp"

namespace signorini::solver {
namespace {

using namespace rows;

// ---- a. prepare, b. warm start: rows.cpp ---------------------------------------------------------
// ---- c. iterate ---------------------------------------------------------------------------------
/// The sweeps of iterate; kSpin: some contacts have a spin row (without any, the loop is the one
/// of a scene without spinning friction, untouched).
template <bool kSpin>
int sweeps(const SolverSettings& s, double h, SolverData& d, bool& converged) {
  Velocities& qd = d.qd;
  const Mat3* dI = d.dI_inv.data();
  JointSet* joints = joints_of(d, true);
  converged = d.rows.empty() && joints == nullptr;
  int sweeps = 0;
  while (!converged && sweeps < s.max_iterations) {
    ++sweeps;
    const double change = by_colour(d, [&](std::size_t first, std::size_t end) {
      double change = 0.0;
      for (std::size_t k = first; k < end; ++k) {  // in solve order, as the rows are stored
        const ContactRows& r = d.rows[k];
        double* alpha = &d.alpha[3 * k];
        // the contact's two bodies, held locally through its three rows (the same arithmetic; the
        // velocities need not go through memory between rows) and stored back after
        BodyVelocity A = qd[r.a], B = qd[r.b];
        contact_rows(s, r, dI, alpha, A, B, change, HardNormal{});
        finish_contact<kSpin>(d, k, r, alpha, A, B, change);
      }
      return change;
    });
    const double joint_change = joints ? sweep_joints(*joints, d, JointSweep::Hard, h) : 0.0;
    converged = s.tolerance > 0.0 && std::max(change, joint_change) <= s.tolerance;
  }
  return sweeps;
}

/// PGS sweeps over all rows (normal, then its two friction rows, then its spin row if it has one,
/// contact by contact in solve order). Returns the sweeps used; converged tells whether the last
/// one met the tolerance.
int iterate(const SolverSettings& s, double h, SolverData& d, bool& converged) {
  return d.spin_rows.empty() ? sweeps<false>(s, h, d, converged) : sweeps<true>(s, h, d, converged);
}

// ---- d. restitution: rows.cpp -------------------------------------------------------------------

// ---- e. position pass ---------------------------------------------------------------------------
/// Split impulse: pseudo-velocities (v_p, omega_p) that remove overlaps beyond the slop (erp of the
/// excess per step, at most max_push_velocity) and carry a bounce on for the part of the step after its impact.
/// They move the poses and are then dropped, so they never add kinetic energy. A contact's slop is
/// min(slop, slop_inner_fraction r_min), r_min the smaller inner radius of its bodies: a fixed
/// 1 mm would let a body 2 mm thick rest half sunk.
int position_pass(double dt, const SolverSettings& s, const Model& model, const std::vector<Contact>& contacts,
                  SolverData& d) {
  const std::size_t K = contacts.size();
  d.b_pos.resize(K);
  bool any = false;
  for (std::size_t i = 0; i < K; ++i) {
    const double gap = contacts[i].gap;
    const double r_min = std::min(model.inner[contacts[i].body_a], model.inner[contacts[i].body_b]);
    const double slop = std::min(s.slop, SolverSettings::slop_inner_fraction * r_min);
    const double push = std::min(s.erp * std::max(-gap - slop, 0.0) / dt, s.max_push_velocity);
    const std::size_t k = static_cast<std::size_t>(d.slot[i]);  // u, e and the flags are by solve position
    const double bounce = d.restitutive[k] ? d.e[k] * std::max(-d.u[k] - std::max(gap, 0.0) / dt, 0.0) : 0.0;
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
      change = std::max(change, update_normal(d.rows[k], d.dI_inv.data(), -d.b_pos[i], d.beta[i], d.qd_p));
    }
    converged = s.tolerance > 0.0 && change <= s.tolerance;
  }
  return sweeps;
}

// ---- f. store: rows.cpp --------------------------------------------------------------------------

}  // namespace

SolverStats solve_contacts(const Model& model, const State& state, double dt, const SolverSettings& settings,
                           std::vector<Contact>& contacts, std::vector<Vec3>& v, std::vector<Vec3>& omega,
                           SolverData& data, const std::vector<Vec3>* anchor_a, const std::vector<Vec3>* anchor_b) {
  const std::size_t N = model.size(), K = contacts.size();
  SolverStats stats;
  stats.contacts = static_cast<int>(K);
  clear_body_forces(data, N);
  // per body (the listed ones; the others' entries stay zero): velocities in, dt I^-1
  parallel::fit(data.qd_p, N, BodyVelocity());
  parallel::fit(data.qd, N, BodyVelocity());
  parallel::fit(data.dI_inv, N, Mat3(Mat3::Zero()));
  parallel::each_body(data.bodies, N, [&](std::size_t i) {
    data.qd_p[i] = BodyVelocity();
    data.dI_inv[i] = dt * dynamics::inverse_inertia_world(model, state, i);
    data.qd[i].omega = omega[i];
    data.qd[i].v = v[i];
  });

  // a. prepare rows; b. warm start; c. iterate
  prepare(model, state, dt, contacts, anchor_a, anchor_b, data);
  if (settings.warm_start && recall_forces(settings, contacts, data)) apply_forces(data);
  JointSet* joints = joints_of(data);
  if (joints) {  // the joints' rows at this substep's poses, warm started from their last forces
    prepare_joints(model, state, dt, nullptr, true, *joints, data);
    if (settings.warm_start) warm_start_joints(*joints, data);
    else for (Joint& j : joints->joints) j.alpha.fill(0.0);
  }
  stats.iterations = iterate(settings, dt, data, stats.converged);
  data.alpha_iter.resize(K);
  for (std::size_t k = 0; k < K; ++k) data.alpha_iter[k] = data.alpha[3 * k];
  // the poses move with the velocities of c; d changes only the kept ones
  parallel::fit(data.v_pos, N, Vec3(Vec3::Zero()));
  parallel::fit(data.omega_pos, N, Vec3(Vec3::Zero()));
  parallel::each_body(data.bodies, N, [&](std::size_t i) {
    data.v_pos[i] = data.qd[i].v;
    data.omega_pos[i] = data.qd[i].omega;
  });
  // d. restitution (the contacts that approached faster than the threshold and pushed); e. position pass
  assign_n(data.restitutive, K, char(0));
  for (std::size_t k = 0; k < K; ++k)
    data.restitutive[k] = data.e[k] > 0.0 && data.u[k] < -settings.restitution_threshold && data.alpha[3 * k] > 0.0;
  stats.restitution_iterations = restitution(settings, data);
  stats.position_iterations = position_pass(dt, settings, model, contacts, data);
  if (joints) stats.position_iterations += joint_position_pass(settings, dt, *joints, data);
  // f. store
  store(dt, settings, contacts, data, stats);
  if (joints) store_joints(state, *joints);
  parallel::fit(data.v_move, N, Vec3(Vec3::Zero()));
  parallel::fit(data.omega_move, N, Vec3(Vec3::Zero()));
  parallel::each_body(data.bodies, N, [&](std::size_t i) {
    v[i] = data.qd[i].v;
    omega[i] = data.qd[i].omega;
    data.v_move[i] = data.v_pos[i] + data.qd_p[i].v;
    data.omega_move[i] = data.omega_pos[i] + data.qd_p[i].omega;
  });
  return stats;
}

void clear_body_forces(SolverData& d, std::size_t n) {
  if (d.bodies == nullptr || d.body_force.size() != n || d.body_torque.size() != n || d.is_forced.size() != n) {
    d.body_force.assign(n, Vec3::Zero());
    d.body_torque.assign(n, Vec3::Zero());
    d.is_forced.assign(n, 0);
    d.forced.clear();
    return;
  }
  for (const int i : d.forced) {
    d.body_force[i].setZero();
    d.body_torque[i].setZero();
    d.is_forced[i] = 0;
  }
  d.forced.clear();
}

void forget_bodies(SolverData& d) {
  // cleared, not freed: the next step sizes them to N again (zero) within their capacity
  d.qd.clear(), d.qd_p.clear(), d.dI_inv.clear(), d.v_pos.clear(), d.omega_pos.clear(), d.v_move.clear(),
      d.omega_move.clear(), d.colours_used.clear(), d.p0.clear(), d.R0.clear(), d.dp.clear(), d.dR.clear(),
      d.kick.clear();
  d.kick_ready = false;
  d.is_forced.clear();  // every entry of body_force may be non-zero: the next clear zeroes all
  d.forced.clear();
}

}  // namespace signorini::solver
