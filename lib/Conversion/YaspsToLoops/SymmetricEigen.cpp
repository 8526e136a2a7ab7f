//===- SymmetricEigen.cpp - tridiagonal QL eigen-decomposition in kernels -===//
//
// The classic two-phase dense symmetric eigensolver (Wilkinson & Reinsch's
// tred2 and tql2, as in EISPACK and JAMA), emitted as kernel code:
//
//  1. Householder reflections reduce the matrix to tridiagonal form and are
//     accumulated into an orthogonal matrix Q (about 8n^3/3 operations).
//  2. The implicit QL iteration with Wilkinson shifts diagonalises the
//     tridiagonal matrix, rotating Q's columns into eigenvectors; each
//     eigenvalue converges cubically, in one to three iterations typically.
//
// Compared with cyclic Jacobi (several sweeps of n^2/2 rotations, each
// touching 4n entries plus a square root and divisions) this does a few
// times fewer operations on local Hessians, and its rotations run over
// contiguous rows. Both are backward stable, which is the accuracy the
// projection needs (the result is exact to a few ulps of the matrix norm).
//
// The outer loops are unrolled at compile time (n is a constant of the
// kernel), so every inner loop has constant or nearly constant bounds.
// The eigenvectors are kept as the rows of `z`: the buffer holds V^T, where
// the algorithm's V has the eigenvectors as columns.
//
//===----------------------------------------------------------------------===//

#include "SymmetricEigen.h"

#include <cmath>

using namespace mlir;
using namespace mlir::yasps;

// QL iterations per eigenvalue before giving up (LAPACK allows 30 per
// eigenvalue too); only NaN or infinite input gets near it.
static constexpr int64_t kMaxIterations = 30;

namespace {
struct EigenEmitter {
  ImperativeBuilder &ib;
  Value z, d, e;
  int64_t n;

  // V(r, c) of the algorithm is z[c][r].
  Value v(Value r, Value c) { return ib.at(z, c, r); }
  void setV(Value x, Value r, Value c) { ib.put(x, z, c, r); }
  Value idx(int64_t i) { return ib.idx(i); }

  void tridiagonalise();
  void diagonalise();
};
} // namespace

