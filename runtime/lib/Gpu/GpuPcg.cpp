//===- GpuPcg.cpp - the GPU system's PCG driver ---------------------------===//
//
// Queues PCG's kernels and keeps the contract of the CPU's solve (Pcg.h):
// its stopping rules, the recomputed residual and its restarts, its stop
// reasons and report.
//
//===----------------------------------------------------------------------===//

#include "yasps/Runtime/Gpu/GpuSystem.h"

#include "GpuSystemDetail.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

using namespace yasps::runtime;
using namespace yasps::runtime::gpu;
using namespace yasps::runtime::detail;

double GpuSystem::recomputedResidual(cu::DevicePtr x, const unsigned char *mask,
                                     std::vector<double> *residual) {
  multiply(x, q.pointer());
  const std::size_t n = static_cast<std::size_t>(numDofs);
  std::vector<double> product(n), b(n);
  q.download(product.data(), n * sizeof(double));
  gradientValues.download(b.data(), n * sizeof(double));
  std::vector<unsigned char> fixedHost;
  if (mask) {
    fixedHost.resize(n);
    fixed.download(fixedHost.data(), n);
  }
  double sum = 0.0;
  if (residual)
    residual->assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    if (fixedHost.empty() || !fixedHost[i]) {
      sum += (b[i] - product[i]) * (b[i] - product[i]);
      if (residual)
        (*residual)[i] = b[i] - product[i];
    }
  return std::sqrt(sum);
}

