// A minimal deterministic parallel-for over task indices with std::thread.
//
// Each task index is computed entirely by one thread with the same arithmetic, so the result
// is bit-for-bit independent of the thread count; threads only change which task runs where.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace allanite {

/// Number of worker threads to use: `requested` if positive, else the hardware concurrency.
inline int resolve_threads(int requested) {
  if (requested > 0) return requested;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : static_cast<int>(hw);
}

/// Run fn(i) for i in [0, n) on `threads` threads, handing out indices dynamically.
/// The first exception thrown by any task is rethrown on the calling thread.
template <class Fn>
void parallel_for(std::size_t n, int threads, Fn&& fn) {
  const std::size_t nthreads =
      std::min<std::size_t>(static_cast<std::size_t>(std::max(threads, 1)), std::max<std::size_t>(n, 1));
  if (nthreads <= 1) {
    for (std::size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&]() {
    for (;;) {
      const std::size_t i = next.fetch_add(1);
      if (i >= n) return;
      try {
        fn(i);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        next.store(n);
        return;
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(nthreads - 1);
  for (std::size_t t = 1; t < nthreads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace allanite
