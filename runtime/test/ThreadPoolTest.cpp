//===- ThreadPoolTest.cpp - tests of the persistent thread pool -----------===//

#include "yasps/Runtime/Support/ThreadPool.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

using yasps::runtime::ThreadPool;

namespace {
using Chunk = std::pair<std::int64_t, std::int64_t>;

/// Runs parallelFor and returns its chunks sorted, checking that they do not
/// overlap by counting how often each index was visited.
std::vector<Chunk> chunksOf(ThreadPool &pool, std::int64_t begin,
                            std::int64_t end, std::int64_t minChunk) {
  std::vector<std::atomic<int>> visits(static_cast<std::size_t>(end - begin));
  std::mutex mutex;
  std::vector<Chunk> chunks;
  pool.parallelFor(begin, end, minChunk,
                   [&](std::int64_t chunkBegin, std::int64_t chunkEnd) {
                     for (std::int64_t i = chunkBegin; i < chunkEnd; ++i)
                       visits[static_cast<std::size_t>(i - begin)]++;
                     std::lock_guard<std::mutex> lock(mutex);
                     chunks.emplace_back(chunkBegin, chunkEnd);
                   });
  for (std::size_t i = 0; i < visits.size(); ++i)
    EXPECT_EQ(visits[i].load(), 1) << "index " << begin + std::int64_t(i);
  std::sort(chunks.begin(), chunks.end());
  return chunks;
}

/// Sets or unsets YASPS_NUM_THREADS for a scope.
class ScopedThreadsVariable {
public:
  explicit ScopedThreadsVariable(const char *value) {
    if (const char *old = std::getenv(kName))
      saved_ = old, hadValue_ = true;
    if (value)
      setenv(kName, value, 1);
    else
      unsetenv(kName);
  }
  ~ScopedThreadsVariable() {
    if (hadValue_)
      setenv(kName, saved_.c_str(), 1);
    else
      unsetenv(kName);
  }

private:
  static constexpr const char *kName = "YASPS_NUM_THREADS";
  std::string saved_;
  bool hadValue_ = false;
};
} // namespace

TEST(ThreadPool, SizeCountsTheCaller) {
  EXPECT_EQ(ThreadPool(1).size(), 1u);
  EXPECT_EQ(ThreadPool(3).size(), 3u);
  EXPECT_EQ(ThreadPool().size(),
            std::max(1u, std::thread::hardware_concurrency()));
}

TEST(ThreadPool, PartitionsEveryRange) {
  const std::vector<Chunk> ranges = {{0, 1},    {0, 10},     {-37, 1000},
                                     {5, 4101}, {3, 100003}, {-100, -1}};
  for (unsigned threads : {1u, 2u, 3u, 8u}) {
    ThreadPool pool(threads);
    for (auto [begin, end] : ranges) {
      for (std::int64_t minChunk : {1, 7, 1000, 1 << 20}) {
        SCOPED_TRACE("threads " + std::to_string(threads) + " range [" +
                     std::to_string(begin) + ", " + std::to_string(end) +
                     ") minChunk " + std::to_string(minChunk));
        std::vector<Chunk> chunks = chunksOf(pool, begin, end, minChunk);
        ASSERT_FALSE(chunks.empty());
        EXPECT_EQ(chunks.front().first, begin);
        EXPECT_EQ(chunks.back().second, end);
        for (std::size_t i = 0; i + 1 < chunks.size(); ++i)
          EXPECT_EQ(chunks[i].second, chunks[i + 1].first);
        for (auto [chunkBegin, chunkEnd] : chunks)
          EXPECT_GE(chunkEnd - chunkBegin, std::min(minChunk, end - begin));
        // EXPECT_* expands to an if-else, hence the braces.
        if (end - begin <= minChunk || threads == 1) {
          EXPECT_EQ(chunks.size(), 1u);
        }
      }
    }
  }
}

TEST(ThreadPool, EmptyRangeCallsNothing) {
  ThreadPool pool(4);
  int calls = 0;
  pool.parallelFor(5, 5, 1, [&](std::int64_t, std::int64_t) { ++calls; });
  pool.parallelFor(0, 0, 100, [&](std::int64_t, std::int64_t) { ++calls; });
  EXPECT_EQ(calls, 0);
}

TEST(ThreadPool, SmallRangeRunsInlineOnTheCaller) {
  ThreadPool pool(4);
  std::vector<std::thread::id> ids;
  std::vector<Chunk> chunks;
  pool.parallelFor(10, 60, 50, [&](std::int64_t begin, std::int64_t end) {
    ids.push_back(std::this_thread::get_id());
    chunks.emplace_back(begin, end);
  });
  EXPECT_EQ(ids, std::vector<std::thread::id>{std::this_thread::get_id()});
  EXPECT_EQ(chunks, (std::vector<Chunk>{{10, 60}}));
}

