//===- BlockSparseMatrixTest.cpp - tests of the block-sparse Hessian ------===//

#include "yasps/Runtime/Sparse/BlockSparseMatrix.h"

#include "yasps/Runtime/Support/ThreadPool.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <tuple>
#include <utility>
#include <vector>

using yasps::runtime::BlockLayout;
using yasps::runtime::BlockSlot;
using yasps::runtime::BlockSparseMatrix;
using yasps::runtime::ThreadPool;

namespace {
using Coord = std::pair<std::int64_t, std::int64_t>;

/// A random problem: local blocks at random coordinates (both triangles,
/// repeats), assembled both into the matrix and into a dense reference that
/// adds each off-diagonal block and its transpose.
struct RandomAssembly {
  BlockLayout layout;
  std::vector<Coord> coords;
  std::vector<std::vector<double>> locals;
  std::vector<double> dense;
};

RandomAssembly makeAssembly(std::mt19937 &rng, std::int64_t numBlocks,
                            std::int64_t numCoords) {
  RandomAssembly a;
  std::vector<std::int64_t> sizes;
  std::uniform_int_distribution<int> pickSize(0, 2);
  const std::int64_t shapes[] = {3, 12, 9};
  for (std::int64_t i = 0; i < numBlocks; ++i)
    sizes.push_back(shapes[pickSize(rng)]);
  a.layout = BlockLayout::fromSizes(sizes);
  std::int64_t n = a.layout.blockOffset.back();
  a.dense.assign(static_cast<std::size_t>(n * n), 0.0);
  std::uniform_int_distribution<std::int64_t> pickBlock(0, numBlocks - 1);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  for (std::int64_t k = 0; k < numCoords; ++k) {
    std::int64_t i = pickBlock(rng);
    // Some diagonal blocks and some repeats of earlier coordinates.
    std::int64_t j = k % 5 == 0 ? i : pickBlock(rng);
    if (k % 7 == 3 && !a.coords.empty())
      std::tie(j, i) = a.coords[static_cast<std::size_t>(k) / 2];
    std::int64_t rows = a.layout.blockSize(i), cols = a.layout.blockSize(j);
    std::vector<double> local(static_cast<std::size_t>(rows * cols));
    for (double &v : local)
      v = value(rng);
    if (i == j) // Diagonal contributions are symmetric.
      for (std::int64_t r = 0; r < rows; ++r)
        for (std::int64_t c = 0; c < r; ++c)
          local[r * cols + c] = local[c * cols + r];
    for (std::int64_t r = 0; r < rows; ++r)
      for (std::int64_t c = 0; c < cols; ++c) {
        std::int64_t gi = a.layout.blockOffset[i] + r;
        std::int64_t gj = a.layout.blockOffset[j] + c;
        a.dense[gi * n + gj] += local[r * cols + c];
        if (i != j)
          a.dense[gj * n + gi] += local[r * cols + c];
      }
    a.coords.push_back({i, j});
    a.locals.push_back(std::move(local));
  }
  return a;
}

void expectNear(const std::vector<double> &actual,
                const std::vector<double> &expected, double tolerance) {
  ASSERT_EQ(actual.size(), expected.size());
  for (std::size_t k = 0; k < actual.size(); ++k)
    ASSERT_NEAR(actual[k], expected[k], tolerance) << "at index " << k;
}
} // namespace

