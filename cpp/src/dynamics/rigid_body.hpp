// Rigid-body kinematics and the unconstrained half of the lecture's discrete equations of motion.
#pragma once

#include <Eigen/Core>

#include "signorini/model.hpp"
#include "signorini/solver.hpp"
#include "signorini/state.hpp"

namespace signorini::parallel { class Pool; }

namespace signorini::dynamics {

using Mat36 = Eigen::Matrix<double, 3, 6>;

/// The rigid-body Jacobian J(y) (3 x 6) at world point y of a body with com p:
/// J = [ -[y - p]_x , I3 ], so J q_dot = omega x (y - p) + p_dot for q_dot = (omega, p_dot).
/// (The lecture's R ([X]^T I) diag(R^T, R^T) written in world quantities.)
Mat36 jacobian(const Vec3& p, const Vec3& y);

/// World inverse inertia R I_body^-1 R^T (zero for a static body).
Mat3 inverse_inertia_world(const Model& model, const State& state, std::size_t i);

/// Unconstrained velocity q_dot* for every body (static ones keep zero velocity; kinematic,
/// disabled and sleeping ones keep v and omega: no gravity, no forces), world frame, with f = f_ext + f_step and
/// tau = tau_ext + tau_step:
///   v* = v + dt (g + f / m)
/// and the angular part from the body-frame Euler equation I w_dot + w x (I w) = tau_b
/// (w = R^T omega, I = I_body), by `gyroscopic` (docs/conventions.md, step 2):
///   Midpoint: I (w' - w) + dt m x (I m) = 0, m = (w + w') / 2, Newton iterated (<= 10 steps,
///             until |step|_inf <= 1e-14 |w'|_inf); energy never above 1/2 w.I w; keeps 1/2 w.I w
///             and |I w| to rounding.
///   Implicit: one Newton step of backward Euler (Catto 2015): w' = w - (I + dt ([w]x I - [I w]x))^-1 dt w x (I w).
///   Explicit: the lecture's omega* = omega + dt I_w^-1 (tau - omega x (I_w omega)), I_w = R I_body R^T.
/// then w* = w' + dt I^-1 tau_b and omega* = R w*. The gyroscopic term has the physical sign
/// (d(I_w omega)/dt = tau); the course README flips it.
/// Outputs v_star, omega_star (one per body, world). Bodies split over pool's threads (null: the
/// calling thread); each body's value does not depend on it.
/// bodies: the bodies to write (ascending; the World passes its non-static ones); null: all. The
/// entries of the others are left as they are: zero (set so when the arrays are sized to N), as
/// every static body's velocity is.
void unconstrained_velocity(const Model& model, const State& state, const Vec3& gravity, double dt,
                            Gyroscopic gyroscopic, std::vector<Vec3>& v_star, std::vector<Vec3>& omega_star,
                            const parallel::Pool* pool = nullptr, const std::vector<BodyIndex>* bodies = nullptr);

/// Free rotation of one body over dt in body coordinates: w (rad/s) -> w' by the chosen rule
/// (no torque). I is the body inertia (kg m^2).
Vec3 free_rotation(const Mat3& I, const Mat3& I_inv, const Vec3& w, double dt, Gyroscopic gyroscopic);

/// Moves every dynamic and kinematic body's pose with the velocities v, omega (N, world):
/// R <- orthonormalize(exp([omega] dt) R), p <- p + dt v. Static, disabled and sleeping bodies
/// (state.asleep) do not move: their poses stay bit for bit.
/// Bodies split over pool's threads (null: the calling thread); bodies: those to visit (null: all;
/// the World passes its non-static ones, the only ones that can move).
void integrate(const Model& model, State& state, const std::vector<Vec3>& v, const std::vector<Vec3>& omega,
               double dt, const parallel::Pool* pool = nullptr, const std::vector<BodyIndex>* bodies = nullptr);

/// The pending impulses (state.impulse J, state.angular_impulse L; N s and N m s, world) change
/// the velocities of enabled dynamic bodies, v += J / m and omega += I_w^-1 L, and are spent
/// (zeroed) for every body of `bodies` (null: all; a static body never has one).
void apply_impulses(const Model& model, State& state, const std::vector<BodyIndex>* bodies = nullptr);

/// The end of a substep of h: the poses move with v_move, omega_move (integrate), then the
/// velocities become v, omega (copied into the state's storage, which NumPy views see) and the
/// time advances by h. All arrays (N, world); bodies as for integrate (the velocities of the others,
/// static bodies', are zero in both).
void advance(const Model& model, State& state, const std::vector<Vec3>& v_move, const std::vector<Vec3>& omega_move,
             const std::vector<Vec3>& v, const std::vector<Vec3>& omega, double h, const parallel::Pool* pool = nullptr,
             const std::vector<BodyIndex>* bodies = nullptr);

}  // namespace signorini::dynamics
