//===- Multilevel.cpp - aggregation multigrid as PCG's preconditioner -----===//

#include "yasps/Runtime/Sparse/Multilevel.h"

#include "yasps/Runtime/Sparse/Lanczos.h"
#include "yasps/Runtime/Sparse/Pcg.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include <cmath>
#include <stdexcept>

using namespace yasps::runtime;

// Below this many DoFs a level's vector steps (smoothing, restriction,
// prolongation) run on the calling thread, as PCG's do (Pcg.cpp): each is
// a few tens of microseconds, about what handing it to the pool costs. The
// products decide for themselves. (At 1 << 18, the fine level of the
// paper-scale cloths-on-bunny, 118,785 DoFs, smoothed on one thread: a
// two-thread solve took 0.19 s instead of 0.16 s.)
static constexpr std::int64_t kMinParallelVector = 1 << 14;
// Aggregates per chunk when restricting and prolonging.
static constexpr std::int64_t kAggregatesPerChunk = 256;
// Coarsening stops where a level keeps more than this share of its finer
// level's DoFs (blocks that nothing couples do not aggregate).
static constexpr double kStalledCoarsening = 0.9;

struct Multilevel::Level {
  /// The level's matrix, as the sum of parts: the fine level's are the
  /// solve's, a coarse level's are its own `matrices`, one per fine part.
  std::vector<std::unique_ptr<BlockSparseMatrix>> matrices;
  HessianParts parts;
  const std::uint8_t *fixed = nullptr;
  std::int64_t size = 0;
  std::unique_ptr<BlockJacobi> smoother;
  double damping = 1.0;
  /// To the next coarser level (all but the coarsest): the aggregates and,
  /// per part and per stored block of it with both blocks aggregated, in
  /// order, its slot in the coarser level's matrix of that part; and the
  /// structure ids of the parts those slots were made for.
  Aggregates aggregates;
  std::vector<std::vector<BlockSlot>> slots;
  std::vector<std::uint64_t> slotsFor;
  /// Per aggregate, its member blocks: members[memberStart[a] ..
  /// memberStart[a + 1]).
  std::vector<std::size_t> memberStart;
  std::vector<std::int64_t> members;
  /// The coarsest level: the dense Cholesky factor L (row-major, lower),
  /// or empty where the level is too large or not positive definite and
  /// its smoother stands in for the solve.
  std::vector<double> cholesky;
  bool coarsest = false;
  /// The fine level's parts' values rounded to f32, which the cycle's
  /// products read: they are bound by reading the blocks, and a
  /// preconditioner's products need not be exact (the cycle stays a
  /// symmetric positive definite operator: see refresh()).
  std::vector<std::vector<float>> rounded;
  /// Vectors of the cycle: the restricted residual (coarse levels), the
  /// correction, a residual and a smoothing step.
  std::vector<double> r, z, t, u;
};

namespace {
/// Copies the s x c block `block` masked by the fixed DoFs of its row and
/// column blocks (offsets rowOffset and colOffset): a masked entry is 0.
void maskBlock(const double *block, std::int64_t s, std::int64_t c,
               const std::uint8_t *fixed, std::int64_t rowOffset,
               std::int64_t colOffset, std::vector<double> &out) {
  out.assign(block, block + s * c);
  if (!fixed)
    return;
  for (std::int64_t p = 0; p < s; ++p)
    for (std::int64_t q = 0; q < c; ++q)
      if (fixed[rowOffset + p] || fixed[colOffset + q])
        out[p * c + q] = 0.0;
}

/// to += the rows x cols block `values`, or its transpose (`to` is then
/// cols x rows): BlockSparseMatrix::addBlock without its checks, unrolled
/// for vertex blocks.
inline void addBlockTo(double *to, const double *values, std::int64_t rows,
                       std::int64_t cols, bool transposed) {
  if (rows == 3 && cols == 3) {
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        to[a * 3 + b] += transposed ? values[b * 3 + a] : values[a * 3 + b];
    return;
  }
  if (!transposed) {
    for (std::int64_t k = 0; k < rows * cols; ++k)
      to[k] += values[k];
    return;
  }
  for (std::int64_t a = 0; a < cols; ++a)
    for (std::int64_t b = 0; b < rows; ++b)
      to[a * rows + b] += values[b * cols + a];
}

/// In-place Cholesky factor of the n x n row-major `a` (lower triangle);
/// false if it is not positive definite.
bool choleskyInPlace(std::vector<double> &a, std::int64_t n) {
  for (std::int64_t j = 0; j < n; ++j) {
    double d = a[j * n + j];
    for (std::int64_t k = 0; k < j; ++k)
      d -= a[j * n + k] * a[j * n + k];
    if (!(d > 0.0) || !std::isfinite(d))
      return false;
    d = std::sqrt(d);
    a[j * n + j] = d;
    for (std::int64_t i = j + 1; i < n; ++i) {
      double v = a[i * n + j];
      for (std::int64_t k = 0; k < j; ++k)
        v -= a[i * n + k] * a[j * n + k];
      a[i * n + j] = v / d;
    }
  }
  return true;
}

double dot(const std::vector<double> &a, const std::vector<double> &b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    sum += a[i] * b[i];
  return sum;
}
} // namespace