void EigenEmitter::tridiagonalise() {
  ImperativeBuilder &b = ib;
  Value scale = b.variable(), h = b.variable(), f = b.variable(),
        g = b.variable();
  Value last = idx(n - 1);
  b.forRange(0, n, [&](Value j) { b.put(v(last, j), d, j); });

  // Reflections eliminate row i left of the subdiagonal, for i = n-1 .. 1.
  for (int64_t i = n - 1; i > 0; --i) {
    Value row = idx(i), prev = idx(i - 1);
    b.set(scale, b.cst(0.0));
    b.set(h, b.cst(0.0));
    b.forRange(0, i, [&](Value k) {
      b.set(scale, b.add(b.get(scale), b.abs(b.at(d, k))));
    });
    b.ifThenElse(
        b.eq(b.get(scale), b.cst(0.0)),
        [&] {
          // Already tridiagonal in this row: nothing to reflect.
          b.put(b.at(d, prev), e, row);
          b.forRange(0, i, [&](Value j) {
            b.put(v(prev, j), d, j);
            setV(b.cst(0.0), row, j);
            setV(b.cst(0.0), j, row);
          });
        },
        [&] {
          // The Householder vector, scaled to avoid over/underflow.
          b.forRange(0, i, [&](Value k) {
            Value dk = b.div(b.at(d, k), b.get(scale));
            b.put(dk, d, k);
            b.set(h, b.add(b.get(h), b.mul(dk, dk)));
          });
          Value f0 = b.at(d, prev);
          Value root = b.sqrt(b.get(h));
          Value g0 = b.select(b.gt(f0, b.cst(0.0)), b.neg(root), root);
          b.put(b.mul(b.get(scale), g0), e, row);
          b.set(h, b.sub(b.get(h), b.mul(f0, g0)));
          b.put(b.sub(f0, g0), d, prev);
          b.forRange(0, i, [&](Value j) { b.put(b.cst(0.0), e, j); });
          // e = A u (lower triangle of the leading i x i block).
          b.forRange(0, i, [&](Value j) {
            Value fj = b.at(d, j);
            setV(fj, j, row);
            b.set(g, b.add(b.at(e, j), b.mul(v(j, j), fj)));
            b.forRange(b.iadd(j, idx(1)), row, [&](Value k) {
              Value vkj = v(k, j);
              b.set(g, b.add(b.get(g), b.mul(vkj, b.at(d, k))));
              b.put(b.add(b.at(e, k), b.mul(vkj, fj)), e, k);
            });
            b.put(b.get(g), e, j);
          });
          // p = A u / h and K = u^T p / 2h; e becomes q = p - K u.
          b.set(f, b.cst(0.0));
          b.forRange(0, i, [&](Value j) {
            Value ej = b.div(b.at(e, j), b.get(h));
            b.put(ej, e, j);
            b.set(f, b.add(b.get(f), b.mul(ej, b.at(d, j))));
          });
          Value hh = b.div(b.get(f), b.add(b.get(h), b.get(h)));
          b.forRange(0, i, [&](Value j) {
            b.put(b.sub(b.at(e, j), b.mul(hh, b.at(d, j))), e, j);
          });
          // A' = A - q u^T - u q^T on the lower triangle.
          b.forRange(0, i, [&](Value j) {
            Value fj = b.at(d, j), gj = b.at(e, j);
            b.forRange(j, row, [&](Value k) {
              Value update =
                  b.add(b.mul(fj, b.at(e, k)), b.mul(gj, b.at(d, k)));
              setV(b.sub(v(k, j), update), k, j);
            });
            b.put(v(prev, j), d, j);
            setV(b.cst(0.0), row, j);
          });
        });
    b.put(b.get(h), d, row);
  }

  // Accumulate the reflections into V.
  for (int64_t i = 0; i < n - 1; ++i) {
    Value col = idx(i), next = idx(i + 1), end = idx(i + 1);
    setV(v(col, col), last, col);
    setV(b.cst(1.0), col, col);
    Value hi = b.at(d, next);
    b.ifThen(b.fcmp(arith::CmpFPredicate::UNE, hi, b.cst(0.0)), [&] {
      b.forRange(idx(0), end,
                 [&](Value k) { b.put(b.div(v(k, next), hi), d, k); });
      b.forRange(idx(0), end, [&](Value j) {
        b.set(g, b.cst(0.0));
        b.forRange(idx(0), end, [&](Value k) {
          b.set(g, b.add(b.get(g), b.mul(v(k, next), v(k, j))));
        });
        Value gj = b.get(g);
        b.forRange(idx(0), end, [&](Value k) {
          setV(b.sub(v(k, j), b.mul(gj, b.at(d, k))), k, j);
        });
      });
    });
    b.forRange(idx(0), end, [&](Value k) { setV(b.cst(0.0), k, next); });
  }
  b.forRange(0, n, [&](Value j) {
    b.put(v(last, j), d, j);
    setV(b.cst(0.0), last, j);
  });
  setV(b.cst(1.0), last, last);
  b.put(b.cst(0.0), e, idx(0));
}

