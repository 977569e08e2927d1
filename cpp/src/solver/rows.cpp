#include "solver/rows.hpp"

#include <array>
#include <atomic>
#include <cstring>
#include <limits>
#include <mutex>

namespace signorini::solver::rows {

/// tangent_basis treats components of a unit normal that differ by less than this as tied.
constexpr double kTangentTie = 1e-9;

namespace {

/// Below this slip speed (m/s) a contact counts as sticking for the maximum-dissipation check.
constexpr double kSlidingSpeed = 1e-3;

/// Equal keys; a function object, as by_key below, which the standard algorithms inline.
constexpr auto same_key = [](const CachedContact& x, const CachedContact& y) { return !key_less(x, y) && !key_less(y, x); };
/// key_less as a function object, which the standard algorithms inline (a function pointer they may not).
constexpr auto by_key = [](const CachedContact& x, const CachedContact& y) { return key_less(x, y); };

/// true when contact i is the only one of its body pair: the contact list holds each pair's
/// contacts next to each other (docs/conventions.md, "Order"), so its neighbours tell.
bool alone_in_pair(const std::vector<Contact>& contacts, std::size_t i) {
  const auto same_pair = [&](std::size_t j) {
    return contacts[j].body_a == contacts[i].body_a && contacts[j].body_b == contacts[i].body_b;
  };
  return (i == 0 || !same_pair(i - 1)) && (i + 1 == contacts.size() || !same_pair(i + 1));
}

/// What a contact's rows need of its body pair (and the soft step of its sides' rounding), the
/// same for every point of the pair: found once per pair, as the narrow phase lists a pair's
/// points one after the other. Static and kinematic bodies have infinite mass here: contacts never
/// change their velocities.
struct PairFacts {
  int a = -1, b = -1;
  bool a_moves = false, b_moves = false;
  double dinv_mass_a = 0.0, dinv_mass_b = 0.0;  ///< dt / m_X (s/kg; 0 for a body that does not move)
  double mu = 0.0, e = 0.0;                     ///< friction sqrt(mu_A mu_B), restitution max(e_A, e_B)
  bool spinning = false;                        ///< either side has spinning friction
  /// the rounding radius of the part of A (of B) the last point came from, and that part
  std::uint32_t part_a = 0, part_b = 0;
  double rho_a = -1.0, rho_b = -1.0;            ///< -1: not looked up yet

  /// Facts of the pair (a, b) for a step of dt.
  PairFacts(const Model& model, int a, int b, double dt) : a(a), b(b) {
    a_moves = !model.is_static[a] && !model.is_kinematic[a];
    b_moves = !model.is_static[b] && !model.is_kinematic[b];
    dinv_mass_a = a_moves ? dt * model.inv_mass[a] : 0.0;
    dinv_mass_b = b_moves ? dt * model.inv_mass[b] : 0.0;
    const Material& ma = model.material[a];
    const Material& mb = model.material[b];
    mu = std::sqrt(ma.friction * mb.friction);
    e = std::max(ma.restitution, mb.restitution);
    spinning = ma.spinning_friction > 0.0 || mb.spinning_friction > 0.0;
  }
  PairFacts() = default;

