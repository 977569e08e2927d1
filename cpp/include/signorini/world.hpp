// World: owns the static Model, the dynamic State, the collision caches and the solver's arrays,
// and runs the step as the pipeline of docs/conventions.md:
//   impulses -> contacts -> per substep (carry, unconstrained velocity, contact solve, integrate,
//   guard) -> guard -> commit.
// Its definitions are split by concept (cpp/src/world/): world.cpp (settings and the step),
// bodies.cpp (add, validate, re-centre, remove), body_access.cpp (setters and getters),
// saved_state.cpp (save_state, restore_state); step_guard.cpp holds the step's checks and undo.
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "signorini/contact.hpp"
#include "signorini/joint.hpp"
#include "signorini/model.hpp"
#include "signorini/query.hpp"
#include "signorini/shapes.hpp"
#include "signorini/solver.hpp"
#include "signorini/state.hpp"
#include "signorini/types.hpp"

namespace signorini {

namespace collision { class BroadPhase; struct Scratch; struct ContactMemory; }
namespace solver { struct SolverData; struct JointSet; }
namespace parallel { class Pool; }
class StepGuard;
class Islands;

/// When bodies fall asleep (docs/conventions.md, "Sleeping"). A dynamic body whose speed stays at
/// most linear_velocity and whose angular speed stays at most angular_velocity for time_to_sleep
/// seconds is ready to sleep; an island (bodies linked by contacts) sleeps when all its bodies are
/// ready. A sleeping body keeps its pose bit for bit and costs no solver or broad-phase work.
struct SleepSettings {
  /// false: nothing sleeps (every body is woken when it is switched off). On by default
  /// (docs/conventions.md, "Sleeping", Default).
  bool enabled = true;
  double linear_velocity = 0.05;  ///< m/s, >= 0: |v| at most this counts as at rest
  double angular_velocity = 0.05; ///< rad/s, >= 0: |omega| at most this counts as at rest
  double time_to_sleep = 0.5;     ///< s, >= 0: how long an island stays at rest before it sleeps
};

struct WorldSettings {
  Vec3 gravity = Vec3(0.0, 0.0, -9.81);  ///< m/s^2
  double contact_margin = 0.005;         ///< m: pairs closer than this get (speculative) contacts
  SolverSettings solver;
  SleepSettings sleep;
  /// worker threads of the step (>= 1; 0: the machine's cores). Results are bit-identical for every
  /// count (docs/conventions.md, "Threads").
  int threads = 0;
};

/// A body index that is not in the world (std::out_of_range; Python's BodyIndexError).
struct BodyIndexError : std::out_of_range {
  using std::out_of_range::out_of_range;
};

/// What a user asks for when adding a body. Exactly one of density and mass is given for a dynamic
/// body; neither for a static one; either or neither for a kinematic one (without, it has infinite
/// mass and can never become dynamic). A non-unit orientation quaternion is normalised.
struct BodyDesc {
  Shape shape = Sphere(1.0);
  bool is_static = false;
  /// moved by its velocity only (set_velocity, set_angular_velocity): no gravity or forces,
  /// infinite mass for the contacts it makes with dynamic bodies, which it pushes
  bool is_kinematic = false;
  std::optional<double> density;  ///< kg/m^3
  std::optional<double> mass;     ///< kg
  /// Inertia about the centre of mass, body axes (kg m^2), symmetric positive definite; given
  /// together with mass it replaces the shape's mass properties: the body origin is then taken as
  /// the centre of mass and the shape is used as it is (not re-centred).
  std::optional<Mat3> inertia;
  std::string name;               ///< "" or unique in the world (find())
  CollisionFilter filter;         ///< group and mask bits
  bool enabled = true;
  Vec3 position = Vec3::Zero();          ///< centre of mass, world (m); a mesh is re-centred on it
  Quat4 orientation = Quat4(1, 0, 0, 0); ///< (w, x, y, z), world-from-body
  Vec3 velocity = Vec3::Zero();          ///< m/s
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s, world frame
  Material material;                     ///< friction >= 0, restitution in [0, 1], spinning_friction >= 0 (m)
  bool can_sleep = true;                 ///< false: never sleeps, and keeps every island it is in awake
  bool sensor = false;                   ///< detects overlaps (sensor events) instead of colliding
  bool bullet = false;                   ///< continuous collision every step, not only when fast
};

/// Where the wall time of the last call of World::step went (ms, summed over its steps), stage by
/// stage in the step's order (docs/conventions.md, "Where a step's time goes"): for finding what a
/// scene costs, as Box2D's b2Profile and MuJoCo's mjData.timer do. The stages follow each other
/// without gaps, so they add up to `total` (up to rounding). Never part of any result; a step
/// that throws adds nothing for its last stage.
struct StepProfile {
  double detect = 0.0;     ///< broad and narrow phase: the step's contacts (once per step)
  double wake = 0.0;       ///< sleeping islands touched by moving bodies woken
  double prepare = 0.0;    ///< soft step: rows, solve order and colours, groups, warm-start lookup (once per step)
  double solve = 0.0;      ///< the solver per substep: velocities with gravity, warm start, sweeps (the PGS: its
                           ///< rows, sweeps, position pass and store too, every substep)
  double integrate = 0.0;  ///< poses moved with the solved velocities, and the finite check, per substep
  double relax = 0.0;      ///< soft step: relax sweeps and restitution, per substep
  double store = 0.0;      ///< soft step: forces, the next warm-start cache and the certificate (once per step)
  double continuous = 0.0; ///< fast bodies swept against the static ones (once per step)
  double guard = 0.0;      ///< the step's checkpoint (what an undo puts back), pending impulses, energy check
  double commit = 0.0;     ///< the reported contacts and forces, sleep timers and islands
  double total = 0.0;      ///< the whole step
};

/// What the last call of World::step did over its steps (and substeps).
struct StepReport {
  int steps = 0;                   ///< steps (substeps included) run by the call
  int flagged = 0;                 ///< of those, steps that ended unconverged with
                                   ///< max_penetration_velocity > warn_velocity
  double worst_penetration_velocity = 0.0;  ///< the largest such figure (m/s)
  double worst_time = 0.0;         ///< time at the start of that step (s)
  int continuous = 0;              ///< bodies put back by continuous collision (SolverSettings::continuous)
  StepProfile time;                ///< where the call's wall time went
};

/// One contact event of the last World::step call (docs/conventions.md, "Contact events"). A body
/// pair touches after a step when one of its contacts pushed in the step (impulse > 0) or overlaps
/// (gap < 0); it begins touching in the step after which it touches and did not before, and ends
/// in the step after which it no longer touches. A hit is a beginning whose approach was faster
/// than the world's hit_speed.
struct ContactEvent {
  int step = 0;                        ///< the step of the call it happened in (0 .. steps - 1)
  BodyIndex body_a = -1, body_b = -1;  ///< the pair, as in its contacts (body_a < body_b but for planes and meshes)
  Vec3 point = Vec3::Zero();   ///< begin and hit: the pair's first contact point (m, world); end: zero
  Vec3 normal = Vec3::Zero();  ///< begin and hit: that contact's unit normal, from A to B; end: zero
  /// begin and hit: the fastest approach of the pair's contacts at the step's start,
  /// -n . (v_B(y) - v_A(y)) with the velocities the step started from (m/s; 0 when none
  /// approached); end: 0
  double speed = 0.0;
  double impulse = 0.0;  ///< begin and hit: the pair's summed normal impulse in the step (N s); end: 0
};

/// The events of the last World::step call, each list in the order of the steps and, within a
/// step, of the body pairs (body_a, then body_b): the same for every thread count.
struct ContactEvents {
  std::vector<ContactEvent> begin, end, hits;
  /// a sensor (body_a) and a non-sensor body (body_b) began or ended overlapping (docs "Sensors");
  /// point and normal of their deepest contact at the beginning, speed and impulse 0
  std::vector<ContactEvent> sensor_begin, sensor_end;
};

/// Threads: every public member function takes the world's lock, so calls from several threads on
/// one World run one at a time (a step waits for an add_body in another thread, and the other way
/// round) and none sees another half done. What they return is a copy taken under the lock
/// (contacts, contact forces and torques, the warm-start cache, settings, figures), except the
/// references model() and state(): those are read without it, stay valid during a step (the
/// storage does not move) but show the step's progress, and adding or removing bodies may move
/// them; hold lock() to read them as one picture. Many worlds in many threads never wait for each
/// other.
class World {
 public:
  /// A step is an energy explosion (undone and reported, like a non-finite step) when its final
  /// kinetic energy is more than kExplosionFactor times, and more than kExplosionFloor (J) above,
  /// the kinetic energy it started with plus the work gravity and external forces did in it.
  static constexpr double kExplosionFactor = 100.0;
  static constexpr double kExplosionFloor = 1.0;

