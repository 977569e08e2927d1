// The broad phase against brute force on random scenes, bit-for-bit determinism of the narrow
// phase and of a stepped World, and boxes resting on a box and on a triangle-mesh floor with a
// steady 4-point manifold.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "collision/collision.hpp"
#include "collision/ray.hpp"
#include "math/rotation.hpp"
#include "random_scene.hpp"
#include "signorini/world.hpp"

using namespace signorini;
using collision::Pose;

namespace {

using Pair = std::pair<BodyIndex, BodyIndex>;

/// true when a and b hold the same bits (so -0.0 != 0.0, and NaN == the same NaN).
template <class T>
bool same_bits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

bool same_bits(const Contact& a, const Contact& b) {
  return a.body_a == b.body_a && a.body_b == b.body_b && same_bits(a.point, b.point) &&
         same_bits(a.normal, b.normal) && same_bits(a.gap, b.gap) && a.feature_a == b.feature_a &&
         a.feature_b == b.feature_b && same_bits(a.alpha, b.alpha) && same_bits(a.impulse, b.impulse);
}

/// The speculative reach of every body of the scene (collision::speculative_reach, returned).
std::vector<double> reach_of(const scenes::Scene& scene, double dt, const Vec3& gravity) {
  std::vector<double> reach;
  collision::speculative_reach(scene.model, scene.state, dt, gravity, reach);
  return reach;
}

/// The broad phase's pairs (BroadPhase::pairs, returned).
std::vector<Pair> pairs_of(collision::BroadPhase& broad_phase, const scenes::Scene& scene,
                           const std::vector<double>& reach, double margin) {
  std::vector<Pair> out;
  broad_phase.pairs(scene.model, scene.state, reach, margin, out);
  return out;
}

/// Every pair (i < j, not both static) whose narrow phase gives at least one contact with
/// threshold margin + reach_i + reach_j, by trying all of them.
std::vector<Pair> brute_force_pairs(const scenes::Scene& scene, const std::vector<double>& reach, double margin) {
  std::vector<Pair> pairs;
  std::vector<Contact> out;
  const BodyIndex n = static_cast<BodyIndex>(scene.size());
  for (BodyIndex i = 0; i < n; ++i)
    for (BodyIndex j = i + 1; j < n; ++j) {
      if (scene.model.is_static[i] && scene.model.is_static[j]) continue;
      out.clear();
      collision::collide(scene.model.shape[i], {scene.state.p[i], scene.state.R[i]}, scene.model.shape[j],
                         {scene.state.p[j], scene.state.R[j]}, margin + reach[i] + reach[j], {}, out);
      if (!out.empty()) pairs.emplace_back(i, j);
    }
  return pairs;
}


using Ids = std::vector<std::pair<FeatureId, FeatureId>>;

Ids ids_of(const std::vector<Contact>& contacts) {
  Ids ids;
  for (const Contact& c : contacts) ids.emplace_back(c.feature_a, c.feature_b);
  return ids;
}

/// A unit box (half extents 0.5, 1000 kg/m^3) placed exactly resting (bottom at z = 0) on the
/// static floor body 0 of `world`, stepped 240 times at dt = 1/240: exactly 4 contacts every step,
/// with the (feature_a, feature_b) ids of the first step, and the height within 1e-6 m of 0.5.
void expect_steady_rest(World& world, const Vec3& xy, const Mat3& R) {
  BodyDesc box;
  box.shape = Box(Vec3(0.5, 0.5, 0.5));
  box.density = 1000.0;
  box.position = Vec3(xy.x(), xy.y(), 0.5);
  box.orientation = math::matrix_to_quat(R);
  const BodyIndex b = world.add_body(box);
  Ids first;
  double drift = 0.0;
  int wrong_count = 0, changed_ids = 0;
  for (int step = 0; step < 240; ++step) {
    world.step(1.0 / 240.0);
    const auto& contacts = world.contacts();
    if (contacts.size() != 4u) {
      if (wrong_count++ < 5)
        ADD_FAILURE() << "step " << step << ": " << contacts.size() << " contacts, expected 4";
    }
    if (step == 0) first = ids_of(contacts);
    if (ids_of(contacts) != first) {
      if (changed_ids++ < 5) {
        std::string what;
        for (const auto& [fa, fb] : ids_of(contacts))
          what += " (" + std::to_string(fa) + ", " + std::to_string(fb) + ")";
        ADD_FAILURE() << "step " << step << ": feature ids changed to" << what;
      }
    }
    drift = std::max(drift, std::abs(world.state().p[b].z() - 0.5));
  }
  EXPECT_EQ(wrong_count, 0) << "steps without exactly 4 contacts";
  EXPECT_EQ(changed_ids, 0) << "steps whose feature ids differ from step 0's";
  EXPECT_LE(drift, 1e-6) << "largest |z - 0.5| over 240 steps (m)";
  EXPECT_LE((world.state().p[b].head<2>() - xy.head<2>()).norm(), 1e-6) << "the box slid";
}

}  // namespace

