//===- ThreadPool.cpp - persistent pool for parallel loops ----------------===//

#include "yasps/Runtime/Support/ThreadPool.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>

using namespace yasps::runtime;

// A few chunks per thread let threads that finish early, or the caller that
// starts before the workers wake, take over work from slower ones.
static constexpr std::int64_t kChunksPerThread = 4;

// How long a thread polls for the next job (a worker) or for the workers to
// finish (the caller) before it sleeps on a condition variable. Waking a
// sleeping thread costs tens of microseconds, up to about a hundred on a
// loaded 2-core machine: more than a Newton step's kernels and products of a
// small scene take. Jobs come in bursts (a solve's products, an assembly's
// kernels), so a thread that has just finished one polls a little while and
// picks up the next at once; between bursts it sleeps.
static constexpr auto kPollFor = std::chrono::microseconds(100);

namespace {
/// Polls `ready` until it holds or kPollFor has passed; returns it.
template <typename Ready> bool pollUntil(Ready &&ready) {
  auto deadline = std::chrono::steady_clock::now() + kPollFor;
  for (unsigned spins = 0;; ++spins) {
    if (ready())
      return true;
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
    if (spins % 64 == 63 && std::chrono::steady_clock::now() > deadline)
      return ready();
  }
}
} // namespace

// The pool whose chunk the current thread is running, so that a nested
// parallelFor on the same pool runs inline instead of waiting for itself.
static thread_local const ThreadPool *currentPool = nullptr;

namespace {
/// Sets currentPool for a scope and restores the previous value.
class CurrentPoolScope {
public:
  explicit CurrentPoolScope(const ThreadPool *pool) : saved_(currentPool) {
    currentPool = pool;
  }
  ~CurrentPoolScope() { currentPool = saved_; }

private:
  const ThreadPool *saved_;
};
} // namespace

/// One parallelFor call. Chunk k is [begin + k * base + min(k, rem), ...):
/// the first `rem` chunks get one index more, so sizes differ by at most one
/// and none is below minChunk.
struct ThreadPool::Job {
  const std::function<void(std::int64_t, std::int64_t)> &body;
  std::int64_t begin;
  std::int64_t base;
  std::int64_t rem;
  std::int64_t numChunks;
  /// Whether each thread takes at most one chunk (runTeam's members).
  bool onePerThread = false;
  std::atomic<std::int64_t> nextChunk{0};
  std::atomic<bool> failed{false};
  std::mutex errorMutex;
  std::exception_ptr error;
};

ThreadPool::ThreadPool(unsigned numThreads) {
  if (numThreads == 0)
    numThreads = std::max(1u, std::thread::hardware_concurrency());
  try {
    workers_.reserve(numThreads - 1);
    for (unsigned i = 1; i < numThreads; ++i)
      workers_.emplace_back([this] { workerLoop(); });
  } catch (...) {
    // Joinable threads left in workers_ would call std::terminate.
    stopWorkers();
    throw;
  }
}

ThreadPool::~ThreadPool() { stopWorkers(); }

void ThreadPool::stopWorkers() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_.store(true, std::memory_order_release);
  }
  wakeWorkers_.notify_all();
  for (std::thread &worker : workers_)
    worker.join();
  workers_.clear();
}

void ThreadPool::workerLoop() {
  CurrentPoolScope scope(this);
  std::uint64_t seen = 0;
  while (true) {
    auto posted = [&] {
      return stopping_.load(std::memory_order_acquire) ||
             generation_.load(std::memory_order_acquire) != seen;
    };
    if (!pollUntil(posted)) {
      std::unique_lock<std::mutex> lock(mutex_);
      wakeWorkers_.wait(lock, posted);
    }
    if (stopping_.load(std::memory_order_acquire))
      return;
    seen = generation_.load(std::memory_order_acquire);
    runChunks(*job_.load(std::memory_order_acquire));
    if (pendingWorkers_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
      // The caller may sleep on jobDone_: notify under the mutex, so that it
      // cannot miss this between its check and its wait.
      std::lock_guard<std::mutex> lock(mutex_);
      jobDone_.notify_one();
    }
  }
}

void ThreadPool::runChunks(Job &job) {
  while (!job.failed.load(std::memory_order_relaxed)) {
    std::int64_t k = job.nextChunk.fetch_add(1, std::memory_order_relaxed);
    if (k >= job.numChunks)
      return;
    runChunk(job, k);
    if (job.onePerThread)
      return;
  }
}

void ThreadPool::runChunk(Job &job, std::int64_t k) {
  std::int64_t chunkBegin = job.begin + k * job.base + std::min(k, job.rem);
  std::int64_t chunkEnd = chunkBegin + job.base + (k < job.rem ? 1 : 0);
  try {
    job.body(chunkBegin, chunkEnd);
  } catch (...) {
    std::lock_guard<std::mutex> lock(job.errorMutex);
    if (!job.error)
      job.error = std::current_exception();
    job.failed.store(true, std::memory_order_relaxed);
  }
}

