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

/// A ball joint's twist psi (rad, in (-pi, pi]) and its rate's direction t: with a_X = R_X axis_X,
/// the swing S is the least turn taking a_B onto a_A (S x = (a_B . a_A) x + c x x + c (c . x) /
/// (1 + a_B . a_A), c = a_B x a_A), and psi is the angle from R_A ref_a to S R_B ref_b about a_A.
/// Then dpsi/dt = t . (omega_B - omega_A) exactly, t = (a_A + a_B) / (1 + a_A . a_B). False where
/// the axes point apart (1 + a_A . a_B <= 1e-9: a swing of pi, where the twist is not defined).
bool twist_angle(const Joint& j, const Mat3& RA, const Mat3& RB, double& psi, Vec3& t) {
  const Vec3 a_A = RA * j.axis_a, a_B = RB * j.axis_b;
  const double cos_swing = a_B.dot(a_A);
  if (!(1.0 + cos_swing > 1e-9)) return false;
  const Vec3 c = a_B.cross(a_A), u_a = RA * j.ref_a, u_b = RB * j.ref_b;
  const Vec3 swung = cos_swing * u_b + c.cross(u_b) + (c.dot(u_b) / (1.0 + cos_swing)) * c;
  psi = std::atan2(a_A.dot(u_a.cross(swung)), u_a.dot(swung));
  t = (a_A + a_B) / (1.0 + cos_swing);
  return true;
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

/// A unit vector normal to unit u (u x e_k for the axis e_k least along u).
Vec3 perpendicular_to(const Vec3& u) {
  int k = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(u[i]) < std::abs(u[k])) k = i;
  return u.cross(Vec3::Unit(k)).normalized();
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

/// The directions t1, t2 across a hinge's or slider's axis: the contacts' basis of A's axis in A's
/// own frame, turned with A (R_A t_k). Chosen in the world at each pose, the basis would jump where
/// the choice of the axis's smallest component changes (an axis along y turned a little): the rows'
/// warm-started forces would then act along other directions, and the drift (the rows at the
/// midpoint pose less the rows now) would be a 90-degree turn of the rows rather than h/2 of their rate.
void turning_with_a(const Joint& j, const Mat3& RA, Vec3& t1, Vec3& t2) {
  Vec3 u1, u2;
  tangent_basis(j.axis_a, u1, u2);
  t1 = RA * u1;
  t2 = RA * u2;
}

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
        turning_with_a(j, RA, t1, t2);
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
        turning_with_a(j, RA, t1, t2);
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
        if (j.has_limits) {
          // the cone: the angle phi between the axes a_A = R_A axis_a and a_B = R_B axis_b at most
          // upper; C = upper - phi, and dphi/dt = n . (omega_B - omega_A), n = unit(a_A x a_B) (any
          // normal of a_A where the axes meet: C is then the whole cone, far from binding)
          const Vec3 a_A = RA * j.axis_a, a_B = RB * j.axis_b;
          const Vec3 c = a_A.cross(a_B);
          const double s = c.norm();
          const Vec3 n = s > 1e-12 ? Vec3(c / s) : perpendicular_to(a_A);
          JointBlock& cone = add_block(js, j, JointBlock::Limit, 1, kSlotUpper, a_moves, b_moves);
          angular_row(cone, 0, -n);
          cone.C[0] = j.upper - std::atan2(s, a_A.dot(a_B));
        }
        if (j.has_twist) {  // as a hinge's limits, about t
          double psi = 0.0;
          Vec3 t;
          // where the twist is not defined (a swing of pi) the rows stay, far open (C = 2 pi: a
          // speculative row that cannot push), so a joint has the same rows at every pose (the
          // drift pairs the blocks at the substep's start and midpoint one to one)
          const bool defined = twist_angle(j, RA, RB, psi, t);
          if (!defined) t = RA * j.axis_a;
          JointBlock& lo = add_block(js, j, JointBlock::Limit, 1, kSlotTwistLower, a_moves, b_moves);
          angular_row(lo, 0, t);
          lo.C[0] = defined ? psi - j.twist_lower : 2.0 * M_PI;
          JointBlock& hi = add_block(js, j, JointBlock::Limit, 1, kSlotTwistUpper, a_moves, b_moves);
          angular_row(hi, 0, -t);
          hi.C[0] = defined ? j.twist_upper - psi : 2.0 * M_PI;
        }
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

namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

/// (J W J^T) between row i of block x and row k of block y of one joint (both on bodies a, b).
double row_K(const JointBlock& x, int i, const JointBlock& y, int k) {
  return x.ang_a[i].dot(y.w_ang_a[k]) + y.w_lin_a * x.lin_a[i].dot(y.lin_a[k]) + x.ang_b[i].dot(y.w_ang_b[k]) +
         y.w_lin_b * x.lin_b[i].dot(y.lin_b[k]);
}

/// The group of the joint whose blocks are js.blocks[first, end): K_EE over its equality rows (the
/// Equality blocks' rows in order), its inverse when positive definite (Cholesky; else the blocks are
/// solved one by one), and each bounded row's g = K_EE^-1 K_El and K_eff = K_ll - K_lE g.
void group_joint(JointSet& js, Joint& joint, std::size_t first) {
  JointGroup g;
  g.joint = &joint;
  g.first = first;
  g.end = js.blocks.size();
  std::array<std::pair<const JointBlock*, int>, 6> E;
  for (std::size_t i = first; i < g.end; ++i)
    if (js.blocks[i].kind == JointBlock::Equality)
      for (int k = 0; k < js.blocks[i].n; ++k) E[static_cast<std::size_t>(g.n_e++)] = {&js.blocks[i], k};
  if (g.n_e > 0) {
    Mat6 K_EE = Mat6::Identity();  // padded with the identity past n_e, so that one 6 x 6 Cholesky serves
    for (int r = 0; r < g.n_e; ++r)
      for (int c = 0; c < g.n_e; ++c) K_EE(r, c) = row_K(*E[r].first, E[r].second, *E[c].first, E[c].second);
    const Eigen::LLT<Mat6> llt(K_EE);
    if (llt.info() == Eigen::Success) {
      g.coupled = true;
      g.K_EE_inv = llt.solve(Mat6::Identity());
      g.K_EE_inv.bottomRows(6 - g.n_e).setZero();
      g.K_EE_inv.rightCols(6 - g.n_e).setZero();
    }
  }
  for (std::size_t i = first; i < g.end; ++i) {
    JointBlock& l = js.blocks[i];
    l.g.setZero();
    l.K_eff = l.K(0, 0);
    if (!g.coupled || l.kind == JointBlock::Equality) continue;
    Vec6 K_El = Vec6::Zero();
    for (int r = 0; r < g.n_e; ++r) K_El[r] = row_K(*E[r].first, E[r].second, l, 0);
    l.g = g.K_EE_inv * K_El;
    l.K_eff = l.K(0, 0) - K_El.dot(l.g);
  }
  js.groups.push_back(g);
}

}  // namespace

