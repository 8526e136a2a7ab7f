//===- GpuSystem.cpp - the Newton system on the GPU -----------------------===//

#include "yasps/Runtime/GpuSystem.h"

#include "yasps/Runtime/GpuMultilevelKernels.h"

#include "GpuSystemDetail.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

using namespace yasps::runtime;
using namespace yasps::runtime::gpu;
using namespace yasps::runtime::detail;

namespace {
#define YASPS_SPMV_NAME(R, C) "yasps_spmv_" #R "x" #C,
const char *const kSpmvKernels[] = {YASPS_SPMV_SHAPES(YASPS_SPMV_NAME)};
#undef YASPS_SPMV_NAME
const char *const kOtherKernels[] = {
    "yasps_assemble",         "yasps_check_finite",  "yasps_jacobi_invert",
    "yasps_jacobi_apply",     "yasps_dot",           "yasps_pcg_init",
    "yasps_pcg_update",       "yasps_pcg_direction", "yasps_pcg_scalar",
    "yasps_spmv_any",         "yasps_ml_coarsen",    "yasps_ml_restrict",
    "yasps_ml_prolong",       "yasps_ml_smooth",     "yasps_ml_residual",
    "yasps_ml_dense_scatter", "yasps_ml_row_bound",  "yasps_ml_dense_invert",
    "yasps_ml_dense_apply"};

/// The specialised SpMV kernel of a rows x cols block, else the generic one.
std::string spmvKernel(std::int64_t rows, std::int64_t cols) {
  std::string name =
      "yasps_spmv_" + std::to_string(rows) + "x" + std::to_string(cols);
  for (const char *known : kSpmvKernels)
    if (name == known)
      return name;
  return "yasps_spmv_any";
}

} // namespace

std::vector<std::string> yasps::runtime::gpuSolverKernelNames() {
  std::vector<std::string> names(std::begin(kOtherKernels),
                                 std::end(kOtherKernels));
  names.insert(names.end(), std::begin(kSpmvKernels), std::end(kSpmvKernels));
  return names;
}

GpuSystem::GpuSystem(const CudaContext &context, const GlobalSystem &host)
    : ctx(context), host(host) {
  const std::vector<GpuImage> &images = gpuSolverImages();
  if (images.empty())
    throw CudaError("this build of yasps has no GPU solver kernels: nvcc was "
                    "not found when it was built",
                    0);
  const std::string chip = ctx.driver().devices().at(ctx.ordinal()).chip();
  module =
      std::make_unique<CudaModule>(ctx, *selectGpuImage(images, chip).bytes);

  const BlockLayout &layout = host.staticHessian().layout();
  numDofs = host.size();
  // SpMV keeps block coordinates in 32 bits (far beyond what fits in a
  // GPU's memory as a Hessian).
  if (numDofs > std::numeric_limits<int>::max())
    throw std::invalid_argument(
        "the GPU system supports at most " +
        std::to_string(std::numeric_limits<int>::max()) + " DoFs, not " +
        std::to_string(numDofs));
  numBlocks = layout.numBlocks();
  numStatic = host.numStaticEnergies();
  allocateJacobi(ctx, jacobi, layout);
  const std::size_t n = static_cast<std::size_t>(numDofs);
  for (DeviceBuffer *vector : {&gradientValues, &r, &z, &p, &q})
    *vector = DeviceBuffer(ctx, n * sizeof(double));
  partials = DeviceBuffer(ctx, kMaxPartials * sizeof(double));
  state = DeviceBuffer(ctx, sizeof(PcgState));
  fixed = DeviceBuffer(ctx, n);

  parts[0] = std::make_unique<Part>();
  uploadPart(*parts[0], host.staticHessian(), host, 0, numStatic);
  updateDynamic(host);
  setZero();
}

GpuSystem::~GpuSystem() = default;