  explicit World(const WorldSettings& settings = WorldSettings());
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  /// Validates desc completely, then adds the body; returns its index. On a bad desc throws
  /// std::invalid_argument naming the body index and the problem, and the world is unchanged.
  BodyIndex add_body(const BodyDesc& desc);

  /// Removes body i. Bodies after it move down one index (like erasing from a list); contacts,
  /// the warm-start cache and excluded pairs are renumbered, those of body i dropped. Storage of
  /// the state arrays stays in place (no reallocation).
  void remove_body(BodyIndex i);
  /// Removes the bodies at `indices` (any order, each once) in one pass, O(N + K) plus one
  /// broad-phase rebuild, as remove_body of each would: the bodies that stay keep their order and
  /// close up. Throws BodyIndexError for an index out of range and std::invalid_argument for one
  /// given twice, with nothing changed.
  void remove_bodies(const std::vector<BodyIndex>& indices);

  // ---- joints (docs/conventions.md, "Joints") ----
  /// Validates desc completely (bodies exist, differ and are not both static; anchors and axes
  /// finite, axes non-zero; limits lower <= upper; motor max_force >= 0; lengths 0 <= min <= max,
  /// max > 0; a unique name), then adds the joint, converting its world anchor and axis to each
  /// body's frame at the bodies' current poses; returns its index. Both bodies wake. On a bad desc
  /// throws std::invalid_argument (BodyIndexError for a body out of range) naming the joint and the
  /// problem, and the world is unchanged.
  JointIndex add_joint(const JointDesc& desc);
  /// Removes joint j (later joints move down one index); its bodies wake (and collide again unless
  /// another joint or an excluded pair keeps them apart).
  void remove_joint(JointIndex j);
  /// A new motor for one-dof joint j (Revolute, Prismatic), from the next step on: enabled with its
  /// target speed (finite) and max_force (finite, >= 0), or disabled. Its bodies wake. Errors as
  /// add_joint's, naming the joint; nothing changes on error.
  void set_joint_motor(JointIndex j, const Motor& motor);
  /// Breaks joint j (broken true) or mends it (false: its rows return from the next step, from
  /// zero forces, at the bodies' poses then). Its bodies wake.
  void set_joint_broken(JointIndex j, bool broken);
  /// The effort of one-dof joint j (N m or N, finite; JointDesc::effort) from the next step on: a
  /// control set per step. Its bodies wake; errors name the joint, nothing changes on error.
  void set_joint_effort(JointIndex j, double effort);
  /// The joints that broke in the last call of step(), in the order they broke (by step, then index).
  struct JointBreak {
    int step = 0;             ///< the step of the call (0 .. steps - 1)
    JointIndex joint = 0;
    Vec3 force = Vec3::Zero(), torque = Vec3::Zero();  ///< what it transmitted to B when it broke (N, N m)
  };
  std::vector<JointBreak> joint_breaks() const;
  std::size_t num_joints() const;
  /// The joints as kept (body frames, warm-start forces, last forces); a copy.
  std::vector<Joint> joints() const;
  /// Index of the joint named `name`, or -1.
  JointIndex find_joint(const std::string& name) const;
  /// Per joint: the coordinate (rad or m) and its rate of a one-dof joint (NaN for the others), and
  /// the force (N) and torque about B's anchor (N m) it transmits to body B in the last substep (world).
  std::vector<double> joint_positions() const;
  std::vector<double> joint_velocities() const;
  std::vector<Vec3> joint_forces() const;
  std::vector<Vec3> joint_torques() const;
  /// "joint 2 'knee' (Revolute)" or "joint 2 (Revolute)": how errors name joint j.
  std::string joint_label(JointIndex j) const;

