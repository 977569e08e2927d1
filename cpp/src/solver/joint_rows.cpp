#include "solver/joint_rows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "math/rotation.hpp"
#include "solver/contact_solver.hpp"

namespace signorini::solver {
namespace {

/// Where a joint sits now: world lever arms r_X = R_X anchor_X, anchor points x_X = p_X + r_X, and
/// d = x_B - x_A.
struct Frames {
  Vec3 r_a, r_b, d;
};

Frames frames(const Joint& j, const State& s) {
  Frames f;
  f.r_a = s.R[j.a] * j.anchor_a;
  f.r_b = s.R[j.b] * j.anchor_b;
  f.d = (s.p[j.b] + f.r_b) - (s.p[j.a] + f.r_a);
  return f;
}

/// The axial vector of the skew part of E: for E = exp([phi]x) close to I, phi (sin |phi| along it).
Vec3 axial(const Mat3& E) {
  return 0.5 * Vec3(E(2, 1) - E(1, 2), E(0, 2) - E(2, 0), E(1, 0) - E(0, 1));
}

/// A hinge's angle: B's turn about the axis relative to A (rad, in (-pi, pi]).
double hinge_angle(const Joint& j, const Mat3& RA, const Mat3& RB) {
  const Vec3 axis = RA * j.axis_a;
  const Vec3 u_a = RA * j.ref_a, u_b = RB * j.ref_b;
  return std::atan2(axis.dot(u_a.cross(u_b)), u_a.dot(u_b));
}

bool moves(const Model& model, const State& state, int i) {
  return !model.is_static[i] && !model.is_kinematic[i] && model.enabled[i] && !state.asleep(i);
}

/// A new block of `kind` and n rows of joint j, alpha at its slot.
JointBlock& add_block(JointSet& js, Joint& j, JointBlock::Kind kind, int n, int slot, bool a_moves, bool b_moves) {
  js.blocks.emplace_back();
  JointBlock& b = js.blocks.back();
  b.kind = kind;
  b.n = n;
  b.a = j.a;
  b.b = j.b;
  b.a_moves = a_moves;
  b.b_moves = b_moves;
  b.alpha = &j.alpha[static_cast<std::size_t>(slot)];
  return b;
}

/// Row k of a block along the linear direction e at the points (lever arms ra_lin on A's angular
/// part, r_b on B's): J_A = (-(ra_lin x e), -e), J_B = (r_b x e, e).
void linear_row(JointBlock& b, int k, const Vec3& e, const Vec3& ra_lin, const Vec3& r_b) {
  b.ang_a[k] = -ra_lin.cross(e);
  b.lin_a[k] = -e;
  b.ang_b[k] = r_b.cross(e);
  b.lin_b[k] = e;
}

/// Row k about the direction e: J_A = (-e, 0), J_B = (e, 0).
void angular_row(JointBlock& b, int k, const Vec3& e) {
  b.ang_a[k] = -e;
  b.lin_a[k].setZero();
  b.ang_b[k] = e;
  b.lin_b[k].setZero();
}

/// w_ang = dt I_X^-1 ang_X of a block whose Jacobians are set (d.dI_inv holds dt I^-1, world).
void finish_block(JointBlock& b, const SolverData& d) {
  for (int k = 0; k < b.n; ++k) {
    b.w_ang_a[k] = b.a_moves ? Vec3(d.dI_inv[b.a] * b.ang_a[k]) : Vec3::Zero();
    b.w_ang_b[k] = b.b_moves ? Vec3(d.dI_inv[b.b] * b.ang_b[k]) : Vec3::Zero();
  }
}

/// K = J W J^T and its inverse (zero when singular).
void finish_K(JointBlock& b) {
  b.K.setZero();
  for (int j = 0; j < b.n; ++j)
    for (int k = 0; k < b.n; ++k)
      b.K(j, k) = b.ang_a[j].dot(b.w_ang_a[k]) + b.w_lin_a * b.lin_a[j].dot(b.lin_a[k]) + b.ang_b[j].dot(b.w_ang_b[k]) +
                  b.w_lin_b * b.lin_b[j].dot(b.lin_b[k]);
  b.K_inv.setZero();
  if (b.n == 1) {
    if (b.K(0, 0) > 0.0) b.K_inv(0, 0) = 1.0 / b.K(0, 0);
  } else if (b.n == 2) {
    const Eigen::Matrix2d K2 = b.K.topLeftCorner<2, 2>();
    const double det = K2.determinant();
    if (det > 0.0) b.K_inv.topLeftCorner<2, 2>() = K2.inverse();
  } else {
    const double det = b.K.determinant();
    if (det > 0.0) b.K_inv = b.K.inverse();
  }
}

/// J q_dot of the block's rows (n entries) at velocities qd.
Vec3 block_velocity(const JointBlock& b, const std::vector<BodyVelocity>& qd) {
  const BodyVelocity& A = qd[b.a];
  const BodyVelocity& B = qd[b.b];
  Vec3 u = Vec3::Zero();
  for (int k = 0; k < b.n; ++k)
    u[k] = b.ang_a[k].dot(A.omega) + b.lin_a[k].dot(A.v) + b.ang_b[k].dot(B.omega) + b.lin_b[k].dot(B.v);
  return u;
}

/// q_dot += W J^T d_alpha for the block's force changes.
void apply(const JointBlock& b, const Vec3& d_alpha, std::vector<BodyVelocity>& qd) {
  if (b.a_moves) {
    BodyVelocity& A = qd[b.a];
    for (int k = 0; k < b.n; ++k) {
      A.omega += d_alpha[k] * b.w_ang_a[k];
      A.v += (d_alpha[k] * b.w_lin_a) * b.lin_a[k];
    }
  }
  if (b.b_moves) {
    BodyVelocity& B = qd[b.b];
    for (int k = 0; k < b.n; ++k) {
      B.omega += d_alpha[k] * b.w_ang_b[k];
      B.v += (d_alpha[k] * b.w_lin_b) * b.lin_b[k];
    }
  }
}

/// The largest |(K d_alpha)_k|: how much the block changed its rows' velocities.
double change_of(const JointBlock& b, const Vec3& d_alpha) {
  double m = 0.0;
  for (int j = 0; j < b.n; ++j) {
    double x = 0.0;
    for (int k = 0; k < b.n; ++k) x += b.K(j, k) * d_alpha[k];
    m = std::max(m, std::abs(x));
  }
  return m;
}

/// The soft step's spring of `hertz` and damping ratio zeta over h (the contacts' soften).
void soften(JointSet& js, double hertz, double zeta, double h) {
  const Softness k = solver::soften(hertz, zeta, h);
  js.bias_rate = k.bias_rate;
  js.mass_scale = k.mass_scale;
  js.impulse_scale = k.impulse_scale;
}

}  // namespace

/// Where a body is: its centre of mass p and rotation R (world).
struct Pose {
  Vec3 p;
  Mat3 R;
};

/// The drive row b of a one-dof joint whose coordinate is x (rad or m): a rigid velocity motor, or
/// a spring-damper F = k (position - x_new) + c (speed - x_dot_new) over a substep of h with
/// x_new = x + h x_dot_new, i.e. x_dot_new = target - gamma F with gamma = 1 / (k h + c) and
/// target = gamma (k (position - x) + c speed); a hinge's position error taken the short way round.
void drive(JointBlock& b, const Motor& m, double x, double h, bool angle) {
  b.lo = -m.max_force;
  b.hi = m.max_force;
  if (!m.soft()) {
    b.target = m.speed;
    b.gamma = 0.0;
    return;
  }
  double error = m.position - x;
  if (angle) error = std::remainder(error, 2.0 * M_PI);  // in [-pi, pi]
  b.gamma = 1.0 / (m.stiffness * h + m.damping);
  b.target = b.gamma * (m.stiffness * error + m.damping * m.speed);
}

/// The friction row b of a one-dof joint: a rigid motor of speed 0 whose force is at most `friction`.
void resist(JointBlock& b, double friction) {
  b.target = 0.0;
  b.gamma = 0.0;
  b.lo = -friction;
  b.hi = friction;
}

/// The effort row b of joint j: bounds lo = hi = effort, so every sweep leaves alpha = effort, and
/// its force is applied once per substep, by the warm start (the joint's alpha holds it), or by the
/// first sweep without warm start.
void push_with(JointBlock& b, Joint& j) {
  b.target = 0.0;
  b.gamma = 0.0;
  b.lo = b.hi = j.effort;
  *b.alpha = j.effort;
}

/// Appends the blocks of joint j with its bodies at poses A and B (Jacobians and C only; h: the
/// substep, for a spring-damper drive).
void build_blocks(JointSet& js, Joint& j, const Pose& A, const Pose& B, bool a_moves, bool b_moves, double h) {
  Frames f;
  f.r_a = A.R * j.anchor_a;
  f.r_b = B.R * j.anchor_b;
  f.d = (B.p + f.r_b) - (A.p + f.r_a);
  const Mat3& RA = A.R;
  const Mat3& RB = B.R;
    switch (j.kind) {
      case JointKind::Revolute: {
        const Vec3 axis = RA * j.axis_a;
        const double theta = hinge_angle(j, RA, RB);
        if (j.motor.enabled) {
          JointBlock& b = add_block(js, j, JointBlock::Motor, 1, kSlotMotor, a_moves, b_moves);
          angular_row(b, 0, axis);
          drive(b, j.motor, theta, h, true);
        }
        if (j.friction > 0.0) {
          JointBlock& b = add_block(js, j, JointBlock::Motor, 1, kSlotFriction, a_moves, b_moves);
          angular_row(b, 0, axis);
          resist(b, j.friction);
        }
        if (j.effort != 0.0) {
          JointBlock& b = add_block(js, j, JointBlock::Motor, 1, kSlotEffort, a_moves, b_moves);
          angular_row(b, 0, axis);
          push_with(b, j);
        }
        if (j.has_limits) {
          JointBlock& lo = add_block(js, j, JointBlock::Limit, 1, kSlotLower, a_moves, b_moves);
          angular_row(lo, 0, axis);
          lo.C[0] = theta - j.lower;
          JointBlock& hi = add_block(js, j, JointBlock::Limit, 1, kSlotUpper, a_moves, b_moves);
          angular_row(hi, 0, -axis);
          hi.C[0] = j.upper - theta;
        }
        JointBlock& p = add_block(js, j, JointBlock::Equality, 3, kSlotLinear, a_moves, b_moves);
        for (int k = 0; k < 3; ++k) linear_row(p, k, Vec3::Unit(k), f.r_a, f.r_b);
        p.C = f.d;
        JointBlock& w = add_block(js, j, JointBlock::Equality, 2, kSlotAngular, a_moves, b_moves);
        Vec3 t1, t2;
        tangent_basis(axis, t1, t2);
        const Vec3 tilt = axis.cross(RB * j.axis_b);  // B's axis turned off A's (sin of the angle)
        angular_row(w, 0, t1);
        angular_row(w, 1, t2);
        w.C = Vec3(t1.dot(tilt), t2.dot(tilt), 0.0);
        break;
      }
      case JointKind::Prismatic: {
        const Vec3 axis = RA * j.axis_a;
        const Vec3 ra_lin = f.r_a + f.d;  // A's lever arm to B's anchor: the axis turns with A
        const double s = axis.dot(f.d);
        if (j.motor.enabled) {
          JointBlock& b = add_block(js, j, JointBlock::Motor, 1, kSlotMotor, a_moves, b_moves);
          linear_row(b, 0, axis, ra_lin, f.r_b);
          drive(b, j.motor, s, h, false);
        }
        if (j.friction > 0.0) {
          JointBlock& b = add_block(js, j, JointBlock::Motor, 1, kSlotFriction, a_moves, b_moves);
          linear_row(b, 0, axis, ra_lin, f.r_b);
          resist(b, j.friction);
        }
        if (j.effort != 0.0) {
          JointBlock& b = add_block(js, j, JointBlock::Motor, 1, kSlotEffort, a_moves, b_moves);
          linear_row(b, 0, axis, ra_lin, f.r_b);
          push_with(b, j);
        }
        if (j.has_limits) {
          JointBlock& lo = add_block(js, j, JointBlock::Limit, 1, kSlotLower, a_moves, b_moves);
          linear_row(lo, 0, axis, ra_lin, f.r_b);
          lo.C[0] = s - j.lower;
          JointBlock& hi = add_block(js, j, JointBlock::Limit, 1, kSlotUpper, a_moves, b_moves);
          linear_row(hi, 0, -axis, ra_lin, f.r_b);
          hi.C[0] = j.upper - s;
        }
        Vec3 t1, t2;
        tangent_basis(axis, t1, t2);
        JointBlock& p = add_block(js, j, JointBlock::Equality, 2, kSlotLinear, a_moves, b_moves);
        linear_row(p, 0, t1, ra_lin, f.r_b);
        linear_row(p, 1, t2, ra_lin, f.r_b);
        p.C = Vec3(t1.dot(f.d), t2.dot(f.d), 0.0);
        JointBlock& w = add_block(js, j, JointBlock::Equality, 3, kSlotAngular, a_moves, b_moves);
        for (int k = 0; k < 3; ++k) angular_row(w, k, Vec3::Unit(k));
        w.C = axial(RB * j.R_rel.transpose() * RA.transpose());
        break;
      }
      case JointKind::Spherical: {
        JointBlock& p = add_block(js, j, JointBlock::Equality, 3, kSlotLinear, a_moves, b_moves);
        for (int k = 0; k < 3; ++k) linear_row(p, k, Vec3::Unit(k), f.r_a, f.r_b);
        p.C = f.d;
        break;
      }
      case JointKind::Fixed: {
        JointBlock& p = add_block(js, j, JointBlock::Equality, 3, kSlotLinear, a_moves, b_moves);
        for (int k = 0; k < 3; ++k) linear_row(p, k, Vec3::Unit(k), f.r_a, f.r_b);
        p.C = f.d;
        JointBlock& w = add_block(js, j, JointBlock::Equality, 3, kSlotAngular, a_moves, b_moves);
        for (int k = 0; k < 3; ++k) angular_row(w, k, Vec3::Unit(k));
        w.C = axial(RB * j.R_rel.transpose() * RA.transpose());
        break;
      }
      case JointKind::Distance: {
        const double length = f.d.norm();
        // the line from A's anchor to B's (x when they coincide: any direction is as good)
        const Vec3 u = length > 1e-12 ? Vec3(f.d / length) : Vec3(Vec3::UnitX());
        if (j.min_length == j.max_length) {
          JointBlock& e = add_block(js, j, JointBlock::Equality, 1, kSlotLower, a_moves, b_moves);
          linear_row(e, 0, u, f.r_a, f.r_b);
          e.C[0] = length - j.min_length;
          break;
        }
        if (j.min_length > 0.0) {
          JointBlock& lo = add_block(js, j, JointBlock::Limit, 1, kSlotLower, a_moves, b_moves);
          linear_row(lo, 0, u, f.r_a, f.r_b);
          lo.C[0] = length - j.min_length;
        }
        if (std::isfinite(j.max_length)) {
          JointBlock& hi = add_block(js, j, JointBlock::Limit, 1, kSlotUpper, a_moves, b_moves);
          linear_row(hi, 0, -u, f.r_a, f.r_b);
          hi.C[0] = j.max_length - length;
        }
        break;
      }
    }
}

void prepare_joints(const Model& model, const State& state, double h, bool soft, bool predict, JointSet& js,
                    const SolverData& d) {
  js.blocks.clear();
  if (soft) soften(js, std::min(kJointHertz, 0.25 / h), kJointDampingRatio, h);
  for (Joint& j : js.joints) {
    const bool a_moves = moves(model, state, j.a), b_moves = moves(model, state, j.b);
    if (!a_moves && !b_moves) continue;  // nothing to move (both asleep, static, kinematic or disabled)
    if (j.broken) continue;
    const std::size_t first = js.blocks.size();
    const Pose A{state.p[j.a], state.R[j.a]}, B{state.p[j.b], state.R[j.b]};
    build_blocks(js, j, A, B, a_moves, b_moves, h);
    const double inv_m_a = a_moves ? h * model.inv_mass[j.a] : 0.0;
    const double inv_m_b = b_moves ? h * model.inv_mass[j.b] : 0.0;
    for (std::size_t k = first; k < js.blocks.size(); ++k) {
      JointBlock& b = js.blocks[k];
      finish_block(b, d);
      b.w_lin_a = inv_m_a;
      b.w_lin_b = inv_m_b;
      finish_K(b);
      b.drift.setZero();
    }
    if (!predict) continue;
    // the rows at the poses the bodies' velocities reach in h / 2: J(x_{n+1/2}) q_dot - J(x_n) q_dot
    // is h/2 (dJ/dt) q_dot, half the rows' centripetal term over the substep, asked of the solve as a
    // velocity bias: the solved velocity is then the one the rows allow at the substep's midpoint.
    // Projected at x_n alone, a swing loses O((v h / L)^2) of its energy at every substep (the next
    // substep's rows have turned by v h / L); at x_{n+1} it gains as much; at the midpoint the two
    // cancel to that order (docs/conventions.md, "Joints")
    const BodyVelocity& va = d.qd[j.a];
    const BodyVelocity& vb = d.qd[j.b];
    const double half = 0.5 * h;
    const Pose A1{A.p + half * va.v, math::rodrigues(va.omega, half) * A.R};
    const Pose B1{B.p + half * vb.v, math::rodrigues(vb.omega, half) * B.R};
    const std::size_t n = js.blocks.size() - first;
    build_blocks(js, j, A1, B1, a_moves, b_moves, h);
    for (std::size_t k = 0; k < n; ++k) {
      JointBlock& b = js.blocks[first + k];
      const JointBlock& b1 = js.blocks[first + n + k];
      if (b.kind == JointBlock::Motor) continue;
      for (int r = 0; r < b.n; ++r)
        b.drift[r] = (b1.ang_a[r] - b.ang_a[r]).dot(va.omega) + (b1.lin_a[r] - b.lin_a[r]).dot(va.v) +
                     (b1.ang_b[r] - b.ang_b[r]).dot(vb.omega) + (b1.lin_b[r] - b.lin_b[r]).dot(vb.v);
    }
    js.blocks.resize(first + n);
  }
}

void warm_start_joints(const JointSet& js, SolverData& d) {
  for (const JointBlock& b : js.blocks) apply(b, Vec3(b.alpha[0], b.n > 1 ? b.alpha[1] : 0.0, b.n > 2 ? b.alpha[2] : 0.0), d.qd);
}

double sweep_joints(JointSet& js, SolverData& d, JointSweep mode, double h) {
  double change = 0.0;
  const double inv_h = 1.0 / h;
  for (JointBlock& b : js.blocks) {
    const Vec3 u = block_velocity(b, d.qd) + b.drift;
    Vec3 d_alpha = Vec3::Zero();
    switch (b.kind) {
      case JointBlock::Equality: {
        Vec3 alpha(b.alpha[0], b.n > 1 ? b.alpha[1] : 0.0, b.n > 2 ? b.alpha[2] : 0.0);
        if (mode == JointSweep::SoftBiased) {
          d_alpha = -js.mass_scale * (b.K_inv * (u + js.bias_rate * b.C)) - js.impulse_scale * alpha;
        } else {
          d_alpha = -(b.K_inv * u);
        }
        if (b.n < 3) d_alpha[2] = 0.0;
        if (b.n < 2) d_alpha[1] = 0.0;
        for (int k = 0; k < b.n; ++k) b.alpha[k] += d_alpha[k];
        break;
      }
      case JointBlock::Limit: {
        const double C = b.C[0];
        const double old = b.alpha[0];
        double next;
        if (C > 0.0) {
          next = old - b.K_inv(0, 0) * (u[0] + C * inv_h);  // speculative: close the distance, no more
        } else if (mode == JointSweep::SoftBiased) {
          next = old - js.mass_scale * b.K_inv(0, 0) * (u[0] + js.bias_rate * C) - js.impulse_scale * old;
        } else {
          next = old - b.K_inv(0, 0) * u[0];
        }
        next = std::max(next, 0.0);
        d_alpha[0] = next - old;
        b.alpha[0] = next;
        break;
      }
      case JointBlock::Motor: {
        const double old = b.alpha[0];
        // a rigid motor: J q_dot = target; a spring-damper drive: J q_dot + gamma alpha = target
        const double next = b.gamma == 0.0 ? std::clamp(old - b.K_inv(0, 0) * (u[0] - b.target), b.lo, b.hi)
                                           : std::clamp(old - (u[0] + b.gamma * old - b.target) / (b.K(0, 0) + b.gamma),
                                                        b.lo, b.hi);
        d_alpha[0] = next - old;
        b.alpha[0] = next;
        break;
      }
    }
    apply(b, d_alpha, d.qd);
    change = std::max(change, change_of(b, d_alpha));
  }
  return change;
}

int joint_position_pass(const SolverSettings& s, double h, JointSet& js, SolverData& d) {
  const std::size_t n = js.blocks.size();
  // every equality block takes part (one without an error holds while the others are corrected);
  // a limit only while it is violated; the pass runs when some block has an error
  const auto active = [](const JointBlock& b) {
    return b.kind == JointBlock::Equality || (b.kind == JointBlock::Limit && b.C[0] < 0.0);
  };
  bool any = false;
  for (const JointBlock& b : js.blocks)
    any = any || (b.kind == JointBlock::Equality ? !b.C.isZero(0.0) : b.kind == JointBlock::Limit && b.C[0] < 0.0);
  if (!any) return 0;
  js.beta.assign(n, {0.0, 0.0, 0.0});
  const double rate = s.erp / h;
  int sweeps = 0;
  bool converged = false;
  while (!converged && sweeps < s.max_iterations) {
    ++sweeps;
    double change = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const JointBlock& b = js.blocks[i];
      if (!active(b)) continue;
      const Vec3 u = block_velocity(b, d.qd_p) + rate * b.C;  // J q_p = -erp C / h
      Vec3 d_beta = Vec3::Zero();
      if (b.kind == JointBlock::Equality) {
        d_beta = -(b.K_inv * u);
        if (b.n < 3) d_beta[2] = 0.0;
        if (b.n < 2) d_beta[1] = 0.0;
        for (int k = 0; k < b.n; ++k) js.beta[i][k] += d_beta[k];
      } else {
        const double next = std::max(js.beta[i][0] - b.K_inv(0, 0) * u[0], 0.0);
        d_beta[0] = next - js.beta[i][0];
        js.beta[i][0] = next;
      }
      apply(b, d_beta, d.qd_p);
      change = std::max(change, change_of(b, d_beta));
    }
    converged = s.tolerance > 0.0 && change <= s.tolerance;
  }
  return sweeps;
}

