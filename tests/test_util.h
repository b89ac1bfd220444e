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

#include "hullpipe/launch/cyclone_config.h"
#include "hullpipe/launch/domain.h"
#include "hullpipe/launch/process.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe::test {

/// Directory of the built executables.
inline std::string BinDir() { return HULLPIPE_BIN_DIR; }

/// A DDS domain id that no other live process on this machine holds (a lease on
/// its lock file, kept until this test process ends), in 100..229.
inline uint32_t UniqueDomain() {
  static std::vector<launch::DomainLease> leases;
  leases.emplace_back(100, 229);
  return leases.back().id();
}

/// Writes the loopback Cyclone config (launch/cyclone_config.h, as the
/// launcher's) into `dir`; returns its path. loss_per_mille > 0 makes every
/// participant drop that fraction of its outgoing data packets.
inline std::string WriteLoopbackConfig(const std::filesystem::path& dir, int loss_per_mille = 0) {
  launch::CycloneConfigOptions o;
  o.loss_per_mille = loss_per_mille;
  return launch::WriteCycloneConfig((dir / (loss_per_mille ? "cyclonedds-lossy.xml" : "cyclonedds.xml")).string(), o);
}

}  // namespace hullpipe::test

#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <sstream>
#include <thread>

namespace hullpipe::test {

/// A child process (posix_spawn; SIGKILLed and reaped if still running when
/// destroyed, so a failing test leaves no orphan).
using Process = launch::Process;

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
