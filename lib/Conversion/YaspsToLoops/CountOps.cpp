//===- CountOps.cpp - arithmetic op counts of generated kernels -----------===//

#include "yasps/Conversion/Passes.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "mlir/Dialect/Arith/IR/Arith.h"
#include "mlir/Dialect/Func/IR/FuncOps.h"
#include "mlir/Dialect/Math/IR/Math.h"

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSCOUNTOPS
#include "yasps/Conversion/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;

namespace {
struct CountOpsPass
    : public mlir::yasps::impl::YaspsCountOpsBase<CountOpsPass> {
  void runOnOperation() override {
    for (auto func : getOperation().getOps<func::FuncOp>()) {
      if (!func->hasAttr(yasps::kKernelOfAttr))
        continue;
      int64_t mul = 0, add = 0, div = 0, math = 0;
      func.walk([&](Operation *op) {
        if (isa<arith::MulFOp>(op))
          ++mul;
        else if (isa<arith::AddFOp, arith::SubFOp>(op))
          ++add;
        else if (isa<arith::DivFOp>(op))
          ++div;
        else if (isa_and_nonnull<math::MathDialect>(op->getDialect()))
          ++math;
      });
      Builder b(func.getContext());
      func->setAttr(yasps::kOpCountsAttr,
                    b.getDictionaryAttr({
                        b.getNamedAttr("add", b.getI64IntegerAttr(add)),
                        b.getNamedAttr("div", b.getI64IntegerAttr(div)),
                        b.getNamedAttr("math", b.getI64IntegerAttr(math)),
                        b.getNamedAttr("mul", b.getI64IntegerAttr(mul)),
                    }));
    }
  }
};
} // namespace
