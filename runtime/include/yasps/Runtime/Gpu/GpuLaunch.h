//===- GpuLaunch.h - loading and launching yasps GPU kernels ----*- C++ -*-===//
//
// The GPU compiler (lib/Target/GPU) turns each loop kernel
//   (index begin, index end, memref<?xT> buffer2, memref<?xT> buffer3, ...)
// into a CUDA kernel with one thread per instance and records how its
// parameters come from the loop kernel's arguments: an index (begin or end),
// a buffer (MLIR's memref descriptor: allocated and aligned pointer, offset
// 0, size, stride 1; five parameters) or a constant. This file loads the
// binaries into a context and launches the kernels by that record.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_GPU_GPULAUNCH_H
#define YASPS_RUNTIME_GPU_GPULAUNCH_H

#include "yasps/Runtime/Gpu/GpuParam.h"
#include "yasps/Runtime/Support/CudaMemory.h"

#include <cstdint>
#include <string>
#include <vector>

namespace yasps::runtime {

/// A device buffer as a loop-kernel argument.
struct GpuBufferArg {
  cu::DevicePtr pointer = 0;
  std::int64_t size = 0; ///< in elements
};

/// A compiled binary of a library: a cubin for `chip` or PTX for it.
struct GpuImage {
  std::string chip;   ///< "sm_90"
  std::string format; ///< "cubin" or "ptx"
  const std::string *bytes = nullptr;
};

/// The image a device of compute capability `chip` runs: its own cubin, else
/// a cubin of an older chip of the same major version (binary compatible),
/// else PTX for an older or equal chip (which the driver compiles); for the
/// stand-in driver's chip "host", the host image (HostImage.h). Throws
/// CudaError naming what there is when nothing fits.
const GpuImage &selectGpuImage(const std::vector<GpuImage> &images,
                               const std::string &chip);

/// A module loaded into a context.
class CudaModule {
public:
  CudaModule(const CudaContext &context, const std::string &image);
  ~CudaModule();
  CudaModule(const CudaModule &) = delete;
  CudaModule &operator=(const CudaModule &) = delete;

  /// The kernel named `name` (throws CudaError naming it if absent).
  cu::Function function(const std::string &name) const;

private:
  const CudaContext &ctx;
  cu::Module module = nullptr;
};

/// The kernel parameters of one launch, as cuLaunchKernel takes them: every
/// value is 8 bytes; `pointers()` points at each.
class GpuLaunchParams {
public:
  GpuLaunchParams(const std::vector<GpuParam> &params,
                  const std::vector<GpuBufferArg> &buffers, std::int64_t begin,
                  std::int64_t end);
  void **pointers() { return addresses.data(); }
  const std::vector<std::uint64_t> &values() const { return storage; }

private:
  std::vector<std::uint64_t> storage;
  std::vector<void *> addresses;
};

/// Launches `kernel` on instances [begin, end) with `threadsPerBlock`
/// threads per block (asynchronously, on the default stream). Buffer
/// argument i of the loop kernel is `buffers[i - 2]`.
void launchGpuKernel(const CudaContext &context, cu::Function kernel,
                     const std::vector<GpuParam> &params,
                     const std::vector<GpuBufferArg> &buffers,
                     std::int64_t begin, std::int64_t end,
                     std::int64_t threadsPerBlock);

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_GPU_GPULAUNCH_H
