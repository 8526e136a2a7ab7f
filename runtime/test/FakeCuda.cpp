//===- FakeCuda.cpp - a stand-in CUDA driver library for tests ------------===//
//
// Exports the driver entry points CudaDriver resolves, backed by host
// memory, so that loading, error reporting and buffers are tested on
// machines without a GPU. `fakeCudaSetMode` picks the behaviour: 0 a
// healthy driver with one "Fake GPU" (compute capability 9.0, 8 GiB, of
// which 1 GiB is free), 1 a cuInit that fails with CUDA_ERROR_NO_DEVICE,
// 2 a driver without devices. Modules load any image. Launches are
// recorded (`fakeCudaLastLaunch`), with as many 8-byte parameters as
// `fakeCudaExpectParams` said; memory starts zeroed, so that the outputs
// of kernels that do not run read as zeros. Launches of the GPU solver's
// kernels
// (GpuSolverKernels.h) also run: their bodies, the ones nvcc compiles, run
// on the host, on "device" memory that is host memory here: phase by phase
// (every thread up to a barrier, then every thread to the next), or with
// `fakeCudaSetThreads(1)` each thread on a fiber of its own that waits at
// the barriers (FiberBlock.h), which a missing barrier cannot pass
// unnoticed, or with `fakeCudaSetThreads(2)` each on an OS thread, all at
// once (OsThreadTeam.h), for ThreadSanitizer. Host images of the generated
// kernels (HostImage.h) load and run too (HostImageLoader.h), and
// `yaspsStandInRunsHostImages` tells the runtime to compile them; other kernels
// are not run.
//
//===----------------------------------------------------------------------===//

#include "Gpu/GpuMultilevelKernels.h"

#include "FiberBlock.h"
#include "HostImageLoader.h"
#include "OsThreadTeam.h"

#include <cstddef>
#include <cstdlib>
#include <cstring>

#include <cstdint>
#include <iterator>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