  /// rounding_radius of part `part` of body x's shape (x: a or b), looked up once per part.
  double rounding(const Model& model, bool on_a, std::uint32_t part) {
    double& rho = on_a ? rho_a : rho_b;
    std::uint32_t& known = on_a ? part_a : part_b;
    if (rho < 0.0 || known != part) {
      rho = rounding_radius(model.shape[static_cast<std::size_t>(on_a ? a : b)], part);
      known = part;
    }
    return rho;
  }
};

/// The rows of one contact of the pair f (bodies a and b), acting at lever arms r_a = y_a - p_a on
/// A and r_b = y_b - p_b on B, along the directions d[0..2] (unit, world; normal, t1, t2):
/// J_A,k = -(r_a x d_k, d_k), J_B,k = (r_b x d_k, d_k), delta_k = dt (J_A,k M_A^-1 J_A,k + J_B,k M_B^-1 J_B,k),
/// and the friction rows' couplings W_jk = dt J_j M^-1 J_k^T. dI_inv holds dt I_X^-1 per body (world).
void make_rows(const PairFacts& f, const std::vector<Mat3>& dI_inv, const Vec3& r_a, const Vec3& r_b, const Vec3* d,
               ContactRows& c) {
  c.a = f.a;
  c.b = f.b;
  c.a_moves = f.a_moves;
  c.b_moves = f.b_moves;
  c.dinv_mass_a = f.dinv_mass_a;
  c.dinv_mass_b = f.dinv_mass_b;
  c.n = d[0];
  c.t1 = d[1];
  c.t2 = d[2];
  c.r_a = r_a;
  c.r_b = r_b;
  // per row: the angular parts J_X_ang,k and dt I_X^-1 J_X_ang,k (zero for a body that does not move)
  Vec3 JA[3], JB[3], MJA[3], MJB[3];
  for (int k = 0; k < 3; ++k) {
    JA[k] = -r_a.cross(d[k]);
    JB[k] = r_b.cross(d[k]);
    MJA[k] = c.a_moves ? Vec3(dI_inv[f.a] * JA[k]) : Vec3::Zero();
    MJB[k] = c.b_moves ? Vec3(dI_inv[f.b] * JB[k]) : Vec3::Zero();
  }
  const double dinv_mass = c.dinv_mass_a + c.dinv_mass_b;
  const auto W = [&](int j, int k) { return JB[j].dot(MJB[k]) + JA[j].dot(MJA[k]) + dinv_mass * d[j].dot(d[k]); };
  for (int k = 0; k < 3; ++k) {
    c.delta[k] = W(k, k);
    c.inv_delta[k] = c.delta[k] > 0.0 ? 1.0 / c.delta[k] : 0.0;
  }
  c.W_1n = W(1, 0);
  c.W_2n = W(2, 0);
  c.W_21 = W(2, 1);
  c.bias = 0.0;
  c.mu = f.mu;
}

}  // namespace

// ---- a. prepare ---------------------------------------------------------------------------------
/// The solve order (docs/conventions.md, "Solve order"): units coloured greedily in contact order
/// (a unit is a contact, Order::ByContact, or the run of consecutive contacts of one body pair,
/// Order::ByPair), each taking the lowest of 64 colours that none of its moving bodies has yet,
/// from colour 32 up for a unit against a body that does not move (the rest share a 65th), then
/// listed colour by colour, within a colour first (by pair) the units of exactly two contacts,
/// then the other units of at most kManifoldPoints contacts, then the longer ones, each part in
/// contact order (so that the lanes' groups of two-point pairs, solved as blocks, are whole). A
/// contact with the ground is then solved after those of the bodies it carries, so that in a sweep
/// the ground has the last word (Box2D v3 does the same with its last colours): a light body under
/// a heavy one no longer rocks. By
/// contact, consecutive contacts rarely share a body, so a sweep does not wait for one contact's
/// velocity update before starting the next (the idea of Box2D v3's graph colouring, here for one
/// thread); by pair, a pair's points follow each other and the soft step's lanes solve four pairs
/// at once (wide_rows.hpp), each lane keeping its pair's two bodies in registers.
/// Out: d.order (K: solve position -> contact), d.slot (K: contact -> solve position),
/// d.unit_first, d.colour_start, d.two_end, d.long_start, and the blocks the threads claim
/// (d.block_start, d.colour_block).
static void solve_order(const Model& model, const std::vector<Contact>& contacts, Order kind, SolverData& d) {
  const std::size_t K = contacts.size();
  constexpr int kColours = 65;
  constexpr int kStaticColour = 32;  // where units against a body that does not move start
  const auto same_pair = [&](std::size_t i, std::size_t j) {
    return contacts[i].body_a == contacts[j].body_a && contacts[i].body_b == contacts[j].body_b;
  };
  // the colours of the listed bodies (the others, static, never take one) start empty
  parallel::fit(d.colours_used, model.size(), std::uint64_t(0));
  parallel::each_body(d.bodies, model.size(), [&](std::size_t i) { d.colours_used[i] = 0; });
  // each contact's bucket first: 3 colour, + 0 in a two-point unit (by pair), + 2 in a long one,
  // + 1 in any other
  d.slot.resize(K);
  std::array<int, 3 * kColours + 1> start{};
  for (std::size_t i = 0, j = 0; i < K; i = j) {
    j = i + 1;
    // (each contact is read for its bodies: asked for ahead, as the contacts walked go by)
    const auto ask = [&](std::size_t k) {
      if (k + kWalkAhead < K) prefetch_read(&contacts[k + kWalkAhead], 2 * sizeof(BodyIndex));
    };
    ask(i);
    if (kind == Order::ByPair)
      while (j < K && same_pair(i, j)) ask(j++);
    const int a = contacts[i].body_a, b = contacts[i].body_b;
    const bool a_moves = !model.is_static[a] && !model.is_kinematic[a];
    const bool b_moves = !model.is_static[b] && !model.is_kinematic[b];
    const std::uint64_t taken = (a_moves ? d.colours_used[a] : 0) | (b_moves ? d.colours_used[b] : 0);
    int colour = kColours - 1;
    if (~taken != 0) {
      // against a body that does not move: the lowest free colour from kStaticColour up (solved
      // after the others), else the lowest free one
      colour = a_moves && b_moves ? 0 : kStaticColour;
      if (colour > 0 && (~taken >> colour) == 0) colour = 0;
      colour += __builtin_ctzll(~taken >> colour);  // the lowest free colour from there (one is free)
      if (a_moves) d.colours_used[a] |= std::uint64_t(1) << colour;
      if (b_moves) d.colours_used[b] |= std::uint64_t(1) << colour;
    }
    const int bucket = 3 * colour + (j - i > kManifoldPoints ? 2 : kind == Order::ByPair && j - i == 2 ? 0 : 1);
    // (2 bucket + whether the contact starts its unit, so that the contacts are read once)
    for (std::size_t k = i; k < j; ++k) d.slot[k] = 2 * bucket + (k == i);
    start[bucket + 1] += static_cast<int>(j - i);
  }
  for (int c = 0; c < 3 * kColours; ++c) start[c + 1] += start[c];
  d.colour_start.resize(kColours + 1);  // 66 ints: the capacity stays after the first step
  d.two_end.resize(kColours);
  d.long_start.resize(kColours);
  for (int c = 0; c <= kColours; ++c) d.colour_start[c] = start[3 * c];
  for (int c = 0; c < kColours; ++c) d.two_end[c] = start[3 * c + 1];
  for (int c = 0; c < kColours; ++c) d.long_start[c] = start[3 * c + 2];
  d.order.resize(K);
  d.unit_first.resize(K);
  for (std::size_t i = 0; i < K; ++i) {
    const int k = start[d.slot[i] / 2]++;
    // a unit's contacts are consecutive in both orders: it starts where its pair does
    d.unit_first[k] = static_cast<char>(d.slot[i] % 2);
    d.order[k] = static_cast<int>(i);
    d.slot[i] = k;
  }
  // the blocks the threads claim (by_colour), each within one colour, of at least kContactsPerTask
  // contacts and about a colour's share for each thread taken twice: each block's start costs a
  // wait for the colours before it and a cold start of its walk, so on few threads fewer, longer
  // blocks do better (the 5,050-cube pyramid on 2 threads, colours of about 2,500 contacts: blocks
  // of 256 took 3.7 and 4.3 ms for the biased and relax sweeps, of 512 3.5 and 4.0, of 128 4.2 and
  // 4.8), while 16 threads still get blocks of 256. By pair, cut between units only, and among the
  // two-point units and among the other short ones only every kLanes units of the part (a
  // WideGroup is never split); the shared last colour is one block
  const std::size_t shares = 2 * static_cast<std::size_t>(d.pool != nullptr ? d.pool->threads() : 1);
  d.block_start.clear();
  d.colour_block.resize(kColours + 1);
  for (int c = 0; c < kColours; ++c) {
    d.colour_block[c] = static_cast<int>(d.block_start.size());
    const int first = d.colour_start[c], end = d.colour_start[c + 1];
    if (first == end) continue;
    if (c + 1 == kColours) {
      d.block_start.push_back(first);
      continue;
    }
    // the block's first position; two-point and other short units so far in the colour
    int block = first, twos = 0, units = 0;
    const int least = static_cast<int>(std::max(kContactsPerTask, static_cast<std::size_t>(end - first) / shares));
    d.block_start.push_back(first);
    for (int k = first + 1; k <= end; ++k) {
      if (k < end && !d.unit_first[k]) continue;  // within a unit
      if (k - 1 < d.two_end[c]) ++twos;
      else if (k - 1 < d.long_start[c]) ++units;
      const bool at_group = k >= d.long_start[c] || (k < d.two_end[c] ? twos : units) % static_cast<int>(kLanes) == 0;
      if (k < end && k - block >= least && at_group) {
        block = k;
        d.block_start.push_back(k);
      }
    }
  }
  d.colour_block[kColours] = static_cast<int>(d.block_start.size());
  d.block_start.push_back(static_cast<int>(K));
}

/// Rows (normal, t1, t2 per contact, stored in solve order), pair materials, u_i = J_n q_dot*
/// (before the solve), and the spin rows (a contact alone in its body pair, with
/// mu_spin = max(mu_spin_A, mu_spin_B) > 0, in solve order).
namespace {
bool find_recalled(const std::vector<Contact>& contacts, SolverData& d);
inline void recall_force(const SolverSettings& s, SolverData& d, std::size_t i, std::size_t position, const Vec3& t1,
                         const Vec3& t2, double mu);
void recall_spin(const std::vector<Contact>& contacts, SolverData& d);
}  // namespace

void prepare(const Model& model, const State& state, double dt, const std::vector<Contact>& contacts,
             const std::vector<Vec3>* anchor_a, const std::vector<Vec3>* anchor_b, SolverData& d, Order order,
             const SolverSettings* recall, const SoftPoint* springs) {
  const std::size_t K = contacts.size();
  solve_order(model, contacts, order, d);
  // the warm start's entries first, when asked for: each contact's forces are then written as its
  // rows are made (the tangents and mu in hand), not in a pass of their own that reaches the rows
  // out of order
  const bool recalled = recall != nullptr && find_recalled(contacts, d);
  d.rows.resize(K);
  assign_n(d.alpha, 3 * K, 0.0);
  // e_i and u_i zero, in order, and written below only for a contact that can bounce (a write
  // where the solve position takes it, for every contact, reached a cache line out of order)
  assign_n(d.u, K, 0.0);
  assign_n(d.e, K, 0.0);
  if (springs) d.soft.resize(K);
  std::atomic<bool> spinning{false};  // some contact's pair has spinning friction
  // each contact writes only its own rows, u_i and e_i: split over the threads
  for_ranges(d, K, 512, [&](std::size_t first, std::size_t end) {
    Vec3 dir[3];  // the last contact's normal and tangents
    PairFacts f;  // the last contact's pair
    bool spins = false;
    for (std::size_t i = first; i < end; ++i) {
      if (i + kAhead < end) prefetch_write(&d.rows[d.slot[i + kAhead]], sizeof(ContactRows));
      const Contact& c = contacts[i];
      const int a = c.body_a, b = c.body_b;
      if (a != f.a || b != f.b) {
        f = PairFacts(model, a, b, dt);
        spins = spins || f.spinning;
      }
      // the tangents are a function of the normal's bits alone: a manifold's points, which share
      // it, find them once (the range's first contact finds its own)
      if (i == first || std::memcmp(c.normal.data(), dir[0].data(), sizeof(Vec3)) != 0) {
        dir[0] = c.normal;
        tangent_basis(c.normal, dir[1], dir[2]);
      }
      // in contact order, reading the contacts in turn (writing the rows where they go costs less
      // than reading the contacts out of order: a write does not wait)
      const std::size_t k = static_cast<std::size_t>(d.slot[i]);  // its solve position
      ContactRows& r = d.rows[k];
      // a kept contact's lever arms are those it was found with (docs/conventions.md, "Contact recycling")
      const Vec3 r_a = anchor_a ? Vec3((*anchor_a)[i] - state.p[a]) : c.kept ? c.arm_a : Vec3(c.point - state.p[a]);
      const Vec3 r_b = anchor_b ? Vec3((*anchor_b)[i] - state.p[b]) : c.kept ? c.arm_b : Vec3(c.point - state.p[b]);
      make_rows(f, d.dI_inv, r_a, r_b, dir, r);
      // a speculative contact may close its gap, no more; an overlap is left to the position pass
      r.bias = std::max(c.gap, 0.0) / dt;
      // the approach is read only by a contact that can bounce (restitution, the certificate's
      // target of a restitutive contact): the others skip gathering their bodies' velocities
      if (f.e > 0.0) {
        d.e[k] = f.e;
        d.u[k] = normal_velocity(r, d.qd);
      }
      if (recalled && d.recalled[i] >= 0) recall_force(*recall, d, i, k, r.t1, r.t2, r.mu);
      if (springs) {  // the soft step's point: its spring, its gap, a round side's core offset
        SoftPoint& p = d.soft[k];
        p = springs[r.a_moves && r.b_moves ? 0 : 1];
        p.gap0 = p.s = c.gap;
        // a round side's carried point: its core, gap0 / 2 + rho along n from the contact point
        const double rho_a = f.rounding(model, true, feature_part(c.feature_a));
        const double rho_b = f.rounding(model, false, feature_part(c.feature_b));
        if (rho_a > 0.0) p.sigma_a = 0.5 * c.gap + rho_a;
        if (rho_b > 0.0) p.sigma_b = 0.5 * c.gap + rho_b;
      }
    }
    if (spins) spinning.store(true, std::memory_order_relaxed);
  });
  const bool any_spin = spinning.load();
  // spin rows: J_A = (-n, 0), J_B = (n, 0), delta = dt (n . I_A^-1 n + n . I_B^-1 n); none, and
  // nothing more to do, when no pair has spinning friction
  d.spin_rows.clear();
  if (any_spin) assign_n(d.spin_slot, K, -1);
  for (std::size_t k = 0; any_spin && k < K; ++k) {
    const int i = d.order[k];
    const Contact& c = contacts[i];
    const double mu_spin =
        std::max(model.material[c.body_a].spinning_friction, model.material[c.body_b].spinning_friction);
    if (!(mu_spin > 0.0) || !alone_in_pair(contacts, static_cast<std::size_t>(i))) continue;
    const ContactRows& r = d.rows[k];
    SpinRow q;
    q.n = c.normal;
    q.dMJA_ang = r.a_moves ? Vec3(d.dI_inv[r.a] * -c.normal) : Vec3::Zero();
    q.dMJB_ang = r.b_moves ? Vec3(d.dI_inv[r.b] * c.normal) : Vec3::Zero();
    q.delta = q.n.dot(q.dMJB_ang) - q.n.dot(q.dMJA_ang);
    if (!(q.delta > 0.0)) continue;
    q.inv_delta = 1.0 / q.delta;
    q.mu_spin = mu_spin;
    d.spin_slot[k] = static_cast<int>(d.spin_rows.size());
    d.spin_rows.push_back(q);
  }
  assign_n(d.spin_alpha, d.spin_rows.size(), 0.0);
  if (recalled) recall_spin(contacts, d);
}

// ---- b. warm start ------------------------------------------------------------------------------
namespace {

/// d.recalled: each contact's cache entry with its key (-1: none; an entry goes to the first contact
/// in contact order with its key). Returns whether any contact found one.
bool find_recalled(const std::vector<Contact>& contacts, SolverData& d) {
  if (d.cache.empty()) return false;
  const std::size_t K = contacts.size();
  assign_n(d.recalled, K, -1);
  // each contact's cache entry with its key (-1: none), over the threads: a range starts with a
  // binary search, then walks on, since the narrow phase lists contacts in key order (everything
  // before the cursor is below the key); a key that goes back is searched for from the start
  for_ranges(d, K, 1024, [&](std::size_t first, std::size_t end) {
    CachedContact key, previous;
    auto cursor = d.cache.begin();  // the first entry not below the previous contact's key
    for (std::size_t i = first; i < end; ++i) {
      if (i + kWalkAhead < end) prefetch_read(&contacts[i + kWalkAhead], kContactKeyBytes);
      const Contact& c = contacts[i];
      key.body_a = c.body_a;
      key.body_b = c.body_b;
      key.feature_a = c.feature_a;
      key.feature_b = c.feature_b;
      auto it = cursor;
      if (i > first && !key_less(key, previous))
        while (it != d.cache.end() && key_less(*it, key)) ++it;
      else
        it = std::lower_bound(d.cache.begin(), d.cache.end(), key, by_key);
      cursor = it;
      previous = key;
      d.recalled[i] = it != d.cache.end() && same_key(*it, key) ? static_cast<int>(it - d.cache.begin()) : -1;
    }
  });
  // an entry goes to the first contact in contact order with its key (one pass, in order)
  bool found = false;
  assign_n(d.cache_used, d.cache.size(), char(0));
  for (std::size_t i = 0; i < K; ++i) {
    const int j = d.recalled[i];
    if (j < 0) continue;
    if (d.cache_used[j]) {
      d.recalled[i] = -1;
    } else {
      d.cache_used[j] = 1;
      found = true;
    }
  }
  return found;
}

/// Contact i's recalled forces (d.recalled[i] >= 0) at its solve position, clamped to the friction
/// set of its rows' tangents t1, t2 and friction coefficient mu.
inline void recall_force(const SolverSettings& s, SolverData& d, std::size_t i, std::size_t position, const Vec3& t1,
                         const Vec3& t2, double mu) {
  const CachedContact& entry = d.cache[static_cast<std::size_t>(d.recalled[i])];
  const double alpha_n = entry.alpha;
  double a1 = entry.friction.dot(t1), a2 = entry.friction.dot(t2);
  const double bound = mu * alpha_n;
  if (s.friction_cone == FrictionCone::Cone) {
    clamp_to_disk(a1, a2, bound);
  } else {
    a1 = std::clamp(a1, -bound, bound);
    a2 = std::clamp(a2, -bound, bound);
  }
  double* alpha = &d.alpha[3 * position];
  alpha[0] = alpha_n;
  alpha[1] = a1;
  alpha[2] = a2;
}

/// The recalled spin torques of the spin rows, clamped to [-mu_spin alpha_n, mu_spin alpha_n].
void recall_spin(const std::vector<Contact>& contacts, SolverData& d) {
  if (d.spin_rows.empty()) return;
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    if (d.recalled[i] < 0) continue;
    const std::size_t position = static_cast<std::size_t>(d.slot[i]);
    if (d.spin_slot[position] < 0) continue;
    const CachedContact& entry = d.cache[static_cast<std::size_t>(d.recalled[i])];
    const std::size_t j = static_cast<std::size_t>(d.spin_slot[position]);
    const double spin_bound = d.spin_rows[j].mu_spin * entry.alpha;
    d.spin_alpha[j] = std::clamp(entry.spin, -spin_bound, spin_bound);
  }
}

}  // namespace

