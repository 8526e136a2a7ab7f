//===- KernelEmitter.h - the body of one loop kernel ------------*- C++ -*-===//
//
// Private to yasps-lower-to-loops: evaluates an attribute for one instance
// as scalar arith/math code (stored attributes loaded, computed attributes
// evaluated in place, JOINs gathered, UNIONs decoded) and adds the kernel
// function's buffer arguments as it meets them.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_LIB_CONVERSION_YASPSTOLOOPS_KERNELEMITTER_H
#define YASPS_LIB_CONVERSION_YASPSTOLOOPS_KERNELEMITTER_H

#include "ImperativeBuilder.h"
#include "yasps/Conversion/YaspsToLoops/ScalarLowering.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "mlir/Dialect/Func/IR/FuncOps.h"
#include "mlir/Dialect/MemRef/IR/MemRef.h"
#include "mlir/Dialect/SCF/IR/SCF.h"

#include <map>

namespace mlir::yasps {

/// Builds the body of one kernel function, adding buffer arguments to it as
/// the evaluation meets stored attributes, connectivities and unions.
class KernelEmitter {
public:
  /// `attrStorage` and `outStorage`, when set, are the float types of the
  /// attribute buffers and of the output buffer, whatever the IR computes
  /// in (yasps-lower-to-loops' `storage` and `out-storage` options).
  KernelEmitter(SceneOp scene, SymbolTableCollection &tables, func::FuncOp func,
                bool symbolicZeros, FloatType attrStorage = {},
                FloatType outStorage = {})
      : scene(scene), tables(tables), func(func), symbolicZeros(symbolicZeros),
        attrStorage(attrStorage), outStorage(outStorage) {}

  /// The buffer argument holding `symbol`'s data, created on first use.
  /// Float buffers hold the storage type where one is set.
  Value buffer(KernelArgKind kind, Operation *symbol, Type elementType) {
    auto key = std::make_pair(kind, symbol);
    auto it = buffers.find(key);
    if (it != buffers.end())
      return it->second;
    Block &entry = func.getBody().front();
    FloatType storage = kind == KernelArgKind::out ? outStorage : attrStorage;
    if (storage && isa<FloatType>(elementType))
      elementType = storage;
    Type type = MemRefType::get({ShapedType::kDynamic}, elementType);
    Value arg = entry.addArgument(type, symbol->getLoc());
    buffers[key] = arg;
    MLIRContext *ctx = func.getContext();
    // Scene-wide buffers (the DoF offsets of targets) name the scene.
    SymbolRefAttr path =
        isa<SceneOp>(symbol)
            ? FlatSymbolRefAttr::get(ctx, cast<SceneOp>(symbol).getSymName())
            : getScenePath(symbol);
    roles.push_back(KernelArgAttr::get(ctx, kind, path));
    return arg;
  }

  /// The value of the attribute declared by `decl` at instance `index`.
  FailureOr<ScalarMatrix> evaluate(OpBuilder &b, Operation *decl, Value index) {
    for (auto &scope : llvm::reverse(scopes))
      if (auto it = scope.find({decl, index}); it != scope.end())
        return it->second;
    FailureOr<ScalarMatrix> result = failure();
    if (auto computed = dyn_cast<AttrOp>(decl))
      result = evaluateComputed(b, computed, index);
    else
      result = load(b, decl, index);
    if (succeeded(result))
      scopes.back()[{decl, index}] = *result;
    return result;
  }

  void store(OpBuilder &b, Value out, const ScalarMatrix &value, Value index) {
    Location loc = func.getLoc();
    Value base = offset(b, index, value.values.size());
    Type stored = cast<MemRefType>(out.getType()).getElementType();
    for (auto [i, scalar] : llvm::enumerate(value.values))
      memref::StoreOp::create(b, loc, convertFloat(b, loc, scalar, stored), out,
                              ValueRange{add(b, base, i)});
  }

  /// `value` (a float or a vector of floats) as element type `to`: extended
  /// or truncated (to nearest) where the widths differ.
  static Value convertFloat(OpBuilder &b, Location loc, Value value, Type to) {
    Type from = getElementTypeOrSelf(value.getType());
    if (from == to)
      return value;
    Type target = to;
    if (auto vector = dyn_cast<VectorType>(value.getType()))
      target = vector.clone(to);
    if (cast<FloatType>(to).getWidth() > cast<FloatType>(from).getWidth())
      return arith::ExtFOp::create(b, loc, target, value);
    return arith::TruncFOp::create(b, loc, target, value);
  }

  ArrayAttr getRoles() { return ArrayAttr::get(func.getContext(), roles); }

