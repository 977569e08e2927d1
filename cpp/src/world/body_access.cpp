// Reading and changing bodies one at a time or in batches: every setter checks its input (the body
// named on error) before it writes, so a refused call changes nothing.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "collision/collision.hpp"
#include "math/rotation.hpp"
#include "signorini/world.hpp"
#include "solver/contact_solver.hpp"
#include "world/checks.hpp"
#include "world/islands.hpp"

namespace signorini {

void World::set_material(BodyIndex i, const Material& material) {
  const Lock lock(mutex_);
  check_index(i);
  checks::check_material(label(i), material);
  model_.material[i] = material;
  wake(i);  // a new friction may let it slide
}

std::string World::label(BodyIndex i) const {
  const Lock lock(mutex_);
  check_index(i);
  return checks::body_label(model_, i);
}

void World::check_index(BodyIndex i) const {
  if (i < 0 || static_cast<std::size_t>(i) >= model_.size())
    throw BodyIndexError("body index " + std::to_string(i) + " is out of range: the world has " +
                         std::to_string(model_.size()) + " bodies");
}

void World::set_position(BodyIndex i, const Vec3& p) {
  const Lock lock(mutex_);
  check_index(i);
  checks::require_finite(label(i), "position", p);
  state_.p[i] = p;
  memory_->placed(i, p);  // moved, not travelled: no crossing
  if (model_.is_static[i]) broad_phase_->move_static(i, state_.p[i], state_.R[i]);
  wake(i);
}

void World::set_orientation(BodyIndex i, const Quat4& q) {
  const Lock lock(mutex_);
  check_index(i);
  state_.R[i] = math::quat_to_matrix(checks::unit_quaternion(label(i), q));
  state_.q[i] = math::matrix_to_quat(state_.R[i]);
  if (model_.is_static[i]) broad_phase_->move_static(i, state_.p[i], state_.R[i]);
  wake(i);
}

void World::check_velocity(BodyIndex i, const char* what, const Vec3& x) const {
  check_index(i);
  const std::string who = label(i);
  checks::require_finite(who, what, x);
  if (model_.is_static[i] && x.squaredNorm() > 0.0)
    throw std::invalid_argument(who + ": a static body cannot have a velocity");
}

void World::set_velocity(BodyIndex i, const Vec3& v) {
  const Lock lock(mutex_);
  check_velocity(i, "velocity", v);
  state_.v[i] = v;
  wake(i);
}

void World::set_angular_velocity(BodyIndex i, const Vec3& omega) {
  const Lock lock(mutex_);
  check_velocity(i, "angular_velocity", omega);
  state_.omega[i] = omega;
  wake(i);
}

void World::check_batch(const char* who, const Indices& bodies, Eigen::Index rows) const {
  if (bodies.size() != rows)
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(bodies.size()) + " indices but " +
                                std::to_string(rows) + " rows of values");
  for (Eigen::Index k = 0; k < bodies.size(); ++k)
    if (bodies[k] < 0 || static_cast<std::size_t>(bodies[k]) >= model_.size())
      throw BodyIndexError(std::string(who) + ": indices[" + std::to_string(k) + "] = " + std::to_string(bodies[k]) +
                           " is out of range: the world has " + std::to_string(model_.size()) + " bodies");
}

void World::set_positions(const Indices& bodies, const Points& values) {
  const Lock lock(mutex_);
  check_batch("set_positions", bodies, values.rows());
  for (Eigen::Index k = 0; k < bodies.size(); ++k)
    checks::require_finite(label(static_cast<BodyIndex>(bodies[k])), "position", values.row(k).transpose());
  for (Eigen::Index k = 0; k < bodies.size(); ++k) {
    const auto i = static_cast<BodyIndex>(bodies[k]);
    state_.p[i] = values.row(k).transpose();
    memory_->placed(i, state_.p[i]);  // moved, not travelled: no crossing
    if (model_.is_static[i]) broad_phase_->move_static(i, state_.p[i], state_.R[i]);
    wake(i);
  }
}