TEST(BlockSparseMatrix, NormalisesAndDeduplicatesByShape) {
  // Blocks of 3, 12, 9 and 3 DoFs.
  BlockLayout layout = BlockLayout::fromSizes({3, 12, 9, 3});
  std::vector<Coord> coords = {{1, 0}, {0, 1}, {2, 2}, {3, 0}, {0, 0},
                               {2, 1}, {0, 3}, {3, 3}, {1, 2}, {2, 3}};
  std::vector<BlockSlot> slots;
  BlockSparseMatrix m(layout, coords, &slots);
  EXPECT_EQ(m.numBlocks(), 4);
  EXPECT_EQ(m.size(), 27);
  // Unique upper coordinates: (0,0) (0,1) (0,3) (1,2) (2,2) (2,3) (3,3).
  ASSERT_EQ(m.numStoredBlocks(), 7u);

  // Groups sorted by shape, blocks inside by (row, col).
  const auto &groups = m.groups();
  ASSERT_EQ(groups.size(), 5u);
  struct Expected {
    std::int64_t rows, cols;
    std::vector<std::int64_t> row, col;
  };
  std::vector<Expected> expected = {{3, 3, {0, 0, 3}, {0, 3, 3}},
                                    {3, 12, {0}, {1}},
                                    {9, 3, {2}, {3}},
                                    {9, 9, {2}, {2}},
                                    {12, 9, {1}, {2}}};
  std::size_t first = 0;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    EXPECT_EQ(groups[g].rows, expected[g].rows) << "group " << g;
    EXPECT_EQ(groups[g].cols, expected[g].cols) << "group " << g;
    EXPECT_EQ(groups[g].rowCoordinate, expected[g].row) << "group " << g;
    EXPECT_EQ(groups[g].colCoordinate, expected[g].col) << "group " << g;
    EXPECT_EQ(groups[g].firstBlock, first);
    for (std::size_t k = 0; k < groups[g].size(); ++k) {
      EXPECT_EQ(m.blockRow(first + k), expected[g].row[k]);
      EXPECT_EQ(m.blockCol(first + k), expected[g].col[k]);
    }
    first += groups[g].size();
  }

  // Values are contiguous, block after block.
  std::size_t values = 9 + 9 + 9 + 36 + 27 + 81 + 108;
  EXPECT_EQ(m.values().size(), values);
  for (std::size_t b = 0; b + 1 < m.numStoredBlocks(); ++b)
    EXPECT_EQ(m.blockData(b + 1) - m.blockData(b),
              m.layout().blockSize(m.blockRow(b)) *
                  m.layout().blockSize(m.blockCol(b)));

  // Per input coordinate: block (0,0)=0 (0,3)=1 (3,3)=2 (0,1)=3 (2,3)=4
  // (2,2)=5 (1,2)=6.
  std::vector<BlockSlot> expectedSlots = {
      {3, true}, {3, false}, {5, false}, {1, true},  {0, false},
      {6, true}, {1, false}, {2, false}, {6, false}, {4, false}};
  EXPECT_EQ(slots, expectedSlots);
}

TEST(BlockSparseMatrix, RejectsBadLayoutsAndCoordinates) {
  EXPECT_THROW(BlockSparseMatrix(BlockLayout{{}}, {}), std::invalid_argument);
  EXPECT_THROW(BlockSparseMatrix(BlockLayout{{1, 3}}, {}),
               std::invalid_argument);
  EXPECT_THROW(BlockSparseMatrix(BlockLayout{{0, 3, 2}}, {}),
               std::invalid_argument);
  BlockLayout layout = BlockLayout::fromSizes({3, 3});
  EXPECT_THROW(BlockSparseMatrix(layout, {{0, 2}}), std::invalid_argument);
  EXPECT_THROW(BlockSparseMatrix(layout, {{-1, 0}}), std::invalid_argument);
  BlockSparseMatrix m(layout, {{0, 1}});
  std::vector<double> local(9, 1.0);
  EXPECT_THROW(m.addBlock({1, false}, local.data()), std::out_of_range);
  // An empty structure is fine.
  BlockSparseMatrix empty(layout, {});
  EXPECT_EQ(empty.numStoredBlocks(), 0u);
  EXPECT_EQ(empty.toDense(), std::vector<double>(36, 0.0));
}

TEST(BlockSparseMatrix, AssemblesLikeADenseReference) {
  std::mt19937 rng(7);
  RandomAssembly a = makeAssembly(rng, 20, 120);
  std::vector<BlockSlot> slots;
  BlockSparseMatrix m(a.layout, a.coords, &slots);
  ASSERT_EQ(slots.size(), a.coords.size());
  for (std::size_t k = 0; k < a.coords.size(); ++k) {
    BlockSlot slot = slots[k];
    EXPECT_EQ(slot.transposed, a.coords[k].first > a.coords[k].second);
    EXPECT_EQ(m.blockRow(slot.block),
              std::min(a.coords[k].first, a.coords[k].second));
    EXPECT_EQ(m.blockCol(slot.block),
              std::max(a.coords[k].first, a.coords[k].second));
    m.addBlock(slot, a.locals[k].data());
  }
  expectNear(m.toDense(), a.dense, 1e-12);

  // Assembling again after setZero gives the same matrix, here from
  // several threads at once.
  m.setZero();
  EXPECT_EQ(m.toDense(), std::vector<double>(a.dense.size(), 0.0));
  ThreadPool pool(4);
  pool.parallelFor(0, static_cast<std::int64_t>(slots.size()), 1,
                   [&](std::int64_t begin, std::int64_t end) {
                     for (std::int64_t k = begin; k < end; ++k)
                       m.addBlockConcurrent(slots[k], a.locals[k].data());
                   });
  expectNear(m.toDense(), a.dense, 1e-12);
}

