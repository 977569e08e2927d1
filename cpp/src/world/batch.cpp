#include "signorini/batch.hpp"

#include <algorithm>
#include <stdexcept>

#include "parallel/pool.hpp"

namespace signorini {

BatchStepper::BatchStepper(int threads) : pool_(std::make_unique<parallel::Pool>(threads)) {}
BatchStepper::~BatchStepper() = default;

int BatchStepper::threads() const { return pool_->threads(); }

void BatchStepper::copy_state(const World& world, std::size_t N, std::size_t i, double* positions,
                              double* orientations, double* velocities, double* angular_velocities) {
  const auto held = world.lock();
  const State& s = world.state();
  if (s.p.size() != N)
    throw std::invalid_argument("batch: world " + std::to_string(i) + " has " + std::to_string(s.p.size()) +
                                " bodies, the batch " + std::to_string(N));
  for (std::size_t b = 0; b < N; ++b) {
    for (int k = 0; k < 3; ++k) {
      positions[(i * N + b) * 3 + k] = s.p[b][k];
      velocities[(i * N + b) * 3 + k] = s.v[b][k];
      angular_velocities[(i * N + b) * 3 + k] = s.omega[b][k];
    }
    for (int k = 0; k < 4; ++k) orientations[(i * N + b) * 4 + k] = s.q[b][k];
  }
}

void BatchStepper::step(const std::vector<World*>& worlds, double dt, int steps, std::vector<std::uint8_t>& frozen,
                        std::vector<std::string>& errors, double* positions, double* orientations, double* velocities,
                        double* angular_velocities) const {
  const std::size_t n = worlds.size();
  if (frozen.size() != n || errors.size() != n) throw std::invalid_argument("batch: one flag and one message per world");
  if (n == 0) return;
  const std::size_t N = worlds[0]->num_bodies();
  // one task per world: each writes only its own world, flag, message and output rows
  pool_->for_ranges(n, 1, [&](std::size_t first, std::size_t end) {
    for (std::size_t i = first; i < end; ++i) {
      if (!frozen[i]) {
        try {
          worlds[i]->step(dt, steps);
        } catch (const std::exception& e) {
          frozen[i] = 1;
          errors[i] = e.what();
        }
      }
      copy_state(*worlds[i], N, i, positions, orientations, velocities, angular_velocities);
    }
  });
}

}  // namespace signorini
