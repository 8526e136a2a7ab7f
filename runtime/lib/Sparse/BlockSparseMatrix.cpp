//===- BlockSparseMatrix.cpp - symmetric block-sparse Hessian -------------===//

#include "yasps/Runtime/Sparse/BlockSparseMatrix.h"

#include "yasps/Runtime/Support/ThreadPool.h"

#include "VertexBlockSpmv.h"

#include <algorithm>
#include <atomic>
#include <climits>
#include <map>
#include <stdexcept>
#include <string>

using namespace yasps::runtime;

// Enough stripes that threads assembling different blocks rarely wait on
// each other, few enough to cost nothing per matrix.
static constexpr std::size_t kNumLocks = 64;

// Fewest block rows in one of rowRanges' ranges: a block row is a few small
// dense products, too little work to hand to a thread by itself.
static constexpr std::int64_t kMinRowsPerRange = 64;

// Fewest stored values for which a product is split between threads. Waking
// a sleeping pool thread costs tens of microseconds, up to about a hundred on
// a loaded 2-core machine: on the twisting cloth (67k values, a product in
// about 20 us) two threads made each CG iteration 5x slower. Since the pool's
// threads poll between jobs that cost is gone, yet splitting that product
// (a threshold of 2^14) still gained nothing over the whole run (0.124
// against 0.121 s/frame). Above this a product reads megabytes and takes a
// millisecond or more.
static constexpr std::size_t kMinValuesToSplit = std::size_t{1} << 19;

static void checkLayout(const BlockLayout &layout) {
  const std::vector<std::int64_t> &offsets = layout.blockOffset;
  if (offsets.empty())
    throw std::invalid_argument(
        "a block layout needs numBlocks + 1 offsets, got none");
  if (offsets.front() != 0)
    throw std::invalid_argument("a block layout must start at offset 0, got " +
                                std::to_string(offsets.front()));
  for (std::size_t i = 0; i + 1 < offsets.size(); ++i)
    if (offsets[i + 1] < offsets[i])
      throw std::invalid_argument("block " + std::to_string(i) +
                                  " has negative size: offsets " +
                                  std::to_string(offsets[i]) + " then " +
                                  std::to_string(offsets[i + 1]));
}

/// A new structure's id (BlockSparseMatrix::structureId).
static std::uint64_t nextStructureId() {
  static std::atomic<std::uint64_t> next{1};
  return next.fetch_add(1, std::memory_order_relaxed);
}

