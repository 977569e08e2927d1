// Checks and small helpers the World's files share: how errors name a body, the finite / unit /
// range checks of user input (std::invalid_argument with the body named), and in-place copies
// that keep the storage NumPy views point at.
#pragma once

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "signorini/model.hpp"
#include "signorini/shapes.hpp"
#include "signorini/types.hpp"

namespace signorini::checks {

/// "body 3 'ball' (Sphere)", or "body 3 (Sphere)" without a name.
std::string body_label(BodyIndex i, const std::string& name, const Shape& shape);
/// The same for body i of a model.
std::string body_label(const Model& model, BodyIndex i);
/// x must be finite: "<who>: <what> must be finite, got (...)".
void require_finite(const std::string& who, const char* what, const Eigen::VectorXd& x);
/// Unit quaternion from a user's one (math::unit_quaternion), errors prefixed with who.
Quat4 unit_quaternion(const std::string& who, const Quat4& q);
/// friction >= 0, restitution in [0, 1], spinning friction >= 0, all finite.
void check_material(const std::string& who, const Material& m);
/// A World setting: "World: <what>" unless ok.
void require(bool ok, const std::string& what);

/// Copies src into dst element by element: dst keeps its storage (NumPy views of it stay live).
template <class T>
void copy_into(std::vector<T>& dst, const std::vector<T>& src) {
  if (dst.size() != src.size()) throw std::logic_error("copy_into: sizes differ");
  std::copy(src.begin(), src.end(), dst.begin());
}

}  // namespace signorini::checks
