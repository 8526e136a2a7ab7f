//===- GpuCompiler.h - attribute kernels for NVIDIA GPUs --------*- C++ -*-===//
//
// Compiles the attributes of a scene into CUDA kernels: the loop kernels
// every target shares become gpu.func kernels (one thread per instance,
// yasps-loops-to-gpu), all in one gpu.module, which is lowered to NVVM and
// serialised by gpu-module-to-binary into a cubin per compute capability
// (ptxas from the CUDA toolkit) plus PTX for newer devices. Binaries are
// cached on disk like CPU objects. Nothing here needs a GPU or a driver.
// Asked for the chip "host", it compiles the same NVVM-level IR for the host
// CPU instead (HostImage.h), for tests on machines without a GPU.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_TARGET_GPU_GPUCOMPILER_H
#define YASPS_TARGET_GPU_GPUCOMPILER_H

#include "yasps/Runtime/Gpu/GpuParam.h"
#include "yasps/Target/KernelGeneration.h"

#include "mlir/IR/DialectRegistry.h"

#include <memory>
#include <string>
#include <vector>

namespace mlir::yasps {

/// One GPU kernel: launch it with `threadsPerBlock` threads per block and
/// ceil((end - begin) / threadsPerBlock) blocks.
struct GpuKernel : KernelDescription {
  std::string kernelName; ///< the entry point in the binaries
  /// How to launch it, in the runtime's terms.
  std::vector<::yasps::runtime::GpuParam> launchParams;
  int64_t threadsPerBlock = 0;
};

/// A serialised gpu.module: a cubin for one chip, or PTX.
struct GpuBinary {
  std::string chip;   ///< e.g. "sm_90"
  std::string format; ///< "cubin", "ptx" or "host" (a host image)
  std::string bytes;
};

struct GpuKernelLibrary {
  std::vector<GpuKernel> kernels;
  std::vector<GpuBinary> binaries;
};

struct GpuCompileOptions {
  /// Compute capabilities to build cubins for; "host" asks for a host
  /// image instead (HostImage.h), which the stand-in driver runs.
  std::vector<std::string> chips = {"sm_80", "sm_90"};
  /// Also emit PTX for the newest chip, which the driver compiles for
  /// devices newer than every cubin.
  bool keepPtx = true;
  int64_t threadsPerBlock = 128;
  /// Directory of the on-disk binary cache; empty disables it.
  std::string cacheDir;
};

struct GpuCompileStats {
  bool fromDisk = false;
  double lowerSeconds = 0;     ///< yasps IR to gpu.func kernels
  double serializeSeconds = 0; ///< NVVM, LLVM's NVPTX back end and ptxas
  std::string key;
};

/// Registers the dialects, interfaces and translations the GPU pipeline
/// uses.
void registerGpuCompilerDialects(DialectRegistry &registry);

/// Compiles GPU kernels for `attributes` of the module's scene (see
/// generateLoopKernels for `attributes` and `prePipeline`). The module is
/// left unchanged.
llvm::Expected<std::shared_ptr<GpuKernelLibrary>>
compileGpuKernels(ModuleOp module, const std::vector<std::string> &attributes,
                  const GpuCompileOptions &options,
                  GpuCompileStats *stats = nullptr,
                  llvm::StringRef prePipeline = "");

} // namespace mlir::yasps

#endif // YASPS_TARGET_GPU_GPUCOMPILER_H
