// Saved states (World::save_state, restore_state): a flat little-endian byte string in which each
// owner writes its own part, in this order: the World's header (body count, and each body's shape
// kind, static flag and mass, to recognise the world) and flags (kinematic, enabled); the State
// (time, then its arrays in State::for_each_array order); the solver (contact forces and torques,
// the warm-start cache); the World's last contacts and solver figures; the contact memory
// (format 3; from format 5 with the kept manifolds of contact recycling); the islands (format 4:
// per body awake, sleep timer and island label, then the sleeping islands' warm-start forces); the
// joints (format 5: each joint whole, in its bodies' frames, with its warm-start forces and last
// force and torque; format 6: the kept manifolds with their rows as found; format 7: each joint's
// motor with its servo position, stiffness and damping, its friction, effort and their rows' forces, its breaking limits and whether it broke; then the sensors' overlapping pairs). Formats 1 (no spin
// torques), 2 (no contact memory), 3 (no islands: every body awake, timers zero), 4 (no kept
// manifolds: every pair found anew, no pair counts; no joints: the world keeps its joints, their
// warm start zeroed), 5 (kept manifolds without their rows: every pair found anew) and 6 (rigid
// velocity motors only) still read.
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "collision/collision.hpp"
#include "serial/byte_stream.hpp"
#include "signorini/world.hpp"
#include "solver/contact_solver.hpp"
#include "solver/joint_rows.hpp"
#include "world/checks.hpp"
#include "world/islands.hpp"

