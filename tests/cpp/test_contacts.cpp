// Contact generation through collision::collide: golden manifolds with exact answers (docs/
// conventions.md, "Manifolds"), feature ids, A/B symmetry, speculative gaps, unsupported pairs.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <vector>

#include "collision/collision.hpp"
#include "math/rotation.hpp"
#include "random_scene.hpp"

using namespace signorini;
using collision::Pose;
using scenes::floor_mesh;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<Contact> collide(const Shape& a, const Pose& pa, const Shape& b, const Pose& pb, double threshold = 1e-6) {
  std::vector<Contact> out;
  collision::collide(a, pa, b, pb, threshold, {}, out);
  return out;
}

Mat3 rot_z(double angle) { return Eigen::AngleAxisd(angle, Vec3::UnitZ()).toRotationMatrix(); }

/// The same contacts, bit for bit, in the same order.
bool same(const std::vector<Contact>& x, const std::vector<Contact>& y) {
  if (x.size() != y.size()) return false;
  for (std::size_t k = 0; k < x.size(); ++k)
    if (x[k].point != y[k].point || x[k].normal != y[k].normal || x[k].gap != y[k].gap ||
        x[k].feature_a != y[k].feature_a || x[k].feature_b != y[k].feature_b)
      return false;
  return true;
}


}  // namespace

// slots golden: plane-polytope
TEST(Manifold, BoxFaceDownOnAPlaneHasItsFourBottomCornersWithVertexIds) {
  const Box box(Vec3(0.5, 0.5, 0.5));
  const auto out = collide(Plane(Vec3::UnitZ(), 0.0), {}, box, {Vec3(0.2, -0.3, 0.5), Mat3::Identity()}, 1e-3);
  ASSERT_EQ(out.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_LT(std::abs(out[k].gap), 1e-9);
    EXPECT_EQ(out[k].normal, Vec3::UnitZ());
    EXPECT_EQ(out[k].feature_a, feature_id(FeatureKind::Face, 0));
    EXPECT_EQ(out[k].feature_b, feature_id(FeatureKind::Vertex, k));
    const Vec3 corner(k & 1 ? 0.7 : -0.3, k & 2 ? 0.2 : -0.8, 0.0);
    EXPECT_LT((out[k].point - corner).norm(), 1e-12);
  }
}

// slots golden: polytope-polytope
TEST(Manifold, UnitBoxOnALargerBoxHasFourCornerPointsAndTheExactNormal) {
  const Box ground(Vec3(2.0, 2.0, 0.5)), box(Vec3(0.5, 0.5, 0.5));
  const Pose pg{Vec3(0, 0, -0.5), Mat3::Identity()};
  const Pose pb{Vec3(0.3, 0.1, 0.5), Mat3::Identity()};
  const auto out = collide(ground, pg, box, pb);
  ASSERT_EQ(out.size(), 4u);
  std::set<FeatureId> ids;
  for (const Contact& c : out) {
    EXPECT_LT(std::abs(c.gap), 1e-9);
    EXPECT_EQ(c.normal, Vec3::UnitZ());
    EXPECT_NEAR(std::abs(c.point.x() - 0.3), 0.5, 1e-12);
    EXPECT_NEAR(std::abs(c.point.y() - 0.1), 0.5, 1e-12);
    EXPECT_NEAR(c.point.z(), 0.0, 1e-12);
    ids.insert(c.feature_b);
  }
  // the reference face is the ground's top (face 5, +z); the box's bottom corners are vertices 0..3
  EXPECT_EQ(ids, (std::set<FeatureId>{feature_id(FeatureKind::Vertex, 0), feature_id(FeatureKind::Vertex, 1),
                                       feature_id(FeatureKind::Vertex, 2), feature_id(FeatureKind::Vertex, 3)}));
  EXPECT_EQ(out[0].feature_a, feature_id(FeatureKind::Face, 5));
  // the same with B's reference: swapping A and B flips the normal and keeps the points
  const auto swapped = collide(box, pb, ground, pg);
  ASSERT_EQ(swapped.size(), 4u);
  for (const Contact& c : swapped) EXPECT_EQ(c.normal, -Vec3::UnitZ());
}

// slots golden: polytope-polytope
TEST(Manifold, BoxTurned45DegreesOnABoxKeepsFourPointsOnTheOverlapOctagon) {
  const Box box(Vec3(0.5, 0.5, 0.5));
  const Pose lower{Vec3::Zero(), Mat3::Identity()};
  const Pose upper{Vec3(0, 0, 1.0), rot_z(kPi / 4)};
  const auto out = collide(box, lower, box, upper);
  ASSERT_EQ(out.size(), 4u);
  // the overlap of the two unit squares is a regular octagon with vertices at radius
  // 0.5 / cos(22.5 deg) on the directions 22.5 + 45 k degrees
  const double rv = 0.5 / std::cos(kPi / 8);
  std::vector<Vec3> octagon;
  for (int k = 0; k < 8; ++k) octagon.emplace_back(rv * std::cos(kPi / 8 + k * kPi / 4), rv * std::sin(kPi / 8 + k * kPi / 4), 0.5);
  for (const Contact& c : out) {
    EXPECT_LT(std::abs(c.gap), 1e-9);
    EXPECT_LT((c.normal - Vec3::UnitZ()).norm(), 1e-12);
    double nearest = 1e9;
    for (const Vec3& o : octagon) nearest = std::min(nearest, (c.point - o).norm());
    EXPECT_LT(nearest, 1e-9) << "every point is an octagon vertex";
  }
  // the 4 points span the largest quadrilateral of the octagon: half its area or more
  // (a square on alternate vertices: 2 rv^2; the octagon itself: 2 sqrt(2) rv^2)
  const Vec3 d1 = out[0].point, d2 = out[1].point, d3 = out[2].point, d4 = out[3].point;
  double area = 0.0;
  const Vec3 centre = (d1 + d2 + d3 + d4) / 4;
  std::vector<Vec3> pts = {d1, d2, d3, d4};
  std::sort(pts.begin(), pts.end(), [&](const Vec3& a, const Vec3& b) {
    return std::atan2(a.y() - centre.y(), a.x() - centre.x()) < std::atan2(b.y() - centre.y(), b.x() - centre.x());
  });
  for (int k = 0; k < 4; ++k) area += 0.5 * (pts[k].x() * pts[(k + 1) % 4].y() - pts[(k + 1) % 4].x() * pts[k].y());
  EXPECT_GE(area, 2 * rv * rv * (1 - 1e-9));
}

