// Child processes for the launcher, node_bench and the multi-process tests,
// started with posix_spawn (nothing runs between fork and exec, so a
// multi-threaded parent cannot deadlock in the child), output to a log file.
#pragma once

#include <sys/types.h>

#include <string>
#include <utility>
#include <vector>

namespace hullpipe::launch {

class Process {
 public:
  /// Starts argv[0] (searched on PATH when it has no '/') with argv, the
  /// parent's environment plus `env`, stdout and stderr to `log` (empty: the
  /// parent's), or stderr to `err_log` when that is given (tests of what a
  /// tool prints on stdout alone). Throws std::runtime_error naming the program
  /// if it cannot start.
  Process(const std::vector<std::string>& argv, const std::string& log,
          const std::vector<std::pair<std::string, std::string>>& env = {}, const std::string& err_log = "");
  /// SIGKILLs and reaps the child if it is still running (no orphans).
  ~Process();
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;

  pid_t pid() const { return pid_; }
  /// Not yet exited (reaps it if it has).
  bool Running();
  /// Waits up to timeout_s for the exit; returns the exit code, 128 + signal if
  /// killed by one, or -1 if still running.
  int Wait(double timeout_s);
  /// Sends `sig` if running.
  void Signal(int sig);
  /// SIGINT, then Wait(timeout_s).
  int Stop(double timeout_s = 10);
  /// The raw wait status (valid once exited).
  int status() const { return status_; }

 private:
  pid_t pid_ = -1;
  bool exited_ = false;
  int status_ = 0;
};

/// "exit N" or "killed by signal NAME" for a wait status.
std::string DescribeStatus(int status);

/// The last line of a node's log that spdlog wrote at level error or critical
/// (the node pattern "[time] [name] error message", or spdlog's default
/// "[time] [error] message" before the node set its own), read from the log's last
/// 64 KiB, cut to 300 bytes; empty when there is none or the log cannot be read.
/// The launcher prints it when a node fails, so the reason is on the terminal,
/// not only a log path.
std::string LastErrorLine(const std::string& log_path);

}  // namespace hullpipe::launch