namespace {
int mode = 0;
int allocations = 0;
constexpr std::size_t kGiB = std::size_t(1) << 30;
int expectedParams = 0;
std::string loadedImage, functionName;
unsigned lastDims[6];
std::vector<std::uint64_t> lastParams;
struct ErrorText {
  int code;
  const char *name, *text;
};
constexpr ErrorText kErrors[] = {
    {0, "CUDA_SUCCESS", "no error"},
    {2, "CUDA_ERROR_OUT_OF_MEMORY", "out of memory"},
    {100, "CUDA_ERROR_NO_DEVICE", "no CUDA-capable device is detected"},
    {200, "CUDA_ERROR_INVALID_IMAGE",
     "device kernel image is invalid (a host image did not link)"}};

using yasps::runtime::test::HostImageModule;
using yasps::runtime::test::HostKernel;
/// Loaded host images, by the handle cuModuleLoadData gave out.
std::map<const void *, std::unique_ptr<HostImageModule>> hostModules;
/// Every kernel handle of a host image.
std::set<const void *> hostKernels;
/// Why the last host image did not load.
std::string hostImageError;

using namespace yasps::runtime::gpu;

using ThreadBlock = yasps::runtime::test::ThreadedBlock<SharedMemory>;

/// How a block's threads run (`fakeCudaSetThreads`, or
/// YASPS_FAKE_CUDA_THREADS): 0 phase by phase, 1 each thread on a fiber
/// (FiberBlock.h), 2 each on an OS thread (OsThreadTeam.h); -1 not read yet.
int threadMode = -1;
/// The barrier that threads of `skipKernel` do not wait at, or -1
/// (`fakeCudaSkipSync`): a missing __syncthreads, for tests that it shows.
std::string skipKernel;
int skipSync = -1;

/// The scheduler of blocks whose threads run the body themselves, or null
/// for phase by phase. One of each kind serves every kernel: the OS thread
/// team keeps its threads between launches.
yasps::runtime::test::BlockScheduler *blockScheduler() {
  if (threadMode < 0) {
    const char *value = std::getenv("YASPS_FAKE_CUDA_THREADS");
    threadMode = value ? std::atoi(value) : 0;
  }
  static yasps::runtime::test::FiberScheduler fibers;
  static yasps::runtime::test::OsThreadTeam team;
  return threadMode == 1
             ? static_cast<yasps::runtime::test::BlockScheduler *>(&fibers)
         : threadMode == 2 ? &team
                           : nullptr;
}

/// Runs a solver kernel's body over `grid` blocks of `threads` threads:
/// each block phase by phase, or its threads through the whole body.
template <typename Args, void (*Body)(HostBlock &, const Args &),
          void (*ThreadBody)(ThreadBlock &, const Args &)>
void emulate(void **params, unsigned grid, unsigned threads) {
  const Args &args = *static_cast<const Args *>(params[0]);
  static SharedMemory shared;
  yasps::runtime::test::BlockScheduler *scheduler = blockScheduler();
  if (!scheduler) {
    for (unsigned b = 0; b < grid; ++b) {
      HostBlock block{&shared, b, grid, static_cast<int>(threads)};
      Body(block, args);
    }
    return;
  }
  const int skip = functionName == skipKernel ? skipSync : -1;
  for (unsigned b = 0; b < grid; ++b)
    scheduler->run(static_cast<int>(threads), [&](int t) {
      ThreadBlock block{&shared, b,         grid, static_cast<int>(threads),
                        t,       scheduler, skip};
      ThreadBody(block, args);
    });
}

struct EmulatedKernel {
  const char *name;
  void (*run)(void **, unsigned, unsigned);
};
#define YASPS_EMULATED_SPMV(R, C)                                              \
  {"yasps_spmv_" #R "x" #C,                                                    \
   emulate<SpmvArgs, spmvBody<R, C, HostBlock>, spmvBody<R, C, ThreadBlock>>},
const EmulatedKernel kEmulated[] = {
    {"yasps_assemble",
     emulate<AssembleArgs, assembleBody<HostBlock>, assembleBody<ThreadBlock>>},
    {"yasps_check_finite", emulate<CheckFiniteArgs, checkFiniteBody<HostBlock>,
                                   checkFiniteBody<ThreadBlock>>},
    {"yasps_jacobi_invert",
     emulate<JacobiInvertArgs, jacobiInvertBody<HostBlock>,
             jacobiInvertBody<ThreadBlock>>},
    {"yasps_jacobi_apply", emulate<JacobiApplyArgs, jacobiApplyBody<HostBlock>,
                                   jacobiApplyBody<ThreadBlock>>},
    {"yasps_dot", emulate<DotArgs, dotBody<HostBlock>, dotBody<ThreadBlock>>},
    {"yasps_pcg_init",
     emulate<PcgInitArgs, pcgInitBody<HostBlock>, pcgInitBody<ThreadBlock>>},
    {"yasps_pcg_update", emulate<PcgUpdateArgs, pcgUpdateBody<HostBlock>,
                                 pcgUpdateBody<ThreadBlock>>},
    {"yasps_pcg_direction",
     emulate<PcgDirectionArgs, pcgDirectionBody<HostBlock>,
             pcgDirectionBody<ThreadBlock>>},
    {"yasps_pcg_scalar", emulate<PcgScalarArgs, pcgScalarBody<HostBlock>,
                                 pcgScalarBody<ThreadBlock>>},
    {"yasps_spmv_any",
     emulate<SpmvArgs, spmvBody<0, 0, HostBlock>, spmvBody<0, 0, ThreadBlock>>},
    {"yasps_ml_coarsen",
     emulate<CoarsenArgs, coarsenBody<HostBlock>, coarsenBody<ThreadBlock>>},
    {"yasps_ml_restrict",
     emulate<TransferArgs, restrictBody<HostBlock>, restrictBody<ThreadBlock>>},
    {"yasps_ml_prolong",
     emulate<TransferArgs, prolongBody<HostBlock>, prolongBody<ThreadBlock>>},
    {"yasps_ml_smooth",
     emulate<SmoothArgs, smoothBody<HostBlock>, smoothBody<ThreadBlock>>},
    {"yasps_ml_residual",
     emulate<ResidualArgs, residualBody<HostBlock>, residualBody<ThreadBlock>>},
    {"yasps_ml_dense_scatter",
     emulate<DenseScatterArgs, denseScatterBody<HostBlock>,
             denseScatterBody<ThreadBlock>>},
    {"yasps_ml_row_bound",
     emulate<RowBoundArgs, rowBoundBody<HostBlock>, rowBoundBody<ThreadBlock>>},
    {"yasps_ml_dense_invert",
     emulate<DenseInvertArgs, denseInvertBody<HostBlock>,
             denseInvertBody<ThreadBlock>>},
    {"yasps_ml_dense_apply", emulate<DenseApplyArgs, denseApplyBody<HostBlock>,
                                     denseApplyBody<ThreadBlock>>},
    YASPS_SPMV_SHAPES(YASPS_EMULATED_SPMV)};
#undef YASPS_EMULATED_SPMV

const EmulatedKernel *emulatedKernel(const void *function) {
  for (const EmulatedKernel &kernel : kEmulated)
    if (function == &kernel)
      return &kernel;
  return nullptr;
}

const ErrorText *findError(int code) {
  for (const ErrorText &error : kErrors)
    if (error.code == code)
      return &error;
  return nullptr;
}
} // namespace