  /// Advances `steps` steps of dt seconds. dt must be positive and finite.
  void step(double dt, int steps = 1);
  /// The substeps a step of dt (s, positive and finite, else std::invalid_argument) runs now
  /// (SolverSettings::substep_count; the soft step's shorter ones while the world has a joint that
  /// is not broken and has a body awake).
  int substep_count(double dt) const;

  // state setters: validated, the body named on error, nothing changed on error
  void set_position(BodyIndex i, const Vec3& p);
  void set_orientation(BodyIndex i, const Quat4& q);
  void set_velocity(BodyIndex i, const Vec3& v);
  void set_angular_velocity(BodyIndex i, const Vec3& omega);
  void set_external_wrench(BodyIndex i, const Vec3& force, const Vec3& torque);
  /// Batch setters: row k of values (n x 3, or n x 4 quaternions) goes to body bodies[k] (n indices;
  /// a repeated index takes its last row). Every entry is checked as the single setters check it
  /// before any is written: on an error nothing changes.
  void set_positions(const Indices& bodies, const Points& values);
  void set_orientations(const Indices& bodies, const Quats& values);
  void set_velocities(const Indices& bodies, const Points& values);
  void set_angular_velocities(const Indices& bodies, const Points& values);
  /// Friction mu >= 0, restitution e in [0, 1] and spinning friction mu_spin >= 0 (m), all finite;
  /// static bodies too.
  void set_material(BodyIndex i, const Material& material);
  /// A dynamic or kinematic body's mass m > 0 (kg, finite); its inertia scales by m / m_old (the same
  /// shape, uniformly denser or lighter). Static bodies and bodies added without a mass are refused.
  void set_mass(BodyIndex i, double mass);
  /// Gravity (m/s^2, world, finite); the world is woken (everything may fall another way).
  void set_gravity(const Vec3& gravity);
  /// For the next step only (then zeroed; the first step of the next step() call): an impulse J
  /// (N s, world) at world point x (m) adds J / m to v and I_w^-1 ((x - p) x J) to omega at the start
  /// of the step; a force F (N) at x acts through the whole step with torque (x - p) x F. Several
  /// calls add up. Dynamic bodies only (a disabled body ignores them). Without a point, at the
  /// body's centre of mass (read under the lock, with the index checked).
  void apply_impulse(BodyIndex i, const Vec3& impulse, const std::optional<Vec3>& point = std::nullopt);
  void apply_force(BodyIndex i, const Vec3& force, const std::optional<Vec3>& point = std::nullopt);
  /// Makes a dynamic body kinematic (its velocity kept, from now on moved by it alone) or a kinematic
  /// one dynamic again (needs a finite mass). Static bodies cannot change.
  void set_kinematic(BodyIndex i, bool kinematic);
  /// A disabled body keeps its pose and velocity, feels no forces and collides with nothing.
  void set_enabled(BodyIndex i, bool enabled);
  void set_collision_filter(BodyIndex i, const CollisionFilter& filter);
  /// Bodies i and j (i != j) never collide (disable), or collide again as their filters say (enable).
  void set_pair_collision(BodyIndex i, BodyIndex j, bool collide);
  /// Sleeping (docs/conventions.md, "Sleeping"). set_awake(i, true) wakes body i's island (a no-op
  /// for an awake dynamic or kinematic body); set_awake(i, false) puts the island body i is in by
  /// the last step's contacts to sleep now (velocities zeroed). Errors (std::invalid_argument, the
  /// body named, nothing changed): a static body (never awake), a kinematic or disabled body put to
  /// sleep, an island with a body that cannot sleep, or sleeping switched off.
  void set_awake(BodyIndex i, bool awake);
  /// Whether body i may sleep; false wakes its island (and keeps it awake while it touches i).
  void set_can_sleep(BodyIndex i, bool can_sleep);
  /// Makes body i a sensor (its contacts are found, never solved or reported: its overlaps are
  /// sensor events) or a body that collides again. Wakes it.
  void set_sensor(BodyIndex i, bool sensor);
  /// Whether dynamic body i is swept against the static bodies after every step (continuous
  /// collision), not only when it moves fast.
  void set_bullet(BodyIndex i, bool bullet);
  /// Index of the body named `name`, or -1.
  BodyIndex find(const std::string& name) const;
  /// "body 3 'ball' (Sphere)", or "body 3 (Sphere)" for an unnamed body: how errors name body i.
  std::string label(BodyIndex i) const;

