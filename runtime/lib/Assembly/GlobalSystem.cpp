//===- GlobalSystem.cpp - assembling the Newton system --------------------===//

#include "yasps/Runtime/Assembly/GlobalSystem.h"

#include "yasps/Runtime/Support/ThreadPool.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <tuple>

using namespace yasps::runtime;

GlobalSystem::Part GlobalSystem::buildPart(const BlockLayout &layout,
                                           const std::vector<DofMap> &energies,
                                           std::size_t firstEnergy) {
  std::int64_t size =
      layout.blockOffset.empty() ? 0 : layout.blockOffset.back();
  // The block of every DoF, looked up once per local parameter (a search
  // of the offsets per parameter was a large part of building a part).
  std::vector<std::int64_t> blockOf(static_cast<std::size_t>(size));
  for (std::int64_t b = 0; b < layout.numBlocks(); ++b)
    std::fill(blockOf.begin() + layout.blockOffset[b],
              blockOf.begin() + layout.blockOffset[b + 1], b);
  std::vector<std::pair<std::int64_t, std::int64_t>> coords;
  std::vector<EnergyMap> maps(energies.size());
  for (std::size_t e = 0; e < energies.size(); ++e) {
    const DofMap &in = energies[e];
    EnergyMap &map = maps[e];
    map.count = in.count;
    map.numParams = in.numParams;
    map.localBlock.assign(in.count * in.numParams, -1);
    map.offset.assign(in.count * in.numParams, -1);
    // Each instance's distinct blocks, in order of first appearance: at
    // most one per parameter, kept flat.
    std::vector<std::int64_t> blocks(in.count * in.numParams);
    std::vector<std::int64_t> numBlocks(in.count, 0);
    for (std::int64_t i = 0; i < in.count; ++i) {
      std::int64_t *mine = &blocks[i * in.numParams];
      std::int64_t &found = numBlocks[i];
      for (std::int64_t a = 0; a < in.numParams; ++a) {
        std::int64_t dof = in.dofs[i * in.numParams + a];
        if (dof < 0)
          continue;
        if (dof >= size)
          throw std::invalid_argument(
              "energy " + std::to_string(firstEnergy + e) + ", instance " +
              std::to_string(i) + ": DoF " + std::to_string(dof) +
              " is outside the system of " + std::to_string(size) + " DoFs");
        std::int64_t block = blockOf[dof];
        std::int64_t local = std::find(mine, mine + found, block) - mine;
        if (local == found)
          mine[found++] = block;
        map.localBlock[i * in.numParams + a] = static_cast<std::int32_t>(local);
        map.offset[i * in.numParams + a] =
            static_cast<std::int32_t>(dof - layout.blockOffset[block]);
      }
      map.maxBlocks = std::max<std::int64_t>(map.maxBlocks, found);
    }
    map.globalBlock.assign(in.count * map.maxBlocks, -1);
    for (std::int64_t i = 0; i < in.count; ++i) {
      const std::int64_t *mine = &blocks[i * in.numParams];
      for (std::int64_t k = 0; k < numBlocks[i]; ++k) {
        map.globalBlock[i * map.maxBlocks + k] = mine[k];
        for (std::int64_t l = k; l < numBlocks[i]; ++l)
          coords.emplace_back(std::min(mine[k], mine[l]),
                              std::max(mine[k], mine[l]));
      }
    }
  }
  std::vector<BlockSlot> slots;
  BlockSparseMatrix matrix(layout, coords, &slots);
  // Hand each instance its pair slots, in the order coordinates were made.
  std::size_t next = 0;
  for (EnergyMap &map : maps) {
    std::int64_t m = map.maxBlocks;
    map.pairSlot.assign(map.count * m * m, BlockSlot{0, false});
    for (std::int64_t i = 0; i < map.count; ++i) {
      const std::int64_t *global = &map.globalBlock[i * m];
      std::int64_t k = 0;
      while (k < m && global[k] >= 0)
        ++k;
      for (std::int64_t a = 0; a < k; ++a)
        for (std::int64_t b = a; b < k; ++b) {
          BlockSlot slot = slots[next++];
          map.pairSlot[(i * m + a) * m + b] = slot;
          map.pairSlot[(i * m + b) * m + a] = slot;
        }
    }
  }
  return Part{std::move(maps), std::move(matrix)};
}

