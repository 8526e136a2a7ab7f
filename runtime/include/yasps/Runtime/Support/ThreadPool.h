//===- ThreadPool.h - persistent pool for parallel loops --------*- C++ -*-===//
//
// Kernels run once per simulation step, so the threads that run them are
// created once and kept: starting threads every step would cost more than
// small steps take. The calling thread takes chunks too, so a pool of N
// threads keeps only N - 1 workers. Threads that have just finished a job
// poll for the next one for a short while before they sleep: jobs come in
// bursts, and waking a sleeping thread costs more than a small job.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SUPPORT_THREADPOOL_H
#define YASPS_RUNTIME_SUPPORT_THREADPOOL_H

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace yasps::runtime {

class ThreadPool {
public:
  /// A pool of `numThreads` threads counting the caller of parallelFor; 0
  /// means std::thread::hardware_concurrency() (at least 1).
  explicit ThreadPool(unsigned numThreads = 0);
  ~ThreadPool();

  ThreadPool(const ThreadPool &) = delete;
  ThreadPool &operator=(const ThreadPool &) = delete;

  /// Number of threads that run chunks, the caller of parallelFor included.
  unsigned size() const { return static_cast<unsigned>(workers_.size()) + 1; }

  /// Runs `body(chunkBegin, chunkEnd)` on contiguous chunks that partition
  /// [begin, end), on the pool's threads and the calling thread, and returns
  /// when all have finished. Chunks hold at least `minChunk` indices unless
  /// the range is smaller; a range of at most `minChunk` indices, a pool of
  /// one thread, or a call from inside a body of this pool runs inline as one
  /// chunk. An empty range calls nothing.
  ///
  /// If bodies throw, chunks not yet started are skipped and the first
  /// exception is rethrown here once no chunk is running. Calls from several
  /// threads are serialised. Throws std::invalid_argument if `end < begin`,
  /// the range holds more than INT64_MAX indices, or `minChunk < 1`.
  void parallelFor(std::int64_t begin, std::int64_t end, std::int64_t minChunk,
                   const std::function<void(std::int64_t, std::int64_t)> &body);

  /// Runs `body(member, teamSize)` once on each of the pool's threads at
  /// the same time, member 0 on the caller, and returns when all have
  /// finished. Unlike parallelFor's chunks, the members run concurrently and
  /// may wait for each other (at a TeamBarrier of teamSize threads). A pool
  /// of one thread, or a call from inside a body of this pool, runs
  /// body(0, 1) inline. If bodies throw, the first exception is rethrown
  /// here once all have returned; a body that throws must first release
  /// the others from any barrier they could wait at (TeamBarrier::abort).
  void runTeam(const std::function<void(unsigned, unsigned)> &body);

private:
  struct Job;

  /// Posts `job` to the workers, runs it on the calling thread too, and
  /// waits for the workers to finish it.
  void runJob(Job &job);

  void workerLoop();
  void stopWorkers();
  void runChunks(Job &job);
  void runChunk(Job &job, std::int64_t k);

  std::vector<std::thread> workers_;
  // Held while a job runs: one job at a time.
  std::mutex callMutex_;
  // Sleeping threads wait on these; the generation and the stop flag change
  // under it, so that a thread checking them there cannot miss a change.
  std::mutex mutex_;
  std::condition_variable wakeWorkers_;
  std::condition_variable jobDone_;
  std::atomic<Job *> job_{nullptr};
  // Bumped per job so that each worker takes part in each job exactly once.
  std::atomic<std::uint64_t> generation_{0};
  // Workers that have not yet finished with the current job; the job lives
  // on the caller's stack until this is 0.
  std::atomic<unsigned> pendingWorkers_{0};
  std::atomic<bool> stopping_{false};
};

/// A barrier for the members of ThreadPool::runTeam: each wait() returns
/// once all `count` members have arrived. Waiting threads poll, then yield
/// the core (a member the system has descheduled gets it back), so a wait
/// costs a fraction of a microsecond when all members are running.
class TeamBarrier {
public:
  explicit TeamBarrier(unsigned count) : count_(count) {}

  /// Waits for all members; false once abort() was called (the caller
  /// should return: the team's work is off).
  bool wait();
  /// Releases every member waiting now or later with false.
  void abort() { aborted_.store(true, std::memory_order_release); }

private:
  const unsigned count_;
  std::atomic<unsigned> arrived_{0};
  std::atomic<std::uint64_t> phase_{0};
  std::atomic<bool> aborted_{false};
};

/// The size defaultThreadPool() gets: the positive integer in environment
/// variable YASPS_NUM_THREADS if it is set and not empty, otherwise
/// std::thread::hardware_concurrency() (at least 1). Throws
/// std::invalid_argument if the variable holds anything else.
unsigned defaultThreadCount();

/// The process-wide pool, created on first use with defaultThreadCount()
/// threads.
ThreadPool &defaultThreadPool();

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SUPPORT_THREADPOOL_H
