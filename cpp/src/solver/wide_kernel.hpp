// The soft step's sweep over WideGroups in the lanes of one ISA (solver/wide_rows.hpp), included
// once per ISA by wide_kernel_sse2.cpp and wide_kernel_avx2.cpp (compiled with -mavx2). xsimd
// gives the registers and their operations; nothing here calls Eigen or the standard library.
//
// Every lane repeats the scalar sweep's operations (rows.hpp, contact_rows with SoftNormal;
// wide_rows.hpp, gap_now) in the same order, so the results are the same bits: a sum of three
// products is (x0 y0 + x1 y1) + x2 y2 as Eigen's dot; a 3 x 3 matrix times a vector is, row by
// row, (m_i0 x0 + m_i1 x1) + m_i2 x2 for the first two rows and m_20 x0 + (m_21 x1 + m_22 x2) for
// the third, as Eigen's fixed-size product evaluates them at the library's compile flags (ctest
// WideRows.* checks the bits against the scalar sweep); std::max(x, y) is y when x < y, else x;
// std::clamp(v, lo, hi) is lo when v < lo, else hi when hi < v, else v.
#pragma once

#include <cstddef>

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
  static V3 select3(const Mask& c, const V3& a, const V3& b) {
    return {xsimd::select(c, a.x, b.x), xsimd::select(c, a.y, b.y), xsimd::select(c, a.z, b.z)};
  }
  /// std::max(x, y) and std::clamp(v, lo, hi), lane by lane (NaN and signed zeros as they give)
  static B max_of(const B& x, const B& y) { return xsimd::select(x < y, y, x); }
  static B clamp(const B& v, const B& lo, const B& hi) { return xsimd::select(v < lo, lo, xsimd::select(hi < v, hi, v)); }

  /// L lanes' values f(l) as one register
  template <class F>
  static B gather(F&& f) {
    alignas(64) double t[L];
    for (std::size_t l = 0; l < L; ++l) t[l] = f(l);
    return B::load_aligned(t);
  }
  /// n consecutive doubles from base + stride * index[l] for each lane, as n registers
  template <int n>
  static void gather_n(const double* base, std::size_t stride, const int* index, B* out) {
    alignas(64) double t[n][L];
    for (std::size_t l = 0; l < L; ++l) {
      const double* p = base + stride * static_cast<std::size_t>(index[l]);
      for (int j = 0; j < n; ++j) t[j][l] = p[j];
    }
    for (int j = 0; j < n; ++j) out[j] = B::load_aligned(t[j]);
  }

  /// gap_now for lanes h .. h + L - 1 of g: gap0 + n . ((dp_B + dR_B r_B) - (dp_A + dR_A r_A))
  static B gap(const Lanes& d, const WideGroup& g, std::size_t h, std::size_t k0) {
    B dRa[9], dRb[9], dpa[3], dpb[3];
    gather_n<9>(d.dR, 9, g.a + h, dRa);
    gather_n<9>(d.dR, 9, g.b + h, dRb);
    gather_n<3>(d.dp, 3, g.a + h, dpa);
    gather_n<3>(d.dp, 3, g.b + h, dpb);
    const V3 moved_b = add({dpb[0], dpb[1], dpb[2]}, mul(dRb, load3(g.r_b, h)));
    const V3 moved_a = add({dpa[0], dpa[1], dpa[2]}, mul(dRa, load3(g.r_a, h)));
    const B gap0 = gather([&](std::size_t l) { return d.soft[k0 + l].gap0; });
    return gap0 + dot(load3(g.n, h), sub(moved_b, moved_a));
  }

  template <bool kGap>
  static void run(const SoftSweep& x, const Lanes& d, std::size_t group, std::size_t groups, std::size_t position) {
    const B zero(0.0), one(1.0), inv_h(x.inv_h), max_push(-x.max_push_velocity);
    for (std::size_t gi = group; gi < group + groups; ++gi, position += kLanes) {
      const WideGroup& g = d.groups[gi];
      for (std::size_t h = 0; h < kLanes; h += L) {
        const std::size_t k0 = position + h;
        SoftPoint* p = d.soft + k0;
        // the normal row's rule (SoftNormal): speculative (s > 0) closes its gap; an overlap is
        // the spring in a biased sweep, rigid in a relax sweep
        B s;
        if constexpr (kGap) {
          s = gap(d, g, h, k0);
          alignas(64) double t[L];
          s.store_aligned(t);
          for (std::size_t l = 0; l < L; ++l) p[l].s = t[l];
        } else {
          s = gather([&](std::size_t l) { return p[l].s; });
        }
        const Mask speculative = s > zero;
        B bias = xsimd::select(speculative, s * inv_h, zero), mass_scale = one, impulse_scale = zero;
        if (x.biased) {
          const B ms = gather([&](std::size_t l) { return p[l].mass_scale; });
          const B rate = gather([&](std::size_t l) { return p[l].bias_rate; });
          const B is = gather([&](std::size_t l) { return p[l].impulse_scale; });
          bias = xsimd::select(speculative, bias, max_of(ms * rate * s, max_push));
          mass_scale = xsimd::select(speculative, one, ms);
          impulse_scale = xsimd::select(speculative, zero, is);
        }
        // the bodies' velocities and inverse inertias
        B qa[6], qb[6], dIa[9], dIb[9];
        gather_n<6>(d.qd, 6, g.a + h, qa);
        gather_n<6>(d.qd, 6, g.b + h, qb);
        gather_n<9>(d.dI, 9, g.a + h, dIa);
        gather_n<9>(d.dI, 9, g.b + h, dIb);
        const V3 wa{qa[0], qa[1], qa[2]}, va{qa[3], qa[4], qa[5]};
        const V3 wb{qb[0], qb[1], qb[2]}, vb{qb[3], qb[4], qb[5]};
        B a_n = gather([&](std::size_t l) { return d.alpha[3 * (k0 + l)]; });
        B a_1 = gather([&](std::size_t l) { return d.alpha[3 * (k0 + l) + 1]; });
        B a_2 = gather([&](std::size_t l) { return d.alpha[3 * (k0 + l) + 2]; });
        const V3 n = load3(g.n, h), t1 = load3(g.t1, h), t2 = load3(g.t2, h);
        const V3 r_a = load3(g.r_a, h), r_b = load3(g.r_b, h);
        // the relative velocity at the point
        const V3 dv = sub(add(vb, cross(wb, r_b)), add(va, cross(wa, r_a)));
        // normal
        const B vn = dot(n, dv);
        const B a0 = max_of(a_n - (mass_scale * vn + bias) * load(g.inv_delta[0] + h) - impulse_scale * a_n, zero);
        const B d0 = a0 - a_n;
        // friction, bounded by mu times the new normal force
        const B bound = load(g.mu + h) * a0;
        const B u1 = dot(t1, dv) + load(g.W_1n + h) * d0;
        B a1 = clamp(a_1 - u1 * load(g.inv_delta[1] + h), -bound, bound);
        B d1 = a1 - a_1;
        const B u2 = dot(t2, dv) + (load(g.W_2n + h) * d0 + load(g.W_21 + h) * d1);
        B a2 = clamp(a_2 - u2 * load(g.inv_delta[2] + h), -bound, bound);
        B d2 = a2 - a_2;
        const Mask unbounded = bound == zero;  // a zero bound projects friction to 0
        d1 = xsimd::select(unbounded, -a_1, d1);
        d2 = xsimd::select(unbounded, -a_2, d2);
        a1 = xsimd::select(unbounded, zero, a1);
        a2 = xsimd::select(unbounded, zero, a2);
        // the three changes as one impulse on B (the opposite on A), where any changed
        const Mask moved = (d0 != zero) || (d1 != zero) || (d2 != zero);
        const V3 P = add(add(scale(d0, n), scale(d1, t1)), scale(d2, t2));
        const V3 wa_new = sub(wa, mul(dIa, cross(r_a, P)));
        const V3 va_new = sub(va, scale(load(g.dinv_mass_a + h), P));
        const V3 wb_new = add(wb, mul(dIb, cross(r_b, P)));
        const V3 vb_new = add(vb, scale(load(g.dinv_mass_b + h), P));
        // back: the forces, and the velocities of the bodies that move
        alignas(64) double out[15][L];
        a0.store_aligned(out[0]);
        a1.store_aligned(out[1]);
        a2.store_aligned(out[2]);
        const V3 w_a = select3(moved, wa_new, wa), v_a = select3(moved, va_new, va);
        const V3 w_b = select3(moved, wb_new, wb), v_b = select3(moved, vb_new, vb);
        w_a.x.store_aligned(out[3]);
        w_a.y.store_aligned(out[4]);
        w_a.z.store_aligned(out[5]);
        v_a.x.store_aligned(out[6]);
        v_a.y.store_aligned(out[7]);
        v_a.z.store_aligned(out[8]);
        w_b.x.store_aligned(out[9]);
        w_b.y.store_aligned(out[10]);
        w_b.z.store_aligned(out[11]);
        v_b.x.store_aligned(out[12]);
        v_b.y.store_aligned(out[13]);
        v_b.z.store_aligned(out[14]);
        for (std::size_t l = 0; l < L; ++l) {
          double* alpha_l = d.alpha + 3 * (k0 + l);
          alpha_l[0] = out[0][l];
          alpha_l[1] = out[1][l];
          alpha_l[2] = out[2][l];
          if (g.a_moves[h + l]) {
            double* q = d.qd + 6 * static_cast<std::size_t>(g.a[h + l]);
            for (int j = 0; j < 6; ++j) q[j] = out[3 + j][l];
          }
          if (g.b_moves[h + l]) {
            double* q = d.qd + 6 * static_cast<std::size_t>(g.b[h + l]);
            for (int j = 0; j < 6; ++j) q[j] = out[9 + j][l];
          }
        }
      }
    }
  }
};

}  // namespace
}  // namespace signorini::solver::wide