/// `layout`, after checking that its offsets start at 0 and grow: the
/// blocks' DoFs are looked up by them.
static const BlockLayout &checked(const BlockLayout &layout) {
  const std::vector<std::int64_t> &offsets = layout.blockOffset;
  if (offsets.empty() || offsets.front() != 0)
    throw std::invalid_argument(
        "GlobalSystem: the block offsets must start at 0");
  for (std::size_t b = 1; b < offsets.size(); ++b)
    if (offsets[b] <= offsets[b - 1])
      throw std::invalid_argument(
          "GlobalSystem: block " + std::to_string(b - 1) + " ends at " +
          std::to_string(offsets[b]) + ", not after its start " +
          std::to_string(offsets[b - 1]));
  return layout;
}

GlobalSystem::GlobalSystem(BlockLayout layout,
                           const std::vector<DofMap> &staticEnergies)
    : staticPart(buildPart(checked(layout), staticEnergies, 0)),
      dynamicPart(buildPart(layout, {}, staticEnergies.size())),
      gradientValues(static_cast<std::size_t>(staticPart.matrix.size()), 0.0) {}

void GlobalSystem::setDynamic(const std::vector<DofMap> &dynamicEnergies) {
  dynamicPart = buildPart(staticPart.matrix.layout(), dynamicEnergies,
                          numStaticEnergies());
}

void GlobalSystem::finishAssembly() {
  if (!singleProduct_)
    return;
  staticPart.matrix.roundValuesForProduct();
  dynamicPart.matrix.roundValuesForProduct();
}

void GlobalSystem::setZero() {
  staticPart.matrix.setZero();
  dynamicPart.matrix.setZero();
  std::fill(gradientValues.begin(), gradientValues.end(), 0.0);
}

// Instances from which an assembly is split between threads: below, the
// threads would cost more than the few hundred entries each adds.
static constexpr std::int64_t kMinInstancesToSplit = 256;

std::pair<GlobalSystem::Part *, const GlobalSystem::EnergyMap *>
GlobalSystem::energyMap(std::size_t energy) {
  if (energy >= numEnergies())
    throw std::out_of_range("energy " + std::to_string(energy) +
                            " out of range: the system has " +
                            std::to_string(numEnergies()) + " energies");
  bool isStatic = energy < numStaticEnergies();
  Part &part = isStatic ? staticPart : dynamicPart;
  return {&part, &part.maps[isStatic ? energy : energy - numStaticEnergies()]};
}

const GlobalSystem::EnergyMap &
GlobalSystem::energyStructure(std::size_t energy) const {
  return *const_cast<GlobalSystem *>(this)->energyMap(energy).second;
}

/// Whether instance i adds to a block row of `rows`: its Hessian's
/// diagonal blocks lie in its blocks' rows, and every other entry in one of
/// them too.
static bool touches(const GlobalSystem::EnergyMap &map, std::int64_t i,
                    GlobalSystem::RowRange rows) {
  const std::int64_t *global = &map.globalBlock[i * map.maxBlocks];
  for (std::int64_t p = 0; p < map.maxBlocks; ++p)
    if (global[p] >= 0 && rows.owns(global[p]))
      return true;
  return false;
}

