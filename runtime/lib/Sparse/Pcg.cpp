//===- Pcg.cpp - preconditioned conjugate gradient ------------------------===//

#include "yasps/Runtime/Sparse/Pcg.h"

#include "yasps/Runtime/Sparse/BlockJacobi.h"
#include "yasps/Runtime/Sparse/BlockSparseMatrix.h"
#include "yasps/Runtime/Sparse/Lanczos.h"
#include "yasps/Runtime/Sparse/Multilevel.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

using namespace yasps::runtime;

// Dot products sum fixed-size segments in parallel, then the segment sums in
// order: the result does not depend on the number of threads, so neither
// does the iteration count. Small enough that a team's members get shares
// of about the same size on the scenes of bench/stark_peer.py (7,482 and
// 1,875 DoFs).
static constexpr std::int64_t kSegment = 1024;
// Elements per chunk for element-wise vector updates.
static constexpr std::int64_t kElementsPerChunk = 4096;
// Below this many DoFs the vector steps of an iteration run on the calling
// thread, where handing one to the pool (about 18 us on two threads) costs
// what it saves. Since the steps were fused with their dot products the
// bunny's (57,579 DoFs) gain from a second thread: its block-Jacobi solve
// went from 140-147 to 120-126 ms (median) when this was lowered from 2^18
// (bench/newton_calls.py --threads 2). The SpMV decides for itself.
static constexpr std::int64_t kMinParallelVector = 1 << 14;
// Fewest DoFs for which a block-Jacobi solve runs as a team (iterateAsTeam):
// on two threads the team made a PCG iteration of the soft bunny on the
// cloth (7,482 DoFs) 1.2x faster than one thread (68 against 56 us) where
// handing each step to the pool had made it slower (72 us); the twisting
// cloth's (1,875 DoFs) solves gained 1.25x.
static constexpr std::int64_t kMinTeamDofs = 768;

/// The sum of term(i) over [0, n): fixed segments summed in parallel,
/// then the segment sums in order. `term` may also update entry i of
/// vectors, fusing a vector step with the dot product it feeds.
///
/// Within a segment, four sums of every fourth term, added pairwise at the
/// end: with one running sum each term waits for the previous addition.
/// With this and applyDot's three sums the bunny's one-thread PCG iteration
/// took 0.755-0.887 ms against 0.786-0.932 ms (best of 15 solves, 5 runs
/// each, yasps-spmv-bench). The order is fixed by the segment, so the
/// result still does not depend on the number of threads.
template <typename Term>
static double segmentSum(std::int64_t segment, std::int64_t n, Term &term) {
  const std::int64_t last = std::min(n, (segment + 1) * kSegment);
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  std::int64_t i = segment * kSegment;
  for (; i + 4 <= last; i += 4) {
    s0 += term(i);
    s1 += term(i + 1);
    s2 += term(i + 2);
    s3 += term(i + 3);
  }
  for (; i < last; ++i)
    s0 += term(i);
  return (s0 + s1) + (s2 + s3);
}

static std::int64_t numSegments(std::int64_t n) {
  return (n + kSegment - 1) / kSegment;
}

static double sumInOrder(const double *partial, std::int64_t count) {
  double sum = 0.0;
  for (std::int64_t s = 0; s < count; ++s)
    sum += partial[s];
  return sum;
}

template <typename Term>
static double sumBySegments(std::int64_t n, std::vector<double> &partial,
                            ThreadPool &pool, Term term) {
  const std::int64_t count = numSegments(n);
  partial.assign(static_cast<std::size_t>(count), 0.0);
  pool.parallelFor(0, count, 1, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t s = begin; s < end; ++s)
      partial[s] = segmentSum(s, n, term);
  });
  return sumInOrder(partial.data(), count);
}

static double dot(const double *a, const double *b, std::int64_t n,
                  std::vector<double> &partial, ThreadPool &pool) {
  return sumBySegments(n, partial, pool,
                       [&](std::int64_t i) { return a[i] * b[i]; });
}

