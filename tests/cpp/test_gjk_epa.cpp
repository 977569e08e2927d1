// GJK / EPA (collision/gjk_epa.hpp) on seeded random pairs of every item kind that the support
// path sees (sphere, box, capsule, cylinder, convex hull, a mesh triangle), separated, touching and
// deeply overlapping, against independent references:
//   - closed forms where they exist: sphere-sphere, sphere-cylinder, sphere-box, sphere-capsule,
//     capsule-capsule (segment distances), a cylinder on a slab and on a large triangle, and the
//     separating axes of two polytopes when they overlap (then the deepest axis is the depth);
//   - for the rest, a brute-force search of g(d) = (s_B(-d) - s_A(d)) . d over a dense Fibonacci
//     grid of directions, refined by a pattern search; g(d) <= signed distance for every d, so the
//     reference can only fall short, never exceed;
//   - on every pair, a certificate: the reported gap is an upper bound (GJK: the distance of two
//     points of the shapes; EPA: the depth of a polytope inside the Minkowski difference) and
//     g(normal) a lower bound, so gap - g(normal) >= |gap - signed distance|.
// Tolerance 1e-9 m on shapes of 0.1 - 1 m: GJK stops at a duality gap of 1e-12 of the pair's scale
// (a few metres here), EPA at 1e-10 L (L = sum of bounding radii <= 3.5 m), so both stay below
// 1e-9 m with a margin; 1e-9 m is also the target. The largest errors are printed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <string>

#include "collision/collision.hpp"
#include "collision/gjk_epa.hpp"
#include "random_scene.hpp"

using namespace signorini;
using collision::Distance;
using collision::GjkEpaStats;
using collision::Item;
using collision::Pose;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTol = 1e-9;  // m

enum Kind { kSphere, kBox, kCapsule, kCylinder, kHull, kTriangle, kKinds };
const char* kKindName[kKinds] = {"sphere", "box", "capsule", "cylinder", "hull", "triangle"};

/// One random item and the shape it points to (kept alive here).
struct Body {
  Kind kind;
  std::unique_ptr<Sphere> sphere;
  std::unique_ptr<Box> box;
  std::unique_ptr<Capsule> capsule;
  std::unique_ptr<Cylinder> cylinder;
  std::unique_ptr<ConvexHull> hull;
  std::unique_ptr<Polytope> triangle;
  Item item;
};

/// A triangle as a two-faced polytope (as the triangle-mesh path builds it), vertices in its frame.
std::unique_ptr<Polytope> triangle_polytope(const Vec3& v0, const Vec3& v1, const Vec3& v2) {
  auto P = std::make_unique<Polytope>();
  P->vertices.resize(3, 3);
  P->vertices.row(0) = v0.transpose();
  P->vertices.row(1) = v1.transpose();
  P->vertices.row(2) = v2.transpose();
  P->faces = {{0, 1, 2}, {0, 2, 1}};
  P->face_edges = {{0, 1, 2}, {2, 1, 0}};
  P->edges = {{0, 1, 0, 1}, {1, 2, 0, 1}, {2, 0, 0, 1}};
  const Vec3 n = (v1 - v0).cross(v2 - v0).normalized();
  P->normals = {n, -n};
  P->offsets = {n.dot(v0), -n.dot(v0)};
  P->centroid = (v0 + v1 + v2) / 3.0;
  return P;
}

/// A random body of the given kind, sizes (radii, half extents) in [0.1, 1] m, at pose.
std::unique_ptr<Body> random_body(std::mt19937_64& rng, Kind kind, const Pose& pose) {
  std::uniform_real_distribution<double> size(0.1, 1.0);
  auto b = std::make_unique<Body>();
  b->kind = kind;
  Item& it = b->item;
  switch (kind) {
    case kSphere: b->sphere = std::make_unique<Sphere>(size(rng)), it.sphere = b->sphere.get(); break;
    case kBox:
      b->box = std::make_unique<Box>(Vec3(size(rng), size(rng), size(rng)));
      it.box = b->box.get(), it.polytope = b->box->polytope.get();
      break;
    case kCapsule:
      b->capsule = std::make_unique<Capsule>(size(rng), size(rng)), it.capsule = b->capsule.get();
      break;
    case kCylinder:
      b->cylinder = std::make_unique<Cylinder>(size(rng), size(rng)), it.cylinder = b->cylinder.get();
      break;
    case kHull:
      b->hull = std::make_unique<ConvexHull>(scenes::random_hull(rng, 24, Vec3(size(rng), size(rng), size(rng))));
      it.hull = b->hull.get(), it.polytope = b->hull->polytope.get();
      break;
    default: {
      // a triangle of sides 0.2 - 2 m about its frame's origin
      const Vec3 v0 = scenes::random_vector(rng, 1.0), v1 = scenes::random_vector(rng, 1.0);
      Vec3 v2 = scenes::random_vector(rng, 1.0);
      while ((v1 - v0).cross(v2 - v0).norm() < 0.05) v2 = scenes::random_vector(rng, 1.0);
      const Vec3 c = (v0 + v1 + v2) / 3.0;
      b->triangle = triangle_polytope(v0 - c, v1 - c, v2 - c);
      it.polytope = b->triangle.get();
    }
  }
  it.pose = pose;
  return b;
}

