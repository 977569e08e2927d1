// Candidate contact points of one body pair -> its manifold (docs/conventions.md, "Manifolds"):
// filter by the threshold, canonical id order, duplicates dropped, at most 4 points kept by area.
// Written here because the rule (and its tie-breaking, which the oracle repeats) is ours; FCL has
// no manifold reduction.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "collision/collision.hpp"

namespace signorini::collision {
namespace {

/// Index of the first candidate whose score is within tol of the largest score.
template <class Score>
std::size_t first_best(const std::vector<Contact>& c, double tol, Score score) {
  double best = -std::numeric_limits<double>::infinity();
  for (const Contact& x : c) best = std::max(best, score(x));
  for (std::size_t k = 0; k < c.size(); ++k)
    if (score(c[k]) >= best - tol) return k;
  return 0;
}

}  // namespace

void finish_manifold(std::vector<Contact>& c, double threshold, double L, std::vector<Contact>& out, bool reduce) {
  c.erase(std::remove_if(c.begin(), c.end(), [&](const Contact& x) { return !(x.gap < threshold); }), c.end());
  if (c.empty()) return;
  const auto by_ids = [](const Contact& x, const Contact& y) {
    return x.feature_a != y.feature_a ? x.feature_a < y.feature_a : x.feature_b < y.feature_b;
  };
  if (!std::is_sorted(c.begin(), c.end(), by_ids)) std::sort(c.begin(), c.end(), by_ids);
  const double tol = 1e-9 * L, tol2 = 1e-9 * L * L;
  // exact duplicates (the same point reached through two features, e.g. a corner of two triangles)
  std::size_t kept = 0;
  for (std::size_t k = 0; k < c.size(); ++k) {
    bool duplicate = false;
    for (std::size_t j = 0; j < kept && !duplicate; ++j)
      duplicate = (c[j].point - c[k].point).norm() <= tol;
    if (!duplicate) c[kept++] = c[k];
  }
  c.resize(kept);
  if (c.size() <= 4 || !reduce) {
    out.insert(out.end(), c.begin(), c.end());
    return;
  }
  // reduction to 4: deepest, farthest from it, largest triangle, largest added area
  const std::size_t i1 = first_best(c, tol, [](const Contact& x) { return -x.gap; });
  const Vec3 p1 = c[i1].point, n = c[i1].normal;
  const std::size_t i2 = first_best(c, tol2, [&](const Contact& x) { return (x.point - p1).squaredNorm(); });
  Vec3 p2 = c[i2].point;
  auto area = [&n](const Vec3& a, const Vec3& b, const Vec3& q) { return 0.5 * (b - a).cross(q - a).dot(n); };
  std::size_t i3 = first_best(c, tol2, [&](const Contact& x) { return std::abs(area(p1, p2, x.point)); });
  if (!(std::abs(area(p1, p2, c[i3].point)) > tol2)) {
    // all on one line: its two ends are the manifold
    out.push_back(c[std::min(i1, i2)]);
    out.push_back(c[std::max(i1, i2)]);
    return;
  }
  std::array<std::size_t, 4> pick = {i1, i2, i3, i3};
  if (area(p1, p2, c[i3].point) < 0.0) std::swap(pick[1], pick[2]);
  p2 = c[pick[1]].point;
  const Vec3 p3 = c[pick[2]].point;
  auto added = [&](const Contact& x) {
    return std::max({-area(p1, p2, x.point), -area(p2, p3, x.point), -area(p3, p1, x.point)});
  };
  const std::size_t i4 = first_best(c, tol2, added);
  int count = 3;
  if (added(c[i4]) > tol2) pick[count++] = i4;
  std::sort(pick.begin(), pick.begin() + count);
  for (int k = 0; k < count; ++k) out.push_back(c[pick[k]]);
}

double pair_scale(const Shape& a, const Shape& b) {
  double L = 0.0;
  for (const Shape* s : {&a, &b})
    if (!static_only(*s)) L += bounding_radius(*s);
  return L > 0.0 ? L : 1.0;
}

}  // namespace signorini::collision
