//===- GpuMultilevel.cpp - the multilevel preconditioner on the GPU -------===//
//
// GpuSystem's side of Multilevel.h: the host's Multilevel builds the
// levels' structure (aggregates, coarse block structures, where each fine
// block lands), which is uploaded once per structure; every solve then
// computes the coarse values, block-Jacobi inverses, dampings and the
// coarsest level's dense inverse on the device, and each PCG iteration runs
// one V-cycle there. Same algorithm as the CPU's, step for step; sums run
// in another order, so iterates agree to round-off, not to the bit.
//
//===----------------------------------------------------------------------===//

#include "GpuMultilevelKernels.h"
#include "yasps/Runtime/Gpu/GpuSystem.h"
#include "yasps/Runtime/Sparse/Lanczos.h"
#include "yasps/Runtime/Sparse/Multilevel.h"

#include "GpuSystemDetail.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

using namespace yasps::runtime;
using namespace yasps::runtime::gpu;
using namespace yasps::runtime::detail;

void GpuSystem::prepareLevels(const PcgOptions &options) {
  HessianParts hostParts = host.hessianParts();
  if (!levels || !levels->structure.matches(hostParts) ||
      !(levels->structure.options() == options.multilevel)) {
    levels = std::make_unique<Levels>(hostParts, options.multilevel);
    uploadLevels();
  } else if (levels->structure.restructure(hostParts)) {
    uploadLevels();
  }
}

std::int64_t GpuSystem::levelCount() const {
  return levels ? static_cast<std::int64_t>(levels->levels.size()) : 1;
}

void GpuSystem::uploadLevels() {
  Multilevel &structure = levels->structure;
  const std::size_t numLevels = structure.numLevels();
  levels->levels.clear();
  levels->levels.resize(numLevels);
  for (std::size_t l = 0; l < numLevels; ++l) {
    Levels::Level &level = levels->levels[l];
    const HessianParts &hostParts = structure.levelParts(l);
    const BlockLayout &layout = hostParts.front()->layout();
    level.size = hostParts.front()->size();
    if (l == 0) {
      level.parts = {parts[0].get(), parts[1].get()};
      level.jacobi = &jacobi;
    } else {
      for (const BlockSparseMatrix *matrix : hostParts) {
        level.own.push_back(std::make_unique<Part>());
        uploadMatrix(*level.own.back(), *matrix);
        level.parts.push_back(level.own.back().get());
      }
      allocateJacobi(ctx, level.ownJacobi, layout);
      level.jacobi = &level.ownJacobi;
    }
    const std::size_t bytes = static_cast<std::size_t>(level.size) * 8;
    for (DeviceBuffer *vector :
         {&level.r, &level.z, &level.t, &level.u, &level.p, &level.q, &level.x})
      *vector = DeviceBuffer(ctx, bytes);
    if (l + 1 == numLevels)
      break;

    // The transfers: aggregates' DoFs and their members' first DoFs.
    const Aggregates &agg = structure.aggregates(l);
    const BlockLayout &coarse = structure.levelParts(l + 1).front()->layout();
    level.numAggregates = agg.count();
    std::vector<long long> coarseDof(coarse.blockOffset.begin(),
                                     coarse.blockOffset.end() - 1);
    std::vector<int> sizes(agg.size.begin(), agg.size.end());
    std::vector<long long> memberStart(structure.memberStart(l).begin(),
                                       structure.memberStart(l).end());
    std::vector<long long> memberDof;
    for (std::int64_t b : structure.members(l))
      memberDof.push_back(layout.blockOffset[b]);
    level.coarseDof = deviceCopy(ctx, coarseDof);
    level.aggregateSize = deviceCopy(ctx, sizes);
    level.memberStart = deviceCopy(ctx, memberStart);
    level.memberDof = deviceCopy(ctx, memberDof);

    // Where each fine block lands (Multilevel::coarsen, as tables).
    level.coarsen.resize(hostParts.size());
    for (std::size_t k = 0; k < hostParts.size(); ++k) {
      const BlockSparseMatrix &fine = *hostParts[k];
      const BlockSparseMatrix &target = *structure.levelParts(l + 1)[k];
      const std::vector<BlockSlot> &slots = structure.slots(l, k);
      std::vector<long long> fineValue, coarseValue, rowDof, colDof;
      std::vector<int> rows, cols, flags;
      std::size_t next = 0;
      for (std::size_t b = 0; b < fine.numStoredBlocks(); ++b) {
        std::int64_t i = fine.blockRow(b), j = fine.blockCol(b);
        if (agg.of[i] < 0 || agg.of[j] < 0)
          continue;
        BlockSlot slot = slots[next++];
        fineValue.push_back(static_cast<long long>(fine.valueOffset(b)));
        coarseValue.push_back(
            static_cast<long long>(target.valueOffset(slot.block)));
        rowDof.push_back(layout.blockOffset[i]);
        colDof.push_back(layout.blockOffset[j]);
        rows.push_back(static_cast<int>(layout.blockSize(i)));
        cols.push_back(static_cast<int>(layout.blockSize(j)));
        flags.push_back((slot.transposed ? 1 : 0) |
                        (agg.of[i] == agg.of[j] && i != j ? 2 : 0));
      }
      Levels::Coarsen &c = level.coarsen[k];
      c.count = static_cast<long long>(fineValue.size());
      c.fineValue = deviceCopy(ctx, fineValue);
      c.coarseValue = deviceCopy(ctx, coarseValue);
      c.rowDof = deviceCopy(ctx, rowDof);
      c.colDof = deviceCopy(ctx, colDof);
      c.rows = deviceCopy(ctx, rows);
      c.cols = deviceCopy(ctx, cols);
      c.flags = deviceCopy(ctx, flags);
    }
  }
  const std::int64_t last = levels->levels.back().size;
  levels->denseInverse = last <= structure.options().coarsestDofs;
  levels->dense = DeviceBuffer(
      ctx,
      levels->denseInverse ? static_cast<std::size_t>(last * last) * 8 : 0);
  levels->failed = DeviceBuffer(ctx, sizeof(int));
  levels->estimateState = DeviceBuffer(ctx, sizeof(PcgState));
}

