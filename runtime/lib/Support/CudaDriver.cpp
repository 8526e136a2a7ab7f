//===- CudaDriver.cpp - the CUDA driver API, loaded at run time -----------===//

#include "yasps/Runtime/Support/CudaDriver.h"

#include <cstdlib>
#include <dlfcn.h>

using namespace yasps::runtime;

std::string CudaDeviceInfo::chip() const {
  return "sm_" + std::to_string(computeMajor) + std::to_string(computeMinor);
}

CudaDriver &CudaDriver::get() {
  // Never destroyed: kernels and buffers may outlive other statics.
  static CudaDriver *driver = [] {
    const char *path = std::getenv("YASPS_CUDA_LIBRARY");
    return new CudaDriver(path && *path ? path : "libcuda.so.1");
  }();
  return *driver;
}

CudaDriver::CudaDriver(const std::string &path) { load(path); }

CudaDriver::~CudaDriver() {
  if (handle)
    dlclose(handle);
}

void CudaDriver::load(const std::string &path) {
  handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char *error = dlerror();
    reason = "the CUDA driver library " + path +
             " could not be loaded (no NVIDIA driver installed?): " +
             (error ? error : "unknown error");
    return;
  }
  bool complete = true;
  auto resolve = [&](auto &fn, const char *symbol) {
    fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(
        dlsym(handle, symbol));
    if (!fn && complete) {
      complete = false;
      reason = path + " has no " + symbol + " (CUDA driver too old?)";
    }
  };
  resolve(cuGetErrorName, "cuGetErrorName");
  resolve(cuGetErrorString, "cuGetErrorString");
  resolve(cuInit, "cuInit");
  resolve(cuDriverGetVersion, "cuDriverGetVersion");
  resolve(cuDeviceGetCount, "cuDeviceGetCount");
  resolve(cuDeviceGet, "cuDeviceGet");
  resolve(cuDeviceGetName, "cuDeviceGetName");
  resolve(cuDeviceGetAttribute, "cuDeviceGetAttribute");
  resolve(cuDeviceTotalMem, "cuDeviceTotalMem_v2");
  resolve(cuDevicePrimaryCtxRetain, "cuDevicePrimaryCtxRetain");
  resolve(cuDevicePrimaryCtxRelease, "cuDevicePrimaryCtxRelease_v2");
  resolve(cuCtxSetCurrent, "cuCtxSetCurrent");
  resolve(cuCtxSynchronize, "cuCtxSynchronize");
  resolve(cuMemAlloc, "cuMemAlloc_v2");
  resolve(cuMemFree, "cuMemFree_v2");
  resolve(cuMemGetInfo, "cuMemGetInfo_v2");
  resolve(cuMemcpyHtoD, "cuMemcpyHtoD_v2");
  resolve(cuMemcpyDtoH, "cuMemcpyDtoH_v2");
  resolve(cuMemcpyDtoD, "cuMemcpyDtoD_v2");
  resolve(cuMemsetD8, "cuMemsetD8_v2");
  resolve(cuModuleLoadData, "cuModuleLoadData");
  resolve(cuModuleUnload, "cuModuleUnload");
  resolve(cuModuleGetFunction, "cuModuleGetFunction");
  resolve(cuLaunchKernel, "cuLaunchKernel");
  if (!complete)
    return;
  // Not a CUDA entry point: only the stand-in driver has it.
  if (auto standIn = reinterpret_cast<int (*)()>(
          dlsym(handle, "yaspsStandInRunsHostImages")))
    hostImages = standIn() != 0;

  try {
    check(cuInit(0), "cuInit");
    int count = 0;
    check(cuDeviceGetCount(&count), "cuDeviceGetCount");
    for (int ordinal = 0; ordinal < count; ++ordinal) {
      cu::Device device;
      check(cuDeviceGet(&device, ordinal), "cuDeviceGet");
      CudaDeviceInfo info;
      info.ordinal = ordinal;
      char name[256] = {};
      check(cuDeviceGetName(name, sizeof(name) - 1, device), "cuDeviceGetName");
      info.name = name;
      check(cuDeviceGetAttribute(&info.computeMajor, cu::kAttrComputeMajor,
                                 device),
            "cuDeviceGetAttribute");
      check(cuDeviceGetAttribute(&info.computeMinor, cu::kAttrComputeMinor,
                                 device),
            "cuDeviceGetAttribute");
      check(cuDeviceTotalMem(&info.totalMemory, device), "cuDeviceTotalMem");
      deviceList.push_back(info);
    }
    if (deviceList.empty())
      reason = "the CUDA driver reports no device";
  } catch (const CudaError &error) {
    reason = error.what();
  }
}

void CudaDriver::requireUsable() const {
  if (!usable())
    throw CudaError("the GPU backend cannot be used: " + reason, 0);
}

std::string CudaDriver::describe(cu::Result result) const {
  const char *name = nullptr, *text = nullptr;
  if (cuGetErrorName)
    cuGetErrorName(result, &name);
  if (cuGetErrorString)
    cuGetErrorString(result, &text);
  std::string out = name ? name : "CUresult " + std::to_string(result);
  if (text)
    out += std::string(" (") + text + ")";
  return out;
}

void CudaDriver::check(cu::Result result, const char *call) const {
  if (result != cu::kSuccess)
    throw CudaError(std::string(call) + " failed: " + describe(result), result);
}
