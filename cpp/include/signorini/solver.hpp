// Settings and report of the contact solver (docs/conventions.md, "One step" and "The Signorini
// certificate"). The solver itself is internal (cpp/src/solver/); users see these two structs.
#pragma once

#include <string>

namespace signorini {

/// How friction is bounded by the normal force alpha_n.
enum class FrictionCone {
  Pyramid,  ///< each tangent force in [-mu alpha_n, mu alpha_n] (the default; as Bullet, Box2D)
  Cone,     ///< the tangent force vector in the disk |f_t| <= mu alpha_n (the circular cone)
};

/// How the unconstrained angular velocity treats the gyroscopic term w x (I w).
enum class Gyroscopic {
  Midpoint,  ///< implicit midpoint rule, Newton iterated: keeps energy and |L| (the default)
  Implicit,  ///< one Newton step of backward Euler (Catto 2015, Bullet): stable, dissipates
  Explicit,  ///< the lecture's explicit term: gains energy on fast spinners
};

/// Which contact solver a step runs (docs/conventions.md, "One step" and "The soft step").
enum class SolverMethod {
  PGS,   ///< the lecture's hard PGS, swept to the tolerance in every substep, with a split-impulse position pass
  Soft,  ///< the soft step: per substep a warm start, biased sweeps on soft contacts, the poses, relax sweeps; restitution last
};

struct SolverSettings {
  /// Which solver a step runs.
  SolverMethod method = SolverMethod::PGS;
  /// Fraction of an overlap (negative gap) the position pass removes per step, in [0, 1].
  /// Positive gaps are always used whole (speculative contacts).
  double erp = 0.2;
  /// A stage stops after a sweep in which no row changed its velocity delta |d alpha| by more
  /// than this (m/s). 0 runs every sweep up to max_iterations (whether a sweep changes nothing at
  /// all is decided by rounding; the oracle comparison needs both sides to run the same sweeps).
  double tolerance = 1e-6;
  /// Upper bound on sweeps per stage (iterate, restitution, position pass) and step.
  int max_iterations = 30;
  /// Overlap the position pass leaves alone (m, >= 0): resting contacts sink this far at most
  /// and are never pushed, so a settled stack is not stirred by pushes. A contact whose smaller
  /// body is thin gets less: slop_i = min(slop, slop_inner_fraction r_min), r_min the smaller
  /// inner_radius() of its two bodies.
  double slop = 0.001;
  /// The most of the smaller body's inner radius a contact's slop may be (dimensionless): a body
  /// 1.8 mm thick (inner radius 0.9 mm) rests at most 0.18 mm deep, not the 1 mm that is more than
  /// its half thickness. Bodies of inner radius 5 mm and more keep the whole slop.
  static constexpr double slop_inner_fraction = 0.2;
  /// Cap on the speed at which the position pass pushes overlapping bodies apart (m/s, > 0).
  double max_push_velocity = 1.0;
  /// Approach speeds below this get no restitution (m/s, >= 0): resting contacts stay at rest.
  double restitution_threshold = 0.5;
  FrictionCone friction_cone = FrictionCone::Pyramid;
  Gyroscopic gyroscopic = Gyroscopic::Midpoint;
  /// Start each step from the previous step's forces, matched by body pair and feature ids.
  bool warm_start = true;
  /// A step detects its contacts once and solves them in n substeps of dt / n, each carrying the
  /// contacts along with the bodies' motion (docs/conventions.md, "One step"): n = substeps when it
  /// is >= 1; 0 (the default) takes the fewest that keep each at most auto_substep
  /// (substep_count()). Substeps cost solver sweeps, not contact detection.
  int substeps = 0;
  /// The longest automatic substep of the PGS (s): 4 substeps at dt = 1/240, 16 at dt = 1/60, so
  /// that the quality (a 10-box stack stands within 1 mm) and the solver's cost per simulated
  /// second do not depend on dt.
  static constexpr double auto_substep = 1.0 / 960.0;
  /// The longest automatic substep of the soft step (s): 1 at dt = 1/240, 4 at dt = 1/60 (Box2D
  /// v3's default of 4 substeps at 60 Hz); in a world with joints at most 0.25 / joint_hertz, so
  /// that the joints' springs are as stiff as asked (1/960 s at the default 240 Hz).
  static constexpr double soft_auto_substep = 1.0 / 240.0;
  /// The number of substeps a step of dt runs; joints: the world has a joint that is not broken.
  int substep_count(double dt, bool joints = false) const;
  /// A step that ends unconverged with max_penetration_velocity above this (m/s) is counted in
  /// World::step_report() (the Python layer warns). 1 m/s: approaching that fast, a contact sinks
  /// through the 1 mm slop within one default substep (1/960 s); slower leftovers of an unconverged
  /// solve (piles at impact: up to 0.2 m/s in the built-in scenes) stay within what the position
  /// pass removes, and only the certificate reports them.
  double warn_velocity = 1.0;
  /// Contact recycling (m, >= 0; docs/conventions.md, "Contact recycling"): a pair of bodies that
  /// are not spheres, planes or triangle meshes keeps the manifold it was last found with, its
  /// points carried with the bodies, while no point of either body has moved by more than this
  /// relative to the other since (counting the coming step's motion at the current velocities),
  /// and at most 2% of the smaller body's inner radius; so a resting pile is not collided again
  /// step after step. 0: every pair is found anew every step (the exact contacts of the narrow
  /// phase, as the oracle computes them), and the default: the soft step's stacks are
  /// sensitive to the small changes a kept manifold makes (docs/conventions.md, "Contact
  /// recycling", what was measured), so it is for now a setting to opt into; 0.01 mm keeps the
  /// acceptance scenes within their marks but the soft 10-box stack's.
  double recycle_distance = 0.0;
  /// Continuous collision (docs/conventions.md, "Shape casts and continuous collision"): after
  /// each step, a dynamic body that moved more than kFastFraction of its inner radius in it (or any
  /// `bullet` body) is swept from its start to its end position against the static bodies, and put
  /// back just before its first touch of one when its centre's path went on past it; one that turned
  /// fast and ended deeper in a static body than it started is put back along its travel and turn to
  /// where it was not.
  bool continuous = true;

