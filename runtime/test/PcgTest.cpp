//===- PcgTest.cpp - tests of the block-Jacobi preconditioned CG ----------===//

#include "yasps/Runtime/Sparse/Pcg.h"

#include "yasps/Runtime/Sparse/BlockSparseMatrix.h"
#include "yasps/Runtime/Sparse/Lanczos.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

using yasps::runtime::BlockLayout;
using yasps::runtime::BlockSlot;
using yasps::runtime::BlockSparseMatrix;
using yasps::runtime::PcgOptions;
using yasps::runtime::PcgPreconditioner;
using yasps::runtime::PcgResult;
using yasps::runtime::PcgStop;
using yasps::runtime::PcgStopping;
using yasps::runtime::solvePcg;
using yasps::runtime::ThreadPool;

namespace {
using Coord = std::pair<std::int64_t, std::int64_t>;

/// A random symmetric positive definite block system: 50 blocks of 3 and 4
/// of 12, random off-diagonal blocks, and diagonal blocks that make it
/// strictly diagonally dominant, barely (so CG needs several iterations).
BlockSparseMatrix randomSpd(std::mt19937 &rng, bool offDiagonal = true) {
  std::vector<std::int64_t> sizes(50, 3);
  for (std::size_t k : {5u, 17u, 30u, 44u})
    sizes[k] = 12;
  BlockLayout layout = BlockLayout::fromSizes(sizes);
  std::int64_t numBlocks = layout.numBlocks();
  std::uniform_int_distribution<std::int64_t> pickBlock(0, numBlocks - 1);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<Coord> coords;
  std::vector<std::vector<double>> locals;
  for (int k = 0; offDiagonal && k < 150; ++k) {
    std::int64_t i = pickBlock(rng), j = pickBlock(rng);
    if (i == j)
      continue;
    std::vector<double> local(
        static_cast<std::size_t>(layout.blockSize(i) * layout.blockSize(j)));
    for (double &v : local)
      v = value(rng);
    coords.push_back({i, j});
    locals.push_back(std::move(local));
  }
  // Absolute row sums of the off-diagonal part, then the diagonal blocks: a
  // random symmetric part plus a shift above the row sums.
  std::int64_t n = layout.blockOffset.back();
  std::vector<double> rowSum(static_cast<std::size_t>(n), 0.0);
  for (std::size_t k = 0; k < coords.size(); ++k) {
    auto [i, j] = coords[k];
    std::int64_t rows = layout.blockSize(i), cols = layout.blockSize(j);
    for (std::int64_t r = 0; r < rows; ++r)
      for (std::int64_t c = 0; c < cols; ++c) {
        double v = std::fabs(locals[k][r * cols + c]);
        rowSum[layout.blockOffset[i] + r] += v;
        rowSum[layout.blockOffset[j] + c] += v;
      }
  }
  for (std::int64_t b = 0; b < numBlocks; ++b) {
    std::int64_t s = layout.blockSize(b);
    std::vector<double> local(static_cast<std::size_t>(s * s));
    for (std::int64_t r = 0; r < s; ++r)
      for (std::int64_t c = 0; c <= r; ++c)
        local[r * s + c] = local[c * s + r] = 0.3 * value(rng);
    for (std::int64_t r = 0; r < s; ++r) {
      double offSum = 0.0;
      for (std::int64_t c = 0; c < s; ++c)
        if (c != r)
          offSum += std::fabs(local[r * s + c]);
      local[r * s + r] = rowSum[layout.blockOffset[b] + r] + offSum + 0.1;
    }
    coords.push_back({b, b});
    locals.push_back(std::move(local));
  }
  std::vector<BlockSlot> slots;
  BlockSparseMatrix m(layout, coords, &slots);
  for (std::size_t k = 0; k < slots.size(); ++k)
    m.addBlock(slots[k], locals[k].data());
  return m;
}

/// Solves the dense n x n system a x = b by Gaussian elimination with
/// partial pivoting.
std::vector<double> denseSolve(std::vector<double> a, std::vector<double> b) {
  std::size_t n = b.size();
  for (std::size_t k = 0; k < n; ++k) {
    std::size_t pivot = k;
    for (std::size_t i = k + 1; i < n; ++i)
      if (std::fabs(a[i * n + k]) > std::fabs(a[pivot * n + k]))
        pivot = i;
    for (std::size_t j = 0; j < n; ++j)
      std::swap(a[k * n + j], a[pivot * n + j]);
    std::swap(b[k], b[pivot]);
    for (std::size_t i = k + 1; i < n; ++i) {
      double f = a[i * n + k] / a[k * n + k];
      for (std::size_t j = k; j < n; ++j)
        a[i * n + j] -= f * a[k * n + j];
      b[i] -= f * b[k];
    }
  }
  std::vector<double> x(n);
  for (std::size_t i = n; i-- > 0;) {
    double v = b[i];
    for (std::size_t j = i + 1; j < n; ++j)
      v -= a[i * n + j] * x[j];
    x[i] = v / a[i * n + i];
  }
  return x;
}

std::vector<double> randomVector(std::mt19937 &rng, std::int64_t n) {
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<double> v(static_cast<std::size_t>(n));
  for (double &e : v)
    e = value(rng);
  return v;
}

double relativeError(const std::vector<double> &x,
                     const std::vector<double> &reference) {
  double diff = 0.0, norm = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    diff += (x[i] - reference[i]) * (x[i] - reference[i]);
    norm += reference[i] * reference[i];
  }
  return std::sqrt(diff / norm);
}
} // namespace

