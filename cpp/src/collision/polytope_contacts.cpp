// Convex polytope pairs (boxes, hulls, convex mesh pieces) by separating axes and reference/incident
// face clipping (docs/conventions.md, "Manifolds"). Written here because FCL 0.7 returns one contact
// per pair and its EPA depths carry ~1e-5 m of error (DESIGN.md, measured); the separating-axis
// depth of two polytopes is exact and the clipped face gives the 4-point manifold a box needs to lie
// still. Edge pairs are pruned on the Gauss map (only those that form a face of the Minkowski
// difference can realise the separation).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "collision/collision.hpp"

namespace signorini::collision {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// How much better (times the pair's length scale L) B's face or an edge pair must separate than
/// A's face to be chosen (docs/conventions.md, "Manifolds").
constexpr double kFacePreference = 5e-4;
/// An edge axis within 0.05 rad of the face normal is "nearly parallel": only then does the face
/// preference apply to it; crossing points of such edges keep their exact edge-edge distance.
const double kNearlyParallel = std::cos(0.05);

/// A polytope's vertices, face normals and offsets expressed in one common frame (A's).
struct View {
  const Polytope* topo = nullptr;
  std::vector<Vec3> v, n;
  std::vector<double> d;
  Vec3 centroid;
  std::uint32_t part = 0;

