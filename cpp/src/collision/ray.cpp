// Ray casts and point tests against one shape (ray.hpp). Each convex test works in the item's own
// frame (o_l = R^T (o - p), u_l = R^T u: t is the same in both frames) and returns the entry t, or
// "inside" for an origin strictly inside the solid. An origin on the surface enters at t = 0 when
// u points in, and misses when u points out or along it.
#include "collision/ray.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <variant>

namespace signorini::collision {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Local-frame test of one convex primitive: 0 miss, 1 hit (t, normal in the local frame,
/// feature index and kind), 2 origin inside.
enum class Local { Miss, Hit, Inside };

struct LocalHit {
  double t = 0.0;
  Vec3 n = Vec3::Zero();
  FeatureKind kind = FeatureKind::Face;
  std::uint32_t index = 0;
};

/// Sphere of radius r about c: the entry root of |o + t u - c|^2 = r^2 (a = 1, b = (o - c) . u,
/// c0 = |o - c|^2 - r^2; D = r^2 - |q|^2 with q the line's closest point to c, which keeps D exact
/// where b^2 and c0 nearly cancel).
Local ray_ball(const Vec3& o, const Vec3& u, const Vec3& c, double r, double t_max, LocalHit& h) {
  const Vec3 oc = o - c;
  const double c0 = oc.squaredNorm() - r * r;
  if (c0 < 0.0) return Local::Inside;
  const double b = oc.dot(u);
  if (b >= 0.0 && c0 > 0.0) return Local::Miss;  // outside and moving away
  if (c0 == 0.0) {  // on the surface: enters only when u points in
    if (b >= 0.0) return Local::Miss;
    h.t = 0.0;
  } else {
    const Vec3 q = oc - b * u;
    const double D = r * r - q.squaredNorm();
    if (D < 0.0) return Local::Miss;
    double t0, t1;
    quadratic_roots(1.0, b, c0, D, t0, t1);
    h.t = std::max(t0, 0.0);
  }
  if (h.t > t_max) return Local::Miss;
  h.n = (oc + h.t * u) / r;
  return Local::Hit;
}

/// Infinite cylinder x^2 + y^2 <= r^2 along z: the interval [s0, s1] of t inside it (false: none).
bool side_interval(const Vec3& o, const Vec3& u, double r, double& s0, double& s1) {
  const double a = u.x() * u.x() + u.y() * u.y();
  const double c0 = o.x() * o.x() + o.y() * o.y() - r * r;
  if (a == 0.0) {  // parallel to the axis
    if (c0 > 0.0) return false;
    s0 = -kInf, s1 = kInf;
    return true;
  }
  const double b = o.x() * u.x() + o.y() * u.y();
  const double tc = -b / a;
  const double qx = o.x() + tc * u.x(), qy = o.y() + tc * u.y();
  const double D = a * (r * r - (qx * qx + qy * qy));  // b^2 - a c0, from the closest approach
  if (D < 0.0) return false;
  quadratic_roots(a, b, c0, D, s0, s1);
  return true;
}

/// Box of half extents e: slabs; the entering face is the one whose slab is entered last.
Local ray_box(const Vec3& o, const Vec3& u, const Vec3& e, double t_max, LocalHit& h) {
  if (std::abs(o.x()) < e.x() && std::abs(o.y()) < e.y() && std::abs(o.z()) < e.z()) return Local::Inside;
  double t_in = -kInf, t_out = kInf;
  int face = -1;
  for (int i = 0; i < 3; ++i) {
    if (u[i] == 0.0) {
      if (std::abs(o[i]) > e[i]) return Local::Miss;
      continue;
    }
    double t0 = (-e[i] - o[i]) / u[i], t1 = (e[i] - o[i]) / u[i];
    int f0 = 2 * i, f1 = 2 * i + 1;  // faces at -e_i and +e_i
    if (t0 > t1) std::swap(t0, t1), std::swap(f0, f1);
    if (t0 > t_in) t_in = t0, face = f0;
    t_out = std::min(t_out, t1);
  }
  if (face < 0 || t_in < 0.0 || t_in > t_out || t_in > t_max) return Local::Miss;
  h.t = t_in;
  h.n = Vec3::Zero();
  h.n[face / 2] = (face % 2) ? 1.0 : -1.0;
  h.kind = FeatureKind::Face;
  h.index = static_cast<std::uint32_t>(face);
  return Local::Hit;
}

/// Convex polytope: the ray clipped by every face's half-space n_f . x <= d_f.
Local ray_polytope(const Polytope& P, const Vec3& o, const Vec3& u, double t_max, LocalHit& h) {
  double t_in = -kInf, t_out = kInf;
  int face = -1;
  bool inside = true;
  for (std::size_t f = 0; f < P.normals.size(); ++f) {
    const double dist = P.normals[f].dot(o) - P.offsets[f];  // > 0: outside this face
    const double denom = P.normals[f].dot(u);
    if (dist >= 0.0) inside = false;
    if (denom == 0.0) {
      if (dist > 0.0) return Local::Miss;
      continue;
    }
    const double t = -dist / denom;
    if (denom < 0.0) {
      if (t > t_in) t_in = t, face = static_cast<int>(f);
    } else {
      t_out = std::min(t_out, t);
    }
  }
  if (inside) return Local::Inside;
  if (face < 0 || t_in < 0.0 || t_in > t_out || t_in > t_max) return Local::Miss;
  h.t = t_in;
  h.n = P.normals[face];
  h.kind = FeatureKind::Face;
  h.index = static_cast<std::uint32_t>(face);
  return Local::Hit;
}

/// Capsule (segment z in [-hl, hl], radius r): the union of the side cylinder and the two end
/// balls, entered first where any of them is entered first (the origin being outside all).
Local ray_capsule(const Capsule& c, const Vec3& o, const Vec3& u, double t_max, LocalHit& h) {
  const double hl = c.half_length, r = c.radius;
  const Vec3 axis_point(0.0, 0.0, std::clamp(o.z(), -hl, hl));
  if ((o - axis_point).squaredNorm() < r * r) return Local::Inside;
  bool hit = false;
  double s0, s1;
  if (side_interval(o, u, r, s0, s1) && s0 >= 0.0 && s0 <= t_max) {
    const double z = o.z() + s0 * u.z();
    if (z >= -hl && z <= hl) {
      h.t = s0;
      h.n = Vec3(o.x() + s0 * u.x(), o.y() + s0 * u.y(), 0.0).normalized();
      h.kind = FeatureKind::Edge, h.index = 0;
      hit = true;
    }
  }
  for (std::uint32_t k = 0; k < 2; ++k) {
    LocalHit b;
    if (ray_ball(o, u, Vec3(0.0, 0.0, k ? hl : -hl), r, t_max, b) == Local::Hit && (!hit || b.t < h.t)) {
      h.t = b.t, h.n = b.n, h.kind = FeatureKind::Vertex, h.index = k;
      hit = true;
    }
  }
  return hit ? Local::Hit : Local::Miss;
}

/// Cylinder (radius r, z in [-hh, hh]): the z slab intersected with the side's interval.
Local ray_cylinder(const Cylinder& c, const Vec3& o, const Vec3& u, double t_max, LocalHit& h) {
  const double r = c.radius, hh = c.half_height;
  if (o.x() * o.x() + o.y() * o.y() < r * r && std::abs(o.z()) < hh) return Local::Inside;
  double z0 = -kInf, z1 = kInf;
  std::uint32_t cap = 0;
  if (u.z() == 0.0) {
    if (std::abs(o.z()) > hh) return Local::Miss;
  } else {
    z0 = (-hh - o.z()) / u.z(), z1 = (hh - o.z()) / u.z();
    cap = 0;  // z = -hh
    if (z0 > z1) std::swap(z0, z1), cap = 1;
  }
  double s0, s1;
  if (!side_interval(o, u, r, s0, s1)) return Local::Miss;
  const bool by_cap = z0 >= s0;
  const double t_in = std::max(z0, s0), t_out = std::min(z1, s1);
  if (t_in < 0.0 || t_in > t_out || t_in > t_max) return Local::Miss;
  h.t = t_in;
  h.kind = FeatureKind::Face;
  if (by_cap) {
    h.n = Vec3(0.0, 0.0, cap ? 1.0 : -1.0);
    h.index = cap;
  } else {
    h.n = Vec3(o.x() + t_in * u.x(), o.y() + t_in * u.y(), 0.0).normalized();
    h.index = 2;
  }
  return Local::Hit;
}

// the local test of each primitive kind (overloads, so that a part is never copied)
Local local_ray(const Sphere& s, const Vec3& o, const Vec3& u, double t_max, LocalHit& h) {
  h.kind = FeatureKind::Face, h.index = 0;
  return ray_ball(o, u, Vec3::Zero(), s.radius, t_max, h);
}
Local local_ray(const Box& b, const Vec3& o, const Vec3& u, double t_max, LocalHit& h) {
  return ray_box(o, u, b.half_extents, t_max, h);
}
Local local_ray(const Capsule& c, const Vec3& o, const Vec3& u, double t_max, LocalHit& h) {
  return ray_capsule(c, o, u, t_max, h);
}
Local local_ray(const Cylinder& c, const Vec3& o, const Vec3& u, double t_max, LocalHit& h) {
  return ray_cylinder(c, o, u, t_max, h);
}
Local local_ray(const ConvexHull& hull, const Vec3& o, const Vec3& u, double t_max, LocalHit& h) {
  return ray_polytope(*hull.polytope, o, u, t_max, h);
}
Local local_ray(const Polytope& P, const Vec3& o, const Vec3& u, double t_max, LocalHit& h) {
  return ray_polytope(P, o, u, t_max, h);
}

/// One convex solid (a primitive or a polytope) at pose, as a world-frame result with part `part`.
/// Returns Miss, Hit or Inside as the local test does.
template <class S>
Local ray_convex(const S& shape, const Pose& pose, const Ray& ray, std::uint32_t part, RayResult& r) {
  const Vec3 o = pose.R.transpose() * (ray.o - pose.p);
  const Vec3 u = pose.R.transpose() * ray.u;
  LocalHit h;
  const Local got = local_ray(shape, o, u, ray.t_max, h);
  if (got == Local::Hit) {
    r.t = h.t, r.normal = pose.R * h.n, r.feature = feature_id(h.kind, h.index, part), r.inside = false;
  } else if (got == Local::Inside) {
    r.t = 0.0, r.normal = -ray.u, r.feature = feature_id(FeatureKind::Shape, 0, part), r.inside = true;
  }
  return got;
}

/// Keeps the earlier of two results (the first on ties: the lower part).
void keep_first(Local got, const RayResult& r, bool& hit, RayResult& best) {
  if (got == Local::Miss) return;
  if (!hit || r.t < best.t) best = r, hit = true;
}

bool in_polytope(const Polytope& P, const Vec3& x) {
  for (std::size_t f = 0; f < P.normals.size(); ++f)
    if (P.normals[f].dot(x) > P.offsets[f]) return false;
  return true;
}

bool local_contains(const Sphere& s, const Vec3& x) { return x.squaredNorm() <= s.radius * s.radius; }
bool local_contains(const Box& b, const Vec3& x) { return (x.cwiseAbs() - b.half_extents).maxCoeff() <= 0.0; }
bool local_contains(const Capsule& c, const Vec3& x) {
  const Vec3 q(0.0, 0.0, std::clamp(x.z(), -c.half_length, c.half_length));
  return (x - q).squaredNorm() <= c.radius * c.radius;
}
bool local_contains(const Cylinder& c, const Vec3& x) {
  return x.x() * x.x() + x.y() * x.y() <= c.radius * c.radius && std::abs(x.z()) <= c.half_height;
}
bool local_contains(const ConvexHull& h, const Vec3& x) { return in_polytope(*h.polytope, x); }

}  // namespace

void quadratic_roots(double a, double b, double c, double D, double& t0, double& t1) {
  const double q = -(b + std::copysign(std::sqrt(D), b));
  if (q == 0.0) {  // b = 0 and D = 0: a double root at 0
    t0 = t1 = 0.0;
    return;
  }
  t0 = q / a, t1 = c / q;
  if (t0 > t1) std::swap(t0, t1);
}

bool ray_triangle(const Vec3& o, const Vec3& u, const Vec3& a, const Vec3& b, const Vec3& c, double t_max,
                  double& t, bool& front) {
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 p = u.cross(e2);
  const double det = e1.dot(p);
  if (det == 0.0) return false;  // parallel to the triangle's plane
  const double inv = 1.0 / det;
  const Vec3 s = o - a;
  const double bu = s.dot(p) * inv;
  if (bu < 0.0 || bu > 1.0) return false;
  const Vec3 q = s.cross(e1);
  const double bv = u.dot(q) * inv;
  if (bv < 0.0 || bu + bv > 1.0) return false;
  const double tt = e2.dot(q) * inv;
  if (tt < 0.0 || tt > t_max) return false;
  t = tt;
  front = det > 0.0;  // det = -u . (e1 x e2): positive when u runs against the normal
  return true;
}

bool ray_shape(const Shape& shape, const Pose& pose, const Ray& ray, const TriangleQuery* triangles,
               std::vector<int>& stack, RayResult& result) {
  if (const auto* plane = std::get_if<Plane>(&shape)) {
    const Vec3 n = pose.R * plane->normal;
    const double offset = plane->offset + n.dot(pose.p);
    const double dist = n.dot(ray.o) - offset, denom = n.dot(ray.u);
    result.feature = feature_id(FeatureKind::Face, 0);
    if (dist < 0.0) {
      result.t = 0.0, result.normal = -ray.u, result.feature = feature_id(FeatureKind::Shape, 0);
      result.inside = true;
      return true;
    }
    if (denom >= 0.0) return false;
    const double t = -dist / denom;
    if (t > ray.t_max) return false;
    result.t = t, result.normal = n, result.inside = false;
    return true;
  }
  if (const auto* mesh = std::get_if<TriangleMesh>(&shape)) {
    if (!triangles) throw std::logic_error("ray_shape: a TriangleMesh needs its TriangleQuery");
    const Vec3 o = pose.R.transpose() * (ray.o - pose.p);
    const Vec3 u = pose.R.transpose() * ray.u;
    double t;
    int tri;
    bool front;
    if (!triangles->cast_ray(*mesh, o, u, ray.t_max, t, tri, front, stack)) return false;
    const Vec3 n = pose.R * mesh->normals[tri];
    result.t = t, result.normal = front ? n : Vec3(-n), result.inside = false;
    result.feature = feature_id(FeatureKind::Face, 0, static_cast<std::uint32_t>(tri));
    return true;
  }
  bool hit = false;
  RayResult r;
  if (const auto* c = std::get_if<Compound>(&shape)) {
    for (std::size_t k = 0; k < c->parts.size(); ++k) {
      const Compound::Part& part = c->parts[k];
      const Pose pk{pose.R * part.position + pose.p, pose.R * part.rotation};
      std::visit([&](const auto& ps) { keep_first(ray_convex(ps, pk, ray, static_cast<std::uint32_t>(k), r), r, hit, result); },
                 part.shape);
    }
  } else if (const auto* m = std::get_if<Mesh>(&shape)) {
    if (m->pieces.empty()) {  // a convex mesh the world has not prepared
      const Polytope P = polytope_from_triangles(m->vertices, m->faces);
      keep_first(ray_convex(P, pose, ray, 0, r), r, hit, result);
    } else {
      for (std::size_t k = 0; k < m->pieces.size(); ++k)
        keep_first(ray_convex(*m->pieces[k], pose, ray, static_cast<std::uint32_t>(k), r), r, hit, result);
    }
  } else {
    std::visit(
        [&](const auto& s) {
          using T = std::decay_t<decltype(s)>;
          if constexpr (is_primitive_v<T>)
            keep_first(ray_convex(s, pose, ray, 0, r), r, hit, result);
          else
            throw std::logic_error("ray_shape: no ray test for a " + shape_name(shape));
        },
        shape);
  }
  return hit;
}

bool shape_contains(const Shape& shape, const Pose& pose, const Vec3& x) {
  if (const auto* plane = std::get_if<Plane>(&shape)) {
    const Vec3 n = pose.R * plane->normal;
    return n.dot(x) <= plane->offset + n.dot(pose.p);
  }
  if (std::holds_alternative<TriangleMesh>(shape)) return false;
  const Vec3 xl = pose.R.transpose() * (x - pose.p);
  if (const auto* c = std::get_if<Compound>(&shape)) {
    for (const Compound::Part& part : c->parts)
      if (std::visit([&](const auto& ps) { return local_contains(ps, part.rotation.transpose() * (xl - part.position)); },
                     part.shape))
        return true;
    return false;
  }
  if (const auto* m = std::get_if<Mesh>(&shape)) {
    if (m->pieces.empty()) return in_polytope(polytope_from_triangles(m->vertices, m->faces), xl);
    for (const auto& piece : m->pieces)
      if (in_polytope(*piece, xl)) return true;
    return false;
  }
  bool in = false;
  std::visit(
      [&](const auto& s) {
        using T = std::decay_t<decltype(s)>;
        if constexpr (is_primitive_v<T>)
          in = local_contains(s, xl);
        else
          throw std::logic_error("shape_contains: no point test for a " + shape_name(shape));
      },
      shape);
  return in;
}

}  // namespace signorini::collision
