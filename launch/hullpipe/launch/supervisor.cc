#include "hullpipe/launch/supervisor.h"

#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <thread>

namespace hullpipe::launch {
namespace {
bool ExitedZero(int status) { return WIFEXITED(status) && WEXITSTATUS(status) == 0; }
}  // namespace

std::string RunUntilDone(std::vector<SupervisedNode>& nodes, const volatile std::sig_atomic_t& stop) {
  SupervisedNode& parent = nodes.front();
  while (true) {
    if (stop) return "interrupted";
    if (!parent.process->Running()) return parent.name + " finished";
    for (size_t i = 1; i < nodes.size(); ++i) {
      SupervisedNode& n = nodes[i];
      if (!n.process->Running() && !ExitedZero(n.process->status()))
        return n.name + " failed (" + DescribeStatus(n.process->status()) + "), see " + n.log;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

void StopAll(std::vector<SupervisedNode>& nodes, double grace_s) {
  for (auto& n : nodes) n.process->Signal(SIGINT);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(grace_s);
  while (std::chrono::steady_clock::now() < deadline) {
    bool all = true;
    for (auto& n : nodes) all &= !n.process->Running();
    if (all) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  for (auto& n : nodes)
    if (n.process->Running()) {
      std::fprintf(stderr, "  %s did not stop within %.1f s: SIGKILL\n", n.name.c_str(), grace_s);
      n.process->Signal(SIGKILL);
      n.process->Wait(10);
    }
}

int ReportExits(const std::vector<SupervisedNode>& nodes) {
  int rc = 0;
  for (size_t i = 0; i < nodes.size(); ++i) {
    const int st = nodes[i].process->status();
    std::printf("  %-8s %s\n", nodes[i].name.c_str(), DescribeStatus(st).c_str());
    if (ExitedZero(st)) continue;
    rc = 1;
    const std::string why = i == 0 ? "" : LastErrorLine(nodes[i].log);  // the parent wrote to the terminal
    if (!why.empty()) std::printf("           %s\n", why.c_str());
  }
  std::fflush(stdout);
  return rc;
}

}  // namespace hullpipe::launch
