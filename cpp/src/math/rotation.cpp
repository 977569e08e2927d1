#include "math/rotation.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

namespace signorini::math {

Mat3 skew(const Vec3& x) {
  Mat3 S;
  S << 0.0, -x.z(), x.y(),
       x.z(), 0.0, -x.x(),
      -x.y(), x.x(), 0.0;
  return S;
}

Mat3 rodrigues(const Vec3& omega, double dt) {
  const Vec3 phi = omega * dt;
  const double theta2 = phi.squaredNorm();
  const double theta = std::sqrt(theta2);
  double A, B;
  if (theta < 1e-4) {
    // series: next terms are theta^4/120 and theta^4/720, below 1e-18 here
    A = 1.0 - theta2 / 6.0;
    B = 0.5 - theta2 / 24.0;
  } else {
    A = std::sin(theta) / theta;
    B = (1.0 - std::cos(theta)) / theta2;
  }
  const Mat3 K = skew(phi);
  return Mat3::Identity() + A * K + B * (K * K);
}

Mat3 orthonormalize(const Mat3& R) {
  return 1.5 * R - 0.5 * R * (R.transpose() * R);
}

Mat3 quat_to_matrix(const Quat4& q) {
  return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
}

Quat4 unit_quaternion(const Quat4& q) {
  auto text = [&q]() {
    std::ostringstream s;
    s << "(" << q[0] << ", " << q[1] << ", " << q[2] << ", " << q[3] << ")";
    return s.str();
  };
  if (!q.allFinite()) throw std::invalid_argument("orientation quaternion must be finite, got " + text());
  // the plain norm, or when its squares overflow or underflow (entries beyond ~1e154 or below
  // ~1e-154) the scaled one, so that (1e300, 1e300, 0, 0) is a quarter turn, not an error
  double norm = q.norm();
  if (!std::isfinite(norm) || norm < 1e-150) norm = q.stableNorm();
  if (!(norm > 1e-12))
    throw std::invalid_argument("orientation quaternion " + text() + " is zero; use (1, 0, 0, 0) for no rotation");
  return q / norm;
}

Quat4 matrix_to_quat(const Mat3& R) {
  Eigen::Quaterniond q(R);
  q.normalize();
  Quat4 out(q.w(), q.x(), q.y(), q.z());
  if (out[0] < 0.0) out = -out;
  return out;
}

}  // namespace signorini::math