TEST(Pcg, SolvesRandomSpdBlockSystems) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 3; ++trial) {
    BlockSparseMatrix h = randomSpd(rng);
    std::vector<double> b = randomVector(rng, h.size());
    std::vector<double> expected = denseSolve(h.toDense(), b);
    PcgOptions options;
    options.relativeTolerance = 1e-12;
    std::int64_t firstIterations = -1;
    for (unsigned threads : {1u, 4u}) {
      ThreadPool pool(threads);
      std::vector<double> x(b.size(), 5.0);
      PcgResult result = solvePcg(h, b.data(), x.data(), options, pool);
      EXPECT_TRUE(result.converged) << "trial " << trial;
      EXPECT_LE(result.relativeResidual, 1e-12);
      EXPECT_GT(result.iterations, 1);
      EXPECT_LT(relativeError(x, expected), 1e-8) << "trial " << trial;
      if (firstIterations < 0)
        firstIterations = result.iterations;
      else
        EXPECT_EQ(result.iterations, firstIterations);
    }
  }
}

TEST(Pcg, SolvesOnTheFreeDofsOnly) {
  std::mt19937 rng(5);
  BlockSparseMatrix h = randomSpd(rng);
  std::int64_t n = h.size();
  std::vector<double> b = randomVector(rng, n);
  std::vector<std::uint8_t> fixed(static_cast<std::size_t>(n), 0);
  // Whole blocks and single DoFs inside blocks (of 3 and of 12).
  for (std::int64_t i = 0; i < n; i += 7)
    fixed[i] = 1;
  for (std::int64_t i = 0; i < 3; ++i)
    fixed[h.layout().blockOffset[2] + i] = 1;

  // The reference: the dense system restricted to the free DoFs.
  std::vector<double> dense = h.toDense();
  std::vector<std::int64_t> freeDofs;
  for (std::int64_t i = 0; i < n; ++i)
    if (!fixed[i])
      freeDofs.push_back(i);
  std::size_t m = freeDofs.size();
  std::vector<double> a(m * m), bFree(m);
  for (std::size_t i = 0; i < m; ++i) {
    bFree[i] = b[freeDofs[i]];
    for (std::size_t j = 0; j < m; ++j)
      a[i * m + j] = dense[freeDofs[i] * n + freeDofs[j]];
  }
  std::vector<double> xFree = denseSolve(a, bFree);

  PcgOptions options;
  options.relativeTolerance = 1e-12;
  options.fixedDofs = &fixed;
  ThreadPool pool(2);
  std::vector<double> x(static_cast<std::size_t>(n), 5.0);
  PcgResult result = solvePcg(h, b.data(), x.data(), options, pool);
  EXPECT_TRUE(result.converged);
  std::vector<double> solvedFree(m);
  for (std::size_t i = 0; i < m; ++i)
    solvedFree[i] = x[freeDofs[i]];
  EXPECT_LT(relativeError(solvedFree, xFree), 1e-8);
  for (std::int64_t i = 0; i < n; ++i)
    EXPECT_TRUE(!fixed[i] || x[i] == 0.0) << "fixed DoF " << i;

  std::vector<std::uint8_t> wrongSize(static_cast<std::size_t>(n) - 1, 0);
  options.fixedDofs = &wrongSize;
  EXPECT_THROW(solvePcg(h, b.data(), x.data(), options, pool),
               std::invalid_argument);
}

