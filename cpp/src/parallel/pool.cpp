#include "parallel/pool.hpp"

#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace signorini::parallel {

struct Pool::Arena {
  explicit Arena(int threads) : arena(threads) {}
  tbb::task_arena arena;
};

Pool::Pool(int threads) : threads_(threads) {
  if (threads < 1) throw std::invalid_argument("threads must be >= 1, got " + std::to_string(threads));
  if (threads > 1) arena_ = std::make_unique<Arena>(threads);
}

Pool::~Pool() = default;

int Pool::machine_threads() {
  const int n = tbb::info::default_concurrency();
  return n >= 1 ? n : 1;
}

int Pool::thread_index() {
  const int k = tbb::this_task_arena::current_thread_index();
  return k >= 0 ? k : 0;
}

void Pool::run(std::size_t n, std::size_t grain, Body body, void* f) const {
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                      [&](const tbb::blocked_range<std::size_t>& r) { body(f, r.begin(), r.end()); });
  });
}

}  // namespace signorini::parallel
