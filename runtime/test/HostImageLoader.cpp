//===- HostImageLoader.cpp - the stand-in driver's host images ------------===//

#include "HostImageLoader.h"

#include "llvm/ExecutionEngine/Orc/ExecutionUtils.h"
#include "llvm/ExecutionEngine/Orc/LLJIT.h"
#include "llvm/Support/MemoryBuffer.h"
#include "llvm/Support/TargetSelect.h"

#include <mutex>

using namespace yasps::runtime::test;
namespace host_image = yasps::runtime::host_image;

struct HostImageModule::Jit {
  std::unique_ptr<llvm::orc::LLJIT> session;
};

HostImageModule::HostImageModule() : jit_(std::make_unique<Jit>()) {}
HostImageModule::~HostImageModule() = default;

std::unique_ptr<HostImageModule> HostImageModule::load(const void *image,
                                                       std::string &error) {
  static std::once_flag once;
  std::call_once(once, [] {
    llvm::InitializeNativeTarget();
    llvm::InitializeNativeTargetAsmPrinter();
  });
  auto fail = [&](llvm::Error err) {
    error = llvm::toString(std::move(err));
    return nullptr;
  };
  const char *bytes = static_cast<const char *>(image);
  auto object = llvm::MemoryBuffer::getMemBufferCopy(
      llvm::StringRef(bytes + host_image::kHeaderBytes,
                      host_image::objectBytes(image)),
      "yasps_host_image");
  auto session = llvm::orc::LLJITBuilder().create();
  if (!session)
    return fail(session.takeError());
  // The kernels call the host's math library (sqrt, exp, ...): from the
  // process, or from libm itself where the process has not loaded it
  // globally (a tool that dlopens this driver with RTLD_LOCAL).
  const char prefix = (*session)->getDataLayout().getGlobalPrefix();
  for (const char *library :
       {static_cast<const char *>(nullptr), "libm.so.6"}) {
    auto generator =
        library
            ? llvm::orc::DynamicLibrarySearchGenerator::Load(library, prefix)
            : llvm::orc::DynamicLibrarySearchGenerator::GetForCurrentProcess(
                  prefix);
    if (!generator)
      return fail(generator.takeError());
    (*session)->getMainJITDylib().addGenerator(std::move(*generator));
  }
  if (llvm::Error err = (*session)->addObjectFile(std::move(object)))
    return fail(std::move(err));
  std::unique_ptr<HostImageModule> module(new HostImageModule());
  module->jit_->session = std::move(*session);
  return module;
}

const HostKernel *HostImageModule::kernel(const std::string &name) {
  auto found = kernels_.find(name);
  if (found != kernels_.end())
    return &found->second;
  auto address = jit_->session->lookup(name);
  if (!address) {
    llvm::consumeError(address.takeError());
    return nullptr;
  }
  HostKernel &kernel = kernels_[name];
  kernel.entry = address->toPtr<host_image::Entry>();
  kernel.name = name;
  return &kernel;
}

void yasps::runtime::test::runHostKernel(const HostKernel &kernel,
                                         void **params, const unsigned grid[3],
                                         const unsigned block[3]) {
  host_image::ThreadContext thread{};
  for (int axis = 0; axis < 3; ++axis) {
    thread.nctaid[axis] = grid[axis];
    thread.ntid[axis] = block[axis];
  }
  for (unsigned bz = 0; bz < grid[2]; ++bz)
    for (unsigned by = 0; by < grid[1]; ++by)
      for (unsigned bx = 0; bx < grid[0]; ++bx)
        for (unsigned tz = 0; tz < block[2]; ++tz)
          for (unsigned ty = 0; ty < block[1]; ++ty)
            for (unsigned tx = 0; tx < block[0]; ++tx) {
              thread.ctaid[0] = bx, thread.ctaid[1] = by, thread.ctaid[2] = bz;
              thread.tid[0] = tx, thread.tid[1] = ty, thread.tid[2] = tz;
              kernel.entry(params, &thread);
            }
}