/// y = a * x + b * y, element-wise.
static void axpby(double a, const double *x, double b, double *y,
                  std::int64_t n, ThreadPool &pool) {
  pool.parallelFor(0, n, kElementsPerChunk,
                   [&](std::int64_t begin, std::int64_t end) {
                     for (std::int64_t i = begin; i < end; ++i)
                       y[i] = a * x[i] + b * y[i];
                   });
}

void yasps::runtime::multiplySum(const HessianParts &parts, const double *x,
                                 double *y, std::vector<double> &scratch,
                                 ThreadPool &pool) {
  parts.front()->multiply(x, y, pool);
  const std::size_t n = static_cast<std::size_t>(parts.front()->size());
  for (std::size_t k = 1; k < parts.size(); ++k) {
    if (parts[k]->numStoredBlocks() == 0)
      continue;
    scratch.resize(n);
    parts[k]->multiply(x, scratch.data(), pool);
    for (std::size_t i = 0; i < n; ++i)
      y[i] += scratch[i];
  }
}

// Values per chunk of the finiteness checks.
static constexpr std::int64_t kFiniteChunk = 1 << 16;

/// Whether every entry of v is finite: chunks shared over `pool`, each
/// without a branch per entry (v - v is 0 exactly when v is finite), so
/// that it vectorises; at 86k DoFs the Hessian's values were 2 ms of
/// serial checks per solve.
static bool allFinite(const double *v, std::size_t n, ThreadPool &pool) {
  std::atomic<bool> finite{true};
  pool.parallelFor(0, static_cast<std::int64_t>(n), kFiniteChunk,
                   [&](std::int64_t begin, std::int64_t end) {
                     bool ok = true;
                     for (std::int64_t i = begin; i < end; ++i)
                       ok &= (v[i] - v[i]) == 0.0;
                     if (!ok)
                       finite.store(false, std::memory_order_relaxed);
                   });
  return finite.load();
}

void yasps::runtime::checkPcgOptions(const PcgOptions &options,
                                     std::int64_t size) {
  if (options.fixedDofs &&
      options.fixedDofs->size() != static_cast<std::size_t>(size))
    throw std::invalid_argument(
        "the fixed-DoF mask has " + std::to_string(options.fixedDofs->size()) +
        " entries but the matrix has " + std::to_string(size) + " DoFs");
  if (options.maxIterations < 0)
    throw std::invalid_argument("PCG needs maxIterations >= 0, got " +
                                std::to_string(options.maxIterations));
  if (options.stopping == PcgStopping::EnergyNorm && options.energyDelay < 1)
    throw std::invalid_argument("PCG's energy-norm estimate needs a delay >= "
                                "1 iteration, got " +
                                std::to_string(options.energyDelay));
  if (!(options.relativeTolerance >= 0.0))
    throw std::invalid_argument("PCG needs a relative tolerance >= 0, got " +
                                std::to_string(options.relativeTolerance));
}

PcgResult yasps::runtime::solvePcg(const BlockSparseMatrix &H, const double *b,
                                   double *x, const PcgOptions &options,
                                   ThreadPool &pool) {
  return solvePcg(HessianParts{&H}, b, x, options, pool);
}

const char *yasps::runtime::stopName(PcgStop stop) {
  switch (stop) {
  case PcgStop::Converged:
    return "converged";
  case PcgStop::MaxIterations:
    return "max-iterations";
  case PcgStop::Breakdown:
    return "breakdown";
  case PcgStop::NonFinite:
    return "non-finite";
  case PcgStop::RoundOff:
    return "round-off";
  }
  return "unknown";
}

namespace {
/// The state of one PCG solve: its vectors, the coefficients that the
/// energy-norm estimate and the condition estimate read, and the stop.
class PcgSolve {
public:
  PcgSolve(const HessianParts &parts, const double *b, double *x,
           const PcgOptions &options, ThreadPool &pool)
      : parts_(parts), b_(b), x_(x), options_(options), pool_(pool),
        n_(parts.front()->size()),
        vectors_(n_ >= kMinParallelVector ? pool : serial_),
        fixed_(options.fixedDofs ? options.fixedDofs->data() : nullptr) {}

