//===- YaspsNative.cpp - Python bindings over the yasps compiler ----------===//
//
// A thin layer: Python owns the user API and emits textual yasps IR; this
// module parses it with the same dialect, verifiers and passes as yasps-opt.
// Diagnostics come back as the exception's message, formatted like
// yasps-opt's (location, severity, message, source line).
//
//===----------------------------------------------------------------------===//

#include "mlir/IR/Diagnostics.h"
#include "mlir/IR/MLIRContext.h"
#include "mlir/IR/OwningOpRef.h"
#include "mlir/IR/Verifier.h"
#include "mlir/Parser/Parser.h"
#include "mlir/Pass/PassManager.h"
#include "mlir/Pass/PassRegistry.h"
#include "mlir/Transforms/Passes.h"
#include "llvm/Support/SourceMgr.h"
#include "llvm/Support/raw_ostream.h"

#include "yasps/Dialect/Yasps/IR/Yasps.h"
#include "yasps/Dialect/Yasps/Transforms/Passes.h"

#include <nanobind/nanobind.h>
#include <nanobind/stl/string.h>

#include <mutex>
#include <stdexcept>
#include <string>

namespace nb = nanobind;
using namespace mlir;

namespace {

/// Raised for IR that does not parse or verify, or a pipeline that fails.
struct IRError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// One context for the process: dialects and passes are registered once.
MLIRContext &getContext() {
  static MLIRContext *context = [] {
    DialectRegistry registry;
    registry.insert<yasps::YaspsDialect>();
    auto *ctx = new MLIRContext(registry, MLIRContext::Threading::DISABLED);
    ctx->loadAllAvailableDialects();
    // Diagnostics quote the user's line; the generic form of the op adds
    // nothing for a scene author.
    ctx->printOpOnDiagnostic(false);
    yasps::registerYaspsPasses();
    registerTransformsPasses();
    return ctx;
  }();
  return *context;
}

std::mutex &getLock() {
  static std::mutex lock;
  return lock;
}

/// Collects diagnostics, printed with their source lines, into a string.
class DiagnosticCollector {
public:
  DiagnosticCollector(MLIRContext &context, llvm::SourceMgr &sourceMgr)
      : os(text), handler(sourceMgr, &context, os) {}
  std::string take() { return text; }

private:
  std::string text;
  llvm::raw_string_ostream os;
  SourceMgrDiagnosticHandler handler;
};

std::string printModule(ModuleOp module) {
  std::string out;
  llvm::raw_string_ostream os(out);
  module.print(os);
  return out;
}

/// Parses and verifies `ir`, then runs `pipeline` (textual pass pipeline on
/// the module, e.g. "yasps-inline-reads,cse"; empty for none) and returns the
/// printed result.
std::string runPipeline(const std::string &ir, const std::string &pipeline,
                        const std::string &bufferName) {
  std::lock_guard<std::mutex> guard(getLock());
  MLIRContext &context = getContext();
  llvm::SourceMgr sourceMgr;
  sourceMgr.AddNewSourceBuffer(
      llvm::MemoryBuffer::getMemBufferCopy(ir, bufferName), llvm::SMLoc());
  DiagnosticCollector diagnostics(context, sourceMgr);

  OwningOpRef<ModuleOp> module =
      parseSourceFile<ModuleOp>(sourceMgr, ParserConfig(&context));
  if (!module)
    throw IRError(diagnostics.take());

  PassManager pm(&context, ModuleOp::getOperationName(),
                 OpPassManager::Nesting::Implicit);
  std::string errors;
  llvm::raw_string_ostream errorStream(errors);
  if (failed(parsePassPipeline(pipeline, pm, errorStream)))
    throw std::invalid_argument("invalid pass pipeline '" + pipeline +
                                "': " + errors);
  // An empty pipeline still runs the verifier.
  if (failed(pm.run(*module)))
    throw IRError(diagnostics.take());
  return printModule(*module);
}

} // namespace

NB_MODULE(_yasps_native, m) {
  m.doc() = "Bindings over the yasps MLIR compiler (parse, verify, passes).";

  nb::exception<IRError>(m, "IRError", PyExc_ValueError);

  m.def(
      "verify",
      [](const std::string &ir, const std::string &name) {
        runPipeline(ir, "", name);
      },
      nb::arg("ir"), nb::arg("name") = "<yasps>",
      "Parses and verifies yasps IR; raises IRError with the diagnostics.");
  m.def("run_pipeline", &runPipeline, nb::arg("ir"), nb::arg("pipeline"),
        nb::arg("name") = "<yasps>",
        "Parses and verifies yasps IR, runs a textual pass pipeline on the "
        "module (e.g. 'yasps-inline-reads,cse') and returns the printed IR.");
}
