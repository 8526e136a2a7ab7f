//===- CudaMemory.cpp - device contexts and buffers -----------------------===//

#include "yasps/Runtime/Support/CudaMemory.h"

#include <cstdio>
#include <utility>

using namespace yasps::runtime;

CudaContext::CudaContext(CudaDriver &driver, int ordinal)
    : drv(driver), device(ordinal) {
  drv.requireUsable();
  cu::Device handle;
  drv.check(drv.cuDeviceGet(&handle, ordinal), "cuDeviceGet");
  drv.check(drv.cuDevicePrimaryCtxRetain(&context, handle),
            "cuDevicePrimaryCtxRetain");
  makeCurrent();
}

CudaContext::~CudaContext() {
  cu::Device handle;
  if (drv.cuDeviceGet(&handle, device) == cu::kSuccess)
    drv.cuDevicePrimaryCtxRelease(handle);
}

void CudaContext::makeCurrent() const {
  drv.check(drv.cuCtxSetCurrent(context), "cuCtxSetCurrent");
}

void CudaContext::synchronize() const {
  drv.check(drv.cuCtxSynchronize(), "cuCtxSynchronize");
}

std::string yasps::runtime::formatBytes(std::size_t bytes) {
  const char *units[] = {"KiB", "MiB", "GiB", "TiB"};
  if (bytes < 1024)
    return std::to_string(bytes) + " bytes";
  double value = double(bytes) / 1024;
  int unit = 0;
  while (value >= 1024 && unit < 3) {
    value /= 1024;
    ++unit;
  }
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f %s", value < 10 ? 2 : 1, value,
                units[unit]);
  return text;
}

DeviceBuffer::DeviceBuffer(const CudaContext &context, std::size_t bytes)
    : ctx(&context), length(bytes) {
  if (bytes == 0)
    return;
  CudaDriver &drv = context.driver();
  context.makeCurrent();
  cu::Result result = drv.cuMemAlloc(&ptr, bytes);
  if (result == cu::kOutOfMemory) {
    std::size_t freeBytes = 0, totalBytes = 0;
    std::string state =
        drv.cuMemGetInfo(&freeBytes, &totalBytes) == cu::kSuccess
            ? formatBytes(freeBytes) + " free of " + formatBytes(totalBytes)
            : "unknown free memory";
    throw CudaError("out of GPU memory: allocating " + formatBytes(bytes) +
                        " on device " + std::to_string(context.ordinal()) +
                        " (" + state + ")",
                    result);
  }
  drv.check(result, "cuMemAlloc");
}

DeviceBuffer::~DeviceBuffer() { release(); }

DeviceBuffer::DeviceBuffer(DeviceBuffer &&other) noexcept
    : ctx(other.ctx), ptr(std::exchange(other.ptr, 0)),
      length(std::exchange(other.length, 0)) {}

DeviceBuffer &DeviceBuffer::operator=(DeviceBuffer &&other) noexcept {
  if (this != &other) {
    release();
    ctx = other.ctx;
    ptr = std::exchange(other.ptr, 0);
    length = std::exchange(other.length, 0);
  }
  return *this;
}

void DeviceBuffer::release() noexcept {
  if (ptr)
    ctx->driver().cuMemFree(ptr);
  ptr = 0;
}

void DeviceBuffer::upload(const void *host, std::size_t bytes) {
  if (bytes > length)
    throw std::out_of_range("upload of " + std::to_string(bytes) +
                            " bytes into a device buffer of " +
                            std::to_string(length));
  if (bytes == 0)
    return;
  ctx->makeCurrent();
  ctx->driver().check(ctx->driver().cuMemcpyHtoD(ptr, host, bytes),
                      "cuMemcpyHtoD");
}

void DeviceBuffer::download(void *host, std::size_t bytes) const {
  if (bytes > length)
    throw std::out_of_range("download of " + std::to_string(bytes) +
                            " bytes from a device buffer of " +
                            std::to_string(length));
  if (bytes == 0)
    return;
  ctx->makeCurrent();
  ctx->driver().check(ctx->driver().cuMemcpyDtoH(host, ptr, bytes),
                      "cuMemcpyDtoH");
}

void DeviceBuffer::setZero(std::size_t bytes) {
  if (bytes > length)
    throw std::out_of_range("zeroing " + std::to_string(bytes) +
                            " bytes of a device buffer of " +
                            std::to_string(length));
  if (bytes == 0)
    return;
  ctx->makeCurrent();
  ctx->driver().check(ctx->driver().cuMemsetD8(ptr, 0, bytes), "cuMemsetD8");
}

void DeviceBuffer::copyFrom(const DeviceBuffer &source, std::size_t bytes) {
  if (bytes > length || bytes > source.length)
    throw std::out_of_range("device copy of " + std::to_string(bytes) +
                            " bytes from a buffer of " +
                            std::to_string(source.length) + " into one of " +
                            std::to_string(length));
  if (bytes == 0)
    return;
  ctx->makeCurrent();
  ctx->driver().check(ctx->driver().cuMemcpyDtoD(ptr, source.ptr, bytes),
                      "cuMemcpyDtoD");
}