namespace {

/// Each row's drift h/2 (dJ/dt) q_dot from the velocities qd (motors: 0): the rows at the poses the
/// bodies' velocities reach in h / 2 (J(x_{n+1/2}) q_dot - J(x_n) q_dot), half the rows' centripetal
/// term over the substep, asked of the solve as a velocity bias: the solved velocity is then the one
/// the rows allow at the substep's midpoint. Projected at x_n alone, a swing loses O((v h / L)^2) of
/// its energy at every substep (the next substep's rows have turned by v h / L); at x_{n+1} it gains
/// as much; at the midpoint the two cancel to that order (docs/conventions.md, "Joints").
/// rows: the contact rows; a joint one of whose moving bodies has a contact in them keeps drift 0
/// (null: every joint gets its drift).
/// turn: the most a joint's bodies may turn in h / 2 for its drift (rad; the soft step's kDriftTurn,
/// the PGS none). limits: whether limit rows get theirs (the PGS's do; the soft step's not: the
/// midpoint's cancellation holds for a row that holds through the substep, and a limit that lets go
/// keeps the separating velocity its drift asked for: a taut rope between two capsules spun at
/// 190 rad/s, in substeps of 1/960 s, doubled fuzz 1:1's energy on it)
void predict_drift(JointSet& js, const State& state, const std::vector<BodyVelocity>& qd, double h,
                   const parallel::HugeVector<ContactRows>* rows, double turn, bool limits) {
  const double half = 0.5 * h;
  if (rows) {
    js.touching.assign(qd.size(), 0);
    for (const ContactRows& r : *rows) {
      if (r.a_moves) js.touching[static_cast<std::size_t>(r.a)] = 1;
      if (r.b_moves) js.touching[static_cast<std::size_t>(r.b)] = 1;
    }
  }
  for (const JointGroup& g : js.groups) {
    Joint& j = *g.joint;
    if (rows && (js.touching[static_cast<std::size_t>(j.a)] || js.touching[static_cast<std::size_t>(j.b)])) continue;
    // nor, in the soft step, where a body turns more than kDriftTurn in h / 2: the rule is the first
    // term of an expansion in that turn (a 1 cm capsule of a fuzzed chain, spun to 1,800 rad/s, turned
    // 1.9 rad in h / 2 and gained energy without bound on it)
    if (half * std::max(qd[j.a].omega.norm(), qd[j.b].omega.norm()) > turn) continue;
    const BodyVelocity& va = qd[j.a];
    const BodyVelocity& vb = qd[j.b];
    const Pose A1{state.p[j.a] + half * va.v, math::rodrigues(va.omega, half) * state.R[j.a]};
    const Pose B1{state.p[j.b] + half * vb.v, math::rodrigues(vb.omega, half) * state.R[j.b]};
    const std::size_t n = g.end - g.first, there = js.blocks.size();
    // the midpoint's blocks, made after the others and dropped (effort rows set the joint's alpha
    // to its effort again, which it holds)
    build_blocks(js, j, A1, B1, js.blocks[g.first].a_moves, js.blocks[g.first].b_moves, h);
    for (std::size_t k = 0; k < n; ++k) {
      JointBlock& b = js.blocks[g.first + k];
      const JointBlock& b1 = js.blocks[there + k];
      b.drift.setZero();
      if (b.kind == JointBlock::Motor || (!limits && b.kind == JointBlock::Limit)) continue;
      for (int r = 0; r < b.n; ++r)
        b.drift[r] = (b1.ang_a[r] - b.ang_a[r]).dot(va.omega) + (b1.lin_a[r] - b.lin_a[r]).dot(va.v) +
                     (b1.ang_b[r] - b.ang_b[r]).dot(vb.omega) + (b1.lin_b[r] - b.lin_b[r]).dot(vb.v);
    }
    js.blocks.resize(there);
  }
}

}  // namespace

