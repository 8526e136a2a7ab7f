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
  if (static_cast<int64_t>(getMembers().size()) > kMaxMembers)
    return emitOpError() << describe(*this) << " has " << getMembers().size()
                         << " members; a union has at most " << kMaxMembers;
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
  Operation *target =
      lookupInScene(getEnclosingScene(*this), getTarget(), &tables);
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
  Block &body = getBody().front();
  if (body.getNumArguments() != 0)
    return emitOpError() << describe(*this)
                         << " must not have region arguments: values come "
                            "from 'yasps.read', 'yasps.join' and 'yasps.union'";
  if (body.empty() || !isa<YieldOp>(body.back()))
    return emitOpError() << describe(*this)
                         << " must end its region with 'yasps.yield'";
  // An unregistered op (generic syntax, even one named "yasps.") has no
  // dialect object to ask.
  for (Operation &op : body)
    if (!op.isRegistered() || !isa_and_nonnull<YaspsDialect>(op.getDialect()))
      return op.emitOpError()
             << "is not a yasps expression; " << describe(*this)
             << " may only contain yasps ops";
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

/// Finds a path of computed attributes from `from` back to `target`; on
/// success `path` holds the attributes in between.
static bool dependsOn(AttrOp from, AttrOp target, SymbolTableCollection &tables,
                      llvm::SmallPtrSetImpl<Operation *> &visited,
                      SmallVectorImpl<Operation *> &path) {
  for (Operation *dep : getAttributeDependencies(from, tables)) {
    auto computed = dyn_cast<AttrOp>(dep);
    if (!computed)
      continue;
    if (computed == target)
      return true;
    if (!visited.insert(computed).second)
      continue;
    path.push_back(computed);
    if (dependsOn(computed, target, tables, visited, path))
      return true;
    path.pop_back();
  }
  return false;
}

LogicalResult AttrOp::verifySymbolUses(SymbolTableCollection &tables) {
  // The symbol-table walk visits this op before the ops in its region; check
  // those first so a wrong read is reported as such, not as a consequence.
  for (Operation &op : getBodyBlock())
    if (auto user = dyn_cast<SymbolUserOpInterface>(op))
      if (failed(user.verifySymbolUses(tables)))
        return failure();

  // An attribute cannot be computed from itself, directly or through reads,
  // JOINs and UNIONs: evaluation and differentiation need an acyclic graph.
  llvm::SmallPtrSet<Operation *, 16> visited;
  SmallVector<Operation *> path;
  if (dependsOn(*this, *this, tables, visited, path)) {
    InFlightDiagnostic diag = emitOpError()
                              << describe(*this) << " depends on itself";
    for (Operation *step : path)
      diag << (step == path.front() ? " through " : ", ") << describe(step);
    return diag;
  }

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
  Operation *owner = getOwningEntity(decl);
  bool dynamic = hasDynamicInstances(owner);
  if (dynamic && !getDynamicInstances())
    return emitOpError() << "energy " << describe(decl) << " is on "
                         << describe(owner)
                         << ", whose instances change at run time; register "
                            "it with 'dynamic_instances'";
  if (!dynamic && getDynamicInstances())
    return emitOpError() << "energy " << describe(decl)
                         << " is marked 'dynamic_instances' but "
                         << describe(owner) << " is not dynamic";
  for (auto other : cast<SceneOp>((*this)->getParentOp())
                        .getBodyBlock()
                        .getOps<EnergyOp>()) {
    if (other == *this)
      break;
    if (other.getAttribute() == getAttribute())
      return emitOpError() << "energy " << describe(decl)
                           << " is registered twice";
  }
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
