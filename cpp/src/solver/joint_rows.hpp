// Joint rows (docs/conventions.md, "Joints"): each joint of the World becomes a few row blocks,
// Jacobian pairs J_A = (ang_a, lin_a), J_B = (ang_b, lin_b) in the lecture's (omega, p_dot) layout,
// solved beside the contact rows in both schedules:
//   the PGS (contact_solver.cpp): prepare -> warm start -> one joint sweep after each contact sweep
//     (equality rows unbiased: drift is left to the position pass) -> position pass on the
//     pseudo-velocities (erp of the position error C per substep, never kept as velocity) -> store;
//   the soft step (soft_step.cpp): per substep prepare at the substep's poses -> warm start -> a
//     joint sweep after each biased contact sweep (a spring-damper of joint_hertz on C) -> poses
//     move -> a rigid joint sweep after each relax sweep, on the same blocks (Jacobians, C and drift
//     of the substep's start) -> store.
// Blocks are solved in joint order on the calling thread (a few per joint: the results do not
// depend on the thread count). Equality blocks of 2 or 3 rows are solved together with K^-1,
// K = J W J^T, W = diag(dt I_A^-1, dt/m_A, dt I_B^-1, dt/m_B) (s/kg); limit and motor rows are single
// rows with bounds. A row's alpha is a force (N) or torque (N m), as a contact row's.
// The PGS (its iterate and position pass) solves each joint as one group (JointGroup): all its
// equality rows E at once with K_EE^-1, then each bounded row l of its free direction with the
// effective K_l - K_lE K_EE^-1 K_El, the equality rows following it (d alpha_E = -K_EE^-1 K_El
// d alpha_l) so that they stay satisfied. Row by row, a limit on a hinge whose load sits far out
// (m L^2 / I = 150) would see only the load's spin about its own centre and take hundreds of sweeps.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "signorini/joint.hpp"
#include "signorini/model.hpp"
#include "signorini/solver.hpp"
#include "signorini/state.hpp"