void prepare_joints(const Model& model, const State& state, double h, const SolverSettings* soft, bool predict, JointSet& js,
                    const SolverData& d) {
  js.blocks.clear();
  js.groups.clear();
  js.state = &state;
  js.hard_sweeps = 0;
  js.drift_after_first_sweep = predict && !soft;
  if (soft) soften(js, std::min(soft->joint_hertz, kMaxHertzPerRate / h), soft->joint_damping_ratio, h);
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
    group_joint(js, j, first);
  }
  // the soft step: the drift of the velocities before the solve; the PGS: of those its first sweep
  // leaves (sweep_joints), which the joints and contacts have already made consistent: the velocities
  // before the solve may run into a contact or a limit, and their midpoint rows then ask the solve
  // for velocities that are not there to keep (measured: 50 ragdolls in a pile gained 800 J in one
  // step at one substep, and more with every extra sweep); and, in both, none for a joint whose
  // bodies touch something (a contact changes their velocities within the substep, so the midpoint
  // is not where they go: small ragdolls spun to hundreds of rad/s in fuzzed piles exploded on it)
  if (predict && soft) predict_drift(js, state, d.qd, h, &d.rows, kDriftTurn, false);
}

void warm_start_joints(const JointSet& js, SolverData& d) {
  for (const JointBlock& b : js.blocks) apply(b, Vec3(b.alpha[0], b.n > 1 ? b.alpha[1] : 0.0, b.n > 2 ? b.alpha[2] : 0.0), d.qd);
}