BlockSparseMatrix::BlockSparseMatrix(
    BlockLayout layout,
    const std::vector<std::pair<std::int64_t, std::int64_t>> &coords,
    std::vector<BlockSlot> *positions)
    : layout_(std::move(layout)), structureId_(nextStructureId()),
      locks_(new std::mutex[kNumLocks]), rowRanges_(new RowRangeCache) {
  checkLayout(layout_);
  const std::int64_t n = layout_.numBlocks();

  // One entry per input coordinate, normalised to the upper triangle and
  // keyed by (shape, row, col): in that order the entries are the stored
  // blocks. Counting sorts order the ~10^6 coordinates of a large scene in
  // a few passes, where a comparison sort of all of them took most of the
  // structure's build time.
  // Kept small (24 bytes): the entries are read in sorted, hence random,
  // order, and a scene's million coordinates make that memory-bound.
  struct Entry {
    std::int64_t row, col;
    std::uint32_t shape; // index into shapes
    bool transposed;     // the input coordinate was in the lower triangle
  };
  std::vector<Entry> unordered;
  unordered.reserve(coords.size());
  std::map<std::pair<std::int64_t, std::int64_t>, std::size_t> shapeIds;
  std::vector<std::pair<std::int64_t, std::int64_t>> shapes;
  for (std::size_t k = 0; k < coords.size(); ++k) {
    auto [i, j] = coords[k];
    if (i < 0 || i >= n || j < 0 || j >= n)
      throw std::invalid_argument(
          "block coordinate " + std::to_string(k) + " (" + std::to_string(i) +
          ", " + std::to_string(j) + ") is outside a layout of " +
          std::to_string(n) + " blocks");
    std::int64_t row = std::min(i, j), col = std::max(i, j);
    std::pair<std::int64_t, std::int64_t> shape{layout_.blockSize(row),
                                                layout_.blockSize(col)};
    auto [found, added] = shapeIds.try_emplace(shape, shapes.size());
    if (added)
      shapes.push_back(shape);
    unordered.push_back(
        {row, col, static_cast<std::uint32_t>(found->second), i > j});
  }
  // Shape ids in (rows, cols) order, as the comparison sort had them.
  std::vector<std::size_t> shapeRank(shapeIds.size());
  {
    std::size_t rank = 0;
    for (const auto &[shape, id] : shapeIds)
      shapeRank[id] = rank++;
  }
  // By row (counting sort), then by column within each row (a row holds a
  // few dozen entries), then, stably, by shape when there are several.
  std::vector<std::size_t> order(unordered.size());
  {
    std::vector<std::size_t> start(static_cast<std::size_t>(n) + 1, 0);
    for (const Entry &e : unordered)
      ++start[e.row + 1];
    for (std::int64_t r = 0; r < n; ++r)
      start[r + 1] += start[r];
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    for (std::size_t k = 0; k < unordered.size(); ++k)
      order[fill[unordered[k].row]++] = k;
    for (std::int64_t r = 0; r < n; ++r)
      std::sort(order.begin() + start[r], order.begin() + start[r + 1],
                [&](std::size_t a, std::size_t b) {
                  return unordered[a].col < unordered[b].col;
                });
  }
  if (shapeRank.size() > 1) {
    std::vector<std::size_t> start(shapeRank.size() + 1, 0), next(order.size());
    for (std::size_t k : order)
      ++start[shapeRank[unordered[k].shape] + 1];
    for (std::size_t r = 0; r + 1 < start.size(); ++r)
      start[r + 1] += start[r];
    for (std::size_t k : order)
      next[start[shapeRank[unordered[k].shape]]++] = k;
    order.swap(next);
  }

  if (positions)
    positions->resize(coords.size());
  valueOffset_.push_back(0);
  const Entry *previous = nullptr;
  for (std::size_t k : order) {
    const Entry &e = unordered[k];
    // Equal shapes and coordinates: the same stored block.
    bool newBlock = !previous || previous->shape != e.shape ||
                    previous->row != e.row || previous->col != e.col;
    if (newBlock) {
      auto [rows, cols] = shapes[e.shape];
      if (groups_.empty() || groups_.back().rows != rows ||
          groups_.back().cols != cols)
        groups_.push_back({rows, cols, blockRow_.size(), {}, {}});
      groups_.back().rowCoordinate.push_back(e.row);
      groups_.back().colCoordinate.push_back(e.col);
      blockRow_.push_back(e.row);
      blockCol_.push_back(e.col);
      valueOffset_.push_back(valueOffset_.back() +
                             static_cast<std::size_t>(rows * cols));
    }
    if (positions)
      (*positions)[k] = BlockSlot{blockRow_.size() - 1, e.transposed};
    previous = &e;
  }
  values_.assign(valueOffset_.back(), 0.0);
  if (layout_.blockOffset.back() <= INT32_MAX) {
    colDof_.resize(blockCol_.size());
    for (std::size_t b = 0; b < blockCol_.size(); ++b)
      colDof_[b] = static_cast<std::int32_t>(layout_.blockOffset[blockCol_[b]]);
  }

  // For multiply, per group: the block range of each row (blocks of a row
  // are consecutive within a group) and the list of off-diagonal blocks of
  // each column, by counting sort so that they stay in block order.
  const std::size_t numRows = static_cast<std::size_t>(n);
  const std::size_t stride = numRows + 1;
  rowStart_.assign(groups_.size() * stride, 0);
  colStart_.assign(groups_.size() * stride, 0);
  diagonalBlock_.assign(numRows, -1);
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const BlockGroup &group = groups_[g];
    std::size_t *rows = &rowStart_[g * stride];
    std::size_t *cols = &colStart_[g * stride];
    for (std::size_t k = 0; k < group.size(); ++k) {
      std::size_t b = group.firstBlock + k;
      ++rows[blockRow_[b] + 1];
      if (blockRow_[b] != blockCol_[b])
        ++cols[blockCol_[b] + 1];
      else
        diagonalBlock_[blockRow_[b]] = static_cast<std::int64_t>(b);
    }
    rows[0] = group.firstBlock;
    cols[0] = colBlocks_.size();
    for (std::size_t r = 0; r < numRows; ++r) {
      rows[r + 1] += rows[r];
      cols[r + 1] += cols[r];
    }
    colBlocks_.resize(cols[numRows]);
    std::vector<std::size_t> fill(cols, cols + numRows);
    for (std::size_t k = 0; k < group.size(); ++k) {
      std::size_t b = group.firstBlock + k;
      if (blockRow_[b] != blockCol_[b])
        colBlocks_[fill[blockCol_[b]]++] = b;
    }
  }
}

