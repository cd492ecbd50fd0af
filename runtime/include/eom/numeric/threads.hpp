// Independent tasks on a pool of std::jthreads: the ensembles' (eom/ensemble/ensemble.hpp) and the
// contact rollouts' (eom/contact/rollout.hpp) threads. The work takes its tasks from a shared
// counter, so that any number of threads does all of them. Why std::jthread and not a task
// library: ensemble.hpp's note.
#pragma once

#include <algorithm>
#include <cstddef>
#include <thread>
#include <vector>

namespace eom::detail {

// Runs work() on `threads` threads (the caller's one of them) and joins them. If a thread cannot
// be started, the others (at least the caller) do its share: work() must take its tasks from a
// shared counter.
template <class Work> void run_on_threads(unsigned threads, Work& work) noexcept {
  std::vector<std::jthread> pool;
#if defined(__cpp_exceptions)
  try {
    pool.reserve(threads > 1 ? threads - 1 : 0);
    for (unsigned i = 1; i < threads; ++i) pool.emplace_back([&work] { work(); });
  } catch (...) {  // no memory or no more threads: fewer threads, same results
  }
#else
  pool.reserve(threads > 1 ? threads - 1 : 0);
  for (unsigned i = 1; i < threads; ++i) pool.emplace_back([&work] { work(); });
#endif
  work();
}  // the jthreads join here; their writes are visible to the caller after the join

inline unsigned thread_count(unsigned requested, std::size_t cases) noexcept {
  unsigned n = requested != 0 ? requested : std::max(1u, std::thread::hardware_concurrency());
  return static_cast<unsigned>(std::min<std::size_t>(n, std::max<std::size_t>(cases, 1)));
}

}  // namespace eom::detail