/// Block-row ranges, one per thread, that split `map`'s blocks evenly: an
/// energy touches only its own bodies' rows (the cloth's, the bunny's), so
/// the matrix's own even split (rowRanges) could leave one thread nearly
/// all of an energy's instances. Cached in the map.
static const std::vector<std::int64_t> &
energyRanges(const GlobalSystem::EnergyMap &map, std::int64_t numBlocks,
             std::int64_t threads) {
  if (map.splitThreads == threads)
    return map.splitRanges;
  std::vector<std::int64_t> perRow(static_cast<std::size_t>(numBlocks), 0);
  std::int64_t total = 0;
  for (std::int64_t block : map.globalBlock)
    if (block >= 0) {
      ++perRow[block];
      ++total;
    }
  std::vector<std::int64_t> &ranges = map.splitRanges;
  ranges.assign(1, 0);
  std::int64_t seen = 0;
  for (std::int64_t row = 0; row < numBlocks; ++row) {
    seen += perRow[row];
    const auto next = static_cast<std::int64_t>(ranges.size());
    // Close a range once it holds its share of the blocks, leaving at
    // least one row to each range still to come.
    if (next < threads && seen * threads >= next * total &&
        numBlocks - (row + 1) >= threads - next)
      ranges.push_back(row + 1);
  }
  ranges.push_back(numBlocks);
  map.splitThreads = threads;
  return ranges;
}

/// Runs body(rows) once per range of block rows (energyRanges), ranges on
/// the pool's threads, or once over all rows when there is no pool, one
/// thread or little work. A body adds, of every instance in order, only the
/// entries whose block row is in its range (and the gradient entries of
/// those blocks): each entry is written by one thread and gets its terms in
/// instance order, so the sums do not depend on the number of threads and
/// need no atomics. An instance across ranges is read by each of them.
template <typename Body>
static void forRowRanges(ThreadPool *pool, const BlockSparseMatrix &matrix,
                         const GlobalSystem::EnergyMap &map, Body body) {
  const GlobalSystem::RowRange all{0, matrix.numBlocks()};
  if (!pool || pool->size() < 2 || map.count < kMinInstancesToSplit)
    return body(all);
  const std::vector<std::int64_t> &ranges = energyRanges(
      map, matrix.numBlocks(), static_cast<std::int64_t>(pool->size()));
  const std::int64_t parts = static_cast<std::int64_t>(ranges.size()) - 1;
  if (parts == 1)
    return body(all);
  pool->parallelFor(0, parts, 1, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t t = begin; t < end; ++t)
      body(GlobalSystem::RowRange{ranges[t], ranges[t + 1]});
  });
}

void GlobalSystem::add(std::size_t energy, const double *gradients,
                       const double *hessians, ThreadPool *pool) {
  addLocal(energy, gradients, hessians, pool);
}

void GlobalSystem::add(std::size_t energy, const float *gradients,
                       const float *hessians, ThreadPool *pool) {
  addLocal(energy, gradients, hessians, pool);
}

template <typename T>
void GlobalSystem::addLocal(std::size_t energy, const T *gradients,
                            const T *hessians, ThreadPool *pool) {
  // Named, not structured bindings: lambdas capture them (C++17).
  Part *part;
  const EnergyMap *map;
  std::tie(part, map) = energyMap(energy);
  // New values: until finishAssembly, products read the f64 ones.
  part->matrix.dropSingleValues();
  const std::int64_t n = map->numParams;
  forRowRanges(pool, part->matrix, *map, [&](RowRange rows) {
    for (std::int64_t i = 0; i < map->count; ++i)
      if (touches(*map, i, rows))
        addInstance(*part, *map, i, gradients + i * n, hessians + i * n * n,
                    gradientValues, rows);
  });
}

void GlobalSystem::addToInstances(std::size_t energy,
                                  const std::int64_t *instances,
                                  std::int64_t count, const double *hessians) {
  Part *part;
  const EnergyMap *map;
  std::tie(part, map) = energyMap(energy);
  part->matrix.dropSingleValues();
  const std::int64_t n = map->numParams;
  // The gradient gets zeros (a -0.0 entry becomes +0.0, nothing else).
  std::vector<double> noGradient(static_cast<std::size_t>(n), 0.0);
  const RowRange all{0, part->matrix.numBlocks()};
  for (std::int64_t k = 0; k < count; ++k) {
    const std::int64_t i = instances[k];
    if (i < 0 || i >= map->count)
      throw std::out_of_range("addToInstances: instance " + std::to_string(i) +
                              " of an energy of " + std::to_string(map->count));
    addInstance(*part, *map, i, noGradient.data(), hessians + k * n * n,
                gradientValues, all);
  }
}

