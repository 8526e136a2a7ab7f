//===- YaspsNative.cpp - Python bindings over the yasps compiler ----------===//
//
// A thin layer: Python owns the user API and emits textual yasps IR; this
// module parses it with the same dialect, verifiers and passes as yasps-opt.
// Diagnostics come back as the exception's message, formatted like
// yasps-opt's (location, severity, message, source line).
//
//===----------------------------------------------------------------------===//

#include "GpuRuntimeBindings.h"

#include "mlir/AsmParser/AsmParser.h"
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

#include "mlir/Conversion/Passes.h"
#include "yasps/Conversion/Passes.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"
#include "yasps/Dialect/Yasps/Transforms/Passes.h"
#include "yasps/Dialect/Yasps/Transforms/Pipelines.h"
#include "yasps/Runtime/CpuKernel.h"
#include "yasps/Runtime/GlobalSystem.h"
#include "yasps/Runtime/LocalCompression.h"
#include "yasps/Runtime/ThreadPool.h"
#include "yasps/Target/CPU/CpuCompiler.h"
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

#include <map>
#include <memory>

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

/// Parses and verifies `ir`, then returns `compile(module)`'s library; its
/// error, with the diagnostics collected meanwhile, becomes an IRError.
template <typename Compile>
auto compileVerified(const std::string &ir, const std::string &bufferName,
                     Compile compile) {
  std::lock_guard<std::mutex> guard(getLock());
  llvm::SourceMgr sourceMgr;
  DiagnosticCollector diagnostics(getContext(), sourceMgr);
  OwningOpRef<ModuleOp> module =
      parseVerified(ir, bufferName, sourceMgr, diagnostics);
  auto library = compile(*module);
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

CpuLibrary compileCpu(const std::string &ir,
                      const std::vector<std::string> &attributes,
                      const std::string &cacheDir, unsigned optLevel,
                      const std::string &bufferName,
                      const std::string &prePipeline, int64_t lanes) {
  mlir::yasps::CpuCompileOptions options;
  options.cacheDir = cacheDir;
  options.optLevel = optLevel;
  options.lanes = lanes;
  CpuLibrary result;
  result.library = compileVerified(ir, bufferName, [&](ModuleOp module) {
    return mlir::yasps::compileCpuKernels(module, attributes, options,
                                          &result.stats, prePipeline);
  });
  return result;
}

/// Compiled GPU kernels: binaries and launch descriptions (no device needed).
struct GpuLibrary {
  std::shared_ptr<mlir::yasps::GpuKernelLibrary> library;
  mlir::yasps::GpuCompileStats stats;
};

GpuLibrary compileGpu(const std::string &ir,
                      const std::vector<std::string> &attributes,
                      const std::vector<std::string> &chips, bool keepPtx,
                      const std::string &cacheDir,
                      const std::string &bufferName,
                      const std::string &prePipeline) {
  mlir::yasps::GpuCompileOptions options;
  options.chips = chips;
  options.keepPtx = keepPtx;
  options.cacheDir = cacheDir;
  GpuLibrary result;
  result.library = compileVerified(ir, bufferName, [&](ModuleOp module) {
    return mlir::yasps::compileGpuKernels(module, attributes, options,
                                          &result.stats, prePipeline);
  });
  return result;
}

::yasps::runtime::ThreadPool &poolFor(unsigned threads) {
  if (threads == 0)
    return ::yasps::runtime::defaultThreadPool();
  static std::mutex lock;
  static std::map<unsigned, std::unique_ptr<::yasps::runtime::ThreadPool>>
      pools;
  std::lock_guard<std::mutex> guard(lock);
  auto &pool = pools[threads];
  if (!pool)
    pool = std::make_unique<::yasps::runtime::ThreadPool>(threads);
  return *pool;
}

using Buffer = nb::ndarray<nb::c_contig, nb::device::cpu>;

/// Runs the kernel of `attribute` on `numInstances` instances; `buffers`
/// follow the kernel's argument list (float64 for out/attr, int32 for
/// conn, int64 for offsets and dof_offsets).
void launchCpu(const CpuLibrary &self, const std::string &attribute,
               int64_t numInstances, const std::vector<Buffer> &buffers,
               unsigned threads) {
  const mlir::yasps::CpuKernel *kernel = &self.kernel(attribute);
  if (buffers.size() != kernel->arguments.size())
    throw std::invalid_argument("kernel for " + attribute + " takes " +
                                std::to_string(kernel->arguments.size()) +
                                " buffers, got " +
                                std::to_string(buffers.size()));
  std::vector<::yasps::runtime::KernelBuffer> args;
  for (size_t i = 0; i < buffers.size(); ++i) {
    const std::string &kind = kernel->arguments[i].kind;
    nb::dlpack::dtype expected = kind == "conn" ? nb::dtype<int32_t>()
                                 : kind == "offsets" || kind == "dof_offsets"
                                     ? nb::dtype<int64_t>()
                                     : nb::dtype<double>();
    if (buffers[i].dtype() != expected || buffers[i].ndim() != 1)
      throw std::invalid_argument("buffer " + std::to_string(i) + " (" + kind +
                                  " " + kernel->arguments[i].path +
                                  ") has the wrong dtype or rank");
    args.push_back({buffers[i].data(), (int64_t)buffers[i].shape(0)});
  }
  nb::gil_scoped_release release;
  ::yasps::runtime::launchCpuKernel(kernel->packed, args, numInstances,
                                    poolFor(threads), /*minChunk=*/256);
}

/// The `yasps.params` of attributes after running `pipeline`: one list of
/// printed fields per parameter slot.
std::vector<std::vector<std::vector<std::string>>>
attributeParams(const std::string &ir, const std::string &pipeline,
                const std::vector<std::string> &paths,
                const std::string &bufferName) {
  std::lock_guard<std::mutex> guard(getLock());
  MLIRContext &context = getContext();
  llvm::SourceMgr sourceMgr;
  DiagnosticCollector diagnostics(context, sourceMgr);
  OwningOpRef<ModuleOp> module =
      parseVerified(ir, bufferName, sourceMgr, diagnostics);
  applyPipeline(*module, pipeline, diagnostics);
  std::vector<std::vector<std::vector<std::string>>> result;
  auto scenes = module->getOps<mlir::yasps::SceneOp>();
  for (const std::string &text : paths) {
    auto path = dyn_cast_or_null<SymbolRefAttr>(parseAttribute(text, &context));
    Operation *decl = path && !scenes.empty()
                          ? mlir::yasps::lookupInScene(*scenes.begin(), path)
                          : nullptr;
    auto params =
        decl ? decl->getAttrOfType<ArrayAttr>("yasps.params") : ArrayAttr();
    std::vector<std::vector<std::string>> slots =
        mlir::yasps::describeParams(params);
    result.push_back(slots);
  }
  return result;
}

/// The global Newton system of a scene, over the C++ runtime.
class PySystem {
public:
  using Int64Array = nb::ndarray<int64_t, nb::c_contig, nb::device::cpu>;
  using DoubleArray = nb::ndarray<double, nb::c_contig, nb::device::cpu>;

  PySystem(Int64Array blockOffsets, std::vector<Int64Array> dofMaps) {
    ::yasps::runtime::BlockLayout layout;
    layout.blockOffset.assign(blockOffsets.data(),
                              blockOffsets.data() + blockOffsets.size());
    std::vector<::yasps::runtime::DofMap> maps =
        keep(dofMaps, staticMaps, staticShapes);
    system = std::make_unique<::yasps::runtime::GlobalSystem>(layout, maps);
  }

  /// Replaces the dynamic energies (numbered after the static ones).
  void setDynamic(std::vector<Int64Array> dofMaps) {
    std::vector<std::vector<int64_t>> kept;
    std::vector<std::pair<int64_t, int64_t>> shapes;
    std::vector<::yasps::runtime::DofMap> maps = keep(dofMaps, kept, shapes);
    system->setDynamic(maps);
    // The runtime points into the copies: keep them as long as it uses them.
    dynamicMaps = std::move(kept);
    dynamicShapes = std::move(shapes);
  }

  int64_t size() const { return system->size(); }
  const ::yasps::runtime::GlobalSystem &runtime() const { return *system; }
  size_t storedBlocks() const {
    return system->staticHessian().numStoredBlocks() +
           system->dynamicHessian().numStoredBlocks();
  }
  void setZero() { system->setZero(); }

  void add(size_t energy, DoubleArray gradients, DoubleArray hessians,
           unsigned threads) {
    if (energy >= system->numEnergies())
      throw std::invalid_argument("no energy " + std::to_string(energy));
    auto [count, n] = shape(energy);
    if (gradients.size() != size_t(count * n) ||
        hessians.size() != size_t(count * n * n))
      throw std::invalid_argument(
          "energy " + std::to_string(energy) + " expects " +
          std::to_string(count) + " gradients of " + std::to_string(n) +
          " and Hessians of " + std::to_string(n) + "x" + std::to_string(n));
    nb::gil_scoped_release release;
    system->add(energy, gradients.data(), hessians.data(), &poolFor(threads));
  }

  void addFactored(size_t energy, DoubleArray gradients, DoubleArray maps,
                   DoubleArray inner, int64_t m, unsigned threads) {
    if (energy >= system->numEnergies())
      throw std::invalid_argument("no energy " + std::to_string(energy));
    auto [count, n] = shape(energy);
    if (gradients.size() != size_t(count * n) ||
        maps.size() != size_t(count * m * n) ||
        inner.size() != size_t(count * m * m))
      throw std::invalid_argument(
          "energy " + std::to_string(energy) + " expects " +
          std::to_string(count) + " gradients of " + std::to_string(n) +
          ", inner maps of " + std::to_string(m) + "x" + std::to_string(n) +
          " and inner Hessians of " + std::to_string(m) + "x" +
          std::to_string(m));
    nb::gil_scoped_release release;
    system->addFactored(energy, gradients.data(), maps.data(), inner.data(), m,
                        &poolFor(threads));
  }

  void gradient(DoubleArray out) const {
    check(out, size_t(size()));
    std::copy(system->gradient().begin(), system->gradient().end(), out.data());
  }

  void dense(DoubleArray out) const {
    check(out, size_t(size() * size()));
    std::vector<double> d = system->toDense();
    std::copy(d.begin(), d.end(), out.data());
  }

  using MaskArray =
      nb::ndarray<uint8_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

  nb::tuple solve(DoubleArray out, double tolerance, int64_t maxIterations,
                  unsigned threads, std::optional<MaskArray> fixed) const {
    check(out, size_t(size()));
    ::yasps::runtime::PcgOptions options;
    options.relativeTolerance = tolerance;
    options.maxIterations = maxIterations;
    std::vector<uint8_t> mask;
    if (fixed) {
      mask.assign(fixed->data(), fixed->data() + fixed->shape(0));
      options.fixedDofs = &mask;
    }
    ::yasps::runtime::PcgResult result;
    {
      nb::gil_scoped_release release;
      result = system->solve(out.data(), options, poolFor(threads));
    }
    return nb::make_tuple(result.iterations, result.relativeResidual,
                          result.converged);
  }

  /// Scalar entries of the Hessian (both triangles, both parts; an entry
  /// of both parts counts twice).
  int64_t nonZeros() const {
    int64_t count = 0;
    for (const auto *H : system->hessianParts())
      for (size_t b = 0; b < H->numStoredBlocks(); ++b) {
        int64_t r = H->blockRow(b), c = H->blockCol(b);
        int64_t entries = H->layout().blockSize(r) * H->layout().blockSize(c);
        count += r == c ? entries : 2 * entries;
      }
    return count;
  }

  /// The Hessian in coordinate form, into arrays of nonZeros() entries
  /// (duplicates, from the two parts, are to be summed).
  void coordinates(Int64Array rows, Int64Array cols, DoubleArray values) const {
    size_t nnz = size_t(nonZeros());
    if (rows.size() != nnz || cols.size() != nnz)
      throw std::invalid_argument("coordinate arrays need " +
                                  std::to_string(nnz) + " entries");
    check(values, nnz);
    size_t k = 0;
    for (const auto *H : system->hessianParts()) {
      const auto &offset = H->layout().blockOffset;
      for (size_t b = 0; b < H->numStoredBlocks(); ++b) {
        int64_t r = H->blockRow(b), c = H->blockCol(b);
        int64_t nr = H->layout().blockSize(r), nc = H->layout().blockSize(c);
        const double *data = H->blockData(b);
        for (int64_t i = 0; i < nr; ++i)
          for (int64_t j = 0; j < nc; ++j) {
            rows.data()[k] = offset[r] + i;
            cols.data()[k] = offset[c] + j;
            values.data()[k++] = data[i * nc + j];
            if (r != c) {
              rows.data()[k] = offset[c] + j;
              cols.data()[k] = offset[r] + i;
              values.data()[k++] = data[i * nc + j];
            }
          }
      }
    }
  }

  /// y = H x with the runtime's SpMV.
  void multiply(DoubleArray x, DoubleArray y, unsigned threads) const {
    check(x, size_t(size()));
    check(y, size_t(size()));
    nb::gil_scoped_release release;
    system->multiply(x.data(), y.data(), poolFor(threads));
  }

private:
  static void check(const DoubleArray &out, size_t size) {
    if (out.size() != size)
      throw std::invalid_argument("output array of " +
                                  std::to_string(out.size()) +
                                  " entries, expected " + std::to_string(size));
  }
  /// Copies the DoF maps into `storage` (the runtime keeps no copy).
  static std::vector<::yasps::runtime::DofMap>
  keep(std::vector<Int64Array> &dofMaps,
       std::vector<std::vector<int64_t>> &storage,
       std::vector<std::pair<int64_t, int64_t>> &shapes) {
    std::vector<::yasps::runtime::DofMap> maps;
    storage.clear();
    shapes.clear();
    storage.reserve(dofMaps.size());
    for (Int64Array &map : dofMaps) {
      if (map.ndim() != 2)
        throw std::invalid_argument("a DoF map must be (count, params)");
      storage.emplace_back(map.data(), map.data() + map.size());
      shapes.emplace_back(map.shape(0), map.shape(1));
      maps.push_back({(int64_t)map.shape(0), (int64_t)map.shape(1),
                      storage.back().data()});
    }
    return maps;
  }
  std::pair<int64_t, int64_t> shape(size_t energy) const {
    bool isStatic = energy < staticMaps.size();
    const auto &maps = isStatic ? staticShapes : dynamicShapes;
    return maps[isStatic ? energy : energy - staticMaps.size()];
  }
  std::vector<std::vector<int64_t>> staticMaps, dynamicMaps;
  std::vector<std::pair<int64_t, int64_t>> staticShapes, dynamicShapes;
  std::unique_ptr<::yasps::runtime::GlobalSystem> system;
};

/// A NumPy array that owns `values`.
template <typename T>
nb::ndarray<nb::numpy, T> ownedArray(std::vector<T> &&values,
                                     std::vector<size_t> shape) {
  auto *heap = new std::vector<T>(std::move(values));
  nb::capsule owner(
      heap, [](void *p) noexcept { delete static_cast<std::vector<T> *>(p); });
  return nb::ndarray<nb::numpy, T>(heap->data(), shape.size(), shape.data(),
                                   owner);
}

using DofArray =
    nb::ndarray<int64_t, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using MatrixBatch =
    nb::ndarray<double, nb::ndim<3>, nb::c_contig, nb::device::cpu>;

/// The local Hessians compressed by DoF (paper 7.2), grouped by size: a
/// list of (k, instances, matrices (m, k, k)).
nb::list compressLocalHessians(DofArray dofs, MatrixBatch hessians) {
  int64_t count = dofs.shape(0), n = dofs.shape(1);
  if (hessians.shape(0) != size_t(count) || hessians.shape(1) != size_t(n) ||
      hessians.shape(2) != size_t(n))
    throw std::invalid_argument("hessians must be (count, n, n) for DoF maps "
                                "of (count, n)");
  std::vector<::yasps::runtime::CompressedBatch> batches;
  {
    nb::gil_scoped_release release;
    batches = ::yasps::runtime::compressLocalHessians(count, n, dofs.data(),
                                                      hessians.data());
  }
  nb::list out;
  for (auto &batch : batches) {
    size_t m = batch.instances.size(), k = size_t(batch.size);
    out.append(
        nb::make_tuple(batch.size, ownedArray(std::move(batch.instances), {m}),
                       ownedArray(std::move(batch.matrices), {m, k, k})));
  }
  return out;
}

/// The compressed size of every instance of a DoF map (count, n).
nb::ndarray<nb::numpy, int64_t> compressedSizes(DofArray dofs) {
  int64_t count = dofs.shape(0), n = dofs.shape(1);
  std::vector<int64_t> sizes(static_cast<size_t>(count));
  for (int64_t i = 0; i < count; ++i)
    sizes[i] = ::yasps::runtime::compressedSize(n, dofs.data() + i * n);
  return ownedArray(std::move(sizes), {size_t(count)});
}

/// Writes projected compressed matrices back to (count, n, n) `out`.
void expandLocalHessians(
    DofArray dofs, int64_t k,
    nb::ndarray<int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu> instances,
    MatrixBatch projected, MatrixBatch out) {
  int64_t count = dofs.shape(0), n = dofs.shape(1);
  if (out.shape(0) != size_t(count) || out.shape(1) != size_t(n) ||
      out.shape(2) != size_t(n) || projected.shape(0) != instances.shape(0) ||
      projected.shape(1) != size_t(k) || projected.shape(2) != size_t(k))
    throw std::invalid_argument("expand_local_hessians: inconsistent shapes");
  ::yasps::runtime::CompressedBatch batch;
  batch.size = k;
  batch.instances.assign(instances.data(),
                         instances.data() + instances.shape(0));
  ::yasps::runtime::expandLocalHessians(count, n, dofs.data(), batch,
                                        projected.data(), out.data());
}

} // namespace

