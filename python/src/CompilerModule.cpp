//===- CompilerModule.cpp - Python bindings over the yasps compiler -------===//
//
// The extension module `_yasps_compiler`, the one that links MLIR (the
// runtime's is RuntimeModule.cpp). A thin layer: Python owns the user API
// and emits textual yasps IR; this module parses it with the same dialect,
// verifiers and passes as yasps-opt, and compiles kernels from it.
// Diagnostics come back as the exception's message, formatted like
// yasps-opt's (location, severity, message, source line).
//
//===----------------------------------------------------------------------===//

#include "mlir/AsmParser/AsmParser.h"
#include "mlir/IR/Diagnostics.h"
#include "mlir/IR/MLIRContext.h"
#include "mlir/IR/OwningOpRef.h"
#include "mlir/IR/Verifier.h"
#include "mlir/Parser/Parser.h"
#include "mlir/Pass/PassManager.h"
#include "mlir/Pass/PassRegistry.h"
#include "mlir/Transforms/Passes.h"
#include "llvm/ADT/StringExtras.h"
#include "llvm/Support/SHA256.h"
#include "llvm/Support/SourceMgr.h"
#include "llvm/Support/raw_ostream.h"

#include "mlir/Conversion/Passes.h"
#include "yasps/Conversion/Passes.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"
#include "yasps/Dialect/Yasps/Transforms/Passes.h"
#include "yasps/Dialect/Yasps/Transforms/Pipelines.h"
#include "yasps/Runtime/Support/CpuKernel.h"
#include "yasps/Target/CPU/CpuCompiler.h"
#include "yasps/Target/CPU/CpuSourceCache.h"
#include "yasps/Target/GPU/GpuCompiler.h"
#include "yasps/Target/KernelGeneration.h"

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/map.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <list>
#include <map>
#include <memory>

#include <mutex>
#include <stdexcept>
#include <string>
#include <tuple>

namespace nb = nanobind;
using namespace mlir;

