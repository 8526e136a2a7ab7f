//===- Pcg.h - preconditioned conjugate gradient ----------------*- C++ -*-===//
//
// The Newton step's linear solve (the paper's appendix D): conjugate
// gradient on the block-sparse Hessian, preconditioned by the inverses of
// its diagonal blocks (BlockJacobi.h), which capture the strong coupling
// inside each DoF group at little cost, or by a V-cycle over coarser
// levels (Multilevel.h), which carries corrections across the mesh.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SPARSE_PCG_H
#define YASPS_RUNTIME_SPARSE_PCG_H

#include "yasps/Runtime/Sparse/BlockJacobi.h"
#include "yasps/Runtime/Sparse/Multilevel.h"

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace yasps::runtime {

class BlockSparseMatrix;
class ThreadPool;

/// When PCG stops on success.
enum class PcgStopping {
  /// ||b - H x|| <= relativeTolerance * ||b||, checked on the residual
  /// recomputed from x (not only the one CG updates as it goes).
  Residual,
  /// The estimated error in the energy norm, ||x* - x||_H, is at most
  /// relativeTolerance * ||x||_H: the Hestenes-Stiefel estimate over
  /// `energyDelay` iterations (Strakos and Tichy 2002), which measures the
  /// step where a stiff part of H makes the residual's 2-norm say little.
  EnergyNorm,
  /// The residual in the preconditioner's inverse norm: r^T M^-1 r <=
  /// relativeTolerance^2 b^T M^-1 b, on the residual CG updates (GIPC's
  /// and the YASPS paper's rule, who compare the squared ratio with their
  /// tolerance: their 1e-4 is a relativeTolerance of 1e-2 here).
  Preconditioned,
};

/// Why PCG stopped.
enum class PcgStop {
  Converged,
  /// maxIterations reached before the tolerance.
  MaxIterations,
  /// p^T H p <= 0: H is not positive definite on the free DoFs.
  Breakdown,
  /// b, H or an iterate holds a NaN or infinity.
  NonFinite,
  /// The residual recomputed from x stays above the tolerance after being
  /// restarted from it twice: the tolerance is below what round-off in this
  /// system allows.
  RoundOff,
};

/// The name of a stop reason ("converged", "max-iterations", ...).
const char *stopName(PcgStop stop);

/// PCG's preconditioner.
enum class PcgPreconditioner {
  /// The inverses of the diagonal blocks (BlockJacobi.h).
  BlockJacobi,
  /// A V-cycle over aggregated coarse levels (Multilevel.h): fewer
  /// iterations at a higher cost per iteration and a setup per solve.
  Multilevel,
};

struct PcgOptions {
  /// See `stopping`; 2-norms over the free DoFs.
  double relativeTolerance = 1e-6;
  std::int64_t maxIterations = 1000;
  PcgStopping stopping = PcgStopping::Residual;
  /// Iterations the energy-norm estimate looks ahead (EnergyNorm only).
  std::int64_t energyDelay = 4;
  /// Optional mask of size H.size(): a nonzero entry fixes that DoF, whose
  /// solution is 0 and whose row and column of H are ignored (the solve runs
  /// on the free DoFs only). Not owned.
  const std::vector<std::uint8_t> *fixedDofs = nullptr;
  PcgPreconditioner preconditioner = PcgPreconditioner::BlockJacobi;
  /// The levels of PcgPreconditioner::Multilevel.
  MultilevelOptions multilevel;
  /// Where the multilevel preconditioner is kept between solves (not
  /// owned; null: built for this solve only). PCG refreshes the one there
  /// when its structure and options match, else builds one there: the
  /// aggregation and the coarse structures are then built once per
  /// structure of H. Solves sharing a cache must not run concurrently.
  std::unique_ptr<Multilevel> *multilevelCache = nullptr;
};

struct PcgResult {
  /// Number of CG updates of x.
  std::int64_t iterations = 0;
  /// ||b - H x|| / ||b||, recomputed from the returned x (0 if b is 0 on the
  /// free DoFs); NaN if b or H holds a NaN or infinity or the iteration
  /// broke down.
  double relativeResidual = 0.0;
  bool converged = false;
  PcgStop stop = PcgStop::Converged;
  /// The estimated relative energy-norm error ||x* - x||_H / ||x||_H of the
  /// iterate `energyDelay` iterations before the last (an upper estimate for
  /// the last); NaN before that many iterations.
  double energyError = std::numeric_limits<double>::quiet_NaN();
  /// sqrt(r^T M^-1 r / b^T M^-1 b) of the last iterate, on the residual CG
  /// updates (what the Preconditioned rule compares with the tolerance).
  double preconditionedResidual = std::numeric_limits<double>::quiet_NaN();
  /// The condition number of the preconditioned matrix M^-1 H that CG's own
  /// coefficients show (the extreme Ritz values of its Lanczos matrix); a
  /// lower estimate, NaN with fewer than two iterations.
  double conditionEstimate = std::numeric_limits<double>::quiet_NaN();
  /// The largest over the smallest diagonal entry of H on the free DoFs: a
  /// lower bound of H's condition number, known before any iteration (inf
  /// if a diagonal entry is <= 0).
  double diagonalRatio = std::numeric_limits<double>::quiet_NaN();
  /// Times the updated residual was replaced by the recomputed one.
  std::int64_t residualReplacements = 0;
  /// The preconditioner's levels: 1 for block-Jacobi.
  std::int64_t levels = 1;
};

/// Throws std::invalid_argument if `options` do not fit a matrix of `size`
/// DoFs: a fixed-DoF mask of another size, maxIterations < 0 or a negative
/// or NaN tolerance.
void checkPcgOptions(const PcgOptions &options, std::int64_t size);

/// Solves H x = b from x = 0 by CG preconditioned as options.preconditioner
/// says (block-Jacobi by default). `b` and `x` hold H.size() values. H must be
/// symmetric positive definite on the free DoFs; a diagonal block whose free
/// part has no Cholesky factor (not positive definite) is preconditioned by the
/// inverses of its diagonal entries' magnitudes instead, and by 1 where an
/// entry is 0.
///
/// Never fails silently: stopping at maxIterations, a breakdown (p^T H p <=
/// 0), non-finite input or a tolerance below round-off is reported with
/// converged = false and its PcgStop, x holding the last iterate (0 for
/// non-finite input). Convergence is only reported once the residual
/// recomputed from x meets the tolerance (Residual stopping); where CG's
/// updated residual drifted from it, CG restarts from the recomputed one.
/// Throws std::invalid_argument if the fixed-DoF mask's size is not H.size(),
/// maxIterations is negative or the tolerance is negative or NaN.
PcgResult solvePcg(const BlockSparseMatrix &H, const double *b, double *x,
                   const PcgOptions &options, ThreadPool &pool);

/// solvePcg on H = the sum of `parts`; the preconditioner inverts the sums
/// of their diagonal blocks. Also throws std::invalid_argument if there is
/// no part or the parts' layouts differ.
PcgResult solvePcg(const HessianParts &parts, const double *b, double *x,
                   const PcgOptions &options, ThreadPool &pool);

/// y = (sum of parts) x; `scratch` holds one part's product.
void multiplySum(const HessianParts &parts, const double *x, double *y,
                 std::vector<double> &scratch, ThreadPool &pool);

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SPARSE_PCG_H
