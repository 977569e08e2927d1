// Jacobian, unconstrained velocity (gyroscopic term), and the single-contact closed form.
#include <gtest/gtest.h>

#include "dynamics/rigid_body.hpp"
#include "math/rotation.hpp"
#include "signorini/mass_properties.hpp"
#include "solver/contact_solver.hpp"

using namespace signorini;

namespace {

/// A one-body model/state: a box of half extents h and density 1000, no gravity.
void one_box(Model& model, State& state, const Vec3& h, const Mat3& R, const Vec3& omega) {
  const MassProperties mp = mass_properties(Box(h), 1000.0);
  model.shape.push_back(Box(h));
  model.is_static.push_back(false);
  model.mass.push_back(mp.mass);
  model.inv_mass.push_back(1.0 / mp.mass);
  model.I_body.push_back(mp.inertia);
  model.I_body_inv.push_back(mp.inertia.inverse());
  model.rho.push_back(h.norm());
  model.inner.push_back(h.minCoeff());
  state.p.push_back(Vec3(0.1, 0.2, 0.3));
  state.R.push_back(R);
  state.v.push_back(Vec3::Zero());
  state.omega.push_back(omega);
  state.f_ext.push_back(Vec3::Zero());
  state.tau_ext.push_back(Vec3::Zero());
  state.f_step.push_back(Vec3::Zero());
  state.tau_step.push_back(Vec3::Zero());
  model.push_defaults();
}

}  // namespace

TEST(Dynamics, JacobianMatchesFiniteDifferences) {
  // x(t) = R(t) X + p(t) with R(t) = exp([omega] t) R0, p(t) = p0 + t v: dx/dt at 0 by central
  // differences (error O(h^2) ~ 1e-10 for h = 1e-5, rounding ~1e-16/h ~ 1e-11)
  const Mat3 R0 = math::quat_to_matrix(Quat4(0.8, 0.2, -0.4, 0.4).normalized());
  const Vec3 p0(0.5, -1.0, 2.0), X(0.3, 0.1, -0.7), omega(1.0, -2.0, 0.5), v(0.2, 0.3, -0.1);
  const double h = 1e-5;
  auto x = [&](double t) { return Vec3(math::rodrigues(omega, t) * R0 * X + p0 + t * v); };
  const Vec3 fd = (x(h) - x(-h)) / (2 * h);
  Vec6 q_dot;
  q_dot << omega, v;
  const Vec3 y = R0 * X + p0;
  EXPECT_LT((dynamics::jacobian(p0, y) * q_dot - fd).norm(), 1e-9);
}

TEST(Dynamics, GravityAndForceInUnconstrainedVelocity) {
  Model model;
  State state;
  one_box(model, state, Vec3(0.5, 0.5, 0.5), Mat3::Identity(), Vec3::Zero());
  state.f_ext[0] = Vec3(1000.0, 0.0, 0.0);  // mass 1000 kg: 1 m/s^2
  std::vector<Vec3> v, w;
  dynamics::unconstrained_velocity(model, state, Vec3(0, 0, -9.81), 0.01, Gyroscopic::Midpoint, v, w);
  EXPECT_LT((v[0] - Vec3(0.01, 0.0, -0.0981)).norm(), 1e-15);
  EXPECT_LT(w[0].norm(), 1e-15);
}