TEST(Pcg, ReportsNonConvergence) {
  std::mt19937 rng(9);
  BlockSparseMatrix h = randomSpd(rng);
  std::vector<double> b = randomVector(rng, h.size());
  PcgOptions options;
  options.relativeTolerance = 1e-12;
  options.maxIterations = 2;
  ThreadPool pool(2);
  std::vector<double> x(b.size());
  PcgResult result = solvePcg(h, b.data(), x.data(), options, pool);
  EXPECT_FALSE(result.converged);
  EXPECT_EQ(result.iterations, 2);
  EXPECT_GT(result.relativeResidual, 1e-12);
  EXPECT_LT(result.relativeResidual, 1.0);

  options.maxIterations = -1;
  EXPECT_THROW(solvePcg(h, b.data(), x.data(), options, pool),
               std::invalid_argument);
  options.maxIterations = 10;
  options.relativeTolerance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(solvePcg(h, b.data(), x.data(), options, pool),
               std::invalid_argument);
}

TEST(Pcg, ReportsNaNInput) {
  std::mt19937 rng(13);
  BlockSparseMatrix h = randomSpd(rng);
  std::vector<double> b = randomVector(rng, h.size());
  ThreadPool pool(2);
  std::vector<double> x(b.size());
  PcgOptions options;

  std::vector<double> badB = b;
  badB[17] = std::numeric_limits<double>::quiet_NaN();
  PcgResult result = solvePcg(h, badB.data(), x.data(), options, pool);
  EXPECT_FALSE(result.converged);
  EXPECT_TRUE(std::isnan(result.relativeResidual));

  h.values()[h.values().size() / 2] = std::numeric_limits<double>::quiet_NaN();
  result = solvePcg(h, b.data(), x.data(), options, pool);
  EXPECT_FALSE(result.converged);
  EXPECT_TRUE(std::isnan(result.relativeResidual));
}

TEST(Pcg, SolvesBlockDiagonalSystemsInOneIteration) {
  std::mt19937 rng(17);
  BlockSparseMatrix h = randomSpd(rng, /*offDiagonal=*/false);
  std::vector<double> b = randomVector(rng, h.size());
  std::vector<double> expected = denseSolve(h.toDense(), b);
  PcgOptions options;
  options.relativeTolerance = 1e-10;
  ThreadPool pool(3);
  std::vector<double> x(b.size());
  PcgResult result = solvePcg(h, b.data(), x.data(), options, pool);
  EXPECT_TRUE(result.converged);
  EXPECT_EQ(result.iterations, 1);
  EXPECT_LT(relativeError(x, expected), 1e-12);
}

TEST(Pcg, ZeroRightHandSideNeedsNoIteration) {
  std::mt19937 rng(19);
  BlockSparseMatrix h = randomSpd(rng);
  std::vector<double> b(static_cast<std::size_t>(h.size()), 0.0);
  std::vector<double> x(b.size(), 1.0);
  ThreadPool pool(1);
  PcgResult result = solvePcg(h, b.data(), x.data(), PcgOptions(), pool);
  EXPECT_TRUE(result.converged);
  EXPECT_EQ(result.iterations, 0);
  EXPECT_EQ(result.relativeResidual, 0.0);
  EXPECT_EQ(x, b);
}

