//===- Pcg.h - block-Jacobi preconditioned conjugate gradient ---*- C++ -*-===//
//
// The Newton step's linear solve (the paper's appendix D): conjugate
// gradient on the block-sparse Hessian, preconditioned by the inverses of
// its diagonal blocks, which capture the strong coupling inside each DoF
// group at little cost.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_PCG_H
#define YASPS_RUNTIME_PCG_H

#include <cstdint>
#include <vector>

namespace yasps::runtime {

class BlockSparseMatrix;
class ThreadPool;

struct PcgOptions {
  /// Stop once ||r|| <= relativeTolerance * ||b|| (2-norms over the free
  /// DoFs, r the residual that CG updates as it goes).
  double relativeTolerance = 1e-6;
  std::int64_t maxIterations = 1000;
  /// Optional mask of size H.size(): a nonzero entry fixes that DoF, whose
  /// solution is 0 and whose row and column of H are ignored (the solve runs
  /// on the free DoFs only). Not owned.
  const std::vector<std::uint8_t> *fixedDofs = nullptr;
};

struct PcgResult {
  /// Number of CG updates of x.
  std::int64_t iterations;
  /// ||r|| / ||b|| at the end (0 if b is 0 on the free DoFs); NaN if b or H
  /// holds a NaN or infinity or the iteration broke down.
  double relativeResidual;
  bool converged;
};

/// Throws std::invalid_argument if `options` do not fit a matrix of `size`
/// DoFs: a fixed-DoF mask of another size, maxIterations < 0 or a negative
/// or NaN tolerance.
void checkPcgOptions(const PcgOptions &options, std::int64_t size);

/// Solves H x = b from x = 0 by block-Jacobi preconditioned CG. `b` and `x`
/// hold H.size() values. H must be symmetric positive definite on the free
/// DoFs; a diagonal block whose free part has no Cholesky factor (not
/// positive definite) is preconditioned by the inverses of its diagonal
/// entries' magnitudes instead, and by 1 where an entry is 0.
///
/// Never fails silently: stopping at maxIterations, a breakdown (p^T H p <=
/// 0), or non-finite input is reported with converged = false, x holding the
/// last iterate (0 for non-finite input). Throws std::invalid_argument if
/// the fixed-DoF mask's size is not H.size(), maxIterations is negative or
/// the tolerance is negative or NaN.
PcgResult solvePcg(const BlockSparseMatrix &H, const double *b, double *x,
                   const PcgOptions &options, ThreadPool &pool);

/// A matrix kept as the sum of parts with one block layout (the static and
/// dynamic parts of a Hessian, paper section 10.6).
using HessianParts = std::vector<const BlockSparseMatrix *>;

/// solvePcg on H = the sum of `parts`; the preconditioner inverts the sums
/// of their diagonal blocks. Also throws std::invalid_argument if there is
/// no part or the parts' layouts differ.
PcgResult solvePcg(const HessianParts &parts, const double *b, double *x,
                   const PcgOptions &options, ThreadPool &pool);

/// y = (sum of parts) x; `scratch` holds one part's product.
void multiplySum(const HessianParts &parts, const double *x, double *y,
                 std::vector<double> &scratch, ThreadPool &pool);

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_PCG_H
