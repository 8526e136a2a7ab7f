//===- ProjectLowering.cpp - PSD projection in kernel code ----------------===//
//
// `yasps.project` first tests the symmetric matrix for positive
// definiteness (LDL^T pivots, unrolled) and returns it unchanged when it
// passes. Otherwise it eigen-decomposes it with the cyclic Jacobi method and
// rebuilds it with its eigenvalues clamped at zero (or made absolute).
// Jacobi is slow for large matrices but local Hessians are at most a few
// dozen rows, and it is accurate where projection needs it: repeated
// eigenvalues, and tiny ones relative to the largest (Demmel & Veselic).
//
// The matrix lives in two stack buffers (the matrix being diagonalised and
// the accumulated rotations) allocated once in the kernel's entry block: an
// alloca inside the instance loop would grow the stack with every instance,
// and memref.alloca_scope cannot hold the loops once they are lowered to
// branches. The CPU runs the instances of a chunk one after another, so the
// buffers are scratch space of one instance at a time. The loops keep code
// size independent of the number of sweeps.
//
//===----------------------------------------------------------------------===//

#include "yasps/Conversion/YaspsToLoops/ScalarLowering.h"

#include "mlir/Dialect/Arith/IR/Arith.h"
#include "mlir/Dialect/Math/IR/Math.h"
#include "mlir/Dialect/MemRef/IR/MemRef.h"
#include "mlir/Dialect/SCF/IR/SCF.h"
#include "mlir/Interfaces/FunctionInterfaces.h"

using namespace mlir;
using namespace mlir::yasps;

// Sweeps of the cyclic Jacobi method. Convergence is quadratic; for the
// matrix sizes of local Hessians a handful of sweeps reach machine precision,
// and later sweeps only test that off-diagonal entries are negligible.
static constexpr int64_t kMaxSweeps = 16;

namespace {
struct JacobiBuilder {
  OpBuilder &b;
  Location loc;
  FloatType type;

  Value cst(double v) {
    return arith::ConstantOp::create(b, loc, b.getFloatAttr(type, v));
  }
  Value idx(int64_t v) { return arith::ConstantIndexOp::create(b, loc, v); }
  Value load(Value m, Value r, Value c) {
    return memref::LoadOp::create(b, loc, m, ValueRange{r, c});
  }
  void store(Value v, Value m, Value r, Value c) {
    memref::StoreOp::create(b, loc, v, m, ValueRange{r, c});
  }
  Value add(Value x, Value y) { return arith::AddFOp::create(b, loc, x, y); }
  Value sub(Value x, Value y) { return arith::SubFOp::create(b, loc, x, y); }
  Value mul(Value x, Value y) { return arith::MulFOp::create(b, loc, x, y); }
  Value div(Value x, Value y) { return arith::DivFOp::create(b, loc, x, y); }
  Value abs(Value x) { return math::AbsFOp::create(b, loc, x); }
  Value eq(Value x, Value y) {
    return arith::CmpFOp::create(b, loc, arith::CmpFPredicate::OEQ, x, y);
  }

  /// for k in [0, n): body(k)
  template <typename Fn> void loop(int64_t n, Fn body) {
    scf::ForOp::create(b, loc, idx(0), idx(n), idx(1), ValueRange{},
                       [&](OpBuilder &nested, Location, Value k, ValueRange) {
                         OpBuilder::InsertionGuard guard(b);
                         b.setInsertionPoint(scf::YieldOp::create(nested, loc));
                         body(k);
                       });
  }

  /// Rotates entries (p, k), (q, k) of `m` for every k when `rows`, else
  /// entries (k, p), (k, q): x' = c x - s y, y' = s x + c y.
  void rotate(Value m, int64_t n, Value p, Value q, Value c, Value s,
              bool rows) {
    loop(n, [&](Value k) {
      Value x = rows ? load(m, p, k) : load(m, k, p);
      Value y = rows ? load(m, q, k) : load(m, k, q);
      Value nx = sub(mul(c, x), mul(s, y));
      Value ny = add(mul(s, x), mul(c, y));
      if (rows) {
        store(nx, m, p, k);
        store(ny, m, q, k);
      } else {
        store(nx, m, k, p);
        store(ny, m, k, q);
      }
    });
  }

  /// For j in [lb, ub): rotates the entries at(j) = ((r1, c1), (r2, c2)) of
  /// m: x' = c x - s y, y' = s x + c y.
  template <typename At>
  void rotateRange(Value m, Value lb, Value ub, Value c, Value s, At at) {
    scf::ForOp::create(b, loc, lb, ub, idx(1), ValueRange{},
                       [&](OpBuilder &nested, Location, Value j, ValueRange) {
                         OpBuilder::InsertionGuard guard(b);
                         b.setInsertionPoint(scf::YieldOp::create(nested, loc));
                         auto [first, second] = at(j);
                         Value x = load(m, first.first, first.second);
                         Value y = load(m, second.first, second.second);
                         store(sub(mul(c, x), mul(s, y)), m, first.first,
                               first.second);
                         store(add(mul(s, x), mul(c, y)), m, second.first,
                               second.second);
                       });
  }