  PcgResult run();

private:
  /// Zeroes the fixed DoFs of v.
  void maskFixed(double *v) const {
    if (fixed_)
      for (std::int64_t i = 0; i < n_; ++i)
        if (fixed_[i])
          v[i] = 0.0;
  }
  double dot(const double *a, const double *c) {
    return ::dot(a, c, n_, partial_, vectors_);
  }
  /// r = b - H x on the free DoFs; returns ||r||.
  double recomputeResidual(std::vector<double> &r) {
    multiplySum(parts_, x_, r.data(), partProduct_, pool_);
    for (std::int64_t i = 0; i < n_; ++i)
      r[i] = b_[i] - r[i];
    maskFixed(r.data());
    return std::sqrt(dot(r.data(), r.data()));
  }
  /// Whether the energy-norm estimate meets the tolerance now (and records
  /// it in the result).
  bool energyConverged() {
    const std::int64_t d = std::max<std::int64_t>(1, options_.energyDelay);
    const std::int64_t k = static_cast<std::int64_t>(terms_.size());
    if (k < d)
      return false;
    double ahead = 0.0;
    for (std::int64_t j = k - d; j < k; ++j)
      ahead += terms_[j];
    // ||x_k||_H^2 = sum of the terms so far, in exact arithmetic.
    double ratio = ahead / std::max(termSum_, 1e-300);
    result_.energyError = std::sqrt(ratio);
    return result_.energyError <= options_.relativeTolerance;
  }
  /// Whether the stopping test at the loop's top holds: the tolerance is
  /// met, the iterations are spent or the residual is not finite.
  bool stopTestHolds() {
    if (!std::isfinite(rNorm_))
      return true;
    return toleranceMet() || result_.iterations == options_.maxIterations;
  }
  /// Whether the stopping rule's tolerance is met now (on the residual CG
  /// updates).
  bool toleranceMet() {
    if (rz0_ > 0.0)
      result_.preconditionedResidual = std::sqrt(std::max(rz_, 0.0) / rz0_);
    switch (options_.stopping) {
    case PcgStopping::EnergyNorm:
      return energyConverged();
    case PcgStopping::Preconditioned:
      return result_.preconditionedResidual <= options_.relativeTolerance;
    case PcgStopping::Residual:
      break;
    }
    return rNorm_ <= threshold_;
  }
  /// The bookkeeping of a finished iteration with step alpha, and the
  /// coefficient beta of the next direction.
  void recordIteration(double alpha, double beta) {
    ++result_.iterations;
    terms_.push_back(alpha * rz_);
    termSum_ += alpha * rz_;
    if (!restarted_) {
      alphas_.push_back(alpha);
      betas_.push_back(beta);
    }
  }
  /// One CG iteration on the calling thread (the products and the vector
  /// steps split over the pool where large enough). False if CG broke down
  /// (then pq holds p . H p).
  bool iterate(double &pq);
  /// CG iterations until the stopping test holds, each thread of the pool
  /// a member of one team that shares every step of each iteration: the
  /// product by rows, the vector steps by segments, meeting at a barrier
  /// between the steps. The same sums in the same order as iterate(), so
  /// the same iterates bit for bit. False if CG broke down.
  bool iterateAsTeam(double &pq);
  PcgResult finish(PcgStop stop, double relativeResidual) {
    result_.stop = stop;
    result_.converged = stop == PcgStop::Converged;
    result_.relativeResidual = relativeResidual;
    result_.conditionEstimate = ritzConditionNumber(alphas_, betas_);
    return result_;
  }

  const HessianParts &parts_;
  const double *b_;
  double *x_;
  const PcgOptions &options_;
  ThreadPool &pool_;
  const std::int64_t n_;
  /// The pool of the vector steps: pool_, or for small systems serial_.
  ThreadPool serial_{1};
  ThreadPool &vectors_;
  const std::uint8_t *fixed_;
  std::vector<double> partial_, partProduct_;
  /// CG's vectors, r . z and ||r||.
  std::vector<double> r_, z_, p_, q_;
  double rz_ = 0.0, rNorm_ = 0.0, threshold_ = 0.0;
  /// b^T M^-1 b: the Preconditioned rule's reference.
  double rz0_ = 0.0;
  std::unique_ptr<BlockJacobi> jacobi_;
  Multilevel *multilevel_ = nullptr;
  /// The block-Jacobi whose fused passes PCG runs: jacobi_'s, or an
  /// additive multilevel's fine level (null for the V-cycle).
  const BlockJacobi *fine_ = nullptr;
  /// With an additive multilevel, z += P cycle(P^T r) after fine_'s pass;
  /// returns its term of r . z (0 without one).
  double coarseCorrection();
  /// alpha_j r_j.z_j per iteration: the energy-norm estimate's terms.
  std::vector<double> terms_;
  double termSum_ = 0.0;
  /// CG's coefficients up to the first restart (the Lanczos matrix).
  std::vector<double> alphas_, betas_;
  bool restarted_ = false;
  PcgResult result_;
};
} // namespace

