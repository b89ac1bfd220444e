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

namespace hullpipe::nodes {
namespace {

// Under load a peer's reports come further apart: the threshold follows its own
// longest recent gap (x3), so a peer reporting every 0.5 s that slows to 1.05 s
// gaps is not declared silent, while one that stops still is (positive control),
// at most 10x the configured silence later.
TEST(PeerLiveness, ThresholdFollowsALoadedPeersGapsButAStoppedPeerStillFallsSilent) {
  PeerLiveness l(1.0);
  double t = 0;
  for (int k = 0; k < 10; ++k) {
    if (k > 0) t += 0.5;
    l.Heard("recon0", t);
  }
  EXPECT_DOUBLE_EQ(l.ThresholdFor("recon0"), 1.5);
  // Loaded: gaps stretch to 0.9 and then 1.05 s; never silent.
  for (double gap : {0.9, 0.9, 1.05, 1.05, 0.95}) {
    for (double dt = 0.05; dt < gap; dt += 0.05) EXPECT_TRUE(l.Update(t + dt).empty()) << "false alarm at +" << dt;
    t += gap;
    l.Heard("recon0", t);
  }
  EXPECT_DOUBLE_EQ(l.ThresholdFor("recon0"), 3.0 * 1.05);
  // Stopped: silent once 3.15 s pass without a report.
  EXPECT_TRUE(l.Update(t + 3.0).empty());
  const auto changes = l.Update(t + 3.2);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_TRUE(changes[0].silent);
  // The cap: a peer whose gaps were huge is still dropped after 10 x silence_s.
  PeerLiveness c(0.5);
  c.Heard("r", 0);
  c.Heard("r", 30);
  EXPECT_DOUBLE_EQ(c.ThresholdFor("r"), 5.0);
}

}  // namespace
}  // namespace hullpipe::nodes
