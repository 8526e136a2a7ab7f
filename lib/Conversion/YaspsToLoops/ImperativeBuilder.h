//===- ImperativeBuilder.h - loops and mutable scalars in kernel code -----===//
//
// Dense linear algebra in kernels (PSD projection) is written as the
// imperative algorithms of the numerical literature: loops over small
// buffers and scalar variables that are reassigned. This helper emits such
// code with scf/memref ops. Variables and buffers are allocas in the
// function's entry block: an alloca inside the instance loop would grow the
// stack with every instance (and memref.alloca_scope cannot hold the loops
// once they are lowered to branches). LLVM's SROA turns scalar variables
// back into registers, so they cost nothing.
//
// With `lanes` > 1 every float is a vector of that many independent
// problems (one per kernel instance) that run in lockstep: buffers get a
// trailing lane dimension, comparisons give lane masks, and branches become
// predicated execution. `ifThen` runs its body when any lane needs it, with
// a mask under which `put` and `set` of float vectors only change the
// active lanes; `doWhile` repeats while any lane asks to. Index values stay
// scalars: loop indices are the same in every lane, and lane-dependent
// positions are kept as float vectors by the algorithms that need them.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_LIB_CONVERSION_YASPSTOLOOPS_IMPERATIVEBUILDER_H
#define YASPS_LIB_CONVERSION_YASPSTOLOOPS_IMPERATIVEBUILDER_H

#include "mlir/Dialect/Arith/IR/Arith.h"
#include "mlir/Dialect/Math/IR/Math.h"
#include "mlir/Dialect/MemRef/IR/MemRef.h"
#include "mlir/Dialect/SCF/IR/SCF.h"
#include "mlir/Dialect/Vector/IR/VectorOps.h"
#include "mlir/IR/Builders.h"
#include "mlir/Interfaces/FunctionInterfaces.h"

#include <cmath>

namespace mlir::yasps {

struct ImperativeBuilder {
  OpBuilder &b;
  Location loc;
  FloatType type;
  /// Problems per float value (1: plain scalars).
  int64_t lanes = 1;
  /// Lane masks of the enclosing `ifThen`/`doWhile` bodies (lanes > 1).
  SmallVector<Value> masks = {};

  /// The type of a float value: a scalar or a vector of `lanes`.
  Type valueType() {
    return lanes > 1 ? Type(VectorType::get({lanes}, type)) : Type(type);
  }

  // --- storage -------------------------------------------------------------

  /// An alloca of `memrefType` in the entry block of the enclosing function.
  Value entryAlloca(MemRefType memrefType) {
    OpBuilder::InsertionGuard guard(b);
    Operation *func = b.getInsertionBlock()->getParentOp();
    while (!isa<FunctionOpInterface>(func))
      func = func->getParentOp();
    b.setInsertionPointToStart(&func->getRegion(0).front());
    return memref::AllocaOp::create(b, loc, memrefType);
  }
  /// A float buffer of the given shape (and a trailing lane dimension).
  Value buffer(ArrayRef<int64_t> shape) {
    SmallVector<int64_t> full(shape);
    if (lanes > 1)
      full.push_back(lanes);
    return entryAlloca(MemRefType::get(full, type));
  }
  /// A mutable float value (or a mutable scalar of type `t`, the same in
  /// every lane).
  Value variable(Type t = {}) {
    if (t || lanes == 1)
      return entryAlloca(MemRefType::get({}, t ? t : Type(type)));
    return buffer({});
  }
  Value get(Value var) { return load(var, {}); }
  void set(Value var, Value v) { store(v, var, {}); }
  Value at(Value m, Value i) { return load(m, {i}); }
  Value at(Value m, Value i, Value j) { return load(m, {i, j}); }
  void put(Value v, Value m, Value i) { store(v, m, {i}); }
  void put(Value v, Value m, Value i, Value j) { store(v, m, {i, j}); }