void GpuSystem::allocateJacobi(const CudaContext &context, Jacobi &jacobi,
                               const BlockLayout &layout) {
  jacobi.numBlocks = layout.numBlocks();
  std::vector<long long> offsets(layout.blockOffset.begin(),
                                 layout.blockOffset.end());
  std::vector<long long> starts{0};
  for (std::int64_t b = 0; b < jacobi.numBlocks; ++b)
    starts.push_back(starts.back() + layout.blockSize(b) * layout.blockSize(b));
  std::vector<long long> dofBlock;
  for (std::int64_t b = 0; b < jacobi.numBlocks; ++b)
    dofBlock.insert(dofBlock.end(), layout.blockSize(b), b);
  jacobi.blockOffset = deviceCopy(context, offsets);
  jacobi.inverseStart = deviceCopy(context, starts);
  jacobi.dofBlock = deviceCopy(context, dofBlock);
  const std::size_t squares = static_cast<std::size_t>(starts.back());
  jacobi.inverse = DeviceBuffer(context, squares * sizeof(double));
  jacobi.scratchA = DeviceBuffer(context, squares * sizeof(double));
  jacobi.scratchL = DeviceBuffer(context, squares * sizeof(double));
  jacobi.scratchFree = DeviceBuffer(
      context,
      static_cast<std::size_t>(layout.blockOffset.back()) * sizeof(long long));
}

void GpuSystem::invertJacobi(const Jacobi &jacobi,
                             const std::vector<Part *> &parts,
                             const unsigned char *mask) {
  JacobiInvertArgs invert{};
  invert.numBlocks = jacobi.numBlocks;
  invert.numParts = static_cast<long long>(parts.size());
  invert.blockOffset = as<const long long>(jacobi.blockOffset);
  invert.inverseStart = as<const long long>(jacobi.inverseStart);
  for (std::size_t k = 0; k < parts.size(); ++k) {
    invert.diagonalValue[k] = as<const long long>(parts[k]->diagonalValue);
    invert.values[k] = as<const double>(parts[k]->values);
  }
  invert.fixed = mask;
  invert.inverse = as<double>(jacobi.inverse);
  invert.scratchA = as<double>(jacobi.scratchA);
  invert.scratchL = as<double>(jacobi.scratchL);
  invert.scratchFree = as<long long>(jacobi.scratchFree);
  launch("yasps_jacobi_invert", ceilDiv(jacobi.numBlocks, kThreadsPerBlock),
         invert);
}

void GpuSystem::updateDynamic(const GlobalSystem &host) {
  if (host.size() != numDofs || host.numStaticEnergies() != numStatic)
    throw std::invalid_argument("GpuSystem::updateDynamic: a GlobalSystem "
                                "other than the one this system mirrors");
  if (!parts[1])
    parts[1] = std::make_unique<Part>();
  uploadPart(*parts[1], host.dynamicHessian(), host, numStatic,
             host.numEnergies() - numStatic);
  parts[1]->values.setZero(parts[1]->numValues * sizeof(double));
}

void GpuSystem::uploadMatrix(Part &part, const BlockSparseMatrix &matrix) {
  // A part's buffers are reused when it is uploaded again (the dynamic
  // part, every Newton iteration).
  const BlockLayout &layout = matrix.layout();
  const std::int64_t numBlocks = layout.numBlocks();
  const std::size_t stored = matrix.numStoredBlocks();
  part.groups.clear();
  std::vector<int> rowDof(stored), colDof(stored);
  for (std::size_t k = 0; k < stored; ++k) {
    rowDof[k] = static_cast<int>(layout.blockOffset[matrix.blockRow(k)]);
    colDof[k] = static_cast<int>(layout.blockOffset[matrix.blockCol(k)]);
  }
  for (const BlockGroup &group : matrix.groups())
    if (group.size() > 0 && group.rows * group.cols > 0)
      part.groups.push_back({group.rows, group.cols, std::int64_t(group.size()),
                             std::int64_t(group.firstBlock),
                             std::int64_t(matrix.valueOffset(group.firstBlock)),
                             function(spmvKernel(group.rows, group.cols))});
  std::vector<long long> diagonal(static_cast<std::size_t>(numBlocks), -1);
  for (std::int64_t b = 0; b < numBlocks; ++b)
    if (matrix.diagonalBlock(b) >= 0)
      diagonal[b] = static_cast<long long>(matrix.valueOffset(
          static_cast<std::size_t>(matrix.diagonalBlock(b))));
  part.numValues = matrix.values().size();
  reserve(ctx, part.values, part.numValues * sizeof(double));
  uploadInto(ctx, part.rowDof, rowDof);
  uploadInto(ctx, part.colDof, colDof);
  uploadInto(ctx, part.diagonalValue, diagonal);
}