namespace {

/// The new force of a bounded row (limit or motor) of velocity u (J q_dot with its drift) whose K is
/// k (the row's own, or its group's effective one), in a sweep of `mode`:
///   limit  C > 0: alpha - (u + C / h) / k (speculative: close the distance, no more); else
///          alpha - (u + bias C) / k softened (the soft step's biased sweep) or alpha - u / k; >= 0
///   motor  alpha - (u - target) / k (rigid) or alpha - (u + gamma alpha - target) / (k + gamma)
///          (a spring-damper), in [lo, hi]
double bounded_next(const JointBlock& b, const JointSet& js, double old, double u, double k, JointSweep mode,
                    double inv_h) {
  const double k_inv = k > 0.0 ? 1.0 / k : 0.0;
  if (b.kind == JointBlock::Limit) {
    const double C = b.C[0];
    double next;
    if (C > 0.0) {
      next = old - k_inv * (u + C * inv_h);
    } else if (mode == JointSweep::SoftBiased) {
      next = old - js.mass_scale * k_inv * (u + js.bias_rate * C) - js.impulse_scale * old;
    } else {
      next = old - k_inv * u;
    }
    return std::max(next, 0.0);
  }
  return b.gamma == 0.0 ? std::clamp(old - k_inv * (u - b.target), b.lo, b.hi)
                        : std::clamp(old - (u + b.gamma * old - b.target) / (k + b.gamma), b.lo, b.hi);
}

/// Block i alone in a sweep of `mode` on d.qd; returns its rows' largest velocity change.
double solve_block(JointSet& js, std::size_t i, SolverData& d, JointSweep mode, double inv_h) {
  JointBlock& b = js.blocks[i];
  const Vec3 u = block_velocity(b, d.qd) + b.drift;
  Vec3 d_alpha = Vec3::Zero();
  if (b.kind == JointBlock::Equality) {
    const Vec3 alpha(b.alpha[0], b.n > 1 ? b.alpha[1] : 0.0, b.n > 2 ? b.alpha[2] : 0.0);
    if (mode == JointSweep::SoftBiased)
      d_alpha = -js.mass_scale * (b.K_inv * (u + js.bias_rate * b.C)) - js.impulse_scale * alpha;
    else
      d_alpha = -(b.K_inv * u);
    if (b.n < 3) d_alpha[2] = 0.0;
    if (b.n < 2) d_alpha[1] = 0.0;
    for (int k = 0; k < b.n; ++k) b.alpha[k] += d_alpha[k];
  } else {
    const double old = b.alpha[0];
    b.alpha[0] = bounded_next(b, js, old, u[0], b.K(0, 0), mode, inv_h);
    d_alpha[0] = b.alpha[0] - old;
  }
  apply(b, d_alpha, d.qd);
  return change_of(b, d_alpha);
}

/// The equality rows of group g take the force changes d_E (n_e entries, in their blocks' order):
/// added to alpha(i) of each Equality block i and applied to qd.
template <class Alpha>
void add_to_equalities(const JointSet& js, const JointGroup& g, const Vec6& d_E, std::vector<BodyVelocity>& qd,
                       Alpha alpha) {
  int r = 0;
  for (std::size_t i = g.first; i < g.end; ++i) {
    const JointBlock& b = js.blocks[i];
    if (b.kind != JointBlock::Equality) continue;
    const Vec3 part(d_E[r], b.n > 1 ? d_E[r + 1] : 0.0, b.n > 2 ? d_E[r + 2] : 0.0);
    double* a = alpha(i);
    for (int k = 0; k < b.n; ++k) a[k] += part[k];
    apply(b, part, qd);
    r += b.n;
  }
}

/// One pass over a coupled group (JointGroup) on qd: the equality rows at once, d_alpha_E =
/// -K_EE^-1 (J_E qd + bias_E) (unless `equalities` is false: then they only follow); then each
/// bounded row l that is `active`, its new force from next(l, alpha_l, J_l qd + bias_l, K_eff), the
/// equality rows following it by -g_l d_alpha_l. bias(i): block i's velocity bias; alpha(i): where
/// block i's forces accumulate. Returns the rows' largest velocity change (the equality rows: their
/// residual |J_E qd + bias_E|).
template <class Bias, class Alpha, class Active, class Next>
double solve_group(const JointSet& js, const JointGroup& g, std::vector<BodyVelocity>& qd, Bias bias, Alpha alpha,
                   Active active, Next next, bool equalities = true) {
  double change = 0.0;
  if (equalities) {
    Vec6 u_E = Vec6::Zero();
    int r = 0;
    for (std::size_t i = g.first; i < g.end; ++i) {
      const JointBlock& b = js.blocks[i];
      if (b.kind != JointBlock::Equality) continue;
      const Vec3 u = block_velocity(b, qd) + bias(i);
      for (int k = 0; k < b.n; ++k, ++r) u_E[r] = u[k];
    }
    change = u_E.cwiseAbs().maxCoeff();
    add_to_equalities(js, g, Vec6(-(g.K_EE_inv * u_E)), qd, alpha);
  }
  for (std::size_t i = g.first; i < g.end; ++i) {
    const JointBlock& l = js.blocks[i];
    if (l.kind == JointBlock::Equality || !active(l)) continue;
    double* a = alpha(i);
    const double old = a[0];
    a[0] = next(l, old, block_velocity(l, qd)[0] + bias(i)[0], l.K_eff);
    const double d_l = a[0] - old;
    if (d_l == 0.0) continue;
    apply(l, Vec3(d_l, 0.0, 0.0), qd);
    add_to_equalities(js, g, -d_l * l.g, qd, alpha);
    change = std::max(change, std::abs(l.K_eff * d_l));
  }
  return change;
}

/// The soft step's biased pass over a coupled group. A soft row's new force is mass_scale times the
/// rigid force that the velocity without it asks: alpha + d_alpha = (1 - impulse_scale) alpha -
/// mass_scale K^-1 (J qd + bias) = mass_scale (alpha - K^-1 (J qd + bias)), as 1 - impulse_scale =
/// mass_scale. For a group, K is the matrix of its equality rows and its limits with C <= 0
/// together. Solved one after the other, each with its own release (-impulse_scale alpha), the
/// equality rows' release reached the limit unanswered: the point rows of a hinge whose anchor is
/// far from a body of small inertia (m L^2 / I = 25,000) carry the limit's force through that lever,
/// and a tenth of it given back spun the body at thousands of rad/s (the point-like bob, test_joints:
/// an energy explosion). So the soft rows (and the speculative limits, C > 0) give their forces
/// back, the group is solved rigidly from zero (the equality rows at once, then the limits with
/// C <= 0 with the equality rows following: exact for one active limit), and (1 - mass_scale) of
/// that is taken back; then the rigid rows: motors, friction and effort from their forces, the
/// speculative limits from zero (close the distance, no more), the equality rows following each in
/// full. A speculative limit kept its force through the equality rows' solve, and softening their
/// answer to it exploded the bob at rest (the limit's C passing through 0 substep by substep); one
/// softened with them made the arm with a welded load bounce off its limit and explode at rest.
/// The change reported is 0: the soft step runs a fixed number of sweeps.
template <class Bias>
void solve_group_soft(const JointSet& js, const JointGroup& g, std::vector<BodyVelocity>& qd, Bias bias,
                      double inv_h) {
  const auto soft_row = [](const JointBlock& b) {
    return b.kind == JointBlock::Equality || (b.kind == JointBlock::Limit && b.C[0] <= 0.0);
  };
  const auto speculative = [](const JointBlock& b) { return b.kind == JointBlock::Limit && b.C[0] > 0.0; };
  // the soft rows' alpha -> s alpha (and the speculative limits' too, when `all`), applied to qd
  const auto scale = [&](double s, bool all) {
    for (std::size_t i = g.first; i < g.end; ++i) {
      const JointBlock& b = js.blocks[i];
      if (!soft_row(b) && !(all && speculative(b))) continue;
      Vec3 d = Vec3::Zero();
      for (int k = 0; k < b.n; ++k) {
        d[k] = (s - 1.0) * b.alpha[k];
        b.alpha[k] += d[k];
      }
      apply(b, d, qd);
    }
  };
  const auto alpha = [&](std::size_t i) { return js.blocks[i].alpha; };
  const auto soft_limit = [&](const JointBlock& b) { return b.kind == JointBlock::Limit && soft_row(b); };
  const auto pushing = [&](const JointBlock& b, double old, double u, double k) {
    return std::max(old - (k > 0.0 ? 1.0 / k : 0.0) * (u + js.bias_rate * b.C[0]), 0.0);
  };
  scale(0.0, true);
  solve_group(js, g, qd, bias, alpha, soft_limit, pushing);
  scale(js.mass_scale, false);
  // then the rigid rows from where they were (motors, friction, effort), and the speculative
  // limits from zero, rigid (close the distance, no more), the equality rows following each in full
  const auto rigid_row = [&](const JointBlock& b) { return !soft_row(b); };
  const auto next = [&](const JointBlock& b, double old, double u, double k) {
    return bounded_next(b, js, old, u, k, JointSweep::SoftBiased, inv_h);
  };
  solve_group(js, g, qd, bias, alpha, rigid_row, next, false);
}

}  // namespace