  Value load(Value m, SmallVector<Value> indices) {
    if (!isLaneBuffer(m))
      return memref::LoadOp::create(b, loc, m, indices);
    indices.push_back(idx(0));
    return vector::LoadOp::create(b, loc, cast<VectorType>(valueType()), m,
                                  indices);
  }
  /// Stores `v`; under a lane mask, only the active lanes change.
  void store(Value v, Value m, SmallVector<Value> indices) {
    if (!isLaneBuffer(m)) {
      memref::StoreOp::create(b, loc, v, m, indices);
      return;
    }
    if (!masks.empty())
      v = select(masks.back(), v, load(m, indices));
    indices.push_back(idx(0));
    vector::StoreOp::create(b, loc, v, m, indices);
  }
  bool isLaneBuffer(Value m) {
    auto type = cast<MemRefType>(m.getType());
    return lanes > 1 && type.getRank() > 0 && type.getShape().back() == lanes &&
           isa<FloatType>(type.getElementType());
  }

  // --- lanes -----------------------------------------------------------------

  /// A lane-independent flag or float as a value of every lane.
  Value splat(Value v) {
    if (lanes == 1 || isa<VectorType>(v.getType()))
      return v;
    return vector::BroadcastOp::create(
        b, loc, VectorType::get({lanes}, v.getType()), v);
  }
  /// True (scalar i1) if `cond` holds in any lane / in every lane.
  Value any(Value cond) {
    if (!isa<VectorType>(cond.getType()))
      return cond;
    return vector::ReductionOp::create(b, loc, vector::CombiningKind::OR, cond);
  }
  Value all(Value cond) {
    if (!isa<VectorType>(cond.getType()))
      return cond;
    return vector::ReductionOp::create(b, loc, vector::CombiningKind::AND,
                                       cond);
  }
  /// The largest lane of a float value.
  Value laneMax(Value v) {
    if (!isa<VectorType>(v.getType()))
      return v;
    return vector::ReductionOp::create(b, loc, vector::CombiningKind::MAXIMUMF,
                                       v);
  }
  /// An index as a float value (exact for the small sizes used here).
  Value indexAsFloat(Value i) {
    Value wide = arith::IndexCastOp::create(b, loc, b.getI64Type(), i);
    return splat(arith::SIToFPOp::create(b, loc, type, wide));
  }
  /// A non-negative integral float as an index.
  Value floatAsIndex(Value f) {
    Value wide = arith::FPToSIOp::create(b, loc, b.getI64Type(), f);
    return arith::IndexCastOp::create(b, loc, b.getIndexType(), wide);
  }

  // --- constants and arithmetic ---------------------------------------------

  Value cst(double v) {
    Attribute value = b.getFloatAttr(type, v);
    if (lanes > 1)
      value = DenseElementsAttr::get(cast<ShapedType>(valueType()), value);
    return arith::ConstantOp::create(b, loc, cast<TypedAttr>(value));
  }
  Value idx(int64_t v) { return arith::ConstantIndexOp::create(b, loc, v); }
  Value flag(bool v) {
    return arith::ConstantOp::create(b, loc, b.getBoolAttr(v));
  }
  Value add(Value x, Value y) { return arith::AddFOp::create(b, loc, x, y); }
  Value sub(Value x, Value y) { return arith::SubFOp::create(b, loc, x, y); }
  Value mul(Value x, Value y) { return arith::MulFOp::create(b, loc, x, y); }
  Value div(Value x, Value y) { return arith::DivFOp::create(b, loc, x, y); }
  Value neg(Value x) { return arith::NegFOp::create(b, loc, x); }
  Value abs(Value x) { return math::AbsFOp::create(b, loc, x); }
  Value sqrt(Value x) { return math::SqrtOp::create(b, loc, x); }
  Value max(Value x, Value y) {
    return arith::MaximumFOp::create(b, loc, x, y);
  }
  Value select(Value c, Value x, Value y) {
    if (isa<VectorType>(x.getType()) || isa<VectorType>(y.getType()))
      c = splat(c), x = splat(x), y = splat(y);
    return arith::SelectOp::create(b, loc, c, x, y);
  }
  Value fcmp(arith::CmpFPredicate p, Value x, Value y) {
    return arith::CmpFOp::create(b, loc, p, x, y);
  }
  Value lt(Value x, Value y) { return fcmp(arith::CmpFPredicate::OLT, x, y); }
  Value gt(Value x, Value y) { return fcmp(arith::CmpFPredicate::OGT, x, y); }
  Value eq(Value x, Value y) { return fcmp(arith::CmpFPredicate::OEQ, x, y); }
  Value both(Value x, Value y) {
    if (isa<VectorType>(x.getType()) != isa<VectorType>(y.getType()))
      x = splat(x), y = splat(y);
    return arith::AndIOp::create(b, loc, x, y);
  }
  Value either(Value x, Value y) {
    if (isa<VectorType>(x.getType()) != isa<VectorType>(y.getType()))
      x = splat(x), y = splat(y);
    return arith::OrIOp::create(b, loc, x, y);
  }
  Value negate(Value flag) {
    Value ones = arith::ConstantOp::create(
        b, loc, b.getIntegerAttr(getElementTypeOrSelf(flag.getType()), 1));
    return arith::XOrIOp::create(b, loc, flag, splat(ones));
  }
  Value iadd(Value x, Value y) { return arith::AddIOp::create(b, loc, x, y); }
  Value isub(Value x, Value y) { return arith::SubIOp::create(b, loc, x, y); }
  Value icmp(arith::CmpIPredicate p, Value x, Value y) {
    return arith::CmpIOp::create(b, loc, p, x, y);
  }

