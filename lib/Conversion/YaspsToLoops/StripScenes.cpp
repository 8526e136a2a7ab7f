//===- StripScenes.cpp - erase scenes after kernel generation -------------===//

#include "yasps/Conversion/Passes.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSSTRIPSCENES
#include "yasps/Conversion/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;
using namespace mlir::yasps;

namespace {
struct StripScenesPass
    : public mlir::yasps::impl::YaspsStripScenesBase<StripScenesPass> {
  void runOnOperation() override {
    for (auto scene :
         llvm::make_early_inc_range(getOperation().getOps<SceneOp>()))
      scene.erase();
  }
};
} // namespace
