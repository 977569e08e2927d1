// Storage on transparent huge pages for the step's largest scratch arrays (issue 21): the rows, the
// lanes' groups and the soft points are some megabytes each at thousands of bodies (15 MB of groups
// on the 5,050-cube pyramid) and are walked several times a step. On 4 kB pages every group (about
// 4 kB) is a page of its own, whose translation the walk looks up anew; on 2 MB pages one lookup
// serves 500 groups.
//
// Linux maps anonymous memory on 2 MB pages only where asked (transparent_hugepage "madvise", the
// default of Debian and Ubuntu) or everywhere ("always"); glibc's allocator never asks. So a block
// of at least kHugePage bytes is mapped here, aligned to 2 MB, and offered with madvise
// (MADV_HUGEPAGE) before anything touches it; smaller blocks, and systems without the advice, take
// the ordinary heap. Written by hand because no library the project uses (Eigen, the standard
// library, oneTBB's scalable allocator: that one is not linked) offers an allocator that asks for
// huge pages. A hint: it changes no value, only where the pages come from.
#pragma once

#include <cstddef>
#include <new>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace signorini::parallel {

/// A transparent huge page (bytes): blocks this large or larger are mapped on them where the system can.
constexpr std::size_t kHugePage = std::size_t(2) << 20;

/// Whether this system maps large blocks here (Linux); elsewhere every block takes the heap.
#if defined(__linux__)
constexpr bool kMapsHuge = true;
#else
constexpr bool kMapsHuge = false;
#endif

/// Maps `bytes` rounded up to whole huge pages, aligned to one, advising huge pages for them (an
/// advice the system refuses leaves 4 kB pages: the block is the same); throws std::bad_alloc when
/// the system has no memory for it.
void* map_huge(std::size_t bytes);
/// Unmaps a block map_huge returned for `bytes`.
void unmap_huge(void* p, std::size_t bytes) noexcept;

/// std::allocator, except that on Linux a block of kHugePage bytes or more is mapped by map_huge
/// (where it comes from is a function of its size alone, so deallocate knows).
template <class T>
struct HugePageAllocator {
  using value_type = T;
  HugePageAllocator() = default;
  template <class U>
  HugePageAllocator(const HugePageAllocator<U>&) noexcept {}

  T* allocate(std::size_t n) {
    if (kMapsHuge && n >= kHugePage / sizeof(T)) return static_cast<T*>(map_huge(n * sizeof(T)));
    return std::allocator<T>().allocate(n);
  }
  void deallocate(T* p, std::size_t n) noexcept {
    if (kMapsHuge && n >= kHugePage / sizeof(T)) return unmap_huge(p, n * sizeof(T));
    std::allocator<T>().deallocate(p, n);
  }
  template <class U>
  bool operator==(const HugePageAllocator<U>&) const noexcept { return true; }
  template <class U>
  bool operator!=(const HugePageAllocator<U>&) const noexcept { return false; }
};

/// A std::vector on HugePageAllocator.
template <class T>
using HugeVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace signorini::parallel