  // ---- the soft step (method = Soft; docs/conventions.md, "The soft step") ----
  /// Stiffness of a contact as the natural frequency of its spring (Hz, > 0), capped at a quarter
  /// of the substep rate; a contact with a static or kinematic body gets twice this.
  double contact_hertz = 30.0;
  /// Damping ratio of a contact's spring (>= 0; 1 is critical); a contact with a static or
  /// kinematic body gets half this.
  double damping_ratio = 10.0;
  /// Stiffness of a joint's rows in the soft step as the natural frequency of their spring (Hz,
  /// > 0), capped at a quarter of the substep rate; the automatic substeps of a world with joints
  /// are short enough for it. 240 Hz: a joint stretches by its load / (m_eff omega^2), a chain of
  /// 21 rods sags within 0.2 % of its catenary (60 Hz, Box2D v3's choice: 2.1 %).
  double joint_hertz = 240.0;
  /// Damping ratio of a joint's spring (>= 0).
  double joint_damping_ratio = 2.0;
  /// Sweeps with the soft bias per substep (>= 1).
  int soft_iterations = 1;
  /// Sweeps without bias per substep, after the poses move (>= 0): they take back the bias's
  /// velocity so that pushing out of an overlap does not become kinetic energy.
  int relax_iterations = 1;
};

/// What the last solve did, and how well its contacts satisfy the Signorini conditions (the
/// certificate of docs/conventions.md, ContactBench's metrics, Le Lidec et al. 2023).
struct SolverStats {
  int iterations = 0;              ///< sweeps of the iterate stage
  int restitution_iterations = 0;  ///< sweeps of the restitution stage
  int position_iterations = 0;     ///< sweeps of the position pass
  bool converged = true;           ///< the iterate stage met the tolerance
  int contacts = 0;
  int pairs = 0;           ///< body pairs the step's detection collided (broad-phase candidates)
  int recycled_pairs = 0;  ///< of them, pairs that kept their manifold (SolverSettings::recycle_distance)
  double residual = 0.0;                   ///< natural residual over all rows (m/s)
  double max_alpha_negative = 0.0;         ///< max(0, -min alpha_i) (N)
  double max_penetration_velocity = 0.0;   ///< max(0, -min w_i) (m/s)
  double max_complementarity = 0.0;        ///< max |alpha_i w_i| (W)
  double max_cone_violation = 0.0;         ///< max(0, max |f_i| - mu_i alpha_i) (N)
  double max_dissipation_violation = 0.0;  ///< sliding contacts: max |f_i + mu_i alpha_i s_i/|s_i|| (N)
  double max_overlap = 0.0;                ///< max(0, -min gap_i) (m)
};

/// The code the soft step's sweeps solve four body pairs at a time with (docs/conventions.md, "Rows
/// four pairs at a time"): "auto" (the widest the CPU has, the default, run only where the lanes pay
/// for copying the rows into them), "avx2", "sse2" (run wherever the lanes can), or "scalar" (one
/// contact at a time). Every choice gives the same bits; process-wide, for benchmarks and tests
/// that compare them. Throws std::invalid_argument for another name, or "avx2" on a CPU or build
/// without it.
void set_simd(const std::string& isa);
/// The code the sweeps run with now: "avx2", "sse2" or "scalar".
std::string simd();

}  // namespace signorini
