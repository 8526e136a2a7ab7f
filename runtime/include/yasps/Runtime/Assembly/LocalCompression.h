//===- LocalCompression.h - compressing local Hessians ----------*- C++ -*-===//
//
// Before a local Hessian is projected (paper section 7.2), the rows and
// columns of parameters that map to the same global DoF are merged (summed)
// and those of no DoF (the zero padding of inactive UNION branches) are
// dropped: the projection then works on the k x k matrix that the instance
// really adds to the global Hessian, k <= n. Instances are grouped by k so
// that one projection kernel per size runs over each group; the projected
// k x k matrices are then expanded back to n x n with each merged entry at
// the first parameter of its DoF (zeros elsewhere), which assembles to the
// same global matrix.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_ASSEMBLY_LOCALCOMPRESSION_H
#define YASPS_RUNTIME_ASSEMBLY_LOCALCOMPRESSION_H

#include <cstdint>
#include <vector>

namespace yasps::runtime {

/// The instances of one compressed size.
struct CompressedBatch {
  std::int64_t size = 0;               ///< k
  std::vector<std::int64_t> instances; ///< in increasing order
  std::vector<double> matrices;        ///< instances x k x k, row-major
};

/// The compressed size of instance i: the number of distinct DoFs >= 0
/// among its n parameters.
std::int64_t compressedSize(std::int64_t n, const std::int64_t *dofs);

/// Compresses the local Hessians (count x n x n, row-major) of an energy
/// with DoF maps `dofs` (count x n, -1 for none), grouped by compressed
/// size, in increasing size. Within an instance, compressed row c is the
/// c-th distinct DoF in parameter order.
std::vector<CompressedBatch> compressLocalHessians(std::int64_t count,
                                                   std::int64_t n,
                                                   const std::int64_t *dofs,
                                                   const double *hessians);

/// Writes `projected` (batch.instances x k x k) back into `out` (count x n
/// x n): every instance of the batch is first zeroed, then each compressed
/// entry goes to the first parameters of its row's and column's DoFs.
void expandLocalHessians(std::int64_t count, std::int64_t n,
                         const std::int64_t *dofs, const CompressedBatch &batch,
                         const double *projected, double *out);

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_ASSEMBLY_LOCALCOMPRESSION_H