void BlockSparseMatrix::setZero() {
  std::fill(values_.begin(), values_.end(), 0.0);
  dropSingleValues();
}

void BlockSparseMatrix::roundValuesForProduct() {
  singleValues_.resize(values_.size());
  std::transform(values_.begin(), values_.end(), singleValues_.begin(),
                 [](double v) { return static_cast<float>(v); });
}

void BlockSparseMatrix::addBlock(BlockSlot slot, const double *local) {
  if (slot.block >= numStoredBlocks())
    throw std::out_of_range("block " + std::to_string(slot.block) +
                            " out of range: the matrix stores " +
                            std::to_string(numStoredBlocks()) + " blocks");
  std::int64_t rows = layout_.blockSize(blockRow_[slot.block]);
  std::int64_t cols = layout_.blockSize(blockCol_[slot.block]);
  double *dst = blockData(slot.block);
  if (!slot.transposed) {
    for (std::int64_t k = 0; k < rows * cols; ++k)
      dst[k] += local[k];
    return;
  }
  // `local` is cols x rows.
  for (std::int64_t a = 0; a < rows; ++a)
    for (std::int64_t b = 0; b < cols; ++b)
      dst[a * cols + b] += local[b * rows + a];
}

void BlockSparseMatrix::addBlockConcurrent(BlockSlot slot,
                                           const double *local) {
  std::lock_guard<std::mutex> lock(locks_[slot.block % kNumLocks]);
  addBlock(slot, local);
}

// Fixed-size block products: vertex blocks (3x3) dominate the Hessians of
// IPC scenes, and the compiler fully unrolls these (paper appendix C).
template <int R, int C, typename T>
static inline void timesBlock(const T *data, const double *x, double *y) {
  for (int i = 0; i < R; ++i) {
    double sum = 0.0;
    for (int j = 0; j < C; ++j)
      sum += data[i * C + j] * x[j];
    y[i] += sum;
  }
}

template <int R, int C, typename T>
static inline void timesTransposedBlock(const T *data, const double *x,
                                        double *y) {
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j)
      y[j] += data[i * C + j] * x[i];
}

// The block shapes of vertex (3) and affine-body (12) DoF groups get
// unrolled products; other shapes use the generic loops, which add the
// terms in the same order.
#define YASPS_FOR_BLOCK_SHAPES(CASE)                                           \
  CASE(3, 3) CASE(3, 12) CASE(12, 3) CASE(12, 12)

// y_r += B x_c for a stored block B (rows x cols).
template <typename T>
static inline void addProduct(const T *data, std::int64_t rows,
                              std::int64_t cols, const double *x, double *y) {
#define YASPS_PRODUCT_CASE(R, C)                                               \
  if (rows == R && cols == C)                                                  \
    return timesBlock<R, C>(data, x, y);
  YASPS_FOR_BLOCK_SHAPES(YASPS_PRODUCT_CASE)
#undef YASPS_PRODUCT_CASE
  for (std::int64_t i = 0; i < rows; ++i) {
    double sum = 0.0;
    for (std::int64_t j = 0; j < cols; ++j)
      sum += data[i * cols + j] * x[j];
    y[i] += sum;
  }
}

// y_c += B^T x_r for a stored block B (rows x cols).
template <typename T>
static inline void addTransposedProduct(const T *data, std::int64_t rows,
                                        std::int64_t cols, const double *x,
                                        double *y) {
#define YASPS_TRANSPOSED_CASE(R, C)                                            \
  if (rows == R && cols == C)                                                  \
    return timesTransposedBlock<R, C>(data, x, y);
  YASPS_FOR_BLOCK_SHAPES(YASPS_TRANSPOSED_CASE)
#undef YASPS_TRANSPOSED_CASE
  for (std::int64_t i = 0; i < rows; ++i)
    for (std::int64_t j = 0; j < cols; ++j)
      y[j] += data[i * cols + j] * x[i];
}

