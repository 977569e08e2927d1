// The geometry layer of the new shapes: the box's polytope numbering, polytopes from triangles,
// Qhull hulls, triangle-mesh edge flags, compounds, and the closed-form mass properties.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <string>

#include "math/rotation.hpp"
#include "signorini/mass_properties.hpp"
#include "signorini/shapes.hpp"
#include "signorini/world.hpp"

using namespace signorini;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Runs f, expects std::invalid_argument whose message contains `part`.
template <class F>
void expect_error(F&& f, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "no exception; expected one containing \"" << part << "\"";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

/// |a - b| <= rel max(|b|, scale) elementwise (relative to the tensor's size for zero entries).
void expect_close(const Mat3& a, const Mat3& b, double rel) {
  const double scale = b.cwiseAbs().maxCoeff();
  EXPECT_LE((a - b).cwiseAbs().maxCoeff(), rel * scale) << "got\n" << a << "\nexpected\n" << b;
}

/// The 8 corners of a box (k & 1 -> +x, k & 2 -> +y, k & 4 -> +z) and its 12 outward triangles.
Points cube_corners(const Vec3& h) {
  Points v(8, 3);
  for (int k = 0; k < 8; ++k)
    v.row(k) << ((k & 1) ? h.x() : -h.x()), ((k & 2) ? h.y() : -h.y()), ((k & 4) ? h.z() : -h.z());
  return v;
}

Triangles cube_triangles() {
  Triangles f(12, 3);
  f << 0, 2, 1, 1, 2, 3,   // z-
       4, 5, 6, 5, 7, 6,   // z+
       0, 1, 4, 1, 5, 4,   // y-
       2, 6, 3, 3, 6, 7,   // y+
       0, 4, 2, 2, 4, 6,   // x-
       1, 3, 5, 3, 7, 5;   // x+
  return f;
}

/// Everything a polytope promises about itself: planar convex loops counter-clockwise about unit
/// outward normals, all vertices behind every face, edges and face_edges consistent, Euler's formula.
void check_polytope(const Polytope& p, double tol) {
  ASSERT_EQ(p.normals.size(), p.faces.size());
  ASSERT_EQ(p.offsets.size(), p.faces.size());
  ASSERT_EQ(p.face_edges.size(), p.faces.size());
  std::set<int> used;
  for (std::size_t f = 0; f < p.faces.size(); ++f) {
    const auto& loop = p.faces[f];
    const Vec3& n = p.normals[f];
    EXPECT_NEAR(n.norm(), 1.0, 1e-15);
    ASSERT_GE(loop.size(), 3u);
    ASSERT_EQ(p.face_edges[f].size(), loop.size());
    for (std::size_t k = 0; k < loop.size(); ++k) {
      used.insert(loop[k]);
      const Vec3 a = p.vertex(loop[k]), b = p.vertex(loop[(k + 1) % loop.size()]),
                 c = p.vertex(loop[(k + 2) % loop.size()]);
      EXPECT_NEAR(n.dot(a), p.offsets[f], tol) << "face " << f << " is not planar";
      EXPECT_GT((b - a).cross(c - b).dot(n), 0.0) << "face " << f << " turns clockwise at corner " << k;
      // side k's edge runs loop[k] -> loop[k + 1] in f0, the other way in f1
      const Polytope::Edge& e = p.edges[p.face_edges[f][k]];
      const int v0 = loop[k], v1 = loop[(k + 1) % loop.size()];
      if (e.f0 == static_cast<int>(f)) {
        EXPECT_EQ(e.v0, v0);
        EXPECT_EQ(e.v1, v1);
      } else {
        EXPECT_EQ(e.f1, static_cast<int>(f));
        EXPECT_EQ(e.v0, v1);
        EXPECT_EQ(e.v1, v0);
      }
    }
    for (int i : used) EXPECT_LE(n.dot(p.vertex(i)), p.offsets[f] + tol);
  }
  for (const Polytope::Edge& e : p.edges) EXPECT_NE(e.f0, e.f1);
  // V - E + F = 2 for a closed convex polyhedron
  EXPECT_EQ(static_cast<int>(used.size()) - static_cast<int>(p.edges.size()) + static_cast<int>(p.faces.size()), 2);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Box polytope numbering (the table in docs/polytope_numbering.md)

TEST(BoxPolytope, NumberingIsTheDocumentedTable) {
  const Vec3 h(0.5, 1.0, 1.5);
  const Box box(h);
  const Polytope& p = *box.polytope;
  ASSERT_EQ(p.vertices.rows(), 8);
  EXPECT_EQ(p.vertices, cube_corners(h));
  const std::vector<std::vector<int>> faces = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                               {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  EXPECT_EQ(p.faces, faces);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(p.normals[2 * i], -Vec3::Unit(i));
    EXPECT_EQ(p.normals[2 * i + 1], Vec3::Unit(i));
    EXPECT_EQ(p.offsets[2 * i], h[i]);
    EXPECT_EQ(p.offsets[2 * i + 1], h[i]);
  }
  const int edges[12][4] = {{0, 4, 0, 2}, {4, 6, 0, 5}, {6, 2, 0, 3}, {2, 0, 0, 4}, {1, 3, 1, 4}, {3, 7, 1, 3},
                            {7, 5, 1, 5}, {5, 1, 1, 2}, {0, 1, 2, 4}, {5, 4, 2, 5}, {6, 7, 3, 5}, {3, 2, 3, 4}};
  ASSERT_EQ(p.edges.size(), 12u);
  for (int e = 0; e < 12; ++e) {
    EXPECT_EQ(p.edges[e].v0, edges[e][0]) << "edge " << e;
    EXPECT_EQ(p.edges[e].v1, edges[e][1]) << "edge " << e;
    EXPECT_EQ(p.edges[e].f0, edges[e][2]) << "edge " << e;
    EXPECT_EQ(p.edges[e].f1, edges[e][3]) << "edge " << e;
  }
  const std::vector<std::vector<int>> face_edges = {{0, 1, 2, 3}, {4, 5, 6, 7}, {8, 7, 9, 0},
                                                    {2, 10, 5, 11}, {3, 11, 4, 8}, {9, 6, 10, 1}};
  EXPECT_EQ(p.face_edges, face_edges);
  EXPECT_EQ(p.centroid, Vec3::Zero());
  check_polytope(p, 0.0);
}

TEST(BoxPolytope, FaceLoopsFollowTheSignRule) {
  // face s e_i, j = i + 1, k = i + 2: s = +1 walks (j, k) signs (-,-), (+,-), (+,+), (-,+), s = -1
  // walks (-,-), (-,+), (+,+), (+,-); coordinate i has the sign s throughout
  const Box box(Vec3(1, 2, 3));
  const Polytope& p = *box.polytope;
  for (int i = 0; i < 3; ++i)
    for (int s : {-1, 1}) {
      const int j = (i + 1) % 3, k = (i + 2) % 3;
      const auto& loop = p.faces[2 * i + (s > 0)];
      const int want[2][4][2] = {{{-1, -1}, {-1, 1}, {1, 1}, {1, -1}}, {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}};
      for (int c = 0; c < 4; ++c) {
        const Vec3 v = p.vertex(loop[c]);
        EXPECT_EQ(v[i] > 0, s > 0);
        EXPECT_EQ(v[j] > 0, want[s > 0][c][0] > 0) << "face " << 2 * i + (s > 0) << " corner " << c;
        EXPECT_EQ(v[k] > 0, want[s > 0][c][1] > 0) << "face " << 2 * i + (s > 0) << " corner " << c;
      }
    }
}

// ---------------------------------------------------------------------------------------------
// polytope_from_triangles

TEST(PolytopeFromTriangles, MergesACubeMeshIntoSixQuads) {
  const Vec3 h(0.3, 0.7, 1.1);
  const Polytope p = polytope_from_triangles(cube_corners(h), cube_triangles());
  ASSERT_EQ(p.faces.size(), 6u);
  for (const auto& loop : p.faces) EXPECT_EQ(loop.size(), 4u);
  EXPECT_EQ(p.edges.size(), 12u);
  check_polytope(p, 1e-15);
  // groups in order of their first triangle; each loop starts at that triangle's first corner
  EXPECT_EQ(p.faces[0], (std::vector<int>{0, 2, 3, 1}));
  EXPECT_EQ(p.normals[0], -Vec3::UnitZ());
  EXPECT_EQ(p.normals[5], Vec3::UnitX());
  EXPECT_NEAR(p.offsets[5], h.x(), 1e-15);
  EXPECT_LT(p.centroid.norm(), 1e-15);
}

TEST(PolytopeFromTriangles, ATetrahedronKeepsItsTriangles) {
  Points v(4, 3);
  v << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Triangles f(4, 3);
  f << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  const Polytope p = polytope_from_triangles(v, f);
  ASSERT_EQ(p.faces.size(), 4u);
  for (int t = 0; t < 4; ++t) EXPECT_EQ(p.faces[t], (std::vector<int>{int(f(t, 0)), int(f(t, 1)), int(f(t, 2))}));
  EXPECT_EQ(p.edges.size(), 6u);
  check_polytope(p, 1e-15);
  EXPECT_LT((p.centroid - Vec3::Constant(0.25)).norm(), 1e-15);
}

TEST(PolytopeFromTriangles, RejectsOpenAndNonConvexMeshes) {
  const Points v = cube_corners(Vec3(1, 1, 1));
  const Triangles f = cube_triangles();
  expect_error([&] { polytope_from_triangles(v, Triangles(f.topRows(11))); }, "open");
  Points dented = v;
  dented.row(7) *= 0.2;  // corner 7 pushed in past the plane x + y + z = 1 of its neighbours: a dent
  expect_error([&] { polytope_from_triangles(dented, f); }, "not convex");
  Triangles inverted = f;
  inverted.col(1).swap(inverted.col(2));
  expect_error([&] { polytope_from_triangles(v, inverted); }, "not convex");
}

// ---------------------------------------------------------------------------------------------
// ConvexHull (Qhull)

TEST(ConvexHull, CubeCornersWithInteriorPoints) {
  const Vec3 h(0.5, 1.0, 1.5);
  const Points corners = cube_corners(h);
  // corners at rows 1, 3, ..., 15; interior points and a duplicate corner in between
  Points cloud(17, 3);
  for (int k = 0; k < 8; ++k) {
    cloud.row(2 * k) = 0.3 * corners.row((k + 3) % 8);
    cloud.row(2 * k + 1) = corners.row(k);
  }
  cloud.row(16) = corners.row(5);
  const ConvexHull hull(cloud);
  ASSERT_EQ(hull.vertices.rows(), 8);
  EXPECT_EQ(hull.vertices, corners);  // increasing original index: corner k was row 2 k + 1
  EXPECT_EQ(hull.faces.rows(), 12);
  ASSERT_EQ(hull.polytope->faces.size(), 6u);
  for (const auto& loop : hull.polytope->faces) EXPECT_EQ(loop.size(), 4u);
  EXPECT_EQ(hull.polytope->edges.size(), 12u);
  check_polytope(*hull.polytope, 1e-15);
  // the triangulation is the box's solid
  const MassProperties mp = mass_properties(hull, 2.0), exact = mass_properties(Box(h), 2.0);
  EXPECT_NEAR(mp.mass, exact.mass, 1e-12 * exact.mass);
  EXPECT_LT(mp.com.norm(), 1e-15);
  expect_close(mp.inertia, exact.inertia, 1e-12);
}

TEST(ConvexHull, RandomCloudIsContainedAndDeterministic) {
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Points cloud(200, 3);
  for (Eigen::Index i = 0; i < cloud.rows(); ++i)
    cloud.row(i) << gauss(rng), 0.5 * gauss(rng), 2.0 * gauss(rng);
  const ConvexHull hull(cloud);
  const Polytope& p = *hull.polytope;
  check_polytope(p, 1e-12);
  const double tol = 1e-12 * cloud.cwiseAbs().maxCoeff();
  for (Eigen::Index i = 0; i < cloud.rows(); ++i)
    for (std::size_t f = 0; f < p.faces.size(); ++f)
      EXPECT_LE(p.normals[f].dot(cloud.row(i).transpose()), p.offsets[f] + tol) << "point " << i << " face " << f;
  // every hull vertex is an input point, in increasing input order
  Eigen::Index next = 0;
  for (Eigen::Index v = 0; v < hull.vertices.rows(); ++v) {
    while (next < cloud.rows() && cloud.row(next) != hull.vertices.row(v)) ++next;
    EXPECT_LT(next, cloud.rows()) << "hull vertex " << v << " is not an input point (in order)";
  }
  // outward triangles: positive volume; the hull is closed: 2 F = 3 E... V - E + F = 2 with F = 2V - 4
  EXPECT_GT(mass_properties(hull, 1.0).volume, 0.0);
  EXPECT_EQ(hull.faces.rows(), 2 * hull.vertices.rows() - 4);
  const ConvexHull again(cloud);
  EXPECT_EQ(again.vertices, hull.vertices);
  EXPECT_EQ(again.faces, hull.faces);
  EXPECT_EQ(again.polytope->faces, hull.polytope->faces);
}

TEST(ConvexHull, BadInputIsRejectedWithAReason) {
  const Points corners = cube_corners(Vec3(1, 1, 1));
  expect_error([&] { ConvexHull(Points(corners.topRows(3))); }, "ConvexHull: needs at least 4 points, got 3");
  Points nan = corners;
  nan(2, 1) = kNaN;
  expect_error([&] { ConvexHull{nan}; }, "ConvexHull: point 2 is not finite");
  Points flat = corners;
  flat.col(2).setConstant(0.25);  // z = 0.25 for all: a square, twice
  expect_error([&] { ConvexHull{flat}; }, "ConvexHull: the points are coplanar (the hull has no volume)");
  Points line(5, 3);
  for (int i = 0; i < 5; ++i) line.row(i) << i, 2 * i, -i;
  expect_error([&] { ConvexHull{line}; }, "collinear (the hull has no volume)");
  Points same(4, 3);
  same.rowwise() = Eigen::RowVector3d(1, 2, 3);
  expect_error([&] { ConvexHull{same}; }, "coincide (the hull has no volume)");
}

// ---------------------------------------------------------------------------------------------
// TriangleMesh

TEST(TriangleMesh, FlatFloorHasOnlyItsRimActive) {
  Points v(4, 3);
  v << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  Triangles f(2, 3);
  f << 0, 1, 2, 0, 2, 3;
  const TriangleMesh floor(v, f);
  // face 0: 0->1 rim, 1->2 rim, 2->0 diagonal; face 1: 0->2 diagonal, 2->3 rim, 3->0 rim
  EXPECT_EQ(floor.active_edge[0], (std::array<bool, 3>{true, true, false}));
  EXPECT_EQ(floor.active_edge[1], (std::array<bool, 3>{false, true, true}));
  EXPECT_EQ(floor.normals[0], Vec3::UnitZ());
  EXPECT_EQ(floor.normals[1], Vec3::UnitZ());
}

TEST(TriangleMesh, RidgeIsActiveValleyIsNot) {
  // two triangles over the edge p0 = (0, 0, z), p1 = (0, 1, z), opposite vertices at x = +-1, z = 0
  for (double z : {1.0, -1.0, 1e-8, 1e-4}) {
    Points v(4, 3);
    v << 0, 0, z, 0, 1, z, 1, 0.5, 0, -1, 0.5, 0;
    Triangles f(2, 3);
    f << 0, 2, 1, 1, 3, 0;
    const TriangleMesh m(v, f);
    EXPECT_GT(m.normals[0].z(), 0.0);
    EXPECT_GT(m.normals[1].z(), 0.0);
    // a ridge (z > 0) folds by about 2 z rad at small z: active above 1e-6 rad only
    const bool convex = z > 0 && 2 * z > 1e-6;
    EXPECT_EQ(m.active_edge[0][2], convex) << "z = " << z;
    EXPECT_EQ(m.active_edge[1][2], convex) << "z = " << z;
    EXPECT_TRUE(m.active_edge[0][0] && m.active_edge[0][1] && m.active_edge[1][0] && m.active_edge[1][1]);
  }
}

TEST(TriangleMesh, NonManifoldEdgeIsActive) {
  Points v(5, 3);
  v << 0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, -1, 0, 0.5, 0, 1;
  Triangles f(3, 3);
  f << 0, 1, 2, 1, 0, 3, 0, 1, 4;  // three faces on the edge 0-1
  const TriangleMesh m(v, f);
  EXPECT_TRUE(m.active_edge[0][0] && m.active_edge[1][0] && m.active_edge[2][0]);
}

TEST(TriangleMesh, BadInputIsRejectedWithTheFaceIndex) {
  Points v(4, 3);
  v << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  Triangles dup(3, 3);
  dup << 0, 1, 2, 0, 2, 3, 2, 0, 1;
  expect_error([&] { TriangleMesh(v, dup); }, "TriangleMesh: face 2 repeats face 0");
  Triangles flipped(2, 3);
  flipped << 0, 1, 2, 2, 1, 0;  // the same triangle facing the other way is a duplicate too
  expect_error([&] { TriangleMesh(v, flipped); }, "face 1 repeats face 0");
  Triangles degenerate(2, 3);
  degenerate << 0, 1, 2, 0, 0, 3;
  expect_error([&] { TriangleMesh(v, degenerate); }, "TriangleMesh: face 1 is degenerate");
  Triangles out(1, 3);
  out << 0, 1, 4;
  expect_error([&] { TriangleMesh(v, out); }, "face 0 has vertex index 4 outside [0, 4)");
  Points bad = v;
  bad(3, 0) = INFINITY;
  expect_error([&] { TriangleMesh(bad, Triangles(dup.topRows(2))); }, "TriangleMesh: vertex 3 is not finite");
}

// ---------------------------------------------------------------------------------------------
// Capsule, Cylinder, Compound: construction

TEST(Primitives, BadSizesNameTheShapeAndValue) {
  expect_error([] { Capsule(-1.0, 1.0); }, "Capsule: radius must be positive and finite, got -1");
  expect_error([] { Capsule(1.0, -0.5); }, "Capsule: half_length must be finite and >= 0, got -0.5");
  expect_error([] { Capsule(kNaN, 1.0); }, "Capsule: radius");
  EXPECT_NO_THROW(Capsule(1.0, 0.0));
  expect_error([] { Cylinder(0.0, 1.0); }, "Cylinder: radius must be positive and finite, got 0");
  expect_error([] { Cylinder(1.0, 0.0); }, "Cylinder: half_height must be positive and finite, got 0");
  expect_error([] { Cylinder(1.0, INFINITY); }, "Cylinder: half_height");
}

TEST(Compound, PartsAreValidated) {
  expect_error([] { Compound({}); }, "Compound: needs at least one part");
  const Compound::Part good{Sphere(1.0), Vec3(1, 0, 0), Mat3::Identity()};
  expect_error([&] { Compound({good, {Sphere(1.0), Vec3(0, kNaN, 0), Mat3::Identity()}}); },
               "Compound: part 1: position must be finite");
  expect_error([&] { Compound({good, good, {Box(Vec3(1, 1, 1)), Vec3::Zero(), 1.01 * Mat3::Identity()}}); },
               "Compound: part 2: rotation must be a proper rotation");
  const Mat3 mirror = Vec3(1, 1, -1).asDiagonal();
  expect_error([&] { Compound({{Capsule(1.0, 1.0), Vec3::Zero(), mirror}}); }, "part 0: rotation must be a proper");
  // quaternion parts: normalised, zero refused
  const Compound::Part q = Compound::make_part(Box(Vec3(1, 2, 3)), Vec3(0, 0, 1), Quat4(2, 0, 0, 2));
  const Mat3 Rz = Eigen::AngleAxisd(kPi / 2, Vec3::UnitZ()).toRotationMatrix();
  EXPECT_LT((q.rotation - Rz).norm(), 1e-15);
  EXPECT_LT((q.orientation() - Quat4(1, 0, 0, 1) / std::sqrt(2.0)).norm(), 1e-15);
  expect_error([] { Compound::make_part(Sphere(1.0), Vec3::Zero(), Quat4::Zero()); }, "is zero");
  expect_error([] { Compound::make_part(Sphere(1.0), Vec3::Zero(), Quat4(kNaN, 0, 0, 1)); }, "finite");
}

TEST(Shapes, InnerRadiiAreBallsTheShapesContain) {
  // closed forms: the largest ball about the centre (a hull: about its vertex mean)
  EXPECT_EQ(inner_radius(Sphere(0.3)), 0.3);
  EXPECT_EQ(inner_radius(Box(Vec3(0.4, 0.1, 0.2))), 0.1);
  EXPECT_EQ(inner_radius(Capsule(0.5, 2.0)), 0.5);
  EXPECT_EQ(inner_radius(Cylinder(3.0, 0.25)), 0.25);
  EXPECT_EQ(inner_radius(Cylinder(0.25, 3.0)), 0.25);
  EXPECT_DOUBLE_EQ(inner_radius(ConvexHull(cube_corners(Vec3(1, 2, 0.5)))), 0.5);
  // a compound: its largest part's, wherever the part is placed
  const Compound c({{Sphere(0.5), Vec3(3, 0, 0), Mat3::Identity()}, {Box(Vec3(0.7, 0.9, 0.8)), Vec3(0, 0, 1), Mat3::Identity()}});
  EXPECT_EQ(inner_radius(c), 0.7);
  // planes and triangle meshes bound nothing
  EXPECT_EQ(inner_radius(Plane(Vec3::UnitZ(), 0.0)), std::numeric_limits<double>::infinity());
  Points v(3, 3);
  v << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  EXPECT_EQ(inner_radius(TriangleMesh(v, Triangles(Eigen::RowVector3<std::int64_t>(0, 1, 2)))),
            std::numeric_limits<double>::infinity());
}

TEST(Shapes, NamesRadiiAndStaticOnly) {
  EXPECT_EQ(shape_name(Capsule(1, 2)), "Capsule");
  EXPECT_EQ(shape_name(ConvexHull(cube_corners(Vec3(1, 1, 1)))), "ConvexHull");
  EXPECT_EQ(bounding_radius(Capsule(0.5, 2.0)), 2.5);
  EXPECT_EQ(bounding_radius(Cylinder(3.0, 4.0)), 5.0);
  EXPECT_DOUBLE_EQ(bounding_radius(ConvexHull(cube_corners(Vec3(1, 2, 2)))), 3.0);
  // compound: exact per part. A cylinder (r 1, h 1) lying along x at (0, 0, 2): its rims are
  // centred at (+-1, 0, 2) with axis x, so they reach sqrt(1 + (2 + 1)^2) = sqrt(10).
  const Mat3 Ry = Eigen::AngleAxisd(kPi / 2, Vec3::UnitY()).toRotationMatrix();
  const Compound c({{Sphere(0.5), Vec3(1, 0, 0), Mat3::Identity()}, {Cylinder(1.0, 1.0), Vec3(0, 0, 2), Ry}});
  EXPECT_NEAR(bounding_radius(c), std::sqrt(10.0), 1e-15);
  const Compound s({{Sphere(0.5), Vec3(3, 0, 0), Mat3::Identity()}, {Capsule(0.5, 1.0), Vec3(0, 0, 1), Mat3::Identity()}});
  EXPECT_DOUBLE_EQ(bounding_radius(s), 3.5);
  EXPECT_TRUE(static_only(Plane(Vec3::UnitZ(), 0.0)));
  Points v(3, 3);
  v << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  EXPECT_TRUE(static_only(TriangleMesh(v, Triangles(Eigen::RowVector3<std::int64_t>(0, 1, 2)))));
  EXPECT_FALSE(static_only(Box(Vec3(1, 1, 1))));
  EXPECT_FALSE(static_only(c));
}

// ---------------------------------------------------------------------------------------------
// mass properties against closed forms (relative 1e-12: only rounding separates them)

TEST(MassPropertiesNew, CylinderClosedForm) {
  const double r = 0.4, h = 0.9, rho = 700.0, H = 2 * h;
  const MassProperties mp = mass_properties(Cylinder(r, h), rho);
  const double m = rho * kPi * r * r * H;
  EXPECT_NEAR(mp.mass, m, 1e-12 * m);
  EXPECT_NEAR(mp.volume, m / rho, 1e-12 * m / rho);
  expect_close(mp.inertia, Vec3(m * (3 * r * r + H * H) / 12, m * (3 * r * r + H * H) / 12, m * r * r / 2).asDiagonal(), 1e-12);
  EXPECT_EQ(mp.com, Vec3::Zero());
}

TEST(MassPropertiesNew, CapsuleClosedForm) {
  const double r = 0.3, h = 0.8, rho = 1200.0;
  const MassProperties mp = mass_properties(Capsule(r, h), rho);
  const double m_c = rho * kPi * r * r * 2 * h, m_s = rho * 4.0 / 3.0 * kPi * r * r * r;
  EXPECT_NEAR(mp.mass, m_c + m_s, 1e-12 * (m_c + m_s));
  // second moments, independently: for the two hemispheres int x^2 dm = m_s r^2 / 5 and
  // int z^2 dm = sum over the halves of int (z' +- h)^2 = m_s r^2/5 + 2 h m_s (3 r / 8) + m_s h^2
  const double xx = m_c * r * r / 4 + m_s * r * r / 5;
  const double zz = m_c * h * h / 3 + m_s * r * r / 5 + 2 * h * m_s * 3 * r / 8 + m_s * h * h;
  expect_close(mp.inertia, Vec3(xx + zz, xx + zz, 2 * xx).asDiagonal(), 1e-12);
}

TEST(MassPropertiesNew, CapsuleOfZeroLengthIsASphere) {
  const MassProperties cap = mass_properties(Capsule(0.7, 0.0), 900.0), ball = mass_properties(Sphere(0.7), 900.0);
  EXPECT_NEAR(cap.mass, ball.mass, 1e-12 * ball.mass);
  expect_close(cap.inertia, ball.inertia, 1e-12);
}

TEST(MassPropertiesNew, TwoBoxesSideBySideAreOneLongBox) {
  const Vec3 h(0.5, 0.3, 0.2);
  const MassProperties one = mass_properties(Box(Vec3(2 * h.x(), h.y(), h.z())), 800.0);
  const Compound pair({{Box(h), Vec3(-h.x(), 0, 0), Mat3::Identity()}, {Box(h), Vec3(h.x(), 0, 0), Mat3::Identity()}});
  MassProperties two = mass_properties(pair, 800.0);
  EXPECT_NEAR(two.mass, one.mass, 1e-12 * one.mass);
  EXPECT_NEAR(two.volume, one.volume, 1e-12 * one.volume);
  EXPECT_LT(two.com.norm(), 1e-15);
  expect_close(two.inertia, one.inertia, 1e-12);
  // the same with the parts turned a quarter about z (half extents swapped), and the whole moved
  const Mat3 Rz = Eigen::AngleAxisd(kPi / 2, Vec3::UnitZ()).toRotationMatrix();
  const Vec3 hs(h.y(), h.x(), h.z()), t(0.1, -0.2, 0.3);
  const Compound turned({{Box(hs), Vec3(-h.x(), 0, 0) + t, Rz}, {Box(hs), Vec3(h.x(), 0, 0) + t, Rz}});
  two = mass_properties(turned, 800.0);
  EXPECT_LT((two.com - t).norm(), 1e-15);
  expect_close(two.inertia, one.inertia, 1e-12);
}

TEST(MassPropertiesNew, CompoundOfOneRotatedPartIsThatPartMoved) {
  const Mat3 R = math::quat_to_matrix(Quat4(0.9, 0.1, -0.3, 0.2).normalized());
  const Vec3 t(1.0, -2.0, 0.5);
  const MassProperties part = mass_properties(Capsule(0.2, 0.5), 500.0);
  const MassProperties whole = mass_properties(Compound({{Capsule(0.2, 0.5), t, R}}), 500.0);
  EXPECT_NEAR(whole.mass, part.mass, 1e-12 * part.mass);
  EXPECT_LT((whole.com - t).norm(), 1e-15);
  expect_close(whole.inertia, R * part.inertia * R.transpose(), 1e-12);
  // a hull part whose own com is off its origin
  const ConvexHull hull(cube_corners(Vec3(1, 1, 1)).rowwise() + Eigen::RowVector3d(2, 0, 0));
  const MassProperties hp = mass_properties(hull, 3.0);
  EXPECT_LT((hp.com - Vec3(2, 0, 0)).norm(), 1e-15);
  const MassProperties moved = mass_properties(Compound({{hull, t, R}}), 3.0);
  EXPECT_LT((moved.com - (t + R * Vec3(2, 0, 0))).norm(), 1e-14);
  expect_close(moved.inertia, R * hp.inertia * R.transpose(), 1e-12);
}

TEST(MassPropertiesNew, StaticOnlyShapesHaveNoMass) {
  Points v(3, 3);
  v << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  expect_error([&] { mass_properties(TriangleMesh(v, Triangles(Eigen::RowVector3<std::int64_t>(0, 1, 2))), 1.0); },
               "TriangleMesh: a triangle mesh has no volume; it can only be static");
  expect_error([] { mass_properties(Plane(Vec3::UnitZ(), 0.0), 1.0); }, "has no volume; it can only be static");
}

// ---------------------------------------------------------------------------------------------
// World: re-centring and static-only shapes

TEST(WorldShapes, DynamicHullAndCompoundAreRecentredOnTheirCom) {
  World w;
  BodyDesc hull;
  hull.shape = ConvexHull(cube_corners(Vec3(1, 1, 1)).rowwise() + Eigen::RowVector3d(2, 0, 0));
  hull.density = 1.0;
  hull.position = Vec3(0, 0, 5);
  w.add_body(hull);
  const auto& h = std::get<ConvexHull>(w.model().shape[0]);
  EXPECT_LT((h.vertices.colwise().mean()).norm(), 1e-15);
  EXPECT_LT(h.polytope->vertices.colwise().mean().norm(), 1e-15);
  EXPECT_LT(h.polytope->centroid.norm(), 1e-15);
  for (std::size_t f = 0; f < h.polytope->faces.size(); ++f) EXPECT_NEAR(h.polytope->offsets[f], 1.0, 1e-15);
  check_polytope(*h.polytope, 1e-15);

  BodyDesc pair;
  pair.shape = Compound({{Sphere(1.0), Vec3(10, 0, 0), Mat3::Identity()}, {Sphere(1.0), Vec3(14, 0, 0), Mat3::Identity()}});
  pair.mass = 2.0;
  w.add_body(pair);
  const auto& c = std::get<Compound>(w.model().shape[1]);
  EXPECT_EQ(c.parts[0].position, Vec3(-2, 0, 0));
  EXPECT_EQ(c.parts[1].position, Vec3(2, 0, 0));
  EXPECT_EQ(w.model().rho[1], 3.0);
  EXPECT_NEAR(w.model().mass[1], 2.0, 1e-15);
}

TEST(WorldShapes, TriangleMeshIsStaticOnly) {
  World w;
  Points v(3, 3);
  v << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  BodyDesc d;
  d.shape = TriangleMesh(v, Triangles(Eigen::RowVector3<std::int64_t>(0, 1, 2)));
  d.density = 1.0;
  expect_error([&] { w.add_body(d); }, "body 0 (TriangleMesh): a triangle mesh can only be static; use add_static");
  EXPECT_EQ(w.num_bodies(), 0u);
}
