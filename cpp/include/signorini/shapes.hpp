// Collision shapes. Each is a plain, validated value: a constructor that is handed a bad parameter
// (NaN, infinity, non-positive size, malformed or degenerate mesh arrays, coplanar hull points)
// throws std::invalid_argument and no shape exists. All shapes are described in their body frame;
// a body's pose (p, R) places them: x_world = R x_body + p.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "signorini/types.hpp"

namespace signorini {

/// A convex polyhedron with its topology, as the separating-axis test and face clipping need it.
/// Faces are convex polygons (coplanar triangles merged), their vertex loops counter-clockwise seen
/// from outside. Built for Box and ConvexHull (and for convex meshes by the narrow phase).
struct Polytope {
  struct Edge {
    int v0, v1;  ///< vertex indices; the edge runs v0 -> v1 in face f0's loop
    int f0, f1;  ///< the two faces sharing it (f1 runs v1 -> v0)
  };
  Points vertices;                      ///< (n, 3), body frame (m)
  std::vector<std::vector<int>> faces;  ///< vertex loops, CCW seen from outside
  std::vector<Vec3> normals;            ///< unit outward normal per face
  std::vector<double> offsets;          ///< normals[f] . x = offsets[f] on face f, <= inside (m)
  std::vector<Edge> edges;              ///< each undirected edge once, in order of first appearance
  std::vector<std::vector<int>> face_edges;  ///< per face, the edge index of loop side k (v_k -> v_k+1)
  Vec3 centroid = Vec3::Zero();         ///< mean of the vertices (an interior point)
  Vec3 vertex(int i) const { return vertices.row(i).transpose(); }
};

/// The polytope of a closed convex polyhedron given by vertices and triangles (outward,
/// counter-clockwise): coplanar neighbouring triangles (normals within 1e-9) are merged into one
/// polygon. Throws std::invalid_argument if the mesh is open or not convex.
Polytope polytope_from_triangles(const Points& vertices, const Triangles& faces);

/// Ball of the given radius (m), centred at the body origin.
struct Sphere {
  explicit Sphere(double radius);
  double radius;
};

/// Box with half extents (a, b, c) (m) along the body axes, centred at the body origin.
/// Vertex k = (sx a, sy b, sz c) with sx = +1 if k & 1 else -1, sy from k & 2, sz from k & 4;
/// face 2 i + 0 has outward normal -e_i, face 2 i + 1 has +e_i (i = 0, 1, 2).
struct Box {
  explicit Box(const Vec3& half_extents);
  Vec3 half_extents;
  std::shared_ptr<const Polytope> polytope;  ///< its 8 vertices, 6 faces, 12 edges in the order above
};

/// Static half-space {x : n . x <= offset}; its surface is n . x = offset and the outside (where
/// bodies live) is n . x > offset. normal (3,) is normalised on construction; offset in m.
struct Plane {
  Plane(const Vec3& normal, double offset);
  Vec3 normal;
  double offset;
};

/// Capsule: the points within `radius` (m) of the segment from (0, 0, -half_length) to
/// (0, 0, +half_length) (m) on the body z axis. half_length may be 0 (a sphere); radius > 0.
struct Capsule {
  Capsule(double radius, double half_length);
  double radius, half_length;
};

/// Solid cylinder of `radius` (m) around the body z axis, from z = -half_height to +half_height (m).
struct Cylinder {
  Cylinder(double radius, double half_height);
  double radius, half_height;
};

/// Convex hull of a point cloud (m, body frame), computed by Qhull. Needs at least 4 points that
/// are not all coplanar; interior and duplicate points are dropped.
struct ConvexHull {
  explicit ConvexHull(const Points& points);
  Points vertices;    ///< (n, 3) hull vertices
  Triangles faces;    ///< (k, 3) triangulation of the hull surface, outward, counter-clockwise
  std::shared_ptr<const Polytope> polytope;  ///< the same hull with merged polygon faces
  Vec3 vertex(Eigen::Index i) const { return vertices.row(i).transpose(); }
};

/// Triangle mesh: vertices (n x 3, m, body frame), faces (k x 3) vertex indices, counter-clockwise
/// seen from outside (outward normals). The constructor checks array contents (finite vertices,
/// indices in range, no degenerate triangle); whether it is closed and consistently oriented is
/// checked where it matters (a dynamic body needs a closed mesh for its mass properties).
/// A non-convex dynamic mesh collides through `pieces`, its convex decomposition (the Python layer
/// fills them with CoACD); its mass properties stay those of the mesh itself.
struct Mesh {
  Mesh(Points vertices, Triangles faces);
  Points vertices;
  Triangles faces;
  std::vector<std::shared_ptr<const Polytope>> pieces;  ///< convex pieces (body frame), may be empty
  /// true when every vertex lies on or behind every face plane (within a relative 1e-9).
  bool is_convex() const;
  /// empty when closed (every edge used by exactly two faces, in opposite directions);
  /// otherwise a sentence saying what is wrong.
  std::string closedness_problem() const;
  /// Vertex position of vertex i (body frame).
  Vec3 vertex(Eigen::Index i) const { return vertices.row(i).transpose(); }
};

/// Static triangle mesh of any shape (terrain, bowls, ramps): need not be closed or convex.
/// Faces are counter-clockwise seen from the side bodies touch (the front). Degenerate (zero-area)
/// and duplicated triangles are rejected. Edge adjacency is precomputed so that contacts on an
/// interior edge of a flat or concave region take the face normal (no ghost contacts).
struct TriangleMesh {
  TriangleMesh(Points vertices, Triangles faces);
  Points vertices;
  Triangles faces;
  /// per face and side k (edge v_k -> v_k+1): true when that edge can produce edge contacts, that is
  /// it is a boundary edge or its dihedral angle with the neighbour is convex by more than 1e-6 rad.
  std::vector<std::array<bool, 3>> active_edge;
  /// per face and side k: true when that edge is the mesh's rim (no other face uses it), where a
  /// body can come round from beside the mesh to behind it without passing through any face.
  std::vector<std::array<bool, 3>> boundary_edge;
  std::vector<Vec3> normals;  ///< unit face normals (body frame)
  Vec3 vertex(Eigen::Index i) const { return vertices.row(i).transpose(); }
};

/// One convex part of a Compound.
using Primitive = std::variant<Sphere, Box, Capsule, Cylinder, ConvexHull>;

/// is_primitive_v<T>: T is one of the kinds a Primitive holds (the convex kinds with a support
/// function), for the std::visit branches that treat them alike.
template <class T, class V = Primitive>
struct is_primitive;
template <class T, class... Kinds>
struct is_primitive<T, std::variant<Kinds...>> : std::bool_constant<(std::is_same_v<T, Kinds> || ...)> {};
template <class T>
inline constexpr bool is_primitive_v = is_primitive<T>::value;

/// Several convex parts with local poses on one body. The body frame is the compound's frame;
/// when it is added as a dynamic body it is re-centred on the combined centre of mass.
struct Compound {
  struct Part {
    Primitive shape;
    Vec3 position;   ///< part origin in the compound frame (m)
    Mat3 rotation;   ///< compound-from-part rotation
    /// `rotation` as a unit quaternion (w, x, y, z) with w >= 0.
    Quat4 orientation() const;
  };
  /// A part placed by a quaternion (w, x, y, z) instead of a matrix: normalised when it is not unit
  /// length; a zero or non-finite one throws std::invalid_argument.
  static Part make_part(Primitive shape, const Vec3& position, const Quat4& orientation);
  /// Throws std::invalid_argument naming the part for no parts, a non-finite position, or a
  /// rotation that is not proper (orthonormal within 1e-9, determinant +1).
  explicit Compound(std::vector<Part> parts);
  std::vector<Part> parts;
};

using Shape = std::variant<Sphere, Box, Plane, Mesh, Capsule, Cylinder, ConvexHull, TriangleMesh, Compound>;

/// "Sphere", "Box", "Plane", "Mesh", "Capsule", "Cylinder", "ConvexHull", "TriangleMesh", "Compound".
std::string shape_name(const Shape& shape);

/// Largest distance from the body origin to the shape's surface (m); infinity for a plane.
double bounding_radius(const Shape& shape);

/// Radius (m) of a ball the shape surely contains: sphere and capsule r, box its smallest half
/// extent, cylinder min(r, h); a convex hull or piece the distance from its vertex mean to its
/// nearest face plane; a mesh the largest over its convex pieces (or, without pieces, the convex
/// mesh's own); a compound the largest over its parts; infinity for a plane, a triangle mesh and a
/// mesh with no piece whose vertex mean lies inside every face plane (no ball is known). The
/// solver scales a contact's slop by it (SolverSettings::slop_inner_fraction).
double inner_radius(const Shape& shape);

/// The radius (m) by which the shape, or a compound's part `part`, rounds a core: a contact's
/// witness point on it is its core point (a sphere's centre, the nearest point of a capsule's
/// segment) moved by this radius against the contact normal, whichever way the body has turned,
/// so that a rolling ball's witness stays at its bottom. Sphere and Capsule: their radius; a
/// compound: its part's (0 for a part index it does not have); every other shape 0 (its witness
/// points are points of the body: vertices, edges, faces).
double rounding_radius(const Shape& shape, std::uint32_t part = 0);

/// true for shapes that can only be static (Plane, TriangleMesh).
bool static_only(const Shape& shape);

}  // namespace signorini
