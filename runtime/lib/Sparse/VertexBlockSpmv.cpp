//===- VertexBlockSpmv.cpp - SIMD product of 3x3 blocks -------------------===//
//
// Vertex blocks dominate IPC Hessians, and their scalar product is bound by
// instruction count, not memory. Here one AVX2 vector holds a block's row
// (for B^T x_r, a sum of rows times broadcast entries of x_r) or, after an
// in-register transpose, its column (for B x_c). Multiplications and
// additions stay separate (no FMA) and in the scalar loop's order, so the
// SIMD and scalar products give the same bits.
//
//===----------------------------------------------------------------------===//

#include "VertexBlockSpmv.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define YASPS_VERTEX_SIMD 1
#endif

using namespace yasps::runtime;

#ifdef YASPS_VERTEX_SIMD

bool detail::hasVertexBlockSimd() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

/// Four entries of a block from `p` as doubles: the first two rows' loads,
/// whose fourth lane (the next row's first entry, within the block) no
/// result takes.
__attribute__((target("avx2"), always_inline)) static inline __m256d
loadRow(const double *p) {
  return _mm256_loadu_pd(p);
}
__attribute__((target("avx2"), always_inline)) static inline __m256d
loadRow(const float *p) {
  return _mm256_cvtps_pd(_mm_loadu_ps(p));
}

/// The last row's three entries (a fourth would read past the block), as
/// a two-entry and a one-entry load. Not AVX2's masked loads and stores
/// (vmaskmovpd): AMD's Zen cores run the stores as microcode, and a masked
/// store does not forward to the next load of the same entries. On an AMD
/// EPYC host the bunny's one-thread product took a median 1.13 ms with them,
/// 0.86 ms without (yasps-spmv-bench, 12 runs each, alternated).
__attribute__((target("avx2"), always_inline)) static inline __m256d
loadLastRow(const double *p) {
  return _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p)),
                              _mm_load_sd(p + 2), 1);
}
__attribute__((target("avx2"), always_inline)) static inline __m256d
loadLastRow(const float *p) {
  const __m128 two =
      _mm_castpd_ps(_mm_load_sd(reinterpret_cast<const double *>(p)));
  return _mm256_cvtps_pd(_mm_movelh_ps(two, _mm_load_ss(p + 2)));
}

/// y[0..2] as the first three lanes (the fourth is zero), and back.
__attribute__((target("avx2"), always_inline)) static inline __m256d
loadThree(const double *y) {
  return loadLastRow(y);
}
__attribute__((target("avx2"), always_inline)) static inline void
storeThree(double *y, __m256d v) {
  _mm_storeu_pd(y, _mm256_castpd256_pd128(v));
  _mm_store_sd(y + 2, _mm256_extractf128_pd(v, 1));
}

/// B x_c for the 3x3 block with rows r0, r1, r2 (fourth lanes ignored):
/// the columns by a 4x4 transpose with a zero fourth row, then lane i is
/// (B_i0 x0 + B_i1 x1) + B_i2 x2, the scalar loop's order.
__attribute__((target("avx2"), always_inline)) static inline __m256d
timesColumns(__m256d r0, __m256d r1, __m256d r2, const double *xc) {
  const __m256d zero = _mm256_setzero_pd();
  const __m256d lo01 = _mm256_unpacklo_pd(r0, r1);
  const __m256d hi01 = _mm256_unpackhi_pd(r0, r1);
  const __m256d lo2 = _mm256_unpacklo_pd(r2, zero);
  const __m256d hi2 = _mm256_unpackhi_pd(r2, zero);
  const __m256d c0 = _mm256_permute2f128_pd(lo01, lo2, 0x20);
  const __m256d c1 = _mm256_permute2f128_pd(hi01, hi2, 0x20);
  const __m256d c2 = _mm256_permute2f128_pd(lo01, lo2, 0x31);
  return _mm256_add_pd(
      _mm256_add_pd(_mm256_mul_pd(c0, _mm256_broadcast_sd(xc)),
                    _mm256_mul_pd(c1, _mm256_broadcast_sd(xc + 1))),
      _mm256_mul_pd(c2, _mm256_broadcast_sd(xc + 2)));
}

template <bool Limited, typename T>
__attribute__((target("avx2"), always_inline)) static inline void
vertexBlocks(const T *data, const std::size_t *rowStart, std::int64_t rowBegin,
             std::int64_t rowEnd, const std::int32_t *colDof,
             const std::int64_t *offset, std::int64_t limitDof, const double *x,
             double *y) {
  for (std::int64_t r = rowBegin; r < rowEnd; ++r) {
    std::size_t b = rowStart[r];
    const std::size_t end = rowStart[r + 1];
    if (b == end)
      continue;
    const std::int64_t rowDof = offset[r];
    double *yr = y + rowDof;
    const double *xr = x + rowDof;
    const __m256d xr0 = _mm256_broadcast_sd(xr),
                  xr1 = _mm256_broadcast_sd(xr + 1),
                  xr2 = _mm256_broadcast_sd(xr + 2);
    __m256d acc = loadThree(yr);
    for (; b < end; ++b, data += 9) {
      const std::int64_t c = colDof[b];
      const double *xc = x + c;
      const __m256d r0 = loadRow(data);
      const __m256d r1 = loadRow(data + 3);
      const __m256d r2 = loadLastRow(data + 6);
      acc = _mm256_add_pd(acc, timesColumns(r0, r1, r2, xc));
      if (c != rowDof && (!Limited || c < limitDof)) {
        // y_c[j] += B_0j xr0, then B_1j xr1, then B_2j xr2.
        double *yc = y + c;
        __m256d t = loadThree(yc);
        t = _mm256_add_pd(t, _mm256_mul_pd(r0, xr0));
        t = _mm256_add_pd(t, _mm256_mul_pd(r1, xr1));
        t = _mm256_add_pd(t, _mm256_mul_pd(r2, xr2));
        storeThree(yc, t);
      }
    }
    storeThree(yr, acc);
  }
}