void EigenEmitter::diagonalise() {
  ImperativeBuilder &b = ib;
  b.forRange(1, n, [&](Value i) { b.put(b.at(e, i), e, b.isub(i, idx(1))); });
  b.put(b.cst(0.0), e, idx(n - 1));

  Value f = b.variable(), tst1 = b.variable(), p = b.variable(),
        c = b.variable(), c2 = b.variable(), c3 = b.variable(),
        s = b.variable(), s2 = b.variable();
  Value m = b.variable(b.b.getIndexType());
  Value iter = b.variable(b.b.getIndexType());
  b.set(f, b.cst(0.0));
  b.set(tst1, b.cst(0.0));
  // The unit round-off of the type computed in: 2^-52 in f64, 2^-23 in f32
  // (a tolerance below it would never be met in f32).
  const double eps = std::ldexp(
      1.0, 1 - int(APFloat::semanticsPrecision(b.type.getFloatSemantics())));

  for (int64_t l = 0; l < n; ++l) {
    Value at = idx(l);
    b.set(tst1,
          b.max(b.get(tst1), b.add(b.abs(b.at(d, at)), b.abs(b.at(e, at)))));
    if (l < n - 1) {
      // The first negligible subdiagonal entry at or after l splits off the
      // block l..m, which QL then diagonalises.
      Value tol = b.mul(b.cst(eps), b.get(tst1));
      // m, the end of the block, differs between lanes: it is kept as a
      // float (`mLanes`), the sweep runs to the largest one and each
      // rotation applies where i < m.
      Value mEnd, mLanes, active;
      if (b.lanes > 1) {
        mLanes = b.cst(double(n - 1));
        for (int64_t j = n - 2; j >= l; --j)
          mLanes = b.select(
              b.fcmp(arith::CmpFPredicate::OLE, b.abs(b.at(e, idx(j))), tol),
              b.cst(double(j)), mLanes);
        mEnd = b.floatAsIndex(b.laneMax(mLanes));
        active = b.gt(mLanes, b.cst(double(l)));
      } else {
        b.set(m, at);
        b.doWhile([&] {
          Value mv = b.get(m);
          Value more = b.both(b.icmp(arith::CmpIPredicate::ult, mv, idx(n - 1)),
                              b.gt(b.abs(b.at(e, mv)), tol));
          b.ifThen(more, [&] { b.set(m, b.iadd(mv, idx(1))); });
          return more;
        });
        mEnd = b.get(m);
        active = b.icmp(arith::CmpIPredicate::ugt, mEnd, at);
      }
      b.ifThen(active, [&] {
        b.set(iter, idx(0));
        b.doWhile([&] {
          b.set(iter, b.iadd(b.get(iter), idx(1)));
          // The Wilkinson shift from the leading 2x2 block.
          Value next = idx(l + 1);
          Value g0 = b.at(d, at), el = b.at(e, at);
          Value p0 = b.div(b.sub(b.at(d, next), g0), b.mul(b.cst(2.0), el));
          Value r0 = b.hypot(p0, b.cst(1.0));
          Value pr = b.add(p0, b.select(b.lt(p0, b.cst(0.0)), b.neg(r0), r0));
          Value dl = b.div(el, pr);
          Value dl1 = b.mul(el, pr);
          b.put(dl, d, at);
          b.put(dl1, d, next);
          Value shift = b.sub(g0, dl);
          b.forRange(l + 2, n,
                     [&](Value i) { b.put(b.sub(b.at(d, i), shift), d, i); });
          b.set(f, b.add(b.get(f), shift));

          // The implicit QL sweep from m-1 down to l.
          if (b.lanes > 1) {
            Value dm = b.cst(0.0);
            for (int64_t j = l + 1; j < n; ++j)
              dm =
                  b.select(b.eq(mLanes, b.cst(double(j))), b.at(d, idx(j)), dm);
            b.set(p, dm);
          } else {
            b.set(p, b.at(d, mEnd));
          }
          b.set(c, b.cst(1.0));
          b.set(c2, b.cst(1.0));
          b.set(c3, b.cst(1.0));
          b.set(s, b.cst(0.0));
          b.set(s2, b.cst(0.0));
          Value el1 = b.at(e, next);
          b.forDown(at, mEnd, [&](Value i) {
            auto rotate = [&] {
              Value i1 = b.iadd(i, idx(1));
              Value ci = b.get(c), si = b.get(s), pi = b.get(p);
              b.set(c3, b.get(c2));
              b.set(c2, ci);
              b.set(s2, si);
              Value ei = b.at(e, i), di = b.at(d, i);
              Value gi = b.mul(ci, ei);
              Value hi = b.mul(ci, pi);
              Value r = b.hypot(pi, ei);
              b.put(b.mul(si, r), e, i1);
              // r = 0 only when p = e_i = 0: the identity rotation.
              Value zero = b.eq(r, b.cst(0.0));
              Value inv = b.div(b.cst(1.0), b.select(zero, b.cst(1.0), r));
              Value sn = b.mul(ei, inv);
              Value cn = b.select(zero, b.cst(1.0), b.mul(pi, inv));
              b.set(s, sn);
              b.set(c, cn);
              b.set(p, b.sub(b.mul(cn, di), b.mul(sn, gi)));
              b.put(b.add(hi, b.mul(sn, b.add(b.mul(cn, gi), b.mul(sn, di)))),
                    d, i1);
              // Rotate eigenvector rows i and i+1 of z.
              b.forRange(0, n, [&](Value k) {
                Value zi = b.at(z, i, k), zi1 = b.at(z, i1, k);
                b.put(b.add(b.mul(sn, zi), b.mul(cn, zi1)), z, i1, k);
                b.put(b.sub(b.mul(cn, zi), b.mul(sn, zi1)), z, i, k);
              });
            };
            if (b.lanes > 1)
              b.ifThen(b.lt(b.indexAsFloat(i), mLanes), rotate);
            else
              rotate();
          });
          // el1 / dl1 first: el1 * e_l underflows for matrices near the
          // smallest normal numbers, where the quotient is of order one.
          Value pl = b.mul(b.mul(b.mul(b.neg(b.get(s)), b.get(s2)), b.get(c3)),
                           b.mul(b.div(el1, dl1), b.at(e, at)));
          b.put(b.mul(b.get(s), pl), e, at);
          b.put(b.mul(b.get(c), pl), d, at);
          Value unconverged = b.gt(b.abs(b.at(e, at)), tol);
          Value budget = b.icmp(arith::CmpIPredicate::ult, b.get(iter),
                                idx(kMaxIterations));
          return b.both(unconverged, budget);
        });
      });
    }
    b.put(b.add(b.at(d, at), b.get(f)), d, at);
    b.put(b.cst(0.0), e, at);
  }
}

