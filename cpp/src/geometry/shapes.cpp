#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include <Eigen/Geometry>

#include "geometry/polytope.hpp"
#include "math/rotation.hpp"
#include "signorini/shapes.hpp"

namespace signorini {
namespace {

bool finite(double x) { return std::isfinite(x); }

std::string fmt(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

std::string fmt(const Vec3& x) {
  std::ostringstream s;
  s << "(" << x.x() << ", " << x.y() << ", " << x.z() << ")";
  return s.str();
}

}  // namespace

Sphere::Sphere(double r) : radius(r) {
  if (!(finite(r) && r > 0.0))
    throw std::invalid_argument("Sphere: radius must be positive and finite, got " + fmt(r));
}

Box::Box(const Vec3& h) : half_extents(h) {
  if (!(h.allFinite() && (h.array() > 0.0).all()))
    throw std::invalid_argument("Box: half extents must be positive and finite, got " + fmt(h));
  polytope = std::make_shared<const Polytope>(geometry::box_polytope(h));
}

Plane::Plane(const Vec3& n, double d) : normal(n), offset(d) {
  if (!n.allFinite() || !finite(d))
    throw std::invalid_argument("Plane: normal and offset must be finite, got normal " + fmt(n) +
                                " and offset " + fmt(d));
  const double length = n.norm();
  if (!(length > 0.0)) throw std::invalid_argument("Plane: normal must be non-zero");
  normal = n / length;
}

Mesh::Mesh(Points v, Triangles f) : vertices(std::move(v)), faces(std::move(f)) {
  const Eigen::Index n = vertices.rows();
  if (n < 3) throw std::invalid_argument("Mesh: needs at least 3 vertices, got " + std::to_string(n));
  if (faces.rows() < 1) throw std::invalid_argument("Mesh: needs at least one face");
  for (Eigen::Index i = 0; i < n; ++i)
    if (!vertices.row(i).allFinite())
      throw std::invalid_argument("Mesh: vertex " + std::to_string(i) + " is not finite");
  // a triangle is degenerate when its area is below 1e-12 of the squared mesh size: such a face
  // has no normal, and no mass-property or contact formula can use it
  const double size = (vertices.colwise().maxCoeff() - vertices.colwise().minCoeff()).norm();
  for (Eigen::Index k = 0; k < faces.rows(); ++k) {
    for (int c = 0; c < 3; ++c)
      if (faces(k, c) < 0 || faces(k, c) >= n)
        throw std::invalid_argument("Mesh: face " + std::to_string(k) + " has vertex index " +
                                    std::to_string(faces(k, c)) + " outside [0, " +
                                    std::to_string(n) + ")");
    const Vec3 a = vertex(faces(k, 0)), b = vertex(faces(k, 1)), c = vertex(faces(k, 2));
    if ((b - a).cross(c - a).norm() <= 1e-12 * size * size)
      throw std::invalid_argument("Mesh: face " + std::to_string(k) +
                                  " is degenerate (zero area or repeated vertex)");
  }
}

std::string Mesh::closedness_problem() const {
  // closed and consistently oriented <=> every directed edge appears exactly once and its
  // reverse exactly once
  std::map<std::pair<std::int64_t, std::int64_t>, int> directed;
  for (Eigen::Index k = 0; k < faces.rows(); ++k)
    for (int c = 0; c < 3; ++c) ++directed[{faces(k, c), faces(k, (c + 1) % 3)}];
  for (const auto& [edge, count] : directed) {
    const std::string name = "edge (" + std::to_string(edge.first) + ", " +
                             std::to_string(edge.second) + ")";
    if (count > 1)
      return name + " is used " + std::to_string(count) +
             " times in the same direction: faces are inconsistently oriented, duplicated or "
             "non-manifold";
    const auto reverse = directed.find({edge.second, edge.first});
    if (reverse == directed.end())
      return name + " belongs to a single face: the mesh is open (has a boundary)";
  }
  return {};
}

bool Mesh::is_convex() const {
  const double size = (vertices.colwise().maxCoeff() - vertices.colwise().minCoeff()).norm();
  const double tol = 1e-9 * size;
  for (Eigen::Index k = 0; k < faces.rows(); ++k) {
    const Vec3 a = vertex(faces(k, 0)), b = vertex(faces(k, 1)), c = vertex(faces(k, 2));
    const Vec3 n = (b - a).cross(c - a).normalized();
    for (Eigen::Index i = 0; i < vertices.rows(); ++i)
      if (n.dot(vertex(i) - a) > tol) return false;
  }
  return true;
}

Capsule::Capsule(double r, double h) : radius(r), half_length(h) {
  if (!(finite(r) && r > 0.0))
    throw std::invalid_argument("Capsule: radius must be positive and finite, got " + fmt(r));
  if (!(finite(h) && h >= 0.0))
    throw std::invalid_argument("Capsule: half_length must be finite and >= 0, got " + fmt(h));
}

Cylinder::Cylinder(double r, double h) : radius(r), half_height(h) {
  if (!(finite(r) && r > 0.0))
    throw std::invalid_argument("Cylinder: radius must be positive and finite, got " + fmt(r));
  if (!(finite(h) && h > 0.0))
    throw std::invalid_argument("Cylinder: half_height must be positive and finite, got " + fmt(h));
}

TriangleMesh::TriangleMesh(Points v, Triangles f) : vertices(std::move(v)), faces(std::move(f)) {
  const Eigen::Index n = vertices.rows(), F = faces.rows();
  if (n < 3) throw std::invalid_argument("TriangleMesh: needs at least 3 vertices, got " + std::to_string(n));
  if (F < 1) throw std::invalid_argument("TriangleMesh: needs at least one face");
  for (Eigen::Index i = 0; i < n; ++i)
    if (!vertices.row(i).allFinite())
      throw std::invalid_argument("TriangleMesh: vertex " + std::to_string(i) + " is not finite, got " +
                                  fmt(Vec3(vertices.row(i).transpose())));
  // as for Mesh: a triangle whose doubled area is below 1e-12 of the squared mesh size is degenerate
  const double size = (vertices.colwise().maxCoeff() - vertices.colwise().minCoeff()).norm();
  std::map<std::array<std::int64_t, 3>, Eigen::Index> seen;  // sorted vertex triple -> first face
  normals.resize(static_cast<std::size_t>(F));
  for (Eigen::Index k = 0; k < F; ++k) {
    for (int c = 0; c < 3; ++c)
      if (faces(k, c) < 0 || faces(k, c) >= n)
        throw std::invalid_argument("TriangleMesh: face " + std::to_string(k) + " has vertex index " +
                                    std::to_string(faces(k, c)) + " outside [0, " + std::to_string(n) + ")");
    const Vec3 a = vertex(faces(k, 0)), b = vertex(faces(k, 1)), c = vertex(faces(k, 2));
    const Vec3 area = (b - a).cross(c - a);
    if (area.norm() <= 1e-12 * size * size)
      throw std::invalid_argument("TriangleMesh: face " + std::to_string(k) +
                                  " is degenerate (zero area or repeated vertex)");
    std::array<std::int64_t, 3> key{faces(k, 0), faces(k, 1), faces(k, 2)};
    std::sort(key.begin(), key.end());
    if (const auto [it, fresh] = seen.emplace(key, k); !fresh)
      throw std::invalid_argument("TriangleMesh: face " + std::to_string(k) + " repeats face " +
                                  std::to_string(it->second) + " (the same three vertices)");
    normals[k] = area.normalized();
  }

  // edge adjacency: undirected edge -> the (face, side) pairs that use it
  std::map<std::pair<std::int64_t, std::int64_t>, std::vector<std::pair<Eigen::Index, int>>> users;
  for (Eigen::Index k = 0; k < F; ++k)
    for (int s = 0; s < 3; ++s) users[std::minmax(faces(k, s), faces(k, (s + 1) % 3))].push_back({k, s});

  // side s of face k (v_s -> v_s+1) is active when a boundary edge, a non-manifold one, or a fold
  // atan2(-n . w, (e x n) . w) > 1e-6 rad, w = o - v_s (docs/conventions.md, "Contacts")
  active_edge.assign(static_cast<std::size_t>(F), {true, true, true});
  boundary_edge.assign(static_cast<std::size_t>(F), {false, false, false});
  for (Eigen::Index k = 0; k < F; ++k)
    for (int s = 0; s < 3; ++s) {
      const std::int64_t i0 = faces(k, s), i1 = faces(k, (s + 1) % 3);
      const auto& around = users.at(std::minmax(i0, i1));
      boundary_edge[static_cast<std::size_t>(k)][static_cast<std::size_t>(s)] = around.size() == 1;
      if (around.size() != 2) continue;  // boundary or non-manifold: active
      const Eigen::Index g = around[0].first == k ? around[1].first : around[0].first;
      std::int64_t o = -1;
      for (int c = 0; c < 3; ++c)
        if (faces(g, c) != i0 && faces(g, c) != i1) o = faces(g, c);
      const Vec3 e = (vertex(i1) - vertex(i0)).normalized();
      const Vec3 w = vertex(o) - vertex(i0);
      const double d = normals[k].dot(w), t = e.cross(normals[k]).dot(w);
      active_edge[k][s] = std::atan2(-d, t) > 1e-6;
    }
}

Compound::Part Compound::make_part(Primitive shape, const Vec3& position, const Quat4& q) {
  return Part{std::move(shape), position, math::quat_to_matrix(math::unit_quaternion(q))};
}

Quat4 Compound::Part::orientation() const { return math::matrix_to_quat(rotation); }

Compound::Compound(std::vector<Part> p) : parts(std::move(p)) {
  if (parts.empty()) throw std::invalid_argument("Compound: needs at least one part");
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const std::string who = "Compound: part " + std::to_string(i);
    const Part& part = parts[i];
    if (!part.position.allFinite()) throw std::invalid_argument(who + ": position must be finite, got " + fmt(part.position));
    const Mat3& R = part.rotation;
    if (!R.allFinite() || (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff() > 1e-9 ||
        std::abs(R.determinant() - 1.0) > 1e-9)
      throw std::invalid_argument(who + ": rotation must be a proper rotation (orthonormal within 1e-9, determinant +1)");
  }
}

std::string shape_name(const Shape& shape) {
  struct Name {
    std::string operator()(const Sphere&) const { return "Sphere"; }
    std::string operator()(const Box&) const { return "Box"; }
    std::string operator()(const Plane&) const { return "Plane"; }
    std::string operator()(const Mesh&) const { return "Mesh"; }
    std::string operator()(const Capsule&) const { return "Capsule"; }
    std::string operator()(const Cylinder&) const { return "Cylinder"; }
    std::string operator()(const ConvexHull&) const { return "ConvexHull"; }
    std::string operator()(const TriangleMesh&) const { return "TriangleMesh"; }
    std::string operator()(const Compound&) const { return "Compound"; }
  };
  return std::visit(Name{}, shape);
}

namespace {

/// Largest |x| over the points x = t + R y of a convex part (t, R) (m), exact for each shape:
/// sphere |t| + r; box and hull the largest over the vertices; capsule the larger segment end
/// plus r; cylinder the larger over the two rims: a rim of centre c, axis a and radius r reaches
/// sqrt((c . a)^2 + (|c - (c . a) a| + r)^2).
double part_radius(const Primitive& shape, const Vec3& t, const Mat3& R) {
  struct Radius {
    const Vec3& t;
    const Mat3& R;
    double operator()(const Sphere& s) const { return t.norm() + s.radius; }
    double operator()(const Box& b) const { return farthest(b.polytope->vertices); }
    double operator()(const ConvexHull& h) const { return farthest(h.vertices); }
    double operator()(const Capsule& c) const {
      const Vec3 a = R.col(2) * c.half_length;
      return std::max((t - a).norm(), (t + a).norm()) + c.radius;
    }
    double operator()(const Cylinder& c) const {
      const Vec3 a = R.col(2);
      double out = 0.0;
      for (double s : {-1.0, 1.0}) {
        const Vec3 centre = t + s * c.half_height * a;
        const double along = centre.dot(a);
        out = std::max(out, std::hypot(along, (centre - along * a).norm() + c.radius));
      }
      return out;
    }
    /// max_i |v_i R^T + t| (a row at a time: the whole product would be a matrix on the heap, and
    /// a step asks for the radius of a pair's shapes)
    double farthest(const Points& v) const {
      double out = 0.0;
      for (Eigen::Index i = 0; i < v.rows(); ++i) {
        const Eigen::RowVector3d x = v.row(i) * R.transpose() + t.transpose();
        out = i == 0 ? x.norm() : std::max(out, x.norm());
      }
      return out;
    }
  };
  return std::visit(Radius{t, R}, shape);
}

}  // namespace

double bounding_radius(const Shape& shape) {
  struct Radius {
    double operator()(const Sphere& s) const { return s.radius; }
    double operator()(const Box& b) const { return b.half_extents.norm(); }
    double operator()(const Plane&) const { return std::numeric_limits<double>::infinity(); }
    double operator()(const Mesh& m) const { return m.vertices.rowwise().norm().maxCoeff(); }
    double operator()(const Capsule& c) const { return c.radius + c.half_length; }
    double operator()(const Cylinder& c) const { return std::hypot(c.radius, c.half_height); }
    double operator()(const ConvexHull& h) const { return h.vertices.rowwise().norm().maxCoeff(); }
    double operator()(const TriangleMesh& m) const { return m.vertices.rowwise().norm().maxCoeff(); }
    double operator()(const Compound& c) const {
      double r = 0.0;
      for (const Compound::Part& p : c.parts) r = std::max(r, part_radius(p.shape, p.position, p.rotation));
      return r;
    }
  };
  return std::visit(Radius{}, shape);
}

namespace {

/// Distance (m) from a polytope's vertex mean (an interior point) to its nearest face plane.
double polytope_inner(const Polytope& p) {
  double r = std::numeric_limits<double>::infinity();
  for (std::size_t f = 0; f < p.normals.size(); ++f) r = std::min(r, p.offsets[f] - p.normals[f].dot(p.centroid));
  return r;
}

}  // namespace

double rounding_radius(const Shape& shape, std::uint32_t part) {
  const auto primitive = [](const auto& s) -> double {
    using T = std::decay_t<decltype(s)>;
    if constexpr (std::is_same_v<T, Sphere> || std::is_same_v<T, Capsule>) return s.radius;
    else return 0.0;
  };
  if (const auto* c = std::get_if<Compound>(&shape))
    return part < c->parts.size() ? std::visit(primitive, c->parts[part].shape) : 0.0;
  return std::visit(primitive, shape);
}

double inner_radius(const Shape& shape) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  struct Inner {
    double operator()(const Sphere& s) const { return s.radius; }
    double operator()(const Box& b) const { return b.half_extents.minCoeff(); }
    double operator()(const Plane&) const { return inf; }
    double operator()(const Mesh& m) const {
      if (!m.pieces.empty()) {
        double r = 0.0;
        for (const auto& piece : m.pieces) r = std::max(r, polytope_inner(*piece));
        return r;
      }
      // no pieces: the triangles' planes seen from the vertex mean, a ball only if it is inside all
      const Vec3 c = m.vertices.colwise().mean().transpose();
      double r = inf;
      for (Eigen::Index k = 0; k < m.faces.rows(); ++k) {
        const Vec3 a = m.vertex(m.faces(k, 0)), b = m.vertex(m.faces(k, 1)), d = m.vertex(m.faces(k, 2));
        const Vec3 n = (b - a).cross(d - a).normalized();
        r = std::min(r, n.dot(a - c));
      }
      return r > 0.0 ? r : inf;
    }
    double operator()(const Capsule& c) const { return c.radius; }
    double operator()(const Cylinder& c) const { return std::min(c.radius, c.half_height); }
    double operator()(const ConvexHull& h) const { return polytope_inner(*h.polytope); }
    double operator()(const TriangleMesh&) const { return inf; }
    double operator()(const Compound& c) const {
      double r = 0.0;
      for (const Compound::Part& p : c.parts) r = std::max(r, std::visit([this](const auto& s) { return (*this)(s); }, p.shape));
      return r;
    }
  };
  return std::visit(Inner{}, shape);
}

bool static_only(const Shape& shape) {
  return std::holds_alternative<Plane>(shape) || std::holds_alternative<TriangleMesh>(shape);
}

}  // namespace signorini