  /// One Jacobi rotation annihilating entry (p, q) of `a`, accumulated in v.
  /// Returns an i1 that is true if a rotation was needed.
  Value annihilate(Value a, Value v, int64_t n, Value p, Value q) {
    Value apq = load(a, p, q), app = load(a, p, p), aqq = load(a, q, q);
    // Numerical Recipes' test: the entry no longer changes either diagonal
    // entry it couples, so it is set to zero instead of rotated.
    Value g = mul(cst(100.0), abs(apq));
    Value negligible = arith::AndIOp::create(
        b, loc, eq(add(abs(app), g), abs(app)), eq(add(abs(aqq), g), abs(aqq)));
    auto ifOp = scf::IfOp::create(b, loc, TypeRange{b.getI1Type()}, negligible,
                                  /*withElseRegion=*/true);
    {
      OpBuilder::InsertionGuard guard(b);
      b.setInsertionPointToStart(ifOp.thenBlock());
      store(cst(0.0), a, p, q);
      store(cst(0.0), a, q, p);
      scf::YieldOp::create(b, loc, flag(false));
      b.setInsertionPointToStart(ifOp.elseBlock());
      Value theta = div(sub(aqq, app), mul(cst(2.0), apq));
      Value absTheta = abs(theta);
      // t = sign(theta) / (|theta| + sqrt(theta^2 + 1)); for huge theta the
      // square would overflow and t = 1 / (2 theta) is exact enough.
      Value root =
          math::SqrtOp::create(b, loc, add(mul(theta, theta), cst(1.0)));
      Value sign = math::CopySignOp::create(b, loc, cst(1.0), theta);
      Value tSmall = div(sign, add(absTheta, root));
      Value tHuge = div(cst(1.0), mul(cst(2.0), theta));
      Value huge = arith::CmpFOp::create(b, loc, arith::CmpFPredicate::OGT,
                                         absTheta, cst(1e150));
      Value t = arith::SelectOp::create(b, loc, huge, tHuge, tSmall);
      Value c =
          div(cst(1.0), math::SqrtOp::create(b, loc, add(mul(t, t), cst(1.0))));
      Value s = mul(t, c);
      // Only the upper triangle of a is kept (p < q everywhere): the
      // diagonal moves by t * apq, entry (p, q) vanishes, and the other
      // entries of rows/columns p and q rotate in three ranges.
      Value h = mul(t, apq);
      store(sub(app, h), a, p, p);
      store(add(aqq, h), a, q, q);
      store(cst(0.0), a, p, q);
      Value p1 = arith::AddIOp::create(b, loc, p, idx(1));
      Value q1 = arith::AddIOp::create(b, loc, q, idx(1));
      rotateRange(a, idx(0), p, c, s, [&](Value j) {
        return std::make_pair(std::make_pair(j, p), std::make_pair(j, q));
      });
      rotateRange(a, p1, q, c, s, [&](Value j) {
        return std::make_pair(std::make_pair(p, j), std::make_pair(j, q));
      });
      rotateRange(a, q1, idx(n), c, s, [&](Value j) {
        return std::make_pair(std::make_pair(p, j), std::make_pair(q, j));
      });
      rotate(v, n, p, q, c, s, /*rows=*/false);
      scf::YieldOp::create(b, loc, flag(true));
    }
    return ifOp.getResult(0);
  }

  Value flag(bool value) {
    return arith::ConstantOp::create(b, loc, b.getBoolAttr(value));
  }

  /// for k in [lb, ub) with one i1 carried value: body(k, carried) -> i1.
  template <typename Fn>
  Value loopCarrying(Value lb, Value ub, Value init, Fn body) {
    auto forOp = scf::ForOp::create(
        b, loc, lb, ub, idx(1), ValueRange{init},
        [&](OpBuilder &nested, Location, Value k, ValueRange carried) {
          OpBuilder::InsertionGuard guard(b);
          b.setInsertionPoint(nested.getInsertionBlock(),
                              nested.getInsertionPoint());
          Value next = body(k, carried[0]);
          scf::YieldOp::create(b, loc, next);
        });
    return forOp.getResult(0);
  }

  /// One cyclic sweep over the upper triangle; true if anything rotated.
  Value sweep(Value a, Value v, int64_t n) {
    return loopCarrying(idx(0), idx(n), flag(false), [&](Value p, Value any) {
      Value next = arith::AddIOp::create(b, loc, p, idx(1));
      return loopCarrying(next, idx(n), any, [&](Value q, Value anyInner) {
        Value rotated = annihilate(a, v, n, p, q);
        return Value(arith::OrIOp::create(b, loc, anyInner, rotated));
      });
    });
  }
};
} // namespace

