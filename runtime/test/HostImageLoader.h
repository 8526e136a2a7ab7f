//===- HostImageLoader.h - the stand-in driver's host images ----*- C++ -*-===//
//
// Loads a host image (yasps/Runtime/Gpu/HostImage.h), the generated GPU kernels
// compiled for the host, with LLVM's JIT linker, and runs a kernel over a
// grid the way a GPU would lay its threads out: block after block, thread
// after thread, each thread given its ids in a ThreadContext. Generated
// kernels have no barriers or shared memory (yasps-nvvm-to-host refuses
// them), so one thread after another computes what concurrent threads do.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_TEST_HOSTIMAGELOADER_H
#define YASPS_RUNTIME_TEST_HOSTIMAGELOADER_H

#include "yasps/Runtime/Gpu/HostImage.h"

#include <map>
#include <memory>
#include <string>

namespace yasps::runtime::test {

/// One kernel of a loaded image: what cuModuleGetFunction hands out.
struct HostKernel {
  host_image::Entry entry;
  std::string name;
};

/// A loaded host image: what cuModuleLoadData hands out.
class HostImageModule {
public:
  /// Loads `image` (which starts with the host image header); null with
  /// `error` set if its object cannot be linked.
  static std::unique_ptr<HostImageModule> load(const void *image,
                                               std::string &error);
  ~HostImageModule();

  /// The kernel called `name`, or null.
  const HostKernel *kernel(const std::string &name);
  /// Whether `kernel` is one of this image's.
  bool owns(const HostKernel *kernel) const {
    for (const auto &entry : kernels_)
      if (&entry.second == kernel)
        return true;
    return false;
  }

private:
  HostImageModule();
  struct Jit;
  std::unique_ptr<Jit> jit_;
  std::map<std::string, HostKernel> kernels_;
};

/// Runs `kernel` over a grid of `grid` blocks of `block` threads (x, y, z)
/// with cuLaunchKernel's `params`.
void runHostKernel(const HostKernel &kernel, void **params,
                   const unsigned grid[3], const unsigned block[3]);

} // namespace yasps::runtime::test

#endif // YASPS_RUNTIME_TEST_HOSTIMAGELOADER_H
