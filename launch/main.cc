// hullpipe_launch: starts the five processes of a launch description (capture, two
// recon, sim, render) on a private DDS domain kept on loopback, waits for
// render_node (the parent) to finish at the end of the input, then stops the
// others with SIGINT (SIGKILL after a grace period) and reaps every child: no
// orphans. Ctrl-C stops everything the same way.
#include <signal.h>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "hullpipe/launch/cyclone_config.h"
#include "hullpipe/launch/description.h"
#include "hullpipe/launch/domain.h"
#include "hullpipe/launch/process.h"
#include "hullpipe/launch/supervisor.h"
#include "hullpipe/nodes/launch_flags.h"
#include "hullpipe/util/logging.h"

namespace fs = std::filesystem;

namespace {

volatile std::sig_atomic_t g_stop = 0;
extern "C" void OnSignal(int) { g_stop = 1; }

}  // namespace

int main(int argc, char** argv) {
  hullpipe::LogToStderr("hullpipe_launch");  // stdout carries only what a user asked for
  hullpipe::SetCommandLine(argc, argv);
  CLI::App app{"hullpipe_launch: run the five-process pipeline and stop it cleanly"};
  hullpipe::nodes::LaunchFlags flags;
  flags.Register(app);
  CLI11_PARSE(app, argc, argv);
  try {
    flags.Resolve(HULLPIPE_SOURCE_DIR);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  hullpipe::launch::LaunchDescription launch;
  try {
    launch = hullpipe::launch::LoadLaunchDescription(flags.description);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  const fs::path self_dir = fs::canonical("/proc/self/exe").parent_path();
  const std::string bin_dir = flags.bin_dir.empty() ? self_dir.string() : flags.bin_dir;
  // A domain no other live run on this machine holds (tests lease 100..229).
  int domain = flags.domain;
  std::optional<hullpipe::launch::DomainLease> lease;
  if (domain < 0) {
    lease.emplace(1, 99);
    domain = int(lease->id());
  }
  fs::create_directories(fs::path(flags.out) / "logs");
  const std::string out = fs::absolute(flags.out).string();
  std::string dds_config = flags.dds_config;
  if (dds_config.empty()) {
    dds_config = (fs::path(out) / "cyclonedds.xml").string();
    hullpipe::launch::CycloneConfigOptions cfg;
    cfg.comment = "Written by hullpipe_launch: all traffic stays on loopback (unicast discovery to 127.0.0.1, "
                  "as lo has no multicast); quick repair of lost fragments and announcements every second";
    hullpipe::launch::WriteCycloneConfig(dds_config, cfg);
  }
  dds_config = fs::absolute(dds_config).string();
  hullpipe::launch::LaunchContext ctx = flags.Context(
      out, std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
               .count());
  ctx.domain = domain;

  struct sigaction sa = {};
  sa.sa_handler = OnSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  std::printf("hullpipe_launch: domain %d, run id %s, DDS config %s, logs in %s/logs\n", domain, ctx.run_id.c_str(),
              dds_config.c_str(), out.c_str());
  std::vector<hullpipe::launch::SupervisedNode> children;
  for (size_t i = 0; i < launch.nodes.size(); ++i) {
    const hullpipe::launch::NodeSpec& spec = launch.nodes[i];
    // A staggered start (cameras on several machines start when they start).
    const auto start_at = std::chrono::steady_clock::now() + std::chrono::duration<double>(spec.start_delay);
    while (!g_stop && std::chrono::steady_clock::now() < start_at)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (g_stop) break;
    const std::vector<std::string> argv_s = hullpipe::launch::NodeCommand(
        spec, (fs::path(bin_dir) / spec.exec).string(), hullpipe::launch::ExpandArguments(launch, i, ctx), dds_config);
    hullpipe::launch::SupervisedNode c;
    c.name = spec.name;
    c.log = (fs::path(out) / "logs" / (spec.name + ".log")).string();
    const bool to_terminal = i == 0;  // the parent's progress goes to the terminal
    try {
      c.process = std::make_unique<hullpipe::launch::Process>(
          argv_s, to_terminal ? std::string() : c.log,
          std::vector<std::pair<std::string, std::string>>{{"CYCLONEDDS_URI", "file://" + dds_config}});
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 1;  // the children started so far are killed and reaped by their destructors
    }
    std::printf("  started %-8s pid %d on %s\n", spec.name.c_str(), c.process->pid(), spec.host.c_str());
    children.push_back(std::move(c));
  }
  std::fflush(stdout);
  if (children.empty()) return 130;  // interrupted before anything started

  // Run until render_node (the parent pipe) ends, a node fails, or Ctrl-C.
  const std::string reason = hullpipe::launch::RunUntilDone(children, g_stop);
  hullpipe::launch::StopAll(children, flags.grace);
  std::printf("hullpipe_launch: %s\n", reason.c_str());
  const int rc = hullpipe::launch::ReportExits(children);
  return g_stop ? 130 : rc;
}
