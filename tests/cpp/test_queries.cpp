// Ray casts against each analytic shape (collision/ray.hpp) by their closed forms, written here
// because FCL 0.7 has no ray query to compare with: the sphere's quadratic, the box's slabs, the
// capsule's side and end balls, the cylinder's caps and side, the plane's one division. Then a
// World: queries between steps leave the steps bit for bit as they were.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "collision/ray.hpp"
#include "math/rotation.hpp"
#include "signorini/world.hpp"

using namespace signorini;
using collision::Pose;
using collision::Ray;
using collision::RayResult;

namespace {

constexpr double kRel = 1e-12;  // a few dozen roundings of ~1e-16 on distances of a few metres

bool cast(const Shape& s, const Pose& pose, const Vec3& o, const Vec3& d, RayResult& r, double t_max = INFINITY) {
  std::vector<int> stack;
  return collision::ray_shape(s, pose, Ray{o, d.normalized(), t_max}, nullptr, stack, r);
}

Mat3 random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return math::quat_to_matrix(Quat4(g(rng), g(rng), g(rng), g(rng)).normalized());
}

}  // namespace

TEST(RayShape, SphereQuadratic) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double r = 0.6;
  const Pose pose{Vec3(0.2, -0.4, 1.0), random_rotation(rng)};
  int hits = 0;
  for (int k = 0; k < 500; ++k) {
    const Vec3 o = pose.p + 4.0 * Vec3(u(rng), u(rng), u(rng)).normalized();
    const Vec3 d = (pose.p + Vec3(u(rng), u(rng), u(rng)) - o).normalized();
    // the textbook roots of t^2 + 2 b t + c = 0
    const double b = (o - pose.p).dot(d), c = (o - pose.p).squaredNorm() - r * r, disc = b * b - c;
    RayResult res;
    const bool hit = cast(Sphere(r), pose, o, d, res);
    ASSERT_EQ(hit, disc >= 0.0 && b < 0.0) << k;
    if (!hit) continue;
    ++hits;
    const double t = -b - std::sqrt(disc);
    EXPECT_NEAR(res.t, t, kRel * t);
    EXPECT_NEAR((o + res.t * d - pose.p).norm(), r, 1e-12);
    EXPECT_LT((res.normal - (o + res.t * d - pose.p) / r).norm(), 1e-12);
  }
  EXPECT_GT(hits, 100);
}

TEST(RayShape, BoxSlabsFacesAndInside) {
  const Box box(Vec3(0.5, 0.3, 0.2));
  const Pose pose{Vec3(1, 0, 0), Mat3::Identity()};
  RayResult r;
  ASSERT_TRUE(cast(box, pose, Vec3(1.1, 0.1, 5), Vec3(0, 0, -1), r));
  EXPECT_NEAR(r.t, 4.8, kRel * 4.8);
  EXPECT_EQ(r.feature, feature_id(FeatureKind::Face, 5));
  EXPECT_EQ(r.normal, Vec3(0, 0, 1));
  // a slanted ray through the -x face: t = (x_face - x_o) / u_x
  const Vec3 d = Vec3(1.0, 0.05, 0.02).normalized();
  ASSERT_TRUE(cast(box, pose, Vec3(-3, 0, 0), d, r));
  EXPECT_NEAR(r.t, 3.5 / d.x(), kRel * 3.5 / d.x());
  EXPECT_EQ(r.feature, feature_id(FeatureKind::Face, 0));
  EXPECT_FALSE(cast(box, pose, Vec3(-3, 0.31, 0), Vec3(1, 0, 0), r));
  EXPECT_FALSE(cast(box, pose, Vec3(-3, 0, 0), Vec3(1, 0, 0), r, 3.49));
  ASSERT_TRUE(cast(box, pose, Vec3(1.2, 0.1, 0.1), Vec3(0, 1, 0), r));
  EXPECT_TRUE(r.inside);
  EXPECT_EQ(r.t, 0.0);
  EXPECT_EQ(r.normal, Vec3(0, -1, 0));
  // on the surface: in at 0, out misses
  ASSERT_TRUE(cast(box, pose, Vec3(1.5, 0, 0), Vec3(-1, 0, 0), r));
  EXPECT_EQ(r.t, 0.0);
  EXPECT_FALSE(r.inside);
  EXPECT_FALSE(cast(box, pose, Vec3(1.5, 0, 0), Vec3(1, 0, 0), r));
}

