//===- LoopsToGpuPipeline.h - loop kernels to GPU binaries ------*- C++ -*-===//
//
// The GPU side of the compiler: the loop kernels of yasps-lower-to-loops
// (one scf.parallel over instances) become gpu.func kernels, one GPU thread
// per instance, then NVVM and a binary per requested compute capability,
// or a host image for the stand-in driver.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_CONVERSION_LOOPSTOGPU_LOOPSTOGPUPIPELINE_H
#define YASPS_CONVERSION_LOOPSTOGPU_LOOPSTOGPUPIPELINE_H

#include "mlir/Pass/PassManager.h"

#include <string>
#include <vector>

namespace mlir::yasps {

/// Threads per block of generated kernels. Kernels are heavy in registers
/// (a local Hessian per thread), so blocks are kept small.
inline constexpr int64_t kDefaultThreadsPerBlock = 128;

/// Adds the passes that turn loop kernels into outlined gpu.func kernels:
/// the instance loop is tiled by `threadsPerBlock`, mapped to blocks and
/// threads and converted to gpu.launch; scratch buffers move into the
/// launch; the launch is outlined into a gpu.module. Host functions keep a
/// gpu.launch_func whose operands are the kernel's arguments.
void buildLoopsToGpuKernelsPipeline(OpPassManager &pm, int64_t threadsPerBlock);

/// Adds the passes that compile every gpu.module to NVVM and serialise it
/// for each chip in `chips` (e.g. "sm_90") in `format` ("bin" for cubins,
/// "isa" for PTX; see gpu-module-to-binary).
void buildGpuSerializationPipeline(OpPassManager &pm,
                                   const std::vector<std::string> &chips,
                                   const std::string &format);

/// Adds the passes that lower every gpu.module to NVVM, as the
/// serialisation does, and then make its kernels callable on the host
/// (yasps-nvvm-to-host): the IR of a host image (HostImage.h), which
/// lib/Target/GPU/HostImage.cpp compiles for the host CPU.
void buildGpuHostImagePipeline(OpPassManager &pm);

/// Registers the `yasps-loops-to-gpu` pass pipeline (both of the above) for
/// yasps-opt.
void registerLoopsToGpuPipeline();

} // namespace mlir::yasps

#endif // YASPS_CONVERSION_LOOPSTOGPU_LOOPSTOGPUPIPELINE_H
