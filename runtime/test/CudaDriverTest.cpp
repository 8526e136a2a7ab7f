//===- CudaDriverTest.cpp - loading the CUDA driver, errors, buffers ------===//
//
// Runs without a GPU against FakeCuda.cpp (a stand-in driver library); the
// last test checks whatever the real driver of this machine reports.
//
//===----------------------------------------------------------------------===//

#include "yasps/Runtime/Gpu/GpuLaunch.h"
#include "yasps/Runtime/Gpu/HostImage.h"
#include "yasps/Runtime/Support/CudaMemory.h"

#include "FakeCudaDriver.h"

#include <gtest/gtest.h>

#include <dlfcn.h>
#include <vector>

using namespace yasps::runtime;
using yasps::runtime::test::fakeDriver;

namespace {

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
  // The stand-in says that it runs host images of the generated kernels.
  EXPECT_TRUE(driver->runsHostImages());
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

TEST(GpuLaunch, PicksTheDevicesCubinElsePtx) {
  std::string bytes = "x";
  std::vector<GpuImage> images = {{"sm_80", "cubin", &bytes},
                                  {"sm_90", "cubin", &bytes},
                                  {"sm_90", "ptx", &bytes}};
  EXPECT_EQ(selectGpuImage(images, "sm_80").format, "cubin");
  EXPECT_EQ(selectGpuImage(images, "sm_90").chip, "sm_90");
  EXPECT_EQ(selectGpuImage(images, "sm_90").format, "cubin");
  EXPECT_EQ(selectGpuImage(images, "sm_120").format, "ptx");
  // sm_80 code runs on sm_86 and sm_89.
  EXPECT_EQ(selectGpuImage(images, "sm_89").chip, "sm_80");
  EXPECT_EQ(selectGpuImage(images, "sm_89").format, "cubin");
  try {
    selectGpuImage(images, "sm_75");
    FAIL() << "an sm_75 device got a binary";
  } catch (const CudaError &error) {
    EXPECT_STREQ(error.what(),
                 "no GPU binary runs on this device (sm_75): the kernels were "
                 "compiled to sm_80 cubin, sm_90 cubin, sm_90 ptx");
  }
  // The stand-in's "host" runs the host image, and nothing else.
  EXPECT_THROW(selectGpuImage(images, "host"), CudaError);
  images.push_back({"host", "host", &bytes});
  EXPECT_EQ(selectGpuImage(images, "host").format, "host");
  EXPECT_EQ(selectGpuImage(images, "sm_90").format, "cubin");
}

TEST(GpuLaunch, AHostImageThatDoesNotLinkIsAnInvalidImage) {
  auto driver = fakeDriver(0);
  CudaContext context(*driver, 0);
  std::string image(host_image::kMagic, sizeof(host_image::kMagic));
  std::uint64_t bytes = 5;
  image.append(reinterpret_cast<const char *>(&bytes), sizeof(bytes));
  image += "\x7f"
           "ELF?";
  try {
    CudaModule module(context, image);
    FAIL() << "a broken host image loaded";
  } catch (const CudaError &error) {
    EXPECT_EQ(error.code, 200);
    EXPECT_NE(std::string(error.what()).find("CUDA_ERROR_INVALID_IMAGE"),
              std::string::npos)
        << error.what();
  }
}

TEST(GpuLaunch, ParametersFollowTheRecordedAbi) {
  // begin, end, a constant, then buffer argument 3 and buffer argument 2.
  std::vector<GpuParam> params = {{GpuParam::Kind::Constant, -1, 128},
                                  {GpuParam::Kind::Index, 0, 0},
                                  {GpuParam::Kind::Index, 1, 0},
                                  {GpuParam::Kind::Buffer, 3, 0},
                                  {GpuParam::Kind::Buffer, 2, 0}};
  std::vector<GpuBufferArg> buffers = {{0x1000, 40}, {0x2000, 7}};
  GpuLaunchParams values(params, buffers, 5, 300);
  std::vector<std::uint64_t> expected = {
      128, 5, 300, 0x2000, 0x2000, 0, 7, 1, 0x1000, 0x1000, 0, 40, 1};
  EXPECT_EQ(values.values(), expected);
  for (size_t i = 0; i < expected.size(); ++i)
    EXPECT_EQ(*static_cast<std::uint64_t *>(values.pointers()[i]), expected[i]);
  std::vector<GpuParam> bad = {{GpuParam::Kind::Buffer, 4, 0}};
  EXPECT_THROW(GpuLaunchParams(bad, buffers, 0, 1), std::invalid_argument);
}

TEST(GpuLaunch, LaunchesOneThreadPerInstance) {
  auto driver = fakeDriver(0);
  void *fake = dlopen(test::fakeCudaPath(), RTLD_NOW | RTLD_LOCAL);
  auto expect =
      reinterpret_cast<void (*)(int)>(dlsym(fake, "fakeCudaExpectParams"));
  auto last = reinterpret_cast<const char *(*)(const char **, unsigned *,
                                               std::uint64_t *)>(
      dlsym(fake, "fakeCudaLastLaunch"));
  CudaContext context(*driver, 0);
  CudaModule module(context, std::string(".version 8.0\n.target sm_90"));
  EXPECT_THROW(module.function("missing"), CudaError);
  cu::Function kernel = module.function("yasps_eval_m__p__x_kernel");
  DeviceBuffer out(context, 300 * sizeof(double));
  expect(7);
  launchGpuKernel(context, kernel,
                  {{GpuParam::Kind::Index, 0, 0},
                   {GpuParam::Kind::Index, 1, 0},
                   {GpuParam::Kind::Buffer, 2, 0}},
                  {{out.pointer(), 300}}, 0, 300, 128);
  const char *image = nullptr;
  unsigned dims[6];
  std::uint64_t values[7];
  EXPECT_STREQ(last(&image, dims, values), "yasps_eval_m__p__x_kernel");
  EXPECT_STREQ(image, ".version 8.0\n.target sm_90");
  // ceil(300 / 128) = 3 blocks of 128 threads.
  EXPECT_EQ(std::vector<unsigned>(dims, dims + 6),
            std::vector<unsigned>({3, 1, 1, 128, 1, 1}));
  EXPECT_EQ(std::vector<std::uint64_t>(values, values + 7),
            std::vector<std::uint64_t>(
                {0, 300, out.pointer(), out.pointer(), 0, 300, 1}));
  EXPECT_THROW(launchGpuKernel(context, kernel, {}, {}, 0, 1, 0),
               std::invalid_argument);
  dlclose(fake);
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
