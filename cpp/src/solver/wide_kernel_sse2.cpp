// The wide sweep in two lanes of SSE2 (x86-64's baseline: every CPU the library runs on has it).
#include "solver/wide_kernel.hpp"

namespace signorini::solver::wide {

void sweep_sse2(const SoftSweep& x, const Lanes& d, std::size_t group, std::size_t groups) {
  if (x.update_gaps) Kernel<xsimd::sse2>::run<true>(x, d, group, groups);
  else Kernel<xsimd::sse2>::run<false>(x, d, group, groups);
}

void warm_start_sse2(const Lanes& d, std::size_t group, std::size_t groups) {
  Kernel<xsimd::sse2>::warm_start(d, group, groups);
}

}  // namespace signorini::solver::wide
