// The soft step (docs/conventions.md, "The soft step"): Catto's soft-constraint substepping, as in
// Box2D v3 and Box3D, on the lecture's rows. A step of dt detects its contacts once and runs n
// substeps of h = dt / n:
//   begin (once) -> per substep: [unconstrained velocity] -> solve -> [poses move] -> relax (and
//   restitution where a contact first pushes) -> end (once): store.
// Each contact is a spring-damper of documented stiffness while it overlaps
// (solve), and rigid in the relax sweeps, which take the spring's velocity back so that pushing
// out of an overlap moves the poses without becoming kinetic energy. Rows are built once per step
// at the start poses; each contact's gap is carried with its two bodies from substep to substep.
#pragma once

#include <vector>

#include "solver/contact_solver.hpp"

namespace signorini::solver {

/// Begins a step of n substeps of h (s).
/// In:  model; state (poses and velocities at the step's start, pending impulses applied);
///      substeps: how many substeps these rows serve (n, or the rest of the step after a cut; the
///      lanes run when they pay for their copy of the rows: widen);
///      contacts (K, as the narrow phase wrote them); d.cache (the previous step's forces).
/// Out: d's rows (dt folded as h), solve order, soft points (anchors, gaps, softness), u_i from the
///      state's velocities, and d.alpha recalled from the cache (applied by every solve).
void soft_begin(const Model& model, const State& state, double h, int substeps, const SolverSettings& settings,
                const std::vector<Contact>& contacts, SolverData& d, const std::vector<Vec3>* anchor_a = nullptr,
                const std::vector<Vec3>* anchor_b = nullptr);

/// A substep's solve. In: state (poses now), v, omega (N, world) = the unconstrained velocities.
/// Out: v, omega = the velocities that move the poses: the forces of the last substep (or the
/// cache) applied again, then soft_iterations sweeps with the soft bias.
void soft_solve(const Model& model, const State& state, const SolverSettings& settings, std::vector<Vec3>& v,
                std::vector<Vec3>& omega, SolverData& d);

/// A substep's relax, after the poses moved. In/out: v, omega (N, world): relax_iterations sweeps
/// with rigid contacts (speculative ones still close their gap) on the velocities of solve; then
/// restitution on the contacts that pushed for the first time in this substep, with e > 0 and an
/// approach u (their J_n q_dot before the biased sweep) faster than the threshold: n^T (v_B - v_A) >= -e u.
/// another: a substep follows, whose warm start the last sweep then gathers per body (d.kick),
/// when no contact has restitution.
void soft_relax(const Model& model, const State& state, const SolverSettings& settings, std::vector<Vec3>& v,
                std::vector<Vec3>& omega, SolverData& d, bool another = false);

/// Ends the step. In: v, omega (N) = the last substep's velocities.
/// Out: contacts[i].alpha, friction, force, spin_torque (the last substep's, N and N m), impulse
/// (the step's whole normal impulse, N s), normal_velocity, slip; d.body_force, d.body_torque;
/// d.cache_next; returns the stats with the certificate against the rigid targets (each contact's
/// end gap / h, or e u).
/// report = false (a run of rows that another follows within the step): what the next run needs
/// only (store's report = false): the contacts' alpha, friction, spin_torque and impulse, and
/// d.cache_next; the bodies' sums and the certificate are not made (the stats returned hold the
/// counts only: contacts, sweeps).
SolverStats soft_end(const Model& model, const State& state, const SolverSettings& settings,
                     std::vector<Contact>& contacts, std::vector<Vec3>& v, std::vector<Vec3>& omega, SolverData& d,
                     bool report = true);

}  // namespace signorini::solver
