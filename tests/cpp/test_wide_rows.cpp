// The soft step's sweeps and warm start four body pairs at a time (cpp/src/solver/wide_rows.hpp)
// give the bits of the scalar code, in every ISA this CPU has and at every thread count.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "parallel/huge_pages.hpp"
#include "random_scene.hpp"
#include "signorini/world.hpp"
#include "solver/wide_rows.hpp"

using namespace signorini;

namespace {

/// Restores the process-wide choice when a test ends, whatever it set ("auto" when it was).
struct KeepSimd {
  std::string isa = simd();
  bool named = solver::wide_isa_named();
  ~KeepSimd() { set_simd(named ? isa : std::string("auto")); }
};

std::vector<std::string> isas() {
  std::vector<std::string> out{"scalar", "sse2"};
  set_simd("auto");
  if (simd() == "avx2") out.push_back("avx2");
  return out;
}

/// A busy scene for the lanes: 300 boxes in stacks of 3 on the ground (thousands of contacts:
/// full groups, colours whose pairs do not fill their last group), spheres that bounce
/// (restitution; pairs of one point beside pairs of four in a group), spinning capsules and balls
/// rolling (round sides, whose gaps carry their cores) and a kinematic paddle
/// sweeping through a row of them (a body that does not move in the lanes but has a velocity).
/// The state after `steps` steps as bytes, with every contact's outputs and the certificate.
/// relax_iterations 0: the gaps are brought up to date in a pass of their own rather than in the
/// first relax sweep. bouncy false: the spheres do not bounce (no restitution anywhere), so the
/// grouped contacts keep their impulse sums in the groups until the step's end (wide_accumulate,
/// wide_settle_out) rather than settling after every substep.
std::vector<double> busy_scene(int threads, int steps, int relax_iterations = 1, bool bouncy = true) {
  WorldSettings settings;
  settings.solver.method = SolverMethod::Soft;
  settings.solver.relax_iterations = relax_iterations;
  settings.threads = threads;
  settings.sleep.enabled = false;
  World world(settings);
  world.add_body(scenes::ground());
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      for (int k = 0; k < 3; ++k) {
        BodyDesc d;
        d.shape = Box(Vec3(0.5, 0.5, 0.5));
        d.density = 1000.0 * (1 + (i + j + k) % 3);
        d.position = Vec3(1.2 * i + 0.03 * k, 1.2 * j, 0.55 + 1.05 * k);
        d.orientation = Quat4(1.0, 0.01 * (i % 3), 0.01 * (j % 2), 0.02 * k);
        d.material.friction = 0.3 + 0.1 * (j % 4);
        world.add_body(d);
      }
  for (int i = 0; i < 12; ++i) {
    BodyDesc s;
    s.shape = Sphere(0.2);
    s.mass = 1.0 + i;
    s.position = Vec3(-2.0, 0.5 * i, 0.5 + 0.3 * i);
    s.material.restitution = bouncy ? 0.6 : 0.0;
    world.add_body(s);
  }
  for (int i = 0; i < 8; ++i) {
    BodyDesc s;
    s.shape = i % 2 ? Shape(Capsule(0.1, 0.3)) : Shape(Sphere(0.15));
    s.mass = 0.5 + i;
    s.position = Vec3(-5.0, 0.6 * i, 0.3);
    s.orientation = Quat4(1.0, 1.0, 0.0, 0.1 * i);  // a capsule lies on its side
    s.velocity = Vec3(1.0 + 0.5 * i, 0.0, 0.0);
    s.angular_velocity = Vec3(0.0, 40.0 + 10.0 * i, 0.0);
    world.add_body(s);
  }
  // capsules lying side by side on the ground and on each other: pairs of two points, whose
  // normal rows the lanes solve as blocks (groups of four such pairs, and the last ones that fill
  // no group one by one), dropped from a little above so that they land
  for (int i = 0; i < 11; ++i)
    for (int k = 0; k < 2; ++k) {
      BodyDesc c;
      c.shape = Capsule(0.1, 0.3);
      c.mass = 1.0 + 0.5 * (i % 3) + k;
      c.position = Vec3(14.0 + 0.01 * k, 0.25 * i, 0.12 + 0.21 * k);
      c.orientation = Quat4(1.0, 1.0, 0.0, 0.0);  // its axis along y: lying
      c.velocity = Vec3(0.0, 0.0, -1.0 - 0.2 * i);
      c.material.friction = 0.4 + 0.05 * k;
      world.add_body(c);
    }
  BodyDesc paddle;
  paddle.shape = Box(Vec3(0.1, 3.0, 0.3));
  paddle.is_kinematic = true;
  paddle.position = Vec3(-3.0, 2.5, 0.3);
  paddle.velocity = Vec3(0.8, 0.0, 0.0);
  world.add_body(paddle);
  world.step(1.0 / 60.0, steps);
  std::vector<double> bytes;
  for (std::size_t i = 0; i < world.state().p.size(); ++i)
    for (const Vec3& x : {world.state().p[i], world.state().v[i], world.state().omega[i]})
      bytes.insert(bytes.end(), x.data(), x.data() + 3);
  for (const Contact& c : world.contacts()) {
    bytes.push_back(c.alpha);
    bytes.push_back(c.impulse);
    bytes.push_back(c.normal_velocity);
    for (const Vec3& x : {c.friction, c.force, c.slip}) bytes.insert(bytes.end(), x.data(), x.data() + 3);
  }
  const SolverStats stats = world.solver_stats();
  for (double x : {stats.residual, stats.max_alpha_negative, stats.max_penetration_velocity, stats.max_complementarity,
                   stats.max_cone_violation, stats.max_dissipation_violation, stats.max_overlap})
    bytes.push_back(x);
  return bytes;
}

/// Stacks of 3 boxes on the ground, each box turned about the vertical a little more than the one
/// under it (their pairs' clipped edge crossings each take the normal of their two edges: the
/// groups take their points' own directions, WideGroup::frame), stepped `steps` times of dt; the
/// state after, as bytes.
std::vector<double> turned_stacks(double dt, int steps) {
  WorldSettings settings;
  settings.solver.method = SolverMethod::Soft;
  settings.sleep.enabled = false;
  World world(settings);
  world.add_body(scenes::ground());
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j)
      for (int k = 0; k < 3; ++k) {
        BodyDesc d;
        d.shape = Box(Vec3(0.5, 0.5, 0.5));
        d.density = 1000.0;
        d.position = Vec3(1.5 * i, 1.5 * j, 0.5 + 1.0 * k);
        const double turn = 0.05 * k + 0.01 * (i + j);
        d.orientation = Quat4(std::cos(0.5 * turn), 0.0, 0.0, std::sin(0.5 * turn));
        world.add_body(d);
      }
  world.step(dt, steps);
  return scenes::motion_bytes(world);
}

}  // namespace

