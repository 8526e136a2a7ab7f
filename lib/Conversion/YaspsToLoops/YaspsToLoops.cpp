//===- YaspsToLoops.cpp - per-instance loop kernels for attributes --------===//
//
// Each requested attribute becomes a function with one parallel loop over the
// instances of its owner. Inside the loop the attribute is evaluated by
// walking its definition: stored attributes are loaded, computed attributes
// are evaluated in place (nothing intermediate is materialised), JOINs gather
// through connectivity buffers and evaluate their source at the gathered
// instances, UNIONs decode the union index and evaluate the member's
// attribute in an scf.if chain.
//
// With `lanes` W > 1 (CPU kernels), instances run in tiles of W, one per
// SIMD lane. The attribute's arithmetic (its region and those of the
// computed attributes of the same owner that it reads) is emitted once on
// vector<Wxf64> values: a first loop over the tile's instances evaluates
// the region's leaves (stored values, JOINs, UNIONs, DoF numbers: loads and
// index arithmetic, which differ per instance) and stages them in a buffer
// with the lanes innermost; the arithmetic then runs on whole vectors, and a
// last loop stores each lane's result. Straight-line derivative code gets
// W instances per instruction, and the PSD projection's eigensolver runs W
// matrices in lockstep (its QL iteration is a chain of dependent square
// roots and divisions, and lanes keep W chains in flight).
//
//===----------------------------------------------------------------------===//

#include "yasps/Conversion/Passes.h"

#include "ImperativeBuilder.h"
#include "yasps/Conversion/YaspsToLoops/ScalarLowering.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "mlir/AsmParser/AsmParser.h"
#include "mlir/Dialect/Math/IR/Math.h"
#include "mlir/Dialect/Vector/IR/VectorOps.h"
#include "mlir/IR/Matchers.h"

#include <map>

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSLOWERTOLOOPS
#include "yasps/Conversion/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;
using namespace mlir::yasps;

namespace {

/// Builds the body of one kernel function, adding buffer arguments to it as
/// the evaluation meets stored attributes, connectivities and unions.
class KernelEmitter {
public:
  KernelEmitter(SceneOp scene, SymbolTableCollection &tables, func::FuncOp func,
                bool symbolicZeros)
      : scene(scene), tables(tables), func(func), symbolicZeros(symbolicZeros) {
  }

  /// The buffer argument holding `symbol`'s data, created on first use.
  Value buffer(KernelArgKind kind, Operation *symbol, Type elementType) {
    auto key = std::make_pair(kind, symbol);
    auto it = buffers.find(key);
    if (it != buffers.end())
      return it->second;
    Block &entry = func.getBody().front();
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
    for (auto [i, scalar] : llvm::enumerate(value.values))
      memref::StoreOp::create(b, loc, scalar, out, ValueRange{add(b, base, i)});
  }

  ArrayAttr getRoles() { return ArrayAttr::get(func.getContext(), roles); }

  /// Forgets computed values (before emitting the body again elsewhere).
  void resetScopes() {
    scopes.clear();
    scopes.emplace_back();
  }

  bool hasSymbolicZeros() const { return symbolicZeros; }

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
      out.values.push_back(memref::LoadOp::create(b, decl->getLoc(), data,
                                                  ValueRange{add(b, base, i)}));
    return out;
  }