namespace signorini::solver {

struct SolverData;

/// Joint springs of the soft step (Catto, "Soft constraints"): a joint's position error C is a
/// spring-damper of SolverSettings::joint_hertz (capped at a quarter of the substep rate) and
/// joint_damping_ratio in the biased sweeps, and rigid in the relax sweeps.
/// The soft step asks the midpoint rule's drift of a joint only while its bodies turn at most this
/// much (rad) in half a substep (joint_rows.cpp, predict_drift; the PGS of any joint: without it a
/// fuzzed ragdoll pushed a part through a height field at dt 1/1000).
constexpr double kDriftTurn = 0.1;

/// One block of a joint's rows (1 to 3 rows of one kind), as a sweep reads it.
struct JointBlock {
  enum Kind : std::uint8_t {
    Equality,  ///< J q_dot = 0 (C = 0), unbounded, solved as one block with K^-1
    Limit,     ///< one row, alpha >= 0: J q_dot >= -C / h while C > 0 (speculative), C >= 0 kept
    Motor,     ///< one row, |alpha| <= max_force: J q_dot + gamma alpha = target
  };
  Kind kind = Equality;
  int n = 1;                 ///< rows (1..3)
  int a = 0, b = 0;          ///< bodies
  bool a_moves = false, b_moves = false;  ///< dynamic, enabled and awake (else infinite mass)
  double* alpha = nullptr;   ///< the rows' forces, in the joint's Joint::alpha (n entries)
  std::array<Vec3, 3> ang_a, lin_a, ang_b, lin_b;  ///< the rows' Jacobians (world)
  std::array<Vec3, 3> w_ang_a, w_ang_b;            ///< dt I_X^-1 ang_X (0 when X does not move)
  double w_lin_a = 0.0, w_lin_b = 0.0;             ///< dt / m_X (0 when X does not move)
  Mat3 K = Mat3::Zero();     ///< J W J^T (top-left n x n; s/kg, s/(kg m^2), ...)
  Mat3 K_inv = Mat3::Zero(); ///< its inverse (zero when K is singular)
  Vec3 C = Vec3::Zero();     ///< position error of each row (m or rad); a limit row's distance to its limit
  double lo = 0.0, hi = 0.0; ///< Motor: the bounds on alpha (N or N m)
  double target = 0.0;       ///< Motor: target J q_dot (m/s or rad/s)
  /// Motor: the drive's compliance 1 / (stiffness h + damping) (0: a rigid velocity motor; rad/(N m s)
  /// or m/(N s)): a spring-damper drive's row asks J q_dot = target - gamma alpha
  double gamma = 0.0;
  /// h/2 (dJ/dt) q_dot of each row (m/s or rad/s): J at the poses the velocities reach in h / 2,
  /// minus J now, times the velocities at prepare; the iterate and biased sweeps ask J q_dot + drift = 0
  /// (0 for a motor, and when prepare was not asked to predict)
  Vec3 drift = Vec3::Zero();
  /// In a coupled group (a bounded row only): K_EE^-1 K_El, the equality rows' forces that follow a
  /// unit force of this row (n_E entries), and this row's effective K_l - K_lE K_EE^-1 K_El
  Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
  double K_eff = 0.0;
};

/// One joint's blocks as the PGS solves them together (JointSet::groups).
struct JointGroup {
  Joint* joint = nullptr;          ///< its joint (in JointSet::joints)
  std::size_t first = 0, end = 0;  ///< its blocks in JointSet::blocks, [first, end)
  int n_e = 0;                     ///< its equality rows (0..6), its Equality blocks' rows in order
  /// whether the equality rows are solved as one (K_EE positive definite; else block by block)
  bool coupled = false;
  Eigen::Matrix<double, 6, 6> K_EE_inv = Eigen::Matrix<double, 6, 6>::Zero();  ///< top-left n_e x n_e
};

/// The World's joints as the solver sees them (owned by the World; SolverData points here).
struct JointSet {
  std::vector<Joint> joints;            ///< in index order; their alpha are the warm start
  std::vector<JointBlock> blocks;       ///< this substep's blocks, in joint order
  std::vector<JointGroup> groups;       ///< the blocks of each joint, for the PGS (prepare_joints)
  std::vector<std::array<double, 3>> beta;  ///< the PGS position pass's pseudo-forces per block
  /// what a step changes in each joint (its alpha, force and torque), kept at the step's start so
  /// that a step the guard refuses leaves the joints as they were
  struct Kept {
    std::array<double, kJointSlots> alpha;
    Vec3 force, torque;
  };
  std::vector<Kept> kept;
  // prepare's poses for the PGS's drift, which its second sweep computes from the
  // velocities the first left (predict_drift); the sweeps of this substep so far
  const State* state = nullptr;
  bool drift_after_first_sweep = false;
  std::vector<char> touching;  ///< per body: has a contact row this substep (the PGS's drift)
  int hard_sweeps = 0;
  // the soft step's joint spring for the current substep (soften: bias_rate 1/s, the two scales)
  double bias_rate = 0.0, mass_scale = 1.0, impulse_scale = 0.0;
  bool empty() const { return joints.empty(); }
};

/// The joints a solve works with: d.joints when the World has any (else null); with_blocks: only
/// when this substep's blocks are built (the sweeps' check).
JointSet* joints_of(const SolverData& d, bool with_blocks = false);

/// Sweep modes: the PGS's iterate (equality rows without bias), the soft step's biased sweep, and
/// its relax sweep (rigid).
enum class JointSweep { Hard, SoftBiased, SoftRelax };

/// Builds the blocks of every joint at the current poses.
/// In: model, state (poses p, R of the substep; sleeping flags), h (s), soft: the soft step's
///     settings (the joint spring of joint_hertz and joint_damping_ratio over h is made), nullptr
///     for the PGS; predict: each row's drift from the poses the velocities reach in
///     h / 2 (predict_drift): the soft step's from d.qd now, the PGS's from the velocities its first
///     sweep leaves (computed at the second; zero in the first);
///     d.dI_inv (N, h I^-1 world), d.qd (N, the velocities before the joints' solve).
/// Out: js.blocks (Jacobians, K, K^-1, C, drift), their alpha pointing into js.joints[j].alpha.
void prepare_joints(const Model& model, const State& state, double h, const SolverSettings* soft, bool predict,
                    JointSet& js,
                    const SolverData& d);

/// Applies every block's alpha (the warm start) to d.qd.
void warm_start_joints(const JointSet& js, SolverData& d);

/// One Gauss-Seidel sweep over the blocks on d.qd; returns the largest velocity change of a row
/// (|K d_alpha|, m/s or rad/s), as a contact sweep's change.
double sweep_joints(JointSet& js, SolverData& d, JointSweep mode, double h);

/// The PGS position pass for joints, after the contacts' (on d.qd_p, the pseudo-velocities): per
/// block the target J q_p = -erp C / h (limits only while violated), swept to the tolerance.
/// Returns the sweeps used (0 when no block has an error).
int joint_position_pass(const SolverSettings& s, double h, JointSet& js, SolverData& d);

/// Each joint's force on B (N) and torque about B's anchor (N m), world, from its blocks' alpha (a
/// joint without blocks this substep, its bodies asleep, keeps its last).
void store_joints(const State& state, JointSet& js);

/// A one-dof joint's coordinate: a hinge's angle theta (rad, B about the axis relative to A, in
/// (-pi, pi]) or a slider's offset (m along the axis, from A's anchor to B's); NaN for the others.
double joint_position(const Joint& j, const State& state);
/// Its rate (rad/s or m/s; NaN for the others).
double joint_velocity(const Joint& j, const State& state);

}  // namespace signorini::solver
