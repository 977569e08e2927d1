// The wide sweep in two lanes of SSE2 (x86-64's baseline: every CPU the library runs on has it).
#include "solver/wide_kernel.hpp"

namespace signorini::solver::wide {

void sweep_sse2(const SoftSweep& x, const Lanes& d, std::size_t group, std::size_t groups) {
  using K = Kernel<xsimd::sse2>;
  if (x.kick) x.update_gaps ? K::run<true, true>(x, d, group, groups) : K::run<false, true>(x, d, group, groups);
  else x.update_gaps ? K::run<true, false>(x, d, group, groups) : K::run<false, false>(x, d, group, groups);
}

void warm_start_sse2(const Lanes& d, std::size_t group, std::size_t groups) {
  Kernel<xsimd::sse2>::warm_start(d, group, groups);
}

}  // namespace signorini::solver::wide
