// Supervising a launched pipeline: run until the parent (the first node) ends,
// another node fails or a stop is asked for; then stop every node with SIGINT,
// SIGKILL after a grace period, reap all (no orphans) and report each node's
// exit. The launcher's policy, apart from its main so tests can drive it with
// plain processes.
#pragma once

#include <csignal>
#include <memory>
#include <string>
#include <vector>

#include "hullpipe/launch/process.h"

namespace hullpipe::launch {

/// One started node.
struct SupervisedNode {
  std::string name;
  std::unique_ptr<Process> process;
  std::string log;  ///< Its log file (empty: the terminal).
};

/// Polls every 50 ms until nodes[0] exits (reason "<name> finished"), another
/// node exits other than with status 0 ("<name> failed (exit N), see <log>"),
/// or `stop` is set ("interrupted"). Returns the reason. nodes must not be empty.
std::string RunUntilDone(std::vector<SupervisedNode>& nodes, const volatile std::sig_atomic_t& stop);

/// SIGINT to every node, then SIGKILL (said on stderr, naming the node) to those
/// still running after grace_s seconds; every node is reaped.
void StopAll(std::vector<SupervisedNode>& nodes, double grace_s);

/// One line per node on stdout, its exit described, and for a failed node other
/// than the parent the last error line of its log (the reason on the terminal,
/// not only a path). Returns 0 if every node exited 0, else 1.
int ReportExits(const std::vector<SupervisedNode>& nodes);

}  // namespace hullpipe::launch