TEST(BlockSparseMatrix, MultipliesLikeTheDenseMatrix) {
  std::mt19937 rng(11);
  RandomAssembly a = makeAssembly(rng, 200, 900);
  std::vector<BlockSlot> slots;
  BlockSparseMatrix m(a.layout, a.coords, &slots);
  for (std::size_t k = 0; k < slots.size(); ++k)
    m.addBlock(slots[k], a.locals[k].data());
  std::int64_t n = m.size();
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<double> x(static_cast<std::size_t>(n));
  for (double &v : x)
    v = value(rng);
  std::vector<double> expected(static_cast<std::size_t>(n), 0.0);
  for (std::int64_t i = 0; i < n; ++i)
    for (std::int64_t j = 0; j < n; ++j)
      expected[i] += a.dense[i * n + j] * x[j];

  std::vector<double> first;
  for (unsigned threads : {1u, 2u, 3u, 8u}) {
    ThreadPool pool(threads);
    // Stale values in y must not leak into the product.
    std::vector<double> y(static_cast<std::size_t>(n), 123.0);
    m.multiply(x.data(), y.data(), pool);
    expectNear(y, expected, 1e-10);
    // The summation order is fixed, so every thread count agrees exactly.
    if (first.empty())
      first = y;
    else
      EXPECT_EQ(y, first) << threads << " threads";
  }
}

TEST(BlockSparseMatrix, VertexBlocksGiveTheSameBitsOnEveryThreadCount) {
  // Only 3x3 blocks at random coordinates, so that every range reads many
  // blocks above it: one thread makes one storage-order pass, more split
  // the rows (SIMD kernels where the CPU has them, else scalar products);
  // all add in the same order.
  std::mt19937 rng(5);
  BlockLayout layout =
      BlockLayout::fromSizes(std::vector<std::int64_t>(300, 3));
  const std::int64_t n = layout.blockOffset.back();
  std::uniform_int_distribution<std::int64_t> pick(0, 299);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<double> dense(static_cast<std::size_t>(n * n), 0.0);
  std::vector<std::pair<std::int64_t, std::int64_t>> coords;
  std::vector<std::vector<double>> locals;
  for (int k = 0; k < 2000; ++k) {
    std::int64_t i = pick(rng), j = k % 4 == 0 ? i : pick(rng);
    std::vector<double> local(9);
    for (double &v : local)
      v = value(rng) * std::exp(8.0 * value(rng));
    if (i == j)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < r; ++c)
          local[r * 3 + c] = local[c * 3 + r];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        dense[(3 * i + r) * n + 3 * j + c] += local[r * 3 + c];
        if (i != j)
          dense[(3 * j + c) * n + 3 * i + r] += local[r * 3 + c];
      }
    coords.push_back({i, j});
    locals.push_back(local);
  }
  std::vector<BlockSlot> slots;
  BlockSparseMatrix m(layout, coords, &slots);
  for (std::size_t k = 0; k < slots.size(); ++k)
    m.addBlock(slots[k], locals[k].data());
  std::vector<double> x(static_cast<std::size_t>(n));
  for (double &v : x)
    v = value(rng);
  std::vector<double> expected(static_cast<std::size_t>(n), 0.0);
  for (std::int64_t i = 0; i < n; ++i)
    for (std::int64_t j = 0; j < n; ++j)
      expected[i] += dense[i * n + j] * x[j];
  std::vector<double> one(static_cast<std::size_t>(n), 7.0);
  ThreadPool single(1);
  m.multiply(x.data(), one.data(), single);
  double scale = 0.0;
  for (double e : expected)
    scale = std::max(scale, std::abs(e));
  expectNear(one, expected, 1e-12 * scale);
  for (unsigned threads : {2u, 3u, 4u}) {
    ThreadPool pool(threads);
    ASSERT_EQ(m.rowRanges(threads).size(), threads + 1);
    std::vector<double> split(static_cast<std::size_t>(n), -7.0);
    m.multiply(x.data(), split.data(), pool);
    EXPECT_EQ(split, one) << threads << " threads";
  }
}