void World::set_orientations(const Indices& bodies, const Quats& values) {
  const Lock lock(mutex_);
  check_batch("set_orientations", bodies, values.rows());
  std::vector<Mat3> R(bodies.size());
  for (Eigen::Index k = 0; k < bodies.size(); ++k)
    R[k] = math::quat_to_matrix(checks::unit_quaternion(label(static_cast<BodyIndex>(bodies[k])), values.row(k).transpose()));
  for (Eigen::Index k = 0; k < bodies.size(); ++k) {
    const auto i = static_cast<BodyIndex>(bodies[k]);
    state_.R[i] = R[k];
    state_.q[i] = math::matrix_to_quat(R[k]);
    if (model_.is_static[i]) broad_phase_->move_static(i, state_.p[i], state_.R[i]);
    wake(i);
  }
}

void World::set_velocities(const Indices& bodies, const Points& values) {
  const Lock lock(mutex_);
  check_batch("set_velocities", bodies, values.rows());
  for (Eigen::Index k = 0; k < bodies.size(); ++k)
    check_velocity(static_cast<BodyIndex>(bodies[k]), "velocity", values.row(k).transpose());
  for (Eigen::Index k = 0; k < bodies.size(); ++k) {
    state_.v[bodies[k]] = values.row(k).transpose();
    wake(static_cast<BodyIndex>(bodies[k]));
  }
}

void World::set_angular_velocities(const Indices& bodies, const Points& values) {
  const Lock lock(mutex_);
  check_batch("set_angular_velocities", bodies, values.rows());
  for (Eigen::Index k = 0; k < bodies.size(); ++k)
    check_velocity(static_cast<BodyIndex>(bodies[k]), "angular_velocity", values.row(k).transpose());
  for (Eigen::Index k = 0; k < bodies.size(); ++k) {
    state_.omega[bodies[k]] = values.row(k).transpose();
    wake(static_cast<BodyIndex>(bodies[k]));
  }
}

void World::set_external_wrench(BodyIndex i, const Vec3& force, const Vec3& torque) {
  const Lock lock(mutex_);
  check_index(i);
  const std::string who = label(i);
  checks::require_finite(who, "force", force);
  checks::require_finite(who, "torque", torque);
  state_.f_ext[i] = force;
  state_.tau_ext[i] = torque;
  wake(i);
}

Vec3 World::check_push(BodyIndex i, const char* what, const Vec3& push, const std::optional<Vec3>& point) const {
  check_index(i);
  const std::string who = label(i);
  checks::require_finite(who, what, push);
  if (point) checks::require_finite(who, "point", *point);
  if (model_.is_static[i] || model_.is_kinematic[i])
    throw std::invalid_argument(who + ": a " + (model_.is_static[i] ? "static" : "kinematic") + " body takes no " +
                                what + "s (it has infinite mass); set its velocity instead");
  return point ? *point : state_.p[i];
}

void World::apply_impulse(BodyIndex i, const Vec3& impulse, const std::optional<Vec3>& point) {
  const Lock lock(mutex_);
  const Vec3 x = check_push(i, "impulse", impulse, point);
  state_.impulse[i] += impulse;
  state_.angular_impulse[i] += (x - state_.p[i]).cross(impulse);
  wake(i);
}

void World::apply_force(BodyIndex i, const Vec3& force, const std::optional<Vec3>& point) {
  const Lock lock(mutex_);
  const Vec3 x = check_push(i, "force", force, point);
  state_.f_step[i] += force;
  state_.tau_step[i] += (x - state_.p[i]).cross(force);
  wake(i);
}

void World::set_kinematic(BodyIndex i, bool kinematic) {
  const Lock lock(mutex_);
  check_index(i);
  const std::string who = label(i);
  if (model_.is_static[i]) throw std::invalid_argument(who + ": a static body cannot become kinematic or dynamic");
  if (!kinematic && !std::isfinite(model_.mass[i]))
    throw std::invalid_argument(who + ": it was added without a mass, so it can only be kinematic");
  if (model_.is_kinematic[i] == kinematic) return;
  wake(i);  // a kinematic body never sleeps
  set_kinematic_flag(i, kinematic);
  if (kinematic) {
    state_.f_step[i].setZero();
    state_.tau_step[i].setZero();
    state_.impulse[i].setZero();
    state_.angular_impulse[i].setZero();
  }
}

