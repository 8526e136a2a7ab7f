//===- CpuCompiler.cpp - attribute kernels for the CPU --------------------===//

#include "yasps/Target/CPU/CpuCompiler.h"

#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "mlir/Conversion/ArithToLLVM/ArithToLLVM.h"
#include "mlir/Conversion/ControlFlowToLLVM/ControlFlowToLLVM.h"
#include "mlir/Conversion/FuncToLLVM/ConvertFuncToLLVM.h"
#include "mlir/Conversion/IndexToLLVM/IndexToLLVM.h"
#include "mlir/Conversion/MathToLLVM/MathToLLVM.h"
#include "mlir/Conversion/MemRefToLLVM/MemRefToLLVM.h"
#include "mlir/Conversion/Passes.h"
#include "mlir/Conversion/UBToLLVM/UBToLLVM.h"
#include "mlir/Conversion/VectorToLLVM/ConvertVectorToLLVM.h"
#include "mlir/Dialect/ControlFlow/IR/ControlFlow.h"
#include "mlir/Dialect/Func/IR/FuncOps.h"
#include "mlir/Dialect/Index/IR/IndexDialect.h"
#include "mlir/Dialect/LLVMIR/LLVMDialect.h"
#include "mlir/Dialect/Math/IR/Math.h"
#include "mlir/Dialect/MemRef/IR/MemRef.h"
#include "mlir/Dialect/SCF/IR/SCF.h"
#include "mlir/Dialect/UB/IR/UBOps.h"
#include "mlir/Dialect/Vector/IR/VectorOps.h"
#include "mlir/ExecutionEngine/ExecutionEngine.h"
#include "mlir/ExecutionEngine/OptUtils.h"
#include "mlir/Pass/PassManager.h"
#include "mlir/Pass/PassRegistry.h"
#include "mlir/Target/LLVMIR/Dialect/Builtin/BuiltinToLLVMIRTranslation.h"
#include "mlir/Target/LLVMIR/Dialect/LLVMIR/LLVMToLLVMIRTranslation.h"
#include "mlir/Transforms/Passes.h"

#include "llvm/ADT/StringExtras.h"
#include "llvm/ExecutionEngine/Orc/ExecutionUtils.h"
#include "llvm/ExecutionEngine/Orc/JITTargetMachineBuilder.h"
#include "llvm/ExecutionEngine/Orc/LLJIT.h"
#include "llvm/Support/FileSystem.h"
#include "llvm/Support/MemoryBuffer.h"
#include "llvm/Support/Path.h"
#include "llvm/Support/SHA256.h"
#include "llvm/Support/TargetSelect.h"
#include "llvm/TargetParser/Host.h"
#include "llvm/TargetParser/SubtargetFeature.h"
#include "llvm/TargetParser/X86TargetParser.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <thread>

using namespace mlir;
using namespace mlir::yasps;

// Bumped whenever generated code changes for the same IR, so that stale
// objects in an on-disk cache are never reused.
// 3: position-independent code (objects link into shared libraries).
static constexpr const char *kCodegenVersion = "yasps-cpu-3";

static constexpr const char *kLoweringPipeline =
    "convert-scf-to-cf,convert-to-llvm,reconcile-unrealized-casts";

StringRef mlir::yasps::getCpuLoweringPipeline() { return kLoweringPipeline; }

void mlir::yasps::registerCpuCompilerDialects(DialectRegistry &registry) {
  registry.insert<YaspsDialect, arith::ArithDialect, cf::ControlFlowDialect,
                  func::FuncDialect, index::IndexDialect, LLVM::LLVMDialect,
                  math::MathDialect, memref::MemRefDialect, scf::SCFDialect,
                  ub::UBDialect, vector::VectorDialect>();
  arith::registerConvertArithToLLVMInterface(registry);
  cf::registerConvertControlFlowToLLVMInterface(registry);
  registerConvertFuncToLLVMInterface(registry);
  index::registerConvertIndexToLLVMInterface(registry);
  registerConvertMathToLLVMInterface(registry);
  registerConvertMemRefToLLVMInterface(registry);
  vector::registerConvertVectorToLLVMInterface(registry);
  ub::registerConvertUBToLLVMInterface(registry);
  registerBuiltinDialectTranslation(registry);
  registerLLVMDialectTranslation(registry);
}

CpuKernelLibrary::~CpuKernelLibrary() = default;

