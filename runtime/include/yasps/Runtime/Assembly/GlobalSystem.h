//===- GlobalSystem.h - assembling the Newton system ------------*- C++ -*-===//
//
// The global gradient and Hessian of a Newton step, assembled from the
// per-instance local gradients and (projected) Hessians of every energy.
// Each energy comes with a DoF map: for every instance and local parameter,
// the global DoF it belongs to (-1 for parameters that are not DoFs, e.g.
// the zero padding of UNION slots). The DoFs are partitioned into blocks
// (one per target instance, paper appendix A.1); the block structure of the
// Hessian is derived from the maps (appendix B), once for static energies
// and again only for dynamic ones when they change, and each step only
// accumulates into known places.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_ASSEMBLY_GLOBALSYSTEM_H
#define YASPS_RUNTIME_ASSEMBLY_GLOBALSYSTEM_H

#include "yasps/Runtime/Assembly/SlotFactors.h"
#include "yasps/Runtime/Sparse/BlockSparseMatrix.h"
#include "yasps/Runtime/Sparse/Pcg.h"

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

/// The global system, kept in two parts (paper section 10.6): the static
/// energies, whose structure is built once, and the dynamic ones (collision
/// pairs), whose structure is rebuilt whenever their instances change. The
/// Hessian is the sum of both parts' matrices. Energies are numbered static
/// first, then dynamic.
class GlobalSystem {
public:
  /// Builds the block structure of the static energies; the dynamic part
  /// starts empty. Throws std::invalid_argument for a DoF outside the
  /// layout.
  GlobalSystem(BlockLayout layout, const std::vector<DofMap> &staticEnergies);

  /// Replaces the dynamic energies and rebuilds only their structure. The
  /// dynamic part's values are zero afterwards.
  void setDynamic(const std::vector<DofMap> &dynamicEnergies);

  /// Zeroes the gradient and the Hessian before a new assembly.
  void setZero();

  /// With `on`, products (multiply, solve) read the Hessian's blocks
  /// rounded to f32 once an assembly is finished (finishAssembly): mixed
  /// precision, f32 storage for the SpMV, which reading the blocks bounds,
  /// with f64 vectors, dot products and preconditioner. The solve is then
  /// of H~ x = g, H~ within f32's round-off of H entry by entry.
  void setSingleProduct(bool on) { singleProduct_ = on; }
  bool singleProduct() const { return singleProduct_; }
  /// Ends an assembly: with single products, takes the blocks' f32 copies.
  /// An add() after it drops its part's copy (products then read the f64
  /// values until the next finishAssembly).
  void finishAssembly();

  /// Adds energy `energy`'s local gradients (count x n) and local Hessians
  /// (count x n x n, each row-major) to the global system. With a pool of
  /// more than one thread, each thread writes one range of block rows
  /// (BlockSparseMatrix::rowRanges) and the gradient of those blocks, taking
  /// from every instance that reaches them the entries that fall there.
  /// No atomics: every entry gets its terms in instance order, so the
  /// result is that of one thread to the last bit.
  void add(std::size_t energy, const double *gradients, const double *hessians,
           ThreadPool *pool = nullptr);
  /// add() of f32 local derivatives (an f32 scene's kernels store them as
  /// they compute them); the sums are f64, in the same order.
  void add(std::size_t energy, const float *gradients, const float *hessians,
           ThreadPool *pool = nullptr);

  /// Adds local Hessians (count x n x n, row-major) to the instances
  /// `instances[0..count)` of energy `energy` only, and nothing to the
  /// gradient: progressive projection's update, the projected minus the
  /// exact Hessians of the few instances it chose, without a pass over the
  /// others. Throws std::out_of_range for an instance outside the energy.
  void addToInstances(std::size_t energy, const std::int64_t *instances,
                      std::int64_t count, const double *hessians);

