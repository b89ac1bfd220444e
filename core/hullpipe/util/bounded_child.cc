#include "hullpipe/util/bounded_child.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

namespace hullpipe {

BoundedChildResult RunBoundedChild(const std::function<void(int fd)>& body, int cpu_seconds, double wall_seconds,
                                   uint64_t max_output_bytes, StopFlag stop) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int e = errno;
    ::close(fds[0]), ::close(fds[1]);
    throw std::runtime_error(std::string("fork: ") + std::strerror(e));
  }
  if (pid == 0) {
    for (int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL, SIGXCPU}) ::signal(sig, SIG_DFL);
    // The child ends with the parent (a SIGINT to a node alone must not leave
    // a child running for up to its bound).
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(0);
    const rlimit cpu{rlim_t(cpu_seconds), rlim_t(cpu_seconds) + 1};
    ::setrlimit(RLIMIT_CPU, &cpu);
    const rlimit no_core{0, 0};
    ::setrlimit(RLIMIT_CORE, &no_core);
    ::close(fds[0]);
    body(fds[1]);
    ::_exit(0);  // closes the pipe: the parent sees EOF
  }
  ::close(fds[1]);
  BoundedChildResult r;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(wall_seconds);
  char buf[1 << 16];
  for (;;) {
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) {
      r.timed_out = true;
      break;
    }
    if (Stopped(stop)) {
      r.interrupted = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int n_ready = ::poll(&p, 1, int(std::min(left, 0.2) * 1000) + 1);
    if (n_ready <= 0) continue;  // EINTR or the 0.2-s tick
    const ssize_t n = ::read(fds[0], buf, sizeof(buf));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // EOF: the child is done
    r.output.append(buf, size_t(n));
    if (r.output.size() > max_output_bytes) {
      r.output_over = true;
      break;
    }
  }
  ::close(fds[0]);
  if (r.timed_out || r.output_over || r.interrupted) ::kill(pid, SIGKILL);
  while (::waitpid(pid, &r.status, 0) < 0 && errno == EINTR) {
  }
  return r;
}

}  // namespace hullpipe
