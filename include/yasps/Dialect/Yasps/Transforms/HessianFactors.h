//===- HessianFactors.h - yasps-differentiate's hessian-factors -*- C++ -*-===//
//
// The values of the `hessian-factors` option, declared once for the pass
// (Passes.td) and the pipeline that runs it (Pipelines.h).
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_DIALECT_YASPS_TRANSFORMS_HESSIANFACTORS_H
#define YASPS_DIALECT_YASPS_TRANSFORMS_HESSIANFACTORS_H

#include "llvm/Support/CommandLine.h"

namespace mlir::yasps {

/// Whether the reduced-space factors of a projected Hessian stay apart:
/// never, always, or where they hold at most half the values of the
/// product ("auto").
enum class HessianFactors { never, always, automatic };

/// The option's spellings, for a pass option or a pipeline option.
inline auto hessianFactorsValues() {
  return llvm::cl::values(
      clEnumValN(HessianFactors::never, "never", "form J^T P J"),
      clEnumValN(HessianFactors::always, "always", "keep J and P apart"),
      clEnumValN(HessianFactors::automatic, "auto",
                 "keep J and P apart where 2 m (n + m) <= n^2"));
}

} // namespace mlir::yasps

#endif // YASPS_DIALECT_YASPS_TRANSFORMS_HESSIANFACTORS_H
