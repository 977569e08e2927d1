// The World: validation that leaves the world unchanged, pipeline order, resting and momentum.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <random>
#include <set>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "random_scene.hpp"
#include "signorini/mass_properties.hpp"
#include "signorini/world.hpp"

using namespace signorini;
using scenes::ground;

namespace {

BodyDesc box_at(double z) {
  BodyDesc d;
  d.shape = Box(Vec3(0.5, 0.5, 0.5));
  d.density = 1000.0;
  d.position = Vec3(0, 0, z);
  return d;
}

}  // namespace

TEST(World, BadBodiesAreRejectedAndTheWorldIsUnchanged) {
  World world;
  world.add_body(ground());
  BodyDesc bad = box_at(1.0);
  bad.position.x() = std::nan("");
  EXPECT_THROW(world.add_body(bad), std::invalid_argument);
  bad = box_at(1.0);
  bad.density = -1.0;
  try {
    world.add_body(bad);
    FAIL() << "negative density accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("body 1 (Box)"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("density"), std::string::npos) << e.what();
  }
  bad = box_at(1.0);
  bad.orientation = Quat4::Zero();
  EXPECT_THROW(world.add_body(bad), std::invalid_argument);
  bad = box_at(1.0);
  bad.mass = 3.0;  // both mass and density
  EXPECT_THROW(world.add_body(bad), std::invalid_argument);
  BodyDesc dynamic_plane = ground();
  dynamic_plane.is_static = false;
  dynamic_plane.mass = 1.0;
  EXPECT_THROW(world.add_body(dynamic_plane), std::invalid_argument);
  EXPECT_EQ(world.num_bodies(), 1u);
  EXPECT_EQ(world.state().p.size(), 1u);
  EXPECT_THROW(world.step(0.0), std::invalid_argument);
  EXPECT_THROW(world.step(std::nan("")), std::invalid_argument);
  EXPECT_THROW(world.set_velocity(5, Vec3::Zero()), std::out_of_range);
  EXPECT_EQ(world.state().time, 0.0);
}

TEST(World, NonUnitQuaternionIsNormalised) {
  World world;
  BodyDesc d = box_at(1.0);
  d.orientation = Quat4(2.0, 0.0, 0.0, 0.0);
  world.add_body(d);
  EXPECT_LT((world.state().R[0] - Mat3::Identity()).norm(), 1e-15);
}

TEST(World, BoxDroppedOnPlaneRestsAtHalfHeight) {
  // 0.5 m above rest, 1/240 s steps: after 3 s it must lie still at z = 0.5 (speculative contacts
  // stop it at gap 0 up to the linearisation of the corner motion; 1 mm is the bound)
  World world;
  world.add_body(ground());
  world.add_body(box_at(1.0));
  world.step(1.0 / 240.0, 720);
  EXPECT_NEAR(world.state().p[1].z(), 0.5, 1e-3);
  EXPECT_LT(world.state().v[1].norm(), 1e-6);
  EXPECT_EQ(world.contacts().size(), 4u);
  EXPECT_TRUE(world.solver_stats().converged);
  // and it does not sink over the next 10 s
  double lowest = 1.0;
  for (int k = 0; k < 2400; ++k) {
    world.step(1.0 / 240.0);
    lowest = std::min(lowest, world.state().p[1].z());
  }
  EXPECT_GT(lowest, 0.5 - 1e-3);
}