// ---- broad phase -------------------------------------------------------------------------------

TEST(BroadPhase, FindsEveryPairThatBruteForceFindsOnRandomScenes) {
  // 200 random convex bodies (spheres, boxes, capsules, cylinders, hulls; sizes 0.05..0.4 m) in a
  // 4.5 m cube, 20 % static, speeds up to 5 m/s and spins up to 8 rad/s per axis, dt = 1/60 s:
  // every pair with narrow-phase contacts at the speculative threshold must be a candidate. (With
  // these speeds, AABBs not grown by reach + margin would miss some of them: printed as context.)
  const double dt = 1.0 / 60.0, margin = 0.005;
  const Vec3 gravity(0, 0, -9.81);
  std::size_t brute_total = 0, broad_total = 0;
  for (std::uint64_t seed : {1u, 2u, 3u, 4u, 5u, 6u}) {
    const scenes::Scene scene =
        scenes::random_scene(seed, 200, scenes::Mix::AllConvex, 4.5, 0.05, 0.4, 5.0, 8.0, 0.2);
    collision::BroadPhase broad_phase;
    scenes::register_bodies(scene, broad_phase);
    const std::vector<double> reach = reach_of(scene, dt, gravity);
    const std::vector<Pair> broad = pairs_of(broad_phase, scene, reach, margin);
    const std::vector<Pair> brute = brute_force_pairs(scene, reach, margin);
    ASSERT_FALSE(brute.empty()) << "seed " << seed << ": the scene has no contacts to find";
    EXPECT_TRUE(std::is_sorted(broad.begin(), broad.end())) << "seed " << seed;
    const std::set<Pair> found(broad.begin(), broad.end());
    EXPECT_EQ(found.size(), broad.size()) << "seed " << seed << ": duplicate pairs";
    for (const auto& [i, j] : broad) {
      EXPECT_LT(i, j);
      EXPECT_FALSE(scene.model.is_static[i] && scene.model.is_static[j]) << "static pair " << i << ", " << j;
    }
    for (const Pair& p : brute)
      EXPECT_TRUE(found.count(p)) << "seed " << seed << ": broad phase misses pair (" << p.first << ", "
                                  << p.second << ") " << shape_name(scene.model.shape[p.first]) << " - "
                                  << shape_name(scene.model.shape[p.second]);
    // context: how many of the brute-force pairs bare AABBs (no reach, no margin) would miss
    const std::vector<Pair> bare = pairs_of(broad_phase, scene, std::vector<double>(scene.size(), 0.0), 0.0);
    const std::set<Pair> bare_found(bare.begin(), bare.end());
    std::size_t need_growth = 0;
    for (const Pair& p : brute) need_growth += bare_found.count(p) ? 0 : 1;
    std::printf("[          ] seed %llu: %zu brute-force pairs, %zu broad-phase pairs (ratio %.2f); "
                "%zu need the reach + margin growth\n",
                static_cast<unsigned long long>(seed), brute.size(), broad.size(),
                static_cast<double>(broad.size()) / static_cast<double>(brute.size()), need_growth);
    brute_total += brute.size();
    broad_total += broad.size();
  }
  std::printf("[          ] all seeds: broad-phase / brute-force pairs = %zu / %zu = %.2f\n", broad_total,
              brute_total, static_cast<double>(broad_total) / static_cast<double>(brute_total));
}