  /// Everything the next step reads that the user or a step can change, as bytes: time, poses,
  /// velocities, persistent and one-step wrenches, pending impulses, kinematic and enabled flags,
  /// the warm-start cache, and the last step's contacts, body forces and solver figures (with each
  /// body's shape kind, static flag and mass, to recognise the world it belongs to).
  std::string save_state() const;
  /// Restores a save_state() of this world (or of one built the same way): stepping on is then
  /// bit-identical (a world with sleeping off wakes the bodies the state has asleep). A state of another world (body count, shape kinds, static flags or masses
  /// differ) or damaged bytes throw std::invalid_argument and change nothing.
  void restore_state(const std::string& saved);

  /// The static model and the dynamic state, read without the lock (see Threads above).
  const Model& model() const { return model_; }
  const State& state() const { return state_; }
  /// The world's lock, held by the caller until the returned object goes: meanwhile no call of
  /// another thread runs on this World, so model() and state() read as one picture (this thread's
  /// own calls still run: the lock is recursive). Hold it briefly.
  [[nodiscard]] std::unique_lock<std::recursive_mutex> lock() const { return std::unique_lock(mutex_); }
  WorldSettings settings() const;
  void set_settings(const WorldSettings& settings);
  std::size_t num_bodies() const;

  /// Contacts of the last step (detected at its start), with their solved forces and velocities;
  /// a copy (shared_contacts() shares the list without copying).
  std::vector<Contact> contacts() const;
  /// The same list, shared: a holder keeps it valid and unchanged (the World moves to a new list
  /// at the next step when it is held, and reuses it when not).
  std::shared_ptr<const std::vector<Contact>> shared_contacts() const;
  /// The last step's solver figures and Signorini certificate.
  SolverStats solver_stats() const;
  /// What the last call of step() did (for warnings).
  StepReport step_report() const;
  /// The contact events of the last call of step() (copies).
  ContactEvents events() const;
  /// The approach speed above which a beginning is also a hit (m/s, >= 0 and finite; default 1,
  /// as Box2D's). Throws std::invalid_argument otherwise, and keeps the old value.
  void set_hit_speed(double speed);
  double hit_speed() const;
  /// Per body, the summed contact force (N, world) and torque about its com (N m, world) of the
  /// last step; static bodies included (the reaction on the ground). Copies: a step in another
  /// thread rewrites the solver's own arrays as it runs.
  std::vector<Vec3> contact_forces() const;
  std::vector<Vec3> contact_torques() const;
  /// The warm-start cache the next step starts from, sorted by key (docs/conventions.md, 3 b); a copy.
  std::vector<CachedContact> warm_start_cache() const;