/// g(d) = (s_B(-d) - s_A(d)) . d, d unit: the gap between A's support plane along d and B's
/// along -d. Its maximum over the sphere is the signed distance, so every value is a lower bound.
double support_gap(const Item& a, const Item& b, const Vec3& d) {
  return (collision::support_point(b, -d) - collision::support_point(a, d)).dot(d);
}

/// Pattern search for a local maximum of g from d: 24 directions on a cone about d, the cone
/// shrinking by half when none improves, from rho to 1e-12 rad (at most `budget` evaluations).
void climb(const Item& a, const Item& b, Vec3& d, double& g, double rho, int budget) {
  while (rho > 1e-12 && budget > 0) {
    const Vec3 e1 = (std::abs(d.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(d).normalized();
    const Vec3 e2 = d.cross(e1);
    Vec3 best_d = d;
    double best_g = g;
    for (int k = 0; k < 24; ++k, --budget) {
      const double phi = k * kPi / 12.0;
      const Vec3 t = (std::cos(rho) * d + std::sin(rho) * (std::cos(phi) * e1 + std::sin(phi) * e2)).normalized();
      const double gt = support_gap(a, b, t);
      if (gt > best_g) best_g = gt, best_d = t;
    }
    if (best_g > g) {
      g = best_g, d = best_d;
      rho *= 1.5;
    } else {
      rho *= 0.5;
    }
  }
}

/// Brute-force signed distance: g on a Fibonacci grid of n directions, the best 4 climbed.
double brute_force_distance(const Item& a, const Item& b, int n) {
  std::vector<std::pair<double, Vec3>> seeds;
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < n; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / n, r = std::sqrt(1.0 - z * z);
    const Vec3 d(r * std::cos(golden * k), r * std::sin(golden * k), z);
    seeds.emplace_back(support_gap(a, b, d), d);
  }
  std::partial_sort(seeds.begin(), seeds.begin() + 4, seeds.end(),
                    [](const auto& x, const auto& y) { return x.first > y.first; });
  double best = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4; ++k) {
    Vec3 d = seeds[k].second;
    double g = seeds[k].first;
    climb(a, b, d, g, 2.0 * std::sqrt(4.0 * kPi / n), 200000);
    best = std::max(best, g);
  }
  return best;
}

// ---- closed forms ----

/// Signed distance of point x (world) to a box / cylinder item.
double point_box(const Item& it, const Vec3& x) {
  const Vec3 q = (it.pose.R.transpose() * (x - it.pose.p)).cwiseAbs() - it.box->half_extents;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}
double point_cylinder(const Item& it, const Vec3& x) {
  const Vec3 q = it.pose.R.transpose() * (x - it.pose.p);
  const double dr = std::hypot(q.x(), q.y()) - it.cylinder->radius, dz = std::abs(q.z()) - it.cylinder->half_height;
  return std::hypot(std::max(dr, 0.0), std::max(dz, 0.0)) + std::min(std::max(dr, dz), 0.0);
}

/// A capsule's or sphere's core segment (world) and radius.
void core_segment(const Item& it, Vec3& p0, Vec3& p1, double& r) {
  if (it.sphere) {
    p0 = p1 = it.pose.p, r = it.sphere->radius;
    return;
  }
  const Vec3 h = it.capsule->half_length * it.pose.R.col(2);
  p0 = it.pose.p - h, p1 = it.pose.p + h, r = it.capsule->radius;
}

/// Distance of point x to segment p0 p1.
double point_segment(const Vec3& x, const Vec3& p0, const Vec3& p1) {
  const Vec3 s = p1 - p0;
  const double ss = s.squaredNorm();
  const double t = ss > 0.0 ? std::clamp((x - p0).dot(s) / ss, 0.0, 1.0) : 0.0;
  return (x - p0 - t * s).norm();
}