/// Forces of the previous step for contacts with the same key, clamped to the friction set (a spin
/// row's torque to [-mu_spin alpha_n, mu_spin alpha_n]).
bool recall_forces(const SolverSettings& s, const std::vector<Contact>& contacts, SolverData& d) {
  if (!find_recalled(contacts, d)) return false;
  const std::size_t K = contacts.size();
  // the forces, clamped to the friction set, over the threads (each contact writes its own rows),
  // in contact order, as the cache is sorted: the rows are reached out of order, asked for early
  for_ranges(d, K, 1024, [&](std::size_t first, std::size_t end) {
    for (std::size_t i = first; i < end; ++i) {
      if (i + kAhead < end && d.recalled[i + kAhead] >= 0) {
        const std::size_t ahead = static_cast<std::size_t>(d.slot[i + kAhead]);
        prefetch_read(&d.rows[ahead].t1, 2 * sizeof(Vec3));  // what is read: t1, t2 and mu
        prefetch_read(&d.rows[ahead].mu, sizeof(double));
        prefetch_write(&d.alpha[3 * ahead], 3 * sizeof(double));
      }
      if (d.recalled[i] < 0) continue;
      const std::size_t position = static_cast<std::size_t>(d.slot[i]);
      const ContactRows& r = d.rows[position];
      recall_force(s, d, i, position, r.t1, r.t2, r.mu);
    }
  });
  recall_spin(contacts, d);
  return true;
}