  /// Orientation of body i as a unit quaternion (w, x, y, z), w >= 0.
  Quat4 orientation(BodyIndex i) const;
  /// Total kinetic energy 1/2 sum (m v.v + omega . I_w omega) (J).
  double kinetic_energy() const;
  /// Gravitational potential energy -sum m g . p relative to the origin (J).
  double potential_energy() const;

  // queries between steps (issue 24; world/queries.cpp, docs/conventions.md "Queries"): the
  // broad phase's trees walked, never every body; bodies `filter` sees (query.hpp), sleeping ones
  // included. A ray is origin + t u, u = direction / |direction|, t in [0, max_distance] (m);
  // bad input throws std::invalid_argument (BodyIndexError for an exclude index) naming the
  // argument, and nothing changes. Each call first refits the boxes of the non-static bodies.
  /// The closest hit (ties: the lower body index), or none.
  std::optional<RayHit> cast_ray(const Vec3& origin, const Vec3& direction, double max_distance,
                                 const QueryFilter& filter = QueryFilter()) const;
  /// Some hit, the first the walk meets (not necessarily the closest), or none.
  std::optional<RayHit> cast_ray_any(const Vec3& origin, const Vec3& direction, double max_distance,
                                     const QueryFilter& filter = QueryFilter()) const;
  /// Every body the ray meets, one hit each (its first), sorted by (distance, body).
  std::vector<RayHit> cast_ray_all(const Vec3& origin, const Vec3& direction, double max_distance,
                                   const QueryFilter& filter = QueryFilter()) const;
  /// n rays: origins, directions (n, 3), max_distance (n,); row k is cast_ray of ray k bit for
  /// bit, the rays spread over the world's threads (the same bits for any thread count).
  RayHits cast_rays(const Points& origins, const Points& directions, const Eigen::VectorXd& max_distance,
                    const QueryFilter& filter = QueryFilter()) const;
  /// The bodies (ascending) whose shape overlaps (signed distance < 0, as the narrow phase finds
  /// it) a bounded shape at (position, orientation (w, x, y, z)).
  std::vector<BodyIndex> overlap(const Shape& shape, const Vec3& position, const Quat4& orientation,
                                 const QueryFilter& filter = QueryFilter()) const;
  /// The bodies (ascending) overlapping the box [lo, hi] (world axes, lo < hi in each axis).
  std::vector<BodyIndex> overlap_aabb(const Vec3& lo, const Vec3& hi, const QueryFilter& filter = QueryFilter()) const;
  /// The bodies (ascending) whose closed solid contains the point (triangle meshes never do).
  std::vector<BodyIndex> overlap_point(const Vec3& point, const QueryFilter& filter = QueryFilter()) const;
  /// Signed distance of bodies i and j (i != j, not both planes or triangle meshes), normal i -> j.
  BodyDistance distance(BodyIndex i, BodyIndex j) const;
  /// A bounded shape at (position, orientation (w, x, y, z)) swept along `translation` (m, world):
  /// the first body it touches (world/continuous.cpp; conservative advancement on exact distances,
  /// the fraction to 1e-12 of the sweep's size; a triangle mesh from its front only), or none; a
  /// shape that overlaps a body at the start hits it at fraction 0 (the lower index first).
  std::optional<ShapeHit> cast_shape(const Shape& shape, const Vec3& position, const Quat4& orientation,
                                     const Vec3& translation, const QueryFilter& filter = QueryFilter()) const;
  /// Counts of the last query call.
  QueryStats query_stats() const;

  /// Contacts the current state would produce for a step of dt, without stepping.
  std::vector<Contact> detect_contacts(double dt) const;
  /// The same, written into out (cleared first; its capacity is reused).
  void detect_contacts(double dt, std::vector<Contact>& out) const;

