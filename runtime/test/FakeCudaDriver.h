//===- FakeCudaDriver.h - loading the stand-in CUDA driver in tests -------===//
//
// Tests of the GPU backend run against FakeCuda.cpp, a stand-in driver
// library built beside them: at the path YASPS_FAKE_CUDA had at build time,
// or at $YASPS_FAKE_CUDA (for a test binary carried to another machine).
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_TEST_FAKECUDADRIVER_H
#define YASPS_RUNTIME_TEST_FAKECUDADRIVER_H

#include "yasps/Runtime/Support/CudaDriver.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <dlfcn.h>
#include <memory>

namespace yasps::runtime::test {

/// Where the stand-in driver library is.
inline const char *fakeCudaPath() {
  const char *path = std::getenv("YASPS_FAKE_CUDA");
  return path && *path ? path : YASPS_FAKE_CUDA;
}

/// The stand-in's function `name` (valid while a driver from fakeDriver
/// keeps the library loaded).
template <typename Function> Function *fakeCudaFunction(const char *name) {
  void *fake = dlopen(fakeCudaPath(), RTLD_NOW | RTLD_LOCAL);
  EXPECT_NE(fake, nullptr) << dlerror();
  auto *function = reinterpret_cast<Function *>(dlsym(fake, name));
  EXPECT_NE(function, nullptr) << name;
  dlclose(fake);
  return function;
}

/// How the stand-in runs a block of a solver kernel (fakeCudaSetThreads).
enum class BlockThreads {
  Phases = 0,    ///< every thread up to a barrier, then to the next
  Fibers = 1,    ///< each thread on a fiber, meeting at barriers
  OsThreads = 2, ///< each thread on an OS thread, all at once
};

/// Loads the fake driver in `mode` (see FakeCuda.cpp), running blocks as
/// `threads` says.
inline std::unique_ptr<CudaDriver>
fakeDriver(int mode, BlockThreads threads = BlockThreads::Phases) {
  void *fake = dlopen(fakeCudaPath(), RTLD_NOW | RTLD_LOCAL);
  EXPECT_NE(fake, nullptr) << dlerror();
  auto setMode =
      reinterpret_cast<void (*)(int)>(dlsym(fake, "fakeCudaSetMode"));
  setMode(mode);
  auto setThreads =
      reinterpret_cast<void (*)(int)>(dlsym(fake, "fakeCudaSetThreads"));
  setThreads(static_cast<int>(threads));
  auto driver = std::make_unique<CudaDriver>(fakeCudaPath());
  dlclose(fake);
  return driver;
}

} // namespace yasps::runtime::test

#endif // YASPS_RUNTIME_TEST_FAKECUDADRIVER_H
