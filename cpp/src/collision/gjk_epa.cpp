// GJK with the signed-volumes subalgorithm, and EPA; see gjk_epa.hpp for the contract.
//
// Notation: D = B - A (Minkowski difference), z = b - a its points, v the point of the current
// simplex closest to the origin, w the support of D along -v. Every vertex keeps the support
// points a, b it came from, so that witnesses are the same barycentric combination of them.
#include "collision/gjk_epa.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace signorini::collision {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kGjkMaxIterations = 128;
constexpr int kEnclosingMaxIterations = 64;
constexpr int kEpaMaxIterations = 128;
constexpr double kGjkTolerance = 1e-12;  // duality gap, relative to L + |p_b - p_a|
constexpr double kEpaTolerance = 1e-10;  // support beyond the closest face, relative to L
constexpr double kInflation = 1e-6;      // mu, relative to L

/// A vertex of D: z = b - a + 2 mu d, with a = s_A(-d), b = s_B(d) the support points of the
/// items themselves (mu = 0 outside EPA).
struct Vertex {
  Vec3 z, a, b;
};

Vertex support_of_difference(const Item& A, const Item& B, const Vec3& d, double mu) {
  Vertex v;
  v.a = support_point(A, -d);
  v.b = support_point(B, d);
  v.z = v.b - v.a + (2.0 * mu) * d;
  return v;
}

using Lambda = std::array<double, 4>;

bool same_sign(double x, double y) { return (x > 0.0 && y > 0.0) || (x < 0.0 && y < 0.0); }

// ---- signed-volumes distance subalgorithm (Montanari, Petrinic, Barbieri 2017, section 3) ----
// Each returns the squared distance of the origin to the sub-simplex of s with the given vertex
// indices and writes the barycentric coordinates of its closest point into lam (0 elsewhere).

/// S1D: segment s_i s_j.
double s1d(const Vec3* s, int i, int j, Lambda& lam) {
  lam.fill(0.0);
  const Vec3 t = s[j] - s[i];
  const double tt = t.squaredNorm();
  const double u = tt > 0.0 ? -s[i].dot(t) / tt : 0.0;
  if (!(u > 0.0)) {
    lam[i] = 1.0;
    return s[i].squaredNorm();
  }
  if (u >= 1.0) {
    lam[j] = 1.0;
    return s[j].squaredNorm();
  }
  lam[i] = 1.0 - u;
  lam[j] = u;
  return (lam[i] * s[i] + lam[j] * s[j]).squaredNorm();
}

/// S2D: triangle s_i s_j s_k. The origin is projected onto its plane and the signed areas of the
/// sub-triangles are taken in the coordinate plane where the triangle's projection is largest.
double s2d(const Vec3* s, int i, int j, int k, Lambda& lam) {
  const Vec3 n = (s[j] - s[i]).cross(s[k] - s[i]);
  int ax = 0;
  if (std::abs(n.y()) > std::abs(n[ax])) ax = 1;
  if (std::abs(n.z()) > std::abs(n[ax])) ax = 2;
  const double mu_max = n[ax];
  if (mu_max != 0.0) {
    const Vec3 p0 = n * (s[i].dot(n) / n.squaredNorm());
    const int x = (ax + 1) % 3, y = (ax + 2) % 3;
    auto area = [x, y](const Vec3& p, const Vec3& q, const Vec3& r) {
      return (q[x] - p[x]) * (r[y] - p[y]) - (q[y] - p[y]) * (r[x] - p[x]);
    };
    const double c0 = area(p0, s[j], s[k]), c1 = area(s[i], p0, s[k]), c2 = area(s[i], s[j], p0);
    if (same_sign(c0, mu_max) && same_sign(c1, mu_max) && same_sign(c2, mu_max)) {
      lam.fill(0.0);
      lam[i] = c0 / mu_max;
      lam[j] = c1 / mu_max;
      lam[k] = c2 / mu_max;
      return (lam[i] * s[i] + lam[j] * s[j] + lam[k] * s[k]).squaredNorm();
    }
    // the closest point lies on an edge facing the projection (opposite a negative coordinate)
    double best = kInf;
    Lambda tmp;
    const double c[3] = {c0, c1, c2};
    const int e[3][2] = {{j, k}, {i, k}, {i, j}};
    for (int m = 0; m < 3; ++m) {
      if (same_sign(c[m], mu_max)) continue;
      const double d2 = s1d(s, e[m][0], e[m][1], tmp);
      if (d2 < best) best = d2, lam = tmp;
    }
    return best;
  }
  // a degenerate (collinear) triangle: its best edge
  double best = kInf;
  Lambda tmp;
  const int e[3][2] = {{j, k}, {i, k}, {i, j}};
  for (const auto& ed : e) {
    const double d2 = s1d(s, ed[0], ed[1], tmp);
    if (d2 < best) best = d2, lam = tmp;
  }
  return best;
}