TEST(BroadPhase, BodiesAddedAfterTheTreesAreBuiltAreFoundOneAtATimeOrManyAtOnce) {
  // the leaves of added bodies enter the trees at the next pairs(): the first 100 as a tree built
  // at once, then one at a time (inserted into it) and then many (the tree built anew with them);
  // each time, the pairs are those of a broad phase given all the bodies at once
  const double dt = 1.0 / 60.0, margin = 0.005;
  const scenes::Scene scene = scenes::random_scene(7, 200, scenes::Mix::AllConvex, 4.5, 0.05, 0.4, 5.0, 8.0, 0.2);
  const std::vector<double> reach = reach_of(scene, dt, Vec3(0, 0, -9.81));
  const auto add = [&](collision::BroadPhase& broad_phase, std::size_t i) {
    broad_phase.add_body(static_cast<BodyIndex>(i), scene.model.shape[i], scene.model.is_static[i], scene.state.p[i],
                         scene.state.R[i]);
  };
  collision::BroadPhase grown;
  std::size_t n = 0;
  for (const std::size_t upto : {100u, 101u, 102u, 160u, 200u}) {
    for (; n < upto; ++n) add(grown, n);
    collision::BroadPhase fresh;
    for (std::size_t i = 0; i < upto; ++i) add(fresh, i);
    const std::vector<Pair> expected = pairs_of(fresh, scene, reach, margin);
    ASSERT_FALSE(expected.empty()) << upto << " bodies";
    EXPECT_EQ(pairs_of(grown, scene, reach, margin), expected) << upto << " bodies";
  }
}

TEST(BroadPhase, SleepingBodiesArePairedWithAwakeOnesOnlyAsTheyFallAsleepAndWake) {
  // the same random scenes with a share of the dynamic bodies asleep (state.awake 0, at rest):
  // no pair of two sleeping bodies or of a sleeping and a static one; every brute-force pair with
  // an awake side found; then the sleepers wake and others fall asleep (the bodies change trees)
  const double dt = 1.0 / 60.0, margin = 0.005;
  const Vec3 gravity(0, 0, -9.81);
  for (std::uint64_t seed : {7u, 8u, 9u}) {
    scenes::Scene scene = scenes::random_scene(seed, 200, scenes::Mix::AllConvex, 4.5, 0.05, 0.4, 5.0, 8.0, 0.2);
    collision::BroadPhase broad_phase;
    scenes::register_bodies(scene, broad_phase);
    const std::size_t n = scene.size();
    for (int round = 0; round < 3; ++round) {
      scene.state.awake.assign(n, 1);
      for (std::size_t i = 0; i < n; ++i) {
        const bool sleeps = scene.model.is_static[i] || (i + round) % 3 == 0;
        scene.state.awake[i] = sleeps ? 0 : 1;
        if (sleeps) scene.state.v[i].setZero(), scene.state.omega[i].setZero();
      }
      const std::vector<double> reach = reach_of(scene, dt, gravity);
      const std::vector<Pair> broad = pairs_of(broad_phase, scene, reach, margin);
      const std::set<Pair> found(broad.begin(), broad.end());
      std::size_t with_sleeper = 0;
      for (const auto& [i, j] : broad) {
        EXPECT_TRUE(scene.state.awake[i] || scene.state.awake[j]) << "seed " << seed << ": pair " << i << ", " << j;
        with_sleeper += !(scene.state.awake[i] && scene.state.awake[j]);
      }
      EXPECT_GT(with_sleeper, 0u) << "seed " << seed << ": no awake-sleeping pair to test";
      for (const Pair& p : brute_force_pairs(scene, reach, margin))
        if (scene.state.awake[p.first] || scene.state.awake[p.second])
          EXPECT_TRUE(found.count(p)) << "seed " << seed << ", round " << round << ": misses (" << p.first << ", "
                                      << p.second << ")";
    }
  }
}

TEST(BroadPhase, KeepsFindingThemWhileBodiesMove) {
  // the incremental refit: the same check after 30 steps of drift, every 10th step
  const double dt = 1.0 / 60.0, margin = 0.005, side = 4.5;
  const Vec3 gravity(0, 0, -9.81);
  scenes::Scene scene = scenes::random_scene(11, 200, scenes::Mix::AllConvex, side, 0.05, 0.4, 5.0, 8.0, 0.2);
  collision::BroadPhase broad_phase;
  scenes::register_bodies(scene, broad_phase);
  for (int step = 0; step <= 30; ++step) {
    const std::vector<double> reach = reach_of(scene, dt, gravity);
    const std::vector<Pair> broad = pairs_of(broad_phase, scene, reach, margin);
    if (step % 10 == 0) {
      const std::set<Pair> found(broad.begin(), broad.end());
      for (const Pair& p : brute_force_pairs(scene, reach, margin))
        EXPECT_TRUE(found.count(p)) << "step " << step << ": broad phase misses (" << p.first << ", " << p.second << ")";
    }
    scenes::drift(scene, dt, side);
  }
}