void GpuSystem::refreshLevels(const unsigned char *mask,
                              const std::uint8_t *hostMask) {
  std::vector<Levels::Level> &all = levels->levels;
  // Level 0's block-Jacobi is the solve's; the coarse levels' values and
  // inverses follow, finest first.
  for (std::size_t l = 0; l + 1 < all.size(); ++l) {
    Levels::Level &level = all[l], &coarse = all[l + 1];
    for (std::size_t k = 0; k < level.parts.size(); ++k) {
      Part &target = *coarse.parts[k];
      target.values.setZero(target.numValues * sizeof(double));
      const Levels::Coarsen &c = level.coarsen[k];
      CoarsenArgs args{c.count,
                       as<const long long>(c.fineValue),
                       as<const long long>(c.coarseValue),
                       as<const long long>(c.rowDof),
                       as<const long long>(c.colDof),
                       as<const int>(c.rows),
                       as<const int>(c.cols),
                       as<const int>(c.flags),
                       as<const double>(level.parts[k]->values),
                       l == 0 ? mask : nullptr,
                       as<double>(target.values)};
      launch("yasps_ml_coarsen", ceilDiv(c.count, kThreadsPerBlock), args);
    }
    invertJacobi(*coarse.jacobi, coarse.parts, nullptr);
  }
  const bool additiveFine = levels->structure.options().additiveFine;
  for (std::size_t l = 0; l + 1 < all.size(); ++l) {
    // An additive fine level needs no damping (Multilevel.h).
    if (l == 0 && additiveFine) {
      all[l].damping = 1.0;
      continue;
    }
    all[l].damping = estimateDamping(l, l == 0 ? mask : nullptr,
                                     l == 0 ? hostMask : nullptr);
    // The cap of Multilevel::estimateDamping: w lmax < 2 whatever Lanczos
    // missed.
    double bound = eigenvalueBound(l, l == 0 ? mask : nullptr);
    if (bound > 0.0 && std::isfinite(bound))
      all[l].damping = std::min(all[l].damping, 1.9 / bound);
  }

  // The coarsest level's dense matrix, then its inverse.
  Levels::Level &last = all.back();
  levels->denseReady = false;
  if (!levels->denseInverse)
    return;
  levels->dense.setZero();
  const unsigned char *lastMask = all.size() == 1 ? mask : nullptr;
  for (const Part *part : last.parts)
    for (const Part::Group &group : part->groups) {
      DenseScatterArgs args{group.count,
                            group.rows,
                            group.cols,
                            as<const int>(part->rowDof) + group.first,
                            as<const int>(part->colDof) + group.first,
                            as<const double>(part->values) + group.valueStart,
                            lastMask,
                            last.size,
                            as<double>(levels->dense)};
      launch("yasps_ml_dense_scatter", ceilDiv(group.count, kThreadsPerBlock),
             args);
    }
  levels->failed.setZero();
  launch("yasps_ml_dense_invert", 1,
         DenseInvertArgs{last.size, as<double>(levels->dense),
                         as<int>(levels->failed)});
  int failed = 0;
  levels->failed.download(&failed, sizeof(failed));
  levels->denseReady = failed == 0;
}