// slots golden: polytope-polytope
TEST(Manifold, CrossedEdgesGiveOneEdgeEdgePointWithTheExactGap) {
  // a box standing on an edge along x, above a box lying on an edge along y
  const Box box(Vec3(0.5, 0.5, 0.5));
  const Mat3 Rx = Eigen::AngleAxisd(kPi / 4, Vec3::UnitX()).toRotationMatrix();
  const Mat3 Ry = Eigen::AngleAxisd(kPi / 4, Vec3::UnitY()).toRotationMatrix();
  const double h = 0.5 * std::sqrt(2.0);
  const auto out = collide(box, {Vec3::Zero(), Ry}, box, {Vec3(0, 0, 2 * h - 0.01), Rx}, 1e-3);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].gap, -0.01, 1e-12);
  EXPECT_LT((out[0].normal - Vec3::UnitZ()).norm(), 1e-12);
  EXPECT_LT((out[0].point - Vec3(0, 0, h - 0.005)).norm(), 1e-12);
  EXPECT_EQ(feature_kind(out[0].feature_a), FeatureKind::Edge);
  EXPECT_EQ(feature_kind(out[0].feature_b), FeatureKind::Edge);
}

/// Distance (m) of the world point x from the box of half extents h at pose (p, R): the length of
/// the part of R^T (x - p) outside [-h, h].
double box_distance(const Vec3& h, const Pose& pose, const Vec3& x) {
  const Vec3 local = pose.R.transpose() * (x - pose.p);
  return (local.cwiseAbs() - h).cwiseMax(0.0).norm();
}

// slots golden: polytope-polytope
TEST(Manifold, SeparatedCrossedEdgesOffTheirSegmentsGiveTheClosestPairOfTheBoxes) {
  // A unit box on an edge along x (vertices 6 -> 7 at y = 0, z = h, x in [-1/2, 1/2]) and above it
  // a unit box on an edge along y (vertices 1 -> 3, edge 4, at x = 1/2 + ex, z = h + g), both
  // turned 45 degrees. The edge axis +z separates them by g, better than any face (B's lower face
  // towards A's corner sees sqrt(1/2) (ex + g) < g); the closest points of the two edge lines lie
  // off A's edge (x = 1/2 + ex > 1/2), so the distance is that of A's corner 7 (1/2, 0, h) from
  // B's edge, or from B's end vertex 1 when B is also moved along y so that its edge starts at
  // y = ey > 0: sqrt(ex^2 + g^2), sqrt(ex^2 + ey^2 + g^2).
  const Vec3 half(0.5, 0.5, 0.5);
  const Box box(half);
  const Mat3 Rx = Eigen::AngleAxisd(kPi / 4, Vec3::UnitX()).toRotationMatrix();
  const Mat3 Ry = Eigen::AngleAxisd(kPi / 4, Vec3::UnitY()).toRotationMatrix();
  const double h = 0.5 * std::sqrt(2.0), ex = 0.001, g = 0.003;
  const Vec3 corner(0.5, 0.0, h);
  struct Case {
    double ey;              // B's edge starts at y = ey (-1/2: centred on y = 0)
    FeatureId feature_b;    // the feature of B holding the closest point
    Vec3 on_b;              // that point
  };
  const Case cases[] = {
      {-0.5, feature_id(FeatureKind::Edge, 4), Vec3(0.5 + ex, 0.0, h + g)},
      {0.001, feature_id(FeatureKind::Vertex, 1), Vec3(0.5 + ex, 0.001, h + g)},
  };
  for (const Case& k : cases) {
    const Pose pa{Vec3::Zero(), Rx}, pb{Vec3(0.5 + ex, k.ey + 0.5, 2 * h + g), Ry};
    const double distance = (k.on_b - corner).norm();
    const auto out = collide(box, pa, box, pb, 0.005);
    ASSERT_EQ(out.size(), 1u) << "ey " << k.ey;
    const Contact& c = out[0];
    EXPECT_NEAR(c.gap, distance, 1e-15) << "ey " << k.ey;
    EXPECT_GT(c.gap, g);  // the edge axis's separation is only a lower bound
    EXPECT_LT((c.normal - (k.on_b - corner) / distance).norm(), 1e-12);
    EXPECT_LT((c.point - 0.5 * (corner + k.on_b)).norm(), 1e-15);
    EXPECT_EQ(c.feature_a, feature_id(FeatureKind::Vertex, 7));
    EXPECT_EQ(c.feature_b, k.feature_b);
    // the point is the midpoint of points of the two boxes: within gap / 2 of each
    EXPECT_LE(box_distance(half, pa, c.point), 0.5 * c.gap + 1e-12);
    EXPECT_LE(box_distance(half, pb, c.point), 0.5 * c.gap + 1e-12);
    // the same pair the other way round: the same point and gap, the normal and the ids swapped
    const auto back = collide(box, pb, box, pa, 0.005);
    ASSERT_EQ(back.size(), 1u);
    EXPECT_NEAR(back[0].gap, c.gap, 1e-15);
    EXPECT_LT((back[0].point - c.point).norm(), 1e-15);
    EXPECT_LT((back[0].normal + c.normal).norm(), 1e-12);  // (q - p) / |q - p|: rounding of ~1e-16 m over 3 mm
    EXPECT_EQ(back[0].feature_a, c.feature_b);
    EXPECT_EQ(back[0].feature_b, c.feature_a);
    // no contact when the true distance reaches the threshold, though the axis's bound does not
    EXPECT_TRUE(collide(box, pa, box, pb, 0.5 * (g + distance)).empty());
  }
}

