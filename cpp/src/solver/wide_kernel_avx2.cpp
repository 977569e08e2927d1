// The wide sweep in four lanes of AVX2; this file alone is compiled with -mavx2 (and without
// FMA contraction: the lanes must round as the scalar sweep does), and runs only where the CPU
// has AVX2 (wide_rows.cpp asks xsimd).
#include "solver/wide_kernel.hpp"

namespace signorini::solver::wide {

void sweep_avx2(const SoftSweep& x, const Lanes& d, std::size_t group, std::size_t groups) {
  using K = Kernel<xsimd::avx2>;
  if (x.kick) x.update_gaps ? K::run<true, true>(x, d, group, groups) : K::run<false, true>(x, d, group, groups);
  else x.update_gaps ? K::run<true, false>(x, d, group, groups) : K::run<false, false>(x, d, group, groups);
}

void warm_start_avx2(const Lanes& d, std::size_t group, std::size_t groups) {
  Kernel<xsimd::avx2>::warm_start(d, group, groups);
}

}  // namespace signorini::solver::wide
