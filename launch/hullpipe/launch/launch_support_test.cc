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

// The launcher shows a failed node's reason: its last error line.
TEST(Process, LastErrorLineIsTheNodesLastErrorOrCritical) {
  const auto log = std::filesystem::temp_directory_path() / ("hullpipe_errline_" + std::to_string(getpid()) + ".log");
  std::ofstream(log) << "[10:00:00.000] [capture] info starting\n"
                     << "[10:00:00.100] [capture] error first problem\n"
                     << "[10:00:00.200] [capture] warning a warning, not an error\n"
                     << "[10:00:00.300] [capture] error the input ended early (exit 3): camera(s) 2 ended\n"
                     << "[10:00:00.400] [capture] info published 128 frames, 0 rejected\n";
  EXPECT_EQ(LastErrorLine(log.string()),
            "[10:00:00.300] [capture] error the input ended early (exit 3): camera(s) 2 ended");
  std::ofstream(log) << "[2026-11-22 10:00:00.000] [error] --tiles must be 1..64\n[10:00:00.000] [x] info y\n";
  EXPECT_EQ(LastErrorLine(log.string()), "[2026-11-22 10:00:00.000] [error] --tiles must be 1..64");
  std::ofstream(log) << "[10:00:00.000] [capture] info all well\n";
  EXPECT_EQ(LastErrorLine(log.string()), "");
  std::ofstream(log) << "[10:00:00.000] [sim] critical " << std::string(1000, 'x') << "\n";
  EXPECT_EQ(LastErrorLine(log.string()).size(), 300u);
  std::filesystem::remove(log);
  EXPECT_EQ(LastErrorLine(log.string()), "") << "a missing log";
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