TEST(World, SoftStepRestsABoxOnFourSpringsAtTheClosedFormOverlap) {
  // the soft step (docs/conventions.md, "The soft step"): a unit box on a plane rests on four
  // equal springs of 2 x 30 Hz (a static contact is twice as stiff); each corner carries m g / 4
  // with m_eff = m / 4, so the box overlaps the plane by g / omega^2, omega = 2 pi 60, and the
  // step's impulse over dt is the weight
  WorldSettings settings;
  settings.solver.method = SolverMethod::Soft;
  // awake throughout: the box creeps onto its springs' rest slower than the sleep thresholds, and
  // would fall asleep short of it (docs/conventions.md, "Sleeping", Default)
  settings.sleep.enabled = false;
  World world(settings);
  world.add_body(ground());
  world.add_body(box_at(0.5));
  const double dt = 1.0 / 60.0, m = 1000.0, g = 9.81;
  world.step(dt, 300);
  const double omega = 2.0 * M_PI * 60.0;
  EXPECT_NEAR((0.5 - world.state().p[1].z()) / (g / (omega * omega)), 1.0, 1e-9);
  ASSERT_EQ(world.contacts().size(), 4u);
  double impulse = 0.0;
  for (const Contact& c : world.contacts()) {
    EXPECT_NEAR(c.alpha / (m * g / 4.0), 1.0, 1e-12);
    impulse += c.impulse;
  }
  EXPECT_NEAR(impulse / dt / (m * g), 1.0, 1e-12);
  EXPECT_EQ(world.settings().solver.substep_count(dt), 4);  // at most 1/240 s each
  // and the same world stepped again gives the same bits
  World again(settings);
  again.add_body(ground());
  again.add_body(box_at(0.5));
  again.step(dt, 300);
  EXPECT_EQ(again.state().p[1], world.state().p[1]);
}

TEST(World, SoftStepSettingsOutOfRangeAreRefusedAndTheWorldIsUnchanged) {
  World world;
  for (int k = 0; k < 7; ++k) {
    WorldSettings bad;
    bad.solver.method = SolverMethod::Soft;
    if (k == 0) bad.solver.contact_hertz = 0.0;
    if (k == 1) bad.solver.damping_ratio = std::nan("");
    if (k == 2) bad.solver.soft_iterations = 0;
    if (k == 3) bad.solver.relax_iterations = -1;
    if (k == 4) bad.solver.joint_hertz = -60.0;
    if (k == 5) bad.solver.joint_hertz = std::numeric_limits<double>::infinity();
    if (k == 6) bad.solver.joint_damping_ratio = -1.0;
    EXPECT_THROW(world.set_settings(bad), std::invalid_argument) << k;
    EXPECT_EQ(world.settings().solver.method, SolverMethod::PGS);
  }
}

/// A 20 x 20 grid of tilted box stacks of 3 falling on a plane: every colour of the solve order
/// holds more contacts than one task takes (rows::kContactsPerTask), so the colours are split over
/// threads. The state after 40 steps, as bytes.
std::vector<double> grid_of_stacks(const WorldSettings& settings) {
  World world(settings);
  world.add_body(ground());
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j)
      for (int k = 0; k < 3; ++k) {
        BodyDesc d = box_at(0.55 + 1.05 * k);
        d.position.x() = 1.2 * i + 0.03 * k;
        d.position.y() = 1.2 * j;
        d.orientation = Quat4(1.0, 0.01 * (i % 3), 0.01 * (j % 2), 0.02 * k);
        world.add_body(d);
      }
  world.step(1.0 / 60.0, 40);
  return scenes::motion_bytes(world);
}

TEST(World, EveryThreadCountGivesTheBitsOfOneThread) {
  for (SolverMethod method : {SolverMethod::PGS, SolverMethod::Soft}) {
    WorldSettings settings;
    settings.solver.method = method;
    settings.solver.max_iterations = 5;  // the PGS: a fixed number of sweeps, so that it is quick
    settings.threads = 1;
    const std::vector<double> one = grid_of_stacks(settings);
    for (int threads : {2, 3, 8, 0}) {  // 3 and 8: more threads than this machine has cores
      settings.threads = threads;
      EXPECT_EQ(grid_of_stacks(settings), one) << "threads " << threads << ", method " << static_cast<int>(method);
    }
  }
}

TEST(World, ThreadsBelowZeroAreRefusedAndTheWorldIsUnchanged) {
  WorldSettings settings;
  settings.threads = 2;
  World world(settings);
  EXPECT_EQ(world.settings().threads, 2);
  settings.threads = -1;
  EXPECT_THROW(world.set_settings(settings), std::invalid_argument);
  EXPECT_EQ(world.settings().threads, 2);
  settings.threads = 0;  // the machine's cores
  world.set_settings(settings);
  EXPECT_GE(world.settings().threads, 1);
}

