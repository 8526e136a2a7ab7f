//===- HostImage.h - GPU kernels compiled for the host ----------*- C++ -*-===//
//
// A host image is the third binary format of a GPU kernel library, beside
// cubins and PTX: the kernels' NVVM-level IR, the IR that becomes the cubin,
// compiled for the host CPU instead of by NVPTX and ptxas
// (`yasps-nvvm-to-host`, lib/Target/GPU/HostImage.cpp). A stand-in driver
// (runtime/test/FakeCuda.cpp) loads it through cuModuleLoadData and runs
// its kernels through cuLaunchKernel's own parameter array, one block after
// another and one thread after another, so that tests on machines without
// a GPU compare the generated kernels' results with the CPU backend's.
//
// This header is the contract between the compiler that writes the image
// and the driver that runs it; it needs neither MLIR nor CUDA.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_GPU_HOSTIMAGE_H
#define YASPS_RUNTIME_GPU_HOSTIMAGE_H

#include <cstdint>
#include <cstring>

namespace yasps::runtime::host_image {

/// An image starts with these 8 bytes and the object's size (a
/// little-endian u64); a relocatable object file for the host follows.
/// cuModuleLoadData receives no size, hence the header.
constexpr char kMagic[8] = {'Y', 'A', 'S', 'P', 'S', 'H', 'I', '1'};
constexpr std::size_t kHeaderBytes = 16;

/// The chip and format names of a host image in a kernel library.
constexpr const char *kChip = "host";
constexpr const char *kFormat = "host";

/// What a kernel's thread reads where a GPU thread reads its special
/// registers: per axis x, y, z, its thread id, the block's size, its block
/// id and the grid's size (PTX's %tid, %ntid, %ctaid, %nctaid).
struct ThreadContext {
  std::uint32_t tid[3];
  std::uint32_t ntid[3];
  std::uint32_t ctaid[3];
  std::uint32_t nctaid[3];
};

/// The i32 slot of each register in ThreadContext, for the compiler.
enum Slot : std::int64_t { kTid = 0, kNtid = 3, kCtaid = 6, kNctaid = 9 };

/// The entry point of kernel `name` in the object: a function of this
/// type, under the kernel's own name. `params` is cuLaunchKernel's
/// `kernelParams` (a pointer to each parameter's value, in the kernel's
/// order).
using Entry = void (*)(void **params, const ThreadContext *thread);

/// Whether `image` starts with a host image's header.
inline bool isHostImage(const void *image) {
  return std::memcmp(image, kMagic, sizeof(kMagic)) == 0;
}

/// The size of the object that follows the header.
inline std::uint64_t objectBytes(const void *image) {
  std::uint64_t bytes = 0;
  std::memcpy(&bytes, static_cast<const char *>(image) + sizeof(kMagic),
              sizeof(bytes));
  return bytes;
}

} // namespace yasps::runtime::host_image

#endif // YASPS_RUNTIME_GPU_HOSTIMAGE_H
