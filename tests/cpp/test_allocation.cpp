// No heap allocation inside World::step() after warm-up but a buffer growing past the pile's
// largest size so far (the solver's rows and cache, the collision
// scratch buffers and the broad phase's pair list are owned by the World and reused). This file is
// its own executable: it replaces the global operator new/delete and malloc with counting
// versions, which would otherwise count for every test of the main suite. (Counting operator new
// alone missed Eigen's dynamic matrices, which call malloc: a hull's vertices copied into a
// Primitive for its bounding box, and a product on the heap for a shape's bounding radius, some
// 36 allocations a step in the busy pile.)
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <random>
#include <vector>

#include "random_scene.hpp"
#include "signorini/world.hpp"

namespace {
std::atomic<bool> counting{false};
std::atomic<long> allocations{0};
/// One allocation, counted while counting.
void count_allocation() {
  if (counting.load(std::memory_order_relaxed)) allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

// malloc and its kin too, which Eigen's dynamic matrices call directly (not operator new): glibc
// lets the executable's definitions stand for every library's calls, and the __libc_ entry points
// are its own allocator (elsewhere only operator new is counted)
#if defined(__GLIBC__)
constexpr bool kCountsMalloc = true;
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t n, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
void* malloc(std::size_t size) {
  count_allocation();
  return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) {
  count_allocation();
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) {
  count_allocation();
  return __libc_realloc(p, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  count_allocation();
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  count_allocation();
  *out = __libc_memalign(alignment, size);
  return *out ? 0 : ENOMEM;
}
}
#define SIGNORINI_RAW_MALLOC __libc_malloc
#define SIGNORINI_RAW_MEMALIGN __libc_memalign
#else
constexpr bool kCountsMalloc = false;
#define SIGNORINI_RAW_MALLOC std::malloc
#define SIGNORINI_RAW_MEMALIGN(a, n) std::aligned_alloc(a, n)
#endif

// every form of operator new goes through these two (counted once: they take the memory from
// glibc directly); the deletes only have to match malloc/free
void* operator new(std::size_t size) {
  count_allocation();
  if (void* p = SIGNORINI_RAW_MALLOC(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return operator new(size);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, const std::nothrow_t& tag) noexcept { return operator new(size, tag); }
void* operator new(std::size_t size, std::align_val_t align) {
  count_allocation();
  const std::size_t a = static_cast<std::size_t>(align);
  if (void* p = SIGNORINI_RAW_MEMALIGN(a, (size + a - 1) / a * a)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size, std::align_val_t align) { return operator new(size, align); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace signorini {
namespace {

/// Heap allocations made by f().
template <class F>
long allocations_during(F&& f) {
  allocations = 0;
  counting = true;
  f();
  counting = false;
  return allocations.load();
}

/// Heap allocations in each of three windows of 240 steps, after a warm-up of 1440 steps (6 s: the
/// pile has landed and settled, its buffers have grown to its size). A settled pile is not at rest
/// (a ball rolls on, a body creeps), so its contact count can still pass a buffer's capacity once in
/// a while, and that buffer doubles: steps allocate nothing but such a growth. (Measured: a change
/// of trajectory moved one pile's count from 414 to 416 after 6.4 s, past a capacity of 414.)
std::array<long, 3> allocations_after_warm_up(World& w, double dt) {
  w.step(dt, 1440);
  std::array<long, 3> n{};
  for (long& x : n) x = allocations_during([&] { w.step(dt, 240); });
  std::printf("heap allocations in 3 windows of 240 steps after warm-up: %ld %ld %ld\n", n[0], n[1], n[2]);
  return n;
}

/// Every window allocates at most a few buffer growths, and one allocates nothing.
void expect_quiet(const std::array<long, 3>& n) {
  EXPECT_LE(*std::max_element(n.begin(), n.end()), 4) << "more than a few buffers grew in 240 steps";
  EXPECT_EQ(*std::min_element(n.begin(), n.end()), 0) << "every window of 240 steps allocated";
}

/// The plane z = 0, static, as body 0.
void add_ground(World& w) {
  BodyDesc ground;
  ground.is_static = true;
  ground.shape = Plane(Vec3(0, 0, 1), 0.0);
  w.add_body(ground);
}

/// A busy scene: 64 bodies of every convex kind (spheres, boxes, capsules, cylinders, hulls,
/// compounds) dropped into a pit of static boxes on a plane, half of it tessellated as a triangle
/// mesh floor, so every pair family of the narrow phase and both broad-phase trees are exercised.
/// spinning_friction (m) on every body: with it, the single-point contacts get spin rows too.
/// Settings with every body kept awake: the tests of the awake step's buffers (a pile whose bodies
/// fall asleep sets its islands' contacts aside, a store that grows with them: the sleeping tests
/// below).
WorldSettings awake() {
  WorldSettings settings;
  settings.sleep.enabled = false;
  return settings;
}

void build_pit(World& w, double spinning_friction = 0.0) {
  add_ground(w);
  BodyDesc floor;
  floor.is_static = true;
  floor.shape = scenes::floor_mesh(0.6, 6);
  floor.position = Vec3(0.0, 0.0, 0.001);
  w.add_body(floor);
  for (int axis = 0; axis < 2; ++axis)
    for (double side : {-1.0, 1.0}) {
      BodyDesc wall;
      wall.is_static = true;
      Vec3 half(0.8, 0.8, 0.4), centre(0.0, 0.0, 0.4);
      half[axis] = 0.05;
      centre[axis] = side * 0.75;
      wall.shape = Box(half);
      wall.position = centre;
      w.add_body(wall);
    }
  std::mt19937_64 rng(11);
  for (int k = 0; k < 64; ++k) {
    BodyDesc d;
    d.shape = k % 6 == 5 ? Shape(Compound({{Box(Vec3(0.06, 0.06, 0.02)), Vec3(0, 0, 0.02), Mat3::Identity()},
                                           {Sphere(0.03), Vec3(0, 0, -0.03), Mat3::Identity()}}))
                         : scenes::random_shape(rng, scenes::Mix::AllConvex, k, 0.03, 0.07);
    d.density = 500.0;
    d.position = Vec3(-0.45 + 0.3 * (k % 4), -0.45 + 0.3 * ((k / 4) % 4), 0.2 + 0.25 * (k / 16));
    const Eigen::Quaterniond q(scenes::random_rotation(rng));
    d.orientation = Quat4(q.w(), q.x(), q.y(), q.z());
    d.angular_velocity = scenes::random_vector(rng, 2.0);
    d.material.spinning_friction = spinning_friction;
    w.add_body(d);
  }
}

TEST(Allocation, StepsOfABusyPileAllocateNothingAfterWarmUp) {
  World w(awake());
  build_pit(w);
  expect_quiet(allocations_after_warm_up(w, 1.0 / 240.0));
  EXPECT_GT(w.contacts().size(), 100u);
}

/// Jointed chains (each joint kind, a limit and a motor) swinging onto the ground among loose
/// boxes, in both solvers: the joints' blocks and their undo copy are reused from step to step.
TEST(Allocation, StepsOfJointedChainsAllocateNothingAfterWarmUp) {
  for (SolverMethod method : {SolverMethod::Soft, SolverMethod::PGS}) {
    WorldSettings settings = awake();
    settings.solver.method = method;
    World w(settings);
    add_ground(w);
    const JointKind kinds[] = {JointKind::Revolute, JointKind::Spherical, JointKind::Fixed, JointKind::Distance,
                               JointKind::Prismatic};
    for (int c = 0; c < 5; ++c) {
      BodyIndex previous = 0;  // the ground
      for (int k = 0; k < 4; ++k) {
        BodyDesc d;
        d.shape = Box(Vec3(0.1, 0.03, 0.03));
        d.density = 500.0;
        d.position = Vec3(0.1 + 0.2 * k, 0.3 * c, 0.6);
        const BodyIndex b = w.add_body(d);
        JointDesc j;
        j.kind = k == 0 && kinds[c] == JointKind::Fixed ? JointKind::Revolute : kinds[c];
        j.body_a = previous;
        j.body_b = b;
        j.anchor = Vec3(0.2 * k, 0.3 * c, 0.6);
        j.anchor_b = j.kind == JointKind::Distance ? Vec3(0.2 * k + 0.05, 0.3 * c, 0.6) : j.anchor;
        j.max_length = j.kind == JointKind::Distance ? 0.06 : j.max_length;
        j.axis = j.kind == JointKind::Prismatic ? Vec3(0.6, 0.0, -0.8) : Vec3::UnitY();
        if (j.kind == JointKind::Revolute && k == 1) j.has_limits = true, j.lower = -0.5, j.upper = 0.5;
        if (j.kind == JointKind::Revolute && k == 2) j.motor = Motor{true, 2.0, 0.1};
        if (j.kind == JointKind::Prismatic) j.has_limits = true, j.lower = -0.1, j.upper = 0.3;
        w.add_joint(j);
        previous = b;
      }
    }
    for (int k = 0; k < 8; ++k) {
      BodyDesc d;
      d.shape = Box(Vec3(0.05, 0.05, 0.05));
      d.density = 500.0;
      d.position = Vec3(0.15 * k, 0.15 + 0.05 * (k % 3), 0.06);
      w.add_body(d);
    }
    expect_quiet(allocations_after_warm_up(w, 1.0 / 240.0));
    EXPECT_EQ(w.num_joints(), 20u);
    EXPECT_GT(w.contacts().size(), 8u);
  }
}

/// Steps on two threads (the soft step and the PGS): a 17 x 17 grid of boxes on a plane, so that
/// a colour holds more contacts than one task and the solve is split over the threads; oneTBB's
/// tasks come from its own pools once warm.
TEST(Allocation, StepsOnTwoThreadsAllocateNothingAfterWarmUp) {
  for (SolverMethod method : {SolverMethod::Soft, SolverMethod::PGS}) {
    WorldSettings settings = awake();
    settings.threads = 2;
    settings.solver.method = method;
    settings.solver.max_iterations = 4;
    World w(settings);
    add_ground(w);
    for (int i = 0; i < 17; ++i)
      for (int j = 0; j < 17; ++j) {
        BodyDesc d;
        d.shape = Box(Vec3(0.1, 0.1, 0.1));
        d.density = 500.0;
        d.position = Vec3(0.3 * i, 0.3 * j, 0.12);
        w.add_body(d);
      }
    expect_quiet(allocations_after_warm_up(w, 1.0 / 240.0));
    EXPECT_EQ(w.contacts().size(), 4u * 289u);  // each box on four corners: 289 in each of 4 colours
  }
}

/// A cube spinning at 200 rad/s on a frictionless floor among resting boxes, in both solvers: its
/// corner pairs are collided again within the step (the PGS's substeps, the soft step's runs of
/// rows), into kept buffers.
TEST(Allocation, StepsWithATurningPairFoundAgainAllocateNothingAfterWarmUp) {
  for (SolverMethod method : {SolverMethod::Soft, SolverMethod::PGS}) {
    WorldSettings settings = awake();
    settings.solver.method = method;
    World w(settings);
    BodyDesc floor;
    floor.shape = Plane(Vec3::UnitZ(), 0.0);
    floor.is_static = true;
    floor.material.friction = 0.0;
    w.add_body(floor);
    for (int k = 0; k < 4; ++k) {
      BodyDesc d;
      d.shape = Box(Vec3(0.05, 0.05, 0.05));
      d.mass = 1.0;
      d.position = Vec3(0.3 * k, 0.0, 0.05);
      d.material.friction = 0.0;
      if (k == 0) d.angular_velocity = Vec3(0.0, 0.0, 200.0);
      w.add_body(d);
    }
    expect_quiet(allocations_after_warm_up(w, 1.0 / 60.0));
    EXPECT_GT(w.step_report().steps, 16);  // the turn's substeps
  }
}

TEST(Allocation, StepsOfABusyPileWithSpinRowsAllocateNothingAfterWarmUp) {
  World w(awake());
  build_pit(w, 0.002);
  expect_quiet(allocations_after_warm_up(w, 1.0 / 240.0));
  std::size_t spinning = 0;
  for (const Contact& c : w.contacts()) spinning += c.spin_torque != 0.0;
  EXPECT_GT(spinning, 0u);
}

TEST(Allocation, StepsOfASleepingPileAllocateNothing) {
  // 27 cubes in 3 x 3 columns of 3 on a plane, sleeping on: once the pile sleeps, a step touches
  // none of its buffers (steps in which islands fall asleep and wake: the next test)
  WorldSettings settings;
  settings.sleep.enabled = true;
  World w(settings);
  add_ground(w);
  for (int k = 0; k < 27; ++k) {
    BodyDesc d;
    d.shape = Box(Vec3(0.1, 0.1, 0.1));
    d.density = 500.0;
    d.position = Vec3(0.25 * (k % 3), 0.25 * ((k / 3) % 3), 0.1 + 0.201 * (k / 9));
    w.add_body(d);
  }
  const std::array<long, 3> n = allocations_after_warm_up(w, 1.0 / 240.0);
  for (std::size_t i = 1; i < w.num_bodies(); ++i) ASSERT_EQ(w.state().awake[i], 0) << "body " << i << " awake";
  EXPECT_EQ(n, (std::array<long, 3>{0, 0, 0}));
}

/// Steps in which islands fall asleep and are woken by a body landing on them: 4 cubes on a plane,
/// each with a ball that is lifted 2 m above it every 3 s (a setter, between steps, not counted).
/// The cube falls asleep alone while the ball falls (0.63 s > time_to_sleep 0.5 s), the ball lands
/// on it and wakes it inside a step, and ball and cube fall asleep together once at rest. Returns
/// the heap allocations of the steps alone in each of 3 windows of `cycles` cycles after `warm_up`
/// cycles, and the sleep and wake events the steps saw in them.
struct SleepWakeCount {
  std::array<long, 3> allocations{};
  long fell_asleep = 0, woke = 0;
};
SleepWakeCount sleep_wake_allocations(int warm_up, int cycles) {
  WorldSettings settings;
  settings.sleep.enabled = true;
  World w(settings);
  add_ground(w);
  std::vector<BodyIndex> balls;
  for (int k = 0; k < 4; ++k) {
    BodyDesc cube;
    cube.shape = Box(Vec3(0.1, 0.1, 0.1));
    cube.density = 500.0;
    cube.position = Vec3(0.5 * k, 0.0, 0.1);
    w.add_body(cube);
    BodyDesc ball;
    ball.shape = Sphere(0.05);
    ball.density = 500.0;
    ball.position = Vec3(0.5 * k, 0.0, 0.3);
    balls.push_back(w.add_body(ball));
  }
  const double dt = 1.0 / 60.0;
  SleepWakeCount out;
  std::vector<std::uint8_t> awake = w.state().awake;
  const auto cycle = [&](long* allocations) {
    for (std::size_t k = 0; k < balls.size(); ++k) {
      const BodyIndex b = balls[k];
      w.set_position(b, Vec3(0.5 * static_cast<double>(k), 0.0, 2.2));
      w.set_velocity(b, Vec3::Zero());
      w.set_angular_velocity(b, Vec3::Zero());
    }
    awake = w.state().awake;
    for (int s = 0; s < 180; ++s) {
      const long n = allocations_during([&] { w.step(dt); });
      if (allocations) *allocations += n;
      for (std::size_t i = 0; i < awake.size(); ++i) {
        if (awake[i] && !w.state().awake[i]) ++out.fell_asleep;
        if (!awake[i] && w.state().awake[i]) ++out.woke;
        awake[i] = w.state().awake[i];
      }
    }
  };
  for (int c = 0; c < warm_up; ++c) cycle(nullptr);
  out.fell_asleep = out.woke = 0;
  for (long& n : out.allocations)
    for (int c = 0; c < cycles; ++c) cycle(&n);
  std::printf("sleep/wake: heap allocations of the steps in 3 windows of %d cycles after warm-up: %ld %ld %ld "
              "(%ld bodies fell asleep, %ld woke inside steps)\n",
              cycles, out.allocations[0], out.allocations[1], out.allocations[2], out.fell_asleep, out.woke);
  return out;
}

TEST(Allocation, StepsWhereIslandsSleepAndWakeAllocateNothingAfterWarmUp) {
  const SleepWakeCount n = sleep_wake_allocations(4, 4);
  // the scene does what it is for: cubes fall asleep alone and are woken by their balls in steps
  EXPECT_GE(n.fell_asleep, 3 * 4 * 4);
  EXPECT_GE(n.woke, 3 * 4 * 4);
  EXPECT_EQ(n.allocations, (std::array<long, 3>{0, 0, 0}));
}

TEST(Allocation, TheCounterSeesAnAllocation) {
  // the counter itself works: a fresh vector of a runtime size allocates once
  volatile std::size_t size = 16;
  const long n = allocations_during([&] { std::vector<double> x(size); x[0] = 1.0; });
  EXPECT_EQ(n, 1);
  // and so does a matrix of Eigen's, which takes its memory from malloc
  const long m = allocations_during([&] {
    Points x(static_cast<Eigen::Index>(size), 3);
    x.setZero();
    volatile double keep = x(0, 0);
    (void)keep;
  });
  EXPECT_EQ(m, kCountsMalloc ? 1 : 0);
}

}  // namespace
}  // namespace signorini
