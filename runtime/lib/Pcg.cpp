//===- Pcg.cpp - block-Jacobi preconditioned conjugate gradient -----------===//

#include "yasps/Runtime/Pcg.h"

#include "yasps/Runtime/BlockInverse.h"
#include "yasps/Runtime/BlockSparseMatrix.h"
#include "yasps/Runtime/ThreadPool.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

using namespace yasps::runtime;

// Dot products sum fixed-size segments in parallel, then the segment sums in
// order: the result does not depend on the number of threads, so neither
// does the iteration count.
static constexpr std::int64_t kSegment = 4096;
// Elements per chunk for element-wise vector updates.
static constexpr std::int64_t kElementsPerChunk = 4096;
// Diagonal blocks per chunk when building and applying the preconditioner.
static constexpr std::int64_t kBlocksPerChunk = 64;

namespace {
/// The inverses of the diagonal blocks restricted to the free DoFs, each
/// stored whole (size x size, row-major) with zero rows and columns at fixed
/// DoFs, so that applying it also projects onto the free DoFs.
class BlockJacobi {
public:
  BlockJacobi(const HessianParts &parts, const std::uint8_t *fixed,
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
      start_[r + 1] =
          start_[r] +
          static_cast<std::size_t>(layout_.blockSize(r) * layout_.blockSize(r));
    pool.parallelFor(0, layout_.numBlocks(), kBlocksPerChunk,
                     [&](std::int64_t begin, std::int64_t end) {
                       std::vector<long long> freeDofs;
                       std::vector<double> a, l;
                       for (std::int64_t r = begin; r < end; ++r)
                         invertBlock(r, fixed, freeDofs, a, l);
                     });
  }

  /// z = M^-1 r.
  void apply(const double *r, double *z, ThreadPool &pool) const {
    pool.parallelFor(0, layout_.numBlocks(), kBlocksPerChunk,
                     [&](std::int64_t begin, std::int64_t end) {
                       for (std::int64_t b = begin; b < end; ++b) {
                         std::int64_t s = layout_.blockSize(b);
                         std::int64_t o = layout_.blockOffset[b];
                         const double *inv = inverse_.data() + start_[b];
                         for (std::int64_t i = 0; i < s; ++i) {
                           double sum = 0.0;
                           for (std::int64_t j = 0; j < s; ++j)
                             sum += inv[i * s + j] * r[o + j];
                           z[o + i] = sum;
                         }
                       }
                     });
  }

private:
  /// Replaces diagonal block `r` (in inverse_) by its preconditioner.
  void invertBlock(std::int64_t r, const std::uint8_t *fixed,
                   std::vector<long long> &freeDofs, std::vector<double> &a,
                   std::vector<double> &l) {
    std::int64_t s = layout_.blockSize(r);
    freeDofs.resize(static_cast<std::size_t>(s));
    a.resize(static_cast<std::size_t>(s * s));
    l.resize(static_cast<std::size_t>(s * s));
    invertDiagonalBlock(s, inverse_.data() + start_[r],
                        fixed ? fixed + layout_.blockOffset[r] : nullptr,
                        freeDofs.data(), a.data(), l.data());
  }

  const BlockLayout &layout_;
  std::vector<double> inverse_;
  std::vector<std::size_t> start_;
};
} // namespace

static double dot(const double *a, const double *b, std::int64_t n,
                  std::vector<double> &partial, ThreadPool &pool) {
  std::int64_t numSegments = (n + kSegment - 1) / kSegment;
  partial.assign(static_cast<std::size_t>(numSegments), 0.0);
  pool.parallelFor(0, numSegments, 1,
                   [&](std::int64_t begin, std::int64_t end) {
                     for (std::int64_t s = begin; s < end; ++s) {
                       double sum = 0.0;
                       for (std::int64_t i = s * kSegment;
                            i < std::min(n, (s + 1) * kSegment); ++i)
                         sum += a[i] * b[i];
                       partial[s] = sum;
                     }
                   });
  double sum = 0.0;
  for (double p : partial)
    sum += p;
  return sum;
}

/// y = a * x + b * y, element-wise.
static void axpby(double a, const double *x, double b, double *y,
                  std::int64_t n, ThreadPool &pool) {
  pool.parallelFor(0, n, kElementsPerChunk,
                   [&](std::int64_t begin, std::int64_t end) {
                     for (std::int64_t i = begin; i < end; ++i)
                       y[i] = a * x[i] + b * y[i];
                   });
}

