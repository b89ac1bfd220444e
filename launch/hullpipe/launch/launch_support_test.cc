#include <signal.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "hullpipe/launch/cyclone_config.h"
#include "hullpipe/launch/domain.h"
#include "hullpipe/launch/process.h"

namespace hullpipe::launch {
namespace {

TEST(DomainLease, NoTwoLiveLeasesShareAnIdAndReleasedIdsAreReused) {
  std::set<uint32_t> ids;
  std::vector<DomainLease> leases;
  for (int i = 0; i < 5; ++i) {
    leases.emplace_back(200, 204);
    EXPECT_TRUE(ids.insert(leases.back().id()).second) << leases.back().id();
  }
  EXPECT_THROW(DomainLease(200, 204), std::runtime_error) << "all five held";
  const uint32_t freed = leases.front().id();
  leases.erase(leases.begin());
  EXPECT_EQ(DomainLease(200, 204).id(), freed);
}

TEST(Process, ExitCodesSignalsLogAndEnvironment) {
  const auto log = std::filesystem::temp_directory_path() / ("hullpipe_process_" + std::to_string(getpid()) + ".log");
  {
    Process p({"sh", "-c", "echo \"$HULLPIPE_X\"; exit 3"}, log.string(), {{"HULLPIPE_X", "hello"}});
    EXPECT_EQ(p.Wait(10), 3);
  }
  std::ifstream f(log);
  std::string line;
  std::getline(f, line);
  EXPECT_EQ(line, "hello");
  Process sleeper({"sleep", "30"}, "");
  EXPECT_TRUE(sleeper.Running());
  EXPECT_EQ(sleeper.Stop(5), 128 + SIGINT);
  EXPECT_EQ(DescribeStatus(sleeper.status()), std::string("killed by signal ") + strsignal(SIGINT));
  EXPECT_THROW(Process({"/nonexistent/program"}, ""), std::runtime_error);
  std::filesystem::remove(log);
}

TEST(CycloneConfig, LoopbackWithFastRepairAnnouncementsAndLoss) {
  const std::string x = CycloneConfigXml({});
  for (const char* part : {"<NetworkInterface name=\"lo\"/>", "<Peer address=\"127.0.0.1\"/>",
                           "<SPDPInterval>1s</SPDPInterval>", "<NackDelay>2ms</NackDelay>",
                           "<AllowMulticast>false</AllowMulticast>"})
    EXPECT_NE(x.find(part), std::string::npos) << part;
  EXPECT_EQ(x.find("XmitLossiness"), std::string::npos);
  CycloneConfigOptions lossy;
  lossy.loss_per_mille = 50;
  lossy.interface = "eth0";
  lossy.peers = {"10.0.0.1", "10.0.0.2"};
  const std::string y = CycloneConfigXml(lossy);
  EXPECT_NE(y.find("<XmitLossiness>50</XmitLossiness>"), std::string::npos);
  EXPECT_NE(y.find("<Peer address=\"10.0.0.1\"/><Peer address=\"10.0.0.2\"/>"), std::string::npos);
  EXPECT_NE(y.find("name=\"eth0\""), std::string::npos);
}

}  // namespace
}  // namespace hullpipe::launch
