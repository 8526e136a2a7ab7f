//===- Pipelines.h - named yasps pass pipelines -----------------*- C++ -*-===//
//
// Pipelines that the compiler's clients (yasps-opt, the CPU and GPU
// compilers, the Python package) name instead of spelling their passes.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_DIALECT_YASPS_TRANSFORMS_PIPELINES_H
#define YASPS_DIALECT_YASPS_TRANSFORMS_PIPELINES_H

#include "mlir/Pass/PassManager.h"
#include "yasps/Dialect/Yasps/Transforms/HessianFactors.h"

namespace mlir::yasps {

/// Adds the passes that give every energy its local derivatives and their
/// placement indices: yasps-inline-reads, canonicalize, cse,
/// yasps-differentiate (with its `hessian-factors` option: never, always
/// or auto, and `linear-maps`) and yasps-generate-indices.
void buildDifferentiatePipeline(
    OpPassManager &pm, HessianFactors hessianFactors = HessianFactors::never,
    bool linearMaps = true);

/// Registers the `yasps-differentiate-pipeline` pass pipeline, so that it
/// can be named in textual pipelines.
void registerDifferentiatePipeline();

} // namespace mlir::yasps

#endif // YASPS_DIALECT_YASPS_TRANSFORMS_PIPELINES_H