void World::set_mass(BodyIndex i, double mass) {
  const Lock lock(mutex_);
  check_index(i);
  const std::string who = label(i);
  if (model_.is_static[i]) throw std::invalid_argument(who + ": a static body has no mass to set");
  if (!std::isfinite(model_.mass[i]))
    throw std::invalid_argument(who + ": it was added without a mass (a kinematic body): give it one when adding it");
  if (!std::isfinite(mass) || mass <= 0.0)
    throw std::invalid_argument(who + ": mass must be finite and > 0, got " + std::to_string(mass));
  const double scale = mass / model_.mass[i];
  model_.mass[i] = mass;
  model_.I_body[i] *= scale;
  set_kinematic_flag(i, model_.is_kinematic[i]);  // inv_mass and I_body_inv from the new values
  wake(i);
}

void World::set_gravity(const Vec3& gravity) {
  const Lock lock(mutex_);
  if (!gravity.allFinite()) throw std::invalid_argument("gravity must be finite");
  settings_.gravity = gravity;
  wake_all();
}

void World::set_enabled(BodyIndex i, bool enabled) {
  const Lock lock(mutex_);
  check_index(i);
  wake(i);  // a disabled body never sleeps, and its island loses it
  model_.enabled[i] = enabled;
}

void World::set_collision_filter(BodyIndex i, const CollisionFilter& filter) {
  const Lock lock(mutex_);
  check_index(i);
  wake(i);
  model_.filter[i] = filter;
}

void World::set_pair_collision(BodyIndex i, BodyIndex j, bool collide) {
  const Lock lock(mutex_);
  check_index(i);
  check_index(j);
  if (i == j) throw std::invalid_argument(label(i) + ": a body never collides with itself; give two different bodies");
  const std::pair<int, int> key(std::min(i, j), std::max(i, j));
  auto& pairs = model_.excluded_pairs;
  const auto it = std::lower_bound(pairs.begin(), pairs.end(), key);
  const bool listed = it != pairs.end() && *it == key;
  if (!collide && !listed) pairs.insert(it, key);
  if (collide && listed) pairs.erase(it);
  wake(i);
  wake(j);
}

void World::set_awake(BodyIndex i, bool awake) {
  const Lock lock(mutex_);
  check_index(i);
  const std::string who = label(i);
  if (model_.is_static[i]) throw std::invalid_argument(who + ": a static body never moves, so it is never awake or asleep");
  if (awake) return wake(i);
  if (state_.asleep(i)) return;
  if (!settings_.sleep.enabled)
    throw std::invalid_argument(who + ": sleeping is switched off in this world (sleeping=False)");
  if (model_.is_kinematic[i]) throw std::invalid_argument(who + ": a kinematic body never sleeps");
  if (!model_.enabled[i]) throw std::invalid_argument(who + ": a disabled body never sleeps");
  const BodyIndex blocker =
      islands_->sleep_island_of(model_, state_, i, *contacts_, solver_->cache, solver_->body_force, solver_->body_torque);
  if (blocker >= 0)
    throw std::invalid_argument(who + ": its island cannot sleep: " + label(blocker) + " has can_sleep false");
}

void World::set_sensor(BodyIndex i, bool sensor) {
  const Lock lock(mutex_);
  check_index(i);
  if (model_.is_sensor[i] == sensor) return;
  model_.is_sensor[i] = sensor;
  // what rests on it falls through a new sensor; what sleeps in an old one wakes to collide with it
  // (its overlaps end at the next step)
  wake(i);
  for (const Touch& t : sensing_)
    if (t.a == i) wake(t.b);
}

void World::set_bullet(BodyIndex i, bool bullet) {
  const Lock lock(mutex_);
  check_index(i);
  if (bullet && model_.is_static[i])
    throw std::invalid_argument("set_bullet: " + label(i) + " is static: it never moves, so it is never swept");
  model_.bullet[i] = bullet;
}

void World::set_can_sleep(BodyIndex i, bool can_sleep) {
  const Lock lock(mutex_);
  check_index(i);
  if (!can_sleep) wake(i);
  model_.can_sleep[i] = can_sleep;
}

BodyIndex World::find(const std::string& name) const {
  const Lock lock(mutex_);
  const auto it = by_name_.find(name);
  return it == by_name_.end() ? -1 : it->second;
}

Quat4 World::orientation(BodyIndex i) const {
  const Lock lock(mutex_);
  check_index(i);
  return state_.q[i];
}

}  // namespace signorini
