//===- GpuCompiler.cpp - attribute kernels for NVIDIA GPUs ----------------===//

#include "yasps/Target/GPU/GpuCompiler.h"

#include "yasps/Conversion/LoopsToGPU/LoopsToGpuPipeline.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"
#include "yasps/Runtime/Gpu/HostImage.h"
#include "yasps/Target/GPU/HostImage.h"

#include "mlir/Conversion/ArithToLLVM/ArithToLLVM.h"
#include "mlir/Conversion/ControlFlowToLLVM/ControlFlowToLLVM.h"
#include "mlir/Conversion/FuncToLLVM/ConvertFuncToLLVM.h"
#include "mlir/Conversion/GPUToNVVM/GPUToNVVM.h"
#include "mlir/Conversion/IndexToLLVM/IndexToLLVM.h"
#include "mlir/Conversion/MathToLLVM/MathToLLVM.h"
#include "mlir/Conversion/MemRefToLLVM/MemRefToLLVM.h"
#include "mlir/Conversion/NVVMToLLVM/NVVMToLLVM.h"
#include "mlir/Conversion/UBToLLVM/UBToLLVM.h"
#include "mlir/Dialect/Affine/IR/AffineOps.h"
#include "mlir/Dialect/ControlFlow/IR/ControlFlow.h"
#include "mlir/Dialect/Func/IR/FuncOps.h"
#include "mlir/Dialect/GPU/IR/GPUDialect.h"
#include "mlir/Dialect/Index/IR/IndexDialect.h"
#include "mlir/Dialect/LLVMIR/LLVMDialect.h"
#include "mlir/Dialect/LLVMIR/NVVMDialect.h"
#include "mlir/Dialect/Math/IR/Math.h"
#include "mlir/Dialect/MemRef/IR/MemRef.h"
#include "mlir/Dialect/SCF/IR/SCF.h"
#include "mlir/Dialect/UB/IR/UBOps.h"
#include "mlir/IR/Matchers.h"
#include "mlir/Target/LLVM/NVVM/Target.h"
#include "mlir/Target/LLVMIR/Dialect/Builtin/BuiltinToLLVMIRTranslation.h"
#include "mlir/Target/LLVMIR/Dialect/GPU/GPUToLLVMIRTranslation.h"
#include "mlir/Target/LLVMIR/Dialect/LLVMIR/LLVMToLLVMIRTranslation.h"
#include "mlir/Target/LLVMIR/Dialect/NVVM/NVVMToLLVMIRTranslation.h"

#include "llvm/Support/FileSystem.h"
#include "llvm/Support/MemoryBuffer.h"
#include "llvm/Support/Path.h"

#include <algorithm>
#include <chrono>

using namespace mlir;
using namespace mlir::yasps;
using ::yasps::runtime::GpuParam;

// Bumped whenever generated code changes for the same kernels, so that
// stale binaries in an on-disk cache are never reused.
static constexpr const char *kGpuCodegenVersion = "yasps-gpu-1";
static constexpr const char *kDeviceModuleName = "yasps_kernels";

void mlir::yasps::registerGpuCompilerDialects(DialectRegistry &registry) {
  registry.insert<YaspsDialect, affine::AffineDialect, arith::ArithDialect,
                  cf::ControlFlowDialect, func::FuncDialect, gpu::GPUDialect,
                  index::IndexDialect, LLVM::LLVMDialect, math::MathDialect,
                  memref::MemRefDialect, NVVM::NVVMDialect, scf::SCFDialect,
                  ub::UBDialect>();
  // convert-gpu-to-nvvm lowers the other dialects through their
  // ConvertToLLVMPatternInterface.
  arith::registerConvertArithToLLVMInterface(registry);
  cf::registerConvertControlFlowToLLVMInterface(registry);
  registerConvertFuncToLLVMInterface(registry);
  index::registerConvertIndexToLLVMInterface(registry);
  registerConvertMathToLLVMInterface(registry);
  registerConvertMemRefToLLVMInterface(registry);
  registerConvertNVVMToLLVMInterface(registry);
  ub::registerConvertUBToLLVMInterface(registry);
  NVVM::registerNVVMTargetInterfaceExternalModels(registry);
  registerBuiltinDialectTranslation(registry);
  registerGPUDialectTranslation(registry);
  registerLLVMDialectTranslation(registry);
  registerNVVMDialectTranslation(registry);
}

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

llvm::Error error(const llvm::Twine &message) {
  return llvm::createStringError(llvm::inconvertibleErrorCode(), message);
}

