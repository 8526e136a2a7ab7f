//===- BlockInverse.h - inverting one block-Jacobi block --------*- C++ -*-===//
//
// The block-Jacobi preconditioner of PCG (the paper's appendix D) inverts
// each diagonal block of the Hessian on its own. The CPU solver (Pcg.cpp)
// and the GPU one (lib/Gpu/SolverKernels.cu, one thread per block) call the
// same function, so both backends precondition alike.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SPARSE_BLOCKINVERSE_H
#define YASPS_RUNTIME_SPARSE_BLOCKINVERSE_H

#include "yasps/Runtime/Support/HostDevice.h"

namespace yasps::runtime {

/// Replaces the s x s diagonal block `block` (row-major, symmetric) by its
/// preconditioner: the inverse of its restriction to the free DoFs (those
/// whose `fixed` entry is 0; `fixed` may be null: all free), with zero rows
/// and columns at fixed DoFs, so that applying it also projects onto the
/// free DoFs. A restriction without a Cholesky factor (not positive
/// definite, or not finite) is replaced by the inverses of its diagonal
/// entries' magnitudes, and by 1 where an entry is 0 or not finite.
///
/// Scratch: `freeDofs` holds s entries, `a` and `l` s * s each.
YASPS_HD inline void invertDiagonalBlock(long long s, double *block,
                                         const unsigned char *fixed,
                                         long long *freeDofs, double *a,
                                         double *l) {
  long long m = 0;
  for (long long i = 0; i < s; ++i)
    if (!fixed || !fixed[i])
      freeDofs[m++] = i;
  for (long long i = 0; i < m; ++i)
    for (long long j = 0; j < m; ++j)
      a[i * m + j] = block[freeDofs[i] * s + freeDofs[j]];
  for (long long i = 0; i < s * s; ++i)
    block[i] = 0.0;

  // Cholesky A = L L^T, lower triangle of l, but with 1 / L_jj on the
  // diagonal: the substitutions below multiply by it. With divisions, the
  // 3x3 blocks' inversion took about 6% of a bunny solve of 55 iterations.
  for (long long i = 0; i < m * m; ++i)
    l[i] = 0.0;
  bool ok = true;
  for (long long j = 0; j < m && ok; ++j) {
    double d = a[j * m + j];
    for (long long k = 0; k < j; ++k)
      d -= l[j * m + k] * l[j * m + k];
    // `!(d > 0)` also catches NaN.
    if (!(d > 0.0) || !hdIsFinite(d)) {
      ok = false;
      break;
    }
    double inverseLjj = 1.0 / hdSqrt(d);
    l[j * m + j] = inverseLjj;
    for (long long i = j + 1; i < m; ++i) {
      double v = a[i * m + j];
      for (long long k = 0; k < j; ++k)
        v -= l[i * m + k] * l[j * m + k];
      l[i * m + j] = v * inverseLjj;
    }
  }
  if (!ok) {
    for (long long i = 0; i < m; ++i) {
      double d = hdFabs(a[i * m + i]);
      block[freeDofs[i] * s + freeDofs[i]] =
          d > 0.0 && hdIsFinite(d) ? 1.0 / d : 1.0;
    }
    return;
  }
  // Column `col` of A^-1 solves L L^T y = e_col; `a` is reused for y.
  for (long long col = 0; col < m; ++col) {
    double *y = a;
    for (long long i = 0; i < m; ++i) {
      double v = i == col ? 1.0 : 0.0;
      for (long long k = 0; k < i; ++k)
        v -= l[i * m + k] * y[k];
      y[i] = v * l[i * m + i];
    }
    for (long long i = m - 1; i >= 0; --i) {
      double v = y[i];
      for (long long k = i + 1; k < m; ++k)
        v -= l[k * m + i] * y[k];
      y[i] = v * l[i * m + i];
    }
    for (long long i = 0; i < m; ++i)
      block[freeDofs[i] * s + freeDofs[col]] = y[i];
  }
}

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SPARSE_BLOCKINVERSE_H
