//===- GenerateIndices.cpp - placement indices as yasps attributes --------===//
//
// The Newton system needs, for every energy instance, the global DoF of each
// local parameter (paper appendix A.3). The parameters are described by the
// `yasps.params` of the derivatives: target reads, JOIN slots and UNION
// slots, recursively. This pass writes that description as yasps IR, an
// `@E__dofs` attribute per energy, so that the indices are computed by
// kernels from the same IR as the derivatives (on any back end) instead of
// being re-derived by the host.
//
//===----------------------------------------------------------------------===//

#include "yasps/Dialect/Yasps/IR/Yasps.h"
#include "yasps/Dialect/Yasps/Transforms/Passes.h"

#include <map>

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSGENERATEINDICES
#include "yasps/Dialect/Yasps/Transforms/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;
using namespace mlir::yasps;

namespace {

class IndexGenerator {
public:
  IndexGenerator(SceneOp scene, SymbolTableCollection &tables)
      : scene(scene), tables(tables) {}

  /// `@X__dofs` of attribute `decl` (a target or an attribute with
  /// parameters), created on first use on decl's entity.
  FailureOr<AttrOp> dofsOf(Operation *decl);

  /// `@E__dofs` of an energy from its gradient's parameters.
  FailureOr<AttrOp> energyDofs(AttrOp energy, AttrOp grad);

private:
  bool isTarget(Operation *decl);
  AttrOp newAttr(Operation *entity, StringRef name, MatrixType type);
  FailureOr<AttrOp> build(Operation *entity, StringRef name, MatrixType scalar,
                          ArrayAttr params);
  FailureOr<Value> slot(OpBuilder &b, Location loc, Operation *entity,
                        ParamAttr param, MatrixType scalar);
  FailureOr<AttrOp> paddedMemberDofs(Operation *member, StringAttr name,
                                     int64_t width, MatrixType scalar);
  Value zeros(OpBuilder &b, Location loc, MatrixType type) {
    SmallVector<double> values(type.getNumElements(), 0.0);
    return ConstantOp::create(
        b, loc, type,
        DenseElementsAttr::get(type.getTensorType(), ArrayRef(values)));
  }
  /// `column` (k x 1) followed by zeros down to width x 1.
  Value pad(OpBuilder &b, Location loc, Value column, int64_t width) {
    auto type = cast<MatrixType>(column.getType());
    int64_t k = type.getRows();
    if (k == width)
      return column;
    Value rest = zeros(b, loc, type.withShape(width - k, 1));
    if (k == 0)
      return rest;
    return ConcatOp::create(b, loc, type.withShape(width, 1),
                            ConcatAxis::vertical, ValueRange{column, rest});
  }

