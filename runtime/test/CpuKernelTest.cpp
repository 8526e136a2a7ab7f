//===- CpuKernelTest.cpp - tests of launching packed-ABI kernels ----------===//
//
// The kernels here are written by hand against the packed ABI that MLIR's
// ExecutionEngine generates: args[i] points to the i-th flattened argument,
// (begin, end) then five fields per memref<?xT>.
//
//===----------------------------------------------------------------------===//

#include "yasps/Runtime/Support/CpuKernel.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

using yasps::runtime::KernelBuffer;
using yasps::runtime::launchCpuKernel;
using yasps::runtime::ThreadPool;

namespace {
/// A memref<?xT> read back from its five flattened fields.
template <typename T> struct MemRefView {
  T *allocated;
  T *aligned;
  std::int64_t offset;
  std::int64_t size;
  std::int64_t stride;

  T &operator[](std::int64_t i) const { return aligned[offset + i * stride]; }
};

template <typename T> MemRefView<T> memrefAt(void **args, int index) {
  void **fields = args + 2 + 5 * index;
  return {*static_cast<T **>(fields[0]), *static_cast<T **>(fields[1]),
          *static_cast<std::int64_t *>(fields[2]),
          *static_cast<std::int64_t *>(fields[3]),
          *static_cast<std::int64_t *>(fields[4])};
}

std::int64_t beginOf(void **args) {
  return *static_cast<std::int64_t *>(args[0]);
}
std::int64_t endOf(void **args) {
  return *static_cast<std::int64_t *>(args[1]);
}

// Set by kernels that see a descriptor other than the launcher promises.
std::atomic<bool> badDescriptor{false};

template <typename T>
void checkDescriptor(const MemRefView<T> &memref, std::int64_t size) {
  if (memref.allocated != memref.aligned || memref.offset != 0 ||
      memref.stride != 1 || memref.size != size)
    badDescriptor = true;
}

/// out[i] = a[i] * 2 + b[i] over (begin, end, a, b, out), all f64.
void axpyKernel(void **args) {
  MemRefView<double> a = memrefAt<double>(args, 0);
  MemRefView<double> b = memrefAt<double>(args, 1);
  MemRefView<double> out = memrefAt<double>(args, 2);
  checkDescriptor(b, a.size);
  checkDescriptor(out, a.size);
  for (std::int64_t i = beginOf(args); i < endOf(args); ++i)
    out[i] = a[i] * 2 + b[i];
}

/// visits[i] += 1 over (begin, end, visits: i64) and records the chunk.
std::mutex chunkMutex;
std::vector<std::pair<std::int64_t, std::int64_t>> chunks;
void countingKernel(void **args) {
  MemRefView<std::int64_t> visits = memrefAt<std::int64_t>(args, 0);
  for (std::int64_t i = beginOf(args); i < endOf(args); ++i)
    visits[i] += 1;
  std::lock_guard<std::mutex> lock(chunkMutex);
  chunks.emplace_back(beginOf(args), endOf(args));
}

/// out[i] = float(ints[i]) + float(longs[i]) over (begin, end, ints: i32,
/// longs: i64, out: f32), with the buffer sizes checked against `sizes`.
std::vector<std::int64_t> expectedSizes;
void mixedKernel(void **args) {
  MemRefView<std::int32_t> ints = memrefAt<std::int32_t>(args, 0);
  MemRefView<std::int64_t> longs = memrefAt<std::int64_t>(args, 1);
  MemRefView<float> out = memrefAt<float>(args, 2);
  checkDescriptor(ints, expectedSizes[0]);
  checkDescriptor(longs, expectedSizes[1]);
  checkDescriptor(out, expectedSizes[2]);
  for (std::int64_t i = beginOf(args); i < endOf(args); ++i)
    out[i] = static_cast<float>(ints[i]) + static_cast<float>(longs[i]);
}

std::atomic<int> calls{0};
void callCountingKernel(void **) { ++calls; }
} // namespace

