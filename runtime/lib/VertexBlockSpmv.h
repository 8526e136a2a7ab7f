//===- VertexBlockSpmv.h - SIMD product of 3x3 blocks -----------*- C++ -*-===//
//
// Private to BlockSparseMatrix.cpp: the storage-order SpMV of a run of 3x3
// upper blocks, and the transposed products into one row, with AVX2 where
// the CPU has it.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_LIB_VERTEXBLOCKSPMV_H
#define YASPS_RUNTIME_LIB_VERTEXBLOCKSPMV_H

#include <climits>
#include <cstddef>
#include <cstdint>

namespace yasps::runtime::detail {

/// A `limit` of multiplyVertexBlocksAvx2 that no column reaches.
constexpr std::int64_t kNoLimit = INT64_MAX;

/// Whether this CPU runs multiplyVertexBlocksAvx2.
bool hasVertexBlockSimd();

/// y_r += B x_c and, off the diagonal and for c < limit, y_c += B^T x_r
/// for the `count` 3x3 row-major blocks at `data` (rows consecutive),
/// block b at (row[b], col[b]) with DoF offsets `offset`. Adds the same terms
/// in the same order as the scalar loop, one vector lane per row or column of a
/// block, so the results are identical to the last bit. T, the blocks' type, is
/// double or float (f32 blocks are widened exactly to f64 as they load).
void multiplyVertexBlocksAvx2(const double *data, const std::int64_t *row,
                              const std::int64_t *col,
                              const std::int64_t *offset, std::size_t count,
                              std::int64_t limit, const double *x, double *y);
void multiplyVertexBlocksAvx2(const float *data, const std::int64_t *row,
                              const std::int64_t *col,
                              const std::int64_t *offset, std::size_t count,
                              std::int64_t limit, const double *x, double *y);

/// y_c += B^T x_r for the `count` 3x3 blocks `blocks` (indices, block b
/// at values + 9 (b - first), at (row[b], col[b])), in order. Same order
/// as the scalar products. Blocks in f64 or f32, as above.
void addTransposedVertexBlocksAvx2(const double *values, std::size_t first,
                                   const std::size_t *blocks, std::size_t count,
                                   const std::int64_t *row,
                                   const std::int64_t *col,
                                   const std::int64_t *offset, const double *x,
                                   double *y);
void addTransposedVertexBlocksAvx2(const float *values, std::size_t first,
                                   const std::size_t *blocks, std::size_t count,
                                   const std::int64_t *row,
                                   const std::int64_t *col,
                                   const std::int64_t *offset, const double *x,
                                   double *y);

} // namespace yasps::runtime::detail

#endif // YASPS_RUNTIME_LIB_VERTEXBLOCKSPMV_H