  // --- control flow ----------------------------------------------------------

  /// for i in [lb, ub): body(i)
  template <typename Fn> void forRange(Value lb, Value ub, Fn body) {
    scf::ForOp::create(b, loc, lb, ub, idx(1), ValueRange{},
                       [&](OpBuilder &nested, Location, Value i, ValueRange) {
                         OpBuilder::InsertionGuard guard(b);
                         b.setInsertionPoint(scf::YieldOp::create(nested, loc));
                         body(i);
                       });
  }
  template <typename Fn> void forRange(int64_t lb, int64_t ub, Fn body) {
    if (lb < ub)
      forRange(idx(lb), idx(ub), body);
  }
  /// for i = ub - 1 down to lb: body(i)
  template <typename Fn> void forDown(Value lb, Value ub, Fn body) {
    forRange(lb, ub,
             [&](Value k) { body(isub(iadd(lb, isub(ub, k)), idx(1))); });
  }
  /// Runs `then` (and `otherwise`) under `cond`: a branch, or with lane
  /// masks a predicated body that runs when any lane needs it.
  template <typename Then> void ifThen(Value cond, Then then) {
    if (isa<VectorType>(cond.getType())) {
      Value mask = masks.empty() ? cond : both(masks.back(), cond);
      auto ifOp =
          scf::IfOp::create(b, loc, any(mask), /*withElseRegion=*/false);
      OpBuilder::InsertionGuard guard(b);
      b.setInsertionPoint(ifOp.thenBlock()->getTerminator());
      masks.push_back(mask);
      then();
      masks.pop_back();
      return;
    }
    auto ifOp = scf::IfOp::create(b, loc, cond, /*withElseRegion=*/false);
    OpBuilder::InsertionGuard guard(b);
    b.setInsertionPoint(ifOp.thenBlock()->getTerminator());
    then();
  }
  template <typename Then, typename Else>
  void ifThenElse(Value cond, Then then, Else otherwise) {
    if (isa<VectorType>(cond.getType())) {
      ifThen(cond, then);
      ifThen(negate(cond), otherwise);
      return;
    }
    auto ifOp = scf::IfOp::create(b, loc, cond, /*withElseRegion=*/true);
    OpBuilder::InsertionGuard guard(b);
    b.setInsertionPoint(ifOp.thenBlock()->getTerminator());
    then();
    b.setInsertionPoint(ifOp.elseBlock()->getTerminator());
    otherwise();
  }
  /// A value of type `t` computed by `then()` or `otherwise()`: the branch
  /// not taken costs nothing (unlike a select). With lanes, both are
  /// computed (they must be free of side effects) and selected per lane.
  template <typename Then, typename Else>
  Value ifValue(Value cond, Type t, Then then, Else otherwise) {
    if (isa<VectorType>(cond.getType())) {
      Value x = then(), y = otherwise();
      return select(cond, x, y);
    }
    auto ifOp = scf::IfOp::create(b, loc, TypeRange{t}, cond,
                                  /*withElseRegion=*/true);
    OpBuilder::InsertionGuard guard(b);
    b.setInsertionPointToStart(ifOp.thenBlock());
    scf::YieldOp::create(b, loc, then());
    b.setInsertionPointToStart(ifOp.elseBlock());
    scf::YieldOp::create(b, loc, otherwise());
    return ifOp.getResult(0);
  }
  /// do { cond = body(); } while (cond). With lanes, a lane that once
  /// returns false stays masked off while the others go on.
  template <typename Fn> void doWhile(Fn body) {
    if (lanes > 1) {
      Value start = masks.empty() ? splat(flag(true)) : masks.back();
      auto whileOp = scf::WhileOp::create(b, loc, TypeRange{start.getType()},
                                          ValueRange{start});
      OpBuilder::InsertionGuard guard(b);
      Block *before =
          b.createBlock(&whileOp.getBefore(), {}, {start.getType()}, {loc});
      b.setInsertionPointToStart(before);
      masks.push_back(before->getArgument(0));
      Value more = both(before->getArgument(0), body());
      masks.pop_back();
      scf::ConditionOp::create(b, loc, any(more), ValueRange{more});
      Block *after =
          b.createBlock(&whileOp.getAfter(), {}, {start.getType()}, {loc});
      b.setInsertionPointToStart(after);
      scf::YieldOp::create(b, loc, after->getArguments());
      return;
    }
    auto whileOp = scf::WhileOp::create(b, loc, TypeRange{}, ValueRange{});
    OpBuilder::InsertionGuard guard(b);
    Block *before = b.createBlock(&whileOp.getBefore());
    b.setInsertionPointToStart(before);
    scf::ConditionOp::create(b, loc, body(), ValueRange{});
    Block *after = b.createBlock(&whileOp.getAfter());
    b.setInsertionPointToStart(after);
    scf::YieldOp::create(b, loc, ValueRange{});
  }

