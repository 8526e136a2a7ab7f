//===- Direction.h - tangents of a region in one direction -----*- C++ -*-===//
//
// Forward mode over one attribute's region, private to yasps-differentiate:
// the tangent of each value in one direction, from seeds at the region's
// leaves (reads, JOINs, UNIONs) or, for derivatives with respect to inner
// variables, at a cut of values that stand in for everything upstream.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_LIB_DIALECT_YASPS_TRANSFORMS_DIRECTION_H
#define YASPS_LIB_DIALECT_YASPS_TRANSFORMS_DIRECTION_H

#include "yasps/Dialect/Yasps/IR/Yasps.h"

namespace mlir::yasps::differentiation {

/// Tangents of one region's values in one direction, emitted at the
/// builder's insertion point and cached per value. A null tangent is zero.
class Direction {
public:
  using SeedFn = function_ref<FailureOr<Value>(Operation *leaf)>;
  using CutSeedFn = function_ref<Value(size_t index)>;

  /// Seeds leaves with `seedFn`. With a `cut`, its values are the
  /// independent variables instead: value i is seeded by `cutSeed(i)` and
  /// nothing upstream of it is visited (leaves reached otherwise get
  /// `seedFn`, which for a cut of every path is never needed).
  Direction(OpBuilder &b, SeedFn seedFn, ArrayRef<Value> cut = {},
            CutSeedFn cutSeed = nullptr)
      : b(b), seedFn(seedFn), cut(cut), cutSeed(cutSeed) {}

  FailureOr<Value> tangent(Value value) {
    if (auto it = cache.find(value); it != cache.end())
      return it->second;
    FailureOr<Value> result = Value();
    const Value *at = llvm::find(cut, value);
    Operation *op = value.getDefiningOp();
    if (at != cut.end()) {
      result = cutSeed(at - cut.begin());
    } else if (isa<ReadOp, JoinOp, UnionOp>(op)) {
      result = seedFn(op);
    } else {
      SmallVector<Value> operandTangents;
      for (Value operand : op->getOperands()) {
        FailureOr<Value> t = tangent(operand);
        if (failed(t))
          return failure();
        operandTangents.push_back(*t);
      }
      result =
          cast<DifferentiableOpInterface>(op).emitTangent(b, operandTangents);
    }
    if (succeeded(result))
      cache[value] = *result;
    return result;
  }

private:
  OpBuilder &b;
  SeedFn seedFn;
  ArrayRef<Value> cut;
  CutSeedFn cutSeed;
  DenseMap<Value, Value> cache;
};

} // namespace mlir::yasps::differentiation

#endif // YASPS_LIB_DIALECT_YASPS_TRANSFORMS_DIRECTION_H
