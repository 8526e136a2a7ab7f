//===- GpuBlockJacobi.cpp - the GPU system's block-Jacobi preconditioner --===//
//
// The inverses of the Hessian's diagonal blocks on the device, as
// BlockJacobi.cpp keeps them on the host.
//
//===----------------------------------------------------------------------===//

#include "yasps/Runtime/Gpu/GpuSystem.h"

#include "GpuSystemDetail.h"

#include <vector>

using namespace yasps::runtime;
using namespace yasps::runtime::gpu;
using namespace yasps::runtime::detail;

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
