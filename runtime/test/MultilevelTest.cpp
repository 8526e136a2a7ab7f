//===- MultilevelTest.cpp - tests of the multilevel preconditioner --------===//

#include "yasps/Runtime/Sparse/Multilevel.h"

#include "yasps/Runtime/Sparse/Aggregation.h"
#include "yasps/Runtime/Sparse/BlockSparseMatrix.h"
#include "yasps/Runtime/Sparse/Pcg.h"
#include "yasps/Runtime/Sparse/PcgSolver.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <utility>
#include <vector>

using namespace yasps::runtime;

namespace {
using Coord = std::pair<std::int64_t, std::int64_t>;

/// The stiffness of springs between the vertices of an n^3 grid (to their
/// axis and face-diagonal neighbours) plus a small mass on each: a mesh
/// whose low-frequency modes block-Jacobi converges slowly on. Spring
/// stiffness varies randomly (1-10); `extra` adds 12-DoF and 1-DoF blocks
/// coupled to some vertices.
struct Grid {
  BlockLayout layout;
  std::vector<Coord> coords;
  std::vector<std::vector<double>> locals;

  Grid(int n, double mass, bool extra, unsigned seed = 1) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> stiffness(1.0, 10.0);
    std::vector<std::int64_t> sizes(static_cast<std::size_t>(n * n * n), 3);
    if (extra) {
      sizes.push_back(12);
      sizes.push_back(1);
    }
    layout = BlockLayout::fromSizes(sizes);
    auto id = [n](int x, int y, int z) { return (z * n + y) * n + x; };
    for (std::int64_t b = 0; b < layout.numBlocks(); ++b) {
      std::int64_t s = layout.blockSize(b);
      std::vector<double> local(static_cast<std::size_t>(s * s), 0.0);
      for (std::int64_t k = 0; k < s; ++k)
        local[k * s + k] = mass;
      add(b, b, local);
    }
    const int steps[][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0},
                            {1, 0, 1}, {0, 1, 1}, {1, -1, 0}};
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
          for (const auto &d : steps) {
            int X = x + d[0], Y = y + d[1], Z = z + d[2];
            if (X < 0 || Y < 0 || X >= n || Y >= n || Z >= n)
              continue;
            double len =
                std::sqrt(double(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
            double k = stiffness(rng);
            std::vector<double> dd(9);
            for (int r = 0; r < 3; ++r)
              for (int c = 0; c < 3; ++c)
                dd[r * 3 + c] = k * d[r] * d[c] / (len * len);
            std::vector<double> minus(dd);
            for (double &v : minus)
              v = -v;
            std::int64_t i = id(x, y, z), j = id(X, Y, Z);
            add(i, i, dd);
            add(j, j, dd);
            add(i, j, minus);
          }
    if (extra) {
      // A 12-DoF body tied to vertex 0 and a 1-DoF block to vertex 1,
      // through diagonally dominant couplings.
      std::int64_t body = layout.numBlocks() - 2, scalar = body + 1;
      std::vector<double> tie(3 * 12, 0.0), bodyDiag(144, 0.0);
      for (int r = 0; r < 3; ++r)
        tie[r * 12 + r] = -0.5;
      for (int k = 0; k < 12; ++k)
        bodyDiag[k * 12 + k] = 2.0;
      add(0, body, tie);
      add(body, body, bodyDiag);
      std::vector<double> diag3(9, 0.0);
      for (int r = 0; r < 3; ++r)
        diag3[r * 3 + r] = 0.5;
      add(0, 0, diag3);
      std::vector<double> tie1 = {-0.5, 0.0, 0.0}, one = {2.0};
      add(1, scalar, tie1);
      add(scalar, scalar, one);
      std::vector<double> first(9, 0.0);
      first[0] = 0.5;
      add(1, 1, first);
    }
  }

  void add(std::int64_t i, std::int64_t j, std::vector<double> local) {
    coords.push_back({i, j});
    locals.push_back(std::move(local));
  }

  /// The matrix of the contributions [begin, end) (all by default).
  BlockSparseMatrix matrix(std::size_t begin = 0,
                           std::size_t end = SIZE_MAX) const {
    end = std::min(end, coords.size());
    std::vector<Coord> some(coords.begin() + begin, coords.begin() + end);
    std::vector<BlockSlot> slots;
    BlockSparseMatrix m(layout, some, &slots);
    for (std::size_t k = 0; k < slots.size(); ++k)
      m.addBlock(slots[k], locals[begin + k].data());
    return m;
  }
};

std::vector<double> randomVector(std::int64_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<double> v(static_cast<std::size_t>(n));
  for (double &e : v)
    e = value(rng);
  return v;
}

/// The dense matrix of the preconditioner M^-1, column by column.
std::vector<double> denseInverse(Multilevel &m, std::int64_t n,
                                 ThreadPool &pool) {
  std::vector<double> out(static_cast<std::size_t>(n * n)), e(n), z(n);
  for (std::int64_t j = 0; j < n; ++j) {
    std::fill(e.begin(), e.end(), 0.0);
    e[j] = 1.0;
    m.apply(e.data(), z.data(), pool);
    for (std::int64_t i = 0; i < n; ++i)
      out[i * n + j] = z[i];
  }
  return out;
}

/// Whether the dense symmetric n x n `a` has a Cholesky factor.
bool positiveDefinite(std::vector<double> a, std::int64_t n) {
  for (std::int64_t j = 0; j < n; ++j) {
    double d = a[j * n + j];
    for (std::int64_t k = 0; k < j; ++k)
      d -= a[j * n + k] * a[j * n + k];
    if (!(d > 0.0))
      return false;
    d = std::sqrt(d);
    a[j * n + j] = d;
    for (std::int64_t i = j + 1; i < n; ++i) {
      double v = a[i * n + j];
      for (std::int64_t k = 0; k < j; ++k)
        v -= a[i * n + k] * a[j * n + k];
      a[i * n + j] = v / d;
    }
  }
  return true;
}

PcgResult solve(const HessianParts &parts, const std::vector<double> &b,
                std::vector<double> &x, PcgPreconditioner preconditioner,
                ThreadPool &pool,
                const std::vector<std::uint8_t> *fixed = nullptr,
                bool additiveFine = true) {
  PcgOptions options;
  options.relativeTolerance = 1e-8;
  options.preconditioner = preconditioner;
  options.multilevel.coarsestDofs = 60;
  options.multilevel.additiveFine = additiveFine;
  options.fixedDofs = fixed;
  x.assign(b.size(), 0.0);
  return solvePcg(parts, b.data(), x.data(), options, pool);
}
} // namespace

