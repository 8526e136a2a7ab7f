//===- BlockSparseMatrix.h - symmetric block-sparse Hessian -----*- C++ -*-===//
//
// The global Hessian of a Newton step (the paper's appendices B-D) is
// symmetric and block-sparse: every energy instance contributes dense
// sub-blocks at block coordinates given by the DoF groups it reads. Only the
// upper triangle (block row <= block column) is stored, so an off-diagonal
// block (i, j) also stands for its transpose at (j, i). Stored blocks are
// grouped by shape (rows, cols) so that kernels of one shape can run over
// one group; within a group they are sorted by (row, col) and unique.
//
// The structure is built once from the list of coordinates that the energy
// instances contribute; the builder returns, per input coordinate, the block
// it lands in (the paper's PositionInData), so that assembling a step only
// accumulates into known places.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SPARSE_BLOCKSPARSEMATRIX_H
#define YASPS_RUNTIME_SPARSE_BLOCKSPARSEMATRIX_H

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

namespace yasps::runtime {

class ThreadPool;

/// A partition of the scalar DoFs into consecutive blocks: block i covers
/// scalar DoFs [blockOffset[i], blockOffset[i+1]). Blocks may be empty.
struct BlockLayout {
  std::vector<std::int64_t> blockOffset;

  /// The layout of consecutive blocks of the given sizes.
  static BlockLayout fromSizes(const std::vector<std::int64_t> &sizes) {
    BlockLayout layout{{0}};
    for (std::int64_t size : sizes)
      layout.blockOffset.push_back(layout.blockOffset.back() + size);
    return layout;
  }

  std::int64_t numBlocks() const {
    return static_cast<std::int64_t>(blockOffset.size()) - 1;
  }
  std::int64_t blockSize(std::int64_t block) const {
    return blockOffset[block + 1] - blockOffset[block];
  }
};

/// Where one contributed coordinate is stored: the index of its stored block
/// and whether the contribution lies in the lower triangle, so that it is
/// stored transposed (at (col, row)).
struct BlockSlot {
  std::size_t block;
  bool transposed;

  bool operator==(const BlockSlot &other) const {
    return block == other.block && transposed == other.transposed;
  }
};

/// The stored blocks of one shape: blocks [firstBlock, firstBlock + size)
/// of the matrix, at block coordinates (rowCoordinate[k], colCoordinate[k]),
/// sorted by (row, col).
struct BlockGroup {
  std::int64_t rows;
  std::int64_t cols;
  std::size_t firstBlock;
  std::vector<std::int64_t> rowCoordinate;
  std::vector<std::int64_t> colCoordinate;

  std::size_t size() const { return rowCoordinate.size(); }
};

/// A symmetric block-sparse matrix storing its upper block triangle.
///
/// Values live in one contiguous array: the stored blocks one after another
/// in block-index order (group by group, groups sorted by (rows, cols)),
/// each block row-major (rows x cols). Diagonal blocks are stored whole
/// (both of their triangles) and used as they are, so callers keep them
/// symmetric. An off-diagonal block B at (i, j), i < j, means H_ij = B and
/// H_ji = B^T: a contribution to a pair of blocks must be added once, at
/// (i, j) or at (j, i), not at both.
class BlockSparseMatrix {
public:
  /// Builds the structure, zero-filled, from the block coordinates
  /// `coords` (any order, duplicates and lower-triangle coordinates
  /// allowed). If `positions` is given, it receives one slot per input
  /// coordinate. Throws std::invalid_argument if the layout is not a
  /// non-decreasing list starting at 0, or a coordinate is outside
  /// [0, numBlocks).
  BlockSparseMatrix(
      BlockLayout layout,
      const std::vector<std::pair<std::int64_t, std::int64_t>> &coords,
      std::vector<BlockSlot> *positions = nullptr);

  /// Sets every stored value to zero, keeping the structure, and drops the
  /// single-precision copy (roundValuesForProduct).
  void setZero();

