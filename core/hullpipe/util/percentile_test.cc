#include "hullpipe/util/percentile.h"

#include <gtest/gtest.h>

#include "hullpipe/util/latency_stats.h"

namespace hullpipe {
namespace {

TEST(Percentile, NearestRankOnKnownSamples) {
  const std::vector<double> v{5, 1, 4, 2, 3, 10, 9, 8, 7, 6};  // 1..10
  EXPECT_EQ(Percentile(v, 0), 1);
  EXPECT_EQ(Percentile(v, 10), 1);   // ceil(1.0) = 1st
  EXPECT_EQ(Percentile(v, 11), 2);   // ceil(1.1) = 2nd
  EXPECT_EQ(Percentile(v, 50), 5);
  EXPECT_EQ(Percentile(v, 95), 10);
  EXPECT_EQ(Percentile(v, 100), 10);
  EXPECT_EQ(Percentile(v, 250), 10);  // clamped
  EXPECT_EQ(Percentile({}, 50), 0);
  EXPECT_EQ(Median(v), 6);  // upper median of an even count
  EXPECT_EQ(Median({3, 1, 2}), 2);
  EXPECT_EQ(Median({}), 0);
}

TEST(Percentile, SampleStatsUsesTheSameRuleOverItsRing) {
  SampleStats s(4);
  for (double x : {100.0, 1.0, 2.0, 3.0, 4.0}) s.Add(x);  // 100 falls out of the ring
  EXPECT_EQ(s.count(), 5u);
  EXPECT_EQ(s.Percentile(100), 4);
  EXPECT_EQ(s.Percentile(50), 2);
  EXPECT_DOUBLE_EQ(s.Mean(), 2.5);
}

}  // namespace
}  // namespace hullpipe
