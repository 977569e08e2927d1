// Joints of the World (docs/conventions.md, "Joints"): add (validate completely, convert the world
// anchor and axis to each body's frame, then commit), remove, and read. The rows are the solver's
// (solver/joint_rows.cpp); saved states carry the joints (saved_state.cpp).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "signorini/world.hpp"
#include "solver/contact_solver.hpp"
#include "solver/joint_rows.hpp"
#include "world/checks.hpp"
#include "world/islands.hpp"

namespace signorini {
namespace {

/// Joint j of joints, or std::out_of_range naming the index and the count.
Joint& checked(std::vector<Joint>& joints, JointIndex j) {
  if (j < 0 || static_cast<std::size_t>(j) >= joints.size())
    throw std::out_of_range("joint index " + std::to_string(j) + " is out of range: the world has " +
                            std::to_string(joints.size()) + " joints");
  return joints[static_cast<std::size_t>(j)];
}

const char* kind_name(JointKind k) {
  switch (k) {
    case JointKind::Revolute: return "Revolute";
    case JointKind::Prismatic: return "Prismatic";
    case JointKind::Spherical: return "Spherical";
    case JointKind::Fixed: return "Fixed";
    case JointKind::Distance: return "Distance";
  }
  return "?";
}

std::string num(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

std::string vec(const Vec3& x) { return "(" + num(x[0]) + ", " + num(x[1]) + ", " + num(x[2]) + ")"; }

/// A motor's settings, or fail(why): a finite speed and position, max_force >= 0 (infinite allowed:
/// an unbounded drive), stiffness and damping finite and >= 0.
template <class Fail>
void check_motor(const Motor& m, Fail&& fail) {
  if (!std::isfinite(m.speed)) fail("motor speed must be finite, got " + num(m.speed));
  if (!(m.max_force >= 0.0)) fail("motor max force (torque) must be >= 0, got " + num(m.max_force));
  if (!std::isfinite(m.position)) fail("motor position must be finite, got " + num(m.position));
  if (!(std::isfinite(m.stiffness) && m.stiffness >= 0.0))
    fail("motor stiffness must be finite and >= 0, got " + num(m.stiffness));
  if (!(std::isfinite(m.damping) && m.damping >= 0.0))
    fail("motor damping must be finite and >= 0, got " + num(m.damping));
}

/// A unit vector perpendicular to unit a: the first tangent of the contacts' basis.
Vec3 perpendicular(const Vec3& a) {
  Vec3 t1, t2;
  solver::tangent_basis(a, t1, t2);
  return t1;
}

}  // namespace

std::string World::joint_label(JointIndex j) const {
  const Lock lock(mutex_);
  const Joint& x = joints_->joints[static_cast<std::size_t>(j)];
  return "joint " + std::to_string(j) + (x.name.empty() ? "" : " '" + x.name + "'") + " (" + kind_name(x.kind) + ")";
}

JointIndex World::add_joint(const JointDesc& desc) {
  const Lock lock(mutex_);
  const auto j = static_cast<JointIndex>(joints_->joints.size());
  const std::string who = "joint " + std::to_string(j) + (desc.name.empty() ? "" : " '" + desc.name + "'") + " (" +
                          kind_name(desc.kind) + ")";
  const auto fail = [&](const std::string& why) { throw std::invalid_argument(who + ": " + why); };
  const auto n = static_cast<BodyIndex>(model_.size());
  for (const BodyIndex i : {desc.body_a, desc.body_b})
    if (i < 0 || i >= n)
      throw BodyIndexError(who + ": body index " + std::to_string(i) + " is out of range: the world has " +
                           std::to_string(n) + " bodies");
  if (desc.body_a == desc.body_b) fail("body_a and body_b are the same body, " + label(desc.body_a) + "; give two bodies");
  if (model_.is_static[desc.body_a] && model_.is_static[desc.body_b])
    fail("both bodies are static (" + label(desc.body_a) + ", " + label(desc.body_b) + "): a joint needs one that moves");
  if (!desc.anchor.allFinite()) fail("anchor must be finite, got " + vec(desc.anchor));
  if (desc.kind == JointKind::Distance && !desc.anchor_b.allFinite())
    fail("anchor_b must be finite, got " + vec(desc.anchor_b));
  const bool axial = desc.kind == JointKind::Revolute || desc.kind == JointKind::Prismatic;
  if (desc.has_twist && desc.kind != JointKind::Spherical) fail("only Spherical joints take twist limits");
  if (axial) {
    if (!desc.axis.allFinite()) fail("axis must be finite, got " + vec(desc.axis));
    if (!(desc.axis.norm() > 1e-12)) fail("axis must be a non-zero vector, got " + vec(desc.axis));
    if (desc.has_limits) {
      if (!std::isfinite(desc.lower) || !std::isfinite(desc.upper))
        fail("limits must be finite, got (" + num(desc.lower) + ", " + num(desc.upper) + ")");
      if (desc.lower > desc.upper)
        fail("limits need lower <= upper, got (" + num(desc.lower) + ", " + num(desc.upper) + ")");
      if (desc.kind == JointKind::Revolute && (desc.lower <= -M_PI || desc.upper >= M_PI))
        fail("a hinge's limits must lie in (-pi, pi) rad, got (" + num(desc.lower) + ", " + num(desc.upper) + ")");
    }
    if (desc.motor.enabled) check_motor(desc.motor, fail);
    if (!(std::isfinite(desc.friction) && desc.friction >= 0.0))
      fail("friction must be finite and >= 0, got " + num(desc.friction));
    if (!std::isfinite(desc.effort)) fail("effort must be finite, got " + num(desc.effort));
  } else {
    if ((desc.has_limits || desc.has_twist) && desc.kind == JointKind::Spherical) {
      // a ball joint's cone (B's axis within upper of A's; lower is 0) and twist about the axis
      if (!desc.axis.allFinite()) fail("axis must be finite, got " + vec(desc.axis));
      if (!(desc.axis.norm() > 1e-12)) fail("axis must be a non-zero vector, got " + vec(desc.axis));
      if (desc.has_limits && (desc.lower != 0.0 || !(desc.upper > 0.0 && desc.upper < M_PI)))
        fail("a ball joint's cone angle must lie in (0, pi) rad, got " + num(desc.upper));
      const std::string twist = "(" + num(desc.twist_lower) + ", " + num(desc.twist_upper) + ")";
      if (desc.has_twist && !(desc.twist_lower > -M_PI && desc.twist_upper < M_PI))
        fail("a ball joint's twist limits must lie in (-pi, pi) rad, got " + twist);
      if (desc.has_twist && !(desc.twist_lower <= desc.twist_upper))
        fail("a ball joint's twist limits need lower <= upper, got " + twist);
    } else if (desc.has_limits) {
      fail("only Revolute and Prismatic joints take limits, and Spherical ones a cone");
    }
    if (desc.motor.enabled) fail("only Revolute and Prismatic joints take a motor");
    if (desc.friction != 0.0) fail("only Revolute and Prismatic joints take friction");
    if (desc.effort != 0.0) fail("only Revolute and Prismatic joints take an effort");
  }
  if (desc.kind == JointKind::Distance) {
    if (!(std::isfinite(desc.min_length) && desc.min_length >= 0.0))
      fail("min_length must be finite and >= 0, got " + num(desc.min_length));
    if (std::isnan(desc.max_length) || desc.max_length < desc.min_length)
      fail("max_length must be >= min_length, got min " + num(desc.min_length) + ", max " + num(desc.max_length));
    if (!(desc.max_length > 0.0)) fail("max_length must be > 0, got " + num(desc.max_length));
  }
  if (!(desc.break_force > 0.0)) fail("break_force must be > 0 (infinite: never), got " + num(desc.break_force));
  if (!(desc.break_torque > 0.0)) fail("break_torque must be > 0 (infinite: never), got " + num(desc.break_torque));
  if (!desc.name.empty() && find_joint(desc.name) >= 0)
    fail("the name '" + desc.name + "' is taken by joint " + std::to_string(find_joint(desc.name)));

  // the world's anchor and axis in each body's frame, at the bodies' current poses
  Joint x;
  x.kind = desc.kind;
  x.a = desc.body_a;
  x.b = desc.body_b;
  const Mat3& RA = state_.R[x.a];
  const Mat3& RB = state_.R[x.b];
  const Vec3 at_b = desc.kind == JointKind::Distance ? desc.anchor_b : desc.anchor;
  x.anchor_a = RA.transpose() * (desc.anchor - state_.p[x.a]);
  x.anchor_b = RB.transpose() * (at_b - state_.p[x.b]);
  const bool coned = desc.kind == JointKind::Spherical && (desc.has_limits || desc.has_twist);
  const Vec3 axis = axial || coned ? Vec3(desc.axis.normalized()) : Vec3(Vec3::UnitZ());
  const Vec3 ref = perpendicular(axis);
  x.axis_a = RA.transpose() * axis;
  x.axis_b = RB.transpose() * axis;
  x.ref_a = RA.transpose() * ref;
  x.ref_b = RB.transpose() * ref;
  x.R_rel = RA.transpose() * RB;
  x.has_limits = desc.has_limits;
  x.lower = desc.lower;
  x.upper = desc.upper;
  x.has_twist = desc.has_twist;
  x.twist_lower = desc.twist_lower;
  x.twist_upper = desc.twist_upper;
  x.motor = desc.motor;
  x.friction = desc.friction;
  x.effort = desc.effort;
  x.break_force = desc.break_force;
  x.break_torque = desc.break_torque;
  x.min_length = desc.min_length;
  x.max_length = desc.max_length;
  x.collide_connected = desc.collide_connected;
  x.name = desc.name;
  joints_->joints.push_back(std::move(x));
  joints_changed();
  wake(desc.body_a);
  wake(desc.body_b);
  return j;
}

void World::remove_joint(JointIndex j) {
  const Lock lock(mutex_);
  const Joint& gone = checked(joints_->joints, j);
  const BodyIndex a = gone.a, b = gone.b;
  joints_->joints.erase(joints_->joints.begin() + j);
  joints_changed();
  wake(a);
  wake(b);
}

void World::set_joint_motor(JointIndex j, const Motor& motor) {
  const Lock lock(mutex_);
  Joint& x = checked(joints_->joints, j);
  const auto fail = [&](const std::string& why) { throw std::invalid_argument(joint_label(j) + ": " + why); };
  if (motor.enabled) {
    if (!x.one_dof()) fail("only Revolute and Prismatic joints take a motor");
    check_motor(motor, fail);
  }
  // a motor switched on or off changes the joint's rows: its warm-start force starts from zero
  if (motor.enabled != x.motor.enabled) x.alpha[kSlotMotor] = 0.0;
  x.motor = motor;
  wake(x.a);
  wake(x.b);
}

void World::set_joint_effort(JointIndex j, double effort) {
  const Lock lock(mutex_);
  Joint& x = checked(joints_->joints, j);
  if (!x.one_dof()) throw std::invalid_argument(joint_label(j) + ": only Revolute and Prismatic joints take an effort");
  if (!std::isfinite(effort)) throw std::invalid_argument(joint_label(j) + ": effort must be finite, got " + num(effort));
  x.effort = effort;
  if (effort == 0.0) x.alpha[kSlotEffort] = 0.0;
  wake(x.a);
  wake(x.b);
}

void World::set_joint_broken(JointIndex j, bool broken) {
  const Lock lock(mutex_);
  Joint& x = checked(joints_->joints, j);
  if (x.broken == broken) return;
  x.broken = broken;
  x.alpha.fill(0.0);
  x.force.setZero();
  x.torque.setZero();
  joints_changed();
  wake(x.a);
  wake(x.b);
}

void World::break_joints(int step) {
  bool any = false;
  for (std::size_t k = 0; k < joints_->joints.size(); ++k) {
    Joint& x = joints_->joints[k];
    if (x.broken || !(x.force.norm() > x.break_force || x.torque.norm() > x.break_torque)) continue;
    breaks_.push_back({step, static_cast<JointIndex>(k), x.force, x.torque});
    x.broken = true;
    x.alpha.fill(0.0);
    x.force.setZero();
    x.torque.setZero();
    any = true;
  }
  if (any) joints_changed();  // its bodies collide from the next step
}

std::vector<World::JointBreak> World::joint_breaks() const {
  const Lock lock(mutex_);
  return breaks_;
}

void World::joints_changed() {
  auto& pairs = model_.joined_pairs;
  pairs.clear();
  for (const Joint& x : joints_->joints)
    if (!x.collide_connected && !x.broken) pairs.emplace_back(std::min(x.a, x.b), std::max(x.a, x.b));
  std::sort(pairs.begin(), pairs.end());
  joints_->blocks.clear();  // their alpha pointers may have moved
  joints_->kept.clear();
}

std::size_t World::num_joints() const {
  const Lock lock(mutex_);
  return joints_->joints.size();
}

std::vector<Joint> World::joints() const {
  const Lock lock(mutex_);
  return joints_->joints;
}

JointIndex World::find_joint(const std::string& name) const {
  const Lock lock(mutex_);
  if (name.empty()) return -1;
  for (std::size_t j = 0; j < joints_->joints.size(); ++j)
    if (joints_->joints[j].name == name) return static_cast<JointIndex>(j);
  return -1;
}

std::vector<double> World::joint_positions() const {
  const Lock lock(mutex_);
  std::vector<double> out;
  out.reserve(joints_->joints.size());
  for (const Joint& x : joints_->joints) out.push_back(solver::joint_position(x, state_));
  return out;
}

std::vector<double> World::joint_velocities() const {
  const Lock lock(mutex_);
  std::vector<double> out;
  out.reserve(joints_->joints.size());
  for (const Joint& x : joints_->joints) out.push_back(solver::joint_velocity(x, state_));
  return out;
}

std::vector<Vec3> World::joint_forces() const {
  const Lock lock(mutex_);
  std::vector<Vec3> out;
  out.reserve(joints_->joints.size());
  for (const Joint& x : joints_->joints) out.push_back(x.force);
  return out;
}

std::vector<Vec3> World::joint_torques() const {
  const Lock lock(mutex_);
  std::vector<Vec3> out;
  out.reserve(joints_->joints.size());
  for (const Joint& x : joints_->joints) out.push_back(x.torque);
  return out;
}

}  // namespace signorini