double GpuSystem::eigenvalueBound(std::size_t l, const unsigned char *mask) {
  Levels::Level &level = levels->levels[l];
  const Jacobi &bj = *level.jacobi;
  level.q.setZero();
  for (const Part *part : level.parts)
    for (const Part::Group &group : part->groups) {
      RowBoundArgs args{group.count,
                        group.rows,
                        group.cols,
                        as<const int>(part->rowDof) + group.first,
                        as<const int>(part->colDof) + group.first,
                        as<const double>(part->values) + group.valueStart,
                        as<const long long>(bj.dofBlock),
                        as<const long long>(bj.inverseStart),
                        as<const double>(bj.inverse),
                        mask,
                        as<double>(level.q)};
      launch("yasps_ml_row_bound", ceilDiv(group.count, kThreadsPerBlock),
             args);
    }
  std::vector<double> rowSums(static_cast<std::size_t>(level.size));
  level.q.download(rowSums.data(), rowSums.size() * sizeof(double));
  return rowSums.empty() ? 0.0
                         : *std::max_element(rowSums.begin(), rowSums.end());
}

double GpuSystem::estimateDamping(std::size_t l, const unsigned char *mask,
                                  const std::uint8_t *hostMask) {
  // Block-Jacobi PCG steps on level l from the CPU's start vector; their
  // coefficients make the Lanczos matrix whose largest eigenvalue
  // estimates lmax(D^-1 A), as in Multilevel::estimateDamping.
  Levels::Level &level = levels->levels[l];
  const Jacobi &bj = *level.jacobi;
  const long long n = level.size;
  std::vector<double> start = multilevelStartVector(n, hostMask);
  level.t.upload(start.data(), start.size() * sizeof(double));
  PcgState initial{};
  initial.maxIterations = levels->structure.options().eigenvalueSteps + 1;
  levels->estimateState.upload(&initial, sizeof(initial));
  PcgState *st = as<PcgState>(levels->estimateState);
  double *partialSums = as<double>(partials);
  const std::int64_t vectorBlocks = reductionBlocks(n);
  const std::int64_t blockBlocks = reductionBlocks(bj.numBlocks);
  auto scalar = [&](int step, std::int64_t numPartials) {
    launch("yasps_pcg_scalar", 1,
           PcgScalarArgs{step, numPartials, partialSums, st});
  };
  const JacobiApplyArgs apply{bj.numBlocks,
                              as<const long long>(bj.blockOffset),
                              as<const long long>(bj.inverseStart),
                              as<const double>(bj.inverse),
                              as<const double>(level.t),
                              as<double>(level.u),
                              partialSums,
                              st};
  const PcgDirectionArgs direction{n, as<const double>(level.u),
                                   as<double>(level.p), st};
  level.p.setZero();
  level.x.setZero();
  launch("yasps_jacobi_apply", blockBlocks, apply);
  scalar(kPcgBeta, blockBlocks);
  launch("yasps_pcg_direction", vectorBlocks, direction);
  std::vector<double> alphas, betas;
  for (std::int64_t k = 0; k < levels->structure.options().eigenvalueSteps;
       ++k) {
    level.q.setZero();
    addPartProducts(level.parts, as<const double>(level.p), as<double>(level.q),
                    st);
    launch("yasps_dot", vectorBlocks,
           DotArgs{n, as<const double>(level.p), as<double>(level.q), mask,
                   partialSums, st});
    scalar(kPcgAlpha, vectorBlocks);
    launch("yasps_pcg_update", vectorBlocks,
           PcgUpdateArgs{n, as<const double>(level.p),
                         as<const double>(level.q), as<double>(level.x),
                         as<double>(level.t), partialSums, st});
    launch("yasps_jacobi_apply", blockBlocks, apply);
    scalar(kPcgBeta, blockBlocks);
    launch("yasps_pcg_direction", vectorBlocks, direction);
    PcgState now;
    levels->estimateState.download(&now, sizeof(now));
    if (now.stopped)
      break;
    alphas.push_back(now.alpha);
    betas.push_back(now.beta);
  }
  double largest = ritzExtremeValues(alphas, betas).second;
  return largest > 0.0 && std::isfinite(largest) ? 4.0 / (3.0 * largest) : 1.0;
}