PcgResult GpuSystem::solve(cu::DevicePtr x, const PcgOptions &options,
                           int checkEvery) {
  checkPcgOptions(options, numDofs);
  if (options.preconditioner == PcgPreconditioner::Multilevel)
    prepareLevels(options);
  if (options.stopping == PcgStopping::EnergyNorm &&
      options.energyDelay > kPcgMaxEnergyDelay)
    throw std::invalid_argument(
        "the GPU solve's energy-norm estimate looks at most " +
        std::to_string(kPcgMaxEnergyDelay) + " iterations ahead, not " +
        std::to_string(options.energyDelay));
  if (checkEvery < 1)
    throw std::invalid_argument("GpuSystem::solve: checkEvery must be >= 1");
  const unsigned char *mask = nullptr;
  if (options.fixedDofs) {
    fixed.upload(options.fixedDofs->data(), options.fixedDofs->size());
    mask = as<const unsigned char>(fixed);
  }
  PcgState initial{};
  initial.tolerance = options.relativeTolerance;
  initial.maxIterations = options.maxIterations;
  initial.rule =
      options.stopping == PcgStopping::EnergyNorm       ? kPcgRuleEnergyNorm
      : options.stopping == PcgStopping::Preconditioned ? kPcgRulePreconditioned
                                                        : kPcgRuleResidual;
  initial.energyDelay = static_cast<int>(options.energyDelay);
  state.upload(&initial, sizeof(initial));
  PcgState *st = as<PcgState>(state);
  double *partialSums = as<double>(partials);
  auto scalar = [&](int step, std::int64_t numPartials) {
    launch("yasps_pcg_scalar", 1,
           PcgScalarArgs{step, numPartials, partialSums, st});
  };
  auto result = [&] {
    PcgState now;
    state.download(&now, sizeof(now));
    return now;
  };
  std::int64_t replacements = 0;
  // `trueNorm`: ||b - H x|| when the caller has it, else < 0.
  auto finish = [&](const PcgState &now, double trueNorm = -1.0,
                    bool roundOff = false) {
    PcgResult out;
    out.iterations = now.iterations;
    out.relativeResidual = now.residual;
    out.stop = now.stopped == kPcgConverged       ? PcgStop::Converged
               : now.stopped == kPcgMaxIterations ? PcgStop::MaxIterations
               : now.stopped == kPcgBreakdown     ? PcgStop::Breakdown
                                                  : PcgStop::NonFinite;
    if (std::isfinite(now.residual) && now.bNorm > 0.0) {
      // Reported, as on the CPU, as the residual recomputed from x.
      if (trueNorm < 0.0)
        trueNorm = recomputedResidual(x, mask);
      out.relativeResidual = trueNorm / now.bNorm;
    }
    if (roundOff)
      out.stop = PcgStop::RoundOff;
    out.converged = out.stop == PcgStop::Converged;
    out.energyError = now.energyError;
    out.preconditionedResidual = now.preconditionedResidual;
    out.residualReplacements = replacements;
    if (options.preconditioner == PcgPreconditioner::Multilevel)
      out.levels = levelCount();
    return out;
  };

  // r = b (free DoFs), x = 0, ||b||; non-finite input stops at once.
  const std::int64_t vectorBlocks = reductionBlocks(numDofs);
  launch("yasps_pcg_init", vectorBlocks,
         PcgInitArgs{numDofs, as<const double>(gradientValues), mask,
                     as<double>(x), as<double>(r), partialSums, st});
  for (const std::unique_ptr<Part> &part : parts)
    launch("yasps_check_finite",
           reductionBlocks(static_cast<std::int64_t>(part->numValues)),
           CheckFiniteArgs{static_cast<long long>(part->numValues),
                           as<const double>(part->values), st});
  scalar(kPcgBegin, vectorBlocks);
  PcgState now = result();
  if (now.stopped)
    return finish(now);

  invertJacobi(jacobi, {parts[0].get(), parts[1].get()}, mask);
  const bool multilevel =
      options.preconditioner == PcgPreconditioner::Multilevel;
  if (multilevel)
    refreshLevels(mask,
                  options.fixedDofs ? options.fixedDofs->data() : nullptr);

  const std::int64_t blockBlocks = reductionBlocks(numBlocks);
  const JacobiApplyArgs apply{numBlocks,
                              as<const long long>(jacobi.blockOffset),
                              as<const long long>(jacobi.inverseStart),
                              as<const double>(jacobi.inverse),
                              as<const double>(r),
                              as<double>(z),
                              partialSums,
                              st};
  const PcgDirectionArgs direction{numDofs, as<const double>(z), as<double>(p),
                                   st};
  // z = M^-1 r and the partial sums of r . z, then rz.
  auto precondition = [&] {
    if (!multilevel) {
      launch("yasps_jacobi_apply", blockBlocks, apply);
      scalar(kPcgBeta, blockBlocks);
      return;
    }
    cycle(0, as<const double>(r), as<double>(z), mask, st);
    launch("yasps_dot", vectorBlocks,
           DotArgs{numDofs, as<const double>(r), as<double>(z), nullptr,
                   partialSums, st});
    scalar(kPcgBeta, vectorBlocks);
  };
  // p = z (beta is 0 while rz is).
  p.setZero();
  precondition();
  launch("yasps_pcg_direction", vectorBlocks, direction);

  const double threshold = options.relativeTolerance * now.bNorm;
  double lastTrueNorm = std::numeric_limits<double>::infinity();
  while (true) {
    // The device stops itself by iteration maxIterations at the latest.
    for (std::int64_t k = now.iterations; k <= options.maxIterations; ++k) {
      scalar(kPcgCheck, 0);
      q.setZero();
      addProducts(as<const double>(p), as<double>(q), st);
      launch("yasps_dot", vectorBlocks,
             DotArgs{numDofs, as<const double>(p), as<double>(q), mask,
                     partialSums, st});
      scalar(kPcgAlpha, vectorBlocks);
      launch("yasps_pcg_update", vectorBlocks,
             PcgUpdateArgs{numDofs, as<const double>(p), as<const double>(q),
                           as<double>(x), as<double>(r), partialSums, st});
      scalar(kPcgAfterUpdate, vectorBlocks);
      precondition();
      launch("yasps_pcg_direction", vectorBlocks, direction);
      if ((k + 1) % checkEvery == 0 && result().stopped)
        break;
    }
    now = result();
    if (now.stopped != kPcgConverged || !std::isfinite(now.residual) ||
        options.stopping != PcgStopping::Residual)
      return finish(now);
    // The updated residual drifts from b - H x in round-off: judged, as on
    // the CPU, by the recomputed one, and restarted from it once it does
    // not meet the tolerance; if that did not help, the tolerance is below
    // round-off.
    std::vector<double> trueResidual;
    const double trueNorm = recomputedResidual(x, mask, &trueResidual);
    if (!std::isfinite(trueNorm)) {
      now.stopped = kPcgNonFinite;
      now.residual = std::numeric_limits<double>::quiet_NaN();
      return finish(now);
    }
    if (trueNorm <= threshold)
      return finish(now, trueNorm);
    if (replacements >= 2 && trueNorm > 0.5 * lastTrueNorm)
      return finish(now, trueNorm, true);
    lastTrueNorm = trueNorm;
    ++replacements;
    r.upload(trueResidual.data(), trueResidual.size() * sizeof(double));
    now.stopped = kPcgRunning;
    now.rNorm = trueNorm;
    now.rz = 0.0;
    state.upload(&now, sizeof(now));
    precondition();
    launch("yasps_pcg_direction", vectorBlocks, direction);
  }
}