/// Every pair (i < j) whose boxes overlap: a body's tight box grown by margin/2, and by its reach
/// too while it is dynamic and awake; at least one side dynamic and awake (what pairs() promises).
std::vector<Pair> box_pairs(const scenes::Scene& scene, const std::vector<double>& reach, double margin) {
  const std::size_t n = scene.size();
  std::vector<Vec3> lo(n), hi(n);
  for (std::size_t i = 0; i < n; ++i) {
    collision::shape_aabb(scene.model.shape[i], Pose{scene.state.p[i], scene.state.R[i]}, lo[i], hi[i]);
    const bool awake = !scene.model.is_static[i] && !scene.state.asleep(static_cast<BodyIndex>(i));
    const double grow = 0.5 * margin + (awake ? reach[i] : 0.0);
    lo[i] -= Vec3::Constant(grow);
    hi[i] += Vec3::Constant(grow);
  }
  const auto awake = [&](std::size_t i) { return !scene.model.is_static[i] && !scene.state.asleep(static_cast<BodyIndex>(i)); };
  std::vector<Pair> pairs;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j)
      if ((awake(i) || awake(j)) && (lo[i].array() <= hi[j].array()).all() && (lo[j].array() <= hi[i].array()).all())
        pairs.emplace_back(static_cast<BodyIndex>(i), static_cast<BodyIndex>(j));
  return pairs;
}

TEST(BroadPhase, FatBoxesGiveExactlyThePairsWhoseBoxesOverlapWhateverMoves) {
  // the tree holds fat boxes and is walked again only when a box leaves its fat one; the pairs must
  // still be exactly those whose boxes overlap now, step after step, whether nothing moved, a few
  // bodies moved (their leaves looked up alone) or most did (the tree walked whole), and as bodies
  // fall asleep and wake
  const double dt = 1.0 / 60.0, margin = 0.005, side = 4.5;
  const Vec3 gravity(0, 0, -9.81);
  scenes::Scene scene = scenes::random_scene(12, 200, scenes::Mix::AllConvex, side, 0.05, 0.4, 5.0, 8.0, 0.2);
  const std::size_t n = scene.size();
  const State start = scene.state;
  collision::BroadPhase broad_phase;
  scenes::register_bodies(scene, broad_phase);
  std::mt19937_64 rng(5);
  int mismatched = 0;
  for (int step = 0; step < 120; ++step) {
    // phases of 20 steps: all move at full speed, nothing moves, a few creep, a few jump, sleep
    // comes and goes, all move again
    const int phase = step / 20;
    for (std::size_t i = 0; i < n; ++i) {
      if (scene.model.is_static[i]) continue;
      const double scale = phase == 0 || phase == 5 ? 1.0 : phase == 1 ? 0.0 : (i % 17 == 0 ? 1.0 : 0.0);
      scene.state.v[i] = scale * start.v[i];
      scene.state.omega[i] = scale * start.omega[i];
      if (phase == 3 && i % 17 == 0 && rng() % 4 == 0) scene.state.p[i] += Vec3(0.3, -0.2, 0.25);
    }
    scene.state.awake.assign(n, 1);
    if (phase == 4)
      for (std::size_t i = 0; i < n; ++i)
        if (!scene.model.is_static[i] && (i + static_cast<std::size_t>(step / 5)) % 3 == 0) {
          scene.state.awake[i] = 0;
          scene.state.v[i].setZero();
          scene.state.omega[i].setZero();
        }
    const std::vector<double> reach = reach_of(scene, dt, gravity);
    const std::vector<Pair> broad = pairs_of(broad_phase, scene, reach, margin);
    const std::vector<Pair> exact = box_pairs(scene, reach, margin);
    if (broad != exact && mismatched++ < 5)
      ADD_FAILURE() << "step " << step << " (phase " << phase << "): " << broad.size() << " pairs, the boxes give "
                    << exact.size();
    EXPECT_FALSE(exact.empty()) << "step " << step;
    scenes::drift(scene, dt, side);
  }
  EXPECT_EQ(mismatched, 0);
}

