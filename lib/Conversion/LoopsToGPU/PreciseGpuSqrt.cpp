//===- PreciseGpuSqrt.cpp - correctly rounded f32 square roots on GPUs ----===//
//
// convert-gpu-to-nvvm lowers math.sqrt (and llvm.intr.sqrt) to libdevice's
// __nv_sqrtf, which selects sqrt.approx.f32 unless __CUDA_PREC_SQRT is
// reflected (nvcc sets it; this pipeline has no way to). Here each f32
// square root becomes the correctly rounded PTX instruction, sqrt.rn.f32,
// as inline assembly (which the conversion keeps), so f32 kernels match
// the CPU's IEEE square roots. f64 keeps libdevice: __nv_sqrt is
// sqrt.rn.f64.
//
//===----------------------------------------------------------------------===//

#include "yasps/Conversion/Passes.h"

#include "mlir/Dialect/GPU/IR/GPUDialect.h"
#include "mlir/Dialect/LLVMIR/LLVMDialect.h"
#include "mlir/Dialect/Math/IR/Math.h"

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSPRECISEGPUSQRT
#include "yasps/Conversion/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;

namespace {
struct PreciseGpuSqrtPass
    : public mlir::yasps::impl::YaspsPreciseGpuSqrtBase<PreciseGpuSqrtPass> {
  void runOnOperation() override {
    // GPU kernels are scalar (one instance per thread): vector square
    // roots, which no kernel has, are left as they are.
    getOperation().walk([](math::SqrtOp sqrt) {
      if (!sqrt.getType().isF32())
        return;
      OpBuilder b(sqrt);
      MLIRContext *ctx = b.getContext();
      auto precise = LLVM::InlineAsmOp::create(
          b, sqrt.getLoc(), b.getF32Type(), ValueRange{sqrt.getOperand()},
          StringAttr::get(ctx, "sqrt.rn.f32 $0, $1;"),
          StringAttr::get(ctx, "=f,f"), /*has_side_effects=*/UnitAttr(),
          /*is_align_stack=*/UnitAttr(), LLVM::TailCallKindAttr(),
          LLVM::AsmDialectAttr(), ArrayAttr());
      sqrt.replaceAllUsesWith(precise.getResult(0));
      sqrt.erase();
    });
  }
};
} // namespace
