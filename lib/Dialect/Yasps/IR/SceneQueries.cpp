//===- SceneQueries.cpp - navigating the scene hierarchy ------------------===//
//
// Scenes, meshes, primitives and unions nest as ops; attribute paths are
// symbol references relative to the scene. These helpers are what the
// verifiers and passes use to resolve paths and to reason about lineage.
//
//===----------------------------------------------------------------------===//

#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "llvm/ADT/TypeSwitch.h"

using namespace mlir;
using namespace mlir::yasps;

bool mlir::yasps::isEntity(Operation *op) {
  return isa_and_nonnull<SceneOp, MeshOp, PrimitiveOp, PrimitiveUnionOp>(op);
}

bool mlir::yasps::isAttributeDecl(Operation *op) {
  return isa_and_nonnull<DataAttrOp, ConstAttrOp, AttrOp>(op);
}

MatrixType mlir::yasps::getAttributeType(Operation *attrDecl) {
  return TypeSwitch<Operation *, MatrixType>(attrDecl)
      .Case<DataAttrOp, ConstAttrOp, AttrOp>(
          [](auto op) { return op.getMatrixType(); })
      .Default([](Operation *) { return MatrixType(); });
}

SceneOp mlir::yasps::getEnclosingScene(Operation *op) {
  if (auto scene = dyn_cast_or_null<SceneOp>(op))
    return scene;
  return op ? op->getParentOfType<SceneOp>() : SceneOp();
}

Operation *mlir::yasps::getOwningEntity(Operation *op) {
  for (Operation *parent = op ? op->getParentOp() : nullptr; parent;
       parent = parent->getParentOp())
    if (isEntity(parent))
      return parent;
  return nullptr;
}

Operation *mlir::yasps::lookupInScene(SceneOp scene, SymbolRefAttr path,
                                      SymbolTableCollection *tables) {
  if (!scene || !path)
    return nullptr;
  if (tables)
    return tables->lookupSymbolIn(scene, path);
  return SymbolTable::lookupSymbolIn(scene, path);
}

SymbolRefAttr mlir::yasps::getScenePath(Operation *symbolOp) {
  SmallVector<StringAttr> names;
  for (Operation *op = symbolOp; op && !isa<SceneOp>(op);
       op = op->getParentOp()) {
    if (auto name =
            op->getAttrOfType<StringAttr>(SymbolTable::getSymbolAttrName()))
      names.push_back(name);
  }
  if (names.empty())
    return {};
  std::reverse(names.begin(), names.end());
  SmallVector<FlatSymbolRefAttr> nested;
  for (StringAttr name : ArrayRef(names).drop_front())
    nested.push_back(FlatSymbolRefAttr::get(name));
  return SymbolRefAttr::get(names.front(), nested);
}

static StringRef kindName(Operation *op) {
  return TypeSwitch<Operation *, StringRef>(op)
      .Case<SceneOp>([](auto) { return "scene"; })
      .Case<MeshOp>([](auto) { return "mesh"; })
      .Case<PrimitiveOp>([](auto) { return "primitive"; })
      .Case<PrimitiveUnionOp>([](auto) { return "primitive union"; })
      .Case<DataAttrOp>([](auto) { return "data attribute"; })
      .Case<ConstAttrOp>([](auto) { return "constant attribute"; })
      .Case<AttrOp>([](auto) { return "computed attribute"; })
      .Case<ConnectivityOp>([](auto) { return "connectivity"; })
      .Default([](Operation *op) { return op->getName().getStringRef(); });
}

std::string mlir::yasps::describe(Operation *symbolOp) {
  std::string text;
  llvm::raw_string_ostream os(text);
  os << kindName(symbolOp) << " ";
  if (auto scene = dyn_cast<SceneOp>(symbolOp))
    os << "@" << scene.getSymName();
  else if (SymbolRefAttr path = getScenePath(symbolOp))
    os << path;
  else
    os << "<unnamed>";
  return text;
}

bool mlir::yasps::isOnLineageOf(Operation *ancestor, Operation *entity) {
  return ancestor && entity &&
         (ancestor == entity || ancestor->isProperAncestor(entity));
}

SmallVector<Operation *>
mlir::yasps::getAttributeDependencies(AttrOp attr,
                                      SymbolTableCollection &tables) {
  SmallVector<Operation *> deps;
  SceneOp scene = getEnclosingScene(attr);
  auto add = [&](Operation *decl) {
    if (isAttributeDecl(decl))
      deps.push_back(decl);
  };
  for (Operation &op : attr.getBodyBlock()) {
    if (auto read = dyn_cast<ReadOp>(op)) {
      add(lookupInScene(scene, read.getAttribute(), &tables));
    } else if (auto join = dyn_cast<JoinOp>(op)) {
      add(lookupInScene(scene, join.getSource(), &tables));
    } else if (auto unionOp = dyn_cast<UnionOp>(op)) {
      auto owner = dyn_cast_or_null<PrimitiveUnionOp>(getOwningEntity(attr));
      if (!owner)
        continue;
      for (auto ref : owner.getMembers().getAsRange<SymbolRefAttr>()) {
        Operation *member = lookupInScene(scene, ref, &tables);
        if (isa_and_nonnull<PrimitiveOp, PrimitiveUnionOp>(member))
          add(tables.lookupSymbolIn(member, unionOp.getNameAttr()));
      }
    }
  }
  return deps;
}

static bool hasDynamicInstancesImpl(Operation *entity,
                                    llvm::SmallPtrSetImpl<Operation *> &seen) {
  if (auto primitive = dyn_cast_or_null<PrimitiveOp>(entity))
    return primitive.getDynamic();
  auto unionOp = dyn_cast_or_null<PrimitiveUnionOp>(entity);
  if (!unionOp || !seen.insert(unionOp).second)
    return false;
  return llvm::any_of(unionOp.getMemberOps(), [&](Operation *member) {
    return hasDynamicInstancesImpl(member, seen);
  });
}

bool mlir::yasps::hasDynamicInstances(Operation *entity) {
  llvm::SmallPtrSet<Operation *, 4> seen;
  return hasDynamicInstancesImpl(entity, seen);
}

AttrOp mlir::yasps::lookupDerivative(Operation *entity, DerivativeRole role,
                                     Operation *of) {
  SymbolRefAttr path = getScenePath(of);
  for (auto attr : entity->getRegion(0).front().getOps<AttrOp>())
    if (auto derivative = attr->getAttrOfType<DerivativeAttr>(kDerivativeAttr);
        derivative && derivative.getRole() == role &&
        derivative.getOf() == path)
      return attr;
  return AttrOp();
}
