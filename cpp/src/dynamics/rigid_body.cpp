#include "dynamics/rigid_body.hpp"

#include "math/rotation.hpp"

namespace signorini::dynamics {

Mat36 jacobian(const Vec3& p, const Vec3& y) {
  Mat36 J;
  J.leftCols<3>() = -math::skew(y - p);
  J.rightCols<3>() = Mat3::Identity();
  return J;
}

Mat3 inverse_inertia_world(const Model& model, const State& state, std::size_t i) {
  const Mat3& R = state.R[i];
  return R * model.I_body_inv[i] * R.transpose();
}

void unconstrained_velocity(const Model& model, const State& state, const Vec3& gravity, double dt,
                            std::vector<Vec3>& v_star, std::vector<Vec3>& omega_star) {
  const std::size_t n = model.size();
  v_star.resize(n);
  omega_star.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (model.is_static[i]) {
      v_star[i].setZero();
      omega_star[i].setZero();
      continue;
    }
    const Mat3& R = state.R[i];
    const Vec3& w = state.omega[i];
    // linear: m p_dot* = m p_dot + dt (m g + f_ext)
    v_star[i] = state.v[i] + dt * (gravity + model.inv_mass[i] * state.f_ext[i]);
    // angular: I_w omega* = I_w omega + dt (tau_ext - omega x (I_w omega))
    const Vec3 L = R * (model.I_body[i] * (R.transpose() * w));
    const Vec3 torque = state.tau_ext[i] - w.cross(L);
    omega_star[i] = w + dt * (R * (model.I_body_inv[i] * (R.transpose() * torque)));
  }
}

void integrate(const Model& model, State& state, double dt) {
  for (std::size_t i = 0; i < model.size(); ++i) {
    if (model.is_static[i]) continue;
    state.R[i] = math::orthonormalize(math::rodrigues(state.omega[i], dt) * state.R[i]);
    state.p[i] += dt * state.v[i];
  }
}

}  // namespace signorini::dynamics