double sweep_joints(JointSet& js, SolverData& d, JointSweep mode, double h) {
  double change = 0.0;
  const double inv_h = 1.0 / h;
  const bool biased = mode == JointSweep::SoftBiased;
  // the velocity bias: the drift, and in the biased sweep the equality rows' spring on C
  const auto drift = [&](std::size_t i) {
    const JointBlock& b = js.blocks[i];
    return biased && b.kind == JointBlock::Equality ? Vec3(b.drift + js.bias_rate * b.C) : b.drift;
  };
  const auto alpha = [&](std::size_t i) { return js.blocks[i].alpha; };
  const auto every = [](const JointBlock&) { return true; };
  const auto next = [&](const JointBlock& b, double old, double u, double k) {
    return bounded_next(b, js, old, u, k, mode, inv_h);
  };
  if (mode == JointSweep::Hard && js.drift_after_first_sweep && ++js.hard_sweeps == 2)
    predict_drift(js, *js.state, d.qd, h, &d.rows, std::numeric_limits<double>::infinity(), true);
  for (const JointGroup& g : js.groups) {
    if (g.coupled && biased) {
      solve_group_soft(js, g, d.qd, drift, inv_h);
    } else if (g.coupled) {
      change = std::max(change, solve_group(js, g, d.qd, drift, alpha, every, next));
    } else {
      for (std::size_t i = g.first; i < g.end; ++i) change = std::max(change, solve_block(js, i, d, mode, inv_h));
    }
  }
  return change;
}

