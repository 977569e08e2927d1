#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <Eigen/Geometry>

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

std::string shape_name(const Shape& shape) {
  struct Name {
    std::string operator()(const Sphere&) const { return "Sphere"; }
    std::string operator()(const Box&) const { return "Box"; }
    std::string operator()(const Plane&) const { return "Plane"; }
    std::string operator()(const Mesh&) const { return "Mesh"; }
  };
  return std::visit(Name{}, shape);
}

double bounding_radius(const Shape& shape) {
  struct Radius {
    double operator()(const Sphere& s) const { return s.radius; }
    double operator()(const Box& b) const { return b.half_extents.norm(); }
    double operator()(const Plane&) const { return std::numeric_limits<double>::infinity(); }
    double operator()(const Mesh& m) const { return m.vertices.rowwise().norm().maxCoeff(); }
  };
  return std::visit(Radius{}, shape);
}

}  // namespace signorini