/// Signed volume (times 6) of the tetrahedron p q r t.
double volume(const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& t) {
  return (q - p).dot((r - p).cross(t - p));
}

/// S3D: tetrahedron s_0..s_3. The cofactors C_j are the signed volumes with vertex j replaced by
/// the origin; their sum is the tetrahedron's. The origin is inside when all share its sign.
double s3d(const Vec3* s, Lambda& lam) {
  const Vec3 o = Vec3::Zero();
  const double c[4] = {volume(o, s[1], s[2], s[3]), volume(s[0], o, s[2], s[3]), volume(s[0], s[1], o, s[3]),
                       volume(s[0], s[1], s[2], o)};
  const double det = c[0] + c[1] + c[2] + c[3];
  if (same_sign(c[0], det) && same_sign(c[1], det) && same_sign(c[2], det) && same_sign(c[3], det)) {
    for (int m = 0; m < 4; ++m) lam[m] = c[m] / det;
    return 0.0;
  }
  // the closest point lies on a face facing the origin (all four when the tetrahedron is flat)
  double best = kInf;
  Lambda tmp;
  const int f[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  for (int m = 0; m < 4; ++m) {
    if (same_sign(c[m], det)) continue;
    const double d2 = s2d(s, f[m][0], f[m][1], f[m][2], tmp);
    if (d2 < best) best = d2, lam = tmp;
  }
  return best;
}

/// A GJK simplex of 1 to 4 vertices.
struct Simplex {
  std::array<Vertex, 4> p;
  int n = 0;

  /// Replaces the simplex by the smallest sub-simplex holding its point closest to the origin
  /// (barycentric coordinates > 0); returns that point. enclosed: a tetrahedron holds the origin.
  Vec3 reduce(bool& enclosed) {
    Vec3 s[4];
    for (int k = 0; k < n; ++k) s[k] = p[k].z;
    Lambda lam{};
    switch (n) {
      case 1: lam[0] = 1.0; break;
      case 2: s1d(s, 0, 1, lam); break;
      case 3: s2d(s, 0, 1, 2, lam); break;
      default: s3d(s, lam); break;
    }
    int m = 0;
    Vec3 v = Vec3::Zero();
    for (int k = 0; k < n; ++k) {
      if (!(lam[k] > 0.0)) continue;
      v += lam[k] * p[k].z;
      lambda[m] = lam[k];
      p[m++] = p[k];
    }
    enclosed = n == 4 && m == 4;
    n = m;
    if (enclosed) v = Vec3::Zero();
    return v;
  }

  /// The witnesses: the barycentric combination (after reduce) of the support points.
  void witnesses(Vec3& w_a, Vec3& w_b) const {
    w_a.setZero();
    w_b.setZero();
    for (int k = 0; k < n; ++k) {
      w_a += lambda[k] * p[k].a;
      w_b += lambda[k] * p[k].b;
    }
  }

  std::array<double, 4> lambda{1.0, 0.0, 0.0, 0.0};
};

/// A unit vector perpendicular to unit-or-not t (t != 0).
Vec3 perpendicular(const Vec3& t) {
  const Vec3 e = std::abs(t.x()) < 0.57 ? Vec3::UnitX() : (std::abs(t.y()) < 0.57 ? Vec3::UnitY() : Vec3::UnitZ());
  return t.cross(e).normalized();
}

// ---- EPA ----

struct Face {
  int v[3];         ///< vertex indices, counter-clockwise seen from outside
  int adj[3];       ///< neighbour across edge k (v[k] -> v[k+1])
  int adj_edge[3];  ///< which edge of that neighbour it is
  Vec3 m;           ///< unit outward normal
  double delta;     ///< m . z on the face: distance of its plane from the origin
  bool alive;
};

struct Epa {
  std::vector<Vertex> verts;
  std::vector<Face> faces;
  std::vector<std::pair<int, int>> horizon;  // (face, edge) left standing next to removed faces

  /// Appends face (i, j, k); false when it is degenerate (no normal).
  bool add_face(int i, int j, int k) {
    Face f;
    f.v[0] = i, f.v[1] = j, f.v[2] = k;
    f.adj[0] = f.adj[1] = f.adj[2] = -1;
    f.adj_edge[0] = f.adj_edge[1] = f.adj_edge[2] = -1;
    const Vec3& z0 = verts[i].z;
    const Vec3 c = (verts[j].z - z0).cross(verts[k].z - z0);
    const double len = c.norm();
    f.alive = true;
    if (!(len > 0.0)) {
      f.m = Vec3::UnitZ();
      f.delta = kInf;
      faces.push_back(f);
      return false;
    }
    f.m = c / len;
    f.delta = (f.m.dot(z0) + f.m.dot(verts[j].z) + f.m.dot(verts[k].z)) / 3.0;
    faces.push_back(f);
    return true;
  }

  /// Links the faces from index `first` on, across matching reversed edges, to each other and to
  /// the faces in `others` (their open edge given). False if some edge finds no partner.
  bool link_new(std::size_t first) {
    for (std::size_t x = first; x < faces.size(); ++x)
      for (int e = 0; e < 3; ++e) {
        if (faces[x].adj[e] >= 0) continue;
        const int u = faces[x].v[e], w = faces[x].v[(e + 1) % 3];
        bool found = false;
        for (std::size_t y = first; y < faces.size() && !found; ++y)
          for (int g = 0; g < 3; ++g)
            if (faces[y].v[g] == w && faces[y].v[(g + 1) % 3] == u) {
              faces[x].adj[e] = static_cast<int>(y), faces[x].adj_edge[e] = g;
              faces[y].adj[g] = static_cast<int>(x), faces[y].adj_edge[g] = e;
              found = true;
              break;
            }
        if (!found) return false;
      }
    return true;
  }

  /// Depth-first walk over the faces that see w, removing them and collecting the horizon
  /// (the edges between removed faces and faces left standing).
  void silhouette(int f, int e, const Vec3& w, double eps) {
    Face& F = faces[f];
    if (!F.alive) return;
    if (F.m.dot(w - verts[F.v[0]].z) > eps) {
      F.alive = false;
      const int e1 = (e + 1) % 3, e2 = (e + 2) % 3;
      const int f1 = F.adj[e1], g1 = F.adj_edge[e1], f2 = F.adj[e2], g2 = F.adj_edge[e2];
      silhouette(f1, g1, w, eps);
      silhouette(f2, g2, w, eps);
    } else {
      horizon.emplace_back(f, e);
    }
  }
};

thread_local Epa t_epa;

}  // namespace