void yasps::runtime::multiplySum(const HessianParts &parts, const double *x,
                                 double *y, std::vector<double> &scratch,
                                 ThreadPool &pool) {
  parts.front()->multiply(x, y, pool);
  const std::size_t n = static_cast<std::size_t>(parts.front()->size());
  for (std::size_t k = 1; k < parts.size(); ++k) {
    if (parts[k]->numStoredBlocks() == 0)
      continue;
    scratch.resize(n);
    parts[k]->multiply(x, scratch.data(), pool);
    for (std::size_t i = 0; i < n; ++i)
      y[i] += scratch[i];
  }
}

static bool allFinite(const double *v, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(v[i]))
      return false;
  return true;
}

void yasps::runtime::checkPcgOptions(const PcgOptions &options,
                                     std::int64_t size) {
  if (options.fixedDofs &&
      options.fixedDofs->size() != static_cast<std::size_t>(size))
    throw std::invalid_argument(
        "the fixed-DoF mask has " + std::to_string(options.fixedDofs->size()) +
        " entries but the matrix has " + std::to_string(size) + " DoFs");
  if (options.maxIterations < 0)
    throw std::invalid_argument("PCG needs maxIterations >= 0, got " +
                                std::to_string(options.maxIterations));
  if (!(options.relativeTolerance >= 0.0))
    throw std::invalid_argument("PCG needs a relative tolerance >= 0, got " +
                                std::to_string(options.relativeTolerance));
}

PcgResult yasps::runtime::solvePcg(const BlockSparseMatrix &H, const double *b,
                                   double *x, const PcgOptions &options,
                                   ThreadPool &pool) {
  return solvePcg(HessianParts{&H}, b, x, options, pool);
}

PcgResult yasps::runtime::solvePcg(const HessianParts &parts, const double *b,
                                   double *x, const PcgOptions &options,
                                   ThreadPool &pool) {
  if (parts.empty())
    throw std::invalid_argument("PCG needs at least one matrix");
  const BlockSparseMatrix &H = *parts.front();
  for (const BlockSparseMatrix *part : parts)
    if (part->layout().blockOffset != H.layout().blockOffset)
      throw std::invalid_argument(
          "the parts of a PCG matrix must share one block layout");
  const std::int64_t n = H.size();
  const std::size_t un = static_cast<std::size_t>(n);
  checkPcgOptions(options, n);
  const std::uint8_t *fixed =
      options.fixedDofs ? options.fixedDofs->data() : nullptr;

  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::fill(x, x + n, 0.0);
  std::vector<double> r(b, b + n);
  if (fixed)
    for (std::int64_t i = 0; i < n; ++i)
      if (fixed[i])
        r[i] = 0.0;
  // Checked up front: a NaN in H might otherwise sit where the iterates are
  // zero and go unnoticed, or be hidden by the preconditioner's fallback.
  if (!allFinite(r.data(), un))
    return {0, nan, false};
  for (const BlockSparseMatrix *part : parts)
    if (!allFinite(part->values().data(), part->values().size()))
      return {0, nan, false};

  std::vector<double> partial;
  const double bNorm = std::sqrt(dot(r.data(), r.data(), n, partial, pool));
  if (bNorm == 0.0)
    return {0, 0.0, true};

  BlockJacobi preconditioner(parts, fixed, pool);
  std::vector<double> z(un), p(un), q(un), partProduct;
  preconditioner.apply(r.data(), z.data(), pool);
  p = z;
  double rz = dot(r.data(), z.data(), n, partial, pool);
  double rNorm = bNorm;
  const double threshold = options.relativeTolerance * bNorm;
  std::int64_t iterations = 0;
  while (true) {
    if (!std::isfinite(rNorm))
      return {iterations, nan, false};
    if (rNorm <= threshold)
      return {iterations, rNorm / bNorm, true};
    if (iterations == options.maxIterations)
      return {iterations, rNorm / bNorm, false};

    multiplySum(parts, p.data(), q.data(), partProduct, pool);
    if (fixed)
      for (std::int64_t i = 0; i < n; ++i)
        if (fixed[i])
          q[i] = 0.0;
    double pq = dot(p.data(), q.data(), n, partial, pool);
    // H is not positive definite along p (or rz vanished): CG cannot go on.
    if (!(pq > 0.0) || !std::isfinite(pq) || !(rz > 0.0))
      return {iterations, std::isfinite(pq) ? rNorm / bNorm : nan, false};
    double alpha = rz / pq;
    axpby(alpha, p.data(), 1.0, x, n, pool);
    axpby(-alpha, q.data(), 1.0, r.data(), n, pool);
    ++iterations;
    rNorm = std::sqrt(dot(r.data(), r.data(), n, partial, pool));
    if (rNorm <= threshold)
      continue;

    preconditioner.apply(r.data(), z.data(), pool);
    double rzNext = dot(r.data(), z.data(), n, partial, pool);
    axpby(1.0, z.data(), rzNext / rz, p.data(), n, pool);
    rz = rzNext;
  }
}
