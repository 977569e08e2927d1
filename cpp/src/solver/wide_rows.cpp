#include "solver/wide_rows.hpp"

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstring>
#include <stdexcept>
#include <string>

#include <xsimd/xsimd.hpp>

#include "parallel/pool.hpp"
#include "solver/soft_contact.hpp"

namespace signorini::solver {

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
/// whether the ISA was asked for by name (the lanes then run wherever they can: widen)
std::atomic<bool> named{false};
std::atomic<std::size_t> solved{0}, pairs_solved{0}, framed_solved{0};

/// The solve position of lane l's point j in g (a lane with fewer points repeats its last).
std::size_t point_position(const WideGroup& g, std::size_t l, std::size_t j) {
  return static_cast<std::size_t>(g.first[l]) + std::min<std::size_t>(j, static_cast<std::size_t>(g.count[l]) - 1);
}

/// out <- g, but for the points no lane has (j >= g.points) and, in a group solved one contact at a
/// time, any point: what the sweeps and the passes over the groups read of it.
void put(const WideGroup& g, WideGroup& out) {
  static_assert(offsetof(WideGroup, point) == 0, "a group starts with its points");
  const std::size_t points = g.one_by_one ? 0 : static_cast<std::size_t>(g.points);
  std::memcpy(static_cast<void*>(&out), &g, points * sizeof(WideGroup::Point));
  constexpr std::size_t rest = offsetof(WideGroup, n);
  std::memcpy(reinterpret_cast<char*>(&out) + rest, reinterpret_cast<const char*>(&g) + rest, sizeof(WideGroup) - rest);
}

/// f(point, l, k) for each point the lanes of g solve (lane l's points j < count[l]), with its
/// solve position k.
template <class G, class F>
void each_point(G& g, F&& f) {
  for (std::size_t l = 0; l < kLanes; ++l)
    for (int j = 0; j < g.count[l]; ++j) f(g.point[j], l, static_cast<std::size_t>(g.first[l] + j));
}

/// f(point, l, k) for every point slot the sweeps read (j < g.points) of every group, over the
/// threads: lane l of point j and the solve position k it holds (point_position), for copying a
/// field into the groups.
template <class F>
void each_slot(SolverData& d, F&& f) {
  rows::for_ranges(d, d.wide.size(), 64, [&](std::size_t from, std::size_t to) {
    for (std::size_t gi = from; gi < to; ++gi) {
      WideGroup& g = d.wide[gi];
      for (std::size_t l = 0; l < kLanes; ++l)
        for (std::size_t j = 0; j < static_cast<std::size_t>(g.points); ++j) f(g.point[j], l, point_position(g, l, j));
    }
  });
}

}  // namespace

void set_wide_isa(WideIsa isa) {
  if (isa == WideIsa::AVX2 && !cpu_has_avx2())
    throw std::invalid_argument("set_wide_isa: AVX2 asked for, but this CPU or build has no AVX2 sweep");
  current.store(isa == WideIsa::Auto ? best_isa() : isa);
  named.store(isa != WideIsa::Auto);
}

WideIsa wide_isa() { return current.load(); }
bool wide_isa_named() { return named.load(); }

std::size_t wide_contacts_solved() { return solved.load(std::memory_order_relaxed); }

std::size_t wide_pairs_solved() { return pairs_solved.load(std::memory_order_relaxed); }
std::size_t wide_framed_pairs_solved() { return framed_solved.load(std::memory_order_relaxed); }

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

