//===- BlockJacobi.cpp - the block-Jacobi preconditioner ------------------===//

#include "yasps/Runtime/Sparse/BlockJacobi.h"

#include "yasps/Runtime/Sparse/BlockInverse.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include <algorithm>
#include <cmath>

using namespace yasps::runtime;

// Diagonal blocks per chunk when building and applying the preconditioner.
static constexpr std::int64_t kBlocksPerChunk = 64;
// Diagonal blocks per segment of applyDot's sum: small enough to share out
// evenly among a PCG team's threads (Pcg.cpp).
static constexpr std::int64_t kBlocksPerSegment = 256;

BlockJacobi::BlockJacobi(const HessianParts &parts, const std::uint8_t *fixed,
                         ThreadPool &pool)
    : layout_(parts.front()->layout()) {
  parts.front()->diagonalBlocks(inverse_);
  std::vector<double> more;
  for (std::size_t k = 1; k < parts.size(); ++k) {
    parts[k]->diagonalBlocks(more);
    for (std::size_t i = 0; i < more.size(); ++i)
      inverse_[i] += more[i];
  }
  start_.assign(static_cast<std::size_t>(layout_.numBlocks()) + 1, 0);
  for (std::int64_t r = 0; r < layout_.numBlocks(); ++r)
    start_[r + 1] = start_[r] + static_cast<std::size_t>(layout_.blockSize(r) *
                                                         layout_.blockSize(r));
  measureDiagonal(fixed);
  allVertexBlocks_ = std::all_of(
      layout_.blockOffset.begin() + 1, layout_.blockOffset.end(),
      [&](const std::int64_t &end) { return end - (&end)[-1] == 3; });
  pool.parallelFor(
      0, layout_.numBlocks(), kBlocksPerChunk,
      [&](std::int64_t begin, std::int64_t end) {
        std::vector<long long> freeDofs;
        std::vector<double> a, l;
        for (std::int64_t r = begin; r < end; ++r) {
          std::int64_t s = layout_.blockSize(r);
          freeDofs.resize(static_cast<std::size_t>(s));
          a.resize(static_cast<std::size_t>(s * s));
          l.resize(static_cast<std::size_t>(s * s));
          double *block = inverse_.data() + start_[r];
          const std::uint8_t *blockFixed =
              fixed ? fixed + layout_.blockOffset[r] : nullptr;
          // The size as a constant for vertex blocks, so that
          // their loops unroll.
          if (s == 3)
            invertDiagonalBlock(3, block, blockFixed, freeDofs.data(), a.data(),
                                l.data());
          else
            invertDiagonalBlock(s, block, blockFixed, freeDofs.data(), a.data(),
                                l.data());
        }
      });
}

/// z = inv r on a 3x3 block: vertex blocks, most of an IPC system, with
/// their bounds known (run-time sizes made this a tenth of a PCG iteration
/// on the bunny). The same terms in the same order as the general loop.
/// r's entries come as values: when the caller has just stored them,
/// reading them back as one vector stalls on store forwarding.
__attribute__((always_inline)) static inline void
applyVertexBlock(const double *inv, double r0, double r1, double r2, double *z,
                 double *rz) {
  const double z0 = inv[0] * r0 + inv[1] * r1 + inv[2] * r2;
  const double z1 = inv[3] * r0 + inv[4] * r1 + inv[5] * r2;
  const double z2 = inv[6] * r0 + inv[7] * r1 + inv[8] * r2;
  z[0] = z0;
  z[1] = z1;
  z[2] = z2;
  rz[0] += r0 * z0;
  rz[1] += r1 * z1;
  rz[2] += r2 * z2;
}

__attribute__((always_inline)) inline void
BlockJacobi::applyBlock(std::int64_t b, const double *r, double *z,
                        double *rz) const {
  std::int64_t o = layout_.blockOffset[b];
  std::int64_t s = layout_.blockOffset[b + 1] - o;
  const double *inv = inverse_.data() + start_[b];
  if (s == 3)
    return applyVertexBlock(inv, r[o], r[o + 1], r[o + 2], z + o, rz);
  for (std::int64_t i = 0; i < s; ++i) {
    double sum = 0.0;
    for (std::int64_t j = 0; j < s; ++j)
      sum += inv[i * s + j] * r[o + j];
    z[o + i] = sum;
    rz[i % 3] += r[o + i] * sum;
  }
}