// Bodies added one after another with the same hull share its polytope moved to their centre of
// mass (a pile of copies reads one from the cache); a body with another hull, or the first hull
// again after it, gets its own, with the same numbers: each is its hull's vertices in its frame.
TEST(World, BodiesAddedWithTheSameHullShareItsPolytopeMovedToTheirCentreOfMass) {
  std::mt19937_64 rng(7);
  // off-centre points: the centre of mass is not the origin, so the polytope is moved
  Points points = scenes::random_hull(rng, 20, Vec3(0.4, 0.3, 0.2)).vertices;
  points.rowwise() += Vec3(0.3, -0.2, 0.1).transpose();
  const ConvexHull hull(points);
  const ConvexHull other = scenes::random_hull(rng, 16, Vec3(0.2, 0.3, 0.4));
  World world;
  for (const ConvexHull* h : {&hull, &hull, &other, &hull}) {
    BodyDesc d;
    d.shape = *h;
    d.density = 500.0;
    d.position = Vec3(0.0, 0.0, 2.0 * static_cast<double>(world.model().size()));
    world.add_body(d);
  }
  const auto polytope = [&](BodyIndex i) { return std::get<ConvexHull>(world.model().shape[i]).polytope; };
  EXPECT_EQ(polytope(0), polytope(1));
  EXPECT_NE(polytope(1), polytope(2));
  EXPECT_NE(polytope(2), polytope(3));
  for (BodyIndex i = 0; i < 4; ++i) {
    const ConvexHull& h = std::get<ConvexHull>(world.model().shape[i]);
    ASSERT_EQ(h.polytope->vertices.rows(), h.vertices.rows()) << i;
    EXPECT_TRUE(h.polytope->vertices == h.vertices) << "body " << i << ": its polytope is its hull in its frame";
  }
  EXPECT_TRUE(polytope(3)->vertices == polytope(0)->vertices);
  // moved once: the hull given was off its centre of mass, each body's is centred on it
  EXPECT_GT(mass_properties(Shape(hull), 1.0).com.norm(), 0.3);
  for (BodyIndex i = 0; i < 4; ++i) EXPECT_LT(mass_properties(world.model().shape[i], 1.0).com.norm(), 1e-12) << i;
}

TEST(World, DeterministicBitForBit) {
  auto run = []() {
    World world;
    world.add_body(ground());
    BodyDesc d = box_at(1.5);
    d.orientation = Quat4(0.9, 0.2, 0.3, 0.1);
    d.angular_velocity = Vec3(1.0, -2.0, 0.5);
    world.add_body(d);
    BodyDesc s;
    s.shape = Sphere(0.3);
    s.mass = 2.0;
    s.position = Vec3(0.2, 0.1, 3.0);
    world.add_body(s);
    world.step(1.0 / 240.0, 600);
    return world.state();
  };
  const State a = run(), b = run();
  for (std::size_t i = 0; i < a.p.size(); ++i) {
    EXPECT_EQ(a.p[i], b.p[i]);
    EXPECT_EQ(a.R[i], b.R[i]);
    EXPECT_EQ(a.v[i], b.v[i]);
  }
}

namespace {

/// Three boxes on the ground, settled for 0.25 s (so that the warm-start cache is full).
void settled_boxes(World& world) {
  world.add_body(ground());
  for (int k = 0; k < 3; ++k) {
    BodyDesc d = box_at(0.501 + 0.01 * k);
    d.position.x() = 3.0 * k;
    d.orientation = Quat4(1.0, 0.01 * k, 0.0, 0.0);
    world.add_body(d);
  }
  world.step(1.0 / 240.0, 60);
}

void expect_same_state(const State& a, const State& b) {
  ASSERT_EQ(a.p.size(), b.p.size());
  for (std::size_t i = 0; i < a.p.size(); ++i) {
    EXPECT_EQ(a.p[i], b.p[i]) << i;
    EXPECT_EQ(a.R[i], b.R[i]) << i;
    EXPECT_EQ(a.q[i], b.q[i]) << i;
    EXPECT_EQ(a.v[i], b.v[i]) << i;
    EXPECT_EQ(a.omega[i], b.omega[i]) << i;
  }
  EXPECT_EQ(a.time, b.time);
}

}  // namespace