namespace {
/// The matrix of blocks `locals` at `coords` in `layout`.
BlockSparseMatrix assembled(const BlockLayout &layout,
                            const std::vector<Coord> &coords,
                            const std::vector<std::vector<double>> &locals) {
  std::vector<BlockSlot> slots;
  BlockSparseMatrix m(layout, coords, &slots);
  for (std::size_t k = 0; k < slots.size(); ++k)
    m.addBlock(slots[k], locals[k].data());
  return m;
}

/// A chain of `n` springs on a line, fixed to a wall before
/// node 0, stiffness `ratio` and 1 alternating (node i hangs on spring i):
/// tridiagonal, 1x1 blocks.
BlockSparseMatrix springChain(std::int64_t n, double ratio) {
  BlockLayout layout = BlockLayout::fromSizes(std::vector<std::int64_t>(n, 1));
  std::vector<double> diagonal(static_cast<std::size_t>(n), 0.0);
  std::vector<Coord> coords;
  std::vector<std::vector<double>> locals;
  auto k = [&](std::int64_t i) { return i % 2 == 0 ? ratio : 1.0; };
  for (std::int64_t i = 0; i < n; ++i) {
    diagonal[i] += k(i);
    if (i > 0) {
      diagonal[i - 1] += k(i);
      coords.push_back({i, i - 1});
      locals.push_back({-k(i)});
    }
  }
  for (std::int64_t i = 0; i < n; ++i) {
    coords.push_back({i, i});
    locals.push_back({diagonal[i]});
  }
  return assembled(layout, coords, locals);
}

TEST(Pcg, FindsANonFiniteValueInAnyChunkOfALargeHessian) {
  // The finiteness checks split a large Hessian's values into chunks
  // shared over the pool: a value in the first, a middle or the last
  // chunk stops the solve, on one thread and on two.
  BlockSparseMatrix h = springChain(150000, 10.0);
  ASSERT_GT(h.values().size(), std::size_t{4} << 16);
  std::vector<double> b(static_cast<std::size_t>(h.size()), 1.0);
  for (unsigned threads : {1u, 2u})
    for (std::size_t at :
         {std::size_t{3}, h.values().size() / 2, h.values().size() - 1})
      for (double bad : {std::numeric_limits<double>::infinity(),
                         std::numeric_limits<double>::quiet_NaN()}) {
        const double kept = h.values()[at];
        h.values()[at] = bad;
        ThreadPool pool(threads);
        std::vector<double> x(b.size());
        PcgResult result = solvePcg(h, b.data(), x.data(), PcgOptions{}, pool);
        EXPECT_EQ(result.stop, PcgStop::NonFinite)
            << threads << " threads, value " << at << " = " << bad;
        h.values()[at] = kept;
      }
}

/// sqrt((x - ref)^T H (x - ref) / ref^T H ref).
double relativeEnergyError(const BlockSparseMatrix &H,
                           const std::vector<double> &x,
                           const std::vector<double> &reference) {
  std::int64_t n = H.size();
  std::vector<double> a = H.toDense(), e(x.size());
  for (std::size_t i = 0; i < x.size(); ++i)
    e[i] = x[i] - reference[i];
  auto norm2 = [&](const std::vector<double> &v) {
    double s = 0.0;
    for (std::int64_t i = 0; i < n; ++i)
      for (std::int64_t j = 0; j < n; ++j)
        s += v[i] * a[i * n + j] * v[j];
    return s;
  };
  return std::sqrt(norm2(e) / norm2(reference));
}

/// A load on the stiff first spring and a small one at the chain's end:
/// the residual's 2-norm sees the first and hardly the second.
std::vector<double> stiffLoad(std::int64_t n, double ratio) {
  std::vector<double> b(static_cast<std::size_t>(n), 0.0);
  b.front() = ratio;
  b.back() = 1.0;
  return b;
}
} // namespace