TEST(CpuKernel, ComputesAKernelOverAllInstances) {
  for (unsigned threads : {1u, 2u, 4u, 7u}) {
    ThreadPool pool(threads);
    for (std::int64_t n : {1, 5, 1023, 1024, 1025, 4097, 100000}) {
      for (std::int64_t minChunk : {1, 100, 1024}) {
        SCOPED_TRACE("threads " + std::to_string(threads) + " n " +
                     std::to_string(n) + " minChunk " +
                     std::to_string(minChunk));
        std::vector<double> a(n), b(n), out(n, -1.0);
        for (std::int64_t i = 0; i < n; ++i)
          a[i] = 0.5 * i, b[i] = 3.0 - i;
        badDescriptor = false;
        launchCpuKernel(axpyKernel,
                        {{a.data(), n}, {b.data(), n}, {out.data(), n}}, n,
                        pool, minChunk);
        EXPECT_FALSE(badDescriptor);
        for (std::int64_t i = 0; i < n; ++i)
          ASSERT_EQ(out[i], a[i] * 2 + b[i]) << "instance " << i;
      }
    }
  }
}

TEST(CpuKernel, ChunksCoverEveryInstanceOnce) {
  for (unsigned threads : {1u, 3u, 8u}) {
    ThreadPool pool(threads);
    for (std::int64_t n : {1, 999, 50000}) {
      SCOPED_TRACE("threads " + std::to_string(threads) + " n " +
                   std::to_string(n));
      std::vector<std::int64_t> visits(n, 0);
      chunks.clear();
      launchCpuKernel(countingKernel, {{visits.data(), n}}, n, pool, 64);
      EXPECT_EQ(std::count(visits.begin(), visits.end(), 1), n);
      std::sort(chunks.begin(), chunks.end());
      ASSERT_FALSE(chunks.empty());
      EXPECT_EQ(chunks.front().first, 0);
      EXPECT_EQ(chunks.back().second, n);
      for (std::size_t i = 0; i + 1 < chunks.size(); ++i)
        EXPECT_EQ(chunks[i].second, chunks[i + 1].first);
      if (threads > 1 && n > 64) {
        EXPECT_GT(chunks.size(), 1u);
      }
    }
  }
}

TEST(CpuKernel, PassesEachBufferWithItsOwnTypeAndSize) {
  ThreadPool pool(4);
  const std::int64_t n = 3000;
  // The buffers may be larger than the instance count.
  std::vector<std::int32_t> ints(n + 7);
  std::vector<std::int64_t> longs(n + 1);
  std::vector<float> out(n, 0.0f);
  for (std::int64_t i = 0; i < n; ++i)
    ints[i] = static_cast<std::int32_t>(i), longs[i] = 10 * i;
  expectedSizes = {n + 7, n + 1, n};
  badDescriptor = false;
  launchCpuKernel(
      mixedKernel,
      {{ints.data(), n + 7}, {longs.data(), n + 1}, {out.data(), n}}, n, pool,
      100);
  EXPECT_FALSE(badDescriptor);
  for (std::int64_t i = 0; i < n; ++i)
    ASSERT_EQ(out[i], static_cast<float>(11 * i)) << "instance " << i;
}

TEST(CpuKernel, ZeroInstancesCallsNothing) {
  ThreadPool pool(2);
  calls = 0;
  launchCpuKernel(callCountingKernel, {}, 0, pool);
  launchCpuKernel(callCountingKernel, {{nullptr, 0}}, 0, pool);
  EXPECT_EQ(calls.load(), 0);
  // A kernel without buffers still runs once per chunk.
  launchCpuKernel(callCountingKernel, {}, 10, pool);
  EXPECT_EQ(calls.load(), 1);
}

TEST(CpuKernel, RejectsInvalidArguments) {
  ThreadPool pool(2);
  std::vector<double> data(10);
  EXPECT_THROW(launchCpuKernel(nullptr, {{data.data(), 10}}, 10, pool),
               std::invalid_argument);
  EXPECT_THROW(launchCpuKernel(callCountingKernel, {}, -1, pool),
               std::invalid_argument);
  EXPECT_THROW(
      launchCpuKernel(callCountingKernel, {{data.data(), -1}}, 1, pool),
      std::invalid_argument);
  EXPECT_THROW(launchCpuKernel(callCountingKernel, {{nullptr, 5}}, 1, pool),
               std::invalid_argument);
  EXPECT_THROW(launchCpuKernel(callCountingKernel, {}, 10, pool, 0),
               std::invalid_argument);
}
