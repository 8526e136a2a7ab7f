//===- yasps-opt.cpp - mlir-opt with the yasps dialect --------------------===//
//
// The driver for debugging every stage of the yasps compiler: it knows the
// yasps dialect and passes and all upstream dialects, passes and interface
// extensions the lowering pipelines use, and the translations of GPU
// modules to LLVM IR for gpu-module-to-binary.
//
//===----------------------------------------------------------------------===//

#include "mlir/IR/DialectRegistry.h"
#include "mlir/InitAllDialects.h"
#include "mlir/InitAllExtensions.h"
#include "mlir/InitAllPasses.h"
#include "mlir/Target/LLVMIR/Dialect/All.h"
#include "mlir/Tools/mlir-opt/MlirOptMain.h"

#include "yasps/Conversion/LoopsToGPU/LoopsToGpuPipeline.h"
#include "yasps/Conversion/Passes.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"
#include "yasps/Dialect/Yasps/Transforms/Passes.h"
#include "yasps/Dialect/Yasps/Transforms/Pipelines.h"

int main(int argc, char **argv) {
  mlir::registerAllPasses();
  mlir::yasps::registerYaspsPasses();
  mlir::yasps::registerYaspsConversionPasses();
  mlir::yasps::registerLoopsToGpuPipeline();
  mlir::yasps::registerDifferentiatePipeline();

  mlir::DialectRegistry registry;
  mlir::registerAllDialects(registry);
  mlir::registerAllExtensions(registry);
  // gpu-module-to-binary translates GPU modules to LLVM IR (NVVM, ROCDL).
  mlir::registerAllGPUToLLVMIRTranslations(registry);
  registry.insert<mlir::yasps::YaspsDialect>();

  return mlir::asMainReturnCode(
      mlir::MlirOptMain(argc, argv, "yasps optimizer driver\n", registry));
}