  /// Forgets computed values (before emitting the body again elsewhere).
  void resetScopes() {
    spent = 0;
    scopes.clear();
    scopes.emplace_back();
    gathered.clear();
    gathered.emplace_back();
  }

  bool hasSymbolicZeros() const { return symbolicZeros; }

  /// Adds the scalar operations that lowering `op` emits to the kernel's
  /// total. Past kMaxKernelOperations it fails with an error on `op`: kernels
  /// are straight-line code per instance, and JOINs evaluate their source
  /// once per gathered instance, so a small scene (nested JOINs, a chain of
  /// large products) can ask for more code than any compiler should emit.
  LogicalResult charge(Operation *op) {
    spent += scalarCost(op);
    if (spent <= kMaxKernelOperations)
      return success();
    return op->emitOpError()
           << "makes kernel @" << func.getSymName() << " exceed "
           << kMaxKernelOperations
           << " scalar operations per instance (docs/robustness.md: split "
              "the attribute, or keep large Hessians factored)";
  }

  /// The computed attribute of `owner` that `read` reads, or null when the
  /// read is a leaf (a stored attribute, or another entity's).
  AttrOp sameOwnerComputed(ReadOp read, Operation *owner) {
    Operation *decl = lookupInScene(scene, read.getAttribute(), &tables);
    auto computed = dyn_cast_or_null<AttrOp>(decl);
    return computed && getOwningEntity(computed) == owner ? computed : AttrOp();
  }

  /// The value of a leaf of a region of `owner` (a read, a DoF number, a
  /// JOIN or a UNION) at instance `index`.
  FailureOr<ScalarMatrix> evaluateLeaf(OpBuilder &b, Operation &op,
                                       Operation *owner, Value index) {
    if (auto read = dyn_cast<ReadOp>(op)) {
      Operation *decl = lookupInScene(scene, read.getAttribute(), &tables);
      // Scene and mesh attributes have one instance: a broadcast.
      Value at = getOwningEntity(decl) == owner ? index : constIndex(b, 0);
      return evaluate(b, decl, at);
    }
    if (auto dof = dyn_cast<DofIndexOp>(op))
      return dofNumbers(b, dof, owner, index);
    if (auto join = dyn_cast<JoinOp>(op))
      return evaluateJoin(b, join, index);
    if (auto unionOp = dyn_cast<UnionOp>(op))
      return evaluateUnion(b, cast<PrimitiveUnionOp>(owner),
                           unionOp.getNameAttr(),
                           cast<MatrixType>(unionOp.getType()), index);
    return failure();
  }
  static bool isLeaf(Operation &op) {
    return isa<ReadOp, DofIndexOp, JoinOp, UnionOp>(op);
  }

private:
  /// Scalar operations per instance of lowering `op`, as emitted: a product
  /// of its multiply-adds, a projection its unrolled LDL^T test and rebuild,
  /// anything else the larger of its operands' and its result's entries.
  static int64_t scalarCost(Operation *op) {
    auto entries = [](Type type) {
      auto matrix = dyn_cast<MatrixType>(type);
      return matrix ? matrix.getNumElements() : int64_t(1);
    };
    if (auto product = dyn_cast<MatmulOp>(op)) {
      auto lhs = cast<MatrixType>(product.getLhs().getType());
      return lhs.getNumElements() *
             cast<MatrixType>(product.getType()).getCols();
    }
    if (isa<ProjectOp>(op)) {
      int64_t n = cast<MatrixType>(op->getResult(0).getType()).getRows();
      return n * n * n;
    }
    int64_t cost = 0;
    for (Value operand : op->getOperands())
      cost += entries(operand.getType());
    for (Value result : op->getResults())
      cost = std::max(cost, entries(result.getType()));
    return std::max<int64_t>(cost, 1);
  }

  Value constIndex(OpBuilder &b, int64_t value) {
    return arith::ConstantIndexOp::create(b, func.getLoc(), value);
  }
  Value add(OpBuilder &b, Value base, int64_t value) {
    if (value == 0)
      return base;
    return arith::AddIOp::create(b, func.getLoc(), base, constIndex(b, value));
  }
  Value offset(OpBuilder &b, Value index, int64_t stride) {
    if (stride == 1)
      return index;
    return arith::MulIOp::create(b, func.getLoc(), index,
                                 constIndex(b, stride));
  }

