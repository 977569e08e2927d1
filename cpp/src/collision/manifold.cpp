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

/// Position (in `index`) of the first candidate whose score is within tol of the largest score.
template <class Score>
std::size_t first_best(const std::vector<Contact>& c, const std::vector<int>& index, double tol, Score score) {
  double best = -std::numeric_limits<double>::infinity();
  for (const int k : index) best = std::max(best, score(c[k]));
  for (std::size_t j = 0; j < index.size(); ++j)
    if (score(c[index[j]]) >= best - tol) return j;
  return 0;
}

/// first_best among the touching candidates (end gap <= touch) if the best of them scores above
/// `floor`, else among all.
template <class EndGap, class Score>
std::size_t touching_first(const std::vector<Contact>& c, const std::vector<int>& index, EndGap end_gap, double touch,
                           double tol, double floor, Score score) {
  const auto among_touching = [&](const Contact& x) {
    return end_gap(x) <= touch ? score(x) : -std::numeric_limits<double>::infinity();
  };
  const std::size_t j = first_best(c, index, tol, among_touching);
  return among_touching(c[index[j]]) > floor ? j : first_best(c, index, tol, score);
}

}  // namespace

void finish_manifold(std::vector<Contact>& c, double threshold, double L, std::vector<Contact>& out,
                     std::vector<int>& index, const PairMotion* motion) {
  // the candidates stay where they are: the rules below run on their indices (a Contact is large
  // to move), and only the kept ones are copied out
  index.clear();
  for (std::size_t k = 0; k < c.size(); ++k)
    if (c[k].gap < threshold) index.push_back(static_cast<int>(k));
  if (index.empty()) return;
  // sorted by (feature_a, feature_b), stably (insertion sort: a pair has a handful of points)
  for (std::size_t j = 1; j < index.size(); ++j) {
    const int x = index[j];
    std::size_t i = j;
    for (; i > 0; --i) {
      const Contact& p = c[index[i - 1]];
      const Contact& q = c[x];
      if (!(p.feature_a != q.feature_a ? q.feature_a < p.feature_a : q.feature_b < p.feature_b)) break;
      index[i] = index[i - 1];
    }
    index[i] = x;
  }
  const double tol = 1e-9 * L, tol2 = 1e-9 * L * L;
  // exact duplicates (the same point reached through two features, e.g. a corner of two triangles)
  std::size_t kept = 0;
  for (std::size_t k = 0; k < index.size(); ++k) {
    bool duplicate = false;
    for (std::size_t j = 0; j < kept && !duplicate; ++j)
      duplicate = (c[index[j]].point - c[index[k]].point).norm() <= tol;
    if (!duplicate) index[kept++] = index[k];
  }
  index.resize(kept);
  if (index.size() <= 4) {
    for (const int k : index) out.push_back(c[k]);
    return;
  }
  // reduction to 4 by end gaps (gaps without a motion): deepest, farthest from it, largest
  // triangle, largest added area, each from the touching points while they offer one (why:
  // docs/conventions.md, "Manifolds")
  const auto end_gap = [motion](const Contact& x) { return motion ? motion->end_gap(x) : x.gap; };
  const std::size_t i1 = first_best(c, index, tol, [&](const Contact& x) { return -end_gap(x); });
  const Vec3 p1 = c[index[i1]].point, n = c[index[i1]].normal;
  // touching: the points that end the step on the plane, gravity's kick k (the same for every
  // point: a supported body does not fall it) counted up to kTouchInnerFraction of the smaller
  // inner radius (with all of it, at dt 1/60 every vertex of a small resting body within dt^2 g =
  // 2.7 mm touched, and it stood on far vertices and sank at its deepest; without it, a tilt of
  // 1e-9 rad chose a resting ring's points)
  double touch = std::max(end_gap(c[index[i1]]), 0.0) + tol;
  if (motion) {
    const double kick = n.dot(Vec3(motion->dt * motion->dt * motion->g_rel));
    touch = std::max(end_gap(c[index[i1]]), std::min(0.0, kick + kTouchInnerFraction * motion->inner)) + tol;
  }
  const std::size_t i2 = touching_first(c, index, end_gap, touch, tol2, tol * tol,
                                        [&](const Contact& x) { return (x.point - p1).squaredNorm(); });
  Vec3 p2 = c[index[i2]].point;
  auto area = [&n](const Vec3& a, const Vec3& b, const Vec3& q) { return 0.5 * (b - a).cross(q - a).dot(n); };
  std::size_t i3 =
      touching_first(c, index, end_gap, touch, tol2, tol2, [&](const Contact& x) { return std::abs(area(p1, p2, x.point)); });
  if (!(std::abs(area(p1, p2, c[index[i3]].point)) > tol2)) {
    // all on one line: its two ends are the manifold
    out.push_back(c[index[std::min(i1, i2)]]);
    out.push_back(c[index[std::max(i1, i2)]]);
    return;
  }
  std::array<std::size_t, 4> pick = {i1, i2, i3, i3};
  if (area(p1, p2, c[index[i3]].point) < 0.0) std::swap(pick[1], pick[2]);
  p2 = c[index[pick[1]]].point;
  const Vec3 p3 = c[index[pick[2]]].point;
  auto added = [&](const Contact& x) {
    return std::max({-area(p1, p2, x.point), -area(p2, p3, x.point), -area(p3, p1, x.point)});
  };
  const std::size_t i4 = touching_first(c, index, end_gap, touch, tol2, tol2, added);
  int count = 3;
  if (added(c[index[i4]]) > tol2) pick[count++] = i4;
  std::sort(pick.begin(), pick.begin() + count);
  for (int k = 0; k < count; ++k) out.push_back(c[index[pick[k]]]);
}

double pair_scale(const Shape& a, double rho_a, const Shape& b, double rho_b) {
  double L = 0.0;
  if (!static_only(a)) L += rho_a;
  if (!static_only(b)) L += rho_b;
  return L > 0.0 ? L : 1.0;
}

double pair_scale(const Shape& a, const Shape& b) {
  // a static-only shape's radius is not needed (a plane's is infinite): not computed
  return pair_scale(a, static_only(a) ? 0.0 : bounding_radius(a), b, static_only(b) ? 0.0 : bounding_radius(b));
}

}  // namespace signorini::collision