Multilevel::Multilevel(const HessianParts &parts, const std::uint8_t *fixed,
                       ThreadPool &pool, const MultilevelOptions &options)
    : Multilevel(parts, options) {
  refresh(parts, fixed, pool);
}

Multilevel::Multilevel(const HessianParts &parts,
                       const MultilevelOptions &options)
    : options_(options), structure_(parts.front()->structureId()) {
  auto fine = std::make_unique<Level>();
  fine->parts = parts;
  fine->size = parts.front()->size();
  levels_.push_back(std::move(fine));
  while (true) {
    Level &level = *levels_.back();
    level.z.resize(static_cast<std::size_t>(level.size));
    level.t.resize(static_cast<std::size_t>(level.size));
    level.u.resize(static_cast<std::size_t>(level.size));
    bool last = level.size <= options.coarsestDofs ||
                static_cast<std::int64_t>(levels_.size()) >= options.maxLevels;
    if (!last) {
      // The first part's structure alone decides the aggregates, so that
      // the others (contact) may change without changing the levels.
      level.aggregates = aggregateBlocks({level.parts.front()});
      std::int64_t coarseSize = 0;
      for (std::int64_t s : level.aggregates.size)
        coarseSize += s;
      last = coarseSize > kStalledCoarsening * static_cast<double>(level.size);
    }
    if (last) {
      level.coarsest = true;
      break;
    }
    // Aggregate members, for the restriction.
    const Aggregates &agg = level.aggregates;
    level.memberStart.assign(static_cast<std::size_t>(agg.count()) + 1, 0);
    for (std::int64_t a : agg.of)
      if (a >= 0)
        ++level.memberStart[a + 1];
    for (std::int64_t a = 0; a < agg.count(); ++a)
      level.memberStart[a + 1] += level.memberStart[a];
    level.members.resize(level.memberStart.back());
    std::vector<std::size_t> fill(level.memberStart.begin(),
                                  level.memberStart.end() - 1);
    for (std::int64_t b = 0; b < static_cast<std::int64_t>(agg.of.size()); ++b)
      if (agg.of[b] >= 0)
        level.members[fill[agg.of[b]]++] = b;

    auto coarse = std::make_unique<Level>();
    coarse->matrices.resize(level.parts.size());
    level.slots.resize(level.parts.size());
    level.slotsFor.assign(level.parts.size(), 0);
    Level &added = *coarse;
    levels_.push_back(std::move(coarse));
    for (std::size_t k = 0; k < level.parts.size(); ++k)
      buildCoarsePart(levels_.size() - 2, k);
    added.size = added.parts.front()->size();
    added.r.resize(static_cast<std::size_t>(added.size));
  }
}

const HessianParts &Multilevel::levelParts(std::size_t l) const {
  return levels_.at(l)->parts;
}
const Aggregates &Multilevel::aggregates(std::size_t l) const {
  return levels_.at(l)->aggregates;
}
const std::vector<std::size_t> &Multilevel::memberStart(std::size_t l) const {
  return levels_.at(l)->memberStart;
}
const std::vector<std::int64_t> &Multilevel::members(std::size_t l) const {
  return levels_.at(l)->members;
}
const std::vector<BlockSlot> &Multilevel::slots(std::size_t l,
                                                std::size_t part) const {
  return levels_.at(l)->slots.at(part);
}

