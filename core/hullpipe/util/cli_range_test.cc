#include "hullpipe/util/cli_range.h"

#include <gtest/gtest.h>

namespace hullpipe {
namespace {

// "nan" passed CLI::Range (hullpipe_launch --start-in nan ran a whole pipeline).
TEST(FiniteRange, RefusesNanAndOutOfRangeAcceptsTheBounds) {
  const CLI::Validator v = FiniteRange(0.0, 600.0);
  for (std::string bad : {"nan", "NaN", "-nan", "inf", "-1", "600.5", "abc", ""}) EXPECT_NE(v(bad), "") << bad;
  for (std::string ok : {"0", "600", "12.5", "1e2"}) EXPECT_EQ(v(ok), "") << ok;
  std::string nan = "nan";
  // Control: the premise, CLI::Range lets nan through.
  EXPECT_EQ(CLI::Range(0.0, 600.0)(nan), "");
}

}  // namespace
}  // namespace hullpipe
