// The soft step's sweeps and warm start four body pairs at a time (docs/conventions.md, "Rows
// four pairs at a time"). A colour's pairs share no moving body, so any of them can be solved at
// once: the rows of each four consecutive pairs of a colour (of at most kManifoldPoints contacts)
// are copied into one WideGroup (each field four values side by side, point by point), and a
// sweep runs a group's four pairs in the lanes of SIMD registers (xsimd: two lanes of SSE2, or
// four of AVX2 where the CPU has it, chosen at run time), each lane its pair's points one after
// the other with the pair's two bodies in registers. Each lane does exactly the scalar sweep's
// operations in the scalar sweep's order, so the bits are those of the scalar sweep for every lane
// width and every thread count (ctest WideRows.*).
//
//   widen (once per step, after prepare, the soft points and the warm-start forces): d.rows,
//     d.soft, d.alpha -> d.wide, d.wide_first
//   wide_settle, wide_alpha_in: the grouped contacts' forces to d.alpha (settled) and back
//   wide_sweep, wide_warm_start (per sweep and per substep, per block of by_colour): the groups of
//   [first, end), and the contacts in no group (the colour's last pairs that fill no group, its
//   pairs of more points, the shared last colour) one by one
#pragma once

#include <cstddef>

#include "solver/contact_solver.hpp"

