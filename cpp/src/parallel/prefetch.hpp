// Hints to the memory: asking for cache lines before a loop reads or writes them (issue 21: the
// step's large lists, contacts, rows and the lanes' groups, are walked in orders or strides the
// processor's own prefetcher does not follow). A hint changes no result.
#pragma once

#include <cstddef>

namespace signorini::parallel {

/// Items ahead of the one in hand that a walk reading a few fields of each, in order, asks for: a
/// Contact spans four cache lines and such a walk reads one or two of them, a stride the
/// processor's prefetcher did not follow on the 5,050-cube pyramid's 15,000 contacts (every read
/// waited on memory); a walk doing a few nanoseconds of work an item asks this far ahead to hide it.
constexpr std::size_t kWalkAhead = 32;

/// Asks the memory for the cache lines of [p, p + bytes), to be written (kWrite = 1,
/// prefetch_write) or read (prefetch_read) soon. Always inlined, as every function whose work is
/// prefetches alone must be: GCC finds such a function const (a prefetch has no effect it models)
/// and deletes the calls it did not inline.
template <int kWrite>
[[gnu::always_inline]] inline void prefetch(const void* p, std::size_t bytes) {
  const char* c = static_cast<const char*>(p);
  for (std::size_t o = 0; o < bytes; o += 64) __builtin_prefetch(c + o, kWrite);
  __builtin_prefetch(c + bytes - 1, kWrite);  // the last line, when [p, p + bytes) starts inside one
}
[[gnu::always_inline]] inline void prefetch_write(const void* p, std::size_t bytes) { prefetch<1>(p, bytes); }
[[gnu::always_inline]] inline void prefetch_read(const void* p, std::size_t bytes) { prefetch<0>(p, bytes); }

}  // namespace signorini::parallel
