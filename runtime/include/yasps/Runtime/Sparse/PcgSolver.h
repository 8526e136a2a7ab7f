//===- PcgSolver.h - PCG that keeps its preconditioner ----------*- C++ -*-===//
//
// A Newton loop solves H x = b once per iteration on a Hessian whose values
// change every time and whose structure changes only when the collision set
// does. Building the multilevel preconditioner's aggregation and coarse
// structures (paper section 10.7) costs more than refreshing their values,
// so a PcgSolver keeps them from one solve to the next. It is apart from the
// assembled system (GlobalSystem): assembling and solving are separate jobs,
// and one system may be solved by several solvers or none.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SPARSE_PCGSOLVER_H
#define YASPS_RUNTIME_SPARSE_PCGSOLVER_H

#include "yasps/Runtime/Sparse/Multilevel.h"
#include "yasps/Runtime/Sparse/Pcg.h"

#include <memory>
#include <mutex>

namespace yasps::runtime {

/// Solves H x = b (H the sum of `parts`) by solvePcg, keeping the multilevel
/// preconditioner between solves: it is refreshed when H's structure and the
/// multilevel options are those of the last solve, and rebuilt otherwise.
/// Solves on one solver are serialised (a lock), so one solver may be shared
/// between threads; a block-Jacobi solve keeps nothing.
class PcgSolver {
public:
  /// Same contract as solvePcg. A multilevelCache given in `options` is used
  /// instead of the solver's own.
  PcgResult solve(const HessianParts &parts, const double *b, double *x,
                  const PcgOptions &options, ThreadPool &pool);

  /// Whether a multilevel preconditioner is kept for the next solve.
  bool keepsPreconditioner() const;
  /// Drops the kept preconditioner; the next multilevel solve builds one.
  void forget();

private:
  std::unique_ptr<Multilevel> multilevel_;
  mutable std::mutex mutex_;
};

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SPARSE_PCGSOLVER_H
