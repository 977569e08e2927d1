// Settings and report of the Projected Gauss-Seidel contact solver.
#pragma once

namespace signorini {

struct SolverSettings {
  /// Baumgarte factor: the fraction of an overlap (negative gap) removed per step, in [0, 1].
  /// Positive gaps are always used whole (speculative contacts).
  double erp = 0.2;
  /// Stop sweeping when no contact changed its velocity delta_i |d alpha_i| by more than this (m/s).
  double tolerance = 1e-10;
  /// Upper bound on PGS sweeps per step.
  int max_iterations = 100;
};

/// What the last solve did. residual is the Signorini certificate max_i |min(delta_i alpha_i, w_i)|
/// in m/s, with w_i the final relative normal velocity plus the gap bias (see docs/conventions.md):
/// zero exactly when every contact pushes only, separates or rests, and never both.
struct SolverStats {
  int iterations = 0;
  double residual = 0.0;
  bool converged = true;
  int contacts = 0;
};

}  // namespace signorini