  FailureOr<ScalarMatrix> evaluateComputed(OpBuilder &b, AttrOp attr,
                                           Value index) {
    Operation *owner = getOwningEntity(attr);
    DenseMap<Value, ScalarMatrix> values;
    for (Operation &op : attr.getBodyBlock()) {
      if (auto yield = dyn_cast<YieldOp>(op))
        return values.lookup(yield.getValue());
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
      Value raw =
          memref::LoadOp::create(b, loc, indices, ValueRange{add(b, base, l)});
      Value target = arith::IndexCastOp::create(b, loc, b.getIndexType(), raw);
      FailureOr<ScalarMatrix> row = evaluate(b, source, target);
      if (failed(row))
        return failure();
      for (auto [m, scalar] : llvm::enumerate(row->values))
        out.values[m * arity + l] = scalar;
    }
    return out;
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
      FailureOr<ScalarMatrix> value =
          branch == 0 ? evaluateMember(inner, member)
                      : chain(inner, loc, type, member + 1, numMembers,
                              offsetOf, evaluateMember, index);
      scopes.pop_back();
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
  std::map<std::pair<KernelArgKind, Operation *>, Value> buffers;
  SmallVector<Attribute> roles;
  /// Values already computed, per region: an inner region may reuse the
  /// values of enclosing ones but not those of its siblings.
  SmallVector<DenseMap<std::pair<Operation *, Value>, ScalarMatrix>> scopes{1};
};

/// Evaluates an attribute for a tile of instances in SIMD lanes (see the
/// top of this file).
class LaneBatch {
public:
  LaneBatch(KernelEmitter &emitter, AttrOp decl, int64_t lanes)
      : emitter(emitter), decl(decl), owner(getOwningEntity(decl)),
        lanes(lanes) {}

  /// Emits the tile's code into `loop` (over tiles starting at its
  /// induction variable, ending at `end`). Fails, leaving the loop to be
  /// erased, if the region cannot be evaluated in lanes.
  LogicalResult emit(scf::ParallelOp loop, Value out, Value end);

  /// Whether the emitted tile is worth it over scalar code. Lanes cost
  /// staging (a store and a load per leaf entry and per result entry) and
  /// pay off by the arithmetic done once per tile; kernels that mostly
  /// write their results (a 9x9 Hessian of a cheap energy) are bound by
  /// memory either way. Divisions and square roots weigh more (vector units
  /// do several per instruction); other math functions count nothing (LLVM
  /// calls libm once per lane). A PSD projection (its QL loop) always pays.
  /// The threshold comes from bench/simd_lanes.py on the energies of
  /// bench/energy_cases.py.
  bool worthwhile(scf::ParallelOp loop);

private:
  /// Stores a full tile's results (`rows[k]`: entry k of every lane) into
  /// `out`, instance-major, through in-register transposes.
  void storeTransposed(OpBuilder &b, ArrayRef<Value> rows, Value out,
                       Value tile, int64_t entries);
  /// Numbers the leaves of `attr`'s region and of the same-owner computed
  /// attributes it reads.
  void collectLeaves(AttrOp attr);
  /// `attr`'s value on all lanes, from the staged leaves.
  FailureOr<ScalarMatrix> evaluateLanes(OpBuilder &b, AttrOp attr);
  Value index(OpBuilder &b, int64_t value) {
    return arith::ConstantIndexOp::create(b, decl.getLoc(), value);
  }