void apply_forces(SolverData& d) {
  // each contact's three forces as one impulse, then its spin torque
  // (colour by colour: the same sums in the same order per body for every thread count)
  const Mat3* dI = d.dI_inv.data();
  by_colour(d, [&](std::size_t first, std::size_t end) {
    for (std::size_t k = first; k < end; ++k) apply_force(d, dI, k);
    return 0.0;
  });
}

// ---- d. restitution -----------------------------------------------------------------------------
/// Newton's law on the contacts flagged restitutive (they approached faster than the threshold and pushed):
/// n^T (v_B - v_A) >= -e u. Returns the sweeps used.
int restitution(const SolverSettings& s, SolverData& d) {
  const std::size_t K = d.u.size();
  if (std::none_of(d.restitutive.begin(), d.restitutive.begin() + K, [](char x) { return x != 0; })) return 0;
  int sweeps = 0;
  bool converged = false;
  while (!converged && sweeps < s.max_iterations) {
    ++sweeps;
    double change = 0.0;
    for (std::size_t k = 0; k < K; ++k) {  // in solve order
      if (d.restitutive[k])
        change = std::max(change, update_normal(d.rows[k], d.dI_inv.data(), d.e[k] * d.u[k], d.alpha[3 * k], d.qd));
    }
    converged = s.tolerance > 0.0 && change <= s.tolerance;
  }
  return sweeps;
}