/// The launch of `kernel`'s host function: which gpu.func, and where each
/// of its operands comes from.
llvm::Error describeLaunch(ModuleOp module, GpuKernel &kernel) {
  auto func = module.lookupSymbol<func::FuncOp>(kernel.symbol);
  SmallVector<gpu::LaunchFuncOp> launches;
  if (func)
    func.walk([&](gpu::LaunchFuncOp op) { launches.push_back(op); });
  if (launches.size() != 1)
    return error("kernel @" + kernel.symbol + " of " + kernel.attribute +
                 " did not become exactly one GPU launch");
  gpu::LaunchFuncOp launch = launches.front();
  kernel.kernelName = launch.getKernelName().str();
  for (Value operand : launch.getKernelOperands()) {
    auto arg = dyn_cast<BlockArgument>(operand);
    IntegerAttr constant;
    if (arg && arg.getOwner()->getParentOp() == func) {
      bool buffer = isa<MemRefType>(arg.getType());
      kernel.launchParams.push_back(
          {buffer ? GpuParam::Kind::Buffer : GpuParam::Kind::Index,
           arg.getArgNumber(), 0});
    } else if (matchPattern(operand, m_Constant(&constant))) {
      kernel.launchParams.push_back(
          {GpuParam::Kind::Constant, -1, constant.getInt()});
    } else {
      return error("kernel @" + kernel.symbol +
                   " passes a value computed on the host to the GPU");
    }
  }
  return llvm::Error::success();
}

/// A module holding one gpu.module with every outlined kernel of `host`.
OwningOpRef<ModuleOp> gatherDeviceCode(ModuleOp host) {
  OpBuilder b(host.getContext());
  OwningOpRef<ModuleOp> device = ModuleOp::create(host.getLoc());
  (*device)->setAttr(gpu::GPUDialect::getContainerModuleAttrName(),
                     b.getUnitAttr());
  b.setInsertionPointToEnd(device->getBody());
  auto merged = gpu::GPUModuleOp::create(b, host.getLoc(), kDeviceModuleName);
  for (auto module : host.getOps<gpu::GPUModuleOp>())
    for (Operation &op : module.getBody()->getOperations())
      if (!op.hasTrait<OpTrait::IsTerminator>()) {
        b.setInsertionPointToEnd(merged.getBody());
        b.clone(op);
      }
  return device;
}

/// Runs the serialisation pipeline on a copy of `device` and returns the
/// binaries of its gpu.binary op.
llvm::Expected<std::vector<GpuBinary>>
serialize(ModuleOp device, const std::vector<std::string> &chips,
          const std::string &format) {
  OwningOpRef<ModuleOp> copy(cast<ModuleOp>(device->clone()));
  if (llvm::Error err =
          runPasses(*copy, "GPU code generation failed", [&](PassManager &pm) {
            buildGpuSerializationPipeline(pm, chips, format);
            return success();
          }))
    return std::move(err);
  std::vector<GpuBinary> out;
  for (auto binary : copy->getOps<gpu::BinaryOp>())
    for (auto object : binary.getObjects().getAsRange<gpu::ObjectAttr>()) {
      auto target = dyn_cast<NVVM::NVVMTargetAttr>(object.getTarget());
      out.push_back({target ? target.getChip().str() : std::string("?"),
                     format == "bin" ? "cubin" : "ptx",
                     object.getObject().str()});
    }
  return out;
}

/// "sm_90" -> 90, for picking the newest chip.
int chipNumber(const std::string &chip) {
  size_t digits = chip.find_first_of("0123456789");
  return digits == std::string::npos ? 0 : std::atoi(chip.c_str() + digits);
}

std::string cachePath(const std::string &dir, const std::string &key,
                      const GpuBinary &binary) {
  llvm::SmallString<256> path(dir);
  llvm::sys::path::append(path, key + "." + binary.chip + "." + binary.format);
  return path.str().str();
}

/// The binaries `wanted` from the cache, or nothing if any is missing.
std::optional<std::vector<GpuBinary>>
loadCached(const std::string &dir, const std::string &key,
           std::vector<GpuBinary> wanted) {
  for (GpuBinary &binary : wanted) {
    auto buffer = llvm::MemoryBuffer::getFile(cachePath(dir, key, binary),
                                              /*IsText=*/false);
    if (!buffer)
      return std::nullopt;
    binary.bytes = (*buffer)->getBuffer().str();
  }
  return wanted;
}