const CpuKernel *CpuKernelLibrary::lookup(StringRef attributePath) const {
  for (const CpuKernel &kernel : kernelList)
    if (kernel.attribute == attributePath)
      return &kernel;
  return nullptr;
}

namespace {

/// Kernels JIT-compiled in this process by mlir::ExecutionEngine.
class EngineLibrary : public CpuKernelLibrary {
public:
  EngineLibrary(std::unique_ptr<ExecutionEngine> engine,
                std::vector<CpuKernel> kernels)
      : engine(std::move(engine)) {
    kernelList = std::move(kernels);
  }

private:
  std::unique_ptr<ExecutionEngine> engine;
};

/// Kernels of several libraries, one per kernel: each kernel is compiled
/// and cached on its own, so requests that share kernels share their code.
class CompositeLibrary : public CpuKernelLibrary {
public:
  CompositeLibrary(std::vector<std::shared_ptr<CpuKernelLibrary>> parts)
      : parts(std::move(parts)) {
    for (const auto &part : this->parts)
      for (const CpuKernel &kernel : part->kernels())
        kernelList.push_back(kernel);
  }

private:
  std::vector<std::shared_ptr<CpuKernelLibrary>> parts;
};

/// Kernels loaded from a cached object file.
class ObjectLibrary : public CpuKernelLibrary {
public:
  ObjectLibrary(std::unique_ptr<llvm::orc::LLJIT> jit,
                std::vector<CpuKernel> kernels)
      : jit(std::move(jit)) {
    kernelList = std::move(kernels);
  }

private:
  std::unique_ptr<llvm::orc::LLJIT> jit;
};

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// CPU kernels for the described loop kernels (their code comes later).
std::vector<CpuKernel> cpuKernels(std::vector<KernelDescription> described) {
  std::vector<CpuKernel> kernels;
  for (KernelDescription &description : described) {
    CpuKernel kernel;
    static_cast<KernelDescription &>(kernel) = std::move(description);
    kernels.push_back(std::move(kernel));
  }
  return kernels;
}

} // namespace

int64_t mlir::yasps::hostDoubleLanes() {
  llvm::StringMap<bool> features = llvm::sys::getHostCPUFeatures();
  if (features.lookup("avx512f"))
    return 8;
  if (features.lookup("avx") || features.lookup("neon"))
    return 4;
  return 2;
}

int64_t mlir::yasps::doubleLanesOf(StringRef cpu) {
  if (cpu.empty())
    return hostDoubleLanes();
  llvm::SmallVector<StringRef, 64> features;
  llvm::X86::getFeaturesForCPU(cpu, features);
  if (llvm::is_contained(features, "avx512f"))
    return 8;
  return llvm::is_contained(features, "avx") ? 4 : 2;
}