void Multilevel::buildCoarsePart(std::size_t l, std::size_t k) {
  // Every stored block of the part lands in the block of its aggregates
  // (coarsen() adds the values).
  Level &level = *levels_[l];
  Level &coarse = *levels_[l + 1];
  const Aggregates &agg = level.aggregates;
  const BlockSparseMatrix &part = *level.parts[k];
  std::vector<std::pair<std::int64_t, std::int64_t>> coords;
  for (std::size_t b = 0; b < part.numStoredBlocks(); ++b) {
    std::int64_t i = part.blockRow(b), j = part.blockCol(b);
    if (agg.of[i] >= 0 && agg.of[j] >= 0)
      coords.emplace_back(agg.of[i], agg.of[j]);
  }
  coarse.matrices[k] = std::make_unique<BlockSparseMatrix>(
      BlockLayout::fromSizes(agg.size), coords, &level.slots[k]);
  level.slotsFor[k] = part.structureId();
  coarse.parts.resize(coarse.matrices.size());
  coarse.parts[k] = coarse.matrices[k].get();
}

bool Multilevel::matches(const HessianParts &parts) const {
  return parts.size() == levels_.front()->parts.size() &&
         parts.front()->structureId() == structure_;
}

void Multilevel::coarsen(std::size_t l) {
  Level &level = *levels_[l];
  const Aggregates &agg = level.aggregates;
  const BlockLayout &layout = level.parts.front()->layout();
  // Per block, whether it has a fixed DoF: only those blocks are masked
  // (a copy per block made this loop the bulk of a refresh).
  std::vector<std::uint8_t> hasFixed(
      static_cast<std::size_t>(layout.numBlocks()), 0);
  if (level.fixed)
    for (std::int64_t b = 0; b < layout.numBlocks(); ++b)
      for (std::int64_t k = 0; k < layout.blockSize(b); ++k)
        hasFixed[b] |= level.fixed[layout.blockOffset[b] + k];
  std::vector<double> masked;
  for (std::size_t k = 0; k < level.parts.size(); ++k) {
    const BlockSparseMatrix &part = *level.parts[k];
    BlockSparseMatrix &coarse = *levels_[l + 1]->matrices[k];
    coarse.setZero();
    std::size_t next = 0;
    // A block between two members of one aggregate stands for itself and
    // its transpose, which both land in the aggregate's diagonal block.
    for (std::size_t b = 0; b < part.numStoredBlocks(); ++b) {
      std::int64_t i = part.blockRow(b), j = part.blockCol(b);
      if (agg.of[i] < 0 || agg.of[j] < 0)
        continue;
      const std::int64_t rows = layout.blockSize(i), cols = layout.blockSize(j);
      const double *values = part.blockData(b);
      if (hasFixed[i] || hasFixed[j]) {
        maskBlock(values, rows, cols, level.fixed, layout.blockOffset[i],
                  layout.blockOffset[j], masked);
        values = masked.data();
      }
      BlockSlot slot = level.slots[k][next++];
      double *to = coarse.blockData(slot.block);
      addBlockTo(to, values, rows, cols, slot.transposed);
      if (agg.of[i] == agg.of[j] && i != j)
        addBlockTo(to, values, rows, cols, !slot.transposed);
    }
  }
}

bool Multilevel::restructure(const HessianParts &parts) {
  if (!matches(parts))
    throw std::invalid_argument("Multilevel: the parts' structure is not the "
                                "one the levels were built for");
  levels_.front()->parts = parts;
  bool changed = false;
  for (std::size_t l = 0; l + 1 < levels_.size(); ++l)
    for (std::size_t k = 0; k < parts.size(); ++k)
      if (levels_[l]->slotsFor[k] != levels_[l]->parts[k]->structureId()) {
        buildCoarsePart(l, k);
        changed = true;
      }
  return changed;
}

