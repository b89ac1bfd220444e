#include "hullpipe/nodes/peer_liveness.h"

#include <gtest/gtest.h>

namespace hullpipe::nodes {
namespace {

TEST(PeerLiveness, SilenceOutagesReturnAndFinalReports) {
  EXPECT_THROW(PeerLiveness(0), std::invalid_argument);
  PeerLiveness l(1.0);
  EXPECT_FALSE(l.Alive("a", 0)) << "unknown";
  l.Heard("a", 10);
  EXPECT_TRUE(l.Alive("a", 11.0));
  EXPECT_TRUE(l.Update(11.0).empty());
  EXPECT_FALSE(l.Alive("a", 11.01));
  auto c = l.Update(11.5);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_TRUE(c[0].silent);
  EXPECT_TRUE(l.Update(12).empty()) << "a change is reported once";
  l.Heard("a", 12);
  c = l.Update(12);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_FALSE(c[0].silent);
  l.Heard("a", 12.5, /*final_report=*/true);
  EXPECT_FALSE(l.Alive("a", 12.5));
  l.Update(12.5);
  EXPECT_EQ(l.outages().at("a"), 2);
  l.Expect("b", 20);
  EXPECT_TRUE(l.Alive("b", 20.5));
}

}  // namespace
}  // namespace hullpipe::nodes