  void place(const Polytope& P, const Mat3& R, const Vec3& t, std::uint32_t part_index) {
    topo = &P;
    part = part_index;
    const Eigen::Index nv = P.vertices.rows();
    v.resize(nv);
    for (Eigen::Index i = 0; i < nv; ++i) v[i] = R * P.vertex(static_cast<int>(i)) + t;
    const std::size_t nf = P.normals.size();
    n.resize(nf);
    d.resize(nf);
    for (std::size_t f = 0; f < nf; ++f) {
      n[f] = R * P.normals[f];
      d[f] = P.offsets[f] + n[f].dot(t);
    }
    centroid = R * P.centroid + t;
  }
  /// min over vertices of n . v
  double min_along(const Vec3& dir) const {
    double m = kInf;
    for (const Vec3& x : v) m = std::min(m, dir.dot(x));
    return m;
  }
  FeatureId id(FeatureKind kind, int index) const { return feature_id(kind, static_cast<std::uint32_t>(index), part); }
};

struct FaceQuery {
  double separation = -kInf;
  int face = -1;
};

/// Largest separation of `other`'s vertices from the face planes of `self` (first on ties).
FaceQuery face_query(const View& self, const View& other) {
  FaceQuery q;
  for (std::size_t f = 0; f < self.n.size(); ++f) {
    const double s = other.min_along(self.n[f]) - self.d[f];
    if (s > q.separation) {
      q.separation = s;
      q.face = static_cast<int>(f);
    }
  }
  return q;
}

struct EdgeQuery {
  double separation = -kInf;
  int edge_a = -1, edge_b = -1;
  Vec3 axis = Vec3::Zero();  ///< unit, from A towards B
};

/// Do the Gauss-map arcs (a, b) of an edge of A and (c, d) of an edge of -B cross? Then the edge
/// pair spans a face of the Minkowski difference and its cross product is a candidate axis.
bool minkowski_face(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const Vec3 bxa = b.cross(a), dxc = d.cross(c);
  const double cba = c.dot(bxa), dba = d.dot(bxa), adc = a.dot(dxc), bdc = b.dot(dxc);
  return cba * dba < 0.0 && adc * bdc < 0.0 && cba * bdc > 0.0;
}

EdgeQuery edge_query(const View& A, const View& B) {
  EdgeQuery q;
  const auto& ea = A.topo->edges;
  const auto& eb = B.topo->edges;
  for (std::size_t i = 0; i < ea.size(); ++i) {
    const Vec3& pa = A.v[ea[i].v0];
    const Vec3 ua = A.v[ea[i].v1] - pa;
    const Vec3& na0 = A.n[ea[i].f0];
    const Vec3& na1 = A.n[ea[i].f1];
    for (std::size_t j = 0; j < eb.size(); ++j) {
      if (!minkowski_face(na0, na1, -B.n[eb[j].f0], -B.n[eb[j].f1])) continue;
      const Vec3& pb = B.v[eb[j].v0];
      const Vec3 ub = B.v[eb[j].v1] - pb;
      Vec3 L = ua.cross(ub);
      const double len = L.norm();
      if (!(len > 1e-9 * ua.norm() * ub.norm())) continue;  // parallel edges: a face axis covers them
      L /= len;
      if (L.dot(pa - A.centroid) < 0.0) L = -L;
      const double s = L.dot(pb - pa);
      if (s > q.separation) {
        q.separation = s;
        q.edge_a = static_cast<int>(i);
        q.edge_b = static_cast<int>(j);
        q.axis = L;
      }
    }
  }
  return q;
}

/// A vertex of the polygon being clipped: position, its ids on the reference and incident shapes,
/// and the label of the polygon side that leaves it (an incident edge, or a reference side plane).
struct ClipVertex {
  Vec3 q;
  FeatureId ref_id, inc_id;
  bool side_is_ref;
  int side;  ///< incident edge index, or reference loop side k
  bool keep = true;  ///< false when made on an inactive side of a triangle-mesh face
};

/// Parameters s, t of the closest points p0 + s u and q0 + t w of two non-parallel lines.
void closest_on_lines(const Vec3& p0, const Vec3& u, const Vec3& q0, const Vec3& w, double& s, double& t) {
  const Vec3 r = p0 - q0;
  const double uu = u.dot(u), ww = w.dot(w), uw = u.dot(w), ur = u.dot(r), wr = w.dot(r);
  const double det = uw * uw - uu * ww;  // non-zero: the lines are not parallel
  s = (ur * ww - uw * wr) / det;
  t = (uw * ur - uu * wr) / det;
}

/// The edge-edge contact of the query e (A's edge e.edge_a against B's e.edge_b along e.axis, in
/// A's frame): one point, midway between the closest points of the two edge lines.
void edge_contact(const View& A, const View& B, const EdgeQuery& e, const Pose& pa, std::vector<Contact>& out) {
  const auto& EA = A.topo->edges[e.edge_a];
  const auto& EB = B.topo->edges[e.edge_b];
  const Vec3 p0 = A.v[EA.v0], u = A.v[EA.v1] - p0;
  const Vec3 q0 = B.v[EB.v0], w = B.v[EB.v1] - q0;
  double s, t;
  closest_on_lines(p0, u, q0, w, s, t);
  // the points on the edges themselves: a speculative pair's lines can meet far beyond its edges
  // (s clamped, then t for it, then s for that t: the closest points of the two segments)
  s = std::clamp(s, 0.0, 1.0);
  t = std::clamp((p0 + s * u - q0).dot(w) / w.squaredNorm(), 0.0, 1.0);
  s = std::clamp((q0 + t * w - p0).dot(u) / u.squaredNorm(), 0.0, 1.0);
  Contact c;
  c.point = pa.R * (0.5 * ((p0 + s * u) + (q0 + t * w))) + pa.p;
  c.normal = pa.R * e.axis;
  c.gap = e.separation;
  c.feature_a = A.id(FeatureKind::Edge, e.edge_a);
  c.feature_b = B.id(FeatureKind::Edge, e.edge_b);
  out.push_back(c);
}

/// A clipped point where an incident edge crosses a side of the reference face: when the two edges
/// are nearly perpendicular to n_ref (their cross product within 0.05 rad of it) and their closest
/// points lie on both, the contact there is edge against edge, so its gap, point and normal become
/// the exact ones of the two edge lines (the plane distance differs from it to second order).
void edge_crossing(const View& ref, FeatureId ref_edge, const View& inc, FeatureId inc_edge, const Vec3& n_ref,
                   double& gap, Vec3& y, Vec3& n) {
  const auto& er = ref.topo->edges[feature_index(ref_edge)];
  const auto& ei = inc.topo->edges[feature_index(inc_edge)];
  const Vec3 p0 = ref.v[er.v0], u = ref.v[er.v1] - p0;
  const Vec3 q0 = inc.v[ei.v0], w = inc.v[ei.v1] - q0;
  Vec3 L = u.cross(w);
  const double len = L.norm();
  if (!(len > 1e-9 * u.norm() * w.norm())) return;
  L /= len;
  if (L.dot(n_ref) < 0.0) L = -L;
  if (L.dot(n_ref) < kNearlyParallel) return;
  double s, t;
  closest_on_lines(p0, u, q0, w, s, t);
  if (s < 0.0 || s > 1.0 || t < 0.0 || t > 1.0) return;
  const Vec3 x_ref = p0 + s * u, x_inc = q0 + t * w;
  gap = L.dot(x_inc - x_ref);
  y = 0.5 * (x_ref + x_inc);
  n = L;
}

/// Sutherland-Hodgman of the incident face's loop against the side planes of the reference face,
/// tracking feature ids; appends the clipped points below the threshold as contacts. The reference
/// face is `ref` face f; `ref_is_a` says whether the reference polytope is A.
void clip_faces(const View& ref, int f, const View& inc, bool ref_is_a, double threshold,
                const Mat3& R_a, const Vec3& p_a, std::vector<ClipVertex>& poly, std::vector<ClipVertex>& next,
                std::vector<Contact>& out, const std::array<bool, 3>* ref_active = nullptr) {
  const Vec3& n_ref = ref.n[f];
  // incident face: among the faces around the incident shape's deepest vertex along -n_ref, the
  // most anti-parallel (first on ties). For a box that is its most anti-parallel face; on a hull
  // with many faces the most anti-parallel one overall can lie far from the overlap.
  int deepest = 0;
  for (std::size_t i = 1; i < inc.v.size(); ++i)
    if (inc.v[i].dot(n_ref) < inc.v[deepest].dot(n_ref)) deepest = static_cast<int>(i);
  int g = -1;
  double least = kInf;
  for (std::size_t k = 0; k < inc.n.size(); ++k) {
    const auto& loop = inc.topo->faces[k];
    if (std::find(loop.begin(), loop.end(), deepest) == loop.end()) continue;
    const double c = inc.n[k].dot(n_ref);
    if (c < least) {
      least = c;
      g = static_cast<int>(k);
    }
  }
  const auto& inc_loop = inc.topo->faces[g];
  poly.clear();
  for (std::size_t k = 0; k < inc_loop.size(); ++k)
    poly.push_back({inc.v[inc_loop[k]], ref.id(FeatureKind::Face, f), inc.id(FeatureKind::Vertex, inc_loop[k]),
                    false, inc.topo->face_edges[g][k]});
  const auto& ref_loop = ref.topo->faces[f];
  const std::size_t m = ref_loop.size();
  for (std::size_t k = 0; k < m && !poly.empty(); ++k) {
    const Vec3& r0 = ref.v[ref_loop[k]];
    const Vec3& r1 = ref.v[ref_loop[(k + 1) % m]];
    const Vec3 side = (r1 - r0).cross(n_ref).normalized();
    const double c = side.dot(r0);
    next.clear();
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const ClipVertex& P = poly[i];
      const ClipVertex& Q = poly[(i + 1) % poly.size()];
      const double dP = side.dot(P.q) - c, dQ = side.dot(Q.q) - c;
      if (dP <= 0.0) next.push_back(P);
      if ((dP <= 0.0) != (dQ <= 0.0)) {
        ClipVertex X;
        X.q = P.q + (dP / (dP - dQ)) * (Q.q - P.q);
        if (P.side_is_ref) {
          // the cut along side k' meets side k at the reference face's shared corner
          const int kp = P.side;
          const int corner = (static_cast<std::size_t>(kp) + 1) % m == k ? ref_loop[k]
                             : (k + 1) % m == static_cast<std::size_t>(kp) ? ref_loop[(k + 1) % m] : -1;
          X.ref_id = corner >= 0 ? ref.id(FeatureKind::Vertex, corner) : ref.id(FeatureKind::Face, f);
          X.inc_id = inc.id(FeatureKind::Face, g);
          X.keep = !ref_active || ((*ref_active)[k] && (*ref_active)[kp]);
        } else {
          X.ref_id = ref.id(FeatureKind::Edge, ref.topo->face_edges[f][k]);
          X.inc_id = inc.id(FeatureKind::Edge, P.side);
          // a cut along an interior (inactive) edge of a triangle mesh lies inside the surface
          X.keep = !ref_active || (*ref_active)[k];
        }
        if (dP <= 0.0) {  // leaving: the next side runs along the cut
          X.side_is_ref = true;
          X.side = static_cast<int>(k);
        } else {  // entering: the next side continues along P -> Q
          X.side_is_ref = P.side_is_ref;
          X.side = P.side;
        }
        next.push_back(X);
      }
    }
    std::swap(poly, next);
  }
  for (const ClipVertex& V : poly) {
    if (!V.keep) continue;
    double gap = n_ref.dot(V.q) - ref.d[f];
    Vec3 y = V.q - 0.5 * gap * n_ref, n = n_ref;
    if (feature_kind(V.ref_id) == FeatureKind::Edge && feature_kind(V.inc_id) == FeatureKind::Edge)
      edge_crossing(ref, V.ref_id, inc, V.inc_id, n_ref, gap, y, n);
    if (!(gap < threshold)) continue;
    const Vec3 n_world = R_a * n;
    Contact c;
    c.point = R_a * y + p_a;
    c.normal = ref_is_a ? n_world : Vec3(-n_world);
    c.gap = gap;
    c.feature_a = ref_is_a ? V.ref_id : V.inc_id;
    c.feature_b = ref_is_a ? V.inc_id : V.ref_id;
    out.push_back(c);
  }
}

