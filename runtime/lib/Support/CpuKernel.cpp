//===- CpuKernel.cpp - launching compiled CPU kernels ---------------------===//

#include "yasps/Runtime/Support/CpuKernel.h"

#include "yasps/Runtime/Support/ThreadPool.h"

#include <stdexcept>
#include <string>

using namespace yasps::runtime;

namespace {
/// The fields a memref<?xT> flattens into, in the packed ABI's order.
struct MemRef1D {
  void *allocated;
  void *aligned;
  std::int64_t offset;
  std::int64_t size;
  std::int64_t stride;
};

/// The argument storage of one call: the packed ABI passes pointers to the
/// values, so the values must outlive the call and, since chunks run at the
/// same time, belong to one chunk.
class PackedArguments {
public:
  PackedArguments(std::int64_t begin, std::int64_t end,
                  const std::vector<KernelBuffer> &buffers)
      : begin_(begin), end_(end) {
    memrefs_.reserve(buffers.size());
    for (const KernelBuffer &buffer : buffers)
      memrefs_.push_back({buffer.data, buffer.data, 0, buffer.size, 1});
    // Filled after memrefs_ stops growing, so the pointers stay valid.
    pointers_.reserve(2 + 5 * memrefs_.size());
    pointers_.push_back(&begin_);
    pointers_.push_back(&end_);
    for (MemRef1D &memref : memrefs_) {
      pointers_.push_back(&memref.allocated);
      pointers_.push_back(&memref.aligned);
      pointers_.push_back(&memref.offset);
      pointers_.push_back(&memref.size);
      pointers_.push_back(&memref.stride);
    }
  }

  PackedArguments(const PackedArguments &) = delete;
  PackedArguments &operator=(const PackedArguments &) = delete;

  void **data() { return pointers_.data(); }

private:
  std::int64_t begin_;
  std::int64_t end_;
  std::vector<MemRef1D> memrefs_;
  std::vector<void *> pointers_;
};
} // namespace

static void checkBuffers(const std::vector<KernelBuffer> &buffers) {
  for (std::size_t i = 0; i < buffers.size(); ++i) {
    if (buffers[i].size < 0)
      throw std::invalid_argument("kernel buffer " + std::to_string(i) +
                                  " has a negative size (" +
                                  std::to_string(buffers[i].size) + ")");
    if (!buffers[i].data && buffers[i].size > 0)
      throw std::invalid_argument(
          "kernel buffer " + std::to_string(i) + " has null data but " +
          std::to_string(buffers[i].size) + " elements");
  }
}

void yasps::runtime::launchCpuKernel(PackedKernelFn fn,
                                     const std::vector<KernelBuffer> &buffers,
                                     std::int64_t numInstances,
                                     ThreadPool &pool, std::int64_t minChunk) {
  if (!fn)
    throw std::invalid_argument("launchCpuKernel needs a kernel, got null");
  if (numInstances < 0)
    throw std::invalid_argument("launchCpuKernel got a negative instance "
                                "count (" +
                                std::to_string(numInstances) + ")");
  checkBuffers(buffers);
  // parallelFor checks minChunk and calls nothing for an empty range.
  pool.parallelFor(0, numInstances, minChunk,
                   [&](std::int64_t begin, std::int64_t end) {
                     PackedArguments args(begin, end, buffers);
                     fn(args.data());
                   });
}