  /// add() for an energy whose local Hessians are kept as factors (paper
  /// 7.2, 10.9): instance i's Hessian is J_i^T P_i J_i, with `maps` the
  /// inner maps J (count x m x n, each row-major) and `inner` the projected
  /// inner Hessians P (count x m x m). The product is formed one instance
  /// at a time while assembling, so no n x n Hessian is ever stored.
  void addFactored(std::size_t energy, const double *gradients,
                   const double *maps, const double *inner, std::int64_t m,
                   ThreadPool *pool = nullptr);

  /// add() for an energy whose local Hessians are J^T P J with J taken, slot
  /// by slot, from Jacobian tables shared between energies (SlotFactors.h):
  /// `innerGradients` (count x m) and `innerHessians` (count x m x m, the
  /// projected P) are all that is stored per instance. Throws
  /// std::invalid_argument for a reference outside the tables or the
  /// energy's local parameters.
  void addSlotFactored(std::size_t energy, const double *innerGradients,
                       const double *innerHessians, const SlotFactors &factors,
                       ThreadPool *pool = nullptr);

  const std::vector<double> &gradient() const { return gradientValues; }
  const BlockSparseMatrix &staticHessian() const { return staticPart.matrix; }
  const BlockSparseMatrix &dynamicHessian() const { return dynamicPart.matrix; }
  /// The Hessian as the sum of its parts.
  HessianParts hessianParts() const {
    return {&staticPart.matrix, &dynamicPart.matrix};
  }
  /// y = H x (both parts).
  void multiply(const double *x, double *y, ThreadPool &pool) const;
  /// The dense H (both parts), row-major. For tests and debugging.
  std::vector<double> toDense() const;

  /// Per energy: for each instance and parameter, the index of its block
  /// among the instance's blocks and its offset in the block (-1: no DoF);
  /// for each instance, the stored slot of every pair of its blocks.
  struct EnergyMap {
    std::int64_t count = 0, numParams = 0, maxBlocks = 0;
    std::vector<std::int32_t> localBlock, offset;
    std::vector<std::int64_t> globalBlock; // count x maxBlocks, -1 padded
    std::vector<BlockSlot> pairSlot;       // count x maxBlocks x maxBlocks
    /// The block-row ranges a split assembly of this energy gives its
    /// threads (splitRanges[t] .. splitRanges[t + 1]), computed for
    /// splitThreads threads at the first split (0: not yet).
    mutable std::vector<std::int64_t> splitRanges;
    mutable std::int64_t splitThreads = 0;
  };
  /// Block rows [lo, hi): what one thread of a split assembly writes, the
  /// stored blocks of those rows and the gradient entries of those blocks.
  struct RowRange {
    std::int64_t lo, hi;
    bool owns(std::int64_t block) const { return lo <= block && block < hi; }
  };
  /// The structure of energy `energy` (throws std::out_of_range).
  const EnergyMap &energyStructure(std::size_t energy) const;

  std::int64_t size() const { return staticPart.matrix.size(); }
  std::size_t numStaticEnergies() const { return staticPart.maps.size(); }
  std::size_t numEnergies() const {
    return staticPart.maps.size() + dynamicPart.maps.size();
  }

private:
  /// Energies and the matrix their structure makes.
  struct Part {
    std::vector<EnergyMap> maps;
    BlockSparseMatrix matrix;
  };

  static Part buildPart(const BlockLayout &layout,
                        const std::vector<DofMap> &energies,
                        std::size_t firstEnergy);
  /// The part and map of energy `energy` (throws std::out_of_range).
  std::pair<Part *, const EnergyMap *> energyMap(std::size_t energy);
  /// Adds instance i's gradient g (n) and Hessian h (n x n): the entries
  /// in the block rows `rows`, and the gradient entries of those blocks.
  template <typename T>
  static void addInstance(Part &part, const EnergyMap &map, std::int64_t i,
                          const T *g, const T *h, std::vector<double> &gradient,
                          RowRange rows);
  /// add() for local derivatives of type T.
  template <typename T>
  void addLocal(std::size_t energy, const T *gradients, const T *hessians,
                ThreadPool *pool);

  Part staticPart;
  Part dynamicPart;
  std::vector<double> gradientValues;
  bool singleProduct_ = false;
};

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_ASSEMBLY_GLOBALSYSTEM_H