// Every product adds the terms of an entry of y in the same order: group
// by group, first the transposed blocks (q, r), q < r, by increasing q, then
// the blocks (r, c) of the row by increasing c. So the result does not
// depend on the number of threads.

template <typename T>
void BlockSparseMatrix::multiplyRange(const T *values, const RowSplit &split,
                                      std::int64_t t, const double *x,
                                      double *y) const {
  // One pass over the range's values, each block read once for both of its
  // products: half the memory traffic of a full (CSR) matrix. Only the
  // blocks above the range in its columns are read a second time.
  const std::vector<std::int64_t> &offset = layout_.blockOffset;
  const std::int64_t lo = split.ranges[t], hi = split.ranges[t + 1];
  const std::size_t stride = static_cast<std::size_t>(numBlocks()) + 1;
  const bool simd = detail::hasVertexBlockSimd();
  auto blockAt = [&](std::size_t b) { return values + valueOffset_[b]; };
  std::fill(y + offset[lo], y + offset[hi], 0.0);
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const BlockGroup &group = groups_[g];
    const bool vertex = group.rows == 3 && group.cols == 3;
    // The rows above the range come first in its entries' sums: the
    // transposes of its blocks above, by increasing row as in storage.
    const std::size_t *above =
        split.above.data() + split.aboveStart[t * groups_.size() + g];
    const std::size_t numAbove = split.aboveStart[t * groups_.size() + g + 1] -
                                 split.aboveStart[t * groups_.size() + g];
    if (vertex && simd) {
      detail::addTransposedVertexBlocksAvx2(
          blockAt(group.firstBlock), group.firstBlock, above, numAbove,
          blockRow_.data(), blockCol_.data(), offset.data(), x, y);
    } else {
      for (std::size_t k = 0; k < numAbove; ++k) {
        const std::size_t b = above[k];
        addTransposedProduct(blockAt(b), group.rows, group.cols,
                             x + offset[blockRow_[b]],
                             y + offset[blockCol_[b]]);
      }
    }
    // Then the range's rows in storage order. Transposes into columns at
    // or past hi belong to later ranges, which add them themselves.
    if (vertex) {
      // The last range's transposes all stay in it.
      multiply3x3InStorageOrder(
          values, g, lo, hi, hi == numBlocks() ? detail::kNoLimit : hi, x, y);
      continue;
    }
    const std::size_t *rowStart = &rowStart_[g * stride];
    const std::size_t first = rowStart[lo], last = rowStart[hi];
    const T *data = blockAt(first);
    for (std::size_t b = first; b < last;
         ++b, data += group.rows * group.cols) {
      std::int64_t r = blockRow_[b], c = blockCol_[b];
      addProduct(data, group.rows, group.cols, x + offset[c], y + offset[r]);
      if (r != c && c < hi)
        addTransposedProduct(data, group.rows, group.cols, x + offset[r],
                             y + offset[c]);
    }
  }
}

template <typename T>
void BlockSparseMatrix::multiply3x3InStorageOrder(
    const T *values, std::size_t g, std::int64_t rowBegin, std::int64_t rowEnd,
    std::int64_t limit, const double *x, double *y) const {
  // Vertex blocks: the row's partial y stays in registers while the
  // blocks of a row stream by (rows are consecutive in storage); y_r is
  // written once per row. The terms are added in the order of addProduct.
  const std::vector<std::int64_t> &offset = layout_.blockOffset;
  const std::size_t *rowStart =
      &rowStart_[g * (static_cast<std::size_t>(numBlocks()) + 1)];
  const std::size_t begin = rowStart[rowBegin], end = rowStart[rowEnd];
  const T *data = values + valueOffset_[begin];
  if (detail::hasVertexBlockSimd() && !colDof_.empty())
    return detail::multiplyVertexBlocksAvx2(
        data, rowStart, rowBegin, rowEnd, colDof_.data(), offset.data(),
        limit == detail::kNoLimit ? detail::kNoLimit : offset[limit], x, y);
  std::size_t b = begin;
  while (b < end) {
    const std::int64_t r = blockRow_[b];
    double *yr = y + offset[r];
    const double *xr = x + offset[r];
    double y0 = yr[0], y1 = yr[1], y2 = yr[2];
    for (; b < end && blockRow_[b] == r; ++b, data += 9) {
      const std::int64_t c = blockCol_[b];
      const double *xc = x + offset[c];
      y0 += data[0] * xc[0] + data[1] * xc[1] + data[2] * xc[2];
      y1 += data[3] * xc[0] + data[4] * xc[1] + data[5] * xc[2];
      y2 += data[6] * xc[0] + data[7] * xc[1] + data[8] * xc[2];
      if (c != r && c < limit) {
        double *yc = y + offset[c];
        timesTransposedBlock<3, 3, T>(data, xr, yc);
      }
    }
    yr[0] = y0;
    yr[1] = y1;
    yr[2] = y2;
  }
}