namespace {

std::string hostDescription() {
  std::string text = llvm::sys::getHostCPUName().str();
  for (const auto &feature : llvm::sys::getHostCPUFeatures())
    if (feature.second)
      text += "," + feature.first().str();
  return text;
}

/// Kernels with more arithmetic per instance than this are optimised at
/// O2 at most. LLVM's O3 took 12% longer to compile the largest contact
/// kernels (the edge-edge barrier's projected 12x12 Hessian, 5,900 ops:
/// 1.55 -> 1.36 s cold for the energy) for run times within 0-8% of O2's
/// (bench/compile_times.py, docs/benchmarks.md).
constexpr int64_t kLargeKernelOps = 3500;

/// The LLVM optimisation level of `kernel`.
unsigned optLevelOf(const CpuKernel &kernel, const CpuCompileOptions &options) {
  int64_t ops = 0;
  for (const auto &entry : kernel.opCounts)
    ops += entry.second;
  return ops > kLargeKernelOps ? std::min(options.optLevel, 2u)
                               : options.optLevel;
}

/// The machine the kernels are for, in their cache keys.
std::string targetDescription(const CpuCompileOptions &options) {
  return options.targetCpu.empty() ? hostDescription()
                                   : "cpu:" + options.targetCpu;
}

std::string cacheKey(ModuleOp kernels, unsigned optLevel,
                     const CpuCompileOptions &options) {
  std::string extra;
  llvm::raw_string_ostream os(extra);
  os << kLoweringPipeline << "\nO" << optLevel << "\n"
     << kCodegenVersion << "\n"
     << targetDescription(options);
  return hashKernels(kernels, extra);
}

void initializeNativeTarget() {
  static std::once_flag once;
  std::call_once(once, [] {
    llvm::InitializeNativeTarget();
    llvm::InitializeNativeTargetAsmPrinter();
  });
}

llvm::Expected<std::shared_ptr<CpuKernelLibrary>>
loadObject(const std::string &path, std::vector<CpuKernel> kernels) {
  auto buffer = llvm::MemoryBuffer::getFile(path);
  if (!buffer)
    return llvm::errorCodeToError(buffer.getError());
  auto jit = llvm::orc::LLJITBuilder().create();
  if (!jit)
    return jit.takeError();
  auto &mainLib = (*jit)->getMainJITDylib();
  auto generator =
      llvm::orc::DynamicLibrarySearchGenerator::GetForCurrentProcess(
          (*jit)->getDataLayout().getGlobalPrefix());
  if (!generator)
    return generator.takeError();
  mainLib.addGenerator(std::move(*generator));
  if (llvm::Error err = (*jit)->addObjectFile(std::move(*buffer)))
    return std::move(err);
  for (CpuKernel &kernel : kernels) {
    auto address = (*jit)->lookup("_mlir_" + kernel.symbol);
    if (!address)
      return address.takeError();
    kernel.packed = address->toPtr<void (*)(void **)>();
  }
  return std::make_shared<ObjectLibrary>(std::move(*jit), std::move(kernels));
}

std::mutex &cacheLock() {
  static std::mutex lock;
  return lock;
}

/// Libraries by cache key. They stay loaded for the life of the process:
/// kernels are small and a scene may be evaluated again at any time. The
/// map is never destroyed: JIT sessions must not be torn down after LLVM's
/// own statics.
std::map<std::string, std::shared_ptr<CpuKernelLibrary>> &libraries() {
  static auto &map =
      *new std::map<std::string, std::shared_ptr<CpuKernelLibrary>>();
  return map;
}

/// Where the object of `key` is cached ("" without a cache directory).
std::string objectPathOf(const std::string &key,
                         const CpuCompileOptions &options) {
  if (options.cacheDir.empty())
    return "";
  llvm::SmallString<256> path(options.cacheDir);
  llvm::sys::path::append(path, key + ".o");
  return path.str().str();
}

/// The library of `key` from memory or disk, null if neither has it; the
/// caller holds cacheLock().
std::shared_ptr<CpuKernelLibrary>
lookupLocked(const std::string &key, const std::vector<CpuKernel> &kernels,
             const CpuCompileOptions &options, CpuCompileStats &st) {
  if (auto cached = libraries()[key]) {
    st.fromMemory = true;
    return cached;
  }
  initializeNativeTarget();
  std::string objectPath = objectPathOf(key, options);
  if (objectPath.empty() || !llvm::sys::fs::exists(objectPath))
    return nullptr;
  Clock::time_point loadStart = Clock::now();
  auto library = loadObject(objectPath, kernels);
  if (!library) {
    // A damaged cache entry is rebuilt by the caller.
    llvm::consumeError(library.takeError());
    return nullptr;
  }
  st.fromDisk = true;
  st.codegenSeconds = secondsSince(loadStart);
  libraries()[key] = *library;
  return *library;
}

std::string hashText(llvm::StringRef text) {
  std::array<uint8_t, 32> hash = llvm::SHA256::hash(llvm::ArrayRef(
      reinterpret_cast<const uint8_t *>(text.data()), text.size()));
  return llvm::toHex(hash, /*LowerCase=*/true);
}

std::atomic<int64_t> &compiledCount() {
  static std::atomic<int64_t> count{0};
  return count;
}

/// One kernel on its way to machine code.
struct KernelUnit {
  OwningOpRef<ModuleOp> module; ///< the kernel function alone
  CpuKernel kernel;
  std::string key; ///< the cache key of its object
  std::shared_ptr<CpuKernelLibrary> library;
};

/// The kernels of `kernels`, each in a module of its own with its key.
std::vector<KernelUnit> splitKernels(ModuleOp kernels,
                                     const std::vector<CpuKernel> &described,
                                     const CpuCompileOptions &options) {
  std::vector<KernelUnit> units;
  for (const CpuKernel &kernel : described) {
    KernelUnit unit;
    // The module without the other kernels' bodies, built op by op: a
    // clone of the whole module per kernel, pruned afterwards, made this
    // quadratic in the kernels requested (6 s of 20 for the README demo's
    // 60 derivative kernels at once).
    auto module = cast<ModuleOp>(kernels->cloneWithoutRegions());
    module.getBodyRegion().emplaceBlock();
    unit.module = module;
    OpBuilder builder = OpBuilder::atBlockEnd(module.getBody());
    for (Operation &op : kernels.getBody()->getOperations()) {
      auto func = dyn_cast<func::FuncOp>(op);
      if (!func || func.isDeclaration() || func.getSymName() == kernel.symbol)
        builder.clone(op);
    }
    unit.kernel = kernel;
    unit.key =
        cacheKey(*unit.module, optLevelOf(kernel, options), options);
    unit.kernel.objectKey = unit.key;
    units.push_back(std::move(unit));
  }
  return units;
}

/// The target machine for kernels at `optLevel`: the host, or
/// `options.targetCpu` with that CPU's features only. Its code is position
/// independent, so that the cached objects also link into the shared
/// libraries of the kernel store (python/yasps/compiler/store.py), which a
/// runtime without LLVM loads with dlopen.
llvm::Expected<std::unique_ptr<llvm::TargetMachine>>
kernelTargetMachine(unsigned optLevel, const CpuCompileOptions &options) {
  auto builder = llvm::orc::JITTargetMachineBuilder::detectHost();
  if (!builder)
    return builder.takeError();
  if (!options.targetCpu.empty()) {
    builder->setCPU(options.targetCpu);
    builder->getFeatures() = llvm::SubtargetFeatures();
  }
  builder->setRelocationModel(llvm::Reloc::PIC_);
  builder->setCodeGenOptLevel(
      static_cast<llvm::CodeGenOptLevel>(std::min(optLevel, 3u)));
  return builder->createTargetMachine();
}

/// LLVM's optimisation and code generation of one lowered kernel, its
/// object written to the disk cache; safe to run for several kernels at
/// once (each has its own LLVM context and JIT).
llvm::Error jitUnit(KernelUnit &unit, const CpuCompileOptions &options) {
  std::string objectPath = objectPathOf(unit.key, options);
  ExecutionEngineOptions engineOptions;
  // `transformer` is a function_ref: the function it refers to must outlive
  // ExecutionEngine::create, which runs it.
  unsigned optLevel = optLevelOf(unit.kernel, options);
  std::function<llvm::Error(llvm::Module *)> optimize =
      makeOptimizingTransformer(optLevel, /*sizeLevel=*/0,
                                /*targetMachine=*/nullptr);
  engineOptions.transformer = optimize;
  engineOptions.jitCodeGenOptLevel =
      static_cast<llvm::CodeGenOptLevel>(std::min(optLevel, 3u));
  engineOptions.enableObjectDump = !objectPath.empty();
  auto machine = kernelTargetMachine(optLevel, options);
  if (!machine)
    return machine.takeError();
  auto engine = ExecutionEngine::create(*unit.module, engineOptions,
                                        std::move(*machine));
  ++compiledCount();
  if (!engine)
    return engine.takeError();
  auto fn = (*engine)->lookupPacked(unit.kernel.symbol);
  if (!fn)
    return fn.takeError();
  unit.kernel.packed = *fn;
  if (!objectPath.empty()) {
    llvm::sys::fs::create_directories(options.cacheDir);
    storeAtomically(objectPath,
                    [&](StringRef tmp) { (*engine)->dumpToObjectFile(tmp); });
  }
  unit.library = std::make_shared<EngineLibrary>(
      std::move(*engine), std::vector<CpuKernel>{unit.kernel});
  return llvm::Error::success();
}

} // namespace

