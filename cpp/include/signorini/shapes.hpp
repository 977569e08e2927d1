// Collision shapes. Each is a plain, validated value: a constructor that is handed a bad parameter
// (NaN, infinity, non-positive size, malformed mesh arrays) throws std::invalid_argument and no
// shape exists. All shapes are described in their body frame; a body's pose places them.
#pragma once

#include <string>
#include <variant>

#include "signorini/types.hpp"

namespace signorini {

/// Ball of the given radius (m), centred at the body origin.
struct Sphere {
  explicit Sphere(double radius);
  double radius;
};

/// Box with half extents (a, b, c) (m) along the body axes, centred at the body origin.
struct Box {
  explicit Box(const Vec3& half_extents);
  Vec3 half_extents;
};

/// Static half-space {x : n . x <= offset}; its surface is n . x = offset and the outside (where
/// bodies live) is n . x > offset. normal (3,) is normalised on construction; offset in m.
struct Plane {
  Plane(const Vec3& normal, double offset);
  Vec3 normal;
  double offset;
};

/// Triangle mesh: vertices (n x 3, m, body frame), faces (k x 3) vertex indices, counter-clockwise
/// seen from outside (outward normals). The constructor checks array contents (finite vertices,
/// indices in range, no degenerate triangle); whether it is closed and consistently oriented is
/// checked where it matters (a dynamic body needs a closed mesh for its mass properties).
struct Mesh {
  Mesh(Points vertices, Triangles faces);
  Points vertices;
  Triangles faces;
  /// true when every vertex lies on or behind every face plane (within a relative 1e-9).
  bool is_convex() const;
  /// empty when closed (every edge used by exactly two faces, in opposite directions);
  /// otherwise a sentence saying what is wrong.
  std::string closedness_problem() const;
  /// Vertex position of vertex i (body frame).
  Vec3 vertex(Eigen::Index i) const { return vertices.row(i).transpose(); }
};

using Shape = std::variant<Sphere, Box, Plane, Mesh>;

/// "Sphere", "Box", "Plane", "Mesh".
std::string shape_name(const Shape& shape);

/// Largest distance from the body origin to the shape's surface (m); infinity for a plane.
double bounding_radius(const Shape& shape);

}  // namespace signorini