double BlockJacobi::eigenvalueBound(const HessianParts &parts,
                                    const std::uint8_t *fixed) const {
  std::vector<double> rowSums(
      static_cast<std::size_t>(layout_.blockOffset.back()), 0.0);
  auto isFixed = [&](std::int64_t dof) { return fixed && fixed[dof]; };
  // Adds |M_r^-1 B| (or |M_r^-1 B^T|) to the rows of block r, B the stored
  // block between blocks r and c.
  auto addRows = [&](std::int64_t r, std::int64_t c, const double *block,
                     bool transposed) {
    const std::int64_t rows = layout_.blockSize(r), cols = layout_.blockSize(c);
    const std::int64_t rowStart = layout_.blockOffset[r];
    const std::int64_t colStart = layout_.blockOffset[c];
    const double *inv = inverse_.data() + start_[r];
    for (std::int64_t i = 0; i < rows; ++i) {
      if (isFixed(rowStart + i))
        continue;
      for (std::int64_t j = 0; j < cols; ++j) {
        if (isFixed(colStart + j))
          continue;
        double value = 0.0;
        for (std::int64_t k = 0; k < rows; ++k)
          value += inv[i * rows + k] *
                   (transposed ? block[j * rows + k] : block[k * cols + j]);
        rowSums[static_cast<std::size_t>(rowStart + i)] += std::abs(value);
      }
    }
  };
  for (const BlockSparseMatrix *part : parts)
    for (std::size_t b = 0; b < part->numStoredBlocks(); ++b) {
      const std::int64_t r = part->blockRow(b), c = part->blockCol(b);
      addRows(r, c, part->blockData(b), false);
      if (r != c)
        addRows(c, r, part->blockData(b), true);
    }
  return rowSums.empty() ? 0.0
                         : *std::max_element(rowSums.begin(), rowSums.end());
}

void BlockJacobi::apply(const double *r, double *z, ThreadPool &pool) const {
  pool.parallelFor(0, layout_.numBlocks(), kBlocksPerChunk,
                   [&](std::int64_t begin, std::int64_t end) {
                     double unused[3] = {0.0, 0.0, 0.0};
                     for (std::int64_t b = begin; b < end; ++b)
                       applyBlock(b, r, z, unused);
                   });
}

std::int64_t BlockJacobi::numSegments() const {
  return (layout_.numBlocks() + kBlocksPerSegment - 1) / kBlocksPerSegment;
}

template <int NumSums, typename Body>
void BlockJacobi::sumSegments(std::int64_t begin, std::int64_t end,
                              double *partial, Body body) const {
  const std::int64_t numBlocks = layout_.numBlocks();
  for (std::int64_t segment = begin; segment < end; ++segment) {
    // Three running sums each, the DoFs of a block spread over them: one
    // made every term wait for the previous addition. Fixed by the
    // segment, so the same on every thread count.
    double sums[NumSums][3] = {};
    body(segment * kBlocksPerSegment,
         std::min(numBlocks, (segment + 1) * kBlocksPerSegment), sums);
    for (int k = 0; k < NumSums; ++k)
      partial[segment * NumSums + k] = (sums[k][0] + sums[k][1]) + sums[k][2];
  }
}

template <int NumSums, typename Body>
std::array<double, NumSums>
BlockJacobi::sumOverBlockRanges(std::vector<double> &partial, ThreadPool &pool,
                                Body body) const {
  const std::int64_t count = numSegments();
  partial.assign(static_cast<std::size_t>(NumSums * count), 0.0);
  pool.parallelFor(0, count, 1, [&](std::int64_t begin, std::int64_t end) {
    sumSegments<NumSums>(begin, end, partial.data(), body);
  });
  std::array<double, NumSums> total{};
  for (std::int64_t segment = 0; segment < count; ++segment)
    for (int k = 0; k < NumSums; ++k)
      total[k] += partial[segment * NumSums + k];
  return total;
}

double BlockJacobi::applyDot(const double *r, double *z,
                             std::vector<double> &partial,
                             ThreadPool &pool) const {
  return sumOverBlockRanges<1>(
      partial, pool,
      [&](std::int64_t begin, std::int64_t end, double(*sums)[3]) {
        for (std::int64_t b = begin; b < end; ++b)
          applyBlock(b, r, z, sums[0]);
      })[0];
}

