// The public rotation functions (signorini/rotation.hpp): checks, then the maths of math/rotation.
#include "signorini/rotation.hpp"

#include <stdexcept>

#include "math/rotation.hpp"

namespace signorini {

Mat3 rotation_matrix(const Quat4& q) { return math::quat_to_matrix(math::unit_quaternion(q)); }

Quat4 rotation_quaternion(const Mat3& R) {
  if (!R.allFinite()) throw std::invalid_argument("rotation matrix must be finite");
  if (!(R.norm() > 1e-12)) throw std::invalid_argument("rotation matrix is zero");
  return math::matrix_to_quat(R);
}

}  // namespace signorini