TEST(World, RestoreStateContinuesBitForBit) {
  World world;
  settled_boxes(world);
  ASSERT_FALSE(world.warm_start_cache().empty());
  const std::string saved = world.save_state();
  world.step(1.0 / 240.0, 30);
  const State first = world.state();
  const std::size_t contacts = world.contacts().size();
  world.restore_state(saved);
  world.step(1.0 / 240.0, 30);
  expect_same_state(world.state(), first);
  EXPECT_EQ(world.contacts().size(), contacts);
  // another world's state is refused and nothing changes
  World other;
  other.add_body(ground());
  const State before = world.state();
  EXPECT_THROW(world.restore_state(other.save_state()), std::invalid_argument);
  EXPECT_THROW(world.restore_state(saved.substr(0, saved.size() - 1)), std::invalid_argument);
  expect_same_state(world.state(), before);
}

TEST(World, RemoveBodyShiftsIndicesAndRenumbersTheCache) {
  World world;
  settled_boxes(world);
  const State before = world.state();
  const std::vector<CachedContact> cache = world.warm_start_cache();
  std::vector<CachedContact> expected;  // body 2's entries dropped, body 3's renamed 2
  for (CachedContact c : cache) {
    if (c.body_a == 2 || c.body_b == 2) continue;
    if (c.body_b == 3) c.body_b = 2;
    expected.push_back(c);
  }
  ASSERT_LT(expected.size(), cache.size());
  world.remove_body(2);
  ASSERT_EQ(world.num_bodies(), 3u);
  EXPECT_EQ(world.state().p[2], before.p[3]);
  ASSERT_EQ(world.warm_start_cache().size(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) {
    EXPECT_EQ(world.warm_start_cache()[k].body_b, expected[k].body_b);
    EXPECT_EQ(world.warm_start_cache()[k].alpha, expected[k].alpha);
  }
  EXPECT_THROW(world.remove_body(3), BodyIndexError);
  world.step(1.0 / 240.0, 60);
  EXPECT_NEAR(world.state().p[2].z(), 0.5, 2e-3);
}

TEST(World, RemoveBodiesIsRemoveBodyOfEachInOnePass) {
  World one, batch;
  settled_boxes(one);
  settled_boxes(batch);
  const State before = batch.state();
  EXPECT_THROW(batch.remove_bodies({1, 3, 1}), std::invalid_argument);  // given twice
  EXPECT_THROW(batch.remove_bodies({1, 4}), BodyIndexError);
  expect_same_state(batch.state(), before);
  one.remove_body(3);
  one.remove_body(1);
  batch.remove_bodies({3, 1});
  ASSERT_EQ(batch.num_bodies(), 2u);
  expect_same_state(batch.state(), one.state());
  ASSERT_EQ(batch.warm_start_cache().size(), one.warm_start_cache().size());
  for (std::size_t k = 0; k < one.warm_start_cache().size(); ++k) {
    EXPECT_EQ(batch.warm_start_cache()[k].body_a, one.warm_start_cache()[k].body_a);
    EXPECT_EQ(batch.warm_start_cache()[k].body_b, one.warm_start_cache()[k].body_b);
    EXPECT_EQ(batch.warm_start_cache()[k].alpha, one.warm_start_cache()[k].alpha);
  }
  one.step(1.0 / 240.0, 30);
  batch.step(1.0 / 240.0, 30);
  expect_same_state(batch.state(), one.state());
}

TEST(World, KinematicBodyKeepsItsVelocityAndFiltersRemovePairs) {
  World world;
  world.add_body(ground());
  BodyDesc paddle;
  paddle.shape = Box(Vec3(0.1, 0.5, 0.3));
  paddle.is_kinematic = true;
  paddle.position = Vec3(-1.0, 0.0, 0.2);  // overlaps the ground: two infinite masses, no contact
  paddle.velocity = Vec3(0.5, 0.0, 0.0);
  const BodyIndex k = world.add_body(paddle);
  world.step(1.0 / 240.0, 240);
  EXPECT_EQ(world.state().v[k], Vec3(0.5, 0.0, 0.0));
  EXPECT_NEAR(world.state().p[k].x(), -0.5, 1e-12);
  EXPECT_EQ(world.state().p[k].z(), 0.2);
  EXPECT_TRUE(world.contacts().empty());
  // Box2D's rule on the model: (group_a & mask_b) && (group_b & mask_a)
  BodyDesc d = box_at(2.0);
  d.filter = CollisionFilter{2, 2};
  const BodyIndex b = world.add_body(d);
  EXPECT_FALSE(world.model().can_collide(0, b));  // ground group 1 & mask 2 = 0
  world.set_collision_filter(b, CollisionFilter{2, 1});
  EXPECT_TRUE(world.model().can_collide(0, b));
  world.set_pair_collision(b, 0, false);
  EXPECT_FALSE(world.model().can_collide(0, b));
  world.set_enabled(b, false);
  world.set_pair_collision(0, b, true);
  EXPECT_FALSE(world.model().can_collide(0, b));
  world.set_enabled(b, true);
  EXPECT_TRUE(world.model().can_collide(b, 0));
}

// ---- torsional (spinning) friction ------------------------------------------------------------

namespace {

/// A sphere (1 kg, radius 0.1 m) resting on the ground, spun at omega0 about the vertical, the
/// ground's and the ball's spinning friction as given.
void spinning_ball(World& world, double mu_spin_ground, double mu_spin_ball, double omega0) {
  BodyDesc g = ground();
  g.material.spinning_friction = mu_spin_ground;
  world.add_body(g);
  BodyDesc s;
  s.shape = Sphere(0.1);
  s.mass = 1.0;
  s.position = Vec3(0.0, 0.0, 0.1);
  s.angular_velocity = Vec3(0.0, 0.0, omega0);
  s.material.spinning_friction = mu_spin_ball;
  world.add_body(s);
}

}  // namespace

TEST(World, SpinningFrictionStopsASpinningBallAtTheClosedFormRate) {
  // the torque about the normal is mu_spin alpha_n = mu_spin m g (the pair's mu_spin is the larger
  // of the two), so omega falls by dt mu_spin m g / I per step, I = 2/5 m r^2, until it stops
  // within one step of t* = I omega0 / (mu_spin m g) and stays stopped
  const double dt = 1.0 / 240.0, omega0 = 5.0, g = 9.81, I = 0.4 * 0.1 * 0.1;
  for (const auto& [ground_mu, ball_mu] : {std::pair{0.0, 0.002}, std::pair{0.002, 0.0005}}) {
    World world;
    spinning_ball(world, ground_mu, ball_mu, omega0);
    const double rate = 0.002 * g / I;  // rad/s^2
    int stopped = -1;
    double before = omega0;
    for (int k = 1; k <= 300; ++k) {
      world.step(dt);
      const double omega = world.state().omega[1].z();
      // a full step's drop while it spins (the last step may stop it part way)
      if (stopped < 0 && omega > rate * dt) EXPECT_NEAR(before - omega, rate * dt, 1e-9 * rate * dt) << k;
      if (stopped < 0 && std::abs(omega) <= 1e-12) stopped = k;
      if (stopped > 0) EXPECT_LE(std::abs(omega), 1e-12) << k;
      before = omega;
    }
    ASSERT_GT(stopped, 0);
    EXPECT_LE(std::abs(stopped * dt - omega0 / rate), dt);
    ASSERT_EQ(world.contacts().size(), 1u);
    EXPECT_NEAR(world.contacts()[0].spin_torque, 0.0, 1e-12);
  }
}

TEST(World, ZeroSpinningFrictionKeepsTheSpinBitForBit) {
  // no row: the ball spins on at omega0 exactly (no torque about the vertical reaches it)
  World world;
  spinning_ball(world, 0.0, 0.0, 5.0);
  world.step(1.0 / 240.0, 480);
  EXPECT_EQ(world.state().omega[1], Vec3(0.0, 0.0, 5.0));
  EXPECT_EQ(world.contacts()[0].spin_torque, 0.0);
  EXPECT_EQ(world.warm_start_cache()[0].spin, 0.0);
}

TEST(World, BadSpinningFrictionIsRejectedAndTheWorldIsUnchanged) {
  World world;
  spinning_ball(world, 0.0, 0.001, 5.0);
  world.step(1.0 / 240.0, 10);
  const State before = world.state();
  for (double bad : {-0.001, std::nan(""), double(INFINITY)}) {
    BodyDesc d = box_at(3.0);
    d.material.spinning_friction = bad;
    try {
      world.add_body(d);
      FAIL() << "spinning_friction " << bad << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("body 2 (Box)"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("spinning_friction"), std::string::npos) << e.what();
    }
    Material m;
    m.spinning_friction = bad;
    try {
      world.set_material(1, m);
      FAIL() << "spinning_friction " << bad << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("body 1 (Sphere)"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("spinning_friction"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(world.num_bodies(), 2u);
  EXPECT_EQ(world.model().material[1].spinning_friction, 0.001);
  expect_same_state(world.state(), before);
}

TEST(World, RestoreStateContinuesBitForBitWithSpinRows) {
  // the warm-start cache keeps each contact's spin torque: restored, the steps repeat exactly
  World world;
  spinning_ball(world, 0.0, 0.001, 5.0);
  world.step(1.0 / 240.0, 20);
  ASSERT_NE(world.warm_start_cache()[0].spin, 0.0);
  const std::string saved = world.save_state();
  world.step(1.0 / 240.0, 30);
  const State first = world.state();
  const double torque = world.contacts()[0].spin_torque;
  world.restore_state(saved);
  EXPECT_NE(world.contacts()[0].spin_torque, 0.0);
  world.step(1.0 / 240.0, 30);
  expect_same_state(world.state(), first);
  EXPECT_EQ(world.contacts()[0].spin_torque, torque);
}

namespace {

/// A stack of 4 boxes on the ground and a ball falling onto it: contacts in every step.
void busy_stack(World& world) {
  world.add_body(ground());
  for (int k = 0; k < 4; ++k) world.add_body(box_at(0.5005 + 1.001 * k));
  BodyDesc ball;
  ball.shape = Sphere(0.3);
  ball.density = 500.0;
  ball.position = Vec3(0.2, 0.1, 5.0);
  world.add_body(ball);
}

}  // namespace

TEST(WorldThreads, StepsFromFourThreadsRunOneAtATimeAndMatchOneThread) {
  // a step is not divisible: 4 threads stepping one world 25 times each, while reading it, give
  // the 100 steps of one thread, bit for bit (each step waits for the one running)
  const double dt = 1.0 / 240.0;
  World alone, shared;
  busy_stack(alone);
  busy_stack(shared);
  alone.step(dt, 100);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&shared, dt] {
      for (int s = 0; s < 25; ++s) {
        shared.step(dt);
        (void)shared.save_state();
        (void)shared.shared_contacts();
        (void)shared.solver_stats();
        (void)shared.kinetic_energy();
      }
    });
  for (std::thread& th : threads) th.join();
  expect_same_state(alone.state(), shared.state());
  EXPECT_GT(shared.contacts().size(), 0u);
}

TEST(WorldThreads, BodiesAddedAndRemovedDuringStepsWaitForThem) {
  // one thread steps while another adds and removes far-away bodies: every add or remove waits for
  // the step running, so the stack's bodies end as if nothing else had happened
  const double dt = 1.0 / 240.0;
  World alone, shared;
  busy_stack(alone);
  busy_stack(shared);
  const std::size_t n = shared.num_bodies();
  alone.step(dt, 200);
  std::thread stepper([&shared, dt] {
    for (int s = 0; s < 200; ++s) shared.step(dt);
  });
  std::thread editor([&shared, n] {
    for (int k = 0; k < 200; ++k) {
      BodyDesc far = box_at(1.0);
      far.position = Vec3(1000.0 + 3.0 * k, 0.0, 1000.0);  // touches nothing in 200 steps
      shared.add_body(far);
      shared.set_velocity(static_cast<BodyIndex>(n), Vec3(1.0, 0.0, 0.0));
      if (k % 2 == 1) shared.remove_bodies({static_cast<BodyIndex>(n), static_cast<BodyIndex>(n + 1)});
    }
  });
  stepper.join();
  editor.join();
  ASSERT_EQ(shared.num_bodies(), n);
  State s = shared.state();
  expect_same_state(alone.state(), s);
}

namespace {

/// What a reader copies out of a World, as numbers to compare bit for bit.
std::vector<double> numbers(const std::vector<Vec3>& xs) {
  std::vector<double> out;
  for (const Vec3& x : xs) out.insert(out.end(), x.data(), x.data() + 3);
  return out;
}

std::vector<double> numbers(const std::vector<CachedContact>& cache) {
  std::vector<double> out;
  for (const CachedContact& c : cache)
    out.insert(out.end(), {double(c.body_a), double(c.body_b), double(c.feature_a), double(c.feature_b), c.alpha,
                           c.friction.x(), c.friction.y(), c.friction.z(), c.spin});
  return out;
}

std::vector<double> numbers(const std::vector<Contact>& contacts) {
  std::vector<double> out;
  for (const Contact& c : contacts)
    out.insert(out.end(), {double(c.body_a), double(c.body_b), c.point.x(), c.point.z(), c.gap, c.alpha,
                           c.force.x(), c.force.z()});
  return out;
}

}  // namespace

TEST(WorldThreads, LastStepFiguresAreCopiesTakenUnderTheLock) {
  // a reference to the solver's arrays would be read after the lock is released, while another
  // thread's step zeroes and re-sums them
  const World* w = nullptr;
  EXPECT_TRUE((std::is_same_v<decltype(w->contact_forces()), std::vector<Vec3>>));
  EXPECT_TRUE((std::is_same_v<decltype(w->contact_torques()), std::vector<Vec3>>));
  EXPECT_TRUE((std::is_same_v<decltype(w->warm_start_cache()), std::vector<CachedContact>>));
  EXPECT_TRUE((std::is_same_v<decltype(w->contacts()), std::vector<Contact>>));
  EXPECT_TRUE((std::is_same_v<decltype(w->settings()), WorldSettings>));
}

TEST(WorldThreads, FiguresReadDuringAnotherThreadsStepsAreThoseOfAFinishedStep) {
  // a reader in a second thread copies the contact forces, torques, warm-start cache and contacts
  // while the main thread steps: each copy equals, bit for bit, what the main thread read between
  // two of its steps (never a step's half-written arrays, which read as zeros or partial sums)
  const double dt = 1.0 / 240.0;
  World world;
  busy_stack(world);
  world.step(dt);  // from here on every step has contacts: no finished step has all-zero forces
  using Numbers = std::vector<double>;
  std::set<Numbers> finished[4], seen[4];
  auto read = [&world](std::set<Numbers>* into) {
    into[0].insert(numbers(world.contact_forces()));
    into[1].insert(numbers(world.contact_torques()));
    into[2].insert(numbers(world.warm_start_cache()));
    into[3].insert(numbers(world.contacts()));
  };
  read(finished);
  std::atomic<bool> done{false};
  std::atomic<int> reads{0};
  std::thread reader([&] {
    while (!done.load()) {
      read(seen);
      ++reads;
    }
  });
  for (int s = 0; s < 300; ++s) {
    world.step(dt);
    read(finished);
    std::this_thread::yield();  // a chance for the reader between two steps
  }
  done = true;
  reader.join();
  EXPECT_GT(reads.load(), 0);
  const char* what[4] = {"contact_forces", "contact_torques", "warm_start_cache", "contacts"};
  for (int k = 0; k < 4; ++k) {
    int torn = 0;
    for (const Numbers& x : seen[k]) torn += finished[k].count(x) == 0;
    EXPECT_EQ(torn, 0) << what[k] << ": " << torn << " of " << seen[k].size()
                       << " distinct reads match no finished step";
  }
}

/// A frictionless floor and on it a cube of half side 0.05 m, 1 kg, spun at 200 rad/s about z;
/// returns the cube.
BodyIndex add_spun_cube(World& world) {
  BodyDesc floor = ground();
  floor.material.friction = 0.0;
  world.add_body(floor);
  BodyDesc cube;
  cube.shape = Box(Vec3(0.05, 0.05, 0.05));
  cube.mass = 1.0;
  cube.position = Vec3(0, 0, 0.05);
  cube.angular_velocity = Vec3(0, 0, 200.0);
  cube.material.friction = 0.0;
  return world.add_body(cube);
}

/// Steps the spun cube b 20 times by dt and expects, every step, 24 substeps, its 4 corner
/// contacts, and the floor's impulse over the step (the contacts' summed impulses) equal to m g dt
/// plus the change of vertical momentum (m = 1 kg) within `tolerance` (N s).
void expect_floor_impulse_balances(World& world, BodyIndex b, double dt, double tolerance) {
  const double g = 9.81;
  for (int k = 0; k < 20; ++k) {
    const double vz = world.state().v[b].z();
    world.step(dt);
    EXPECT_EQ(world.step_report().steps, 24) << k;
    const std::vector<Contact> contacts = world.contacts();
    ASSERT_EQ(contacts.size(), 4u) << k;
    double impulse = 0.0;
    for (const Contact& c : contacts) impulse += c.impulse * c.normal.z();
    EXPECT_NEAR(impulse, (world.state().v[b].z() - vz) + g * dt, tolerance) << k;
  }
}

TEST(World, AFastTurningCubeIsSteppedInShorterSubstepsWithItsContactsFoundAgain) {
  // a cube of half side 0.05 m (rho = 0.0866 m, inner radius 0.05 m), 1 kg, on a frictionless
  // floor, spun at 200 rad/s about z: its corners sweep 17.3 m/s against a quarter of its inner
  // radius, so a step of 1/60 s takes min(64, ceil(17.3 / 60 / 0.0125)) = 24 substeps, not 16
  // (docs/conventions.md, "One step": turning pairs); its four corner contacts are found again in
  // the substeps once it has turned, with the same features, so each keeps the impulse summed over
  // the step: the floor's impulse over the step is m g dt plus the change of vertical momentum,
  // to the PGS's tolerance per substep (1e-6 m/s, times m)
  const double dt = 1.0 / 60.0;
  WorldSettings settings;
  settings.sleep.enabled = false;
  World world(settings);
  const BodyIndex b = add_spun_cube(world);
  expect_floor_impulse_balances(world, b, dt, 24 * 1e-6);
  // it spun on, flat, its corners within the slop (a fifth of its inner radius) of the floor
  for (const Contact& c : world.contacts()) EXPECT_GT(c.gap, -0.2 * 0.05);
  // a fixed substep count is kept as set
  WorldSettings fixed = world.settings();
  fixed.solver.substeps = 2;
  world.set_settings(fixed);
  world.step(dt);
  EXPECT_EQ(world.step_report().steps, 2);
}

TEST(World, TheSoftStepMakesItsRowsAgainForAFastTurningCube) {
  // the cube above with the soft step (its own 4 substeps at dt 1/60): the same 24 substeps for
  // the turn (at most half of the budget of 16 per 1/240 s up front), and a run of rows ends each
  // time a corner's pair has turned a quarter of the inner radius since its rows were made; the
  // corners are collided again with the same features, so each contact keeps its impulse summed
  // over the runs. The soft step changes the velocities by exactly the impulses it applies: the
  // floor's impulse over the step is m g dt plus the change of vertical momentum, to rounding;
  // each corner rests at its spring's static deflection, g / omega^2 (a quarter of the weight on
  // the corner's effective mass of 0.25 kg; the floor's spring is twice contact_hertz)
  const double dt = 1.0 / 60.0, g = 9.81;
  WorldSettings settings;
  settings.sleep.enabled = false;
  settings.solver.method = SolverMethod::Soft;
  World world(settings);
  const BodyIndex b = add_spun_cube(world);
  const double omega = 2.0 * M_PI * 2.0 * settings.solver.contact_hertz;
  expect_floor_impulse_balances(world, b, dt, 1e-12);
  for (const Contact& c : world.contacts()) EXPECT_GT(c.gap, -1.1 * g / (omega * omega));
  // with its own 4 substeps, fixed, it keeps its rows through the step
  WorldSettings fixed = world.settings();
  fixed.solver.substeps = 4;
  world.set_settings(fixed);
  world.step(dt);
  EXPECT_EQ(world.step_report().steps, 4);
}
