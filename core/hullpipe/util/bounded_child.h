// A forked child process bounded in time, CPU and output: the one mechanism
// that runs a third-party parser on untrusted input where a hang or a crash of
// the parser must end in an error, not in the caller's (docs/reliability.md:
// Assimp's importers, OpenCV's YAML parser).
#pragma once

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>

#include "hullpipe/util/interrupt.h"

namespace hullpipe {

/// How a bounded child ended, as its parent saw it.
struct BoundedChildResult {
  bool timed_out = false;    ///< no EOF on its pipe within the wall bound; it was SIGKILLed
  bool output_over = false;  ///< it wrote more than the output bound; it was SIGKILLed
  bool interrupted = false;  ///< `stop` was set; it was SIGKILLed
  int status = 0;            ///< waitpid's status (WIFSIGNALED / WEXITSTATUS)
  std::string output;        ///< what it wrote to its pipe, whole unless output_over
};

/// Forks a child that runs `body(fd)`, `fd` the write end of a pipe to the
/// parent, then _exit(0). Before `body`, the child restores the default action
/// of SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL and SIGXCPU (a crash ends it by
/// its signal, not by a sanitizer's or libFuzzer's handler), dies with its
/// parent (PR_SET_PDEATHSIG), and gets `cpu_seconds` of CPU (soft; SIGKILL one
/// second later) and no core file. The parent reads the pipe until EOF,
/// `wall_seconds` (> 0) or `max_output_bytes` pass, SIGKILLs the child on
/// either bound, and reaps it; it does the same within 0.2 s of `stop` being
/// set (a node's SIGINT flag: a node stops within a second, even mid-import).
/// Throws std::runtime_error "pipe: ..." or "fork: ..." (errno's text) where
/// the child cannot be started.
BoundedChildResult RunBoundedChild(const std::function<void(int fd)>& body, int cpu_seconds, double wall_seconds,
                                   uint64_t max_output_bytes, StopFlag stop = nullptr);

}  // namespace hullpipe
