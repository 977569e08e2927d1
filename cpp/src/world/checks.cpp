#include "world/checks.hpp"

#include <cmath>
#include <sstream>

#include "math/rotation.hpp"

namespace signorini::checks {
namespace {

std::string fmt(const Eigen::VectorXd& x) {
  std::ostringstream s;
  s << "(";
  for (Eigen::Index k = 0; k < x.size(); ++k) s << (k ? ", " : "") << x[k];
  s << ")";
  return s.str();
}

}  // namespace

std::string body_label(BodyIndex i, const std::string& name, const Shape& shape) {
  return "body " + std::to_string(i) + (name.empty() ? "" : " '" + name + "'") + " (" + shape_name(shape) + ")";
}

void require_finite(const std::string& who, const char* what, const Eigen::VectorXd& x) {
  if (!x.allFinite())
    throw std::invalid_argument(who + ": " + what + " must be finite, got " + fmt(x));
}

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

std::string body_label(const Model& model, BodyIndex i) {
  return body_label(i, model.name[static_cast<std::size_t>(i)], model.shape[static_cast<std::size_t>(i)]);
}

}  // namespace signorini::checks
