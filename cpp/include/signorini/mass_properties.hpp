// Mass properties of shapes: volume, centre of mass and inertia tensor about the centre of mass.
#pragma once

#include "signorini/shapes.hpp"

namespace signorini {

struct MassProperties {
  double mass;    ///< kg
  double volume;  ///< m^3
  Vec3 com;       ///< centre of mass in the shape's frame (m); zero for sphere, box, capsule, cylinder
  Mat3 inertia;   ///< inertia tensor about com, shape axes (kg m^2)
};

/// Mass properties for a uniform density (kg/m^3), in the shape's frame:
/// - Sphere r: m = rho 4/3 pi r^3, I = 2/5 m r^2 I3.
/// - Box (a, b, c): m = 8 rho a b c, I = m/3 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2).
/// - Cylinder r, half height h (axis z): m = rho pi r^2 2h, I = diag(m (r^2/4 + h^2/3) twice, m r^2/2)
///   (the textbook m (3 r^2 + H^2) / 12 with the full height H = 2 h).
/// - Capsule r, half length h (axis z): a cylinder (m_c = rho pi r^2 2h) and two hemispheres
///   (m_s = rho 4/3 pi r^3 together), each hemisphere's COM 3r/8 from its flat face, moved to the
///   centre by the parallel-axis theorem: I_zz = m_c r^2/2 + 2/5 m_s r^2,
///   I_xx = I_yy = m_c (r^2/4 + h^2/3) + m_s (2/5 r^2 + 3/4 h r + h^2). com = 0.
/// - Mesh: divergence theorem over signed tetrahedra (origin, v0, v1, v2), then shifted to the com
///   by the parallel-axis theorem. Needs a closed, outward-oriented mesh of positive volume. A Mesh
///   with convex `pieces` keeps the properties of the mesh itself (pieces only collide).
/// - ConvexHull: the same divergence-theorem routine over its triangulation `faces`.
/// - Compound: the parts' masses summed, com = sum m_p (R_p c_p + t_p) / m, and the parts'
///   inertias rotated into compound axes (R_p I_p R_p^T) and moved to the combined com by the
///   parallel-axis theorem (+ m_p (|d_p|^2 I3 - d_p d_p^T), d_p = R_p c_p + t_p - com). Overlapping
///   parts count twice. volume = the sum of the parts' volumes.
/// Throws std::invalid_argument for a Plane or TriangleMesh ("has no volume; it can only be
/// static"), a bad density, or an unusable mesh.
MassProperties mass_properties(const Shape& shape, double density);

}  // namespace signorini