 private:
  void check_index(BodyIndex i) const;
  /// Wakes the island body i sleeps in; for a static or kinematic body, the islands resting on it.
  void wake(BodyIndex i);
  /// Wakes every sleeping body.
  void wake_all();
  /// The indices of a batch setter as BodyIndex, checked: as many as `rows`, each in range.
  void check_batch(const char* who, const Indices& bodies, Eigen::Index rows) const;
  /// contacts_ ready to be written: a new list when someone holds the current one.
  std::vector<Contact>& own_contacts();
  void set_kinematic_flag(BodyIndex i, bool kinematic);
  /// Appends x to a state vector; when it is full, the old storage is kept in retired_ rather than
  /// freed, so that a NumPy view of it never dangles.
  template <class T> void push_keeping(std::vector<T>& v, const T& x);
  /// A velocity for body i must be finite, and zero for a static body.
  void check_velocity(BodyIndex i, const char* what, const Vec3& x) const;
  /// A push (`what`: "impulse" or "force") of body i at a world point (its centre of mass when
  /// none): both finite, and the body dynamic (static and kinematic bodies have infinite mass).
  /// Returns the point.
  Vec3 check_push(BodyIndex i, const char* what, const Vec3& push, const std::optional<Vec3>& point) const;
  /// One step of dt, as a pipeline of named stages (world.cpp); a step the guard refuses (a
  /// non-finite state, an energy explosion) is undone and throws std::runtime_error naming the
  /// body or bodies.
  void step_once(double dt);
  /// step_once with the soft step (SolverMethod::Soft): contacts once, then per substep
  /// unconstrained velocity -> solve -> poses -> relax, then restitution and store (soft_step.hpp).
  void soft_step_once(double dt);
  /// The step's contacts carried to substep k into contacts_next_ (k = 0: as detected); from k = 1
  /// on, the pairs whose bodies' turns since the step's detection moved their points too far
  /// (collision::turned_far), and the pairs of escaped bodies (find_escaped) that carry no
  /// contact, collided again (collision::redetect_turned, for the `rest` of the step, s), and the
  /// step's impulse sums then matched to the new list by contact key.
  void carry_contacts(int k, double rest);
  /// escaped_ (ascending): the awake dynamic bodies (not kinematic) whose
  /// surface has moved further since `from` (the step's start) than the step's detection reached
  /// for them, out of the box its broad phase grew, |p - p_0| + turned_ > scratch_->reach +
  /// contact_margin / 2 (a body set moving within the step: struck by a faster one, pulled by a
  /// joint); with any, escape_pairs_: their candidate pairs at the
  /// present poses for the `rest` of the step (collision::BroadPhase::escaped_pairs), those
  /// model.can_collide refuses, a sensor's, a sleeping body's and those the step's contacts
  /// already hold left out. Returns whether any pair is left (pairs to find anew). Reads turned_
  /// (find_turned first).
  bool find_escaped(const State& from, double rest);
  /// turned_ (N): how far each awake, non-spherical body's turn since `from` (the step's start,
  /// or where the soft step's rows were made) has moved its points, at most (m; 0 for the others:
  /// a sphere's contacts do not follow its turn).
  void find_turned(const State& from);
  /// contacts_next_ and anchor_a_, anchor_b_ (carried) with the pairs turned far (turned_) collided
  /// again at the present poses for the `rest` of the step (collision::redetect_turned).
  /// escapes: also the escaped bodies' pairs that carry no contact (find_escaped's; the PGS step's).
  void redetect_turned(double rest, bool escapes = false);
  /// The most substeps the turning rule gives a step of dt whose own rule gives n:
  /// max(collision::kTurnSubsteps per 1/kTurnRate s begun, collision::kTurnSubstepFactor n). A step
  /// takes at most half of them before its first substep, so that a body set turning by an impact
  /// has room left.
  int turn_budget(double dt, int n) const;
  /// A step's first plan of its substeps, after its detection and wake: n its own count
  /// (substep_count) or, when automatic (settings' substeps < 1), at least as many as
  /// turn_substeps asks for its detected contacts (contacts_base_), at most half of `most`
  /// (turn_budget), the cap on the substeps it may split into later.
  struct SubstepPlan {
    int n = 1;
    int most = 1;
    bool automatic = false;
  };
  SubstepPlan plan_substeps(double dt) const;
  /// The soft step after substep k of n (h s each; automatic substeps): when a pair of its
  /// contacts has turned far since its rows were made (collision::turned_far), or a body turns so
  /// fast that the rest of the step wants more substeps (turn_substeps, at most `most` in all),
  /// this run of rows ends (soft_end: its forces become the warm start, its impulses join the
  /// step's sums), the contacts are carried to now with the turned pairs collided again, and the
  /// rest of the step runs on rows made anew (soft_begin), in n - k - 1 or more substeps (n and h
  /// updated). Returns whether it cut.
  bool soft_cut(int k, int& n, double& h, int most);
  /// contacts_next_'s impulses += impulse_sum_ (the runs before, matched by key); impulse_sum_
  /// takes the totals.
  void add_impulse_sums();
  /// The substeps `span` seconds take for the fast-turning bodies of `contacts` at their present
  /// angular velocities: so many that each turns a pair by at most collision::kTurnReach of its
  /// smaller inner radius (1 when none turns; at most 1e6). A step with automatic substeps takes
  /// this many for its contacts as detected (at most half of turn_budget), and when a substep has
  /// set bodies turning faster, the rest of the step is split again for the substep's contacts,
  /// at most turn_budget substeps in all.
  int turn_substeps(const std::vector<Contact>& contacts, double span) const;
  /// A bound on turn_substeps's count from the moving bodies alone, so that a step where nothing
  /// turns or moves fast reads no contact (a pass over a large pile's contacts costs more than its
  /// solve's share of a substep): no contact's term, (sweep_A + sweep_B + f u) / min(inner_A,
  /// inner_B), exceeds 2 S / min(inner), S the largest |omega| rho (not for a sphere) + |v| of a
  /// moving body (f u <= |v_A| + |v_B|), min(inner) over every body. Returns 2 S / min(inner) (1/s),
  /// with (1 + 1e-9) for the rounding of the terms' sums; and the largest turn, turned_, of a
  /// moving body into *turned (m) when asked for.
  double turn_rate_bound(double* turned = nullptr) const;
  /// After substep k's solve: each contact's impulse becomes the sum over the substeps so far
  /// (Contacts.impulse is the step's whole normal impulse).
  void sum_impulses(int k);
  /// After substep k of h: the next warm-starts from its cache; its figures go to the report.
  void end_substep(const SolverStats& stats, double h);
  /// Counts a solve that ended unconverged with a contact approaching faster than warn_velocity in
  /// the report (the worst at `time`).
  void end_substep_flags(const SolverStats& stats, double time);
  /// After contact detection: wakes the sleeping islands a moving body touches, then detects again.
  void wake_touched(double dt);
  /// The islands stage, after a kept step of dt: timers, islands, sleep (Islands::end_step).
  void end_islands(double dt);
  /// Continuous collision after the step's substeps (world/continuous.cpp): each fast or bullet
  /// dynamic body swept from its pose at the step's start to its end against the static bodies.
  void continuous();
  /// After bodies are added or removed, or a state restored: moving_ listed again (relist), and the
  /// stages' per-body scratch (and the guard's checkpoint) taken whole again at the next step.
  void bodies_changed(bool relist);
  /// Keeps a step the guard let through: its last contacts and figures, what the meshes remember,
  /// the new rotations' quaternions; the one-step forces are spent.
  void commit_step(const SolverStats& stats);
  /// The touching pairs of a contact list (in its order, which lists a pair's contacts together):
  /// body_a, body_b, the pair's first contact (impulse: unused, 0). With `bodies` (2 per contact)
  /// and `touches` (1 per contact), the solver's compact copies of the list's bodies and touching
  /// flags, those are read instead of the contact records.
  struct Touch {
    BodyIndex a, b;
    std::size_t first;
    double impulse;
  };
  static void touching_pairs(const std::vector<Contact>& contacts, std::vector<Touch>& out,
                             const BodyIndex* bodies = nullptr, const char* touches = nullptr);
  /// The step's events from the pairs touching before (touching_, from the last contacts when not
  /// known) and after it (the new contacts), appended to events_; touching_ becomes the new pairs.
  void record_events(const std::vector<Contact>& now);
  /// Moves the contacts of sensor bodies out of `contacts` (stable): a pair of two sensors is
  /// dropped, a (sensor, visitor) pair that overlaps (some gap < 0) goes to sensing_next_ with its
  /// contacts in sensed_contacts_. Nothing when the world has no sensor.
  void split_sensors(std::vector<Contact>& contacts) const;
  /// The sensor events of a step: sensing_next_ against sensing_ (a pair whose visitor sleeps stays:
  /// its contacts are not detected while it sleeps), appended to events_; sensing_ becomes the new pairs.
  void record_sensor_events();
  /// After a kept step: every unbroken joint whose force or torque passed its limit breaks (and
  /// is listed in breaks_, with step).
  void break_joints(int step);
  /// model_.joined_pairs again from the joints (after they or the bodies change).
  void joints_changed();