  KernelEmitter &emitter;
  AttrOp decl;
  Operation *owner;
  int64_t lanes;
  SmallVector<Operation *> leaves;
  DenseMap<Operation *, int64_t> firstSlot; ///< leaf -> staging row
  DenseMap<std::pair<OperationName, Attribute>, Operation *> leafByKey;
  int64_t stagedRows = 0;
  DenseSet<Operation *> walked;
  DenseMap<Operation *, ScalarMatrix> laneValues; ///< attr -> its lanes
  std::map<int64_t, APFloat> constantSlots; ///< staging rows known statically
  DenseMap<int64_t, int64_t> slotAlias;     ///< row -> earlier equal row
  Value staging;
};

void LaneBatch::collectLeaves(AttrOp attr) {
  if (!walked.insert(attr).second)
    return;
  for (Operation &op : attr.getBodyBlock()) {
    if (auto read = dyn_cast<ReadOp>(op))
      if (AttrOp inner = emitter.sameOwnerComputed(read, owner)) {
        collectLeaves(inner);
        continue;
      }
    if (KernelEmitter::isLeaf(op)) {
      // Leaves have no operands: equal attributes read equal values, and
      // share a slot (as their scalar code would be merged by CSE).
      std::pair<OperationName, Attribute> key(op.getName(),
                                              op.getAttrDictionary());
      if (auto same = leafByKey.find(key); same != leafByKey.end()) {
        firstSlot[&op] = firstSlot.lookup(same->second);
        continue;
      }
      leafByKey[key] = &op;
      firstSlot[&op] = stagedRows;
      stagedRows +=
          cast<MatrixType>(op.getResult(0).getType()).getNumElements();
      leaves.push_back(&op);
    }
  }
}

bool LaneBatch::worthwhile(scf::ParallelOp loop) {
  int64_t work = 0;
  bool eigensolver = false;
  loop.getBody()->walk([&](Operation *op) {
    if (isa<scf::ForOp>(op) && op->getParentOp() == loop)
      return WalkResult::skip(); // the per-instance staging loops
    if (isa<scf::WhileOp>(op))
      eigensolver = true;
    if (isa<arith::DivFOp, math::SqrtOp>(op))
      work += 20;
    else if (isa<arith::AddFOp, arith::SubFOp, arith::MulFOp, arith::NegFOp,
                 arith::SelectOp, arith::CmpFOp>(op))
      work += 1;
    return WalkResult::advance();
  });
  int64_t traffic =
      stagedRows + cast<MatrixType>(decl.getType()).getNumElements();
  return eigensolver || work >= 20 * traffic;
}

FailureOr<ScalarMatrix> LaneBatch::evaluateLanes(OpBuilder &b, AttrOp attr) {
  if (auto it = laneValues.find(attr); it != laneValues.end())
    return it->second;
  Location loc = attr.getLoc();
  auto laneType = VectorType::get(
      {lanes}, cast<MatrixType>(attr.getType()).getElementType());
  DenseMap<Value, ScalarMatrix> values;
  for (Operation &op : attr.getBodyBlock()) {
    if (auto yield = dyn_cast<YieldOp>(op)) {
      ScalarMatrix result = values.lookup(yield.getValue());
      laneValues[attr] = result;
      return result;
    }
    FailureOr<ScalarMatrix> result = failure();
    AttrOp inner;
    if (auto read = dyn_cast<ReadOp>(op))
      inner = emitter.sameOwnerComputed(read, owner);
    if (inner) {
      result = evaluateLanes(b, inner);
    } else if (KernelEmitter::isLeaf(op)) {
      auto type = cast<MatrixType>(op.getResult(0).getType());
      ScalarMatrix staged{type.getRows(), type.getCols(), {}};
      for (int64_t k = 0; k < type.getNumElements(); ++k) {
        int64_t slot = firstSlot.lookup(&op) + k;
        if (auto alias = slotAlias.find(slot); alias != slotAlias.end())
          slot = alias->second;
        auto constant = constantSlots.find(slot);
        staged.values.push_back(
            constant != constantSlots.end()
                ? arith::ConstantOp::create(
                      b, loc,
                      DenseElementsAttr::get(
                          laneType, b.getFloatAttr(laneType.getElementType(),
                                                   constant->second)))
                      .getResult()
                : vector::LoadOp::create(
                      b, loc, laneType, staging,
                      ValueRange{index(b, slot), index(b, 0)})
                      .getResult());
      }
      result = staged;
    } else {
      SmallVector<ScalarMatrix> operands;
      for (Value operand : op.getOperands())
        operands.push_back(values.lookup(operand));
      result =
          lowerToScalars(b, &op, operands, emitter.hasSymbolicZeros(), lanes);
    }
    if (failed(result))
      return failure();
    values[op.getResult(0)] = *result;
  }
  return failure();
}

LogicalResult LaneBatch::emit(scf::ParallelOp loop, Value out, Value end) {
  Location loc = decl.getLoc();
  OpBuilder b = OpBuilder::atBlockTerminator(loop.getBody());
  Value tile = loop.getInductionVars()[0];
  Value count = arith::MinUIOp::create(
      b, loc, index(b, lanes), arith::SubIOp::create(b, loc, end, tile));
  MatrixType type = cast<MatrixType>(decl.getType());
  auto laneType = VectorType::get({lanes}, type.getElementType());
  collectLeaves(decl);
  ImperativeBuilder alloc{b, loc, cast<FloatType>(type.getElementType()),
                          lanes};
  staging = alloc.buffer({std::max<int64_t>(stagedRows, 1)});
  Value results = alloc.buffer({type.getNumElements()});
  auto laneLoop = [&](auto body) {
    auto forOp = scf::ForOp::create(b, loc, index(b, 0), count, index(b, 1));
    OpBuilder inner = OpBuilder::atBlockTerminator(forOp.getBody());
    Value lane = forOp.getInductionVar();
    return body(inner, lane, arith::AddIOp::create(inner, loc, tile, lane));
  };

  // Lanes past the end of the last tile compute on zeros: cheap, and never
  // on uninitialised memory.
  Value zeros = arith::ConstantOp::create(
      b, loc,
      DenseElementsAttr::get(laneType,
                             b.getFloatAttr(type.getElementType(), 0)));
  for (int64_t k = 0; k < stagedRows; ++k)
    vector::StoreOp::create(b, loc, zeros, staging,
                            ValueRange{index(b, k), index(b, 0)});

  // 1. Each instance stages its leaves (loads, gathers, index arithmetic).
  emitter.resetScopes();
  bool staged = laneLoop([&](OpBuilder &inner, Value lane, Value instance) {
    // All loads first, then all stores: a store between two gathers of the
    // same values would keep CSE from merging them.
    SmallVector<ScalarMatrix> values;
    for (Operation *leaf : leaves) {
      FailureOr<ScalarMatrix> value =
          emitter.evaluateLeaf(inner, *leaf, owner, instance);
      if (failed(value))
        return false;
      values.push_back(*value);
    }
    DenseMap<Value, int64_t> stagedAt;
    for (auto [leaf, value] : llvm::zip(leaves, values))
      for (auto [k, v] : llvm::enumerate(value.values)) {
        int64_t slot = firstSlot.lookup(leaf) + k;
        // An entry equal to an earlier one (the same SSA value, e.g. a
        // coefficient repeated in a gathered Jacobian) reuses its lane
        // vector, so that products with it are still merged by CSE.
        if (auto earlier = stagedAt.find(v); earlier != stagedAt.end()) {
          slotAlias[slot] = earlier->second;
          continue;
        }
        stagedAt[v] = slot;
        // Constant entries (the structural zeros and ones of gathered
        // Jacobians) are the same in every lane: they stay constants, so
        // that the arithmetic folds them as the scalar code does.
        APFloat constant(0.0);
        if (matchPattern(v, m_ConstantFloat(&constant))) {
          constantSlots.try_emplace(slot, constant);
          continue;
        }
        memref::StoreOp::create(inner, loc, v, staging,
                                ValueRange{index(inner, slot), lane});
      }
    return true;
  });
  emitter.resetScopes();
  if (!staged)
    return failure();

  // 2. The arithmetic, once for all lanes.
  FailureOr<ScalarMatrix> value = evaluateLanes(b, decl);
  if (failed(value))
    return failure();

  // 3. Each instance stores its result: in a full tile, groups of `lanes`
  // consecutive entries are transposed in registers (entry-major vectors to
  // instance-major ones) and stored contiguously; otherwise (the last,
  // partial tile) lane by lane from the staged results.
  int64_t entries = type.getNumElements();
  bool transposable = llvm::isPowerOf2_64(lanes) && entries >= lanes;
  Value full = arith::CmpIOp::create(b, loc, arith::CmpIPredicate::eq, count,
                                     index(b, lanes));
  auto ifFull = scf::IfOp::create(
      b, loc,
      transposable
          ? full
          : arith::ConstantOp::create(b, loc, b.getBoolAttr(false)).getResult(),
      /*withElseRegion=*/true);
  {
    OpBuilder::InsertionGuard guard(b);
    b.setInsertionPoint(ifFull.thenBlock()->getTerminator());
    if (transposable)
      storeTransposed(b, value->values, out, tile, entries);
    b.setInsertionPoint(ifFull.elseBlock()->getTerminator());
    for (auto [k, v] : llvm::enumerate(value->values))
      vector::StoreOp::create(b, loc, v, results,
                              ValueRange{index(b, k), index(b, 0)});
    laneLoop([&](OpBuilder &inner, Value lane, Value instance) {
      ScalarMatrix result{type.getRows(), type.getCols(), {}};
      for (int64_t k = 0; k < entries; ++k)
        result.values.push_back(memref::LoadOp::create(
            inner, loc, results, ValueRange{index(inner, k), lane}));
      emitter.store(inner, out, result, instance);
      return true;
    });
  }
  return success();
}

void LaneBatch::storeTransposed(OpBuilder &b, ArrayRef<Value> rows, Value out,
                                Value tile, int64_t entries) {
  Location loc = decl.getLoc();
  // out[(tile + lane) * entries + k] = rows[k][lane].
  Value base = arith::MulIOp::create(b, loc, tile, index(b, entries));
  auto at = [&](int64_t lane, int64_t k) -> Value {
    return arith::AddIOp::create(b, loc, base, index(b, lane * entries + k));
  };
  int64_t k = 0;
  for (; k + lanes <= entries; k += lanes) {
    // Butterfly transpose: at stride s, rows i and i + s swap the
    // off-diagonal s x s blocks of their 2s x 2s block.
    SmallVector<Value> r(rows.begin() + k, rows.begin() + k + lanes);
    for (int64_t stride = 1; stride < lanes; stride *= 2)
      for (int64_t i = 0; i < lanes; ++i) {
        if (i & stride)
          continue;
        SmallVector<int64_t> low, high;
        for (int64_t j = 0; j < lanes; ++j) {
          bool fromB = j & stride;
          low.push_back(fromB ? lanes + j - stride : j);
          high.push_back(fromB ? lanes + j : j + stride);
        }
        Value a = r[i], c = r[i + stride];
        r[i] = vector::ShuffleOp::create(b, loc, a, c, low);
        r[i + stride] = vector::ShuffleOp::create(b, loc, a, c, high);
      }
    for (int64_t lane = 0; lane < lanes; ++lane)
      vector::StoreOp::create(b, loc, r[lane], out, ValueRange{at(lane, k)});
  }
  // The remaining entries one by one.
  for (; k < entries; ++k)
    for (int64_t lane = 0; lane < lanes; ++lane)
      memref::StoreOp::create(b, loc,
                              vector::ExtractOp::create(b, loc, rows[k], lane),
                              out, ValueRange{at(lane, k)});
}

std::string kernelName(SymbolRefAttr path) {
  std::string name = "yasps_eval_" + path.getRootReference().str();
  for (FlatSymbolRefAttr nested : path.getNestedReferences())
    name += "__" + nested.getValue().str();
  return name;
}

struct LowerToLoopsPass
    : public mlir::yasps::impl::YaspsLowerToLoopsBase<LowerToLoopsPass> {
  using YaspsLowerToLoopsBase::YaspsLowerToLoopsBase;

  void runOnOperation() override;
  LogicalResult lowerAttribute(SceneOp scene, SymbolTableCollection &tables,
                               SymbolRefAttr path);
};

} // namespace

