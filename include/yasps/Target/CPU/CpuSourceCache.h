//===- CpuSourceCache.h - compiled kernels found by their source -*- C++ -*-===//
//
// The object cache of compileCpuKernels is keyed by the generated kernels,
// so finding an object still parses the scene, runs the pass pipeline and
// lowers the kernels. A warm start of a whole scene would redo all of that
// per request. This cache records, per request (IR text, attributes,
// pre-pipeline, options and the build of the compiler itself), which object
// it compiled to and the kernels' descriptions, so that a repeated request
// in a new process loads the object without parsing anything.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_TARGET_CPU_CPUSOURCECACHE_H
#define YASPS_TARGET_CPU_CPUSOURCECACHE_H

#include "yasps/Target/CPU/CpuCompiler.h"

#include <memory>
#include <string>
#include <vector>

namespace mlir::yasps {

/// The key of a compilation request: a hash of the IR text, the attributes,
/// the pre-pipeline, the options, the host and this build of the compiler.
std::string cpuSourceKey(llvm::StringRef ir,
                         const std::vector<std::string> &attributes,
                         llvm::StringRef prePipeline,
                         const CpuCompileOptions &options);

/// The library a request compiled to before (in `options.cacheDir`), or
/// null; sets `stats.fromSource` when found.
std::shared_ptr<CpuKernelLibrary>
lookupCpuSource(const std::string &sourceKey, const CpuCompileOptions &options,
                CpuCompileStats &stats);

/// Records that the request `sourceKey` compiled to `library` (the objects
/// of its kernels, by their `objectKey`s).
void recordCpuSource(const std::string &sourceKey,
                     const CpuKernelLibrary &library,
                     const CpuCompileOptions &options);

} // namespace mlir::yasps

#endif // YASPS_TARGET_CPU_CPUSOURCECACHE_H
