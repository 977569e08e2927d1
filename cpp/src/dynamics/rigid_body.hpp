// Rigid-body kinematics and the unconstrained half of the lecture's discrete equations of motion.
#pragma once

#include <Eigen/Core>

#include "signorini/model.hpp"
#include "signorini/state.hpp"

namespace signorini::dynamics {

using Mat36 = Eigen::Matrix<double, 3, 6>;

/// The rigid-body Jacobian J(y) (3 x 6) at world point y of a body with com p:
/// J = [ -[y - p]_x , I3 ], so J q_dot = omega x (y - p) + p_dot for q_dot = (omega, p_dot).
/// (The lecture's R ([X]^T I) diag(R^T, R^T) written in world quantities.)
Mat36 jacobian(const Vec3& p, const Vec3& y);

/// World inverse inertia R I_body^-1 R^T (zero for a static body).
Mat3 inverse_inertia_world(const Model& model, const State& state, std::size_t i);

/// Unconstrained velocity q_dot* for every body (static ones keep zero velocity):
///   v* = v + dt (g + f_ext / m)
///   omega* = omega + dt I_w^-1 (tau_ext - omega x (I_w omega)),   I_w = R I_body R^T
/// The gyroscopic term has the physical sign (d(I_w omega)/dt = tau); the course README flips it.
/// Outputs v_star, omega_star (one per body, world).
void unconstrained_velocity(const Model& model, const State& state, const Vec3& gravity, double dt,
                            std::vector<Vec3>& v_star, std::vector<Vec3>& omega_star);

/// Integrates poses with the end-of-step velocities already in state (v, omega):
/// R <- orthonormalize(exp([omega] dt) R), p <- p + dt v. Static bodies do not move.
void integrate(const Model& model, State& state, double dt);

}  // namespace signorini::dynamics
