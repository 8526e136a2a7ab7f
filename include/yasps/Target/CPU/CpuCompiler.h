//===- CpuCompiler.h - attribute kernels for the CPU ------------*- C++ -*-===//
//
// Compiles the attributes of a scene into CPU kernels: yasps IR is lowered to
// loop kernels (yasps-lower-to-loops), then to the LLVM dialect, and JIT
// compiled by mlir::ExecutionEngine with LLVM's -O3 pipeline for the host.
// Compiled objects are cached in memory and on disk, keyed by a hash of the
// kernel IR, the pipeline and the host CPU, so a second process with the
// same scene compiles nothing.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_TARGET_CPU_CPUCOMPILER_H
#define YASPS_TARGET_CPU_CPUCOMPILER_H

#include "yasps/Target/KernelGeneration.h"

#include "mlir/IR/BuiltinOps.h"
#include "mlir/IR/DialectRegistry.h"
#include "llvm/Support/Error.h"

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace mlir::yasps {

/// One compiled attribute kernel, callable with MLIR's packed ABI:
/// (index begin, index end, memref<?x...> buffers...).
struct CpuKernel : KernelDescription {
  void (*packed)(void **) = nullptr;
  /// The cache key of the object that holds it: every kernel is compiled
  /// and cached on its own.
  std::string objectKey;
};

/// How a compilation went, for users and benchmarks.
struct CpuCompileStats {
  bool fromMemory = false;   ///< reused a kernel library of this process
  bool fromDisk = false;     ///< loaded a cached object, no code generation
  /// found by the IR text and request alone (CpuSourceCache.h): nothing
  /// was parsed or lowered
  bool fromSource = false;
  double lowerSeconds = 0;   ///< yasps IR to LLVM dialect
  double codegenSeconds = 0; ///< LLVM optimisation, code generation, loading
  /// the cache key (of the one kernel's object, else of them all)
  std::string key;
};

/// A set of compiled kernels and the JIT session that owns their code.
class CpuKernelLibrary {
public:
  virtual ~CpuKernelLibrary();
  /// The kernel evaluating `attributePath`, or null.
  const CpuKernel *lookup(llvm::StringRef attributePath) const;
  const std::vector<CpuKernel> &kernels() const { return kernelList; }

protected:
  std::vector<CpuKernel> kernelList;
  friend class CpuCompiler;
};

struct CpuCompileOptions {
  /// Directory of the on-disk object cache; empty disables it.
  std::string cacheDir;
  /// LLVM optimisation level of the kernels (0-3).
  unsigned optLevel = 3;
  /// Instances evaluated together in SIMD lanes (yasps-lower-to-loops
  /// {lanes}); 0 picks the host's vector width in doubles (8 with AVX-512,
  /// else 4), 1 evaluates one instance at a time.
  int64_t lanes = 0;
  /// The CPU the kernels are for, an LLVM CPU name ("x86-64-v3" for any
  /// x86 machine with AVX2 and FMA), for kernels carried to other machines
  /// (the kernel store); empty: this host, with every feature it has.
  std::string targetCpu;
  /// Called with each kernel's attribute path once its machine code is
  /// made (not for kernels found in a cache), from the thread that made it
  /// and one call at a time: for progress shown to users. No part of any
  /// cache key.
  std::function<void(const std::string &attribute)> onKernelCompiled;
};

/// How many kernels this process has compiled to machine code (LLVM
/// optimisation and code generation; loads from the caches not counted).
int64_t cpuKernelsCompiled();

/// The number of f64 lanes in the host's widest vector registers.
int64_t hostDoubleLanes();

/// The number of f64 lanes in the widest vector registers of `cpu` (an
/// LLVM CPU name; empty: the host).
int64_t doubleLanesOf(llvm::StringRef cpu);

/// Registers the dialects, interfaces and translations the CPU pipeline uses.
void registerCpuCompilerDialects(DialectRegistry &registry);

/// The pass pipeline from kernel functions (after yasps-lower-to-loops) to
/// the LLVM dialect, as a yasps-opt pipeline string.
llvm::StringRef getCpuLoweringPipeline();

/// Compiles kernels for `attributes` (scene-relative paths; empty: every
/// energy) of the module's scene. The module is left unchanged. Libraries
/// are shared between calls with the same kernels.
/// `prePipeline` (a yasps-opt pipeline string, e.g.
/// "yasps-inline-reads,cse,yasps-differentiate") runs first, for attributes
/// that passes create.
llvm::Expected<std::shared_ptr<CpuKernelLibrary>>
compileCpuKernels(ModuleOp module, const std::vector<std::string> &attributes,
                  const CpuCompileOptions &options,
                  CpuCompileStats *stats = nullptr,
                  llvm::StringRef prePipeline = "");

/// The library of `kernels` (descriptions with their `objectKey`s), each
/// from this process's libraries, else from `options.cacheDir`; null if one
/// is in neither.
std::shared_ptr<CpuKernelLibrary>
loadCachedCpuKernels(std::vector<CpuKernel> kernels,
                     const CpuCompileOptions &options, CpuCompileStats &stats);

} // namespace mlir::yasps

#endif // YASPS_TARGET_CPU_CPUCOMPILER_H