TEST(Pcg, ReportsTheResidualRecomputedFromTheSolution) {
  std::mt19937 rng(11);
  BlockSparseMatrix H = randomSpd(rng);
  std::vector<double> b = randomVector(rng, H.size());
  std::vector<double> x(b.size()), hx(b.size());
  ThreadPool pool(2);
  PcgOptions options;
  options.relativeTolerance = 1e-8;
  PcgResult result = solvePcg(H, b.data(), x.data(), options, pool);
  ASSERT_TRUE(result.converged);
  EXPECT_EQ(result.stop, PcgStop::Converged);
  H.multiply(x.data(), hx.data(), pool);
  double r = 0.0, bb = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    r += (b[i] - hx[i]) * (b[i] - hx[i]);
    bb += b[i] * b[i];
  }
  EXPECT_NEAR(result.relativeResidual, std::sqrt(r / bb), 1e-14);
  EXPECT_LE(result.relativeResidual, 1e-8);
}

TEST(Pcg, ATolerancePastRoundOffIsNotConvergence) {
  // The updated residual keeps falling far below what b - H x can reach;
  // restarted from the recomputed one twice without gain, PCG says so.
  std::mt19937 rng(12);
  BlockSparseMatrix H = randomSpd(rng);
  std::vector<double> b = randomVector(rng, H.size()), x(b.size());
  ThreadPool pool(1);
  PcgOptions options;
  options.relativeTolerance = 1e-22;
  options.maxIterations = 100000;
  PcgResult result = solvePcg(H, b.data(), x.data(), options, pool);
  EXPECT_FALSE(result.converged);
  EXPECT_EQ(result.stop, PcgStop::RoundOff);
  EXPECT_GE(result.residualReplacements, 2);
  EXPECT_LT(result.iterations, options.maxIterations);
  EXPECT_GT(result.relativeResidual, 1e-22);
  EXPECT_LT(result.relativeResidual, 1e-12);
}

TEST(Pcg, ShowsWhenAConvergedResidualSaysLittle) {
  // Stiffness ratio 1e8: one iteration meets the residual tolerance with
  // the soft end hardly moved. The diagonal ratio shows it.
  const std::int64_t n = 40;
  BlockSparseMatrix H = springChain(n, 1e8);
  std::vector<double> b = stiffLoad(n, 1e8), x(b.size());
  ThreadPool pool(1);
  PcgOptions options;
  options.relativeTolerance = 1e-4;
  PcgResult result = solvePcg(H, b.data(), x.data(), options, pool);
  ASSERT_TRUE(result.converged);
  EXPECT_EQ(result.iterations, 1);
  EXPECT_GT(relativeError(x, denseSolve(H.toDense(), b)), 0.9);
  EXPECT_GE(result.diagonalRatio, 1e7);
  EXPECT_GT(result.diagonalRatio * result.relativeResidual, 1.0);
  EXPECT_TRUE(std::isnan(result.conditionEstimate));
}

TEST(Pcg, EnergyNormStoppingMeasuresTheStep) {
  const std::int64_t n = 40;
  BlockSparseMatrix H = springChain(n, 1e4);
  std::vector<double> b = stiffLoad(n, 1e4);
  std::vector<double> reference = denseSolve(H.toDense(), b);
  ThreadPool pool(1);
  PcgOptions options;
  options.relativeTolerance = 1e-4;
  std::vector<double> byResidual(b.size()), byEnergy(b.size());
  PcgResult residual = solvePcg(H, b.data(), byResidual.data(), options, pool);
  options.stopping = PcgStopping::EnergyNorm;
  PcgResult energy = solvePcg(H, b.data(), byEnergy.data(), options, pool);
  ASSERT_TRUE(residual.converged);
  ASSERT_TRUE(energy.converged);
  // The residual rule stops with 4% left in the energy norm.
  EXPECT_GT(relativeEnergyError(H, byResidual, reference), 1e-2);
  EXPECT_LE(energy.energyError, 1e-4);
  EXPECT_LE(relativeEnergyError(H, byEnergy, reference), 1e-4);
  // CG's Ritz values see the conditioning the diagonal hides (1e4).
  EXPECT_GT(residual.conditionEstimate, 1e5);
}

