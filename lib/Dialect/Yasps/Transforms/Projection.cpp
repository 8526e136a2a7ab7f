//===- Projection.cpp - how an energy's local Hessian is projected --------===//
//
// The projection strategy of yasps-differentiate: the PSD projection of the
// local Hessian in reduced space (paper 5.4: J^T P(H_inner) J, with H_inner
// the Hessian in the entries of E's leaves and J their Jacobian) where that
// is exact and smaller, else of the full local Hessian.
//
//===----------------------------------------------------------------------===//

#include "Differentiator.h"

#include "mlir/IR/IRMapping.h"
#include "llvm/ADT/StringSwitch.h"

using namespace mlir;
using namespace mlir::yasps;
using namespace mlir::yasps::differentiation;

FailureOr<bool> Differentiator::curvatureFree(AttrOp energy) {
  FailureOr<SmallVector<ParamGroup>> groups = groupsOf(energy);
  if (failed(groups))
    return failure();
  // Linear in its parameters: the Jacobian's own Jacobian is zero.
  auto linear = [&](Operation *decl) -> FailureOr<bool> {
    auto computed = dyn_cast<AttrOp>(decl);
    if (!computed)
      return true;
    FailureOr<AttrOp> jac = jacobian(computed);
    if (failed(jac))
      return failure();
    if (!*jac)
      return true;
    FailureOr<AttrOp> second = jacobian(*jac);
    if (failed(second))
      return failure();
    return !*second;
  };
  for (const ParamGroup &g : *groups) {
    SmallVector<Operation *> sources;
    if (g.kind == GroupKind::Join)
      sources.push_back(g.base);
    if (g.kind == GroupKind::Union)
      for (Operation *member : cast<PrimitiveUnionOp>(g.key).getMemberOps())
        sources.push_back(tables.lookupSymbolIn(
            member, g.base->getAttrOfType<StringAttr>(
                        SymbolTable::getSymbolAttrName())));
    for (Operation *source : sources) {
      FailureOr<bool> isLinear = linear(source);
      if (failed(isLinear))
        return failure();
      if (!*isLinear)
        return false;
    }
  }
  return true;
}

FailureOr<AttrOp> Differentiator::innerMap(AttrOp energy) {
  FailureOr<SmallVector<ParamGroup>> groups = groupsOf(energy);
  if (failed(groups))
    return failure();
  int64_t n = 0, m = 0;
  for (const ParamGroup &g : *groups) {
    n += g.size();
    m += g.leafEntries;
  }
  MatrixType scalar = energy.getMatrixType();
  FailureOr<AttrOp> created = createAttr(
      energy, (energy.getSymName() + "__ij").str(), scalar.withShape(m, n),
      nullptr, ArrayAttr(), DerivativeRole::ij);
  if (failed(created))
    return failure();
  AttrOp map = *created;
  IRMapping mapping;
  OpBuilder b = OpBuilder::atBlockEnd(&map.getBodyBlock());
  Location loc = energy.getLoc();
  for (Operation &op : energy.getBodyBlock().without_terminator())
    b.clone(op, mapping);
  SmallVector<std::pair<Operation *, const ParamGroup *>> leaves =
      leavesOf(map, *groups);
  // Column p: the seeds of parameter p at every leaf, flattened and stacked
  // in the order of the groups (the inner variables' order).
  SmallVector<Value> columns;
  for (const ParamGroup &g : *groups) {
    for (int64_t p = 0; p < g.size(); ++p) {
      SmallVector<Value> blocks;
      for (const ParamGroup &h : *groups) {
        MatrixType block = scalar.withShape(h.leafEntries, 1);
        Value value;
        if (&h == &g) {
          Operation *leaf = nullptr;
          for (auto [op, group] : leaves)
            if (group == &h && !leaf)
              leaf = op;
          FailureOr<Value> seeded = seed(b, leaf, g, p / g.width, p % g.width);
          if (failed(seeded))
            return failure();
          if (*seeded)
            value = ResizeOp::create(b, loc, block, *seeded);
        }
        blocks.push_back(value ? value : zeros(b, loc, block));
      }
      columns.push_back(blocks.size() == 1
                            ? blocks[0]
                            : ConcatOp::create(b, loc, scalar.withShape(m, 1),
                                               ConcatAxis::vertical, blocks)
                                  .getResult());
    }
  }
  Value result = columns.size() == 1
                     ? columns[0]
                     : ConcatOp::create(b, loc, scalar.withShape(m, n),
                                        ConcatAxis::horizontal, columns)
                           .getResult();
  YieldOp::create(b, loc, result);
  return map;
}

/// Whether reduced factors of m inner variables and d parameters stay
/// apart: the factors J (m x d) and P (m x m) are cheaper to compute, store
/// and assemble than the d x d product when they hold at most half its
/// values (a 48 x 48 Hessian of point-triangle pairs on affine bodies
/// against its 12 x 48 and 12 x 12 factors).
static bool keepFactors(HessianFactors factors, int64_t m, int64_t d) {
  switch (factors) {
  case HessianFactors::never:
    return false;
  case HessianFactors::always:
    return true;
  case HessianFactors::automatic:
    return 2 * m * (d + m) <= d * d;
  }
  llvm_unreachable("unknown HessianFactors");
}

