//===- YaspsStructureOps.cpp - scene structure verifiers ------------------===//

#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "llvm/ADT/DenseSet.h"

using namespace mlir;
using namespace mlir::yasps;

//===----------------------------------------------------------------------===//
// SceneOp
//===----------------------------------------------------------------------===//

LogicalResult SceneOp::verify() {
  MinimizeOp first;
  for (auto minimize : getBodyBlock().getOps<MinimizeOp>()) {
    if (!first) {
      first = minimize;
      continue;
    }
    return minimize.emitOpError()
           << "scene @" << getSymName()
           << " already lists its minimisation targets; merge them into one "
              "'yasps.minimize'";
  }
  return success();
}

//===----------------------------------------------------------------------===//
// PrimitiveUnionOp
//===----------------------------------------------------------------------===//

SmallVector<Operation *> PrimitiveUnionOp::getMemberOps() {
  SmallVector<Operation *> members;
  SceneOp scene = getEnclosingScene(*this);
  for (auto member : getMembers().getAsRange<SymbolRefAttr>())
    members.push_back(lookupInScene(scene, member));
  return members;
}

LogicalResult PrimitiveUnionOp::verify() {
  if (getMembers().empty())
    return emitOpError() << describe(*this) << " must have at least one member";
  llvm::SmallDenseSet<Attribute> seen;
  for (Attribute member : getMembers()) {
    if (!seen.insert(member).second)
      return emitOpError() << describe(*this) << " lists member " << member
                           << " twice";
  }
  return success();
}

/// True if following union members from `from` reaches `target`.
static bool reachesUnion(PrimitiveUnionOp from, PrimitiveUnionOp target,
                         SymbolTableCollection &tables,
                         llvm::SmallPtrSetImpl<Operation *> &visited) {
  if (!visited.insert(from).second)
    return false;
  SceneOp scene = getEnclosingScene(from);
  for (auto ref : from.getMembers().getAsRange<SymbolRefAttr>()) {
    auto member =
        dyn_cast_or_null<PrimitiveUnionOp>(lookupInScene(scene, ref, &tables));
    if (!member)
      continue;
    if (member == target || reachesUnion(member, target, tables, visited))
      return true;
  }
  return false;
}

LogicalResult
PrimitiveUnionOp::verifySymbolUses(SymbolTableCollection &tables) {
  SceneOp scene = getEnclosingScene(*this);
  for (auto ref : getMembers().getAsRange<SymbolRefAttr>()) {
    Operation *member = lookupInScene(scene, ref, &tables);
    if (!isa_and_nonnull<PrimitiveOp, PrimitiveUnionOp>(member))
      return emitOpError() << "member " << ref << " of " << describe(*this)
                           << " does not name a primitive or primitive union";
    if (member == getOperation())
      return emitOpError() << describe(*this) << " lists itself as a member";
    auto memberUnion = dyn_cast<PrimitiveUnionOp>(member);
    llvm::SmallPtrSet<Operation *, 8> visited;
    if (memberUnion && reachesUnion(memberUnion, *this, tables, visited))
      return emitOpError() << describe(*this) << " contains itself through "
                           << describe(member);
  }
  return success();
}

//===----------------------------------------------------------------------===//
// ConnectivityOp
//===----------------------------------------------------------------------===//

LogicalResult ConnectivityOp::verifySymbolUses(SymbolTableCollection &tables) {
  Operation *target = lookupInScene(getEnclosingScene(*this), getTarget(),
                                    &tables);
  if (!isa_and_nonnull<PrimitiveOp, PrimitiveUnionOp>(target))
    return emitOpError() << "target " << getTarget() << " of "
                         << describe(*this)
                         << " does not name a primitive or primitive union";
  return success();
}

//===----------------------------------------------------------------------===//
// AttrOp
//===----------------------------------------------------------------------===//

LogicalResult AttrOp::verify() {
  // The terminator's verifier checks the yielded type; here only the region's
  // shape, so the message names the attribute.
  if (getBody().front().empty() ||
      !isa<YieldOp>(getBody().front().back()))
    return emitOpError() << describe(*this)
                         << " must end its region with 'yasps.yield'";
  return success();
}

/// Depth of an entity below the scene (scene 0, mesh 1, primitive/union 2).
static unsigned entityDepth(Operation *entity) {
  unsigned depth = 0;
  for (Operation *op = entity; op && !isa<SceneOp>(op); op = op->getParentOp())
    if (isEntity(op))
      ++depth;
  return depth;
}

LogicalResult AttrOp::verifySymbolUses(SymbolTableCollection &tables) {
  // Lineage rule, second half (paper 4.3): the result belongs to the deepest
  // entity among the operands. Reads off the lineage are reported by the read
  // itself; JOIN and UNION results are on the owner by construction.
  Operation *owner = getOwningEntity(*this);
  SceneOp scene = getEnclosingScene(*this);
  Operation *deepest = nullptr;
  bool readsAnything = false;
  for (Operation &op : getBodyBlock()) {
    if (isa<JoinOp, UnionOp>(op))
      return success();
    auto read = dyn_cast<ReadOp>(op);
    if (!read)
      continue;
    readsAnything = true;
    Operation *decl = lookupInScene(scene, read.getAttribute(), &tables);
    Operation *entity = decl ? getOwningEntity(decl) : nullptr;
    if (!entity || !isOnLineageOf(entity, owner))
      continue;
    if (!deepest || entityDepth(entity) > entityDepth(deepest))
      deepest = entity;
  }
  if (!readsAnything || !deepest || deepest == owner)
    return success();
  return emitOpError() << describe(*this) << " is declared on "
                       << describe(owner)
                       << " but only reads attributes of its ancestors; the "
                          "result belongs to the deepest entity it reads, "
                       << describe(deepest);
}

//===----------------------------------------------------------------------===//
// EnergyOp and MinimizeOp
//===----------------------------------------------------------------------===//

LogicalResult EnergyOp::verifySymbolUses(SymbolTableCollection &tables) {
  Operation *decl =
      lookupInScene(getEnclosingScene(*this), getAttribute(), &tables);
  if (!isAttributeDecl(decl))
    return emitOpError() << "energy " << getAttribute()
                         << " does not name an attribute";
  MatrixType type = getAttributeType(decl);
  if (!type.isScalar())
    return emitOpError() << "energy " << describe(decl)
                         << " must be 1x1 per instance, got " << type;
  return success();
}

LogicalResult MinimizeOp::verifySymbolUses(SymbolTableCollection &tables) {
  if (getTargets().empty())
    return emitOpError() << "needs at least one minimisation target";
  SceneOp scene = getEnclosingScene(*this);
  llvm::SmallDenseSet<Attribute> seen;
  for (auto target : getTargets().getAsRange<SymbolRefAttr>()) {
    if (!seen.insert(target).second)
      return emitOpError() << "minimisation target " << target
                           << " is listed twice";
    Operation *decl = lookupInScene(scene, target, &tables);
    if (!isAttributeDecl(decl))
      return emitOpError() << "minimisation target " << target
                           << " does not name an attribute";
    if (!isa<DataAttrOp>(decl))
      return emitOpError() << "minimisation target " << describe(decl)
                           << " is not a data attribute; only "
                              "'yasps.data_attr' attributes can be minimised";
  }
  return success();
}