void GlobalSystem::addFactored(std::size_t energy, const double *gradients,
                               const double *maps, const double *inner,
                               std::int64_t m, ThreadPool *pool) {
  // Named, not structured bindings: lambdas capture them (C++17).
  Part *part;
  const EnergyMap *map;
  std::tie(part, map) = energyMap(energy);
  // New values: until finishAssembly, products read the f64 ones.
  part->matrix.dropSingleValues();
  const std::int64_t n = map->numParams;
  forRowRanges(pool, part->matrix, *map, [&](RowRange rows) {
    std::vector<double> pj(static_cast<std::size_t>(m * n)),
        h(static_cast<std::size_t>(n * n));
    for (std::int64_t i = 0; i < map->count; ++i) {
      if (!touches(*map, i, rows))
        continue;
      const double *j = maps + i * m * n;
      const double *p = inner + i * m * m;
      // PJ = P J (m x n), then H = J^T (PJ) (n x n, symmetric: the upper
      // triangle is computed and mirrored).
      for (std::int64_t r = 0; r < m; ++r)
        for (std::int64_t c = 0; c < n; ++c) {
          double sum = 0.0;
          for (std::int64_t k = 0; k < m; ++k)
            sum += p[r * m + k] * j[k * n + c];
          pj[r * n + c] = sum;
        }
      for (std::int64_t a = 0; a < n; ++a)
        for (std::int64_t b = a; b < n; ++b) {
          double sum = 0.0;
          for (std::int64_t k = 0; k < m; ++k)
            sum += j[k * n + a] * pj[k * n + b];
          h[a * n + b] = h[b * n + a] = sum;
        }
      addInstance(*part, *map, i, gradients + i * n, h.data(), gradientValues,
                  rows);
    }
  });
}

/// Throws unless every local parameter that is a DoF lies in a slot with a
/// Jacobian: formLocal writes only those, and a DoF outside them would
/// read another instance's values.
static void requireCovered(const GlobalSystem::EnergyMap &map,
                           const SlotFactors &factors) {
  const std::int64_t n = map.numParams;
  const std::int64_t numSlots = static_cast<std::int64_t>(factors.slots.size());
  std::vector<char> covered(n);
  for (std::int64_t i = 0; i < map.count; ++i) {
    std::fill(covered.begin(), covered.end(), 0);
    for (std::int64_t s = 0; s < numSlots; ++s) {
      std::int64_t table = factors.sources[(i * numSlots + s) * 2];
      if (table < 0)
        continue;
      std::int64_t column = factors.slots[s].column;
      std::fill(covered.begin() + column,
                covered.begin() + column + factors.tables[table].cols, 1);
    }
    for (std::int64_t a = 0; a < n; ++a)
      if (map.localBlock[i * n + a] >= 0 && !covered[a])
        throw std::invalid_argument("instance " + std::to_string(i) +
                                    ": local parameter " + std::to_string(a) +
                                    " is a DoF but in no slot's Jacobian");
  }
}

void GlobalSystem::addSlotFactored(std::size_t energy,
                                   const double *innerGradients,
                                   const double *innerHessians,
                                   const SlotFactors &factors,
                                   ThreadPool *pool) {
  // Named, not structured bindings: lambdas capture them (C++17).
  Part *part;
  const EnergyMap *map;
  std::tie(part, map) = energyMap(energy);
  // New values: until finishAssembly, products read the f64 ones.
  part->matrix.dropSingleValues();
  const std::int64_t n = map->numParams, m = factors.numInner;
  factors.check(map->count, n);
  requireCovered(*map, factors);
  forRowRanges(pool, part->matrix, *map, [&](RowRange rows) {
    // Per range, not per instance: only the slots' entries are written
    // (padding is skipped by addInstance), so nothing is cleared.
    std::vector<double> g(n), h(n * n), scratch(m * n);
    for (std::int64_t i = 0; i < map->count; ++i) {
      if (!touches(*map, i, rows))
        continue;
      factors.formLocal(i, n, innerGradients + i * m, innerHessians + i * m * m,
                        g.data(), h.data(), scratch.data());
      addInstance(*part, *map, i, g.data(), h.data(), gradientValues, rows);
    }
  });
}

