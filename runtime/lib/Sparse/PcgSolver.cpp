//===- PcgSolver.cpp - PCG that keeps its preconditioner ------------------===//

#include "yasps/Runtime/Sparse/PcgSolver.h"

namespace yasps::runtime {

PcgResult PcgSolver::solve(const HessianParts &parts, const double *b,
                           double *x, const PcgOptions &options,
                           ThreadPool &pool) {
  std::lock_guard<std::mutex> lock(mutex_);
  PcgOptions kept = options;
  if (!kept.multilevelCache)
    kept.multilevelCache = &multilevel_;
  return solvePcg(parts, b, x, kept, pool);
}

bool PcgSolver::keepsPreconditioner() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return multilevel_ != nullptr;
}

void PcgSolver::forget() {
  std::lock_guard<std::mutex> lock(mutex_);
  multilevel_.reset();
}

} // namespace yasps::runtime