llvm::Expected<std::shared_ptr<CpuKernelLibrary>>
mlir::yasps::compileCpuKernels(ModuleOp module,
                               const std::vector<std::string> &attributes,
                               const CpuCompileOptions &options,
                               CpuCompileStats *stats, StringRef prePipeline) {
  CpuCompileStats localStats;
  CpuCompileStats &st = stats ? *stats : localStats;
  Clock::time_point start = Clock::now();

  // 1. Kernel functions in upstream dialects.
  // The host's vector width in the type the scene computes in: twice the
  // lanes in f32.
  int64_t lanes = options.lanes > 0
                      ? options.lanes
                      : doubleLanesOf(options.targetCpu) *
                            (64 / computeFloatBits(module));
  // By default projections of small matrices run two vectors of problems
  // at a time; a width the user chose applies to every kernel.
  int64_t projectionLanes = options.lanes > 0 ? options.lanes : 2 * lanes;
  // Outputs in the type computed in: f32 local derivatives of an f32 scene
  // are stored as they are, half the bytes, and assembled from f32.
  auto generated = generateLoopKernels(module, attributes, prePipeline, lanes,
                                       projectionLanes, /*outStorage=*/"");
  if (!generated)
    return generated.takeError();
  OwningOpRef<ModuleOp> kernels = std::move(*generated);
  std::vector<CpuKernel> described = cpuKernels(describeKernels(*kernels));
  st.lowerSeconds = secondsSince(start);

  // 2. One module per kernel (each kernel function is self-contained), so
  // that every kernel is compiled once per process and cached on its own,
  // whichever requests share it.
  std::vector<KernelUnit> units = splitKernels(*kernels, described, options);
  std::string keys;
  for (const KernelUnit &unit : units)
    keys += unit.key + "\n";
  st.key = units.size() == 1 ? units[0].key : hashText(keys);

  // 3. Caches: this process, then disk.
  std::vector<KernelUnit *> missing;
  bool anyFromDisk = false;
  {
    std::lock_guard<std::mutex> guard(cacheLock());
    for (KernelUnit &unit : units) {
      CpuCompileStats unitStats;
      unit.library = lookupLocked(unit.key, {unit.kernel}, options, unitStats);
      anyFromDisk |= unitStats.fromDisk;
      if (!unit.library)
        missing.push_back(&unit);
    }
  }
  st.fromMemory = missing.empty() && !anyFromDisk;
  st.fromDisk = missing.empty() && anyFromDisk;

  // 4. The missing kernels: LLVM dialect here, then LLVM's optimisation and
  // code generation on every core, one kernel per thread at a time.
  for (KernelUnit *unit : missing)
    if (llvm::Error err =
            runPasses(*unit->module, "lowering to the LLVM dialect failed",
                      [&](PassManager &pm) {
                        return parsePassPipeline(kLoweringPipeline, pm);
                      },
                      Verification::AtEnd))
      return std::move(err);
  st.lowerSeconds = secondsSince(start);
  Clock::time_point codegenStart = Clock::now();
  std::vector<llvm::Error> errors;
  for (size_t i = 0; i < missing.size(); ++i)
    errors.push_back(llvm::Error::success());
  size_t workers = std::min<size_t>(
      missing.size(), std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::thread> threads;
  std::atomic<size_t> next{0};
  std::mutex progressLock;
  for (size_t w = 0; w < workers; ++w)
    threads.emplace_back([&] {
      for (size_t i = next++; i < missing.size(); i = next++) {
        errors[i] = jitUnit(*missing[i], options);
        if (options.onKernelCompiled && !errors[i]) {
          std::lock_guard<std::mutex> guard(progressLock);
          options.onKernelCompiled(missing[i]->kernel.attribute);
        }
      }
    });
  for (std::thread &thread : threads)
    thread.join();
  for (llvm::Error &err : errors)
    if (err)
      return std::move(err);
  st.codegenSeconds = secondsSince(codegenStart);

  std::vector<std::shared_ptr<CpuKernelLibrary>> parts;
  {
    std::lock_guard<std::mutex> guard(cacheLock());
    for (KernelUnit *unit : missing)
      libraries()[unit->key] = unit->library;
  }
  for (KernelUnit &unit : units)
    parts.push_back(unit.library);
  return std::make_shared<CompositeLibrary>(std::move(parts));
}

int64_t mlir::yasps::cpuKernelsCompiled() { return compiledCount(); }

std::shared_ptr<CpuKernelLibrary>
mlir::yasps::loadCachedCpuKernels(std::vector<CpuKernel> kernels,
                                  const CpuCompileOptions &options,
                                  CpuCompileStats &stats) {
  std::lock_guard<std::mutex> guard(cacheLock());
  std::vector<std::shared_ptr<CpuKernelLibrary>> parts;
  std::string keys;
  bool anyFromDisk = false;
  for (CpuKernel &kernel : kernels) {
    CpuCompileStats kernelStats;
    auto part = lookupLocked(kernel.objectKey, {kernel}, options, kernelStats);
    if (!part)
      return nullptr;
    anyFromDisk |= kernelStats.fromDisk;
    keys += kernel.objectKey + "\n";
    parts.push_back(std::move(part));
  }
  stats.fromMemory = !anyFromDisk;
  stats.fromDisk = anyFromDisk;
  stats.key = kernels.size() == 1 ? kernels[0].objectKey : hashText(keys);
  return std::make_shared<CompositeLibrary>(std::move(parts));
}
