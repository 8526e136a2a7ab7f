//===- LaneBatch.cpp - loop kernels in SIMD lanes -------------------------===//

#include "LaneBatch.h"

#include "mlir/Dialect/Math/IR/Math.h"
#include "mlir/Dialect/Vector/IR/VectorOps.h"
#include "mlir/IR/Matchers.h"

using namespace mlir;
using namespace mlir::yasps;

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
      if (failed(emitter.charge(&op)))
        return failure();
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

  int64_t entries = type.getNumElements();
  bool transposable = llvm::isPowerOf2_64(lanes) && entries >= lanes;
  if (transposable)
    prefetchNextTile(b, out, tile, end, entries);

  // 2. The arithmetic, once for all lanes.
  FailureOr<ScalarMatrix> value = evaluateLanes(b, decl);
  if (failed(value))
    return failure();

  // 3. Each instance stores its result: in a full tile, groups of `lanes`
  // consecutive entries are transposed in registers (entry-major vectors to
  // instance-major ones) and stored contiguously; otherwise (the last,
  // partial tile) lane by lane from the staged results.
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

void LaneBatch::prefetchNextTile(OpBuilder &b, Value out, Value tile, Value end,
                                 int64_t entries) {
  Location loc = decl.getLoc();
  auto memref = cast<MemRefType>(out.getType());
  int64_t bytes = memref.getElementType().getIntOrFloatBitWidth() / 8;
  constexpr int64_t kLineBytes = 64;
  int64_t perLine = std::max<int64_t>(1, kLineBytes / bytes);
  // Only where the next tile is full: its lines lie inside `out`.
  Value nextEnd = arith::AddIOp::create(b, loc, tile, index(b, 2 * lanes));
  Value inside =
      arith::CmpIOp::create(b, loc, arith::CmpIPredicate::ule, nextEnd, end);
  auto ifInside = scf::IfOp::create(b, loc, inside, /*withElseRegion=*/false);
  OpBuilder::InsertionGuard guard(b);
  b.setInsertionPoint(ifInside.thenBlock()->getTerminator());
  Value first = arith::MulIOp::create(
      b, loc, arith::AddIOp::create(b, loc, tile, index(b, lanes)),
      index(b, entries));
  auto lines = scf::ForOp::create(b, loc, index(b, 0),
                                  index(b, lanes * entries), index(b, perLine));
  OpBuilder inner = OpBuilder::atBlockTerminator(lines.getBody());
  Value at = arith::AddIOp::create(inner, loc, first, lines.getInductionVar());
  memref::PrefetchOp::create(inner, loc, out, ValueRange{at},
                             /*isWrite=*/true, /*localityHint=*/3,
                             /*isDataCache=*/true);
}

void LaneBatch::storeTransposed(OpBuilder &b, ArrayRef<Value> rows, Value out,
                                Value tile, int64_t entries) {
  Location loc = decl.getLoc();
  // out[(tile + lane) * entries + k] = rows[k][lane].
  Value base = arith::MulIOp::create(b, loc, tile, index(b, entries));
  Type stored = cast<MemRefType>(out.getType()).getElementType();
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
      vector::StoreOp::create(
          b, loc, KernelEmitter::convertFloat(b, loc, r[lane], stored), out,
          ValueRange{at(lane, k)});
  }
  // The remaining entries one by one.
  for (; k < entries; ++k)
    for (int64_t lane = 0; lane < lanes; ++lane)
      memref::StoreOp::create(
          b, loc,
          KernelEmitter::convertFloat(
              b, loc, vector::ExtractOp::create(b, loc, rows[k], lane), stored),
          out, ValueRange{at(lane, k)});
}
