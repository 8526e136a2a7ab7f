//===- HostImage.cpp - GPU kernel modules compiled for the host -----------===//

#include "yasps/Target/GPU/HostImage.h"

#include "yasps/Conversion/LoopsToGPU/LoopsToGpuPipeline.h"
#include "yasps/Runtime/Gpu/HostImage.h"
#include "yasps/Target/KernelGeneration.h"

#include "mlir/Dialect/GPU/IR/GPUDialect.h"
#include "mlir/ExecutionEngine/OptUtils.h"
#include "mlir/Target/LLVMIR/Export.h"

#include "llvm/ExecutionEngine/Orc/JITTargetMachineBuilder.h"
#include "llvm/IR/LegacyPassManager.h"
#include "llvm/IR/Module.h"
#include "llvm/Support/TargetSelect.h"
#include "llvm/Support/raw_ostream.h"
#include "llvm/Target/TargetMachine.h"

#include <mutex>

using namespace mlir;
using namespace mlir::yasps;
namespace host_image = ::yasps::runtime::host_image;

namespace {

llvm::Error error(const llvm::Twine &message) {
  return llvm::createStringError(llvm::inconvertibleErrorCode(), message);
}

/// The kernels' code as a plain LLVM dialect module (the gpu.module's body).
llvm::Expected<OwningOpRef<ModuleOp>> hostModule(ModuleOp device) {
  OwningOpRef<ModuleOp> copy(cast<ModuleOp>(device->clone()));
  if (llvm::Error err = runPasses(*copy, "GPU host image lowering failed",
                                  [&](PassManager &pm) {
                                    buildGpuHostImagePipeline(pm);
                                    return success();
                                  }))
    return std::move(err);
  auto modules = llvm::to_vector(copy->getOps<gpu::GPUModuleOp>());
  if (modules.size() != 1)
    return error("a host image is made of exactly one gpu.module");
  OwningOpRef<ModuleOp> host = ModuleOp::create(device.getLoc());
  Block *body = modules.front().getBody();
  for (Operation &op : llvm::make_early_inc_range(*body))
    if (!op.hasTrait<OpTrait::IsTerminator>())
      op.moveBefore(host->getBody(), host->getBody()->end());
  return std::move(host);
}

} // namespace

llvm::Expected<std::string> mlir::yasps::compileHostImage(ModuleOp device) {
  static std::once_flag once;
  std::call_once(once, [] {
    llvm::InitializeNativeTarget();
    llvm::InitializeNativeTargetAsmPrinter();
  });
  auto host = hostModule(device);
  if (!host)
    return host.takeError();

  auto builder = llvm::orc::JITTargetMachineBuilder::detectHost();
  if (!builder)
    return builder.takeError();
  auto machine = builder->createTargetMachine();
  if (!machine)
    return machine.takeError();
  llvm::LLVMContext context;
  std::unique_ptr<llvm::Module> module =
      translateModuleToLLVMIR(**host, context, "yasps_host_image");
  if (!module)
    return error("the host image's kernels did not translate to LLVM IR");
  module->setDataLayout((*machine)->createDataLayout());
  module->setTargetTriple((*machine)->getTargetTriple());
  // O2: the image serves tests, whose kernels must not take long to build.
  if (llvm::Error err = makeOptimizingTransformer(
          /*optLevel=*/2, /*sizeLevel=*/0, machine->get())(module.get()))
    return std::move(err);

  llvm::SmallVector<char, 0> object;
  llvm::raw_svector_ostream os(object);
  llvm::legacy::PassManager codegen;
  if ((*machine)->addPassesToEmitFile(codegen, os, nullptr,
                                      llvm::CodeGenFileType::ObjectFile))
    return error("the host target cannot emit object files");
  codegen.run(*module);

  std::string image(host_image::kMagic, sizeof(host_image::kMagic));
  std::uint64_t bytes = object.size();
  image.append(reinterpret_cast<const char *>(&bytes), sizeof(bytes));
  image.append(object.data(), object.size());
  return image;
}
