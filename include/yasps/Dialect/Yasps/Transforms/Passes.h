//===- Passes.h - yasps transformation passes -------------------*- C++ -*-===//

#ifndef YASPS_DIALECT_YASPS_TRANSFORMS_PASSES_H
#define YASPS_DIALECT_YASPS_TRANSFORMS_PASSES_H

#include "mlir/Pass/Pass.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"
#include "yasps/Dialect/Yasps/Transforms/HessianFactors.h"

namespace mlir::yasps {

#define GEN_PASS_DECL
#include "yasps/Dialect/Yasps/Transforms/Passes.h.inc"

#define GEN_PASS_REGISTRATION
#include "yasps/Dialect/Yasps/Transforms/Passes.h.inc"

} // namespace mlir::yasps

#endif // YASPS_DIALECT_YASPS_TRANSFORMS_PASSES_H
