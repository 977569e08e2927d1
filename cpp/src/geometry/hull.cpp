// ConvexHull: the convex hull of a point cloud, computed by Qhull.
//
// Why Qhull and not our own quickhull: a 3-d hull is short to write and long to make robust
// (nearly coplanar and duplicate points, precision merges, facets that must stay convex). Qhull has
// handled exactly that for decades and is what SciPy, CGAL users and Bullet's tools reach for; the
// house rule is to use real libraries for what they do well. We only call it with plain options,
// keep its messages off stdout/stderr, and make the output canonical so it is reproducible.
#include <libqhull_r/qhull_ra.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/polytope.hpp"
#include "signorini/shapes.hpp"

namespace signorini {
namespace {

/// Qhull's messages go to this in-memory stream, never to the terminal; text() reads them back.
class MessageSink {
 public:
  MessageSink() : file_(open_memstream(&buffer_, &size_)) {}
  ~MessageSink() {
    if (file_) std::fclose(file_);
    std::free(buffer_);
  }
  MessageSink(const MessageSink&) = delete;
  MessageSink& operator=(const MessageSink&) = delete;
  FILE* file() const { return file_; }
  std::string first_line() {
    if (!file_) return {};
    std::fflush(file_);
    std::string s(buffer_ ? buffer_ : "", size_);
    const auto start = s.find_first_not_of(" \n");
    if (start == std::string::npos) return {};
    return s.substr(start, s.find('\n', start) - start);
  }

 private:
  char* buffer_ = nullptr;
  std::size_t size_ = 0;
  FILE* file_;
};

std::string fmt_row(const Points& p, Eigen::Index i) {
  std::ostringstream s;
  s << "(" << p(i, 0) << ", " << p(i, 1) << ", " << p(i, 2) << ")";
  return s.str();
}

/// Rejects clouds with no volume before Qhull sees them: with p0 the first point, p1 the farthest
/// from p0, p2 the farthest from the line p0 p1 and the largest distance from the plane p0 p1 p2,
/// each compared with 1e-10 of |p1 - p0| (coincident: |p1 - p0| <= 1e-12 max |p|).
void require_volume(const Points& P) {
  const Eigen::Index n = P.rows();
  const Vec3 p0 = P.row(0).transpose();
  Eigen::Index i1 = 0;
  double L = 0.0;
  for (Eigen::Index i = 0; i < n; ++i)
    if (const double d = (P.row(i).transpose() - p0).norm(); d > L) L = d, i1 = i;
  const double scale = P.rowwise().norm().maxCoeff();
  if (!(L > 1e-12 * scale))
    throw std::invalid_argument("ConvexHull: the points all coincide (the hull has no volume)");
  const Vec3 u = (P.row(i1).transpose() - p0) / L;
  Eigen::Index i2 = 0;
  double d2 = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 w = P.row(i).transpose() - p0;
    if (const double d = (w - w.dot(u) * u).norm(); d > d2) d2 = d, i2 = i;
  }
  if (!(d2 > 1e-10 * L))
    throw std::invalid_argument("ConvexHull: the points are collinear (the hull has no volume)");
  const Vec3 normal = u.cross(P.row(i2).transpose() - p0).normalized();
  double d3 = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) d3 = std::max(d3, std::abs(normal.dot(P.row(i).transpose() - p0)));
  if (!(d3 > 1e-10 * L))
    throw std::invalid_argument("ConvexHull: the points are coplanar (the hull has no volume)");
}