/// Distance of two segments: a ternary search over the first one (the distance to a segment is
/// convex along a line).
double segment_segment(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  double lo = 0.0, hi = 1.0;
  for (int k = 0; k < 200; ++k) {
    const double m1 = lo + (hi - lo) / 3.0, m2 = hi - (hi - lo) / 3.0;
    if (point_segment(p0 + m1 * (p1 - p0), q0, q1) <= point_segment(p0 + m2 * (p1 - p0), q0, q1)) hi = m2;
    else lo = m1;
  }
  return point_segment(p0 + 0.5 * (lo + hi) * (p1 - p0), q0, q1);
}

/// Separating-axis value of two polytope items: the largest separation over their face normals
/// and edge-edge cross products. Exactly minus the penetration depth when they overlap (the
/// depth is attained on a face normal of B - A); a lower bound of the distance otherwise.
double polytope_sat(const Item& a, const Item& b) {
  auto world_vertices = [](const Item& it) {
    std::vector<Vec3> v;
    for (Eigen::Index i = 0; i < it.polytope->vertices.rows(); ++i)
      v.push_back(it.pose.R * it.polytope->vertex(static_cast<int>(i)) + it.pose.p);
    return v;
  };
  const std::vector<Vec3> va = world_vertices(a), vb = world_vertices(b);
  auto separation = [&](Vec3 n) {
    double ha = -1e300, hb = -1e300;  // A's support along n, B's along -n
    for (const Vec3& x : va) ha = std::max(ha, n.dot(x));
    for (const Vec3& x : vb) hb = std::max(hb, -n.dot(x));
    return -ha - hb;
  };
  double best = -1e300;
  std::vector<Vec3> axes;
  for (const Item* it : {&a, &b})
    for (const Vec3& n : it->polytope->normals) axes.push_back(it->pose.R * n);
  for (const auto& ea : a.polytope->edges)
    for (const auto& eb : b.polytope->edges) {
      const Vec3 c = (a.pose.R * (a.polytope->vertex(ea.v1) - a.polytope->vertex(ea.v0)))
                         .cross(b.pose.R * (b.polytope->vertex(eb.v1) - b.polytope->vertex(eb.v0)));
      if (c.norm() > 1e-9) axes.push_back(c.normalized());
    }
  for (const Vec3& n : axes) best = std::max({best, separation(n), separation(-n)});
  return best;
}

