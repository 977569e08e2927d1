#include "solver/wide_rows.hpp"

#include <algorithm>
#include <atomic>
#include <stdexcept>
#include <string>

#include <xsimd/xsimd.hpp>

#include "parallel/pool.hpp"
#include "solver/soft_contact.hpp"

namespace signorini::solver {

static_assert(rows::kContactsPerTask % kLanes == 0, "by_colour's blocks must start at a group");
static_assert(sizeof(BodyVelocity) == 6 * sizeof(double), "the lanes read a body's velocity as 6 doubles");
static_assert(sizeof(Mat3) == 9 * sizeof(double) && sizeof(Vec3) == 3 * sizeof(double),
              "the lanes read matrices and vectors as packed doubles");

namespace {

bool cpu_has_avx2() {
#ifdef SIGNORINI_WIDE_AVX2
  return xsimd::available_architectures().avx2;
#else
  return false;  // the build has no AVX2 sweep (a compiler or CPU family without it)
#endif
}

WideIsa best_isa() { return cpu_has_avx2() ? WideIsa::AVX2 : WideIsa::SSE2; }

std::atomic<WideIsa> current{best_isa()};
std::atomic<std::size_t> solved{0};

}  // namespace

void set_wide_isa(WideIsa isa) {
  if (isa == WideIsa::AVX2 && !cpu_has_avx2())
    throw std::invalid_argument("set_wide_isa: AVX2 asked for, but this CPU or build has no AVX2 sweep");
  current.store(isa == WideIsa::Auto ? best_isa() : isa);
}

WideIsa wide_isa() { return current.load(); }

std::size_t wide_contacts_solved() { return solved.load(std::memory_order_relaxed); }

}  // namespace signorini::solver

namespace signorini {

void set_simd(const std::string& isa) {
  using solver::WideIsa;
  if (isa == "auto") solver::set_wide_isa(WideIsa::Auto);
  else if (isa == "avx2") solver::set_wide_isa(WideIsa::AVX2);
  else if (isa == "sse2") solver::set_wide_isa(WideIsa::SSE2);
  else if (isa == "scalar") solver::set_wide_isa(WideIsa::Scalar);
  else throw std::invalid_argument("set_simd: isa must be 'auto', 'avx2', 'sse2' or 'scalar', got '" + isa + "'");
}

std::string simd() {
  switch (solver::wide_isa()) {
    case solver::WideIsa::AVX2: return "avx2";
    case solver::WideIsa::SSE2: return "sse2";
    default: return "scalar";
  }
}

}  // namespace signorini