LogicalResult LowerToLoopsPass::lowerAttribute(SceneOp scene,
                                               SymbolTableCollection &tables,
                                               SymbolRefAttr path) {
  ModuleOp module = getOperation();
  Operation *decl = lookupInScene(scene, path, &tables);
  if (!isAttributeDecl(decl))
    return scene.emitError()
           << "yasps-lower-to-loops: " << path
           << " does not name an attribute of scene @" << scene.getSymName();
  MatrixType type = getAttributeType(decl);
  Location loc = decl->getLoc();
  std::string name = kernelName(path);
  if (SymbolTable::lookupSymbolIn(module, name))
    return decl->emitError() << "kernel @" << name << " already exists";

  OpBuilder builder = OpBuilder::atBlockEnd(module.getBody());
  Type indexType = builder.getIndexType();
  auto func = func::FuncOp::create(
      builder, loc, name, builder.getFunctionType({indexType, indexType}, {}));
  Block *entry = func.addEntryBlock();
  OpBuilder b = OpBuilder::atBlockBegin(entry);

  // Derivative attributes (from yasps-differentiate) get symbolic zeros.
  KernelEmitter emitter(scene, tables, func,
                        /*symbolicZeros=*/decl->hasAttr("yasps.params"));
  Value out = emitter.buffer(KernelArgKind::out, decl, type.getElementType());
  Value one = arith::ConstantIndexOp::create(b, loc, 1);
  auto ret = func::ReturnOp::create(b, loc);
  b.setInsertionPoint(ret);
  // The loop is created first and filled afterwards so that code generated
  // for the body can reach the enclosing function (e.g. for scratch buffers).
  bool batched = false;
  auto computed = dyn_cast<AttrOp>(decl);
  if (lanes > 1 && computed) {
    Value step = arith::ConstantIndexOp::create(b, loc, lanes);
    auto loop = scf::ParallelOp::create(
        b, loc, ValueRange{entry->getArgument(0)},
        ValueRange{entry->getArgument(1)}, ValueRange{step});
    // A region that cannot run in lanes (an op the lowering rejects) is
    // emitted one instance at a time below, which reports the error.
    {
      ScopedDiagnosticHandler quiet(&getContext(),
                                    [](Diagnostic &) { return success(); });
      LaneBatch batch(emitter, computed, lanes);
      batched = succeeded(batch.emit(loop, out, entry->getArgument(1))) &&
                batch.worthwhile(loop);
    }
    if (!batched) {
      loop.erase();
      emitter.resetScopes();
    }
  }
  if (!batched) {
    auto loop = scf::ParallelOp::create(
        b, loc, ValueRange{entry->getArgument(0)},
        ValueRange{entry->getArgument(1)}, ValueRange{one});
    OpBuilder body = OpBuilder::atBlockTerminator(loop.getBody());
    Value instance = loop.getInductionVars()[0];
    FailureOr<ScalarMatrix> value = emitter.evaluate(body, decl, instance);
    if (failed(value))
      return failure();
    emitter.store(body, out, *value, instance);
  }

  func.setType(builder.getFunctionType(entry->getArgumentTypes(), {}));
  func->setAttr("yasps.kernel_of", path);
  func->setAttr("yasps.kernel_args", emitter.getRoles());
  // Rows and columns of each instance's value in `out`.
  func->setAttr("yasps.kernel_shape",
                builder.getDenseI64ArrayAttr({type.getRows(), type.getCols()}));
  // Derivative attributes describe their local parameters; keep that with
  // the kernel for the runtime.
  if (Attribute params = decl->getAttr("yasps.params"))
    func->setAttr("yasps.params", params);
  // And projected Hessians how they are projected (full, reduced, ...).
  if (Attribute projection = decl->getAttr("yasps.projection"))
    func->setAttr("yasps.projection", projection);
  return success();
}

