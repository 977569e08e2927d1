// Model: the static description of the bodies (mjModel's role). Written by World::add_body and the
// material setter, read by every stage of the step (collision, dynamics, solver).
#pragma once

#include <cstddef>
#include <vector>

#include "signorini/shapes.hpp"
#include "signorini/types.hpp"

namespace signorini {

/// Material of one body. The pair values a contact uses (docs/conventions.md, "Materials"):
/// friction mu = sqrt(mu_A mu_B), restitution e = max(e_A, e_B).
struct Material {
  double friction = 0.5;     ///< Coulomb coefficient mu >= 0 (dimensionless)
  double restitution = 0.0;  ///< Newton's coefficient e in [0, 1] (dimensionless)
};

/// One entry per body, in the order added (static bodies included).
struct Model {
  std::vector<Shape> shape;      ///< body frame; a dynamic mesh is re-centred on its com
  std::vector<bool> is_static;
  std::vector<double> mass;      ///< kg (infinity for static)
  std::vector<double> inv_mass;  ///< 1/kg (0 for static)
  std::vector<Mat3> I_body;      ///< inertia about the com, body axes (kg m^2; zero for static)
  std::vector<Mat3> I_body_inv;  ///< its inverse (zero for static)
  std::vector<double> rho;       ///< bounding radius about the body origin (m; inf for a plane)
  std::vector<Material> material;///< friction and restitution
  std::size_t size() const { return shape.size(); }
};

}  // namespace signorini
