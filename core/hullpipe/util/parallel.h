// Splitting image rows across threads, for the per-pixel loops of the sweep, the
// exact reference and the reprojection.
#pragma once

#include <algorithm>
#include <atomic>
#include <functional>
#include <thread>
#include <vector>

namespace hullpipe {

/// Calls fn(t) once for every t in [0, n) and returns when all have returned:
/// t = 0 on the calling thread, the others on threads started on first need
/// and kept for later calls (up to 255, idle between calls; as many as the
/// system gives), or on the calling thread where it is free first. Where fn
/// throws, the first exception is rethrown here once every call has
/// returned. A call from inside fn (nested), or in a process forked after the
/// threads started, runs every t on the calling thread, in order.
/// Thread-safe: calls from several threads share the kept threads.
void RunOnThreads(int n, const std::function<void(int)>& fn);

/// The threads RunOnThreads has started so far in this process (kept for
/// later calls).
int KeptThreads();

/// `threads` if positive, else this machine's cores (at least 1): the meaning
/// of every "--threads 0" in hullpipe.
inline int ThreadsOrCores(int threads) {
  return threads > 0 ? threads : int(std::max(1u, std::thread::hardware_concurrency()));
}

/// Calls rows(r0, r1, band) for `threads` contiguous bands [r0, r1) covering
/// [0, height), band 0 on the calling thread and the others on kept threads
/// (RunOnThreads), and returns when all are done. threads is clamped to [1,
/// max(1, height)]; band indices are 0..threads-1. rows must be safe to run
/// concurrently on disjoint rows.
template <class Rows>
void ForEachRowBand(int height, int threads, Rows&& rows) {
  threads = std::clamp(threads, 1, std::max(1, height));
  if (threads == 1) {
    rows(0, height, 0);
    return;
  }
  RunOnThreads(threads, [&](int t) { rows(height * t / threads, height * (t + 1) / threads, t); });
}

/// Calls rows(r, thread) once for every r in [0, count), the rows handed out one
/// at a time to `threads` workers (thread 0 the calling thread, the others kept:
/// RunOnThreads) as each finishes its last: for rows of very unequal cost,
/// where fixed bands would leave one thread waiting on another. threads is
/// clamped to [1, max(1, count)]; rows must be safe to run concurrently on
/// different rows.
template <class Rows>
void ForEachRowDynamic(int count, int threads, Rows&& rows) {
  threads = std::clamp(threads, 1, std::max(1, count));
  if (threads == 1) {
    for (int r = 0; r < count; ++r) rows(r, 0);
    return;
  }
  std::atomic<int> next{0};
  RunOnThreads(threads, [&](int t) {
    for (int r = next++; r < count; r = next++) rows(r, t);
  });
}

/// Calls rows(r0, r1, thread) for the chunks [r0, r1) of `chunk` rows (the
/// last may be shorter) covering [0, height), handed out in order to `threads`
/// workers (thread 0 the calling thread) as each finishes its last: rows of
/// unequal cost (a view's rays near the hull) spread over the workers, each
/// call's set-up paid once a chunk. One call with all rows when threads is 1.
/// threads is clamped to [1, max(1, chunks)] (chunk to at least 1); rows must
/// be safe to run concurrently on different chunks.
template <class Rows>
void ForEachRowChunk(int height, int chunk, int threads, Rows&& rows) {
  chunk = std::max(1, chunk);
  const int chunks = height > 0 ? (height + chunk - 1) / chunk : 0;
  if (std::clamp(threads, 1, std::max(1, chunks)) == 1) {
    if (height > 0) rows(0, height, 0);
    return;
  }
  ForEachRowDynamic(chunks, threads, [&](int i, int t) { rows(i * chunk, std::min(height, (i + 1) * chunk), t); });
}

}  // namespace hullpipe