/// The closed-form signed distance of a pair, or NaN where there is none; `exact` says whether
/// the value is exact (else a lower bound: polytopes apart).
double closed_form(const Item& a, Kind ka, const Item& b, Kind kb, bool& exact) {
  exact = true;
  const bool round_a = ka == kSphere || ka == kCapsule, round_b = kb == kSphere || kb == kCapsule;
  if (round_a && round_b) {
    Vec3 p0, p1, q0, q1;
    double ra, rb;
    core_segment(a, p0, p1, ra);
    core_segment(b, q0, q1, rb);
    return segment_segment(p0, p1, q0, q1) - ra - rb;
  }
  if (ka == kSphere && kb == kCylinder) return point_cylinder(b, a.pose.p) - a.sphere->radius;
  if (kb == kSphere && ka == kCylinder) return point_cylinder(a, b.pose.p) - b.sphere->radius;
  if (ka == kSphere && kb == kBox) return point_box(b, a.pose.p) - a.sphere->radius;
  if (kb == kSphere && ka == kBox) return point_box(a, b.pose.p) - b.sphere->radius;
  if (a.polytope && b.polytope) {
    const double sat = polytope_sat(a, b);
    exact = sat < 0.0;
    return sat;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

/// Figures per pair kind, printed at the end.
struct Figures {
  int pairs = 0, epa = 0, closed = 0, brute = 0;
  double cert = 0.0, closed_err = 0.0, brute_err = 0.0, witness = 0.0, epa_witness = 0.0;
  int max_gjk = 0, max_epa = 0;
  double sat_short = 0.0;
};

}  // namespace

// slots random: sphere-sphere, sphere-capsule, sphere-cylinder, capsule-capsule, cylinder-cylinder, cylinder-polytope (the distance routine alone)
TEST(GjkEpa, RandomPairsOfEveryKindAgreeWithClosedFormsBruteForceAndTheirCertificate) {
  std::map<std::string, Figures> table;
  int stopped_early = 0;
  std::mt19937_64 rng(20261123);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int per_kind = 600;   // pairs per kind pair: 21 x 600 = 12,600
  const int brute_every = 6;  // every 6th pair also against the brute-force search (slow)
  for (int ka = 0; ka < kKinds; ++ka)
    for (int kb = ka; kb < kKinds; ++kb) {
      if (ka == kTriangle && kb == kTriangle) continue;
      const std::string name = std::string(kKindName[ka]) + "-" + kKindName[kb];
      Figures& fig = table[name];
      for (int n = 0; n < per_kind; ++n) {
        auto A = random_body(rng, static_cast<Kind>(ka), {scenes::random_vector(rng, 0.5), scenes::random_rotation(rng)});
        const Vec3 dir = scenes::random_vector(rng, 1.0).normalized();
        auto B = random_body(rng, static_cast<Kind>(kb), {Vec3::Zero(), scenes::random_rotation(rng)});
        const double reach = A->item.radius() + B->item.radius();
        // a third deeply overlapping, a third apart, a third touching (moved along the normal)
        const int regime = n % 3;
        B->item.pose.p = A->item.pose.p + dir * (regime == 0 ? 0.4 * unit(rng) * reach : (0.3 + unit(rng)) * reach);
        if (regime == 2) {
          const Distance d0 = collision::gjk_epa(A->item, B->item);
          const double jitter = std::pow(10.0, -12.0 + 5.0 * unit(rng)) * (unit(rng) < 0.5 ? -1.0 : 1.0);
          B->item.pose.p -= (d0.gap + jitter) * d0.normal;
        }
        const Item& a = A->item;
        const Item& b = B->item;
        GjkEpaStats st;
        const Distance d = collision::gjk_epa(a, b, &st);
        ++fig.pairs;
        fig.epa += st.used_epa;
        fig.max_gjk = std::max(fig.max_gjk, st.gjk_iterations);
        fig.max_epa = std::max(fig.max_epa, st.epa_iterations);
        ASSERT_TRUE(std::isfinite(d.gap)) << name << " pair " << n;
        // EPA may stop early on a polytope that rounding has damaged (1 pair in 12,600 here, a
        // touching cylinder-hull pair): it then returns its best face, certified below
        if (!st.converged) ++stopped_early;
        const double tol = st.converged ? kTol : 1e-7;
        EXPECT_NEAR(d.normal.norm(), 1.0, 1e-12) << name << " pair " << n;
        // the certificate: gap is an upper bound and g(normal) a lower one
        const double cert = d.gap - support_gap(a, b, d.normal);
        EXPECT_GE(cert, -1e-12) << name << " pair " << n;
        EXPECT_LE(cert, tol) << name << " pair " << n << " gap " << d.gap << " epa " << st.used_epa << " gjk "
                             << st.gjk_iterations << " " << st.stop;
        fig.cert = std::max(fig.cert, cert);
        // witnesses: w_b - w_a = gap n (exactly when apart; for EPA, the point of its polytope on
        // the ray through gap n, to its tolerance or, on an unrefined neighbour face, to about the
        // shift |c|), and they lie in the support planes
        {
          const double wtol = tol + 2.0 * st.shift;
          const double err = (d.w_b - d.w_a - d.gap * d.normal).norm();
          EXPECT_LE(err, wtol) << name << " pair " << n << " epa " << st.used_epa << " shift " << st.shift;
          double& worst = st.used_epa ? fig.epa_witness : fig.witness;
          worst = std::max(worst, err);
          EXPECT_NEAR(d.normal.dot(d.w_a), d.normal.dot(collision::support_point(a, d.normal)), wtol) << name;
          EXPECT_NEAR(d.normal.dot(d.w_b), d.normal.dot(collision::support_point(b, -d.normal)), wtol) << name;
        }
        bool exact = false;
        const double ref = closed_form(a, static_cast<Kind>(ka), b, static_cast<Kind>(kb), exact);
        if (std::isfinite(ref)) {
          if (exact) {
            EXPECT_NEAR(d.gap, ref, tol) << name << " pair " << n;
            fig.closed_err = std::max(fig.closed_err, std::abs(d.gap - ref));
            ++fig.closed;
          } else {
            // apart: the separating axes bound the distance from below. Known shortfall: a pair
            // within ~1e-6 L of contact where GJK stalls goes to EPA on D shifted by ~4 |v|, which
            // can pick the wrong one of two nearly tied facets (measured up to 1.6e-8 m here)
            EXPECT_GE(d.gap, ref - 1e-7) << name << " pair " << n;
            fig.sat_short = std::max(fig.sat_short, ref - d.gap);
          }
        }
        if (n % brute_every == 0 && !(std::isfinite(ref) && exact)) {
          // one-sided: no direction the search finds beats the gap (the search itself falls short
          // along the ridges of g, by up to ~1e-3 m here: that is what the pattern search of the
          // old support_distance did too, and why the certificate above is the tight check)
          const double bf = brute_force_distance(a, b, 2048);
          EXPECT_LE(bf, d.gap + kTol) << name << " pair " << n;
          fig.brute_err = std::max(fig.brute_err, d.gap - bf);
          ++fig.brute;
        }
      }
    }
  EXPECT_LE(stopped_early, 2);
  std::printf("largest per kind pair: certificate gap - g(normal) (m), closed-form error (m), brute-force search\n"
              "shortfall gap - best g found (m, one-sided), |w_b - w_a - gap n| (m, of GJK and of EPA results),\n"
              "GJK iterations, EPA expansions; %d pair(s) stopped early\n", stopped_early);
  std::printf("%-20s %6s %5s %12s %8s %12s %10s %7s %12s %12s %12s %5s %5s\n", "pair", "pairs", "epa", "certificate",
              "closed", "closed err", "SAT short", "brute", "shortfall", "witness", "EPA witness", "gjk", "epa");
  for (const auto& [name, f] : table)
    std::printf("%-20s %6d %5d %12.2e %8d %12.2e %10.2e %7d %12.2e %12.2e %12.2e %5d %5d\n", name.c_str(), f.pairs,
                f.epa, f.cert, f.closed, f.closed_err, f.sat_short, f.brute, f.brute_err, f.witness, f.epa_witness,
                f.max_gjk, f.max_epa);
}

// slots golden: cylinder-polytope (the distance routine alone)
TEST(GjkEpa, CylinderOnASlabAndOnALargeTriangleMatchesTheClosedForm) {
  // a cylinder tilted at random above the top face z = 0 of a 10 x 10 m slab (and of a triangle
  // of sides ~20 m in z = 0): gap = z_c - h |a_z| - r sqrt(1 - a_z^2) while the lowest rim point
  // is over the face and the overlap is shallower than the slab. The slab makes the pair ~8 m
  // across (L), and EPA's tolerance is relative to L: 2e-9 m here
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Box slab(Vec3(5.0, 5.0, 0.5));
  auto tri = triangle_polytope(Vec3(-10, -10, 0), Vec3(10, -10, 0), Vec3(0, 12, 0));
  double worst = 0.0;
  for (int n = 0; n < 3000; ++n) {
    const Cylinder cyl(0.1 + 0.9 * u(rng), 0.1 + 0.9 * u(rng));
    Item c;
    c.cylinder = &cyl;
    const Mat3 R = n % 5 == 0 ? Mat3(Eigen::AngleAxisd(1e-9 * u(rng), Vec3::UnitX())) : scenes::random_rotation(rng);
    const double az = std::abs(R(2, 2));
    const double low = cyl.half_height * az + cyl.radius * std::sqrt(std::max(0.0, 1.0 - az * az));
    const double gap = (n % 3 == 0 ? 1e-9 : 0.2) * (2.0 * u(rng) - 1.0);
    c.pose = {Vec3(2.0 * u(rng) - 1.0, 2.0 * u(rng) - 1.0, low + gap), R};
    Item s;
    s.box = &slab, s.polytope = slab.polytope.get(), s.pose = {Vec3(0, 0, -0.5), Mat3::Identity()};
    Item t;
    t.polytope = tri.get();
    for (const Item* other : {&s, &t}) {
      // the thin triangle: pushing the cylinder down through it must cost more than pushing it up
      if (other == &t && -gap >= low - 1e-3) continue;
      for (int order = 0; order < 2; ++order) {
        GjkEpaStats st;
        const Distance d = order ? collision::gjk_epa(c, *other, &st) : collision::gjk_epa(*other, c, &st);
        EXPECT_TRUE(st.converged) << st.stop;
        EXPECT_NEAR(d.gap, gap, 2e-9) << "pair " << n << " " << st.stop << " epa " << st.used_epa;
        EXPECT_NEAR(std::abs(d.normal.z()), 1.0, 1e-6) << "pair " << n << " " << st.stop << " epa " << st.used_epa << " gap " << d.gap;
        worst = std::max(worst, std::abs(d.gap - gap));
      }
    }
  }
  std::printf("cylinder on slab / triangle: largest gap error %.2e m\n", worst);
}

TEST(GjkEpa, FormerlyPathologicalPairsFinishInFewIterations) {
  // the pattern search crawled along ridges of g for these (a cylinder on a triangle, a cylinder
  // standing or lying on a box, crossed and parallel cylinders, a cylinder against a 42-vertex
  // hull): iterations are counted, never timed
  std::mt19937_64 rng(11);
  const Cylinder small(0.01, 0.02), cyl(0.3, 0.5);
  const Box box(Vec3(0.5, 0.5, 0.5));
  const ConvexHull ball = scenes::random_hull(rng, 42, Vec3(0.4, 0.4, 0.4));
  auto tri = triangle_polytope(Vec3(-0.5, -0.3, 0), Vec3(0.5, -0.3, 0), Vec3(0, 0.6, 0));
  const Mat3 I = Mat3::Identity();
  const Mat3 lying = Eigen::AngleAxisd(kPi / 2, Vec3::UnitX()).toRotationMatrix();
  struct Case {
    const char* name;
    Item a, b;
  };
  std::vector<Case> cases;
  auto item_cyl = [](const Cylinder& c, const Pose& p) { Item it; it.cylinder = &c; it.pose = p; return it; };
  Item tri_item;
  tri_item.polytope = tri.get();
  Item box_item;
  box_item.box = &box, box_item.polytope = box.polytope.get();
  Item ball_item;
  ball_item.hull = &ball, ball_item.polytope = ball.polytope.get();
  cases.push_back({"small cylinder standing on a triangle", tri_item, item_cyl(small, {Vec3(0.0, 0.0, 0.02), I})});
  cases.push_back({"small cylinder lying on a triangle", tri_item, item_cyl(small, {Vec3(0.0, 0.0, 0.01), lying})});
  cases.push_back({"cylinder standing on a box", box_item, item_cyl(cyl, {Vec3(0.1, 0.2, 1.0), I})});
  cases.push_back({"cylinder lying on a box", box_item, item_cyl(cyl, {Vec3(0.1, 0.2, 0.8), lying})});
  cases.push_back({"cylinder rim on a box edge", box_item,
                   item_cyl(cyl, {Vec3(0.5 + 0.3 / std::sqrt(2.0), 0.0, 0.5 + 0.5 / std::sqrt(2.0) + 0.3 / std::sqrt(2.0)),
                                  Eigen::AngleAxisd(kPi / 4, Vec3::UnitY()).toRotationMatrix()})});
  cases.push_back({"parallel cylinders side by side", item_cyl(cyl, {Vec3::Zero(), I}), item_cyl(cyl, {Vec3(0.6, 0, 0.1), I})});
  cases.push_back({"crossed cylinders", item_cyl(cyl, {Vec3::Zero(), lying}),
                   item_cyl(cyl, {Vec3(0, 0, 0.6), Eigen::AngleAxisd(kPi / 2, Vec3::UnitY()).toRotationMatrix()})});
  cases.push_back({"cylinder against a 42-point hull", ball_item, item_cyl(cyl, {Vec3(0.2, 0.1, 0.85), I})});
  for (const Case& c : cases) {
    int most_gjk = 0, most_epa = 0;
    for (int k = 0; k < 2000; ++k) {
      // perturbed by up to 1e-4 m and 1e-3 rad, so touching, just apart and just overlapping
      Item a = c.a, b = c.b;
      b.pose.p += scenes::random_vector(rng, 1e-4);
      b.pose.R = scenes::small_rotation(rng, 1e-3) * b.pose.R;
      GjkEpaStats st;
      const Distance d = collision::gjk_epa(a, b, &st);
      ASSERT_TRUE(std::isfinite(d.gap)) << c.name;
      EXPECT_TRUE(st.converged) << c.name;
      EXPECT_LE(d.gap - support_gap(a, b, d.normal), kTol) << c.name;
      most_gjk = std::max(most_gjk, st.gjk_iterations);
      most_epa = std::max(most_epa, st.epa_iterations);
    }
    EXPECT_LE(most_gjk, 64) << c.name;
    EXPECT_LE(most_epa, 100) << c.name;
    std::printf("%-40s most GJK iterations %3d, most EPA expansions %3d\n", c.name, most_gjk, most_epa);
  }
}
