#include "hullpipe/util/parallel.h"

#include <condition_variable>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <system_error>

#include <unistd.h>

namespace hullpipe {
namespace {

// Threads started once and kept for RunOnThreads: starting and joining a
// thread costs tens of microseconds, and a frameset's stages run a dozen rounds
// of them (docs/benchmarks.md, "Rows handed out in chunks, and threads kept").
// Never destroyed: its threads idle on a condition variable until the process
// ends.
class WorkerPool {
 public:
  static WorkerPool& Get() {
    static WorkerPool* const pool = new WorkerPool;
    return *pool;
  }

  void Run(int n, const std::function<void(int)>& fn) {
    // A nested call (from one of these threads) or one in a forked child
    // (where these threads do not exist and a lock may be held) runs here.
    auto job = std::make_shared<Job>(&fn, n);
    if (n <= 1 || in_pool_ || ::getpid() != pid_) {
      for (int t = 0; t < n; ++t) job->Do(t);
      if (job->error) std::rethrow_exception(job->error);
      return;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      while (started_ < std::min(n - 1, kMaxThreads)) {
        try {
          std::thread(&WorkerPool::Serve, this).detach();
        } catch (const std::system_error&) {
          break;  // no more threads to be had: this thread takes the parts left
        }
        ++started_;
      }
      for (int t = 1; t < n; ++t) queue_.push_back(job);
    }
    for (int t = 1; t < n; ++t) wake_.notify_one();  // as many as there are parts, not every kept thread
    // This thread takes part 0, then any part no worker has taken yet, then
    // waits for the parts the workers took.
    job->Do(0);
    for (int t = job->next++; t < n; t = job->next++) job->Do(t);
    std::unique_lock<std::mutex> lock(job->mutex);
    job->finished.wait(lock, [&] { return job->done == n; });
    if (job->error) std::rethrow_exception(job->error);
  }

  int started() {
    std::lock_guard<std::mutex> lock(mutex_);
    return started_;
  }

 private:
  static constexpr int kMaxThreads = 255;
  struct Job {
    Job(const std::function<void(int)>* f, int count) : fn(f), n(count) {}
    const std::function<void(int)>* fn;
    const int n;
    std::atomic<int> next{1};  // part 0 is the caller's
    std::mutex mutex;          // guards done, error
    std::condition_variable finished;
    int done = 0;
    std::exception_ptr error;
    // Runs part t, keeping its exception for the caller, and counts it done.
    void Do(int t) {
      std::exception_ptr e;
      try {
        (*fn)(t);
      } catch (...) {
        e = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(mutex);
      if (e && !error) error = e;
      if (++done == n) finished.notify_all();
    }
  };

  WorkerPool() : pid_(::getpid()) {}

  void Serve() {
    in_pool_ = true;
    for (;;) {
      std::shared_ptr<Job> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return !queue_.empty(); });
        job = std::move(queue_.front());
        queue_.pop_front();
      }
      // Parts the caller or another worker has not taken yet (none once all
      // are: a job's later entries are then skipped).
      for (int t = job->next++; t < job->n; t = job->next++) job->Do(t);
    }
  }

  const pid_t pid_;
  std::mutex mutex_;  // guards queue_, started_
  std::condition_variable wake_;
  std::deque<std::shared_ptr<Job>> queue_;
  int started_ = 0;
  static thread_local bool in_pool_;
};

thread_local bool WorkerPool::in_pool_ = false;

}  // namespace

void RunOnThreads(int n, const std::function<void(int)>& fn) { WorkerPool::Get().Run(n, fn); }

int KeptThreads() { return WorkerPool::Get().started(); }

}  // namespace hullpipe