template <typename T>
void BlockSparseMatrix::multiplyValues(const T *values, const double *x,
                                       double *y, ThreadPool &pool) const {
  const RowSplit &split = rowSplit(pool.size());
  const std::int64_t parts = static_cast<std::int64_t>(split.ranges.size()) - 1;
  if (parts == 1)
    return multiplyRange(values, split, 0, x, y);
  if (values_.size() < kMinValuesToSplit) {
    // The same ranges in turn: the same sums as the threads would form.
    for (std::int64_t t = 0; t < parts; ++t)
      multiplyRange(values, split, t, x, y);
    return;
  }
  // Each range writes only its rows of y, so no two threads write the same
  // entry.
  pool.parallelFor(0, parts, 1, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t t = begin; t < end; ++t)
      multiplyRange(values, split, t, x, y);
  });
}

void BlockSparseMatrix::multiply(const double *x, double *y,
                                 ThreadPool &pool) const {
  if (hasSingleValues())
    return multiplyValues(singleValues_.data(), x, y, pool);
  multiplyValues(values_.data(), x, y, pool);
}

void BlockSparseMatrix::multiplyRows(const double *x, double *y, unsigned parts,
                                     std::int64_t t) const {
  const RowSplit &split = rowSplit(parts);
  if (t < 0 || t + 1 >= static_cast<std::int64_t>(split.ranges.size()))
    return;
  if (hasSingleValues())
    return multiplyRange(singleValues_.data(), split, t, x, y);
  multiplyRange(values_.data(), split, t, x, y);
}

void BlockSparseMatrix::multiplyRounded(const std::vector<float> &rounded,
                                        const double *x, double *y,
                                        ThreadPool &pool) const {
  if (rounded.size() != values_.size())
    throw std::invalid_argument(
        "multiplyRounded: " + std::to_string(rounded.size()) +
        " rounded values for a matrix of " + std::to_string(values_.size()));
  multiplyValues(rounded.data(), x, y, pool);
}

const std::vector<std::int64_t> &
BlockSparseMatrix::rowRanges(unsigned parts) const {
  return rowSplit(parts).ranges;
}

const BlockSparseMatrix::RowSplit &
BlockSparseMatrix::rowSplit(unsigned parts) const {
  std::lock_guard<std::mutex> lock(rowRanges_->mutex);
  auto found = rowRanges_->byParts.find(parts);
  if (found == rowRanges_->byParts.end())
    found = rowRanges_->byParts.emplace(parts, splitRows(parts)).first;
  return found->second;
}

BlockSparseMatrix::RowSplit BlockSparseMatrix::splitRows(unsigned parts) const {
  RowSplit split;
  split.ranges = balanceRowRanges(parts);
  const std::size_t numRanges = split.ranges.size() - 1;
  const std::size_t numGroups = groups_.size();
  auto rangeOf = [&](std::int64_t block) {
    return static_cast<std::size_t>(
        std::upper_bound(split.ranges.begin(), split.ranges.end(), block) -
        split.ranges.begin() - 1);
  };
  // Listed in storage order, so each range reads its blocks above forward
  // through memory, and adds each entry's terms by increasing row.
  std::vector<std::vector<std::size_t>> lists(numRanges * numGroups);
  for (std::size_t g = 0; numRanges > 1 && g < numGroups; ++g) {
    const std::size_t end = groups_[g].firstBlock + groups_[g].size();
    for (std::size_t b = groups_[g].firstBlock; b < end; ++b) {
      std::size_t rowRange = rangeOf(blockRow_[b]),
                  colRange = rangeOf(blockCol_[b]);
      if (rowRange < colRange)
        lists[colRange * numGroups + g].push_back(b);
    }
  }
  split.aboveStart.push_back(0);
  for (const std::vector<std::size_t> &list : lists) {
    split.above.insert(split.above.end(), list.begin(), list.end());
    split.aboveStart.push_back(split.above.size());
  }
  return split;
}

