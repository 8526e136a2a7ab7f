//===- OsThreadTeam.h - a CUDA block's threads as OS threads -----*- C++
//-*-===//
//
// Runs each CUDA thread of a block on an OS thread of its own, all at once,
// with a barrier for `sync()`: the threads of one phase run concurrently, as
// on a GPU, and ThreadSanitizer watches them (scripts/sanitize.sh runs the
// GPU solver's tests so). The team's threads are kept between launches: a
// PCG solve launches thousands of blocks. The outcome of a race depends on
// timing here, so a test that must fail on a missing barrier runs on fibers
// (FiberBlock.h); here it is ThreadSanitizer's report that shows it.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_TEST_OSTHREADTEAM_H
#define YASPS_RUNTIME_TEST_OSTHREADTEAM_H

#include "ThreadedBlock.h"

#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <thread>
#include <vector>

namespace yasps::runtime::test {

class OsThreadTeam : public BlockScheduler {
public:
  ~OsThreadTeam() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
      ++launch_;
    }
    start_.notify_all();
    for (std::thread &worker : workers_)
      worker.join();
  }

  void run(int threads, const std::function<void(int)> &body) override {
    while (static_cast<int>(workers_.size()) < threads) {
      int t = static_cast<int>(workers_.size());
      std::lock_guard<std::mutex> lock(mutex_);
      workers_.emplace_back(
          [this, t, seen = launch_]() mutable { work(t, seen); });
    }
    std::unique_lock<std::mutex> lock(mutex_);
    body_ = &body;
    active_ = threads;
    finished_ = arrived_ = 0;
    ++launch_;
    start_.notify_all();
    done_.wait(lock, [&] { return finished_ == active_; });
  }

  void sync() override {
    std::unique_lock<std::mutex> lock(mutex_);
    const long long barrier = barrier_;
    if (++arrived_ == active_) {
      arrived_ = 0;
      ++barrier_;
      released_.notify_all();
      return;
    }
    checkNotDivergent();
    released_.wait(lock, [&] { return barrier_ != barrier; });
  }

private:
  /// Worker t: runs each launch's body(t) if the block has a thread t.
  void work(int t, long long seen) {
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      start_.wait(lock, [&] { return launch_ != seen; });
      seen = launch_;
      if (stopping_)
        return;
      if (t >= active_)
        continue;
      const std::function<void(int)> *body = body_;
      lock.unlock();
      (*body)(t);
      lock.lock();
      ++finished_;
      checkNotDivergent();
      if (finished_ == active_)
        done_.notify_all();
    }
  }

  /// Aborts if every thread still running waits at a barrier that the
  /// finished ones will never reach (called with the lock held).
  void checkNotDivergent() const {
    if (finished_ > 0 && arrived_ > 0 && arrived_ + finished_ == active_) {
      std::fprintf(stderr,
                   "stand-in driver: %d of %d threads of a block returned "
                   "while the others wait at a barrier\n",
                   finished_, active_);
      std::abort();
    }
  }

  std::mutex mutex_;
  std::condition_variable start_, done_, released_;
  std::vector<std::thread> workers_;
  const std::function<void(int)> *body_ = nullptr;
  long long launch_ = 0, barrier_ = 0;
  int active_ = 0, finished_ = 0, arrived_ = 0;
  bool stopping_ = false;
};

} // namespace yasps::runtime::test

#endif // YASPS_RUNTIME_TEST_OSTHREADTEAM_H
