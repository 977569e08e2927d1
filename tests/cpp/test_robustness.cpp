// Issue 8 in the core alone: a step whose energy explodes is undone and names the body; values too
// large or too small for double precision say so; a body that has crossed a triangle is pushed back.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "collision/collision.hpp"
#include "random_scene.hpp"
#include "signorini/world.hpp"

using namespace signorini;

namespace {

/// Explicit (forward Euler) gyroscopic step of a free body whose axes are the world's:
/// omega_1 = omega_0 - dt I^-1 (omega_0 x I omega_0).
Vec3 explicit_spin(const Vec3& I, const Vec3& w, double dt) {
  return w - dt * (w.cross(I.cwiseProduct(w))).cwiseQuotient(I);
}

}  // namespace

TEST(Robustness, AnEnergyExplosionIsUndoneAndNamesTheBody) {
  WorldSettings s;
  s.gravity = Vec3::Zero();
  s.solver.gyroscopic = Gyroscopic::Explicit;
  s.solver.substeps = 1;
  World world(s);
  BodyDesc d;
  const Vec3 h(0.5, 0.25, 0.1);
  d.shape = Box(h);
  d.mass = 1.0;
  world.add_body(d);
  const Vec3 w0(20.0, 20.0, 20.0);
  world.set_angular_velocity(0, w0);
  // the closed form: I = m/3 (b^2 + c^2, a^2 + c^2, a^2 + b^2) for half extents (a, b, c)
  const Vec3 I(h.y() * h.y() + h.z() * h.z(), h.x() * h.x() + h.z() * h.z(), h.x() * h.x() + h.y() * h.y());
  const Vec3 w1 = explicit_spin(I / 3.0, w0, 1.0);
  const double T0 = 0.5 * w0.dot((I / 3.0).cwiseProduct(w0)), T1 = 0.5 * w1.dot((I / 3.0).cwiseProduct(w1));
  ASSERT_GT(T1, World::kExplosionFactor * T0);
  try {
    world.step(1.0);
    FAIL() << "no explosion reported";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("energy explosion"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("body 0 (Box)"), std::string::npos) << e.what();
  }
  EXPECT_EQ(world.state().omega[0], w0);
  EXPECT_EQ(world.state().R[0], Mat3::Identity());
  EXPECT_EQ(world.state().time, 0.0);
}

// An undone step puts the warm-start cache back as it was, bit for bit: the guard keeps the cache
// the step started with by swapping buffers as the step's runs of rows end (StepGuard::swap_cache),
// so this holds after one substep's swap, after several, and after a soft step's.
TEST(Robustness, AnUndoneStepPutsTheWarmStartCacheBack) {
  for (SolverMethod method : {SolverMethod::PGS, SolverMethod::Soft}) {
    for (int substeps : {1, 4}) {
      WorldSettings s;
      s.solver.method = method;
      s.solver.substeps = substeps;
      s.solver.gyroscopic = Gyroscopic::Explicit;
      s.sleep.enabled = false;
      World world(s);
      BodyDesc ground;
      ground.shape = Plane(Vec3::UnitZ(), 0.0);
      ground.is_static = true;
      world.add_body(ground);
      BodyDesc box;  // resting on the ground: four contacts, each with its cache entry
      box.shape = Box(Vec3(0.5, 0.5, 0.5));
      box.mass = 1.0;
      box.position = Vec3(0.0, 0.0, 0.5);
      world.add_body(box);
      BodyDesc spinner;  // far away, spun so fast that its explicit gyroscopic step explodes
      spinner.shape = Box(Vec3(0.5, 0.25, 0.1));
      spinner.mass = 1.0;
      spinner.position = Vec3(20.0, 0.0, 5.0);
      world.add_body(spinner);
      for (int k = 0; k < 30; ++k) world.step(1.0 / 60.0);
      const std::vector<CachedContact> before = world.warm_start_cache();
      ASSERT_GE(before.size(), 4u);
      const State state = world.state();
      world.set_angular_velocity(2, Vec3(200.0, 200.0, 200.0));
      EXPECT_THROW(world.step(1.0), std::runtime_error) << "method " << static_cast<int>(method);
      const std::vector<CachedContact> after = world.warm_start_cache();
      ASSERT_EQ(after.size(), before.size());
      for (std::size_t k = 0; k < before.size(); ++k) {
        EXPECT_EQ(after[k].body_a, before[k].body_a);
        EXPECT_EQ(after[k].feature_a, before[k].feature_a);
        EXPECT_EQ(after[k].alpha, before[k].alpha);
        EXPECT_EQ(after[k].friction, before[k].friction);
      }
      EXPECT_EQ(world.state().p[1], state.p[1]);
      EXPECT_EQ(world.state().time, state.time);
    }
  }
}

TEST(Robustness, ShapesAndMassesBeyondDoublePrecisionSaySo) {
  World world;
  auto message = [&](const Shape& shape, double mass) -> std::string {
    BodyDesc d;
    d.shape = shape;
    d.mass = mass;
    try {
      world.add_body(d);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message(Sphere(1e308), 1.0).find("too large"), std::string::npos);
  EXPECT_NE(message(Sphere(1e-300), 1.0).find("too small"), std::string::npos);
  EXPECT_NE(message(Sphere(0.5), 1e-320).find("mass"), std::string::npos);
  EXPECT_NE(message(Sphere(0.5), 1e-320).find("too small"), std::string::npos);
  EXPECT_EQ(world.num_bodies(), 0u);
  EXPECT_EQ(message(Sphere(1.0), 1e300), "");  // finite inertia, though its determinant is not
  EXPECT_EQ(world.num_bodies(), 1u);
}

TEST(Robustness, ABodyThatCrossedATriangleIsPushedBackAlongItsNormal) {
  // a sphere whose centre is 1 cm below a triangle floor, inside a triangle: one contact, normal
  // +z, gap -(r + 1 cm); before, the one-sided test let it go
  const TriangleMesh floor = scenes::floor_mesh(2.0, 4);
  std::vector<Contact> out;
  collision::collide(floor, {}, Sphere(0.05), {Vec3(0.13, 0.21, -0.01), Mat3::Identity()}, 0.0, {}, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_LT((out[0].normal - Vec3::UnitZ()).norm(), 1e-15);
  EXPECT_NEAR(out[0].gap, -0.06, 1e-15);
}