// slots golden: polytope-polytope
TEST(Manifold, SpeculativeBoxAboveABoxHasPositiveGaps) {
  const Box box(Vec3(0.5, 0.5, 0.5));
  const auto out = collide(box, {}, box, {Vec3(0.1, 0, 1.003), Mat3::Identity()}, 0.005);
  ASSERT_EQ(out.size(), 4u);
  for (const Contact& c : out) EXPECT_NEAR(c.gap, 0.003, 1e-12);
  EXPECT_TRUE(collide(box, {}, box, {Vec3(0.1, 0, 1.006), Mat3::Identity()}, 0.005).empty());
}

// slots golden: polytope-polytope
TEST(Manifold, SpeculativeClipThatMissesTheClosestPairGetsItWithTheDistance) {
  // A unit box A (axis-aligned at the origin) and a box B (half extents 0.6, 0.6, 0.2) tilted by
  // theta = 0.02 rad about (1, -1, 0) so that its lower face descends towards +x +y, that face
  // h = 1 mm from A's corner 7 = c = (1/2, 1/2, 1/2), c's foot 2 cm inside B's corner 3 in both
  // face directions. B's lower face covers A's whole upper face; its corner 3 overhangs A's corner
  // by 2.8 cm along the descent, 0.57 mm lower, so A's upper face separates by less than B's lower
  // face, by less than the face preference, and A's face is the reference: the clip keeps A's 4
  // upper corners at their heights under B's face along +z. At c that height is h / (n_B . z) > h:
  // the clip misses the distance h (by h (1 / cos theta - 1) = 2e-7 m), and the closest pair,
  // corner 7 of A against B's face 4 (the clipped corner's own ids), replaces it: gap h, normal
  // z_B (A to B), point c + h z_B / 2. The other 3 corners keep their clipped contacts, x on A's
  // upper face under B's plane z_B . x = z_B . c + h: gap (h + z_B . (c - x)) / (z_B . z), normal
  // +z. (docs/conventions.md, "Manifolds", face contact.)
  const Vec3 ha(0.5, 0.5, 0.5), hb(0.6, 0.6, 0.2);
  const double theta = 0.02, h = 1e-3;
  const Mat3 R = Eigen::AngleAxisd(-theta, Vec3(1, -1, 0).normalized()).toRotationMatrix();
  const Vec3 z_b = R.col(2), c(0.5, 0.5, 0.5);
  const Pose pa{Vec3::Zero(), Mat3::Identity()};
  const Pose pb{c + (h + hb.z()) * z_b - (hb.x() - 0.02) * R.col(0) - (hb.y() - 0.02) * R.col(1), R};
  const auto out = collide(Box(ha), pa, Box(hb), pb, 0.05);
  ASSERT_EQ(out.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    const Contact& x = out[k];
    EXPECT_EQ(x.feature_a, feature_id(FeatureKind::Vertex, 4 + k));  // A's upper corners 4..7 in id order
    EXPECT_EQ(x.feature_b, feature_id(FeatureKind::Face, 4));
    const Vec3 corner((k & 1) ? 0.5 : -0.5, (k & 2) ? 0.5 : -0.5, 0.5);
    if (k == 3) {
      EXPECT_NEAR(x.gap, h, 1e-15);
      EXPECT_LT((x.normal - z_b).norm(), 1e-12);
      EXPECT_LT((x.point - (c + 0.5 * h * z_b)).norm(), 1e-15);
    } else {
      const double gap = (h + z_b.dot(c - corner)) / z_b.z();
      EXPECT_NEAR(x.gap, gap, 1e-12) << k;  // clipped: interpolated along B's face edges
      EXPECT_LT((x.normal - Vec3::UnitZ()).norm(), 1e-15) << k;
      EXPECT_LT((x.point - (corner + 0.5 * gap * Vec3::UnitZ())).norm(), 1e-12) << k;
    }
  }
  // the other way round B's face is the reference (it separates more) and its clip reaches c
  const auto back = collide(Box(hb), pb, Box(ha), pa, 0.05);
  ASSERT_EQ(back.size(), 4u);
  double least = 1.0;
  for (const Contact& x : back) least = std::min(least, x.gap);
  EXPECT_NEAR(least, h, 1e-15);
}