TEST(BlockSparseMatrix, RowRangesSplitTheProductEvenly) {
  // A banded vertex matrix (a chain, each block coupled to the next 4):
  // the ranges partition the rows in order and read about the same number
  // of blocks each, counting those above a range in its columns.
  const std::int64_t numBlocks = 2000;
  BlockLayout layout =
      BlockLayout::fromSizes(std::vector<std::int64_t>(numBlocks, 3));
  std::vector<std::pair<std::int64_t, std::int64_t>> coords;
  for (std::int64_t i = 0; i < numBlocks; ++i)
    for (std::int64_t j = i; j < std::min(numBlocks, i + 5); ++j)
      coords.push_back({i, j});
  BlockSparseMatrix m(layout, coords);
  for (unsigned parts : {1u, 2u, 3u, 7u}) {
    const std::vector<std::int64_t> &ranges = m.rowRanges(parts);
    ASSERT_EQ(ranges.size(), parts + 1);
    EXPECT_EQ(ranges.front(), 0);
    EXPECT_EQ(ranges.back(), numBlocks);
    std::vector<double> cost(parts, 0.0);
    for (std::size_t b = 0; b < m.numStoredBlocks(); ++b)
      for (unsigned t = 0; t < parts; ++t) {
        std::int64_t r = m.blockRow(b), c = m.blockCol(b);
        bool own = ranges[t] <= r && r < ranges[t + 1];
        bool above = r < ranges[t] && ranges[t] <= c && c < ranges[t + 1];
        cost[t] += own || above;
      }
    const double total = static_cast<double>(m.numStoredBlocks());
    for (unsigned t = 0; t < parts; ++t)
      EXPECT_NEAR(cost[t], total / parts, 0.01 * total) << t << "/" << parts;
    // Cached: the same ranges, at the same place.
    EXPECT_EQ(&m.rowRanges(parts), &ranges);
  }
  // A matrix too small to split gets one range.
  BlockSparseMatrix small(BlockLayout::fromSizes({3, 3}), {{0, 1}});
  EXPECT_EQ(small.rowRanges(4), (std::vector<std::int64_t>{0, 2}));
}

TEST(BlockSparseMatrix, ShortRowsBesideVertexBlocksKeepToTheirRows) {
  // Vertex blocks with 1-DoF blocks between them and last: the SIMD
  // kernels touch three entries of y per row; a 1-DoF row must not be
  // handed to them (the sanitizer run catches the read and write past y's
  // end).
  std::mt19937 rng(17);
  std::vector<std::int64_t> sizes;
  for (int k = 0; k < 300; ++k)
    sizes.push_back(k % 3 == 2 ? 1 : 3);
  sizes.push_back(1);
  BlockLayout layout = BlockLayout::fromSizes(sizes);
  const std::int64_t numBlocks = layout.numBlocks(),
                     n = layout.blockOffset.back();
  std::uniform_int_distribution<std::int64_t> pick(0, numBlocks - 1);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<double> dense(static_cast<std::size_t>(n * n), 0.0);
  std::vector<std::pair<std::int64_t, std::int64_t>> coords;
  std::vector<std::vector<double>> locals;
  for (int k = 0; k < 1500; ++k) {
    std::int64_t i = pick(rng), j = k % 4 == 0 ? i : pick(rng);
    std::int64_t rows = layout.blockSize(i), cols = layout.blockSize(j);
    std::vector<double> local(static_cast<std::size_t>(rows * cols));
    for (double &v : local)
      v = value(rng);
    if (i == j)
      for (std::int64_t r = 0; r < rows; ++r)
        for (std::int64_t c = 0; c < r; ++c)
          local[r * cols + c] = local[c * cols + r];
    for (std::int64_t r = 0; r < rows; ++r)
      for (std::int64_t c = 0; c < cols; ++c) {
        std::int64_t gi = layout.blockOffset[i] + r,
                     gj = layout.blockOffset[j] + c;
        dense[gi * n + gj] += local[r * cols + c];
        if (i != j)
          dense[gj * n + gi] += local[r * cols + c];
      }
    coords.push_back({i, j});
    locals.push_back(std::move(local));
  }
  std::vector<BlockSlot> slots;
  BlockSparseMatrix m(layout, coords, &slots);
  for (std::size_t k = 0; k < slots.size(); ++k)
    m.addBlock(slots[k], locals[k].data());
  std::vector<double> x(static_cast<std::size_t>(n));
  for (double &v : x)
    v = value(rng);
  std::vector<double> expected(static_cast<std::size_t>(n), 0.0);
  for (std::int64_t i = 0; i < n; ++i)
    for (std::int64_t j = 0; j < n; ++j)
      expected[i] += dense[i * n + j] * x[j];
  std::vector<float> rounded(m.values().begin(), m.values().end());
  for (unsigned threads : {1u, 2u, 3u}) {
    ThreadPool pool(threads);
    std::vector<double> y(static_cast<std::size_t>(n), 9.0);
    m.multiply(x.data(), y.data(), pool);
    expectNear(y, expected, 1e-12);
    m.multiplyRounded(rounded, x.data(), y.data(), pool);
    expectNear(y, expected, 1e-5);
  }
}

