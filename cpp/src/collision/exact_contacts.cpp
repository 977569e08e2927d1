// Contacts computed exactly by hand: against a plane, one dot product per feature; a sphere against
// anything, the closest point to its centre (why not FCL's: docs/conventions.md, "Contacts").
#include <algorithm>
#include <cmath>
#include <type_traits>
#include <limits>
#include <stdexcept>
#include <variant>

#include "collision/collision.hpp"

namespace signorini::collision {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// The contact of world point x (on B) against the plane n . x = offset (A).
void point_on_plane(const Vec3& n, double offset, const Vec3& x, FeatureId id_b, std::vector<Contact>& out) {
  Contact c;
  c.normal = n;
  c.gap = n.dot(x) - offset;
  c.point = x - 0.5 * c.gap * n;  // midpoint of w_B = x and w_A = x - gap n
  c.feature_a = feature_id(FeatureKind::Face, 0);
  c.feature_b = id_b;
  out.push_back(c);
}

/// Closest point to x on triangle (a, b, c): the Voronoi-region walk of Ericson, Real-Time
/// Collision Detection, section 5.1.5.
Vec3 closest_on_triangle(const Vec3& x, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ax = x - a;
  const double d1 = ab.dot(ax), d2 = ac.dot(ax);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Vec3 bx = x - b;
  const double d3 = ab.dot(bx), d4 = ac.dot(bx);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + d1 / (d1 - d3) * ab;
  const Vec3 cx = x - c;
  const double d5 = ab.dot(cx), d6 = ac.dot(cx);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

/// The contact of a sphere (centre c_l, radius r, in the shape's frame) with a shape at pose,
/// from the shape-frame normal n_l (shape -> sphere), the shape's witness w_shape and the gap.
void shape_sphere(const Pose& pose, const Vec3& c_l, double r, const Vec3& n_l, const Vec3& w_shape, double gap,
                  FeatureId id_shape, std::vector<Contact>& out) {
  Contact c;
  c.normal = pose.R * n_l;
  c.gap = gap;
  c.point = pose.R * (0.5 * (w_shape + (c_l - r * n_l))) + pose.p;
  c.feature_a = id_shape;
  c.feature_b = feature_id(FeatureKind::Shape, 0);
  out.push_back(c);
}

/// Convex polytope against a sphere centre c_l (polytope frame): outside, the closest point over
/// the triangles; inside, out through the face plane of largest signed distance (first on ties).
template <class Triangles>
void polytope_sphere(const Pose& pose, const Polytope& P, const Triangles& each_triangle, const Vec3& c_l,
                     double r, std::uint32_t part, std::vector<Contact>& out) {
  double outermost = -std::numeric_limits<double>::infinity();
  std::size_t face = 0;
  for (std::size_t f = 0; f < P.normals.size(); ++f) {
    const double d = P.normals[f].dot(c_l) - P.offsets[f];
    if (d > outermost) {
      outermost = d;
      face = f;
    }
  }
  const FeatureId id = feature_id(FeatureKind::Shape, 0, part);
  if (outermost <= 0.0) {
    const Vec3& n = P.normals[face];
    shape_sphere(pose, c_l, r, n, c_l - outermost * n, outermost - r, id, out);
    return;
  }
  double best = std::numeric_limits<double>::infinity();
  Vec3 w = Vec3::Zero();
  each_triangle([&](const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 q = closest_on_triangle(c_l, a, b, c);
    const double d2 = (c_l - q).squaredNorm();
    if (d2 < best) {
      best = d2;
      w = q;
    }
  });
  const double dist = std::sqrt(best);
  shape_sphere(pose, c_l, r, (c_l - w) / dist, w, dist - r, id, out);
}

}  // namespace

void plane_item(const Vec3& n, double offset, const Item& b, std::vector<Contact>& out) {
  const Pose& pb = b.pose;
  const std::uint32_t part = b.part;
  if (b.sphere) {
    point_on_plane(n, offset, pb.p - b.sphere->radius * n, feature_id(FeatureKind::Shape, 0, part), out);
  } else if (b.box) {
    const Vec3& h = b.box->half_extents;
    for (int k = 0; k < 8; ++k) {
      const Vec3 corner((k & 1) ? h.x() : -h.x(), (k & 2) ? h.y() : -h.y(), (k & 4) ? h.z() : -h.z());
      point_on_plane(n, offset, pb.R * corner + pb.p, feature_id(FeatureKind::Vertex, k, part), out);
    }
  } else if (b.capsule) {
    const Vec3 a = pb.R.col(2);
    for (int k = 0; k < 2; ++k) {
      const Vec3 end = pb.p + (k ? 1.0 : -1.0) * b.capsule->half_length * a;
      point_on_plane(n, offset, end - b.capsule->radius * n, feature_id(FeatureKind::Vertex, k, part), out);
    }
  } else if (b.cylinder) {
    const Vec3 a = pb.R.col(2);
    const Vec3 u = -n + n.dot(a) * a;  // towards the plane, across the axis
    const double u_norm = u.norm();
    for (int s = 0; s < 2; ++s) {
      const Vec3 centre = pb.p + (s ? 1.0 : -1.0) * b.cylinder->half_height * a;
      for (int k = 0; k < 8; ++k) {
        const double phi = k * kPi / 4.0;
        const Vec3 rim = centre + b.cylinder->radius * (std::cos(phi) * pb.R.col(0) + std::sin(phi) * pb.R.col(1));
        point_on_plane(n, offset, rim, feature_id(FeatureKind::Vertex, 8 * s + k, part), out);
      }
      if (u_norm > 1e-12)
        point_on_plane(n, offset, centre + b.cylinder->radius * u / u_norm, feature_id(FeatureKind::Edge, s, part), out);
    }
  } else if (b.polytope) {
    const Polytope& P = *b.polytope;
    for (Eigen::Index i = 0; i < P.vertices.rows(); ++i)
      point_on_plane(n, offset, pb.R * P.vertex(static_cast<int>(i)) + pb.p,
                     feature_id(FeatureKind::Vertex, static_cast<std::uint32_t>(i), part), out);
  } else {
    throw std::logic_error(std::string("plane_item: no plane test for a ") + item_kind_name(b.kind) + " item");
  }
}

void plane_contacts(const Plane& plane, const Pose& pa, const Shape& b, const Pose& pb, double threshold,
                    Scratch& scratch, std::vector<Contact>& out) {
  (void)threshold;  // the manifold filters; kept for symmetry with the other pair tests
  const Vec3 n = pa.R * plane.normal;
  const double offset = plane.offset + n.dot(pa.p);
  if (const auto* mesh = std::get_if<Mesh>(&b)) {
    for (Eigen::Index i = 0; i < mesh->vertices.rows(); ++i)
      point_on_plane(n, offset, pb.R * mesh->vertex(i) + pb.p,
                     feature_id(FeatureKind::Vertex, static_cast<std::uint32_t>(i)), out);
  } else {
    std::vector<std::shared_ptr<const Polytope>> keep;  // stays empty: the world prepares meshes
    scratch.items_b.clear();
    items_of(b, pb, scratch.items_b, keep);
    for (const Item& it : scratch.items_b) plane_item(n, offset, it, out);
  }
}

Contact rounded_contact(const Vec3& x_a, double r_a, const Vec3& x_b, double r_b, const Vec3& n_hint,
                        FeatureId fa, FeatureId fb) {
  const Vec3 d = x_b - x_a;
  const double dist = d.norm();
  Contact c;
  c.normal = dist > 0.0 ? Vec3(d / dist) : n_hint;
  c.gap = dist - r_a - r_b;
  c.point = 0.5 * ((x_a + r_a * c.normal) + (x_b - r_b * c.normal));
  c.feature_a = fa;
  c.feature_b = fb;
  return c;
}

void sphere_sphere(const Vec3& c_a, double r_a, const Vec3& c_b, double r_b, std::vector<Contact>& out) {
  // coincident centres have no direction: +z, as any unit vector is a valid normal there
  out.push_back(rounded_contact(c_a, r_a, c_b, r_b, Vec3::UnitZ(), feature_id(FeatureKind::Shape, 0),
                                feature_id(FeatureKind::Shape, 0)));
}

void item_sphere(const Item& item, const Vec3& c, double r, std::vector<Contact>& out) {
  const Pose& pa = item.pose;
  const std::uint32_t part = item.part;
  const Vec3 c_l = pa.R.transpose() * (c - pa.p);
  const FeatureId id = feature_id(FeatureKind::Shape, 0, part);
  if (const Sphere* s = item.sphere) {
    sphere_sphere(pa.p, s->radius, c, r, out);
    out.back().feature_a = id;
  } else if (const Box* box = item.box) {
    // the centre clamped into the box, or out through the nearest face if inside (lowest axis on ties)
    const Vec3& h = box->half_extents;
    const Vec3 q = c_l.cwiseMax(-h).cwiseMin(h);
    if (q != c_l) {
      const double dist = (c_l - q).norm();
      shape_sphere(pa, c_l, r, (c_l - q) / dist, q, dist - r, id, out);
      return;
    }
    int k = 0;
    for (int axis = 1; axis < 3; ++axis)
      if (h[axis] - std::abs(c_l[axis]) < h[k] - std::abs(c_l[k])) k = axis;
    const double sign = c_l[k] < 0.0 ? -1.0 : 1.0;
    Vec3 n_l = Vec3::Zero(), w = c_l;
    n_l[k] = sign;
    w[k] = sign * h[k];
    shape_sphere(pa, c_l, r, n_l, w, -(h[k] - std::abs(c_l[k])) - r, id, out);
  } else if (const Capsule* cap = item.capsule) {
    // the closest point of the segment on the z axis, t in [0, 1] from -h to +h
    const double h = cap->half_length;
    const double t = h > 0.0 ? std::clamp((c_l.z() + h) / (2.0 * h), 0.0, 1.0) : 0.0;
    const Vec3 q(0.0, 0.0, -h + 2.0 * h * t);
    const double dist = (c_l - q).norm();
    const Vec3 n_l = dist > 0.0 ? Vec3((c_l - q) / dist) : Vec3::UnitX();
    const FeatureId fid = t <= 0.0 ? feature_id(FeatureKind::Vertex, 0, part)
                          : t >= 1.0 ? feature_id(FeatureKind::Vertex, 1, part)
                                     : feature_id(FeatureKind::Edge, 0, part);
    shape_sphere(pa, c_l, r, n_l, q + cap->radius * n_l, dist - cap->radius - r, fid, out);
  } else if (const Cylinder* cyl = item.cylinder) {
    const double R = cyl->radius, h = cyl->half_height;
    const double rho = std::hypot(c_l.x(), c_l.y());
    const Vec3 radial = rho > 0.0 ? Vec3(c_l.x() / rho, c_l.y() / rho, 0.0) : Vec3::UnitX();
    if (rho <= R && std::abs(c_l.z()) <= h) {
      // inside: out through the side or the nearer cap, whichever is closer (the cap on ties)
      if (h - std::abs(c_l.z()) <= R - rho) {
        const Vec3 n_l(0.0, 0.0, c_l.z() < 0.0 ? -1.0 : 1.0);
        shape_sphere(pa, c_l, r, n_l, Vec3(c_l.x(), c_l.y(), n_l.z() * h), -(h - std::abs(c_l.z())) - r, id, out);
      } else {
        shape_sphere(pa, c_l, r, radial, Vec3(R * radial.x(), R * radial.y(), c_l.z()), -(R - rho) - r, id, out);
      }
      return;
    }
    const Vec3 q(rho > R ? R * radial.x() : c_l.x(), rho > R ? R * radial.y() : c_l.y(), std::clamp(c_l.z(), -h, h));
    const double dist = (c_l - q).norm();
    shape_sphere(pa, c_l, r, (c_l - q) / dist, q, dist - r, id, out);
  } else if (const ConvexHull* hull = item.hull) {
    polytope_sphere(pa, *hull->polytope, [&](auto&& f) {
      for (Eigen::Index k = 0; k < hull->faces.rows(); ++k)
        f(hull->vertex(hull->faces(k, 0)), hull->vertex(hull->faces(k, 1)), hull->vertex(hull->faces(k, 2)));
    }, c_l, r, part, out);
  } else if (const Polytope* P = item.polytope) {
    // a mesh piece: its polygon faces fanned into triangles
    polytope_sphere(pa, *P, [&](auto&& f) {
      for (const auto& loop : P->faces)
        for (std::size_t k = 1; k + 1 < loop.size(); ++k) f(P->vertex(loop[0]), P->vertex(loop[k]), P->vertex(loop[k + 1]));
    }, c_l, r, part, out);
  } else {
    throw std::logic_error(std::string("item_sphere: no sphere test for a ") + item_kind_name(item.kind) + " item");
  }
}

}  // namespace signorini::collision