bool PcgSolve::iterate(double &pq) {
  multiplySum(parts_, p_.data(), q_.data(), partProduct_, pool_);
  // q's fixed entries zeroed, and p . q, in one pass.
  double *pp = p_.data(), *qq = q_.data();
  pq = sumBySegments(n_, partial_, vectors_, [&](std::int64_t i) {
    if (fixed_ && fixed_[i])
      qq[i] = 0.0;
    return pp[i] * qq[i];
  });
  // H is not positive definite along p (or rz vanished): CG cannot go on.
  if (!(pq > 0.0) || !std::isfinite(pq) || !(rz_ > 0.0))
    return false;
  double alpha = rz_ / pq;
  // x += alpha p, r -= alpha q, r . r, and with block-Jacobi z = M^-1 r
  // and r . z, in one pass.
  double rr2, rzNext;
  if (fine_) {
    BlockJacobi::StepDots dots = fine_->stepApplyDots(
        alpha, pp, qq, x_, r_.data(), z_.data(), partial_, vectors_);
    rr2 = dots.rr;
    rzNext = dots.rz + coarseCorrection();
  } else {
    double *rr = r_.data(), *xx = x_;
    rr2 = sumBySegments(n_, partial_, vectors_, [&](std::int64_t i) {
      xx[i] += alpha * pp[i];
      rr[i] -= alpha * qq[i];
      return rr[i] * rr[i];
    });
    multilevel_->apply(r_.data(), z_.data(), pool_);
    rzNext = dot(r_.data(), z_.data());
  }
  double beta = rzNext / rz_;
  recordIteration(alpha, beta);
  rNorm_ = std::sqrt(rr2);
  axpby(1.0, z_.data(), beta, p_.data(), n_, vectors_);
  rz_ = rzNext;
  return true;
}

