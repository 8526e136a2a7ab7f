//===- FakeCudaDriver.h - loading the stand-in CUDA driver in tests -------===//
//
// Tests of the GPU backend run against FakeCuda.cpp, a stand-in driver
// library built beside them (its path is YASPS_FAKE_CUDA).
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_TEST_FAKECUDADRIVER_H
#define YASPS_RUNTIME_TEST_FAKECUDADRIVER_H

#include "yasps/Runtime/CudaDriver.h"

#include <gtest/gtest.h>

#include <dlfcn.h>
#include <memory>

namespace yasps::runtime::test {

/// Loads the fake driver in `mode` (see FakeCuda.cpp).
inline std::unique_ptr<CudaDriver> fakeDriver(int mode) {
  void *fake = dlopen(YASPS_FAKE_CUDA, RTLD_NOW | RTLD_LOCAL);
  EXPECT_NE(fake, nullptr) << dlerror();
  auto setMode =
      reinterpret_cast<void (*)(int)>(dlsym(fake, "fakeCudaSetMode"));
  setMode(mode);
  auto driver = std::make_unique<CudaDriver>(YASPS_FAKE_CUDA);
  dlclose(fake);
  return driver;
}

} // namespace yasps::runtime::test

#endif // YASPS_RUNTIME_TEST_FAKECUDADRIVER_H
