#include "signorini/mass_properties.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

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

MassProperties mesh_properties(const Mesh& mesh, double rho) {
  if (const std::string problem = mesh.closedness_problem(); !problem.empty())
    throw std::invalid_argument("Mesh: " + problem + "; mass properties need a closed mesh");
  // divergence theorem: the solid is the signed sum of tetrahedra (0, a, b, c) over the faces.
  // For one tetrahedron with det = a . (b x c): volume det/6, first moment det/24 (a + b + c),
  // second moment C = int x x^T dV = det/120 (a a^T + b b^T + c c^T + s s^T), s = a + b + c.
  double V = 0.0;
  Vec3 first = Vec3::Zero();
  Mat3 C = Mat3::Zero();
  for (Eigen::Index k = 0; k < mesh.faces.rows(); ++k) {
    const Vec3 a = mesh.vertex(mesh.faces(k, 0));
    const Vec3 b = mesh.vertex(mesh.faces(k, 1));
    const Vec3 c = mesh.vertex(mesh.faces(k, 2));
    const double det = a.dot(b.cross(c));
    const Vec3 s = a + b + c;
    V += det / 6.0;
    first += det / 24.0 * s;
    C += det / 120.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  const double scale = (mesh.vertices.colwise().maxCoeff() - mesh.vertices.colwise().minCoeff()).norm();
  if (!(V > 1e-12 * scale * scale * scale))
    throw std::invalid_argument("Mesh: volume is " + std::to_string(V) +
                                ", not positive: the triangles must face outwards and enclose a solid");
  const Vec3 com = first / V;
  // parallel-axis theorem on the second moment, then I = tr(C) I3 - C
  const Mat3 C_com = C - V * com * com.transpose();
  const Mat3 I = rho * (C_com.trace() * Mat3::Identity() - C_com);
  return {rho * V, V, com, I};
}

}  // namespace

MassProperties mass_properties(const Shape& shape, double density) {
  if (!(std::isfinite(density) && density > 0.0))
    throw std::invalid_argument("density must be positive and finite, got " + std::to_string(density));
  if (const auto* s = std::get_if<Sphere>(&shape)) return sphere_properties(*s, density);
  if (const auto* b = std::get_if<Box>(&shape)) return box_properties(*b, density);
  if (const auto* m = std::get_if<Mesh>(&shape)) return mesh_properties(*m, density);
  throw std::invalid_argument("Plane: a plane has no volume and no mass; add it as a static body");
}

}  // namespace signorini