namespace signorini {
namespace {

constexpr char kStateMagic[8] = {'S', 'G', 'S', 'T', 'A', 'T', 'E', '8'};
constexpr std::size_t kStateVersionAt = 7;  ///< the format digit's position in the magic

void save(serial::Writer& w, const State& s) {
  w.pod(s.time);
  s.for_each_array([&w](const auto& x) { w.mats(x); });
}

void load(serial::Reader& r, std::size_t n, State& s) {
  s.time = r.pod<double>();
  s.for_each_array([&r, n](auto& x) { r.mats(x, n); });
}

void save(serial::Writer& w, const Contact& c) {
  w.pod(c.body_a);
  w.pod(c.body_b);
  w.mat(c.point);
  w.mat(c.normal);
  w.pod(c.gap);
  w.pod(c.feature_a);
  w.pod(c.feature_b);
  w.pod(c.alpha);
  w.pod(c.impulse);
  w.mat(c.friction);
  w.mat(c.force);
  w.pod(c.spin_torque);
  w.pod(c.normal_velocity);
  w.mat(c.slip);
}

/// A contact of a saved state of format `version` (1: without spin_torque).
Contact load_contact(serial::Reader& r, char version) {
  Contact c;
  c.body_a = r.pod<BodyIndex>();
  c.body_b = r.pod<BodyIndex>();
  r.mat(c.point);
  r.mat(c.normal);
  c.gap = r.pod<double>();
  c.feature_a = r.pod<FeatureId>();
  c.feature_b = r.pod<FeatureId>();
  c.alpha = r.pod<double>();
  c.impulse = r.pod<double>();
  r.mat(c.friction);
  r.mat(c.force);
  if (version >= '2') c.spin_torque = r.pod<double>();
  c.normal_velocity = r.pod<double>();
  r.mat(c.slip);
  return c;
}

void save(serial::Writer& w, const SolverStats& s) {
  for (int x : {s.iterations, s.restitution_iterations, s.position_iterations, s.contacts, static_cast<int>(s.converged)})
    w.pod(x);
  w.pod(s.pairs);
  w.pod(s.recycled_pairs);
  for (double x : {s.residual, s.max_alpha_negative, s.max_penetration_velocity, s.max_complementarity,
                   s.max_cone_violation, s.max_dissipation_violation, s.max_overlap})
    w.pod(x);
}

SolverStats load_stats(serial::Reader& r, char version) {
  SolverStats s;
  for (int* x : {&s.iterations, &s.restitution_iterations, &s.position_iterations, &s.contacts}) *x = r.pod<int>();
  s.converged = r.pod<int>() != 0;
  if (version >= '5') {
    s.pairs = r.pod<int>();
    s.recycled_pairs = r.pod<int>();
  }
  for (double* x : {&s.residual, &s.max_alpha_negative, &s.max_penetration_velocity, &s.max_complementarity,
                    &s.max_cone_violation, &s.max_dissipation_violation, &s.max_overlap})
    *x = r.pod<double>();
  return s;
}

void save(serial::Writer& w, const Joint& j) {
  w.pod(static_cast<std::uint8_t>(j.kind));
  w.pod(static_cast<std::int32_t>(j.a));
  w.pod(static_cast<std::int32_t>(j.b));
  for (const Vec3* x : {&j.anchor_a, &j.anchor_b, &j.axis_a, &j.axis_b, &j.ref_a, &j.ref_b}) w.mat(*x);
  w.mat(j.R_rel);
  w.pod(static_cast<std::uint8_t>(j.has_limits));
  w.pod(j.lower);
  w.pod(j.upper);
  w.pod(static_cast<std::uint8_t>(j.has_twist));
  w.pod(j.twist_lower);
  w.pod(j.twist_upper);
  w.pod(static_cast<std::uint8_t>(j.motor.enabled));
  w.pod(j.motor.speed);
  w.pod(j.motor.max_force);
  w.pod(j.motor.position);
  w.pod(j.motor.stiffness);
  w.pod(j.motor.damping);
  w.pod(j.friction);
  w.pod(j.effort);
  w.pod(j.break_force);
  w.pod(j.break_torque);
  w.pod(static_cast<std::uint8_t>(j.broken));
  w.pod(j.min_length);
  w.pod(j.max_length);
  w.pod(static_cast<std::uint8_t>(j.collide_connected));
  w.pod(static_cast<std::uint64_t>(j.name.size()));
  w.out.append(j.name);
  for (const double a : j.alpha) w.pod(a);
  w.mat(j.force);
  w.mat(j.torque);
}

/// A joint of a saved state, checked against n bodies (kinds, indices, finite values).
Joint load_joint(serial::Reader& r, std::size_t n, char version) {
  const std::string damaged = "restore_state: the saved state is damaged (a joint)";
  Joint j;
  const auto kind = r.pod<std::uint8_t>();
  if (kind > static_cast<std::uint8_t>(JointKind::Distance)) throw std::invalid_argument(damaged);
  j.kind = static_cast<JointKind>(kind);
  j.a = r.pod<std::int32_t>();
  j.b = r.pod<std::int32_t>();
  if (j.a < 0 || j.b < 0 || static_cast<std::size_t>(j.a) >= n || static_cast<std::size_t>(j.b) >= n || j.a == j.b)
    throw std::invalid_argument(damaged);
  for (Vec3* x : {&j.anchor_a, &j.anchor_b, &j.axis_a, &j.axis_b, &j.ref_a, &j.ref_b}) r.mat(*x);
  r.mat(j.R_rel);
  j.has_limits = r.pod<std::uint8_t>() != 0;
  j.lower = r.pod<double>();
  j.upper = r.pod<double>();
  if (version >= '8') {  // format 7 and before: no twist limits
    j.has_twist = r.pod<std::uint8_t>() != 0;
    j.twist_lower = r.pod<double>();
    j.twist_upper = r.pod<double>();
  }
  j.motor.enabled = r.pod<std::uint8_t>() != 0;
  j.motor.speed = r.pod<double>();
  j.motor.max_force = r.pod<double>();
  if (version >= '7') {  // format 6 and before: a rigid velocity motor
    j.motor.position = r.pod<double>();
    j.motor.stiffness = r.pod<double>();
    j.motor.damping = r.pod<double>();
    j.friction = r.pod<double>();
    j.effort = r.pod<double>();
    j.break_force = r.pod<double>();
    j.break_torque = r.pod<double>();
    j.broken = r.pod<std::uint8_t>() != 0;
  }
  j.min_length = r.pod<double>();
  j.max_length = r.pod<double>();
  j.collide_connected = r.pod<std::uint8_t>() != 0;
  const std::size_t length = r.count(1);
  j.name.assign(r.in, r.at, length);
  r.at += length;
  // format 6 and before: the slots before the friction row's
  const std::size_t slots = version >= '7' ? j.alpha.size() : static_cast<std::size_t>(kSlotFriction);
  for (std::size_t k = 0; k < slots; ++k) j.alpha[k] = r.pod<double>();
  r.mat(j.force);
  r.mat(j.torque);
  bool finite = j.anchor_a.allFinite() && j.anchor_b.allFinite() && j.axis_a.allFinite() && j.axis_b.allFinite() &&
                j.ref_a.allFinite() && j.ref_b.allFinite() && j.R_rel.allFinite() && j.force.allFinite() &&
                j.torque.allFinite() && !std::isnan(j.lower) && !std::isnan(j.upper) && std::isfinite(j.twist_lower) &&
                std::isfinite(j.twist_upper) && std::isfinite(j.min_length) &&
                !std::isnan(j.max_length) && std::isfinite(j.motor.speed) && j.motor.max_force >= 0.0 &&
                std::isfinite(j.motor.position) && std::isfinite(j.motor.stiffness) && j.motor.stiffness >= 0.0 &&
                std::isfinite(j.motor.damping) && j.motor.damping >= 0.0 && std::isfinite(j.friction) &&
                j.friction >= 0.0 && std::isfinite(j.effort) && j.break_force > 0.0 && j.break_torque > 0.0;
  for (const double a : j.alpha) finite = finite && std::isfinite(a);
  if (!finite) throw std::invalid_argument(damaged);
  return j;
}

}  // namespace

std::string World::save_state() const {
  const Lock lock(mutex_);
  serial::Writer w;
  w.out.append(kStateMagic, sizeof kStateMagic);
  const std::size_t n = model_.size();
  w.pod(static_cast<std::uint64_t>(n));
  // the world it belongs to
  for (std::size_t i = 0; i < n; ++i) {
    w.pod(static_cast<std::uint8_t>(model_.shape[i].index()));
    w.pod(static_cast<std::uint8_t>(model_.is_static[i]));
    w.pod(model_.mass[i]);
  }
  for (std::size_t i = 0; i < n; ++i) {
    w.pod(static_cast<std::uint8_t>(model_.is_kinematic[i]));
    w.pod(static_cast<std::uint8_t>(model_.enabled[i]));
  }
  save(w, state_);
  solver::save(w, *solver_);
  w.pod(static_cast<std::uint64_t>(contacts_->size()));
  for (const Contact& c : *contacts_) save(w, c);
  save(w, stats_);
  memory_->save(w);
  islands_->save(w, state_);
  w.pod(static_cast<std::uint64_t>(islands_->contacts().size()));
  for (const Contact& c : islands_->contacts()) save(w, c);
  w.pod(static_cast<std::uint64_t>(joints_->joints.size()));
  for (const Joint& j : joints_->joints) save(w, j);
  w.pod(static_cast<std::uint64_t>(sensing_.size()));  // format 7: the sensors' overlaps
  for (const Touch& t : sensing_) {
    w.pod(static_cast<std::int32_t>(t.a));
    w.pod(static_cast<std::int32_t>(t.b));
  }
  return std::move(w.out);
}

void World::restore_state(const std::string& saved) {
  const Lock lock(mutex_);
  // read and check everything first: the world changes only once nothing can fail
  serial::Reader r{saved};
  const std::string bad = "restore_state: not a saved state of this world: ";
  if (saved.size() < sizeof kStateMagic || std::memcmp(saved.data(), kStateMagic, kStateVersionAt) != 0)
    throw std::invalid_argument("restore_state: not a saved state (no header)");
  const char version = saved[kStateVersionAt];
  if (version < '1' || version > '8')
    throw std::invalid_argument(std::string("restore_state: a saved state of format '") + version +
                                "', which this signorini does not read (it reads formats 1 to 8)");
  r.at = sizeof kStateMagic;
  const std::size_t n = r.pod<std::uint64_t>();
  if (n != model_.size())
    throw std::invalid_argument(bad + "it has " + std::to_string(n) + " bodies, the world has " +
                                std::to_string(model_.size()));
  static const char* kinds[] = {"Sphere", "Box", "Plane", "Mesh", "Capsule", "Cylinder", "ConvexHull", "TriangleMesh", "Compound"};
  for (std::size_t i = 0; i < n; ++i) {
    const auto kind = r.pod<std::uint8_t>();
    const bool is_static = r.pod<std::uint8_t>() != 0;
    const double mass = r.pod<double>();
    const std::string who = label(static_cast<BodyIndex>(i));
    if (kind != model_.shape[i].index())
      throw std::invalid_argument(bad + who + " is a " + (kind < 9 ? kinds[kind] : "?") + " there");
    if (is_static != model_.is_static[i])
      throw std::invalid_argument(bad + who + " is " + (is_static ? "static" : "not static") + " there");
    if (!(mass == model_.mass[i]))
      throw std::invalid_argument(bad + who + " has mass " + std::to_string(mass) + " kg there, " +
                                  std::to_string(model_.mass[i]) + " kg here");
  }
  std::vector<char> kinematic(n), enabled(n);
  for (std::size_t i = 0; i < n; ++i) {
    kinematic[i] = r.pod<std::uint8_t>() != 0;
    enabled[i] = r.pod<std::uint8_t>() != 0;
    if (kinematic[i] && model_.is_static[i]) throw std::invalid_argument("restore_state: the saved state is damaged");
    if (!kinematic[i] && !model_.is_static[i] && !std::isfinite(model_.mass[i]))
      throw std::invalid_argument(bad + label(static_cast<BodyIndex>(i)) + " is dynamic there but has no mass here");
  }
  State s;
  load(r, n, s);
  solver::SolverData solved;
  solver::load(r, version, n, solved);
  auto contacts = std::make_shared<std::vector<Contact>>(r.count(sizeof(double)));
  for (Contact& c : *contacts) c = load_contact(r, version);
  const SolverStats stats = load_stats(r, version);
  // formats 1 and 2 have no contact memory: it starts afresh, as after set_position
  collision::ContactMemory memory;
  if (version >= '3') {
    memory.load(r, model_, version);
  } else {
    for (const Vec3& p : s.p) memory.add_body(p);
  }
  // format 3 and before: every dynamic body awake, no timers, nothing stashed
  std::vector<std::uint8_t> awake(n);
  std::vector<double> sleep_time(n, 0.0);
  std::vector<std::int32_t> island(n, -1);
  std::vector<CachedContact> stash;
  std::vector<Contact> sleeping_contacts;
  std::vector<Vec3> sleeping_force(n, Vec3::Zero()), sleeping_torque(n, Vec3::Zero());
  if (version >= '4') {
    Islands::load(r, n, awake, sleep_time, island, stash, sleeping_force, sleeping_torque);
    sleeping_contacts.resize(r.count(sizeof(double)));
    for (Contact& c : sleeping_contacts) c = load_contact(r, version);
  } else {
    for (std::size_t i = 0; i < n; ++i) awake[i] = model_.is_static[i] ? 0 : 1;
  }
  // format 4 and before: no joints (the world keeps its own, their warm start zeroed)
  std::vector<Joint> joints;
  if (version >= '5') {
    joints.resize(r.count(64));
    for (Joint& j : joints) j = load_joint(r, n, version);
  } else {
    joints = joints_->joints;
    for (Joint& j : joints) j.alpha.fill(0.0), j.force.setZero(), j.torque.setZero();
  }
  // format 6 and before: no sensor overlaps (the next step begins those it finds)
  std::vector<Touch> sensing;
  if (version >= '7') {
    sensing.resize(r.count(8));
    for (Touch& t : sensing) {
      t.a = r.pod<std::int32_t>();
      t.b = r.pod<std::int32_t>();
      t.first = 0;
      t.impulse = 0.0;
      if (t.a < 0 || t.b < 0 || static_cast<std::size_t>(t.a) >= n || static_cast<std::size_t>(t.b) >= n)
        throw std::invalid_argument("restore_state: the saved state is damaged (a sensor's overlap)");
    }
  }
  if (r.at != saved.size()) throw std::invalid_argument("restore_state: the saved state has trailing bytes");
  const auto in_range = [n](BodyIndex k) { return k >= 0 && static_cast<std::size_t>(k) < n; };
  for (const CachedContact& c : solved.cache)
    if (!in_range(c.body_a) || !in_range(c.body_b)) throw std::invalid_argument("restore_state: the saved state is damaged");
  for (const Contact& c : *contacts)
    if (!in_range(c.body_a) || !in_range(c.body_b)) throw std::invalid_argument("restore_state: the saved state is damaged");
  for (const CachedContact& c : stash)
    if (!in_range(c.body_a) || !in_range(c.body_b)) throw std::invalid_argument("restore_state: the saved state is damaged");
  for (const Contact& c : sleeping_contacts)
    if (!in_range(c.body_a) || !in_range(c.body_b)) throw std::invalid_argument("restore_state: the saved state is damaged");
  for (std::size_t i = 0; i < n; ++i) {
    // asleep with a label in range, or awake without one; static bodies never awake; kinematic and
    // disabled bodies never asleep
    const bool asleep = awake[i] == 0;
    const bool labelled = island[i] >= 0 && static_cast<std::size_t>(island[i]) < n;
    const bool ok = model_.is_static[i] ? asleep && island[i] == -1
                                        : (asleep ? labelled && !kinematic[i] && enabled[i] : island[i] == -1) &&
                                              awake[i] <= 1 && std::isfinite(sleep_time[i]) && sleep_time[i] >= 0.0;
    if (!ok) throw std::invalid_argument("restore_state: the saved state is damaged (sleeping flags of " +
                                         label(static_cast<BodyIndex>(i)) + ")");
  }
  if (!std::isfinite(s.time)) throw std::invalid_argument("restore_state: the saved state is damaged (time)");
  for (std::size_t i = 0; i < n; ++i)
    if (!(s.p[i].allFinite() && s.R[i].allFinite() && s.q[i].allFinite() && s.v[i].allFinite() &&
          s.omega[i].allFinite() && s.f_ext[i].allFinite() && s.tau_ext[i].allFinite()))
      throw std::invalid_argument("restore_state: the saved state is damaged (" + label(static_cast<BodyIndex>(i)) +
                                  " is not finite)");

  // commit: in place, so that views of the state stay live
  for (std::size_t i = 0; i < n; ++i) {
    const auto b = static_cast<BodyIndex>(i);
    if (!model_.is_static[i]) {
      if (model_.is_kinematic[i] != static_cast<bool>(kinematic[i])) set_kinematic_flag(b, kinematic[i]);
    } else if (s.p[i] != state_.p[i] || s.R[i] != state_.R[i]) {
      broad_phase_->move_static(b, s.p[i], s.R[i]);
    }
    model_.enabled[i] = enabled[i];
  }
  state_.for_each_array_with(s, [](auto& mine, const auto& saved_array) { checks::copy_into(mine, saved_array); });
  state_.time = s.time;
  checks::copy_into(state_.awake, awake);
  checks::copy_into(state_.sleep_time, sleep_time);
  checks::copy_into(state_.island, island);
  islands_->assign(std::move(stash), std::move(sleeping_contacts), std::move(sleeping_force), std::move(sleeping_torque));
  checks::copy_into(solver_->body_force, solved.body_force);
  checks::copy_into(solver_->body_torque, solved.body_torque);
  solver_->cache = std::move(solved.cache);
  contacts_ = std::move(contacts);
  stats_ = stats;
  checks::copy_into(memory_->previous_p, memory.previous_p);
  checks::copy_into(memory_->crossing, memory.crossing);
  memory_->manifolds.last = std::move(memory.manifolds.last);  // not per body: sized as saved
  memory_->manifolds.last_points = std::move(memory.manifolds.last_points);
  joints_->joints = std::move(joints);
  joints_changed();
  sensing_ = std::move(sensing);
  bodies_changed(false);  // the contact forces and static poses changed outside a step
  if (!settings_.sleep.enabled) wake_all();  // a world with sleeping off keeps nothing asleep
}

}  // namespace signorini