namespace signorini::solver {

/// One sweep's settings as the lanes read them.
struct SoftSweep {
  bool biased = false;      ///< the spring's bias on overlapping contacts (else rigid: the relax sweep)
  bool update_gaps = false; ///< each contact's gap is brought up to date first (gap_now)
  double inv_h = 0.0;       ///< 1 / h (1/s)
  double max_push_velocity = 0.0;  ///< the spring's bias is at least -this (m/s)
  /// the last relax sweep of a substep that another follows: each contact's forces as they leave
  /// the sweep are also summed, as the warm start applies them, into its bodies' d.kick (the next
  /// substep's warm start, gathered while the rows are at hand: SolverData::kick)
  bool kick = false;
  /// the last relax sweep of a substep without restitution: each grouped point's force as it
  /// leaves the sweep is also added to its impulse (h alpha_n) and its largest force, as
  /// wide_accumulate would add them after the sweep (the same sums: the sweep is their last change)
  bool accumulate = false;
  double h = 0.0;  ///< the substep (s), for accumulate
};

/// Which code runs the groups: the best the CPU has (Auto), or one forced, for tests that compare
/// them; Scalar runs every contact one by one.
enum class WideIsa { Auto, Scalar, SSE2, AVX2 };

/// Sets the code the wide sweeps run with (process-wide; Auto by default). Throws
/// std::invalid_argument when the CPU (or the build) lacks the one asked for.
void set_wide_isa(WideIsa isa);
/// The code the wide sweeps run with now (never Auto).
WideIsa wide_isa();
/// Whether it was asked for by name (set_wide_isa other than Auto): the lanes then run wherever
/// they can, not only where they pay (widen).
bool wide_isa_named();

/// Contacts the lanes have solved since the process started (summed per wide run, a count for tests
/// that check the lanes ran).
std::size_t wide_contacts_solved();
/// Two-point pairs the lanes have solved as blocks since the process started (WideGroup::two; a
/// count for tests).
std::size_t wide_pairs_solved();
/// Pairs the lanes have solved with their points' own directions since the process started
/// (WideGroup::frame; a count for tests).
std::size_t wide_framed_pairs_solved();

/// d.wide and d.wide_first from d.rows, d.colour_start and d.long_start (the solve order by pair):
/// colour c's pairs of at most kManifoldPoints contacts, from the colour's start, fill groups
/// wide_first[c] .. wide_first[c + 1] - 1, four pairs a group; the shared last colour has none. A
/// group with a contact whose normal or first friction row has delta <= 0 (both bodies static:
/// never made by the narrow phase), or a pair whose points differ in spring, is flagged, and its
/// contacts run one by one, as are those of a group of blocks or with a round side whose pair's
/// points differ in direction; any other group whose pairs' points differ in direction takes their
/// own from d.frames (WideGroup::frame).
/// passes: how many times the groups will be swept (their warm starts counted) before the rows are
/// made again. Unless an ISA was asked for by name (set_wide_isa, set_simd), the lanes run only
/// where they pay for copying the rows into the groups: at least kLanePasses passes, over pairs of
/// kLanePoints contacts or more on average (measured: docs/conventions.md, "Rows four pairs at a
/// time"); otherwise the contacts are solved one by one, with the same bits.
/// Out: d.lanes (whether the lanes run this step: not with the scalar code chosen, spin rows or
/// the cone rule, nor where they do not pay; without them no groups are made).
void widen(const SolverSettings& s, SolverData& d, int passes);

/// Where the lanes pay for their copy of the rows (widen): each group swept at least this many
/// times, and its pairs of at least this many contacts on average. Measured on a 2-core x86-64
/// with AVX2 (soft step, 1 thread): the 5,050-cube pyramid at dt 1/60 (4 substeps, 12 passes, 4
/// contacts a pair) 37.0 ms a step with the lanes against 39.4 one by one, at dt 1/240 (3 passes)
/// 29.8 against 25.9; Box3D's rain (12 passes or more, 1 or 2 contacts a pair) 13.6 against 11.8.
constexpr int kLanePasses = 8;
constexpr int kLanePoints = 3;

/// The gaps of the grouped contacts (which live in the groups while the sweeps run) back into their
/// soft points (wide_gaps_out), and the soft points' gaps into the groups (wide_gaps_in: after a
/// pass over the soft points changed them).
void wide_gaps_out(SolverData& d);
void wide_gaps_in(SolverData& d);

/// Likewise the forces of the grouped contacts, which live in the groups while the sweeps run: to
/// d.alpha after a substep's relax sweeps (wide_settle, which settles each such contact in the
/// same pass: soft_contact.hpp, settle; returns whether any bounces), and back (wide_alpha_in:
/// after restitution changed some in d.alpha). d.in_lanes flags the solve positions they cover
/// (set by widen: the contacts of the groups the lanes solve).
bool wide_settle(const SolverSettings& s, SolverData& d);
void wide_alpha_in(SolverData& d);

/// Without restitution anywhere (!d.bouncy no contact can bounce), settling a grouped contact is
/// only bookkeeping: its impulse grows by h alpha_n, its largest force is kept, and its last forces
/// are the step's. wide_accumulate does the first two in the groups after each substep's relax
/// sweeps (contiguous, no per-contact scatter), and wide_settle_out hands all of it to d.alpha,
/// d.alpha_iter, d.restitutive and the soft points once, at the step's end: the same bits as
/// wide_settle after every substep (the same additions in the same order, the same max).
/// wide_settle_out also gives the soft points their gaps (wide_gaps_out) in the same pass.
void wide_accumulate(SolverData& d);
void wide_settle_out(SolverData& d);

/// The soft step's sweep over solve positions [first, end) (one by_colour block, or everything):
/// each group's pairs in lanes, the other contacts one by one, colour by colour (all one by one
/// without lanes, d.lanes). The rows have no spin rows when d.lanes.
void wide_sweep(const SolverSettings& s, const SoftSweep& x, SolverData& d, std::size_t first, std::size_t end);

/// rows::apply_forces with the groups in lanes (each pair's points in solve order, its bodies read
/// once), colour by colour over the threads; rows::apply_forces itself without lanes (d.lanes).
void wide_warm_start(SolverData& d);

namespace wide {
/// What the per-ISA sweeps read and write, as raw arrays: those files run no Eigen or standard
/// library code, whose inline functions compiled for AVX2 the linker could otherwise pick for the
/// whole program.
struct Lanes {
  WideGroup* groups;        ///< d.wide (the points' gaps and forces are written)
  double* qd;               ///< d.qd: per body omega (3) then v (3)
  const double* dp;         ///< d.dp: per body (3)
  const double* dR;         ///< d.dR: per body (3 x 3, column-major)
  double* kick;             ///< d.kick: per body omega (3) then v (3) (written with SoftSweep::kick)
  const PointFrames* frames;  ///< d.frames: the points' own directions of a group with WideGroup::frame >= 0
};

/// The groups [group, group + groups) (none flagged one_by_one) in the lanes of one ISA
/// (wide_kernel.hpp, compiled once per ISA).
void sweep_sse2(const SoftSweep& x, const Lanes& d, std::size_t group, std::size_t groups);
void sweep_avx2(const SoftSweep& x, const Lanes& d, std::size_t group, std::size_t groups);
/// The warm start of the groups [group, group + groups) (wide_warm_start).
void warm_start_sse2(const Lanes& d, std::size_t group, std::size_t groups);
void warm_start_avx2(const Lanes& d, std::size_t group, std::size_t groups);
}  // namespace wide

}  // namespace signorini::solver