// ---- f. store -----------------------------------------------------------------------------------
namespace {

/// The next cache sorted by key (first in contact order on equal keys), one entry per key; the
/// narrow phase lists contacts by body pair and feature ids, so it is usually sorted already
/// (checked over the threads: each range with the entry before it; sorted and without repeated
/// keys, the usual case, nothing more is done).
void sort_cache(SolverData& d) {
  const auto before = [](const CachedContact& x, const CachedContact& y) {
    return key_less(x, y) || (same_key(x, y) && x.order < y.order);
  };
  std::atomic<bool> unsorted{false}, repeats{false};
  for_ranges(d, d.cache_next.size(), 4096, [&](std::size_t first, std::size_t end) {
    bool down = false, same = false;
    for (std::size_t k = std::max<std::size_t>(first, 1); k < end && !down; ++k) {
      down = before(d.cache_next[k], d.cache_next[k - 1]);
      same = same || same_key(d.cache_next[k], d.cache_next[k - 1]);
    }
    if (down) unsorted.store(true, std::memory_order_relaxed);
    if (same) repeats.store(true, std::memory_order_relaxed);
  });
  if (unsorted.load()) std::sort(d.cache_next.begin(), d.cache_next.end(), before);
  if (unsorted.load() || repeats.load())
    d.cache_next.erase(std::unique(d.cache_next.begin(), d.cache_next.end(), same_key), d.cache_next.end());
}

/// Asks early for what store reads of the contact at solve position j: its rows (whole, or only
/// t1 and t2), forces, normal force and soft point.
[[gnu::always_inline]] inline void ask_ahead(const SolverData& d, const std::vector<SoftPoint>* soft, std::size_t j,
                                             bool whole_rows) {
  if (whole_rows) prefetch_read(&d.rows[j], sizeof(ContactRows));
  else prefetch_read(&d.rows[j].t1, 2 * sizeof(Vec3));
  prefetch_read(&d.alpha[3 * j], 3 * sizeof(double));
  prefetch_read(&d.alpha_iter[j], sizeof(double));
  if (soft) prefetch_read(&(*soft)[j], sizeof(SoftPoint));
}

/// Contact c's forces from its rows r at solve position k: alpha (normal force), impulse (dt
/// alpha, or with soft its substeps' summed impulse), friction alpha_t1 t1 + alpha_t2 t2 (on B; A
/// gets the opposite) and spin_torque (n on B, the opposite on A).
inline void contact_forces(double dt, const SolverData& d, const std::vector<SoftPoint>* soft, std::size_t k,
                           const ContactRows& r, Contact& c) {
  const double* alpha = &d.alpha[3 * k];
  c.alpha = alpha[0];
  c.impulse = soft ? (*soft)[k].impulse : dt * alpha[0];
  c.friction = alpha[1] * r.t1 + alpha[2] * r.t2;
  const int spin = d.spin_rows.empty() ? -1 : d.spin_slot[k];
  c.spin_torque = spin >= 0 ? d.spin_alpha[spin] : 0.0;
}

/// The next step's warm-start entry of contact c (contact i, solve position k): its key, its force
/// before restitution (d.alpha_iter), its friction and spin torque, its contact order.
inline void cache_entry(SolverData& d, std::size_t i, std::size_t k, const Contact& c) {
  CachedContact& e = d.cache_next[i];
  e.body_a = c.body_a;
  e.body_b = c.body_b;
  e.feature_a = c.feature_a;
  e.feature_b = c.feature_b;
  e.alpha = d.alpha_iter[k];
  e.friction = c.friction;
  e.spin = c.spin_torque;
  e.order = static_cast<int>(i);
}

/// store without the report (store's report = false): each contact's forces and impulse, its
/// touching flag and the next cache only.
void store_forces(double dt, std::vector<Contact>& contacts, SolverData& d, const std::vector<SoftPoint>* soft) {
  const std::size_t K = contacts.size();
  d.cache_next.resize(K);
  d.touches.resize(K);
  for_ranges(d, K, 512, [&](std::size_t first, std::size_t end) {
    for (std::size_t i = first; i < end; ++i) {
      if (i + kAhead < end) ask_ahead(d, soft, static_cast<std::size_t>(d.slot[i + kAhead]), false);
      const std::size_t k = static_cast<std::size_t>(d.slot[i]);
      Contact& c = contacts[i];
      contact_forces(dt, d, soft, k, d.rows[k], c);
      d.touches[i] = c.impulse > 0.0 || c.gap < 0.0;
      cache_entry(d, i, k, c);
    }
  });
  sort_cache(d);
}

}  // namespace

