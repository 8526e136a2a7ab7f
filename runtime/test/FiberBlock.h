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
// Fibers, beside OS threads (OsThreadTeam.h): the schedule is the same on
// every run, so a test fails for a missing barrier deterministically, and a
// block of 128 threads costs 128 stack switches per barrier, not 128 OS
// threads on two cores. What fibers cannot show, races between threads of
// one phase, OS threads under ThreadSanitizer do.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_TEST_FIBERBLOCK_H
#define YASPS_RUNTIME_TEST_FIBERBLOCK_H

#include "ThreadedBlock.h"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <ucontext.h>
#include <vector>

#if defined(__SANITIZE_THREAD__)
#define YASPS_FIBERS_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define YASPS_FIBERS_TSAN 1
#endif
#endif
#ifdef YASPS_FIBERS_TSAN
#include <sanitizer/tsan_interface.h>
#endif

namespace yasps::runtime::test {

/// ThreadSanitizer's view of the fibers (nothing without it).
struct FiberSanitizer {
#ifdef YASPS_FIBERS_TSAN
  static void *create() { return __tsan_create_fiber(0); }
  static void *current() { return __tsan_get_current_fiber(); }
  static void switchTo(void *fiber) {
    __tsan_switch_to_fiber(fiber, __tsan_switch_to_fiber_no_sync);
  }
  static void release(void *sync) { __tsan_release(sync); }
  static void acquire(void *sync) { __tsan_acquire(sync); }
#else
  static void *create() { return nullptr; }
  static void *current() { return nullptr; }
  static void switchTo(void *) {}
  static void release(void *) {}
  static void acquire(void *) {}
#endif
};

/// Runs the threads of one block as fibers that meet at barriers.
class FiberScheduler : public BlockScheduler {
public:
  /// Runs body(t) for the threads t of a block of `threads`, each on its
  /// own fiber; returns when all have returned.
  void run(int threads, const std::function<void(int)> &body) override {
    while (static_cast<int>(fibers_.size()) < threads)
      fibers_.push_back(std::make_unique<Fiber>());
    body_ = &body;
    active().store(this, std::memory_order_relaxed);
    self_ = FiberSanitizer::current();
    for (int t = 0; t < threads; ++t) {
      Fiber &fiber = *fibers_[t];
      if (!fiber.stack) {
        // A fiber runs thread t of every launch (trampoline), so that
        // ThreadSanitizer's record of its calls stays balanced.
        fiber.stack.reset(new char[kStackBytes]);
        fiber.sanitizer = FiberSanitizer::create();
        getcontext(&fiber.context);
        fiber.context.uc_stack.ss_sp = fiber.stack.get();
        fiber.context.uc_stack.ss_size = kStackBytes;
        fiber.context.uc_link = nullptr;
        makecontext(&fiber.context, &FiberScheduler::trampoline, 0);
      }
      fiber.state.store(State::Ready, std::memory_order_relaxed);
      fiber.barriers = 0;
    }
    // What the host did before the launch comes before every thread.
    FiberSanitizer::release(&start_);
    while (true) {
      for (int t = 0; t < threads; ++t)
        if (fibers_[t]->state.load(std::memory_order_relaxed) == State::Ready) {
          current_.store(t, std::memory_order_relaxed);
          FiberSanitizer::switchTo(fibers_[t]->sanitizer);
          swapcontext(&scheduler_, &fibers_[t]->context);
        }
      int done = 0;
      for (int t = 0; t < threads; ++t)
        done +=
            fibers_[t]->state.load(std::memory_order_relaxed) == State::Done;
      if (done == threads) {
        // Every thread comes before what the host does next.
        FiberSanitizer::acquire(&done_);
        return;
      }
      if (done > 0) {
        std::fprintf(stderr,
                     "stand-in driver: %d of %d threads of a block "
                     "returned while the others wait at a barrier\n",
                     done, threads);
        std::abort();
      }
      // Every thread is at the barrier: release them all.
      for (int t = 0; t < threads; ++t)
        fibers_[t]->state.store(State::Ready, std::memory_order_relaxed);
    }
  }

  /// Called on a fiber: waits until every thread of the block is here.
  void sync() override {
    Fiber &fiber = *fibers_[current_.load(std::memory_order_relaxed)];
    fiber.state.store(State::Waiting, std::memory_order_relaxed);
    // One address per barrier, two in turn: a thread that left barrier k
    // must not acquire what an earlier one did after it, and by barrier
    // k + 2 every thread has left barrier k.
    char *barrier = &barriers_[fiber.barriers++ % 2];
    FiberSanitizer::release(barrier);
    FiberSanitizer::switchTo(self_);
    swapcontext(&fiber.context, &scheduler_);
    FiberSanitizer::acquire(barrier);
  }

private:
#ifdef YASPS_FIBERS_TSAN
  // Instrumented frames are larger (the multilevel kernels overflowed 256
  // KiB).
  static constexpr std::size_t kStackBytes = 2048 * 1024;
#else
  static constexpr std::size_t kStackBytes = 256 * 1024;
#endif
  enum class State { Ready, Waiting, Done };
  struct Fiber {
    ucontext_t context;
    std::unique_ptr<char[]> stack;
    std::atomic<State> state{State::Done};
    void *sanitizer = nullptr; ///< ThreadSanitizer's fiber
    int barriers = 0;          ///< barriers passed in this launch
  };

  static std::atomic<FiberScheduler *> &active() {
    static std::atomic<FiberScheduler *> scheduler{nullptr};
    return scheduler;
  }
  /// A fiber's life: thread t of each launch, then back to the scheduler
  /// until the next launch resumes it. It never returns.
  static void trampoline() {
    FiberScheduler *self = active().load(std::memory_order_relaxed);
    const int t = self->current_.load(std::memory_order_relaxed);
    Fiber &fiber = *self->fibers_[t];
    while (true) {
      FiberSanitizer::acquire(&self->start_);
      // Read before the thread's end is released: the next launch writes
      // it.
      void *scheduler = self->self_;
      (*self->body_)(t);
      fiber.state.store(State::Done, std::memory_order_relaxed);
      FiberSanitizer::release(&self->done_);
      FiberSanitizer::switchTo(scheduler);
      swapcontext(&fiber.context, &self->scheduler_);
    }
  }

  std::vector<std::unique_ptr<Fiber>> fibers_;
  ucontext_t scheduler_;
  /// ThreadSanitizer's fiber of the scheduler, and the addresses that stand
  /// for a launch's start, its barriers and its threads' ends.
  void *self_ = nullptr;
  char start_ = 0, barriers_[2] = {0, 0}, done_ = 0;
  /// The scheduler's bookkeeping, which fibers and the scheduler share:
  /// relaxed atomics, so that ThreadSanitizer neither reports them nor
  /// takes them for an order between the threads.
  std::atomic<int> current_{0};
  const std::function<void(int)> *body_ = nullptr;
};

} // namespace yasps::runtime::test

#endif // YASPS_RUNTIME_TEST_FIBERBLOCK_H
