// Rotations for users of the library: the quaternion <-> matrix conversions the World itself uses
// for orientations, so callers (the Python codec, file readers) get the core's numbers to the bit.
#pragma once

#include "signorini/types.hpp"

namespace signorini {

/// Rotation matrix R (3x3, world-from-body) of a quaternion q = (w, x, y, z). q is made unit first
/// exactly as World does for a body's orientation, so the result equals World's R to the bit. q
/// must be finite and non-zero, else std::invalid_argument naming the problem.
Mat3 rotation_matrix(const Quat4& q);

/// Unit quaternion (w, x, y, z), w >= 0, of a rotation matrix R (3x3). R must be finite and
/// non-zero (it is taken as a rotation: the nearest quaternion, normalised), else
/// std::invalid_argument naming the problem.
Quat4 rotation_quaternion(const Mat3& R);

}  // namespace signorini