// slots golden: trimesh-polytope
TEST(Manifold, BoxBesideALoneTrianglesVertexGetsTheClosestPair) {
  // The triangle (0, 0, 0), (1, 0, 0), (0, 1, 0) (n_t = +z, all edges active) and an axis-aligned
  // box of half extents 0.1 wholly in front of it, beside its vertex 0: the triangle's face clip
  // keeps nothing (the box lies beside the triangle), and the contact is the closest pair,
  // vertex 0 against the box's corner 3 (+x +y -z) at (-ex, -ey, ez), or against its edge 4
  // (corner 1 -> 3, along y) when ey < 0 puts vertex 0 beside that edge: gap |w|, w the
  // box's point minus the vertex, normal w / |w|, point w / 2.
  Points v(3, 3);
  v << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  Triangles f(1, 3);
  f << 0, 1, 2;
  const TriangleMesh tri(v, f);
  const Box box(Vec3(0.1, 0.1, 0.1));
  struct Case {
    double ey;
    FeatureId feature_b;
  };
  for (const Case& k : {Case{0.002, feature_id(FeatureKind::Vertex, 3)}, Case{-0.05, feature_id(FeatureKind::Edge, 4)}}) {
    const double ex = 0.002, ez = 0.003;
    const Pose pb{Vec3(-ex - 0.1, -k.ey - 0.1, ez + 0.1), Mat3::Identity()};
    const Vec3 w(-ex, std::min(-k.ey, 0.0), ez);
    const auto out = collide(tri, {}, box, pb, 0.01);
    ASSERT_EQ(out.size(), 1u) << "ey " << k.ey;
    EXPECT_NEAR(out[0].gap, w.norm(), 1e-15);
    EXPECT_LT((out[0].normal - w.normalized()).norm(), 1e-12);
    EXPECT_LT((out[0].point - 0.5 * w).norm(), 1e-15);
    EXPECT_EQ(out[0].feature_a, feature_id(FeatureKind::Vertex, 0, 0));
    EXPECT_EQ(out[0].feature_b, k.feature_b);
    EXPECT_TRUE(collide(tri, {}, box, pb, 0.5 * (ez + w.norm())).empty());  // its face plane is nearer
  }
}

// slots golden: trimesh-polytope
TEST(Manifold, BoxCornerBesideAFloorDiagonalGetsNoGhostOfTheClosestPair) {
  // A box (half extents 0.1, 0.15, 0.2) turned corner down (its diagonal along z), the lowest corner
  // 2 mm over the two-triangle floor_mesh(2, 1) just beside its diagonal (inactive: flat; the rims
  // are active). The triangle not under the corner has its closest pair on the diagonal, tilted: a
  // ghost, replaced by that face's own clip (here nothing nearer than the threshold). One contact:
  // gap 2 mm, normal +z, the corner over its triangle. (Without the ghost pass the pair stays: 2
  // contacts, one tilted.)
  const TriangleMesh floor = floor_mesh(2.0, 1);
  const Vec3 hb(0.1, 0.15, 0.2);
  const Mat3 R = Eigen::Quaterniond::FromTwoVectors(Vec3(-1, -1, -1), Vec3(0, 0, -1)).toRotationMatrix();
  for (const Vec3& low : {Vec3(0.003, 0.001, 0.002), Vec3(-0.002, 0.004, 0.002)}) {
    const Pose pb{low + R * hb, R};  // corner 0 (- - -) at `low`
    const auto out = collide(floor, {}, Box(hb), pb, 0.01);
    ASSERT_EQ(out.size(), 1u) << low.transpose();
    EXPECT_NEAR(out[0].gap, 0.002, 1e-15);
    EXPECT_LT((out[0].normal - Vec3::UnitZ()).norm(), 1e-15);
    EXPECT_LT((out[0].point - (low - Vec3(0, 0, 0.001))).norm(), 1e-15);
    EXPECT_EQ(feature_kind(out[0].feature_a), FeatureKind::Face);
    EXPECT_EQ(out[0].feature_b, feature_id(FeatureKind::Vertex, 0));
  }
}

// slots golden: capsule-polytope (a box)
// slots golden: plane-capsule (gap only)
TEST(Manifold, CapsuleLyingOnABoxOrAPlaneHasTwoPoints) {
  const Capsule capsule(0.1, 0.4);
  const Mat3 lying = Eigen::AngleAxisd(kPi / 2, Vec3::UnitY()).toRotationMatrix();  // axis along x
  const auto on_box = collide(Box(Vec3(1, 1, 0.5)), {Vec3(0, 0, -0.5), Mat3::Identity()}, capsule,
                              {Vec3(0.2, 0.3, 0.1), lying});
  ASSERT_EQ(on_box.size(), 2u);
  for (const Contact& c : on_box) {
    EXPECT_LT(std::abs(c.gap), 1e-12);
    EXPECT_LT((c.normal - Vec3::UnitZ()).norm(), 1e-12);
    EXPECT_NEAR(std::abs(c.point.x() - 0.2), 0.4, 1e-12);
  }
  // hanging over the box's edge: the segment is clipped to the face
  const auto over_edge = collide(Box(Vec3(1, 1, 0.5)), {Vec3(0, 0, -0.5), Mat3::Identity()}, capsule,
                                 {Vec3(0.9, 0.0, 0.1), lying});
  ASSERT_EQ(over_edge.size(), 2u);
  EXPECT_NEAR(std::max(over_edge[0].point.x(), over_edge[1].point.x()), 1.0, 1e-12);
  const auto on_plane = collide(Plane(Vec3::UnitZ(), 0.0), {}, capsule, {Vec3(0, 0, 0.1), lying});
  ASSERT_EQ(on_plane.size(), 2u);
  for (const Contact& c : on_plane) EXPECT_LT(std::abs(c.gap), 1e-12);
}

