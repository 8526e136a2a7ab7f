//===- LaneBatch.h - loop kernels in SIMD lanes -----------------*- C++ -*-===//
//
// With `lanes` W > 1 (CPU kernels), instances run in tiles of W, one per
// SIMD lane. The attribute's arithmetic (its region and those of the
// computed attributes of the same owner that it reads) is emitted once on
// vector<Wxf64> values: a first loop over the tile's instances evaluates
// the region's leaves (stored values, JOINs, UNIONs, DoF numbers: loads and
// index arithmetic, which differ per instance) and stages them in a buffer
// with the lanes innermost; the arithmetic then runs on whole vectors, and a
// last loop stores each lane's result. Straight-line derivative code gets
// W instances per instruction, and the PSD projection's eigensolver runs W
// matrices in lockstep (its QL iteration is a chain of dependent square
// roots and divisions, and lanes keep W chains in flight).
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_LIB_CONVERSION_YASPSTOLOOPS_LANEBATCH_H
#define YASPS_LIB_CONVERSION_YASPSTOLOOPS_LANEBATCH_H

#include "KernelEmitter.h"

#include "mlir/Dialect/Arith/IR/Arith.h"

#include <map>

namespace mlir::yasps {

/// Evaluates an attribute for a tile of instances in SIMD lanes (see the
/// top of this file).
class LaneBatch {
public:
  LaneBatch(KernelEmitter &emitter, AttrOp decl, int64_t lanes)
      : emitter(emitter), decl(decl), owner(getOwningEntity(decl)),
        lanes(lanes) {}

  /// Emits the tile's code into `loop` (over tiles starting at its
  /// induction variable, ending at `end`). Fails, leaving the loop to be
  /// erased, if the region cannot be evaluated in lanes.
  LogicalResult emit(scf::ParallelOp loop, Value out, Value end);

  /// Whether the emitted tile is worth it over scalar code. Lanes cost
  /// staging (a store and a load per leaf entry and per result entry) and
  /// pay off by the arithmetic done once per tile; kernels that mostly
  /// write their results (a 9x9 Hessian of a cheap energy) are bound by
  /// memory either way. Divisions and square roots weigh more (vector units
  /// do several per instruction); other math functions count nothing (LLVM
  /// calls libm once per lane). A PSD projection (its QL loop) always pays.
  /// The threshold comes from bench/simd_lanes.py on the energies of
  /// bench/energy_cases.py.
  bool worthwhile(scf::ParallelOp loop);

private:
  /// Prefetches for writing the output lines of the tile after the one
  /// at `tile`, when that tile is full (its instances end by `end`). A
  /// tile stores all its results at once at its end, lanes x entries
  /// values (9 KB for a 12x12 f64 Hessian in 8 lanes); where `out` is
  /// larger than the caches, each store then waits for its line to be read
  /// for ownership, and the kernel ran at half the speed of scalar code,
  /// which spreads its stores over its arithmetic. Fetched during the
  /// previous tile's arithmetic, the lines are in cache when stored.
  void prefetchNextTile(OpBuilder &b, Value out, Value tile, Value end,
                        int64_t entries);
  /// Stores a full tile's results (`rows[k]`: entry k of every lane) into
  /// `out`, instance-major, through in-register transposes.
  void storeTransposed(OpBuilder &b, ArrayRef<Value> rows, Value out,
                       Value tile, int64_t entries);
  /// Numbers the leaves of `attr`'s region and of the same-owner computed
  /// attributes it reads.
  void collectLeaves(AttrOp attr);
  /// `attr`'s value on all lanes, from the staged leaves.
  FailureOr<ScalarMatrix> evaluateLanes(OpBuilder &b, AttrOp attr);
  Value index(OpBuilder &b, int64_t value) {
    return arith::ConstantIndexOp::create(b, decl.getLoc(), value);
  }

  KernelEmitter &emitter;
  AttrOp decl;
  Operation *owner;
  int64_t lanes;
  SmallVector<Operation *> leaves;
  DenseMap<Operation *, int64_t> firstSlot; ///< leaf -> staging row
  DenseMap<std::pair<OperationName, Attribute>, Operation *> leafByKey;
  int64_t stagedRows = 0;
  DenseSet<Operation *> walked;
  DenseMap<Operation *, ScalarMatrix> laneValues; ///< attr -> its lanes
  std::map<int64_t, APFloat> constantSlots; ///< staging rows known statically
  DenseMap<int64_t, int64_t> slotAlias;     ///< row -> earlier equal row
  Value staging;
};

} // namespace mlir::yasps

#endif // YASPS_LIB_CONVERSION_YASPSTOLOOPS_LANEBATCH_H