  /// sqrt(x^2 + y^2) without overflow or underflow in the squares.
  Value hypot(Value x, Value y) {
    Value sq = add(mul(x, x), mul(y, y));
    // The squares are representable and normal between these bounds, with
    // a margin of 2^26 (about 1e-300..1e300 in f64, 1e-30..1e30 in f32).
    const llvm::fltSemantics &semantics = type.getFloatSemantics();
    double margin = std::ldexp(1.0, 26);
    double largest = APFloat::getLargest(semantics).convertToDouble();
    double smallest =
        APFloat::getSmallestNormalized(semantics).convertToDouble();
    Value safe =
        both(fcmp(arith::CmpFPredicate::OLT, sq, cst(largest / margin)),
             fcmp(arith::CmpFPredicate::OGT, sq, cst(smallest * margin)));
    auto scaled = [&] {
      Value big = max(abs(x), abs(y));
      Value nonzero = gt(big, cst(0.0));
      Value scale = select(nonzero, big, cst(1.0));
      Value xs = div(x, scale), ys = div(y, scale);
      return mul(scale, sqrt(add(mul(xs, xs), mul(ys, ys))));
    };
    if (lanes == 1)
      return ifValue(
          safe, valueType(), [&] { return sqrt(sq); }, scaled);
    // With lanes, the scaled form (two divisions) runs only when a lane
    // needs it: this is on the QL iteration's critical path.
    Value fast = sqrt(sq);
    auto ifOp = scf::IfOp::create(b, loc, TypeRange{valueType()}, all(safe),
                                  /*withElseRegion=*/true);
    OpBuilder::InsertionGuard guard(b);
    b.setInsertionPointToStart(ifOp.thenBlock());
    scf::YieldOp::create(b, loc, fast);
    b.setInsertionPointToStart(ifOp.elseBlock());
    scf::YieldOp::create(b, loc, select(safe, fast, scaled()));
    return ifOp.getResult(0);
  }
};

} // namespace mlir::yasps

#endif // YASPS_LIB_CONVERSION_YASPSTOLOOPS_IMPERATIVEBUILDER_H
