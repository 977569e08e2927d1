// Projected Gauss-Seidel over the contacts, as in the lecture notes (seeds/001).
#pragma once

#include <vector>

#include "signorini/contact.hpp"
#include "signorini/solver.hpp"
#include "signorini/model.hpp"
#include "signorini/state.hpp"

namespace signorini::solver {

/// Solves the contact LCP of one step by PGS, in contact order, starting from alpha = 0.
///
/// For contact i between A and B, with g_i^A = -J_A(y_i)^T n_i and g_i^B = J_B(y_i)^T n_i:
///   delta_i = dt (g_B^T M_B^-1 g_B + g_A^T M_A^-1 g_A)
///   gamma_i = g_B^T q_dot_B + g_A^T q_dot_A - delta_i alpha_i + b_i    (every contact but i)
///   alpha_i <- max(-gamma_i / delta_i, 0)
/// where q_dot = q_dot* + dt sum_j alpha_j M^-1 g_j is kept current, and the gap bias
/// b_i = gap_i / dt (gap >= 0: a speculative contact may close its gap, no more) or
/// erp gap_i / dt (overlap: Baumgarte) enforces n^T (v_B - v_A) >= -b_i.
///
/// In:  v, omega = q_dot* per body (world); contacts with body_a, body_b, point, normal, gap.
/// Out: v, omega = q_dot^{t+1}; contacts[i].alpha (N) and .impulse = dt alpha (N s).
/// Returns sweeps used, convergence (max_i delta_i |d alpha_i| <= tolerance, m/s) and the residual.
SolverStats solve_pgs(const Model& model, const State& state, double dt, const SolverSettings& settings,
                      std::vector<Contact>& contacts, std::vector<Vec3>& v, std::vector<Vec3>& omega);

}  // namespace signorini::solver