LogicalResult
differentiation::addProjectedHessian(Differentiator &diff, EnergyOp energy,
                                     AttrOp attr, AttrOp jac, AttrOp hessAttr,
                                     const ProjectionOptions &options) {
  MatrixType row = jac.getMatrixType();
  int64_t d = row.getCols();
  MatrixType square = row.withShape(d, d);
  auto params = jac->getAttrOfType<ArrayAttr>(kParamsAttr);
  // In reduced space (paper 5.4) when the parameterisations behind the
  // leaves are linear and the leaves have fewer entries than there are
  // parameters: J^T Project(H_inner) J, with H_inner the Hessian in the
  // leaf entries. Otherwise the full local Hessian is projected.
  FailureOr<bool> reducible = diff.curvatureFree(attr);
  FailureOr<SmallVector<ParamGroup>> groups = diff.groupsOf(attr);
  if (failed(reducible) || failed(groups))
    return failure();
  int64_t m = 0;
  for (const ParamGroup &g : *groups)
    m += g.leafEntries;
  bool reduced = *reducible && m < d;
  bool separate = reduced && keepFactors(options.factors, m, d);
  // Smaller still, a linear cut of the region (paper 10.4): J^T P(H_cut) J
  // with H_cut the Hessian in the cut's entries. Factors stay in the
  // leaves, whose Jacobians the runtime takes slot by slot.
  SmallVector<Value> cut;
  if (*reducible && !separate && options.linearMaps) {
    FailureOr<SmallVector<Value>> found = diff.innerCut(attr);
    if (failed(found))
      return failure();
    if (!found->empty() && cutEntries(*found) < (reduced ? m : d)) {
      cut = std::move(*found);
      m = cutEntries(cut);
      reduced = true;
    }
  }
  FailureOr<AttrOp> created = diff.createAttr(
      jac,
      (attr.getSymName() + (separate ? "__hess_inner_proj" : "__hess_proj"))
          .str(),
      separate ? row.withShape(m, m) : square, nullptr, params,
      separate ? DerivativeRole::hess_inner_proj : DerivativeRole::hess_proj,
      attr);
  if (failed(created))
    return failure();
  AttrOp projected = *created;
  projected->setAttr(kProjectionAttr,
                     ProjectionKindAttr::get(attr.getContext(),
                                             separate ? ProjectionKind::separate
                                             : reduced ? ProjectionKind::reduced
                                                       : ProjectionKind::full));
  Location loc = projected.getLoc();
  OpBuilder pb = OpBuilder::atBlockEnd(&projected.getBodyBlock());
  if (!reduced) {
    Value h = ReadOp::create(pb, loc, square, getScenePath(hessAttr));
    Value p = ProjectOp::create(pb, loc, energy.getProjection(), h);
    YieldOp::create(pb, loc, p);
    return success();
  }
  FailureOr<AttrOp> innerHess, map;
  if (!cut.empty()) {
    innerHess = diff.cutHessian(attr, cut);
    map = diff.cutMap(attr, cut);
  } else {
    FailureOr<AttrOp> innerGrad = diff.jacobian(attr, /*inner=*/true);
    innerHess =
        succeeded(innerGrad) && *innerGrad
            ? diff.jacobian(*innerGrad, /*inner=*/true, /*symmetric=*/true)
            : FailureOr<AttrOp>(AttrOp());
    map = diff.innerMap(attr);
  }
  if (failed(innerHess) || failed(map))
    return failure();
  MatrixType innerType = row.withShape(m, m);
  Value hi = *innerHess
                 ? ReadOp::create(pb, loc, innerType, getScenePath(*innerHess))
                       .getResult()
                 : zeros(pb, loc, innerType);
  Value pi = ProjectOp::create(pb, loc, energy.getProjection(), hi);
  if (separate) {
    // J (@E__ij) stays an attribute of its own; the runtime forms
    // J^T P J while it assembles. The unprojected H_inner is kept too:
    // with linear parameterisations J^T H_inner J is the local Hessian,
    // without a d x d forward-mode Jacobian.
    (*map)->setAttr(kParamsAttr, params);
    YieldOp::create(pb, loc, pi);
    FailureOr<AttrOp> inner = diff.createAttr(
        jac, (attr.getSymName() + "__hess_inner").str(), innerType, nullptr,
        params, DerivativeRole::hess_inner, attr);
    if (failed(inner))
      return failure();
    OpBuilder ib = OpBuilder::atBlockEnd(&inner->getBodyBlock());
    Value h = *innerHess
                  ? ReadOp::create(ib, loc, innerType, getScenePath(*innerHess))
                        .getResult()
                  : zeros(ib, loc, innerType);
    YieldOp::create(ib, loc, h);
    return success();
  }
  Value j = ReadOp::create(pb, loc, row.withShape(m, d), getScenePath(*map));
  Value jt = TransposeOp::create(pb, loc, row.withShape(d, m), j);
  Value pj = MatmulOp::create(pb, loc, row.withShape(m, d), pi, j);
  Value result = MatmulOp::create(pb, loc, square, jt, pj);
  YieldOp::create(pb, loc, result);
  return success();
}
