//===- HostImage.h - GPU kernel modules compiled for the host ---*- C++ -*-===//
//
// The host image of a GPU kernel module (yasps/Runtime/Gpu/HostImage.h): the
// module lowered to NVVM as for its cubins, made callable on the host by
// yasps-nvvm-to-host, translated to LLVM IR and compiled for the host CPU
// into a relocatable object, behind the image's header. The stand-in driver
// runs it; no GPU, driver or ptxas is needed.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_TARGET_GPU_HOSTIMAGE_H
#define YASPS_TARGET_GPU_HOSTIMAGE_H

#include "mlir/IR/BuiltinOps.h"
#include "llvm/Support/Error.h"

#include <string>

namespace mlir::yasps {

/// The host image of the gpu.module in `device` (a module holding exactly
/// one, whose kernels are outlined gpu.func kernels); `device` is left
/// unchanged.
llvm::Expected<std::string> compileHostImage(ModuleOp device);

} // namespace mlir::yasps

#endif // YASPS_TARGET_GPU_HOSTIMAGE_H
