// The step's worker threads (issue 21, "Threads"): one task arena of oneTBB per World, so that a
// World's threads never exceed its own `threads` setting, whatever other Worlds do. oneTBB (Debian
// libtbb-dev) is the task scheduler: work stealing over ranges, no thread pool written here.
//
// Determinism: work is only ever split over items that do not touch the same data (bodies; the
// contacts of one solve colour, which share no moving body; per-item outputs), so every thread
// count gives the same bits. A reduction is only a max, which does not depend on the order.
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <thread>
#include <type_traits>
#include <vector>

namespace signorini::parallel {

class Pool {
 public:
  /// threads >= 1; 1 runs everything on the calling thread (no oneTBB call at all).
  explicit Pool(int threads);
  ~Pool();
  Pool(const Pool&) = delete;
  Pool& operator=(const Pool&) = delete;

  int threads() const { return threads_; }

  /// f(begin, end) over [0, n) cut into ranges of at least `grain` items, on this pool's threads;
  /// on the calling thread alone when the pool has 1 thread or n <= grain. f must only write what
  /// its own items own.
  template <class F>
  void for_ranges(std::size_t n, std::size_t grain, F&& f) const {
    if (threads_ <= 1 || n <= grain) {
      if (n > 0) f(std::size_t(0), n);
      return;
    }
    using Fn = std::remove_reference_t<F>;
    run(n, grain, &call<Fn>, const_cast<void*>(static_cast<const void*>(&f)));
  }

  /// f(k) for k in [0, threads()) on this pool's threads: the participants of a job that they
  /// share out among themselves (claiming work from an atomic counter). Any participant may run
  /// before, after or beside any other, or all on the calling thread, so f must be written so that
  /// one participant alone finishes the job (it may only wait on work another has claimed).
  template <class F>
  void join(F&& f) const {
    for_ranges(static_cast<std::size_t>(threads_), 1, [&](std::size_t first, std::size_t end) {
      for (std::size_t k = first; k < end; ++k) f(k);
    });
  }
  /// The number of threads the machine offers (oneTBB's default concurrency), at least 1.
  static int machine_threads();

  /// The calling thread's slot in the arena running it, 0 .. threads() - 1 (0 outside any
  /// arena): for per-thread buffers, which must never change a result.
  static int thread_index();

 private:
  using Body = void (*)(void*, std::size_t, std::size_t);
  template <class F>
  static void call(void* f, std::size_t begin, std::size_t end) {
    (*static_cast<F*>(f))(begin, end);  // F may be const: f points at the caller's callable
  }
  void run(std::size_t n, std::size_t grain, Body body, void* f) const;

  int threads_;
  struct Arena;
  std::unique_ptr<Arena> arena_;  // oneTBB stays inside pool.cpp
};

/// One wait of a thread spinning on other threads' work, the spin-th in a row: the CPU's pause
/// hint for the first thousand or so (a colour's blocks end within microseconds of each other),
/// then the processor offered to others (a yield returns at once when nobody else wants it), and
/// after some thousands of those a short sleep: with more threads than cores (other programs,
/// other Worlds) the thread waited for may not be running at all, and a waiter that never sleeps
/// can keep it off the core. On an unloaded machine a wait ends long before the sleeps begin.
inline void back_off(int spin) {
  if (spin < 1024) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  } else if (spin < 1024 + 4096) {
    std::this_thread::yield();
  } else {
    std::this_thread::sleep_for(std::chrono::microseconds(20));
  }
}

/// f(begin, end) over [0, n) on pool's threads, or on the calling thread when pool is null.
template <class F>
void for_ranges(const Pool* pool, std::size_t n, std::size_t grain, F&& f) {
  if (pool != nullptr)
    pool->for_ranges(n, grain, f);
  else if (n > 0)
    f(std::size_t(0), n);
}

/// f(i) for every body i of `bodies` (null: every i in [0, n)), the list split over pool's threads
/// in ranges of at least `grain` entries (on the calling thread when pool is null). The World
/// passes its non-static bodies, so that a stage over bodies costs nothing per static body.
template <class F>
void for_bodies(const Pool* pool, const std::vector<int>* bodies, std::size_t n, std::size_t grain, F&& f) {
  for_ranges(pool, bodies ? bodies->size() : n, grain, [&](std::size_t first, std::size_t end) {
    for (std::size_t k = first; k < end; ++k) f(bodies ? static_cast<std::size_t>((*bodies)[k]) : k);
  });
}

/// f(i) for every body i of `bodies` (null: every i in [0, n)), in order, on the calling thread.
template <class F>
void each_body(const std::vector<int>* bodies, std::size_t n, F&& f) {
  if (bodies) {
    for (const int i : *bodies) f(static_cast<std::size_t>(i));
  } else {
    for (std::size_t i = 0; i < n; ++i) f(i);
  }
}

/// v sized n: when it is not, every entry becomes `zero` (entries a list-driven stage never
/// writes, those of static bodies, keep that value).
template <class T>
void fit(std::vector<T>& v, std::size_t n, const T& zero) {
  if (v.size() != n) v.assign(n, zero);
}

}  // namespace signorini::parallel