void widen(const SolverSettings& s, SolverData& d, int passes) {
  d.lanes = wide_isa() != WideIsa::Scalar && d.spin_rows.empty() && s.friction_cone == FrictionCone::Pyramid;
  if (d.lanes && !named.load()) {
    // whether they pay: enough passes, and enough contacts a pair among those the groups would take
    // (each colour's pairs of at most kManifoldPoints contacts; the shared last colour has none)
    std::size_t pairs = 0, points = 0;
    for (std::size_t c = 0; c + 2 < d.colour_start.size(); ++c) {
      const auto from = static_cast<std::size_t>(d.colour_start[c]), to = static_cast<std::size_t>(d.long_start[c]);
      points += to - from;
      for (std::size_t k = from; k < to; ++k) pairs += d.unit_first[k] ? 1 : 0;
    }
    d.lanes = passes >= kLanePasses && points >= static_cast<std::size_t>(kLanePoints) * pairs && pairs > 0;
  }
  if (!d.lanes) {
    d.wide.clear();
    d.wide_first.assign(d.colour_start.size(), 0);
    return;
  }
  const std::size_t colours = d.colour_start.size() - 1;
  // the groups' lanes, colour by colour: every four units from the colour's start among its
  // two-point pairs (listed first: groups of blocks, WideGroup::two), then every four among its
  // other pairs of at most kManifoldPoints contacts (listed next); the shared last colour has none
  d.wide_first.resize(colours + 1);
  std::size_t G = 0;
  for (std::size_t c = 0; c < colours; ++c) {
    d.wide_first[c] = static_cast<int>(G);
    if (c + 1 == colours) continue;
    const auto at = [](int k) { return static_cast<std::size_t>(k); };
    const struct {
      std::size_t from, end;
      bool two;
    } parts[2] = {{at(d.colour_start[c]), at(d.two_end[c]), true}, {at(d.two_end[c]), at(d.long_start[c]), false}};
    for (const auto& part : parts) {
      const std::size_t end = part.end;
      std::size_t lane = 0;
      for (std::size_t k = part.from; k < end;) {
        std::size_t m = k + 1;
        while (m < end && !d.unit_first[m]) ++m;
        if (lane == 0) {
          if (G == d.wide.size()) d.wide.emplace_back();
          ++G;
        }
        WideGroup& g = d.wide[G - 1];
        g.two = part.two;
        g.first[lane] = static_cast<int>(k);
        g.count[lane] = static_cast<int>(m - k);
        lane = (lane + 1) % kLanes;
        k = m;
      }
      if (lane != 0) --G;  // the part's last units that do not fill a group: one by one
    }
  }
  d.wide_first[colours] = static_cast<int>(G);
  d.wide.resize(G);
  rows::assign_n(d.in_lanes, d.rows.size(), char(0));
  // each group looked at and filled by one thread, in one pass over its rows: whether the lanes
  // can solve it, and with its points' own directions. The lanes assume the rows the scalar sweep
  // solves in full (contact_rows' first branches) and one spring per pair, to the bit; a pair's
  // points may differ in normal (so in tangents: a box turned on another, whose clipped edge
  // crossings each take the normal of their two edges) where the group takes each point's own
  // (frame; not in a group of blocks, which solves a pair's two normal rows along one normal, nor
  // with a round side, whose core's travel is read along the pair's). A group the lanes do not
  // solve is solved one contact at a time, and nothing reads its fields: they are not written.
  // The directions of the groups with a frame are written in a pass of their own once the frames
  // are numbered (few groups have one).
  const auto fill = [&](WideGroup& g) {
    // the sweeps read points j < g.points only (a group of capsules lying on each other fills
    // two of kManifoldPoints)
    g.points = 0;
    for (std::size_t l = 0; l < kLanes; ++l) g.points = std::max(g.points, g.count[l]);
    const std::size_t points = static_cast<std::size_t>(g.points);
    g.one_by_one = false;
    g.round = false;
    bool turned = false;  // some pair's points differ in direction
    for (std::size_t l = 0; l < kLanes; ++l) {
      const std::size_t k0 = static_cast<std::size_t>(g.first[l]);
      const ContactRows& pair = d.rows[k0];
      const SoftPoint& spring = d.soft[k0];
      for (std::size_t j = 0; j < points; ++j) {
        const std::size_t k = point_position(g, l, j);
        const ContactRows& r = d.rows[k];
        const SoftPoint& soft = d.soft[k];
        turned = turned || std::memcmp(r.n.data(), pair.n.data(), sizeof(Vec3)) != 0 ||
                 std::memcmp(r.t1.data(), pair.t1.data(), sizeof(Vec3)) != 0 ||
                 std::memcmp(r.t2.data(), pair.t2.data(), sizeof(Vec3)) != 0;
        const bool same_spring = soft.bias_rate == spring.bias_rate && soft.mass_scale == spring.mass_scale &&
                                 soft.impulse_scale == spring.impulse_scale;
        if (!(r.delta[0] > 0.0) || !(r.delta[1] > 0.0) || !same_spring) g.one_by_one = true;
        if (soft.sigma_a != 0.0 || soft.sigma_b != 0.0) g.round = true;
      }
    }
    if (turned && (g.two || g.round)) g.one_by_one = true;
    g.frame = turned && !g.one_by_one ? 0 : -1;  // (numbered below)
    if (g.one_by_one) return;
    // its pairs' bodies, materials, directions and springs, and each point's rows and gaps (the
    // rows just read, still in cache)
    for (std::size_t l = 0; l < kLanes; ++l) {
      const std::size_t k0 = static_cast<std::size_t>(g.first[l]);
      const ContactRows& pair = d.rows[k0];
      const SoftPoint& spring = d.soft[k0];
      g.a[l] = pair.a;
      g.b[l] = pair.b;
      g.a_moves[l] = pair.a_moves;
      g.b_moves[l] = pair.b_moves;
      g.dinv_mass_a[l] = pair.dinv_mass_a;
      g.dinv_mass_b[l] = pair.dinv_mass_b;
      const double* dIa = d.dI_inv[static_cast<std::size_t>(pair.a)].data();
      const double* dIb = d.dI_inv[static_cast<std::size_t>(pair.b)].data();
      for (int i = 0; i < 9; ++i) {
        g.dI_a[i][l] = dIa[i];
        g.dI_b[i][l] = dIb[i];
      }
      g.mu[l] = pair.mu;
      for (int i = 0; i < 3; ++i) {
        g.n[i][l] = pair.n[i];
        g.t1[i][l] = pair.t1[i];
        g.t2[i][l] = pair.t2[i];
      }
      g.bias_rate[l] = spring.bias_rate;
      g.mass_scale[l] = spring.mass_scale;
      g.impulse_scale[l] = spring.impulse_scale;
      for (std::size_t j = 0; j < points; ++j) {
        WideGroup::Point& p = g.point[j];
        // a lane with fewer points repeats its last: the lanes compute it, and write nothing
        const std::size_t k = point_position(g, l, j);
        const ContactRows& r = d.rows[k];
        const SoftPoint& soft = d.soft[k];
        for (int i = 0; i < 3; ++i) {
          p.r_a[i][l] = r.r_a[i];
          p.r_b[i][l] = r.r_b[i];
          p.inv_delta[i][l] = r.inv_delta[i];
        }
        p.W_1n[l] = r.W_1n;
        p.W_2n[l] = r.W_2n;
        p.W_21[l] = r.W_21;
        p.gap0[l] = soft.gap0;
        p.s[l] = soft.s;
        for (int i = 0; i < 3; ++i) p.alpha[i][l] = d.alpha[3 * k + static_cast<std::size_t>(i)];
        p.impulse[l] = soft.impulse;
        p.alpha_max[l] = soft.alpha_max;
      }
    }
    // a group of blocks: each pair's normal rows' deltas and coupling (rows::normal_coupling)
    if (g.two)
      for (std::size_t l = 0; l < kLanes; ++l) {
        const std::size_t k0 = static_cast<std::size_t>(g.first[l]);
        g.K11[l] = d.rows[k0].delta[0];
        g.K22[l] = d.rows[k0 + 1].delta[0];
        g.K12[l] = rows::normal_coupling(d.rows[k0], d.rows[k0 + 1], d.dI_inv.data());
      }
    // the round sides' core offsets, read only in a group that has one (a group of boxes is
    // spared filling them: the groups are made anew every step)
    if (g.round)
      for (std::size_t l = 0; l < kLanes; ++l)
        for (std::size_t j = 0; j < points; ++j) {
          const SoftPoint& soft = d.soft[point_position(g, l, j)];
          g.point[j].sigma_a[l] = soft.sigma_a;
          g.point[j].sigma_b[l] = soft.sigma_b;
        }
    each_point(g, [&](const WideGroup::Point&, std::size_t, std::size_t k) { d.in_lanes[k] = 1; });
  };
  // Each group is filled in a copy on the thread's stack, then put in place whole (put): filled
  // in place, field by field and lane by lane, each of the group's 62 cache lines (out of cache
  // since the last step's sweeps) was read for ownership at its first write, one miss after
  // another; copied whole, the lines stream (the 5,050-cube pyramid, 1 thread: prepare 11.7 ->
  // 10.5 ms).
  rows::for_ranges(d, G, 64, [&](std::size_t from, std::size_t to) {
    alignas(64) WideGroup g;
    for (std::size_t gi = from; gi < to; ++gi) {
      WideGroup& out = d.wide[gi];
      std::copy(out.first, out.first + kLanes, g.first);
      std::copy(out.count, out.count + kLanes, g.count);
      g.two = out.two;
      fill(g);
      put(g, out);
    }
  });
  // the frames, numbered in group order, and each framed group's points' directions
  std::size_t F = 0;
  for (WideGroup& g : d.wide)
    if (g.frame >= 0) g.frame = static_cast<int>(F++);
  d.frames.resize(F);
  if (F == 0) return;
  rows::for_ranges(d, G, 64, [&](std::size_t from, std::size_t to) {
    for (std::size_t gi = from; gi < to; ++gi) {
      const WideGroup& g = d.wide[gi];
      if (g.frame < 0) continue;
      PointFrames& frame = d.frames[static_cast<std::size_t>(g.frame)];
      for (std::size_t l = 0; l < kLanes; ++l)
        for (std::size_t j = 0; j < static_cast<std::size_t>(g.points); ++j) {
          const ContactRows& r = d.rows[point_position(g, l, j)];
          for (int i = 0; i < 3; ++i) {
            frame.n[j][i][l] = r.n[i];
            frame.t1[j][i][l] = r.t1[i];
            frame.t2[j][i][l] = r.t2[i];
          }
        }
    }
  });
}