  using Lock = std::lock_guard<std::recursive_mutex>;
  /// Taken by every public member function (recursive: they call each other).
  mutable std::recursive_mutex mutex_;
  WorldSettings settings_;
  Model model_;
  State state_;
  std::shared_ptr<std::vector<Contact>> contacts_;
  SolverStats stats_;
  std::unordered_map<std::string, BodyIndex> by_name_;
  /// bodies whose shape is a bare non-convex mesh (collision::is_bare_nonconvex_mesh): the only
  /// shape of an unsupported pair, so add_body checks a new shape against the bodies it may touch
  /// only while there is one, or when the new shape is one (else building a world of N bodies
  /// would make N^2 / 2 pair checks)
  std::size_t bare_meshes_ = 0;
  /// The last hull add_body moved to its centre of mass, and where: bodies added with the same
  /// hull share the moved polytope (a pile of 5,000 copies reads one from the cache, not 5,000).
  struct MovedHull {
    std::shared_ptr<const Polytope> source, moved;
    Vec3 com = Vec3::Zero();
  } last_hull_;
  std::vector<std::shared_ptr<void>> retired_;  ///< outgrown state storage (see push_keeping)
  StepReport report_;
  ContactEvents events_;       ///< the last step() call's contact events
  std::vector<JointBreak> breaks_;  ///< the joints the last step() call broke
  double hit_speed_ = 1.0;      ///< m/s: a beginning faster than this is a hit
  int event_step_ = 0;          ///< the step of the call the next events belong to
  std::vector<Touch> touching_, touching_next_;  ///< pairs touching after the last step, and scratch
  /// (sensor, visitor) pairs overlapping after the last step (Touch::first unused), and the last
  /// detection's (first: the index of the deepest contact in sensed_contacts_)
  std::vector<Touch> sensing_;
  mutable std::vector<Touch> sensing_next_;
  mutable std::vector<Contact> sensed_contacts_;
  std::vector<Touch> sensing_merged_;  ///< scratch
  bool touching_known_ = false;  ///< touching_ matches the reported contacts (else taken from them)
  std::unique_ptr<collision::BroadPhase> broad_phase_;
  /// what contact detection remembers across steps (separating faces, the meshes' crossings)
  std::unique_ptr<collision::ContactMemory> memory_;
  std::unique_ptr<collision::Scratch> scratch_;  ///< the narrow phase's buffers (contact detection
                                                 ///< is const but reuses them: one World per thread)
  std::unique_ptr<solver::SolverData> solver_;  ///< rows, forces and the warm-start cache
  std::unique_ptr<parallel::Pool> pool_;        ///< the step's worker threads (settings_.threads of them)
  std::unique_ptr<StepGuard> guard_;            ///< the step's checkpoints and what an undo restores
  std::unique_ptr<Islands> islands_;            ///< sleeping islands' warm-start forces, the union-find
  std::unique_ptr<solver::JointSet> joints_;    ///< the joints and their rows (solver/joint_rows.hpp)
  // step scratch, kept between steps so that a step reuses its buffers instead of allocating
  std::vector<Contact> contacts_base_;   ///< the step's contacts as detected
  std::vector<Contact> contacts_next_;   ///< a substep's contacts (carried), kept when the step succeeds
  std::vector<Vec3> anchor_a_, anchor_b_;///< a carried contact's point moved with A and with B
  std::vector<Vec3> v_, omega_;          ///< q_dot* and then q_dot^{t+1}
  std::vector<double> impulse_sum_;      ///< per contact: its normal impulse over the substeps so far (N s)
  std::vector<double> turned_;           ///< per body: how far its turn since the step's detection moved it (m)
  std::vector<BodyIndex> escaped_;       ///< the bodies that outran the step's reach (find_escaped), ascending
  std::vector<double> escape_reach_;     ///< per body: its reach from the present poses for the rest of the step (m)
  std::vector<std::pair<BodyIndex, BodyIndex>> escape_pairs_;  ///< the escaped bodies' candidate pairs now
  std::vector<BodyIndex> escape_met_;    ///< the bodies a tree walk met
  std::vector<const void*> escape_stack_;///< the tree walk's stack
  /// the smallest inner radius of any body (m; soft_cut's bound), negative until read after the
  /// bodies changed (bodies_changed), so that a step's cost does not follow the static bodies
  mutable double least_inner_ = -1.0;
  std::vector<Contact> contacts_prev_;   ///< the last substep's contacts, while a substep detects again
  std::vector<Contact> redetected_list_; ///< a substep's contacts with the turned bodies' pairs found again
  std::vector<Vec3> redetected_a_, redetected_b_;  ///< their anchors
  bool redetected_ = false;              ///< the last substep's contacts were not only carried
  int soft_runs_ = 0;                    ///< the soft step's runs of rows ended so far (soft_cut)
  State segment_start_;                  ///< p and R where the soft step's present rows were made
  /// the non-static bodies, ascending: the only ones a step moves, so the only ones its per-body
  /// stages visit (a step's cost grows with them and the contacts, not with static bodies)
  std::vector<BodyIndex> moving_;
  mutable QueryStats query_stats_;  ///< the last query's counts (queries.cpp)
};

}  // namespace signorini