TEST(Pcg, RitzValuesFindTheConditionNumber) {
  // The 1D Laplacian (2, -1): eigenvalues 2 - 2 cos(j pi / (n + 1)); the
  // Jacobi preconditioner only halves them.
  const std::int64_t n = 30;
  BlockLayout layout = BlockLayout::fromSizes(std::vector<std::int64_t>(n, 1));
  std::vector<Coord> coords;
  std::vector<std::vector<double>> locals;
  for (std::int64_t i = 0; i < n; ++i) {
    coords.push_back({i, i});
    locals.push_back({2.0});
    if (i > 0) {
      coords.push_back({i, i - 1});
      locals.push_back({-1.0});
    }
  }
  BlockSparseMatrix H = assembled(layout, coords, locals);
  std::mt19937 rng(13);
  std::vector<double> b = randomVector(rng, n), x(b.size());
  ThreadPool pool(1);
  PcgOptions options;
  options.relativeTolerance = 1e-12;
  PcgResult result = solvePcg(H, b.data(), x.data(), options, pool);
  ASSERT_TRUE(result.converged);
  const double pi = std::acos(-1.0);
  double expected =
      (1 - std::cos(n * pi / (n + 1))) / (1 - std::cos(pi / (n + 1)));
  EXPECT_NEAR(result.conditionEstimate / expected, 1.0, 1e-6);
}

TEST(Pcg, TridiagonalEigenvaluesByBisection) {
  // diag(1, 5, 3) with off-diagonals 0: exactly 1 and 5.
  auto [lo, hi] =
      yasps::runtime::tridiagonalExtremeEigenvalues({1, 5, 3}, {0, 0});
  EXPECT_NEAR(lo, 1.0, 1e-12);
  EXPECT_NEAR(hi, 5.0, 1e-12);
  // [[2, 1], [1, 2]]: 1 and 3.
  auto [a, c] = yasps::runtime::tridiagonalExtremeEigenvalues({2, 2}, {1});
  EXPECT_NEAR(a, 1.0, 1e-12);
  EXPECT_NEAR(c, 3.0, 1e-12);
}

TEST(Pcg, EnergyDelayMustBePositive) {
  std::mt19937 rng(14);
  BlockSparseMatrix H = randomSpd(rng);
  std::vector<double> b(static_cast<std::size_t>(H.size()), 1.0), x(b.size());
  ThreadPool pool(1);
  PcgOptions options;
  options.stopping = PcgStopping::EnergyNorm;
  options.energyDelay = 0;
  EXPECT_THROW(solvePcg(H, b.data(), x.data(), options, pool),
               std::invalid_argument);
}

TEST(Pcg, LargeSystemsGiveTheSameBitsOnEveryThreadCount) {
  // 6,000 vertex blocks (18,000 DoFs): enough that the vector steps, the
  // SpMV and block-Jacobi all split across the threads. Each adds in a
  // fixed order, so every thread count takes the same iterations to the
  // same solution, to the last bit.
  const std::int64_t numBlocks = 6000;
  BlockLayout layout =
      BlockLayout::fromSizes(std::vector<std::int64_t>(numBlocks, 3));
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<Coord> coords;
  for (std::int64_t i = 0; i < numBlocks; ++i)
    for (std::int64_t j : {i, i + 1, i + 7, i + 500})
      if (j < numBlocks)
        coords.push_back({i, j});
  std::vector<BlockSlot> slots;
  BlockSparseMatrix h(layout, coords, &slots);
  for (std::size_t k = 0; k < coords.size(); ++k) {
    std::vector<double> local(9);
    for (double &v : local)
      v = 0.2 * value(rng);
    if (coords[k].first == coords[k].second)
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < r; ++c)
          local[r * 3 + c] = local[c * 3 + r];
        local[r * 3 + r] += 3.0; // above the rows' absolute sums
      }
    h.addBlock(slots[k], local.data());
  }
  std::vector<double> b = randomVector(rng, h.size());
  PcgOptions options;
  options.relativeTolerance = 1e-10;
  std::vector<double> first;
  std::int64_t firstIterations = -1;
  for (unsigned threads : {1u, 2u, 3u}) {
    ThreadPool pool(threads);
    std::vector<double> x(b.size(), 0.0);
    PcgResult result = solvePcg(h, b.data(), x.data(), options, pool);
    ASSERT_TRUE(result.converged) << threads << " threads";
    if (first.empty()) {
      first = x;
      firstIterations = result.iterations;
      EXPECT_GT(firstIterations, 5);
      continue;
    }
    EXPECT_EQ(result.iterations, firstIterations) << threads << " threads";
    EXPECT_EQ(x, first) << threads << " threads";
  }
}

