// Bodies: add (validate completely, then re-centre a mesh, hull or compound on its centre of mass
// and commit), and remove (one pass that renumbers everything that names bodies).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "collision/collision.hpp"
#include "geometry/polytope.hpp"
#include "math/rotation.hpp"
#include "signorini/mass_properties.hpp"
#include "signorini/world.hpp"
#include "solver/contact_solver.hpp"
#include "solver/joint_rows.hpp"
#include "world/checks.hpp"
#include "world/islands.hpp"

namespace signorini {

template <class T>
void World::push_keeping(std::vector<T>& v, const T& x) {
  if (v.size() == v.capacity() && v.capacity() > 0) {
    std::vector<T> bigger;
    bigger.reserve(2 * v.capacity());
    bigger.assign(v.begin(), v.end());
    retired_.push_back(std::make_shared<std::vector<T>>(std::move(v)));
    v = std::move(bigger);
  }
  v.push_back(x);
}

BodyIndex World::add_body(const BodyDesc& desc) {
  const Lock lock(mutex_);
  // validate everything first: the world changes only once nothing can fail
  const BodyIndex index = static_cast<BodyIndex>(model_.size());
  const std::string who = checks::body_label(index, desc.name, desc.shape);
  if (!desc.name.empty() && by_name_.count(desc.name))
    throw std::invalid_argument(who + ": the name '" + desc.name + "' is taken by body " +
                                std::to_string(by_name_.at(desc.name)));
  checks::require_finite(who, "position", desc.position);
  checks::require_finite(who, "velocity", desc.velocity);
  checks::require_finite(who, "angular_velocity", desc.angular_velocity);
  const Mat3 R = math::quat_to_matrix(checks::unit_quaternion(who, desc.orientation));
  checks::check_material(who, desc.material);
  const bool is_plane = std::holds_alternative<Plane>(desc.shape);

  Shape shape = desc.shape;
  Vec3 position = desc.position;
  double mass = std::numeric_limits<double>::infinity();
  double inv_mass = 0.0;
  Mat3 I_body = Mat3::Zero(), I_body_inv = Mat3::Zero();
  if (desc.is_static && desc.is_kinematic)
    throw std::invalid_argument(who + ": a body is static or kinematic, not both");
  if (desc.is_static) {
    if (desc.density || desc.mass || desc.inertia)
      throw std::invalid_argument(who + ": a static body takes neither mass nor density nor inertia");
    if (desc.velocity.squaredNorm() > 0.0 || desc.angular_velocity.squaredNorm() > 0.0)
      throw std::invalid_argument(who + ": a static body cannot have a velocity");
  } else if (desc.is_kinematic && !desc.density && !desc.mass) {
    if (desc.inertia) throw std::invalid_argument(who + ": inertia needs a mass");
    if (is_plane || static_only(desc.shape))
      throw std::invalid_argument(who + ": a " + shape_name(desc.shape) + " can only be static; use add_static");
  } else if (desc.inertia) {
    if (is_plane || static_only(desc.shape))
      throw std::invalid_argument(who + ": a " + shape_name(desc.shape) + " can only be static; use add_static");
    if (!desc.mass || desc.density) throw std::invalid_argument(who + ": an inertia goes with a mass, not a density");
    if (!(std::isfinite(*desc.mass) && *desc.mass > 0.0))
      throw std::invalid_argument(who + ": mass must be positive and finite, got " + std::to_string(*desc.mass));
    const Mat3& I = *desc.inertia;
    if (!I.allFinite()) throw std::invalid_argument(who + ": inertia must be finite");
    if (!((I - I.transpose()).cwiseAbs().maxCoeff() <= 1e-9 * I.cwiseAbs().maxCoeff()))
      throw std::invalid_argument(who + ": inertia must be symmetric");
    if (Eigen::LLT<Mat3>(I).info() != Eigen::Success || !(I.trace() > 0.0))
      throw std::invalid_argument(who + ": inertia must be positive definite");
    mass = *desc.mass;
    inv_mass = 1.0 / mass;
    I_body = I;
    I_body_inv = I.inverse();
  } else {
    if (is_plane) throw std::invalid_argument(who + ": a plane is unbounded and can only be static; use add_static");
    if (static_only(desc.shape))
      throw std::invalid_argument(who + ": a triangle mesh can only be static; use add_static");
    if (desc.density.has_value() == desc.mass.has_value())
      throw std::invalid_argument(who + ": give exactly one of density and mass");
    const double given = desc.density ? *desc.density : *desc.mass;
    const char* what = desc.density ? "density" : "mass";
    if (!(std::isfinite(given) && given > 0.0))
      throw std::invalid_argument(who + ": " + what + " must be positive and finite, got " + std::to_string(given));
    MassProperties props;
    try {
      props = mass_properties(desc.shape, 1.0);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(who + ": " + e.what());
    }
    // the shape at unit density: its volume and inertia must be normal doubles, and the inertia
    // (scaled to its largest entry, so that only its shape counts) must not be flat
    std::ostringstream size;
    size << "(bounding radius " << bounding_radius(desc.shape) << " m)";
    if (!(std::isfinite(props.volume) && props.inertia.allFinite()))
      throw std::invalid_argument(who + ": the shape is too large " + size.str() +
                                  ": its volume or inertia overflows double precision");
    const double J_max = props.inertia.cwiseAbs().maxCoeff();
    if (!(props.volume >= std::numeric_limits<double>::min() && J_max >= std::numeric_limits<double>::min()))
      throw std::invalid_argument(who + ": the shape is too small " + size.str() +
                                  ": its volume or inertia underflows double precision");
    const Mat3 J_unit = props.inertia / J_max;
    const Mat3 J_unit_inv = J_unit.inverse();
    if (!J_unit_inv.allFinite())
      throw std::invalid_argument(who + ": inertia tensor is singular (a flat or degenerate solid)");
    // then the given mass or density: mass, 1 / mass, inertia and its inverse must all be finite
    const double density = desc.density ? *desc.density : *desc.mass / props.volume;
    mass = density * props.volume;
    inv_mass = 1.0 / mass;
    // the plain products (the same numbers as mass_properties at this density); the unit-scaled
    // tensor above only decides flat against too small
    I_body = density * props.inertia;
    I_body_inv = I_body.inverse();
    // a very large or small tensor whose determinant leaves double precision: inverted scaled
    if (!I_body_inv.allFinite() || !I_body.allFinite()) {
      I_body = (density * J_max) * J_unit;
      I_body_inv = J_unit_inv / (density * J_max);
    }
    auto number = [](double x) {
      std::ostringstream s;
      s << x;
      return s.str();
    };
    if (!(std::isfinite(density) && std::isfinite(mass) && I_body.allFinite()))
      throw std::invalid_argument(who + ": " + what + " " + number(given) + " is too large for a shape " + size.str() +
                                  ": its density, mass or inertia overflows double precision");
    if (!(density > 0.0 && std::isfinite(inv_mass) && I_body_inv.allFinite() &&
          I_body.cwiseAbs().maxCoeff() >= std::numeric_limits<double>::min()))
      throw std::invalid_argument(who + ": " + what + " " + number(given) + " is too small for a shape " + size.str() +
                                  ": its inverse mass or inverse inertia overflows double precision");
    // a mesh, hull or compound body's frame is its centre of mass: the geometry is moved by -com
    // (vertices, convex pieces, polytope, part positions), axes unchanged
    if (auto* mesh = std::get_if<Mesh>(&shape)) {
      mesh->vertices.rowwise() -= props.com.transpose();
      for (auto& piece : mesh->pieces) piece = std::make_shared<const Polytope>(geometry::translated(*piece, -props.com));
    } else if (auto* hull = std::get_if<ConvexHull>(&shape)) {
      hull->vertices.rowwise() -= props.com.transpose();
      // the same hull moved by the same bits as the last one: its polytope is shared, read only
      if (last_hull_.source != hull->polytope || std::memcmp(last_hull_.com.data(), props.com.data(), sizeof(Vec3)) != 0)
        last_hull_ = {hull->polytope, std::make_shared<const Polytope>(geometry::translated(*hull->polytope, -props.com)),
                      props.com};
      hull->polytope = last_hull_.moved;
    } else if (auto* compound = std::get_if<Compound>(&shape)) {
      for (Compound::Part& part : compound->parts) part.position -= props.com;
    }
  }
  // a convex mesh collides as one polytope: built once here, not in every step
  if (auto* mesh = std::get_if<Mesh>(&shape);
      mesh && mesh->pieces.empty() && mesh->is_convex() && mesh->closedness_problem().empty()) {
    try {
      mesh->pieces.push_back(std::make_shared<const Polytope>(polytope_from_triangles(mesh->vertices, mesh->faces)));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(who + ": " + e.what());
    }
  }
  // every body it may touch (a static body: the non-static ones, two static bodies never collide);
  // only a pair with a bare non-convex mesh can fail, so without one on either side nothing is checked
  const bool bare = collision::is_bare_nonconvex_mesh(shape);
  const auto check_pair = [&](BodyIndex j) {
    const std::string problem = collision::unsupported_pair(model_.shape[j], shape);
    if (!problem.empty()) throw std::invalid_argument(who + ": " + problem + " (with body " + std::to_string(j) + ")");
  };
  if (bare || bare_meshes_ > 0) {
    if (desc.is_static) {
      for (const BodyIndex j : moving_) check_pair(j);
    } else {
      for (BodyIndex j = 0; j < index; ++j) check_pair(j);
    }
  }

  // commit
  broad_phase_->add_body(index, shape, desc.is_static, position, R);
  model_.rho.push_back(bounding_radius(shape));
  model_.inner.push_back(inner_radius(shape));
  model_.shape.push_back(std::move(shape));
  bare_meshes_ += bare ? 1 : 0;
  model_.is_static.push_back(desc.is_static);
  model_.mass.push_back(mass);
  model_.inv_mass.push_back(inv_mass);
  model_.I_body.push_back(I_body);
  model_.I_body_inv.push_back(I_body_inv);
  model_.material.push_back(desc.material);
  model_.is_kinematic.push_back(false);
  model_.enabled.push_back(desc.enabled);
  model_.can_sleep.push_back(desc.can_sleep);
  model_.is_sensor.push_back(desc.sensor);
  model_.bullet.push_back(desc.bullet);
  model_.filter.push_back(desc.filter);
  model_.name.push_back(desc.name);
  if (desc.is_kinematic) set_kinematic_flag(index, true);
  if (!desc.name.empty()) by_name_[desc.name] = index;
  solver_->body_force.push_back(Vec3::Zero());
  solver_->body_torque.push_back(Vec3::Zero());
  // every state array grows by a zero entry, then the body's pose and velocity are set
  state_.for_each_array([this](auto& x) {
    using T = typename std::decay_t<decltype(x)>::value_type;
    push_keeping(x, T(T::Zero()));
  });
  Islands::add_body(model_, state_, index, [this](auto& v, const auto& x) { push_keeping(v, x); });
  islands_->add_body();
  state_.p[index] = position;
  state_.R[index] = R;
  state_.q[index] = math::matrix_to_quat(R);
  state_.v[index] = desc.velocity;
  state_.omega[index] = desc.angular_velocity;
  memory_->add_body(position);
  if (!desc.is_static) moving_.push_back(index);
  bodies_changed(false);
  return index;
}

void World::set_kinematic_flag(BodyIndex i, bool kinematic) {
  model_.is_kinematic[i] = kinematic;
  model_.inv_mass[i] = kinematic ? 0.0 : 1.0 / model_.mass[i];
  model_.I_body_inv[i] = kinematic ? Mat3(Mat3::Zero()) : Mat3(model_.I_body[i].inverse());
}

void World::remove_body(BodyIndex i) { remove_bodies({i}); }

void World::remove_bodies(const std::vector<BodyIndex>& indices) {
  const Lock lock(mutex_);
  const auto n = static_cast<BodyIndex>(model_.size());
  for (const BodyIndex i : indices) check_index(i);
  std::vector<BodyIndex> to(static_cast<std::size_t>(n), 0);
  for (const BodyIndex i : indices) {
    if (to[i] < 0) throw std::invalid_argument("remove_bodies: " + label(i) + " is given twice");
    to[i] = -1;
  }
  // new index of each body, -1 for the removed ones: later bodies move down past every removed one
  BodyIndex kept = 0;
  for (BodyIndex j = 0; j < n; ++j)
    if (to[j] == 0) to[j] = kept++;
  if (kept == n) return;
  const auto gone = [&to](BodyIndex k) { return to[k] < 0; };
  // the broad phase of the bodies that stay, built first: nothing has changed if it throws
  auto broad_phase = std::make_unique<collision::BroadPhase>();
  for (BodyIndex j = 0; j < n; ++j)
    if (!gone(j)) broad_phase->add_body(to[j], model_.shape[j], model_.is_static[j], state_.p[j], state_.R[j]);
  // sleeping islands that lose a body, or a body they rest on, wake (before the renumbering)
  islands_->mark_removed(state_, gone);
  for (const Joint& x : joints_->joints) {  // a sleeping island held by a joint to a removed body
    if (gone(x.a)) islands_->mark(state_, x.b);
    if (gone(x.b)) islands_->mark(state_, x.a);
  }
  islands_->wake_marked(model_, state_, solver_->cache, true, &moving_);
  // model, state and per-body solver output compacted in one pass each (storage stays in place)
  const auto compact = [&](auto& v) {
    for (BodyIndex j = 0; j < n; ++j)
      if (!gone(j) && to[j] != j) v[to[j]] = std::move(v[j]);
    v.erase(v.begin() + kept, v.end());
  };
  model_.for_each_array(compact);
  state_.for_each_array(compact);
  state_.for_each_sleep_array(compact);
  islands_->renumber(state_, to);
  compact(solver_->body_force);
  compact(solver_->body_torque);
  // the meshes' memory of crossings: the removed bodies' dropped, crossings of removed meshes
  // forgotten, the rest renumbered
  memory_->remove(to);
  broad_phase_ = std::move(broad_phase);
  // names, excluded pairs, the warm-start cache and the last contacts: renumbered, the removed
  // bodies' dropped
  by_name_.clear();
  for (BodyIndex j = 0; j < kept; ++j)
    if (!model_.name[j].empty()) by_name_[model_.name[j]] = j;
  bare_meshes_ = static_cast<std::size_t>(
      std::count_if(model_.shape.begin(), model_.shape.end(), [](const Shape& x) { return collision::is_bare_nonconvex_mesh(x); }));
  auto& pairs = model_.excluded_pairs;
  pairs.erase(std::remove_if(pairs.begin(), pairs.end(), [&](const auto& p) { return gone(p.first) || gone(p.second); }),
              pairs.end());
  for (auto& p : pairs) p = {to[p.first], to[p.second]};
  const auto renumber = [&](auto& list) {
    list.erase(std::remove_if(list.begin(), list.end(), [&](const auto& c) { return gone(c.body_a) || gone(c.body_b); }),
               list.end());
    for (auto& c : list) c.body_a = to[c.body_a], c.body_b = to[c.body_b];
  };
  renumber(solver_->cache);
  // the sensors' overlaps: those of a removed body dropped, the rest renumbered
  sensing_.erase(std::remove_if(sensing_.begin(), sensing_.end(), [&](const Touch& t) { return gone(t.a) || gone(t.b); }),
                 sensing_.end());
  for (Touch& t : sensing_) t.a = to[t.a], t.b = to[t.b];
  // joints: those of a removed body dropped, the rest renumbered
  auto& joints = joints_->joints;
  joints.erase(std::remove_if(joints.begin(), joints.end(), [&](const Joint& x) { return gone(x.a) || gone(x.b); }),
               joints.end());
  for (Joint& x : joints) x.a = to[x.a], x.b = to[x.b];
  joints_changed();
  if (contacts_.use_count() > 1) contacts_ = std::make_shared<std::vector<Contact>>(*contacts_);
  renumber(*contacts_);
  bodies_changed(true);
}

}  // namespace signorini
