// Rotations: skew matrices, the exponential map (Rodrigues), quaternions, re-orthonormalisation.
#pragma once

#include "signorini/types.hpp"

namespace signorini::math {

/// [x]_x, the 3x3 cross-product matrix: skew(x) * y == x.cross(y).
Mat3 skew(const Vec3& x);

/// exp([omega]_x dt) by Rodrigues' formula: I + A K + B K^2 with K = [omega dt]_x, theta = |omega| dt,
/// A = sin(theta)/theta, B = (1 - cos(theta))/theta^2; Taylor series below theta = 1e-4 (error
/// below 1e-20). omega in rad/s (world), dt in s.
Mat3 rodrigues(const Vec3& omega, double dt);

/// One Newton step of the polar decomposition, R <- 1.5 R - 0.5 R R^T R: pulls a nearly orthonormal
/// R back to the rotation group (error e -> O(e^2)).
Mat3 orthonormalize(const Mat3& R);

/// A user's orientation quaternion (w, x, y, z) made unit: it must be finite and non-zero (norm >
/// 1e-12); a non-unit one is normalised. Otherwise std::invalid_argument "orientation quaternion
/// (w, x, y, z) must be finite" or "... is zero; use (1, 0, 0, 0) for no rotation" (callers prefix
/// who it belongs to). The one check of user quaternions for bodies, setters and compound parts.
Quat4 unit_quaternion(const Quat4& q);

/// Unit quaternion (w, x, y, z) -> rotation matrix. q must be unit length.
Mat3 quat_to_matrix(const Quat4& q);

/// Rotation matrix -> unit quaternion (w, x, y, z) with w >= 0.
Quat4 matrix_to_quat(const Mat3& R);

}  // namespace signorini::math
