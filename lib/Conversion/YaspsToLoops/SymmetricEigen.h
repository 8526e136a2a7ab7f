//===- SymmetricEigen.h - symmetric eigen-decomposition in kernels --------===//

#ifndef YASPS_LIB_CONVERSION_YASPSTOLOOPS_SYMMETRICEIGEN_H
#define YASPS_LIB_CONVERSION_YASPSTOLOOPS_SYMMETRICEIGEN_H

#include "ImperativeBuilder.h"

namespace mlir::yasps {

/// Emits the eigen-decomposition of the symmetric n x n matrix held (both
/// triangles) in the buffer `z`: afterwards row i of `z` is the unit
/// eigenvector of the eigenvalue in `d[i]` (eigenvalues unsorted). The
/// method is Householder reduction to tridiagonal form followed by the
/// implicit QL iteration with Wilkinson shifts (EISPACK tred2/tql2), which
/// is backward stable: eigenvalues and the reconstructed matrix are exact to
/// a few ulps of the matrix's norm, whatever the spread of eigenvalues.
void emitSymmetricEigen(ImperativeBuilder &ib, Value z, Value d, int64_t n);

} // namespace mlir::yasps

#endif // YASPS_LIB_CONVERSION_YASPSTOLOOPS_SYMMETRICEIGEN_H
