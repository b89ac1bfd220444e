// Helpers of hullpipe's multi-process tests (the core's fixtures are
// hullpipe/testing/fixtures.h).
#pragma once

#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/testing/fixtures.h"

namespace hullpipe::test {

/// Directory of the built executables.
inline std::string BinDir() { return HULLPIPE_BIN_DIR; }

/// A DDS domain id unique to this test process (tests run in parallel), 100..229.
inline uint32_t UniqueDomain() {
  static std::atomic<int> counter{0};
  return 100 + uint32_t((getpid() * 7 + counter++) % 130);
}

/// Writes a Cyclone config that keeps all traffic on loopback; returns its path.
/// loss_per_mille > 0 makes every participant drop that fraction of its outgoing
/// data packets (Cyclone's Internal/Test/XmitLossiness), for packet-loss tests
/// where the kernel has no netem. Lost fragments are repaired quickly, as in the
/// launcher's own config (heartbeats every 10 ms, NACKs after 2 ms).
inline std::string WriteLoopbackConfig(const std::filesystem::path& dir, int loss_per_mille = 0) {
  const auto path = dir / (loss_per_mille ? "cyclonedds-lossy.xml" : "cyclonedds.xml");
  std::ofstream(path) << R"(<?xml version="1.0" encoding="UTF-8"?>
<CycloneDDS xmlns="https://cdds.io/config"><Domain id="any">
<General><Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast>
<MaxMessageSize>65500B</MaxMessageSize></General>
<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>
<Peers><Peer address="127.0.0.1"/></Peers><SPDPInterval>1s</SPDPInterval></Discovery>
<Internal><HeartbeatInterval min="2ms" minsched="5ms">10ms</HeartbeatInterval><NackDelay>2ms</NackDelay>
<AutoReschedNackDelay>20ms</AutoReschedNackDelay>)"
                      << (loss_per_mille ? "<Test><XmitLossiness>" + std::to_string(loss_per_mille) +
                                               "</XmitLossiness></Test>"
                                         : std::string())
                      << "</Internal></Domain></CycloneDDS>\n";
  return path.string();
}

}  // namespace hullpipe::test

#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <sstream>
#include <thread>

namespace hullpipe::test {

/// A child process for multi-process tests; SIGKILLed if still running when
/// destroyed, so a failing test leaves no orphan.
class Process {
 public:
  Process(const std::vector<std::string>& argv, const std::string& log_path,
          const std::vector<std::pair<std::string, std::string>>& env = {}) {
    pid_ = fork();
    if (pid_ == 0) {
      for (const auto& [k, v] : env) setenv(k.c_str(), v.c_str(), 1);
      FILE* f = std::fopen(log_path.c_str(), "w");
      if (f) {
        dup2(fileno(f), 1);
        dup2(fileno(f), 2);
      }
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      execv(args[0], args.data());
      _exit(127);
    }
  }
  ~Process() {
    if (pid_ > 0 && !exited_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;
  bool Running() {
    if (exited_) return false;
    int st = 0;
    if (waitpid(pid_, &st, WNOHANG) == pid_) {
      exited_ = true;
      status_ = st;
    }
    return !exited_;
  }
  /// Waits up to timeout_s for the process to exit; returns its exit code, or -1
  /// on timeout, or 128+signal if killed by a signal.
  int Wait(double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (Running() && std::chrono::steady_clock::now() < end)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (!exited_) return -1;
    return WIFEXITED(status_) ? WEXITSTATUS(status_) : 128 + WTERMSIG(status_);
  }
  /// SIGINT, then Wait.
  int Stop(double timeout_s = 10) {
    if (Running()) kill(pid_, SIGINT);
    return Wait(timeout_s);
  }

 private:
  pid_t pid_ = -1;
  bool exited_ = false;
  int status_ = 0;
};

/// Starts one of hullpipe's executables (`exe` in BinDir()) on DDS domain
/// `domain` with the Cyclone config file `config`, its output to `log`.
inline std::unique_ptr<Process> StartExe(const std::string& exe, std::vector<std::string> args, uint32_t domain,
                                         const std::string& config, const std::string& log) {
  args.insert(args.begin(), BinDir() + "/" + exe);
  args.insert(args.end(), {"--domain", std::to_string(domain)});
  return std::make_unique<Process>(args, log,
                                   std::vector<std::pair<std::string, std::string>>{{"CYCLONEDDS_URI", "file://" + config}});
}

inline std::string ReadFile(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace hullpipe::test