  SceneOp scene;
  SymbolTableCollection &tables;
  std::map<Operation *, AttrOp> made;
};

bool IndexGenerator::isTarget(Operation *decl) {
  for (auto minimize : scene.getBodyBlock().getOps<MinimizeOp>())
    for (auto target : minimize.getTargets().getAsRange<SymbolRefAttr>())
      if (lookupInScene(scene, target, &tables) == decl)
        return true;
  return false;
}

AttrOp IndexGenerator::newAttr(Operation *entity, StringRef name,
                               MatrixType type) {
  OpBuilder b = OpBuilder::atBlockEnd(&entity->getRegion(0).front());
  auto attr = AttrOp::create(b, entity->getLoc(), b.getStringAttr(name),
                             TypeAttr::get(type));
  attr.getBody().push_back(new Block());
  tables.invalidateSymbolTable(entity);
  return attr;
}

FailureOr<AttrOp> IndexGenerator::dofsOf(Operation *decl) {
  if (auto it = made.find(decl); it != made.end())
    return it->second;
  Operation *entity = getOwningEntity(decl);
  StringRef name =
      decl->getAttrOfType<StringAttr>(SymbolTable::getSymbolAttrName())
          .getValue();
  MatrixType type = getAttributeType(decl);
  AttrOp result;
  if (isTarget(decl)) {
    result = newAttr(entity, (name + "__dofs").str(),
                     type.withShape(type.getNumElements(), 1));
    OpBuilder b = OpBuilder::atBlockEnd(&result.getBodyBlock());
    Value v = DofIndexOp::create(b, decl->getLoc(), result.getMatrixType(),
                                 getScenePath(decl));
    YieldOp::create(b, decl->getLoc(), v);
  } else {
    // Its parameters are those of its Jacobian.
    AttrOp jac = lookupDerivative(entity, DerivativeRole::jac, decl);
    ArrayAttr params =
        jac ? jac->getAttrOfType<ArrayAttr>(kParamsAttr) : ArrayAttr();
    if (!params)
      return decl->emitError()
             << "yasps-generate-indices: " << getScenePath(decl)
             << " has no parameters (no Jacobian with yasps.params); run "
                "yasps-differentiate first";
    FailureOr<AttrOp> built =
        build(entity, (name + "__dofs").str(), type.getScalarType(), params);
    if (failed(built))
      return failure();
    result = *built;
  }
  result->setAttr(kDerivativeAttr,
                  DerivativeAttr::get(decl->getContext(), DerivativeRole::dofs,
                                      getScenePath(decl)));
  made[decl] = result;
  return result;
}

FailureOr<AttrOp> IndexGenerator::build(Operation *entity, StringRef name,
                                        MatrixType scalar, ArrayAttr params) {
  // Created before its body so that recursive sources see it exists.
  AttrOp attr = newAttr(entity, name, scalar);
  OpBuilder b = OpBuilder::atBlockEnd(&attr.getBodyBlock());
  Location loc = entity->getLoc();
  SmallVector<Value> parts;
  int64_t rows = 0;
  for (auto param : params.getAsRange<ParamAttr>()) {
    FailureOr<Value> part = slot(b, loc, entity, param, scalar);
    if (failed(part))
      return failure();
    rows += cast<MatrixType>(part->getType()).getRows();
    parts.push_back(*part);
  }
  MatrixType type = scalar.withShape(rows, 1);
  Value all = parts.size() == 1
                  ? parts.front()
                  : ConcatOp::create(b, loc, type, ConcatAxis::vertical, parts)
                        .getResult();
  YieldOp::create(b, loc, all);
  attr.setTypeAttr(TypeAttr::get(type));
  return attr;
}

FailureOr<Value> IndexGenerator::slot(OpBuilder &b, Location loc,
                                      Operation *entity, ParamAttr param,
                                      MatrixType scalar) {
  if (param.getKind() == ParamKind::read) {
    Operation *target = lookupInScene(scene, param.getPath(), &tables);
    MatrixType type = getAttributeType(target);
    return DofIndexOp::create(b, loc, type.withShape(type.getNumElements(), 1),
                              getScenePath(target))
        .getResult();
  }
  int64_t width = param.getWidth();
  if (param.getKind() == ParamKind::join) {
    auto connectivity =
        cast<ConnectivityOp>(tables.lookupSymbolIn(entity, param.getVia()));
    int64_t slotIndex = param.getSlot();
    Operation *source = lookupInScene(scene, param.getPath(), &tables);
    FailureOr<AttrOp> dofs = dofsOf(source);
    if (failed(dofs))
      return failure();
    int64_t k = dofs->getMatrixType().getRows();
    int64_t arity = connectivity.getArity();
    Value gathered =
        JoinOp::create(b, loc, scalar.withShape(arity, k),
                       connectivity.getSymNameAttr(), getScenePath(*dofs));
    Value row = RowOp::create(b, loc, scalar.withShape(1, k), gathered,
                              b.getI64IntegerAttr(slotIndex));
    Value column = ResizeOp::create(b, loc, scalar.withShape(k, 1), row);
    return pad(b, loc, column, width);
  }
  // A UNION slot: each member's indices, padded to the slot's width.
  auto unionOp =
      cast<PrimitiveUnionOp>(lookupInScene(scene, param.getPath(), &tables));
  StringAttr name = param.getVia().getAttr();
  std::string padded =
      (name.getValue() + "__udofs" + std::to_string(width)).str();
  for (Operation *member : unionOp.getMemberOps())
    if (failed(paddedMemberDofs(member, name, width, scalar)))
      return failure();
  return UnionOp::create(b, loc, scalar.withShape(width, 1),
                         FlatSymbolRefAttr::get(b.getStringAttr(padded)))
      .getResult();
}

FailureOr<AttrOp> IndexGenerator::paddedMemberDofs(Operation *member,
                                                   StringAttr name,
                                                   int64_t width,
                                                   MatrixType scalar) {
  std::string padded =
      (name.getValue() + "__udofs" + std::to_string(width)).str();
  if (auto existing = dyn_cast_or_null<AttrOp>(tables.lookupSymbolIn(
          member, StringAttr::get(member->getContext(), padded))))
    return existing;
  Operation *decl = tables.lookupSymbolIn(member, name);
  AttrOp attr = newAttr(member, padded, scalar.withShape(width, 1));
  OpBuilder b = OpBuilder::atBlockEnd(&attr.getBodyBlock());
  Location loc = member->getLoc();
  // A member whose attribute has no parameters (a constant, or computed
  // from no target) contributes only padding.
  bool hasParams = isTarget(decl);
  if (!hasParams) {
    AttrOp jac = lookupDerivative(member, DerivativeRole::jac, decl);
    hasParams = jac && jac->getAttrOfType<ArrayAttr>(kParamsAttr);
  }
  Value value = zeros(b, loc, scalar.withShape(width, 1));
  if (hasParams) {
    FailureOr<AttrOp> dofs = dofsOf(decl);
    if (failed(dofs))
      return failure();
    MatrixType type = dofs->getMatrixType();
    value =
        pad(b, loc, ReadOp::create(b, loc, type, getScenePath(*dofs)), width);
  }
  YieldOp::create(b, loc, value);
  return attr;
}

FailureOr<AttrOp> IndexGenerator::energyDofs(AttrOp energy, AttrOp grad) {
  auto params = grad->getAttrOfType<ArrayAttr>(kParamsAttr);
  FailureOr<AttrOp> dofs =
      build(getOwningEntity(energy), (energy.getSymName() + "__dofs").str(),
            energy.getMatrixType().getScalarType(), params);
  if (succeeded(dofs))
    (*dofs)->setAttr(kDerivativeAttr,
                     DerivativeAttr::get(energy.getContext(),
                                         DerivativeRole::dofs,
                                         getScenePath(energy)));
  return dofs;
}

struct GenerateIndicesPass
    : public mlir::yasps::impl::YaspsGenerateIndicesBase<GenerateIndicesPass> {
  void runOnOperation() override {
    SymbolTableCollection tables;
    for (auto scene : getOperation().getOps<SceneOp>()) {
      IndexGenerator generator(scene, tables);
      for (auto energy : scene.getBodyBlock().getOps<EnergyOp>()) {
        auto attr = dyn_cast_or_null<AttrOp>(
            lookupInScene(scene, energy.getAttribute(), &tables));
        if (!attr)
          continue;
        AttrOp grad =
            lookupDerivative(getOwningEntity(attr), DerivativeRole::grad, attr);
        // Energies of no target have no derivatives and no indices.
        if (!grad || !grad->getAttrOfType<ArrayAttr>(kParamsAttr))
          continue;
        if (failed(generator.energyDofs(attr, grad)))
          return signalPassFailure();
      }
    }
  }
};

} // namespace