void wide_gaps_out(SolverData& d) {
  rows::for_ranges(d, d.wide.size(), 64, [&](std::size_t from, std::size_t to) {
    for (std::size_t gi = from; gi < to; ++gi) {
      const WideGroup& g = d.wide[gi];
      if (g.one_by_one) continue;  // its contacts' gaps are the soft points' already
      each_point(g, [&](const WideGroup::Point& p, std::size_t l, std::size_t k) { d.soft[k].s = p.s[l]; });
    }
  });
}

void wide_gaps_in(SolverData& d) {
  each_slot(d, [&](WideGroup::Point& p, std::size_t l, std::size_t k) { p.s[l] = d.soft[k].s; });
}

bool wide_settle(const SolverSettings& s, SolverData& d) {
  std::atomic<bool> bounces{false};
  rows::for_ranges(d, d.wide.size(), 64, [&](std::size_t from, std::size_t to) {
    bool any = false;
    for (std::size_t gi = from; gi < to; ++gi) {
      const WideGroup& g = d.wide[gi];
      if (g.one_by_one) continue;  // its contacts' forces are d.alpha's already (settled one by one)
      each_point(g, [&](const WideGroup::Point& p, std::size_t l, std::size_t k) {
        for (std::size_t i = 0; i < 3; ++i) d.alpha[3 * k + i] = p.alpha[i][l];
        any = settle(s, d, k) || any;
      });
    }
    if (any) bounces.store(true, std::memory_order_relaxed);
  });
  return bounces.load(std::memory_order_relaxed);
}

