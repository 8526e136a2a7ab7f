//===- Multilevel.h - aggregation multigrid for PCG ------------*- C++ -*-===//
//
// Block-Jacobi sees one DoF group at a time, so CG needs many iterations to
// carry a correction across a mesh: its count grows with the mesh's
// resolution and the material's stiffness. Like the multilevel additive
// Schwarz preconditioner of GIPC (Wu et al. 2022), this one adds coarse
// levels whose DoFs are aggregates of neighbouring blocks, with each
// coarse matrix the sum of the finer one's blocks (the Galerkin product
// P^T A P for the aggregates' translations). Unlike it, the levels are
// combined multiplicatively, as a symmetric V-cycle, so that each level
// corrects what the finer ones left instead of adding a correction of its
// own: on bunny-19k it needs 18 iterations where block-Jacobi needs 55
// (docs/benchmarks.md).
//
// One V-cycle on level l, from residual r:
//   z  = w D^-1 r                  (damped block-Jacobi, D its blocks)
//   z += P cycle(l + 1, P^T (r - A z))
//   z += w D^-1 (r - A z)
// with the coarsest level solved by a dense Cholesky factor. The damping
// w = 4 / (3 lmax) comes from a few Lanczos steps estimating lmax(D^-1 A);
// since Lanczos never overestimates, w lmax stays below 2 while the
// estimate is within two thirds of lmax, which keeps the cycle symmetric
// positive definite (a smoother that converges in A's norm).
//
// By default the fine level is combined additively instead:
//   z = D^-1 r + P cycle(1, P^T r)
// which reads no fine matrix at all (PCG's own product is the only one per
// iteration): an application costs about half a block-Jacobi iteration
// more, where the V-cycle's two products with the fine matrix made it
// 3.5x. It needs more iterations than the V-cycle and, on the contact
// systems of larger scenes, far fewer seconds: over every solve of frames
// 16-18 (in contact) of the bench's bunny on a pinned cloth at 86k DoFs,
// block-Jacobi took 21.0 s, the V-cycle 16.5 s and this cycle 10.4 s; over
// frames 17-18 at 169k DoFs 46.1, 27.9 and 18.3 s. The sum of a
// positive block diagonal and a positive semidefinite coarse correction
// is positive definite whatever their weights, so the fine level needs no
// damping, and none of its estimate's products.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SPARSE_MULTILEVEL_H
#define YASPS_RUNTIME_SPARSE_MULTILEVEL_H

#include "yasps/Runtime/Sparse/Aggregation.h"
#include "yasps/Runtime/Sparse/BlockJacobi.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace yasps::runtime {

struct MultilevelOptions {
  /// A level with at most this many DoFs is the coarsest, solved exactly.
  std::int64_t coarsestDofs = 128;
  /// Levels at most, the fine one included.
  std::int64_t maxLevels = 10;
  /// Lanczos steps that estimate each level's lmax(D^-1 A).
  std::int64_t eigenvalueSteps = 4;
  /// The fine level's block-Jacobi added to the coarse levels' V-cycle
  /// (true) or composed with it as the V-cycle's first level (false).
  bool additiveFine = true;

  bool operator==(const MultilevelOptions &other) const {
    return coarsestDofs == other.coarsestDofs && maxLevels == other.maxLevels &&
           eigenvalueSteps == other.eigenvalueSteps &&
           additiveFine == other.additiveFine;
  }
};

/// The start of every damping estimate: n entries in [-1, 1] from a fixed
/// seed, 0 at fixed DoFs, so that the estimate does not depend on timing
/// and the CPU and the GPU estimate from the same vector.
std::vector<double> multilevelStartVector(std::int64_t n,
                                          const std::uint8_t *fixed);

/// The V-cycle preconditioner on the sum of `parts`, restricted to the free
/// DoFs like BlockJacobi. The levels' structure (aggregates, coarse block
/// structures) depends only on the parts' block structure and is built
/// once; refresh() recomputes the values for new matrix values or fixed
/// DoFs, at the cost of a few products.
class Multilevel {
public:
  /// Builds the levels and refreshes them. `parts` and `fixed` (one entry
  /// per DoF, nonzero for a fixed DoF; null: all free) are read until the
  /// next refresh.
  Multilevel(const HessianParts &parts, const std::uint8_t *fixed,
             ThreadPool &pool, const MultilevelOptions &options = {});
  /// Builds the levels' structure only, for a backend that computes their
  /// values itself (the GPU): apply() needs a refresh() first.
  Multilevel(const HessianParts &parts, const MultilevelOptions &options);
  ~Multilevel();