TEST(WideRows, PairsWhosePointsDifferInNormalRunInTheLanesWithTheirOwnDirections) {
  KeepSimd keep;
  set_simd("scalar");
  const std::vector<double> scalar = turned_stacks(1.0 / 60.0, 30);
  for (const std::string& isa : isas()) {
    if (isa == "scalar") continue;
    set_simd(isa);
    const std::size_t framed = solver::wide_framed_pairs_solved();
    EXPECT_EQ(turned_stacks(1.0 / 60.0, 30), scalar) << isa;
    EXPECT_GT(solver::wide_framed_pairs_solved(), framed)
        << isa << ": no pair went through the lanes with its points' own directions";
  }
}

TEST(WideRows, ChosenAutomaticallyTheLanesRunWhereTheyPayForCopyingTheRows) {
  KeepSimd keep;
  set_simd("scalar");
  const std::vector<double> at_60 = turned_stacks(1.0 / 60.0, 20), at_240 = turned_stacks(1.0 / 240.0, 20);
  set_simd("auto");
  if (simd() == "scalar") GTEST_SKIP() << "no lanes on this CPU";
  // dt 1/60: 4 substeps of a biased and a relax sweep, 12 passes over pairs of 4 contacts: lanes
  std::size_t before = solver::wide_contacts_solved();
  EXPECT_EQ(turned_stacks(1.0 / 60.0, 20), at_60);
  EXPECT_GT(solver::wide_contacts_solved(), before);
  // dt 1/240: 1 substep, 3 passes: one by one, the same bits
  before = solver::wide_contacts_solved();
  EXPECT_EQ(turned_stacks(1.0 / 240.0, 20), at_240);
  EXPECT_EQ(solver::wide_contacts_solved(), before);
}

