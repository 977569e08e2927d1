#include "solver/soft_step.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "dynamics/rigid_body.hpp"
#include "solver/joint_rows.hpp"
#include "solver/rows.hpp"
#include "solver/soft_contact.hpp"
#include "solver/wide_rows.hpp"

namespace signorini::solver {
namespace {

using namespace rows;

/// p's spring (soften) of `hertz` and damping ratio zeta over h.
void soften(SoftPoint& p, double hertz, double zeta, double h) {
  const Softness k = solver::soften(hertz, zeta, h);
  p.bias_rate = k.bias_rate;
  p.mass_scale = k.mass_scale;
  p.impulse_scale = k.impulse_scale;
}

/// d.qd <- (v, omega), for the listed bodies (the others' entries stay zero, as their velocities are).
void load(const std::vector<Vec3>& v, const std::vector<Vec3>& omega, SolverData& d) {
  parallel::fit(d.qd, v.size(), BodyVelocity());
  parallel::for_bodies(d.pool, d.bodies, v.size(), 1024, [&](std::size_t i) {
    d.qd[i].omega = omega[i];
    d.qd[i].v = v[i];
  });
}

/// (v, omega) <- d.qd, for the listed bodies.
void unload(const SolverData& d, std::vector<Vec3>& v, std::vector<Vec3>& omega) {
  parallel::for_bodies(d.pool, d.bodies, v.size(), 1024, [&](std::size_t i) {
    v[i] = d.qd[i].v;
    omega[i] = d.qd[i].omega;
  });
}

/// dp = p - p0 and dR = R R0^T - I of the listed bodies (the others', static bodies', stay zero):
/// how far each body has moved and turned since the step's start, for the contacts' gaps (gap_now).
void body_motion(const Model& model, const State& state, SolverData& d) {
  const std::size_t N = model.size();
  parallel::fit(d.dp, N, Vec3(Vec3::Zero()));
  parallel::fit(d.dR, N, Mat3(Mat3::Zero()));
  parallel::for_bodies(d.pool, d.bodies, N, 1024, [&](std::size_t i) {
    d.dp[i] = state.p[i] - d.p0[i];
    d.dR[i].noalias() = state.R[i] * d.R0[i].transpose();
    d.dR[i].diagonal().array() -= 1.0;
  });
}

/// One sweep over every contact in solve order (soft_units), colour by colour over the threads;
/// four body pairs at a time (wide_sweep) when the lanes run (d.lanes).
template <bool kSpin, bool kGap>
void sweep(const SolverSettings& s, SolverData& d, bool biased, bool kick, bool accumulate) {
  SoftSweep x;
  x.biased = biased;
  x.kick = kick;
  x.accumulate = accumulate;
  x.h = d.h;
  x.update_gaps = kGap;
  x.inv_h = 1.0 / d.h;
  x.max_push_velocity = s.max_push_velocity;
  by_colour(d, [&](std::size_t first, std::size_t end) {
    if (!kSpin) {
      wide_sweep(s, x, d, first, end);
    } else {
      soft_units<kSpin, kGap>(s, x, d, first, end);
    }
    return 0.0;  // not used: the soft step runs a fixed number of sweeps
  });
}

/// count sweeps; update_gaps: the first brings every contact's gap up to date (with count 0, a
/// pass of its own does); kick: the last also gathers the next substep's warm start (SoftSweep::kick);
/// accumulate: the last also adds the grouped points' forces to their impulses (SoftSweep::accumulate).
void sweeps(const SolverSettings& s, SolverData& d, bool biased, int count, bool update_gaps, bool kick = false,
            bool accumulate = false) {
  const bool spin = !d.spin_rows.empty();
  if (update_gaps && count == 0) {
    for_ranges(d, d.soft.size(), 1024, [&](std::size_t first, std::size_t end) {
      for (std::size_t k = first; k < end; ++k) d.soft[k].s = gap_now(d, d.rows[k], d.soft[k]);
    });
    if (d.lanes) wide_gaps_in(d);  // the groups' copies of the gaps
  }
  JointSet* joints = joints_of(d, true);
  for (int i = 0; i < count; ++i) {
    const bool last_kick = kick && i + 1 == count, last_sum = accumulate && i + 1 == count;
    if (i == 0 && update_gaps)
      spin ? sweep<true, true>(s, d, biased, last_kick, last_sum)
           : sweep<false, true>(s, d, biased, last_kick, last_sum);
    else
      spin ? sweep<true, false>(s, d, biased, last_kick, last_sum)
           : sweep<false, false>(s, d, biased, last_kick, last_sum);
    if (joints) sweep_joints(*joints, d, biased ? JointSweep::SoftBiased : JointSweep::SoftRelax, d.h);
  }
}

}  // namespace

Softness soften(double hertz, double zeta, double h) {
  const double omega = 2.0 * M_PI * hertz;
  const double a1 = 2.0 * zeta + h * omega;
  const double a2 = h * omega * a1;
  const double a3 = 1.0 / (1.0 + a2);
  return Softness{omega / a1, a2 * a3, a3};
}

void soft_begin(const Model& model, const State& state, double h, int substeps, const SolverSettings& settings,
                const std::vector<Contact>& contacts, SolverData& d, const std::vector<Vec3>* anchor_a,
                const std::vector<Vec3>* anchor_b) {
  const std::size_t N = model.size(), K = contacts.size();
  d.h = h;
  parallel::fit(d.dI_inv, N, Mat3(Mat3::Zero()));
  parallel::fit(d.p0, N, Vec3(Vec3::Zero()));
  parallel::fit(d.R0, N, Mat3(Mat3::Zero()));
  parallel::fit(d.kick, N, BodyVelocity());
  parallel::for_bodies(d.pool, d.bodies, N, 1024, [&](std::size_t i) {
    d.dI_inv[i] = h * dynamics::inverse_inertia_world(model, state, i);
    d.p0[i] = state.p[i];
    d.R0[i] = state.R[i];
    d.kick[i] = BodyVelocity();  // (zero after every use; a step cut short may have left one)
  });
  d.kick_ready = false;
  load(state.v, state.omega, d);
  const double hertz = std::min(settings.contact_hertz, kMaxHertzPerRate / h);
  // the two springs: between two bodies that move, and against one that does not (twice as stiff
  // and half as damped: it carries the load alone; Box2D v3)
  SoftPoint springs[2];
  soften(springs[0], hertz, settings.damping_ratio, h);
  soften(springs[1], 2.0 * hertz, 0.5 * settings.damping_ratio, h);
  // a pair's points together, for the lanes; the warm start's forces recalled and the soft points
  // made as the rows are made, in one pass over the contacts
  prepare(model, state, h, contacts, anchor_a, anchor_b, d, Order::ByPair, settings.warm_start ? &settings : nullptr,
          springs);
  d.restitution_sweeps = 0;
  d.alpha_iter.clear();
  // whether any contact has restitution (without, no contact's approach is ever read)
  d.bouncy = std::any_of(d.e.begin(), d.e.begin() + static_cast<std::ptrdiff_t>(K), [](double e) { return e > 0.0; });
  // the groups take the warm-start forces too; each is swept, with its warm start, this many times
  widen(settings, d, substeps * (1 + settings.soft_iterations + settings.relax_iterations));
}

void soft_solve(const Model& model, const State& state, const SolverSettings& settings, std::vector<Vec3>& v,
                std::vector<Vec3>& omega, SolverData& d) {
  load(v, omega, d);
  // the last substep's forces (the cache's in the first) as this one's first guess: gathered per
  // body by the last substep's relax sweep where it could (SoftSweep::kick), else applied row by row
  if (d.kick_ready) {
    parallel::for_bodies(d.pool, d.bodies, v.size(), 1024, [&](std::size_t i) {
      if (model.is_kinematic[i]) return;  // (its entry stays zero: its velocity is its own)
      d.qd[i].omega += d.kick[i].omega;
      d.qd[i].v += d.kick[i].v;
      d.kick[i] = BodyVelocity();
    });
    d.kick_ready = false;
  } else {
    wide_warm_start(d);
  }
  if (JointSet* joints = joints_of(d)) {  // the joints' rows at these poses, warm started
    prepare_joints(model, state, d.h, &settings, true, *joints, d);
    if (settings.warm_start) warm_start_joints(*joints, d);
    else for (Joint& j : joints->joints) j.alpha.fill(0.0);
  }
  // the gaps are those soft_relax left (or soft_begin's in the first substep): the poses have not
  // moved since
  // the approach of each contact that has not pushed yet, for restitution if it pushes now (only
  // a contact with restitution can bounce: the others' approach is never read)
  if (d.bouncy) {
    for_ranges(d, d.soft.size(), 1024, [&](std::size_t first, std::size_t end) {
      for (std::size_t k = first; k < end; ++k)
        if (d.soft[k].alpha_max == 0.0 && d.e[k] > 0.0)
          d.soft[k].u_before = normal_velocity(d.rows[k], d.qd);
    });
  }
  sweeps(settings, d, true, settings.soft_iterations, false);
  unload(d, v, omega);
}

void soft_relax(const Model& model, const State& state, const SolverSettings& settings, std::vector<Vec3>& v,
                std::vector<Vec3>& omega, SolverData& d, bool another) {
  const std::size_t K = d.soft.size();
  load(v, omega, d);
  body_motion(model, state, d);  // the poses have moved: each contact's gap with the first relax sweep
  // the next substep's warm start gathered by the last sweep, unless restitution may still change
  // forces after it (no contact has restitution: !d.bouncy)
  const bool kick = another && !d.bouncy && settings.relax_iterations >= 1;
  // without restitution the grouped contacts only add up their impulses, in the groups, until
  // soft_end hands them out: as the last relax sweep leaves them (SoftSweep::accumulate), or
  // (wide_accumulate) in a pass of their own when no sweep runs
  const bool deferred = d.lanes && !d.bouncy;
  const bool in_sweep = deferred && settings.relax_iterations >= 1;
  sweeps(settings, d, false, settings.relax_iterations, true, kick, in_sweep);
  d.kick_ready = kick;
  // each contact settled (settle: its force for the cache, whether it bounces, its impulse); the
  // grouped ones as their forces leave the groups, the others in order
  d.alpha_iter.resize(K);
  d.restitutive.resize(K);
  if (deferred && !in_sweep) wide_accumulate(d);
  std::atomic<bool> bounces{d.lanes && !deferred && wide_settle(settings, d)};
  for_ranges(d, K, 1024, [&](std::size_t first, std::size_t end) {
    bool any = false;
    for (std::size_t k = first; k < end; ++k)  // in solve order, as the points and flags are stored
      if (!d.lanes || !d.in_lanes[k]) any = settle(settings, d, k) || any;
    if (any) bounces.store(true, std::memory_order_relaxed);
  });
  if (bounces.load(std::memory_order_relaxed)) {
    d.restitution_sweeps += restitution(settings, d);
    if (d.lanes) wide_alpha_in(d);  // the next substep's sweeps start from the bounced forces
    for_ranges(d, K, 1024, [&](std::size_t first, std::size_t end) {
      for (std::size_t k = first; k < end; ++k)
        if (d.restitutive[k]) add_impulse(d, k);
    });
  }
  unload(d, v, omega);
}

SolverStats soft_end(const Model& model, const State& state, const SolverSettings& settings,
                     std::vector<Contact>& contacts, std::vector<Vec3>& v, std::vector<Vec3>& omega, SolverData& d,
                     bool report) {
  const std::size_t N = model.size(), K = contacts.size();
  SolverStats stats;
  stats.contacts = static_cast<int>(K);
  stats.iterations = settings.soft_iterations + settings.relax_iterations;
  stats.restitution_iterations = d.restitution_sweeps;
  if (report) {  // (the bodies' sums and the velocities after the solve: the report's alone)
    clear_body_forces(d, N);
    load(v, omega, d);
  }
  if (d.alpha_iter.size() != K) {  // no substep ran (never: a step has at least one)
    d.alpha_iter.assign(K, 0.0);
    d.restitutive.assign(K, char(0));
  }
  // the grouped contacts' forces, impulses and gaps, kept in the groups
  if (d.lanes && !d.bouncy) wide_settle_out(d);
  else if (d.lanes) wide_gaps_out(d);
  // the certificate's targets: the rigid contact at its end gap (speculative: close it, no more),
  // or e u for a contact that bounced in the last substep; each contact's impulse: its substeps'
  // summed (store reads both from the soft points)
  store(d.h, settings, contacts, d, stats, &d.soft, report);
  if (JointSet* joints = joints_of(d)) store_joints(state, *joints);
  if (report) unload(d, v, omega);
  // a fixed number of sweeps by design: never flagged as unconverged (the certificate says what
  // the contacts satisfy)
  stats.converged = true;
  return stats;
}

}  // namespace signorini::solver
