// hullpipe_launch: starts the five processes of a launch description (capture, two
// recon, sim, render) on a private DDS domain kept on loopback, waits for
// render_node (the parent) to finish at the end of the input, then stops the
// others with SIGINT (SIGKILL after a grace period) and reaps every child: no
// orphans. Ctrl-C stops everything the same way.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <yaml-cpp/yaml.h>

#include "hullpipe/launch/cyclone_config.h"
#include "hullpipe/launch/domain.h"
#include "hullpipe/launch/process.h"
#include "hullpipe/util/cli_range.h"
#include "hullpipe/util/run_id.h"
#include "hullpipe/util/yaml_keys.h"

namespace fs = std::filesystem;

namespace {

volatile sig_atomic_t g_stop = 0;
extern "C" void OnSignal(int) { g_stop = 1; }

struct NodeSpec {
  std::string name, exec, host = "localhost";
  std::vector<std::string> args;
  double start_delay = 0;  ///< Seconds after the previous node started.
  /// Scheduling niceness added to the node (`nice -n`), 0..19: a node that may
  /// take what the others leave (recon on a machine the five nodes share).
  int nice = 0;
};

struct Child {
  NodeSpec spec;
  std::unique_ptr<hullpipe::launch::Process> process;
  std::string log;
};

std::string Substitute(std::string s, const std::map<std::string, std::string>& vars) {
  for (const auto& [k, v] : vars) {
    const std::string key = "${" + k + "}";
    for (size_t p = s.find(key); p != std::string::npos; p = s.find(key, p + v.size())) s.replace(p, key.size(), v);
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_launch: run the five-process pipeline and stop it cleanly"};
  std::string rig, out = "out", description, scene, backend = "auto", bin_dir, dds_config;
  bool synthetic = false;
  int frames = 0, width = 320, height = 240, planes = 50, domain = -1;
  double grace = 5.0;
  app.add_option("--rig", rig, "Rig directory or YAML rig file");
  app.add_flag("--synthetic", synthetic, "Use capture_node's built-in synthetic scene");
  app.add_option("--frames", frames, "Frames to process (0: the whole input)");
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
  app.add_option("--grace", grace, "Seconds between SIGINT and SIGKILL at shutdown")->capture_default_str();
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

  std::vector<NodeSpec> specs;
  try {
    const YAML::Node root = YAML::LoadFile(description);
    // Every key named, a misspelt one refused (it was ignored: "arg:" ran a node
    // without its arguments).
    if (!root.IsMap()) throw std::runtime_error("the file must be a map with a 'nodes' list");
    if (const auto key = hullpipe::FirstUnknownKey(root, {"nodes"}))
      throw std::runtime_error("unknown key '" + *key + "' (known: nodes)");
    if (!root["nodes"].IsSequence()) throw std::runtime_error("'nodes' must be a list");
    for (const auto& n : root["nodes"]) {
      if (!n.IsMap()) throw std::runtime_error("each entry of 'nodes' must be a map");
      const std::initializer_list<const char*> kNodeKeys = {"name", "exec", "host", "args", "start_delay", "nice"};
      if (const auto key = hullpipe::FirstUnknownKey(n, kNodeKeys))
        throw std::runtime_error("node " + (n["name"] ? n["name"].as<std::string>() : std::string("?")) +
                                 ": unknown key '" + *key + "' (known: " + hullpipe::KeyList(kNodeKeys) + ")");
      if (!n["name"] || !n["exec"]) throw std::runtime_error("every node needs 'name' and 'exec'");
      NodeSpec s;
      s.name = n["name"].as<std::string>();
      s.exec = n["exec"].as<std::string>();
      if (s.exec != "render_node" && s.exec != "recon_node" && s.exec != "sim_node" && s.exec != "capture_node")
        throw std::runtime_error("node " + s.name + ": exec '" + s.exec +
                                 "' is not a hullpipe node (render_node, recon_node, sim_node, capture_node)");
      if (n["host"]) s.host = n["host"].as<std::string>();
      if (n["args"]) s.args = n["args"].as<std::vector<std::string>>();
      if (n["start_delay"]) {
        s.start_delay = n["start_delay"].as<double>(-1.0);  // not a number: refused below, naming the key
        if (!(s.start_delay >= 0 && s.start_delay <= 60))
          throw std::runtime_error("node " + s.name + ": start_delay must be seconds in [0, 60]");
      }
      if (n["nice"]) {
        s.nice = n["nice"].as<int>(-1);  // not an integer: refused below, naming the key
        if (s.nice < 0 || s.nice > 19)
          throw std::runtime_error("node " + s.name + ": nice must be an integer in [0, 19]");
      }
      specs.push_back(s);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", description.c_str(), e.what());
    return 2;
  }
  if (specs.empty() || specs.front().exec != "render_node") {
    std::fprintf(stderr, "%s: the first node must be render_node (the parent)\n", description.c_str());
    return 2;
  }
  const std::map<std::string, std::string> vars = {
      {"out", out},       {"frames", std::to_string(frames)}, {"backend", backend},
      {"width", std::to_string(width)}, {"height", std::to_string(height)}, {"scene", fs::absolute(scene).string()},
      {"planes", std::to_string(planes)},
      {"start_time", std::to_string(start_in > 0 ? std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                       std::chrono::system_clock::now().time_since_epoch())
                                                               .count() +
                                                           int64_t(start_in * 1e9)
                                                     : 0)}};

  struct sigaction sa = {};
  sa.sa_handler = OnSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  std::printf("hullpipe_launch: domain %d, run id %s, DDS config %s, logs in %s/logs\n", domain,
              hullpipe::RunIdText(run_id).c_str(), dds_config.c_str(), out.c_str());
  std::vector<Child> children;
  for (const auto& spec : specs) {
    // A staggered start (cameras on several machines start when they start).
    const auto start_at = std::chrono::steady_clock::now() + std::chrono::duration<double>(spec.start_delay);
    while (!g_stop && std::chrono::steady_clock::now() < start_at)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (g_stop) break;
    std::vector<std::string> args;
    for (const auto& a : spec.args) {
      if (a == "${world}") {  // the rig's world for render and sim (none with --synthetic)
        if (!synthetic) args.insert(args.end(), {"--rig", fs::absolute(rig).string()});
        continue;
      }
      if (a == "${source}") {
        if (synthetic) {
          args.push_back("--synthetic");
        } else {
          args.push_back("--rig");
          args.push_back(fs::absolute(rig).string());
        }
      } else {
        args.push_back(Substitute(a, vars));
      }
    }
    if (spec.exec == "render_node") args.insert(args.end(), world_args.begin(), world_args.end());
    if (spec.exec == "render_node" && !head_poses.empty()) {
      args.insert(args.end(), {"--view", "file", "--head-poses", fs::absolute(head_poses).string()});
    }
    args.push_back("--domain");
    args.push_back(std::to_string(domain));
    args.push_back("--run-id");
    args.push_back(hullpipe::RunIdText(run_id));
    const std::string exe = (fs::path(bin_dir) / spec.exec).string();
    std::vector<std::string> argv_s;
    if (spec.host != "localhost" && !spec.host.empty())
      argv_s = {"ssh", spec.host, "env", "CYCLONEDDS_URI=file://" + dds_config};
    // (nice execs the node: the pid, its signals and exit status are the node's.)
    if (spec.nice > 0) argv_s.insert(argv_s.end(), {"nice", "-n", std::to_string(spec.nice)});
    argv_s.push_back(exe);
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    Child c;
    c.spec = spec;
    c.log = (fs::path(out) / "logs" / (spec.name + ".log")).string();
    const bool to_terminal = spec.exec == "render_node";
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
  Child& render = children.front();
  std::string reason = "render_node finished";
  while (true) {
    if (g_stop) {
      reason = "interrupted";
      break;
    }
    if (!render.process->Running()) break;
    bool failed = false;
    for (auto& c : children) {
      if (&c == &render) continue;
      if (!c.process->Running() && !(WIFEXITED(c.process->status()) && WEXITSTATUS(c.process->status()) == 0)) {
        reason = c.spec.name + " failed (" + hullpipe::launch::DescribeStatus(c.process->status()) + "), see " + c.log;
        failed = true;
      }
    }
    if (failed) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  // Stop the rest: SIGINT, then SIGKILL after the grace period; reap all.
  for (auto& c : children) c.process->Signal(SIGINT);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(grace);
  while (std::chrono::steady_clock::now() < deadline) {
    bool all = true;
    for (auto& c : children) all &= !c.process->Running();
    if (all) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  for (auto& c : children)
    if (c.process->Running()) {
      std::fprintf(stderr, "  %s did not stop within %.1f s: SIGKILL\n", c.spec.name.c_str(), grace);
      c.process->Signal(SIGKILL);
      c.process->Wait(10);
    }
  std::printf("hullpipe_launch: %s\n", reason.c_str());
  int rc = 0;
  for (const auto& c : children) {
    const int st = c.process->status();
    const bool ok = WIFEXITED(st) && WEXITSTATUS(st) == 0;
    std::printf("  %-8s %s\n", c.spec.name.c_str(), hullpipe::launch::DescribeStatus(st).c_str());
    if (!ok) {
      rc = 1;
      // The node's reason on the terminal, not only its log's path (render
      // writes to the terminal already).
      const std::string why = c.spec.exec == "render_node" ? "" : hullpipe::launch::LastErrorLine(c.log);
      if (!why.empty()) std::printf("           %s\n", why.c_str());
    }
  }
  return g_stop ? 130 : rc;
}
