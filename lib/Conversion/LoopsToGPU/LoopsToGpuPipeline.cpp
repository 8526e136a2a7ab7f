//===- LoopsToGpuPipeline.cpp - loop kernels to GPU binaries --------------===//

#include "yasps/Conversion/LoopsToGPU/LoopsToGpuPipeline.h"
#include "yasps/Conversion/Passes.h"

#include "mlir/Conversion/AffineToStandard/AffineToStandard.h"
#include "mlir/Conversion/GPUToNVVM/GPUToNVVMPass.h"
#include "mlir/Conversion/ReconcileUnrealizedCasts/ReconcileUnrealizedCasts.h"
#include "mlir/Conversion/SCFToControlFlow/SCFToControlFlow.h"
#include "mlir/Conversion/SCFToGPU/SCFToGPUPass.h"
#include "mlir/Dialect/GPU/IR/GPUDialect.h"
#include "mlir/Dialect/GPU/Transforms/Passes.h"
#include "mlir/Dialect/LLVMIR/Transforms/Passes.h"
#include "mlir/Dialect/SCF/Transforms/Passes.h"
#include "mlir/Pass/PassRegistry.h"
#include "mlir/Transforms/Passes.h"

using namespace mlir;

void mlir::yasps::buildLoopsToGpuKernelsPipeline(OpPassManager &pm,
                                                 int64_t threadsPerBlock) {
  OpPassManager &funcs = pm.nest<func::FuncOp>();
  // Inner tiles of `threadsPerBlock` instances become the threads of a
  // block; the guard for the last, partial tile is an scf.if.
  funcs.addPass(createParallelLoopTilingPass({threadsPerBlock},
                                             /*noMinMaxBounds=*/true));
  funcs.addPass(createGpuMapParallelLoopsPass());
  funcs.addPass(createConvertParallelLoopToGpuPass());
  pm.addPass(createYaspsSinkScratchIntoLaunch());
  pm.addPass(createGpuLaunchSinkIndexComputationsPass());
  pm.addPass(createGpuKernelOutliningPass());
  pm.addPass(createLowerAffinePass());
  pm.addPass(createCanonicalizerPass());
  pm.addPass(createCSEPass());
}

/// The NVVM lowering of a gpu.module that cubins and host images share.
static void addGpuToNVVMPasses(OpPassManager &modules) {
  modules.addPass(createSCFToControlFlowPass());
  modules.addPass(mlir::yasps::createYaspsPreciseGpuSqrt());
  modules.addPass(createConvertGpuOpsToNVVMOps());
  modules.addPass(createCanonicalizerPass());
  modules.addPass(createCSEPass());
  modules.addPass(createReconcileUnrealizedCastsPass());
}

void mlir::yasps::buildGpuSerializationPipeline(
    OpPassManager &pm, const std::vector<std::string> &chips,
    const std::string &format) {
  for (const std::string &chip : chips) {
    GpuNVVMAttachTargetOptions target;
    target.chip = chip;
    target.optLevel = 3;
    // A chip without PTX features: the default PTX ISA does not suit every
    // chip CUDA 13 supports (see TOOLCHAIN.md).
    pm.addPass(createGpuNVVMAttachTarget(target));
  }
  addGpuToNVVMPasses(pm.nest<gpu::GPUModuleOp>());
  GpuModuleToBinaryPassOptions binary;
  binary.compilationTarget = format;
  pm.addPass(createGpuModuleToBinaryPass(binary));
}

void mlir::yasps::buildGpuHostImagePipeline(OpPassManager &pm) {
  OpPassManager &modules = pm.nest<gpu::GPUModuleOp>();
  addGpuToNVVMPasses(modules);
  modules.addPass(mlir::yasps::createYaspsNVVMToHost());
}

namespace {
struct LoopsToGpuPipelineOptions
    : public PassPipelineOptions<LoopsToGpuPipelineOptions> {
  Option<int64_t> threadsPerBlock{
      *this, "threads-per-block",
      llvm::cl::desc("Instances (threads) per block"),
      llvm::cl::init(mlir::yasps::kDefaultThreadsPerBlock)};
  ListOption<std::string> chips{
      *this, "chips",
      llvm::cl::desc("Compute capabilities to compile for (e.g. sm_90); "
                     "none: stop at outlined gpu.func kernels")};
  Option<std::string> format{
      *this, "format",
      llvm::cl::desc("Serialisation format: bin (cubin), isa (PTX) or host "
                     "(the LLVM IR of a host image; no chips needed)"),
      llvm::cl::init("bin")};
};
} // namespace

void mlir::yasps::registerLoopsToGpuPipeline() {
  PassPipelineRegistration<LoopsToGpuPipelineOptions>(
      "yasps-loops-to-gpu",
      "Turn yasps loop kernels into GPU kernels and, given chips, binaries",
      [](OpPassManager &pm, const LoopsToGpuPipelineOptions &options) {
        buildLoopsToGpuKernelsPipeline(pm, options.threadsPerBlock);
        if (options.format == "host")
          buildGpuHostImagePipeline(pm);
        else if (!options.chips.empty())
          buildGpuSerializationPipeline(
              pm,
              std::vector<std::string>(options.chips.begin(),
                                       options.chips.end()),
              options.format);
      });
}
