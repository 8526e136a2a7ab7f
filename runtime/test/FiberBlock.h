//===- FiberBlock.h - a CUDA block's threads as fibers, for the stand-in --===//
//
// The stand-in driver (FakeCuda.cpp) runs the solver kernels' bodies on
// the host. One after another, each `forEachThread` for all threads before
// the next, a missing `sync()` cannot show: every phase has ended before
// the next begins anyway. Here each CUDA thread of a block runs the body
// itself, as on a GPU, on a fiber of its own (ucontext), and `sync()` is a
// barrier: the fiber waits there until every thread of the block has come
// to it. The schedule is thread-major (thread 0 runs to its next barrier,
// then thread 1, ...), one of the schedules a GPU may pick, so that a
// thread that reads what a later thread writes before a barrier it skipped
// reads stale values, on every run: the results differ from the CPU's. (A
// read of what an earlier thread wrote still sees it: that order cannot
// catch every missing barrier.) Threads
// that finish while others wait at a barrier are an error (divergent
// barriers are undefined on a GPU), reported and aborted on.
//
// Fibers, not threads: the schedule is the same on every run, so a test
// fails for a missing barrier deterministically, and a block of 128
// threads costs 128 stack switches per barrier, not 128 OS threads on two
// cores.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_TEST_FIBERBLOCK_H
#define YASPS_RUNTIME_TEST_FIBERBLOCK_H

#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <ucontext.h>
#include <vector>

namespace yasps::runtime::test {

/// Runs the threads of one block as fibers that meet at barriers.
class FiberScheduler {
public:
  /// Runs body(t) for the threads t of a block of `threads`, each on its
  /// own fiber; returns when all have returned.
  void run(int threads, const std::function<void(int)> &body) {
    if (static_cast<int>(fibers_.size()) < threads)
      fibers_.resize(threads);
    body_ = &body;
    active() = this;
    for (int t = 0; t < threads; ++t) {
      Fiber &fiber = fibers_[t];
      if (!fiber.stack)
        fiber.stack.reset(new char[kStackBytes]);
      getcontext(&fiber.context);
      fiber.context.uc_stack.ss_sp = fiber.stack.get();
      fiber.context.uc_stack.ss_size = kStackBytes;
      fiber.context.uc_link = &scheduler_;
      makecontext(&fiber.context, &FiberScheduler::trampoline, 0);
      fiber.state = State::Ready;
    }
    while (true) {
      for (int t = 0; t < threads; ++t)
        if (fibers_[t].state == State::Ready) {
          current_ = t;
          swapcontext(&scheduler_, &fibers_[t].context);
        }
      int waiting = 0, done = 0;
      for (int t = 0; t < threads; ++t) {
        waiting += fibers_[t].state == State::Waiting;
        done += fibers_[t].state == State::Done;
      }
      if (done == threads)
        return;
      if (done > 0) {
        std::fprintf(stderr,
                     "stand-in driver: %d of %d threads of a block "
                     "returned while the others wait at a barrier\n",
                     done, threads);
        std::abort();
      }
      // Every thread is at the barrier: release them all.
      for (int t = 0; t < threads; ++t)
        fibers_[t].state = State::Ready;
    }
  }

  /// Called on a fiber: waits until every thread of the block is here.
  void sync() {
    Fiber &fiber = fibers_[current_];
    fiber.state = State::Waiting;
    swapcontext(&fiber.context, &scheduler_);
  }

private:
  static constexpr std::size_t kStackBytes = 256 * 1024;
  enum class State { Ready, Waiting, Done };
  struct Fiber {
    ucontext_t context;
    std::unique_ptr<char[]> stack;
    State state = State::Done;
  };

  static FiberScheduler *&active() {
    static FiberScheduler *scheduler = nullptr;
    return scheduler;
  }
  static void trampoline() {
    FiberScheduler *self = active();
    const int t = self->current_;
    (*self->body_)(t);
    self->fibers_[t].state = State::Done;
    // Returning resumes uc_link, the scheduler.
  }

  std::vector<Fiber> fibers_;
  ucontext_t scheduler_;
  int current_ = 0;
  const std::function<void(int)> *body_ = nullptr;
};

/// The Block of GpuSolverKernels.h for one thread on a fiber: what the
/// kernel body's calls do on a GPU, for thread `thread`. `skipSync`, when
/// >= 0, is the index of a barrier this thread does not wait at (to test
/// that a missing barrier is caught).
template <typename Shared> struct FiberBlock {
  Shared *shared;
  long long blockIndex = 0, gridSize = 1;
  int blockSize = 1;
  int thread = 0;
  FiberScheduler *scheduler = nullptr;
  int skipSync = -1;
  int syncs = 0;

  long long index() const { return blockIndex; }
  long long numBlocks() const { return gridSize; }
  int size() const { return blockSize; }
  template <typename F> void forEachThread(F &&f) { f(thread); }
  void sync() {
    if (syncs++ == skipSync)
      return;
    scheduler->sync();
  }
};

} // namespace yasps::runtime::test

#endif // YASPS_RUNTIME_TEST_FIBERBLOCK_H