/// Hull facets as loops of original point indices, each loop in counter-clockwise order around the
/// facet's outward normal (Qhull merges coplanar facets, so a loop may have more than 3 points).
std::vector<std::vector<int>> qhull_facets(const Points& P) {
  std::vector<coordT> coords(P.data(), P.data() + P.size());  // row-major (n, 3), as Qhull wants
  MessageSink sink;
  FILE* err = sink.file();
  if (!err) throw std::runtime_error("ConvexHull: could not open a buffer for Qhull's messages");
  qhT qh_qh;
  qhT* qh = &qh_qh;
  qh_zero(qh, err);
  char options[] = "qhull";  // default: merge facets that are not clearly convex (C-0)
  const int exitcode = qh_new_qhull(qh, 3, static_cast<int>(P.rows()), coords.data(), False, options, nullptr, err);
  std::vector<std::vector<int>> loops;
  if (!exitcode) {
    facetT* facet;
    vertexT *vertex, **vertexp;
    FORALLfacets {
      const Vec3 normal(facet->normal[0], facet->normal[1], facet->normal[2]);  // outward, unit
      std::vector<int> ids;
      Vec3 mean = Vec3::Zero();
      FOREACHvertex_(facet->vertices) {
        ids.push_back(qh_pointid(qh, vertex->point));
        mean += P.row(ids.back()).transpose();
      }
      mean /= static_cast<double>(ids.size());
      // counter-clockwise around the normal: sort by angle in the facet plane
      const Vec3 e1 = (P.row(ids[0]).transpose() - mean).normalized();
      const Vec3 e2 = normal.cross(e1);
      std::vector<std::pair<double, int>> by_angle;
      for (int id : ids) {
        const Vec3 w = P.row(id).transpose() - mean;
        by_angle.push_back({std::atan2(w.dot(e2), w.dot(e1)), id});
      }
      std::sort(by_angle.begin(), by_angle.end());
      std::vector<int> loop;
      for (const auto& [angle, id] : by_angle) loop.push_back(id);
      loops.push_back(std::move(loop));
    }
  }
  const std::string message = exitcode ? sink.first_line() : std::string();
  qh_freeqhull(qh, !qh_ALL);
  int curlong = 0, totlong = 0;
  qh_memfreeshort(qh, &curlong, &totlong);
  if (exitcode)
    throw std::invalid_argument("ConvexHull: Qhull could not build the hull (" +
                                (message.empty() ? "exit code " + std::to_string(exitcode) : message) + ")");
  return loops;
}

}  // namespace

ConvexHull::ConvexHull(const Points& points) {
  const Eigen::Index n = points.rows();
  if (n < 4) throw std::invalid_argument("ConvexHull: needs at least 4 points, got " + std::to_string(n));
  for (Eigen::Index i = 0; i < n; ++i)
    if (!points.row(i).allFinite())
      throw std::invalid_argument("ConvexHull: point " + std::to_string(i) + " is not finite, got " + fmt_row(points, i));
  require_volume(points);
  const std::vector<std::vector<int>> loops = qhull_facets(points);

  // vertices: the hull's points in increasing original index
  std::vector<int> new_index(static_cast<std::size_t>(n), -1);
  for (const auto& loop : loops)
    for (int id : loop) new_index[id] = 0;
  int count = 0;
  for (int& k : new_index)
    if (k == 0) k = count++;
  vertices.resize(count, 3);
  for (Eigen::Index i = 0; i < n; ++i)
    if (new_index[i] >= 0) vertices.row(new_index[i]) = points.row(i);

  // faces: each facet fanned from its lowest vertex, every triangle rotated to start at its lowest
  // index, then sorted; so the output depends only on the hull, not on Qhull's facet order
  std::vector<std::array<std::int64_t, 3>> tris;
  for (const auto& loop : loops) {
    std::vector<int> l;
    for (int id : loop) l.push_back(new_index[id]);
    std::rotate(l.begin(), std::min_element(l.begin(), l.end()), l.end());
    for (std::size_t k = 1; k + 1 < l.size(); ++k) tris.push_back({l[0], l[k], l[k + 1]});
  }
  std::sort(tris.begin(), tris.end());
  faces.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t t = 0; t < tris.size(); ++t)
    for (int c = 0; c < 3; ++c) faces(static_cast<Eigen::Index>(t), c) = tris[t][c];

  try {
    polytope = std::make_shared<const Polytope>(geometry::polytope_from_hull_triangles(vertices, faces));
  } catch (const std::invalid_argument& e) {
    // Qhull's output is convex within its own rounding; this only fires for near-degenerate clouds
    throw std::invalid_argument(std::string("ConvexHull: the hull Qhull returned is unusable (") + e.what() + ")");
  }
}

}  // namespace signorini
