// GJK with the signed-volumes subalgorithm, and EPA; see gjk_epa.hpp for the contract.
//
// Notation: D = B - A (Minkowski difference of the cores), z = b - a its points, v the point of the
// current simplex closest to the origin, w the support of D along -v, c the shift of D for EPA.
// Every vertex keeps the support points a, b it came from, so that witnesses are the same
// barycentric combination of them.
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
constexpr int kEpaMaxIterations = 256;
constexpr int kWitnessExpansions = 16;  // of the face the witness ray leaves by (see the end)
constexpr double kGjkTolerance = 1e-12;  // duality gap, relative to L + |p_b - p_a|
constexpr double kEpaTolerance = 1e-10;  // support beyond the closest face, relative to L
constexpr double kShift = 1e-10;         // mu, relative to L
constexpr double kNear = 1e-6;           // a GJK stall below this gap (relative to L) goes to EPA
constexpr double kRound = 1e-14;         // rounding of v, relative to L + |p_b - p_a| (see the GJK loop)

/// A vertex of D: z = b - a - c, with a = s_A(-d), b = s_B(d) the support points of the items'
/// cores and c the shift of D (0 outside EPA).
struct Vertex {
  Vec3 z, a, b;
};

/// The radius by which an item rounds its core: a sphere is a point and a capsule a segment with
/// a radius. GJK and EPA run on the cores and the radii are added at the end, which makes sphere
/// and capsule pairs exact for GJK and spares EPA the doubly curved surfaces it converges slowly on
/// (docs/conventions.md, "Contacts", GJK/EPA).
double rounding(const Item& it) {
  if (it.sphere) return it.sphere->radius;
  if (it.capsule) return it.capsule->radius;
  return 0.0;
}