TEST(WideRows, EveryIsaGivesTheBitsOfTheScalarSweepAtEveryThreadCount) {
  KeepSimd keep;
  set_simd("scalar");
  const std::size_t before = solver::wide_contacts_solved();
  const std::vector<double> scalar = busy_scene(1, 60);
  EXPECT_EQ(solver::wide_contacts_solved(), before) << "the scalar choice ran lanes";
  for (const std::string& isa : isas()) {
    for (int threads : {1, 2, 3}) {
      set_simd(isa);
      const std::size_t start = solver::wide_contacts_solved(), pairs = solver::wide_pairs_solved();
      EXPECT_EQ(busy_scene(threads, 60), scalar) << isa << ", " << threads << " threads";
      if (isa != "scalar") EXPECT_GT(solver::wide_contacts_solved(), start) << isa << ": no contact went through the lanes";
      if (isa != "scalar")
        EXPECT_GT(solver::wide_pairs_solved(), pairs) << isa << ": no pair went through the lanes as a block";
    }
  }
}

TEST(WideRows, WithoutRestitutionTheGroupsKeepTheirImpulsesWithTheSameBits) {
  KeepSimd keep;
  set_simd("scalar");
  const std::vector<double> scalar = busy_scene(1, 40, 1, false);
  EXPECT_NE(scalar, busy_scene(1, 40, 1, true)) << "the spheres' restitution changed nothing";
  for (const std::string& isa : isas()) {
    for (int threads : {1, 2}) {
      set_simd(isa);
      const std::size_t start = solver::wide_contacts_solved();
      EXPECT_EQ(busy_scene(threads, 40, 1, false), scalar) << isa << ", " << threads << " threads";
      if (isa != "scalar") EXPECT_GT(solver::wide_contacts_solved(), start) << isa << ": no contact went through the lanes";
    }
  }
}

TEST(WideRows, WithoutRelaxSweepsTheGapsReachTheLanesAsWell) {
  KeepSimd keep;
  set_simd("scalar");
  const std::vector<double> scalar = busy_scene(1, 30, 0);
  for (const std::string& isa : isas()) {
    set_simd(isa);
    EXPECT_EQ(busy_scene(2, 30, 0), scalar) << isa;
  }
}

TEST(WideRows, UnknownIsasAreRefusedAndTheChoiceIsKept) {
  KeepSimd keep;
  set_simd("sse2");
  EXPECT_THROW(set_simd("avx512"), std::invalid_argument);
  EXPECT_THROW(set_simd(""), std::invalid_argument);
  EXPECT_EQ(simd(), "sse2");
  set_simd("auto");
  EXPECT_NE(simd(), "scalar");
}

// The rows' and groups' storage (parallel/huge_pages.hpp): a block of 2 MB or more is mapped on a
// huge page boundary (Linux; whether the system then backs it with huge pages is its own setting),
// smaller ones come from the heap, and either keeps its values as the vector grows, is copied and
// is freed.
TEST(HugePages, LargeBlocksStartOnAHugePageAndKeepTheirValuesAsTheVectorGrows) {
  using parallel::kHugePage;
  parallel::HugeVector<double> v;
  bool mapped = false;  // some capacity reached a huge page
  for (int i = 0; i < 700000; ++i) {
    v.push_back(0.5 * i);
    if (v.capacity() * sizeof(double) >= kHugePage) {
      mapped = true;
      if (parallel::kMapsHuge) {
        ASSERT_EQ(reinterpret_cast<std::uintptr_t>(v.data()) % kHugePage, 0u) << "at " << v.size() << " values";
      }
    }
  }
  EXPECT_TRUE(mapped);
  for (int i = 0; i < 700000; ++i) ASSERT_EQ(v[static_cast<std::size_t>(i)], 0.5 * i);
  const parallel::HugeVector<double> copy = v;
  EXPECT_EQ(copy, v);
  v.resize(10);
  v.shrink_to_fit();  // back to the heap: the mapping is released
  EXPECT_EQ(v.back(), 4.5);
  parallel::HugeVector<solver::WideGroup> groups(1000);  // over-aligned: 32 bytes, mapped at 2 MB
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(groups.data()) % alignof(solver::WideGroup), 0u);
}