// slots golden: cylinder-polytope (on a box: gap, normal)
// slots golden: plane-cylinder (standing, lying)
TEST(Manifold, CylinderStandingHasRimPointsAndLyingHasTwo) {
  const Cylinder cylinder(0.3, 0.5);
  const auto standing = collide(Plane(Vec3::UnitZ(), 0.0), {}, cylinder, {Vec3(0, 0, 0.5), Mat3::Identity()});
  ASSERT_GE(standing.size(), 3u);
  for (const Contact& c : standing) {
    EXPECT_LT(std::abs(c.gap), 1e-12);
    EXPECT_NEAR(std::hypot(c.point.x(), c.point.y()), 0.3, 1e-12);
  }
  const Mat3 lying = Eigen::AngleAxisd(kPi / 2, Vec3::UnitX()).toRotationMatrix();
  const auto on_side = collide(Plane(Vec3::UnitZ(), 0.0), {}, cylinder, {Vec3(0, 0, 0.3), lying});
  ASSERT_EQ(on_side.size(), 2u);
  for (const Contact& c : on_side) EXPECT_LT(std::abs(c.gap), 1e-12);
  EXPECT_NEAR(std::abs(on_side[0].point.y() - on_side[1].point.y()), 1.0, 1e-12);
  // standing on a box: FCL's normal, then the cap clipped against the box face
  const auto on_box = collide(Box(Vec3(1, 1, 0.5)), {Vec3(0, 0, -0.5), Mat3::Identity()}, cylinder,
                              {Vec3(0, 0, 0.5 - 1e-4), Mat3::Identity()}, 1e-3);
  ASSERT_GE(on_box.size(), 3u);
  for (const Contact& c : on_box) {
    EXPECT_NEAR(c.gap, -1e-4, 1e-9);
    EXPECT_LT((c.normal - Vec3::UnitZ()).norm(), 1e-9);
  }
}

// slots golden: sphere-sphere (gap; no point, no normal)
// slots golden: sphere-capsule (side: gap and feature)
TEST(Manifold, SpherePairsHaveOnePointAndSwappingFlipsTheNormal) {
  const Sphere s(0.5);
  const Pose pa{Vec3::Zero(), Mat3::Identity()}, pb{Vec3(0.9, 0.1, 0), Mat3::Identity()};
  const auto ab = collide(s, pa, s, pb, 0.0);
  const auto ba = collide(s, pb, s, pa, 0.0);
  ASSERT_EQ(ab.size(), 1u);
  ASSERT_EQ(ba.size(), 1u);
  EXPECT_NEAR(ab[0].gap, std::sqrt(0.82) - 1.0, 1e-15);
  EXPECT_LT((ab[0].normal + ba[0].normal).norm(), 1e-15);
  EXPECT_LT((ab[0].point - ba[0].point).norm(), 1e-15);
  // sphere against each primitive, both orders
  const Mat3 R = math::quat_to_matrix(Quat4(0.9, 0.1, 0.3, -0.2).normalized());
  const std::vector<Shape> others = {Box(Vec3(0.5, 0.3, 0.2)), Capsule(0.2, 0.3), Cylinder(0.3, 0.2)};
  for (const Shape& other : others) {
    const Pose po{Vec3(0.1, 0.2, -0.3), R};
    const Pose ps{Vec3(0.3, 0.4, 0.5), Mat3::Identity()};
    const auto x = collide(other, po, Sphere(0.4), ps, 1.0);
    const auto y = collide(Sphere(0.4), ps, other, po, 1.0);
    ASSERT_EQ(x.size(), 1u) << shape_name(other);
    ASSERT_EQ(y.size(), 1u);
    EXPECT_EQ(x[0].gap, y[0].gap);
    EXPECT_LT((x[0].normal + y[0].normal).norm(), 1e-15);
    EXPECT_LT((x[0].point - y[0].point).norm(), 1e-15);
    EXPECT_NEAR(x[0].normal.norm(), 1.0, 1e-15);
  }
  // a sphere on a capsule's side: gap along the perpendicular
  const auto side = collide(Capsule(0.2, 0.5), {}, Sphere(0.1), {Vec3(0.35, 0, 0.2), Mat3::Identity()}, 1.0);
  ASSERT_EQ(side.size(), 1u);
  EXPECT_NEAR(side[0].gap, 0.05, 1e-15);
  EXPECT_EQ(side[0].feature_a, feature_id(FeatureKind::Edge, 0));
}

// slots golden: capsule-capsule (gap, normal)
TEST(Manifold, ParallelCapsulesTouchAlongTwoPointsCrossedOnOne) {
  const Capsule c(0.1, 0.5);
  const Mat3 along_x = Eigen::AngleAxisd(kPi / 2, Vec3::UnitY()).toRotationMatrix();
  const auto parallel = collide(c, {Vec3::Zero(), along_x}, c, {Vec3(0.3, 0, 0.19), along_x}, 0.0);
  ASSERT_EQ(parallel.size(), 2u);
  for (const Contact& k : parallel) {
    EXPECT_NEAR(k.gap, -0.01, 1e-15);
    EXPECT_LT((k.normal - Vec3::UnitZ()).norm(), 1e-15);
  }
  const Mat3 along_y = Eigen::AngleAxisd(kPi / 2, Vec3::UnitX()).toRotationMatrix();
  const auto crossed = collide(c, {Vec3::Zero(), along_x}, c, {Vec3(0, 0, 0.19), along_y}, 0.0);
  ASSERT_EQ(crossed.size(), 1u);
  EXPECT_NEAR(crossed[0].gap, -0.01, 1e-15);
}

// slots golden: trimesh-polytope
TEST(Manifold, BoxOnATriangleMeshFloorKeepsItsFourCornersWithStableIds) {
  const TriangleMesh floor = floor_mesh(2.0, 4);
  const Box box(Vec3(0.5, 0.4, 0.3));
  std::vector<Contact> first;
  for (int step = 0; step < 5; ++step) {
    // the box slides over interior edges of the floor; always the same 4 corners, no ghost normals
    const Pose pb{Vec3(0.13 + 0.01 * step, -0.07, 0.3), rot_z(0.2)};
    const auto out = collide(floor, {}, box, pb, 1e-3);
    ASSERT_EQ(out.size(), 4u) << "step " << step;
    for (const Contact& c : out) {
      EXPECT_LT(std::abs(c.gap), 1e-9);
      EXPECT_LT((c.normal - Vec3::UnitZ()).norm(), 1e-12);
      EXPECT_EQ(feature_kind(c.feature_b), FeatureKind::Vertex);
      EXPECT_LT(feature_index(c.feature_b), 4u);
    }
    if (step == 0) first = out;
    for (int k = 0; k < 4; ++k) EXPECT_EQ(out[k].feature_b, first[k].feature_b);
  }
}