/// Support points of the cores along -d (A, rounded by r_a) and d (B, rounded by r_b).
Vertex support_of_difference(const Item& A, double r_a, const Item& B, double r_b, const Vec3& d, const Vec3& c) {
  Vertex v;
  v.a = support_point(A, -d) + r_a * d;
  v.b = support_point(B, d) - r_b * d;
  v.z = v.b - v.a - c;
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
    Vec3 s[4] = {p[0].z, p[1].z, p[2].z, p[3].z};
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
    if (n == 3) {
      // the origin projected onto the triangle's plane: v is a sum of vertices |z| ~ scale that
      // nearly cancel, so near contact its direction would carry ~1e-16 scale / |v| of rounding;
      // the normal of the plane (a cross product of edges) does not
      const Vec3 nrm = (p[1].z - p[0].z).cross(p[2].z - p[0].z);
      const double nn = nrm.squaredNorm();
      if (nn > 0.0) v = nrm * ((p[0].z.dot(nrm) + p[1].z.dot(nrm) + p[2].z.dot(nrm)) / (3.0 * nn));
    }
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
  std::vector<double> key;                    // per face: delta while alive, else infinity (the
                                              // nearest-face search scans these contiguously)
  std::vector<std::pair<int, int>> horizon;  // (face, edge) left standing next to removed faces
  std::vector<int> removed;                   // the faces one expansion removed
  std::vector<std::pair<int, int>> links;     // and the horizon faces' links before it

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
      key.push_back(kInf);
      return false;
    }
    f.m = c / len;
    f.delta = (f.m.dot(z0) + f.m.dot(verts[j].z) + f.m.dot(verts[k].z)) / 3.0;
    faces.push_back(f);
    key.push_back(f.delta);
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

  /// Adds vertex w beyond face f: removes the faces that see w and closes the hole with faces
  /// fanning out from w. When rounding would damage the polytope (a new face degenerate, an
  /// edge without a partner, or a new face nearer the origin than `floor`: the polytope only
  /// grows, so no face may come nearer than the nearest one before), it is left as it was and
  /// the result is false.
  bool expand(int f, const Vertex& w, double floor, double eps_visible) {
    const int wi = static_cast<int>(verts.size());
    verts.push_back(w);
    horizon.clear();
    removed.clear();
    links.clear();
    faces[f].alive = false;
    key[f] = kInf;
    removed.push_back(f);
    for (int e = 0; e < 3; ++e) silhouette(faces[f].adj[e], faces[f].adj_edge[e], w.z, eps_visible);
    bool sound = horizon.size() >= 3;
    const std::size_t first = faces.size();
    for (std::size_t h = 0; h < horizon.size() && sound; ++h) {
      const auto [g, e] = horizon[h];
      const int u = faces[g].v[e], x = faces[g].v[(e + 1) % 3];
      sound = add_face(x, u, wi);
      Face& nf = faces.back();
      nf.adj[0] = g, nf.adj_edge[0] = e;
      links.emplace_back(faces[g].adj[e], faces[g].adj_edge[e]);
      faces[g].adj[e] = static_cast<int>(faces.size() - 1), faces[g].adj_edge[e] = 0;
      sound = sound && nf.delta >= floor;
    }
    if (sound && link_new(first)) return true;
    // undo: the removed faces back, the horizon's links restored, the new faces and w dropped
    for (int r : removed) faces[r].alive = true, key[r] = faces[r].delta;
    for (std::size_t h = links.size(); h-- > 0;) {
      const auto [g, e] = horizon[h];
      faces[g].adj[e] = links[h].first, faces[g].adj_edge[e] = links[h].second;
    }
    faces.resize(first);
    key.resize(first);
    verts.pop_back();
    return false;
  }

  /// From face `at` on, the face that the ray from the origin along r leaves the polytope by
  /// (the origin inside): across the edge opposite the most negative of the ray coordinates
  /// l_k = r . (z_k+1 x z_k+2), which are the hit point's barycentric ones up to their sum.
  /// True with `at` and l set when found.
  bool walk(const Vec3& r, int& at, double l[3]) const {
    l[0] = l[1] = l[2] = -1.0;
    for (std::size_t step = 0; step <= faces.size() && at >= 0 && faces[at].alive; ++step) {
      const Face& G = faces[at];
      const Vec3& z0 = verts[G.v[0]].z;
      const Vec3& z1 = verts[G.v[1]].z;
      const Vec3& z2 = verts[G.v[2]].z;
      l[0] = r.dot(z1.cross(z2)), l[1] = r.dot(z2.cross(z0)), l[2] = r.dot(z0.cross(z1));
      if (l[0] >= 0.0 && l[1] >= 0.0 && l[2] >= 0.0) break;
      const int worst = l[0] <= l[1] && l[0] <= l[2] ? 0 : l[1] <= l[2] ? 1 : 2;
      at = G.adj[(worst + 1) % 3];  // edge k runs v[k] -> v[k+1]
    }
    return at >= 0 && faces[at].alive && l[0] >= 0.0 && l[1] >= 0.0 && l[2] >= 0.0 && l[0] + l[1] + l[2] > 0.0;
  }

  /// Depth-first walk over the faces that see w, removing them and collecting the horizon
  /// (the edges between removed faces and faces left standing).
  void silhouette(int f, int e, const Vec3& w, double eps) {
    Face& F = faces[f];
    if (!F.alive) return;
    if (F.m.dot(w - verts[F.v[0]].z) > eps) {
      F.alive = false;
      key[f] = kInf;
      removed.push_back(f);
      const int e1 = (e + 1) % 3, e2 = (e + 2) % 3;
      const int f1 = F.adj[e1], g1 = F.adj_edge[e1], f2 = F.adj[e2], g2 = F.adj_edge[e2];
      silhouette(f1, g1, w, eps);
      silhouette(f2, g2, w, eps);
    } else {
      horizon.emplace_back(f, e);
    }
  }
};

}  // namespace

/// The EPA buffers a Scratch holds (reused from pair to pair).
struct EpaScratch : Epa {};
EpaScratch* new_epa_scratch() { return new EpaScratch(); }
void ScratchDeleter::operator()(EpaScratch* p) const { delete p; }

Distance gjk_epa(const Item& a, const Item& b, GjkEpaStats* stats) {
  EpaScratch epa;
  return gjk_epa(a, b, epa, stats);
}