/// stepApplyDots on blocks [begin, end) of a layout of 3x3 blocks only,
/// adding to rr[3] and rz[3] in the order of the general path. Written out
/// with local sums and unaliased pointers: through the general path's
/// callbacks the sums lived in memory and every store ordered the loads
/// after it.
static void stepVertexBlocks(std::int64_t begin, std::int64_t end, double alpha,
                             const double *__restrict p,
                             const double *__restrict q, double *__restrict x,
                             double *__restrict r, double *__restrict z,
                             const double *__restrict inverse, double *rr,
                             double *rz) {
  double rr0 = rr[0], rr1 = rr[1], rr2 = rr[2];
  double rz0 = rz[0], rz1 = rz[1], rz2 = rz[2];
  for (std::int64_t b = begin; b < end; ++b) {
    const std::int64_t o = 3 * b;
    x[o] += alpha * p[o];
    x[o + 1] += alpha * p[o + 1];
    x[o + 2] += alpha * p[o + 2];
    const double r0 = r[o] - alpha * q[o];
    const double r1 = r[o + 1] - alpha * q[o + 1];
    const double r2 = r[o + 2] - alpha * q[o + 2];
    r[o] = r0;
    r[o + 1] = r1;
    r[o + 2] = r2;
    rr0 += r0 * r0;
    rr1 += r1 * r1;
    rr2 += r2 * r2;
    const double *inv = inverse + 9 * b;
    const double z0 = inv[0] * r0 + inv[1] * r1 + inv[2] * r2;
    const double z1 = inv[3] * r0 + inv[4] * r1 + inv[5] * r2;
    const double z2 = inv[6] * r0 + inv[7] * r1 + inv[8] * r2;
    z[o] = z0;
    z[o + 1] = z1;
    z[o + 2] = z2;
    rz0 += r0 * z0;
    rz1 += r1 * z1;
    rz2 += r2 * z2;
  }
  rr[0] = rr0, rr[1] = rr1, rr[2] = rr2;
  rz[0] = rz0, rz[1] = rz1, rz[2] = rz2;
}

/// stepApplyDots' pass over blocks [begin, end).
void BlockJacobi::stepBlocks(std::int64_t begin, std::int64_t end, double alpha,
                             const double *p, const double *q, double *x,
                             double *r, double *z, double (*sums)[3]) const {
  if (allVertexBlocks_)
    return stepVertexBlocks(begin, end, alpha, p, q, x, r, z, inverse_.data(),
                            sums[0], sums[1]);
  const std::int64_t *offset = layout_.blockOffset.data();
  for (std::int64_t b = begin; b < end; ++b) {
    const std::int64_t o = offset[b], s = offset[b + 1] - o;
    for (std::int64_t i = 0; i < s; ++i) {
      x[o + i] += alpha * p[o + i];
      r[o + i] -= alpha * q[o + i];
      sums[0][i % 3] += r[o + i] * r[o + i];
    }
    applyBlock(b, r, z, sums[1]);
  }
}

BlockJacobi::StepDots BlockJacobi::stepApplyDots(double alpha, const double *p,
                                                 const double *q, double *x,
                                                 double *r, double *z,
                                                 std::vector<double> &partial,
                                                 ThreadPool &pool) const {
  std::array<double, 2> dots = sumOverBlockRanges<2>(
      partial, pool,
      [&](std::int64_t begin, std::int64_t end, double(*sums)[3]) {
        stepBlocks(begin, end, alpha, p, q, x, r, z, sums);
      });
  return {dots[0], dots[1]};
}

void BlockJacobi::stepSegments(std::int64_t begin, std::int64_t end,
                               double alpha, const double *p, const double *q,
                               double *x, double *r, double *z,
                               double *partial) const {
  sumSegments<2>(begin, end, partial,
                 [&](std::int64_t first, std::int64_t last, double(*sums)[3]) {
                   stepBlocks(first, last, alpha, p, q, x, r, z, sums);
                 });
}

void BlockJacobi::measureDiagonal(const std::uint8_t *fixed) {
  double smallest = std::numeric_limits<double>::infinity(), largest = 0.0;
  bool any = false;
  for (std::int64_t b = 0; b < layout_.numBlocks(); ++b) {
    std::int64_t s = layout_.blockSize(b), o = layout_.blockOffset[b];
    for (std::int64_t i = 0; i < s; ++i) {
      if (fixed && fixed[o + i])
        continue;
      double d = inverse_[start_[b] + static_cast<std::size_t>(i * s + i)];
      any = true;
      smallest = std::min(smallest, d);
      largest = std::max(largest, d);
    }
  }
  diagonalRatio_ = !any             ? std::numeric_limits<double>::quiet_NaN()
                   : smallest > 0.0 ? largest / smallest
                                    : std::numeric_limits<double>::infinity();
}
