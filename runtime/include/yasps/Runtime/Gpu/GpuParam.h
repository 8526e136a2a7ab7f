//===- GpuParam.h - the launch record of a compiled GPU kernel --*- C++ -*-===//
//
// The GPU compiler (lib/Target/GPU) records, for each kernel, where each
// cuLaunchKernel parameter comes from; the runtime (GpuLaunch.h) launches by
// that record. Both use this one type, which needs neither MLIR nor CUDA.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_GPU_GPUPARAM_H
#define YASPS_RUNTIME_GPU_GPUPARAM_H

#include <cstdint>
#include <optional>
#include <string_view>

namespace yasps::runtime {

/// One kernel parameter as the CUDA driver receives it (cuLaunchKernel's
/// `kernelParams`, in order).
struct GpuParam {
  enum class Kind {
    /// An index argument of the loop kernel (0: begin, 1: end): one i64.
    Index,
    /// Buffer argument `argument` (>= 2) of the loop kernel: five values,
    /// MLIR's memref descriptor (allocated and aligned pointer, i64 offset
    /// 0, i64 size, i64 stride 1).
    Buffer,
    /// A constant the host computed: one i64 `value`.
    Constant,
  };
  Kind kind;
  std::int64_t argument = -1; ///< for Index and Buffer
  std::int64_t value = 0;     ///< for Constant
};

/// The name of a kind where the record is written out (Python, kits):
/// "index", "buffer" or "constant".
inline const char *gpuParamKindName(GpuParam::Kind kind) {
  switch (kind) {
  case GpuParam::Kind::Index:
    return "index";
  case GpuParam::Kind::Buffer:
    return "buffer";
  case GpuParam::Kind::Constant:
    return "constant";
  }
  return "";
}

/// The kind named `name` (see gpuParamKindName), if any.
inline std::optional<GpuParam::Kind> parseGpuParamKind(std::string_view name) {
  for (GpuParam::Kind kind : {GpuParam::Kind::Index, GpuParam::Kind::Buffer,
                              GpuParam::Kind::Constant})
    if (name == gpuParamKindName(kind))
      return kind;
  return std::nullopt;
}

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_GPU_GPUPARAM_H