// ---- determinism -------------------------------------------------------------------------------

TEST(BroadPhase, EscapedBodiesMeetEveryBodyTheirBoxesNowReach) {
  // within a step: after pairs() at the step's start, most dynamic bodies move within their reach
  // (a shift of 0.9 reach), while 20 escape it (shifted 0.3 to 0.6 m and turned): escaped_pairs
  // must give every pair of an escaped body whose boxes at the new poses, grown by the reach from
  // there + margin/2, overlap (the candidates a detection now would test), and only such pairs
  const double dt = 1.0 / 60.0, margin = 0.005, side = 4.5;
  const Vec3 gravity(0, 0, -9.81);
  for (std::uint64_t seed : {21u, 22u, 23u}) {
    scenes::Scene scene = scenes::random_scene(seed, 200, scenes::Mix::AllConvex, side, 0.05, 0.4, 5.0, 8.0, 0.2);
    collision::BroadPhase broad_phase;
    scenes::register_bodies(scene, broad_phase);
    const std::vector<double> reach = reach_of(scene, dt, gravity);
    pairs_of(broad_phase, scene, reach, margin);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const auto direction = [&] {
      Vec3 d(u(rng), u(rng), u(rng));
      return Vec3(d.norm() > 1e-3 ? Vec3(d.normalized()) : Vec3::UnitX());
    };
    std::vector<BodyIndex> escaped;
    for (std::size_t i = 0; i < scene.size(); ++i) {
      if (scene.model.is_static[i]) continue;
      if (escaped.size() < 20 && i % 7 == 3) {
        escaped.push_back(static_cast<BodyIndex>(i));
        scene.state.p[i] += (0.3 + 0.3 * std::abs(u(rng))) * direction();
        scene.state.R[i] = math::rodrigues(direction(), 1.0) * scene.state.R[i];
      } else {
        scene.state.p[i] += 0.9 * reach[i] * direction();
      }
    }
    ASSERT_EQ(escaped.size(), 20u);
    const std::vector<double> now = reach_of(scene, 0.5 * dt, gravity);
    double bound = 0.0;
    for (double r : now) bound = std::max(bound, r);
    std::vector<Pair> found;
    std::vector<BodyIndex> met;
    std::vector<const void*> stack;
    broad_phase.escaped_pairs(scene.model, scene.state, escaped, now, bound, margin, found, met, stack);
    EXPECT_TRUE(std::is_sorted(found.begin(), found.end()));
    EXPECT_EQ(std::set<Pair>(found.begin(), found.end()).size(), found.size()) << "duplicate pairs";
    const auto is_escaped = [&](BodyIndex i) { return std::binary_search(escaped.begin(), escaped.end(), i); };
    std::size_t expected = 0;
    const std::set<Pair> found_set(found.begin(), found.end());
    for (const Pair& p : box_pairs(scene, now, margin)) {
      if (!is_escaped(p.first) && !is_escaped(p.second)) continue;
      ++expected;
      EXPECT_TRUE(found_set.count(p)) << "seed " << seed << ": misses (" << p.first << ", " << p.second << ")";
    }
    const std::vector<Pair> all = box_pairs(scene, now, margin);
    const std::set<Pair> all_set(all.begin(), all.end());
    for (const Pair& p : found) {
      EXPECT_TRUE(is_escaped(p.first) || is_escaped(p.second)) << "(" << p.first << ", " << p.second << ")";
      EXPECT_TRUE(all_set.count(p)) << "(" << p.first << ", " << p.second << ") whose boxes do not overlap";
    }
    EXPECT_GT(expected, 0u) << "seed " << seed << ": no escaped body meets another";
  }
}