TEST(RayShape, CapsuleSideAndEndBalls) {
  const double r = 0.25, h = 0.5;
  const Capsule cap(r, h);
  const Pose pose;
  RayResult res;
  ASSERT_TRUE(cast(cap, pose, Vec3(-3, 0.1, 0.3), Vec3(1, 0, 0), res));
  const double side = 3 - std::sqrt(r * r - 0.01);
  EXPECT_NEAR(res.t, side, kRel * side);
  EXPECT_EQ(res.feature, feature_id(FeatureKind::Edge, 0));
  ASSERT_TRUE(cast(cap, pose, Vec3(0.1, 0, 3), Vec3(0, 0, -1), res));
  const double top = 3 - h - std::sqrt(r * r - 0.01);
  EXPECT_NEAR(res.t, top, kRel * top);
  EXPECT_EQ(res.feature, feature_id(FeatureKind::Vertex, 1));
  ASSERT_TRUE(cast(cap, pose, Vec3(0, 0, -3), Vec3(0, 0, 1), res));
  EXPECT_EQ(res.feature, feature_id(FeatureKind::Vertex, 0));
  // into the end ball from the side, past the segment's end: the ball's quadratic about (0, 0, h)
  const Vec3 o(-3, 0, h + 0.1);
  ASSERT_TRUE(cast(cap, pose, o, Vec3(1, 0, 0), res));
  const double ball = 3 - std::sqrt(r * r - 0.01);
  EXPECT_NEAR(res.t, ball, kRel * ball);
  EXPECT_EQ(res.feature, feature_id(FeatureKind::Vertex, 1));
  EXPECT_FALSE(cast(cap, pose, Vec3(-3, 0, h + r + 1e-9), Vec3(1, 0, 0), res));
}

TEST(RayShape, CylinderCapsAndSide) {
  const double r = 0.4, h = 0.3;
  const Cylinder cyl(r, h);
  std::mt19937 rng(2);
  const Mat3 R = random_rotation(rng);
  const Pose pose{Vec3(0, 1, 0), R};
  RayResult res;
  // along the axis onto the top cap
  const Vec3 a = R.col(2);
  ASSERT_TRUE(cast(cyl, pose, pose.p + 3.0 * a + 0.1 * R.col(0), -a, res));
  EXPECT_NEAR(res.t, 3 - h, kRel * (3 - h));
  EXPECT_EQ(res.feature, feature_id(FeatureKind::Face, 1));
  EXPECT_LT((res.normal - a).norm(), 1e-15);
  // across the axis onto the side, off by y0 from it
  const double y0 = 0.2;
  ASSERT_TRUE(cast(cyl, pose, pose.p - 3.0 * R.col(0) + y0 * R.col(1), R.col(0), res));
  const double side = 3 - std::sqrt(r * r - y0 * y0);
  EXPECT_NEAR(res.t, side, kRel * side);
  EXPECT_EQ(res.feature, feature_id(FeatureKind::Face, 2));
  EXPECT_FALSE(cast(cyl, pose, pose.p - 3.0 * R.col(0) + (h + 1e-9) * a, R.col(0), res));
}

TEST(RayShape, PlaneOneDivision) {
  const Plane plane(Vec3(0, 0, 1), 0.5);
  const Pose pose{Vec3(0, 0, 1), Mat3::Identity()};  // surface z = 1.5
  RayResult res;
  const Vec3 d = Vec3(0.3, 0.1, -1).normalized();
  ASSERT_TRUE(cast(plane, pose, Vec3(0, 0, 4), d, res));
  EXPECT_NEAR(res.t, 2.5 / -d.z(), kRel * 2.5 / -d.z());
  EXPECT_FALSE(cast(plane, pose, Vec3(0, 0, 4), -d, res));
  ASSERT_TRUE(cast(plane, pose, Vec3(0, 0, 1), d, res));
  EXPECT_TRUE(res.inside);
}

TEST(RayShape, QuadraticRootsHaveNoCancellation) {
  // t^2 - 2e8 t + 1 = 0: the small root 5e-9 is lost by the textbook formula, kept here
  double t0, t1;
  collision::quadratic_roots(1.0, -1e8, 1.0, 1e16 - 1.0, t0, t1);
  EXPECT_NEAR(t0, 5e-9, 1e-12 * 5e-9);
  EXPECT_NEAR(t1, 2e8, 1e-12 * 2e8);
}

TEST(WorldQueries, QueriesBetweenStepsLeaveTheStepsUnchanged) {
  auto build = [](World& w) {
    BodyDesc ground;
    ground.shape = Plane(Vec3::UnitZ(), 0.0);
    ground.is_static = true;
    w.add_body(ground);
    for (int k = 0; k < 12; ++k) {
      BodyDesc d;
      d.shape = k % 2 ? Shape(Box(Vec3(0.2, 0.2, 0.2))) : Shape(Sphere(0.2));
      d.density = 500.0;
      d.position = Vec3(0.1 * (k % 3), 0.05 * k, 0.3 + 0.45 * k);
      w.add_body(d);
      BodyDesc s;
      s.shape = Box(Vec3(0.3, 0.3, 0.3));
      s.is_static = true;
      s.position = Vec3(2.0 + k, 0, 0.3);
      w.add_body(s);
    }
  };
  World plain, queried;
  build(plain);
  build(queried);
  for (int step = 0; step < 200; ++step) {
    plain.step(1.0 / 120.0);
    queried.step(1.0 / 120.0);
    for (int k = 0; k < 5; ++k) queried.cast_ray(Vec3(0.1 * k, 0, 8), Vec3(0, 0, -1), INFINITY);
    queried.overlap_aabb(Vec3(-1, -1, 0), Vec3(1, 1, 1));
  }
  for (std::size_t i = 0; i < plain.num_bodies(); ++i) {
    EXPECT_EQ(std::memcmp(plain.state().p[i].data(), queried.state().p[i].data(), sizeof(Vec3)), 0) << i;
    EXPECT_EQ(std::memcmp(plain.state().R[i].data(), queried.state().R[i].data(), sizeof(Mat3)), 0) << i;
  }
}
