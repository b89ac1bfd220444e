// Helpers of hullpipe's multi-process tests (the core's fixtures are
// hullpipe/testing/fixtures.h).
#pragma once

#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/launch/cyclone_config.h"
#include "hullpipe/launch/domain.h"
#include "hullpipe/launch/process.h"
#include "hullpipe/testing/fixtures.h"
#include "hullpipe/testing/time_scale.h"  // TimeScale

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

/// launch/local.yaml with `arg` ("--flag, value" in the YAML list's syntax)
/// replaced by `by` in the one node whose arguments contain it. Throws
/// std::logic_error if the file no longer has `arg` (the test must follow it).
inline std::string LocalDescriptionWith(const std::string& arg, const std::string& by) {
  std::ifstream f(std::string(HULLPIPE_SOURCE_DIR) + "/launch/local.yaml");
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const size_t at = text.find(arg);
  if (at == std::string::npos) throw std::logic_error("launch/local.yaml has no '" + arg + "'");
  return text.replace(at, arg.size(), by);
}

/// The argument of capture in launch/local.yaml that LocalDescriptionWith
/// prefixes to add capture arguments.
inline const std::string kCaptureWaitArg = "--wait-timeout, \"20\"";

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
  return std::make_unique<Process>(
      args, log, std::vector<std::pair<std::string, std::string>>{{"CYCLONEDDS_URI", "file://" + config}});
}

/// The whole file at `path`, byte for byte (empty where it cannot be read).
inline std::string ReadFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace hullpipe::test