// slots golden: trimesh-cylinder (gap, normal)
TEST(Manifold, CylinderStandingOnATriangleMeshFloorHasRimPoints) {
  const TriangleMesh floor = floor_mesh(2.0, 4);
  const auto out = collide(floor, {}, Cylinder(0.3, 0.2), {Vec3(0.1, 0.2, 0.2 - 1e-4), Mat3::Identity()}, 1e-3);
  ASSERT_GE(out.size(), 3u);
  for (const Contact& c : out) {
    EXPECT_NEAR(c.gap, -1e-4, 1e-9);
    EXPECT_LT((c.normal - Vec3::UnitZ()).norm(), 1e-9);
  }
}

// slots golden: trimesh-sphere
TEST(Manifold, SphereRollingOverATriangleMeshFloorSeesOnlyTheFaceNormal) {
  const TriangleMesh floor = floor_mesh(2.0, 4);
  for (double x : {0.0, 0.5, 1.0, 0.25}) {  // on vertices, on interior edges, inside faces
    const auto out = collide(floor, {}, Sphere(0.2), {Vec3(x, x, 0.19), Mat3::Identity()}, 0.0);
    ASSERT_GE(out.size(), 1u);
    for (const Contact& c : out) {
      EXPECT_LT((c.normal - Vec3::UnitZ()).norm(), 1e-12) << "x = " << x;
      EXPECT_NEAR(c.gap, -0.01, 1e-12);
    }
  }
}

TEST(NarrowPhase, UnsupportedPairsAreNamedAndThrow) {
  // an L-shaped prism: a closed non-convex mesh
  Points v(12, 3);
  v << 0, 0, 0, 2, 0, 0, 2, 1, 0, 1, 1, 0, 1, 2, 0, 0, 2, 0,
       0, 0, 1, 2, 0, 1, 2, 1, 1, 1, 1, 1, 1, 2, 1, 0, 2, 1;
  Triangles f(20, 3);
  f << 0, 2, 1, 0, 3, 2, 0, 5, 3, 3, 5, 4,
       6, 7, 8, 6, 8, 9, 6, 9, 11, 9, 10, 11,
       0, 1, 7, 0, 7, 6, 1, 2, 8, 1, 8, 7, 2, 3, 9, 2, 9, 8,
       3, 4, 10, 3, 10, 9, 4, 5, 11, 4, 11, 10, 5, 0, 6, 5, 6, 11;
  const Mesh L(v, f);
  EXPECT_FALSE(L.is_convex());
  EXPECT_NE(collision::unsupported_pair(L, Sphere(1.0)).find("unsupported pair"), std::string::npos);
  EXPECT_TRUE(collision::unsupported_pair(L, Plane(Vec3::UnitZ(), 0.0)).empty());
  EXPECT_TRUE(collision::unsupported_pair(floor_mesh(1, 1), Cylinder(1, 1)).empty());
  std::vector<Contact> out;
  EXPECT_THROW(collision::collide(L, {}, Sphere(1.0), {}, 0.0, {}, out), std::invalid_argument);
}

// The box-box edge query tests 18 candidate edge pairs instead of all 144: it must give the same
// manifold, bit for bit, as the general polytope test, on random poses (separated, touching,
// overlapping) and on the degenerate ones of a stack (aligned, turned by right angles, tilted by a
// hair, edges crossing exactly).
TEST(Manifold, BoxPairsMatchTheGeneralPolytopeTestBitForBit) {
  std::mt19937_64 rng(20261123);
  std::uniform_real_distribution<double> size(0.05, 2.0), unit(0.0, 1.0);
  collision::Scratch scratch;
  int pairs = 0, touching = 0, edges = 0;
  for (int n = 0; n < 20000; ++n) {
    const Box a(Vec3(size(rng), size(rng), size(rng))), b(Vec3(size(rng), size(rng), size(rng)));
    Pose pa{scenes::random_vector(rng, 1.0), scenes::random_rotation(rng)};
    Pose pb;
    switch (n % 4) {
      case 0:  // anywhere near A
        pb = {pa.p + scenes::random_vector(rng, 2.0), scenes::random_rotation(rng)};
        break;
      case 1:  // stacked on A's top face, tilted by at most a hair
        pb = {pa.p + pa.R * Vec3(0.3 * (unit(rng) - 0.5), 0.3 * (unit(rng) - 0.5),
                                 a.half_extents.z() + b.half_extents.z() + 1e-3 * (unit(rng) - 0.5)),
              pa.R * scenes::small_rotation(rng, 1e-6 * (n % 3))};
        break;
      case 2: {  // turned by right angles about A's axes
        const Mat3 turn = rot_z(0.5 * kPi * (n % 3)) * Eigen::AngleAxisd(0.5 * kPi * (n % 2), Vec3::UnitX()).toRotationMatrix();
        pb = {pa.p + pa.R * scenes::random_vector(rng, 1.5), pa.R * turn};
        break;
      }
      default:  // crossed edges: B's edge above A's top edge, turned about the edge normal
        pb = {pa.p + pa.R * Vec3(0.0, a.half_extents.y() + 0.2 * (unit(rng) - 0.5),
                                 a.half_extents.z() + 0.5 * (unit(rng) - 0.2)),
              pa.R * rot_z(2.0 * kPi * unit(rng)) * Eigen::AngleAxisd(0.25 * kPi, Vec3::UnitX()).toRotationMatrix()};
    }
    for (const double threshold : {1e-6, 0.05}) {
      std::vector<Contact> fast, general;
      collision::polytope_polytope(*a.polytope, pa, 0, *b.polytope, pb, 0, threshold, *scratch.polytope, fast, true);
      collision::polytope_polytope(*a.polytope, pa, 0, *b.polytope, pb, 0, threshold, *scratch.polytope, general, false);
      ASSERT_TRUE(same(fast, general)) << "pair " << n << ", threshold " << threshold << ": " << fast.size()
                                       << " contacts from the box test, " << general.size() << " from the general one";
      ++pairs;
      touching += !general.empty();
      edges += general.size() == 1;
    }
  }
  // the sample must exercise every outcome: no contact, face manifolds and edge-edge points
  EXPECT_GT(touching, pairs / 4);
  EXPECT_GT(edges, 100);
  EXPECT_LT(touching, pairs);
}

