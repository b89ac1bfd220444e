#include "hullpipe/util/run_id.h"

#include <gtest/gtest.h>

namespace hullpipe {
namespace {

TEST(RunId, TextRoundTripsAndBadTextIsRefused) {
  for (const uint64_t id : {uint64_t(1), uint64_t(0xa), uint64_t(0xfedcba9876543210ull), ~uint64_t(0)}) {
    EXPECT_EQ(RunIdText(id).size(), 16u);
    EXPECT_EQ(ParseRunId(RunIdText(id)), id);
  }
  EXPECT_EQ(ParseRunId("A"), 0xau);  // either case, any length up to 16
  for (const char* bad : {"", "0", "0000", "x1", "12345678901234567", "-1", "1 ", "0x1"})
    EXPECT_FALSE(ParseRunId(bad).has_value()) << "'" << bad << "'";
  EXPECT_NE(NewRunId(), 0u);
  EXPECT_NE(NewRunId(), NewRunId());  // 2^-64 to fail
}

}  // namespace
}  // namespace hullpipe