template <typename T>
__attribute__((target("avx2"), always_inline)) static inline void
transposedVertexBlocks(const T *values, std::size_t first,
                       const std::size_t *blocks, std::size_t count,
                       const std::int64_t *row, const std::int64_t *col,
                       const std::int64_t *offset, const double *x, double *y) {
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t b = blocks[k];
    const T *data = values + 9 * (b - first);
    const double *xr = x + offset[row[b]];
    double *yc = y + offset[col[b]];
    // As vertexBlocks: y_c[j] += B_0j xr0, then B_1j xr1, then B_2j xr2.
    __m256d t = loadThree(yc);
    t = _mm256_add_pd(t, _mm256_mul_pd(loadRow(data), _mm256_broadcast_sd(xr)));
    t = _mm256_add_pd(
        t, _mm256_mul_pd(loadRow(data + 3), _mm256_broadcast_sd(xr + 1)));
    t = _mm256_add_pd(
        t, _mm256_mul_pd(loadLastRow(data + 6), _mm256_broadcast_sd(xr + 2)));
    storeThree(yc, t);
  }
}

// One body per product for both block types.
template <typename T>
__attribute__((target("avx2"), always_inline)) static inline void
vertexBlocksUpTo(const T *data, const std::size_t *rowStart,
                 std::int64_t rowBegin, std::int64_t rowEnd,
                 const std::int32_t *colDof, const std::int64_t *offset,
                 std::int64_t limitDof, const double *x, double *y) {
  // Without a limit the loop keeps one test per block: the one-thread
  // product took 35% longer with both.
  if (limitDof == detail::kNoLimit)
    return vertexBlocks<false>(data, rowStart, rowBegin, rowEnd, colDof, offset,
                               limitDof, x, y);
  vertexBlocks<true>(data, rowStart, rowBegin, rowEnd, colDof, offset, limitDof,
                     x, y);
}

__attribute__((target("avx2"))) void detail::multiplyVertexBlocksAvx2(
    const double *data, const std::size_t *rowStart, std::int64_t rowBegin,
    std::int64_t rowEnd, const std::int32_t *colDof, const std::int64_t *offset,
    std::int64_t limitDof, const double *x, double *y) {
  vertexBlocksUpTo(data, rowStart, rowBegin, rowEnd, colDof, offset, limitDof,
                   x, y);
}

__attribute__((target("avx2"))) void detail::multiplyVertexBlocksAvx2(
    const float *data, const std::size_t *rowStart, std::int64_t rowBegin,
    std::int64_t rowEnd, const std::int32_t *colDof, const std::int64_t *offset,
    std::int64_t limitDof, const double *x, double *y) {
  vertexBlocksUpTo(data, rowStart, rowBegin, rowEnd, colDof, offset, limitDof,
                   x, y);
}

__attribute__((target("avx2"))) void detail::addTransposedVertexBlocksAvx2(
    const double *values, std::size_t first, const std::size_t *blocks,
    std::size_t count, const std::int64_t *row, const std::int64_t *col,
    const std::int64_t *offset, const double *x, double *y) {
  transposedVertexBlocks(values, first, blocks, count, row, col, offset, x, y);
}

__attribute__((target("avx2"))) void detail::addTransposedVertexBlocksAvx2(
    const float *values, std::size_t first, const std::size_t *blocks,
    std::size_t count, const std::int64_t *row, const std::int64_t *col,
    const std::int64_t *offset, const double *x, double *y) {
  transposedVertexBlocks(values, first, blocks, count, row, col, offset, x, y);
}

#else

bool detail::hasVertexBlockSimd() { return false; }

// Never called: hasVertexBlockSimd() is false.
void detail::multiplyVertexBlocksAvx2(const double *, const std::size_t *,
                                      std::int64_t, std::int64_t,
                                      const std::int32_t *,
                                      const std::int64_t *, std::int64_t,
                                      const double *, double *) {}
void detail::multiplyVertexBlocksAvx2(const float *, const std::size_t *,
                                      std::int64_t, std::int64_t,
                                      const std::int32_t *,
                                      const std::int64_t *, std::int64_t,
                                      const double *, double *) {}
void detail::addTransposedVertexBlocksAvx2(const double *, std::size_t,
                                           const std::size_t *, std::size_t,
                                           const std::int64_t *,
                                           const std::int64_t *,
                                           const std::int64_t *, const double *,
                                           double *) {}
void detail::addTransposedVertexBlocksAvx2(const float *, std::size_t,
                                           const std::size_t *, std::size_t,
                                           const std::int64_t *,
                                           const std::int64_t *,
                                           const std::int64_t *, const double *,
                                           double *) {}

#endif
