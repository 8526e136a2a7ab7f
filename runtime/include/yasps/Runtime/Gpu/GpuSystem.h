//===- GpuSystem.h - the Newton system on the GPU ---------------*- C++ -*-===//
//
// The device side of GlobalSystem: the same compressed block-sparse
// Hessian (static and dynamic parts) and gradient, held in device memory,
// assembled from device-resident local derivatives with atomic adds, and
// solved by PCG on the device, block-Jacobi or multilevel (paper sections
// 7-8, appendices B-D). Only the results asked for are copied back.
//
// The structure (which blocks exist and where each instance's entries go)
// is built on the host by GlobalSystem and uploaded; a GpuSystem mirrors
// one GlobalSystem and is told when its dynamic part changes.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_GPU_GPUSYSTEM_H
#define YASPS_RUNTIME_GPU_GPUSYSTEM_H

#include "yasps/Runtime/Assembly/GlobalSystem.h"
#include "yasps/Runtime/Gpu/GpuLaunch.h"
#include "yasps/Runtime/Support/CudaMemory.h"

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace yasps::runtime {

namespace gpu {
struct PcgState;
}

/// The binaries of the solver kernels (lib/Gpu/SolverKernels.cu) built
/// into this library: cubins for sm_80 and sm_90 and PTX. Empty when nvcc
/// was not found at build time.
const std::vector<GpuImage> &gpuSolverImages();

/// The names of the solver kernels (every binary defines them all).
std::vector<std::string> gpuSolverKernelNames();

/// The Newton system of a GlobalSystem, on one device.
class GpuSystem {
public:
  /// Uploads `host`'s structure to the device of `context`; values start
  /// at zero. `host` must outlive this system: the multilevel
  /// preconditioner reads its structure when a solve first asks for it. Throws
  /// CudaError when the solver kernels cannot be loaded (built without nvcc, or
  /// no binary fits the device), and std::invalid_argument for more than 2^31 -
  /// 1 DoFs.
  GpuSystem(const CudaContext &context, const GlobalSystem &host);
  ~GpuSystem();
  GpuSystem(const GpuSystem &) = delete;
  GpuSystem &operator=(const GpuSystem &) = delete;

  /// Uploads the dynamic part's structure again, after host.setDynamic().
  /// Its values are zero afterwards.
  void updateDynamic(const GlobalSystem &host);

  /// Zeroes the gradient and the Hessian.
  void setZero();

  /// Adds energy `energy`'s local gradients (count x n) and Hessians
  /// (count x n x n), both in device memory, with one thread per instance.
  void add(std::size_t energy, cu::DevicePtr gradients, cu::DevicePtr hessians);
  /// add() for factored Hessians J^T P J: `maps` (count x m x n, each
  /// row-major, or column-major with `columnMajorMaps`) and `inner`
  /// (count x m x m) in device memory; m <= 64.
  void addFactored(std::size_t energy, cu::DevicePtr gradients,
                   cu::DevicePtr maps, cu::DevicePtr inner, std::int64_t m,
                   bool columnMajorMaps = false);

  /// y = H x (both parts), x and y in device memory (size() each).
  void multiply(cu::DevicePtr x, cu::DevicePtr y);

  /// Solves H x = gradient by PCG on the device, x in device memory, with
  /// options.preconditioner: block-Jacobi, or the multilevel V-cycle
  /// (Multilevel.h; its levels' structure built on the host once, their
  /// values on the device every solve). Same contract as
  /// PcgSolver::solve; the host looks at the solver's state every
  /// `checkEvery` iterations (iterations queued past the end do nothing).
  PcgResult solve(cu::DevicePtr x, const PcgOptions &options,
                  int checkEvery = 8);

  /// The gradient on the device, and copies of it and of a part's values
  /// (0 static, 1 dynamic; laid out as that part's BlockSparseMatrix).
  cu::DevicePtr gradientPointer() const;
  std::vector<double> gradient() const;
  std::vector<double> hessianValues(int part) const;

  std::int64_t size() const { return numDofs; }
  /// Stored blocks of both parts.
  std::size_t storedBlocks() const;
  /// The bytes one multiply() must move at least: every stored value and
  /// block coordinate once, x read and y written once (a bandwidth bound).
  std::size_t multiplyBytes() const;

private:
  struct Energy;
  struct Part;
  struct Levels;
  /// Block-Jacobi inverse blocks of one layout on the device.
  struct Jacobi {
    std::int64_t numBlocks = 0;
    DeviceBuffer blockOffset, inverseStart, inverse, scratchA, scratchL,
        scratchFree;
    /// The block of each DoF.
    DeviceBuffer dofBlock;
  };
  static void allocateJacobi(const CudaContext &context, Jacobi &jacobi,
                             const BlockLayout &layout);
  void invertJacobi(const Jacobi &jacobi, const std::vector<Part *> &parts,
                    const unsigned char *mask);
  /// y += H x over `parts` (addProducts for any level's matrix).
  void addPartProducts(const std::vector<Part *> &parts, const double *x,
                       double *y, const gpu::PcgState *state);
  /// The structure of a matrix into `part`: its groups, coordinates and
  /// diagonal blocks (no energies).
  void uploadMatrix(Part &part, const BlockSparseMatrix &matrix);
  // The multilevel preconditioner (GpuMultilevel.cpp): its levels built or
  // brought up to date with the host's structure, refreshed from the
  // Hessian's values, and one V-cycle z = M^-1 r on level l.
  void prepareLevels(const PcgOptions &options);
  void uploadLevels();
  std::int64_t levelCount() const;
  void refreshLevels(const unsigned char *mask, const std::uint8_t *hostMask);
  /// The CPU's norm bound on lmax(D^-1 A) of level l (its block-Jacobi
  /// inverses computed), from the device's values.
  double eigenvalueBound(std::size_t l, const unsigned char *mask);
  double estimateDamping(std::size_t l, const unsigned char *mask,
                         const std::uint8_t *hostMask);
  /// `fineMask`: the solve's fixed DoFs (level 0 only).
  void cycle(std::size_t l, const double *r, double *z,
             const unsigned char *fineMask, const gpu::PcgState *state);
  template <typename Args>
  void launch(const char *kernel, std::int64_t blocks, const Args &args);
  template <typename Args>
  void launch(cu::Function kernel, std::int64_t blocks, const Args &args);
  /// y += H x (both parts) by the SpMV kernels; `state`, when set, makes
  /// them no-ops once PCG has stopped.
  void addProducts(const double *x, double *y, const gpu::PcgState *state);
  cu::Function function(const std::string &name) const;
  void uploadPart(Part &part, const BlockSparseMatrix &matrix,
                  const GlobalSystem &host, std::size_t firstEnergy,
                  std::size_t numEnergies);
  void addLocal(std::size_t energy, cu::DevicePtr gradients,
                cu::DevicePtr hessians, cu::DevicePtr inner, std::int64_t m,
                bool columnMajorMaps);
  /// Launches the reduction-style kernels over `n` items: their grid.
  static std::int64_t reductionBlocks(std::int64_t n);
  /// ||b - H x|| over the free DoFs (those `mask`, when set, leaves); with
  /// `residual`, b - H x itself (0 on fixed DoFs) goes there.
  double recomputedResidual(cu::DevicePtr x, const unsigned char *mask,
                            std::vector<double> *residual = nullptr);

  const CudaContext &ctx;
  const GlobalSystem &host;
  std::unique_ptr<Levels> levels;
  std::unique_ptr<CudaModule> module;
  std::map<std::string, cu::Function> functions;
  std::int64_t numDofs = 0, numBlocks = 0;
  std::size_t numStatic = 0;
  std::unique_ptr<Part> parts[2];
  Jacobi jacobi;
  DeviceBuffer gradientValues, r, z, p, q, partials, state, fixed;
};

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_GPU_GPUSYSTEM_H
