#include "hullpipe/util/parallel.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace hullpipe {
namespace {

// Every row exactly once, on thread indices within [0, threads), for more and
// fewer rows than threads (and none); chunks whole but for the last.
TEST(Parallel, EveryRowOnceInBandsAndDynamically) {
  for (int count : {0, 1, 3, 17, 100})
    for (int threads : {1, 2, 5}) {
      std::vector<std::atomic<int>> band_hits(static_cast<size_t>(count)), dyn_hits(static_cast<size_t>(count));
      std::vector<std::atomic<int>> chunk_hits(static_cast<size_t>(count));
      std::atomic<int> bad_thread{0};
      const int clamped = std::max(1, std::min(threads, std::max(1, count)));
      ForEachRowBand(count, threads, [&](int r0, int r1, int t) {
        bad_thread += t < 0 || t >= clamped;
        for (int r = r0; r < r1; ++r) ++band_hits[size_t(r)];
      });
      ForEachRowDynamic(count, threads, [&](int r, int t) {
        bad_thread += t < 0 || t >= clamped;
        ++dyn_hits[size_t(r)];
      });
      // Chunks of 4 rows (the last shorter where 4 does not divide the count).
      std::atomic<int> bad_chunk{0};
      ForEachRowChunk(count, 4, threads, [&](int r0, int r1, int t) {
        bad_thread += t < 0 || t >= std::max(1, std::min(threads, (count + 3) / 4));
        bad_chunk += threads > 1 && (r0 % 4 != 0 || (r1 - r0 != 4 && r1 != count));
        for (int r = r0; r < r1; ++r) ++chunk_hits[size_t(r)];
      });
      EXPECT_EQ(bad_chunk.load(), 0) << count << " rows, " << threads << " threads";
      EXPECT_EQ(bad_thread.load(), 0) << count << " rows, " << threads << " threads";
      for (int r = 0; r < count; ++r) {
        EXPECT_EQ(band_hits[size_t(r)].load(), 1) << "row " << r << " of " << count << ", " << threads << " threads";
        EXPECT_EQ(dyn_hits[size_t(r)].load(), 1) << "row " << r << " of " << count << ", " << threads << " threads";
        EXPECT_EQ(chunk_hits[size_t(r)].load(), 1) << "row " << r << " of " << count << ", " << threads << " threads";
      }
    }
}

// Waits until `arrived` reaches n (each part counts itself in first), for at
// most 10 s: parts that all wait for each other prove they ran at once.
bool AllArrive(std::atomic<int>& arrived, int n) {
  ++arrived;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (arrived.load() < n)
    if (std::chrono::steady_clock::now() > deadline) return false;
    else std::this_thread::yield();
  return true;
}

// The kept threads: n parts that wait for each other all run at once (no part
// waits behind another on one thread), later rounds start no thread, and calls
// from several threads at once each get every part exactly once.
TEST(Parallel, ThreadsAreKeptAndSharedByConcurrentCallers) {
  constexpr int n = 4;
  for (int round = 0; round < 20; ++round) {
    std::atomic<int> arrived{0}, late{0};
    RunOnThreads(n, [&](int) { late += !AllArrive(arrived, n); });
    ASSERT_EQ(late.load(), 0) << "round " << round << ": the parts did not all run at once";
  }
  const int kept = KeptThreads();
  EXPECT_GE(kept, n - 1);
  for (int round = 0; round < 20; ++round) RunOnThreads(n, [](int) {});
  EXPECT_EQ(KeptThreads(), kept) << "rounds after the first started threads";
  std::vector<std::thread> callers;
  std::vector<std::vector<std::atomic<int>>> hits(6);
  for (auto& h : hits) h = std::vector<std::atomic<int>>(5);
  for (size_t c = 0; c < hits.size(); ++c)
    callers.emplace_back([&, c] {
      for (int round = 0; round < 20; ++round) RunOnThreads(5, [&](int t) { ++hits[c][size_t(t)]; });
    });
  for (auto& th : callers) th.join();
  for (size_t c = 0; c < hits.size(); ++c)
    for (size_t t = 0; t < 5; ++t) EXPECT_EQ(hits[c][t].load(), 20) << "caller " << c << ", part " << t;
}

// A call from inside a part runs on its own thread and returns (the kept
// threads may all be busy with the outer call); a part's exception reaches
// the caller once every part has returned, nested or not.
TEST(Parallel, NestedCallsFinishAndExceptionsReachTheCaller) {
  auto nested = std::async(std::launch::async, [] {
    std::atomic<int> inner{0};
    RunOnThreads(3, [&](int) { RunOnThreads(3, [&](int) { ++inner; }); });
    return inner.load();
  });
  if (nested.wait_for(std::chrono::seconds(10)) != std::future_status::ready) {
    std::fprintf(stderr, "nested RunOnThreads did not return within 10 s\n");
    std::abort();
  }
  EXPECT_EQ(nested.get(), 9);
  std::atomic<int> ran{0};
  EXPECT_THROW(RunOnThreads(4,
                            [&](int t) {
                              ++ran;
                              if (t == 2) throw std::runtime_error("part 2");
                            }),
               std::runtime_error);
  EXPECT_EQ(ran.load(), 4) << "every part ran before the exception came back";
  // The same from nested calls, which run their parts on their own thread.
  std::atomic<int> inner_ran{0};
  EXPECT_THROW(RunOnThreads(2,
                            [&](int) {
                              RunOnThreads(3, [&](int t) {
                                ++inner_ran;
                                if (t == 1) throw std::runtime_error("inner part 1");
                              });
                            }),
               std::runtime_error);
  EXPECT_EQ(inner_ran.load(), 6) << "every nested part ran before the exception came back";
}

}  // namespace
}  // namespace hullpipe
