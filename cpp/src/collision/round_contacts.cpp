// Pairs with a capsule or a cylinder. Capsules are segments with a radius, so their pairs are exact
// closest-point problems (Ericson, Real-Time Collision Detection, 5.1.9) plus separating axes when a
// segment enters a polytope. Cylinders have no such closed form against boxes, hulls, capsules or
// other cylinders: the signed distance comes from their support mappings by GJK and EPA
// (gjk_epa.hpp, which says why not FCL's), and the manifold from the supporting features of both
// shapes along its normal.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "collision/collision.hpp"
#include "collision/gjk_epa.hpp"

namespace signorini::collision {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = 3.14159265358979323846;

/// Closest points of segments P0 P1 and Q0 Q1: parameters s, t in [0, 1].
void closest_segments(const Vec3& P0, const Vec3& P1, const Vec3& Q0, const Vec3& Q1, double& s, double& t) {
  const Vec3 d1 = P1 - P0, d2 = Q1 - Q0, r = P0 - Q0;
  const double a = d1.dot(d1), e = d2.dot(d2), f = d2.dot(r);
  if (a <= 0.0 && e <= 0.0) {
    s = t = 0.0;
    return;
  }
  if (a <= 0.0) {
    s = 0.0;
    t = std::clamp(f / e, 0.0, 1.0);
    return;
  }
  const double c = d1.dot(r);
  if (e <= 0.0) {
    t = 0.0;
    s = std::clamp(-c / a, 0.0, 1.0);
    return;
  }
  const double b = d1.dot(d2), denom = a * e - b * b;
  s = denom > 0.0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  t = (b * s + f) / e;
  if (t < 0.0) {
    t = 0.0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1.0) {
    t = 1.0;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
}

FeatureId segment_feature(double t, std::uint32_t part) {
  return t <= 0.0 ? feature_id(FeatureKind::Vertex, 0, part)
         : t >= 1.0 ? feature_id(FeatureKind::Vertex, 1, part)
                    : feature_id(FeatureKind::Edge, 0, part);
}

/// Closest point to x on a convex polytope's surface (x outside), in the polytope's frame.
Vec3 closest_on_polytope(const Polytope& P, const Vec3& x) {
  double best = kInf;
  Vec3 w = x;
  for (std::size_t f = 0; f < P.faces.size(); ++f) {
    const auto& loop = P.faces[f];
    const Vec3& n = P.normals[f];
    Vec3 q = x - (n.dot(x) - P.offsets[f]) * n;  // projection onto the face plane
    bool inside = true;
    for (std::size_t k = 0; k < loop.size() && inside; ++k) {
      const Vec3 a = P.vertex(loop[k]), b = P.vertex(loop[(k + 1) % loop.size()]);
      inside = (b - a).cross(n).dot(q - a) <= 0.0;
    }
    if (!inside) {
      double best_edge = kInf;
      for (std::size_t k = 0; k < loop.size(); ++k) {
        const Vec3 a = P.vertex(loop[k]), b = P.vertex(loop[(k + 1) % loop.size()]);
        const double t = std::clamp((x - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
        const Vec3 e = a + t * (b - a);
        if ((x - e).squaredNorm() < best_edge) {
          best_edge = (x - e).squaredNorm();
          q = e;
        }
      }
    }
    if ((x - q).squaredNorm() < best) {
      best = (x - q).squaredNorm();
      w = q;
    }
  }
  return w;
}

}  // namespace

void capsule_capsule(const Capsule& a, const Pose& pa, std::uint32_t part_a, const Capsule& b, const Pose& pb,
                     std::uint32_t part_b, double threshold, std::vector<Contact>& out) {
  const Vec3 ua = pa.R.col(2), ub = pb.R.col(2);
  const Vec3 P0 = pa.p - a.half_length * ua, P1 = pa.p + a.half_length * ua;
  const Vec3 Q0 = pb.p - b.half_length * ub, Q1 = pb.p + b.half_length * ub;
  const Vec3 d1 = P1 - P0, d2 = Q1 - Q0;
  const bool parallel = a.half_length > 0.0 && b.half_length > 0.0 &&
                        d1.cross(d2).norm() <= 1e-9 * d1.norm() * d2.norm();
  if (parallel) {
    // lying side by side: the two ends of the overlap of B's projection onto A
    const double s0 = (Q0 - P0).dot(d1) / d1.squaredNorm(), s1 = (Q1 - P0).dot(d1) / d1.squaredNorm();
    const double lo = std::max(0.0, std::min(s0, s1)), hi = std::min(1.0, std::max(s0, s1));
    if (hi - lo > 1e-9) {
      for (double s : {lo, hi}) {
        const Vec3 x_a = P0 + s * d1;
        const double t = std::clamp((x_a - Q0).dot(d2) / d2.squaredNorm(), 0.0, 1.0);
        Contact c = rounded_contact(x_a, a.radius, Q0 + t * d2, b.radius, pa.R.col(0), segment_feature(s, part_a),
                            segment_feature(t, part_b));
        if (c.gap < threshold) out.push_back(c);
      }
      return;
    }
  }
  double s, t;
  closest_segments(P0, P1, Q0, Q1, s, t);
  Contact c = rounded_contact(P0 + s * d1, a.radius, Q0 + t * d2, b.radius, pa.R.col(0), segment_feature(s, part_a),
                      segment_feature(t, part_b));
  if (c.gap < threshold) out.push_back(c);
}

void polytope_capsule(const Polytope& P, const Pose& pa, std::uint32_t part_a, const Capsule& cap,
                      const Pose& pb, std::uint32_t part_b, double threshold, std::vector<Contact>& out) {
  // in the polytope's frame: the capsule's core segment e0 e1
  const Mat3 Rt = pa.R.transpose();
  const Vec3 axis = Rt * pb.R.col(2);
  const Vec3 centre = Rt * (pb.p - pa.p);
  const Vec3 e0 = centre - cap.half_length * axis, e1 = centre + cap.half_length * axis;
  const Vec3 s = e1 - e0;
  const double r = cap.radius;
  // separating axes of the segment and the polytope: its faces, and its edges crossed with s
  double sep = -kInf;
  Vec3 n_sep = Vec3::UnitZ();
  int sep_edge = -1;  // the polytope edge whose axis separates best (-1: a face's)
  for (std::size_t f = 0; f < P.normals.size(); ++f) {
    const double x = std::min(P.normals[f].dot(e0), P.normals[f].dot(e1)) - P.offsets[f];
    if (x > sep) {
      sep = x;
      n_sep = P.normals[f];
    }
  }
  for (std::size_t k = 0; k < P.edges.size(); ++k) {
    const auto& edge = P.edges[k];
    Vec3 L = (P.vertex(edge.v1) - P.vertex(edge.v0)).cross(s);
    const double len = L.norm();
    if (!(len > 1e-9 * (P.vertex(edge.v1) - P.vertex(edge.v0)).norm() * s.norm())) continue;
    L /= len;
    double lo = kInf, hi = -kInf;
    for (Eigen::Index i = 0; i < P.vertices.rows(); ++i) {
      const double x = L.dot(P.vertex(static_cast<int>(i)));
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    const double slo = std::min(L.dot(e0), L.dot(e1)), shi = std::max(L.dot(e0), L.dot(e1));
    if (slo - hi > sep) {
      sep = slo - hi;
      n_sep = L;
      sep_edge = static_cast<int>(k);
    }
    if (lo - shi > sep) {
      sep = lo - shi;
      n_sep = -L;
      sep_edge = static_cast<int>(k);
    }
  }
  if (!(sep - r < threshold)) return;
  Vec3 n, w_seg;  // normal (polytope -> capsule) and the segment point nearest the polytope
  double gap;
  double t_seg;
  if (sep > 0.0) {
    // apart: the exact distance, over the segment's ends and the polytope's edges
    double best = kInf;
    Vec3 w_poly = Vec3::Zero();
    for (int k = 0; k < 2; ++k) {
      const Vec3 e = k ? e1 : e0;
      const Vec3 q = closest_on_polytope(P, e);
      if ((e - q).squaredNorm() < best) {
        best = (e - q).squaredNorm();
        w_seg = e;
        w_poly = q;
        t_seg = k;
      }
    }
    for (const auto& edge : P.edges) {
      double u, v;
      closest_segments(e0, e1, P.vertex(edge.v0), P.vertex(edge.v1), u, v);
      const Vec3 x = e0 + u * s, q = P.vertex(edge.v0) + v * (P.vertex(edge.v1) - P.vertex(edge.v0));
      if ((x - q).squaredNorm() < best) {
        best = (x - q).squaredNorm();
        w_seg = x;
        w_poly = q;
        t_seg = u;
      }
    }
    const double dist = std::sqrt(best);
    n = (w_seg - w_poly) / dist;
    gap = dist - r;
  } else {
    // the segment enters the polytope: the separating axis of least penetration. On a face's axis
    // the segment's deepest end touches; on an edge's (edge x s), the segment crosses the edge, and
    // the point is where the two lines are closest (on both, for the best of a complete set of axes;
    // the segment's end there would lie up to its length off the polytope)
    n = n_sep;
    gap = sep - r;
    t_seg = n.dot(e0) <= n.dot(e1) ? 0.0 : 1.0;
    if (sep_edge >= 0) {
      double v;
      const auto& edge = P.edges[static_cast<std::size_t>(sep_edge)];
      closest_segments(e0, e1, P.vertex(edge.v0), P.vertex(edge.v1), t_seg, v);
    }
    w_seg = e0 + t_seg * s;
  }
  // lying on a face: the segment clipped to that face gives up to two points
  std::size_t face = 0;
  for (std::size_t f = 1; f < P.normals.size(); ++f)
    if (P.normals[f].dot(n) > P.normals[face].dot(n)) face = f;
  const Vec3& nf = P.normals[face];
  const double offset = P.offsets[face];
  auto emit = [&](const Vec3& x, const Vec3& nn, double g, FeatureId fa, FeatureId fb) {
    Contact c;
    const Vec3 w_b = x - r * nn;
    c.point = pa.R * (w_b - 0.5 * g * nn) + pa.p;
    c.normal = pa.R * nn;
    c.gap = g;
    c.feature_a = fa;
    c.feature_b = fb;
    if (c.gap < threshold) out.push_back(c);
  };
  if (nf.dot(n) >= 1.0 - 1e-8 && std::abs(nf.dot(s)) <= 0.1 * s.norm() + 1e-300) {
    double t0 = 0.0, t1 = 1.0;
    int side0 = -1, side1 = -1;
    const auto& loop = P.faces[face];
    for (std::size_t k = 0; k < loop.size(); ++k) {
      const Vec3 a = P.vertex(loop[k]), b = P.vertex(loop[(k + 1) % loop.size()]);
      const Vec3 m = (b - a).cross(nf);
      const double d0 = m.dot(e0 - a), d1 = m.dot(e1 - a);
      if (d0 > 0.0 && d1 > 0.0) {
        t0 = 1.0;
        t1 = 0.0;
        break;
      }
      if (d0 > 0.0) {
        const double t = d0 / (d0 - d1);
        if (t > t0) t0 = t, side0 = static_cast<int>(k);
      } else if (d1 > 0.0) {
        const double t = d0 / (d0 - d1);
        if (t < t1) t1 = t, side1 = static_cast<int>(k);
      }
    }
    if (t1 - t0 > 1e-9) {
      const auto& face_edges = P.face_edges[face];
      for (int end = 0; end < 2; ++end) {
        const double t = end ? t1 : t0;
        const int side = end ? side1 : side0;
        const Vec3 x = e0 + t * s;
        const FeatureId fa = side < 0 ? feature_id(FeatureKind::Face, static_cast<std::uint32_t>(face), part_a)
                                      : feature_id(FeatureKind::Edge, face_edges[side], part_a);
        emit(x, nf, nf.dot(x) - offset - r, fa, segment_feature(t, part_b));
      }
      return;
    }
  }
  emit(w_seg, n, gap, feature_id(FeatureKind::Shape, 0, part_a), segment_feature(t_seg, part_b));
}

namespace {
constexpr double kFaceCos = 0.995;  // a face within ~5.7 degrees of the normal supports as a face
// A cylinder's side (its generator line), and a polytope's edge beside one, within ~11.5 degrees
// of square to the normal support as a segment: both its ends become points of the manifold, the
// far one speculative, so that a side rocking on a side is caught at both ends (a capsule's side
// keeps the face's 5.7 degrees)
constexpr double kSideSin = 0.2;
}  // namespace

void support_feature(const Item& it, const Vec3& dir, SupportFeature& s) {
  s.points.clear();
  s.ids.clear();
  s.normal = Vec3::Zero();
  s.is_face = false;
  const Mat3& R = it.pose.R;
  const Vec3& p = it.pose.p;
  if (it.polytope) {
    const Polytope& P = *it.polytope;
    const Vec3 d = R.transpose() * dir;
    std::size_t face = 0;
    for (std::size_t f = 1; f < P.normals.size(); ++f)
      if (P.normals[f].dot(d) > P.normals[face].dot(d)) face = f;
    if (P.normals[face].dot(d) >= kFaceCos) {
      for (int v : P.faces[face]) {
        s.points.push_back(R * P.vertex(v) + p);
        s.ids.push_back(feature_id(FeatureKind::Vertex, v, it.part));
      }
      s.normal = R * P.normals[face];
      s.is_face = true;
      return;
    }
    int best = 0;
    for (Eigen::Index i = 1; i < P.vertices.rows(); ++i)
      if (P.vertex(static_cast<int>(i)).dot(d) > P.vertex(best).dot(d)) best = static_cast<int>(i);
    s.points.push_back(R * P.vertex(best) + p);
    s.ids.push_back(feature_id(FeatureKind::Vertex, best, it.part));
    return;
  }
  const Vec3 a = R.col(2);
  const double c = a.dot(dir);
  Vec3 u = dir - c * a;
  const double u_norm = u.norm();
  u = u_norm > 1e-12 ? Vec3(u / u_norm) : Vec3(R.col(0));
  if (const Cylinder* cyl = it.cylinder) {
    const int cap = c >= 0.0 ? 1 : 0;
    const Vec3 centre = p + (cap ? 1.0 : -1.0) * cyl->half_height * a;
    if (std::abs(c) >= kFaceCos) {
      for (int k = 0; k < 8; ++k) {
        const int kk = cap ? k : 7 - k;  // counter-clockwise seen from outside
        const double phi = kk * kPi / 4.0;
        s.points.push_back(centre + cyl->radius * (std::cos(phi) * R.col(0) + std::sin(phi) * R.col(1)));
        s.ids.push_back(feature_id(FeatureKind::Vertex, 8 * cap + kk, it.part));
      }
      s.normal = (cap ? 1.0 : -1.0) * a;
      s.is_face = true;
    } else if (std::abs(c) <= kSideSin) {
      for (int end = 0; end < 2; ++end) {
        s.points.push_back(p + (end ? 1.0 : -1.0) * cyl->half_height * a + cyl->radius * u);
        s.ids.push_back(feature_id(FeatureKind::Vertex, 16 + end, it.part));
      }
    } else {
      s.points.push_back(centre + cyl->radius * u);
      s.ids.push_back(feature_id(FeatureKind::Edge, cap, it.part));
    }
  } else if (const Capsule* capsule = it.capsule) {
    const Vec3 d = dir.normalized();
    if (std::abs(c) <= 1.0 - kFaceCos && capsule->half_length > 0.0) {
      for (int end = 0; end < 2; ++end) {
        s.points.push_back(p + (end ? 1.0 : -1.0) * capsule->half_length * a + capsule->radius * d);
        s.ids.push_back(feature_id(FeatureKind::Vertex, end, it.part));
      }
    } else {
      const int end = c >= 0.0 ? 1 : 0;
      s.points.push_back(p + (end ? 1.0 : -1.0) * capsule->half_length * a + capsule->radius * d);
      s.ids.push_back(feature_id(FeatureKind::Vertex, end, it.part));
    }
  } else if (const Sphere* sphere = it.sphere) {
    s.points.push_back(p + sphere->radius * dir.normalized());
    s.ids.push_back(feature_id(FeatureKind::Shape, 0, it.part));
  } else {
    throw std::logic_error(std::string("support_feature: no support mapping for a ") + item_kind_name(it.kind) + " item");
  }
}

/// The point of item `it` farthest along unit direction d (world): its support mapping.
Vec3 support_point(const Item& it, const Vec3& d) {
  const Mat3& R = it.pose.R;
  const Vec3& p = it.pose.p;
  if (it.sphere) return p + it.sphere->radius * d;
  if (it.capsule) return p + (R.col(2).dot(d) >= 0.0 ? 1.0 : -1.0) * it.capsule->half_length * R.col(2) + it.capsule->radius * d;
  if (it.cylinder) {
    // the rim point along d's part normal to the axis, from the body's x y coordinates: d - (a.d) a
    // keeps a rounding residue along a that a small |u| blows up (docs/conventions.md, "Contacts")
    const Vec3 a = R.col(2);
    const double c = a.dot(d), x = R.col(0).dot(d), y = R.col(1).dot(d);
    // |x|, |y| <= 1: no overflow, so no std::hypot; below 1e-154 un is 0 and the cap's centre (a
    // support point to that precision) is returned
    const double un = std::sqrt(x * x + y * y);
    const Vec3 centre = p + (c >= 0.0 ? 1.0 : -1.0) * it.cylinder->half_height * a;
    return un > 0.0 ? Vec3(centre + (it.cylinder->radius / un) * (x * R.col(0) + y * R.col(1))) : centre;
  }
  if (!it.polytope)
    throw std::logic_error(std::string("support_point: no support mapping for a ") + item_kind_name(it.kind) + " item");
  const Polytope& P = *it.polytope;
  const Vec3 dl = R.transpose() * d;
  int best = 0;
  for (Eigen::Index i = 1; i < P.vertices.rows(); ++i)
    if (P.vertex(static_cast<int>(i)).dot(dl) > P.vertex(best).dot(dl)) best = static_cast<int>(i);
  return R * P.vertex(best) + p;
}

void clip_features(const SupportFeature& ref, const SupportFeature& inc, bool ref_is_a, std::uint32_t ref_part,
                   std::uint32_t inc_part, double threshold, Scratch& scratch, std::vector<Contact>& out) {
  const Vec3& n_ref = ref.normal;
  const double d_ref = n_ref.dot(ref.points[0]);
  // the incident feature clipped by the reference face's side planes (side k: internal id 256 + k)
  auto& poly = scratch.clip;
  auto& next = scratch.clip_next;
  poly.clear();
  for (std::size_t i = 0; i < inc.points.size(); ++i)
    poly.push_back({inc.points[i], {feature_id(FeatureKind::Face, 0, ref_part), inc.ids[i]}});
  const std::size_t m = ref.points.size();
  for (std::size_t k = 0; k < m && !poly.empty(); ++k) {
    const Vec3 side = (ref.points[(k + 1) % m] - ref.points[k]).cross(n_ref).normalized();
    const double c = side.dot(ref.points[k]);
    next.clear();
    const std::size_t np = poly.size();
    const std::size_t sides = np == 2 ? 1 : np;  // a segment has one side, a point none
    for (std::size_t i = 0; i < np; ++i) {
      const auto& P = poly[i];
      const double dP = side.dot(P.first) - c;
      if (dP <= 0.0) next.push_back(P);
      if (i >= sides || np == 1) continue;
      const auto& Q = poly[(i + 1) % np];
      const double dQ = side.dot(Q.first) - c;
      if ((dP <= 0.0) != (dQ <= 0.0))
        next.push_back({P.first + (dP / (dP - dQ)) * (Q.first - P.first),
                        {feature_id(FeatureKind::Edge, 256 + static_cast<std::uint32_t>(k), ref_part),
                         feature_id(FeatureKind::Edge, 256 + static_cast<std::uint32_t>(i), inc_part)}});
    }
    std::swap(poly, next);
  }
  for (const auto& [q, ids] : poly) {
    const double gap = n_ref.dot(q) - d_ref;
    if (!(gap < threshold)) continue;
    Contact c;
    c.point = q - 0.5 * gap * n_ref;
    c.normal = ref_is_a ? n_ref : Vec3(-n_ref);
    c.gap = gap;
    c.feature_a = ref_is_a ? ids.first : ids.second;
    c.feature_b = ref_is_a ? ids.second : ids.first;
    out.push_back(c);
  }
}

namespace {

/// A segment of an item's surface: its ends (world, m) and their feature ids.
struct Side {
  Vec3 end[2];
  FeatureId id[2];
};

/// d's part in the plane square to the unit n.
Vec3 in_plane(const Vec3& d, const Vec3& n) { return d - d.dot(n) * n; }

/// The edge of polytope item `it` at its supporting vertex (feature id `vertex`) that runs most
/// nearly along the unit in-plane direction `along` (square to n), if it is within kSideSin of
/// square to n and of parallel to `along`: the supporting vertex of a box whose edge lies along a
/// cylinder's side.
bool polytope_side(const Item& it, FeatureId vertex, const Vec3& n, const Vec3& along, Side& side) {
  if (feature_kind(vertex) != FeatureKind::Vertex) return false;
  const Polytope& P = *it.polytope;
  const Mat3& R = it.pose.R;
  const int v = static_cast<int>(feature_index(vertex));
  double best = kSideSin;
  bool found = false;
  for (const Polytope::Edge& e : P.edges) {
    if (e.v0 != v && e.v1 != v) continue;
    const int w = e.v0 == v ? e.v1 : e.v0;
    const Vec3 d = (R * (P.vertex(w) - P.vertex(v))).normalized();
    const double off_plane = std::abs(d.dot(n));
    const double across = in_plane(d, n).cross(along).norm();  // sin of the in-plane angle (times |d's part|)
    if (off_plane <= kSideSin && across <= best) {
      best = across;
      side.end[0] = R * P.vertex(v) + it.pose.p;
      side.end[1] = R * P.vertex(w) + it.pose.p;
      side.id[0] = feature_id(FeatureKind::Vertex, static_cast<std::uint32_t>(v), it.part);
      side.id[1] = feature_id(FeatureKind::Vertex, static_cast<std::uint32_t>(w), it.part);
      found = true;
    }
  }
  return found;
}

}  // namespace

bool side_on_side(const Item& a, const Item& b, const SupportFeature& sa, const SupportFeature& sb, const Vec3& n,
                  double threshold, std::vector<Contact>& out) {
  // (written here: FCL and libccd give one point for a pair of convex shapes; a side lying along a
  // side needs both ends of their overlap, as a face's clip gives a face's corners)
  const bool seg_a = sa.points.size() == 2, seg_b = sb.points.size() == 2;
  if (!seg_a && !seg_b) return false;
  // the reference: a straight side of a cylinder or capsule (A's when both are), whose tangent
  // plane along it is square to n to within kSideSin; the incident: the other side or edge
  const bool ref_is_a = seg_a;
  const SupportFeature& s = ref_is_a ? sa : sb;
  Side ref{{s.points[0], s.points[1]}, {s.ids[0], s.ids[1]}}, inc;
  const Vec3 along = in_plane(ref.end[1] - ref.end[0], n);
  const double length = along.norm();
  if (!(length > 0.0)) return false;
  const Vec3 e = along / length;
  const SupportFeature& o = ref_is_a ? sb : sa;
  if (o.points.size() == 2) {
    inc = Side{{o.points[0], o.points[1]}, {o.ids[0], o.ids[1]}};
    if (in_plane((inc.end[1] - inc.end[0]).normalized(), n).cross(e).norm() > kSideSin) return false;
  } else {
    const Item& other = ref_is_a ? b : a;
    if (!other.polytope || o.points.size() != 1 || !polytope_side(other, o.ids[0], n, e, inc)) return false;
  }
  // the incident side clipped to the reference's extent along e, [0, length]; each clipped point q
  // (on the incident body) a contact with the reference body's surface point nearest to it, along
  // the surface's normal there (the radial direction of the cylinder's or capsule's axis): both
  // witnesses lie on their shapes, and the gap is q's distance (signed) from the reference
  const double t0 = e.dot(inc.end[0] - ref.end[0]), t1 = e.dot(inc.end[1] - ref.end[0]);
  const double L = a.radius() + b.radius();
  if (!(std::abs(t1 - t0) > 1e-9 * L)) return false;  // an edge square to the side: one point
  const double lo = std::max(0.0, std::min(t0, t1)), hi = std::min(length, std::max(t0, t1));
  if (!(hi - lo > 1e-9 * L)) return false;
  const Item& round = ref_is_a ? a : b;
  const Vec3 axis = round.pose.R.col(2);
  const double radius = round.cylinder ? round.cylinder->radius : round.capsule->radius;
  const double half = round.cylinder ? round.cylinder->half_height : round.capsule->half_length;
  const std::size_t first = out.size();
  for (const double t : {lo, hi}) {
    const double u = (t - t0) / (t1 - t0), w = t / length;
    const Vec3 q = inc.end[0] + u * (inc.end[1] - inc.end[0]);
    const double z = axis.dot(q - round.pose.p);
    if (round.cylinder && std::abs(z) > half) continue;  // beyond the cylinder's side (a rim)
    const Vec3 core = round.pose.p + std::clamp(z, -half, half) * axis;
    const Vec3 rho = q - core;
    const double distance = rho.norm();
    // (q on the axis: the pair's normal, a deep point whose direction is lost)
    const Vec3 out_dir = distance > 1e-12 * L ? Vec3(rho / distance) : Vec3(ref_is_a ? n : Vec3(-n));
    const double gap = distance - radius;
    if (!(gap < threshold)) continue;
    const Vec3 on_ref = core + radius * out_dir;
    Contact c;
    c.normal = ref_is_a ? out_dir : Vec3(-out_dir);
    c.gap = gap;
    c.point = on_ref + 0.5 * gap * out_dir;
    const FeatureId ref_id = ref.id[w < 0.5 ? 0 : 1], inc_id = inc.id[u < 0.5 ? 0 : 1];
    c.feature_a = ref_is_a ? ref_id : inc_id;
    c.feature_b = ref_is_a ? inc_id : ref_id;
    out.push_back(c);
  }
  return out.size() > first;
}

void convex_by_support(const Item& a, const Item& b, double threshold, Scratch& scratch, std::vector<Contact>& out) {
  convex_by_support(a, b, gjk_epa(a, b, *scratch.epa), threshold, scratch, out);
}

void convex_by_support(const Item& a, const Item& b, const Distance& dist, double threshold, Scratch& scratch,
                       std::vector<Contact>& out) {
  if (!(dist.gap < threshold)) return;
  const Vec3 n = dist.normal;
  SupportFeature& sa = scratch.feature_a;
  SupportFeature& sb = scratch.feature_b;
  support_feature(a, n, sa);
  support_feature(b, -n, sb);
  const bool ref_is_a = sa.is_face && (!sb.is_face || sa.normal.dot(n) >= -sb.normal.dot(n));
  const std::size_t first = out.size();
  if (!sa.is_face && !sb.is_face && !side_on_side(a, b, sa, sb, n, threshold, out)) {
    // no face on either side and not two sides along each other (edge across edge, a rim against
    // a rim): the single point of the distance
    Contact c;
    c.normal = n;
    c.gap = dist.gap;
    c.point = 0.5 * (dist.w_a + dist.w_b);
    c.feature_a = sa.ids.size() == 1 ? sa.ids[0] : feature_id(FeatureKind::Shape, 0, a.part);
    c.feature_b = sb.ids.size() == 1 ? sb.ids[0] : feature_id(FeatureKind::Shape, 0, b.part);
    out.push_back(c);
    return;
  }
  if (sa.is_face || sb.is_face)
    clip_features(ref_is_a ? sa : sb, ref_is_a ? sb : sa, ref_is_a, ref_is_a ? a.part : b.part,
                  ref_is_a ? b.part : a.part, threshold, scratch, out);
  double least = std::numeric_limits<double>::infinity();
  for (std::size_t k = first; k < out.size(); ++k) least = std::min(least, out[k].gap);
  const double L = a.radius() + b.radius();
  if (out.size() == first || dist.gap < least - 1e-9 * L) {
    // the incident feature misses the reference face (a rim over an edge), or the clipped points,
    // sampled on rims, miss the deepest point: the support point pair joins the manifold
    Contact c;
    c.normal = n;
    c.gap = dist.gap;
    c.point = 0.5 * (dist.w_a + dist.w_b);
    c.feature_a = feature_id(FeatureKind::Shape, 0, a.part);
    c.feature_b = feature_id(FeatureKind::Shape, 0, b.part);
    out.push_back(c);
  }
}

}  // namespace signorini::collision
