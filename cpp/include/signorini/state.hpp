// State: the dynamic part of a world (mjData's role), one entry per body. Written by the
// integrate stage and by the user's setters; read by collision, dynamics and the solver.
#pragma once

#include <vector>

#include "signorini/types.hpp"

namespace signorini {

struct State {
  std::vector<Vec3> p;       ///< com position, world (m)                      (N)
  std::vector<Mat3> R;       ///< rotation world-from-body                      (N)
  std::vector<Vec3> v;       ///< p_dot, world (m/s)                            (N)
  std::vector<Vec3> omega;   ///< angular velocity, world (rad/s)               (N)
  std::vector<Vec3> f_ext;   ///< external force at the com, world (N), every step        (N)
  std::vector<Vec3> tau_ext; ///< external torque about the com, world (N m), every step  (N)
  double time = 0.0;         ///< s
};

}  // namespace signorini
