// Contact generation: plane tests, sphere-sphere, FCL pairs, ordering and speculative reach.
#include <gtest/gtest.h>

#include "collision/collision.hpp"
#include <random>

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

TEST(BoxSphere, ExactOutsideInsideAndSwapped) {
  const Mat3 R = math::quat_to_matrix(Quat4(0.9, 0.1, 0.3, -0.2).normalized());
  const Vec3 p(1.0, -0.5, 2.0), h(0.5, 0.3, 0.2);
  // a sphere 1 cm above the +z face, off-centre: the closest point is straight below its centre
  const Vec3 c_face = p + R * Vec3(0.1, -0.1, 0.2 + 0.25 + 0.01);
  const Contact face = collision::box_sphere(0, p, R, h, 1, c_face, 0.25, true);
  EXPECT_NEAR(face.gap, 0.01, 1e-15);
  EXPECT_LT((face.normal - R * Vec3::UnitZ()).norm(), 1e-15);
  EXPECT_LT((face.point - (p + R * Vec3(0.1, -0.1, 0.205))).norm(), 1e-15);
  // beyond an edge: the closest point is on the edge, the normal along the diagonal
  const Vec3 c_edge = p + R * Vec3(0.0, 0.3 + 0.3, 0.2 + 0.4);
  const Contact edge = collision::box_sphere(0, p, R, h, 1, c_edge, 0.25, true);
  EXPECT_NEAR(edge.gap, 0.5 - 0.25, 1e-15);
  EXPECT_LT((edge.normal - R * Vec3(0, 0.6, 0.8)).norm(), 1e-15);
  // centre inside, nearest the -x face: pushed out through it
  const Vec3 c_in = p + R * Vec3(-0.45, 0.0, 0.0);
  const Contact in = collision::box_sphere(0, p, R, h, 1, c_in, 0.1, true);
  EXPECT_NEAR(in.gap, -0.05 - 0.1, 1e-15);
  EXPECT_LT((in.normal + R * Vec3::UnitX()).norm(), 1e-15);
  // the sphere as A: same point and gap, opposite normal
  const Contact swapped = collision::box_sphere(1, p, R, h, 0, c_edge, 0.25, false);
  EXPECT_EQ(swapped.body_a, 0);
  EXPECT_EQ(swapped.body_b, 1);
  EXPECT_LT((swapped.normal + edge.normal).norm(), 1e-15);
  EXPECT_LT((swapped.point - edge.point).norm(), 1e-15);
  EXPECT_EQ(swapped.gap, edge.gap);
}

TEST(FclPairs, BoxBoxNormalIsExactWhenTouchingApartOrOverlapping) {
  // a box resting on a box (gap 0), a hair above it, clearly above, and sunk 1 mm: the normal
  // must be the face normal every time, from A to B, and the gap exact to GJK/EPA accuracy
  const Box big(Vec3(1.0, 1.0, 0.5)), small(Vec3(0.3, 0.2, 0.25));
  for (const double gap : {0.0, 1e-9, 1e-6, 0.05, -1e-3}) {
    Model model;
    State state;
    collision::BroadPhase broad;
    for (int i = 0; i < 2; ++i) {
      model.shape.push_back(i == 0 ? Shape(big) : Shape(small));
      model.is_static.push_back(i == 0);
      model.rho.push_back(bounding_radius(model.shape.back()));
      state.p.push_back(i == 0 ? Vec3::Zero() : Vec3(0.2, -0.1, 0.5 + 0.25 + gap));
      state.R.push_back(Mat3::Identity());
      state.v.push_back(Vec3::Zero());
      state.omega.push_back(Vec3::Zero());
      broad.add_body(i, model.shape.back(), i == 0, state.p.back(), state.R.back());
    }
    const auto pairs = broad.pairs(model, state, {0.0, 0.0}, 0.1);
    ASSERT_EQ(pairs.size(), 1u);
    Contact c;
    ASSERT_TRUE(broad.signed_distance(0, 1, c));
    EXPECT_LT((c.normal - Vec3::UnitZ()).norm(), 1e-9) << "gap " << gap;
    EXPECT_NEAR(c.gap, gap, 1e-6) << "gap " << gap;
  }
}

TEST(ConvexSphere, AgreesWithTheBoxFormulaOnABoxMesh) {
  // a box as a convex mesh and as a Box: two exact methods, one answer (rounding only), for
  // centres outside (faces, edges, corners) and inside the box, with the mesh as A and as B
  const Vec3 h(0.5, 0.3, 0.2);
  Points v(8, 3);
  for (int k = 0; k < 8; ++k) v.row(k) << ((k & 1) ? h.x() : -h.x()), ((k & 2) ? h.y() : -h.y()), ((k & 4) ? h.z() : -h.z());
  Triangles f(12, 3);
  f << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5;
  const Mesh mesh(v, f);
  const Mat3 R = math::quat_to_matrix(Quat4(0.7, -0.2, 0.4, 0.1).normalized());
  const Vec3 p(0.3, 0.2, -0.1);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int trial = 0; trial < 500; ++trial) {
    const Vec3 c = p + R * Vec3(U(rng), U(rng), U(rng));
    const bool mesh_is_a = trial % 2 == 0;
    const Contact exact = collision::box_sphere(0, p, R, h, 1, c, 0.1, mesh_is_a);
    const Contact got = collision::convex_sphere(0, p, R, mesh, 1, c, 0.1, mesh_is_a);
    EXPECT_NEAR(got.gap, exact.gap, 1e-12);
    EXPECT_LT((got.normal - exact.normal).norm(), 1e-12);
    EXPECT_LT((got.point - exact.point).norm(), 1e-12);
    EXPECT_EQ(got.body_a, exact.body_a);
  }
}
