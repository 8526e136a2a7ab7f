//===- CpuKernel.h - launching compiled CPU kernels -------------*- C++ -*-===//
//
// A CPU kernel is an MLIR function
//   (index begin, index end, memref<?xT0> arg0, memref<?xT1> arg1, ...)
// lowered to LLVM that computes instances [begin, end). It is called through
// the ExecutionEngine's packed ABI, `void fn(void **args)`, where args[i]
// points to the i-th flattened scalar argument: begin and end as int64_t,
// then per memref its allocated pointer, aligned pointer, offset, size and
// stride. Passing the range lets the launcher split instances across threads
// without the kernel knowing about threads.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SUPPORT_CPUKERNEL_H
#define YASPS_RUNTIME_SUPPORT_CPUKERNEL_H

#include <cstdint>
#include <vector>

namespace yasps::runtime {

class ThreadPool;

/// A kernel's packed-ABI entry point.
using PackedKernelFn = void (*)(void **);

/// A contiguous buffer passed to a kernel as a memref<?xT>.
struct KernelBuffer {
  void *data;
  std::int64_t size; // in elements
};

/// Calls `fn` on [0, numInstances) split across `pool` in chunks of at least
/// `minChunk` instances, each buffer passed as a memref with offset 0 and
/// stride 1. Returns when all chunks have finished. Throws
/// std::invalid_argument for a null `fn`, a negative `numInstances`, a buffer
/// with a negative size or with null data and a positive size, or
/// `minChunk < 1`; does nothing else for `numInstances == 0`.
void launchCpuKernel(PackedKernelFn fn,
                     const std::vector<KernelBuffer> &buffers,
                     std::int64_t numInstances, ThreadPool &pool,
                     std::int64_t minChunk = 1024);

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SUPPORT_CPUKERNEL_H
