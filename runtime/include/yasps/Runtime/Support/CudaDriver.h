//===- CudaDriver.h - the CUDA driver API, loaded at run time ---*- C++ -*-===//
//
// The GPU backend talks to the CUDA driver (libcuda.so.1), which comes with
// the NVIDIA driver, not with the toolkit. It is opened with dlopen on first
// use instead of being linked, so that one build runs on machines with and
// without a GPU: where the library, a device or a working driver is
// missing, `CudaDriver::get()` says why and the CPU backend is used.
//
// Only the handful of entry points the runtime needs are resolved, with
// their ABI declared here (the stable C ABI of the driver API, `_v2`
// symbols where the driver versions them), so no CUDA header is needed to
// build. Every failed call becomes a `CudaError` whose message names the
// call, the driver's error name and its description.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SUPPORT_CUDADRIVER_H
#define YASPS_RUNTIME_SUPPORT_CUDADRIVER_H

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace yasps::runtime {

/// A failed driver call (or a driver that cannot be used).
class CudaError : public std::runtime_error {
public:
  CudaError(const std::string &message, int code)
      : std::runtime_error(message), code(code) {}
  /// The driver's CUresult (0 where there is none, e.g. dlopen failed).
  int code;
};

/// What the driver reports about one device.
struct CudaDeviceInfo {
  int ordinal = 0;
  std::string name;
  int computeMajor = 0, computeMinor = 0;
  std::size_t totalMemory = 0;
  /// "sm_90" for compute capability 9.0.
  std::string chip() const;
};

/// The driver's ABI types (cuda.h names, without the header).
namespace cu {
using Result = int;
using Device = int;
using DevicePtr = unsigned long long;
using Context = struct CUctx_st *;
using Module = struct CUmod_st *;
using Function = struct CUfunc_st *;
using Stream = struct CUstream_st *;
constexpr Result kSuccess = 0;
constexpr Result kOutOfMemory = 2;
constexpr int kAttrComputeMajor = 75;
constexpr int kAttrComputeMinor = 76;
} // namespace cu

/// The loaded driver library and its entry points.
class CudaDriver {
public:
  /// The process's driver, loaded and initialised (cuInit) on first call
  /// from `$YASPS_CUDA_LIBRARY` if set, else libcuda.so.1. Never throws:
  /// check `usable()`.
  static CudaDriver &get();

  /// Loads the library at `path` and initialises it (for tests; `get()`
  /// is what the runtime uses).
  explicit CudaDriver(const std::string &path);
  ~CudaDriver();
  CudaDriver(const CudaDriver &) = delete;
  CudaDriver &operator=(const CudaDriver &) = delete;

  /// True when the library loaded, cuInit succeeded and there is a device.
  bool usable() const { return reason.empty(); }
  /// Why the driver cannot be used ("" when it can).
  const std::string &unusableReason() const { return reason; }
  /// Throws CudaError(unusableReason()) unless usable.
  void requireUsable() const;

  const std::vector<CudaDeviceInfo> &devices() const { return deviceList; }
  /// Whether the library is a stand-in that runs host images of the
  /// generated kernels (yasps/Runtime/Gpu/HostImage.h) instead of cubins: it
  /// exports `yaspsStandInRunsHostImages`, which returns nonzero.
  bool runsHostImages() const { return hostImages; }

  /// Throws a CudaError for a failed `result` of the call named `call`:
  /// "cuModuleLoadData failed: CUDA_ERROR_INVALID_IMAGE (device kernel
  /// image is invalid)". Does nothing on success.
  void check(cu::Result result, const char *call) const;
  /// The driver's "NAME (description)" of an error code.
  std::string describe(cu::Result result) const;

  // Entry points (null until loaded).
  cu::Result (*cuInit)(unsigned) = nullptr;
  cu::Result (*cuDriverGetVersion)(int *) = nullptr;
  cu::Result (*cuDeviceGetCount)(int *) = nullptr;
  cu::Result (*cuDeviceGet)(cu::Device *, int) = nullptr;
  cu::Result (*cuDeviceGetName)(char *, int, cu::Device) = nullptr;
  cu::Result (*cuDeviceGetAttribute)(int *, int, cu::Device) = nullptr;
  cu::Result (*cuDeviceTotalMem)(std::size_t *, cu::Device) = nullptr;
  cu::Result (*cuDevicePrimaryCtxRetain)(cu::Context *, cu::Device) = nullptr;
  cu::Result (*cuDevicePrimaryCtxRelease)(cu::Device) = nullptr;
  cu::Result (*cuCtxSetCurrent)(cu::Context) = nullptr;
  cu::Result (*cuCtxSynchronize)() = nullptr;
  cu::Result (*cuMemAlloc)(cu::DevicePtr *, std::size_t) = nullptr;
  cu::Result (*cuMemFree)(cu::DevicePtr) = nullptr;
  cu::Result (*cuMemGetInfo)(std::size_t *, std::size_t *) = nullptr;
  cu::Result (*cuMemcpyHtoD)(cu::DevicePtr, const void *,
                             std::size_t) = nullptr;
  cu::Result (*cuMemcpyDtoH)(void *, cu::DevicePtr, std::size_t) = nullptr;
  cu::Result (*cuMemcpyDtoD)(cu::DevicePtr, cu::DevicePtr,
                             std::size_t) = nullptr;
  cu::Result (*cuMemsetD8)(cu::DevicePtr, unsigned char, std::size_t) = nullptr;
  cu::Result (*cuModuleLoadData)(cu::Module *, const void *) = nullptr;
  cu::Result (*cuModuleUnload)(cu::Module) = nullptr;
  cu::Result (*cuModuleGetFunction)(cu::Function *, cu::Module,
                                    const char *) = nullptr;
  cu::Result (*cuLaunchKernel)(cu::Function, unsigned, unsigned, unsigned,
                               unsigned, unsigned, unsigned, unsigned,
                               cu::Stream, void **, void **) = nullptr;
  cu::Result (*cuGetErrorName)(cu::Result, const char **) = nullptr;
  cu::Result (*cuGetErrorString)(cu::Result, const char **) = nullptr;

private:
  void load(const std::string &path);
  void *handle = nullptr;
  std::string reason;
  std::vector<CudaDeviceInfo> deviceList;
  bool hostImages = false;
};

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SUPPORT_CUDADRIVER_H
