//===- BlockSparseMatrix.cpp - symmetric block-sparse Hessian -------------===//

#include "yasps/Runtime/BlockSparseMatrix.h"

#include "yasps/Runtime/ThreadPool.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <tuple>

using namespace yasps::runtime;

// Enough stripes that threads assembling different blocks rarely wait on
// each other, few enough to cost nothing per matrix.
static constexpr std::size_t kNumLocks = 64;

// Block rows per parallelFor chunk in multiply: a block row is a few small
// dense products, too little work to hand out one at a time.
static constexpr std::int64_t kRowsPerChunk = 64;

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

BlockSparseMatrix::BlockSparseMatrix(
    BlockLayout layout,
    const std::vector<std::pair<std::int64_t, std::int64_t>> &coords,
    std::vector<BlockSlot> *positions)
    : layout_(std::move(layout)), locks_(new std::mutex[kNumLocks]) {
  checkLayout(layout_);
  const std::int64_t n = layout_.numBlocks();

  // One entry per input coordinate, normalised to the upper triangle and
  // keyed by (shape, row, col) so that sorting yields the stored order.
  struct Entry {
    std::int64_t rows, cols, row, col;
    std::size_t input;
  };
  std::vector<Entry> entries;
  entries.reserve(coords.size());
  for (std::size_t k = 0; k < coords.size(); ++k) {
    auto [i, j] = coords[k];
    if (i < 0 || i >= n || j < 0 || j >= n)
      throw std::invalid_argument(
          "block coordinate " + std::to_string(k) + " (" + std::to_string(i) +
          ", " + std::to_string(j) + ") is outside a layout of " +
          std::to_string(n) + " blocks");
    std::int64_t row = std::min(i, j), col = std::max(i, j);
    entries.push_back(
        {layout_.blockSize(row), layout_.blockSize(col), row, col, k});
  }
  auto key = [](const Entry &e) {
    return std::make_tuple(e.rows, e.cols, e.row, e.col);
  };
  std::sort(entries.begin(), entries.end(),
            [&](const Entry &a, const Entry &b) { return key(a) < key(b); });

  if (positions)
    positions->assign(coords.size(), BlockSlot{0, false});
  valueOffset_.push_back(0);
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const Entry &e = entries[k];
    bool newBlock = k == 0 || key(entries[k - 1]) != key(e);
    if (newBlock) {
      if (groups_.empty() || groups_.back().rows != e.rows ||
          groups_.back().cols != e.cols)
        groups_.push_back({e.rows, e.cols, blockRow_.size(), {}, {}});
      groups_.back().rowCoordinate.push_back(e.row);
      groups_.back().colCoordinate.push_back(e.col);
      blockRow_.push_back(e.row);
      blockCol_.push_back(e.col);
      valueOffset_.push_back(valueOffset_.back() +
                             static_cast<std::size_t>(e.rows * e.cols));
    }
    if (positions) {
      auto [i, j] = coords[e.input];
      (*positions)[e.input] = BlockSlot{blockRow_.size() - 1, i > j};
    }
  }
  values_.assign(valueOffset_.back(), 0.0);

  // Per-row and per-column lists for multiply, by counting sort so that
  // blocks of a row stay in block-index order (a fixed summation order).
  const std::size_t numRows = static_cast<std::size_t>(n);
  rowStart_.assign(numRows + 1, 0);
  colStart_.assign(numRows + 1, 0);
  diagonalBlock_.assign(numRows, -1);
  for (std::size_t b = 0; b < blockRow_.size(); ++b) {
    ++rowStart_[blockRow_[b] + 1];
    if (blockRow_[b] != blockCol_[b])
      ++colStart_[blockCol_[b] + 1];
    else
      diagonalBlock_[blockRow_[b]] = static_cast<std::int64_t>(b);
  }
  for (std::size_t r = 0; r < numRows; ++r) {
    rowStart_[r + 1] += rowStart_[r];
    colStart_[r + 1] += colStart_[r];
  }
  rowBlocks_.resize(rowStart_.back());
  colBlocks_.resize(colStart_.back());
  std::vector<std::size_t> rowFill(rowStart_.begin(), rowStart_.end() - 1);
  std::vector<std::size_t> colFill(colStart_.begin(), colStart_.end() - 1);
  for (std::size_t b = 0; b < blockRow_.size(); ++b) {
    rowBlocks_[rowFill[blockRow_[b]]++] = b;
    if (blockRow_[b] != blockCol_[b])
      colBlocks_[colFill[blockCol_[b]]++] = b;
  }
}

void BlockSparseMatrix::setZero() {
  std::fill(values_.begin(), values_.end(), 0.0);
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
template <int R, int C>
static inline void timesBlock(const double *data, const double *x, double *y) {
  for (int i = 0; i < R; ++i) {
    double sum = 0.0;
    for (int j = 0; j < C; ++j)
      sum += data[i * C + j] * x[j];
    y[i] += sum;
  }
}

template <int R, int C>
static inline void timesTransposedBlock(const double *data, const double *x,
                                        double *y) {
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j)
      y[j] += data[i * C + j] * x[i];
}

void BlockSparseMatrix::multiply(const double *x, double *y,
                                 ThreadPool &pool) const {
  const std::vector<std::int64_t> &offset = layout_.blockOffset;
  // Each thread writes only the block rows of its chunk, so no two threads
  // write the same entry of y.
  pool.parallelFor(
      0, numBlocks(), kRowsPerChunk, [&](std::int64_t begin, std::int64_t end) {
        for (std::int64_t r = begin; r < end; ++r) {
          double *yr = y + offset[r];
          std::int64_t rows = layout_.blockSize(r);
          std::fill(yr, yr + rows, 0.0);
          // Stored blocks (r, c): y_r += B x_c.
          for (std::size_t k = rowStart_[r]; k < rowStart_[r + 1]; ++k) {
            std::size_t b = rowBlocks_[k];
            std::int64_t c = blockCol_[b];
            std::int64_t cols = layout_.blockSize(c);
            const double *data = blockData(b);
            const double *xc = x + offset[c];
            if (rows == 3 && cols == 3) {
              timesBlock<3, 3>(data, xc, yr);
              continue;
            }
            for (std::int64_t i = 0; i < rows; ++i) {
              double sum = 0.0;
              for (std::int64_t j = 0; j < cols; ++j)
                sum += data[i * cols + j] * xc[j];
              yr[i] += sum;
            }
          }
          // Stored blocks (q, r), q < r: y_r += B^T x_q.
          for (std::size_t k = colStart_[r]; k < colStart_[r + 1]; ++k) {
            std::size_t b = colBlocks_[k];
            std::int64_t q = blockRow_[b];
            std::int64_t qRows = layout_.blockSize(q);
            const double *data = blockData(b);
            const double *xq = x + offset[q];
            if (qRows == 3 && rows == 3) {
              timesTransposedBlock<3, 3>(data, xq, yr);
              continue;
            }
            for (std::int64_t i = 0; i < qRows; ++i)
              for (std::int64_t j = 0; j < rows; ++j)
                yr[j] += data[i * rows + j] * xq[i];
          }
        }
      });
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