  /// Whether `parts` have the structure the levels were built for: the
  /// first part's structure, which alone decides the aggregates, and the
  /// number of parts. The others' structures may change between
  /// refreshes (contact): refresh rebuilds their coarse structures only.
  bool matches(const HessianParts &parts) const;
  const MultilevelOptions &options() const { return options_; }
  /// Takes `parts` (whose structure must match) and rebuilds the coarse
  /// structures of the parts whose structure changed, without values;
  /// returns whether any did. What refresh() does first.
  bool restructure(const HessianParts &parts);
  /// Recomputes every level's values from `parts`, whose structure must
  /// match (else std::invalid_argument).
  void refresh(const HessianParts &parts, const std::uint8_t *fixed,
               ThreadPool &pool);

  /// z = M^-1 r (one V-cycle); `r` is zero at fixed DoFs, and so is z.
  void apply(const double *r, double *z, ThreadPool &pool);

  /// Whether apply() runs the additive fine level in the pieces below
  /// (additiveFine with a coarse level).
  bool splitsFineLevel() const;
  /// The pieces of an additive fine level's apply(), for PCG, whose team
  /// shares the fine level's steps between barriers (Pcg.cpp):
  ///   z = D^-1 r      fineSmoother(), with BlockJacobi's own passes
  ///   r1 = P^T r      restrictAggregates(), aggregates [begin, end)
  ///   z1 = cycle(r1)  solveCoarse(), on the calling thread alone
  ///   z += P z1       prolongAggregates(), aggregates [begin, end)
  /// r . z is r . D^-1 r plus r1 . z1, which solveCoarse returns (r is
  /// zero at fixed DoFs, where z takes no correction).
  const BlockJacobi &fineSmoother() const;
  std::int64_t numFineAggregates() const;
  void restrictAggregates(const double *r, std::int64_t begin,
                          std::int64_t end);
  double solveCoarse();
  void prolongAggregates(double *z, std::int64_t begin, std::int64_t end) const;
  /// The last three pieces over all aggregates (the pool's threads sharing
  /// them where the fine level is large); returns r1 . z1.
  double addCoarseCorrection(const double *r, double *z, ThreadPool &pool);
  /// The fine level's diagonal ratio (BlockJacobi::diagonalRatio).
  double diagonalRatio() const;
  /// Per level, its DoF count, the fine level first.
  std::vector<std::int64_t> levelSizes() const;
  /// Per level but the coarsest, the smoother's damping w (1 on an
  /// additive fine level).
  std::vector<double> dampings() const;

  /// The structure of level l, for backends that upload it: its parts (a
  /// coarse level's hold the structure, and after a refresh the values),
  /// and for every level but the coarsest its aggregates, their members
  /// (members[memberStart[a] .. memberStart[a + 1])) and per part, per
  /// stored block with both blocks aggregated, its slot in level l + 1's
  /// matrix of that part. A block between two members of one aggregate
  /// lands there twice: as itself and as its transpose.
  std::size_t numLevels() const { return levels_.size(); }
  const HessianParts &levelParts(std::size_t l) const;
  const Aggregates &aggregates(std::size_t l) const;
  const std::vector<std::size_t> &memberStart(std::size_t l) const;
  const std::vector<std::int64_t> &members(std::size_t l) const;
  const std::vector<BlockSlot> &slots(std::size_t l, std::size_t part) const;

private:
  struct Level;
  /// The coarse matrix of level l + 1 from level l's values.
  void coarsen(std::size_t l);
  /// Level l + 1's matrix of part k: its structure, from level l's part k.
  void buildCoarsePart(std::size_t l, std::size_t k);
  void estimateDamping(std::size_t l, ThreadPool &pool);
  void factorCoarsest();
  void cycle(std::size_t l, const double *r, double *z, ThreadPool &pool);
  /// Level l + 1's residual on aggregates [begin, end) of level l: the
  /// sums of their members' entries of r.
  void restrictRange(std::size_t l, const double *r, std::int64_t begin,
                     std::int64_t end);
  /// z += level l + 1's correction on the free DoFs of aggregates
  /// [begin, end) of level l.
  void prolongRange(std::size_t l, double *z, std::int64_t begin,
                    std::int64_t end) const;
  void multiply(std::size_t l, const double *x, double *y, ThreadPool &pool);

  MultilevelOptions options_;
  /// The first part's structure id the levels were built for.
  std::uint64_t structure_;
  std::vector<std::unique_ptr<Level>> levels_;
  std::vector<double> scratch_;
  /// The pool of small levels' vector steps.
  ThreadPool serial_{1};
};

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SPARSE_MULTILEVEL_H