  /// Takes an f32 copy of the stored values that multiply reads from then
  /// on, in place of the values: the product is bound by reading the
  /// blocks, and f32 blocks halve that. Vectors and arithmetic stay f64, so
  /// the product is exactly H~ x for H~ the values rounded to f32. The copy
  /// is dropped by setZero() and dropSingleValues(); values changed after
  /// it was taken are not seen by multiply until it is taken again.
  void roundValuesForProduct();
  void dropSingleValues() { singleValues_.clear(); }
  /// Whether multiply reads the f32 copy.
  bool hasSingleValues() const { return !singleValues_.empty(); }

  /// Adds the dense block `local` at a slot from the constructor. `local`
  /// is row-major and shaped as the input coordinate (row, col) it came
  /// from: size(row) x size(col); a transposed slot adds its transpose.
  /// Not synchronised: concurrent calls must target distinct blocks (use
  /// addBlockConcurrent otherwise). Throws std::out_of_range for a block
  /// index outside [0, numStoredBlocks()).
  void addBlock(BlockSlot slot, const double *local);

  /// addBlock that may run concurrently with itself on any slots: a lock
  /// (one of a few, picked by block index) serialises writes to a block.
  void addBlockConcurrent(BlockSlot slot, const double *local);

  /// y = H x over all scalar DoFs, using both triangles. `x` and `y` hold
  /// size() values and must not overlap. One pass over the stored blocks
  /// does both products of each. On several threads each thread takes one
  /// range of block rows (rowRanges) and writes only its rows of y: it
  /// first adds the transposes of the blocks above the range that reach its
  /// columns, then passes over its own rows. Every entry's terms are added
  /// in the one-thread order, so the result does not depend on the number
  /// of threads.
  void multiply(const double *x, double *y, ThreadPool &pool) const;
  /// What multiply's thread t of `parts` does: the rows of range t of
  /// rowRanges(parts) of y = H x (nothing where t is past the last range),
  /// for callers that run the threads themselves (PCG's team). Each range
  /// writes only its rows, so ranges may run at the same time.
  void multiplyRows(const double *x, double *y, unsigned parts,
                    std::int64_t t) const;

  /// multiply() of the matrix whose values are `rounded` (values().size()
  /// f32 entries in the values' order, as roundValuesForProduct takes
  /// them): for a preconditioner's products, which need not be exact.
  void multiplyRounded(const std::vector<float> &rounded, const double *x,
                       double *y, ThreadPool &pool) const;

  /// Splits the block rows into at most `parts` consecutive ranges, range t
  /// being [ranges[t], ranges[t + 1]), that cost a product about the same:
  /// a range reads its rows' blocks and the blocks above it in its
  /// columns. Small matrices get fewer ranges (one at least). Computed once
  /// per number of parts and kept; safe to call from several threads. What
  /// multiply and a threaded assembly (GlobalSystem) split the work by.
  const std::vector<std::int64_t> &rowRanges(unsigned parts) const;

  /// Writes the diagonal blocks to `out`, concatenated in block order, each
  /// row-major (size(i) x size(i)); blocks that are not stored are zero.
  void diagonalBlocks(std::vector<double> &out) const;

  /// The dense size() x size() matrix, row-major, both triangles filled.
  /// For tests and debugging.
  std::vector<double> toDense() const;

  const BlockLayout &layout() const { return layout_; }
  /// Names the structure (layout and stored blocks): unique to the
  /// constructor call that built it, kept by copies and moves, since only
  /// the values change after construction. What caches of structure (the
  /// multilevel preconditioner's levels) compare.
  std::uint64_t structureId() const { return structureId_; }
  std::int64_t numBlocks() const { return layout_.numBlocks(); }
  /// Scalar dimension.
  std::int64_t size() const { return layout_.blockOffset.back(); }
  std::size_t numStoredBlocks() const { return blockRow_.size(); }

