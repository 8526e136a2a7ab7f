//===- Passes.h - yasps conversion passes -----------------------*- C++ -*-===//

#ifndef YASPS_CONVERSION_PASSES_H
#define YASPS_CONVERSION_PASSES_H

#include "mlir/Dialect/Arith/IR/Arith.h"
#include "mlir/Dialect/Func/IR/FuncOps.h"
#include "mlir/Dialect/GPU/IR/GPUDialect.h"
#include "mlir/Dialect/LLVMIR/LLVMDialect.h"
#include "mlir/Dialect/Math/IR/Math.h"
#include "mlir/Dialect/MemRef/IR/MemRef.h"
#include "mlir/Dialect/SCF/IR/SCF.h"
#include "mlir/Dialect/Vector/IR/VectorOps.h"
#include "mlir/Pass/Pass.h"

namespace mlir::yasps {

#define GEN_PASS_DECL
#include "yasps/Conversion/Passes.h.inc"

#define GEN_PASS_REGISTRATION
#include "yasps/Conversion/Passes.h.inc"

} // namespace mlir::yasps

#endif // YASPS_CONVERSION_PASSES_H
