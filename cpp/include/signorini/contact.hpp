// The contact record that the narrow phase writes and the solver reads.
#pragma once

#include "signorini/types.hpp"

namespace signorini {

/// One contact point between bodies A and B (see docs/conventions.md).
struct Contact {
  BodyIndex body_a = -1;  ///< body A (a plane is always A)
  BodyIndex body_b = -1;  ///< body B
  Vec3 point = Vec3::Zero();   ///< y_i, world (m): midpoint of the witness points on A and B
  Vec3 normal = Vec3::Zero();  ///< n_i, world, unit, pointing from A towards B
  double gap = 0.0;            ///< signed distance along n_i (m); negative = overlap
  double alpha = 0.0;          ///< contact force magnitude alpha_i >= 0 (N), as in the notes
  double impulse = 0.0;        ///< dt * alpha_i (N s), applied as -impulse n on A and +impulse n on B
};

}  // namespace signorini
