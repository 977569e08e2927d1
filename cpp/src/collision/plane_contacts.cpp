// Plane tests written by hand: FCL 0.7's halfspace distance queries crash (docs/DESIGN), and the
// exact answer is one dot product per feature.
#include <cmath>
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
  const Vec3 w_sphere = c_l - r * n_l;
  Contact out;
  out.body_a = box_is_a ? box : sphere;
  out.body_b = box_is_a ? sphere : box;
  out.normal = R_box * (box_is_a ? n_l : Vec3(-n_l));
  out.gap = gap;
  out.point = R_box * (0.5 * (w_box + w_sphere)) + p_box;
  return out;
}

}  // namespace signorini::collision
