//===- CudaMemory.h - device contexts and buffers ---------------*- C++ -*-===//
//
// RAII owners of what the GPU backend allocates through the driver: the
// device's primary context (shared with any other CUDA user in the
// process, as the runtime API does) and device buffers. An allocation that
// does not fit says how much was asked for and how much the device had
// free, which is what a user needs to decide what to shrink.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SUPPORT_CUDAMEMORY_H
#define YASPS_RUNTIME_SUPPORT_CUDAMEMORY_H

#include "yasps/Runtime/Support/CudaDriver.h"

#include <vector>

namespace yasps::runtime {

/// A device's primary context, retained while this object lives and made
/// current on the calling thread by `makeCurrent()`.
class CudaContext {
public:
  CudaContext(CudaDriver &driver, int ordinal);
  ~CudaContext();
  CudaContext(const CudaContext &) = delete;
  CudaContext &operator=(const CudaContext &) = delete;

  void makeCurrent() const;
  void synchronize() const;
  CudaDriver &driver() const { return drv; }
  int ordinal() const { return device; }

private:
  CudaDriver &drv;
  int device;
  cu::Context context = nullptr;
};

/// "1.50 GiB", "12.0 MiB", "512 bytes".
std::string formatBytes(std::size_t bytes);

/// A device allocation of `bytes` bytes in `context`.
class DeviceBuffer {
public:
  /// Allocates; throws CudaError, with the sizes involved for out of
  /// memory. Zero bytes allocate nothing.
  DeviceBuffer(const CudaContext &context, std::size_t bytes);
  /// An empty buffer (of no context), to be assigned later.
  DeviceBuffer() = default;
  ~DeviceBuffer();
  DeviceBuffer(DeviceBuffer &&other) noexcept;
  DeviceBuffer &operator=(DeviceBuffer &&other) noexcept;
  DeviceBuffer(const DeviceBuffer &) = delete;
  DeviceBuffer &operator=(const DeviceBuffer &) = delete;

  /// Copies `bytes` bytes from host memory to the start of the buffer
  /// (throws std::out_of_range past its end).
  void upload(const void *host, std::size_t bytes);
  /// Copies `bytes` bytes from the start of the buffer to host memory.
  void download(void *host, std::size_t bytes) const;

  /// Sets every byte to zero.
  void setZero() { setZero(length); }
  /// Sets the first `bytes` bytes to zero (throws std::out_of_range past
  /// the end).
  void setZero(std::size_t bytes);
  /// Copies `bytes` bytes from the start of `source` to the start of this
  /// buffer (on the device; throws std::out_of_range past either's end).
  void copyFrom(const DeviceBuffer &source, std::size_t bytes);

  cu::DevicePtr pointer() const { return ptr; }
  std::size_t size() const { return length; }

private:
  void release() noexcept;
  const CudaContext *ctx = nullptr;
  cu::DevicePtr ptr = 0;
  std::size_t length = 0;
};

/// A device buffer holding a copy of `host`.
template <typename T>
DeviceBuffer deviceCopy(const CudaContext &context,
                        const std::vector<T> &host) {
  DeviceBuffer buffer(context, host.size() * sizeof(T));
  buffer.upload(host.data(), host.size() * sizeof(T));
  return buffer;
}

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SUPPORT_CUDAMEMORY_H
