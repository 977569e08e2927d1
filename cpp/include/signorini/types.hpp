// Basic types shared by every stage. Units are SI (m, kg, s); vectors are world-frame unless a
// name says _body. See docs/conventions.md for the frames and the lecture's symbols.
#pragma once

#include <Eigen/Dense>
#include <cstdint>

namespace signorini {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
/// Unit quaternion (w, x, y, z), the order the Python API uses.
using Quat4 = Eigen::Vector4d;
/// Row-major (n x 3) arrays: the layout NumPy hands over without a copy.
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using Triangles = Eigen::Matrix<std::int64_t, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// Row-major (n x 4) quaternions (w, x, y, z).
using Quats = Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>;
/// A list of body indices, as NumPy's int64 (checked against the body count before any use).
using Indices = Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1>;

/// Index of a body in a World: 0, 1, 2, ... in the order they were added, static bodies included.
using BodyIndex = int;

}  // namespace signorini
