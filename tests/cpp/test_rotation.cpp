// Rotations: Rodrigues against the matrix exponential, orthonormality over 1e5 steps, quaternions.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <unsupported/Eigen/MatrixFunctions>

#include "math/rotation.hpp"
#include "signorini/rotation.hpp"

using namespace signorini;

TEST(Rotation, SkewIsTheCrossProduct) {
  const Vec3 a(0.3, -1.2, 2.0), b(-0.7, 0.4, 1.1);
  EXPECT_LT((math::skew(a) * b - a.cross(b)).norm(), 1e-15);
}

TEST(Rotation, RodriguesMatchesMatrixExponential) {
  // exp of a skew matrix from Eigen's Pade-based expm; both are accurate to a few ulps of |R| = 1
  std::mt19937 rng(7);
  std::normal_distribution<double> N(0.0, 1.0);
  for (double scale : {1e-9, 1e-5, 1e-3, 0.1, 1.0, 3.0, 10.0}) {
    for (int trial = 0; trial < 20; ++trial) {
      const Vec3 omega = scale * Vec3(N(rng), N(rng), N(rng));
      const double dt = 0.37;
      const Mat3 expected = (math::skew(omega) * dt).exp();
      EXPECT_LT((math::rodrigues(omega, dt) - expected).norm(), 1e-14) << "scale " << scale;
    }
  }
}

TEST(Rotation, SmallAngleSeriesIsContinuousAtTheSwitch) {
  // A and B switch from the closed form to the series at theta = 1e-4; both sides agree to ~1e-16
  const Vec3 axis = Vec3(1, 2, -2).normalized();
  const Mat3 below = math::rodrigues(axis * (1e-4 * (1 - 1e-12)), 1.0);
  const Mat3 above = math::rodrigues(axis * (1e-4 * (1 + 1e-12)), 1.0);
  EXPECT_LT((below - above).norm(), 1e-15);
}

TEST(Rotation, StaysOrthonormalOver1e5Steps) {
  // a fast, irregular spin for 1e5 steps: rounding would accumulate as a random walk (~1e-13),
  // the polar Newton step removes it each step, so R^T R stays I to a few ulps
  Mat3 R = Mat3::Identity();
  for (int k = 0; k < 100000; ++k) {
    const Vec3 omega(3.0 * std::sin(0.001 * k), 5.0, -2.0 * std::cos(0.003 * k));
    R = math::orthonormalize(math::rodrigues(omega, 1.0 / 240.0) * R);
  }
  EXPECT_LT((R.transpose() * R - Mat3::Identity()).norm(), 1e-14);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
}

TEST(Rotation, QuaternionRoundTrip) {
  std::mt19937 rng(3);
  std::normal_distribution<double> N(0.0, 1.0);
  for (int trial = 0; trial < 100; ++trial) {
    Quat4 q(N(rng), N(rng), N(rng), N(rng));
    q.normalize();
    if (q[0] < 0) q = -q;
    const Mat3 R = math::quat_to_matrix(q);
    EXPECT_LT((math::matrix_to_quat(R) - q).norm(), 1e-14);
    EXPECT_LT((R.transpose() * R - Mat3::Identity()).norm(), 1e-14);
  }
  // a quarter turn about z takes x to y
  const Quat4 qz(std::sqrt(0.5), 0, 0, std::sqrt(0.5));
  EXPECT_LT((math::quat_to_matrix(qz) * Vec3::UnitX() - Vec3::UnitY()).norm(), 1e-15);
}

TEST(Rotation, PublicFunctionsAreTheWorldsMaths) {
  // rotation_matrix is what World makes of a body's quaternion, to the bit; rotation_quaternion inverts it
  std::mt19937 rng(20);
  std::normal_distribution<double> N(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Quat4 q = 3.0 * Quat4(N(rng), N(rng), N(rng), N(rng));
    const Mat3 R = rotation_matrix(q);
    EXPECT_TRUE(R == math::quat_to_matrix(math::unit_quaternion(q)));
    const Quat4 back = rotation_quaternion(R);
    const Quat4 unit = math::unit_quaternion(q) * (q[0] < 0.0 ? -1.0 : 1.0);
    EXPECT_GE(back[0], 0.0);
    EXPECT_LT((back - unit).norm(), 1e-15);
  }
  EXPECT_THROW(rotation_matrix(Quat4::Zero()), std::invalid_argument);
  EXPECT_THROW(rotation_matrix(Quat4(std::nan(""), 0.0, 0.0, 1.0)), std::invalid_argument);
  EXPECT_THROW(rotation_quaternion(Mat3::Zero()), std::invalid_argument);
  Mat3 bad = Mat3::Identity();
  bad(1, 2) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(rotation_quaternion(bad), std::invalid_argument);
}
