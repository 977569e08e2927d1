#include "signorini/mass_properties.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

namespace signorini {
namespace {

constexpr double kPi = 3.14159265358979323846;

MassProperties sphere_properties(const Sphere& s, double rho) {
  const double r = s.radius;
  const double V = 4.0 / 3.0 * kPi * r * r * r;
  const double m = rho * V;
  return {m, V, Vec3::Zero(), Mat3::Identity() * (0.4 * m * r * r)};
}

MassProperties box_properties(const Box& b, double rho) {
  const Vec3 h2 = b.half_extents.cwiseProduct(b.half_extents);
  const double V = 8.0 * b.half_extents.prod();
  const double m = rho * V;
  const Vec3 d(h2.y() + h2.z(), h2.x() + h2.z(), h2.x() + h2.y());
  return {m, V, Vec3::Zero(), Mat3(d.asDiagonal()) * (m / 3.0)};
}

/// Volume, COM and inertia (unit density) of the solid bounded by closed, outward triangles, by the
/// divergence theorem: the solid is the signed sum of tetrahedra (0, a, b, c) over the faces. For
/// one tetrahedron with det = a . (b x c): volume det/6, first moment det/24 (a + b + c), second
/// moment C = int x x^T dV = det/120 (a a^T + b b^T + c c^T + s s^T), s = a + b + c.
MassProperties solid_properties(const Points& vertices, const Triangles& faces, double rho, const char* who) {
  double V = 0.0;
  Vec3 first = Vec3::Zero();
  Mat3 C = Mat3::Zero();
  for (Eigen::Index k = 0; k < faces.rows(); ++k) {
    const Vec3 a = vertices.row(faces(k, 0)).transpose();
    const Vec3 b = vertices.row(faces(k, 1)).transpose();
    const Vec3 c = vertices.row(faces(k, 2)).transpose();
    const double det = a.dot(b.cross(c));
    const Vec3 s = a + b + c;
    V += det / 6.0;
    first += det / 24.0 * s;
    C += det / 120.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  const double scale = (vertices.colwise().maxCoeff() - vertices.colwise().minCoeff()).norm();
  if (!(V > 1e-12 * scale * scale * scale))
    throw std::invalid_argument(std::string(who) + ": volume is " + std::to_string(V) +
                                ", not positive: the triangles must face outwards and enclose a solid");
  const Vec3 com = first / V;
  // parallel-axis theorem on the second moment, then I = tr(C) I3 - C
  const Mat3 C_com = C - V * com * com.transpose();
  const Mat3 I = rho * (C_com.trace() * Mat3::Identity() - C_com);
  return {rho * V, V, com, I};
}

MassProperties mesh_properties(const Mesh& mesh, double rho) {
  if (const std::string problem = mesh.closedness_problem(); !problem.empty())
    throw std::invalid_argument("Mesh: " + problem + "; mass properties need a closed mesh");
  return solid_properties(mesh.vertices, mesh.faces, rho, "Mesh");
}

/// Cylinder of radius r and height H = 2 h about the z axis:
/// V = pi r^2 H, I_zz = m r^2 / 2, I_xx = I_yy = m (3 r^2 + H^2) / 12 = m (r^2 / 4 + h^2 / 3).
MassProperties cylinder_properties(const Cylinder& c, double rho) {
  const double r = c.radius, h = c.half_height;
  const double V = kPi * r * r * 2.0 * h;
  const double m = rho * V;
  const double I_xx = m * (r * r / 4.0 + h * h / 3.0);
  return {m, V, Vec3::Zero(), Vec3(I_xx, I_xx, 0.5 * m * r * r).asDiagonal()};
}

/// Capsule of radius r and half length h: a cylinder of height 2 h (mass m_c = rho pi r^2 2 h) and
/// two hemispheres (together m_s = rho 4/3 pi r^3). I_zz = m_c r^2 / 2 + 2/5 m_s r^2. Across the
/// axis each hemisphere (mass m_s / 2) has 2/5 (m_s / 2) r^2 about the centre of its flat face, its
/// COM lies 3 r / 8 from that face, so about its COM (m_s / 2)(2/5 - 9/64) r^2 = (m_s / 2) 83/320 r^2,
/// and about the capsule centre (distance h + 3 r / 8) the pair gives
/// m_s (83/320 r^2 + (h + 3 r / 8)^2) = m_s (2/5 r^2 + 3/4 h r + h^2).
/// I_xx = I_yy = m_c (r^2 / 4 + h^2 / 3) + m_s (2/5 r^2 + 3/4 h r + h^2). h = 0 is the sphere.
MassProperties capsule_properties(const Capsule& c, double rho) {
  const double r = c.radius, h = c.half_length;
  const double V_c = kPi * r * r * 2.0 * h, V_s = 4.0 / 3.0 * kPi * r * r * r;
  const double m_c = rho * V_c, m_s = rho * V_s;
  const double I_zz = 0.5 * m_c * r * r + 0.4 * m_s * r * r;
  const double I_xx = m_c * (r * r / 4.0 + h * h / 3.0) + m_s * (0.4 * r * r + 0.75 * h * r + h * h);
  return {m_c + m_s, V_c + V_s, Vec3::Zero(), Vec3(I_xx, I_xx, I_zz).asDiagonal()};
}

MassProperties primitive_properties(const Primitive& shape, double rho) {
  return mass_properties(std::visit([](const auto& s) -> Shape { return s; }, shape), rho);
}

/// Compound: parts p with mass m_p, COM c_p and inertia I_p (part frame), placed at (t_p, R_p):
/// m = sum m_p, com = sum m_p (R_p c_p + t_p) / m, and with d_p = R_p c_p + t_p - com,
/// I = sum R_p I_p R_p^T + m_p (|d_p|^2 I3 - d_p d_p^T) (parallel-axis theorem), compound axes.
/// Overlapping parts are counted twice: a compound is meant to be a union of disjoint parts.
MassProperties compound_properties(const Compound& c, double rho) {
  std::vector<MassProperties> props;
  double m = 0.0, V = 0.0;
  Vec3 moment = Vec3::Zero();
  for (const Compound::Part& part : c.parts) {
    props.push_back(primitive_properties(part.shape, rho));
    m += props.back().mass;
    V += props.back().volume;
    moment += props.back().mass * (part.rotation * props.back().com + part.position);
  }
  const Vec3 com = moment / m;
  Mat3 I = Mat3::Zero();
  for (std::size_t i = 0; i < c.parts.size(); ++i) {
    const Compound::Part& part = c.parts[i];
    const Vec3 d = part.rotation * props[i].com + part.position - com;
    I += part.rotation * props[i].inertia * part.rotation.transpose() +
         props[i].mass * (d.squaredNorm() * Mat3::Identity() - d * d.transpose());
  }
  return {m, V, com, I};
}

}  // namespace

MassProperties mass_properties(const Shape& shape, double density) {
  if (!(std::isfinite(density) && density > 0.0))
    throw std::invalid_argument("density must be positive and finite, got " + std::to_string(density));
  struct Dispatch {
    double rho;
    MassProperties operator()(const Sphere& s) const { return sphere_properties(s, rho); }
    MassProperties operator()(const Box& b) const { return box_properties(b, rho); }
    MassProperties operator()(const Mesh& m) const { return mesh_properties(m, rho); }
    MassProperties operator()(const Capsule& c) const { return capsule_properties(c, rho); }
    MassProperties operator()(const Cylinder& c) const { return cylinder_properties(c, rho); }
    MassProperties operator()(const ConvexHull& h) const { return solid_properties(h.vertices, h.faces, rho, "ConvexHull"); }
    MassProperties operator()(const Compound& c) const { return compound_properties(c, rho); }
    MassProperties operator()(const Plane&) const {
      throw std::invalid_argument("Plane: a plane has no volume; it can only be static");
    }
    MassProperties operator()(const TriangleMesh&) const {
      throw std::invalid_argument("TriangleMesh: a triangle mesh has no volume; it can only be static");
    }
  };
  return std::visit(Dispatch{density}, shape);
}

}  // namespace signorini