void wide_accumulate(SolverData& d) {
  const double h = d.h;
  rows::for_ranges(d, d.wide.size(), 64, [&](std::size_t from, std::size_t to) {
    for (std::size_t gi = from; gi < to; ++gi) {
      WideGroup& g = d.wide[gi];
      if (g.one_by_one) continue;  // settled one by one
      // every slot (a lane past its last point adds to its unused slot, never read)
      for (int j = 0; j < g.points; ++j) {
        WideGroup::Point& p = g.point[j];
        for (std::size_t l = 0; l < kLanes; ++l) {
          p.impulse[l] += h * p.alpha[0][l];
          p.alpha_max[l] = std::max(p.alpha_max[l], p.alpha[0][l]);
        }
      }
    }
  });
}

void wide_settle_out(SolverData& d) {
  rows::for_ranges(d, d.wide.size(), 64, [&](std::size_t from, std::size_t to) {
    for (std::size_t gi = from; gi < to; ++gi) {
      const WideGroup& g = d.wide[gi];
      if (g.one_by_one) continue;
      each_point(g, [&](const WideGroup::Point& p, std::size_t l, std::size_t k) {
        for (std::size_t i = 0; i < 3; ++i) d.alpha[3 * k + i] = p.alpha[i][l];
        d.alpha_iter[k] = p.alpha[0][l];
        d.restitutive[k] = 0;
        SoftPoint& soft = d.soft[k];
        soft.impulse = p.impulse[l];
        soft.alpha_max = p.alpha_max[l];
        soft.s = p.s[l];  // (wide_gaps_out's, in the same pass)
      });
    }
  });
}

void wide_alpha_in(SolverData& d) {
  each_slot(d, [&](WideGroup::Point& p, std::size_t l, std::size_t k) {
    for (std::size_t i = 0; i < 3; ++i) p.alpha[i][l] = d.alpha[3 * k + i];
  });
}