TEST(Pcg, TeamSolvesGiveTheOneThreadBits) {
  // On several threads a block-Jacobi solve runs as one team (each thread
  // a share of the product's rows and of the vector steps, barriers
  // between), and so does one with the additive multilevel preconditioner
  // (the restriction and prolongation shared too, the coarse cycle on one
  // member): with a Hessian in two parts (the dynamic one sparse), fixed
  // DoFs, 12x12 blocks among the vertex blocks (the general step) or none,
  // and both stopping rules, it takes the one-thread iterations to the
  // one-thread bits.
  for (auto [vertexOnly, preconditioner] :
       {std::pair{true, PcgPreconditioner::BlockJacobi},
        std::pair{false, PcgPreconditioner::BlockJacobi},
        std::pair{true, PcgPreconditioner::Multilevel},
        std::pair{false, PcgPreconditioner::Multilevel}}) {
    std::vector<std::int64_t> sizes(900, 3);
    if (!vertexOnly)
      for (std::size_t k = 40; k < sizes.size(); k += 97)
        sizes[k] = 12;
    BlockLayout layout = BlockLayout::fromSizes(sizes);
    const std::int64_t numBlocks = layout.numBlocks();
    std::mt19937 rng(vertexOnly ? 31 : 32);
    std::uniform_real_distribution<double> value(-1.0, 1.0);
    auto part = [&](const std::vector<Coord> &coords, double diagonal) {
      std::vector<std::vector<double>> locals;
      for (const Coord &c : coords) {
        const std::int64_t rows = layout.blockSize(c.first);
        const std::int64_t cols = layout.blockSize(c.second);
        std::vector<double> local(static_cast<std::size_t>(rows * cols));
        for (double &v : local)
          v = 0.15 * value(rng);
        if (c.first == c.second)
          for (std::int64_t r = 0; r < rows; ++r) {
            for (std::int64_t k = 0; k < r; ++k)
              local[r * rows + k] = local[k * rows + r];
            local[r * rows + r] += diagonal;
          }
        locals.push_back(std::move(local));
      }
      return assembled(layout, coords, locals);
    };
    std::vector<Coord> staticCoords, dynamicCoords;
    for (std::int64_t i = 0; i < numBlocks; ++i) {
      for (std::int64_t j : {i, i + 1, i + 9, i + 300})
        if (j < numBlocks)
          staticCoords.push_back({i, j});
      if (i % 5 == 0 && i + 450 < numBlocks)
        dynamicCoords.push_back({i, i + 450});
    }
    BlockSparseMatrix h = part(staticCoords, 4.0);
    BlockSparseMatrix contact = part(dynamicCoords, 0.0);
    std::vector<double> b = randomVector(rng, h.size());
    std::vector<std::uint8_t> fixed(b.size(), 0);
    for (std::size_t i = 0; i < fixed.size(); i += 37)
      fixed[i] = 1;
    for (PcgStopping stopping :
         {PcgStopping::Residual, PcgStopping::EnergyNorm}) {
      PcgOptions options;
      options.relativeTolerance = 1e-9;
      options.fixedDofs = &fixed;
      options.stopping = stopping;
      options.preconditioner = preconditioner;
      std::vector<double> first;
      PcgResult firstResult;
      for (unsigned threads : {1u, 2u, 3u}) {
        ThreadPool pool(threads);
        std::vector<double> x(b.size(), 0.0);
        PcgResult result = solvePcg(yasps::runtime::HessianParts{&h, &contact},
                                    b.data(), x.data(), options, pool);
        ASSERT_TRUE(result.converged) << threads << " threads";
        if (preconditioner == PcgPreconditioner::Multilevel)
          ASSERT_GT(result.levels, 1); // the fine level split
        if (first.empty()) {
          first = x;
          firstResult = result;
          EXPECT_GT(result.iterations, 5);
          continue;
        }
        EXPECT_EQ(result.iterations, firstResult.iterations) << threads;
        EXPECT_EQ(result.relativeResidual, firstResult.relativeResidual);
        EXPECT_EQ(result.conditionEstimate, firstResult.conditionEstimate);
        EXPECT_EQ(x, first) << threads << " threads";
      }
      for (std::size_t i = 0; i < fixed.size(); i += 37)
        EXPECT_EQ(first[i], 0.0);
    }
  }
}

