// Mass properties against closed forms; mesh checks.
#include <gtest/gtest.h>

#include <cmath>

#include "math/rotation.hpp"
#include "signorini/mass_properties.hpp"

using namespace signorini;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Closed box mesh with half extents h, outward faces, optionally rotated by R and shifted by t.
Mesh box_mesh(const Vec3& h, const Mat3& R = Mat3::Identity(), const Vec3& t = Vec3::Zero()) {
  Points v(8, 3);
  for (int k = 0; k < 8; ++k) {
    const Vec3 c((k & 1) ? h.x() : -h.x(), (k & 2) ? h.y() : -h.y(), (k & 4) ? h.z() : -h.z());
    v.row(k) = (R * c + t).transpose();
  }
  Triangles f(12, 3);
  f << 0, 2, 1, 1, 2, 3,   // z-
       4, 5, 6, 5, 7, 6,   // z+
       0, 1, 4, 1, 5, 4,   // y-
       2, 6, 3, 3, 6, 7,   // y+
       0, 4, 2, 2, 4, 6,   // x-
       1, 3, 5, 3, 7, 5;   // x+
  return Mesh(v, f);
}

}  // namespace

TEST(MassProperties, SphereClosedForm) {
  const MassProperties mp = mass_properties(Sphere(0.5), 1000.0);
  EXPECT_NEAR(mp.mass, 1000.0 * 4.0 / 3.0 * kPi * 0.125, 1e-10);
  EXPECT_NEAR(mp.inertia(0, 0), 0.4 * mp.mass * 0.25, 1e-12);
  EXPECT_EQ(mp.inertia(0, 1), 0.0);
}

TEST(MassProperties, BoxClosedForm) {
  const MassProperties mp = mass_properties(Box(Vec3(0.5, 1.0, 1.5)), 2.0);
  const double m = 2.0 * 1.0 * 2.0 * 3.0;
  EXPECT_NEAR(mp.mass, m, 1e-12);
  EXPECT_NEAR(mp.inertia(0, 0), m / 12.0 * (4.0 + 9.0), 1e-12);
  EXPECT_NEAR(mp.inertia(1, 1), m / 12.0 * (1.0 + 9.0), 1e-12);
  EXPECT_NEAR(mp.inertia(2, 2), m / 12.0 * (1.0 + 4.0), 1e-12);
}

TEST(MassProperties, BoxMeshEqualsBoxClosedFormRotatedAndShifted) {
  // the divergence theorem is exact for polyhedra: only rounding separates the two (1e-12)
  const Vec3 h(0.3, 0.7, 1.1);
  const Mat3 R = math::quat_to_matrix(Quat4(0.9, 0.1, -0.3, 0.2).normalized());
  const Vec3 t(1.0, -2.0, 0.5);
  const MassProperties exact = mass_properties(Box(h), 750.0);
  const MassProperties mesh = mass_properties(box_mesh(h, R, t), 750.0);
  EXPECT_NEAR(mesh.mass, exact.mass, 1e-10);
  EXPECT_LT((mesh.com - t).norm(), 1e-12);
  EXPECT_LT((mesh.inertia - R * exact.inertia * R.transpose()).norm(), 1e-10);
}

TEST(MassProperties, OpenAndInvertedMeshesAreRejected) {
  Mesh box = box_mesh(Vec3(1, 1, 1));
  Triangles open_faces = box.faces.topRows(11);
  EXPECT_THROW(
      {
        try {
          mass_properties(Mesh(box.vertices, open_faces), 1.0);
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("open"), std::string::npos) << e.what();
          throw;
        }
      },
      std::invalid_argument);
  Triangles inverted = box.faces;
  inverted.col(1).swap(inverted.col(2));
  EXPECT_THROW(mass_properties(Mesh(box.vertices, inverted), 1.0), std::invalid_argument);
  Triangles one_flipped = box.faces;
  std::swap(one_flipped(0, 1), one_flipped(0, 2));
  EXPECT_NE(Mesh(box.vertices, one_flipped).closedness_problem().find("inconsistently"), std::string::npos);
}

TEST(MassProperties, BadShapeParametersThrow) {
  EXPECT_THROW(Sphere(-1.0), std::invalid_argument);
  EXPECT_THROW(Sphere(std::nan("")), std::invalid_argument);
  EXPECT_THROW(Box(Vec3(1, 0, 1)), std::invalid_argument);
  EXPECT_THROW(Plane(Vec3::Zero(), 0.0), std::invalid_argument);
  Points v(3, 3);
  v << 0, 0, 0, 1, 0, 0, 2, 0, 0;  // collinear: zero-area face
  Triangles f(1, 3);
  f << 0, 1, 2;
  EXPECT_THROW(Mesh(v, f), std::invalid_argument);
  EXPECT_THROW(mass_properties(Plane(Vec3::UnitZ(), 0.0), 1.0), std::invalid_argument);
  EXPECT_THROW(mass_properties(Sphere(1.0), 0.0), std::invalid_argument);
}

TEST(MassProperties, ConvexityTest) {
  EXPECT_TRUE(box_mesh(Vec3(1, 2, 3)).is_convex());
}
