// Contacts computed exactly by hand. Planes: FCL 0.7's halfspace distance queries crash (DESIGN.md)
// and the exact answer is one dot product per feature. Spheres against spheres, boxes and convex
// meshes: FCL's GJK/EPA witness points carry ~1e-5 m of tangential error (measured), which tilts
// the normal of a shallow contact and sets a frictionless body sliding; the closest point to a
// centre is exact and cheap.
#include <cmath>
#include <limits>
#include <variant>

#include "collision/collision.hpp"

namespace signorini::collision {
namespace {

/// Appends the contact of world point x (on B) against the plane n . x = offset, if close enough.
void point_contact(BodyIndex a, BodyIndex b, const Vec3& n, double offset, const Vec3& x_b,
                   double threshold, std::vector<Contact>& out) {
  const double gap = n.dot(x_b) - offset;
  if (!(gap < threshold)) return;
  Contact c;
  c.body_a = a;
  c.body_b = b;
  c.normal = n;
  c.gap = gap;
  c.point = x_b - 0.5 * gap * n;  // midpoint of w_B = x_b and w_A = x_b - gap n
  out.push_back(c);
}

}  // namespace

void plane_contacts(BodyIndex a, const Plane& plane, const Vec3& p_a, const Mat3& R_a, BodyIndex b,
                    const Shape& shape_b, const Vec3& p_b, const Mat3& R_b, double threshold,
                    std::vector<Contact>& out) {
  // the plane in world coordinates
  const Vec3 n = R_a * plane.normal;
  const double offset = plane.offset + n.dot(p_a);
  if (const auto* s = std::get_if<Sphere>(&shape_b)) {
    // the sphere's lowest point along -n
    point_contact(a, b, n, offset, p_b - s->radius * n, threshold, out);
  } else if (const auto* box = std::get_if<Box>(&shape_b)) {
    const Vec3& h = box->half_extents;
    for (int k = 0; k < 8; ++k) {
      const Vec3 corner((k & 1) ? h.x() : -h.x(), (k & 2) ? h.y() : -h.y(), (k & 4) ? h.z() : -h.z());
      point_contact(a, b, n, offset, R_b * corner + p_b, threshold, out);
    }
  } else if (const auto* mesh = std::get_if<Mesh>(&shape_b)) {
    for (Eigen::Index i = 0; i < mesh->vertices.rows(); ++i)
      point_contact(a, b, n, offset, R_b * mesh->vertex(i) + p_b, threshold, out);
  }
  // plane against plane: both static, never in contact
}

Contact sphere_sphere(BodyIndex a, const Vec3& c_a, double r_a, BodyIndex b, const Vec3& c_b, double r_b) {
  const Vec3 d = c_b - c_a;
  const double dist = d.norm();
  Contact c;
  c.body_a = a;
  c.body_b = b;
  // coincident centres have no direction: pick +z, as any unit vector is a valid normal there
  c.normal = dist > 0.0 ? Vec3(d / dist) : Vec3::UnitZ();
  c.gap = dist - r_a - r_b;
  const Vec3 w_a = c_a + r_a * c.normal;
  const Vec3 w_b = c_b - r_b * c.normal;
  c.point = 0.5 * (w_a + w_b);
  return c;
}

namespace {

/// The contact of a sphere (centre c_l, radius r, in the shape's frame) with a shape at (p, R),
/// from the shape-frame normal n_l (shape -> sphere), the shape's witness w_shape and the gap:
/// the sphere's witness is c_l - r n_l, the point their midpoint, the normal flipped if the
/// sphere is A.
Contact shape_sphere_contact(BodyIndex shape_body, const Vec3& p, const Mat3& R, BodyIndex sphere,
                             const Vec3& c_l, double r, const Vec3& n_l, const Vec3& w_shape,
                             double gap, bool shape_is_a) {
  const Vec3 w_sphere = c_l - r * n_l;
  Contact out;
  out.body_a = shape_is_a ? shape_body : sphere;
  out.body_b = shape_is_a ? sphere : shape_body;
  out.normal = R * (shape_is_a ? n_l : Vec3(-n_l));
  out.gap = gap;
  out.point = R * (0.5 * (w_shape + w_sphere)) + p;
  return out;
}

}  // namespace

Contact box_sphere(BodyIndex box, const Vec3& p_box, const Mat3& R_box, const Vec3& h, BodyIndex sphere,
                   const Vec3& c, double r, bool box_is_a) {
  // in box coordinates: the closest box point to the centre, or the nearest face if inside
  const Vec3 c_l = R_box.transpose() * (c - p_box);
  const Vec3 q = c_l.cwiseMax(-h).cwiseMin(h);
  Vec3 n_l, w_box;
  double gap;
  if (q != c_l) {
    const Vec3 d = c_l - q;
    const double dist = d.norm();
    n_l = d / dist;
    gap = dist - r;
    w_box = q;
  } else {
    int k = 0;
    for (int axis = 1; axis < 3; ++axis)
      if (h[axis] - std::abs(c_l[axis]) < h[k] - std::abs(c_l[k])) k = axis;
    const double s = c_l[k] < 0.0 ? -1.0 : 1.0;
    n_l = Vec3::Zero();
    n_l[k] = s;
    gap = -(h[k] - std::abs(c_l[k])) - r;
    w_box = c_l;
    w_box[k] = s * h[k];
  }
  return shape_sphere_contact(box, p_box, R_box, sphere, c_l, r, n_l, w_box, gap, box_is_a);
}

namespace {

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

}  // namespace

Contact convex_sphere(BodyIndex mesh_body, const Vec3& p_mesh, const Mat3& R_mesh, const Mesh& mesh,
                      BodyIndex sphere, const Vec3& c, double r, bool mesh_is_a) {
  // in mesh coordinates: the largest face-plane distance tells inside from outside
  const Vec3 c_l = R_mesh.transpose() * (c - p_mesh);
  double outermost = -std::numeric_limits<double>::infinity();
  Eigen::Index outermost_face = 0;
  for (Eigen::Index k = 0; k < mesh.faces.rows(); ++k) {
    const Vec3 a = mesh.vertex(mesh.faces(k, 0));
    const Vec3 n = (mesh.vertex(mesh.faces(k, 1)) - a).cross(mesh.vertex(mesh.faces(k, 2)) - a).normalized();
    const double d = n.dot(c_l - a);
    if (d > outermost) {
      outermost = d;
      outermost_face = k;
    }
  }
  Vec3 n_l, w_mesh;
  double gap;
  if (outermost <= 0.0) {
    // centre inside (or on the surface): out through the nearest face plane
    const Vec3 a = mesh.vertex(mesh.faces(outermost_face, 0));
    n_l = (mesh.vertex(mesh.faces(outermost_face, 1)) - a).cross(mesh.vertex(mesh.faces(outermost_face, 2)) - a).normalized();
    gap = outermost - r;
    w_mesh = c_l - outermost * n_l;
  } else {
    // outside: the closest surface point over all triangles
    double best = std::numeric_limits<double>::infinity();
    for (Eigen::Index k = 0; k < mesh.faces.rows(); ++k) {
      const Vec3 q = closest_on_triangle(c_l, mesh.vertex(mesh.faces(k, 0)), mesh.vertex(mesh.faces(k, 1)),
                                         mesh.vertex(mesh.faces(k, 2)));
      const double d2 = (c_l - q).squaredNorm();
      if (d2 < best) {
        best = d2;
        w_mesh = q;
      }
    }
    const double dist = std::sqrt(best);
    n_l = (c_l - w_mesh) / dist;
    gap = dist - r;
  }
  return shape_sphere_contact(mesh_body, p_mesh, R_mesh, sphere, c_l, r, n_l, w_mesh, gap, mesh_is_a);
}

}  // namespace signorini::collision
