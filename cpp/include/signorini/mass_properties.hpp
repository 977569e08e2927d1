// Mass properties of shapes: volume, centre of mass and inertia tensor about the centre of mass.
#pragma once

#include "signorini/shapes.hpp"

namespace signorini {

struct MassProperties {
  double mass;    ///< kg
  double volume;  ///< m^3
  Vec3 com;       ///< centre of mass in the shape's frame (m); zero for sphere and box
  Mat3 inertia;   ///< inertia tensor about com, shape axes (kg m^2)
};

/// Mass properties for a uniform density (kg/m^3):
/// - Sphere r: m = rho 4/3 pi r^3, I = 2/5 m r^2 I3.
/// - Box (a, b, c): m = 8 rho a b c, I = m/3 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2).
/// - Mesh: divergence theorem over signed tetrahedra (origin, v0, v1, v2), then shifted to the com
///   by the parallel-axis theorem. Needs a closed, outward-oriented mesh of positive volume.
/// Throws std::invalid_argument for a Plane (no volume), a bad density, or an unusable mesh.
MassProperties mass_properties(const Shape& shape, double density);

}  // namespace signorini
