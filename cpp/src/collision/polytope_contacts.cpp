// Convex polytope pairs (boxes, hulls, convex mesh pieces) by separating axes and reference/incident
// face clipping (docs/conventions.md, "Manifolds"): the separating-axis depth is exact and the
// clipped face gives the 4-point manifold a box needs to lie still (why not FCL's: "Contacts").
// Edge pairs are pruned on the Gauss map (only those that form a face of the Minkowski difference
// can realise the separation).
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
  /// place() at the identity (the polytope in its own frame): the same numbers, copied
  void place_local(const Polytope& P, std::uint32_t part_index) {
    topo = &P;
    part = part_index;
    const Eigen::Index nv = P.vertices.rows();
    v.resize(nv);
    for (Eigen::Index i = 0; i < nv; ++i) v[i] = P.vertex(static_cast<int>(i));
    n.assign(P.normals.begin(), P.normals.end());
    d.assign(P.offsets.begin(), P.offsets.end());
    centroid = P.centroid;
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

/// Largest separation of `other`'s vertices from the face planes of `self` (first on ties), or the
/// first face whose separation reaches `enough` (the caller needs no more: the pair is apart).
/// A face is left as soon as one vertex lies at or below the best separation so far: it cannot be
/// chosen (y -> y - d is monotone in floating point, so min(n . x) - d, computed for the faces that
/// are not left, and the choice are the same numbers as over every vertex).
FaceQuery face_query(const View& self, const View& other, double enough = kInf) {
  FaceQuery q;
  for (std::size_t f = 0; f < self.n.size(); ++f) {
    const Vec3& n = self.n[f];
    const double d = self.d[f];
    double least = kInf;
    bool beaten = false;
    for (const Vec3& x : other.v) {
      const double y = n.dot(x);
      if (y - d <= q.separation) {
        beaten = true;
        break;
      }
      least = std::min(least, y);
    }
    if (beaten) continue;
    const double s = least - d;
    if (s > q.separation) {
      q.separation = s;
      q.face = static_cast<int>(f);
      if (s >= enough) return q;
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

/// The rest of edge_pair once the pair is known to span a face of the Minkowski difference: their
/// unit axis L (pointing away from A's centroid) and the separation L . (p_B - p_A) replace q's if
/// larger (so the first pair in (i, j) order wins ties).
void edge_pair_axis(const View& A, const View& B, int i, int j, EdgeQuery& q) {
  const auto& ea = A.topo->edges[i];
  const auto& eb = B.topo->edges[j];
  const Vec3& pa = A.v[ea.v0];
  const Vec3 ua = A.v[ea.v1] - pa;
  const Vec3& pb = B.v[eb.v0];
  const Vec3 ub = B.v[eb.v1] - pb;
  Vec3 L = ua.cross(ub);
  const double len = L.norm();
  if (!(len > 1e-9 * ua.norm() * ub.norm())) return;  // parallel edges: a face axis covers them
  L /= len;
  if (L.dot(pa - A.centroid) < 0.0) L = -L;
  const double s = L.dot(pb - pa);
  if (s > q.separation || (s == q.separation && (i < q.edge_a || (i == q.edge_a && j < q.edge_b)))) {
    q.separation = s;
    q.edge_a = i;
    q.edge_b = j;
    q.axis = L;
  }
}

/// Edge i of A against edge j of B: the Gauss-map test, then edge_pair_axis.
void edge_pair(const View& A, const View& B, int i, int j, EdgeQuery& q) {
  const auto& ea = A.topo->edges[i];
  const auto& eb = B.topo->edges[j];
  if (minkowski_face(A.n[ea.f0], A.n[ea.f1], -B.n[eb.f0], -B.n[eb.f1])) edge_pair_axis(A, B, i, j, q);
}

/// The largest of M . w over unit M in the cone spanned by unit a and b (a Gauss-map arc, less than
/// a half turn): |w| projected into the plane of a and b when that projection lies in the cone,
/// else the larger end.
double arc_max(const Vec3& a, const Vec3& b, const Vec3& w) {
  const double c = a.dot(b), aw = a.dot(w), bw = b.dot(w), det = 1.0 - c * c;
  if (!(det > 1e-12)) return w.norm();  // a and b (nearly) parallel: the plain bound
  const double alpha = (aw - c * bw) / det, beta = (bw - c * aw) / det;
  if (alpha >= 0.0 && beta >= 0.0) return std::sqrt(std::max(alpha * aw + beta * bw, 0.0));
  return std::max(aw, bw);
}

/// Buffers of edge_query (members of PolytopeScratch): the kept edges of A and B, A's Gauss-map
/// sides (kept E_A x F_B), B's arc circle normals (kept E_B) and sides (F_A x kept E_B).
struct EdgeBuffers {
  std::vector<int> edges_a, edges_b;
  std::vector<double> side_a, side_b;
  std::vector<Vec3> dxc;
};

/// The largest separation over the edge pairs of A and B that span a face of the Minkowski
/// difference (Gauss-map pruning), among the pairs that could reach `bound` (below it, an edge
/// axis can neither beat the faces nor reach the threshold: the caller says which).
/// Edges first: if edge i of A supports A along L with B at separation s, then
/// s <= L . (c_B - p_i) (c_B B's centroid), so an edge whose largest L . (c_B - p_i) over its
/// Gauss-map arc (arc_max) is below `bound` goes (likewise B's edges with c_A).
/// Then minkowski_face in two halves: the side of each A arc's great circle (b x a) that every -B
/// face normal lies on, once per (edge, face) (a B edge passes only when its two faces lie on
/// opposite sides, which most do not), as bit masks when B has at most 64 faces, else tabled; the
/// other half (A's normals against the -B arc's circle, d x c) only for the pairs left. The
/// products are minkowski_face's, so the same pairs are kept.
EdgeQuery edge_query(const View& A, const View& B, double bound, EdgeBuffers& scratch) {
  EdgeQuery q;
  const auto& ea = A.topo->edges;
  const auto& eb = B.topo->edges;
  const std::size_t fa = A.n.size(), fb = B.n.size();
  // edges that can reach the bound (slack: rounding of the bound's own arithmetic)
  const double slack = 1e-9 * ((A.centroid - B.centroid).norm() + 1.0);
  std::vector<int>& ka = scratch.edges_a;
  std::vector<int>& kb = scratch.edges_b;
  ka.clear();
  kb.clear();
  for (std::size_t i = 0; i < ea.size(); ++i)
    if (arc_max(A.n[ea[i].f0], A.n[ea[i].f1], B.centroid - A.v[ea[i].v0]) >= bound - slack) ka.push_back(static_cast<int>(i));
  for (std::size_t j = 0; j < eb.size(); ++j)
    if (arc_max(B.n[eb[j].f0], B.n[eb[j].f1], A.centroid - B.v[eb[j].v0]) >= bound - slack) kb.push_back(static_cast<int>(j));
  const std::size_t na = ka.size(), nb = kb.size();
  if (na == 0 || nb == 0) return q;
  // side_a[i * fb + f] = (-n_B f) . (b_i x a_i), a row per kept edge of A (walked along f below);
  // dxc[j] = d_j x c_j (over the kept edges)
  std::vector<double>& side_a = scratch.side_a;
  std::vector<Vec3>& dxc = scratch.dxc;
  side_a.resize(na * fb);
  for (std::size_t i = 0; i < na; ++i) {
    const auto& e = ea[ka[i]];
    const Vec3 bxa = A.n[e.f1].cross(A.n[e.f0]);
    double* row = &side_a[i * fb];
    for (std::size_t f = 0; f < fb; ++f) row[f] = (-B.n[f]).dot(bxa);
  }
  dxc.resize(nb);
  for (std::size_t j = 0; j < nb; ++j) dxc[j] = (-B.n[eb[kb[j]].f1]).cross(-B.n[eb[kb[j]].f0]);
  if (fb <= 64) {
    for (std::size_t i = 0; i < na; ++i) {
      std::uint64_t above = 0, below = 0;  // B faces with (-n_B) . (b x a) > 0, < 0
      const double* row = &side_a[i * fb];
      for (std::size_t f = 0; f < fb; ++f) {
        above |= std::uint64_t(row[f] > 0.0) << f;
        below |= std::uint64_t(row[f] < 0.0) << f;
      }
      const Vec3& a = A.n[ea[ka[i]].f0];
      const Vec3& b = A.n[ea[ka[i]].f1];
      for (std::size_t j = 0; j < nb; ++j) {
        const auto& e = eb[kb[j]];
        const std::uint64_t m0 = std::uint64_t(1) << e.f0, m1 = std::uint64_t(1) << e.f1;
        // cba * dba < 0: c and d strictly on opposite sides
        if (!(((above & m0) && (below & m1)) || ((below & m0) && (above & m1)))) continue;
        const double cba = row[e.f0];
        const double adc = a.dot(dxc[j]), bdc = b.dot(dxc[j]);
        if (adc * bdc < 0.0 && cba * bdc > 0.0) edge_pair_axis(A, B, ka[i], kb[j], q);
      }
    }
    return q;
  }
  // side_b[g * nb + j] = n_A g . (d_j x c_j)
  std::vector<double>& side_b = scratch.side_b;
  side_b.resize(fa * nb);
  for (std::size_t j = 0; j < nb; ++j)
    for (std::size_t g = 0; g < fa; ++g) side_b[g * nb + j] = A.n[g].dot(dxc[j]);
  for (std::size_t i = 0; i < na; ++i) {
    const auto& e = ea[ka[i]];
    const double* adc_row = &side_b[e.f0 * nb];  // a . (d x c) for every j
    const double* bdc_row = &side_b[e.f1 * nb];  // b . (d x c)
    const double* row = &side_a[i * fb];
    for (std::size_t j = 0; j < nb; ++j) {
      const double cba = row[eb[kb[j]].f0], dba = row[eb[kb[j]].f1];
      if (!(cba * dba < 0.0)) continue;
      const double adc = adc_row[j], bdc = bdc_row[j];
      if (adc * bdc < 0.0 && cba * bdc > 0.0) edge_pair_axis(A, B, ka[i], kb[j], q);
    }
  }
  return q;
}

/// A box's edges by direction: edge[k][c] is the edge along body axis k whose vertex with the
/// k-bit cleared has the index c (vertex numbering of docs/polytope_numbering.md: bit m of a
/// vertex index is the sign of its m-th coordinate).
struct BoxEdges {
  int edge[3][8];
  explicit BoxEdges(const Polytope& box) {
    for (std::size_t e = 0; e < box.edges.size(); ++e) {
      const int v0 = box.edges[e].v0, v1 = box.edges[e].v1, bit = v0 ^ v1;
      const int k = bit == 1 ? 0 : bit == 2 ? 1 : 2;
      edge[k][v0 & ~bit] = static_cast<int>(e);
    }
  }
  /// The edge along axis k that supports the box in direction w (body frame): its other two
  /// coordinates have the signs of w's (ties, w_m = 0, are broken to the negative side; such a
  /// direction lies on the boundary of the edge's normal cone, where no edge pair spans a face of
  /// the Minkowski difference, so the choice does not matter).
  int support(int k, const Vec3& w) const {
    int c = 0;
    for (int m = 0; m < 3; ++m)
      if (m != k && w[m] > 0.0) c |= 1 << m;
    return edge[k][c];
  }
};

/// edge_query for two boxes, with the same result (the general test costs most of a box stack's
/// contact detection): for edge directions k of A and m of B only the edges supporting A along +-L
/// and B along -+L (L = e_k x R_ab e_m) can span a face of the Minkowski difference, so 2 of the 16
/// parallel pairs are tested (18 pairs instead of 144). A direction whose separation
/// |L . t_ab| - r_A(L) - r_B(L) (unit L) lies below `bound` by more than rounding is skipped.
EdgeQuery box_edge_query(const View& A, const View& B, const Mat3& R_ab, const Vec3& t_ab, double bound) {
  const BoxEdges ea(*A.topo), eb(*B.topo);
  const Vec3 h_a = A.topo->vertex(7), h_b = B.topo->vertex(7);  // vertex 7 = (+h_x, +h_y, +h_z)
  // rounding of the formula against edge_pair's separation: a few ulps of the lengths involved
  const double slack = 1e-12 * (t_ab.norm() + h_a.norm() + h_b.norm());
  EdgeQuery q;
  for (int k = 0; k < 3; ++k)
    for (int m = 0; m < 3; ++m) {
      Vec3 L = Vec3::Unit(k).cross(R_ab.col(m));
      const Vec3 L_b = R_ab.transpose() * L;  // L in B's body frame
      const double len = L.norm();
      if (len > 1e-6) {
        const double separation = (std::abs(L.dot(t_ab)) - h_a.dot(L.cwiseAbs()) - h_b.dot(L_b.cwiseAbs())) / len;
        if (separation + slack < bound) continue;
      }
      for (const double sign : {1.0, -1.0})
        edge_pair(A, B, ea.support(k, sign * L), eb.support(m, -sign * L_b), q);
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

/// The pair of points that realises the distance of two disjoint convex polytopes, with the
/// features they lie on (closest_features).
struct ClosestPair {
  Vec3 p = Vec3::Zero(), q = Vec3::Zero();  ///< on A and on B (the views' common frame, m)
  double distance = kInf;                   ///< |q - p| (m)
  int dim = 0;                              ///< the features' dimensions summed (vertex 0, edge 1, face 2)
  FeatureId fa = 0, fb = 0;
};

/// Buffers of closest_features (members of PolytopeScratch): which vertices of A and B lie in the
/// slab where the closest pair can be (1) or not (0).
struct ClosestBuffers {
  std::vector<char> near_a, near_b;
};

/// x's closest point on the segment q0 -> q1 (edge `edge` of `S`, vertices v0 -> v1): the end vertex
/// itself (bit for bit, whichever edge it is reached through) when the parameter is clamped to 0 or
/// 1, else the edge's point. Writes the point, its feature and its dimension (0 or 1).
void closest_on_edge(const View& S, int edge, const Vec3& x, Vec3& point, FeatureId& id, int& dim) {
  const auto& E = S.topo->edges[edge];
  const Vec3& q0 = S.v[E.v0];
  const Vec3 w = S.v[E.v1] - q0;
  const double t = (x - q0).dot(w) / w.dot(w);
  if (!(t > 0.0)) {
    point = q0, id = S.id(FeatureKind::Vertex, E.v0), dim = 0;
  } else if (!(t < 1.0)) {
    point = S.v[E.v1], id = S.id(FeatureKind::Vertex, E.v1), dim = 0;
  } else {
    point = q0 + t * w, id = S.id(FeatureKind::Edge, edge), dim = 1;
  }
}

/// Does x's foot on face f of `S` (x - h n_f, h = n_f . x - d_f) lie strictly inside the face?
/// Side k (loop[k] -> loop[k + 1]) has outward normal (loop[k + 1] - loop[k]) x n_f.
bool foot_inside(const View& S, int f, const Vec3& foot) {
  const auto& loop = S.topo->faces[f];
  const std::size_t m = loop.size();
  for (std::size_t k = 0; k < m; ++k) {
    const Vec3& r0 = S.v[loop[k]];
    if (!((S.v[loop[(k + 1) % m]] - r0).cross(S.n[f]).dot(foot - r0) < 0.0)) return false;
  }
  return true;
}

/// The closest points p on A and q on B of two disjoint convex polytopes (placed in one frame, m)
/// and the features holding them. Inputs: the views, a unit axis L (A -> B; the search is exact
/// for any, and one that separates them narrows it: a_hi = max over A of L . x, b_lo = min over B),
/// an upper bound `bound` of their distance (m), a tie tolerance (m); buffers for the vertex flags.
/// Output: best (p, q, |q - p|, the features' ids and summed dimension). Returns false when no
/// pair was found (a polytope without vertices or edges).
///
/// The closest pair of disjoint convex polytopes lies on a vertex-vertex, vertex-edge, edge-edge,
/// vertex-face or face-vertex pair of features, so the least distance over these candidates, in
/// this order, is exact:
///   1. each vertex of A against each edge of B (closest_on_edge: an end vertex when clamped);
///   2. each edge of A against each vertex of B (likewise);
///   3. each edge of A against each non-parallel edge of B whose lines' closest points lie strictly
///      inside both segments;
///   4. each vertex of A in front of a face of B (h = n_f . x - d_f > 0) whose foot x - h n_f lies
///      strictly inside it (foot_inside);
///   5. each face of A against each vertex of B (likewise);
/// each in (feature of A, feature of B) index order. With D the least distance, the pair chosen is,
/// among those within D + tie, the one of the lowest summed dimension (vertex 0, edge 1, face 2),
/// first in that order (as the oracle's closest_features: a vertex reached through any of its edges
/// is the same vertex). Only features with a vertex in the slab b_lo - bound - 2 tie <= L . x (A),
/// L . x <= a_hi + bound + 2 tie (B) are visited: a pair (p, q) with |q - p| <= bound + tie has
/// L . p >= L . q - |q - p| >= b_lo - bound - tie, so the result is the full search's. A box pair
/// visits at most 8 x 12 + 12 x 8 + 144 + 48 + 48 pairs. Not gjk_epa, whose witnesses carry no
/// feature ids (docs/conventions.md, "Manifolds", edge contact).
bool closest_features(const View& A, const View& B, const Vec3& L, double bound, double tie,
                      ClosestBuffers& buffers, ClosestPair& best) {
  const auto& ea = A.topo->edges;
  const auto& eb = B.topo->edges;
  const std::size_t na = A.v.size(), nb = B.v.size();
  // the slab: vertices that can hold a point of the chosen pair
  double a_hi = -kInf, b_lo = kInf;
  for (const Vec3& x : A.v) a_hi = std::max(a_hi, L.dot(x));
  for (const Vec3& x : B.v) b_lo = std::min(b_lo, L.dot(x));
  std::vector<char>& near_a = buffers.near_a;
  std::vector<char>& near_b = buffers.near_b;
  near_a.resize(na);
  near_b.resize(nb);
  for (std::size_t i = 0; i < na; ++i) near_a[i] = L.dot(A.v[i]) >= b_lo - bound - 2.0 * tie;
  for (std::size_t j = 0; j < nb; ++j) near_b[j] = L.dot(B.v[j]) <= a_hi + bound + 2.0 * tie;
  const auto edge_near = [](const std::vector<char>& near, const Polytope::Edge& e) { return near[e.v0] || near[e.v1]; };
  const auto face_near = [](const std::vector<char>& near, const std::vector<int>& loop) {
    for (int v : loop)
      if (near[v]) return true;
    return false;
  };
  // every candidate pair goes through `visit`; pass 0 finds D, pass 1 chooses among D + tie
  bool found = false;
  double least = kInf;
  const auto offer = [&](int pass, const Vec3& p, const Vec3& q, FeatureId fa, FeatureId fb, int dim) {
    const double d = (q - p).norm();
    if (pass == 0) {
      least = std::min(least, d);
    } else if (d <= least + tie && (!found || dim < best.dim)) {
      best.p = p, best.q = q, best.distance = d, best.dim = dim, best.fa = fa, best.fb = fb;
      found = true;
    }
  };
  for (int pass = 0; pass < 2; ++pass) {
    Vec3 x;
    FeatureId id;
    int dim;
    // 1. vertices of A against edges of B
    for (std::size_t i = 0; i < na; ++i) {
      if (!near_a[i]) continue;
      for (std::size_t j = 0; j < eb.size(); ++j) {
        if (!edge_near(near_b, eb[j])) continue;
        closest_on_edge(B, static_cast<int>(j), A.v[i], x, id, dim);
        offer(pass, A.v[i], x, A.id(FeatureKind::Vertex, static_cast<int>(i)), id, dim);
      }
    }
    // 2. edges of A against vertices of B
    for (std::size_t i = 0; i < ea.size(); ++i) {
      if (!edge_near(near_a, ea[i])) continue;
      for (std::size_t j = 0; j < nb; ++j) {
        if (!near_b[j]) continue;
        closest_on_edge(A, static_cast<int>(i), B.v[j], x, id, dim);
        offer(pass, x, B.v[j], id, B.id(FeatureKind::Vertex, static_cast<int>(j)), dim);
      }
    }
    // 3. edges against edges, closest points inside both
    for (std::size_t i = 0; i < ea.size(); ++i) {
      if (!edge_near(near_a, ea[i])) continue;
      const Vec3& p0 = A.v[ea[i].v0];
      const Vec3 u = A.v[ea[i].v1] - p0;
      for (std::size_t j = 0; j < eb.size(); ++j) {
        if (!edge_near(near_b, eb[j])) continue;
        const Vec3& q0 = B.v[eb[j].v0];
        const Vec3 w = B.v[eb[j].v1] - q0;
        if (!(u.cross(w).norm() > 1e-9 * u.norm() * w.norm())) continue;  // parallel: an end is as close
        double s, t;
        closest_on_lines(p0, u, q0, w, s, t);
        if (!(s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0)) continue;
        offer(pass, p0 + s * u, q0 + t * w, A.id(FeatureKind::Edge, static_cast<int>(i)),
              B.id(FeatureKind::Edge, static_cast<int>(j)), 2);
      }
    }
    // 4. vertices of A in front of faces of B
    for (std::size_t i = 0; i < na; ++i) {
      if (!near_a[i]) continue;
      for (std::size_t f = 0; f < B.n.size(); ++f) {
        if (!face_near(near_b, B.topo->faces[f])) continue;
        const double h = B.n[f].dot(A.v[i]) - B.d[f];
        if (!(h > 0.0)) continue;
        const Vec3 foot = A.v[i] - h * B.n[f];
        if (!foot_inside(B, static_cast<int>(f), foot)) continue;
        offer(pass, A.v[i], foot, A.id(FeatureKind::Vertex, static_cast<int>(i)),
              B.id(FeatureKind::Face, static_cast<int>(f)), 2);
      }
    }
    // 5. faces of A against vertices of B in front of them
    for (std::size_t f = 0; f < A.n.size(); ++f) {
      if (!face_near(near_a, A.topo->faces[f])) continue;
      for (std::size_t j = 0; j < nb; ++j) {
        if (!near_b[j]) continue;
        const double h = A.n[f].dot(B.v[j]) - A.d[f];
        if (!(h > 0.0)) continue;
        const Vec3 foot = B.v[j] - h * A.n[f];
        if (!foot_inside(A, static_cast<int>(f), foot)) continue;
        offer(pass, foot, B.v[j], A.id(FeatureKind::Face, static_cast<int>(f)),
              B.id(FeatureKind::Vertex, static_cast<int>(j)), 2);
      }
    }
    if (!(least < kInf)) return false;
  }
  return found;
}

/// The edge-edge contact of the query e (A's edge e.edge_a against B's e.edge_b along e.axis, in
/// A's frame; pa is A's pose, threshold and the pair's length scale L in m), appended to out
/// (docs/conventions.md, "Manifolds", edge contact):
/// - the edge lines' closest points on both edges, or the shapes overlapping: their midpoint, gap
///   e.separation, normal e.axis, ids (edge of A, edge of B);
/// - apart with a closest point off its edge (the separation only bounds the distance): the
///   polytopes' closest pair p, q (closest_features, ties 1e-12 L), gap |q - p|, normal
///   (q - p) / gap, point (p + q) / 2, when gap < threshold.
/// leave_out(k, lower, nearer): true when no contact of gap >= lower whose normal lies in the cone
/// n . k >= lower / nearer can be kept (polytope_polytope, given the pair's motion); the closest
/// pair is then not looked for.
template <class LeaveOut>
void edge_contact(const View& A, const View& B, const EdgeQuery& e, const Pose& pa, double threshold, double L,
                  ClosestBuffers& buffers, std::vector<Contact>& out, LeaveOut&& leave_out) {
  const auto& EA = A.topo->edges[e.edge_a];
  const auto& EB = B.topo->edges[e.edge_b];
  const Vec3 p0 = A.v[EA.v0], u = A.v[EA.v1] - p0;
  const Vec3 q0 = B.v[EB.v0], w = B.v[EB.v1] - q0;
  double s, t;
  closest_on_lines(p0, u, q0, w, s, t);
  if (e.separation > 0.0 && (s < 0.0 || s > 1.0 || t < 0.0 || t > 1.0)) {
    // an upper bound of the distance from the two edges' own ends (points of the shapes)
    Vec3 x;
    FeatureId id;
    int dim;
    double bound = kInf;
    for (const int v : {EA.v0, EA.v1}) {
      closest_on_edge(B, e.edge_b, A.v[v], x, id, dim);
      bound = std::min(bound, (x - A.v[v]).norm());
    }
    for (const int v : {EB.v0, EB.v1}) {
      closest_on_edge(A, e.edge_a, B.v[v], x, id, dim);
      bound = std::min(bound, (B.v[v] - x).norm());
    }
    // the closest pair: at the separation or farther, nearer than the threshold and than the bound
    if (leave_out(e.axis, e.separation, std::min(threshold, bound))) return;
    ClosestPair c;
    if (closest_features(A, B, e.axis, bound, 1e-12 * L, buffers, c) && c.distance > 0.0) {
      if (!(c.distance < threshold)) return;
      Contact k;
      k.point = pa.R * (0.5 * (c.p + c.q)) + pa.p;
      k.normal = pa.R * ((c.q - c.p) / c.distance);
      k.gap = c.distance;
      k.feature_a = c.fa;
      k.feature_b = c.fb;
      out.push_back(k);
      return;
    }
  }
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
                std::vector<double>& dist, std::vector<Contact>& out, const std::array<bool, 3>* ref_active = nullptr) {
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
  // a convex mesh keeps the vertices that lie inside one of its merged faces (a cap's centre) but
  // no face loop names them: when such a vertex is the deepest, the most anti-parallel face overall
  // (first on ties) is the incident face, as for a box
  if (g < 0) {
    g = 0;
    for (std::size_t k = 1; k < inc.n.size(); ++k)
      if (inc.n[k].dot(n_ref) < inc.n[g].dot(n_ref)) g = static_cast<int>(k);
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
    // the side plane, outward; not normalised: only the signs of the distances and their ratio
    // are used
    const Vec3 side = (r1 - r0).cross(n_ref);
    const double c = side.dot(r0);
    next.clear();
    dist.clear();
    for (const ClipVertex& P : poly) dist.push_back(side.dot(P.q) - c);
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const std::size_t j = i + 1 < poly.size() ? i + 1 : 0;
      const ClipVertex& P = poly[i];
      const ClipVertex& Q = poly[j];
      const double dP = dist[i], dQ = dist[j];
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
    Contact& c = out.emplace_back();  // filled in place (a Contact is large to copy)
    c.point = R_a * y + p_a;
    c.normal = ref_is_a ? n_world : Vec3(-n_world);
    c.gap = gap;
    c.feature_a = ref_is_a ? V.ref_id : V.inc_id;
    c.feature_b = ref_is_a ? V.inc_id : V.ref_id;
  }
}

/// The closest-pair rule after a face clip (docs/conventions.md, "Manifolds", face contact), for
/// two polytopes A and B (views in A's frame) apart or touching: the least gap g_min of the clipped
/// points out[first..] bounds the distance from above and `lower` (the separation along the
/// caller's best axis) from below; when g_min > lower + 1e-9 L the closest pair (closest_features,
/// ties 1e-12 L) is appended if nearer than the threshold and than g_min - 1e-9 L, replacing the
/// clipped points with its ids or within 1e-9 L of its point. Allocates nothing once out and the
/// buffers have grown.
/// Inputs: axis (unit, A -> B, A's frame: narrows the search), n_touch (unit, A -> B, A's frame: the
/// normal of a pair touching, closest points within 1e-12 L), lower, L, threshold (m), pa (A's pose:
/// out is in the world frame), first (the clip's first contact in out).
/// Does nothing when lower < -1e-12 L (overlapping: the clip's depths are the separating axes').
void closest_pair_after_clip(const View& A, const View& B, const Vec3& axis, const Vec3& n_touch, double lower,
                             double L, double threshold, const Pose& pa, ClosestBuffers& buffers, std::size_t first,
                             std::vector<Contact>& out) {
  if (!(lower >= -1e-12 * L)) return;
  double least = kInf;
  for (std::size_t k = first; k < out.size(); ++k) least = std::min(least, out[k].gap);
  if (!(least > lower + 1e-9 * L)) return;  // the distance is within 1e-9 L of a clipped point's gap
  ClosestPair c;
  if (!closest_features(A, B, axis, least, 1e-12 * L, buffers, c)) return;
  if (!(c.distance < threshold && c.distance < least - 1e-9 * L)) return;
  const bool touching = c.distance <= 1e-12 * L;
  Contact k;
  k.point = pa.R * (0.5 * (c.p + c.q)) + pa.p;
  k.normal = pa.R * (touching ? n_touch : Vec3((c.q - c.p) / c.distance));
  k.gap = c.distance;
  k.feature_a = c.fa;
  k.feature_b = c.fb;
  const auto replaced = [&](const Contact& x) {
    return (x.feature_a == k.feature_a && x.feature_b == k.feature_b) || (x.point - k.point).norm() <= 1e-9 * L;
  };
  out.erase(std::remove_if(out.begin() + static_cast<std::ptrdiff_t>(first), out.end(), replaced), out.end());
  out.push_back(k);
}

double radius_of(const Polytope& P) { return P.vertices.rowwise().norm().maxCoeff(); }

/// The polytope's radius in the pair's length scale L: its farthest vertex from its origin; a
/// box's vertices all lie at |h| (vertex 7 = (+h_x, +h_y, +h_z)): the same number, 8 times cheaper.
double scale_radius(const Polytope& P, bool box) { return box ? P.vertex(7).norm() : radius_of(P); }

/// What a pair's motion lets polytope_polytope leave out: bounds of how far a contact's point lies
/// from A's and B's centres (m), the slack for rounding (m) and the threshold the tests run to (m).
struct MotionBounds {
  double r_a = 0.0, r_b = 0.0, slack = 0.0, threshold = 0.0;
};

/// With the pair's motion, a contact it cannot close is dropped after (keep_closable), and the
/// tests stop where none can be closed: at closable_gap (points within the polytopes' radii of
/// their origins, and half the threshold more), but not below 2 tol, under which a face preferred
/// by tol over a separating one could clip points nearer than the separation (the exits leave out
/// only contacts farther than the threshold). The slack: rounding, and the 1e-9 L of
/// closest_pair_after_clip. Every contact kept is the same as without the motion.
MotionBounds motion_bounds(const PairMotion& motion, const Pose& pa, const Pose& pb, double radius_a, double radius_b,
                           double threshold) {
  MotionBounds m;
  const double L = radius_a + radius_b;
  m.r_a = (pa.p - motion.p_a).norm() + radius_a + threshold;
  m.r_b = (pb.p - motion.p_b).norm() + radius_b + threshold;
  m.slack = 1e-6 * (L + motion.margin) + 1e-12 * (pa.p.norm() + pb.p.norm());
  m.threshold = std::min(threshold, std::max(motion.closable_gap(m.r_a, m.r_b), 2.0 * kFacePreference * L) + m.slack);
  return m;
}

}  // namespace

/// The narrow phase's buffers for polytope pairs (a member of Scratch): both polytopes placed in
/// A's frame, the edge query's buffers, and the incident polygon being clipped.
struct PolytopeScratch {
  View A, B;
  EdgeBuffers edges;
  ClosestBuffers closest;
  std::vector<ClipVertex> poly, next;
  std::vector<double> dist;  ///< the polygon's distances to the side plane being clipped against
};


PolytopeScratch* new_polytope_scratch() { return new PolytopeScratch(); }
void ScratchDeleter::operator()(PolytopeScratch* p) const { delete p; }

void polytope_polytope(const Polytope& a, const Pose& pa, std::uint32_t part_a, const Polytope& b,
                       const Pose& pb, std::uint32_t part_b, double threshold, PolytopeScratch& scratch,
                       std::vector<Contact>& out, bool boxes, SeparatingFace* separated, const PairMotion* motion) {
  if (separated) separated->face = -1;
  const double radius_a = scale_radius(a, boxes), radius_b = scale_radius(b, boxes);
  const double L = radius_a + radius_b;
  MotionBounds bounds;
  if (motion) {
    bounds = motion_bounds(*motion, pa, pb, radius_a, radius_b, threshold);
    threshold = bounds.threshold;
  }
  const double r_a = bounds.r_a, r_b = bounds.r_b, slack = bounds.slack;
  // whether a contact of gap >= lower whose normal lies within the cone n . k >= lower / nearer
  // (k unit, A's frame: every contact nearer than `nearer` of a pair separated by lower along k)
  // can be closed (nearer <= 0: the half space n . k >= 0)
  const auto closable_beyond = [&](const Vec3& k, double lower, double nearer) {
    const double c = nearer > 0.0 ? std::clamp((lower - slack) / nearer, 0.0, 1.0) : 0.0;
    return lower - slack < motion->closable_gap(r_a, r_b, pa.R * k, c);
  };
  // everything in A's frame: B placed by R_ab = R_a^T R_b, t_ab = R_a^T (p_b - p_a)
  View& A = scratch.A;
  View& B = scratch.B;
  const Mat3 R_ab = pa.R.transpose() * pb.R;
  const Vec3 t_ab = pa.R.transpose() * (pb.p - pa.p);
  A.place_local(a, part_a);
  B.place(b, R_ab, t_ab, part_b);
  const FaceQuery fa = face_query(A, B, threshold);
  if (!(fa.separation < threshold)) {
    if (separated) separated->of_b = false, separated->face = fa.face;
    return;
  }
  const FaceQuery fb = face_query(B, A, threshold);
  if (!(fb.separation < threshold)) {
    if (separated) separated->of_b = true, separated->face = fb.face;
    return;
  }
  // faces are preferred: B's face only when better than A's by tol, an edge only when better than
  // both by tol (tol = 5e-4 L), or a tilted stack would rock on one point ("Manifolds", box against box)
  // an edge axis matters when it beats both faces by at least 1e-9 L, or reaches the threshold
  const double edge_bound = std::min(std::max(fa.separation, fb.separation) + 1e-9 * L, threshold);
  const EdgeQuery e = boxes ? box_edge_query(A, B, R_ab, t_ab, edge_bound)
                           : edge_query(A, B, edge_bound, scratch.edges);
  if (!(e.separation < threshold)) return;
  const Vec3& n_face = fb.separation > fa.separation ? B.n[fb.face] : A.n[fa.face];
  const double edge_tol = std::abs(e.axis.dot(n_face)) >= kNearlyParallel ? kFacePreference * L : 1e-9 * L;
  const double tol = kFacePreference * L;
  if (e.edge_a >= 0 && e.separation > std::max(fa.separation, fb.separation) + edge_tol) {
    // its contact lies at e.separation or farther, its normal in the cone about the axis
    if (motion && !closable_beyond(e.axis, e.separation, threshold)) return;
    edge_contact(A, B, e, pa, threshold, L, scratch.closest, out, [&](const Vec3& k, double lower, double nearer) {
      return motion && !closable_beyond(k, lower, nearer);
    });
    return;
  }
  const double face_tol = std::abs(A.n[fa.face].dot(B.n[fb.face])) >= kNearlyParallel ? tol : 1e-9 * L;
  const std::size_t first = out.size();
  if (fb.separation > fa.separation + face_tol)
    clip_faces(B, fb.face, A, false, threshold, pa.R, pa.p, scratch.poly, scratch.next, scratch.dist, out);
  else
    clip_faces(A, fa.face, B, true, threshold, pa.R, pa.p, scratch.poly, scratch.next, scratch.dist, out);
  // apart or touching, the clip can miss the closest pair, which is then added (touching: along the
  // better face axis) so that a speculative contact's deepest gap is the distance
  const bool b_better = fb.separation > fa.separation;
  const Vec3 axis = b_better ? Vec3(-n_face) : n_face;
  const double lower = std::max(fa.separation, fb.separation);
  // none of the clipped points can be closed, nor a closest pair (at lower or farther, its normal
  // in the cone about the axis; nearer than the threshold and than the clipped points, or it is
  // not added): the pair gives nothing, and the closest pair is not looked for
  if (motion) {
    double least = threshold;
    bool closable = false;
    for (std::size_t k = first; k < out.size(); ++k) {
      least = std::min(least, out[k].gap);
      closable = closable || motion->can_close(out[k]);
    }
    if (!closable && !closable_beyond(axis, lower, least)) {
      out.resize(first);
      return;
    }
  }
  closest_pair_after_clip(A, B, axis, axis, lower, L, threshold, pa, scratch.closest, first, out);
}

double polytope_threshold(const Polytope& a, const Pose& pa, const Polytope& b, const Pose& pb, bool boxes,
                          double threshold, const PairMotion& motion) {
  return motion_bounds(motion, pa, pb, scale_radius(a, boxes), scale_radius(b, boxes), threshold).threshold;
}

double face_separation(const Polytope& a, const Pose& pa, int f, const Polytope& b, const Pose& pb) {
  const Vec3 n = pa.R * a.normals[f];                // world
  const Vec3 n_b = pb.R.transpose() * n;             // in b's frame
  double m = kInf;
  for (Eigen::Index i = 0; i < b.vertices.rows(); ++i) m = std::min(m, n_b.dot(b.vertex(static_cast<int>(i))));
  return m + n.dot(pb.p) - (a.offsets[f] + n.dot(pa.p));
}

void triangle_polytope(const Polytope& tri, const std::array<bool, 3>& active, const Pose& pa,
                       std::uint32_t triangle, const Polytope& b, const Pose& pb, std::uint32_t part_b,
                       double threshold, PolytopeScratch& scratch, std::vector<Contact>& out, bool face_only) {
  View& A = scratch.A;
  View& B = scratch.B;
  A.place_local(tri, triangle);
  B.place(b, pa.R.transpose() * pb.R, pa.R.transpose() * (pb.p - pa.p), part_b);
  // one-sided: only the front face pushes, and a body whose centre is behind it is left alone
  if (A.n[0].dot(B.centroid) < A.d[0]) return;
  const double sep_a = B.min_along(A.n[0]) - A.d[0];
  if (!(sep_a < threshold)) return;
  if (face_only) {
    clip_faces(A, 0, B, true, threshold, pa.R, pa.p, scratch.poly, scratch.next, scratch.dist, out, &active);
    return;
  }
  const FaceQuery fb = face_query(B, A, threshold);
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
  // overlapping, an edge axis is a contact only where the edge lines meet on both edges; a triangle's
  // best axis can miss that, and the faces then make the manifold (docs/conventions.md, "Contacts")
  bool edge_meets = e.edge_a >= 0 && e.separation > 0.0;
  if (e.edge_a >= 0 && !edge_meets) {
    const auto& ea = tri.edges[e.edge_a];
    const auto& eb = b.edges[e.edge_b];
    double s, t;
    closest_on_lines(A.v[ea.v0], A.v[ea.v1] - A.v[ea.v0], B.v[eb.v0], B.v[eb.v1] - B.v[eb.v0], s, t);
    edge_meets = s >= 0.0 && s <= 1.0 && t >= 0.0 && t <= 1.0;
  }
  if (edge_meets && e.separation > std::max(sep_a, fb.separation) + tol) {
    edge_contact(A, B, e, pa, threshold, radius_of(tri) + radius_of(b), scratch.closest, out,
                 [](const Vec3&, double, double) { return false; });
    return;
  }
  // B's face axis is set by the triangle's feature deepest along it: a vertex between two inactive
  // edges, or an inactive edge, is a ghost of the tessellation (the mesh goes on flat or bends up
  // there, so B's face cannot face that feature alone), and the triangle's face makes the contact
  bool b_face = fb.separation > sep_a + tol;
  if (b_face) {
    const Vec3& n_b = B.n[fb.face];
    double least = kInf;
    for (const Vec3& x : A.v) least = std::min(least, n_b.dot(x));
    bool deepest[3];
    for (int k = 0; k < 3; ++k) deepest[k] = n_b.dot(A.v[k]) <= least + support_tol;
    bool ghost = true;
    for (int k = 0; k < 3; ++k) {
      // edge k (v_k -> v_k+1) holds the deepest feature when both its ends are deepest; a lone
      // deepest vertex k is its own feature, between edges k - 1 and k
      const bool both = deepest[k] && deepest[(k + 1) % 3];
      if (both && active[k]) ghost = false;
      if (deepest[k] && !deepest[(k + 1) % 3] && !deepest[(k + 2) % 3] && (active[k] || active[(k + 2) % 3]))
        ghost = false;
    }
    if (deepest[0] && deepest[1] && deepest[2]) ghost = false;  // B's face lies along the triangle
    b_face = !ghost;
  }
  const std::size_t first = out.size();
  if (b_face)
    clip_faces(B, fb.face, A, false, threshold, pa.R, pa.p, scratch.poly, scratch.next, scratch.dist, out);
  else
    clip_faces(A, 0, B, true, threshold, pa.R, pa.p, scratch.poly, scratch.next, scratch.dist, out, &active);
  // apart or touching, the clip can miss the closest pair: added as for two polytopes, the best of
  // the face, B's and the edge axes bounding the distance from below (ghosts and back-facing
  // normals are dropped in trimesh_item); none for a triangle without active edges clipped by its
  // own face (docs/conventions.md, "Contacts", static triangle mesh)
  if (!b_face && !active[0] && !active[1] && !active[2]) return;
  double lower = sep_a;
  Vec3 n_lower = A.n[0];
  if (fb.separation > lower) lower = fb.separation, n_lower = -B.n[fb.face];
  if (e.separation > lower) lower = e.separation, n_lower = e.axis;
  closest_pair_after_clip(A, B, A.n[0], n_lower, lower, radius_of(tri) + radius_of(b), threshold, pa, scratch.closest,
                          first, out);
}

}  // namespace signorini::collision