  const std::vector<BlockGroup> &groups() const { return groups_; }
  std::int64_t blockRow(std::size_t block) const { return blockRow_[block]; }
  std::int64_t blockCol(std::size_t block) const { return blockCol_[block]; }
  /// Where stored block `block`'s values start in values().
  std::size_t valueOffset(std::size_t block) const {
    return valueOffset_[block];
  }
  /// The stored block holding diagonal block `block` (-1: none).
  std::int64_t diagonalBlock(std::int64_t block) const {
    return diagonalBlock_[block];
  }
  /// The row-major values of stored block `block`.
  double *blockData(std::size_t block) {
    return values_.data() + valueOffset_[block];
  }
  const double *blockData(std::size_t block) const {
    return values_.data() + valueOffset_[block];
  }
  /// All stored values, in the order described above.
  const std::vector<double> &values() const { return values_; }
  std::vector<double> &values() { return values_; }

private:
  // The products, over the values (f64) or their f32 copy (`values` is
  // either's first entry; blocks sit at valueOffset_ in both).
  template <typename T>
  void multiplyValues(const T *values, const double *x, double *y,
                      ThreadPool &pool) const;
  /// rowRanges' ranges, and per range t and group g the group's blocks
  /// above range t in its columns: above[aboveStart[t * numGroups + g]
  /// .. aboveStart[t * numGroups + g + 1]), in storage order.
  struct RowSplit {
    std::vector<std::int64_t> ranges;
    std::vector<std::size_t> above, aboveStart;
  };
  const RowSplit &rowSplit(unsigned parts) const;
  RowSplit splitRows(unsigned parts) const;
  /// Range t's rows of y = H x (see multiply).
  template <typename T>
  void multiplyRange(const T *values, const RowSplit &split, std::int64_t t,
                     const double *x, double *y) const;
  /// The stored 3x3 blocks of block rows [rowBegin, rowEnd) in group g
  /// (a 3x3 group), in storage order; transposes reach only block columns
  /// below `limit`.
  template <typename T>
  void multiply3x3InStorageOrder(const T *values, std::size_t g,
                                 std::int64_t rowBegin, std::int64_t rowEnd,
                                 std::int64_t limit, const double *x,
                                 double *y) const;
  std::vector<std::int64_t> balanceRowRanges(unsigned parts) const;

  BlockLayout layout_;
  std::uint64_t structureId_;
  std::vector<BlockGroup> groups_;
  // Per stored block: its block coordinates and where its values start
  // (valueOffset_ has one more entry, the total).
  std::vector<std::int64_t> blockRow_;
  std::vector<std::int64_t> blockCol_;
  std::vector<std::size_t> valueOffset_;
  // Per stored block, the first DoF of its column, for the SIMD product of
  // 3x3 blocks: one sequential 4-byte read in place of the column and a
  // dependent look-up of its offset. Empty when the DoFs exceed int32.
  std::vector<std::int32_t> colDof_;
  std::vector<double> values_;
  // roundValuesForProduct's copy; empty when multiply reads values_.
  std::vector<float> singleValues_;
  // For multiply, per group g and block row r (index g * (numBlocks + 1)
  // + r): the group's stored blocks of row r are [rowStart_[i],
  // rowStart_[i + 1]), and its off-diagonal blocks of column r, whose
  // transposes lie in row r, are colBlocks_[colStart_[i] .. colStart_[i+1]).
  std::vector<std::size_t> rowStart_;
  std::vector<std::size_t> colStart_;
  std::vector<std::size_t> colBlocks_;
  // Per block, the index of its stored diagonal block, or -1.
  std::vector<std::int64_t> diagonalBlock_;
  // Striped locks for addBlockConcurrent; behind a pointer because mutexes
  // cannot move.
  std::unique_ptr<std::mutex[]> locks_;
  // rowSplit's results by number of parts (a map: references stay valid as
  // entries are added).
  struct RowRangeCache {
    std::mutex mutex;
    std::map<unsigned, RowSplit> byParts;
  };
  std::unique_ptr<RowRangeCache> rowRanges_;
};

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SPARSE_BLOCKSPARSEMATRIX_H
