#include "signorini/world.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "collision/collision.hpp"
#include "dynamics/rigid_body.hpp"
#include "geometry/polytope.hpp"
#include "math/rotation.hpp"
#include "signorini/mass_properties.hpp"
#include "solver/contact_solver.hpp"

namespace signorini {
namespace {

std::string body_label(BodyIndex i, const Shape& shape) {
  return "body " + std::to_string(i) + " (" + shape_name(shape) + ")";
}

std::string fmt(const Eigen::VectorXd& x) {
  std::ostringstream s;
  s << "(";
  for (Eigen::Index k = 0; k < x.size(); ++k) s << (k ? ", " : "") << x[k];
  s << ")";
  return s.str();
}

void require_finite(const std::string& who, const char* what, const Eigen::VectorXd& x) {
  if (!x.allFinite())
    throw std::invalid_argument(who + ": " + what + " must be finite, got " + fmt(x));
}

/// Unit quaternion from a user's one: finite, non-zero; a non-unit one is normalised.
Quat4 unit_quaternion(const std::string& who, const Quat4& q) {
  require_finite(who, "orientation", q);
  const double norm = q.stableNorm();  // scaled: (1e300, 1e300, 0, 0) is a rotation, not an overflow
  if (!(norm > 1e-12))
    throw std::invalid_argument(who + ": orientation quaternion " + fmt(q) + " is zero; use (1, 0, 0, 0) for no rotation");
  return q / norm;
}

void check_material(const std::string& who, const Material& m) {
  if (!(std::isfinite(m.friction) && m.friction >= 0.0))
    throw std::invalid_argument(who + ": friction must be finite and >= 0, got " + std::to_string(m.friction));
  if (!(std::isfinite(m.restitution) && m.restitution >= 0.0 && m.restitution <= 1.0))
    throw std::invalid_argument(who + ": restitution must be in [0, 1], got " + std::to_string(m.restitution));
}

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("World: " + what);
}

}  // namespace

World::World(const WorldSettings& settings)
    : broad_phase_(std::make_unique<collision::BroadPhase>()),
      scratch_(std::make_unique<collision::Scratch>()),
      solver_(std::make_unique<solver::SolverData>()) {
  set_settings(settings);
}

World::~World() = default;

void World::set_settings(const WorldSettings& s) {
  require_finite("World", "gravity", s.gravity);
  require(std::isfinite(s.contact_margin) && s.contact_margin >= 0.0,
          "contact_margin must be finite and >= 0, got " + std::to_string(s.contact_margin));
  const SolverSettings& q = s.solver;
  require(std::isfinite(q.erp) && q.erp >= 0.0 && q.erp <= 1.0, "erp must be in [0, 1], got " + std::to_string(q.erp));
  require(std::isfinite(q.tolerance) && q.tolerance >= 0.0,
          "tolerance must be finite and >= 0, got " + std::to_string(q.tolerance));
  require(q.max_iterations >= 1, "max_iterations must be >= 1, got " + std::to_string(q.max_iterations));
  require(std::isfinite(q.slop) && q.slop >= 0.0, "slop must be finite and >= 0, got " + std::to_string(q.slop));
  require(std::isfinite(q.max_push_velocity) && q.max_push_velocity > 0.0,
          "max_push_velocity must be finite and > 0, got " + std::to_string(q.max_push_velocity));
  require(std::isfinite(q.restitution_threshold) && q.restitution_threshold >= 0.0,
          "restitution_threshold must be finite and >= 0, got " + std::to_string(q.restitution_threshold));
  require(q.substeps >= 0, "substeps must be >= 1, or 0 for automatic, got " + std::to_string(q.substeps));
  require(std::isfinite(q.warn_velocity) && q.warn_velocity >= 0.0,
          "warn_velocity must be finite and >= 0, got " + std::to_string(q.warn_velocity));
  settings_ = s;
}

