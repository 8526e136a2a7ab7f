//===- GlobalSystem.h - assembling the Newton system ------------*- C++ -*-===//
//
// The global gradient and Hessian of a Newton step, assembled from the
// per-instance local gradients and (projected) Hessians of every energy.
// Each energy comes with a DoF map: for every instance and local parameter,
// the global DoF it belongs to (-1 for parameters that are not DoFs, e.g.
// the zero padding of UNION slots). The DoFs are partitioned into blocks
// (one per target instance, paper appendix A.1); the block structure of the
// Hessian is derived once from the maps (appendix B) and each step only
// accumulates into known places.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_GLOBALSYSTEM_H
#define YASPS_RUNTIME_GLOBALSYSTEM_H

#include "yasps/Runtime/BlockSparseMatrix.h"
#include "yasps/Runtime/Pcg.h"

#include <cstdint>
#include <vector>

namespace yasps::runtime {

/// The DoF map of one energy: `count` instances of `numParams` local
/// parameters, row-major, each a global DoF or -1.
struct DofMap {
  std::int64_t count = 0;
  std::int64_t numParams = 0;
  const std::int64_t *dofs = nullptr;
};

class GlobalSystem {
public:
  /// Builds the block structure. Throws std::invalid_argument for a DoF
  /// outside the layout.
  GlobalSystem(BlockLayout layout, const std::vector<DofMap> &energies);

  /// Zeroes the gradient and the Hessian before a new assembly.
  void setZero();

  /// Adds energy `energy`'s local gradients (count x n) and local Hessians
  /// (count x n x n, each row-major) to the global system.
  void add(std::size_t energy, const double *gradients, const double *hessians);

  const std::vector<double> &gradient() const { return gradientValues; }
  const BlockSparseMatrix &hessian() const { return matrix; }

  /// Solves H x = g by block-Jacobi PCG (x has size() entries).
  PcgResult solve(double *x, const PcgOptions &options, ThreadPool &pool) const;

  std::int64_t size() const { return matrix.size(); }

private:
  /// Per energy: for each instance and parameter, the index of its block
  /// among the instance's blocks and its offset in the block (-1: no DoF);
  /// for each instance, the stored slot of every pair of its blocks.
  struct EnergyMap {
    std::int64_t count = 0, numParams = 0, maxBlocks = 0;
    std::vector<std::int32_t> localBlock, offset;
    std::vector<std::int64_t> globalBlock; // count x maxBlocks, -1 padded
    std::vector<BlockSlot> pairSlot;       // count x maxBlocks x maxBlocks
  };

  static BlockSparseMatrix buildStructure(const BlockLayout &layout,
                                          const std::vector<DofMap> &energies,
                                          std::vector<EnergyMap> &maps);

  std::vector<EnergyMap> maps;
  BlockSparseMatrix matrix;
  std::vector<double> gradientValues;
};

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_GLOBALSYSTEM_H