  /// Entries of a stored attribute, read from its buffer.
  FailureOr<ScalarMatrix> load(OpBuilder &b, Operation *decl, Value index) {
    MatrixType type = getAttributeType(decl);
    Value data = buffer(KernelArgKind::attr, decl, type.getElementType());
    Value base = offset(b, index, type.getNumElements());
    ScalarMatrix out{type.getRows(), type.getCols(), {}};
    for (int64_t i = 0; i < type.getNumElements(); ++i)
      out.values.push_back(
          convertFloat(b, decl->getLoc(),
                       memref::LoadOp::create(b, decl->getLoc(), data,
                                              ValueRange{add(b, base, i)}),
                       type.getElementType()));
    return out;
  }

  FailureOr<ScalarMatrix> evaluateComputed(OpBuilder &b, AttrOp attr,
                                           Value index) {
    Operation *owner = getOwningEntity(attr);
    DenseMap<Value, ScalarMatrix> values;
    for (Operation &op : attr.getBodyBlock()) {
      if (auto yield = dyn_cast<YieldOp>(op))
        return values.lookup(yield.getValue());
      // Leaves too: a gather's loads and index arithmetic are code.
      if (failed(charge(&op)))
        return failure();
      FailureOr<ScalarMatrix> result = failure();
      if (isLeaf(op)) {
        result = evaluateLeaf(b, op, owner, index);
      } else {
        SmallVector<ScalarMatrix> operands;
        for (Value operand : op.getOperands())
          operands.push_back(values.lookup(operand));
        result = lowerToScalars(b, &op, operands, symbolicZeros);
      }
      if (failed(result))
        return failure();
      values[op.getResult(0)] = *result;
    }
    llvm_unreachable("verified attribute regions end in yasps.yield");
  }

  /// offset(T) + i*rc + e + 1 for the entries e of target T at instance i;
  /// the targets' offsets come in the "dof_offsets" buffer (i64, one per
  /// target of yasps.minimize, in order).
  FailureOr<ScalarMatrix> dofNumbers(OpBuilder &b, DofIndexOp dof,
                                     Operation *owner, Value index) {
    Location loc = dof.getLoc();
    Operation *decl = lookupInScene(scene, dof.getTarget(), &tables);
    int64_t position = -1, k = 0;
    for (auto minimize : scene.getBodyBlock().getOps<MinimizeOp>())
      for (auto target : minimize.getTargets().getAsRange<SymbolRefAttr>()) {
        if (position < 0 && lookupInScene(scene, target, &tables) == decl)
          position = k;
        ++k;
      }
    if (position < 0)
      return dof.emitOpError() << "names no minimisation target";
    Value offsets = buffer(KernelArgKind::dof_offsets, scene, b.getI64Type());
    Value raw = memref::LoadOp::create(b, loc, offsets,
                                       ValueRange{constIndex(b, position)});
    Value first = arith::IndexCastOp::create(b, loc, b.getIndexType(), raw);
    Value at = getOwningEntity(decl) == owner ? index : constIndex(b, 0);
    MatrixType type = dof.getMatrixType();
    int64_t entries = type.getNumElements();
    Value base = arith::AddIOp::create(b, loc, first, offset(b, at, entries));
    ScalarMatrix out{type.getRows(), type.getCols(), {}};
    for (int64_t e = 0; e < entries; ++e) {
      Value number = arith::IndexCastOp::create(b, loc, b.getI64Type(),
                                                add(b, base, e + 1));
      out.values.push_back(
          arith::SIToFPOp::create(b, loc, type.getElementType(), number));
    }
    return out;
  }

  /// Row l of the result is the source at the l-th connected instance.
  FailureOr<ScalarMatrix> evaluateJoin(OpBuilder &b, JoinOp join, Value index) {
    Location loc = join.getLoc();
    auto primitive = cast<PrimitiveOp>(getOwningEntity(join));
    auto connectivity = cast<ConnectivityOp>(
        tables.lookupSymbolIn(primitive, join.getConnectivityAttr()));
    Operation *source = lookupInScene(scene, join.getSource(), &tables);
    int64_t arity = connectivity.getArity();
    Value indices = buffer(KernelArgKind::conn, connectivity, b.getI32Type());
    Value base = offset(b, index, arity);
    auto type = cast<MatrixType>(join.getType());
    ScalarMatrix out{type.getRows(), type.getCols(), {}};
    out.values.resize(type.getNumElements());
    for (int64_t l = 0; l < arity; ++l) {
      Value target = gatheredIndex(b, loc, connectivity, indices, base, index,
                                   l);
      FailureOr<ScalarMatrix> row = evaluate(b, source, target);
      if (failed(row))
        return failure();
      for (auto [m, scalar] : llvm::enumerate(row->values))
        out.values[m * arity + l] = scalar;
    }
    return out;
  }

