#include "parallel/huge_pages.hpp"

#include <cstdint>

namespace signorini::parallel {
namespace {

std::uintptr_t round_up(std::uintptr_t x, std::uintptr_t to) { return (x + to - 1) / to * to; }

}  // namespace

#if defined(__linux__)
void* map_huge(std::size_t bytes) {
  const std::size_t size = round_up(bytes, kHugePage);
  // a mapping one huge page longer than the block, cut down to its aligned part
  void* raw = mmap(nullptr, size + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  const std::uintptr_t start = reinterpret_cast<std::uintptr_t>(raw), end = start + size + kHugePage;
  const std::uintptr_t first = round_up(start, kHugePage), last = first + size;
  if (first > start) munmap(raw, first - start);
  if (end > last) munmap(reinterpret_cast<void*>(last), end - last);
#if defined(MADV_HUGEPAGE)
  madvise(reinterpret_cast<void*>(first), size, MADV_HUGEPAGE);  // (refused: 4 kB pages, the same block)
#endif
  return reinterpret_cast<void*>(first);
}

void unmap_huge(void* p, std::size_t bytes) noexcept { munmap(p, round_up(bytes, kHugePage)); }
#else
// (not called: HugePageAllocator takes the heap where kMapsHuge is false)
void* map_huge(std::size_t bytes) { return ::operator new(bytes, std::align_val_t(kHugePage)); }
void unmap_huge(void* p, std::size_t) noexcept { ::operator delete(p, std::align_val_t(kHugePage)); }
#endif

}  // namespace signorini::parallel
