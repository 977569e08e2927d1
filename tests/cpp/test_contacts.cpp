// Contact generation: plane tests, sphere-sphere, FCL pairs, ordering and speculative reach.
#include <gtest/gtest.h>

#include "collision/collision.hpp"
#include "math/rotation.hpp"

using namespace signorini;

TEST(PlaneContacts, BoxRestingFaceDownGetsItsFourBottomCorners) {
  std::vector<Contact> out;
  const Box box(Vec3(0.5, 0.5, 0.5));
  collision::plane_contacts(0, Plane(Vec3::UnitZ(), 0.0), Vec3::Zero(), Mat3::Identity(), 1, box,
                            Vec3(0.2, -0.3, 0.5), Mat3::Identity(), 1e-3, out);
  ASSERT_EQ(out.size(), 4u);
  for (const Contact& c : out) {
    EXPECT_EQ(c.body_a, 0);
    EXPECT_EQ(c.body_b, 1);
    EXPECT_EQ(c.gap, 0.0);
    EXPECT_EQ(c.normal, Vec3::UnitZ());
    EXPECT_EQ(c.point.z(), 0.0);
  }
  // corner order k = 0, 1, 2, 3 (sz = -1): (-,-), (+,-), (-,+), (+,+)
  EXPECT_EQ(out[0].point, Vec3(-0.3, -0.8, 0.0));
  EXPECT_EQ(out[3].point, Vec3(0.7, 0.2, 0.0));
}

TEST(PlaneContacts, TiltedPlaneSphereAndPlanePose) {
  // a plane body placed by a pose: local normal z rotated to world x, origin at x = 2
  std::vector<Contact> out;
  const Mat3 R = math::quat_to_matrix(Quat4(std::sqrt(0.5), 0.0, std::sqrt(0.5), 0.0));  // z -> x
  collision::plane_contacts(0, Plane(Vec3::UnitZ(), 0.0), Vec3(2, 0, 0), R, 1, Sphere(0.5),
                            Vec3(2.4, 1, 1), Mat3::Identity(), 0.0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].gap, -0.1, 1e-15);
  EXPECT_LT((out[0].normal - Vec3::UnitX()).norm(), 1e-15);
  EXPECT_LT((out[0].point - Vec3(1.95, 1, 1)).norm(), 1e-15);
}

TEST(SphereSphere, ExactGapNormalAndSymmetricPoint) {
  const Contact c = collision::sphere_sphere(0, Vec3(0, 0, 0), 0.5, 1, Vec3(0.9, 0.1, 0), 0.5);
  const double d = std::sqrt(0.82);
  EXPECT_NEAR(c.gap, d - 1.0, 1e-15);
  EXPECT_LT((c.normal - Vec3(0.9, 0.1, 0) / d).norm(), 1e-15);
  const Contact swapped = collision::sphere_sphere(1, Vec3(0.9, 0.1, 0), 0.5, 0, Vec3(0, 0, 0), 0.5);
  EXPECT_LT((swapped.normal + c.normal).norm(), 1e-15);
  EXPECT_LT((swapped.point - c.point).norm(), 1e-15);
}

TEST(NarrowPhase, UnsupportedPairIsNamed) {
  // a torus-like non-convex mesh: an L-shaped prism is enough
  Points v(12, 3);
  v << 0, 0, 0, 2, 0, 0, 2, 1, 0, 1, 1, 0, 1, 2, 0, 0, 2, 0,
       0, 0, 1, 2, 0, 1, 2, 1, 1, 1, 1, 1, 1, 2, 1, 0, 2, 1;
  Triangles f(20, 3);
  f << 0, 2, 1, 0, 3, 2, 0, 5, 3, 3, 5, 4,        // bottom (z = 0), facing -z
       6, 7, 8, 6, 8, 9, 6, 9, 11, 9, 10, 11,     // top, facing +z
       0, 1, 7, 0, 7, 6, 1, 2, 8, 1, 8, 7, 2, 3, 9, 2, 9, 8,
       3, 4, 10, 3, 10, 9, 4, 5, 11, 4, 11, 10, 5, 0, 6, 5, 6, 11;
  const Mesh L(v, f);
  EXPECT_TRUE(L.closedness_problem().empty()) << L.closedness_problem();
  EXPECT_FALSE(L.is_convex());
  EXPECT_NE(collision::unsupported_pair(L, Sphere(1.0)).find("unsupported pair"), std::string::npos);
  EXPECT_TRUE(collision::unsupported_pair(L, Plane(Vec3::UnitZ(), 0.0)).empty());
  EXPECT_TRUE(collision::unsupported_pair(Box(Vec3(1, 1, 1)), Sphere(1.0)).empty());
}