  /// The l-th instance that `connectivity` connects instance `index` to:
  /// loaded once per region, so that JOINs of several sources (an
  /// attribute, its Jacobian, its second Jacobian) through one
  /// connectivity read one index, and evaluate() finds a source's value
  /// already computed at it. Without this, each JOIN's own load was a new
  /// index, and a chain of JOINs of computed attributes (a kinematic tree's
  /// transforms) re-evaluated every ancestor once per path: 3^depth times.
  Value gatheredIndex(OpBuilder &b, Location loc, ConnectivityOp connectivity,
                      Value indices, Value base, Value index, int64_t l) {
    std::tuple<Operation *, Value, int64_t> key{connectivity, index, l};
    for (auto &scope : llvm::reverse(gathered))
      if (auto it = scope.find(key); it != scope.end())
        return it->second;
    Value raw =
        memref::LoadOp::create(b, loc, indices, ValueRange{add(b, base, l)});
    Value target = arith::IndexCastOp::create(b, loc, b.getIndexType(), raw);
    gathered.back()[key] = target;
    return target;
  }

  /// Finds the member that `index` falls in and evaluates its attribute.
  FailureOr<ScalarMatrix> evaluateUnion(OpBuilder &b, PrimitiveUnionOp owner,
                                        FlatSymbolRefAttr name, MatrixType type,
                                        Value index) {
    Location loc = owner.getLoc();
    Value offsets = buffer(KernelArgKind::offsets, owner, b.getI64Type());
    SmallVector<Operation *> members = owner.getMemberOps();
    auto offsetOf = [&](OpBuilder &ib, int64_t member) -> Value {
      Value raw = memref::LoadOp::create(ib, loc, offsets,
                                         ValueRange{constIndex(ib, member)});
      return arith::IndexCastOp::create(ib, loc, ib.getIndexType(), raw);
    };
    auto evaluateMember = [&](OpBuilder &ib,
                              size_t member) -> FailureOr<ScalarMatrix> {
      Operation *decl = tables.lookupSymbolIn(members[member], name);
      Value local = arith::SubIOp::create(ib, loc, index, offsetOf(ib, member));
      return evaluate(ib, decl, local);
    };
    return chain(b, loc, type, 0, members.size(), offsetOf, evaluateMember,
                 index);
  }

  /// scf.if chain: member m when index < offsets[m+1], else the rest.
  template <typename OffsetFn, typename MemberFn>
  FailureOr<ScalarMatrix> chain(OpBuilder &b, Location loc, MatrixType type,
                                size_t member, size_t numMembers,
                                OffsetFn offsetOf, MemberFn evaluateMember,
                                Value index) {
    if (member + 1 == numMembers)
      return evaluateMember(b, member);
    Value inMember = arith::CmpIOp::create(b, loc, arith::CmpIPredicate::ult,
                                           index, offsetOf(b, member + 1));
    SmallVector<Type> resultTypes(type.getNumElements(), type.getElementType());
    auto ifOp = scf::IfOp::create(b, loc, resultTypes, inMember,
                                  /*withElseRegion=*/true);
    for (int branch = 0; branch < 2; ++branch) {
      Block *block = branch == 0 ? ifOp.thenBlock() : ifOp.elseBlock();
      OpBuilder inner = OpBuilder::atBlockEnd(block);
      scopes.emplace_back();
      gathered.emplace_back();
      FailureOr<ScalarMatrix> value =
          branch == 0 ? evaluateMember(inner, member)
                      : chain(inner, loc, type, member + 1, numMembers,
                              offsetOf, evaluateMember, index);
      scopes.pop_back();
      gathered.pop_back();
      if (failed(value))
        return failure();
      scf::YieldOp::create(inner, loc, value->values);
    }
    ScalarMatrix out{type.getRows(), type.getCols(), {}};
    out.values.append(ifOp.getResults().begin(), ifOp.getResults().end());
    return out;
  }

  SceneOp scene;
  SymbolTableCollection &tables;
  func::FuncOp func;
  bool symbolicZeros;
  FloatType attrStorage, outStorage;
  /// Scalar operations emitted so far (charge).
  int64_t spent = 0;
  std::map<std::pair<KernelArgKind, Operation *>, Value> buffers;
  SmallVector<Attribute> roles;
  /// Values already computed, per region: an inner region may reuse the
  /// values of enclosing ones but not those of its siblings.
  SmallVector<DenseMap<std::pair<Operation *, Value>, ScalarMatrix>> scopes{1};
  /// The instances JOINs gathered, per region as `scopes`
  /// (gatheredIndex).
  SmallVector<DenseMap<std::tuple<Operation *, Value, int64_t>, Value>>
      gathered{1};
};

} // namespace mlir::yasps

#endif // YASPS_LIB_CONVERSION_YASPSTOLOOPS_KERNELEMITTER_H