BodyIndex World::add_body(const BodyDesc& desc) {
  // validate everything first: the world changes only once nothing can fail
  const BodyIndex index = static_cast<BodyIndex>(model_.size());
  const std::string who = body_label(index, desc.shape);
  require_finite(who, "position", desc.position);
  require_finite(who, "velocity", desc.velocity);
  require_finite(who, "angular_velocity", desc.angular_velocity);
  const Mat3 R = math::quat_to_matrix(unit_quaternion(who, desc.orientation));
  check_material(who, desc.material);
  const bool is_plane = std::holds_alternative<Plane>(desc.shape);

  Shape shape = desc.shape;
  Vec3 position = desc.position;
  double mass = std::numeric_limits<double>::infinity();
  double inv_mass = 0.0;
  Mat3 I_body = Mat3::Zero(), I_body_inv = Mat3::Zero();
  if (desc.is_static) {
    if (desc.density || desc.mass)
      throw std::invalid_argument(who + ": a static body takes neither mass nor density");
    if (desc.velocity.squaredNorm() > 0.0 || desc.angular_velocity.squaredNorm() > 0.0)
      throw std::invalid_argument(who + ": a static body cannot have a velocity");
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
    I_body = (density * J_max) * J_unit;
    I_body_inv = J_unit_inv / (density * J_max);
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
      hull->polytope = std::make_shared<const Polytope>(geometry::translated(*hull->polytope, -props.com));
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
  for (BodyIndex j = 0; j < index; ++j) {
    if (desc.is_static && model_.is_static[j]) continue;
    const std::string problem = collision::unsupported_pair(model_.shape[j], shape);
    if (!problem.empty()) throw std::invalid_argument(who + ": " + problem + " (with body " + std::to_string(j) + ")");
  }

  // commit
  broad_phase_->add_body(index, shape, desc.is_static, position, R);
  model_.rho.push_back(bounding_radius(shape));
  model_.shape.push_back(std::move(shape));
  model_.is_static.push_back(desc.is_static);
  model_.mass.push_back(mass);
  model_.inv_mass.push_back(inv_mass);
  model_.I_body.push_back(I_body);
  model_.I_body_inv.push_back(I_body_inv);
  model_.material.push_back(desc.material);
  solver_->body_force.push_back(Vec3::Zero());
  solver_->body_torque.push_back(Vec3::Zero());
  state_.p.push_back(position);
  state_.R.push_back(R);
  state_.v.push_back(desc.velocity);
  state_.omega.push_back(desc.angular_velocity);
  state_.f_ext.push_back(Vec3::Zero());
  state_.tau_ext.push_back(Vec3::Zero());
  previous_p_.push_back(position);
  crossing_.emplace_back();
  return index;
}

std::vector<Contact> World::detect_contacts(double dt) const {
  std::vector<Contact> out;
  detect_contacts(dt, out);
  return out;
}

void World::detect_contacts(double dt, std::vector<Contact>& out) const {
  if (!(std::isfinite(dt) && dt > 0.0))
    throw std::invalid_argument("detect_contacts: dt must be positive and finite, got " + std::to_string(dt));
  collision::detect_contacts(model_, state_, dt, settings_.gravity, settings_.contact_margin, *broad_phase_,
                             *scratch_, out, &previous_p_, &crossing_);
}

void World::step(double dt, int steps) {
  if (!(std::isfinite(dt) && dt > 0.0))
    throw std::invalid_argument("step: dt must be positive and finite, got " + std::to_string(dt));
  if (steps < 0) throw std::invalid_argument("step: steps must be >= 0, got " + std::to_string(steps));
  report_ = StepReport();
  for (int s = 0; s < steps; ++s) step_once(dt);
}

int SolverSettings::substep_count(double dt) const {
  if (substeps >= 1) return substeps;
  // 1e-9: dt = k / 960 gives k substeps despite its rounding; capped so that a huge dt stays an int
  return static_cast<int>(std::clamp(std::ceil(dt / auto_substep - 1e-9), 1.0, 1e6));
}

namespace {

/// Kinetic energy of body i in state s, 1/2 (m v.v + omega . I_w omega) (J); 0 for a static body.
double body_kinetic_energy(const Model& model, const State& s, std::size_t i) {
  if (model.is_static[i]) return 0.0;
  const Vec3& w = s.omega[i];
  return 0.5 * model.mass[i] * s.v[i].squaredNorm() + 0.5 * w.dot(s.R[i] * (model.I_body[i] * (s.R[i].transpose() * w)));
}

}  // namespace

void World::check_energy(double dt) const {
  // the energy balance of the step: kinetic energy T_1 at the end against T_0 + W at the start,
  // W the work of gravity and the external wrenches over the step's actual motion, body by body
  // W_i = (m g + f) . (p_1 - p_0) + tau . (omega_0 + omega_1) dt / 2, counted only where positive
  // (the position pass lifts bodies without giving them kinetic energy: a heavy body lifted out of
  // an overlap must not hide another's fall). Contacts only take energy away or pass it between
  // bodies, so T_1 stays below T_0 + W up to the integrator's rounding; a step that exceeds it by
  // the factor and the floor is an explosion.
  double T0 = 0.0, T1 = 0.0, W = 0.0;
  for (std::size_t i = 0; i < model_.size(); ++i) {
    if (model_.is_static[i]) continue;
    T0 += body_kinetic_energy(model_, before_, i);
    T1 += body_kinetic_energy(model_, state_, i);
    W += std::max(0.0, (model_.mass[i] * settings_.gravity + before_.f_ext[i]).dot(state_.p[i] - before_.p[i]) +
                           before_.tau_ext[i].dot(before_.omega[i] + state_.omega[i]) * 0.5 * dt);
  }
  const double budget = T0 + W;
  if (!(T1 > kExplosionFactor * budget && T1 - budget > kExplosionFloor)) return;
  // name the bodies that gained the most, largest first (at most 3)
  std::array<std::pair<double, std::size_t>, 3> worst{};
  for (std::size_t i = 0; i < model_.size(); ++i) {
    if (model_.is_static[i]) continue;
    const double gained = body_kinetic_energy(model_, state_, i) - body_kinetic_energy(model_, before_, i);
    for (std::size_t k = 0; k < worst.size(); ++k)
      if (gained > worst[k].first) {
        for (std::size_t m = worst.size() - 1; m > k; --m) worst[m] = worst[m - 1];
        worst[k] = {gained, i};
        break;
      }
  }
  std::ostringstream s;
  s.precision(3);
  bool first = true;
  for (const auto& [gained, i] : worst) {
    if (!(gained > 0.0)) continue;
    s << (first ? "" : ", ") << body_label(static_cast<BodyIndex>(i), model_.shape[i]) << " +" << gained << " J";
    first = false;
  }
  std::ostringstream total;
  total.precision(3);
  total << "kinetic energy rose from " << T0 << " J to " << T1 << " J in one step at t = " << before_.time
        << " s (gravity and external forces supplied " << W << " J)";
  throw std::runtime_error("energy explosion: " + total.str() + "; gained most: " + s.str() +
                           "; the step was undone (check dt, masses, speeds and overlaps)");
}

void World::undo_step() {
  state_ = before_;
  solver_->cache.swap(cache_before_);
  solver_->body_force.swap(force_before_);
  solver_->body_torque.swap(torque_before_);
}

void World::step_once(double dt) {
  before_ = state_;
  cache_before_ = solver_->cache;
  force_before_ = solver_->body_force;
  torque_before_ = solver_->body_torque;
  // 1. contacts from the state at the start of the step, reaching as far as the whole step moves
  detect_contacts(dt, contacts_base_);
  const int n = settings_.solver.substep_count(dt);
  const double h = dt / n;
  SolverStats stats;
  for (int k = 0; k < n; ++k) {
    // a substep solves the step's contacts carried along by the motion since detection
    if (k == 0)
      contacts_next_ = contacts_base_;
    else
      collision::carry_contacts(contacts_base_, before_, state_, contacts_next_, anchor_a_, anchor_b_);
    // 2. unconstrained velocity q_dot*
    dynamics::unconstrained_velocity(model_, state_, settings_.gravity, h, settings_.solver.gyroscopic, v_, omega_);
    // 3. contact solve: q_dot* -> q_dot^{t+1}, and the velocities that move the poses
    stats = solver::solve_contacts(model_, state_, h, settings_.solver, contacts_next_, v_, omega_, *solver_,
                                   k == 0 ? nullptr : &anchor_a_, k == 0 ? nullptr : &anchor_b_);
    v_move_.resize(v_.size());
    omega_move_.resize(omega_.size());
    for (std::size_t i = 0; i < v_.size(); ++i) {
      v_move_[i] = solver_->v_pos[i] + solver_->v_p[i];
      omega_move_[i] = solver_->omega_pos[i] + solver_->omega_p[i];
    }
    // 4. integrate the poses; keep the new velocities
    dynamics::integrate(model_, state_, v_move_, omega_move_, h);
    state_.v.swap(v_);
    state_.omega.swap(omega_);
    state_.time += h;
    // a step that produced a non-finite number is undone and reported, never kept
    for (std::size_t i = 0; i < model_.size(); ++i) {
      if (state_.p[i].allFinite() && state_.v[i].allFinite() && state_.omega[i].allFinite() &&
          state_.R[i].allFinite())
        continue;
      undo_step();
      throw std::runtime_error(body_label(static_cast<BodyIndex>(i), model_.shape[i]) +
                               ": state became non-finite at t = " + std::to_string(before_.time) +
                               "; the step was undone (check forces, masses and dt)");
    }
    // the next substep (and step) warm-starts from this one
    solver_->cache.swap(solver_->cache_next);
    ++report_.steps;
    if (!stats.converged && stats.max_penetration_velocity > settings_.solver.warn_velocity) {
      ++report_.flagged;
      if (stats.max_penetration_velocity > report_.worst_penetration_velocity) {
        report_.worst_penetration_velocity = stats.max_penetration_velocity;
        report_.worst_time = state_.time - h;
      }
    }
  }
  // a step whose kinetic energy grew by orders of magnitude is undone and reported, like a
  // non-finite one
  try {
    check_energy(dt);
  } catch (const std::runtime_error&) {
    undo_step();
    throw;
  }
  // keep the step: the last substep's contacts and stats, and what the meshes remember
  previous_p_ = before_.p;
  crossing_.swap(scratch_->crossing_next);
  contacts_.swap(contacts_next_);
  stats_ = stats;
}

const std::vector<Vec3>& World::contact_forces() const { return solver_->body_force; }
const std::vector<Vec3>& World::contact_torques() const { return solver_->body_torque; }
const std::vector<CachedContact>& World::warm_start_cache() const { return solver_->cache; }

void World::set_material(BodyIndex i, const Material& material) {
  check_index(i);
  check_material(body_label(i, model_.shape[i]), material);
  model_.material[i] = material;
}

void World::check_index(BodyIndex i) const {
  if (i < 0 || static_cast<std::size_t>(i) >= model_.size())
    throw std::out_of_range("body index " + std::to_string(i) + " is out of range: the world has " +
                            std::to_string(model_.size()) + " bodies");
}

void World::set_position(BodyIndex i, const Vec3& p) {
  check_index(i);
  require_finite(body_label(i, model_.shape[i]), "position", p);
  state_.p[i] = p;
  previous_p_[i] = p;  // moved, not travelled: no crossing
  crossing_[i] = collision::Crossing();
  if (model_.is_static[i]) broad_phase_->move_static(i, state_.p[i], state_.R[i]);
}

void World::set_orientation(BodyIndex i, const Quat4& q) {
  check_index(i);
  state_.R[i] = math::quat_to_matrix(unit_quaternion(body_label(i, model_.shape[i]), q));
  if (model_.is_static[i]) broad_phase_->move_static(i, state_.p[i], state_.R[i]);
}

void World::check_velocity(BodyIndex i, const char* what, const Vec3& x) const {
  check_index(i);
  const std::string who = body_label(i, model_.shape[i]);
  require_finite(who, what, x);
  if (model_.is_static[i] && x.squaredNorm() > 0.0)
    throw std::invalid_argument(who + ": a static body cannot have a velocity");
}

void World::set_velocity(BodyIndex i, const Vec3& v) {
  check_velocity(i, "velocity", v);
  state_.v[i] = v;
}

void World::set_angular_velocity(BodyIndex i, const Vec3& omega) {
  check_velocity(i, "angular_velocity", omega);
  state_.omega[i] = omega;
}

void World::set_external_wrench(BodyIndex i, const Vec3& force, const Vec3& torque) {
  check_index(i);
  const std::string who = body_label(i, model_.shape[i]);
  require_finite(who, "force", force);
  require_finite(who, "torque", torque);
  state_.f_ext[i] = force;
  state_.tau_ext[i] = torque;
}

Quat4 World::orientation(BodyIndex i) const {
  check_index(i);
  return math::matrix_to_quat(state_.R[i]);
}

double World::kinetic_energy() const {
  double T = 0.0;
  for (std::size_t i = 0; i < model_.size(); ++i) {
    if (model_.is_static[i]) continue;
    const Mat3& R = state_.R[i];
    const Vec3& w = state_.omega[i];
    T += 0.5 * model_.mass[i] * state_.v[i].squaredNorm() + 0.5 * w.dot(R * (model_.I_body[i] * (R.transpose() * w)));
  }
  return T;
}

double World::potential_energy() const {
  double V = 0.0;
  for (std::size_t i = 0; i < model_.size(); ++i)
    if (!model_.is_static[i]) V -= model_.mass[i] * settings_.gravity.dot(state_.p[i]);
  return V;
}

}  // namespace signorini