namespace {

wide::Lanes raw_lanes(SolverData& d) {
  return wide::Lanes{d.wide.data(),
                     d.qd.empty() ? nullptr : d.qd[0].omega.data(),
                     d.dp.empty() ? nullptr : d.dp[0].data(),
                     d.dR.empty() ? nullptr : d.dR[0].data(),
                     d.kick.empty() ? nullptr : d.kick[0].omega.data(), d.frames.data()};
}

/// Solve positions [first, end) colour by colour from the colour of `first` on: lanes(group,
/// groups) for the groups in it (a colour's groups cover its two-point pairs, then its other short
/// pairs, each part from its start, four pairs a group, and by_colour's blocks start at a group or
/// between them), one_by_one(from, to) for the rest.
template <class Lanes, class OneByOne>
void walk(SolverData& d, std::size_t first, std::size_t end, Lanes&& lanes, OneByOne&& one_by_one) {
  std::size_t c = static_cast<std::size_t>(
      std::upper_bound(d.colour_start.begin(), d.colour_start.end(), static_cast<int>(first)) - d.colour_start.begin() - 1);
  const auto group_first = [&](std::size_t gi) { return static_cast<std::size_t>(d.wide[gi].first[0]); };
  const auto group_end = [&](std::size_t gi) {
    return static_cast<std::size_t>(d.wide[gi].first[kLanes - 1] + d.wide[gi].count[kLanes - 1]);
  };
  for (std::size_t k = first; k < end; ++c) {
    const std::size_t stop = std::min(end, static_cast<std::size_t>(d.colour_start[c + 1]));
    if (k >= stop) continue;  // an empty colour
    std::size_t gi = static_cast<std::size_t>(d.wide_first[c]);
    const std::size_t g_end = static_cast<std::size_t>(d.wide_first[c + 1]);
    // past the groups of the blocks before this one (a colour's groups are in solve order: found
    // by bisection, each a group's struct apart)
    const auto groups = d.wide.begin();
    gi = static_cast<std::size_t>(
        std::partition_point(groups + static_cast<std::ptrdiff_t>(gi), groups + static_cast<std::ptrdiff_t>(g_end),
                             [&](const WideGroup& g) { return static_cast<std::size_t>(g.first[0]) < k; }) -
        groups);
    while (gi < g_end && group_end(gi) <= stop) {
      // the units between the groups (a colour's last two-point pairs that fill no group)
      if (group_first(gi) > k) {
        one_by_one(k, group_first(gi));
        k = group_first(gi);
      }
      std::size_t run = 0;  // groups in a row, each where the last ends, that the lanes take
      while (gi + run < g_end && group_end(gi + run) <= stop && !d.wide[gi + run].one_by_one &&
             group_first(gi + run) == (run == 0 ? k : group_end(gi + run - 1)))
        ++run;
      if (run > 0) {
        lanes(gi, run);
        solved.fetch_add(group_end(gi + run - 1) - k, std::memory_order_relaxed);
        std::size_t twos = 0, framed = 0;
        for (std::size_t j = gi; j < gi + run; ++j) {
          twos += d.wide[j].two ? kLanes : 0;
          framed += d.wide[j].frame >= 0 ? kLanes : 0;
        }
        if (twos > 0) pairs_solved.fetch_add(twos, std::memory_order_relaxed);
        if (framed > 0) framed_solved.fetch_add(framed, std::memory_order_relaxed);
        k = group_end(gi + run - 1);
        gi += run;
      } else {
        one_by_one(k, group_end(gi));
        k = group_end(gi);
        ++gi;
      }
    }
    one_by_one(k, stop);
    k = stop;
  }
}

}  // namespace

void wide_sweep(const SolverSettings& s, const SoftSweep& x, SolverData& d, std::size_t first, std::size_t end) {
  const auto one_by_one = [&](std::size_t from, std::size_t to) {
    if (x.update_gaps)
      soft_units<false, true>(s, x, d, from, to);
    else
      soft_units<false, false>(s, x, d, from, to);
  };
  if (!d.lanes) return one_by_one(first, end);
  // (the ISA as chosen now: the groups hold the gaps for the whole step once it began with lanes)
  const auto sweep = wide_isa() == WideIsa::AVX2 ? wide::sweep_avx2 : wide::sweep_sse2;
  const wide::Lanes raw = raw_lanes(d);
  walk(d, first, end, [&](std::size_t group, std::size_t groups) { sweep(x, raw, group, groups); }, one_by_one);
}

void wide_warm_start(SolverData& d) {
  if (!d.lanes) return rows::apply_forces(d);
  const auto warm_start = wide_isa() == WideIsa::AVX2 ? wide::warm_start_avx2 : wide::warm_start_sse2;
  const wide::Lanes raw = raw_lanes(d);
  const Mat3* dI = d.dI_inv.data();
  rows::by_colour(d, [&](std::size_t first, std::size_t end) {
    walk(d, first, end, [&](std::size_t group, std::size_t groups) { warm_start(raw, group, groups); },
         [&](std::size_t from, std::size_t to) {
           for (std::size_t k = from; k < to; ++k) rows::apply_force(d, dI, k);
         });
    return 0.0;
  });
}

}  // namespace signorini::solver