Distance gjk_epa(const Item& a, const Item& b, GjkEpaStats* stats) {
  GjkEpaStats local;
  GjkEpaStats& st = stats ? *stats : local;
  st = GjkEpaStats{};
  const double L = a.radius() + b.radius();
  const Vec3 centres = b.pose.p - a.pose.p;
  const double scale = L + centres.norm();
  const double mu = kInflation * L;
  const double tol_gjk = kGjkTolerance * scale;

  // ---- GJK on D itself ----
  Simplex S;
  const double cn = centres.norm();
  S.p[0] = support_of_difference(a, b, cn > 0.0 ? Vec3(-centres / cn) : Vec3(-Vec3::UnitX()), 0.0);
  S.n = 1;
  Vec3 v = S.p[0].z;
  bool enclosed = false;
  bool separated = false;
  for (;;) {
    const double vv = v.squaredNorm(), vn = std::sqrt(vv);
    if (vn <= mu) break;  // touching or overlapping: EPA
    if (st.gjk_iterations >= kGjkMaxIterations) {
      st.converged = false;
      separated = true;  // |v| is still the distance of two points of the shapes
      break;
    }
    ++st.gjk_iterations;
    const Vertex w = support_of_difference(a, b, -v / vn, 0.0);
    // the duality gap |v| - v.w/|v| bounds the error of |v|
    if (vv - v.dot(w.z) <= tol_gjk * vn) {
      separated = true;
      break;
    }
    bool repeated = false;
    for (int k = 0; k < S.n; ++k) repeated = repeated || S.p[k].z == w.z;
    if (repeated) {
      separated = true;
      break;
    }
    const Simplex previous = S;
    S.p[S.n++] = w;
    const Vec3 v_new = S.reduce(enclosed);
    if (enclosed) break;
    if (!(v_new.squaredNorm() < vv)) {
      // no progress (rounding): the previous simplex is as close as GJK gets
      S = previous;
      separated = true;
      break;
    }
    v = v_new;
  }
  if (separated) {
    Distance d;
    S.witnesses(d.w_a, d.w_b);
    const double vn = v.norm();
    d.gap = vn;
    d.normal = v / vn;
    return d;
  }

  // ---- touching or overlapping: GJK on D' = D + ball(2 mu) until a tetrahedron holds the origin ----
  st.used_epa = true;
  // the fallback if EPA cannot start: GJK's gap, with the line of centres as normal
  Distance fallback;
  S.witnesses(fallback.w_a, fallback.w_b);
  fallback.gap = enclosed ? 0.0 : v.norm();
  fallback.normal = v.norm() > 0.0 ? Vec3(v.normalized()) : (cn > 0.0 ? Vec3(centres / cn) : Vec3(Vec3::UnitZ()));
  const double tiny = 1e-14 * scale;
  for (int it = 0; !enclosed; ++it) {
    if (it >= kEnclosingMaxIterations) {
      st.converged = false;
      return fallback;
    }
    const double vn = v.norm();
    if (vn <= tiny || S.n == 4) {
      // the origin on the simplex: blow it up to a tetrahedron by supports normal to it
      if (S.n == 1) S.p[S.n++] = support_of_difference(a, b, perpendicular(S.p[0].z + Vec3(1e-300, 0, 0)), mu);
      if (S.n == 2) {
        const Vec3 t = S.p[1].z - S.p[0].z;
        Vec3 e = perpendicular(t.squaredNorm() > 0.0 ? t : Vec3(Vec3::UnitX()));
        S.p[S.n++] = support_of_difference(a, b, e, mu);
        if ((S.p[1].z - S.p[0].z).cross(S.p[2].z - S.p[0].z).squaredNorm() == 0.0)
          S.p[2] = support_of_difference(a, b, -e, mu);
      }
      if (S.n == 3) {
        Vec3 nrm = (S.p[1].z - S.p[0].z).cross(S.p[2].z - S.p[0].z);
        if (!(nrm.squaredNorm() > 0.0)) {
          st.converged = false;
          return fallback;
        }
        nrm.normalize();
        if (nrm.dot(S.p[0].z) > 0.0) nrm = -nrm;  // towards the origin's side
        S.p[S.n++] = support_of_difference(a, b, nrm, mu);
      }
      break;  // a tetrahedron with the origin inside or on its boundary
    }
    const Vertex w = support_of_difference(a, b, -v / vn, mu);
    S.p[S.n++] = w;
    const double vv = v.squaredNorm();
    v = S.reduce(enclosed);
    if (!enclosed && !(v.squaredNorm() < vv)) v = Vec3::Zero();  // stalled on the simplex: blow up
  }

  // ---- EPA on D' from that tetrahedron ----
  Epa& E = t_epa;
  E.verts.clear();
  E.faces.clear();
  for (int k = 0; k < 4; ++k) E.verts.push_back(S.p[k]);
  if (volume(E.verts[0].z, E.verts[1].z, E.verts[2].z, E.verts[3].z) > 0.0) std::swap(E.verts[1], E.verts[2]);
  bool ok = E.add_face(0, 1, 2);
  ok = E.add_face(0, 3, 1) && ok;
  ok = E.add_face(0, 2, 3) && ok;
  ok = E.add_face(1, 3, 2) && ok;
  if (!ok || !E.link_new(0)) {
    st.converged = false;
    return fallback;
  }
  const double tol_epa = kEpaTolerance * L;
  const double eps_visible = 1e-15 * scale;
  int best = -1;
  for (int it = 0;; ++it) {
    int f = -1;
    for (std::size_t k = 0; k < E.faces.size(); ++k)
      if (E.faces[k].alive && (f < 0 || E.faces[k].delta < E.faces[f].delta)) f = static_cast<int>(k);
    if (f < 0) break;
    best = f;
    const Vec3 m = E.faces[f].m;
    const double delta = E.faces[f].delta;
    const Vertex w = support_of_difference(a, b, m, mu);
    if (m.dot(w.z) - delta <= tol_epa) break;  // converged
    if (it >= kEpaMaxIterations) {
      st.converged = false;
      break;
    }
    ++st.epa_iterations;
    // remove the faces that see w and close the hole with faces fanning out from w
    const int wi = static_cast<int>(E.verts.size());
    E.verts.push_back(w);
    E.horizon.clear();
    E.faces[f].alive = false;
    for (int e = 0; e < 3; ++e) E.silhouette(E.faces[f].adj[e], E.faces[f].adj_edge[e], w.z, eps_visible);
    bool sound = E.horizon.size() >= 3;
    const std::size_t first = E.faces.size();
    for (std::size_t h = 0; h < E.horizon.size() && sound; ++h) {
      const auto [g, e] = E.horizon[h];
      const int u = E.faces[g].v[e], x = E.faces[g].v[(e + 1) % 3];
      sound = E.add_face(x, u, wi);
      Face& nf = E.faces.back();
      nf.adj[0] = g, nf.adj_edge[0] = e;
      E.faces[g].adj[e] = static_cast<int>(E.faces.size() - 1), E.faces[g].adj_edge[e] = 0;
      // a new face nearer than the one it replaces means rounding has bent the polytope
      sound = sound && nf.delta >= delta - tol_epa;
    }
    sound = sound && E.link_new(first);
    if (!sound) {
      st.converged = false;
      break;  // the polytope is damaged: keep the best face so far
    }
  }
  if (best < 0) {
    st.converged = false;
    return fallback;
  }

  // the origin projected onto the best face, in barycentric coordinates of its vertices
  const Face& F = E.faces[best];
  const Vertex& V0 = E.verts[F.v[0]];
  const Vertex& V1 = E.verts[F.v[1]];
  const Vertex& V2 = E.verts[F.v[2]];
  const Vec3 p = F.delta * F.m;
  const double area = (V1.z - V0.z).cross(V2.z - V0.z).dot(F.m);
  double l0 = (V1.z - p).cross(V2.z - p).dot(F.m) / area;
  double l1 = (V2.z - p).cross(V0.z - p).dot(F.m) / area;
  double l2 = (V0.z - p).cross(V1.z - p).dot(F.m) / area;
  l0 = std::max(l0, 0.0), l1 = std::max(l1, 0.0), l2 = std::max(l2, 0.0);
  const double sum = l0 + l1 + l2;
  if (sum > 0.0) l0 /= sum, l1 /= sum, l2 /= sum;
  else l0 = 1.0, l1 = l2 = 0.0;
  Distance d;
  d.gap = 2.0 * mu - F.delta;
  d.normal = -F.m;
  d.w_a = l0 * V0.a + l1 * V1.a + l2 * V2.a;
  d.w_b = l0 * V0.b + l1 * V1.b + l2 * V2.b;
  return d;
}

}  // namespace signorini::collision