namespace {

/// Raised for IR that does not parse or verify, or a pipeline that fails.
struct IRError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Raised when a kernel is requested for an attribute that does not exist
/// (mlir::yasps::MissingAttributeError); Python sees `symbol`.
struct MissingAttribute : IRError {
  MissingAttribute(const std::string &message, std::string symbol)
      : IRError(message), symbol(std::move(symbol)) {}
  std::string symbol;
};

/// One context for the process: dialects and passes are registered once.
MLIRContext &getContext() {
  static MLIRContext *context = [] {
    DialectRegistry registry;
    mlir::yasps::registerCpuCompilerDialects(registry);
    mlir::yasps::registerGpuCompilerDialects(registry);
    auto *ctx = new MLIRContext(registry, MLIRContext::Threading::DISABLED);
    ctx->loadAllAvailableDialects();
    // Diagnostics quote the user's line; the generic form of the op adds
    // nothing for a scene author.
    ctx->printOpOnDiagnostic(false);
    mlir::yasps::registerYaspsPasses();
    mlir::yasps::registerDifferentiatePipeline();
    mlir::yasps::registerYaspsConversionPasses();
    registerTransformsPasses();
    registerConversionPasses();
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

/// Parses and verifies `ir` into the shared context; the caller holds the
/// lock and the source manager that diagnostics refer to.
OwningOpRef<ModuleOp> parseVerified(const std::string &ir,
                                    const std::string &bufferName,
                                    llvm::SourceMgr &sourceMgr,
                                    DiagnosticCollector &diagnostics) {
  sourceMgr.AddNewSourceBuffer(
      llvm::MemoryBuffer::getMemBufferCopy(ir, bufferName), llvm::SMLoc());
  OwningOpRef<ModuleOp> module =
      parseSourceFile<ModuleOp>(sourceMgr, ParserConfig(&getContext()));
  if (!module)
    throw IRError(diagnostics.take());
  return module;
}

/// Runs a textual pass pipeline on `module`; throws std::invalid_argument
/// for a pipeline that does not parse and IRError with the diagnostics if a
/// pass fails. An empty pipeline still runs the verifier.
void applyPipeline(ModuleOp module, const std::string &pipeline,
                   DiagnosticCollector &diagnostics) {
  PassManager pm(module.getContext(), ModuleOp::getOperationName(),
                 OpPassManager::Nesting::Implicit);
  std::string errors;
  llvm::raw_string_ostream errorStream(errors);
  if (failed(parsePassPipeline(pipeline, pm, errorStream)))
    throw std::invalid_argument("invalid pass pipeline '" + pipeline +
                                "': " + errors);
  if (failed(pm.run(module)))
    throw IRError(diagnostics.take());
}

/// Parses and verifies `ir`, then runs `pipeline` (textual pass pipeline on
/// the module, e.g. "yasps-inline-reads,cse"; empty for none) and returns the
/// printed result.
std::string runPipeline(const std::string &ir, const std::string &pipeline,
                        const std::string &bufferName) {
  std::lock_guard<std::mutex> guard(getLock());
  MLIRContext &context = getContext();
  llvm::SourceMgr sourceMgr;
  DiagnosticCollector diagnostics(context, sourceMgr);
  OwningOpRef<ModuleOp> module =
      parseVerified(ir, bufferName, sourceMgr, diagnostics);

  applyPipeline(*module, pipeline, diagnostics);
  return printModule(*module);
}

/// Compiled CPU kernels of one scene, with what launching them needs.
struct CpuLibrary {
  std::shared_ptr<mlir::yasps::CpuKernelLibrary> library;
  mlir::yasps::CpuCompileStats stats;

  const mlir::yasps::CpuKernel &kernel(const std::string &attribute) const {
    const mlir::yasps::CpuKernel *found = library->lookup(attribute);
    if (!found)
      throw std::invalid_argument("no compiled kernel for " + attribute);
    return *found;
  }
};

/// Scenes after their pre-pipeline (the differentiation pipeline), by the
/// hash of their IR text (without its location definitions) and the
/// pipeline. Every request for a scene's kernels, and every question about
/// its parameters, starts from one parse and one run of the pipeline
/// instead of repeating both (a scene's energies are requested one by one).
/// The caller holds getLock(); the few newest scenes are kept.
class PreparedScenes {
public:
  static constexpr size_t kCapacity = 16;

  static std::string key(const std::string &ir, const std::string &pipeline) {
    std::string text = ir + '\0' + pipeline;
    std::array<uint8_t, 32> hash = llvm::SHA256::hash(llvm::ArrayRef(
        reinterpret_cast<const uint8_t *>(text.data()), text.size()));
    return llvm::toHex(hash, /*LowerCase=*/true);
  }

  /// The prepared scene of `key`, or null.
  ModuleOp find(const std::string &key) {
    for (auto it = entries.begin(); it != entries.end(); ++it)
      if (it->first == key) {
        entries.splice(entries.begin(), entries, it);
        return *entries.front().second;
      }
    return nullptr;
  }

  ModuleOp insert(const std::string &key, OwningOpRef<ModuleOp> module) {
    entries.emplace_front(key, std::move(module));
    if (entries.size() > kCapacity)
      entries.pop_back();
    return *entries.front().second;
  }

private:
  std::list<std::pair<std::string, OwningOpRef<ModuleOp>>> entries;
};

PreparedScenes &preparedScenes() {
  static auto *scenes = new PreparedScenes();
  return *scenes;
}

/// Returns `compile(scene)`'s library, `scene` being `ir` (parsed with the
/// location definitions `locations` and verified) after `pipeline`, from
/// the prepared scenes or prepared now; a failure, with the diagnostics
/// collected meanwhile, becomes an IRError (MissingAttribute for an
/// attribute that does not exist).
template <typename Compile>
auto compilePrepared(const std::string &ir, const std::string &locations,
                     const std::string &pipeline, const std::string &bufferName,
                     Compile compile) {
  std::lock_guard<std::mutex> guard(getLock());
  llvm::SourceMgr sourceMgr;
  DiagnosticCollector diagnostics(getContext(), sourceMgr);
  std::string key = PreparedScenes::key(ir, pipeline);
  using Result = decltype(compile(ModuleOp()));
  auto prepareAndCompile = [&]() -> Result {
    ModuleOp scene = preparedScenes().find(key);
    if (!scene) {
      OwningOpRef<ModuleOp> parsed =
          parseVerified(ir + locations, bufferName, sourceMgr, diagnostics);
      // The differentiated scene is not verified here (0.5 s on the README
      // demo's scene): the loop kernels made from it are, before LLVM sees
      // them; yasps-opt, the lit tests and the fuzzer verify the
      // differentiation passes after each one.
      if (!pipeline.empty())
        if (llvm::Error err = mlir::yasps::runPasses(
                *parsed, "kernel generation failed",
                [&](PassManager &pm) {
                  return parsePassPipeline(pipeline, pm);
                },
                mlir::yasps::Verification::Deferred))
          return std::move(err);
      scene = preparedScenes().insert(key, std::move(parsed));
    }
    return compile(scene);
  };
  Result library = prepareAndCompile();
  if (!library) {
    std::string message, missing;
    llvm::handleAllErrors(
        library.takeError(),
        [&](const mlir::yasps::MissingAttributeError &error) {
          message = error.message();
          missing = error.getSymbol();
        },
        [&](const llvm::ErrorInfoBase &error) { message = error.message(); });
    message = diagnostics.take() + message;
    if (!missing.empty())
      throw MissingAttribute(message, missing);
    throw IRError(message);
  }
  return *library;
}

/// `ir` names what is compiled and is the request's key; `locations` (the
/// definitions of the location aliases `ir` refers to) is parsed after it
/// for diagnostics but is no part of any key.
CpuLibrary compileCpu(const std::string &ir,
                      const std::vector<std::string> &attributes,
                      const std::string &cacheDir, unsigned optLevel,
                      const std::string &bufferName,
                      const std::string &prePipeline, int64_t lanes,
                      const std::string &locations,
                      std::optional<nb::callable> onKernelCompiled,
                      const std::string &cpu) {
  mlir::yasps::CpuCompileOptions options;
  options.cacheDir = cacheDir;
  options.optLevel = optLevel;
  options.lanes = lanes;
  options.targetCpu = cpu;
  if (onKernelCompiled)
    options.onKernelCompiled = [&](const std::string &attribute) {
      nb::gil_scoped_acquire acquire;
      try {
        (*onKernelCompiled)(attribute);
      } catch (nb::python_error &error) {
        // A failing progress display does not fail the compilation.
        error.discard_as_unraisable("yasps progress callback");
      }
    };
  // The callback runs on the compiler's threads: they need the GIL, so
  // this thread lets go of it while compiling.
  nb::gil_scoped_release release;
  CpuLibrary result;
  // A request met before (in this or an earlier process) loads its object
  // without parsing or lowering anything.
  std::string source =
      mlir::yasps::cpuSourceKey(ir, attributes, prePipeline, options);
  if ((result.library =
           mlir::yasps::lookupCpuSource(source, options, result.stats)))
    return result;
  result.library = compilePrepared(
      ir, locations, prePipeline, bufferName, [&](ModuleOp scene) {
        auto library = mlir::yasps::compileCpuKernels(
            scene, attributes, options, &result.stats, /*prePipeline=*/"");
        if (library)
          mlir::yasps::recordCpuSource(source, **library, options);
        return library;
      });
  return result;
}

/// Compiled GPU kernels: binaries and launch descriptions (no device needed).
struct GpuLibrary {
  std::shared_ptr<mlir::yasps::GpuKernelLibrary> library;
  mlir::yasps::GpuCompileStats stats;
};

GpuLibrary
compileGpu(const std::string &ir, const std::vector<std::string> &attributes,
           const std::vector<std::string> &chips, bool keepPtx,
           const std::string &cacheDir, const std::string &bufferName,
           const std::string &prePipeline, const std::string &locations) {
  mlir::yasps::GpuCompileOptions options;
  options.chips = chips;
  options.keepPtx = keepPtx;
  options.cacheDir = cacheDir;
  GpuLibrary result;
  result.library = compilePrepared(
      ir, locations, prePipeline, bufferName, [&](ModuleOp scene) {
        return mlir::yasps::compileGpuKernels(scene, attributes, options,
                                              &result.stats,
                                              /*prePipeline=*/"");
      });
  return result;
}

/// A CPU kernel's entry point and the type of each of its buffers, for the
/// runtime module's launch_cpu_kernel: int32 (i) for conn, int64 (q) for
/// offsets and dof_offsets, float32 (f) for an f32 kernel's out, float64
/// (d) for the rest.
std::pair<std::uintptr_t, std::string> cpuEntry(const CpuLibrary &self,
                                                const std::string &attribute) {
  const mlir::yasps::CpuKernel &kernel = self.kernel(attribute);
  std::string codes;
  for (const auto &argument : kernel.arguments) {
    using mlir::yasps::KernelArgKind;
    switch (argument.kind) {
    case KernelArgKind::conn:
      codes += 'i';
      break;
    case KernelArgKind::offsets:
    case KernelArgKind::dof_offsets:
      codes += 'q';
      break;
    case KernelArgKind::out:
      codes += kernel.outType == "f32" ? 'f' : 'd';
      break;
    case KernelArgKind::attr:
      codes += 'd';
      break;
    }
  }
  return {reinterpret_cast<std::uintptr_t>(kernel.packed), codes};
}

/// The `yasps.params` of attributes after running `pipeline`: one list of
/// printed fields per parameter slot.
std::vector<std::vector<std::vector<std::string>>>
attributeParams(const std::string &ir, const std::string &pipeline,
                const std::vector<std::string> &paths,
                const std::string &bufferName, const std::string &locations) {
  using Slots = std::vector<std::vector<std::vector<std::string>>>;
  return compilePrepared(
      ir, locations, pipeline, bufferName,
      [&](ModuleOp scene) -> llvm::Expected<Slots> {
        Slots result;
        auto scenes = scene.getOps<mlir::yasps::SceneOp>();
        for (const std::string &text : paths) {
          auto path = dyn_cast_or_null<SymbolRefAttr>(
              parseAttribute(text, scene.getContext()));
          Operation *decl =
              path && !scenes.empty()
                  ? mlir::yasps::lookupInScene(*scenes.begin(), path)
                  : nullptr;
          auto params =
              decl ? decl->getAttrOfType<ArrayAttr>(::mlir::yasps::kParamsAttr)
                   : ArrayAttr();
          result.push_back(mlir::yasps::describeParams(params));
        }
        return result;
      });
}

} // namespace

NB_MODULE(_yasps_compiler, m) {
  m.doc() = "Bindings over the yasps MLIR compiler: parsing, verification, "
            "passes, CPU kernels (compiled and launched) and GPU binaries.";

  // The dialect's kinds of kernel buffer arguments: kernels' argument lists
  // carry them as this enum, not as strings.
  nb::enum_<mlir::yasps::KernelArgKind>(
      m, "KernelArgKind", "What a buffer argument of a generated kernel holds")
      .value("out", mlir::yasps::KernelArgKind::out)
      .value("attr", mlir::yasps::KernelArgKind::attr)
      .value("conn", mlir::yasps::KernelArgKind::conn)
      .value("offsets", mlir::yasps::KernelArgKind::offsets)
      .value("dof_offsets", mlir::yasps::KernelArgKind::dof_offsets);

  nb::exception<IRError> irError(m, "IRError", PyExc_ValueError);
  nb::exception<MissingAttribute> missingAttribute(m, "MissingAttributeError",
                                                   irError);
  // Registered after (so tried before) the translator above, which only
  // sets the message: this one also gives the exception its `symbol`.
  nb::register_exception_translator(
      [](const std::exception_ptr &p, void *type) {
        try {
          std::rethrow_exception(p);
        } catch (const MissingAttribute &e) {
          nb::object error =
              nb::borrow(static_cast<PyObject *>(type))(e.what());
          error.attr("symbol") = e.symbol;
          PyErr_SetObject(static_cast<PyObject *>(type), error.ptr());
        }
      },
      missingAttribute.ptr());

  m.def(
      "verify",
      [](const std::string &ir, const std::string &name) {
        runPipeline(ir, "", name);
      },
      nb::arg("ir"), nb::arg("name") = "<yasps>",
      "Parses and verifies yasps IR; raises IRError with the diagnostics.");
  nb::class_<CpuLibrary>(m, "CpuLibrary",
                         "Compiled CPU kernels of a scene's attributes.")
      .def_prop_ro(
          "kernels",
          [](const CpuLibrary &self) {
            std::vector<std::pair<
                std::string, std::vector<std::pair<mlir::yasps::KernelArgKind,
                                                   std::string>>>>
                out;
            for (const auto &kernel : self.library->kernels()) {
              std::vector<std::pair<mlir::yasps::KernelArgKind, std::string>>
                  args;
              for (const auto &arg : kernel.arguments)
                args.emplace_back(arg.kind, arg.path);
              out.emplace_back(kernel.attribute, args);
            }
            return out;
          },
          "[(attribute path, [(kind, path), ...])] per kernel")
      .def(
          "params",
          [](const CpuLibrary &self, const std::string &attribute) {
            return self.kernel(attribute).params;
          },
          nb::arg("attribute"),
          "Local parameters of a derivative attribute's kernel")
      .def(
          "shape",
          [](const CpuLibrary &self, const std::string &attribute) {
            const auto &kernel = self.kernel(attribute);
            return std::make_pair(kernel.rows, kernel.cols);
          },
          nb::arg("attribute"),
          "(rows, cols) of each instance's value computed by a kernel")
      .def(
          "projection",
          [](const CpuLibrary &self, const std::string &attribute) {
            return self.kernel(attribute).projection;
          },
          nb::arg("attribute"),
          "How a projected Hessian's kernel projects: 'full', 'reduced', "
          "'separate', or '' for other kernels")
      .def(
          "out_type",
          [](const CpuLibrary &self, const std::string &attribute) {
            return self.kernel(attribute).outType;
          },
          nb::arg("attribute"),
          "The float type of a kernel's output buffer: 'f64' or 'f32' (the "
          "local derivatives of an f32 scene)")
      .def(
          "op_counts",
          [](const CpuLibrary &self, const std::string &attribute) {
            return self.kernel(attribute).opCounts;
          },
          nb::arg("attribute"),
          "Static arithmetic op counts of a kernel (mul, add, div, math)")
      .def_prop_ro(
          "stats",
          [](const CpuLibrary &self) {
            nb::dict d;
            d["from_memory"] = self.stats.fromMemory;
            d["from_disk"] = self.stats.fromDisk;
            d["from_source"] = self.stats.fromSource;
            d["lower_seconds"] = self.stats.lowerSeconds;
            d["codegen_seconds"] = self.stats.codegenSeconds;
            d["key"] = self.stats.key;
            return d;
          },
          "how the compilation went (cache hits, times, cache key)")
      .def_prop_ro(
          "objects",
          [](const CpuLibrary &self) {
            std::vector<std::tuple<std::string, std::string, std::string>> out;
            for (const auto &kernel : self.library->kernels())
              out.emplace_back(kernel.attribute, kernel.symbol,
                               kernel.objectKey);
            return out;
          },
          "[(attribute path, symbol, object key)] per kernel: its object is "
          "<cache_dir>/<object key>.o, its packed entry point _mlir_<symbol>")
      .def("entry", &cpuEntry, nb::arg("attribute"),
           "(entry point, buffer codes) of an attribute's kernel, for the "
           "runtime's launch_cpu_kernel; valid while the library lives");

  nb::class_<GpuLibrary>(m, "GpuLibrary",
                         "Compiled GPU kernels of a scene's attributes.")
      .def_prop_ro(
          "kernels",
          [](const GpuLibrary &self) {
            nb::list out;
            for (const auto &kernel : self.library->kernels) {
              nb::dict d;
              d["attribute"] = kernel.attribute;
              d["name"] = kernel.kernelName;
              d["threads_per_block"] = kernel.threadsPerBlock;
              d["rows"] = kernel.rows;
              d["cols"] = kernel.cols;
              d["projection"] = kernel.projection;
              nb::list args, params;
              for (const auto &arg : kernel.arguments)
                args.append(nb::make_tuple(arg.kind, arg.path));
              using Kind = ::yasps::runtime::GpuParam::Kind;
              for (const auto &param : kernel.launchParams)
                params.append(nb::make_tuple(
                    ::yasps::runtime::gpuParamKindName(param.kind),
                    param.kind == Kind::Constant ? param.value
                                                 : param.argument));
              d["arguments"] = args;
              d["launch_params"] = params;
              out.append(d);
            }
            return out;
          },
          "one dict per kernel: attribute, name (entry point), "
          "threads_per_block, rows and cols of each instance's value, "
          "projection (as CpuLibrary.projection), arguments [(kind, path)], "
          "launch_params "
          "[('index'|'buffer', loop-kernel argument) or ('constant', value)]")
      .def_prop_ro(
          "binaries",
          [](const GpuLibrary &self) {
            nb::list out;
            for (const auto &binary : self.library->binaries)
              out.append(nb::make_tuple(
                  binary.chip, binary.format,
                  nb::bytes(binary.bytes.data(), binary.bytes.size())));
            return out;
          },
          "[(chip, 'cubin'|'ptx', bytes)]")
      .def_prop_ro(
          "stats",
          [](const GpuLibrary &self) {
            nb::dict d;
            d["from_disk"] = self.stats.fromDisk;
            d["lower_seconds"] = self.stats.lowerSeconds;
            d["serialize_seconds"] = self.stats.serializeSeconds;
            d["key"] = self.stats.key;
            return d;
          },
          "how the compilation went (cache hit, times, cache key)");
  m.def("compile_gpu", &compileGpu, nb::arg("ir"), nb::arg("attributes"),
        nb::arg("chips"), nb::arg("keep_ptx") = true, nb::arg("cache_dir") = "",
        nb::arg("name") = "<yasps>", nb::arg("pre_pipeline") = "",
        nb::arg("locations") = "",
        "Compiles GPU kernels (cubins per chip, PTX of the newest) for the "
        "attributes of the IR's scene; needs the CUDA toolkit's ptxas, not "
        "a GPU. Raises MissingAttributeError (.symbol) for an attribute that "
        "does not exist after pre_pipeline, IRError for other failures.");
  m.def("compile_cpu", &compileCpu, nb::arg("ir"), nb::arg("attributes"),
        nb::arg("cache_dir") = "", nb::arg("opt_level") = 3,
        nb::arg("name") = "<yasps>", nb::arg("pre_pipeline") = "",
        nb::arg("lanes") = 0, nb::arg("locations") = "",
        nb::arg("on_kernel_compiled") = nb::none(), nb::arg("cpu") = "",
        "Compiles CPU kernels for the attributes (scene-relative paths) of "
        "the IR's scene, reusing in-memory and on-disk caches keyed by the "
        "IR; locations: the definitions of the location aliases it refers "
        "to (parsed after it, for diagnostics, and in no key); "
        "on_kernel_compiled(attribute): called as each kernel's machine "
        "code is made (for progress; not for kernels found in a cache). "
        "lanes: instances evaluated together in SIMD lanes (0: the host's "
        "vector width in doubles; 1: one at a time); cpu: an LLVM CPU name "
        "to compile for instead of this host (e.g. 'x86-64-v3'). Raises "
        "MissingAttributeError (.symbol) for an attribute that does not exist "
        "after pre_pipeline, IRError for other failures.");
  m.def("cpu_kernels_compiled", &mlir::yasps::cpuKernelsCompiled,
        "Kernels this process has compiled to machine code for the CPU "
        "(each is compiled once and cached on its own)");
  m.def("host_double_lanes", &mlir::yasps::hostDoubleLanes,
        "f64 lanes of the host's widest vector registers");
  m.def("attribute_params", &attributeParams, nb::arg("ir"),
        nb::arg("pipeline"), nb::arg("paths"), nb::arg("name") = "<yasps>",
        nb::arg("locations") = "",
        "yasps.params of the attributes (e.g. derivative attributes) after "
        "running a pass pipeline; empty lists for attributes without them. "
        "The scene after the pipeline is kept for the kernel requests that "
        "follow (keyed by ir and pipeline, not locations).");
  m.def(
      "cpu_lowering_pipeline",
      [] { return mlir::yasps::getCpuLoweringPipeline().str(); },
      "The pass pipeline from kernel functions to the LLVM dialect.");

  m.def("run_pipeline", &runPipeline, nb::arg("ir"), nb::arg("pipeline"),
        nb::arg("name") = "<yasps>",
        "Parses and verifies yasps IR, runs a textual pass pipeline on the "
        "module (e.g. 'yasps-inline-reads,cse') and returns the printed IR.");
}
