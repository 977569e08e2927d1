// Islands and sleeping (docs/conventions.md, "Sleeping"): when a resting body falls asleep, that it
// stays frozen bit for bit, what wakes it, bad settings, and saved states.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <string>

#include "random_scene.hpp"
#include "signorini/world.hpp"

using namespace signorini;
using scenes::ground;

namespace {

constexpr double kDt = 1.0 / 240.0;

WorldSettings sleeping(SolverMethod method = SolverMethod::PGS) {
  WorldSettings s;
  s.sleep.enabled = true;
  s.solver.method = method;
  return s;
}

/// A 0.2 m cube resting on the ground (its centre at z0 + 0.1) at x.
BodyDesc cube(double x, double z0 = 0.0) {
  BodyDesc d;
  d.shape = Box(Vec3(0.1, 0.1, 0.1));
  d.density = 1000.0;
  d.position = Vec3(x, 0.0, z0 + 0.1);
  return d;
}

/// The step after which a body at rest from the first step has a timer >= time_to_sleep: the timer
/// is the sum of the steps' dt, added in floating point as the world adds it.
int closed_form_sleep_step(double dt, double time_to_sleep) {
  double t = 0.0;
  int k = 0;
  while (!(t > 0.0 && t >= time_to_sleep)) t += dt, ++k;
  return k;
}

bool same_bytes(const Vec3& a, const Vec3& b) { return std::memcmp(a.data(), b.data(), sizeof(Vec3)) == 0; }
bool same_bytes(const Mat3& a, const Mat3& b) { return std::memcmp(a.data(), b.data(), sizeof(Mat3)) == 0; }

class Sleeping : public ::testing::TestWithParam<SolverMethod> {};

}  // namespace

TEST_P(Sleeping, ABoxAtRestSleepsAtTheClosedFormStepAndKeepsItsPoseBitForBit) {
  World w(sleeping(GetParam()));
  w.add_body(ground());
  w.add_body(cube(0.0));
  const int expected = closed_form_sleep_step(kDt, w.settings().sleep.time_to_sleep);
  ASSERT_EQ(expected, 121);  // 120 steps of 1/240 s sum to just under 0.5 s
  double t = 0.0;
  for (int k = 1; k < expected; ++k) {
    w.step(kDt);
    t += kDt;
    ASSERT_EQ(w.state().awake[1], 1) << "asleep after step " << k;
    ASSERT_EQ(w.state().sleep_time[1], t) << "not below the thresholds at step " << k;
  }
  w.step(kDt);
  EXPECT_EQ(w.state().awake[1], 0);
  EXPECT_EQ(w.state().v[1], Vec3::Zero());
  EXPECT_EQ(w.state().omega[1], Vec3::Zero());
  EXPECT_EQ(w.state().awake[0], 0) << "a static body never reads as awake";
  const Vec3 p = w.state().p[1];
  const Mat3 R = w.state().R[1];
  const Quat4 q = w.state().q[1];
  const double V = w.potential_energy();
  const std::vector<Contact> asleep = w.contacts();
  const Vec3 force = w.contact_forces()[1], support = w.contact_forces()[0];
  ASSERT_EQ(asleep.size(), 4u);
  const double weight = 1000.0 * 0.008 * 9.81;  // a 0.2 m cube of 1000 kg/m^3
  EXPECT_NEAR(force.z(), weight, 1e-3 * weight);
  for (int k = 0; k < 2000; ++k) w.step(kDt);
  EXPECT_EQ(w.detect_contacts(kDt).size(), 0u) << "a sleeping pair is not detected";
  // the contacts and forces reported are those it fell asleep with, bit for bit
  const std::vector<Contact> now = w.contacts();
  ASSERT_EQ(now.size(), asleep.size());
  for (std::size_t k = 0; k < now.size(); ++k) {
    EXPECT_EQ(now[k].alpha, asleep[k].alpha);
    EXPECT_TRUE(same_bytes(now[k].force, asleep[k].force));
    EXPECT_TRUE(same_bytes(now[k].point, asleep[k].point));
  }
  EXPECT_TRUE(same_bytes(w.contact_forces()[1], force));
  EXPECT_LT((w.contact_forces()[0] + force).norm(), 1e-12 * weight) << "the ground's reaction";
  EXPECT_LT((support - w.contact_forces()[0]).norm(), 1e-12 * weight);
  EXPECT_TRUE(same_bytes(p, w.state().p[1]));
  EXPECT_TRUE(same_bytes(R, w.state().R[1]));
  EXPECT_EQ(std::memcmp(q.data(), w.state().q[1].data(), sizeof(Quat4)), 0);
  EXPECT_EQ(w.kinetic_energy(), 0.0);
  EXPECT_EQ(w.potential_energy(), V);
}

