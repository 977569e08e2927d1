// Joints on the core alone (docs/conventions.md, "Joints"): a simple pendulum on a hinge against
// its small-angle period, in both solvers, a ball joint's twist limit, and what add_joint refuses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "signorini/world.hpp"

using namespace signorini;

namespace {

constexpr double kG = 9.81;

/// A 1 kg point-like bob (sphere of 1 cm) 1 m below a hinge about y at the origin, on a static
/// plane far below (the world), pulled theta0 aside; returns the bob's index.
BodyIndex pendulum(World& w, double theta0) {
  BodyDesc ground;
  ground.is_static = true;
  ground.shape = Plane(Vec3(0, 0, 1), -100.0);
  const BodyIndex g = w.add_body(ground);
  BodyDesc bob;
  bob.shape = Sphere(0.01);
  bob.mass = 1.0;
  bob.position = Vec3(std::sin(theta0), 0.0, -std::cos(theta0));
  const BodyIndex b = w.add_body(bob);
  JointDesc hinge;
  hinge.kind = JointKind::Revolute;
  hinge.body_a = g;
  hinge.body_b = b;
  hinge.anchor = Vec3::Zero();
  hinge.axis = Vec3::UnitY();
  EXPECT_EQ(w.add_joint(hinge), 0);
  return b;
}

WorldSettings settings(SolverMethod method) {
  WorldSettings s;
  s.gravity = Vec3(0, 0, -kG);
  s.sleep.enabled = false;
  s.solver.method = method;
  return s;
}

}  // namespace

class PendulumOnTheCore : public ::testing::TestWithParam<SolverMethod> {};

TEST_P(PendulumOnTheCore, SmallAnglePeriod) {
  // 0.05 rad: T = 2 pi sqrt(L / g) (1 + theta0^2 / 16 + ...), within 0.5 %; the hinge's angle is
  // the bob's angle from where it was made (B = the bob turns about +y as it swings towards -x)
  World w(settings(GetParam()));
  const BodyIndex b = pendulum(w, 0.05);
  const double dt = 1.0 / 240.0;
  std::vector<double> crossings;
  double x_before = w.state().p[b].x();
  for (int k = 0; k < 5 * 240; ++k) {
    w.step(dt);
    const double x = w.state().p[b].x();
    if (x_before > 0.0 && x <= 0.0) crossings.push_back(w.state().time - dt * x / (x - x_before));
    x_before = x;
    const double theta = std::atan2(-x, -w.state().p[b].z()) + 0.05;
    ASSERT_NEAR(w.joint_positions()[0], theta, 2e-4);
  }
  ASSERT_GE(crossings.size(), 2u);
  const double expected = 2.0 * M_PI * std::sqrt(1.0 / kG);
  for (std::size_t k = 1; k < crossings.size(); ++k)
    EXPECT_NEAR(crossings[k] - crossings[k - 1], expected, 5e-3 * expected);
  // the bob stays 1 m from the hinge (PGS to 1e-5 m, the soft step's 60 Hz spring to 1e-4 m)
  EXPECT_NEAR(w.state().p[b].norm(), 1.0, 1e-4);
}

TEST_P(PendulumOnTheCore, SavedStateContinuesBitIdentical) {
  World w(settings(GetParam()));
  const BodyIndex b = pendulum(w, 1.0);
  w.step(1.0 / 240.0, 50);
  const std::string saved = w.save_state();
  w.step(1.0 / 240.0, 50);
  const Vec3 p = w.state().p[b], v = w.state().v[b], f = w.joint_forces()[0];
  w.restore_state(saved);
  w.step(1.0 / 240.0, 50);
  EXPECT_EQ(w.state().p[b], p);
  EXPECT_EQ(w.state().v[b], v);
  EXPECT_EQ(w.joint_forces()[0], f);
}

INSTANTIATE_TEST_SUITE_P(Solvers, PendulumOnTheCore, ::testing::Values(SolverMethod::PGS, SolverMethod::Soft));

TEST(Joints, BadInputNamesTheJointAndChangesNothing) {
  World w(settings(SolverMethod::PGS));
  pendulum(w, 0.0);
  const std::string before = w.save_state();
  JointDesc d;
  d.kind = JointKind::Revolute;
  d.body_a = 0;
  d.body_b = 1;
  d.axis = Vec3::Zero();
  try {
    w.add_joint(d);
    FAIL() << "a zero axis was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("joint 1 (Revolute): axis must be a non-zero vector"), std::string::npos)
        << e.what();
  }
  d.axis = Vec3::UnitZ();
  d.body_b = 7;
  EXPECT_THROW(w.add_joint(d), BodyIndexError);
  d.body_b = 1;
  d.has_limits = true;
  d.lower = 1.0;
  d.upper = -1.0;
  EXPECT_THROW(w.add_joint(d), std::invalid_argument);
  // a ball joint's twist limits: lower <= upper, inside (-pi, pi), and only on a ball joint
  d.kind = JointKind::Spherical;
  d.has_limits = false;
  d.has_twist = true;
  d.twist_lower = 0.5;
  d.twist_upper = 0.4;
  try {
    w.add_joint(d);
    FAIL() << "twist limits lower > upper were accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("joint 1 (Spherical): a ball joint's twist limits need lower <= upper"),
              std::string::npos)
        << e.what();
  }
  d.twist_lower = -M_PI;
  EXPECT_THROW(w.add_joint(d), std::invalid_argument);
  d.kind = JointKind::Revolute;
  d.twist_lower = -0.3;
  EXPECT_THROW(w.add_joint(d), std::invalid_argument);
  EXPECT_EQ(w.num_joints(), 1u);
  EXPECT_EQ(w.save_state(), before);
}

