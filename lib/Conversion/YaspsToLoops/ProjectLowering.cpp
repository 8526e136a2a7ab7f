//===- ProjectLowering.cpp - PSD projection in kernel code ----------------===//
//
// `yasps.project` first tests the symmetric matrix for positive
// definiteness (LDL^T pivots, unrolled) and returns it unchanged when it
// passes. Otherwise it eigen-decomposes it (SymmetricEigen.cpp) and rebuilds
// it with its eigenvalues clamped at zero (or made absolute).
//
// The rebuild adds rank-one corrections to whichever side is cheaper: with
// k negative eigenvalues, P = H - sum_neg w_i v_i v_i^T when k <= n/2, else
// P is summed from the positive eigenpairs. Local Hessians have few negative
// eigenvalues, so this usually costs k n^2 / 2 operations instead of n^3,
// and a negative definite matrix projects to exactly zero.
//
//===----------------------------------------------------------------------===//

#include "yasps/Conversion/YaspsToLoops/ScalarLowering.h"

#include "ImperativeBuilder.h"
#include "SymmetricEigen.h"

using namespace mlir;
using namespace mlir::yasps;

/// The projection of the symmetric matrix `sym` (row-major scalars) through
/// its eigen-decomposition, emitted at the builder's insertion point; returns
/// the column-major entries of the result.
static SmallVector<Value> eigenProjection(OpBuilder &builder, Location loc,
                                          ProjectionMethod method,
                                          ArrayRef<Value> sym, int64_t n,
                                          FloatType type, int64_t lanes) {
  ImperativeBuilder b{builder, loc, type, lanes};
  Value z = b.buffer({n, n}), d = b.buffer({n}), out = b.buffer({n, n});
  for (int64_t r = 0; r < n; ++r)
    for (int64_t c = 0; c < n; ++c)
      b.put(sym[r * n + c], z, b.idx(r), b.idx(c));
  emitSymmetricEigen(b, z, d, n);

  // Sum from the positive side when most eigenvalues are negative (counted
  // in floats, which lanes keep per problem).
  Value negatives = b.variable();
  b.set(negatives, b.cst(0.0));
  b.forRange(0, n, [&](Value i) {
    Value isNeg = b.lt(b.at(d, i), b.cst(0.0));
    b.set(negatives,
          b.add(b.get(negatives), b.select(isNeg, b.cst(1.0), b.cst(0.0))));
  });
  Value fromPositive =
      b.gt(b.add(b.get(negatives), b.get(negatives)), b.cst(double(n)));
  bool isAbs = method == ProjectionMethod::abs;
  // clamp: P = H - sum_neg l vv^T = sum_pos l vv^T;
  // abs:   P = H - 2 sum_neg l vv^T = -H + 2 sum_pos l vv^T.
  for (int64_t r = 0; r < n; ++r)
    for (int64_t c = r; c < n; ++c) {
      Value h = sym[r * n + c];
      Value base = b.select(fromPositive, isAbs ? b.neg(h) : b.cst(0.0), h);
      b.put(base, out, b.idx(r), b.idx(c));
    }
  b.forRange(0, n, [&](Value i) {
    Value l = b.at(d, i);
    Value scaled = isAbs ? b.mul(b.cst(2.0), l) : l;
    Value onSide =
        b.select(fromPositive, b.gt(l, b.cst(0.0)), b.lt(l, b.cst(0.0)));
    Value w = b.select(fromPositive, scaled, b.neg(scaled));
    b.ifThen(onSide, [&] {
      b.forRange(0, n, [&](Value r) {
        Value wr = b.mul(w, b.at(z, i, r));
        b.forRange(r, b.idx(n), [&](Value c) {
          b.put(b.add(b.at(out, r, c), b.mul(wr, b.at(z, i, c))), out, r, c);
        });
      });
    });
  });
  SmallVector<Value> result;
  for (int64_t c = 0; c < n; ++c)
    for (int64_t r = 0; r < n; ++r)
      result.push_back(b.at(out, b.idx(std::min(r, c)), b.idx(std::max(r, c))));
  return result;
}

