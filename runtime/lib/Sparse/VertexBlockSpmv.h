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

/// A `limitDof` of multiplyVertexBlocksAvx2 that no column reaches.
constexpr std::int64_t kNoLimit = INT64_MAX;

/// Whether this CPU runs multiplyVertexBlocksAvx2.
bool hasVertexBlockSimd();

/// y_r += B x_c and, off the diagonal and for columns whose DoFs start
/// below `limitDof`, y_c += B^T x_r, for the 3x3 row-major blocks of block
/// rows [rowBegin, rowEnd): row r's blocks are [rowStart[r], rowStart[r+1])
/// and lie consecutively from `data`, block b's column starting at DoF
/// colDof[b], row r's at offset[r]. Adds the same terms in the same order
/// as the scalar loop, one vector lane per row or column of a block, so the
/// results are identical to the last bit. The blocks are double or float
/// (f32 blocks are widened exactly to f64 as they load).
void multiplyVertexBlocksAvx2(const double *data, const std::size_t *rowStart,
                              std::int64_t rowBegin, std::int64_t rowEnd,
                              const std::int32_t *colDof,
                              const std::int64_t *offset, std::int64_t limitDof,
                              const double *x, double *y);
void multiplyVertexBlocksAvx2(const float *data, const std::size_t *rowStart,
                              std::int64_t rowBegin, std::int64_t rowEnd,
                              const std::int32_t *colDof,
                              const std::int64_t *offset, std::int64_t limitDof,
                              const double *x, double *y);

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