TEST(Aggregation, GroupsNeighboursOfOneSize) {
  Grid grid(6, 0.1, /*extra=*/true);
  BlockSparseMatrix m = grid.matrix();
  Aggregates agg = aggregateBlocks({&m});
  const BlockLayout &layout = m.layout();
  ASSERT_EQ(agg.of.size(), static_cast<std::size_t>(layout.numBlocks()));
  std::vector<int> members(static_cast<std::size_t>(agg.count()), 0);
  for (std::int64_t b = 0; b < layout.numBlocks(); ++b) {
    ASSERT_GE(agg.of[b], 0) << "block " << b << " was not aggregated";
    EXPECT_EQ(agg.size[agg.of[b]], layout.blockSize(b));
    ++members[agg.of[b]];
  }
  // The body and the scalar block differ in size from every neighbour.
  EXPECT_EQ(members[agg.of[layout.numBlocks() - 2]], 1);
  EXPECT_EQ(members[agg.of[layout.numBlocks() - 1]], 1);
  // A vertex and its neighbours: far fewer aggregates than vertices.
  EXPECT_LT(agg.count(), layout.numBlocks() / 5);
}

/// Both cycles: the fine level added to the coarse levels' correction, and
/// the V-cycle through every level.
class MultilevelCycle : public ::testing::TestWithParam<bool> {};
INSTANTIATE_TEST_SUITE_P(Cycles, MultilevelCycle, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool> &info) {
                           return info.param ? "AdditiveFine" : "VCycle";
                         });