void GpuSystem::uploadPart(Part &part, const BlockSparseMatrix &matrix,
                           const GlobalSystem &host, std::size_t firstEnergy,
                           std::size_t numEnergies) {
  uploadMatrix(part, matrix);
  const BlockLayout &layout = matrix.layout();
  part.energies.resize(numEnergies);

  for (std::size_t e = firstEnergy; e < firstEnergy + numEnergies; ++e) {
    const GlobalSystem::EnergyMap &map = host.energyStructure(e);
    const std::int64_t count = map.count, n = map.numParams, m = map.maxBlocks;
    std::vector<long long> dofs(static_cast<std::size_t>(count * n), -1);
    std::vector<int> sizes(static_cast<std::size_t>(count * m), 0);
    std::vector<long long> pairValue(static_cast<std::size_t>(count * m * m),
                                     -1);
    for (std::int64_t i = 0; i < count; ++i) {
      const std::int64_t *global = &map.globalBlock[i * m];
      for (std::int64_t a = 0; a < n; ++a) {
        std::int32_t local = map.localBlock[i * n + a];
        if (local >= 0)
          dofs[i * n + a] =
              layout.blockOffset[global[local]] + map.offset[i * n + a];
      }
      for (std::int64_t a = 0; a < m; ++a) {
        if (global[a] < 0)
          continue;
        sizes[i * m + a] = static_cast<int>(layout.blockSize(global[a]));
        for (std::int64_t b = 0; b < m; ++b)
          // Pairs in the lower triangle are added through their transpose.
          if (global[b] >= 0 && global[a] <= global[b])
            pairValue[(i * m + a) * m + b] = static_cast<long long>(
                matrix.valueOffset(map.pairSlot[(i * m + a) * m + b].block));
      }
    }
    Energy &energy = part.energies[e - firstEnergy];
    energy.count = count;
    energy.numParams = n;
    energy.maxBlocks = m;
    uploadInto(ctx, energy.dofs, dofs);
    uploadInto(ctx, energy.localBlock, map.localBlock);
    uploadInto(ctx, energy.offset, map.offset);
    uploadInto(ctx, energy.blockSize, sizes);
    uploadInto(ctx, energy.pairValue, pairValue);
  }
}

cu::Function GpuSystem::function(const std::string &name) const {
  auto found = functions.find(name);
  if (found != functions.end())
    return found->second;
  cu::Function fn = module->function(name);
  const_cast<GpuSystem *>(this)->functions.emplace(name, fn);
  return fn;
}

std::int64_t GpuSystem::reductionBlocks(std::int64_t n) {
  return std::clamp<std::int64_t>(ceilDiv(n, kThreadsPerBlock), 1,
                                  kMaxPartials);
}

void GpuSystem::setZero() {
  gradientValues.setZero();
  for (const std::unique_ptr<Part> &part : parts)
    part->values.setZero(part->numValues * sizeof(double));
}

