// The soft step's sweep and warm start over WideGroups in the lanes of one ISA (solver/wide_rows.hpp), included
// once per ISA by wide_kernel_sse2.cpp and wide_kernel_avx2.cpp (compiled with -mavx2). xsimd
// gives the registers and their operations; nothing here calls Eigen or the standard library.
//
// Every lane repeats the scalar code's operations (rows.hpp, contact_rows with SoftNormal and
// apply_force; soft_contact.hpp, gap_now) in the same order, so the results are the same bits: a sum of three
// products is (x0 y0 + x1 y1) + x2 y2 as Eigen's dot; a 3 x 3 matrix times a vector is, row by
// row, (m_i0 x0 + m_i1 x1) + m_i2 x2 for the first two rows and m_20 x0 + (m_21 x1 + m_22 x2) for
// the third, as Eigen's fixed-size product evaluates them at the library's compile flags (ctest
// WideRows.* checks the bits against the scalar sweep); std::max(x, y) is y when x < y, else x;
// std::clamp(v, lo, hi) is lo when v < lo, else hi when hi < v, else v.
#pragma once

#include <cstddef>
#include <utility>

#include <xsimd/xsimd.hpp>

#include "solver/wide_rows.hpp"

namespace signorini::solver::wide {
namespace {

template <class Arch>
struct Kernel {
  using B = xsimd::batch<double, Arch>;
  using Mask = xsimd::batch_bool<double, Arch>;
  static constexpr std::size_t L = B::size;  // lanes per register: a group is kLanes / L registers wide

  struct V3 {
    B x, y, z;
  };

