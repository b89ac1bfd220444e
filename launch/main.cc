// hullpipe_launch: starts the five processes of a launch description (capture, two
// recon, sim, render) on a private DDS domain kept on loopback, waits for
// render_node (the parent) to finish at the end of the input, then stops the
// others with SIGINT (SIGKILL after a grace period) and reaps every child: no
// orphans. Ctrl-C stops everything the same way.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <yaml-cpp/yaml.h>

namespace fs = std::filesystem;

namespace {

volatile sig_atomic_t g_stop = 0;
extern "C" void OnSignal(int) { g_stop = 1; }

struct NodeSpec {
  std::string name, exec, host = "localhost";
  std::vector<std::string> args;
};

struct Child {
  NodeSpec spec;
  pid_t pid = -1;
  int status = 0;
  bool exited = false;
  std::string log;
};

std::string Substitute(std::string s, const std::map<std::string, std::string>& vars) {
  for (const auto& [k, v] : vars) {
    const std::string key = "${" + k + "}";
    for (size_t p = s.find(key); p != std::string::npos; p = s.find(key, p + v.size())) s.replace(p, key.size(), v);
  }
  return s;
}

std::string LoopbackConfig() {
  return R"(<?xml version="1.0" encoding="UTF-8"?>
<!-- Written by hullpipe_launch: all traffic stays on loopback (unicast discovery
     to 127.0.0.1, as lo has no multicast). -->
<CycloneDDS xmlns="https://cdds.io/config">
  <Domain id="any">
    <General>
      <Interfaces><NetworkInterface name="lo"/></Interfaces>
      <AllowMulticast>false</AllowMulticast>
      <MaxMessageSize>65500B</MaxMessageSize>
    </General>
    <Discovery>
      <ParticipantIndex>auto</ParticipantIndex>
      <MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>
      <Peers><Peer address="127.0.0.1"/></Peers>
      <!-- Participant announcements every second (default 30 s): a lost one
           (lossy link) delays discovery by a second, not half a minute. -->
      <SPDPInterval>1s</SPDPInterval>
    </Discovery>
    <!-- Quick repair of lost fragments of large reliable samples (maps, images,
         tiles): a 5% packet loss then costs no frame rate (tests/e2e_test.cc). -->
    <Internal>
      <HeartbeatInterval min="2ms" minsched="5ms">10ms</HeartbeatInterval>
      <NackDelay>2ms</NackDelay>
      <AutoReschedNackDelay>20ms</AutoReschedNackDelay>
    </Internal>
  </Domain>
</CycloneDDS>
)";
}

bool Reap(Child& c, bool block) {
  if (c.exited || c.pid <= 0) return true;
  int st = 0;
  const pid_t r = waitpid(c.pid, &st, block ? 0 : WNOHANG);
  if (r == c.pid) {
    c.exited = true;
    c.status = st;
  }
  return c.exited;
}

