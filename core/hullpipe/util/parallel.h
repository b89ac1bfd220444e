// Splitting image rows across threads, for the per-pixel loops of the sweep, the
// exact reference and the reprojection.
#pragma once

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace hullpipe {

/// `threads` if positive, else this machine's cores (at least 1): the meaning
/// of every "--threads 0" in hullpipe.
inline int ThreadsOrCores(int threads) {
  return threads > 0 ? threads : int(std::max(1u, std::thread::hardware_concurrency()));
}

/// Calls rows(r0, r1, band) for `threads` contiguous bands [r0, r1) covering
/// [0, height), band 0 on the calling thread and the others on new threads, and
/// returns when all are done. threads is clamped to [1, max(1, height)]; band
/// indices are 0..threads-1. rows must be safe to run concurrently on disjoint rows.
template <class Rows>
void ForEachRowBand(int height, int threads, Rows&& rows) {
  threads = std::clamp(threads, 1, std::max(1, height));
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t)
    pool.emplace_back([&, t] { rows(height * t / threads, height * (t + 1) / threads, t); });
  rows(0, height / threads, 0);
  for (auto& th : pool) th.join();
}

/// Calls rows(r, thread) once for every r in [0, count), the rows handed out one
/// at a time to `threads` workers (thread 0 the calling thread) as each finishes
/// its last: for rows of very unequal cost, where fixed bands would leave one
/// thread waiting on another. threads is clamped to [1, max(1, count)]; rows
/// must be safe to run concurrently on different rows.
template <class Rows>
void ForEachRowDynamic(int count, int threads, Rows&& rows) {
  threads = std::clamp(threads, 1, std::max(1, count));
  std::atomic<int> next{0};
  auto work = [&](int t) {
    for (int r = next++; r < count; r = next++) rows(r, t);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (auto& th : pool) th.join();
}

}  // namespace hullpipe
