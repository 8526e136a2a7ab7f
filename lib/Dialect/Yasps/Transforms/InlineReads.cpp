//===- InlineReads.cpp - inline reads of computed attributes --------------===//

#include "yasps/Dialect/Yasps/Transforms/Passes.h"

#include "mlir/IR/IRMapping.h"

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSINLINEREADS
#include "yasps/Dialect/Yasps/Transforms/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;
using namespace mlir::yasps;

namespace {
struct InlineReadsPass
    : public mlir::yasps::impl::YaspsInlineReadsBase<InlineReadsPass> {
  void runOnOperation() override;
};
} // namespace

/// Replaces `read` by a copy of `source`'s region placed right before it.
static void inlineRead(ReadOp read, AttrOp source) {
  OpBuilder builder(read);
  IRMapping mapping;
  Value yielded;
  for (Operation &op : source.getBodyBlock()) {
    if (auto yield = dyn_cast<YieldOp>(op)) {
      yielded = mapping.lookup(yield.getValue());
      break;
    }
    builder.clone(op, mapping);
  }
  read.replaceAllUsesWith(yielded);
  read.erase();
}

void InlineReadsPass::runOnOperation() {
  SymbolTableCollection tables;
  // The verifier rejects cyclic attribute definitions, so repeatedly inlining
  // the first read of a computed attribute terminates.
  WalkResult result = getOperation().walk([&](AttrOp attr) {
    SceneOp scene = getEnclosingScene(attr);
    bool changed = true;
    while (changed) {
      changed = false;
      for (auto read : attr.getBodyBlock().getOps<ReadOp>()) {
        auto source = dyn_cast_or_null<AttrOp>(
            lookupInScene(scene, read.getAttribute(), &tables));
        if (!source)
          continue;
        if (source == attr) {
          read.emitOpError() << describe(attr) << " reads itself";
          return WalkResult::interrupt();
        }
        inlineRead(read, source);
        ++numInlined;
        changed = true;
        break;
      }
    }
    return WalkResult::advance();
  });
  if (result.wasInterrupted())
    signalPassFailure();
}
