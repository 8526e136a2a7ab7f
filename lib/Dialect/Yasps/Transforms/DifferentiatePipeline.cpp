//===- DifferentiatePipeline.cpp - energies to local derivatives ----------===//

#include "yasps/Dialect/Yasps/Transforms/Passes.h"
#include "yasps/Dialect/Yasps/Transforms/Pipelines.h"

#include "mlir/Pass/PassRegistry.h"
#include "mlir/Transforms/Passes.h"

using namespace mlir;
using namespace mlir::yasps;

void mlir::yasps::buildDifferentiatePipeline(OpPassManager &pm,
                                             HessianFactors hessianFactors,
                                             bool linearMaps) {
  // yasps-differentiate needs one expression per energy; canonicalize and
  // cse shrink it (and merge the inlined copies) before it is
  // differentiated once per parameter.
  pm.addPass(createYaspsInlineReads());
  pm.addPass(createCanonicalizerPass());
  pm.addPass(createCSEPass());
  YaspsDifferentiateOptions differentiate;
  differentiate.hessianFactors = hessianFactors;
  differentiate.linearMaps = linearMaps;
  pm.addPass(createYaspsDifferentiate(differentiate));
  pm.addPass(createYaspsGenerateIndices());
}

namespace {
struct DifferentiatePipelineOptions
    : public PassPipelineOptions<DifferentiatePipelineOptions> {
  Option<HessianFactors> hessianFactors{
      *this, "hessian-factors",
      llvm::cl::desc("Keep the reduced-space factors @E__ij, "
                     "@E__hess_inner_proj and @E__hess_inner apart: never, "
                     "always or auto (see yasps-differentiate)"),
      llvm::cl::init(HessianFactors::never), hessianFactorsValues()};
  Option<bool> linearMaps{
      *this, "linear-maps",
      llvm::cl::desc("Project Hessians in the entries of a smaller linear "
                     "cut of the energy (see yasps-differentiate)"),
      llvm::cl::init(true)};
};
} // namespace

void mlir::yasps::registerDifferentiatePipeline() {
  PassPipelineRegistration<DifferentiatePipelineOptions>(
      "yasps-differentiate-pipeline",
      "Local gradients, Hessians and placement indices of every energy",
      [](OpPassManager &pm, const DifferentiatePipelineOptions &options) {
        buildDifferentiatePipeline(pm, options.hessianFactors,
                                   options.linearMaps);
      });
}
