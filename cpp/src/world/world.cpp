#include "signorini/world.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "collision/collision.hpp"
#include "dynamics/rigid_body.hpp"
#include "geometry/polytope.hpp"
#include "math/rotation.hpp"
#include "signorini/mass_properties.hpp"
#include "solver/contact_solver.hpp"

namespace signorini {
namespace {

std::string body_label(BodyIndex i, const std::string& name, const Shape& shape) {
  return "body " + std::to_string(i) + (name.empty() ? "" : " '" + name + "'") + " (" + shape_name(shape) + ")";
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

/// Unit quaternion from a user's one (math::unit_quaternion), errors prefixed with who.
Quat4 unit_quaternion(const std::string& who, const Quat4& q) {
  try {
    return math::unit_quaternion(q);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(who + ": " + e.what());
  }
}

void check_material(const std::string& who, const Material& m) {
  if (!(std::isfinite(m.friction) && m.friction >= 0.0))
    throw std::invalid_argument(who + ": friction must be finite and >= 0, got " + std::to_string(m.friction));
  if (!(std::isfinite(m.restitution) && m.restitution >= 0.0 && m.restitution <= 1.0))
    throw std::invalid_argument(who + ": restitution must be in [0, 1], got " + std::to_string(m.restitution));
  if (!(std::isfinite(m.spinning_friction) && m.spinning_friction >= 0.0))
    throw std::invalid_argument(who + ": spinning_friction must be finite and >= 0 (m), got " +
                                std::to_string(m.spinning_friction));
}

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("World: " + what);
}

/// Copies src into dst element by element: dst keeps its storage (NumPy views of it stay live).
template <class T>
void copy_into(std::vector<T>& dst, const std::vector<T>& src) {
  if (dst.size() != src.size()) throw std::logic_error("copy_into: sizes differ");
  std::copy(src.begin(), src.end(), dst.begin());
}

/// The whole state copied in place (same body count).
void copy_state(State& dst, const State& src) {
  copy_into(dst.p, src.p);
  copy_into(dst.R, src.R);
  copy_into(dst.q, src.q);
  copy_into(dst.v, src.v);
  copy_into(dst.omega, src.omega);
  copy_into(dst.f_ext, src.f_ext);
  copy_into(dst.tau_ext, src.tau_ext);
  copy_into(dst.f_step, src.f_step);
  copy_into(dst.tau_step, src.tau_step);
  copy_into(dst.impulse, src.impulse);
  copy_into(dst.angular_impulse, src.angular_impulse);
  dst.time = src.time;
}

// ---- saved states: a flat little-endian byte string -----------------------------------------
// format 3 adds the triangle meshes' memory (each body's centre at the start of the last step and
// the triangle it is being pushed back through), without which a restored step near a crossing
// differs from the original; format 2 adds the spin torque of each contact and cache entry.
// Formats 1 (before spinning friction: those torques 0, as they then were) and 2 (no crossing
// memory: it starts afresh) are still read
constexpr char kStateMagic[8] = {'S', 'G', 'S', 'T', 'A', 'T', 'E', '3'};
constexpr std::size_t kStateVersionAt = 7;  ///< the format digit's position in the magic

struct Writer {
  std::string out;
  template <class T>
  void pod(const T& x) {
    static_assert(std::is_trivially_copyable_v<T>);
    out.append(reinterpret_cast<const char*>(&x), sizeof(T));
  }
  template <class M>
  void mat(const M& x) {
    for (Eigen::Index k = 0; k < x.size(); ++k) pod(x.data()[k]);
  }
  template <class M>
  void mats(const std::vector<M>& xs) {
    for (const M& x : xs) mat(x);
  }
};

struct Reader {
  const std::string& in;
  std::size_t at = 0;
  template <class T>
  T pod() {
    static_assert(std::is_trivially_copyable_v<T>);
    if (in.size() - at < sizeof(T)) throw std::invalid_argument("restore_state: the saved state is truncated");
    T x;
    std::memcpy(&x, in.data() + at, sizeof(T));
    at += sizeof(T);
    return x;
  }
  template <class M>
  void mat(M& x) {
    for (Eigen::Index k = 0; k < x.size(); ++k) x.data()[k] = pod<double>();
  }
  template <class M>
  void mats(std::vector<M>& xs, std::size_t n) {
    xs.resize(n);
    for (M& x : xs) mat(x);
  }
  /// A count of items of at least `bytes` each that the rest of the input can hold.
  std::size_t count(std::size_t bytes) {
    const auto n = pod<std::uint64_t>();
    if (n > (in.size() - at) / bytes) throw std::invalid_argument("restore_state: the saved state is damaged");
    return static_cast<std::size_t>(n);
  }
};

void write_contact(Writer& w, const Contact& c) {
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
Contact read_contact(Reader& r, char version) {
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

}  // namespace

World::World(const WorldSettings& settings)
    : contacts_(std::make_shared<std::vector<Contact>>()),
      broad_phase_(std::make_unique<collision::BroadPhase>()),
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
  const std::string who = body_label(index, desc.name, desc.shape);
  if (!desc.name.empty() && by_name_.count(desc.name))
    throw std::invalid_argument(who + ": the name '" + desc.name + "' is taken by body " +
                                std::to_string(by_name_.at(desc.name)));
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
  model_.is_kinematic.push_back(false);
  model_.enabled.push_back(desc.enabled);
  model_.filter.push_back(desc.filter);
  model_.name.push_back(desc.name);
  if (desc.is_kinematic) set_kinematic_flag(index, true);
  if (!desc.name.empty()) by_name_[desc.name] = index;
  solver_->body_force.push_back(Vec3::Zero());
  solver_->body_torque.push_back(Vec3::Zero());
  push_keeping(state_.p, position);
  push_keeping(state_.R, R);
  push_keeping(state_.q, math::matrix_to_quat(R));
  push_keeping(state_.v, desc.velocity);
  push_keeping(state_.omega, desc.angular_velocity);
  for (std::vector<Vec3>* x : {&state_.f_ext, &state_.tau_ext, &state_.f_step, &state_.tau_step, &state_.impulse,
                               &state_.angular_impulse})
    push_keeping(*x, Vec3(Vec3::Zero()));
  previous_p_.push_back(position);
  crossing_.emplace_back();
  return index;
}

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

void World::set_kinematic_flag(BodyIndex i, bool kinematic) {
  model_.is_kinematic[i] = kinematic;
  model_.inv_mass[i] = kinematic ? 0.0 : 1.0 / model_.mass[i];
  model_.I_body_inv[i] = kinematic ? Mat3(Mat3::Zero()) : Mat3(model_.I_body[i].inverse());
}

void World::remove_body(BodyIndex i) { remove_bodies({i}); }

void World::remove_bodies(const std::vector<BodyIndex>& indices) {
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
  // model, state and per-body solver output compacted in one pass each (storage stays in place)
  const auto compact = [&](auto& v) {
    for (BodyIndex j = 0; j < n; ++j)
      if (!gone(j) && to[j] != j) v[to[j]] = std::move(v[j]);
    v.erase(v.begin() + kept, v.end());
  };
  compact(model_.shape);
  compact(model_.is_static);
  compact(model_.mass);
  compact(model_.inv_mass);
  compact(model_.I_body);
  compact(model_.I_body_inv);
  compact(model_.rho);
  compact(model_.material);
  compact(model_.is_kinematic);
  compact(model_.enabled);
  compact(model_.filter);
  compact(model_.name);
  for (std::vector<Vec3>* x : {&state_.p, &state_.v, &state_.omega, &state_.f_ext, &state_.tau_ext, &state_.f_step,
                               &state_.tau_step, &state_.impulse, &state_.angular_impulse, &solver_->body_force,
                               &solver_->body_torque})
    compact(*x);
  compact(state_.R);
  compact(state_.q);
  // the meshes' memory of crossings: the removed bodies' dropped, crossings of removed meshes
  // forgotten, the rest renumbered
  compact(previous_p_);
  compact(crossing_);
  for (collision::Crossing& c : crossing_) {
    if (c.mesh >= 0 && gone(c.mesh)) c = collision::Crossing();
    else if (c.mesh >= 0) c.mesh = to[c.mesh];
  }
  broad_phase_ = std::move(broad_phase);
  // names, excluded pairs, the warm-start cache and the last contacts: renumbered, the removed
  // bodies' dropped
  by_name_.clear();
  for (BodyIndex j = 0; j < kept; ++j)
    if (!model_.name[j].empty()) by_name_[model_.name[j]] = j;
  auto& pairs = model_.excluded_pairs;
  pairs.erase(std::remove_if(pairs.begin(), pairs.end(), [&](const auto& p) { return gone(p.first) || gone(p.second); }),
              pairs.end());
  for (auto& p : pairs) p = {to[p.first], to[p.second]};
  auto& cache = solver_->cache;
  cache.erase(std::remove_if(cache.begin(), cache.end(),
                             [&](const CachedContact& c) { return gone(c.body_a) || gone(c.body_b); }),
              cache.end());
  for (CachedContact& c : cache) {
    c.body_a = to[c.body_a];
    c.body_b = to[c.body_b];
  }
  if (contacts_.use_count() > 1) contacts_ = std::make_shared<std::vector<Contact>>(*contacts_);
  auto& contacts = *contacts_;
  contacts.erase(std::remove_if(contacts.begin(), contacts.end(),
                                [&](const Contact& c) { return gone(c.body_a) || gone(c.body_b); }),
                 contacts.end());
  for (Contact& c : contacts) {
    c.body_a = to[c.body_a];
    c.body_b = to[c.body_b];
  }
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

std::vector<Contact>& World::own_contacts() {
  if (contacts_.use_count() > 1) contacts_ = std::make_shared<std::vector<Contact>>();
  return *contacts_;
}

namespace {

/// Kinetic energy of body i in state s, 1/2 (m v.v + omega . I_w omega) (J); 0 for a static body.
double body_kinetic_energy(const Model& model, const State& s, std::size_t i) {
  if (model.is_static[i] || model.is_kinematic[i] || !model.enabled[i]) return 0.0;
  const Vec3& w = s.omega[i];
  return 0.5 * model.mass[i] * s.v[i].squaredNorm() + 0.5 * w.dot(s.R[i] * (model.I_body[i] * (s.R[i].transpose() * w)));
}

}  // namespace

void World::check_energy(double dt, double T0) const {
  // the energy balance of the step: kinetic energy T_1 at the end against T_0 + W at the start,
  // W the work of gravity and the external wrenches over the step's actual motion, body by body
  // W_i = (m g + f) . (p_1 - p_0) + tau . (omega_0 + omega_1) dt / 2, counted only where positive
  // (the position pass lifts bodies without giving them kinetic energy: a heavy body lifted out of
  // an overlap must not hide another's fall). Contacts only take energy away or pass it between
  // bodies, so T_1 stays below T_0 + W up to the integrator's rounding; a step that exceeds it by
  // the factor and the floor is an explosion.
  // a moving kinematic body is a source of energy the balance cannot bound (its mass is
  // infinite, its velocity the user's): such steps are not checked
  for (std::size_t i = 0; i < model_.size(); ++i)
    if (model_.is_kinematic[i] && model_.enabled[i] && (state_.v[i].squaredNorm() > 0.0 || state_.omega[i].squaredNorm() > 0.0))
      return;
  double T1 = 0.0, W = 0.0;
  for (std::size_t i = 0; i < model_.size(); ++i) {
    if (model_.is_static[i] || model_.is_kinematic[i] || !model_.enabled[i]) continue;
    T1 += body_kinetic_energy(model_, state_, i);
    const Vec3 f = model_.mass[i] * settings_.gravity + before_.f_ext[i] + before_.f_step[i];
    const Vec3 tau = before_.tau_ext[i] + before_.tau_step[i];
    W += std::max(0.0, f.dot(state_.p[i] - before_.p[i]) + tau.dot(before_.omega[i] + state_.omega[i]) * 0.5 * dt);
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
    s << (first ? "" : ", ") << label(static_cast<BodyIndex>(i)) << " +" << gained << " J";
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
  copy_state(state_, before_);
  solver_->cache.swap(cache_before_);
  solver_->body_force.swap(force_before_);
  solver_->body_torque.swap(torque_before_);
}

void World::step_once(double dt) {
  before_ = state_;
  // copied into kept storage, grown geometrically (a copy assignment allocates the exact size)
  if (cache_before_.capacity() < solver_->cache.size()) cache_before_.reserve(2 * solver_->cache.size());
  cache_before_ = solver_->cache;
  force_before_ = solver_->body_force;
  torque_before_ = solver_->body_torque;
  // 0. pending impulses change the velocities of dynamic bodies at the start of the step
  for (std::size_t i = 0; i < model_.size(); ++i) {
    Vec3& J = state_.impulse[i];
    Vec3& L = state_.angular_impulse[i];
    if (J.squaredNorm() == 0.0 && L.squaredNorm() == 0.0) continue;
    if (model_.enabled[i] && !model_.is_static[i] && !model_.is_kinematic[i]) {
      state_.v[i] += model_.inv_mass[i] * J;
      state_.omega[i] += dynamics::inverse_inertia_world(model_, state_, i) * L;
    }
    J.setZero();
    L.setZero();
  }
  // kinetic energy after the impulses: what the energy check measures the step against
  double T0 = 0.0;
  for (std::size_t i = 0; i < model_.size(); ++i) T0 += body_kinetic_energy(model_, state_, i);
  // 1. contacts from the state at the start of the step, reaching as far as the whole step moves
  detect_contacts(dt, contacts_base_);
  const int n = settings_.solver.substep_count(dt);
  const double h = dt / n;
  SolverStats stats;
  for (int k = 0; k < n; ++k) {
    // a substep solves the step's contacts carried along by the motion since detection
    if (k == 0) {
      if (contacts_next_.capacity() < contacts_base_.size()) contacts_next_.reserve(2 * contacts_base_.size());
      contacts_next_ = contacts_base_;
    } else {
      collision::carry_contacts(contacts_base_, before_, state_, contacts_next_, anchor_a_, anchor_b_);
    }
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
    copy_into(state_.v, v_);  // copied, not swapped: the state's storage stays where views see it
    copy_into(state_.omega, omega_);
    state_.time += h;
    // a step that produced a non-finite number is undone and reported, never kept
    for (std::size_t i = 0; i < model_.size(); ++i) {
      if (state_.p[i].allFinite() && state_.v[i].allFinite() && state_.omega[i].allFinite() &&
          state_.R[i].allFinite())
        continue;
      undo_step();
      throw std::runtime_error(label(static_cast<BodyIndex>(i)) +
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
    check_energy(dt, T0);
  } catch (const std::runtime_error&) {
    undo_step();
    throw;
  }
  // keep the step: the last substep's contacts and stats, what the meshes remember, quaternions of
  // the new rotations; the one-step forces are spent
  copy_into(previous_p_, before_.p);
  crossing_.swap(scratch_->crossing_next);
  own_contacts().swap(contacts_next_);
  stats_ = stats;
  for (std::size_t i = 0; i < model_.size(); ++i) {
    if (!model_.is_static[i] && model_.enabled[i]) state_.q[i] = math::matrix_to_quat(state_.R[i]);
    state_.f_step[i].setZero();
    state_.tau_step[i].setZero();
  }
}

const std::vector<Vec3>& World::contact_forces() const { return solver_->body_force; }
const std::vector<Vec3>& World::contact_torques() const { return solver_->body_torque; }
const std::vector<CachedContact>& World::warm_start_cache() const { return solver_->cache; }

void World::set_material(BodyIndex i, const Material& material) {
  check_index(i);
  check_material(label(i), material);
  model_.material[i] = material;
}

std::string World::label(BodyIndex i) const {
  check_index(i);
  return body_label(i, model_.name[i], model_.shape[i]);
}

void World::check_index(BodyIndex i) const {
  if (i < 0 || static_cast<std::size_t>(i) >= model_.size())
    throw BodyIndexError("body index " + std::to_string(i) + " is out of range: the world has " +
                         std::to_string(model_.size()) + " bodies");
}

void World::set_position(BodyIndex i, const Vec3& p) {
  check_index(i);
  require_finite(label(i), "position", p);
  state_.p[i] = p;
  previous_p_[i] = p;  // moved, not travelled: no crossing
  crossing_[i] = collision::Crossing();
  if (model_.is_static[i]) broad_phase_->move_static(i, state_.p[i], state_.R[i]);
}

void World::set_orientation(BodyIndex i, const Quat4& q) {
  check_index(i);
  state_.R[i] = math::quat_to_matrix(unit_quaternion(label(i), q));
  state_.q[i] = math::matrix_to_quat(state_.R[i]);
  if (model_.is_static[i]) broad_phase_->move_static(i, state_.p[i], state_.R[i]);
}

void World::check_velocity(BodyIndex i, const char* what, const Vec3& x) const {
  check_index(i);
  const std::string who = label(i);
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
  check_batch("set_positions", bodies, values.rows());
  for (Eigen::Index k = 0; k < bodies.size(); ++k)
    require_finite(label(static_cast<BodyIndex>(bodies[k])), "position", values.row(k).transpose());
  for (Eigen::Index k = 0; k < bodies.size(); ++k) {
    const auto i = static_cast<BodyIndex>(bodies[k]);
    state_.p[i] = values.row(k).transpose();
    previous_p_[i] = state_.p[i];  // moved, not travelled: no crossing
    crossing_[i] = collision::Crossing();
    if (model_.is_static[i]) broad_phase_->move_static(i, state_.p[i], state_.R[i]);
  }
}

void World::set_orientations(const Indices& bodies, const Quats& values) {
  check_batch("set_orientations", bodies, values.rows());
  std::vector<Mat3> R(bodies.size());
  for (Eigen::Index k = 0; k < bodies.size(); ++k)
    R[k] = math::quat_to_matrix(unit_quaternion(label(static_cast<BodyIndex>(bodies[k])), values.row(k).transpose()));
  for (Eigen::Index k = 0; k < bodies.size(); ++k) {
    const auto i = static_cast<BodyIndex>(bodies[k]);
    state_.R[i] = R[k];
    state_.q[i] = math::matrix_to_quat(R[k]);
    if (model_.is_static[i]) broad_phase_->move_static(i, state_.p[i], state_.R[i]);
  }
}

void World::set_velocities(const Indices& bodies, const Points& values) {
  check_batch("set_velocities", bodies, values.rows());
  for (Eigen::Index k = 0; k < bodies.size(); ++k)
    check_velocity(static_cast<BodyIndex>(bodies[k]), "velocity", values.row(k).transpose());
  for (Eigen::Index k = 0; k < bodies.size(); ++k) state_.v[bodies[k]] = values.row(k).transpose();
}

void World::set_angular_velocities(const Indices& bodies, const Points& values) {
  check_batch("set_angular_velocities", bodies, values.rows());
  for (Eigen::Index k = 0; k < bodies.size(); ++k)
    check_velocity(static_cast<BodyIndex>(bodies[k]), "angular_velocity", values.row(k).transpose());
  for (Eigen::Index k = 0; k < bodies.size(); ++k) state_.omega[bodies[k]] = values.row(k).transpose();
}

void World::set_external_wrench(BodyIndex i, const Vec3& force, const Vec3& torque) {
  check_index(i);
  const std::string who = label(i);
  require_finite(who, "force", force);
  require_finite(who, "torque", torque);
  state_.f_ext[i] = force;
  state_.tau_ext[i] = torque;
}

void World::check_push(BodyIndex i, const char* what, const Vec3& push, const Vec3& point) const {
  check_index(i);
  const std::string who = label(i);
  require_finite(who, what, push);
  require_finite(who, "point", point);
  if (model_.is_static[i] || model_.is_kinematic[i])
    throw std::invalid_argument(who + ": a " + (model_.is_static[i] ? "static" : "kinematic") + " body takes no " +
                                what + "s (it has infinite mass); set its velocity instead");
}

void World::apply_impulse(BodyIndex i, const Vec3& impulse, const Vec3& point) {
  check_push(i, "impulse", impulse, point);
  state_.impulse[i] += impulse;
  state_.angular_impulse[i] += (point - state_.p[i]).cross(impulse);
}

void World::apply_force(BodyIndex i, const Vec3& force, const Vec3& point) {
  check_push(i, "force", force, point);
  state_.f_step[i] += force;
  state_.tau_step[i] += (point - state_.p[i]).cross(force);
}

void World::set_kinematic(BodyIndex i, bool kinematic) {
  check_index(i);
  const std::string who = label(i);
  if (model_.is_static[i]) throw std::invalid_argument(who + ": a static body cannot become kinematic or dynamic");
  if (!kinematic && !std::isfinite(model_.mass[i]))
    throw std::invalid_argument(who + ": it was added without a mass, so it can only be kinematic");
  if (model_.is_kinematic[i] == kinematic) return;
  set_kinematic_flag(i, kinematic);
  if (kinematic) {
    state_.f_step[i].setZero();
    state_.tau_step[i].setZero();
    state_.impulse[i].setZero();
    state_.angular_impulse[i].setZero();
  }
}

void World::set_enabled(BodyIndex i, bool enabled) {
  check_index(i);
  model_.enabled[i] = enabled;
}

void World::set_collision_filter(BodyIndex i, const CollisionFilter& filter) {
  check_index(i);
  model_.filter[i] = filter;
}

void World::set_pair_collision(BodyIndex i, BodyIndex j, bool collide) {
  check_index(i);
  check_index(j);
  if (i == j) throw std::invalid_argument(label(i) + ": a body never collides with itself; give two different bodies");
  const std::pair<int, int> key(std::min(i, j), std::max(i, j));
  auto& pairs = model_.excluded_pairs;
  const auto it = std::lower_bound(pairs.begin(), pairs.end(), key);
  const bool listed = it != pairs.end() && *it == key;
  if (!collide && !listed) pairs.insert(it, key);
  if (collide && listed) pairs.erase(it);
}

BodyIndex World::find(const std::string& name) const {
  const auto it = by_name_.find(name);
  return it == by_name_.end() ? -1 : it->second;
}

std::string World::save_state() const {
  Writer w;
  w.out.append(kStateMagic, sizeof kStateMagic);
  const std::size_t n = model_.size();
  w.pod(static_cast<std::uint64_t>(n));
  // the world it belongs to
  for (std::size_t i = 0; i < n; ++i) {
    w.pod(static_cast<std::uint8_t>(model_.shape[i].index()));
    w.pod(static_cast<std::uint8_t>(model_.is_static[i]));
    w.pod(model_.mass[i]);
  }
  // flags and state
  for (std::size_t i = 0; i < n; ++i) {
    w.pod(static_cast<std::uint8_t>(model_.is_kinematic[i]));
    w.pod(static_cast<std::uint8_t>(model_.enabled[i]));
  }
  w.pod(state_.time);
  w.mats(state_.p);
  w.mats(state_.R);
  w.mats(state_.q);
  const solver::SolverData& solved = *solver_;
  for (const std::vector<Vec3>* x : {&state_.v, &state_.omega, &state_.f_ext, &state_.tau_ext, &state_.f_step,
                                     &state_.tau_step, &state_.impulse, &state_.angular_impulse,
                                     &solved.body_force, &solved.body_torque})
    w.mats(*x);
  // warm-start cache, last contacts, last solver figures
  w.pod(static_cast<std::uint64_t>(solver_->cache.size()));
  for (const CachedContact& c : solver_->cache) {
    w.pod(c.body_a);
    w.pod(c.body_b);
    w.pod(c.feature_a);
    w.pod(c.feature_b);
    w.pod(c.alpha);
    w.mat(c.friction);
    w.pod(c.spin);
    w.pod(c.order);
  }
  w.pod(static_cast<std::uint64_t>(contacts_->size()));
  for (const Contact& c : *contacts_) write_contact(w, c);
  for (int x : {stats_.iterations, stats_.restitution_iterations, stats_.position_iterations, stats_.contacts,
                static_cast<int>(stats_.converged)})
    w.pod(x);
  for (double x : {stats_.residual, stats_.max_alpha_negative, stats_.max_penetration_velocity,
                   stats_.max_complementarity, stats_.max_cone_violation, stats_.max_dissipation_violation,
                   stats_.max_overlap})
    w.pod(x);
  // the triangle meshes' memory (format 3): centres at the start of the last step and crossings
  w.mats(previous_p_);
  for (const collision::Crossing& c : crossing_) {
    w.pod(static_cast<std::int32_t>(c.mesh));
    w.pod(static_cast<std::int32_t>(c.triangle));
  }
  return std::move(w.out);
}

void World::restore_state(const std::string& saved) {
  // read and check everything first: the world changes only once nothing can fail
  Reader r{saved};
  const std::string bad = "restore_state: not a saved state of this world: ";
  if (saved.size() < sizeof kStateMagic || std::memcmp(saved.data(), kStateMagic, kStateVersionAt) != 0)
    throw std::invalid_argument("restore_state: not a saved state (no header)");
  const char version = saved[kStateVersionAt];
  if (version < '1' || version > '3')
    throw std::invalid_argument(std::string("restore_state: a saved state of format '") + version +
                                "', which this signorini does not read (it reads formats 1 to 3)");
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
  s.time = r.pod<double>();
  r.mats(s.p, n);
  r.mats(s.R, n);
  r.mats(s.q, n);
  std::vector<Vec3> body_force, body_torque;
  for (std::vector<Vec3>* x : {&s.v, &s.omega, &s.f_ext, &s.tau_ext, &s.f_step, &s.tau_step, &s.impulse,
                               &s.angular_impulse, &body_force, &body_torque})
    r.mats(*x, n);
  std::vector<CachedContact> cache(r.count(sizeof(CachedContact::alpha)));
  for (CachedContact& c : cache) {
    c.body_a = r.pod<BodyIndex>();
    c.body_b = r.pod<BodyIndex>();
    c.feature_a = r.pod<FeatureId>();
    c.feature_b = r.pod<FeatureId>();
    c.alpha = r.pod<double>();
    r.mat(c.friction);
    if (version >= '2') c.spin = r.pod<double>();
    c.order = r.pod<int>();
  }
  auto contacts = std::make_shared<std::vector<Contact>>(r.count(sizeof(double)));
  for (Contact& c : *contacts) c = read_contact(r, version);
  SolverStats stats;
  for (int* x : {&stats.iterations, &stats.restitution_iterations, &stats.position_iterations, &stats.contacts})
    *x = r.pod<int>();
  stats.converged = r.pod<int>() != 0;
  for (double* x : {&stats.residual, &stats.max_alpha_negative, &stats.max_penetration_velocity,
                    &stats.max_complementarity, &stats.max_cone_violation, &stats.max_dissipation_violation,
                    &stats.max_overlap})
    *x = r.pod<double>();
  // formats 1 and 2 have no crossing memory: it starts afresh, as after set_position
  std::vector<Vec3> previous_p = s.p;
  std::vector<collision::Crossing> crossing(n);
  if (version >= '3') {
    r.mats(previous_p, n);
    for (collision::Crossing& c : crossing) {
      c.mesh = r.pod<std::int32_t>();
      c.triangle = r.pod<std::int32_t>();
    }
  }
  if (r.at != saved.size()) throw std::invalid_argument("restore_state: the saved state has trailing bytes");
  const auto in_range = [n](BodyIndex k) { return k >= 0 && static_cast<std::size_t>(k) < n; };
  for (const CachedContact& c : cache)
    if (!in_range(c.body_a) || !in_range(c.body_b)) throw std::invalid_argument("restore_state: the saved state is damaged");
  for (const Contact& c : *contacts)
    if (!in_range(c.body_a) || !in_range(c.body_b)) throw std::invalid_argument("restore_state: the saved state is damaged");
  for (const collision::Crossing& c : crossing) {
    if (c.mesh == -1 && c.triangle == -1) continue;
    const TriangleMesh* mesh = in_range(c.mesh) ? std::get_if<TriangleMesh>(&model_.shape[static_cast<std::size_t>(c.mesh)]) : nullptr;
    if (!mesh || c.triangle < 0 || c.triangle >= mesh->faces.rows())
      throw std::invalid_argument("restore_state: the saved state is damaged (crossing memory)");
  }
  for (const Vec3& x : previous_p)
    if (!x.allFinite()) throw std::invalid_argument("restore_state: the saved state is damaged (previous centres)");
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
  copy_state(state_, s);
  copy_into(solver_->body_force, body_force);
  copy_into(solver_->body_torque, body_torque);
  solver_->cache = std::move(cache);
  contacts_ = std::move(contacts);
  stats_ = stats;
  copy_into(previous_p_, previous_p);
  std::copy(crossing.begin(), crossing.end(), crossing_.begin());
}

Quat4 World::orientation(BodyIndex i) const {
  check_index(i);
  return state_.q[i];
}

double World::kinetic_energy() const {
  double T = 0.0;
  for (std::size_t i = 0; i < model_.size(); ++i) {
    if (model_.is_static[i] || model_.is_kinematic[i]) continue;
    const Mat3& R = state_.R[i];
    const Vec3& w = state_.omega[i];
    T += 0.5 * model_.mass[i] * state_.v[i].squaredNorm() + 0.5 * w.dot(R * (model_.I_body[i] * (R.transpose() * w)));
  }
  return T;
}

double World::potential_energy() const {
  double V = 0.0;
  for (std::size_t i = 0; i < model_.size(); ++i)
    if (!model_.is_static[i] && !model_.is_kinematic[i]) V -= model_.mass[i] * settings_.gravity.dot(state_.p[i]);
  return V;
}

}  // namespace signorini
