//===- yasps-fuzz.cpp - libFuzzer target over the yasps compiler ----------===//
//
// Treats each input as the text of a module and puts it through what a
// scene goes through when Python compiles it: parse and verify, the
// differentiation pipeline (inline reads, canonicalize, cse, differentiate,
// generate indices), loop kernels for each attribute the scene then has
// (yasps-lower-to-loops, one lane or four), and from there both back ends'
// lowerings: to the LLVM dialect (CPU) and to outlined gpu.func kernels
// (GPU). Machine code is not generated: that is LLVM's, not ours, and would
// make every input take seconds.
//
// A diagnostic is a correct answer to a malformed input; the fuzzer looks
// for what is not: crashes, sanitizer reports, leaks and inputs that run
// past its time limit. Only modules made of yasps scenes go past the
// parser, so that findings are in yasps code rather than in upstream
// dialects the fuzzer happens to spell.
//
// Built by scripts/sanitize.sh (clang, -fsanitize=fuzzer,address,undefined)
// and run by scripts/fuzz.sh; docs/robustness.md says how.
//
//===----------------------------------------------------------------------===//

#include "yasps/Conversion/LoopsToGPU/LoopsToGpuPipeline.h"
#include "yasps/Conversion/Passes.h"
#include "yasps/Conversion/YaspsToLoops/ScalarLowering.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"
#include "yasps/Dialect/Yasps/Transforms/Passes.h"
#include "yasps/Dialect/Yasps/Transforms/Pipelines.h"
#include "yasps/Target/CPU/CpuCompiler.h"
#include "yasps/Target/GPU/GpuCompiler.h"
#include "yasps/Target/KernelGeneration.h"

#include "mlir/IR/BuiltinOps.h"
#include "mlir/IR/Diagnostics.h"
#include "mlir/IR/MLIRContext.h"
#include "mlir/InitAllPasses.h"
#include "mlir/Parser/Parser.h"
#include "mlir/Pass/PassManager.h"
#include "mlir/Pass/PassRegistry.h"

#include "llvm/Support/raw_ostream.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

using namespace mlir;
using namespace mlir::yasps;

namespace {
/// One context for the whole run: dialect loading is the slow part of a
/// small input, and nothing an input does outlives its module.
MLIRContext &fuzzContext() {
  static MLIRContext *context = [] {
    // The pipelines are named in text, as Python names them.
    registerAllPasses();
    registerYaspsPasses();
    registerYaspsConversionPasses();
    registerDifferentiatePipeline();
    DialectRegistry registry;
    registerCpuCompilerDialects(registry);
    registerGpuCompilerDialects(registry);
    auto *ctx = new MLIRContext(registry, MLIRContext::Threading::DISABLED);
    ctx->loadAllAvailableDialects();
    return ctx;
  }();
  return *context;
}

/// Every computed attribute of the scene, as the scene-relative paths that
/// yasps-lower-to-loops takes ("@mesh::@primitive::@attr").
std::vector<std::string> attributePaths(SceneOp scene) {
  std::vector<std::string> paths;
  scene.walk([&](AttrOp attr) {
    llvm::raw_string_ostream(paths.emplace_back()) << getScenePath(attr);
  });
  return paths;
}

/// Runs `pipeline` (a textual pass pipeline) on `module`; false if it fails.
bool runPipeline(ModuleOp module, StringRef pipeline) {
  PassManager pm(module.getContext());
  if (failed(parsePassPipeline(pipeline, pm)))
    return false;
  return succeeded(pm.run(module));
}

/// Kernel ops one input may generate in all (see fuzzOne).
constexpr int64_t kMaxOperationsPerInput = 2 * kMaxKernelOperations;

/// Deeper bracket nesting than any scene has (a scene, a mesh, a primitive,
/// an attribute and its expressions nest a dozen levels at most).
constexpr int kMaxNesting = 64;

/// Whether `text` nests brackets deeper than kMaxNesting. MLIR's parser
/// recurses once per level (types in types, attributes in attributes) and
/// overflows the stack near a few thousand: that is upstream's limit, and
/// an input that reaches it says nothing about yasps.
bool nestsTooDeep(StringRef text) {
  int depth = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    char c = text[i];
    if (c == '(' || c == '[' || c == '{' || c == '<')
      ++depth;
    else if (c == ')' || c == ']' || c == '}' ||
             (c == '>' && (i == 0 || text[i - 1] != '-')))
      --depth;
    if (depth > kMaxNesting)
      return true;
  }
  return false;
}

void fuzzOne(StringRef text) {
  if (nestsTooDeep(text))
    return;
  MLIRContext &context = fuzzContext();
  // Diagnostics are expected on most inputs; printing them would only
  // slow the fuzzer down.
  ScopedDiagnosticHandler silence(&context,
                                  [](Diagnostic &) { return success(); });
  OwningOpRef<ModuleOp> module = parseSourceString<ModuleOp>(text, &context);
  if (!module)
    return;
  auto &body = module->getBody()->getOperations();
  if (body.size() != 1 || !isa<SceneOp>(body.front()))
    return;

  // The input's length picks the variants, so a finding reproduces.
  bool separate = text.size() % 3 == 0;
  int64_t lanes = text.size() % 2 ? 4 : 1;
  if (!runPipeline(*module, separate ? "yasps-differentiate-pipeline{hessian-"
                                       "factors=always}"
                                     : "yasps-differentiate-pipeline{hessian-"
                                       "factors=auto}"))
    return;
  // One attribute at a time, as Python requests them, until the kernels
  // made so far hold kMaxOperationsPerInput ops: each kernel is bounded by
  // yasps-lower-to-loops' own limit, and this bounds an input of many.
  int64_t operations = 0;
  for (const std::string &attribute :
       attributePaths(cast<SceneOp>(module->getBody()->front()))) {
    if (operations > kMaxOperationsPerInput)
      break;
    auto kernels = generateLoopKernels(*module, {attribute}, "", lanes);
    if (!kernels) {
      // It may have failed at the kernel limit, after emitting that much:
      // charged as if it had (the error's kind is not asked of its text).
      operations += kMaxKernelOperations;
      llvm::consumeError(kernels.takeError());
      continue;
    }
    (*kernels)->walk([&](Operation *) { ++operations; });
    (void)describeKernels(**kernels);
    OwningOpRef<ModuleOp> gpu(cast<ModuleOp>((*kernels)->clone()));
    (void)runPipeline(**kernels, getCpuLoweringPipeline());
    PassManager pm(&context);
    buildLoopsToGpuKernelsPipeline(pm, kDefaultThreadsPerBlock);
    (void)pm.run(*gpu);
  }
}
} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  // MLIR's lexer stops at a NUL past the end of the buffer; libFuzzer's data
  // has none, so the text is copied into a string, which does.
  std::string text(reinterpret_cast<const char *>(data), size);
  fuzzOne(text);
  return 0;
}