  static B load(const double* p) { return B::load_aligned(p); }
  static V3 load3(const double (&p)[3][kLanes], std::size_t h) { return {load(p[0] + h), load(p[1] + h), load(p[2] + h)}; }
  static V3 add(const V3& a, const V3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
  static V3 sub(const V3& a, const V3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
  static V3 scale(const B& s, const V3& a) { return {s * a.x, s * a.y, s * a.z}; }
  static B dot(const V3& a, const V3& b) { return (a.x * b.x + a.y * b.y) + a.z * b.z; }
  static V3 cross(const V3& a, const V3& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
  }
  /// m x with m[9] a 3 x 3 matrix per lane, column-major (m[3 j + i] = m_ij)
  static V3 mul(const B* m, const V3& x) {
    return {(m[0] * x.x + m[3] * x.y) + m[6] * x.z, (m[1] * x.x + m[4] * x.y) + m[7] * x.z,
            m[2] * x.x + (m[5] * x.y + m[8] * x.z)};
  }
  /// The same, m's entries read from a group's lanes h .. h + L - 1 as they are used (from L1:
  /// cheaper than holding 9 registers that spill)
  static V3 mul(const double (&m)[9][kLanes], std::size_t h, const V3& x) {
    return {(load(m[0] + h) * x.x + load(m[3] + h) * x.y) + load(m[6] + h) * x.z,
            (load(m[1] + h) * x.x + load(m[4] + h) * x.y) + load(m[7] + h) * x.z,
            load(m[2] + h) * x.x + (load(m[5] + h) * x.y + load(m[8] + h) * x.z)};
  }
  static V3 select3(const Mask& c, const V3& a, const V3& b) {
    return {xsimd::select(c, a.x, b.x), xsimd::select(c, a.y, b.y), xsimd::select(c, a.z, b.z)};
  }
  /// std::max(x, y) and std::clamp(v, lo, hi), lane by lane (NaN and signed zeros as they give)
  static B max_of(const B& x, const B& y) { return xsimd::select(x < y, y, x); }
  static B clamp(const B& v, const B& lo, const B& hi) { return xsimd::select(v < lo, lo, xsimd::select(hi < v, hi, v)); }

  /// L lanes' values f(l) as one register, built in registers (no store of single lanes read back
  /// as a vector, which stalls the load on store forwarding)
  template <class F, std::size_t... I>
  static B gather(F&& f, std::index_sequence<I...>) {
    return B{static_cast<double>(f(I))...};
  }
  template <class F>
  static B gather(F&& f) {
    return gather(f, std::make_index_sequence<L>());
  }
  /// n consecutive doubles from base + stride * index[l] for each lane, as n registers
  template <int n>
  static void gather_n(const double* base, std::size_t stride, const int* index, B* out) {
    const double* p[L];
    for (std::size_t l = 0; l < L; ++l) p[l] = base + stride * static_cast<std::size_t>(index[l]);
    for (int j = 0; j < n; ++j) out[j] = gather([&](std::size_t l) { return p[l][j]; });
  }

  /// L lanes' ints i[l] as doubles (small counts: exact)
  static B as_doubles(const int* i) {
    return gather([&](std::size_t l) { return static_cast<double>(i[l]); });
  }

  /// Lanes h .. h + L - 1 of a group: their pairs' bodies' velocities (omega, v of A and of B),
  /// read once for all the pairs' points, and where their inverse inertias are (read as used).
  /// Filled in place (load_pairs): returned by value, the compiler copied it twice per group.
  struct Pairs {
    V3 wa, va, wb, vb;
    const WideGroup* g;
    std::size_t h;
    Mask a_moves, b_moves;  // a body that does not move keeps its velocity (static: zero; kinematic: its own)
  };
  /// The pairs' bodies' per-body entries (omega, v) of lanes h .. h + L - 1 from `from` (d.qd, or d.kick).
  static void load_velocities(const double* from, const WideGroup& g, std::size_t h, Pairs& q) {
    B qa[6], qb[6];
    gather_n<6>(from, 6, g.a + h, qa);
    gather_n<6>(from, 6, g.b + h, qb);
    q.wa = {qa[0], qa[1], qa[2]};
    q.va = {qa[3], qa[4], qa[5]};
    q.wb = {qb[0], qb[1], qb[2]};
    q.vb = {qb[3], qb[4], qb[5]};
  }
  static void load_pairs(const Lanes& d, const WideGroup& g, std::size_t h, Pairs& q) {
    load_velocities(d.qd, g, h, q);
    q.g = &g;
    q.h = h;
    const B zero(0.0);
    q.a_moves = gather([&](std::size_t l) { return g.a_moves[h + l] ? 1.0 : 0.0; }) != zero;
    q.b_moves = gather([&](std::size_t l) { return g.b_moves[h + l] ? 1.0 : 0.0; }) != zero;
  }
  /// The velocities back (into `to`: d.qd, or d.kick), for the bodies that move.
  static void store_pairs(double* to, const WideGroup& g, std::size_t h, const Pairs& q) {
    alignas(64) double out[12][L];
    const B* parts[12] = {&q.wa.x, &q.wa.y, &q.wa.z, &q.va.x, &q.va.y, &q.va.z,
                          &q.wb.x, &q.wb.y, &q.wb.z, &q.vb.x, &q.vb.y, &q.vb.z};
    for (int i = 0; i < 12; ++i) parts[i]->store_aligned(out[i]);
    for (std::size_t l = 0; l < L; ++l) {
      if (g.a_moves[h + l]) {
        double* v = to + 6 * static_cast<std::size_t>(g.a[h + l]);
        for (int i = 0; i < 6; ++i) v[i] = out[i][l];
      }
      if (g.b_moves[h + l]) {
        double* v = to + 6 * static_cast<std::size_t>(g.b[h + l]);
        for (int i = 0; i < 6; ++i) v[i] = out[6 + i][l];
      }
    }
  }
  static void store_pairs(const Lanes& d, const WideGroup& g, std::size_t h, const Pairs& q) { store_pairs(d.qd, g, h, q); }
  /// q_dot += the force P (N: the rows' forces summed along their directions; dt is folded into
  /// dI and dinv_mass) on B at r_b and -P on A at r_a, in the lanes where `where` holds and for the
  /// bodies that move (rows.hpp, push).
  static void push(Pairs& q, const Mask& where, const V3& r_a, const V3& r_b, const V3& P, const B& dinv_mass_a,
                   const B& dinv_mass_b) {
    const Mask on_a = where && q.a_moves, on_b = where && q.b_moves;
    q.wa = select3(on_a, sub(q.wa, mul(q.g->dI_a, q.h, cross(r_a, P))), q.wa);
    q.va = select3(on_a, sub(q.va, scale(dinv_mass_a, P)), q.va);
    q.wb = select3(on_b, add(q.wb, mul(q.g->dI_b, q.h, cross(r_b, P))), q.wb);
    q.vb = select3(on_b, add(q.vb, scale(dinv_mass_b, P)), q.vb);
  }

  /// What a sweep reads of lanes h .. h + L - 1 of a group before its points: the pairs (q; and,
  /// kKick, their bodies' entries of d.kick), how far their bodies have moved (kGap), their
  /// masses, friction, directions, a round side's n . dR n terms, and their springs (biased).
  struct Frame {
    Pairs q, kick;
    B dRa[9], dRb[9], dpa[3], dpb[3];
    B dinv_mass_a, dinv_mass_b, mu;
    V3 n, t1, t2;
    B n_dRa_n, n_dRb_n;
    B ms, rate, is;
  };
  template <bool kGap, bool kKick>
  static void load_frame(const SoftSweep& x, const Lanes& d, const WideGroup& g, std::size_t h, Frame& f) {
    const B zero(0.0), one(1.0);
    load_pairs(d, g, h, f.q);
    if constexpr (kKick) {  // the same pairs and masks, the bodies' entries of d.kick
      f.kick = f.q;
      load_velocities(d.kick, g, h, f.kick);
    }
    if constexpr (kGap) {
      gather_n<9>(d.dR, 9, g.a + h, f.dRa);
      gather_n<9>(d.dR, 9, g.b + h, f.dRb);
      gather_n<3>(d.dp, 3, g.a + h, f.dpa);
      gather_n<3>(d.dp, 3, g.b + h, f.dpb);
    }
    f.dinv_mass_a = load(g.dinv_mass_a + h);
    f.dinv_mass_b = load(g.dinv_mass_b + h);
    f.mu = load(g.mu + h);
    f.n = load3(g.n, h);
    f.t1 = load3(g.t1, h);
    f.t2 = load3(g.t2, h);
    // a round side's carried point is its core (gap_now): n . dR n of each pair's bodies
    f.n_dRa_n = zero;
    f.n_dRb_n = zero;
    if constexpr (kGap) {
      if (g.round) {
        f.n_dRb_n = dot(f.n, mul(f.dRb, f.n));
        f.n_dRa_n = dot(f.n, mul(f.dRa, f.n));
      }
    }
    f.ms = one;  // the pairs' springs
    f.rate = zero;
    f.is = zero;
    if (x.biased) {
      f.ms = load(g.mass_scale + h);
      f.rate = load(g.bias_rate + h);
      f.is = load(g.impulse_scale + h);
    }
  }
  /// A point's gap: brought up to date (gap_now) and stored with kGap, else as stored.
  /// n: the point's normal (the pair's, f.n, unless the group has a frame; never with a round side)
  template <bool kGap>
  static B point_gap(const Frame& f, const WideGroup& g, WideGroup::Point& pt, std::size_t h, const V3& r_a,
                     const V3& r_b, const V3& n) {
    if constexpr (kGap) {
      // gap_now: gap0 + n . ((dp_B + dR_B r_B) - (dp_A + dR_A r_A))
      const V3 moved_b = add({f.dpb[0], f.dpb[1], f.dpb[2]}, mul(f.dRb, r_b));
      const V3 moved_a = add({f.dpa[0], f.dpa[1], f.dpa[2]}, mul(f.dRa, r_a));
      B s = load(pt.gap0 + h) + dot(n, sub(moved_b, moved_a));
      if (g.round) s = s + (load(pt.sigma_b + h) * f.n_dRb_n + load(pt.sigma_a + h) * f.n_dRa_n);
      s.store_aligned(pt.s + h);  // (a lane past its last point writes its own unused slot)
      return s;
    } else {
      return load(pt.s + h);
    }
  }
  /// The normal row's rule at gap s (soft_rule): speculative (s > 0) closes its gap; an overlap is
  /// the spring in a biased sweep, rigid in a relax sweep.
  static void point_rule(const SoftSweep& x, const Frame& f, const B& s, B& bias, B& mass_scale, B& impulse_scale) {
    const B zero(0.0), one(1.0), inv_h(x.inv_h), max_push(-x.max_push_velocity);
    const Mask speculative = s > zero;
    bias = xsimd::select(speculative, s * inv_h, zero);
    mass_scale = one;
    impulse_scale = zero;
    if (x.biased) {
      bias = xsimd::select(speculative, bias, max_of(f.ms * f.rate * s, max_push));
      mass_scale = xsimd::select(speculative, one, f.ms);
      impulse_scale = xsimd::select(speculative, zero, f.is);
    }
  }

  /// Asks the memory for the groups ahead of group gi of [group, end) (a hint: it changes no
  /// result). A group is some 4 kB, about a page, so the processor's own prefetcher, which stops at
  /// a page's end, does not run ahead of the walk: without this a sweep waited on the memory at
  /// each group's first field and each point's first (a third of the biased sweep's time on the
  /// 5,050-cube pyramid). Two stages: the fields before the points of group gi + 2, and the points
  /// the sweeps read of group gi + 1 (its count was asked for one group earlier).
  /// A group with a frame (read only) has its points' directions asked for with its points.
  [[gnu::always_inline]] static void ask_ahead(const Lanes& d, std::size_t gi, std::size_t end) {
    const WideGroup* groups = d.groups;
    if (gi + 2 < end) {
      const char* head = reinterpret_cast<const char*>(&groups[gi + 2].n);
      const char* tail = reinterpret_cast<const char*>(groups + gi + 3);
      for (const char* c = head; c < tail; c += 64) __builtin_prefetch(c, 1);
    }
    if (gi + 1 < end) {
      const WideGroup& next = groups[gi + 1];
      const char* first = reinterpret_cast<const char*>(&next.point[0]);
      const char* last = reinterpret_cast<const char*>(&next.point[next.points]);
      for (const char* c = first; c < last; c += 64) __builtin_prefetch(c, 1);
      if (next.frame >= 0) {
        const char* frame = reinterpret_cast<const char*>(d.frames + next.frame);
        for (std::size_t o = 0; o < sizeof(PointFrames); o += 64) __builtin_prefetch(frame + o, 0);
      }
    }
  }
  /// Point j's directions in lanes h .. h + L - 1: the pair's (f.n, f.t1, f.t2), or the group's
  /// frame's (pf not null).
  static void point_frame(const PointFrames* pf, int j, std::size_t h, const V3& n, const V3& t1, const V3& t2,
                          V3& n_j, V3& t1_j, V3& t2_j) {
    if (pf) {
      n_j = load3(pf->n[j], h);
      t1_j = load3(pf->t1[j], h);
      t2_j = load3(pf->t2[j], h);
    } else {
      n_j = n;
      t1_j = t1;
      t2_j = t2;
    }
  }

  /// The warm start over the groups (rows.cpp, apply_forces): each point's three forces as one
  /// impulse on its pair's bodies, point after point in solve order.
  static void warm_start(const Lanes& d, std::size_t group, std::size_t groups) {
    const B zero(0.0);
    for (std::size_t gi = group; gi < group + groups; ++gi) {
      ask_ahead(d, gi, group + groups);
      const WideGroup& g = d.groups[gi];
      for (std::size_t h = 0; h < kLanes; h += L) {
        Pairs q;
        load_pairs(d, g, h, q);
        const B dinv_mass_a = load(g.dinv_mass_a + h), dinv_mass_b = load(g.dinv_mass_b + h);
        const B count = as_doubles(g.count + h);
        const V3 n_pair = load3(g.n, h), t1_pair = load3(g.t1, h), t2_pair = load3(g.t2, h);
        const PointFrames* pf = g.frame >= 0 ? d.frames + g.frame : nullptr;
        for (int j = 0; j < g.points; ++j) {
          const WideGroup::Point& pt = g.point[j];
          V3 n, t1, t2;
          point_frame(pf, j, h, n_pair, t1_pair, t2_pair, n, t1, t2);
          const B a0 = load(pt.alpha[0] + h), a1 = load(pt.alpha[1] + h), a2 = load(pt.alpha[2] + h);
          const Mask any = ((a0 != zero) || (a1 != zero) || (a2 != zero)) && (B(static_cast<double>(j)) < count);
          const V3 P = add(add(scale(a0, n), scale(a1, t1)), scale(a2, t2));
          push(q, any, load3(pt.r_a, h), load3(pt.r_b, h), P, dinv_mass_a, dinv_mass_b);
        }
        store_pairs(d, g, h, q);
      }
    }
  }

  /// SoftSweep::accumulate: the point's last force f0 in lanes h .. h + L - 1 added to its impulse
  /// (h alpha_n) and its largest force, as wide_accumulate adds them (every lane: a lane past its
  /// last point adds to its unused slot, never read).
  static void accumulate(const SoftSweep& x, WideGroup::Point& pt, std::size_t h, const B& f0) {
    (load(pt.impulse + h) + B(x.h) * f0).store_aligned(pt.impulse + h);
    max_of(load(pt.alpha_max + h), f0).store_aligned(pt.alpha_max + h);
  }

  /// One sweep over the groups: each lane's pair, point after point in solve order, its two bodies'
  /// velocities kept in registers from the first point to the last.
  /// kKick (SoftSweep::kick): each point's forces as it leaves the sweep are also added, as the
  /// warm start would apply them, to its bodies' entries of d.kick, point after point (the same
  /// sums in the same order as the scalar code's rows::apply_force on d.kick).
  template <bool kGap, bool kKick>
  static void run(const SoftSweep& x, const Lanes& d, std::size_t group, std::size_t groups) {
    const B zero(0.0);
    for (std::size_t gi = group; gi < group + groups; ++gi) {
      ask_ahead(d, gi, group + groups);
      WideGroup& g = d.groups[gi];
      if (g.two) {
        run_two<kGap, kKick>(x, d, g);
        continue;
      }
      for (std::size_t h = 0; h < kLanes; h += L) {
        Frame f;
        load_frame<kGap, kKick>(x, d, g, h, f);
        Pairs &q = f.q, &kick = f.kick;
        const B dinv_mass_a = f.dinv_mass_a, dinv_mass_b = f.dinv_mass_b, mu = f.mu;
        const B count = as_doubles(g.count + h);
        const PointFrames* pf = g.frame >= 0 ? d.frames + g.frame : nullptr;
        for (int j = 0; j < g.points; ++j) {
          WideGroup::Point& pt = g.point[j];
          V3 n, t1, t2;  // the point's directions
          point_frame(pf, j, h, f.n, f.t1, f.t2, n, t1, t2);
          const Mask active = B(static_cast<double>(j)) < count;
          const V3 r_a = load3(pt.r_a, h), r_b = load3(pt.r_b, h);
          const B s = point_gap<kGap>(f, g, pt, h, r_a, r_b, n);
          B bias, mass_scale, impulse_scale;
          point_rule(x, f, s, bias, mass_scale, impulse_scale);
          const B a_n = load(pt.alpha[0] + h), a_1 = load(pt.alpha[1] + h), a_2 = load(pt.alpha[2] + h);
          // the relative velocity at the point
          const V3 dv = sub(add(q.vb, cross(q.wb, r_b)), add(q.va, cross(q.wa, r_a)));
          // normal
          const B vn = dot(n, dv);
          const B a0 = max_of(a_n - (mass_scale * vn + bias) * load(pt.inv_delta[0] + h) - impulse_scale * a_n, zero);
          const B d0 = a0 - a_n;
          // friction, bounded by mu times the new normal force
          const B bound = mu * a0;
          const B u1 = dot(t1, dv) + load(pt.W_1n + h) * d0;
          B a1 = clamp(a_1 - u1 * load(pt.inv_delta[1] + h), -bound, bound);
          B d1 = a1 - a_1;
          const B u2 = dot(t2, dv) + (load(pt.W_2n + h) * d0 + load(pt.W_21 + h) * d1);
          B a2 = clamp(a_2 - u2 * load(pt.inv_delta[2] + h), -bound, bound);
          B d2 = a2 - a_2;
          const Mask unbounded = bound == zero;  // a zero bound projects friction to 0
          d1 = xsimd::select(unbounded, -a_1, d1);
          d2 = xsimd::select(unbounded, -a_2, d2);
          a1 = xsimd::select(unbounded, zero, a1);
          a2 = xsimd::select(unbounded, zero, a2);
          // the three changes as one impulse on B (the opposite on A), where any changed
          const Mask moved = ((d0 != zero) || (d1 != zero) || (d2 != zero)) && active;
          const V3 P = add(add(scale(d0, n), scale(d1, t1)), scale(d2, t2));
          push(q, moved, r_a, r_b, P, dinv_mass_a, dinv_mass_b);
          // the point's forces (a lane past its last point keeps its unused slot as it was)
          const B f0 = xsimd::select(active, a0, a_n), f1 = xsimd::select(active, a1, a_1),
                  f2 = xsimd::select(active, a2, a_2);
          f0.store_aligned(pt.alpha[0] + h);
          f1.store_aligned(pt.alpha[1] + h);
          f2.store_aligned(pt.alpha[2] + h);
          if (x.accumulate) accumulate(x, pt, h, f0);
          if constexpr (kKick) {  // the next substep's warm start of this point (warm_start's sums)
            const Mask any = ((f0 != zero) || (f1 != zero) || (f2 != zero)) && active;
            push(kick, any, r_a, r_b, add(add(scale(f0, n), scale(f1, t1)), scale(f2, t2)), dinv_mass_a, dinv_mass_b);
          }
        }
        store_pairs(d, g, h, q);
        if constexpr (kKick) store_pairs(d.kick, g, h, kick);
      }
    }
  }

  /// One sweep over a group of two-point pairs (WideGroup::two), the scalar soft_pair lane by
  /// lane: both normal rows as one block (rows::pair_side, rows::solve_pair), their changes
  /// applied point after point, then each point's friction rows (soft_pair's pair_friction, the
  /// pyramid), then (kKick) each point's forces into d.kick.
  template <bool kGap, bool kKick>
  static void run_two(const SoftSweep& x, const Lanes& d, WideGroup& g) {
    const B zero(0.0), conditioning(kPairConditioning);
    for (std::size_t h = 0; h < kLanes; h += L) {
      Frame f;
      load_frame<kGap, kKick>(x, d, g, h, f);
      Pairs &q = f.q, &kick = f.kick;
      const B dinv_mass_a = f.dinv_mass_a, dinv_mass_b = f.dinv_mass_b, mu = f.mu;
      const V3 &n = f.n, &t1 = f.t1, &t2 = f.t2;
      WideGroup::Point* pt[2] = {&g.point[0], &g.point[1]};
      V3 r_a[2], r_b[2];
      B bias[2], mass_scale[2], impulse_scale[2], a_n[2], vn[2];
      for (int j = 0; j < 2; ++j) {
        r_a[j] = load3(pt[j]->r_a, h);
        r_b[j] = load3(pt[j]->r_b, h);
        point_rule(x, f, point_gap<kGap>(f, g, *pt[j], h, r_a[j], r_b[j], f.n), bias[j], mass_scale[j],
                   impulse_scale[j]);
        a_n[j] = load(pt[j]->alpha[0] + h);
      }
      // both normal rows' velocities before either changes
      for (int j = 0; j < 2; ++j) {
        const V3 dv = sub(add(q.vb, cross(q.wb, r_b[j])), add(q.va, cross(q.wa, r_a[j])));
        vn[j] = dot(n, dv);
      }
      // the block (rows::pair_side, rows::solve_pair: the first case that holds, else the fallback)
      const B K11 = load(g.K11 + h), K22 = load(g.K22 + h), K12 = load(g.K12 + h);
      const B K12s = mass_scale[0] * K12, K21s = mass_scale[1] * K12;  // each row's coupling, soft
      const B own1 = K11 * a_n[0], own2 = K22 * a_n[1];
      const B c1 = ((own1 + K12s * a_n[1]) - impulse_scale[0] * own1) - (mass_scale[0] * vn[0] + bias[0]);
      const B c2 = ((own2 + K21s * a_n[0]) - impulse_scale[1] * own2) - (mass_scale[1] * vn[1] + bias[1]);
      const B det = K11 * K22 - K12s * K21s;
      const Mask well = det >= conditioning * (K11 * K22);
      const B y1 = (K22 * c1 - K12s * c2) / det, y2 = (K11 * c2 - K21s * c1) / det;
      const B z1 = c1 / K11, z2 = c2 / K22;
      const Mask both = well && (y1 >= zero) && (y2 >= zero);
      const Mask first = (z1 >= zero) && (K21s * z1 - c2 >= zero);
      const Mask second = (z2 >= zero) && (K12s * z2 - c1 >= zero);
      const Mask neither = (c1 <= zero) && (c2 <= zero);
      B f1 = max_of(z1, zero), f2 = zero;
      f1 = xsimd::select(neither, zero, f1);
      f2 = xsimd::select(neither, zero, f2);
      f1 = xsimd::select(second, zero, f1);
      f2 = xsimd::select(second, z2, f2);
      f1 = xsimd::select(first, z1, f1);
      f2 = xsimd::select(first, zero, f2);
      f1 = xsimd::select(both, y1, f1);
      f2 = xsimd::select(both, y2, f2);
      const B force[2] = {f1, f2};
      for (int j = 0; j < 2; ++j) {
        const B d0 = force[j] - a_n[j];
        push(q, d0 != zero, r_a[j], r_b[j], scale(d0, n), dinv_mass_a, dinv_mass_b);
        force[j].store_aligned(pt[j]->alpha[0] + h);
      }
      // each point's friction rows (pair_friction), from the velocity at the point now
      for (int j = 0; j < 2; ++j) {
        WideGroup::Point& p = *pt[j];
        const B a_1 = load(p.alpha[1] + h), a_2 = load(p.alpha[2] + h);
        const B bound = mu * force[j];
        const V3 dv = sub(add(q.vb, cross(q.wb, r_b[j])), add(q.va, cross(q.wa, r_a[j])));
        B a1 = clamp(a_1 - dot(t1, dv) * load(p.inv_delta[1] + h), -bound, bound);
        B d1 = a1 - a_1;
        const B u2 = dot(t2, dv) + load(p.W_21 + h) * d1;
        B a2 = clamp(a_2 - u2 * load(p.inv_delta[2] + h), -bound, bound);
        B d2 = a2 - a_2;
        const Mask unbounded = bound == zero;
        d1 = xsimd::select(unbounded, -a_1, d1);
        d2 = xsimd::select(unbounded, -a_2, d2);
        a1 = xsimd::select(unbounded, zero, a1);
        a2 = xsimd::select(unbounded, zero, a2);
        push(q, (d1 != zero) || (d2 != zero), r_a[j], r_b[j], add(scale(d1, t1), scale(d2, t2)), dinv_mass_a,
             dinv_mass_b);
        a1.store_aligned(p.alpha[1] + h);
        a2.store_aligned(p.alpha[2] + h);
      }
      if (x.accumulate)
        for (int j = 0; j < 2; ++j) accumulate(x, *pt[j], h, force[j]);
      if constexpr (kKick) {  // the next substep's warm start of both points (rows::apply_force's sums)
        for (int j = 0; j < 2; ++j) {
          WideGroup::Point& p = *pt[j];
          const B f0 = load(p.alpha[0] + h), fa = load(p.alpha[1] + h), fb = load(p.alpha[2] + h);
          const Mask any = (f0 != zero) || (fa != zero) || (fb != zero);
          push(kick, any, r_a[j], r_b[j], add(add(scale(f0, n), scale(fa, t1)), scale(fb, t2)), dinv_mass_a,
               dinv_mass_b);
        }
      }
      store_pairs(d, g, h, q);
      if constexpr (kKick) store_pairs(d.kick, g, h, kick);
    }
  }
};

}  // namespace
}  // namespace signorini::solver::wide