void store_joints(const State& state, JointSet& js) {
  // each block's forces on B: F = sum_k alpha_k lin_b,k, torque about B's com sum_k alpha_k ang_b,k;
  // a joint without blocks (its bodies asleep or immovable) keeps what it last reported
  std::size_t k = 0;
  for (Joint& j : js.joints) {
    const auto mine = [&](const JointBlock& b) { return b.alpha >= j.alpha.data() && b.alpha < j.alpha.data() + kJointSlots; };
    if (k == js.blocks.size() || !mine(js.blocks[k])) continue;
    Vec3 force = Vec3::Zero(), torque_com = Vec3::Zero();
    for (; k < js.blocks.size() && mine(js.blocks[k]); ++k) {
      const JointBlock& b = js.blocks[k];
      for (int r = 0; r < b.n; ++r) {
        force += b.alpha[r] * b.lin_b[r];
        torque_com += b.alpha[r] * b.ang_b[r];
      }
    }
    // about B's anchor: tau_com - r_b x F
    j.force = force;
    j.torque = torque_com - (state.R[j.b] * j.anchor_b).cross(force);
  }
}

double joint_position(const Joint& j, const State& state) {
  const Mat3& RA = state.R[j.a];
  if (j.kind == JointKind::Revolute) return hinge_angle(j, RA, state.R[j.b]);
  if (j.kind == JointKind::Prismatic) return (RA * j.axis_a).dot(frames(j, state).d);
  return std::numeric_limits<double>::quiet_NaN();
}

double joint_velocity(const Joint& j, const State& state) {
  const Mat3& RA = state.R[j.a];
  const Vec3 axis = RA * j.axis_a;
  if (j.kind == JointKind::Revolute) return axis.dot(state.omega[j.b] - state.omega[j.a]);
  if (j.kind == JointKind::Prismatic) {
    const Frames f = frames(j, state);
    const Vec3 vb = state.v[j.b] + state.omega[j.b].cross(f.r_b);
    const Vec3 va = state.v[j.a] + state.omega[j.a].cross(f.r_a);
    // d/dt (axis . d), the axis turning with A
    return axis.dot(vb - va) + state.omega[j.a].cross(axis).dot(f.d);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

JointSet* joints_of(const SolverData& d, bool with_blocks) {
  if (d.joints == nullptr || d.joints->empty() || (with_blocks && d.joints->blocks.empty())) return nullptr;
  return d.joints;
}

}  // namespace signorini::solver
