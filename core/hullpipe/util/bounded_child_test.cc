// RunBoundedChild: each way a child can end, as its parent sees it. The
// children here are this test binary forked, so each body is a few lines.
#include "hullpipe/util/bounded_child.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>

#include <gtest/gtest.h>

namespace hullpipe {
namespace {

TEST(BoundedChild, OutputAndExitStatusComeBack) {
  const auto r = RunBoundedChild([](int fd) { (void)!::write(fd, "hello", 5); }, 5, 5.0, 1024);
  EXPECT_FALSE(r.timed_out);
  EXPECT_FALSE(r.output_over);
  ASSERT_TRUE(WIFEXITED(r.status));
  EXPECT_EQ(WEXITSTATUS(r.status), 0);
  EXPECT_EQ(r.output, "hello");
}

TEST(BoundedChild, ACrashEndsByItsSignal) {
  const auto r = RunBoundedChild([](int) { ::raise(SIGSEGV); }, 5, 5.0, 0);
  EXPECT_FALSE(r.timed_out);
  ASSERT_TRUE(WIFSIGNALED(r.status));
  EXPECT_EQ(WTERMSIG(r.status), SIGSEGV);
}

// A child that sleeps past the wall bound is killed at it: the parent returns
// after ~0.3 s, not after the child's 30 s (the margin is for a loaded machine).
TEST(BoundedChild, AHangIsKilledAtTheWallBound) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = RunBoundedChild([](int) { ::sleep(30); }, 5, 0.3, 0);
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_TRUE(r.timed_out);
  ASSERT_TRUE(WIFSIGNALED(r.status));
  EXPECT_EQ(WTERMSIG(r.status), SIGKILL);
  EXPECT_LT(took, 3.0);
}

TEST(BoundedChild, OutputPastItsBoundIsCutAndTheChildEnded) {
  const auto r = RunBoundedChild(
      [](int fd) {
        const std::string block(4096, 'x');
        for (;;) (void)!::write(fd, block.data(), block.size());
      },
      5, 5.0, 10000);
  EXPECT_TRUE(r.output_over);
  EXPECT_FALSE(r.timed_out);
  EXPECT_GT(r.output.size(), 10000u);
  // Its next write after the parent closed the pipe ends it by SIGPIPE, unless
  // the parent's SIGKILL comes first.
  ASSERT_TRUE(WIFSIGNALED(r.status));
  EXPECT_TRUE(WTERMSIG(r.status) == SIGPIPE || WTERMSIG(r.status) == SIGKILL) << WTERMSIG(r.status);
}

}  // namespace
}  // namespace hullpipe
