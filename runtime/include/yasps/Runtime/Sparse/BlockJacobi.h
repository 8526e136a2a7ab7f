//===- BlockJacobi.h - the block-Jacobi preconditioner ----------*- C++ -*-===//
//
// PCG's default preconditioner (the paper's appendix D), and the smoother of
// every level of the multilevel one (Multilevel.h): the inverses of the
// Hessian's diagonal blocks, which capture the strong coupling inside each
// DoF group at little cost.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SPARSE_BLOCKJACOBI_H
#define YASPS_RUNTIME_SPARSE_BLOCKJACOBI_H

#include "yasps/Runtime/Sparse/BlockSparseMatrix.h"

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

namespace yasps::runtime {

class ThreadPool;

/// A matrix kept as the sum of parts with one block layout (the static and
/// dynamic parts of a Hessian, paper section 10.6).
using HessianParts = std::vector<const BlockSparseMatrix *>;

/// The inverses of the diagonal blocks of the sum of `parts` restricted to
/// the free DoFs (see invertDiagonalBlock), each stored whole (size x size,
/// row-major) with zero rows and columns at fixed DoFs, so that applying it
/// also projects onto the free DoFs.
class BlockJacobi {
public:
  /// `fixed`: one entry per DoF, nonzero for a fixed DoF; null: all free.
  BlockJacobi(const HessianParts &parts, const std::uint8_t *fixed,
              ThreadPool &pool);

  /// z = M^-1 r.
  void apply(const double *r, double *z, ThreadPool &pool) const;
  /// apply(), returning r . z from the same pass: the sums of fixed
  /// segments of blocks, added in order (the same on any thread count).
  /// `partial` is scratch.
  double applyDot(const double *r, double *z, std::vector<double> &partial,
                  ThreadPool &pool) const;

  /// r . r and r . z after a CG step.
  struct StepDots {
    double rr, rz;
  };
  /// PCG's step and preconditioner in one pass over the blocks: on each
  /// block x += alpha p and r -= alpha q, then z = M^-1 r. The dots are sums
  /// of fixed segments of blocks added in order, as in applyDot. One pass
  /// instead of two over r, and no second hand-off to the pool.
  StepDots stepApplyDots(double alpha, const double *p, const double *q,
                         double *x, double *r, double *z,
                         std::vector<double> &partial, ThreadPool &pool) const;

  /// stepApplyDots split among threads that the caller runs (PCG's team):
  /// the blocks fall into numSegments() fixed segments; stepSegments does
  /// the pass on segments [begin, end) and stores each segment s's r . r and
  /// r . z at partial[2 s] and partial[2 s + 1]. Those partials added in
  /// segment order are stepApplyDots' dots, bit for bit.
  std::int64_t numSegments() const;
  void stepSegments(std::int64_t begin, std::int64_t end, double alpha,
                    const double *p, const double *q, double *x, double *r,
                    double *z, double *partial) const;

  /// The largest over the smallest diagonal entry of H on the free DoFs
  /// (inf if one is <= 0, NaN if there is none), taken before inverting.
  double diagonalRatio() const { return diagonalRatio_; }

  /// An upper bound on the eigenvalues of M^-1 A over the free DoFs, A the
  /// sum of `parts` (whose diagonal blocks made M): the largest row sum of
  /// |M^-1 A|, each part's blocks counted apart. A norm bounds every
  /// eigenvalue, where a few Lanczos steps may miss the largest: a contact
  /// pair's stiff local mode, say.
  double eigenvalueBound(const HessianParts &parts,
                         const std::uint8_t *fixed) const;

private:
  /// z = M^-1 r on block b, adding the term of its i-th DoF to r . z to
  /// rz[i % 3] (three running sums, see applyDot).
  void applyBlock(std::int64_t b, const double *r, double *z, double *rz) const;
  /// body(begin, end, sums) on each fixed segment [begin, end) of blocks,
  /// `sums` being NumSums x 3 running sums of the segment; returns the
  /// NumSums totals, each the segments' sums added in order.
  /// body(begin, end, sums) on segments [begin, end), storing segment s's
  /// NumSums sums at partial[s * NumSums + k].
  template <int NumSums, typename Body>
  void sumSegments(std::int64_t begin, std::int64_t end, double *partial,
                   Body body) const;
  /// stepApplyDots' pass over blocks [begin, end), adding to sums[0] (r . r)
  /// and sums[1] (r . z).
  void stepBlocks(std::int64_t begin, std::int64_t end, double alpha,
                  const double *p, const double *q, double *x, double *r,
                  double *z, double (*sums)[3]) const;
  template <int NumSums, typename Body>
  std::array<double, NumSums> sumOverBlockRanges(std::vector<double> &partial,
                                                 ThreadPool &pool,
                                                 Body body) const;
  void measureDiagonal(const std::uint8_t *fixed);

  BlockLayout layout_;
  std::vector<double> inverse_;
  std::vector<std::size_t> start_;
  /// Whether every block is 3x3 (vertices only), for stepApplyDots.
  bool allVertexBlocks_ = false;
  double diagonalRatio_ = std::numeric_limits<double>::quiet_NaN();
};

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SPARSE_BLOCKJACOBI_H