NB_MODULE(_yasps_native, m) {
  m.doc() = "Bindings over the yasps MLIR compiler (parse, verify, passes).";

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
  ::yasps::python::bindGpuRuntime(m);

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
                std::string, std::vector<std::pair<std::string, std::string>>>>
                out;
            for (const auto &kernel : self.library->kernels()) {
              std::vector<std::pair<std::string, std::string>> args;
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
            d["lower_seconds"] = self.stats.lowerSeconds;
            d["codegen_seconds"] = self.stats.codegenSeconds;
            d["key"] = self.stats.key;
            return d;
          },
          "how the compilation went (cache hits, times, cache key)")
      .def("launch", &launchCpu, nb::arg("attribute"), nb::arg("num_instances"),
           nb::arg("buffers"), nb::arg("threads") = 0,
           "Evaluates an attribute's kernel on num_instances instances.");

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
        "Compiles GPU kernels (cubins per chip, PTX of the newest) for the "
        "attributes of the IR's scene; needs the CUDA toolkit's ptxas, not "
        "a GPU. Raises MissingAttributeError (.symbol) for an attribute that "
        "does not exist after pre_pipeline, IRError for other failures.");
  m.def("compress_local_hessians", &compressLocalHessians, nb::arg("dofs"),
        nb::arg("hessians"),
        "Local Hessians with repeated DoFs merged and padding dropped "
        "(paper 7.2), grouped by compressed size k: [(k, instances, "
        "matrices (m, k, k))]");
  m.def("compressed_sizes", &compressedSizes, nb::arg("dofs"),
        "Distinct DoFs >= 0 of each row of a DoF map (count, n)");
  m.def("expand_local_hessians", &expandLocalHessians, nb::arg("dofs"),
        nb::arg("k"), nb::arg("instances"), nb::arg("projected"),
        nb::arg("out"),
        "Writes compressed (projected) matrices back to (count, n, n), each "
        "entry at the first parameter of its DoF");
  m.def("compile_cpu", &compileCpu, nb::arg("ir"), nb::arg("attributes"),
        nb::arg("cache_dir") = "", nb::arg("opt_level") = 3,
        nb::arg("name") = "<yasps>", nb::arg("pre_pipeline") = "",
        nb::arg("lanes") = 0,
        "Compiles CPU kernels for the attributes (scene-relative paths) of "
        "the IR's scene, reusing in-memory and on-disk caches. "
        "lanes: instances evaluated together in SIMD lanes (0: the host's "
        "vector width in doubles; 1: one at a time). Raises "
        "MissingAttributeError (.symbol) for an attribute that does not exist "
        "after pre_pipeline, IRError for other failures.");
  m.def("host_double_lanes", &mlir::yasps::hostDoubleLanes,
        "f64 lanes of the host's widest vector registers");
  nb::class_<PySystem>(m, "GlobalSystem",
                       "The block-sparse Newton system of a scene.")
      .def(nb::init<PySystem::Int64Array, std::vector<PySystem::Int64Array>>(),
           nb::arg("block_offsets"), nb::arg("dof_maps"))
      .def_prop_ro("size", &PySystem::size)
      .def("set_dynamic", &PySystem::setDynamic, nb::arg("dof_maps"),
           "Replaces the dynamic energies (numbered after the static ones) "
           "and rebuilds only their structure")
      .def("add_factored", &PySystem::addFactored, nb::arg("energy"),
           nb::arg("gradients"), nb::arg("maps"), nb::arg("inner"),
           nb::arg("m"), nb::arg("threads") = 0,
           "Adds an energy whose local Hessians are J^T P J, from the inner "
           "maps J (count, m, n) and projected inner Hessians P (count, m, "
           "m)")
      .def("set_zero", &PySystem::setZero)
      .def("add", &PySystem::add, nb::arg("energy"), nb::arg("gradients"),
           nb::arg("hessians"), nb::arg("threads") = 0,
           "Adds an energy's local gradients and Hessians; with more than "
           "one thread, instances are split across threads (atomic adds)")
      .def("gradient", &PySystem::gradient, nb::arg("out"))
      .def("dense", &PySystem::dense, nb::arg("out"))
      .def_prop_ro("non_zeros", &PySystem::nonZeros)
      .def_prop_ro("stored_blocks",
                   [](const PySystem &self) { return self.storedBlocks(); })
      .def("coordinates", &PySystem::coordinates, nb::arg("rows"),
           nb::arg("cols"), nb::arg("values"))
      .def("multiply", &PySystem::multiply, nb::arg("x"), nb::arg("y"),
           nb::arg("threads") = 0)
      .def("solve", &PySystem::solve, nb::arg("out"), nb::arg("tolerance"),
           nb::arg("max_iterations"), nb::arg("threads") = 0,
           nb::arg("fixed") = nb::none(),
           "PCG on H x = g into out; `fixed` (uint8 per DoF) excludes DoFs, "
           "whose solution is 0; returns (iterations, relative residual, "
           "converged)");
  ::yasps::python::bindGpuSystem(
      m, [](nb::handle system) -> const ::yasps::runtime::GlobalSystem & {
        return nb::cast<const PySystem &>(system).runtime();
      });

  m.def("attribute_params", &attributeParams, nb::arg("ir"),
        nb::arg("pipeline"), nb::arg("paths"), nb::arg("name") = "<yasps>",
        "yasps.params of the attributes (e.g. derivative attributes) after "
        "running a pass pipeline; empty lists for attributes without them.");
  m.def(
      "cpu_lowering_pipeline",
      [] { return mlir::yasps::getCpuLoweringPipeline().str(); },
      "The pass pipeline from kernel functions to the LLVM dialect.");

  m.def("run_pipeline", &runPipeline, nb::arg("ir"), nb::arg("pipeline"),
        nb::arg("name") = "<yasps>",
        "Parses and verifies yasps IR, runs a textual pass pipeline on the "
        "module (e.g. 'yasps-inline-reads,cse') and returns the printed IR.");
}