void GpuSystem::cycle(std::size_t l, const double *r, double *z,
                      const unsigned char *fineMask, const PcgState *state) {
  Levels::Level &level = levels->levels[l];
  const Jacobi &bj = *level.jacobi;
  const long long n = level.size;
  const unsigned char *mask = l == 0 ? fineMask : nullptr;
  const std::int64_t vectorBlocks = reductionBlocks(n);
  const std::int64_t blockBlocks = reductionBlocks(bj.numBlocks);
  auto smooth = [&](const double *in, double damping, int accumulate) {
    launch("yasps_ml_smooth", blockBlocks,
           SmoothArgs{bj.numBlocks, as<const long long>(bj.blockOffset),
                      as<const long long>(bj.inverseStart),
                      as<const double>(bj.inverse), in, z, damping, accumulate,
                      state});
  };
  if (l + 1 == levels->levels.size()) {
    if (levels->denseReady)
      launch("yasps_ml_dense_apply", vectorBlocks,
             DenseApplyArgs{n, as<const double>(levels->dense), r, z, state});
    else
      smooth(r, 1.0, 0);
    return;
  }
  double *t = as<double>(level.t);
  auto residual = [&] {
    level.t.setZero(static_cast<std::size_t>(n) * sizeof(double));
    addPartProducts(level.parts, z, t, state);
    launch("yasps_ml_residual", vectorBlocks,
           ResidualArgs{n, r, t, mask, state});
  };
  // The fine level added to the coarse levels' cycle restricts r itself
  // (Multilevel::apply).
  const bool additive = l == 0 && levels->structure.options().additiveFine;
  smooth(r, level.damping, 0);
  if (!additive)
    residual();
  Levels::Level &coarse = levels->levels[l + 1];
  const std::int64_t aggregateBlocks = reductionBlocks(level.numAggregates);
  TransferArgs transfer{level.numAggregates,
                        as<const long long>(level.coarseDof),
                        as<const long long>(level.memberStart),
                        as<const long long>(level.memberDof),
                        as<const int>(level.aggregateSize),
                        mask,
                        additive ? const_cast<double *>(r) : t,
                        as<double>(coarse.r),
                        state};
  launch("yasps_ml_restrict", aggregateBlocks, transfer);
  cycle(l + 1, as<const double>(coarse.r), as<double>(coarse.z), nullptr,
        state);
  transfer.fine = z;
  transfer.coarse = as<double>(coarse.z);
  launch("yasps_ml_prolong", aggregateBlocks, transfer);
  if (additive)
    return;
  residual();
  smooth(t, level.damping, 1);
}