TEST(Determinism, CollideTwiceGivesBitIdenticalContacts) {
  // every pair of a random scene that has contacts, collided twice (with other pairs in between,
  // so that scratch buffers are reused), gives the same bits
  const scenes::Scene scene = scenes::random_scene(21, 120, scenes::Mix::AllConvex, 3.0, 0.05, 0.4, 0.0, 0.0, 0.0);
  const double threshold = 0.02;
  std::vector<std::vector<Contact>> first;
  std::vector<Pair> pairs;
  for (int pass = 0; pass < 2; ++pass) {
    std::size_t k = 0;
    for (BodyIndex i = 0; i < static_cast<BodyIndex>(scene.size()); ++i)
      for (BodyIndex j = i + 1; j < static_cast<BodyIndex>(scene.size()); ++j) {
        std::vector<Contact> out;
        collision::collide(scene.model.shape[i], {scene.state.p[i], scene.state.R[i]}, scene.model.shape[j],
                           {scene.state.p[j], scene.state.R[j]}, threshold, {}, out);
        if (pass == 0) {
          if (out.empty()) continue;
          pairs.emplace_back(i, j);
          first.push_back(out);
          continue;
        }
        if (k < pairs.size() && pairs[k] == Pair(i, j)) {
          ASSERT_EQ(out.size(), first[k].size()) << "pair " << i << ", " << j;
          for (std::size_t c = 0; c < out.size(); ++c)
            EXPECT_TRUE(same_bits(out[c], first[k][c])) << "pair " << i << ", " << j << " contact " << c;
          ++k;
        } else {
          EXPECT_TRUE(out.empty()) << "pair " << i << ", " << j << " has contacts only the second time";
        }
      }
    if (pass == 1) EXPECT_EQ(k, pairs.size());
  }
  EXPECT_GE(pairs.size(), 20u) << "too few touching pairs to say much";
}

TEST(Determinism, FiftyBoxesDroppedOnAPlaneTwiceGiveBitIdenticalStates) {
  auto run = []() {
    World world;
    BodyDesc ground;
    ground.shape = Plane(Vec3::UnitZ(), 0.0);
    ground.is_static = true;
    world.add_body(ground);
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int k = 0; k < 50; ++k) {
      BodyDesc d;
      d.shape = Box(Vec3(0.1 + 0.2 * u(rng), 0.1 + 0.2 * u(rng), 0.1 + 0.2 * u(rng)));
      d.density = 500.0 + 1000.0 * u(rng);
      // a 2 m x 2 m column, 5 layers: they land on the plane and on each other
      d.position = Vec3(2.0 * u(rng) - 1.0, 2.0 * u(rng) - 1.0, 0.5 + 0.8 * (k / 10) + 0.3 * u(rng));
      d.orientation = math::matrix_to_quat(scenes::random_rotation(rng));
      d.angular_velocity = scenes::random_vector(rng, 2.0);
      world.add_body(d);
    }
    std::vector<std::size_t> contacts;
    for (int s = 0; s < 200; ++s) {
      world.step(1.0 / 240.0);
      contacts.push_back(world.contacts().size());
    }
    return std::make_pair(world.state(), contacts);
  };
  const auto [a, ca] = run();
  const auto [b, cb] = run();
  EXPECT_EQ(ca, cb) << "contact counts per step differ";
  std::size_t touching = 0;
  for (std::size_t c : ca) touching = std::max(touching, c);
  EXPECT_GT(touching, 0u) << "no contacts: the test checks only free flight";
  ASSERT_EQ(a.p.size(), b.p.size());
  EXPECT_TRUE(same_bits(a.time, b.time));
  for (std::size_t i = 0; i < a.p.size(); ++i) {
    EXPECT_TRUE(same_bits(a.p[i], b.p[i])) << "body " << i;
    EXPECT_TRUE(same_bits(a.R[i], b.R[i])) << "body " << i;
    EXPECT_TRUE(same_bits(a.v[i], b.v[i])) << "body " << i;
    EXPECT_TRUE(same_bits(a.omega[i], b.omega[i])) << "body " << i;
  }
}

// ---- resting manifolds -------------------------------------------------------------------------

TEST(Resting, BoxOnABoxKeepsFourContactsWithTheSameIds) {
  World world;
  BodyDesc ground;
  ground.shape = Box(Vec3(2.0, 2.0, 0.5));
  ground.is_static = true;
  ground.position = Vec3(0, 0, -0.5);  // top face at z = 0
  world.add_body(ground);
  expect_steady_rest(world, Vec3(0.13, -0.07, 0.0), Eigen::AngleAxisd(0.2, Vec3::UnitZ()).toRotationMatrix());
}