/// Local parameters a local Hessian is scanned over at once: the DoFs of
/// an instance are gathered first when there are at most this many
/// parameters (UNION padding can make most of them no DoF at all).
static constexpr std::int64_t kMaxGatheredParams = 512;
/// Up to this many parameters that are DoFs, those sharing a DoF are merged
/// before accumulating (a k x k sum on the stack).
static constexpr std::int64_t kMaxMergedParams = 64;

/// The common case of addInstance, block by block: the instance's
/// parameters are m distinct 3-DoF blocks in order (a tet's or a pair's
/// vertices), so each block pair of its Hessian is one 3x3 slice added to
/// one stored block. The entry-by-entry loop looks up the slot and the
/// block's shape per entry: nine times the work, most of an assembly. The
/// same single addition reaches each matrix entry, so the sums are the
/// same. False (nothing added) when the instance is not of that shape.
template <typename T>
static bool
addVertexBlocks(BlockSparseMatrix &matrix, const GlobalSystem::EnergyMap &map,
                std::int64_t i, const T *g, const T *h,
                std::vector<double> &gradient, GlobalSystem::RowRange rows) {
  const BlockLayout &layout = matrix.layout();
  const std::int64_t n = map.numParams, m = map.maxBlocks;
  if (n != 3 * m)
    return false;
  const std::int32_t *local = &map.localBlock[i * n];
  const std::int32_t *offset = &map.offset[i * n];
  const std::int64_t *global = &map.globalBlock[i * m];
  for (std::int64_t a = 0; a < n; ++a)
    if (local[a] != a / 3 || offset[a] != a % 3)
      return false;
  for (std::int64_t p = 0; p < m; ++p) {
    if (global[p] < 0 || layout.blockSize(global[p]) != 3)
      return false;
    for (std::int64_t q = 0; q < p; ++q)
      if (global[q] == global[p])
        return false;
  }
  for (std::int64_t p = 0; p < m; ++p) {
    const std::int64_t gp = global[p];
    // Block row gp: its gradient and the blocks (gp, gq), gq >= gp.
    if (!rows.owns(gp))
      continue;
    double *gradientBlock = &gradient[layout.blockOffset[gp]];
    for (std::int64_t r = 0; r < 3; ++r)
      gradientBlock[r] += g[3 * p + r];
    for (std::int64_t q = 0; q < m; ++q) {
      // Upper triangle: (q, p) adds the transpose of the pairs below it.
      if (gp > global[q])
        continue;
      BlockSlot slot = map.pairSlot[(i * m + p) * m + q];
      double *data = matrix.blockData(slot.block);
      const T *slice = h + 3 * p * n + 3 * q;
      for (std::int64_t r = 0; r < 3; ++r)
        for (std::int64_t c = 0; c < 3; ++c)
          data[r * 3 + c] += slice[r * n + c];
    }
  }
  return true;
}