void Multilevel::refresh(const HessianParts &parts, const std::uint8_t *fixed,
                         ThreadPool &pool) {
  restructure(parts);
  levels_.front()->fixed = fixed;
  // The cycle reads the fine matrix rounded to f32 (A~): it remains
  // M^-1 = 2S - S A~ S + (I - S A~) P C P^T (I - A~ S) with S = w D^-1,
  // symmetric, and positive definite while w lmax(D^-1 A~) < 2, whatever
  // the coarse inverse C's matrix (the coarse levels sum the f64 blocks).
  Level &fine = *levels_.front();
  // An additive fine level reads no fine matrix in the cycle.
  fine.rounded.resize(options_.additiveFine ? 0 : parts.size());
  for (std::size_t k = 0; k < fine.rounded.size(); ++k) {
    const std::vector<double> &values = parts[k]->values();
    fine.rounded[k].resize(values.size());
    for (std::size_t i = 0; i < values.size(); ++i)
      fine.rounded[k][i] = static_cast<float>(values[i]);
  }
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    Level &level = *levels_[l];
    level.smoother =
        std::make_unique<BlockJacobi>(level.parts, level.fixed, pool);
    if (!level.coarsest)
      coarsen(l);
  }
  for (std::size_t l = 0; l + 1 < levels_.size(); ++l) {
    if (l == 0 && options_.additiveFine)
      levels_[l]->damping = 1.0;
    else
      estimateDamping(l, pool);
  }
  factorCoarsest();
}

void Multilevel::estimateDamping(std::size_t l, ThreadPool &pool) {
  // w = 4 / (3 lmax(D^-1 A)), lmax from the Lanczos matrix of a few
  // block-Jacobi PCG steps.
  Level &level = *levels_[l];
  std::vector<double> r = multilevelStartVector(level.size, level.fixed), z(r),
                      p(r), q(r);
  level.smoother->apply(r.data(), z.data(), pool);
  p = z;
  double rz = dot(r, z);
  std::vector<double> alphas, betas;
  for (std::int64_t k = 0; k < options_.eigenvalueSteps && rz > 0.0; ++k) {
    multiply(l, p.data(), q.data(), pool);
    double pq = dot(p, q);
    if (!(pq > 0.0))
      break;
    double alpha = rz / pq;
    alphas.push_back(alpha);
    for (std::size_t i = 0; i < r.size(); ++i)
      r[i] -= alpha * q[i];
    level.smoother->apply(r.data(), z.data(), pool);
    double next = dot(r, z);
    betas.push_back(next / rz);
    for (std::size_t i = 0; i < p.size(); ++i)
      p[i] = z[i] + betas.back() * p[i];
    rz = next;
  }
  double largest = ritzExtremeValues(alphas, betas).second;
  // No estimate: a level without free DoFs, whose vectors are all 0.
  double damping =
      largest > 0.0 && std::isfinite(largest) ? 4.0 / (3.0 * largest) : 1.0;
  // The cycle is positive definite only while w lmax < 2. Lanczos from a
  // random start underestimates lmax where it lies in a few stiff local
  // modes (contact pairs far stiffer than the elastic body around them):
  // PCG then broke down on SPD systems. A norm bound caps w (with 5% to
  // spare for the f32 copy of the fine matrix).
  double bound = level.smoother->eigenvalueBound(level.parts, level.fixed);
  if (bound > 0.0 && std::isfinite(bound))
    damping = std::min(damping, 1.9 / bound);
  level.damping = damping;
}

void Multilevel::factorCoarsest() {
  Level &last = *levels_.back();
  last.cholesky.clear();
  if (last.size > options_.coarsestDofs)
    return;
  const std::int64_t n = last.size;
  std::vector<double> dense(static_cast<std::size_t>(n * n), 0.0);
  for (const BlockSparseMatrix *part : last.parts) {
    std::vector<double> more = part->toDense();
    for (std::size_t i = 0; i < dense.size(); ++i)
      dense[i] += more[i];
  }
  // Fixed DoFs and the DoFs of aggregates of fixed DoFs have zero rows:
  // solving them as identity keeps their zero residual zero.
  for (std::int64_t i = 0; i < n; ++i) {
    bool zero = last.fixed && last.fixed[i];
    if (!zero) {
      zero = true;
      for (std::int64_t j = 0; j < n && zero; ++j)
        zero = dense[i * n + j] == 0.0;
    }
    if (zero) {
      for (std::int64_t j = 0; j < n; ++j)
        dense[i * n + j] = dense[j * n + i] = 0.0;
      dense[i * n + i] = 1.0;
    }
  }
  if (choleskyInPlace(dense, n))
    last.cholesky = std::move(dense);
}

