#include "dynamics/rigid_body.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "math/rotation.hpp"
#include "parallel/pool.hpp"

namespace signorini::dynamics {

/// Bodies per task when a loop over bodies is split over threads.
constexpr std::size_t kBodiesPerTask = 512;

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

Vec3 free_rotation(const Mat3& I, const Mat3& I_inv, const Vec3& w, double dt, Gyroscopic gyroscopic) {
  switch (gyroscopic) {
    case Gyroscopic::Explicit:
      return w - dt * (I_inv * w.cross(I * w));
    case Gyroscopic::Implicit: {
      // one Newton step on f(w') = I (w' - w) + dt w' x (I w'), from w' = w
      const Mat3 J = I + dt * (math::skew(w) * I - math::skew(I * w));
      return w - J.inverse() * (dt * w.cross(I * w));
    }
    case Gyroscopic::Midpoint: {
      // Newton on F(w') = I (w' - w) + dt m x (I m), m = (w + w') / 2
      // (a body that does not turn, rain's falling capsules: F = 0 at w' = w, and the one Newton
      // step below would give w back bit for bit, each zero's sign too: F = +0, so every row of
      // J^-1 F has the +0 of its positive diagonal, and w - (+0) = w)
      if (w.x() == 0.0 && w.y() == 0.0 && w.z() == 0.0) return w;
      Vec3 w1 = w;
      for (int k = 0; k < 10; ++k) {
        const Vec3 m = 0.5 * (w + w1);
        const Vec3 F = I * (w1 - w) + dt * m.cross(I * m);
        const Mat3 J = I + 0.5 * dt * (math::skew(m) * I - math::skew(I * m));
        const Vec3 step = J.inverse() * F;
        w1 -= step;
        if (step.lpNorm<Eigen::Infinity>() <= 1e-14 * w1.lpNorm<Eigen::Infinity>()) break;
      }
      // the gyroscopic term does no work: never leave with more energy than we came with
      const double E0 = w.dot(I * w), E1 = w1.dot(I * w1);
      if (E1 > E0) w1 *= std::sqrt(E0 / E1);
      return w1;
    }
  }
  throw std::logic_error("free_rotation: unknown gyroscopic option");
}

void unconstrained_velocity(const Model& model, const State& state, const Vec3& gravity, double dt,
                            Gyroscopic gyroscopic, std::vector<Vec3>& v_star, std::vector<Vec3>& omega_star,
                            const parallel::Pool* pool, const std::vector<BodyIndex>* bodies) {
  const std::size_t n = model.size();
  parallel::fit(v_star, n, Vec3(Vec3::Zero()));
  parallel::fit(omega_star, n, Vec3(Vec3::Zero()));
  parallel::for_bodies(pool, bodies, n, kBodiesPerTask, [&](std::size_t i) {
    if (model.is_static[i]) {
      v_star[i].setZero();
      omega_star[i].setZero();
      return;
    }
    if (model.is_kinematic[i] || !model.enabled[i] || state.asleep(i)) {
      // moved by its own velocity only (kinematic), or frozen (disabled, asleep): no gravity, no forces
      v_star[i] = state.v[i];
      omega_star[i] = state.omega[i];
      return;
    }
    const Mat3& R = state.R[i];
    const Vec3 f = state.f_ext[i] + state.f_step[i];
    const Vec3 tau = state.tau_ext[i] + state.tau_step[i];
    // linear: m p_dot* = m p_dot + dt (m g + f_ext)
    v_star[i] = state.v[i] + dt * (gravity + model.inv_mass[i] * f);
    const Mat3& I = model.I_body[i];
    if (I(0, 1) == 0.0 && I(0, 2) == 0.0 && I(1, 2) == 0.0 && I(1, 0) == 0.0 && I(2, 0) == 0.0 && I(2, 1) == 0.0 &&
        I(0, 0) == I(1, 1) && I(1, 1) == I(2, 2)) {
      // the same inertia about every axis (a sphere, a cube): omega x (I omega) = 0, so every
      // gyroscopic rule keeps omega, and I_w^-1 = I_body^-1 in any frame. Exactly so here, rather
      // than through the body frame and back (whose rounding turned omega by about 1e-16 a
      // substep) and the midpoint rule's Newton iterations (a fifth of the pyramid's solve stage)
      omega_star[i] = state.omega[i] + dt * (model.I_body_inv[i](0, 0) * tau);
      return;
    }
    if (gyroscopic == Gyroscopic::Explicit) {
      // angular: I_w omega* = I_w omega + dt (tau_ext - omega x (I_w omega))
      const Vec3& w = state.omega[i];
      const Vec3 L = R * (model.I_body[i] * (R.transpose() * w));
      const Vec3 torque = tau - w.cross(L);
      omega_star[i] = w + dt * (R * (model.I_body_inv[i] * (R.transpose() * torque)));
      return;
    }
    // angular, body frame: the free rotation, then the external torque's impulse
    const Vec3 w_body = R.transpose() * state.omega[i];
    const Vec3 w1 = free_rotation(model.I_body[i], model.I_body_inv[i], w_body, dt, gyroscopic);
    omega_star[i] = R * (w1 + dt * (model.I_body_inv[i] * (R.transpose() * tau)));
  });
}

void integrate(const Model& model, State& state, const std::vector<Vec3>& v, const std::vector<Vec3>& omega,
               double dt, const parallel::Pool* pool, const std::vector<BodyIndex>* bodies) {
  parallel::for_bodies(pool, bodies, model.size(), kBodiesPerTask, [&](std::size_t i) {
    if (model.is_static[i] || !model.enabled[i] || state.asleep(i)) return;  // asleep: bit for bit
    state.R[i] = math::orthonormalize(math::rodrigues(omega[i], dt) * state.R[i]);
    state.p[i] += dt * v[i];
  });
}

void apply_impulses(const Model& model, State& state, const std::vector<BodyIndex>* bodies) {
  parallel::each_body(bodies, model.size(), [&](std::size_t i) {
    Vec3& J = state.impulse[i];
    Vec3& L = state.angular_impulse[i];
    if (J.squaredNorm() == 0.0 && L.squaredNorm() == 0.0) return;
    if (model.enabled[i] && !model.is_static[i] && !model.is_kinematic[i]) {
      state.v[i] += model.inv_mass[i] * J;
      state.omega[i] += inverse_inertia_world(model, state, i) * L;
    }
    J.setZero();
    L.setZero();
  });
}

void advance(const Model& model, State& state, const std::vector<Vec3>& v_move, const std::vector<Vec3>& omega_move,
             const std::vector<Vec3>& v, const std::vector<Vec3>& omega, double h, const parallel::Pool* pool,
             const std::vector<BodyIndex>* bodies) {
  integrate(model, state, v_move, omega_move, h, pool, bodies);
  if (v.size() != state.v.size() || omega.size() != state.omega.size())
    throw std::logic_error("advance: velocity arrays do not match the state");
  // copied, not swapped: the storage stays in place (static bodies' entries are zero in both)
  if (bodies) {
    for (const BodyIndex i : *bodies) {
      state.v[i] = v[i];
      state.omega[i] = omega[i];
    }
  } else {
    std::copy(v.begin(), v.end(), state.v.begin());
    std::copy(omega.begin(), omega.end(), state.omega.begin());
  }
  state.time += h;
}

}  // namespace signorini::dynamics
