//===- BlockJacobi.cpp - the block-Jacobi preconditioner ------------------===//

#include "yasps/Runtime/BlockJacobi.h"

#include "yasps/Runtime/BlockInverse.h"
#include "yasps/Runtime/ThreadPool.h"

#include <algorithm>

using namespace yasps::runtime;

// Diagonal blocks per chunk when building and applying the preconditioner.
static constexpr std::int64_t kBlocksPerChunk = 64;
// Diagonal blocks per segment of applyDot's sum.
static constexpr std::int64_t kBlocksPerSegment = 1024;

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
  pool.parallelFor(0, layout_.numBlocks(), kBlocksPerChunk,
                   [&](std::int64_t begin, std::int64_t end) {
                     std::vector<long long> freeDofs;
                     std::vector<double> a, l;
                     for (std::int64_t r = begin; r < end; ++r) {
                       std::int64_t s = layout_.blockSize(r);
                       freeDofs.resize(static_cast<std::size_t>(s));
                       a.resize(static_cast<std::size_t>(s * s));
                       l.resize(static_cast<std::size_t>(s * s));
                       invertDiagonalBlock(
                           s, inverse_.data() + start_[r],
                           fixed ? fixed + layout_.blockOffset[r] : nullptr,
                           freeDofs.data(), a.data(), l.data());
                     }
                   });
}

void BlockJacobi::applyBlock(std::int64_t b, const double *r, double *z,
                             double *rz) const {
  std::int64_t o = layout_.blockOffset[b];
  std::int64_t s = layout_.blockOffset[b + 1] - o;
  const double *inv = inverse_.data() + start_[b];
  if (s == 3) {
    // Vertex blocks, most of an IPC system, unrolled: the loop below with
    // its bounds known, the same terms in the same order. Run-time sizes
    // made it a tenth of a PCG iteration on the bunny.
    const double r0 = r[o], r1 = r[o + 1], r2 = r[o + 2];
    const double z0 = inv[0] * r0 + inv[1] * r1 + inv[2] * r2;
    const double z1 = inv[3] * r0 + inv[4] * r1 + inv[5] * r2;
    const double z2 = inv[6] * r0 + inv[7] * r1 + inv[8] * r2;
    z[o] = z0;
    z[o + 1] = z1;
    z[o + 2] = z2;
    rz[0] += r0 * z0;
    rz[1] += r1 * z1;
    rz[2] += r2 * z2;
    return;
  }
  for (std::int64_t i = 0; i < s; ++i) {
    double sum = 0.0;
    for (std::int64_t j = 0; j < s; ++j)
      sum += inv[i * s + j] * r[o + j];
    z[o + i] = sum;
    rz[i % 3] += r[o + i] * sum;
  }
}

void BlockJacobi::apply(const double *r, double *z, ThreadPool &pool) const {
  pool.parallelFor(0, layout_.numBlocks(), kBlocksPerChunk,
                   [&](std::int64_t begin, std::int64_t end) {
                     double unused[3] = {0.0, 0.0, 0.0};
                     for (std::int64_t b = begin; b < end; ++b)
                       applyBlock(b, r, z, unused);
                   });
}

double BlockJacobi::applyDot(const double *r, double *z,
                             std::vector<double> &partial,
                             ThreadPool &pool) const {
  const std::int64_t numBlocks = layout_.numBlocks();
  const std::int64_t numSegments =
      (numBlocks + kBlocksPerSegment - 1) / kBlocksPerSegment;
  partial.assign(static_cast<std::size_t>(numSegments), 0.0);
  pool.parallelFor(
      0, numSegments, 1, [&](std::int64_t begin, std::int64_t end) {
        for (std::int64_t segment = begin; segment < end; ++segment) {
          // Three running sums, the DoFs of a block spread over them: one
          // made every term wait for the previous addition. Fixed by the
          // segment, so the same on every thread count.
          double rz[3] = {0.0, 0.0, 0.0};
          for (std::int64_t b = segment * kBlocksPerSegment;
               b < std::min(numBlocks, (segment + 1) * kBlocksPerSegment); ++b)
            applyBlock(b, r, z, rz);
          partial[segment] = (rz[0] + rz[1]) + rz[2];
        }
      });
  double sum = 0.0;
  for (double p : partial)
    sum += p;
  return sum;
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
