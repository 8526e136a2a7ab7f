//===- GpuSystemDetail.h - the GPU system's shared internals ----*- C++ -*-===//
//
// What GpuSystem.cpp and GpuMultilevel.cpp share (not installed): buffer
// helpers, kernel launches and the device parts of a GpuSystem.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_LIB_GPUSYSTEMDETAIL_H
#define YASPS_RUNTIME_LIB_GPUSYSTEMDETAIL_H

#include "GpuSolverKernels.h"
#include "yasps/Runtime/Gpu/GpuSystem.h"
#include "yasps/Runtime/Sparse/Multilevel.h"
#include "yasps/Runtime/Support/CudaDriver.h"
#include "yasps/Runtime/Support/CudaMemory.h"

#include <cstdint>
#include <vector>

namespace yasps::runtime::detail {

/// Makes `buffer` hold at least `bytes`, reallocating (with room to grow
/// by half) only when it is smaller: the dynamic part changes size every
/// Newton iteration, and allocations cost more than the uploads.
inline void reserve(const CudaContext &context, DeviceBuffer &buffer,
                    std::size_t bytes) {
  if (buffer.size() < bytes)
    buffer = DeviceBuffer(context, bytes + bytes / 2);
}

/// Copies `host` to the start of `buffer`, growing it when needed.
template <typename T>
void uploadInto(const CudaContext &context, DeviceBuffer &buffer,
                const std::vector<T> &host) {
  reserve(context, buffer, host.size() * sizeof(T));
  buffer.upload(host.data(), host.size() * sizeof(T));
}

template <typename T> T *as(const DeviceBuffer &buffer) {
  return reinterpret_cast<T *>(buffer.pointer());
}
template <typename T> T *as(cu::DevicePtr pointer) {
  return reinterpret_cast<T *>(pointer);
}

inline std::int64_t ceilDiv(std::int64_t a, std::int64_t b) {
  return (a + b - 1) / b;
}

} // namespace yasps::runtime::detail

namespace yasps::runtime {
/// One energy's placement tables (GlobalSystem::EnergyMap, flattened for
/// the assembly kernel).
struct GpuSystem::Energy {
  std::int64_t count = 0, numParams = 0, maxBlocks = 0;
  DeviceBuffer dofs, localBlock, offset, blockSize, pairValue;
};

/// One part of the Hessian (BlockSparseMatrix, on the device).
struct GpuSystem::Part {
  struct Group {
    std::int64_t rows, cols, count, first, valueStart;
    cu::Function spmv; // the SpMV kernel of its shape
  };
  std::vector<Group> groups;
  std::size_t numValues = 0;
  DeviceBuffer values, rowDof, colDof, diagonalValue;
  std::vector<Energy> energies;
};

template <typename Args>
inline void GpuSystem::launch(const char *kernel, std::int64_t blocks,
                              const Args &args) {
  launch(function(kernel), blocks, args);
}

template <typename Args>
inline void GpuSystem::launch(cu::Function kernel, std::int64_t blocks,
                              const Args &args) {
  if (blocks <= 0)
    return;
  ctx.makeCurrent();
  void *params[] = {const_cast<Args *>(&args)};
  ctx.driver().check(
      ctx.driver().cuLaunchKernel(kernel, static_cast<unsigned>(blocks), 1, 1,
                                  gpu::kThreadsPerBlock, 1, 1, 0, nullptr,
                                  params, nullptr),
      "cuLaunchKernel");
}

/// The multilevel preconditioner's levels on the device (GpuMultilevel.cpp).
struct GpuSystem::Levels {
  explicit Levels(const HessianParts &parts, const MultilevelOptions &options)
      : structure(parts, options) {}

  /// What each fine stored block of one part adds to the coarser level.
  struct Coarsen {
    long long count = 0;
    DeviceBuffer fineValue, coarseValue, rowDof, colDof, rows, cols, flags;
  };
  struct Level {
    /// A coarse level's own matrix, one part per fine part (level 0: the
    /// system's parts).
    std::vector<std::unique_ptr<Part>> own;
    std::vector<Part *> parts;
    std::int64_t size = 0;
    Jacobi ownJacobi;
    const Jacobi *jacobi = nullptr;
    double damping = 1.0;
    /// Restriction and prolongation to the next coarser level.
    long long numAggregates = 0;
    DeviceBuffer coarseDof, memberStart, memberDof, aggregateSize;
    std::vector<Coarsen> coarsen;
    /// The coarse right-hand side (level >= 1), the correction and two
    /// scratch vectors (residual, smoothing step; the damping estimate's
    /// too, with p and q).
    DeviceBuffer r, z, t, u, p, q, x;
  };
  Multilevel structure;
  std::vector<Level> levels;
  /// The coarsest level's dense inverse: whether the level is small enough
  /// for one, and whether this solve's exists (else its block-Jacobi stands
  /// in, as on the CPU, for a coarse matrix that round-off left without a
  /// positive pivot).
  DeviceBuffer dense, failed;
  bool denseInverse = false, denseReady = false;
  DeviceBuffer estimateState;
};

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_LIB_GPUSYSTEMDETAIL_H