/// The Jacobi projection of the symmetric matrix `sym` (row-major scalars),
/// emitted at the builder's insertion point; returns the column-major
/// entries of the result.
static SmallVector<Value> jacobiProjection(OpBuilder &b, Location loc,
                                           ProjectionMethod method,
                                           ArrayRef<Value> sym, int64_t n,
                                           FloatType type) {
  JacobiBuilder j{b, loc, type};

  auto squareType = MemRefType::get({n, n}, type);
  Value a, v;
  {
    OpBuilder::InsertionGuard guard(b);
    Operation *func = b.getInsertionBlock()->getParentOp();
    while (!isa<FunctionOpInterface>(func))
      func = func->getParentOp();
    b.setInsertionPointToStart(&func->getRegion(0).front());
    a = memref::AllocaOp::create(b, loc, squareType);
    v = memref::AllocaOp::create(b, loc, squareType);
  }
  // The matrix and the identity.
  for (int64_t r = 0; r < n; ++r)
    for (int64_t c = 0; c < n; ++c) {
      j.store(sym[r * n + c], a, j.idx(r), j.idx(c));
      j.store(j.cst(r == c ? 1.0 : 0.0), v, j.idx(r), j.idx(c));
    }

  // Sweep until a sweep rotates nothing (or the sweep limit).
  j.loopCarrying(
      j.idx(0), j.idx(kMaxSweeps), j.flag(true), [&](Value, Value active) {
        auto ifOp =
            scf::IfOp::create(b, loc, TypeRange{b.getI1Type()}, active, true);
        OpBuilder::InsertionGuard guard(b);
        b.setInsertionPointToStart(ifOp.thenBlock());
        scf::YieldOp::create(b, loc, j.sweep(a, v, n));
        b.setInsertionPointToStart(ifOp.elseBlock());
        scf::YieldOp::create(b, loc, j.flag(false));
        return ifOp.getResult(0);
      });

  // The result is V diag(f(lambda)) V^T with lambda the diagonal of a and
  // f = max(., 0) or |.|; first W = V diag(f(lambda)), overwriting a.
  j.loop(n, [&](Value i) {
    Value l = j.load(a, i, i);
    Value f = method == ProjectionMethod::abs
                  ? j.abs(l)
                  : Value(arith::MaximumFOp::create(b, loc, l, j.cst(0.0)));
    j.loop(n, [&](Value r) { j.store(j.mul(j.load(v, r, i), f), a, r, i); });
  });
  // Entries of W V^T, loaded as scalars (a now holds W).
  SmallVector<Value> out;
  for (int64_t c = 0; c < n; ++c)
    for (int64_t r = 0; r < n; ++r) {
      auto sum = scf::ForOp::create(
          b, loc, j.idx(0), j.idx(n), j.idx(1), ValueRange{j.cst(0.0)},
          [&](OpBuilder &nested, Location, Value i, ValueRange acc) {
            OpBuilder::InsertionGuard guard(b);
            b.setInsertionPoint(nested.getInsertionBlock(),
                                nested.getInsertionPoint());
            Value term = j.mul(j.load(a, j.idx(r), i), j.load(v, j.idx(c), i));
            scf::YieldOp::create(b, loc, j.add(acc[0], term));
          });
      out.push_back(sum.getResult(0));
    }
  return out;
}

/// True (i1) if the symmetric matrix `sym` (row-major) is positive definite:
/// every pivot of its LDL^T factorisation is positive (NaN is not).
static Value isPositiveDefinite(OpBuilder &b, Location loc,
                                ArrayRef<Value> sym, int64_t n,
                                FloatType type) {
  JacobiBuilder j{b, loc, type};
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
  auto type = cast<FloatType>(in.values.front().getType());
  JacobiBuilder j{b, loc, type};
  // The symmetric part of the input (Hessians are symmetric up to rounding).
  SmallVector<Value> sym(n * n);
  for (int64_t r = 0; r < n; ++r)
    for (int64_t c = 0; c < n; ++c)
      sym[r * n + c] =
          r == c ? in.at(r, c)
                 : j.mul(j.cst(0.5), j.add(in.at(r, c), in.at(c, r)));
  // Most local Hessians are already positive definite: an LDL^T test (n^3/3
  // operations) skips the eigen-decomposition for them.
  Value definite = isPositiveDefinite(b, loc, sym, n, type);
  SmallVector<Type> resultTypes(n * n, type);
  auto ifOp = scf::IfOp::create(b, loc, resultTypes, definite,
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
    scf::YieldOp::create(b, loc,
                         jacobiProjection(b, loc, method, sym, n, type));
  }
  ScalarMatrix result{n, n, {}};
  result.values.append(ifOp.getResults().begin(), ifOp.getResults().end());
  return result;
}
