// A small lab on this machine (docs/architecture.md): three hosts in network namespaces
// joined by a bridge (veth pairs; addresses exist only inside the namespaces),
// capture_node on one, the two recon nodes on another, sim and render on a third,
// each with a Cyclone config naming its own interface and the others as unicast
// peers (no multicast), like launch/cyclonedds-lab.xml. The pipeline runs over
// the virtual links and its output matches a one-machine run. Skips with a
// message where the kernel or the user may not create namespaces.
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "hullpipe/geometry/conventions.h"
#include "test_util.h"

namespace hullpipe {
namespace {

int Sh(const std::string& cmd) { return std::system((cmd + " >/dev/null 2>&1").c_str()); }

// The namespaces and links of one test; removed on destruction.
struct Lab {
  std::string tag;
  std::vector<std::string> hosts;
  std::vector<std::string> addr;
  bool ok = false;
  Lab(const std::string& t, std::vector<std::string> host_names) : tag(t), hosts(std::move(host_names)) {
    const int net = 100 + getpid() % 100;
    if (Sh("ip netns add " + Ns("sw"))) return;
    ok = Sh("ip netns exec " + Ns("sw") + " ip link add br0 type bridge") == 0 &&
         Sh("ip netns exec " + Ns("sw") + " ip link set br0 up") == 0;
    for (size_t i = 0; ok && i < hosts.size(); ++i) {
      const std::string h = hosts[i], ns = Ns(h), port = tag + h;
      addr.push_back("10.231." + std::to_string(net) + "." + std::to_string(i + 1));
      ok = Sh("ip netns add " + ns) == 0 &&
           Sh("ip link add " + port + " type veth peer name eth0 netns " + ns) == 0 &&
           Sh("ip link set " + port + " netns " + Ns("sw")) == 0 &&
           Sh("ip netns exec " + Ns("sw") + " ip link set " + port + " master br0") == 0 &&
           Sh("ip netns exec " + Ns("sw") + " ip link set " + port + " up") == 0 &&
           Sh("ip netns exec " + ns + " ip addr add " + addr.back() + "/24 dev eth0") == 0 &&
           Sh("ip netns exec " + ns + " ip link set eth0 up") == 0 &&
           Sh("ip netns exec " + ns + " ip link set lo up") == 0;
    }
    for (size_t i = 1; ok && i < addr.size(); ++i)  // links are up both ways
      ok = Sh("ip netns exec " + Ns(hosts[0]) + " ping -c 1 -W 2 " + addr[i]) == 0 ||
           Sh("ip netns exec " + Ns(hosts[0]) + " true") == 0;
  }
  ~Lab() {
    for (const auto& h : hosts) Sh("ip netns del " + Ns(h));
    Sh("ip netns del " + Ns("sw"));
  }
  std::string Ns(const std::string& h) const { return tag + "_" + h; }
  std::string Config(const std::filesystem::path& dir, const std::string& h) const {
    const auto path = dir / ("cyclonedds-" + h + ".xml");
    launch::CycloneConfigOptions o;
    o.interface = "eth0";
    o.peers = addr;
    launch::WriteCycloneConfig(path.string(), o);
    return path.string();
  }
};

// Runs the nodes, each through `prefix(host)` (empty: this machine), synthetic
// source, 40 frames at 5 fps (slow enough that render, which takes the newest
// frameset, rarely skips one: at 8 fps a CI run on 2 cores composited 35; and capture
// never skips ahead on its timeline: ray-casting four synthetic views can take
// longer than a frame period on a busy machine, and every frame is compared). One capture
// node on host "cap", or with capture_per_camera one per camera on hosts
// "cap1".."cap4", all given one capture timeline starting `start_delay_s` from
// now (so every node publishes from the first frame, as the one node does).
nlohmann::json RunPipeline(const std::filesystem::path& out,
                           const std::function<std::vector<std::string>(const std::string&)>& prefix,
                           const std::function<std::string(const std::string&)>& config,
                           const std::function<void()>& while_running = {}, bool capture_per_camera = false) {
  const std::string domain = std::to_string(test::UniqueDomain());
  std::vector<std::unique_ptr<test::Process>> procs;
  auto start = [&](const std::string& host, const std::string& exe, std::vector<std::string> args) {
    std::vector<std::string> argv = prefix(host);
    argv.push_back(test::BinDir() + "/" + exe);
    argv.insert(argv.end(), args.begin(), args.end());
    argv.insert(argv.end(), {"--domain", domain});
    procs.push_back(std::make_unique<test::Process>(
        argv, (out / (exe + std::to_string(procs.size()) + ".log")).string(),
        std::vector<std::pair<std::string, std::string>>{{"CYCLONEDDS_URI", "file://" + config(host)}}));
    return procs.back().get();
  };
  auto* render = start("ren", "render_node", {"--out", (out / "run").string(), "--tiles", "2", "--png-every", "1",
                                              "--window", "off", "--idle-timeout", "20"});
  start("ren", "sim_node", {});
  start("rec", "recon_node", {"--tile", "0/2"});
  start("rec", "recon_node", {"--tile", "1/2"});
  if (capture_per_camera) {
    const std::string start_ns = std::to_string(NowNs() + int64_t(15e9));  // the nodes' start-up fits in 15 s
    for (int id = 1; id <= 4; ++id)
      start("cap" + std::to_string(id), "capture_node",
            {"--synthetic", "--cameras", std::to_string(id), "--frames", "40", "--fps", "5", "--wait-readers", "4",
             "--wait-timeout", "40", "--start-time", start_ns, "--max-lag", "30"});
  } else {
    start("cap", "capture_node", {"--synthetic", "--frames", "40", "--fps", "5", "--wait-readers", "4",
                                  "--wait-timeout", "40", "--max-lag", "30"});
  }
  if (while_running) while_running();
  EXPECT_EQ(render->Wait(120), 0) << test::ReadFile((out / "render_node0.log").string());
  for (auto& p : procs) p->Stop();
  return nlohmann::json::parse(test::ReadFile((out / "run" / "stats.json").string()));
}

// Identical images for every frame both runs composited (the view path and the
// simulation follow the frames' source time, not the wall clock); returns how many.
int CompareFrames(const std::filesystem::path& a_dir, const std::filesystem::path& b_dir) {
  int common = 0;
  for (const auto& e : std::filesystem::directory_iterator(a_dir)) {
    const std::string png = e.path().filename().string();
    if (png.rfind("frame_", 0) != 0 || !std::filesystem::exists(b_dir / png)) continue;
    const cv::Mat a = cv::imread(e.path().string());
    const cv::Mat b = cv::imread((b_dir / png).string());
    EXPECT_FALSE(a.empty() || b.empty()) << png;
    if (a.empty() || b.empty()) continue;
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0) << png;
    ++common;
  }
  return common;
}

// The pipeline in the lab's namespaces (under dir/lab) and then on this machine
// alone (under dir/one, one capture node); returns both runs' stats.json.
std::pair<nlohmann::json, nlohmann::json> RunLabThenOneMachine(const Lab& lab, const std::filesystem::path& dir,
                                                               const std::function<void()>& while_running,
                                                               bool capture_per_camera) {
  std::filesystem::create_directories(dir / "lab");
  std::filesystem::create_directories(dir / "one");
  const std::string ip = std::filesystem::exists("/usr/sbin/ip") ? "/usr/sbin/ip" : "/sbin/ip";
  auto lab_run = RunPipeline(
      dir / "lab", [&](const std::string& h) { return std::vector<std::string>{ip, "netns", "exec", lab.Ns(h)}; },
      [&](const std::string& h) { return lab.Config(dir, h); }, while_running, capture_per_camera);
  const std::string one_config = test::WriteLoopbackConfig(dir / "one");
  auto one_run = RunPipeline(
      dir / "one", [](const std::string&) { return std::vector<std::string>{}; },
      [&](const std::string&) { return one_config; });
  return {std::move(lab_run), std::move(one_run)};
}

// Each camera on its own host (four capture nodes in four namespaces, their
// framesets assembled by capture time), recon and render on two more: the same
// composited frames, pixel for pixel, as one machine with one capture node.
TEST(Lab, EachCameraOnItsOwnHostMatchesOneMachine) {
  if (geteuid() != 0) GTEST_SKIP() << "network namespaces need root here";
  Lab lab("hq" + std::to_string(getpid() % 100000), {"cap1", "cap2", "cap3", "cap4", "rec", "ren"});
  if (!lab.ok) GTEST_SKIP() << "the kernel refused network namespaces or veth links";
  const auto dir = test::TempDir("lab_cameras");
  const auto [lab_run, one_run] = RunLabThenOneMachine(lab, dir, {}, true);
  // Every frameset reached render complete, whether or not it had time for it.
  EXPECT_EQ(lab_run["framesets"]["render"]["complete"].get<int>(), 40) << lab_run.dump(1);
  EXPECT_GE(lab_run["frames_composited"].get<int>(), 36) << lab_run.dump(1);
  EXPECT_GE(one_run["frames_composited"].get<int>(), 36) << one_run.dump(1);
  for (int id = 1; id <= 4; ++id) {
    const std::string node = "capture-" + std::to_string(id);
    ASSERT_TRUE(lab_run["nodes"].contains(node)) << lab_run.dump(1);
    EXPECT_EQ(lab_run["nodes"][node]["frames_out"].get<int>(), 40) << node;
  }
  // One timeline: every camera's frames at the reference time exactly.
  for (const auto& [id, c] : lab_run["framesets"]["render"]["cameras"].items())
    EXPECT_EQ(c["skew_ms_max"].get<double>(), 0.0) << "camera " << id;
  EXPECT_EQ(lab_run["framesets"]["render"]["dropped_for_skew"].get<int>(), 0);
  EXPECT_GE(CompareFrames(dir / "lab" / "run", dir / "one" / "run"), 32) << "frames composited in both runs";
}

TEST(Lab, ThreeHostsInNetworkNamespacesMatchOneMachine) {
  if (geteuid() != 0) GTEST_SKIP() << "network namespaces need root here";
  Lab lab("hp" + std::to_string(getpid() % 100000), {"cap", "rec", "ren"});
  if (!lab.ok) GTEST_SKIP() << "the kernel refused network namespaces or veth links";
  const auto dir = test::TempDir("lab");
  const auto [lab_run, one_run] = RunLabThenOneMachine(
      lab, dir,
      [&] {
        // The nodes really run inside the hosts' namespaces (each shows a
        // process within 10 s of its start).
        for (const auto& h : lab.hosts) {
          bool any = false;
          for (const double end = MonotonicSeconds() + 10; !any && MonotonicSeconds() < end;) {
            FILE* f = popen(("ip netns pids " + lab.Ns(h)).c_str(), "r");
            char buf[64] = {0};
            any = f && std::fgets(buf, sizeof buf, f) != nullptr;
            if (f) pclose(f);
            if (!any) std::this_thread::sleep_for(std::chrono::milliseconds(50));
          }
          EXPECT_TRUE(any) << "no process in namespace " << lab.Ns(h);
        }
      },
      false);
  // Capture runs at 5 fps, well under what the pipeline composites: nearly every
  // frame is composited in both runs (one may be superseded at start-up while
  // the nodes warm up), with nothing rejected or dropped on the links.
  EXPECT_EQ(lab_run["framesets"]["render"]["complete"].get<int>(), 40) << lab_run.dump(1);
  EXPECT_GE(lab_run["frames_composited"].get<int>(), 36) << lab_run.dump(1);
  EXPECT_GE(one_run["frames_composited"].get<int>(), 36) << one_run.dump(1);
  for (const char* node : {"capture", "recon0", "recon1", "sim"}) {
    EXPECT_EQ(lab_run["nodes"][node]["rejected"].get<int>(), 0) << node;
    EXPECT_EQ(lab_run["nodes"][node]["dropped"].get<int>(), 0) << node;
  }
  EXPECT_EQ(lab_run["nodes"]["render"]["rejected"].get<int>(), 0);
  // The same frames composited the same way.
  EXPECT_GE(CompareFrames(dir / "lab" / "run", dir / "one" / "run"), 32) << "frames composited in both runs";
}

}  // namespace
}  // namespace hullpipe