TEST_P(MultilevelCycle, IsSymmetricPositiveDefinite) {
  ThreadPool pool(1);
  Grid grid(5, 0.05, /*extra=*/true);
  BlockSparseMatrix m = grid.matrix();
  MultilevelOptions options;
  options.coarsestDofs = 40;
  options.additiveFine = GetParam();
  Multilevel levels({&m}, nullptr, pool, options);
  ASSERT_GE(levels.levelSizes().size(), 3u);
  // The default's few Lanczos steps find lmax(D^-1 A) well enough: w
  // lmax < 2 needs the estimate within 2/3 of lmax, which 40 steps find.
  MultilevelOptions precise = options;
  precise.eigenvalueSteps = 40;
  Multilevel reference({&m}, nullptr, pool, precise);
  ASSERT_EQ(levels.dampings().size(), reference.dampings().size());
  // An additive fine level is not damped.
  if (GetParam())
    EXPECT_EQ(levels.dampings().front(), 1.0);
  for (std::size_t l = 0; l < levels.dampings().size(); ++l) {
    double w = levels.dampings()[l], exact = reference.dampings()[l];
    EXPECT_GE(w, exact);
    EXPECT_LT(w, 1.5 * exact) << "level " << l;
  }
  const std::int64_t n = m.size();
  std::vector<double> inverse = denseInverse(levels, n, pool);
  double asymmetry = 0.0, largest = 0.0;
  for (std::int64_t i = 0; i < n; ++i)
    for (std::int64_t j = 0; j < n; ++j) {
      asymmetry = std::max(asymmetry,
                           std::fabs(inverse[i * n + j] - inverse[j * n + i]));
      largest = std::max(largest, std::fabs(inverse[i * n + j]));
    }
  EXPECT_LT(asymmetry, 1e-12 * largest);
  EXPECT_TRUE(positiveDefinite(inverse, n));
}

TEST_P(MultilevelCycle, StiffLocalModesKeepItPositiveDefinite) {
  // Contact pairs: rank-one couplings k g g^T of four nearby vertices (two
  // edges' midpoints pressed together along n), a million times stiffer
  // than the springs. lmax(D^-1 A) then lies in these few local modes,
  // which the default Lanczos steps from a random start miss: the damping
  // from that estimate alone made M^-1 indefinite and PCG broke down.
  ThreadPool pool(1);
  const int n = 6;
  Grid grid(n, 0.01, /*extra=*/false);
  auto id = [n](int x, int y, int z) { return (z * n + y) * n + x; };
  const double normal[3] = {0.0, 0.6, 0.8}, weight[4] = {0.5, 0.5, -0.5, -0.5};
  for (int pair = 0; pair < 6; ++pair) {
    const std::int64_t v[4] = {id(pair % 5, 1, 2), id(pair % 5 + 1, 1, 2),
                               id(pair % 5, 2, 2), id(pair % 5 + 1, 2, 3)};
    for (int i = 0; i < 4; ++i)
      for (int j = i; j < 4; ++j) {
        std::vector<double> local(9);
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c)
            local[r * 3 + c] =
                1e6 * weight[i] * weight[j] * normal[r] * normal[c];
        grid.add(v[i], v[j], local);
      }
  }
  BlockSparseMatrix m = grid.matrix();
  MultilevelOptions options;
  options.coarsestDofs = 40;
  options.additiveFine = GetParam();
  Multilevel levels({&m}, nullptr, pool, options);
  ASSERT_GE(levels.levelSizes().size(), 3u);
  EXPECT_TRUE(positiveDefinite(denseInverse(levels, m.size(), pool), m.size()));
  std::vector<double> b = randomVector(m.size(), 11), x;
  PcgResult result = solve({&m}, b, x, PcgPreconditioner::Multilevel, pool,
                           nullptr, GetParam());
  EXPECT_TRUE(result.converged) << result.iterations << " iterations";
  EXPECT_LE(result.relativeResidual, 1e-8);
}