// Given the pair's motion, polytope_polytope may leave out contacts the step cannot close
// (PairMotion::can_close) and stops its tests where none can be: what can_close keeps of its
// contacts must be exactly what it keeps of those made without the motion, bit for bit; and
// collide()'s manifold must be the same with the separating-face cache as without it. Hulls and
// boxes overlapping, touching and apart (to 1.5 m), falling together (the stack that lands),
// moving apart or towards each other, spinning, one of them static, at dt 1/60 and 1/240.
TEST(Manifold, APairsMotionLeavesOutTheContactsItCannotCloseAndChangesNoOther) {
  std::mt19937_64 rng(20261129);
  std::uniform_real_distribution<double> size(0.1, 1.0), unit(0.0, 1.0);
  collision::Scratch scratch;
  const Vec3 gravity(0.0, 0.0, -9.81);
  int dropped_all = 0, kept = 0, some = 0, left_out = 0, remembered = 0;
  for (int n = 0; n < 4000; ++n) {
    const bool boxes = n % 3 == 0;
    std::unique_ptr<Box> box_a, box_b;
    std::unique_ptr<ConvexHull> hull_a, hull_b;
    const Polytope* a;
    const Polytope* b;
    if (boxes) {
      box_a = std::make_unique<Box>(Vec3(size(rng), size(rng), size(rng)));
      box_b = std::make_unique<Box>(Vec3(size(rng), size(rng), size(rng)));
      a = box_a->polytope.get(), b = box_b->polytope.get();
    } else {
      hull_a = std::make_unique<ConvexHull>(scenes::random_hull(rng, 8 + n % 25, Vec3(size(rng), size(rng), size(rng))));
      hull_b = std::make_unique<ConvexHull>(scenes::random_hull(rng, 8 + n % 25, Vec3(size(rng), size(rng), size(rng))));
      a = hull_a->polytope.get(), b = hull_b->polytope.get();
    }
    const double rho_a = a->vertices.rowwise().norm().maxCoeff(), rho_b = b->vertices.rowwise().norm().maxCoeff();
    const Pose pa{scenes::random_vector(rng, n % 5 == 0 ? 300.0 : 1.0), scenes::random_rotation(rng)};
    const Vec3 direction = scenes::random_vector(rng, 1.0).normalized();
    const Pose pb{pa.p + (0.6 * (rho_a + rho_b) + 1.5 * unit(rng)) * direction, scenes::random_rotation(rng)};
    collision::PairMotion m;
    m.p_a = pa.p, m.p_b = pb.p;
    m.dt = n % 2 ? 1.0 / 60.0 : 1.0 / 240.0;
    m.margin = n % 4 ? 0.005 : 0.02;
    switch (n % 5) {
      case 0: m.v_a = m.v_b = scenes::random_vector(rng, 40.0); break;          // falling together
      case 1: m.v_a = scenes::random_vector(rng, 5.0), m.v_b = scenes::random_vector(rng, 5.0); break;
      case 2: m.v_b = -(3.0 + 20.0 * unit(rng)) * direction; break;           // B towards A
      case 3: m.v_a = scenes::random_vector(rng, 2.0), m.omega_a = scenes::random_vector(rng, 10.0);
              m.omega_b = scenes::random_vector(rng, 10.0); break;             // spinning
      default: break;                                                         // at rest
    }
    const bool a_static = n % 7 == 0;
    if (a_static) m.v_a = m.omega_a = Vec3::Zero();
    m.g_a = a_static ? Vec3::Zero() : gravity;
    m.g_b = gravity;
    m.g_rel = m.g_b - m.g_a;
    m.stoppable_a = !a_static;
    m.stoppable_b = true;
    m.turning = 0.5 * (m.omega_a.squaredNorm() * rho_a + m.omega_b.squaredNorm() * rho_b);
    // the world's threshold: margin and both bodies' reach (collide_pair)
    const auto reach = [&](const Vec3& v, const Vec3& omega, double rho, bool still) {
      return still ? 0.0 : m.dt * (v.norm() + m.dt * gravity.norm() + std::min(omega.norm() * rho, 2.0 * rho / m.dt));
    };
    const double threshold = m.margin + reach(m.v_a, m.omega_a, rho_a, a_static) + reach(m.v_b, m.omega_b, rho_b, false);
    std::vector<Contact> all, given, closable, got;
    collision::polytope_polytope(*a, pa, 0, *b, pb, 0, threshold, *scratch.polytope, all, boxes);
    for (const Contact& c : all)
      if (m.can_close(c)) closable.push_back(c);
    collision::polytope_polytope(*a, pa, 0, *b, pb, 0, threshold, *scratch.polytope, given, boxes, nullptr, &m);
    for (const Contact& c : given)
      if (m.can_close(c)) got.push_back(c);
    ASSERT_TRUE(same(closable, got)) << "pair " << n << ": " << all.size() << " contacts, " << closable.size()
                                     << " closable; given the motion " << given.size() << ", " << got.size();
    // through collide(), as a World calls it from step to step: the second time with B moved
    // towards A by up to 10 % of the way, and the faces the first found separating the pair
    // (tried first, at the threshold the motion narrows)
    const Shape shape_a = boxes ? Shape(*box_a) : Shape(*hull_a);
    const Shape shape_b = boxes ? Shape(*box_b) : Shape(*hull_b);
    const Pose pb_next{pa.p + (1.0 - 0.1 * unit(rng)) * (pb.p - pa.p), pb.R};
    collision::PairMotion m_next = m;
    m_next.p_b = pb_next.p;
    collision::PairContext plain;
    plain.motion = &m;
    std::vector<Contact> expected, expected_next, first_step, second_step;
    collision::collide(shape_a, pa, shape_b, pb, threshold, {nullptr, nullptr, &scratch}, expected, plain);
    plain.motion = &m_next;
    collision::collide(shape_a, pa, shape_b, pb_next, threshold, {nullptr, nullptr, &scratch}, expected_next, plain);
    std::vector<collision::SeparatingFace> none, found, again;
    collision::PairContext cached;
    cached.body_a = 0, cached.body_b = 1;
    cached.motion = &m;
    cached.separating_last = &none, cached.separating_next = &found;
    collision::collide(shape_a, pa, shape_b, pb, threshold, {nullptr, nullptr, &scratch}, first_step, cached);
    cached.motion = &m_next;
    cached.separating_last = &found, cached.separating_next = &again;
    collision::collide(shape_a, pa, shape_b, pb_next, threshold, {nullptr, nullptr, &scratch}, second_step, cached);
    ASSERT_TRUE(same(expected, first_step)) << "pair " << n;
    ASSERT_TRUE(same(expected_next, second_step)) << "pair " << n << ", separating faces remembered: " << found.size();
    remembered += !found.empty() && !again.empty();
    dropped_all += !all.empty() && closable.empty();
    kept += !closable.empty();
    some += !closable.empty() && closable.size() < all.size();
    left_out += given.size() < all.size();
  }
  // the sample must exercise every outcome: pairs whose contacts all go, pairs that keep all or
  // some, and pairs whose tests stopped early
  std::printf("%d pairs lose every contact, %d keep some (%d not all); %d gave fewer given the motion; %d apart along a "
              "remembered face\n", dropped_all, kept, some, left_out, remembered);
  EXPECT_GT(dropped_all, 300);
  EXPECT_GT(kept, 300);
  EXPECT_GT(some, 20);
  EXPECT_GT(left_out, 150);
  EXPECT_GT(remembered, 1000);
}

