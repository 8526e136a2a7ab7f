//===- EnergyDerivatives.cpp - the derivative attributes of an energy -----===//
//
// What yasps-differentiate adds for one energy E: its gradient (the
// transposed Jacobian of E), its Hessian (the Jacobian of the gradient's
// row) and the Hessian's projection (Projection.cpp), all with E's local
// parameters.
//
//===----------------------------------------------------------------------===//

#include "Differentiator.h"

using namespace mlir;
using namespace mlir::yasps;
using namespace mlir::yasps::differentiation;

FailureOr<bool>
differentiation::differentiateEnergy(Differentiator &diff, EnergyOp energy,
                                     AttrOp attr,
                                     const ProjectionOptions &options) {
  // Gradient = Jacobian of E (1 x d), transposed; Hessian = Jacobian of
  // the gradient's row.
  FailureOr<AttrOp> jac = diff.jacobian(attr);
  if (failed(jac))
    return failure();
  if (!*jac)
    return false; // depends on no target
  FailureOr<AttrOp> hess =
      diff.jacobian(*jac, /*inner=*/false, /*symmetric=*/true);
  if (failed(hess))
    return failure();
  MatrixType row = (*jac).getMatrixType();
  int64_t d = row.getCols();
  auto params = (*jac)->getAttrOfType<ArrayAttr>(kParamsAttr);
  auto alias = [&](StringRef suffix, DerivativeRole role, AttrOp of,
                   MatrixType type, bool transpose) -> FailureOr<AttrOp> {
    FailureOr<AttrOp> a =
        diff.createAttr(*jac, (attr.getSymName() + suffix).str(), type, nullptr,
                        params, role, attr);
    if (failed(a))
      return failure();
    OpBuilder b = OpBuilder::atBlockEnd(&a->getBodyBlock());
    Value v =
        ReadOp::create(b, a->getLoc(), of.getMatrixType(), getScenePath(of));
    if (transpose)
      v = TransposeOp::create(b, a->getLoc(), type, v);
    else if (of.getMatrixType() != type)
      v = ResizeOp::create(b, a->getLoc(), type, v);
    YieldOp::create(b, a->getLoc(), v);
    return a;
  };
  MatrixType square = row.withShape(d, d);
  FailureOr<AttrOp> hessAttr;
  if (*hess) {
    hessAttr = alias("__hess", DerivativeRole::hess, *hess, square, false);
  } else {
    hessAttr =
        diff.createAttr(*jac, (attr.getSymName() + "__hess").str(), square,
                        nullptr, params, DerivativeRole::hess, attr);
    if (succeeded(hessAttr)) {
      OpBuilder b = OpBuilder::atBlockEnd(&hessAttr->getBodyBlock());
      YieldOp::create(b, hessAttr->getLoc(),
                      zeros(b, hessAttr->getLoc(), square));
    }
  }
  if (failed(hessAttr) ||
      failed(alias("__grad", DerivativeRole::grad, *jac, row.withShape(d, 1),
                   true)) ||
      failed(addProjectedHessian(diff, energy, attr, *jac, *hessAttr, options)))
    return failure();
  return true;
}