TEST(Dynamics, ExplicitGyroscopicTermKeepsAngularMomentumToSecondOrder) {
  // the lecture's explicit term on a torque-free asymmetric box. One step maps L = I_w omega to L' = Q (L - dt omega x L) with
  // Q = exp([omega'] dt), so |L'| / |L| = sqrt(1 + dt^2 |omega x L|^2 / |L|^2) exactly, and the
  // vector L moves by O(dt^2) per step. With the flipped sign it would move by 2 dt |omega x L|.
  Model model;
  State state;
  const Mat3 R0 = math::quat_to_matrix(Quat4(0.9, 0.3, 0.1, -0.2).normalized());
  one_box(model, state, Vec3(0.1, 0.3, 0.6), R0, Vec3(0.4, 1.0, -0.3));
  const double dt = 1e-3;
  auto L = [&]() { return Vec3(state.R[0] * model.I_body[0] * state.R[0].transpose() * state.omega[0]); };
  double worst_relative = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const Vec3 L0 = L();
    const double predicted = std::sqrt(1.0 + dt * dt * state.omega[0].cross(L0).squaredNorm() / L0.squaredNorm());
    std::vector<Vec3> v, w;
    dynamics::unconstrained_velocity(model, state, Vec3::Zero(), dt, Gyroscopic::Explicit, v, w);
    state.v = v;
    state.omega = w;
    dynamics::integrate(model, state, v, w, dt);
    const Vec3 L1 = L();
    EXPECT_NEAR(L1.norm() / L0.norm(), predicted, 1e-12);
    worst_relative = std::max(worst_relative, std::abs(L1.norm() / L0.norm() - 1.0));
    // vector change second order: dt^2 |omega|^2 |L| times a constant below 1 + 2 I_max/I_min
    // (about 10 for this box); the flipped sign would give 2 dt |omega x L|, 200 times more
    EXPECT_LT((L1 - L0).norm(), 10.0 * dt * dt * state.omega[0].squaredNorm() * L0.norm());
  }
  EXPECT_LT(worst_relative, 1e-6);
}

TEST(Solver, SingleContactClosedForm) {
  // a sphere resting on a static plane: one contact at gap 0, v* = -g dt, so
  // delta = dt / m, gamma = -g dt and alpha = max(-gamma/delta, 0) = m g, after which v = 0
  Model model;
  State state;
  model.shape = {Plane(Vec3::UnitZ(), 0.0), Sphere(0.5)};
  model.is_static = {true, false};
  model.mass = {INFINITY, 2.0};
  model.inv_mass = {0.0, 0.5};
  model.I_body = {Mat3::Zero(), Mat3::Identity() * 0.2};
  model.I_body_inv = {Mat3::Zero(), Mat3::Identity() * 5.0};
  model.rho = {INFINITY, 0.5};
  model.inner = {INFINITY, 0.5};
  model.material = {Material(), Material()};
  state.p = {Vec3::Zero(), Vec3(0, 0, 0.5)};
  state.R = {Mat3::Identity(), Mat3::Identity()};
  state.v = {Vec3::Zero(), Vec3::Zero()};
  state.omega = state.v;
  state.f_ext = state.v;
  state.tau_ext = state.v;
  state.f_step = state.v;
  state.tau_step = state.v;
  model.push_defaults();
  model.push_defaults();
  const double dt = 0.01, g = 9.81;
  std::vector<Contact> contacts(1);
  contacts[0].body_a = 0;
  contacts[0].body_b = 1;
  contacts[0].normal = Vec3::UnitZ();
  contacts[0].point = Vec3::Zero();
  contacts[0].gap = 0.0;
  std::vector<Vec3> v = {Vec3::Zero(), Vec3(0, 0, -g * dt)}, w = {Vec3::Zero(), Vec3::Zero()};
  solver::SolverData data;
  SolverSettings cold;
  cold.warm_start = false;
  const SolverStats stats = solver::solve_contacts(model, state, dt, cold, contacts, v, w, data);
  EXPECT_NEAR(contacts[0].alpha, 2.0 * g, 1e-12);
  EXPECT_NEAR(contacts[0].impulse, 2.0 * g * dt, 1e-14);
  EXPECT_LT(v[1].norm(), 1e-15);
  EXPECT_TRUE(stats.converged);
  EXPECT_LT(stats.residual, 1e-15);
  // a separating sphere gets no force
  v[1] = Vec3(0, 0, 1.0);
  solver::solve_contacts(model, state, dt, cold, contacts, v, w, data);
  EXPECT_EQ(contacts[0].alpha, 0.0);
  // a speculative contact (gap 1 cm) lets the sphere approach by exactly the gap in one step
  contacts[0].gap = 0.01;
  v[1] = Vec3(0, 0, -5.0);
  solver::solve_contacts(model, state, dt, cold, contacts, v, w, data);
  EXPECT_NEAR(v[1].z() * dt, -0.01, 1e-15);
}