TEST_P(MultilevelCycle, NeedsFewerIterationsThanBlockJacobi) {
  ThreadPool pool(1);
  Grid grid(10, 0.01, /*extra=*/true);
  BlockSparseMatrix m = grid.matrix();
  std::vector<double> b = randomVector(m.size(), 7), jacobiX, multilevelX;
  PcgResult jacobi =
      solve({&m}, b, jacobiX, PcgPreconditioner::BlockJacobi, pool);
  PcgResult multilevel =
      solve({&m}, b, multilevelX, PcgPreconditioner::Multilevel, pool, nullptr,
            GetParam());
  ASSERT_TRUE(jacobi.converged);
  ASSERT_TRUE(multilevel.converged);
  EXPECT_GE(multilevel.levels, 3);
  EXPECT_LE(multilevel.relativeResidual, 1e-8);
  // What each must save to pay: a V-cycle costs about 3.5 block-Jacobi
  // iterations, an additive fine level about 1.5 (docs/benchmarks.md).
  // On this grid the V-cycle takes a third of block-Jacobi's iterations
  // and the additive one half (141 against 278).
  const double share = GetParam() ? 0.6 : 1.0 / 3.0;
  EXPECT_LT(multilevel.iterations, share * jacobi.iterations)
      << multilevel.iterations << " against " << jacobi.iterations;
  double diff = 0.0, norm = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    diff = std::max(diff, std::fabs(jacobiX[i] - multilevelX[i]));
    norm = std::max(norm, std::fabs(jacobiX[i]));
  }
  EXPECT_LT(diff, 1e-6 * norm);
}

TEST(Multilevel, SolvesOnTheFreeDofsOnly) {
  ThreadPool pool(1);
  Grid grid(8, 0.01, /*extra=*/false);
  BlockSparseMatrix m = grid.matrix();
  // A fixed face of the grid and scattered single DoFs.
  std::vector<std::uint8_t> fixed(static_cast<std::size_t>(m.size()), 0);
  for (std::int64_t v = 0; v < 64; ++v)
    for (int k = 0; k < 3; ++k)
      fixed[3 * v + k] = 1;
  for (std::int64_t i = 300; i < m.size(); i += 37)
    fixed[i] = 1;
  std::vector<double> b = randomVector(m.size(), 3), jacobiX, multilevelX;
  PcgResult jacobi =
      solve({&m}, b, jacobiX, PcgPreconditioner::BlockJacobi, pool, &fixed);
  PcgResult multilevel =
      solve({&m}, b, multilevelX, PcgPreconditioner::Multilevel, pool, &fixed);
  ASSERT_TRUE(jacobi.converged);
  ASSERT_TRUE(multilevel.converged);
  EXPECT_LT(multilevel.iterations, jacobi.iterations);
  for (std::size_t i = 0; i < b.size(); ++i) {
    if (fixed[i]) {
      EXPECT_EQ(multilevelX[i], 0.0);
    }
    EXPECT_NEAR(multilevelX[i], jacobiX[i], 1e-6);
  }
}

TEST(Multilevel, SmallSystemsAreSolvedExactly) {
  ThreadPool pool(1);
  Grid grid(3, 0.1, /*extra=*/true);
  BlockSparseMatrix m = grid.matrix();
  std::vector<double> b = randomVector(m.size(), 5), x;
  PcgOptions options;
  options.relativeTolerance = 1e-10;
  options.preconditioner = PcgPreconditioner::Multilevel;
  x.assign(b.size(), 0.0);
  PcgResult result = solvePcg({&m}, b.data(), x.data(), options, pool);
  // One level, under coarsestDofs: the preconditioner is H^-1.
  EXPECT_EQ(result.levels, 1);
  EXPECT_TRUE(result.converged);
  EXPECT_LE(result.iterations, 2);
}