// The dispatch table over item kinds: every slot of the four kinds has a test that finds the contact
// of two items overlapping by 1 cm along x (normal from A to B, gap -1 cm), and an item whose kind
// nobody set is refused by name instead of giving no contacts.
TEST(NarrowPhase, EveryItemKindPairHasATestAndAnUnsetKindThrows) {
  const Sphere sphere(0.5);
  const Capsule capsule(0.5, 0.3);    // radius, half length along z
  const Cylinder cylinder(0.5, 0.3);  // radius, half height along z
  const Box box(Vec3(0.5, 0.5, 0.5));
  auto item = [&](collision::ItemKind kind, const Vec3& p) {
    collision::Item it;
    it.kind = kind;
    it.pose = {p, Mat3::Identity()};
    switch (kind) {
      case collision::ItemKind::Sphere: it.sphere = &sphere; break;
      case collision::ItemKind::Capsule: it.capsule = &capsule; break;
      case collision::ItemKind::Cylinder: it.cylinder = &cylinder; break;
      default: it.box = &box, it.polytope = box.polytope.get();
    }
    return it;
  };
  using K = collision::ItemKind;
  collision::Scratch scratch;
  for (K ka : {K::Sphere, K::Capsule, K::Cylinder, K::Polytope})
    for (K kb : {K::Sphere, K::Capsule, K::Cylinder, K::Polytope}) {
      // every kind reaches 0.5 m from its centre along x
      const collision::Item a = item(ka, Vec3::Zero()), b = item(kb, Vec3(0.99, 0.0, 0.0));
      std::vector<Contact> out;
      ASSERT_NO_THROW(collision::contact_items(a, b, 1e-6, scratch, out))
          << collision::item_kind_name(ka) << " - " << collision::item_kind_name(kb);
      ASSERT_FALSE(out.empty()) << collision::item_kind_name(ka) << " - " << collision::item_kind_name(kb);
      for (const Contact& c : out) {
        EXPECT_NEAR(c.gap, -0.01, 1e-9) << collision::item_kind_name(ka) << " - " << collision::item_kind_name(kb);
        EXPECT_NEAR(c.normal.x(), 1.0, 1e-9) << collision::item_kind_name(ka) << " - " << collision::item_kind_name(kb);
      }
    }
  collision::Item unset;
  unset.sphere = &sphere;  // geometry without a kind: a bug in whoever built the item
  std::vector<Contact> out;
  try {
    collision::contact_items(item(K::Polytope, Vec3::Zero()), unset, 1e-6, scratch, out);
    FAIL() << "an unset item kind gave " << out.size() << " contacts instead of an error";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("unsupported item pair Polytope - unknown item kind"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(out.empty());
}
