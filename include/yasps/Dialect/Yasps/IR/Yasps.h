//===- Yasps.h - the yasps dialect ------------------------------*- C++ -*-===//
//
// Dialect, types and operations of yasps, plus the small queries on the
// scene hierarchy that verifiers and passes share.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_DIALECT_YASPS_IR_YASPS_H
#define YASPS_DIALECT_YASPS_IR_YASPS_H

#include "mlir/Bytecode/BytecodeOpInterface.h"
#include "mlir/IR/Builders.h"
#include "mlir/IR/BuiltinAttributes.h"
#include "mlir/IR/BuiltinOps.h"
#include "mlir/IR/BuiltinTypes.h"
#include "mlir/IR/Dialect.h"
#include "mlir/IR/OpDefinition.h"
#include "mlir/IR/OpImplementation.h"
#include "mlir/IR/SymbolTable.h"
#include "mlir/Interfaces/InferTypeOpInterface.h"
#include "mlir/Interfaces/SideEffectInterfaces.h"

#include "yasps/Dialect/Yasps/IR/YaspsEnums.h.inc"
#include "yasps/Dialect/Yasps/IR/YaspsInterfaces.h.inc"

#define GET_TYPEDEF_CLASSES
#include "yasps/Dialect/Yasps/IR/YaspsTypes.h.inc"

#define GET_ATTRDEF_CLASSES
#include "yasps/Dialect/Yasps/IR/YaspsAttrs.h.inc"

// After the attributes: the helpers of its discardable attributes read
// them by type.
#include "yasps/Dialect/Yasps/IR/YaspsDialect.h.inc"

#define GET_OP_CLASSES
#include "yasps/Dialect/Yasps/IR/YaspsOps.h.inc"

namespace mlir::yasps {

/// The names of the discardable attributes, as the dialect declares them
/// (YaspsDialect.td, discardableAttrs).
constexpr llvm::StringLiteral kParamsAttr =
    YaspsDialect::ParamsAttrHelper::getNameStr();
constexpr llvm::StringLiteral kDerivativeAttr =
    YaspsDialect::DerivativeAttrHelper::getNameStr();
constexpr llvm::StringLiteral kProjectionAttr =
    YaspsDialect::ProjectionAttrHelper::getNameStr();
constexpr llvm::StringLiteral kKernelOfAttr =
    YaspsDialect::KernelOfAttrHelper::getNameStr();
constexpr llvm::StringLiteral kKernelArgsAttr =
    YaspsDialect::KernelArgsAttrHelper::getNameStr();
constexpr llvm::StringLiteral kKernelShapeAttr =
    YaspsDialect::KernelShapeAttrHelper::getNameStr();
constexpr llvm::StringLiteral kOpCountsAttr =
    YaspsDialect::OpCountsAttrHelper::getNameStr();

/// True for the ops that own attributes: scene, mesh, primitive, union.
bool isEntity(Operation *op);

/// True for the ops that declare an attribute: data, constant, computed.
bool isAttributeDecl(Operation *op);

/// The matrix type of an attribute declaration (data, constant, computed).
MatrixType getAttributeType(Operation *attrDecl);

/// The scene that (transitively) contains `op`, or null.
SceneOp getEnclosingScene(Operation *op);

/// The entity (scene, mesh, primitive or union) that owns the attribute or
/// expression `op`.
Operation *getOwningEntity(Operation *op);

/// Resolves a scene-relative symbol path such as `@mesh::@prim::@attr`.
Operation *lookupInScene(SceneOp scene, SymbolRefAttr path,
                         SymbolTableCollection *tables = nullptr);

/// The scene-relative path of a symbol op, e.g. `@bunny::@vertices`.
SymbolRefAttr getScenePath(Operation *symbolOp);

/// Human-readable name of an entity or attribute for diagnostics, e.g.
/// "primitive @bunny::@vertices" or "scene @s0".
std::string describe(Operation *symbolOp);

/// The attribute declarations that `attr`'s region reads directly: targets of
/// `yasps.read`, sources of `yasps.join` and, for `yasps.union`, the
/// same-named attribute of every member. Unresolved symbols are skipped.
SmallVector<Operation *>
getAttributeDependencies(AttrOp attr, SymbolTableCollection &tables);

/// True for a dynamic primitive and for a primitive union with a dynamic
/// member: entities whose instance count changes at run time.
bool hasDynamicInstances(Operation *entity);

/// The attribute of `entity` recorded as `yasps.derivative = <role of
/// path(of)>`, or null.
AttrOp lookupDerivative(Operation *entity, DerivativeRole role, Operation *of);

/// True if `ancestor` is `entity` or one of its enclosing entities.
bool isOnLineageOf(Operation *ancestor, Operation *entity);

} // namespace mlir::yasps

#endif // YASPS_DIALECT_YASPS_IR_YASPS_H