void ThreadPool::parallelFor(
    std::int64_t begin, std::int64_t end, std::int64_t minChunk,
    const std::function<void(std::int64_t, std::int64_t)> &body) {
  if (end < begin)
    throw std::invalid_argument("parallelFor range [" + std::to_string(begin) +
                                ", " + std::to_string(end) +
                                ") ends before it begins");
  if (minChunk < 1)
    throw std::invalid_argument("parallelFor minimum chunk size must be "
                                "positive, got " +
                                std::to_string(minChunk));
  if (begin == end)
    return;
  // Unsigned so that a range wider than INT64_MAX does not overflow.
  std::uint64_t count =
      static_cast<std::uint64_t>(end) - static_cast<std::uint64_t>(begin);
  if (count > static_cast<std::uint64_t>(INT64_MAX))
    throw std::invalid_argument("parallelFor range [" + std::to_string(begin) +
                                ", " + std::to_string(end) +
                                ") holds more than INT64_MAX indices");
  if (count <= static_cast<std::uint64_t>(minChunk) || workers_.empty() ||
      currentPool == this) {
    body(begin, end);
    return;
  }
  std::int64_t n = static_cast<std::int64_t>(count);
  std::int64_t numChunks = std::min(
      n / minChunk, static_cast<std::int64_t>(size()) * kChunksPerThread);

  Job job{body, begin, n / numChunks, n % numChunks, numChunks};
  runJob(job);
}

void ThreadPool::runTeam(const std::function<void(unsigned, unsigned)> &body) {
  if (workers_.empty() || currentPool == this) {
    body(0, 1);
    return;
  }
  const unsigned teamSize = size();
  // Every worker takes part in every job, and each member takes one chunk:
  // all teamSize chunks run at once, on distinct threads.
  std::function<void(std::int64_t, std::int64_t)> member =
      [&](std::int64_t index, std::int64_t) {
        body(static_cast<unsigned>(index), teamSize);
      };
  Job job{member, 0, 1, 0, static_cast<std::int64_t>(teamSize)};
  job.onePerThread = true;
  // Member 0 is the caller's (runJob): a worker woken first must not take
  // it.
  job.nextChunk.store(1, std::memory_order_relaxed);
  runJob(job);
}

void ThreadPool::runJob(Job &job) {
  std::lock_guard<std::mutex> callLock(callMutex_);
  CurrentPoolScope scope(this);
  job_.store(&job, std::memory_order_relaxed);
  pendingWorkers_.store(static_cast<unsigned>(workers_.size()),
                        std::memory_order_relaxed);
  {
    // Under the mutex: a worker about to sleep checks the generation there.
    std::lock_guard<std::mutex> lock(mutex_);
    generation_.fetch_add(1, std::memory_order_release);
  }
  wakeWorkers_.notify_all();
  if (job.onePerThread)
    runChunk(job, 0);
  else
    runChunks(job);
  auto finished = [&] {
    return pendingWorkers_.load(std::memory_order_acquire) == 0;
  };
  if (!pollUntil(finished)) {
    std::unique_lock<std::mutex> lock(mutex_);
    jobDone_.wait(lock, finished);
  }
  job_.store(nullptr, std::memory_order_relaxed);
  if (job.error)
    std::rethrow_exception(job.error);
}

bool TeamBarrier::wait() {
  const std::uint64_t phase = phase_.load(std::memory_order_acquire);
  if (arrived_.fetch_add(1, std::memory_order_acq_rel) + 1 == count_) {
    // The last to arrive opens the next phase.
    arrived_.store(0, std::memory_order_relaxed);
    phase_.store(phase + 1, std::memory_order_release);
    return !aborted_.load(std::memory_order_acquire);
  }
  for (unsigned spins = 0;; ++spins) {
    if (phase_.load(std::memory_order_acquire) != phase)
      return !aborted_.load(std::memory_order_acquire);
    if (aborted_.load(std::memory_order_acquire))
      return false;
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
    // A member held up for long was probably descheduled: give it the core.
    if (spins >= 4096)
      std::this_thread::yield();
  }
}

unsigned yasps::runtime::defaultThreadCount() {
  const char *value = std::getenv("YASPS_NUM_THREADS");
  if (!value || !*value)
    return std::max(1u, std::thread::hardware_concurrency());
  // strtoul accepts leading blanks and a minus sign; a count should be
  // digits only.
  bool digitsOnly = true;
  for (const char *c = value; *c; ++c)
    digitsOnly &= *c >= '0' && *c <= '9';
  errno = 0;
  unsigned long parsed = digitsOnly ? std::strtoul(value, nullptr, 10) : 0;
  if (!digitsOnly || errno == ERANGE || parsed == 0 || parsed > UINT_MAX)
    throw std::invalid_argument(
        std::string("YASPS_NUM_THREADS must be a positive integer, got \"") +
        value + "\"");
  return static_cast<unsigned>(parsed);
}

ThreadPool &yasps::runtime::defaultThreadPool() {
  static ThreadPool pool(defaultThreadCount());
  return pool;
}