TEST_P(Sleeping, AnIslandWakesWhenAMovingBodyTouchesItAndNotAnother) {
  World w(sleeping(GetParam()));
  w.add_body(ground());
  // two stacks of two cubes 2 m apart: two islands (the ground joins none)
  for (double x : {0.0, 2.0}) {
    w.add_body(cube(x));
    w.add_body(cube(x, 0.2));
  }
  w.step(kDt, 240);
  for (int i = 1; i <= 4; ++i) ASSERT_EQ(w.state().awake[i], 0) << i;
  const Vec3 far_p = w.state().p[4];
  BodyDesc ball;
  ball.shape = Sphere(0.05);
  ball.density = 1000.0;
  ball.position = Vec3(0.0, 0.0, 0.6);
  const BodyIndex b = w.add_body(ball);
  bool woke = false;
  for (int k = 0; k < 120 && !woke; ++k) {
    w.step(kDt);
    woke = w.state().awake[1] == 1;
  }
  EXPECT_TRUE(woke);
  EXPECT_EQ(w.state().awake[2], 1) << "the touched island wakes whole";
  EXPECT_EQ(w.state().awake[b], 1);
  EXPECT_EQ(w.state().awake[3], 0);
  EXPECT_EQ(w.state().awake[4], 0);
  EXPECT_TRUE(same_bytes(far_p, w.state().p[4]));
}

TEST_P(Sleeping, EveryWakingCallWakesTheIsland) {
  using Call = void (*)(World&);
  const Call calls[] = {
      [](World& w) { w.apply_impulse(2, Vec3(0, 0, 0.01)); },
      [](World& w) { w.apply_force(2, Vec3(0, 0, 0.01)); },
      [](World& w) { w.set_external_wrench(2, Vec3(0, 0, 0.01), Vec3::Zero()); },
      [](World& w) { w.set_position(2, w.state().p[2]); },
      [](World& w) { w.set_orientation(2, w.state().q[2]); },
      [](World& w) { w.set_velocity(2, Vec3::Zero()); },
      [](World& w) { w.set_angular_velocity(2, Vec3::Zero()); },
      [](World& w) { w.set_material(2, Material()); },
      [](World& w) { w.set_enabled(2, true); },
      [](World& w) { w.set_collision_filter(2, CollisionFilter()); },
      [](World& w) { w.set_pair_collision(2, 0, true); },
      [](World& w) { w.set_awake(2, true); },
      [](World& w) { w.set_can_sleep(2, false); },
      [](World& w) { w.remove_body(0); },  // the ground goes: the stack falls
      [](World& w) { w.set_material(0, Material{0.1, 0.0, 0.0}); },  // the ground changes
      [](World& w) { w.set_position(0, Vec3(0.0, 0.0, -0.1)); },     // the ground moves
      [](World& w) {
        WorldSettings s = w.settings();
        s.gravity = Vec3(0.0, 0.0, -9.8);
        w.set_settings(s);
      },
      [](World& w) {
        WorldSettings s = w.settings();
        s.sleep.enabled = false;
        w.set_settings(s);
      },
  };
  int n = 0;
  for (Call call : calls) {
    World w(sleeping(GetParam()));
    w.add_body(ground());
    w.add_body(cube(0.0));
    w.add_body(cube(0.0, 0.2));
    w.step(kDt, 240);
    ASSERT_EQ(w.state().awake[1] + w.state().awake[2], 0);
    call(w);
    const std::size_t first = w.num_bodies() == 2 ? 0 : 1;  // after the ground's removal
    EXPECT_EQ(w.state().awake[first], 1) << "call " << n;
    EXPECT_EQ(w.state().awake[first + 1], 1) << "call " << n;
    EXPECT_EQ(w.state().sleep_time[first], 0.0) << "call " << n;
    ++n;
  }
}

