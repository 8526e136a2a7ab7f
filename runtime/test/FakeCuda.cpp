//===- FakeCuda.cpp - a stand-in CUDA driver library for tests ------------===//
//
// Exports the driver entry points CudaDriver resolves, backed by host
// memory, so that loading, error reporting and buffers are tested on
// machines without a GPU. `fakeCudaSetMode` picks the behaviour: 0 a
// healthy driver with one "Fake GPU" (compute capability 9.0, 8 GiB, of
// which 1 GiB is free), 1 a cuInit that fails with CUDA_ERROR_NO_DEVICE,
// 2 a driver without devices.
//
//===----------------------------------------------------------------------===//

#include <cstddef>
#include <cstdlib>
#include <cstring>

namespace {
int mode = 0;
constexpr std::size_t kGiB = std::size_t(1) << 30;
} // namespace

extern "C" {
void fakeCudaSetMode(int m) { mode = m; }

int cuGetErrorName(int error, const char **name) {
  switch (error) {
  case 0:
    *name = "CUDA_SUCCESS";
    return 0;
  case 2:
    *name = "CUDA_ERROR_OUT_OF_MEMORY";
    return 0;
  case 100:
    *name = "CUDA_ERROR_NO_DEVICE";
    return 0;
  default:
    *name = nullptr;
    return 1;
  }
}
int cuGetErrorString(int error, const char **text) {
  switch (error) {
  case 0:
    *text = "no error";
    return 0;
  case 2:
    *text = "out of memory";
    return 0;
  case 100:
    *text = "no CUDA-capable device is detected";
    return 0;
  default:
    *text = nullptr;
    return 1;
  }
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
  *ptr = reinterpret_cast<unsigned long long>(std::malloc(bytes));
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
// Modules and launches are not faked: they need a real device.
int cuModuleLoadData(void **, const void *) { return 200; }
int cuModuleUnload(void *) { return 0; }
int cuModuleGetFunction(void **, void *, const char *) { return 500; }
int cuLaunchKernel(void *, unsigned, unsigned, unsigned, unsigned, unsigned,
                   unsigned, unsigned, void *, void **, void **) {
  return 1;
}
}