int joint_position_pass(const SolverSettings& s, double h, JointSet& js, SolverData& d) {
  const std::size_t n = js.blocks.size();
  // every equality block takes part (one without an error holds while the others are corrected);
  // a limit only while it is violated; the pass runs when some block has an error
  const auto violated = [](const JointBlock& b) { return b.kind == JointBlock::Limit && b.C[0] < 0.0; };
  const auto active = [&](const JointBlock& b) { return b.kind == JointBlock::Equality || violated(b); };
  bool any = false;
  for (const JointBlock& b : js.blocks) any = any || (b.kind == JointBlock::Equality ? !b.C.isZero(0.0) : violated(b));
  if (!any) return 0;
  js.beta.assign(n, {0.0, 0.0, 0.0});
  const double rate = s.erp / h;
  const auto bias = [&](std::size_t i) { return Vec3(rate * js.blocks[i].C); };  // J q_p = -erp C / h
  const auto beta = [&](std::size_t i) { return js.beta[i].data(); };
  const auto next = [](const JointBlock&, double old, double u, double k) {
    return std::max(old - (k > 0.0 ? 1.0 / k : 0.0) * u, 0.0);
  };
  int sweeps = 0;
  bool converged = false;
  while (!converged && sweeps < s.max_iterations) {
    ++sweeps;
    double change = 0.0;
    for (const JointGroup& g : js.groups) {
      if (g.coupled) {
        change = std::max(change, solve_group(js, g, d.qd_p, bias, beta, violated, next));
        continue;
      }
      for (std::size_t i = g.first; i < g.end; ++i) {
        const JointBlock& b = js.blocks[i];
        if (!active(b)) continue;
        const Vec3 u = block_velocity(b, d.qd_p) + bias(i);
        Vec3 d_beta = Vec3::Zero();
        if (b.kind == JointBlock::Equality) {
          d_beta = -(b.K_inv * u);
          if (b.n < 3) d_beta[2] = 0.0;
          if (b.n < 2) d_beta[1] = 0.0;
          for (int k = 0; k < b.n; ++k) js.beta[i][k] += d_beta[k];
        } else {
          const double nxt = next(b, js.beta[i][0], u[0], b.K(0, 0));
          d_beta[0] = nxt - js.beta[i][0];
          js.beta[i][0] = nxt;
        }
        apply(b, d_beta, d.qd_p);
        change = std::max(change, change_of(b, d_beta));
      }
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
