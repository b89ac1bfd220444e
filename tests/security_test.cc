// DDS Security (docs/architecture.md): launch/make_security.sh makes a lab CA, identities,
// signed governance and permissions, and Cyclone configs. A sim_node with a lab
// identity takes a SceneCommand from hullpipe_cmd with a lab identity; the same
// command from a participant without security, or with a certificate from
// another CA, finds no sim_node (it is not authenticated: nothing it publishes is
// accepted), and a participant without security sees none of sim_node's samples.
#include <cstdlib>
#include <thread>

#include <algorithm>

#include <gtest/gtest.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "test_util.h"

namespace hullpipe {
namespace {

TEST(Security, OnlyTheLabsIdentitiesJoin) {
  if (std::system("command -v openssl >/dev/null 2>&1") != 0) GTEST_SKIP() << "no openssl";
  const auto dir = test::TempDir("security");
  const std::string script = std::string(HULLPIPE_SOURCE_DIR) + "/launch/make_security.sh";
  ASSERT_EQ(std::system(("bash " + script + " " + (dir / "lab").string() + " lo sim cmd >/dev/null 2>&1").c_str()), 0);
  ASSERT_EQ(std::system(("bash " + script + " " + (dir / "rogue").string() + " lo cmd >/dev/null 2>&1").c_str()), 0);
  const uint32_t domain = test::UniqueDomain();
  auto cfg = [&](const std::string& path) {
    return std::vector<std::pair<std::string, std::string>>{{"CYCLONEDDS_URI", "file://" + path}};
  };
  const std::string plain = test::WriteLoopbackConfig(dir);
  test::Process sim({test::BinDir() + "/sim_node", "--domain", std::to_string(domain), "--scene",
                     std::string(HULLPIPE_SOURCE_DIR) + "/scenes/payload.yaml"},
                    (dir / "sim.log").string(), cfg((dir / "lab" / "cyclonedds-secure-sim.xml").string()));
  auto command = [&](const std::string& config, const std::string& spacing, const std::string& log) {
    test::Process p({test::BinDir() + "/hullpipe_cmd", "--domain", std::to_string(domain), "--timeout", "6",
                     "set-spacing", spacing},
                    (dir / log).string(), cfg(config));
    return p.Wait(30);
  };
  // A lab identity: authenticated, its command taken.
  EXPECT_EQ(command((dir / "lab" / "cyclonedds-secure-cmd.xml").string(), "0.2", "cmd_lab.log"), 0)
      << test::ReadFile((dir / "cmd_lab.log").string());
  // No security at all, and a certificate from another CA: not authenticated.
  EXPECT_EQ(command(plain, "0.3", "cmd_plain.log"), 1) << test::ReadFile((dir / "cmd_plain.log").string());
  EXPECT_EQ(command((dir / "rogue" / "cyclonedds-secure-cmd.xml").string(), "0.4", "cmd_rogue.log"), 1)
      << test::ReadFile((dir / "cmd_rogue.log").string());
  // Positive control: a participant with a lab identity sees sim_node's NodeStats
  // (published twice a second, transient-local); how long that took sets the
  // window in which a participant without security must see nothing.
  auto watch = [&](const std::string& config, double seconds, bool stop_at_first) {
    setenv("CYCLONEDDS_URI", ("file://" + config).c_str(), 1);
    dds::Participant p(domain);
    dds::Reader<hullpipe_msg_NodeStats> stats(p);
    int seen = 0;
    const double t0 = MonotonicSeconds();
    double first = -1;
    while (MonotonicSeconds() < t0 + seconds && !(stop_at_first && seen > 0)) {
      seen += int(stats.TakeEach([](const hullpipe_msg_NodeStats&, const dds_sample_info_t&) {}));
      if (seen > 0 && first < 0) first = MonotonicSeconds() - t0;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return std::make_pair(seen, first);
  };
  const auto [lab_seen, lab_first] = watch((dir / "lab" / "cyclonedds-secure-cmd.xml").string(), 20, true);
  ASSERT_GT(lab_seen, 0) << "a lab identity saw nothing of sim_node: the absence below would prove nothing";
  const double window = std::max(3.0, 2 * lab_first);
  EXPECT_EQ(watch(plain, window, false).first, 0) << "an unsecured participant saw sim_node within " << window << " s";
  EXPECT_EQ(sim.Stop(), 0);
  const std::string log = test::ReadFile((dir / "sim.log").string());
  EXPECT_NE(log.find("payload spacing set to 20.0 cm"), std::string::npos) << log;
  EXPECT_EQ(log.find("set to 30.0 cm"), std::string::npos) << log;
  EXPECT_EQ(log.find("set to 40.0 cm"), std::string::npos) << log;
}

}  // namespace
}  // namespace hullpipe