TEST(Multilevel, RefreshFollowsValuesAndChangedParts) {
  ThreadPool pool(1);
  Grid grid(7, 0.01, /*extra=*/false);
  // The diagonal and the first springs are the static part; the last
  // springs the dynamic one, which changes.
  std::size_t split = grid.coords.size() - 200;
  BlockSparseMatrix fixedPart = grid.matrix(0, split);
  BlockSparseMatrix dynamic = grid.matrix(split);
  BlockSparseMatrix fewer = grid.matrix(split + 100);
  std::vector<double> b = randomVector(fixedPart.size(), 11), fresh, kept;
  PcgOptions options;
  options.relativeTolerance = 1e-8;
  options.preconditioner = PcgPreconditioner::Multilevel;
  options.multilevel.coarsestDofs = 60;
  std::unique_ptr<Multilevel> cache;
  options.multilevelCache = &cache;
  auto run = [&](const HessianParts &parts, std::vector<double> &x,
                 bool cached) {
    PcgOptions o = options;
    if (!cached)
      o.multilevelCache = nullptr;
    x.assign(b.size(), 0.0);
    return solvePcg(parts, b.data(), x.data(), o, pool);
  };
  run({&fixedPart, &dynamic}, kept, true);
  const Multilevel *built = cache.get();
  for (double &v : fixedPart.values())
    v *= 2.0;
  for (const HessianParts &parts :
       {HessianParts{&fixedPart, &dynamic}, HessianParts{&fixedPart, &fewer}}) {
    PcgResult a = run(parts, kept, true);
    PcgResult c = run(parts, fresh, false);
    EXPECT_EQ(cache.get(), built) << "the levels were rebuilt";
    EXPECT_EQ(a.iterations, c.iterations);
    for (std::size_t i = 0; i < b.size(); ++i)
      EXPECT_EQ(kept[i], fresh[i]);
  }
}

TEST(PcgSolver, KeepsTheLevelsBetweenSolvesAsACacheDoes) {
  ThreadPool pool(1);
  Grid grid(6, 0.01, /*extra=*/true);
  BlockSparseMatrix m = grid.matrix();
  std::vector<double> b = randomVector(m.size(), 17);
  PcgOptions jacobi;
  jacobi.relativeTolerance = 1e-8;
  PcgOptions levels = jacobi;
  levels.preconditioner = PcgPreconditioner::Multilevel;
  levels.multilevel.coarsestDofs = 60;
  PcgSolver solver;
  std::vector<double> x(b.size()), fresh(b.size());

  // Block-Jacobi keeps nothing; a multilevel solve keeps its levels.
  EXPECT_TRUE(solver.solve({&m}, b.data(), x.data(), jacobi, pool).converged);
  EXPECT_FALSE(solver.keepsPreconditioner());
  EXPECT_TRUE(solver.solve({&m}, b.data(), x.data(), levels, pool).converged);
  EXPECT_TRUE(solver.keepsPreconditioner());

  // New values, same structure: the kept levels are refreshed, and the
  // solve is that of levels built afresh, to the bit.
  for (double &v : m.values())
    v *= 3.0;
  PcgResult kept = solver.solve({&m}, b.data(), x.data(), levels, pool);
  PcgResult built = solvePcg({&m}, b.data(), fresh.data(), levels, pool);
  EXPECT_EQ(kept.iterations, built.iterations);
  for (std::size_t i = 0; i < b.size(); ++i)
    EXPECT_EQ(x[i], fresh[i]);

  // A cache the caller gives is used instead of the solver's own.
  solver.forget();
  EXPECT_FALSE(solver.keepsPreconditioner());
  std::unique_ptr<Multilevel> own;
  PcgOptions shared = levels;
  shared.multilevelCache = &own;
  EXPECT_TRUE(solver.solve({&m}, b.data(), x.data(), shared, pool).converged);
  EXPECT_TRUE(own != nullptr);
  EXPECT_FALSE(solver.keepsPreconditioner());
}

TEST(Multilevel, ResultsDoNotDependOnTheThreadCount) {
  Grid grid(9, 0.01, /*extra=*/true);
  BlockSparseMatrix m = grid.matrix();
  std::vector<double> b = randomVector(m.size(), 13), one, three;
  ThreadPool serial(1), parallel(3);
  PcgResult a = solve({&m}, b, one, PcgPreconditioner::Multilevel, serial);
  PcgResult c = solve({&m}, b, three, PcgPreconditioner::Multilevel, parallel);
  EXPECT_EQ(a.iterations, c.iterations);
  for (std::size_t i = 0; i < b.size(); ++i)
    EXPECT_EQ(one[i], three[i]);
}