std::vector<std::int64_t>
BlockSparseMatrix::balanceRowRanges(unsigned parts) const {
  const std::int64_t n = numBlocks();
  const std::int64_t most = std::max<std::int64_t>(1, n / kMinRowsPerRange);
  const std::int64_t count = std::clamp<std::int64_t>(parts, 1, most);
  // Costs in values read: a row's own blocks, and the blocks of its column
  // that lie above its range (read again by the range's first loop).
  std::vector<double> own(static_cast<std::size_t>(n), 0.0);
  for (std::size_t b = 0; b < blockRow_.size(); ++b)
    own[blockRow_[b]] +=
        static_cast<double>(valueOffset_[b + 1] - valueOffset_[b]);
  const std::size_t stride = static_cast<std::size_t>(n) + 1;
  auto above = [&](std::int64_t r, std::int64_t lo) {
    double cost = 0.0;
    for (std::size_t g = 0; g < groups_.size(); ++g)
      for (std::size_t k = colStart_[g * stride + r];
           k < colStart_[g * stride + r + 1] && blockRow_[colBlocks_[k]] < lo;
           ++k)
        cost += static_cast<double>(groups_[g].rows * groups_[g].cols);
    return cost;
  };
  // Greedy cuts at a target cost per range; the target is first the own
  // blocks' share, then the share of what those cuts cost in all.
  auto cut = [&](double target, double &total) {
    std::vector<std::int64_t> ranges{0};
    double cost = 0.0;
    total = 0.0;
    for (std::int64_t r = 0; r < n; ++r) {
      double rowCost = own[r] + above(r, ranges.back());
      cost += rowCost;
      total += rowCost;
      if (cost >= target && static_cast<std::int64_t>(ranges.size()) < count &&
          r + 1 < n) {
        ranges.push_back(r + 1);
        cost = 0.0;
      }
    }
    ranges.push_back(n);
    return ranges;
  };
  double ownTotal = 0.0, total = 0.0;
  for (double c : own)
    ownTotal += c;
  if (count == 1 || ownTotal == 0.0)
    return {0, n};
  cut(ownTotal / static_cast<double>(count), total);
  return cut(total / static_cast<double>(count), total);
}

void BlockSparseMatrix::diagonalBlocks(std::vector<double> &out) const {
  std::size_t total = 0;
  for (std::int64_t r = 0; r < numBlocks(); ++r)
    total +=
        static_cast<std::size_t>(layout_.blockSize(r) * layout_.blockSize(r));
  out.assign(total, 0.0);
  std::size_t pos = 0;
  for (std::int64_t r = 0; r < numBlocks(); ++r) {
    std::size_t count =
        static_cast<std::size_t>(layout_.blockSize(r) * layout_.blockSize(r));
    if (diagonalBlock_[r] >= 0) {
      const double *data =
          blockData(static_cast<std::size_t>(diagonalBlock_[r]));
      std::copy(data, data + count, out.begin() + pos);
    }
    pos += count;
  }
}

std::vector<double> BlockSparseMatrix::toDense() const {
  const std::size_t n = static_cast<std::size_t>(size());
  std::vector<double> dense(n * n, 0.0);
  const std::vector<std::int64_t> &offset = layout_.blockOffset;
  for (std::size_t b = 0; b < numStoredBlocks(); ++b) {
    std::int64_t r = blockRow_[b], c = blockCol_[b];
    std::int64_t rows = layout_.blockSize(r), cols = layout_.blockSize(c);
    const double *data = blockData(b);
    for (std::int64_t i = 0; i < rows; ++i)
      for (std::int64_t j = 0; j < cols; ++j) {
        std::size_t gi = static_cast<std::size_t>(offset[r] + i);
        std::size_t gj = static_cast<std::size_t>(offset[c] + j);
        dense[gi * n + gj] = data[i * cols + j];
        if (r != c)
          dense[gj * n + gi] = data[i * cols + j];
      }
  }
  return dense;
}