TEST(BlockJacobi, StepApplyDotsMatchesTheStepsDoneApart) {
  // PCG's fused step (x += alpha p, r -= alpha q, z = M^-1 r, r.r, r.z)
  // against the same steps one at a time: on vertex blocks only (its own
  // loop) and with 12x12 blocks among them (the general one).
  using yasps::runtime::BlockJacobi;
  for (bool vertexOnly : {true, false}) {
    std::mt19937 rng(vertexOnly ? 5 : 6);
    BlockSparseMatrix h = randomSpd(rng);
    if (vertexOnly) {
      // randomSpd's layout has 12x12 blocks; this one 3x3 only.
      const std::int64_t numBlocks = 2500; // a few segments of blocks
      BlockLayout layout =
          BlockLayout::fromSizes(std::vector<std::int64_t>(numBlocks, 3));
      std::vector<Coord> coords;
      for (std::int64_t i = 0; i < numBlocks; ++i)
        coords.push_back({i, i});
      std::vector<BlockSlot> slots;
      h = BlockSparseMatrix(layout, coords, &slots);
      std::uniform_real_distribution<double> value(-1.0, 1.0);
      for (const BlockSlot &slot : slots) {
        double local[9];
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c <= r; ++c)
            local[r * 3 + c] = local[c * 3 + r] = 0.3 * value(rng);
        for (int r = 0; r < 3; ++r)
          local[r * 3 + r] += 2.0;
        h.addBlock(slot, local);
      }
    }
    const std::int64_t n = h.size();
    ThreadPool pool(2);
    BlockJacobi jacobi({&h}, nullptr, pool);
    const double alpha = 0.37;
    std::vector<double> p = randomVector(rng, n), q = randomVector(rng, n),
                        x = randomVector(rng, n), r = randomVector(rng, n);
    std::vector<double> xApart = x, rApart = r, zApart(n), z(n), partial;
    double rrApart = 0.0;
    for (std::int64_t i = 0; i < n; ++i) {
      xApart[i] += alpha * p[i];
      rApart[i] -= alpha * q[i];
      rrApart += rApart[i] * rApart[i];
    }
    jacobi.apply(rApart.data(), zApart.data(), pool);
    double rzApart = 0.0;
    for (std::int64_t i = 0; i < n; ++i)
      rzApart += rApart[i] * zApart[i];

    const std::vector<double> x0 = x, r0 = r;
    BlockJacobi::StepDots dots = jacobi.stepApplyDots(
        alpha, p.data(), q.data(), x.data(), r.data(), z.data(), partial, pool);
    EXPECT_EQ(x, xApart);
    EXPECT_EQ(r, rApart);
    EXPECT_EQ(z, zApart);
    EXPECT_NEAR(dots.rr, rrApart, 1e-13 * rrApart);
    EXPECT_NEAR(dots.rz, rzApart, 1e-13 * std::fabs(rzApart));
    // The sums' order is fixed by the blocks: one thread, the same bits.
    ThreadPool one(1);
    std::vector<double> x1 = x0, r1 = r0, z1(n);
    BlockJacobi::StepDots oneThread =
        jacobi.stepApplyDots(alpha, p.data(), q.data(), x1.data(), r1.data(),
                             z1.data(), partial, one);
    EXPECT_EQ(oneThread.rr, dots.rr);
    EXPECT_EQ(oneThread.rz, dots.rz);
  }
}