void mlir::yasps::emitSymmetricEigen(ImperativeBuilder &ib, Value z, Value d,
                                     int64_t n) {
  // Decomposed at entries of magnitude at most 1, the eigenvalues scaled
  // back: near the smallest normal numbers the QL sweep's products fall
  // into subnormals and lose digits (a matrix of norm 1e-300 with repeated
  // eigenvalues was projected 30% off); eigenvectors do not change.
  Value largest = ib.variable();
  ib.set(largest, ib.cst(0.0));
  ib.forRange(0, n, [&](Value r) {
    ib.forRange(0, n, [&](Value c) {
      ib.set(largest, ib.max(ib.get(largest), ib.abs(ib.at(z, r, c))));
    });
  });
  Value scale = ib.select(ib.gt(ib.get(largest), ib.cst(0.0)), ib.get(largest),
                          ib.cst(1.0));
  Value inverse = ib.div(ib.cst(1.0), scale);
  ib.forRange(0, n, [&](Value r) {
    ib.forRange(0, n, [&](Value c) {
      ib.put(ib.mul(ib.at(z, r, c), inverse), z, r, c);
    });
  });
  EigenEmitter emitter{ib, z, d, ib.buffer({n}), n};
  emitter.tridiagonalise();
  emitter.diagonalise();
  ib.forRange(0, n, [&](Value i) { ib.put(ib.mul(ib.at(d, i), scale), d, i); });
}
