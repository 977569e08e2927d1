// The contact solver as named stages over flat arrays (docs/conventions.md, "One step", step 3):
//   prepare rows -> warm start -> iterate (PGS sweeps) -> restitution -> position pass -> store.
// The World owns one SolverData and hands it to every step, so the arrays keep their capacity and
// a step allocates nothing once they have grown to the scene's size.
#pragma once

#include <cstdint>
#include <vector>

#include "signorini/contact.hpp"
#include "signorini/model.hpp"
#include "signorini/solver.hpp"
#include "signorini/state.hpp"

namespace signorini::solver {

/// One constraint row: a Jacobian pair with bounds. It knows bodies and directions, never a
/// Contact, so joints can add rows of their own. Hot data: read and written by every sweep.
///   J_A = (JA_ang, JA_lin), J_B = (JB_ang, JB_lin) in the (omega, p_dot) layout (6 each);
///   its velocity J q_dot = J_B . q_dot_B + J_A . q_dot_A (m/s);
///   delta = dt (J_A . M_A^-1 J_A + J_B . M_B^-1 J_B) (s/kg), the lecture's delta_i;
///   a force change d_alpha (N) moves q_dot_X += dt d_alpha M_X^-1 J_X.
struct Row {
  int a = 0, b = 0;             ///< body indices
  bool a_moves = false, b_moves = false;  ///< false for static bodies (M^-1 = 0: skipped)
  Vec3 JA_ang, JA_lin, JB_ang, JB_lin;
  Vec3 MJA_ang, MJA_lin, MJB_ang, MJB_lin;  ///< M^-1 J for each side
  double delta = 0.0;
  double bias = 0.0;            ///< b (m/s): the row asks J q_dot + b >= 0 (normal rows)
  int normal = -1;              ///< friction rows: the index of the normal row that bounds them
  double mu = 0.0;              ///< friction rows: the bound is mu alpha_normal
};

/// Everything the solver keeps between steps (the cache) or reuses (scratch), as flat arrays.
struct SolverData {
  // rows: 3 per contact (normal, t1, t2), in contact order; their forces alpha (N)
  std::vector<Row> rows;
  std::vector<double> alpha;
  // per contact (cold): pre-solve normal velocity u_i (m/s), restitution e_i, whether stage d
  // applies, position-pass target b_pos (m/s) and pseudo-force beta (N)
  std::vector<double> u, e, b_pos, beta;
  std::vector<char> restitutive;
  // per body: velocities for the positions (after iterate) and pseudo-velocities (position pass)
  std::vector<Vec3> v_pos, omega_pos, v_p, omega_p;
  // per body: summed contact force (N) and torque about the com (N m), world
  std::vector<Vec3> body_force, body_torque;
  // warm-start cache of the previous step, sorted by key, and the one being written
  std::vector<CachedContact> cache, cache_next;
  std::vector<char> cache_used;     ///< per cache entry: already given to a contact this step
  std::vector<double> alpha_iter;   ///< per contact: alpha_n after the iterate stage (N)
};

/// Tangent basis of a unit normal n: k = the axis of the smallest |n_k| (first on ties),
/// t1 = unit(n x e_k), t2 = n x t1.
void tangent_basis(const Vec3& n, Vec3& t1, Vec3& t2);

/// Solves one step's contacts.
/// In:  model, state (poses at the start of the step), dt (s), settings;
///      contacts (K) with body_a, body_b, point, normal, gap, feature ids;
///      v, omega (N, world) = the unconstrained velocities q_dot*.
/// Out: v, omega = the new velocities (after restitution);
///      data.v_pos + data.v_p, data.omega_pos + data.omega_p = the velocities that move the poses;
///      contacts[i].alpha, impulse, friction, force, normal_velocity, slip;
///      data.body_force, data.body_torque; data.cache_next (the caller swaps it into
///      data.cache once the step is kept);
///      returns the stats and the Signorini certificate.
///      anchor_a, anchor_b (K, world), optional: where the force acts on A and on B (a substep's
///      contacts carried with each body); null: contacts[i].point for both.
SolverStats solve_contacts(const Model& model, const State& state, double dt, const SolverSettings& settings,
                           std::vector<Contact>& contacts, std::vector<Vec3>& v, std::vector<Vec3>& omega,
                           SolverData& data, const std::vector<Vec3>* anchor_a = nullptr,
                           const std::vector<Vec3>* anchor_b = nullptr);

}  // namespace signorini::solver