TEST_P(Sleeping, SetAwakeFalseSleepsTheIslandAndCanSleepFalseNeverSleeps) {
  World w(sleeping(GetParam()));
  w.add_body(ground());
  w.add_body(cube(0.0));
  w.add_body(cube(0.0, 0.2));
  BodyDesc lone = cube(2.0);
  lone.can_sleep = false;
  w.add_body(lone);
  w.step(kDt);
  w.set_awake(2, false);
  EXPECT_EQ(w.state().awake[1], 0);
  EXPECT_EQ(w.state().awake[2], 0);
  EXPECT_EQ(w.state().v[1], Vec3::Zero());
  EXPECT_EQ(w.state().awake[3], 1);
  try {
    w.set_awake(3, false);
    FAIL() << "a body that cannot sleep was put to sleep";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("body 3 (Box)"), std::string::npos) << e.what();
  }
  EXPECT_EQ(w.state().awake[3], 1);
  EXPECT_THROW(w.set_awake(0, true), std::invalid_argument);  // static
  w.step(kDt, 1200);
  EXPECT_EQ(w.state().awake[3], 1) << "can_sleep false slept";
  EXPECT_GT(w.state().sleep_time[3], 0.0) << "its timer still runs (it is at rest)";
}

TEST_P(Sleeping, ASavedStateMidSleepStepsOnBitForBit) {
  auto build = [] {
    auto w = std::make_unique<World>(sleeping(GetParam()));
    w->add_body(ground());
    w->add_body(cube(0.0));
    w->add_body(cube(0.0, 0.2));
    BodyDesc ball;
    ball.shape = Sphere(0.05);
    ball.density = 1000.0;
    ball.position = Vec3(0.02, 0.0, 3.0);  // lands on the stack after it has fallen asleep
    w->add_body(ball);
    return w;
  };
  auto a = build();
  a->step(kDt, 150);  // the stack asleep, the ball falling, its timer at 0
  ASSERT_EQ(a->state().awake[1], 0);
  const std::string saved = a->save_state();
  bool woke = false;  // the ball lands and wakes the stack after the save
  for (int k = 0; k < 400; ++k) {
    a->step(kDt);
    woke = woke || a->state().awake[1] == 1;
  }
  EXPECT_TRUE(woke);
  auto b = build();
  b->restore_state(saved);
  b->step(kDt, 400);
  ASSERT_EQ(a->state().awake, b->state().awake);
  ASSERT_EQ(a->state().sleep_time, b->state().sleep_time);
  for (std::size_t i = 0; i < a->num_bodies(); ++i) {
    EXPECT_TRUE(same_bytes(a->state().p[i], b->state().p[i])) << i;
    EXPECT_TRUE(same_bytes(a->state().v[i], b->state().v[i])) << i;
  }
  EXPECT_EQ(a->save_state(), b->save_state());
}

INSTANTIATE_TEST_SUITE_P(BothSolvers, Sleeping, ::testing::Values(SolverMethod::PGS, SolverMethod::Soft),
                         [](const auto& info) { return info.param == SolverMethod::PGS ? "PGS" : "Soft"; });

TEST(SleepSettings, BadThresholdsAreRefusedNamingTheSettingAndChangeNothing) {
  World w(sleeping());
  const WorldSettings before = w.settings();
  const std::pair<const char*, double SleepSettings::*> fields[] = {
      {"sleep_linear_velocity", &SleepSettings::linear_velocity},
      {"sleep_angular_velocity", &SleepSettings::angular_velocity},
      {"time_to_sleep", &SleepSettings::time_to_sleep}};
  for (const auto& [name, field] : fields)
    for (double bad : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
      WorldSettings s = before;
      s.sleep.*field = bad;
      try {
        w.set_settings(s);
        FAIL() << name << " = " << bad << " accepted";
      } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      }
      EXPECT_EQ(w.settings().sleep.*field, before.sleep.*field);
      EXPECT_THROW(World{s}, std::invalid_argument);
    }
}