extern "C" {
void fakeCudaSetMode(int m) { mode = m; }
/// How a block's threads run: 0 phase by phase (the default, unless
/// YASPS_FAKE_CUDA_THREADS says otherwise), 1 as fibers meeting at
/// barriers, 2 as OS threads meeting at barriers.
void fakeCudaSetThreads(int mode) { threadMode = mode; }
/// With fibers, every thread of `kernel` skips its barrier number `index`
/// (from 0); a null kernel or index < 0 skips none.
void fakeCudaSkipSync(const char *kernel, int index) {
  skipKernel = kernel ? kernel : "";
  skipSync = kernel ? index : -1;
}
/// Whether this driver runs host images (HostImage.h): the runtime then
/// compiles generated kernels for the host rather than for a GPU.
int yaspsStandInRunsHostImages() { return 1; }
/// Why the last host image did not load ("" if it did).
const char *fakeCudaHostImageError() { return hostImageError.c_str(); }
/// How many cuMemAlloc calls succeeded so far.
int fakeCudaAllocations() { return allocations; }
void fakeCudaExpectParams(int n) { expectedParams = n; }
/// The last launch: its kernel's name, its module's image, grid and block
/// sizes (6 values) and parameters (`expectedParams` values).
const char *fakeCudaLastLaunch(const char **image, unsigned *dims,
                               std::uint64_t *params) {
  *image = loadedImage.c_str();
  for (int i = 0; i < 6; ++i)
    dims[i] = lastDims[i];
  for (std::size_t i = 0; i < lastParams.size(); ++i)
    params[i] = lastParams[i];
  return functionName.c_str();
}

int cuGetErrorName(int error, const char **name) {
  const ErrorText *known = findError(error);
  *name = known ? known->name : nullptr;
  return known ? 0 : 1;
}
int cuGetErrorString(int error, const char **text) {
  const ErrorText *known = findError(error);
  *text = known ? known->text : nullptr;
  return known ? 0 : 1;
}
int cuInit(unsigned) { return mode == 1 ? 100 : 0; }
int cuDriverGetVersion(int *version) {
  *version = 13000;
  return 0;
}
int cuDeviceGetCount(int *count) {
  *count = mode == 2 ? 0 : 1;
  return 0;
}
int cuDeviceGet(int *device, int ordinal) {
  *device = ordinal;
  return 0;
}
int cuDeviceGetName(char *name, int length, int) {
  std::strncpy(name, "Fake GPU", length);
  return 0;
}
int cuDeviceGetAttribute(int *value, int attribute, int) {
  *value = attribute == 75 ? 9 : 0;
  return 0;
}
int cuDeviceTotalMem_v2(std::size_t *bytes, int) {
  *bytes = 8 * kGiB;
  return 0;
}
int cuDevicePrimaryCtxRetain(void **context, int) {
  static int token;
  *context = &token;
  return 0;
}
int cuDevicePrimaryCtxRelease_v2(int) { return 0; }
int cuCtxSetCurrent(void *) { return 0; }
int cuCtxSynchronize() { return 0; }
int cuMemAlloc_v2(unsigned long long *ptr, std::size_t bytes) {
  if (bytes > kGiB)
    return 2;
  ++allocations;
  // Zeroed, so that outputs of kernels that are not run read as zeros.
  *ptr =
      reinterpret_cast<unsigned long long>(std::calloc(bytes ? bytes : 1, 1));
  return 0;
}
int cuMemFree_v2(unsigned long long ptr) {
  std::free(reinterpret_cast<void *>(ptr));
  return 0;
}
int cuMemGetInfo_v2(std::size_t *freeBytes, std::size_t *totalBytes) {
  *freeBytes = kGiB;
  *totalBytes = 8 * kGiB;
  return 0;
}
int cuMemcpyHtoD_v2(unsigned long long dst, const void *src, std::size_t n) {
  std::memcpy(reinterpret_cast<void *>(dst), src, n);
  return 0;
}
int cuMemcpyDtoH_v2(void *dst, unsigned long long src, std::size_t n) {
  std::memcpy(dst, reinterpret_cast<void *>(src), n);
  return 0;
}
int cuMemcpyDtoD_v2(unsigned long long dst, unsigned long long src,
                    std::size_t n) {
  std::memmove(reinterpret_cast<void *>(dst), reinterpret_cast<void *>(src), n);
  return 0;
}
int cuMemsetD8_v2(unsigned long long dst, unsigned char value, std::size_t n) {
  std::memset(reinterpret_cast<void *>(dst), value, n);
  return 0;
}
int cuModuleLoadData(void **module, const void *image) {
  static int token;
  if (yasps::runtime::host_image::isHostImage(image)) {
    loadedImage = "host image";
    std::unique_ptr<HostImageModule> loaded =
        HostImageModule::load(image, hostImageError);
    if (!loaded)
      return 200; // CUDA_ERROR_INVALID_IMAGE
    *module = loaded.get();
    hostModules[loaded.get()] = std::move(loaded);
    return 0;
  }
  loadedImage = static_cast<const char *>(image);
  *module = &token;
  return 0;
}
int cuModuleUnload(void *module) {
  auto found = hostModules.find(module);
  if (found != hostModules.end()) {
    for (auto it = hostKernels.begin(); it != hostKernels.end();)
      it = found->second->owns(static_cast<const HostKernel *>(*it))
               ? hostKernels.erase(it)
               : std::next(it);
    hostModules.erase(found);
  }
  return 0;
}
int cuModuleGetFunction(void **function, void *module, const char *name) {
  static int token;
  auto host = hostModules.find(module);
  if (host != hostModules.end()) {
    const HostKernel *kernel = host->second->kernel(name);
    if (!kernel)
      return 500; // CUDA_ERROR_NOT_FOUND
    functionName = name;
    *function = const_cast<HostKernel *>(kernel);
    hostKernels.insert(kernel);
    return 0;
  }
  if (std::string(name) == "missing")
    return 500; // CUDA_ERROR_NOT_FOUND
  functionName = name;
  *function = &token;
  for (const EmulatedKernel &kernel : kEmulated)
    if (functionName == kernel.name)
      *function = const_cast<EmulatedKernel *>(&kernel);
  return 0;
}
int cuLaunchKernel(void *function, unsigned gx, unsigned gy, unsigned gz,
                   unsigned bx, unsigned by, unsigned bz, unsigned, void *,
                   void **params, void **) {
  unsigned dims[6] = {gx, gy, gz, bx, by, bz};
  for (int i = 0; i < 6; ++i)
    lastDims[i] = dims[i];
  lastParams.clear();
  if (const EmulatedKernel *kernel = emulatedKernel(function)) {
    // Solver kernels take one argument struct.
    functionName = kernel->name;
    kernel->run(params, gx, bx);
    return 0;
  }
  if (hostKernels.count(function)) {
    const auto &kernel = *static_cast<const HostKernel *>(function);
    functionName = kernel.name;
    const unsigned grid[3] = {gx, gy, gz}, block[3] = {bx, by, bz};
    yasps::runtime::test::runHostKernel(kernel, params, grid, block);
  }
  for (int i = 0; i < expectedParams; ++i)
    lastParams.push_back(*static_cast<std::uint64_t *>(params[i]));
  return 0;
}
}
