//===- ThreadedBlock.h - a CUDA block whose threads run the body ---*- C++
//-*-===//
//
// The stand-in driver (FakeCuda.cpp) can run a solver kernel's block with
// each CUDA thread running the body itself, as on a GPU, meeting the others
// at `sync()`. Two schedulers do that: fibers taking turns in a fixed order
// (FiberBlock.h), which make a missing barrier show on every run, and one OS
// thread per CUDA thread (OsThreadTeam.h), which run concurrently, so that
// ThreadSanitizer sees the races a missing barrier or a plain addition
// where an atomic one belongs would be on a GPU.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_TEST_THREADEDBLOCK_H
#define YASPS_RUNTIME_TEST_THREADEDBLOCK_H

#include <functional>

namespace yasps::runtime::test {

/// Runs the threads of one block, each through the whole body.
class BlockScheduler {
public:
  virtual ~BlockScheduler() = default;
  /// Runs body(t) for the threads t of a block of `threads`; returns when
  /// all have returned. Threads that return while others wait at a barrier
  /// are an error (divergent barriers are undefined on a GPU), reported and
  /// aborted on.
  virtual void run(int threads, const std::function<void(int)> &body) = 0;
  /// Called by a thread of the running block: waits until every thread of
  /// the block is here.
  virtual void sync() = 0;
};

/// The Block of GpuSolverKernels.h for one thread of a block that a
/// BlockScheduler runs: what the kernel body's calls do on a GPU, for
/// thread `thread`. `skipSync`, when >= 0, is the index of a barrier this
/// thread does not wait at (to test that a missing barrier is caught).
template <typename Shared> struct ThreadedBlock {
  Shared *shared;
  long long blockIndex = 0, gridSize = 1;
  int blockSize = 1;
  int thread = 0;
  BlockScheduler *scheduler = nullptr;
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

#endif // YASPS_RUNTIME_TEST_THREADEDBLOCK_H
