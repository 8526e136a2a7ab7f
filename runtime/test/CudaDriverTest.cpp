//===- CudaDriverTest.cpp - loading the CUDA driver, errors, buffers ------===//
//
// Runs without a GPU against FakeCuda.cpp (a stand-in driver library); the
// last test checks whatever the real driver of this machine reports.
//
//===----------------------------------------------------------------------===//

#include "yasps/Runtime/CudaMemory.h"

#include <gtest/gtest.h>

#include <dlfcn.h>
#include <vector>

using namespace yasps::runtime;

namespace {

/// Loads the fake driver in `mode` (see FakeCuda.cpp).
std::unique_ptr<CudaDriver> fakeDriver(int mode) {
  void *fake = dlopen(YASPS_FAKE_CUDA, RTLD_NOW | RTLD_LOCAL);
  EXPECT_NE(fake, nullptr) << dlerror();
  auto setMode =
      reinterpret_cast<void (*)(int)>(dlsym(fake, "fakeCudaSetMode"));
  setMode(mode);
  auto driver = std::make_unique<CudaDriver>(YASPS_FAKE_CUDA);
  dlclose(fake);
  return driver;
}

TEST(CudaDriver, MissingLibraryIsReported) {
  CudaDriver driver("/nonexistent/libcuda.so.1");
  EXPECT_FALSE(driver.usable());
  EXPECT_NE(driver.unusableReason().find("/nonexistent/libcuda.so.1 could not "
                                         "be loaded"),
            std::string::npos)
      << driver.unusableReason();
  try {
    driver.requireUsable();
    FAIL() << "requireUsable did not throw";
  } catch (const CudaError &error) {
    EXPECT_NE(std::string(error.what()).find("GPU backend cannot be used"),
              std::string::npos);
  }
}

TEST(CudaDriver, InitFailureNamesTheError) {
  auto driver = fakeDriver(1);
  EXPECT_FALSE(driver->usable());
  EXPECT_EQ(driver->unusableReason(),
            "cuInit failed: CUDA_ERROR_NO_DEVICE (no CUDA-capable device is "
            "detected)");
}

TEST(CudaDriver, NoDeviceIsReported) {
  auto driver = fakeDriver(2);
  EXPECT_FALSE(driver->usable());
  EXPECT_EQ(driver->unusableReason(), "the CUDA driver reports no device");
}

TEST(CudaDriver, DevicesAreListed) {
  auto driver = fakeDriver(0);
  ASSERT_TRUE(driver->usable()) << driver->unusableReason();
  ASSERT_EQ(driver->devices().size(), 1u);
  const CudaDeviceInfo &device = driver->devices()[0];
  EXPECT_EQ(device.name, "Fake GPU");
  EXPECT_EQ(device.chip(), "sm_90");
  EXPECT_EQ(device.totalMemory, std::size_t(8) << 30);
  // Unknown codes still give a message.
  EXPECT_EQ(driver->describe(999), "CUresult 999");
  try {
    driver->check(100, "cuSomething");
    FAIL() << "check did not throw";
  } catch (const CudaError &error) {
    EXPECT_EQ(error.code, 100);
    EXPECT_STREQ(error.what(), "cuSomething failed: CUDA_ERROR_NO_DEVICE (no "
                               "CUDA-capable device is detected)");
  }
}

TEST(CudaDriver, BuffersRoundTrip) {
  auto driver = fakeDriver(0);
  CudaContext context(*driver, 0);
  std::vector<double> values(1000), back(1000);
  for (size_t i = 0; i < values.size(); ++i)
    values[i] = 0.5 * double(i);
  DeviceBuffer buffer(context, values.size() * sizeof(double));
  EXPECT_NE(buffer.pointer(), 0u);
  buffer.upload(values.data(), values.size() * sizeof(double));
  buffer.download(back.data(), back.size() * sizeof(double));
  EXPECT_EQ(values, back);
  EXPECT_THROW(buffer.upload(values.data(), 8001), std::out_of_range);
  DeviceBuffer moved = std::move(buffer);
  EXPECT_EQ(buffer.pointer(), 0u);
  EXPECT_EQ(moved.size(), 8000u);
  DeviceBuffer empty(context, 0);
  EXPECT_EQ(empty.pointer(), 0u);
}

TEST(CudaDriver, OutOfMemoryNamesTheSizes) {
  auto driver = fakeDriver(0);
  CudaContext context(*driver, 0);
  try {
    DeviceBuffer buffer(context, std::size_t(3) << 30);
    FAIL() << "the allocation did not throw";
  } catch (const CudaError &error) {
    EXPECT_EQ(error.code, 2);
    EXPECT_STREQ(error.what(), "out of GPU memory: allocating 3.00 GiB on "
                               "device 0 (1.00 GiB free of 8.00 GiB)");
  }
}

TEST(CudaDriver, FormatsSizes) {
  EXPECT_EQ(formatBytes(512), "512 bytes");
  EXPECT_EQ(formatBytes(1536), "1.50 KiB");
  EXPECT_EQ(formatBytes(std::size_t(12) << 20), "12.0 MiB");
}

TEST(CudaDriver, ThisMachineEitherHasAUsableDriverOrSaysWhy) {
  CudaDriver &driver = CudaDriver::get();
  if (driver.usable()) {
    ASSERT_FALSE(driver.devices().empty());
    EXPECT_GE(driver.devices()[0].computeMajor, 3);
  } else {
    EXPECT_FALSE(driver.unusableReason().empty());
    EXPECT_TRUE(driver.devices().empty());
  }
}

} // namespace
