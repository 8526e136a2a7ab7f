//===- KernelGeneration.h - loop kernels shared by every target -*- C++ -*-===//
//
// Both back ends start from the same kernels: yasps IR is lowered to one
// loop function per requested attribute (yasps-lower-to-loops), the scene is
// stripped, and the result is canonicalised, CSE'd and annotated with op
// counts. The functions' attributes describe what the runtime must bind.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_TARGET_KERNELGENERATION_H
#define YASPS_TARGET_KERNELGENERATION_H

#include "mlir/IR/BuiltinOps.h"
#include "mlir/IR/OwningOpRef.h"
#include "mlir/Pass/PassManager.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"
#include "llvm/Support/Error.h"

#include <map>
#include <string>
#include <vector>

namespace mlir::yasps {

/// A requested attribute that the module does not declare once the
/// pre-pipeline has run: typically a derivative (`@E__grad`, ...) that
/// yasps-differentiate did not create because E depends on no target.
/// Callers react to this failure, so it is a type, not a message.
class MissingAttributeError : public llvm::ErrorInfo<MissingAttributeError> {
public:
  static char ID;

  MissingAttributeError(std::string symbol, std::string scene)
      : symbol(std::move(symbol)), scene(std::move(scene)) {}

  /// The scene-relative path that was requested, e.g. "@m::@p::@e__grad".
  const std::string &getSymbol() const { return symbol; }

  void log(llvm::raw_ostream &os) const override;
  std::error_code convertToErrorCode() const override;

private:
  std::string symbol;
  std::string scene;
};

/// What one buffer argument of a kernel holds.
struct KernelArgument {
  /// out, attr, conn, offsets or dof_offsets (the dialect's enum, as the
  /// kernel's #yasps.kernel_arg says).
  mlir::yasps::KernelArgKind kind;
  std::string path; ///< scene-relative symbol path, e.g. "@m::@v::@x"
};

/// What a kernel computes and takes, independent of the target.
struct KernelDescription {
  std::string attribute; ///< the attribute it evaluates
  std::string symbol;    ///< the kernel function's name
  std::vector<KernelArgument> arguments;
  /// Rows and columns of each instance's value in the output buffer.
  int64_t rows = 0, cols = 0;
  /// For projected Hessians, `yasps.projection` ("full", "reduced" or
  /// "separate"); empty otherwise.
  std::string projection;
  /// For derivative attributes, their local parameters (`yasps.params`),
  /// each as its printed fields, e.g. {"join", "@m::@t::@t2v", "2",
  /// "@m::@v::@x"}.
  std::vector<std::vector<std::string>> params;
  /// The float type of the output buffer: "f64" or "f32".
  std::string outType = "f64";
  /// Static counts of the kernel's arithmetic (yasps-count-ops): "mul",
  /// "add", "div", "math".
  std::map<std::string, int64_t> opCounts;
};

/// The printed fields of each entry of a `yasps.params` attribute (empty for
/// a null attribute), e.g. {"join", "@t2v", "2", "@m::@v::@x", "3"}.
std::vector<std::vector<std::string>> describeParams(ArrayAttr params);

/// When runPasses verifies the module: after each pass (as yasps-opt does),
/// once after the last, or not at all (the caller verifies a later stage).
enum class Verification { EachPass, AtEnd, Deferred };

/// Runs `populate`'s passes on `module`; on failure the error carries
/// `what` and the diagnostics. Verifying large scenes after every pass
/// took 1.5 s of an 11 s cold compile (the README demo's kernels), so the
/// compile paths verify where the IR leaves them for LLVM.
llvm::Error runPasses(ModuleOp module, const std::string &what,
                      llvm::function_ref<LogicalResult(PassManager &)> populate,
                      Verification verification = Verification::EachPass);

/// A copy of `module` with loop kernels for `attributes` (scene-relative
/// paths; empty: every energy). `prePipeline` (a yasps-opt pipeline string,
/// e.g. "yasps-inline-reads,cse,yasps-differentiate") runs first, for
/// attributes that passes create. `lanes` > 1 evaluates that many
/// instances at once in SIMD lanes (CPU kernels); `projectionLanes` (0:
/// `lanes`) is the width of kernels that PSD-project a small matrix (see
/// yasps-lower-to-loops). Attribute buffers are f64 whatever the IR
/// computes in (the runtime holds values in f64); output buffers have type
/// `outStorage` ("f64", or "" for the IR's type: f32 local derivatives of an
/// f32 scene). A requested attribute that does not exist after
/// `prePipeline` is a MissingAttributeError.
llvm::Expected<OwningOpRef<ModuleOp>>
generateLoopKernels(ModuleOp module, const std::vector<std::string> &attributes,
                    llvm::StringRef prePipeline, int64_t lanes = 1,
                    int64_t projectionLanes = 0,
                    llvm::StringRef outStorage = "f64");

/// The widest float type the attributes of `module`'s scenes compute in, in
/// bits: 32 for a scene written in f32 throughout, else 64. CPU kernels fit
/// twice the lanes in a vector register at 32.
unsigned computeFloatBits(ModuleOp module);

/// The kernels' descriptions, read from the functions of
/// generateLoopKernels.
std::vector<KernelDescription> describeKernels(ModuleOp kernels);

/// A SHA-256 hex digest of `kernels` (generic form) and `extra`.
std::string hashKernels(ModuleOp kernels, llvm::StringRef extra);

/// Has `write` write a cache file under a temporary name, then renames it
/// to `path`, so that concurrent processes never read a partial file.
void storeAtomically(const std::string &path,
                     llvm::function_ref<void(llvm::StringRef)> write);

} // namespace mlir::yasps

#endif // YASPS_TARGET_KERNELGENERATION_H