TEST(ThreadPool, RunsChunksOnAllThreadsAtOnce) {
  // Each chunk waits until every thread of the pool holds one, which only
  // happens if the workers and the caller run chunks at the same time.
  ThreadPool pool(4);
  std::mutex mutex;
  std::condition_variable allArrived;
  std::set<std::thread::id> ids;
  pool.parallelFor(0, 4 * 1000, 1000, [&](std::int64_t, std::int64_t) {
    std::unique_lock<std::mutex> lock(mutex);
    ids.insert(std::this_thread::get_id());
    allArrived.notify_all();
    allArrived.wait_for(lock, std::chrono::seconds(10),
                        [&] { return ids.size() == pool.size(); });
  });
  EXPECT_EQ(ids.size(), 4u);
  EXPECT_EQ(ids.count(std::this_thread::get_id()), 1u);
}

TEST(ThreadPool, UsesSeveralThreadsForLargeRanges) {
  ThreadPool pool(4);
  std::mutex mutex;
  std::set<std::thread::id> ids;
  pool.parallelFor(0, 1 << 20, 1, [&](std::int64_t, std::int64_t) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      ids.insert(std::this_thread::get_id());
    }
    // Long enough that the caller cannot take every chunk alone.
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  });
  EXPECT_GT(ids.size(), 1u);
}

TEST(ThreadPool, RethrowsTheFirstExceptionAfterAllChunks) {
  ThreadPool pool(4);
  std::atomic<int> running{0};
  auto throwing = [&](std::int64_t begin, std::int64_t end) {
    ++running;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    --running;
    if (begin <= 5000 && 5000 < end)
      throw std::runtime_error("chunk failed");
  };
  EXPECT_THROW(pool.parallelFor(0, 10000, 100, throwing), std::runtime_error);
  EXPECT_EQ(running.load(), 0);
  // Every chunk throws: exactly one exception comes out.
  EXPECT_THROW(pool.parallelFor(0, 10000, 100,
                                [](std::int64_t, std::int64_t) {
                                  throw std::logic_error("all fail");
                                }),
               std::logic_error);
  // The inline path rethrows too.
  EXPECT_THROW(pool.parallelFor(4990, 5010, 100, throwing), std::runtime_error);
  // The pool still works afterwards.
  std::vector<Chunk> chunks = chunksOf(pool, 0, 10000, 100);
  EXPECT_GT(chunks.size(), 1u);
}

TEST(ThreadPool, CanBeReusedManyTimes) {
  ThreadPool pool(3);
  for (int iteration = 0; iteration < 2000; ++iteration) {
    std::int64_t n = 1 + iteration % 97 * 31;
    std::atomic<std::int64_t> sum{0};
    pool.parallelFor(0, n, 8, [&](std::int64_t begin, std::int64_t end) {
      std::int64_t local = 0;
      for (std::int64_t i = begin; i < end; ++i)
        local += i;
      sum += local;
    });
    ASSERT_EQ(sum.load(), n * (n - 1) / 2) << "iteration " << iteration;
  }
}

TEST(ThreadPool, JobsAfterIdlePausesReachSleepingWorkers) {
  // Pauses longer than the workers poll for put them to sleep between
  // jobs, shorter ones find them polling; each job still runs every index
  // once and returns only when all chunks are done.
  ThreadPool pool(3);
  for (int iteration = 0; iteration < 30; ++iteration) {
    std::this_thread::sleep_for(std::chrono::microseconds(
        iteration % 3 == 0 ? 0 : (iteration % 3 == 1 ? 50 : 2000)));
    std::vector<std::atomic<int>> hits(4000);
    pool.parallelFor(0, 4000, 1, [&](std::int64_t begin, std::int64_t end) {
      std::this_thread::sleep_for(std::chrono::microseconds(100));
      for (std::int64_t i = begin; i < end; ++i)
        ++hits[i];
    });
    for (const auto &hit : hits)
      ASSERT_EQ(hit.load(), 1) << "iteration " << iteration;
  }
}

TEST(ThreadPool, AcceptsCallsFromSeveralThreads) {
  ThreadPool pool(3);
  std::atomic<std::int64_t> total{0};
  std::vector<std::thread> callers;
  for (int c = 0; c < 4; ++c)
    callers.emplace_back([&] {
      for (int iteration = 0; iteration < 200; ++iteration)
        pool.parallelFor(0, 1000, 10,
                         [&](std::int64_t begin, std::int64_t end) {
                           total += end - begin;
                         });
    });
  for (std::thread &caller : callers)
    caller.join();
  EXPECT_EQ(total.load(), 4 * 200 * 1000);
}

