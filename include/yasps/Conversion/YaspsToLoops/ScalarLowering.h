//===- ScalarLowering.h - yasps expressions as scalar arithmetic -*- C++
//-*-===//
//
// Kernels work on small matrices entry by entry: a per-instance matrix becomes
// rows*cols SSA scalars (column-major), and every yasps expression op becomes
// arith/math ops on them. Matrix-level ops (det, inverse, matmul, ...) are
// expanded here, as late as possible, so that everything before kernel
// generation stays matrix-level.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_CONVERSION_YASPSTOLOOPS_SCALARLOWERING_H
#define YASPS_CONVERSION_YASPSTOLOOPS_SCALARLOWERING_H

#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "mlir/IR/Builders.h"
#include "mlir/IR/Value.h"
#include "llvm/ADT/SmallVector.h"

namespace mlir::yasps {

/// Scalar operations one kernel may emit per instance (or lane group):
/// five times the largest kernel of the tests and the paper's scenes (a
/// point-edge barrier Hessian, 107k), and few enough that lowering takes
/// seconds, not minutes (a 1M-operation product took 5 s). Past it,
/// yasps-lower-to-loops stops with an error on the op that crossed it.
inline constexpr int64_t kMaxKernelOperations = int64_t(1) << 19;

/// A per-instance matrix held as SSA scalars in column-major order.
struct ScalarMatrix {
  int64_t rows = 0;
  int64_t cols = 0;
  SmallVector<Value> values;

  Value at(int64_t r, int64_t c) const { return values[c * rows + r]; }
};

/// Emits the scalar arithmetic of the yasps expression `op` (every op but
/// `yasps.read`, `yasps.join` and `yasps.union`, which need the kernel's
/// buffers) given its operands. Reports an error on `op` and fails for ops
/// that kernels do not support. With `symbolicZeros` (derivative kernels),
/// products with a literal 0 are 0 and with a literal 1 are the other
/// factor, without IEEE's special cases for infinities and NaN. With
/// `lanes` > 1 the operands' entries are vectors of that many instances
/// (SIMD lanes), and so are the results.
FailureOr<ScalarMatrix> lowerToScalars(OpBuilder &b, Operation *op,
                                       ArrayRef<ScalarMatrix> operands,
                                       bool symbolicZeros = false,
                                       int64_t lanes = 1);

/// PSD projection of the symmetric matrix `in` (tridiagonal QL
/// eigen-decomposition, eigenvalues clamped or made absolute); `none`
/// returns `in`.
ScalarMatrix lowerProjection(OpBuilder &b, Location loc,
                             ProjectionMethod method, const ScalarMatrix &in);

} // namespace mlir::yasps

#endif // YASPS_CONVERSION_YASPSTOLOOPS_SCALARLOWERING_H