TEST(Resting, BoxOnATriangleMeshFloorKeepsFourContactsWithTheSameIds) {
  // a flat 4 x 4-cell grid of 32 triangles, [-2, 2]^2 at z = 0; the box covers interior edges
  World world;
  BodyDesc floor;
  floor.shape = scenes::floor_mesh(2.0, 4);
  floor.is_static = true;
  ASSERT_EQ(std::get<TriangleMesh>(floor.shape).faces.rows(), 32);
  world.add_body(floor);
  expect_steady_rest(world, Vec3(0.13, -0.07, 0.0), Eigen::AngleAxisd(0.2, Vec3::UnitZ()).toRotationMatrix());
}

// ---- the separating-face cache ----------------------------------------------------------------

TEST(SeparatingFaceCache, DetectionWithTheCacheIsBitIdenticalToDetectionWithout) {
  // 60 steps of a drifting crowd of boxes and hulls: contacts detected with a kept contact memory
  // (whose cache carries each pair's separating face from step to step) against a fresh memory
  // every step (no cache), bit for bit; and the cache must have been used
  const double dt = 1.0 / 240.0, margin = 0.005, side = 2.5;
  const Vec3 gravity(0, 0, -9.81);
  scenes::Scene scene = scenes::random_scene(5, 120, scenes::Mix::AllConvex, side, 0.1, 0.4, 1.0, 3.0, 0.1);
  collision::BroadPhase broad_phase;
  scenes::register_bodies(scene, broad_phase);
  collision::Scratch scratch;
  collision::ContactMemory kept;
  std::size_t hits_possible = 0, compared = 0;
  for (int step = 0; step < 60; ++step) {
    std::vector<Contact> with_cache, without;
    collision::generate_contacts(scene.model, scene.state, dt, gravity, margin, broad_phase, kept, scratch, with_cache);
    collision::ContactMemory fresh;
    collision::Scratch fresh_scratch;
    collision::generate_contacts(scene.model, scene.state, dt, gravity, margin, broad_phase, fresh, fresh_scratch,
                                 without);
    ASSERT_EQ(with_cache.size(), without.size()) << "step " << step;
    for (std::size_t k = 0; k < without.size(); ++k)
      ASSERT_TRUE(same_bits(with_cache[k], without[k])) << "step " << step << ", contact " << k;
    compared += without.size();
    hits_possible += kept.separating.last.size();
    scenes::drift(scene, dt, side);
  }
  EXPECT_GT(compared, 1000u);
  EXPECT_GT(hits_possible, 1000u) << "the cache held few separating faces: nothing was tested";
}

TEST(BroadPhase, BoxesAreTightAroundRotatedShapesNotTheirBoundingSpheres) {
  // a long thin capsule (half length 1 m, radius 5 cm) turned 30 degrees about z, with small
  // spheres where its bounding sphere's box reaches but the capsule does not, and one sphere
  // touching its end: only that one is a candidate pair
  scenes::Scene scene;
  const Mat3 R = Eigen::AngleAxisd(M_PI / 6.0, Vec3::UnitZ()).toRotationMatrix() *
                 Eigen::AngleAxisd(M_PI / 2.0, Vec3::UnitY()).toRotationMatrix();  // axis along (cos 30, sin 30, 0)
  scene.add(Capsule(0.05, 1.0), false, Vec3::Zero(), R, Vec3::Zero(), Vec3::Zero());
  for (const Vec3& p : {Vec3(0.0, 0.0, 0.9), Vec3(0.0, 0.0, -0.9), Vec3(-0.5, 0.8, 0.0), Vec3(0.5, -0.8, 0.0),
                        Vec3(0.8, 0.5, 0.7), Vec3(-0.8, -0.5, -0.7)})
    scene.add(Sphere(0.05), false, p, Mat3::Identity(), Vec3::Zero(), Vec3::Zero());
  const Vec3 end = 1.05 * Vec3(std::cos(M_PI / 6.0), std::sin(M_PI / 6.0), 0.0);
  scene.add(Sphere(0.05), false, end + Vec3(0.04, 0.0, 0.0), Mat3::Identity(), Vec3::Zero(), Vec3::Zero());
  collision::BroadPhase broad_phase;
  scenes::register_bodies(scene, broad_phase);
  const std::vector<double> reach(scene.size(), 0.0);
  const std::vector<Pair> pairs = pairs_of(broad_phase, scene, reach, 0.005);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0], Pair(0, 7));
}