double radius_of(const Polytope& P) { return P.vertices.rowwise().norm().maxCoeff(); }

}  // namespace

/// The narrow phase's buffers for polytope pairs (a member of Scratch): both polytopes placed in
/// A's frame, and the incident polygon being clipped.
struct PolytopeScratch {
  View A, B;
  std::vector<ClipVertex> poly, next;
};

PolytopeScratch* new_polytope_scratch() { return new PolytopeScratch(); }
void ScratchDeleter::operator()(PolytopeScratch* p) const { delete p; }

void polytope_polytope(const Polytope& a, const Pose& pa, std::uint32_t part_a, const Polytope& b,
                       const Pose& pb, std::uint32_t part_b, double threshold, PolytopeScratch& scratch,
                       std::vector<Contact>& out) {
  // everything in A's frame: B placed by R_ab = R_a^T R_b, t_ab = R_a^T (p_b - p_a)
  View& A = scratch.A;
  View& B = scratch.B;
  A.place(a, Mat3::Identity(), Vec3::Zero(), part_a);
  B.place(b, pa.R.transpose() * pb.R, pa.R.transpose() * (pb.p - pa.p), part_b);
  const FaceQuery fa = face_query(A, B);
  if (!(fa.separation < threshold)) return;
  const FaceQuery fb = face_query(B, A);
  if (!(fb.separation < threshold)) return;
  const EdgeQuery e = edge_query(A, B);
  if (!(e.separation < threshold)) return;
  // faces are preferred: B's face only when better than A's by tol, an edge only when better than
  // both by tol (tol = 5e-4 L). Two stacked boxes tilted by a hair have an edge axis that beats the
  // face axis by ~0.2 L theta; taking it would leave one contact point and the stack would rock.
  const double L = radius_of(a) + radius_of(b);
  const Vec3& n_face = fb.separation > fa.separation ? B.n[fb.face] : A.n[fa.face];
  const double edge_tol = std::abs(e.axis.dot(n_face)) >= kNearlyParallel ? kFacePreference * L : 1e-9 * L;
  const double tol = kFacePreference * L;
  if (e.edge_a >= 0 && e.separation > std::max(fa.separation, fb.separation) + edge_tol) {
    edge_contact(A, B, e, pa, out);
    return;
  }
  const double face_tol = std::abs(A.n[fa.face].dot(B.n[fb.face])) >= kNearlyParallel ? tol : 1e-9 * L;
  if (fb.separation > fa.separation + face_tol)
    clip_faces(B, fb.face, A, false, threshold, pa.R, pa.p, scratch.poly, scratch.next, out);
  else
    clip_faces(A, fa.face, B, true, threshold, pa.R, pa.p, scratch.poly, scratch.next, out);
}