void GpuSystem::addLocal(std::size_t energy, cu::DevicePtr gradients,
                         cu::DevicePtr hessians, cu::DevicePtr inner,
                         std::int64_t m, bool columnMajorMaps) {
  if (energy >= numStatic + parts[1]->energies.size())
    throw std::out_of_range(
        "energy " + std::to_string(energy) + " out of range: the system has " +
        std::to_string(numStatic + parts[1]->energies.size()) + " energies");
  Part &part = energy < numStatic ? *parts[0] : *parts[1];
  const Energy &e =
      part.energies[energy < numStatic ? energy : energy - numStatic];
  if (inner && (m < 1 || m > kMaxInner))
    throw std::invalid_argument("GPU assembly of factored Hessians needs an "
                                "inner size in [1, " +
                                std::to_string(kMaxInner) + "], got " +
                                std::to_string(m));
  AssembleArgs args{};
  args.count = e.count;
  args.numParams = e.numParams;
  args.maxBlocks = e.maxBlocks;
  args.innerSize = m;
  args.mapsColumnMajor = columnMajorMaps ? 1 : 0;
  args.gradients = as<const double>(gradients);
  args.hessians = as<const double>(hessians);
  args.inner = inner ? as<const double>(inner) : nullptr;
  args.dofs = as<const long long>(e.dofs);
  args.localBlock = as<const int>(e.localBlock);
  args.offset = as<const int>(e.offset);
  args.blockSize = as<const int>(e.blockSize);
  args.pairValue = as<const long long>(e.pairValue);
  args.gradient = as<double>(gradientValues);
  args.values = as<double>(part.values);
  launch("yasps_assemble", ceilDiv(e.count, kThreadsPerBlock), args);
}

void GpuSystem::add(std::size_t energy, cu::DevicePtr gradients,
                    cu::DevicePtr hessians) {
  addLocal(energy, gradients, hessians, 0, 0, false);
}

void GpuSystem::addFactored(std::size_t energy, cu::DevicePtr gradients,
                            cu::DevicePtr maps, cu::DevicePtr inner,
                            std::int64_t m, bool columnMajorMaps) {
  if (!inner)
    throw std::invalid_argument("GPU factored assembly without inner Hessians");
  addLocal(energy, gradients, maps, inner, m, columnMajorMaps);
}

void GpuSystem::addProducts(const double *x, double *y, const PcgState *state) {
  addPartProducts({parts[0].get(), parts[1].get()}, x, y, state);
}

void GpuSystem::addPartProducts(const std::vector<Part *> &parts,
                                const double *x, double *y,
                                const PcgState *state) {
  for (const Part *part : parts)
    for (const Part::Group &group : part->groups) {
      SpmvArgs args{};
      args.count = group.count;
      args.rows = group.rows;
      args.cols = group.cols;
      args.rowDof = as<const int>(part->rowDof) + group.first;
      args.colDof = as<const int>(part->colDof) + group.first;
      args.values = as<const double>(part->values) + group.valueStart;
      args.x = x;
      args.y = y;
      args.state = state;
      launch(group.spmv, ceilDiv(group.count, kThreadsPerBlock), args);
    }
}

void GpuSystem::multiply(cu::DevicePtr x, cu::DevicePtr y) {
  ctx.makeCurrent();
  ctx.driver().check(
      ctx.driver().cuMemsetD8(y, 0, static_cast<std::size_t>(numDofs) * 8),
      "cuMemsetD8");
  addProducts(as<const double>(x), as<double>(y), nullptr);
}

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

std::size_t GpuSystem::storedBlocks() const {
  std::size_t blocks = 0;
  for (const std::unique_ptr<Part> &part : parts)
    for (const Part::Group &group : part->groups)
      blocks += static_cast<std::size_t>(group.count);
  return blocks;
}

std::size_t GpuSystem::multiplyBytes() const {
  std::size_t bytes = 2 * static_cast<std::size_t>(numDofs) * sizeof(double);
  for (const std::unique_ptr<Part> &part : parts)
    bytes += part->numValues * sizeof(double);
  return bytes + storedBlocks() * 2 * sizeof(int);
}

cu::DevicePtr GpuSystem::gradientPointer() const {
  return gradientValues.pointer();
}

std::vector<double> GpuSystem::gradient() const {
  std::vector<double> out(static_cast<std::size_t>(numDofs));
  gradientValues.download(out.data(), out.size() * sizeof(double));
  return out;
}

std::vector<double> GpuSystem::hessianValues(int part) const {
  if (part != 0 && part != 1)
    throw std::out_of_range("a GPU system has parts 0 (static) and 1 "
                            "(dynamic), not " +
                            std::to_string(part));
  std::vector<double> out(parts[part]->numValues);
  parts[part]->values.download(out.data(), out.size() * sizeof(double));
  return out;
}
