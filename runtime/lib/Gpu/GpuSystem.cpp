//===- GpuSystem.cpp - the Newton system on the GPU -----------------------===//

#include "yasps/Runtime/Gpu/GpuSystem.h"

#include "GpuMultilevelKernels.h"

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