void LowerToLoopsPass::runOnOperation() {
  ModuleOp module = getOperation();
  SmallVector<SceneOp> scenes = llvm::to_vector(module.getOps<SceneOp>());
  SceneOp scene;
  for (SceneOp candidate : scenes)
    if (sceneName.empty() || candidate.getSymName() == sceneName)
      scene = candidate;
  if (!scene || (sceneName.empty() && scenes.size() != 1)) {
    module.emitError() << "yasps-lower-to-loops: "
                       << (sceneName.empty()
                               ? "the module must hold exactly one scene "
                                 "(or name one with scene=)"
                               : "no scene @" + sceneName);
    return signalPassFailure();
  }

  SmallVector<SymbolRefAttr> paths;
  for (const std::string &text : attributes) {
    auto path =
        dyn_cast_or_null<SymbolRefAttr>(parseAttribute(text, &getContext()));
    if (!path) {
      module.emitError() << "yasps-lower-to-loops: '" << text
                         << "' is not a symbol path like @mesh::@prim::@attr";
      return signalPassFailure();
    }
    paths.push_back(path);
  }
  if (attributes.empty())
    for (auto energy : scene.getBodyBlock().getOps<EnergyOp>())
      paths.push_back(energy.getAttribute());

  SymbolTableCollection tables;
  for (SymbolRefAttr path : paths)
    if (failed(lowerAttribute(scene, tables, path)))
      return signalPassFailure();
}