bool PcgSolve::iterateAsTeam(double &pq) {
  const std::int64_t dotSegments = numSegments(n_);
  const std::int64_t stepSegments = fine_->numSegments();
  // An additive multilevel's coarse correction: restriction and
  // prolongation shared by aggregates, the coarse cycle on member 0.
  const bool coarse = multilevel_ && fine_;
  const std::int64_t aggregates = coarse ? multilevel_->numFineAggregates() : 0;
  double rzCoarse = 0.0;
  std::vector<double> pqPartial(static_cast<std::size_t>(dotSegments));
  std::vector<double> stepPartial(static_cast<std::size_t>(2 * stepSegments));
  // The products of the parts after the first, added into q by the pass
  // that takes p . q: multiplySum's sums, in its order.
  std::vector<const BlockSparseMatrix *> more;
  for (std::size_t k = 1; k < parts_.size(); ++k)
    if (parts_[k]->numStoredBlocks() != 0)
      more.push_back(parts_[k]);
  std::vector<std::vector<double>> moreProducts(
      more.size(), std::vector<double>(static_cast<std::size_t>(n_)));
  TeamBarrier barrier(pool_.size());
  bool brokeDown = false, stop = false;
  double *pp = p_.data(), *qq = q_.data(), *rr = r_.data(), *zz = z_.data();

  pool_.runTeam([&](unsigned member, unsigned team) {
    auto sync = [&] { return team == 1 || barrier.wait(); };
    // This member's share of `count` segments.
    auto share = [&](std::int64_t count) {
      return std::pair<std::int64_t, std::int64_t>{count * member / team,
                                                   count * (member + 1) / team};
    };
    const auto [dotBegin, dotEnd] = share(dotSegments);
    const auto [stepBegin, stepEnd] = share(stepSegments);
    const auto [aggregateBegin, aggregateEnd] = share(aggregates);
    const std::int64_t dofBegin = std::min(n_, dotBegin * kSegment);
    const std::int64_t dofEnd = std::min(n_, dotEnd * kSegment);
    // Every member keeps the scalars; they are the same sums on each.
    double rz = rz_;
    try {
      while (true) {
        parts_.front()->multiplyRows(pp, qq, team, member);
        for (std::size_t k = 0; k < more.size(); ++k)
          more[k]->multiplyRows(pp, moreProducts[k].data(), team, member);
        if (!sync())
          return;
        auto pqTerm = [&](std::int64_t i) {
          for (const std::vector<double> &product : moreProducts)
            qq[i] += product[i];
          if (fixed_ && fixed_[i])
            qq[i] = 0.0;
          return pp[i] * qq[i];
        };
        for (std::int64_t s = dotBegin; s < dotEnd; ++s)
          pqPartial[s] = segmentSum(s, n_, pqTerm);
        if (!sync())
          return;
        const double pqAll = sumInOrder(pqPartial.data(), dotSegments);
        if (!(pqAll > 0.0) || !std::isfinite(pqAll) || !(rz > 0.0)) {
          if (member == 0) {
            pq = pqAll;
            brokeDown = true;
          }
          return;
        }
        const double alpha = rz / pqAll;
        fine_->stepSegments(stepBegin, stepEnd, alpha, pp, qq, x_, rr, zz,
                            stepPartial.data());
        if (!sync())
          return;
        if (coarse) {
          multilevel_->restrictAggregates(rr, aggregateBegin, aggregateEnd);
          if (!sync())
            return;
          if (member == 0)
            rzCoarse = multilevel_->solveCoarse();
          if (!sync())
            return;
          multilevel_->prolongAggregates(zz, aggregateBegin, aggregateEnd);
          if (!sync())
            return;
        }
        double rr2 = 0.0, rzNext = 0.0;
        for (std::int64_t s = 0; s < stepSegments; ++s) {
          rr2 += stepPartial[2 * s];
          rzNext += stepPartial[2 * s + 1];
        }
        rzNext += rzCoarse;
        const double beta = rzNext / rz;
        for (std::int64_t i = dofBegin; i < dofEnd; ++i)
          pp[i] = zz[i] + beta * pp[i];
        if (member == 0) {
          recordIteration(alpha, beta);
          rNorm_ = std::sqrt(rr2);
          rz_ = rzNext;
          stop = stopTestHolds();
        }
        rz = rzNext;
        if (!sync() || stop)
          return;
      }
    } catch (...) {
      barrier.abort();
      throw;
    }
  });
  return !brokeDown;
}

double PcgSolve::coarseCorrection() {
  return multilevel_ && fine_
             ? multilevel_->addCoarseCorrection(r_.data(), z_.data(), pool_)
             : 0.0;
}