Distance gjk_epa(const Item& a, const Item& b, EpaScratch& epa, GjkEpaStats* stats) {
  GjkEpaStats local;
  GjkEpaStats& st = stats ? *stats : local;
  st = GjkEpaStats{};
  const double L = a.radius() + b.radius();
  const Vec3 centres = b.pose.p - a.pose.p;
  const double scale = L + centres.norm();
  const double mu = kShift * L;
  const Vec3 zero = Vec3::Zero();
  const double r_a = rounding(a), r_b = rounding(b);
  // the result for the cores, with the radii put back
  auto rounded = [&](Distance d) {
    d.gap -= r_a + r_b;
    d.w_a += r_a * d.normal;
    d.w_b -= r_b * d.normal;
    return d;
  };
  const double tol_gjk = kGjkTolerance * scale;

  // ---- GJK on D itself ----
  Simplex S;
  const double cn = centres.norm();
  S.p[0] = support_of_difference(a, r_a, b, r_b, cn > 0.0 ? Vec3(-centres / cn) : Vec3(-Vec3::UnitX()), zero);
  S.n = 1;
  Vec3 v = S.p[0].z;
  bool enclosed = false;
  bool separated = false;
  Vertex w_last{Vec3::Constant(kInf), Vec3::Zero(), Vec3::Zero()};  // set when GJK stalls
  Vec3 n0 = cn > 0.0 ? Vec3(centres / cn) : Vec3(Vec3::UnitZ());  // the last direction of v
  bool graced = false;  // the last step was let through without progress (below)
  for (;;) {
    const double vv = v.squaredNorm(), vn = std::sqrt(vv);
    if (vn <= mu) {
      if (vn > 0.0) n0 = v / vn;
      break;  // touching or overlapping: EPA
    }
    n0 = v / vn;
    if (st.gjk_iterations >= kGjkMaxIterations) {
      st.converged = false;
      st.stop = "GJK iteration cap";
      separated = true;  // |v| is still the distance of two points of the shapes
      break;
    }
    ++st.gjk_iterations;
    const Vertex w = support_of_difference(a, r_a, b, r_b, -v / vn, zero);
    // the duality gap |v| - v.w/|v| bounds the error of |v|
    if (vv - v.dot(w.z) <= tol_gjk * vn) {
      separated = true;
      st.stop = "duality gap";
      break;
    }
    bool repeated = false;
    for (int k = 0; k < S.n; ++k) repeated = repeated || S.p[k].z == w.z;
    if (repeated) {
      separated = true;
      st.stop = "repeated support";
      w_last = w;
      break;
    }
    const Simplex previous = S;
    S.p[S.n++] = w;
    const Vec3 v_new = S.reduce(enclosed);
    if (enclosed) break;
    if (!(v_new.squaredNorm() < vv)) {
      // on a ridge of D every other step leaves |v| unchanged up to rounding yet turns v, and the
      // next progresses: one such step that keeps its new vertex is let through (docs/conventions.md,
      // "Contacts", GJK/EPA)
      const bool kept = S.n > 0 && S.p[S.n - 1].z == w.z;
      if (!graced && kept && v_new.norm() <= vn + kRound * scale) {
        graced = true;
        v = v_new;
        continue;
      }
      // no progress (rounding): the previous simplex is as close as GJK gets
      S = previous;
      separated = true;
      st.stop = "no progress";
      w_last = w;
      break;
    }
    graced = false;
    v = v_new;
  }
  st.simplex = S.n;
  // a stall short of the duality gap near contact (rounding turns v's direction by ~1e-16 scale
  // / |v|): EPA decides instead (shift: for the second candidate shift below, which must reach
  // past |v| along n0)
  double shift = mu;
  if (separated && std::isfinite(w_last.z.x())) {
    const double vn = v.norm();
    if (vn - v.dot(w_last.z) / vn > tol_gjk && vn <= kNear * L) {
      separated = false;
      shift = std::max(mu, 0.75 * vn);
      n0 = v / vn;
    }
  }
  if (separated) {
    Distance d;
    S.witnesses(d.w_a, d.w_b);
    const double vn = v.norm();
    d.gap = vn;
    d.normal = v / vn;
    return rounded(d);
  }

  // ---- touching or overlapping: D' = D - c holds the origin inside ----
  // c = v + 2 shift e, e the unit vector from v (GJK's closest point, a point of D; 0 when a
  // tetrahedron enclosed the origin) towards q = (B's interior point) - (A's), inside D: the segment
  // (v, q] lies inside D (convex), so c does. c = 2 shift n0 (GJK's last direction) is the second
  // try (docs/conventions.md, "Contacts", GJK/EPA). GJK on D' runs until a tetrahedron holds the
  // origin; a separating plane means c was not inside D, and the next candidate is tried.
  st.used_epa = true;
  Distance fallback;  // if EPA cannot start: GJK's gap along its last direction
  S.witnesses(fallback.w_a, fallback.w_b);
  fallback.gap = enclosed ? 0.0 : v.norm();
  fallback.normal = n0;
  auto interior = [](const Item& it) {
    return it.polytope ? Vec3(it.pose.R * it.polytope->centroid + it.pose.p) : it.pose.p;
  };
  const Vec3 q = interior(b) - interior(a);
  const Vec3 v_d = enclosed ? Vec3(Vec3::Zero()) : v;  // a point of D (to rounding)
  const double qn = (q - v_d).norm();
  const Vec3 candidates[2] = {qn > 0.0 ? Vec3((q - v_d) / qn) : Vec3(-n0), n0};  // unit
  const Vec3 shifts[2] = {v_d + (2.0 * mu) * candidates[0], (2.0 * shift) * candidates[1]};
  const Simplex S0 = S;
  const double tiny = 1e-14 * scale;
  Vec3 c = Vec3::Zero();
  bool started = false;
  for (int attempt = 0; attempt < 2 && !started; ++attempt) {
    c = shifts[attempt];
    S = S0;
    for (int k = 0; k < S.n; ++k) S.p[k].z -= c;
    v = S.reduce(enclosed);
    bool missed = false;
    for (int it = 0; !enclosed && !missed; ++it) {
      if (it >= kEnclosingMaxIterations) {
        missed = true;
        break;
      }
      const double vn = v.norm();
      if (vn <= tiny) {
        // the origin on the simplex: blow it up to a tetrahedron by supports normal to it
        if (S.n == 1) S.p[S.n++] = support_of_difference(a, r_a, b, r_b, candidates[attempt], c);
        if (S.n == 2) {
          const Vec3 t = S.p[1].z - S.p[0].z;
          const Vec3 e = perpendicular(t.squaredNorm() > 0.0 ? t : Vec3(Vec3::UnitX()));
          S.p[S.n++] = support_of_difference(a, r_a, b, r_b, e, c);
          if ((S.p[1].z - S.p[0].z).cross(S.p[2].z - S.p[0].z).squaredNorm() == 0.0)
            S.p[2] = support_of_difference(a, r_a, b, r_b, -e, c);
        }
        Vec3 nrm = (S.p[1].z - S.p[0].z).cross(S.p[2].z - S.p[0].z);
        if (!(nrm.squaredNorm() > 0.0)) {
          missed = true;
          break;
        }
        nrm.normalize();
        if (nrm.dot(S.p[0].z) > 0.0) nrm = -nrm;  // away from the triangle, on the origin's side
        S.p[3] = support_of_difference(a, r_a, b, r_b, nrm, c);
        S.n = 4;
        enclosed = true;  // the origin inside the tetrahedron or on its boundary
        break;
      }
      const Vertex w = support_of_difference(a, r_a, b, r_b, -v / vn, c);
      if (v.dot(w.z) > 0.0) {
        missed = true;  // a plane separates D' from the origin: c is not inside D
        break;
      }
      S.p[S.n++] = w;
      const double vv = v.squaredNorm();
      v = S.reduce(enclosed);
      if (!enclosed && !(v.squaredNorm() < vv)) v = Vec3::Zero();  // stalled on the simplex: blow up
    }
    started = enclosed && !missed;
  }
  if (!started) {
    st.converged = false;
    st.stop = "no shift puts the origin inside";
    return rounded(fallback);
  }

  // ---- EPA on D' from that tetrahedron ----
  Epa& E = epa;
  E.verts.clear();
  E.faces.clear();
  E.key.clear();
  for (int k = 0; k < 4; ++k) E.verts.push_back(S.p[k]);
  if (volume(E.verts[0].z, E.verts[1].z, E.verts[2].z, E.verts[3].z) > 0.0) std::swap(E.verts[1], E.verts[2]);
  bool ok = E.add_face(0, 1, 2);
  ok = E.add_face(0, 3, 1) && ok;
  ok = E.add_face(0, 2, 3) && ok;
  ok = E.add_face(1, 3, 2) && ok;
  if (!ok || !E.link_new(0)) {
    st.converged = false;
    st.stop = "EPA start degenerate";
    return rounded(fallback);
  }
  const double tol_epa = kEpaTolerance * L;
  const double eps_visible = 1e-15 * scale;
  int best = -1;
  int refined = -1;  // the face EPA stopped on, converged
  for (int it = 0;; ++it) {
    int f = -1;
    double nearest_delta = kInf;
    for (std::size_t k = 0; k < E.key.size(); ++k)
      if (E.key[k] < nearest_delta) nearest_delta = E.key[k], f = static_cast<int>(k);
    if (f < 0)  // no finite distance: the first face alive, if any
      for (std::size_t k = 0; k < E.faces.size() && f < 0; ++k)
        if (E.faces[k].alive) f = static_cast<int>(k);
    if (f < 0) break;
    best = f;
    const Vec3 m = E.faces[f].m;
    const double delta = E.faces[f].delta;
    const Vertex w = support_of_difference(a, r_a, b, r_b, m, c);
    if (m.dot(w.z) - delta <= tol_epa) {
      refined = f;
      break;  // converged
    }
    if (it >= kEpaMaxIterations) {
      st.converged = false;
      st.stop = "EPA iteration cap";
      break;
    }
    ++st.epa_iterations;
    // f is the nearest face: a new face nearer than it means rounding has bent the polytope
    if (!E.expand(f, w, delta - tol_epa, eps_visible)) {
      st.converged = false;
      st.stop = "EPA polytope damaged";
      break;  // rounding would damage the polytope (left as it was): keep the best face so far
    }
  }
  if (best < 0) {
    st.converged = false;
    st.stop = "EPA polytope damaged";
    return rounded(fallback);
  }

  // the shift tilts g by c . n: among the faces that could still be the best without it, the one
  // whose normal n supports the unshifted D best, by g(n) = n . s_D(-n) (one support each; a
  // near-tie of two facets would otherwise cost up to |c| of gap)
  double gap = -E.faces[best].delta - c.dot(E.faces[best].m);
  const double reach = 2.0 * c.norm();
  if (reach > 0.0) {
    const double limit = E.faces[best].delta + reach;
    int chosen = best;
    double g_best = -kInf;
    for (std::size_t k = 0; k < E.faces.size(); ++k) {
      const Face& G = E.faces[k];
      if (!(G.alive || static_cast<int>(k) == best) || !(G.delta <= limit)) continue;
      const double g = -G.m.dot(support_of_difference(a, r_a, b, r_b, G.m, zero).z);
      if (g > g_best) g_best = g, chosen = static_cast<int>(k);
    }
    // g(n) is a lower bound; for EPA's own closest face, converged, gap (above) bounds the signed
    // distance from above to within the tolerance: then the middle of the two
    gap = chosen == best && gap >= g_best ? 0.5 * (gap + g_best) : g_best;
    best = chosen;
  }

  // the witnesses: from the face that the ray from the origin of D' through z*' = gap n - c (n = -m)
  // leaves by (walk), expanded like EPA's nearest face until within EPA's tolerance and walked again
  // (docs/conventions.md, "Contacts", GJK/EPA)
  const Vec3 m_best = E.faces[best].m;
  const Vec3 ray = -gap * m_best - c;
  st.shift = c.norm();
  double nearest = kInf;  // the floor for expansions: no face may come nearer than this
  for (const Face& G : E.faces)
    if (G.alive) nearest = std::min(nearest, G.delta);
  int at = best;
  double l[3];
  bool walked = E.walk(ray, at, l);
  for (int k = 0; walked && at != refined && k < kWitnessExpansions; ++k) {
    const Face& G = E.faces[at];
    const Vertex w = support_of_difference(a, r_a, b, r_b, G.m, c);
    if (G.m.dot(w.z) - G.delta <= tol_epa) break;
    const int before = at;
    const double kept[3] = {l[0], l[1], l[2]};
    if (!E.expand(at, w, nearest - tol_epa, eps_visible)) break;  // left as it was: keep `at`
    ++st.epa_iterations;
    at = static_cast<int>(E.faces.size()) - 1;  // a new face, next to the ray
    walked = E.walk(ray, at, l);
    if (!walked) {
      at = before;
      l[0] = kept[0], l[1] = kept[1], l[2] = kept[2];
      walked = true;
      break;
    }
  }
  double l0 = l[0], l1 = l[1], l2 = l[2];
  if (!walked) {
    // a damaged polytope: the origin projected onto the chosen face, clamped into it
    at = best;
    const Face& G = E.faces[best];
    const Vec3& z0 = E.verts[G.v[0]].z;
    const Vec3& z1 = E.verts[G.v[1]].z;
    const Vec3& z2 = E.verts[G.v[2]].z;
    const Vec3 p = G.delta * G.m;
    l0 = std::max((z1 - p).cross(z2 - p).dot(G.m), 0.0);
    l1 = std::max((z2 - p).cross(z0 - p).dot(G.m), 0.0);
    l2 = std::max((z0 - p).cross(z1 - p).dot(G.m), 0.0);
  }
  const double sum = l0 + l1 + l2;
  if (sum > 0.0) l0 /= sum, l1 /= sum, l2 /= sum;
  else l0 = 1.0, l1 = l2 = 0.0;
  const Face& W = E.faces[at];
  const Vertex& V0 = E.verts[W.v[0]];
  const Vertex& V1 = E.verts[W.v[1]];
  const Vertex& V2 = E.verts[W.v[2]];
  Distance d;
  d.gap = gap;
  d.normal = -m_best;
  d.w_a = l0 * V0.a + l1 * V1.a + l2 * V2.a;
  d.w_b = l0 * V0.b + l1 * V1.b + l2 * V2.b;
  return rounded(d);
}

}  // namespace signorini::collision