class TwistOnTheCore : public ::testing::TestWithParam<SolverMethod> {};

TEST_P(TwistOnTheCore, ASpunRodStopsAtItsTwistLimit) {
  // a 1 kg rod hanging from a ball joint, spun at 2 rad/s about its own axis (-z, the joint's axis)
  // with no torque on it: it twists freely, psi = 2 t, to the 0.4 rad limit and stops there (the
  // PGS's rigid row within 1e-6 rad, the soft step's spring within 1 degree)
  World w(settings(GetParam()));
  BodyDesc ground;
  ground.is_static = true;
  ground.shape = Plane(Vec3(0, 0, 1), -100.0);
  const BodyIndex g = w.add_body(ground);
  BodyDesc rod;
  rod.shape = Box(Vec3(0.05, 0.02, 0.5));
  rod.mass = 1.0;
  rod.position = Vec3(0, 0, -0.5);
  rod.angular_velocity = Vec3(0, 0, -2.0);
  const BodyIndex b = w.add_body(rod);
  JointDesc ball;
  ball.kind = JointKind::Spherical;
  ball.body_a = g;
  ball.body_b = b;
  ball.axis = Vec3(0, 0, -1);
  ball.has_twist = true;
  ball.twist_lower = -0.3;
  ball.twist_upper = 0.4;
  w.add_joint(ball);
  const double dt = 1.0 / 240.0, tolerance = GetParam() == SolverMethod::PGS ? 1e-6 : M_PI / 180.0;
  double largest = 0.0;
  for (int k = 1; k <= 480; ++k) {
    w.step(dt);
    // the rod turns about z only: psi is its turn about -z
    const Mat3& R = w.state().R[b];
    const double psi = -std::atan2(R(1, 0), R(0, 0));
    if (2.0 * k * dt < 0.4 - 2.0 * dt) EXPECT_NEAR(psi, 2.0 * k * dt, 1e-9);
    largest = std::max(largest, psi);
  }
  const double psi = -std::atan2(w.state().R[b](1, 0), w.state().R[b](0, 0));
  EXPECT_LT(largest, 0.4 + tolerance);
  EXPECT_NEAR(psi, 0.4, tolerance);
  EXPECT_LT(std::abs(w.state().omega[b].z()), 1e-3);
}

INSTANTIATE_TEST_SUITE_P(Solvers, TwistOnTheCore, ::testing::Values(SolverMethod::PGS, SolverMethod::Soft));

TEST(JointSubsteps, TheSoftStepRunsAWorldWithAJointInSubstepsForItsJointHertz) {
  // the soft step's contacts take substeps of at most 1/240 s; a joint's spring holds only up to a
  // quarter of the substep rate, so a world with an unbroken joint takes at most 0.25 / joint_hertz
  // (1/960 s at the default 240 Hz); the PGS's 1/960 s are the same with or without joints
  World w(settings(SolverMethod::Soft));
  BodyDesc ground;
  ground.is_static = true;
  ground.shape = Plane(Vec3(0, 0, 1), -100.0);
  w.add_body(ground);
  EXPECT_EQ(w.substep_count(1.0 / 60.0), 4);
  pendulum(w, 0.0);
  EXPECT_EQ(w.substep_count(1.0 / 60.0), 16);
  EXPECT_EQ(w.substep_count(1.0 / 240.0), 4);
  EXPECT_EQ(w.substep_count(1.0 / 1000.0), 1);
  WorldSettings s = w.settings();
  s.solver.joint_hertz = 60.0;
  w.set_settings(s);
  EXPECT_EQ(w.substep_count(1.0 / 60.0), 4);
  s.solver.joint_hertz = 480.0;
  w.set_settings(s);
  EXPECT_EQ(w.substep_count(1.0 / 60.0), 32);
  w.set_joint_broken(0, true);  // a broken joint makes no rows: the contacts' substeps again
  EXPECT_EQ(w.substep_count(1.0 / 60.0), 4);
  s.solver.method = SolverMethod::PGS;
  w.set_settings(s);
  EXPECT_EQ(w.substep_count(1.0 / 60.0), 16);
  EXPECT_THROW(w.substep_count(0.0), std::invalid_argument);
  EXPECT_THROW(w.substep_count(std::nan("")), std::invalid_argument);
}
