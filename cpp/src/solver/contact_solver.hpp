// The contact solver as named stages over flat arrays (docs/conventions.md, "One step", step 3):
//   prepare rows -> warm start -> iterate (PGS sweeps) -> restitution -> position pass -> store.
// The World owns one SolverData and hands it to every step, so the arrays keep their capacity and
// a step allocates nothing once they have grown to the scene's size.
#pragma once

#include <cstdint>
#include <vector>

#include "parallel/huge_pages.hpp"
#include "signorini/contact.hpp"
#include "signorini/model.hpp"
#include "signorini/solver.hpp"
#include "signorini/state.hpp"

namespace signorini::serial { struct Writer; struct Reader; }
namespace signorini::parallel { class Pool; }

namespace signorini::solver {

struct JointSet;

/// A contact's three rows (normal n, friction t1 and t2: the lecture's rows of one contact), held
/// as what they share: the bodies, the three directions and the two lever arms. Row k of direction
/// d_k (n, t1, t2) has the Jacobian
///   J_A = (-(r_a x d_k), -d_k), J_B = (r_b x d_k, d_k) in the (omega, p_dot) layout,
/// so its velocity J q_dot = d_k . (v_B + omega_B x r_b - v_A - omega_A x r_a) is the relative
/// velocity at the point along d_k, and force changes d_alpha_k (N) move the bodies by the impulse
/// P = sum_k d_alpha_k d_k (on B; -P on A): q_dot_B += (dt I_B^-1 (r_b x P), dt m_B^-1 P), A the
/// opposite way, with dt I_X^-1 read from the body (SolverData::dI_inv).
/// Hot data, read by every sweep, so it is kept lean (240 bytes for the three rows, not three rows
/// of their own with dt M^-1 J stored per row: 600 bytes, which made the sweeps of a 57,000-contact
/// pile wait on memory). The lecture's delta_k = dt (J_A,k M_A^-1 J_A,k + J_B,k M_B^-1 J_B,k) (s/kg)
/// and the friction rows' couplings W are stored. Joints will have rows of their own kind.
struct ContactRows {
  int a = 0, b = 0;             ///< body indices
  bool a_moves = false, b_moves = false;  ///< false for static and kinematic bodies (M^-1 = 0: skipped)
  Vec3 n, t1, t2;               ///< the rows' directions d_k (unit, world): normal (A to B), tangents
  Vec3 r_a, r_b;                ///< lever arms y - p_X of the point on A and on B (m, world)
  double dinv_mass_a = 0.0, dinv_mass_b = 0.0;  ///< dt / m_X (s/kg; 0 for a body that does not move)
  double delta[3] = {0.0, 0.0, 0.0};      ///< delta_k of the normal, t1 and t2 rows (s/kg)
  double inv_delta[3] = {0.0, 0.0, 0.0};  ///< 1 / delta_k (0 when delta_k = 0): sweeps multiply, never divide
  double bias = 0.0;            ///< b (m/s) of the normal row: it asks J_n q_dot + b >= 0
  double mu = 0.0;              ///< the friction rows' bound is mu alpha_n
  /// the off-diagonal Delassus entries W_jk = dt J_j M^-1 J_k^T (s/kg) coupling the t1 row to the
  /// normal row (W_1n), t2 to the normal row (W_2n) and t2 to t1 (W_21): a force change d_alpha_k
  /// of row k changes row j's velocity by W_jk d_alpha_k, so a sweep gets the velocity a friction
  /// row sees after the rows before it in the same contact without updating the bodies in between
  double W_1n = 0.0, W_2n = 0.0, W_21 = 0.0;
};

/// A spin row: torsional friction about the normal n of a contact that is its body pair's only
/// point (docs/conventions.md, step 3). Angular only, J_A = (-n, 0), J_B = (n, 0) in the
/// (omega, p_dot) layout; its velocity J q_dot = n . (omega_B - omega_A) (rad/s); its force is a
/// torque (N m) on B about n (A gets the opposite), kept in [-mu_spin alpha_n, mu_spin alpha_n]
/// with alpha_n its contact's current normal force; delta = dt (n . I_A^-1 n + n . I_B^-1 n)
/// (s/(kg m^2)). Its bodies and whether they move are those of its contact's normal row. Kept
/// apart from the contact rows (96 bytes each, in their own array), so that a contact without one
/// costs the sweep nothing but a look at spin_slot, and a scene without any not even that.
struct SpinRow {
  Vec3 n;                       ///< J_B_ang, the contact's normal (J_A_ang = -n)
  Vec3 dMJA_ang, dMJB_ang;      ///< dt I_A^-1 (-n), dt I_B^-1 n (world inverse inertia; 0 for a body that does not move)
  double inv_delta = 0.0;       ///< 1 / delta
  double delta = 0.0;
  double mu_spin = 0.0;         ///< m: the bound is mu_spin times the contact's normal force
};

/// A body's velocity as one sweep reads it: omega and p_dot side by side (48 bytes), so a row
/// touches one place per body rather than two arrays.
struct BodyVelocity {
  Vec3 omega = Vec3::Zero();  ///< rad/s, world
  Vec3 v = Vec3::Zero();      ///< m/s, world
};

/// The soft constraint of a spring of `hertz` (Hz) and damping ratio zeta over a substep h (s)
/// (Catto, "Soft Constraints", GDC 2011): with omega = 2 pi hertz, a1 = 2 zeta + h omega,
/// a2 = h omega a1: bias_rate = omega / a1 (1/s), mass_scale = a2 / (1 + a2), impulse_scale =
/// 1 / (1 + a2). The soft step's contacts and joints both use it.
struct Softness {
  double bias_rate = 0.0, mass_scale = 1.0, impulse_scale = 0.0;
};
Softness soften(double hertz, double zeta, double h);

/// A spring (a contact's or a joint's) is at most this fraction of the substep rate (Hz per 1/h):
/// stiffer springs than the substep can resolve only add energy (Catto, "Solver2D"; Box2D v3 uses
/// 0.25).
constexpr double kMaxHertzPerRate = 0.25;

/// A contact as the soft step carries it through its substeps (docs/conventions.md, "The soft
/// step"), in solve order beside its rows.
struct SoftPoint {
  double gap0 = 0.0;         ///< the gap at detection (m)
  double s = 0.0;            ///< the gap now: gap0 + n . (y_B(t) - y_A(t)), y_X carried with body X (m)
  /// where the carried points y_A, y_B lie from the contact point, along -n and +n (m): on a round
  /// side (rounding_radius rho > 0) its core point, gap0 / 2 + rho from the contact point, so that a
  /// ball turning on the ground keeps its gap; 0 on any other side (the contact point itself)
  double sigma_a = 0.0, sigma_b = 0.0;
  double bias_rate = 0.0;    ///< omega / (2 zeta + h omega) (1/s)
  double mass_scale = 1.0;   ///< h omega (2 zeta + h omega) / (1 + h omega (2 zeta + h omega))
  double impulse_scale = 0.0;///< 1 / (1 + h omega (2 zeta + h omega))
  double impulse = 0.0;      ///< normal impulse over the step so far, sum of h alpha (N s)
  double alpha_max = 0.0;    ///< largest normal force of a substep so far (N)
  double u_before = 0.0;     ///< J_n q_dot before the last biased sweep, while it has not pushed (m/s)
};

/// Units (body pairs) a WideGroup solves at once, one per SIMD lane (solver/wide_rows.hpp).
constexpr std::size_t kLanes = 4;
/// The most contacts of a pair a lane takes (a pair with more is solved one contact at a time).
constexpr std::size_t kManifoldPoints = 4;

/// A two-point pair's normal rows are solved as one block (rows::solve_pair) only while
/// det K >= kPairConditioning K11 K22 (Box2D v2's block solver asks as much of its condition
/// number, at 1,000): two points nearly on top of each other are then solved one at a time.
constexpr double kPairConditioning = 1e-3;

/// How the solve order is made (rows.cpp, solve_order): a colour per contact (the lecture's PGS) or
/// per body pair, the pair's contacts one after the other (the soft step).
enum class Order { ByContact, ByPair };

/// The directions of each point of a WideGroup whose pairs' points do not share one normal
/// (WideGroup::frame): point j's normal and tangents, lane by lane (a lane with fewer points
/// repeats its last, as the group's points do).
struct alignas(32) PointFrames {
  double n[kManifoldPoints][3][kLanes], t1[kManifoldPoints][3][kLanes], t2[kManifoldPoints][3][kLanes];
};

/// Four body pairs of one colour laid out for SIMD (solver/wide_rows.hpp), lane l the run of
/// count[l] contacts (1 to kManifoldPoints) of one pair from solve position first[l] on: what the
/// soft step's sweeps read of their ContactRows and SoftPoints, each field as four values side by
/// side, so a field of the four pairs loads as one register, and each lane's bodies are read once
/// per sweep. A pair's points share its spring (widen checks it, bit for bit), and its normal and
/// tangents, or else the group's points take theirs from SolverData::frames (frame); each point's
/// gap and forces live here during the step (soft_end gives the gaps back to the soft points; the
/// forces go back to d.alpha after each substep's relax sweeps).
struct alignas(32) WideGroup {
  /// the rows of point j of each lane (a lane with fewer points repeats its last: unused)
  struct Point {
    double r_a[3][kLanes], r_b[3][kLanes];  ///< lever arms (m, world)
    double inv_delta[3][kLanes];
    double W_1n[kLanes], W_2n[kLanes], W_21[kLanes];
    double gap0[kLanes], s[kLanes];  ///< the gap at detection and now (m): SoftPoint's
    double alpha[3][kLanes];         ///< the forces of the normal, t1 and t2 rows (N): d.alpha's
    /// the step's normal impulse so far and largest normal force (N s, N): SoftPoint's impulse and
    /// alpha_max while wide_accumulate keeps them here (no restitution in the step)
    double impulse[kLanes], alpha_max[kLanes];
    double sigma_a[kLanes], sigma_b[kLanes];  ///< SoftPoint's (read only in a group with `round`)
  };
  Point point[kManifoldPoints];
  double n[3][kLanes], t1[3][kLanes], t2[3][kLanes];  ///< the rows' directions, per pair
  double dinv_mass_a[kLanes], dinv_mass_b[kLanes];    ///< per pair (s/kg)
  /// dt I^-1 of each pair's bodies (s/(kg m^2), world, column-major: [3 j + i] is row i, column j),
  /// d.dI_inv's, fixed over the step: read in order by the sweeps rather than gathered by body
  double dI_a[9][kLanes], dI_b[9][kLanes];
  double mu[kLanes];                                  ///< per pair
  double bias_rate[kLanes], mass_scale[kLanes], impulse_scale[kLanes];  ///< the pair's spring (SoftPoint's)
  int a[kLanes], b[kLanes];
  int first[kLanes], count[kLanes];  ///< each lane's solve positions [first, first + count)
  bool a_moves[kLanes], b_moves[kLanes];
  int points = 0;           ///< the largest count
  /// every lane a pair of exactly two points, whose normal rows the lanes solve as one block
  /// (rows::solve_pair): K11, K22 their deltas, K12 their coupling (rows::normal_coupling; s/kg)
  bool two = false;
  alignas(32) double K11[kLanes];  // (aligned: the lanes load them as whole registers)
  alignas(32) double K22[kLanes];
  alignas(32) double K12[kLanes];
  bool round = false;       ///< some point has a round side (a sigma != 0)
  /// -1: every point of a pair has the pair's n, t1, t2 (bit for bit); else the index of the
  /// group's PointFrames in SolverData::frames, its points' own directions (a box turned on
  /// another: a clipped edge crossing takes the normal of its two edges, a face point the face's;
  /// never in a group of blocks or with a round side)
  int frame = -1;
  /// solved by the scalar code: a contact whose normal or first friction row has delta <= 0 (both
  /// bodies static: never made by the narrow phase), or a pair whose points differ in normal or spring
  bool one_by_one = false;
};

/// Everything the solver keeps between steps (the cache) or reuses (scratch), as flat arrays.
struct SolverData {
  /// the step's worker threads (the World's; null: the calling thread alone)
  const parallel::Pool* pool = nullptr;
  /// the bodies the per-body stages visit (the World's non-static bodies, ascending; null: all N).
  /// With a list, the per-body arrays below keep their static bodies' entries at zero from the
  /// time they are sized to N (forget_bodies: after bodies are added or removed), so a step's
  /// per-body work grows with the bodies that can move, not with the static ones.
  const std::vector<int>* bodies = nullptr;
  /// the World's joints (solver/joint_rows.hpp), solved beside the contacts; null or empty: none
  JointSet* joints = nullptr;
  /// solve positions where each colour starts (colour c: [colour_start[c], colour_start[c + 1]));
  /// the last colour is the shared one, whose contacts may share bodies; by pair, where each
  /// colour's two-point units end (two_end: they come first, solved as blocks, rows::solve_pair)
  /// and where its units of more than kManifoldPoints contacts start (long_start; the colour's end
  /// when it has none). By contact, two_end is each colour's start.
  std::vector<int> colour_start, two_end, long_start;
  /// the blocks the threads claim in a sweep (rows::by_colour): block i is the solve positions
  /// [block_start[i], block_start[i + 1]), colour c's blocks are colour_block[c] ..
  /// colour_block[c + 1] - 1 (block_start ends with K)
  std::vector<int> block_start, colour_block;
  // rows: one ContactRows per contact (normal, t1, t2), in solve order (contact order[k] at k);
  // their forces alpha (N), 3 per contact (at 3k, 3k + 1, 3k + 2); the solve order (order: position -> contact, slot: contact -> position) and the
  // colours each body has taken while it was made (a bit per colour)
  parallel::HugeVector<ContactRows> rows;
  /// the soft step's rows four pairs at a time (wide_rows.hpp: widen): colour c's groups are
  /// wide[wide_first[c] .. wide_first[c + 1]), from the colour's first contact on, one after the other
  parallel::HugeVector<WideGroup> wide;
  /// the point directions of the groups whose pairs' points differ in them (WideGroup::frame)
  parallel::HugeVector<PointFrames> frames;
  std::vector<int> wide_first;
  /// the soft step's sweeps run the groups in lanes this step (set by soft_begin: not with the
  /// scalar code chosen, spin rows or the cone rule); the grouped contacts' gaps and forces then
  /// live in d.wide
  bool lanes = false;
  std::vector<char> in_lanes;  ///< per solve position (with lanes): in a group the lanes solve
  std::vector<double> alpha;
  std::vector<int> order, slot;
  /// per solve position: 1 where a unit of the solve order starts (each contact by contact; a
  /// pair's first contact by pair)
  std::vector<char> unit_first;
  std::vector<std::uint64_t> colours_used;
  // spin rows (torsional friction), in solve order: spin_slot (K: solve position -> its spin row,
  // or -1 for a contact without one), the rows, and their torques (N m). spin_rows is empty when
  // no contact has one (every pair's spinning friction 0, or no pair with a single point): the
  // sweeps then run exactly as without them, and spin_slot is not read (nor written when every
  // spinning friction is 0)
  std::vector<int> spin_slot;
  std::vector<SpinRow> spin_rows;
  std::vector<double> spin_alpha;
  // per solve position (as the rows are stored, so that the passes over them read in order): the
  // pre-solve normal velocity u_i (m/s; 0 where e_i = 0: only restitution reads it), restitution
  // e_i, whether stage d applies; per contact (cold): position-pass target b_pos (m/s) and
  // pseudo-force beta (N)
  std::vector<double> u, e, b_pos, beta;
  std::vector<char> restitutive;
  // per body: the velocities being solved (copied in and out of the caller's v, omega), the
  // pseudo-velocities of the position pass, the velocities after iterate (v_pos, omega_pos), and
  // what the solve hands back to move the poses with: v_move = v_pos + v_p (likewise omega)
  std::vector<BodyVelocity> qd, qd_p;
  /// the soft step, per body: the next substep's warm start (each contact's forces applied as
  /// rows::apply_force applies them, summed from zero) gathered in a substep's last relax sweep
  /// while its rows are read anyway (SoftSweep::kick), so that the next substep adds it per body
  /// instead of reading every row again; kick_ready: it holds that warm start now
  std::vector<BodyVelocity> kick;
  bool kick_ready = false;
  std::vector<Mat3> dI_inv;  ///< per body: dt times the world inverse inertia R I_body^-1 R^T at the step's start
  std::vector<Vec3> v_pos, omega_pos;
  std::vector<Vec3> v_move, omega_move;
  // per body: summed contact force (N) and torque about the com (N m), world; forced lists the
  // bodies whose entries may be non-zero (each once, flagged in is_forced), so that zeroing them
  // and the step guard's checkpoint of them cost O(contacts), not O(N)
  std::vector<Vec3> body_force, body_torque;
  std::vector<int> forced;
  std::vector<char> is_forced;
  // warm-start cache of the previous step, sorted by key, and the one being written
  std::vector<CachedContact> cache, cache_next;
  std::vector<char> cache_used;     ///< per cache entry: already given to a contact this step
  std::vector<int> recalled;        ///< per contact: its cache entry this step (-1: none)
  /// store's per contact: the torques it puts on A and on B about their centres (2K: A's at 2i,
  /// B's at 2i + 1; N m, world), its force on B (K; N, world) and its bodies (2K: A at 2i, B at
  /// 2i + 1), written with the contact's outputs and summed per body (compact, so that the sums
  /// do not read the contacts themselves again)
  std::vector<Vec3> contact_torque, contact_force;
  std::vector<BodyIndex> contact_body;
  /// per contact (contact order): whether it touches, impulse > 0 or gap < 0 (store: what the
  /// World's contact events read instead of the contact records)
  std::vector<char> touches;
  std::vector<double> alpha_iter;   ///< per solve position: alpha_n after the iterate stage (N)
  // the soft step: per contact in solve order; per body the pose at the step's start and how far
  // it has moved and turned since (dp = p - p0, dR = R R0^T - I)
  std::vector<SoftPoint> soft;
  double h = 0.0;  ///< the substep (s)
  bool bouncy = false;  ///< some contact of the step has restitution e > 0
  int restitution_sweeps = 0;  ///< restitution sweeps over the step's substeps
  std::vector<Vec3> p0, dp;
  std::vector<Mat3> R0, dR;
};

/// Bodies were added or removed (N = body_force.size() now): the per-body scratch arrays are
/// dropped (sized and zeroed again by the next step) and every body_force entry counts as forced.
void forget_bodies(SolverData& d);

/// Zeroes body_force and body_torque, sized n: the forced entries (all n without a body list, or
/// when they are not sized n).
void clear_body_forces(SolverData& d, std::size_t n);

/// Lists body i as forced (its body_force or body_torque may become non-zero).
inline void mark_forced(SolverData& d, int i) {
  if (d.is_forced[i]) return;
  d.is_forced[i] = 1;
  d.forced.push_back(i);
}

/// Tangent basis of a unit normal n: k = the first axis whose |n_k| is within 1e-9 of the
/// smallest (so rounding noise never decides), t1 = unit(n x e_k), t2 = n x t1.
void tangent_basis(const Vec3& n, Vec3& t1, Vec3& t2);

/// Solves one step's contacts.
/// In:  model, state (poses at the start of the step), dt (s), settings;
///      contacts (K) with body_a, body_b, point, normal, gap, feature ids;
///      v, omega (N, world) = the unconstrained velocities q_dot*.
/// Out: v, omega = the new velocities (after restitution);
///      data.v_move, data.omega_move = the velocities that move the poses (those of the iterate
///      stage plus the position pass's pseudo-velocities);
///      contacts[i].alpha, impulse, friction, force, spin_torque, normal_velocity, slip;
///      data.body_force, data.body_torque; data.cache_next (the caller swaps it into
///      data.cache once the step is kept);
///      returns the stats and the Signorini certificate.
///      anchor_a, anchor_b (K, world), optional: where the force acts on A and on B (a substep's
///      contacts carried with each body); null: contacts[i].point for both.
SolverStats solve_contacts(const Model& model, const State& state, double dt, const SolverSettings& settings,
                           std::vector<Contact>& contacts, std::vector<Vec3>& v, std::vector<Vec3>& omega,
                           SolverData& data, const std::vector<Vec3>* anchor_a = nullptr,
                           const std::vector<Vec3>* anchor_b = nullptr);

/// The solver's part of a saved state: per-body contact forces and torques (N), then the
/// warm-start cache. load reads a save of format `version` ('1': no spin) for n bodies into out
/// (its body_force, body_torque and cache), checking counts and indices.
void save(serial::Writer& w, const SolverData& data);
void load(serial::Reader& r, char version, std::size_t n, SolverData& out);

/// A list of warm-start entries in a saved state (its count, then each entry); load_cache reads
/// one written by a save of format `version` ('1': no spin torque).
void save_cache(serial::Writer& w, const std::vector<CachedContact>& cache);
void load_cache(serial::Reader& r, char version, std::vector<CachedContact>& cache);

/// The warm-start cache's order: by body pair, then feature ids (inline: the step's lookups and
/// sorts call it some hundred thousand times).
inline bool key_less(const CachedContact& x, const CachedContact& y) {
  if (x.body_a != y.body_a) return x.body_a < y.body_a;
  if (x.body_b != y.body_b) return x.body_b < y.body_b;
  if (x.feature_a != y.feature_a) return x.feature_a < y.feature_a;
  return x.feature_b < y.feature_b;
}

}  // namespace signorini::solver