TEST(BlockSparseMatrix, SingleValuesMultiplyAsTheRoundedMatrix) {
  // The f32 copy is widened exactly and multiplied in the same order, so
  // the product is, to the bit, that of a matrix whose f64 values are the
  // rounded ones, on every thread count and block shape (3x3 SIMD and the
  // generic products); and it differs from the unrounded product.
  std::mt19937 rng(13);
  RandomAssembly a = makeAssembly(rng, 200, 900);
  std::vector<BlockSlot> slots;
  BlockSparseMatrix m(a.layout, a.coords, &slots);
  for (std::size_t k = 0; k < slots.size(); ++k)
    m.addBlock(slots[k], a.locals[k].data());
  BlockSparseMatrix rounded(a.layout, a.coords);
  rounded.values() = m.values();
  for (double &v : rounded.values())
    v = static_cast<double>(static_cast<float>(v));
  const std::size_t n = static_cast<std::size_t>(m.size());
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<double> x(n);
  for (double &v : x)
    v = value(rng);
  std::vector<double> exact(n), want(n), got(n, 5.0);
  ThreadPool single(1);
  m.multiply(x.data(), exact.data(), single);
  EXPECT_FALSE(m.hasSingleValues());
  // An outside f32 copy gives the rounded matrix's product, the matrix
  // itself still the exact one.
  std::vector<float> copy(m.values().begin(), m.values().end());
  for (unsigned threads : {1u, 2u, 3u}) {
    ThreadPool pool(threads);
    rounded.multiply(x.data(), want.data(), pool);
    m.multiplyRounded(copy, x.data(), got.data(), pool);
    EXPECT_EQ(got, want) << threads << " threads";
  }
  EXPECT_FALSE(m.hasSingleValues());
  copy.pop_back();
  EXPECT_THROW(m.multiplyRounded(copy, x.data(), got.data(), single),
               std::invalid_argument);
  m.roundValuesForProduct();
  EXPECT_TRUE(m.hasSingleValues());
  for (unsigned threads : {1u, 2u, 3u}) {
    ThreadPool pool(threads);
    rounded.multiply(x.data(), want.data(), pool);
    m.multiply(x.data(), got.data(), pool);
    EXPECT_EQ(got, want) << threads << " threads";
  }
  EXPECT_NE(got, exact);
  // f32's round-off of the entries, and no more.
  expectNear(got, exact, 1e-5);
  // setZero drops the copy: products read the (zero) values again.
  m.setZero();
  EXPECT_FALSE(m.hasSingleValues());
  m.multiply(x.data(), got.data(), single);
  EXPECT_EQ(got, std::vector<double>(n, 0.0));
}

TEST(BlockSparseMatrix, ExtractsDiagonalBlocks) {
  BlockLayout layout = BlockLayout::fromSizes({3, 12, 9});
  // Block 1 has no diagonal block stored.
  BlockSparseMatrix m(layout, {{0, 0}, {2, 2}, {0, 1}, {1, 2}});
  for (std::size_t k = 0; k < m.values().size(); ++k)
    m.values()[k] = static_cast<double>(k + 1);
  std::vector<double> dense = m.toDense();
  std::vector<double> diagonal;
  m.diagonalBlocks(diagonal);
  ASSERT_EQ(diagonal.size(), 9u + 144u + 81u);
  std::int64_t n = m.size();
  std::size_t pos = 0;
  for (std::int64_t b = 0; b < m.numBlocks(); ++b) {
    std::int64_t s = layout.blockSize(b), o = layout.blockOffset[b];
    for (std::int64_t i = 0; i < s; ++i)
      for (std::int64_t j = 0; j < s; ++j, ++pos) {
        double expected = b == 1 ? 0.0 : dense[(o + i) * n + o + j];
        EXPECT_EQ(diagonal[pos], expected)
            << "block " << b << " at (" << i << ", " << j << ")";
      }
  }
}
