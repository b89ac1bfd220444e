// hullpipe_launch: starts the five processes of a launch description (capture, two
// recon, sim, render) on a private DDS domain kept on loopback, waits for
// render_node (the parent) to finish at the end of the input, then stops the
// others with SIGINT (SIGKILL after a grace period) and reaps every child: no
// orphans. Ctrl-C stops everything the same way.
#include <signal.h>
#include <cmath>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <map>
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
#include "hullpipe/util/cli_range.h"
#include "hullpipe/util/run_id.h"
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
  std::string rig, out = "out", description, scene, backend = "auto", bin_dir, dds_config;
  bool synthetic = false;
  int frames = 0, width = 320, height = 240, planes = 50, domain = -1;
  double fps = 0;
  double grace = 5.0;
  app.add_option("--rig", rig, "Rig directory or YAML rig file");
  app.add_flag("--synthetic", synthetic, "Use capture_node's built-in synthetic scene");
  app.add_option("--frames", frames, "Frames to process (0: the whole input)");
  app.add_option("--fps", fps, "Pace every capture node at this rate, frames per second (0: the source's rate); "
                               "a rig too large for the machine composites every frame at a rate it keeps")
      ->check(CLI::Range(0.0, 1000.0));
  app.add_option("--out", out, "Output directory")->capture_default_str();
  app.add_option("--description", description, "Launch description YAML (default: launch/local.yaml)");
  std::string head_poses;
  app.add_option("--head-poses", head_poses,
                 "Tracked head poses CSV for render_node (--view file); default: the scripted orbit");
  app.add_option("--scene", scene, "Scene file for sim_node (default: scenes/ball.yaml)");
  app.add_option("--backend", backend, "recon backend cpu|gl|auto")->capture_default_str();
  app.add_option("--width", width, "Novel view width")->capture_default_str();
  app.add_option("--height", height, "Novel view height")->capture_default_str();
  app.add_option("--planes", planes, "Plane-sweep planes")->capture_default_str();
  app.add_option("--domain", domain, "DDS domain id (default: unique per run, from the pid)");
  std::string run_id_text;
  app.add_option("--run-id", run_id_text,
                 "This run's id, 1-16 hex digits, given to every node (default: a random one); render_node and "
                 "recon_node ignore samples of another run on the domain")
      ->check([](const std::string& t) {
        return hullpipe::ParseRunId(t) ? std::string() : "--run-id must be 1 to 16 hex digits, not zero";
      });
  app.add_option("--dds-config", dds_config, "Cyclone XML config (default: loopback config written to --out)");
  app.add_option("--bin-dir", bin_dir, "Directory of the node executables (default: beside this one)");
  app.add_option("--grace", grace, "Seconds between SIGINT and SIGKILL at shutdown")
      ->check(hullpipe::FiniteRange(0.1, 600.0))
      ->capture_default_str();
  double start_in = 0;
  app.add_option("--start-in", start_in,
                 "Give the capture nodes one timeline starting this many seconds after launch, as ${start_time} "
                 "(0: the first capture node announces one)")
      ->check(hullpipe::FiniteRange(0.0, 600.0))
      ->capture_default_str();
  std::vector<std::string> up_flag;
  std::string floor_flag;
  double orbit_radius = 0, orbit_height = std::nan("");
  app.add_option("--up", up_flag, "World up for render_node (default: the rig's world)")->delimiter(',')->expected(3);
  app.add_option("--floor", floor_flag, "Floor for render_node: metres along up, hull or none (default: the rig's)");
  app.add_option("--orbit-radius", orbit_radius, "render_node's orbit radius, metres (default: the rig's)")
      ->check(hullpipe::FiniteRange(0.01, 1000.0));
  app.add_option("--orbit-height", orbit_height, "render_node's eye height above the hull centre, metres")
      ->check(hullpipe::FiniteRange(-1000.0, 1000.0));
  CLI11_PARSE(app, argc, argv);
  // render_node's world flags, after what ${world} gives it (the rig's world).
  std::vector<std::string> world_args;
  if (!up_flag.empty()) world_args.insert(world_args.end(), {"--up", up_flag[0] + "," + up_flag[1] + "," + up_flag[2]});
  if (!floor_flag.empty()) world_args.insert(world_args.end(), {"--floor", floor_flag});
  if (orbit_radius > 0) world_args.insert(world_args.end(), {"--orbit-radius", std::to_string(orbit_radius)});
  if (std::isfinite(orbit_height)) world_args.insert(world_args.end(), {"--orbit-height", std::to_string(orbit_height)});
  if (rig.empty() == !synthetic) {
    std::fprintf(stderr, "give exactly one of --rig DIR or --synthetic\n");
    return 2;
  }
  const uint64_t run_id = run_id_text.empty() ? hullpipe::NewRunId() : *hullpipe::ParseRunId(run_id_text);
  const fs::path self_dir = fs::canonical("/proc/self/exe").parent_path();
  if (bin_dir.empty()) bin_dir = self_dir.string();
  if (description.empty()) description = HULLPIPE_SOURCE_DIR "/launch/local.yaml";
  if (scene.empty()) scene = HULLPIPE_SOURCE_DIR "/scenes/ball.yaml";
  // A domain no other live run on this machine holds (tests lease 100..229).
  std::optional<hullpipe::launch::DomainLease> lease;
  if (domain < 0) {
    lease.emplace(1, 99);
    domain = int(lease->id());
  }
  fs::create_directories(fs::path(out) / "logs");
  out = fs::absolute(out).string();
  if (dds_config.empty()) {
    dds_config = (fs::path(out) / "cyclonedds.xml").string();
    hullpipe::launch::CycloneConfigOptions cfg;
    cfg.comment = "Written by hullpipe_launch: all traffic stays on loopback (unicast discovery to 127.0.0.1, "
                  "as lo has no multicast); quick repair of lost fragments and announcements every second";
    hullpipe::launch::WriteCycloneConfig(dds_config, cfg);
  }
  dds_config = fs::absolute(dds_config).string();

  hullpipe::launch::LaunchDescription launch;
  try {
    launch = hullpipe::launch::LoadLaunchDescription(description);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  hullpipe::launch::LaunchContext ctx;
  ctx.vars = {
      {"out", out},       {"frames", std::to_string(frames)}, {"backend", backend},
      {"width", std::to_string(width)}, {"height", std::to_string(height)}, {"scene", fs::absolute(scene).string()},
      {"planes", std::to_string(planes)},
      {"start_time", std::to_string(start_in > 0 ? std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                       std::chrono::system_clock::now().time_since_epoch())
                                                               .count() +
                                                           int64_t(start_in * 1e9)
                                                     : 0)}};
  ctx.synthetic = synthetic;
  if (fps > 0) ctx.capture_fps = std::to_string(fps);
  if (!synthetic) ctx.rig = fs::absolute(rig).string();
  ctx.parent_args = std::move(world_args);
  if (!head_poses.empty())
    ctx.parent_args.insert(ctx.parent_args.end(), {"--view", "file", "--head-poses", fs::absolute(head_poses).string()});
  ctx.domain = domain;
  ctx.run_id = hullpipe::RunIdText(run_id);

  struct sigaction sa = {};
  sa.sa_handler = OnSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  std::printf("hullpipe_launch: domain %d, run id %s, DDS config %s, logs in %s/logs\n", domain,
              hullpipe::RunIdText(run_id).c_str(), dds_config.c_str(), out.c_str());
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
  hullpipe::launch::StopAll(children, grace);
  std::printf("hullpipe_launch: %s\n", reason.c_str());
  const int rc = hullpipe::launch::ReportExits(children);
  return g_stop ? 130 : rc;
}
