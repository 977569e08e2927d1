// Many worlds stepped together (issue 22, "Many worlds"): n independent Worlds on one pool of
// threads, world by world. Each world steps on one thread exactly as a World of its own does (a
// World's results do not depend on its thread count), so a batch gives, world by world, the bits
// of separate Worlds for every thread count.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "signorini/world.hpp"

namespace signorini {
namespace parallel {
class Pool;
}

class BatchStepper {
 public:
  /// threads >= 1: the worlds are spread over this many threads (oneTBB, one task per world).
  explicit BatchStepper(int threads);
  ~BatchStepper();
  BatchStepper(const BatchStepper&) = delete;
  BatchStepper& operator=(const BatchStepper&) = delete;
  int threads() const;

  /// Advances every world i with frozen[i] == 0 by `steps` steps of dt (s).
  /// In:  worlds (n, each with N bodies; set to one thread of its own by the caller), dt > 0, steps >= 0.
  /// Out: a world whose step throws (non-finite state, energy explosion, ...) keeps the state
  ///      World::step leaves (before the failing step), gets frozen[i] = 1 and errors[i] = the
  ///      message, and the others go on; then each world's positions (m), orientations (w, x, y,
  ///      z), velocities (m/s) and angular velocities (rad/s), world frame, are copied to row i
  ///      of the outputs, row-major arrays of n x N x 3 (orientations n x N x 4) doubles.
  void step(const std::vector<World*>& worlds, double dt, int steps, std::vector<std::uint8_t>& frozen,
            std::vector<std::string>& errors, double* positions, double* orientations, double* velocities,
            double* angular_velocities) const;

  /// Copies world i's state to row i of the outputs (as step does after its steps), for worlds
  /// changed by a setter. Worlds of another body count than the first are refused.
  static void copy_state(const World& world, std::size_t N, std::size_t i, double* positions, double* orientations,
                         double* velocities, double* angular_velocities);

 private:
  std::unique_ptr<parallel::Pool> pool_;
};

}  // namespace signorini