TEST(ThreadPool, NestedCallsRunInline) {
  ThreadPool pool(4);
  std::atomic<std::int64_t> total{0};
  pool.parallelFor(0, 64, 1, [&](std::int64_t begin, std::int64_t end) {
    pool.parallelFor(begin * 100, end * 100, 1,
                     [&](std::int64_t innerBegin, std::int64_t innerEnd) {
                       total += innerEnd - innerBegin;
                     });
  });
  EXPECT_EQ(total.load(), 6400);
}

TEST(ThreadPool, TeamMembersRunTogetherThroughBarriers) {
  // Each member runs once, on its own thread, and the members pass many
  // barriers in step: after each, every member sees what all wrote before.
  for (unsigned threads : {1u, 2u, 4u}) {
    ThreadPool pool(threads);
    yasps::runtime::TeamBarrier barrier(pool.size());
    const int rounds = 2000;
    std::vector<int> written(threads, 0);
    std::vector<std::thread::id> ids(threads);
    std::atomic<int> members{0}, mismatches{0};
    pool.runTeam([&](unsigned member, unsigned team) {
      ASSERT_EQ(team, threads);
      ++members;
      ids[member] = std::this_thread::get_id();
      for (int round = 1; round <= rounds; ++round) {
        written[member] = round;
        if (!barrier.wait())
          return;
        for (unsigned other = 0; other < team; ++other)
          mismatches += written[other] != round;
        if (!barrier.wait())
          return;
      }
    });
    EXPECT_EQ(members.load(), static_cast<int>(threads));
    EXPECT_EQ(mismatches.load(), 0);
    EXPECT_EQ(ids[0], std::this_thread::get_id());
    EXPECT_EQ(std::set<std::thread::id>(ids.begin(), ids.end()).size(),
              threads);
  }
}

TEST(ThreadPool, TeamsRunInlineWhenNested) {
  ThreadPool pool(3);
  std::atomic<int> calls{0};
  pool.parallelFor(0, 3, 1, [&](std::int64_t, std::int64_t) {
    pool.runTeam([&](unsigned member, unsigned team) {
      EXPECT_EQ(member, 0u);
      EXPECT_EQ(team, 1u);
      ++calls;
    });
  });
  EXPECT_EQ(calls.load(), 3);
}

TEST(ThreadPool, AbortedBarriersReleaseTheTeamAndTheErrorComesOut) {
  ThreadPool pool(3);
  yasps::runtime::TeamBarrier barrier(pool.size());
  std::atomic<int> released{0};
  EXPECT_THROW(pool.runTeam([&](unsigned member, unsigned) {
    if (member == 1) {
      // Late enough that the others wait at the barrier.
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      barrier.abort();
      throw std::runtime_error("member failed");
    }
    // The others would wait for member 1 for ever.
    if (!barrier.wait())
      ++released;
  }),
               std::runtime_error);
  // Members that had not started when member 1 failed are skipped; those
  // that had were released.
  EXPECT_LE(released.load(), 2);
  // The pool runs teams afterwards.
  std::atomic<int> members{0};
  pool.runTeam([&](unsigned, unsigned) { ++members; });
  EXPECT_EQ(members.load(), 3);
}

TEST(ThreadPool, RejectsInvalidArguments) {
  ThreadPool pool(2);
  auto body = [](std::int64_t, std::int64_t) {};
  EXPECT_THROW(pool.parallelFor(5, 4, 1, body), std::invalid_argument);
  EXPECT_THROW(pool.parallelFor(0, 10, 0, body), std::invalid_argument);
  EXPECT_THROW(pool.parallelFor(0, 10, -3, body), std::invalid_argument);
  EXPECT_THROW(pool.parallelFor(INT64_MIN, INT64_MAX, 1, body),
               std::invalid_argument);
}

TEST(ThreadPool, DefaultThreadCountReadsTheEnvironment) {
  unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
  {
    ScopedThreadsVariable variable(nullptr);
    EXPECT_EQ(yasps::runtime::defaultThreadCount(), hardware);
  }
  {
    ScopedThreadsVariable variable("");
    EXPECT_EQ(yasps::runtime::defaultThreadCount(), hardware);
  }
  {
    ScopedThreadsVariable variable("3");
    EXPECT_EQ(yasps::runtime::defaultThreadCount(), 3u);
  }
  for (const char *bad :
       {"0", "-2", "abc", "3x", " 4", "99999999999999999999"}) {
    ScopedThreadsVariable variable(bad);
    EXPECT_THROW(yasps::runtime::defaultThreadCount(), std::invalid_argument)
        << "YASPS_NUM_THREADS=\"" << bad << "\"";
  }
}

TEST(ThreadPool, DefaultPoolIsShared) {
  ThreadPool &pool = yasps::runtime::defaultThreadPool();
  EXPECT_EQ(&pool, &yasps::runtime::defaultThreadPool());
  EXPECT_GE(pool.size(), 1u);
  EXPECT_FALSE(chunksOf(pool, 0, 100000, 100).empty());
}