namespace signorini::solver {

void widen(SolverData& d) {
  const std::size_t colours = d.colour_start.size() - 1;
  d.wide_first.resize(colours + 1);
  d.wide_first[0] = 0;
  for (std::size_t c = 0; c < colours; ++c) {
    // the shared last colour's contacts may share a body: none of them in a group
    const int n = c + 1 == colours ? 0 : d.colour_start[c + 1] - d.colour_start[c];
    d.wide_first[c + 1] = d.wide_first[c] + n / static_cast<int>(kLanes);
  }
  const std::size_t G = static_cast<std::size_t>(d.wide_first[colours]);
  if (G > d.wide.capacity()) d.wide.reserve(std::max(G, 2 * d.wide.capacity()));
  d.wide.resize(G);
  // each group written by one thread; its colour is the one whose groups it falls in
  rows::for_ranges(d, G, 256, [&](std::size_t from, std::size_t to) {
    std::size_t c = static_cast<std::size_t>(
        std::upper_bound(d.wide_first.begin(), d.wide_first.end(), static_cast<int>(from)) - d.wide_first.begin() - 1);
    for (std::size_t gi = from; gi < to; ++gi) {
      while (static_cast<std::size_t>(d.wide_first[c + 1]) <= gi) ++c;
      WideGroup& g = d.wide[gi];
      const std::size_t first = static_cast<std::size_t>(d.colour_start[c]) +
                                kLanes * (gi - static_cast<std::size_t>(d.wide_first[c]));
      g.one_by_one = false;
      for (std::size_t l = 0; l < kLanes; ++l) {
        const ContactRows& r = d.rows[first + l];
        for (int i = 0; i < 3; ++i) {
          g.n[i][l] = r.n[i];
          g.t1[i][l] = r.t1[i];
          g.t2[i][l] = r.t2[i];
          g.r_a[i][l] = r.r_a[i];
          g.r_b[i][l] = r.r_b[i];
          g.inv_delta[i][l] = r.inv_delta[i];
        }
        g.dinv_mass_a[l] = r.dinv_mass_a;
        g.dinv_mass_b[l] = r.dinv_mass_b;
        g.W_1n[l] = r.W_1n;
        g.W_2n[l] = r.W_2n;
        g.W_21[l] = r.W_21;
        g.mu[l] = r.mu;
        g.a[l] = r.a;
        g.b[l] = r.b;
        g.a_moves[l] = r.a_moves;
        g.b_moves[l] = r.b_moves;
        // the lanes assume the rows the scalar sweep solves in full (contact_rows' first branches)
        if (!(r.delta[0] > 0.0) || !(r.delta[1] > 0.0)) g.one_by_one = true;
      }
    }
  });
}

void wide_sweep(const SolverSettings& s, const SoftSweep& x, SolverData& d, std::size_t first, std::size_t end) {
  const auto one_by_one = [&](std::size_t from, std::size_t to) {
    if (x.update_gaps)
      for (std::size_t k = from; k < to; ++k) soft_contact<false, true>(s, x, d, k);
    else
      for (std::size_t k = from; k < to; ++k) soft_contact<false, false>(s, x, d, k);
  };
  const WideIsa isa = wide_isa();
  if (isa == WideIsa::Scalar || d.wide_first.empty()) return one_by_one(first, end);
  const auto lanes = isa == WideIsa::AVX2 ? wide::sweep_avx2 : wide::sweep_sse2;
  const wide::Lanes raw{d.wide.data(),
                        d.qd.empty() ? nullptr : d.qd[0].omega.data(),
                        d.dI_inv.empty() ? nullptr : d.dI_inv[0].data(),
                        d.alpha.data(),
                        d.soft.data(),
                        d.dp.empty() ? nullptr : d.dp[0].data(),
                        d.dR.empty() ? nullptr : d.dR[0].data()};
  // colour by colour: the colour of `first`, then on
  std::size_t c = static_cast<std::size_t>(
      std::upper_bound(d.colour_start.begin(), d.colour_start.end(), static_cast<int>(first)) - d.colour_start.begin() - 1);
  for (std::size_t k = first; k < end; ++c) {
    const std::size_t start = static_cast<std::size_t>(d.colour_start[c]);
    const std::size_t stop = std::min(end, static_cast<std::size_t>(d.colour_start[c + 1]));
    if (k >= stop) continue;  // an empty colour
    // the colour's groups in [k, stop): a block of by_colour starts a multiple of kLanes from its
    // colour's start; the rest of the colour (its last n mod 4) one by one
    std::size_t gi = static_cast<std::size_t>(d.wide_first[c]) + (k - start) / kLanes;
    const std::size_t g_end = static_cast<std::size_t>(d.wide_first[c + 1]);
    while (gi < g_end && k + kLanes <= stop) {
      std::size_t run = 0;  // groups in a row that the lanes take
      while (gi + run < g_end && k + kLanes * (run + 1) <= stop && !d.wide[gi + run].one_by_one) ++run;
      if (run > 0) {
        lanes(x, raw, gi, run, k);
        solved.fetch_add(kLanes * run, std::memory_order_relaxed);
        gi += run;
        k += kLanes * run;
      } else {
        one_by_one(k, k + kLanes);
        ++gi;
        k += kLanes;
      }
    }
    one_by_one(k, stop);
    k = stop;
  }
}

}  // namespace signorini::solver