void storeCached(const std::string &dir, const std::string &key,
                 const std::vector<GpuBinary> &binaries) {
  llvm::sys::fs::create_directories(dir);
  for (const GpuBinary &binary : binaries)
    storeAtomically(cachePath(dir, key, binary), [&](StringRef tmp) {
      std::error_code ec;
      llvm::raw_fd_ostream os(tmp, ec);
      if (!ec)
        os << binary.bytes;
    });
}

} // namespace

llvm::Expected<std::shared_ptr<GpuKernelLibrary>>
mlir::yasps::compileGpuKernels(ModuleOp module,
                               const std::vector<std::string> &attributes,
                               const GpuCompileOptions &options,
                               GpuCompileStats *stats, StringRef prePipeline) {
  GpuCompileStats localStats;
  GpuCompileStats &st = stats ? *stats : localStats;
  Clock::time_point start = Clock::now();
  if (options.chips.empty())
    return error("no GPU chip to compile for");

  // 1. The loop kernels every target shares, then GPU kernels.
  auto generated = generateLoopKernels(module, attributes, prePipeline);
  if (!generated)
    return generated.takeError();
  OwningOpRef<ModuleOp> kernels = std::move(*generated);
  auto library = std::make_shared<GpuKernelLibrary>();
  for (KernelDescription &description : describeKernels(*kernels)) {
    GpuKernel kernel;
    static_cast<KernelDescription &>(kernel) = std::move(description);
    kernel.threadsPerBlock = options.threadsPerBlock;
    library->kernels.push_back(std::move(kernel));
  }
  if (llvm::Error err = runPasses(
          *kernels, "GPU kernel outlining failed", [&](PassManager &pm) {
            buildLoopsToGpuKernelsPipeline(pm, options.threadsPerBlock);
            return success();
          }))
    return std::move(err);
  for (GpuKernel &kernel : library->kernels)
    if (llvm::Error err = describeLaunch(*kernels, kernel))
      return std::move(err);
  OwningOpRef<ModuleOp> device = gatherDeviceCode(*kernels);
  st.lowerSeconds = secondsSince(start);

  // 2. The binaries wanted: cubins per chip, PTX of the newest, and a host
  // image where the chip "host" is asked for.
  namespace host_image = ::yasps::runtime::host_image;
  std::vector<std::string> chips;
  bool hostImage = false;
  for (const std::string &chip : options.chips)
    if (chip == host_image::kChip)
      hostImage = true;
    else
      chips.push_back(chip);
  std::vector<GpuBinary> wanted;
  for (const std::string &chip : chips)
    wanted.push_back({chip, "cubin", ""});
  std::string newest =
      chips.empty()
          ? std::string()
          : *std::max_element(chips.begin(), chips.end(),
                              [](const std::string &a, const std::string &b) {
                                return chipNumber(a) < chipNumber(b);
                              });
  bool keepPtx = options.keepPtx && !chips.empty();
  if (keepPtx)
    wanted.push_back({newest, "ptx", ""});
  if (hostImage)
    wanted.push_back({host_image::kChip, host_image::kFormat, ""});
  std::string extra = std::string(kGpuCodegenVersion) + "\n";
  for (const GpuBinary &binary : wanted)
    extra += binary.chip + "." + binary.format + "\n";
  st.key = hashKernels(*device, extra);
  Clock::time_point serializeStart = Clock::now();
  if (!options.cacheDir.empty())
    if (auto cached = loadCached(options.cacheDir, st.key, wanted)) {
      library->binaries = std::move(*cached);
      st.fromDisk = true;
      st.serializeSeconds = secondsSince(serializeStart);
      return library;
    }

  // 3. NVVM, PTX and cubins (ptxas); the host image.
  if (!chips.empty()) {
    auto cubins = serialize(*device, chips, "bin");
    if (!cubins)
      return cubins.takeError();
    library->binaries = std::move(*cubins);
  }
  if (keepPtx) {
    auto ptx = serialize(*device, {newest}, "isa");
    if (!ptx)
      return ptx.takeError();
    library->binaries.insert(library->binaries.end(), ptx->begin(), ptx->end());
  }
  if (hostImage) {
    auto image = compileHostImage(*device);
    if (!image)
      return image.takeError();
    library->binaries.push_back(
        {host_image::kChip, host_image::kFormat, std::move(*image)});
  }
  st.serializeSeconds = secondsSince(serializeStart);
  if (!options.cacheDir.empty())
    storeCached(options.cacheDir, st.key, library->binaries);
  return library;
}
