#include "hullpipe/util/parallel.h"

#include <atomic>
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

}  // namespace
}  // namespace hullpipe