template <typename T>
void GlobalSystem::addInstance(Part &part, const EnergyMap &map, std::int64_t i,
                               const T *g, const T *h,
                               std::vector<double> &gradient, RowRange rows) {
  BlockSparseMatrix &matrix = part.matrix;
  if (addVertexBlocks(matrix, map, i, g, h, gradient, rows))
    return;
  const BlockLayout &layout = matrix.layout();
  std::int64_t n = map.numParams, m = map.maxBlocks;
  const std::int32_t *local = &map.localBlock[i * n];
  const std::int32_t *offset = &map.offset[i * n];
  const std::int64_t *global = &map.globalBlock[i * m];
  // The parameters that are DoFs: a tet of soft vertices in a UNION padded
  // to affine bodies has 12 of 48, so the n x n scan would be 16x the work.
  std::int32_t gathered[kMaxGatheredParams];
  std::int64_t numActive = 0;
  if (n <= kMaxGatheredParams) {
    for (std::int64_t a = 0; a < n; ++a)
      if (local[a] >= 0)
        gathered[numActive++] = static_cast<std::int32_t>(a);
  }
  auto addPair = [&](std::int64_t a, std::int64_t b, std::int64_t ga) {
    std::int64_t gb = global[local[b]];
    // Each pair of distinct blocks is stored once, upper triangle: the
    // entries with ga > gb are its transpose, added from (b, a).
    if (ga > gb)
      return;
    BlockSlot slot = map.pairSlot[(i * m + local[a]) * m + local[b]];
    double *data = matrix.blockData(slot.block);
    std::int64_t cols = layout.blockSize(gb);
    data[offset[a] * cols + offset[b]] += h[a * n + b];
  };
  if (numActive <= kMaxMergedParams) {
    // Parameters of one DoF (the four vertices of a tet of one affine body:
    // 48 parameters, 12 DoFs) are summed here first, so that each DoF pair
    // is accumulated into the matrix once instead of up to 16 times.
    std::int32_t slotOf[kMaxMergedParams], first[kMaxMergedParams];
    std::int64_t dofOf[kMaxMergedParams], k = 0;
    for (std::int64_t x = 0; x < numActive; ++x) {
      std::int64_t a = gathered[x];
      std::int64_t dof = layout.blockOffset[global[local[a]]] + offset[a];
      std::int64_t u = std::find(dofOf, dofOf + k, dof) - dofOf;
      if (u == k) {
        dofOf[k] = dof;
        first[k++] = static_cast<std::int32_t>(a);
      }
      slotOf[x] = static_cast<std::int32_t>(u);
    }
    if (k < numActive) {
      double merged[kMaxMergedParams * kMaxMergedParams] = {};
      double mergedGradient[kMaxMergedParams] = {};
      for (std::int64_t x = 0; x < numActive; ++x) {
        std::int64_t a = gathered[x];
        mergedGradient[slotOf[x]] += g[a];
        for (std::int64_t y = 0; y < numActive; ++y)
          merged[slotOf[x] * k + slotOf[y]] += h[a * n + gathered[y]];
      }
      for (std::int64_t u = 0; u < k; ++u) {
        std::int64_t a = first[u], ga = global[local[a]];
        if (!rows.owns(ga))
          continue;
        gradient[dofOf[u]] += mergedGradient[u];
        for (std::int64_t v = 0; v < k; ++v) {
          std::int64_t b = first[v], gb = global[local[b]];
          if (ga > gb)
            continue;
          BlockSlot slot = map.pairSlot[(i * m + local[a]) * m + local[b]];
          matrix.blockData(
              slot.block)[offset[a] * layout.blockSize(gb) + offset[b]] +=
              merged[u * k + v];
        }
      }
      return;
    }
  }
  if (n <= kMaxGatheredParams) {
    for (std::int64_t x = 0; x < numActive; ++x) {
      std::int64_t a = gathered[x], ga = global[local[a]];
      if (!rows.owns(ga))
        continue;
      gradient[layout.blockOffset[ga] + offset[a]] += g[a];
      for (std::int64_t y = 0; y < numActive; ++y)
        addPair(a, gathered[y], ga);
    }
    return;
  }
  for (std::int64_t a = 0; a < n; ++a) {
    if (local[a] < 0)
      continue;
    std::int64_t ga = global[local[a]];
    if (!rows.owns(ga))
      continue;
    gradient[layout.blockOffset[ga] + offset[a]] += g[a];
    for (std::int64_t b = 0; b < n; ++b)
      if (local[b] >= 0)
        addPair(a, b, ga);
  }
}

void GlobalSystem::multiply(const double *x, double *y,
                            ThreadPool &pool) const {
  std::vector<double> scratch;
  multiplySum(hessianParts(), x, y, scratch, pool);
}

std::vector<double> GlobalSystem::toDense() const {
  std::vector<double> dense = staticPart.matrix.toDense();
  std::vector<double> more = dynamicPart.matrix.toDense();
  for (std::size_t i = 0; i < dense.size(); ++i)
    dense[i] += more[i];
  return dense;
}
