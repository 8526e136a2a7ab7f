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
//===----------------------------------------------------------------------===//

#ifndef YASPS_LIB_CONVERSION_YASPSTOLOOPS_IMPERATIVEBUILDER_H
#define YASPS_LIB_CONVERSION_YASPSTOLOOPS_IMPERATIVEBUILDER_H

#include "mlir/Dialect/Arith/IR/Arith.h"
#include "mlir/Dialect/Math/IR/Math.h"
#include "mlir/Dialect/MemRef/IR/MemRef.h"
#include "mlir/Dialect/SCF/IR/SCF.h"
#include "mlir/IR/Builders.h"
#include "mlir/Interfaces/FunctionInterfaces.h"

namespace mlir::yasps {

struct ImperativeBuilder {
  OpBuilder &b;
  Location loc;
  FloatType type;

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
  /// A float buffer of the given shape.
  Value buffer(ArrayRef<int64_t> shape) {
    return entryAlloca(MemRefType::get(shape, type));
  }
  /// A mutable scalar of the float type (or `t`).
  Value variable(Type t = {}) {
    return entryAlloca(MemRefType::get({}, t ? t : Type(type)));
  }
  Value get(Value var) { return memref::LoadOp::create(b, loc, var); }
  void set(Value var, Value v) { memref::StoreOp::create(b, loc, v, var); }
  Value at(Value m, Value i) { return memref::LoadOp::create(b, loc, m, i); }
  Value at(Value m, Value i, Value j) {
    return memref::LoadOp::create(b, loc, m, ValueRange{i, j});
  }
  void put(Value v, Value m, Value i) {
    memref::StoreOp::create(b, loc, v, m, i);
  }
  void put(Value v, Value m, Value i, Value j) {
    memref::StoreOp::create(b, loc, v, m, ValueRange{i, j});
  }

  // --- constants and arithmetic ---------------------------------------------

  Value cst(double v) {
    return arith::ConstantOp::create(b, loc, b.getFloatAttr(type, v));
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
    return arith::SelectOp::create(b, loc, c, x, y);
  }
  Value fcmp(arith::CmpFPredicate p, Value x, Value y) {
    return arith::CmpFOp::create(b, loc, p, x, y);
  }
  Value lt(Value x, Value y) { return fcmp(arith::CmpFPredicate::OLT, x, y); }
  Value gt(Value x, Value y) { return fcmp(arith::CmpFPredicate::OGT, x, y); }
  Value eq(Value x, Value y) { return fcmp(arith::CmpFPredicate::OEQ, x, y); }
  Value both(Value x, Value y) { return arith::AndIOp::create(b, loc, x, y); }
  Value either(Value x, Value y) { return arith::OrIOp::create(b, loc, x, y); }
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
  /// Runs `then` (and `otherwise`) under `cond`.
  template <typename Then> void ifThen(Value cond, Then then) {
    auto ifOp = scf::IfOp::create(b, loc, cond, /*withElseRegion=*/false);
    OpBuilder::InsertionGuard guard(b);
    b.setInsertionPoint(ifOp.thenBlock()->getTerminator());
    then();
  }
  template <typename Then, typename Else>
  void ifThenElse(Value cond, Then then, Else otherwise) {
    auto ifOp = scf::IfOp::create(b, loc, cond, /*withElseRegion=*/true);
    OpBuilder::InsertionGuard guard(b);
    b.setInsertionPoint(ifOp.thenBlock()->getTerminator());
    then();
    b.setInsertionPoint(ifOp.elseBlock()->getTerminator());
    otherwise();
  }
  /// A value of type `t` computed by `then()` or `otherwise()`: the branch
  /// not taken costs nothing (unlike a select).
  template <typename Then, typename Else>
  Value ifValue(Value cond, Type t, Then then, Else otherwise) {
    auto ifOp = scf::IfOp::create(b, loc, TypeRange{t}, cond,
                                  /*withElseRegion=*/true);
    OpBuilder::InsertionGuard guard(b);
    b.setInsertionPointToStart(ifOp.thenBlock());
    scf::YieldOp::create(b, loc, then());
    b.setInsertionPointToStart(ifOp.elseBlock());
    scf::YieldOp::create(b, loc, otherwise());
    return ifOp.getResult(0);
  }
  /// do { cond = body(); } while (cond)
  template <typename Fn> void doWhile(Fn body) {
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
    // The squares are representable between these bounds (with margin).
    Value safe = both(fcmp(arith::CmpFPredicate::OLT, sq, cst(1e300)),
                      fcmp(arith::CmpFPredicate::OGT, sq, cst(1e-300)));
    return ifValue(
        safe, type, [&] { return sqrt(sq); },
        [&] {
          Value big = max(abs(x), abs(y));
          Value nonzero = gt(big, cst(0.0));
          Value scale = select(nonzero, big, cst(1.0));
          Value xs = div(x, scale), ys = div(y, scale);
          return mul(scale, sqrt(add(mul(xs, xs), mul(ys, ys))));
        });
  }
};

} // namespace mlir::yasps

#endif // YASPS_LIB_CONVERSION_YASPSTOLOOPS_IMPERATIVEBUILDER_H