Multilevel::~Multilevel() = default;

std::vector<double>
yasps::runtime::multilevelStartVector(std::int64_t n,
                                      const std::uint8_t *fixed) {
  std::vector<double> v(static_cast<std::size_t>(n));
  std::uint64_t state = 0x9E3779B97F4A7C15ull;
  for (std::size_t i = 0; i < v.size(); ++i) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    v[i] = fixed && fixed[i]
               ? 0.0
               : static_cast<double>(state >> 11) * 0x1.0p-52 - 1.0;
  }
  return v;
}

double Multilevel::diagonalRatio() const {
  return levels_.front()->smoother->diagonalRatio();
}

std::vector<std::int64_t> Multilevel::levelSizes() const {
  std::vector<std::int64_t> sizes;
  for (const auto &level : levels_)
    sizes.push_back(level->size);
  return sizes;
}

std::vector<double> Multilevel::dampings() const {
  std::vector<double> out;
  for (std::size_t l = 0; l + 1 < levels_.size(); ++l)
    out.push_back(levels_[l]->damping);
  return out;
}

void Multilevel::multiply(std::size_t l, const double *x, double *y,
                          ThreadPool &pool) {
  Level &level = *levels_[l];
  if (level.rounded.empty()) {
    multiplySum(level.parts, x, y, scratch_, pool);
  } else {
    const std::size_t n = static_cast<std::size_t>(level.size);
    level.parts.front()->multiplyRounded(level.rounded.front(), x, y, pool);
    for (std::size_t k = 1; k < level.parts.size(); ++k) {
      if (level.parts[k]->numStoredBlocks() == 0)
        continue;
      scratch_.resize(n);
      level.parts[k]->multiplyRounded(level.rounded[k], x, scratch_.data(),
                                      pool);
      for (std::size_t i = 0; i < n; ++i)
        y[i] += scratch_[i];
    }
  }
  if (level.fixed)
    for (std::int64_t i = 0; i < level.size; ++i)
      if (level.fixed[i])
        y[i] = 0.0;
}

void Multilevel::apply(const double *r, double *z, ThreadPool &pool) {
  if (!splitsFineLevel())
    return cycle(0, r, z, pool);
  Level &fine = *levels_.front();
  fine.smoother->apply(r, z, fine.size >= kMinParallelVector ? pool : serial_);
  addCoarseCorrection(r, z, pool);
}

double Multilevel::addCoarseCorrection(const double *r, double *z,
                                       ThreadPool &pool) {
  Level &fine = *levels_.front();
  ThreadPool &vectors = fine.size >= kMinParallelVector ? pool : serial_;
  const std::int64_t count = numFineAggregates();
  vectors.parallelFor(0, count, kAggregatesPerChunk,
                      [&](std::int64_t begin, std::int64_t end) {
                        restrictAggregates(r, begin, end);
                      });
  double rz = solveCoarse();
  vectors.parallelFor(0, count, kAggregatesPerChunk,
                      [&](std::int64_t begin, std::int64_t end) {
                        prolongAggregates(z, begin, end);
                      });
  return rz;
}

bool Multilevel::splitsFineLevel() const {
  return options_.additiveFine && levels_.size() > 1;
}

const BlockJacobi &Multilevel::fineSmoother() const {
  return *levels_.front()->smoother;
}

std::int64_t Multilevel::numFineAggregates() const {
  return levels_.front()->aggregates.count();
}

void Multilevel::restrictAggregates(const double *r, std::int64_t begin,
                                    std::int64_t end) {
  restrictRange(0, r, begin, end);
}

double Multilevel::solveCoarse() {
  // On one thread whatever the pool, so that PCG's team (whose other
  // members wait meanwhile) and a lone caller get the same sums.
  Level &coarse = *levels_[1];
  cycle(1, coarse.r.data(), coarse.z.data(), serial_);
  double rz = 0.0;
  for (std::int64_t i = 0; i < coarse.size; ++i)
    rz += coarse.r[i] * coarse.z[i];
  return rz;
}