void triangle_polytope(const Polytope& tri, const std::array<bool, 3>& active, const Pose& pa,
                       std::uint32_t triangle, const Polytope& b, const Pose& pb, std::uint32_t part_b,
                       double threshold, PolytopeScratch& scratch, std::vector<Contact>& out) {
  View& A = scratch.A;
  View& B = scratch.B;
  A.place(tri, Mat3::Identity(), Vec3::Zero(), triangle);
  B.place(b, pa.R.transpose() * pb.R, pa.R.transpose() * (pb.p - pa.p), part_b);
  // one-sided: only the front face pushes, and a body whose centre is behind it is left alone
  if (A.n[0].dot(B.centroid) < A.d[0]) return;
  const double sep_a = B.min_along(A.n[0]) - A.d[0];
  if (!(sep_a < threshold)) return;
  const FaceQuery fb = face_query(B, A);
  if (!(fb.separation < threshold)) return;
  const double tol = kFacePreference * (radius_of(tri) + radius_of(b));
  const double support_tol = 1e-9 * (radius_of(tri) + radius_of(b));
  // edge axes from the active triangle edges only (interior edges of a flat region would give
  // ghost normals); a triangle has no Gauss-map arcs, so intervals are projected in full and the
  // pair kept only if both edges support their shapes along the axis
  EdgeQuery e;
  for (int k = 0; k < 3; ++k) {
    if (!active[k]) continue;
    const auto& ea = tri.edges[k];
    const Vec3 ua = A.v[ea.v1] - A.v[ea.v0];
    for (std::size_t j = 0; j < b.edges.size(); ++j) {
      const auto& eb = b.edges[j];
      const Vec3 ub = B.v[eb.v1] - B.v[eb.v0];
      Vec3 L = ua.cross(ub);
      const double len = L.norm();
      if (!(len > 1e-9 * ua.norm() * ub.norm())) continue;
      L /= len;
      double a_lo = kInf, a_hi = -kInf, b_lo = kInf, b_hi = -kInf;
      for (const Vec3& x : A.v) a_lo = std::min(a_lo, L.dot(x)), a_hi = std::max(a_hi, L.dot(x));
      for (const Vec3& x : B.v) b_lo = std::min(b_lo, L.dot(x)), b_hi = std::max(b_hi, L.dot(x));
      if (a_lo - b_hi > b_lo - a_hi) {
        L = -L;
        std::swap(a_lo, a_hi);
        a_lo = -a_lo, a_hi = -a_hi;
        std::swap(b_lo, b_hi);
        b_lo = -b_lo, b_hi = -b_hi;
      }
      const double s = b_lo - a_hi;
      if (!(s > e.separation)) continue;
      const bool a_supports = std::abs(L.dot(A.v[ea.v0]) - a_hi) <= support_tol && std::abs(L.dot(A.v[ea.v1]) - a_hi) <= support_tol;
      const bool b_supports = std::abs(L.dot(B.v[eb.v0]) - b_lo) <= support_tol && std::abs(L.dot(B.v[eb.v1]) - b_lo) <= support_tol;
      if (!(a_supports && b_supports)) continue;
      e.separation = s;
      e.edge_a = k;
      e.edge_b = static_cast<int>(j);
      e.axis = L;
    }
  }
  if (!(e.separation < threshold)) return;
  if (e.edge_a >= 0 && e.separation > std::max(sep_a, fb.separation) + tol) {
    edge_contact(A, B, e, pa, out);
    return;
  }
  if (fb.separation > sep_a + tol)
    clip_faces(B, fb.face, A, false, threshold, pa.R, pa.p, scratch.poly, scratch.next, out);
  else
    clip_faces(A, 0, B, true, threshold, pa.R, pa.p, scratch.poly, scratch.next, out, &active);
}

}  // namespace signorini::collision