std::string Describe(const Child& c) {
  if (WIFEXITED(c.status)) return "exit " + std::to_string(WEXITSTATUS(c.status));
  if (WIFSIGNALED(c.status)) return std::string("killed by signal ") + strsignal(WTERMSIG(c.status));
  return "?";
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
  app.add_option("--dds-config", dds_config, "Cyclone XML config (default: loopback config written to --out)");
  app.add_option("--bin-dir", bin_dir, "Directory of the node executables (default: beside this one)");
  app.add_option("--grace", grace, "Seconds between SIGINT and SIGKILL at shutdown")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (rig.empty() == !synthetic) {
    std::fprintf(stderr, "give exactly one of --rig DIR or --synthetic\n");
    return 2;
  }
  const fs::path self_dir = fs::canonical("/proc/self/exe").parent_path();
  if (bin_dir.empty()) bin_dir = self_dir.string();
  if (description.empty()) description = HULLPIPE_SOURCE_DIR "/launch/local.yaml";
  if (scene.empty()) scene = HULLPIPE_SOURCE_DIR "/scenes/ball.yaml";
  if (domain < 0) domain = 1 + int(getpid() % 200);
  fs::create_directories(fs::path(out) / "logs");
  out = fs::absolute(out).string();
  if (dds_config.empty()) {
    dds_config = (fs::path(out) / "cyclonedds.xml").string();
    std::ofstream(dds_config) << LoopbackConfig();
  }
  dds_config = fs::absolute(dds_config).string();

  std::vector<NodeSpec> specs;
  try {
    const YAML::Node root = YAML::LoadFile(description);
    for (const auto& n : root["nodes"]) {
      NodeSpec s;
      s.name = n["name"].as<std::string>();
      s.exec = n["exec"].as<std::string>();
      if (n["host"]) s.host = n["host"].as<std::string>();
      if (n["args"]) s.args = n["args"].as<std::vector<std::string>>();
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
      {"planes", std::to_string(planes)}};

  struct sigaction sa = {};
  sa.sa_handler = OnSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  std::printf("hullpipe_launch: domain %d, DDS config %s, logs in %s/logs\n", domain, dds_config.c_str(), out.c_str());
  std::vector<Child> children;
  for (const auto& spec : specs) {
    std::vector<std::string> args;
    for (const auto& a : spec.args) {
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
    if (spec.exec == "render_node" && !head_poses.empty()) {
      args.insert(args.end(), {"--view", "file", "--head-poses", fs::absolute(head_poses).string()});
    }
    args.push_back("--domain");
    args.push_back(std::to_string(domain));
    const std::string exe = (fs::path(bin_dir) / spec.exec).string();
    std::vector<std::string> argv_s;
    if (spec.host == "localhost" || spec.host.empty()) {
      argv_s.push_back(exe);
    } else {
      argv_s = {"ssh", spec.host, "env", "CYCLONEDDS_URI=file://" + dds_config, exe};
    }
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    Child c;
    c.spec = spec;
    c.log = (fs::path(out) / "logs" / (spec.name + ".log")).string();
    const bool to_terminal = spec.exec == "render_node";
    c.pid = fork();
    if (c.pid == 0) {
      setenv("CYCLONEDDS_URI", ("file://" + dds_config).c_str(), 1);
      if (!to_terminal) {
        FILE* f = std::fopen(c.log.c_str(), "w");
        if (f) {
          dup2(fileno(f), STDOUT_FILENO);
          dup2(fileno(f), STDERR_FILENO);
        }
      }
      std::vector<char*> cargv;
      for (auto& s : argv_s) cargv.push_back(s.data());
      cargv.push_back(nullptr);
      execvp(cargv[0], cargv.data());
      std::fprintf(stderr, "cannot start %s: %s\n", cargv[0], strerror(errno));
      _exit(127);
    }
    std::printf("  started %-8s pid %d on %s\n", spec.name.c_str(), c.pid, spec.host.c_str());
    children.push_back(std::move(c));
  }
  std::fflush(stdout);

  // Run until render_node (the parent pipe) ends, a node fails, or Ctrl-C.
  Child& render = children.front();
  std::string reason = "render_node finished";
  while (true) {
    if (g_stop) {
      reason = "interrupted";
      break;
    }
    if (Reap(render, false)) break;
    bool failed = false;
    for (auto& c : children) {
      if (&c == &render) continue;
      if (Reap(c, false) && !(WIFEXITED(c.status) && WEXITSTATUS(c.status) == 0)) {
        reason = c.spec.name + " failed (" + Describe(c) + "), see " + c.log;
        failed = true;
      }
    }
    if (failed) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  // Stop the rest: SIGINT, then SIGKILL after the grace period; reap all.
  for (auto& c : children)
    if (!Reap(c, false)) kill(c.pid, SIGINT);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(grace);
  while (std::chrono::steady_clock::now() < deadline) {
    bool all = true;
    for (auto& c : children) all &= Reap(c, false);
    if (all) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  for (auto& c : children)
    if (!Reap(c, false)) {
      std::fprintf(stderr, "  %s did not stop within %.1f s: SIGKILL\n", c.spec.name.c_str(), grace);
      kill(c.pid, SIGKILL);
      Reap(c, true);
    }
  std::printf("hullpipe_launch: %s\n", reason.c_str());
  int rc = 0;
  for (const auto& c : children) {
    const bool ok = WIFEXITED(c.status) && WEXITSTATUS(c.status) == 0;
    std::printf("  %-8s %s\n", c.spec.name.c_str(), Describe(c).c_str());
    if (!ok) rc = 1;
  }
  return g_stop ? 130 : rc;
}
