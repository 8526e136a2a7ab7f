//===- Differentiate.cpp - Jacobians of attributes, energy derivatives ----===//
//
// The pass: for every scene with minimisation targets, the derivatives of
// each energy (EnergyDerivatives.cpp), built by the forward-mode engine
// (Differentiator.cpp) and projected by the projection strategy
// (Projection.cpp).
//
//===----------------------------------------------------------------------===//

#include "Differentiator.h"

#include "yasps/Dialect/Yasps/Transforms/Passes.h"

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSDIFFERENTIATE
#include "yasps/Dialect/Yasps/Transforms/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;
using namespace mlir::yasps;
using namespace mlir::yasps::differentiation;

namespace {
struct DifferentiatePass
    : public mlir::yasps::impl::YaspsDifferentiateBase<DifferentiatePass> {
  using YaspsDifferentiateBase::YaspsDifferentiateBase;
  void runOnOperation() override;
};
} // namespace

void DifferentiatePass::runOnOperation() {
  ProjectionOptions options{hessianFactors, linearMaps};
  SymbolTableCollection tables;
  for (auto scene : getOperation().getOps<SceneOp>()) {
    auto minimize = scene.getBodyBlock().getOps<MinimizeOp>();
    if (minimize.empty())
      continue;
    DenseSet<Operation *> targets;
    for (auto ref :
         (*minimize.begin()).getTargets().getAsRange<SymbolRefAttr>())
      targets.insert(lookupInScene(scene, ref, &tables));
    Differentiator diff(scene, targets, tables);
    for (auto energy : scene.getBodyBlock().getOps<EnergyOp>()) {
      auto attr = dyn_cast_or_null<AttrOp>(
          lookupInScene(scene, energy.getAttribute(), &tables));
      if (!attr) {
        energy.emitOpError() << "energy " << energy.getAttribute()
                             << " is not a computed attribute; nothing to "
                                "differentiate";
        return signalPassFailure();
      }
      if (failed(differentiateEnergy(diff, energy, attr, options)))
        return signalPassFailure();
    }
  }
}