void Multilevel::prolongAggregates(double *z, std::int64_t begin,
                                   std::int64_t end) const {
  prolongRange(0, z, begin, end);
}

void Multilevel::restrictRange(std::size_t l, const double *r,
                               std::int64_t begin, std::int64_t end) {
  Level &level = *levels_[l];
  Level &coarse = *levels_[l + 1];
  const BlockLayout &fine = level.parts.front()->layout();
  const BlockLayout &coarseLayout = coarse.parts.front()->layout();
  for (std::int64_t a = begin; a < end; ++a) {
    std::int64_t o = coarseLayout.blockOffset[a];
    std::int64_t s = level.aggregates.size[a];
    for (std::int64_t k = 0; k < s; ++k)
      coarse.r[o + k] = 0.0;
    for (std::size_t m = level.memberStart[a]; m < level.memberStart[a + 1];
         ++m) {
      std::int64_t f = fine.blockOffset[level.members[m]];
      for (std::int64_t k = 0; k < s; ++k)
        coarse.r[o + k] += r[f + k];
    }
  }
}

void Multilevel::prolongRange(std::size_t l, double *z, std::int64_t begin,
                              std::int64_t end) const {
  const Level &level = *levels_[l];
  const Level &coarse = *levels_[l + 1];
  const BlockLayout &fine = level.parts.front()->layout();
  const BlockLayout &coarseLayout = coarse.parts.front()->layout();
  for (std::int64_t a = begin; a < end; ++a) {
    std::int64_t o = coarseLayout.blockOffset[a];
    std::int64_t s = level.aggregates.size[a];
    for (std::size_t m = level.memberStart[a]; m < level.memberStart[a + 1];
         ++m) {
      std::int64_t f = fine.blockOffset[level.members[m]];
      for (std::int64_t k = 0; k < s; ++k)
        if (!level.fixed || !level.fixed[f + k])
          z[f + k] += coarse.z[o + k];
    }
  }
}

void Multilevel::cycle(std::size_t l, const double *r, double *z,
                       ThreadPool &pool) {
  Level &level = *levels_[l];
  const std::int64_t n = level.size;
  if (level.coarsest) {
    if (level.cholesky.empty()) {
      level.smoother->apply(r, z, serial_);
      return;
    }
    const double *L = level.cholesky.data();
    for (std::int64_t i = 0; i < n; ++i) {
      double v = r[i];
      for (std::int64_t k = 0; k < i; ++k)
        v -= L[i * n + k] * z[k];
      z[i] = v / L[i * n + i];
    }
    for (std::int64_t i = n - 1; i >= 0; --i) {
      double v = z[i];
      for (std::int64_t k = i + 1; k < n; ++k)
        v -= L[k * n + i] * z[k];
      z[i] = v / L[i * n + i];
    }
    return;
  }
  // The coarse levels' V-cycle (an additive fine level is split in
  // apply()).
  const double w = level.damping;
  double *t = level.t.data(), *u = level.u.data();
  ThreadPool &vectors = n >= kMinParallelVector ? pool : serial_;
  level.smoother->apply(r, z, vectors);
  for (std::int64_t i = 0; i < n; ++i)
    z[i] *= w;
  multiply(l, z, t, pool);
  for (std::int64_t i = 0; i < n; ++i)
    t[i] = r[i] - t[i];
  Level &coarse = *levels_[l + 1];
  vectors.parallelFor(0, level.aggregates.count(), kAggregatesPerChunk,
                      [&](std::int64_t begin, std::int64_t end) {
                        restrictRange(l, t, begin, end);
                      });
  cycle(l + 1, coarse.r.data(), coarse.z.data(), pool);
  vectors.parallelFor(0, level.aggregates.count(), kAggregatesPerChunk,
                      [&](std::int64_t begin, std::int64_t end) {
                        prolongRange(l, z, begin, end);
                      });
  multiply(l, z, t, pool);
  for (std::int64_t i = 0; i < n; ++i)
    t[i] = r[i] - t[i];
  level.smoother->apply(t, u, vectors);
  for (std::int64_t i = 0; i < n; ++i)
    z[i] += w * u[i];
}