/// True (i1) if the symmetric matrix `sym` (row-major) is positive definite:
/// every pivot of its LDL^T factorisation is positive (NaN is not).
static Value isPositiveDefinite(OpBuilder &b, Location loc, ArrayRef<Value> sym,
                                int64_t n, FloatType type, int64_t lanes) {
  ImperativeBuilder j{b, loc, type, lanes};
  SmallVector<Value> d(n), l(n * n);
  Value all;
  for (int64_t c = 0; c < n; ++c) {
    Value dc = sym[c * n + c];
    for (int64_t k = 0; k < c; ++k)
      dc = j.sub(dc, j.mul(j.mul(l[c * n + k], l[c * n + k]), d[k]));
    d[c] = dc;
    Value positive = arith::CmpFOp::create(b, loc, arith::CmpFPredicate::OGT,
                                           dc, j.cst(0.0));
    all = all ? arith::AndIOp::create(b, loc, all, positive).getResult()
              : positive;
    for (int64_t r = c + 1; r < n; ++r) {
      Value lrc = sym[r * n + c];
      for (int64_t k = 0; k < c; ++k)
        lrc = j.sub(lrc, j.mul(j.mul(l[r * n + k], l[c * n + k]), d[k]));
      l[r * n + c] = j.div(lrc, dc);
    }
  }
  return all;
}

ScalarMatrix mlir::yasps::lowerProjection(OpBuilder &b, Location loc,
                                          ProjectionMethod method,
                                          const ScalarMatrix &in) {
  if (method == ProjectionMethod::none)
    return in;
  int64_t n = in.rows;
  // Vector entries hold one problem per lane (see ImperativeBuilder).
  Type valueType = in.values.front().getType();
  auto vectorType = dyn_cast<VectorType>(valueType);
  int64_t lanes = vectorType ? vectorType.getNumElements() : 1;
  auto type = cast<FloatType>(getElementTypeOrSelf(valueType));
  ImperativeBuilder j{b, loc, type, lanes};
  // The symmetric part of the input (Hessians are symmetric up to rounding).
  SmallVector<Value> sym(n * n);
  for (int64_t r = 0; r < n; ++r)
    for (int64_t c = 0; c < n; ++c)
      sym[r * n + c] = r == c
                           ? in.at(r, c)
                           : j.mul(j.cst(0.5), j.add(in.at(r, c), in.at(c, r)));
  // Most local Hessians are already positive definite: an LDL^T test (n^3/3
  // operations) skips the eigen-decomposition for them.
  Value definite = isPositiveDefinite(b, loc, sym, n, type, lanes);
  SmallVector<Type> resultTypes(n * n, valueType);
  auto ifOp = scf::IfOp::create(b, loc, resultTypes, j.all(definite),
                                /*withElseRegion=*/true);
  {
    OpBuilder::InsertionGuard guard(b);
    b.setInsertionPointToStart(ifOp.thenBlock());
    SmallVector<Value> same;
    for (int64_t c = 0; c < n; ++c)
      for (int64_t r = 0; r < n; ++r)
        same.push_back(sym[r * n + c]);
    scf::YieldOp::create(b, loc, same);
    b.setInsertionPointToStart(ifOp.elseBlock());
    SmallVector<Value> projected =
        eigenProjection(b, loc, method, sym, n, type, lanes);
    // Lanes that are definite keep their matrix.
    if (lanes > 1)
      for (int64_t k = 0; k < n * n; ++k)
        projected[k] = j.select(definite, same[k], projected[k]);
    scf::YieldOp::create(b, loc, projected);
  }
  ScalarMatrix result{n, n, {}};
  result.values.append(ifOp.getResults().begin(), ifOp.getResults().end());
  return result;
}