PcgResult PcgSolve::run() {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::size_t un = static_cast<std::size_t>(n_);
  std::fill(x_, x_ + n_, 0.0);
  r_.assign(b_, b_ + n_);
  maskFixed(r_.data());
  // Checked up front: a NaN in H might otherwise sit where the iterates are
  // zero and go unnoticed, or be hidden by the preconditioner's fallback.
  if (!allFinite(r_.data(), un, vectors_))
    return finish(PcgStop::NonFinite, nan);
  for (const BlockSparseMatrix *part : parts_)
    if (!allFinite(part->values().data(), part->values().size(), pool_))
      return finish(PcgStop::NonFinite, nan);

  const double bNorm = std::sqrt(dot(r_.data(), r_.data()));
  // The multilevel preconditioner's V-cycle runs products, which split
  // across pool_ by themselves.
  std::unique_ptr<Multilevel> ownLevels;
  if (options_.preconditioner == PcgPreconditioner::Multilevel) {
    std::unique_ptr<Multilevel> &kept =
        options_.multilevelCache ? *options_.multilevelCache : ownLevels;
    if (kept && kept->matches(parts_) && kept->options() == options_.multilevel)
      kept->refresh(parts_, fixed_, pool_);
    else
      kept = std::make_unique<Multilevel>(parts_, fixed_, pool_,
                                          options_.multilevel);
    multilevel_ = kept.get();
    if (multilevel_->splitsFineLevel())
      fine_ = &multilevel_->fineSmoother();
    result_.diagonalRatio = multilevel_->diagonalRatio();
    result_.levels =
        static_cast<std::int64_t>(multilevel_->levelSizes().size());
  } else {
    jacobi_ = std::make_unique<BlockJacobi>(parts_, fixed_, pool_);
    fine_ = jacobi_.get();
    result_.diagonalRatio = jacobi_->diagonalRatio();
  }
  if (bNorm == 0.0)
    return finish(PcgStop::Converged, 0.0);

  z_.assign(un, 0.0);
  q_.assign(un, 0.0);
  std::vector<double> trueResidual(un);
  // z = M^-1 r, rz = r . z, p = z.
  auto restart = [&] {
    if (fine_) {
      rz_ = fine_->applyDot(r_.data(), z_.data(), partial_, vectors_) +
            coarseCorrection();
    } else {
      multilevel_->apply(r_.data(), z_.data(), pool_);
      rz_ = dot(r_.data(), z_.data());
    }
    p_ = z_;
  };
  restart();
  rz0_ = rz_;
  rNorm_ = bNorm;
  threshold_ = options_.relativeTolerance * bNorm;
  double lastTrueNorm = std::numeric_limits<double>::infinity();
  // Rules other than the residual's judge what the residual's 2-norm says
  // little about; the recomputed residual is reported, not required.
  const bool residualRule = options_.stopping == PcgStopping::Residual;
  // The team pays a hand-off per solve and barriers per iteration: worth it
  // on solves big enough to share, with block-Jacobi or an additive
  // multilevel (whose V-cycle on the coarse levels runs on one member).
  const bool team = fine_ && pool_.size() > 1 && n_ >= kMinTeamDofs;
  while (true) {
    if (!std::isfinite(rNorm_))
      return finish(PcgStop::NonFinite, nan);
    bool small = toleranceMet();
    if (small || result_.iterations == options_.maxIterations) {
      // The updated residual drifts from b - H x in round-off: judge the
      // iterate by the recomputed one.
      double trueNorm = recomputeResidual(trueResidual);
      if (!std::isfinite(trueNorm))
        return finish(PcgStop::NonFinite, nan);
      if (!small)
        return finish(PcgStop::MaxIterations, trueNorm / bNorm);
      if (!residualRule || trueNorm <= threshold_)
        return finish(PcgStop::Converged, trueNorm / bNorm);
      // Restarting from the recomputed residual recovers the drift once;
      // if it did not help, the tolerance is below round-off.
      if (result_.residualReplacements >= 2 && trueNorm > 0.5 * lastTrueNorm)
        return finish(PcgStop::RoundOff, trueNorm / bNorm);
      lastTrueNorm = trueNorm;
      ++result_.residualReplacements;
      r_ = trueResidual;
      rNorm_ = trueNorm;
      restarted_ = true;
      restart();
      continue;
    }
    double pq = 0.0;
    // H is not positive definite along p (or rz vanished): CG cannot go on.
    if (!(team ? iterateAsTeam(pq) : iterate(pq)))
      return finish(PcgStop::Breakdown,
                    std::isfinite(pq) ? rNorm_ / bNorm : nan);
  }
}

PcgResult yasps::runtime::solvePcg(const HessianParts &parts, const double *b,
                                   double *x, const PcgOptions &options,
                                   ThreadPool &pool) {
  if (parts.empty())
    throw std::invalid_argument("PCG needs at least one matrix");
  const BlockSparseMatrix &H = *parts.front();
  for (const BlockSparseMatrix *part : parts)
    if (part->layout().blockOffset != H.layout().blockOffset)
      throw std::invalid_argument(
          "the parts of a PCG matrix must share one block layout");
  checkPcgOptions(options, H.size());
  return PcgSolve(parts, b, x, options, pool).run();
}