/// Forces and velocities per contact, summed forces per body, the next cache, the certificate.
void store(double dt, const SolverSettings& s, std::vector<Contact>& contacts, SolverData& d, SolverStats& stats,
           const std::vector<SoftPoint>* soft, bool report) {
  const std::size_t K = contacts.size();
  if (!report) return store_forces(dt, contacts, d, soft);
  d.cache_next.resize(K);
  d.contact_torque.resize(2 * K);  // every entry is written below, contact by contact
  d.contact_force.resize(K);
  d.contact_body.resize(2 * K);
  d.touches.resize(K);
  // each contact's own outputs and the certificate's maxima (max: the same whatever the order the
  // parts are joined in), split over the threads; the bodies' sums below in contact order
  const SolverStats start = stats;
  std::mutex joined;
  // in contact order, as the contacts, the cache and the per-contact sums are written (four
  // arrays in turn), reaching the rows, forces and soft points by solve position, asked for early
  // (in solve order, the four written arrays were the ones reached out of order: 15 % slower on
  // the 5,050-cube pyramid)
  for_ranges(d, K, 512, [&](std::size_t first, std::size_t end) {
    SolverStats part = start;
    for (std::size_t i = first; i < end; ++i) {
      if (i + kAhead < end) {
        ask_ahead(d, soft, static_cast<std::size_t>(d.slot[i + kAhead]), true);
        prefetch_write(&contacts[i + kAhead], sizeof(Contact));  // written whole, read for its key
      }
      if (i + kAhead / 2 < end) {  // the bodies' velocities, read by index (the contact is in by now)
        const Contact& ahead = contacts[i + kAhead / 2];
        prefetch_read(&d.qd[static_cast<std::size_t>(ahead.body_a)], sizeof(BodyVelocity));
        prefetch_read(&d.qd[static_cast<std::size_t>(ahead.body_b)], sizeof(BodyVelocity));
      }
      const std::size_t k = static_cast<std::size_t>(d.slot[i]);
      Contact& c = contacts[i];
      const ContactRows& r = d.rows[k];
      const double* alpha = &d.alpha[3 * k];
      contact_forces(dt, d, soft, k, r, c);
      c.force = alpha[0] * c.normal + c.friction;  // on B (A gets the opposite)
      const int spin = d.spin_rows.empty() ? -1 : d.spin_slot[k];  // its spin row, for the certificate
      // the torques the contact puts on A and B about their centres: the force at the lever arm,
      // and torsional friction (-t n on A, t n on B); for each body's sums below
      const Vec3 spin_torque = c.spin_torque * c.normal;
      d.contact_torque[2 * i] = -r.r_a.cross(c.force) - spin_torque;
      d.contact_torque[2 * i + 1] = r.r_b.cross(c.force) + spin_torque;
      d.contact_force[i] = c.force;
      d.contact_body[2 * i] = c.body_a;
      d.contact_body[2 * i + 1] = c.body_b;
      d.touches[i] = c.impulse > 0.0 || c.gap < 0.0;
      // velocities after the solve: normal and slip
      const Vec3 dv = point_velocity(r, d.qd[r.a], d.qd[r.b]);
      const double vn = r.n.dot(dv);
      const double vt1 = r.t1.dot(dv), vt2 = r.t2.dot(dv);
      c.normal_velocity = vn;
      c.slip = vt1 * r.t1 + vt2 * r.t2;

      // the certificate: w_i against the row's own target
      // (the soft step's target: the rigid contact at its end gap, closed if speculative, no more)
      const double bias = soft ? std::max((*soft)[k].s, 0.0) / dt : r.bias;
      const double b = d.restitutive[k] ? d.e[k] * d.u[k] : bias;
      const double w = vn + b;
      const double mu = r.mu;
      part.max_alpha_negative = std::max(part.max_alpha_negative, -alpha[0]);
      part.max_penetration_velocity = std::max(part.max_penetration_velocity, -w);
      part.max_complementarity = std::max(part.max_complementarity, std::abs(alpha[0] * w));
      part.max_cone_violation = std::max(part.max_cone_violation, c.friction.norm() - mu * alpha[0]);
      const double slip_speed = c.slip.norm();
      if (slip_speed > kSlidingSpeed)
        part.max_dissipation_violation = std::max(part.max_dissipation_violation,
                                                   (c.friction + (mu * alpha[0] / slip_speed) * c.slip).norm());
      part.max_overlap = std::max(part.max_overlap, -c.gap);
      // natural residual delta |alpha - P(alpha - w / delta)| per row
      if (r.delta[0] > 0.0) {
        part.residual = std::max(part.residual, r.delta[0] * std::abs(alpha[0] - std::max(alpha[0] - w / r.delta[0], 0.0)));
        const double bound = mu * alpha[0];
        if (s.friction_cone == FrictionCone::Cone) {
          const double delta_t = std::max(r.delta[1], r.delta[2]);
          double p1 = alpha[1] - vt1 / delta_t, p2 = alpha[2] - vt2 / delta_t;
          clamp_to_disk(p1, p2, bound);
          part.residual = std::max({part.residual, delta_t * std::abs(alpha[1] - p1), delta_t * std::abs(alpha[2] - p2)});
        } else {
          const double p1 = std::clamp(alpha[1] - vt1 / r.delta[1], -bound, bound);
          const double p2 = std::clamp(alpha[2] - vt2 / r.delta[2], -bound, bound);
          part.residual = std::max({part.residual, r.delta[1] * std::abs(alpha[1] - p1), r.delta[2] * std::abs(alpha[2] - p2)});
        }
        if (spin >= 0) {  // the spin row: P onto [-mu_spin alpha_n, mu_spin alpha_n] (rad/s)
          const SpinRow& q = d.spin_rows[spin];
          const double spin_bound = q.mu_spin * alpha[0];
          const double p = std::clamp(c.spin_torque - spin_velocity(q, d.qd[c.body_a], d.qd[c.body_b]) / q.delta,
                                      -spin_bound, spin_bound);
          part.residual = std::max(part.residual, q.delta * std::abs(c.spin_torque - p));
        }
      }

      // the cache for the next step's warm start: the force before restitution
      cache_entry(d, i, k, c);
    }
    const std::lock_guard<std::mutex> lock(joined);
    stats.residual = std::max(stats.residual, part.residual);
    stats.max_alpha_negative = std::max(stats.max_alpha_negative, part.max_alpha_negative);
    stats.max_penetration_velocity = std::max(stats.max_penetration_velocity, part.max_penetration_velocity);
    stats.max_complementarity = std::max(stats.max_complementarity, part.max_complementarity);
    stats.max_cone_violation = std::max(stats.max_cone_violation, part.max_cone_violation);
    stats.max_dissipation_violation = std::max(stats.max_dissipation_violation, part.max_dissipation_violation);
    stats.max_overlap = std::max(stats.max_overlap, part.max_overlap);
  });
  // each body's summed force and torque (N, N m), in contact order: the bodies with contacts are
  // listed (d.forced, in the order of their first contact), and the sums split by body index over
  // the pool's participants, each walking every contact's two entries in contact order and adding
  // those of its own bodies. So every thread count adds the same terms in the same order, no
  // per-body list is built on the calling thread, and each participant reads the 2K entries once
  for (std::size_t e = 0; e < 2 * K; ++e) mark_forced(d, d.contact_body[e]);
  const std::size_t N = d.body_force.size();
  const std::size_t parts = d.pool != nullptr && K > kContactsPerTask ? static_cast<std::size_t>(d.pool->threads()) : 1;
  const auto sum_part = [&](std::size_t part) {
    const auto lo = static_cast<BodyIndex>(N * part / parts), hi = static_cast<BodyIndex>(N * (part + 1) / parts);
    for (std::size_t e = 0; e < 2 * K; ++e) {  // 2i: contact i's body A, 2i + 1: its body B
      const BodyIndex x = d.contact_body[e];
      if (x < lo || x >= hi) continue;
      const Vec3& contact_force = d.contact_force[e / 2];
      if (e % 2 == 0) d.body_force[static_cast<std::size_t>(x)] -= contact_force;
      else d.body_force[static_cast<std::size_t>(x)] += contact_force;
      d.body_torque[static_cast<std::size_t>(x)] += d.contact_torque[e];
    }
  };
  if (parts == 1) sum_part(0);
  else d.pool->join(sum_part);
  sort_cache(d);
  // maxima of violations: 0 when nothing violates (and when there are no contacts)
  stats.max_alpha_negative = std::max(stats.max_alpha_negative, 0.0);
  stats.max_penetration_velocity = std::max(stats.max_penetration_velocity, 0.0);
  stats.max_cone_violation = std::max(stats.max_cone_violation, 0.0);
  stats.max_overlap = std::max(stats.max_overlap, 0.0);
}

}  // namespace signorini::solver::rows

namespace signorini::solver {

void tangent_basis(const Vec3& n, Vec3& t1, Vec3& t2) {
  // the first axis within kTangentTie of the smallest |n_k|: a normal of a stack or a wall has two
  // components that are zero up to rounding, and choosing between them by their rounding noise
  // would turn the friction pyramid by 90 degrees from one computation of the normal to the next
  const Vec3 m = n.cwiseAbs();
  const double least = m.minCoeff() + rows::kTangentTie;
  const int k = m[0] <= least ? 0 : m[1] <= least ? 1 : 2;
  t1 = n.cross(Vec3::Unit(k)).normalized();
  t2 = n.cross(t1);
}

}  // namespace signorini::solver
